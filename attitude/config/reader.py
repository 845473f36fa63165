"""Reading a spacecraft file: TOML in, a validated :class:`~attitude.config.model.SpacecraftConfig` out.

:func:`load_config` reads a file, :func:`parse_config` its text and
:func:`config_from_dict` what :func:`tomllib.loads` returns;
:func:`default_config` is the built-in 12U CubeSat and
:func:`default_config_text` its commented file. Every problem raises
:class:`~attitude.config.schema.ConfigError` naming the file and the key
(module docstring of :mod:`attitude.config`). Every object is built once
(:mod:`attitude.config.build`) during validation, so a file that loads
always builds.
"""

from __future__ import annotations

import dataclasses
import datetime
import difflib
import hashlib
import itertools
import math
import re
import tomllib
from collections.abc import Callable, Iterable, Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from attitude.actuators import SATURATION_MODES
from attitude.config import build
from attitude.config.model import (
    ATMOSPHERE_MODELS,
    DEFAULT_EPOCH_UTC,
    ECLIPSE_MODELS,
    FILTER_KINDS,
    MAGNETIC_FIELD_MODELS,
    NRLMSIS_DEFAULTS,
    ORBIT_KEYS,
    ORBIT_KINDS,
    PYRAMID_ELEVATION_DEG,
    WHEEL_LAYOUTS,
    CoarseSunSensorsConfig,
    ControlConfig,
    ControlFilterConfig,
    DetumbleConfig,
    Dispersion,
    EnvironmentConfig,
    FineSunSensorConfig,
    FlexibleModeConfig,
    GyroConfig,
    InertiaConfig,
    KeepOutConfig,
    LQRBounds,
    MagnetometerConfig,
    MagnetorquersConfig,
    MomentumConfig,
    MonteCarloConfig,
    OrbitConfig,
    PanelConfig,
    PerWheel,
    PlateConfig,
    RequirementsConfig,
    SlewRequirement,
    SpacecraftConfig,
    StarTrackerConfig,
    SurfaceConfig,
    UncertaintyConfig,
    Vector,
    WheelsConfig,
)
from attitude.config.schema import (
    DISPERSIONS,
    DISTRIBUTIONS,
    RENAMED_KEYS,
    SURFACE_DISPERSIONS,
    ConfigError,
    children,
    meaning_of,
    normalise_unit,
    unit_of,
)
from attitude.environment.epoch import Epoch
from attitude.environment.orbit import R_EARTH
from attitude.environment.orbit_environment import DISTURBANCE_SOURCES
from attitude.environment.surface import DEFAULT_DRAG_COEFFICIENT
from attitude.flexible import FlexibleBody
from attitude.sensors import GYRO_PRESETS, STAR_TRACKER_PRESETS

__all__ = [
    "DEFAULT_CONFIG_FILE",
    "MAGNETOMETER_MISALIGNMENT_MAX_DEG",
    "QUATERNION_NORM_TOLERANCE",
    "TLE_LINE_LENGTH",
    "config_from_dict",
    "default_config",
    "default_config_text",
    "load_config",
    "parse_config",
]

#: Name of the built-in spacecraft file inside the package (``attitude/data/``).
DEFAULT_CONFIG_FILE = "default_spacecraft.toml"

#: Label used as the file name in messages about the built-in default.
_DEFAULT_LABEL = "attitude/data/" + DEFAULT_CONFIG_FILE


# ---------------------------------------------------------------------------
# Reading values with messages that name the key

_NUMBER_WITH_TEXT = re.compile(r"^\s*([-+]?(?:\d[\d_]*(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def _describe(value: Any) -> str:
    """A short description of a TOML value for messages: its type and the value."""
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, int):
        return f"the integer {value}"
    if isinstance(value, float):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, (datetime.date, datetime.time)):
        return f"the date/time {value.isoformat()}"
    if value is None:
        return "nothing (None)"
    return f"{type(value).__name__} {value!r}"


class _Reader:
    """Reads one file's values, raising :class:`ConfigError` naming the key and the file."""

    def __init__(self, file: str) -> None:
        self.file = file

    def error(self, key: str | None, problem: str) -> ConfigError:
        return ConfigError(problem, key=key, file=self.file)

    # -- scalars ---------------------------------------------------------------

    def number(self, value: Any, key: str, *, allow_inf: bool = False) -> float:
        """A finite float (ints accepted); strings with units get their own message."""
        if isinstance(value, bool):
            raise self.error(key, f"expected a number, got {_describe(value)}")
        if isinstance(value, int):
            try:
                out = float(value)
            except OverflowError:
                raise self.error(key, f"the integer {value} is too large for a float") from None
        elif isinstance(value, float):
            out = value
        elif isinstance(value, str):
            raise self.error(key, self._string_for_number(value, key))
        else:
            raise self.error(key, f"expected a number, got {_describe(value)}")
        if math.isnan(out):
            raise self.error(key, "must be a number, got nan")
        if math.isinf(out) and not allow_inf:
            raise self.error(key, f"must be finite, got {out!r}")
        return out

    def _string_for_number(self, text: str, key: str) -> str:
        unit = unit_of(key)
        match = _NUMBER_WITH_TEXT.match(text)
        if match is None:
            return f"expected a number, got {_describe(text)}"
        number, written = match.group(1), match.group(2)
        if not written:
            return f"expected a number, got {_describe(text)}: write {number} without quotes"
        if not unit:
            return f"units given where a number is expected: got {text!r}; write {number} (this key takes no unit)"
        if normalise_unit(written) != normalise_unit(unit):
            return (
                f"units given where a number is expected: got {text!r}; write a bare number in {unit} "
                f"(the unit is fixed by the key name; convert from {written!r} first)"
            )
        return (
            f"units given where a number is expected: got {text!r}; write {number} "
            f"(the unit is fixed by the key name: {unit})"
        )

    def integer(self, value: Any, key: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, str):
                raise self.error(key, self._string_for_number(value, key).replace("a number", "an integer"))
            raise self.error(key, f"expected an integer, got {_describe(value)}")
        return value

    def string(self, value: Any, key: str, choices: Sequence[str] | None = None, what: str = "value") -> str:
        if not isinstance(value, str):
            hint = f" (one of {', '.join(map(repr, choices))})" if choices else ""
            raise self.error(key, f"expected a string{hint}, got {_describe(value)}")
        if choices is not None and value not in choices:
            raise self.error(key, f"unknown {what} {value!r}{_did_you_mean(value, choices)} Valid: {_list(choices)}")
        return value

    def vector(self, value: Any, key: str, length: int, *, nonzero: bool = True) -> Vector:
        if not isinstance(value, list):
            raise self.error(key, f"expected a list of {length} numbers, got {_describe(value)}")
        if len(value) != length:
            raise self.error(key, f"expected a list of {length} numbers, got {len(value)}")
        out = tuple(self.number(v, f"{key}[{i}]") for i, v in enumerate(value))
        if nonzero:
            norm = math.sqrt(sum(v * v for v in out))
            if norm == 0.0 or not math.isfinite(norm):
                raise self.error(key, f"must be a non-zero finite vector (it is normalised), got {list(out)}")
        return out

    def matrix3(self, value: Any, key: str) -> tuple[Vector, ...]:
        if not isinstance(value, list) or len(value) != 3:
            got = _describe(value) if not isinstance(value, list) else f"{len(value)} rows"
            raise self.error(key, f"expected 3 rows of 3 numbers ([[Ixx, Ixy, Ixz], [...], [...]]), got {got}")
        return tuple(self.vector(row, f"{key}[{i}]", 3, nonzero=False) for i, row in enumerate(value))

    def scalar_or_list(self, value: Any, key: str, length: int, what: str) -> PerWheel:
        """One number, or a list of ``length`` numbers (one per wheel or axis)."""
        if isinstance(value, list):
            if len(value) != length:
                raise self.error(key, f"expected one number or a list of {length} (one per {what}), got {len(value)}")
            return tuple(self.number(v, f"{key}[{i}]") for i, v in enumerate(value))
        return self.number(value, key)

    # -- rules -----------------------------------------------------------------

    def check(self, ok: bool, key: str, rule: str, value: Any) -> None:
        if not ok:
            shown = list(value) if isinstance(value, tuple) else value
            raise self.error(key, f"must be {rule}, got {shown!r}")


def _did_you_mean(word: str, options: Iterable[str]) -> str:
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else "."


def _list(options: Iterable[str]) -> str:
    return ", ".join(repr(o) for o in options)


def _values(x: PerWheel) -> tuple[float, ...]:
    return x if isinstance(x, tuple) else (x,)


class _Table:
    """A TOML table being read: rejects unknown keys on entry, tracks the path for messages."""

    def __init__(self, reader: _Reader, data: Any, path: str) -> None:
        self.reader = reader
        self.path = path
        if not isinstance(data, dict):
            raise reader.error(path or None, f"expected a table, got {_describe(data)}")
        self.data = data
        schema_path = re.sub(r"\[\d+\]", "[]", path)
        allowed = children(schema_path)
        for key in data:
            old = f"{schema_path}.{key}" if schema_path else key
            if key not in allowed and old in RENAMED_KEYS:
                raise reader.error(
                    self.key(key),
                    f"{old} was renamed {RENAMED_KEYS[old]} (names read quantity, qualifier, unit; DESIGN.md)",
                )
            if key not in allowed:
                where = f"[{path}]" if path else "the top level"
                raise reader.error(
                    self.key(key),
                    f"unknown key{_did_you_mean(key, allowed)} Keys of {where}: {', '.join(allowed)}",
                )

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def has(self, name: str) -> bool:
        return name in self.data

    def missing(self, name: str, hint: str = "") -> ConfigError:
        meaning = meaning_of(self.key(name))
        text = f"missing required key ({meaning})" if meaning else "missing required key"
        return self.reader.error(self.key(name), text + hint)

    def get(self, name: str, read: Callable[[Any, str], Any], *, required: bool = True, default: Any = None) -> Any:
        if name not in self.data:
            if required:
                raise self.missing(name)
            return default
        return read(self.data[name], self.key(name))

    def number(self, name: str, *, required: bool = True, default: float | None = None, **kw: Any) -> Any:
        return self.get(name, lambda v, k: self.reader.number(v, k, **kw), required=required, default=default)

    def table(self, name: str, *, required: bool = True) -> _Table | None:
        if name not in self.data:
            if required:
                meaning = meaning_of(self.key(name))
                raise self.reader.error(
                    self.key(name), f"missing required table: add a [{self.key(name)}] table ({meaning})"
                )
            return None
        return _Table(self.reader, self.data[name], self.key(name))

    def forbid(self, name: str, reason: str) -> None:
        if name in self.data:
            raise self.reader.error(self.key(name), reason)


def _positive(r: _Reader, key: str, value: float | None, *, allow_zero: bool = False, unit: str = "") -> None:
    if value is None:
        return
    for i, v in enumerate(_values(value)):
        k = key if not isinstance(value, tuple) else f"{key}[{i}]"
        rule = "non-negative (>= 0)" if allow_zero else "strictly positive (> 0)"
        r.check(v >= 0 if allow_zero else v > 0, k, rule + (f" [{unit}]" if unit else ""), v)


def _in_range(r: _Reader, key: str, value: float, low: float, high: float, *, low_open: bool, high_open: bool) -> None:
    ok = (value > low if low_open else value >= low) and (value < high if high_open else value <= high)
    unit = unit_of(key)
    interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    r.check(ok, key, f"in {interval}" + (f" {unit}" if unit else ""), value)


# Parsing


def _read_inertia(r: _Reader, t: _Table) -> InertiaConfig:
    has_m, has_t = t.has("moments_kg_m2"), t.has("tensor_kg_m2")
    if has_m and has_t:
        raise r.error(t.key("tensor_kg_m2"), "give moments_kg_m2 or tensor_kg_m2, not both")
    if not (has_m or has_t):
        raise r.error(
            t.key("moments_kg_m2"),
            "missing required key: give moments_kg_m2 = [Ixx, Iyy, Izz] or tensor_kg_m2 = 3 rows of 3 [kg m^2]",
        )
    if has_m:
        key = t.key("moments_kg_m2")
        config = InertiaConfig(moments_kg_m2=r.vector(t.data["moments_kg_m2"], key, 3, nonzero=False))
    else:
        key = t.key("tensor_kg_m2")
        config = InertiaConfig(tensor_kg_m2=r.matrix3(t.data["tensor_kg_m2"], key))
    _try_build(r, key, lambda: build.rigid_body(config))
    return config


def _read_wheels(r: _Reader, t: _Table) -> WheelsConfig:
    layout = t.get("layout", lambda v, k: r.string(v, k, WHEEL_LAYOUTS, "layout"))
    axes = None
    elevation = None
    if layout == "custom":
        if not t.has("axes_B"):
            raise t.missing("axes_B", ": layout = 'custom' needs one axis per wheel")
        key = t.key("axes_B")
        raw = t.data["axes_B"]
        if not isinstance(raw, list) or not raw:
            raise r.error(key, f"expected a list of axes [[x, y, z], ...], got {_describe(raw)}")
        axes = tuple(r.vector(a, f"{key}[{i}]", 3) for i, a in enumerate(raw))
        n = len(axes)
        t.forbid("elevation_deg", "only for layout = 'pyramid'")
    else:
        t.forbid("axes_B", f"only for layout = 'custom' (the {layout} layout fixes the axes)")
        n = 4 if layout == "pyramid" else 3
        if layout == "pyramid":
            elevation = t.number("elevation_deg", required=False, default=PYRAMID_ELEVATION_DEG)
            _in_range(r, t.key("elevation_deg"), elevation, 0.0, 90.0, low_open=True, high_open=True)
        else:
            t.forbid("elevation_deg", "only for layout = 'pyramid'")
    count = t.get("count", r.integer, required=False, default=n)
    if count != n:
        if layout == "custom":
            rule = f"the number of axes_B ({n})"
        else:
            rule = f"{n} for layout = {layout!r} (use layout = 'custom' with axes_B for another set)"
        raise r.error(t.key("count"), f"must be {rule}, got {count}")

    def per_wheel(name: str, *, required: bool = True, allow_zero: bool = False) -> PerWheel:
        value = t.get(name, lambda v, k: r.scalar_or_list(v, k, n, "wheel"), required=required, default=0.0)
        _positive(r, t.key(name), value, allow_zero=allow_zero, unit=unit_of(t.key(name)))
        return value

    config = WheelsConfig(
        layout=layout,
        count=n,
        axes_B=axes,
        elevation_deg=elevation,
        spin_inertia_kg_m2=per_wheel("spin_inertia_kg_m2"),
        torque_max_Nm=per_wheel("torque_max_Nm"),
        momentum_max_Nms=per_wheel("momentum_max_Nms"),
        viscous_friction_Nms_per_rad=per_wheel("viscous_friction_Nms_per_rad", required=False, allow_zero=True),
        coulomb_friction_Nm=per_wheel("coulomb_friction_Nm", required=False, allow_zero=True),
        null_space_gain_per_s=t.number("null_space_gain_per_s", required=False, default=0.0),
        bias_momentum_Nms=t.get(
            "bias_momentum_Nms", lambda v, k: r.scalar_or_list(v, k, n, "wheel"), required=False, default=0.0
        ),
        torque_saturation=_read_saturation(r, t, "torque_saturation"),
    )
    _positive(r, t.key("null_space_gain_per_s"), config.null_space_gain_per_s, allow_zero=True, unit="1/s")
    key = t.key("axes_B") if layout == "custom" else t.key("layout")
    _try_build(r, key, lambda: build.reaction_wheels(config))
    return config


def _read_saturation(r: _Reader, t: _Table, name: str) -> str:
    """A saturation mode (:data:`attitude.actuators.SATURATION_MODES`), 'scale' when left out."""
    return t.get(
        name, lambda v, k: r.string(v, k, SATURATION_MODES, "saturation mode"), required=False, default="scale"
    )


def _read_preset(r: _Reader, t: _Table, presets: Mapping[str, Any], what: str) -> str | None:
    return t.get("preset", lambda v, k: r.string(v, k, tuple(presets), what), required=False)


def _read_gyro(r: _Reader, t: _Table) -> GyroConfig:
    preset = _read_preset(r, t, GYRO_PRESETS, "gyro preset")
    period = t.number("period_s")
    _positive(r, t.key("period_s"), period, unit="s")
    if preset is None and not t.has("arw_deg_per_sqrt_h"):
        raise t.missing("arw_deg_per_sqrt_h", f", or a preset ({_list(GYRO_PRESETS)})")
    num = {
        name: t.number(name, required=False)
        for name in (
            "arw_deg_per_sqrt_h",
            "rrw_deg_per_h_per_sqrt_h",
            "bias_instability_deg_per_h",
            "bias_instability_time_s",
            "quantization_deg_per_s",
        )
    }
    num["saturation_deg_per_s"] = t.number("saturation_deg_per_s", required=False, allow_inf=True)
    for name in ("arw_deg_per_sqrt_h", "bias_instability_deg_per_h", "bias_instability_time_s"):
        _positive(r, t.key(name), num[name], unit=unit_of(t.key(name)))
    for name in ("rrw_deg_per_h_per_sqrt_h", "quantization_deg_per_s"):
        _positive(r, t.key(name), num[name], allow_zero=True, unit=unit_of(t.key(name)))
    _positive(r, t.key("saturation_deg_per_s"), num["saturation_deg_per_s"], unit="deg/s")
    if preset is None and num["bias_instability_deg_per_h"] is not None and num["bias_instability_time_s"] is None:
        raise t.missing("bias_instability_time_s", " (required with bias_instability_deg_per_h)")
    per_axis = {
        name: t.get(name, lambda v, k: r.scalar_or_list(v, k, 3, "axis"), required=False)
        for name in ("bias_deg_per_h", "scale_factor_ppm")
    }
    if per_axis["scale_factor_ppm"] is not None:
        for i, v in enumerate(_values(per_axis["scale_factor_ppm"])):
            k = t.key("scale_factor_ppm") + (f"[{i}]" if isinstance(per_axis["scale_factor_ppm"], tuple) else "")
            r.check(v > -1e6, k, "> -1e6 ppm (a positive gain)", v)
    misalignment = t.get("misalignment_arcsec", lambda v, k: r.vector(v, k, 3, nonzero=False), required=False)
    config = GyroConfig(preset=preset, period_s=period, misalignment_arcsec=misalignment, **num, **per_axis)
    _try_build(r, t.path, lambda: build.gyro(config))
    return config


def _read_star_tracker(r: _Reader, t: _Table, sun: Vector | None) -> StarTrackerConfig:
    preset = _read_preset(r, t, STAR_TRACKER_PRESETS, "star tracker preset")
    period = t.number("period_s")
    _positive(r, t.key("period_s"), period, unit="s")
    if preset is None:
        for name in ("cross_boresight_arcsec", "roll_arcsec"):
            if not t.has(name):
                raise t.missing(name, f", or a preset ({_list(STAR_TRACKER_PRESETS)})")
    cross = t.number("cross_boresight_arcsec", required=False)
    roll = t.number("roll_arcsec", required=False)
    _positive(r, t.key("cross_boresight_arcsec"), cross, unit="arcsec")
    _positive(r, t.key("roll_arcsec"), roll, unit="arcsec")
    boresight = t.get("boresight_B", lambda v, k: r.vector(v, k, 3), required=False, default=(0.0, 0.0, 1.0))
    exclusion = t.number("sun_exclusion_deg", required=False)
    if exclusion is not None:
        _in_range(r, t.key("sun_exclusion_deg"), exclusion, 0.0, 180.0, low_open=True, high_open=True)
    if sun is not None and exclusion is None and preset is None:
        raise t.missing("sun_exclusion_deg", " (needed because environment.sun_direction_N is given)")
    config = StarTrackerConfig(
        preset=preset,
        period_s=period,
        cross_boresight_arcsec=cross,
        roll_arcsec=roll,
        boresight_B=boresight,
        sun_exclusion_deg=exclusion,
    )
    _try_build(r, t.path, lambda: build.star_tracker(config, sun))
    return config


def _read_control(r: _Reader, t: _Table) -> ControlConfig:
    period = t.number("period_s")
    _positive(r, t.key("period_s"), period, unit="s")
    bandwidth = t.get("bandwidth_rad_per_s", lambda v, k: r.scalar_or_list(v, k, 3, "axis"))
    _positive(r, t.key("bandwidth_rad_per_s"), bandwidth, unit="rad/s")
    nyquist = math.pi / period
    for i, v in enumerate(_values(bandwidth)):
        r.check(
            v < nyquist,
            t.key("bandwidth_rad_per_s") + (f"[{i}]" if isinstance(bandwidth, tuple) else ""),
            f"below the Nyquist frequency pi / period_s = {nyquist:.6g} rad/s of the {period:g} s controller "
            "(a tenth of the sample rate or less is the usual design range)",
            v,
        )
    damping = t.get("damping", lambda v, k: r.scalar_or_list(v, k, 3, "axis"))
    _positive(r, t.key("damping"), damping)
    lqr = None
    lt = t.table("lqr", required=False)
    if lt is not None:
        values = {
            name: lt.get(name, lambda v, k: r.scalar_or_list(v, k, 3, "axis"))
            for name in ("angle_max_deg", "rate_max_deg_per_s", "torque_max_Nm")
        }
        for name, value in values.items():
            _positive(r, lt.key(name), value, unit=unit_of(lt.key(name)))
        for i, v in enumerate(_values(values["angle_max_deg"])):
            k = lt.key("angle_max_deg") + (f"[{i}]" if isinstance(values["angle_max_deg"], tuple) else "")
            r.check(v <= 180.0, k, "at most 180 deg (the largest attitude error)", v)
        lqr = LQRBounds(**values)
    filters = t.get("filters", lambda v, k: _read_control_filters(r, v, k, period), required=False, default=())
    return ControlConfig(period_s=period, bandwidth_rad_per_s=bandwidth, damping=damping, lqr=lqr, filters=filters)


#: Default pole damping of a notch (its width: the -3 dB band of a deep notch is 2 x 0.5 x its frequency wide).
NOTCH_DAMPING = 0.5
#: Default damping of a second-order low-pass (Butterworth).
LOW_PASS_DAMPING = 1.0 / math.sqrt(2.0)


def _read_control_filters(r: _Reader, raw: Any, key: str, period: float) -> tuple[ControlFilterConfig, ...]:
    if not isinstance(raw, list) or not raw:
        raise r.error(key, f"expected an array of tables ([[control.filters]] entries), got {_describe(raw)}")
    nyquist_Hz = 0.5 / period
    out = []
    for i, entry in enumerate(raw):
        t = _Table(r, entry, f"{key}[{i}]")
        kind = t.get("kind", lambda v, k: r.string(v, k, FILTER_KINDS, "filter kind"))
        frequency = t.number("frequency_Hz")
        _positive(r, t.key("frequency_Hz"), frequency, unit="Hz")
        r.check(
            frequency < nyquist_Hz,
            t.key("frequency_Hz"),
            f"below the Nyquist frequency 1 / (2 control.period_s) = {nyquist_Hz:.6g} Hz of the {period:g} s "
            "controller (a discrete filter cannot act above it)",
            frequency,
        )
        axes = t.get("axes", lambda v, k: _read_axes(r, v, k), required=False, default=("x", "y", "z"))
        if kind == "notch":
            t.forbid("order", "a notch has no order (order is the low-pass's: 1 or 2)")
            depth = t.number("depth")
            _in_range(r, t.key("depth"), depth, 0.0, 1.0, low_open=False, high_open=True)
            damping = t.number("damping", required=False, default=NOTCH_DAMPING)
            _positive(r, t.key("damping"), damping)
            order = None
        else:
            t.forbid("depth", "a low-pass has no depth (depth is the notch's gain at its centre)")
            order = t.get("order", r.integer, required=False, default=2)
            r.check(order in (1, 2), t.key("order"), "1 or 2", order)
            if order == 1:
                t.forbid("damping", "a first-order low-pass has no damping ratio (give order = 2 for one)")
                damping = None
            else:
                damping = t.number("damping", required=False, default=LOW_PASS_DAMPING)
                _positive(r, t.key("damping"), damping)
            depth = None
        out.append(ControlFilterConfig(kind, frequency, axes, depth, damping, order))
    return tuple(out)


def _read_axes(r: _Reader, value: Any, key: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not value:
        raise r.error(key, f'expected a non-empty list of body axes such as ["x", "z"], got {_describe(value)}')
    axes = tuple(r.string(v, f"{key}[{i}]", ("x", "y", "z"), "axis") for i, v in enumerate(value))
    r.check(len(set(axes)) == len(axes), key, "each axis at most once", list(axes))
    return axes


#: Length of a line of a two-line element set (CelesTrak / Space-Track format).
TLE_LINE_LENGTH = 69


def _read_epoch(r: _Reader, t: _Table) -> str:
    """``epoch_utc`` as a canonical UTC ISO 8601 string (``...Z``); the default epoch when left out."""
    key = t.key("epoch_utc")
    if not t.has("epoch_utc"):
        return DEFAULT_EPOCH_UTC
    value = t.data["epoch_utc"]
    example = 'write e.g. epoch_utc = "2026-03-20T12:00:00Z" (UTC)'
    if isinstance(value, datetime.datetime):
        instant = value
    elif isinstance(value, str):
        try:
            instant = datetime.datetime.fromisoformat(value.strip())
        except ValueError:
            raise r.error(key, f"must be an ISO 8601 date and time, got {_describe(value)}; {example}") from None
    else:
        raise r.error(key, f"expected an ISO 8601 date and time, got {_describe(value)}; {example}")
    if instant.tzinfo is None or instant.utcoffset() is None:
        raise r.error(key, f"must carry its time zone (Z or +hh:mm), got {_describe(value)} without one; {example}")
    utc = instant.astimezone(datetime.UTC)
    text = utc.strftime("%Y-%m-%dT%H:%M:%S") + (f".{utc.microsecond:06d}" if utc.microsecond else "") + "Z"
    _try_build(r, key, lambda: Epoch.from_iso(text))
    return text


def _angle(r: _Reader, t: _Table, name: str, default: float = 0.0) -> float:
    value = t.number(name, required=False, default=default)
    _in_range(r, t.key(name), value, -360.0, 360.0, low_open=False, high_open=False)
    return value


def _inclination(r: _Reader, t: _Table) -> float:
    value = t.number("inclination_deg", required=False, default=0.0)
    _in_range(r, t.key("inclination_deg"), value, 0.0, 180.0, low_open=False, high_open=False)
    return value


def _tle_checksum(line: str) -> int:
    """The modulo-10 checksum of a TLE line's first 68 columns (digits count, '-' counts 1)."""
    return sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68]) % 10


def _read_tle_line(r: _Reader, t: _Table, number: int) -> str:
    name = f"tle_line{number}"
    key = t.key(name)
    if not t.has(name):
        raise t.missing(name, " (kind = 'tle' needs both lines)")
    line = t.data[name]
    if not isinstance(line, str):
        raise r.error(key, f"expected a string (line {number} of the TLE), got {_describe(line)}")
    line = line.rstrip()
    if not line.startswith(f"{number} "):
        raise r.error(key, f"must be line {number} of a TLE, starting with '{number} ', got {line[:12]!r}...")
    if len(line) != TLE_LINE_LENGTH:
        raise r.error(key, f"must be {TLE_LINE_LENGTH} characters long (a TLE line), got {len(line)}")
    if line[68].isdigit() and int(line[68]) != _tle_checksum(line):
        raise r.error(
            key,
            f"checksum fails: the last digit is {line[68]} but the line sums to {_tle_checksum(line)} "
            "(modulo 10, each '-' counting 1): a character was changed in copying",
        )
    return line


def _read_orbit(r: _Reader, t: _Table) -> OrbitConfig:
    kind = t.get("kind", lambda v, k: r.string(v, k, ORBIT_KINDS, "orbit kind"), required=False, default="circular")
    for name in t.data:
        if name != "kind" and name not in ORBIT_KEYS[kind]:
            kinds = [k for k, names in ORBIT_KEYS.items() if name in names]
            raise r.error(
                t.key(name),
                f"applies to kind = {' or '.join(map(repr, kinds))}, not to this kind = {kind!r} orbit"
                + (f" (set kind = {kinds[0]!r} to use it)" if len(kinds) == 1 else ""),
            )
    if kind == "tle":
        config = OrbitConfig(
            kind="tle",
            inclination_deg=None,
            raan_deg=None,
            argument_of_latitude_deg=None,
            epoch_utc=None,
            tle_line1=_read_tle_line(r, t, 1),
            tle_line2=_read_tle_line(r, t, 2),
        )

        def make_tle() -> Any:
            try:
                return build.tle_orbit(config)
            except ValueError as exc:
                line = "tle_line2" if "line2" in str(exc) and "line1" not in str(exc) else "tle_line1"
                raise ConfigError(str(exc), key=t.key(line), file=r.file) from exc

        make_tle()
        return config
    if kind == "circular":
        altitude = t.number("altitude_km")
        _positive(r, t.key("altitude_km"), altitude, unit="km")
        r.check(altitude < 1e9, t.key("altitude_km"), "below 1e9 km (an Earth orbit)", altitude)
        inclination = _inclination(r, t)
        angles = {name: _angle(r, t, name) for name in ("raan_deg", "argument_of_latitude_deg")}
        config = OrbitConfig(altitude_km=altitude, inclination_deg=inclination, epoch_utc=_read_epoch(r, t), **angles)
        _try_build(r, t.path, lambda: build.circular_orbit(config))
        _check_perigee(r, t.key("altitude_km"), altitude)
        return config
    # kepler
    by_altitudes = t.has("perigee_altitude_km") or t.has("apogee_altitude_km")
    by_elements = t.has("semi_major_axis_km") or t.has("eccentricity")
    shapes = "perigee_altitude_km and apogee_altitude_km, or semi_major_axis_km and eccentricity"
    if by_altitudes and by_elements:
        raise r.error(t.key("semi_major_axis_km"), f"give {shapes}, not both")
    if not (by_altitudes or by_elements):
        raise r.error(t.key("perigee_altitude_km"), f"missing required key: a Keplerian orbit needs {shapes}")
    sizes: dict[str, float | None] = {}
    if by_altitudes:
        perigee, apogee = t.number("perigee_altitude_km"), t.number("apogee_altitude_km")
        r.check(
            perigee > 0.0,
            t.key("perigee_altitude_km"),
            "above the Earth's surface (> 0 km, equatorial radius)",
            perigee,
        )
        r.check(apogee < 1e9, t.key("apogee_altitude_km"), "below 1e9 km (an Earth orbit)", apogee)
        r.check(
            apogee >= perigee,
            t.key("apogee_altitude_km"),
            f"at least perigee_altitude_km = {perigee:g} km (the apogee is the highest point)",
            apogee,
        )
        sizes.update(perigee_altitude_km=perigee, apogee_altitude_km=apogee)
    else:
        a_km, e = t.number("semi_major_axis_km"), t.number("eccentricity")
        r.check(0.0 <= e < 1.0, t.key("eccentricity"), "in [0, 1) for a closed orbit", e)
        r.check(a_km < 1e9, t.key("semi_major_axis_km"), "below 1e9 km (an Earth orbit)", a_km)
        perigee_km = a_km * (1.0 - e) - R_EARTH / 1000.0
        if not perigee_km > 0.0:
            raise r.error(
                t.key("semi_major_axis_km"),
                f"must put the perigee above the Earth's surface: a (1 - e) - R = {a_km:g} km x (1 - {e:g}) - "
                f"{R_EARTH / 1000.0:g} km = {perigee_km:.6g} km altitude (with eccentricity = {e:g})",
            )
        sizes.update(semi_major_axis_km=a_km, eccentricity=e)
    config = OrbitConfig(
        kind="kepler",
        inclination_deg=_inclination(r, t),
        raan_deg=_angle(r, t, "raan_deg"),
        argument_of_latitude_deg=None,
        argument_of_perigee_deg=_angle(r, t, "argument_of_perigee_deg"),
        mean_anomaly_deg=_angle(r, t, "mean_anomaly_deg"),
        epoch_utc=_read_epoch(r, t),
        **sizes,
    )
    kepler = _try_build(r, t.path, lambda: build.kepler_orbit(config))
    key = t.key("perigee_altitude_km" if by_altitudes else "semi_major_axis_km")
    _check_perigee(r, key, kepler.perigee_altitude_m / 1000.0)
    return config


#: Lowest perigee accepted [km]: the Karman line. Below it drag ends an orbit within a few revolutions
#: (and the exponential atmosphere's 0-100 km bands describe air, not orbits).
PERIGEE_ALTITUDE_MIN_KM = 100.0


def _check_perigee(r: _Reader, key: str, perigee_km: float) -> None:
    if not perigee_km >= PERIGEE_ALTITUDE_MIN_KM:
        raise r.error(
            key,
            f"must keep the perigee at least {PERIGEE_ALTITUDE_MIN_KM:g} km up (the Karman line: below it drag "
            f"ends any orbit within a few revolutions), got a perigee altitude of {perigee_km:.6g} km",
        )


def _fraction(r: _Reader, t: _Table, name: str, default: float) -> float:
    value = t.number(name, required=False, default=default)
    _in_range(r, t.key(name), value, 0.0, 1.0, low_open=False, high_open=False)
    return value


def _optics_sum(r: _Reader, t: _Table, specular: str, diffuse: str, values: tuple[float, float]) -> None:
    s, d = values
    if s + d > 1.0:
        raise r.error(
            t.key(diffuse),
            f"{specular} + {diffuse} must be at most 1 (the absorbed fraction 1 - {specular} - {diffuse} "
            f"cannot be negative), got {s!r} + {d!r} = {s + d!r}",
        )


def _drag(r: _Reader, t: _Table, name: str) -> float:
    value = t.number(name, required=False, default=DEFAULT_DRAG_COEFFICIENT)
    _positive(r, t.key(name), value, allow_zero=True)
    return value


def _read_plates(r: _Reader, raw: Any, key: str, panel: bool) -> tuple[Any, ...]:
    what = "surface.panel" if panel else "surface.plate"
    if not isinstance(raw, list) or not raw:
        raise r.error(key, f"expected an array of tables ([[{what}]] entries), got {_describe(raw)}")
    out = []
    for i, entry in enumerate(raw):
        t = _Table(r, entry, f"{key}[{i}]")
        area = t.number("area_m2")
        _positive(r, t.key("area_m2"), area, unit="m^2")
        normal = t.get("normal_B", lambda v, k: r.vector(v, k, 3))
        cop = t.get("centre_of_pressure_B_m", lambda v, k: r.vector(v, k, 3, nonzero=False))
        specular, diffuse = _fraction(r, t, "specular", 0.0), _fraction(r, t, "diffuse", 0.0)
        _optics_sum(r, t, "specular", "diffuse", (specular, diffuse))
        if panel:
            back_s = _fraction(r, t, "back_specular", specular)
            back_d = _fraction(r, t, "back_diffuse", diffuse)
            _optics_sum(r, t, "back_specular", "back_diffuse", (back_s, back_d))
            out.append(
                PanelConfig(area, normal, cop, specular, diffuse, back_s, back_d, _drag(r, t, "drag_coefficient"))
            )
        else:
            out.append(PlateConfig(area, normal, cop, specular, diffuse, _drag(r, t, "drag_coefficient")))
    return tuple(out)


def _read_surface(r: _Reader, t: _Table) -> SurfaceConfig:
    box = t.get("box_m", lambda v, k: r.vector(v, k, 3, nonzero=False), required=False)
    box_keys = ("centre_of_pressure_offset_B_m", "box_specular", "box_diffuse", "box_drag_coefficient")
    extra: dict[str, Any] = {}
    if box is None:
        for name in box_keys:
            t.forbid(name, "only with box_m (it describes the box faces; each plate and panel carries its own)")
    else:
        for i, v in enumerate(box):
            r.check(v > 0.0, f"{t.key('box_m')}[{i}]", "strictly positive (> 0) [m] (an edge length)", v)
        extra["centre_of_pressure_offset_B_m"] = t.get(
            "centre_of_pressure_offset_B_m",
            lambda v, k: r.vector(v, k, 3, nonzero=False),
            required=False,
            default=(0.0, 0.0, 0.0),
        )
        extra["box_specular"] = _fraction(r, t, "box_specular", 0.0)
        extra["box_diffuse"] = _fraction(r, t, "box_diffuse", 0.0)
        _optics_sum(r, t, "box_specular", "box_diffuse", (extra["box_specular"], extra["box_diffuse"]))
        extra["box_drag_coefficient"] = _drag(r, t, "box_drag_coefficient")
    plates = t.get("plate", lambda v, k: _read_plates(r, v, k, panel=False), required=False, default=())
    panels = t.get("panel", lambda v, k: _read_plates(r, v, k, panel=True), required=False, default=())
    if box is None and not plates:
        raise r.error(
            t.key("box_m"),
            "missing required key: a [surface] needs box_m = [x, y, z] [m] or [[surface.plate]] entries "
            "(panels are added to them)",
        )
    dipole = t.get(
        "residual_dipole_Am2", lambda v, k: r.vector(v, k, 3, nonzero=False), required=False, default=(0.0, 0.0, 0.0)
    )
    config = SurfaceConfig(box_m=box, plates=plates, panels=panels, residual_dipole_Am2=dipole, **extra)
    _try_build(r, t.path, lambda: build.surface_model(config))
    return config


#: The ``[environment]`` keys that describe the orbit environment (all but the Sun direction).
_ENVIRONMENT_MODEL_KEYS = (
    "magnetic_field",
    "atmosphere",
    "f107_sfu",
    "f107_average_sfu",
    "ap",
    "eclipse",
    "sources",
    "sample_period_s",
)


def _read_sources(r: _Reader, value: Any, key: str) -> tuple[str, ...]:
    if not isinstance(value, list):
        raise r.error(key, f"expected a list of names drawn from {_list(DISTURBANCE_SOURCES)}, got {_describe(value)}")
    names = tuple(r.string(v, f"{key}[{i}]", DISTURBANCE_SOURCES, "disturbance source") for i, v in enumerate(value))
    for i, name in enumerate(names):
        if name in names[:i]:
            raise r.error(f"{key}[{i}]", f"repeats {name!r} (each source is flown once)")
    return names


def _read_environment(
    r: _Reader, t: _Table | None, sun: Vector | None, orbit: OrbitConfig | None, surface: SurfaceConfig | None
) -> EnvironmentConfig:
    if t is None:
        config = EnvironmentConfig(sun)
    else:
        if orbit is None:
            for name in _ENVIRONMENT_MODEL_KEYS:
                t.forbid(name, "needs an [orbit] table (the environment models are evaluated along the orbit)")
        field = t.get(
            "magnetic_field",
            lambda v, k: r.string(v, k, MAGNETIC_FIELD_MODELS, "field model"),
            required=False,
            default="igrf",
        )
        air = t.get(
            "atmosphere",
            lambda v, k: r.string(v, k, ATMOSPHERE_MODELS, "atmosphere model"),
            required=False,
            default="exponential",
        )
        weather: dict[str, float | None] = dict.fromkeys(NRLMSIS_DEFAULTS)
        if air == "nrlmsis":
            for name, default in NRLMSIS_DEFAULTS.items():
                weather[name] = t.number(name, required=False, default=default)
            _positive(r, t.key("f107_sfu"), weather["f107_sfu"], unit="sfu")
            _positive(r, t.key("f107_average_sfu"), weather["f107_average_sfu"], unit="sfu")
            _in_range(r, t.key("ap"), weather["ap"], 0.0, 400.0, low_open=False, high_open=False)
        else:
            for name in NRLMSIS_DEFAULTS:
                t.forbid(name, f"only with atmosphere = 'nrlmsis' (the space weather of NRLMSIS), not {air!r}")
        eclipse = t.get(
            "eclipse", lambda v, k: r.string(v, k, ECLIPSE_MODELS, "eclipse model"), required=False, default="conical"
        )
        sources = t.get("sources", lambda v, k: _read_sources(r, v, k), required=False)
        period = t.number("sample_period_s", required=False, default=1.0)
        _positive(r, t.key("sample_period_s"), period, unit="s")
        if sources is not None:
            key = t.key("sources")
            needs = {"aerodynamic": "a [surface]", "solar_pressure": "a [surface]", "magnetic": "a [surface]"}
            for name in sources:
                if name in needs and surface is None:
                    raise r.error(
                        key,
                        f"{name!r} needs a [surface] table (the plates and the residual dipole); "
                        'add one or fly sources = ["gravity_gradient"]',
                    )
            if "magnetic" in sources and field == "none":
                raise r.error(key, "'magnetic' needs a field model: environment.magnetic_field is 'none'")
            if "aerodynamic" in sources and air == "none":
                raise r.error(key, "'aerodynamic' needs an atmosphere: environment.atmosphere is 'none'")
        config = EnvironmentConfig(
            sun_direction_N=sun,
            magnetic_field=field,
            atmosphere=air,
            eclipse=eclipse,
            sources=sources,
            sample_period_s=period,
            **weather,
        )
    if orbit is not None:
        env = _try_build(r, "environment", lambda: build.orbit_environment(orbit, config, surface))
        if env is not None and env.magnetic_field is not None:
            # The field model's coefficients cover a span of dates (IGRF-14: 1900-2030): refuse an epoch outside.
            key = "orbit.tle_line1" if orbit.kind == "tle" else "orbit.epoch_utc"
            _try_build(
                r,
                key,
                lambda: env.magnetic_field.field_N(env.orbit.position_N(0.0)[None], env.epoch, np.zeros(1)),
                context="the orbit's epoch is outside the geomagnetic field model: ",
            )
    return config


def _needs(r: _Reader, key: str, what: str, **present: Any) -> None:
    """Refuse a table whose prerequisites are missing (a table flown without them would be ignored)."""
    missing = [name for name, value in present.items() if not value]
    if missing:
        tables = " and ".join(f"an [{name}] table" if name[0] in "aeiou" else f"a [{name}] table" for name in missing)
        raise r.error(key, f"needs {tables} ({what})")


def _read_magnetorquers(r: _Reader, t: _Table) -> MagnetorquersConfig:
    axes = None
    if t.has("axes_B"):
        key = t.key("axes_B")
        raw = t.data["axes_B"]
        if not isinstance(raw, list) or not raw:
            raise r.error(key, f"expected a list of axes [[x, y, z], ...], got {_describe(raw)}")
        axes = tuple(r.vector(a, f"{key}[{i}]", 3) for i, a in enumerate(raw))
    n = 3 if axes is None else len(axes)
    dipole = t.get("dipole_max_Am2", lambda v, k: r.scalar_or_list(v, k, n, "rod"))
    _positive(r, t.key("dipole_max_Am2"), dipole, unit="A m^2")
    quantum = t.get("quantum_Am2", lambda v, k: r.scalar_or_list(v, k, n, "rod"), required=False)
    _positive(r, t.key("quantum_Am2"), quantum, unit="A m^2")
    saturation = _read_saturation(r, t, "saturation")
    config = MagnetorquersConfig(dipole_max_Am2=dipole, quantum_Am2=quantum, axes_B=axes, saturation=saturation)
    _try_build(r, t.path, lambda: build.magnetorquers(config))
    return config


#: Largest magnetometer misalignment [deg]: the error model is the first-order rotation ``I - [phi x]``.
MAGNETOMETER_MISALIGNMENT_MAX_DEG = 10.0


def _read_magnetometer(r: _Reader, t: _Table) -> MagnetometerConfig:
    period = t.number("period_s")
    _positive(r, t.key("period_s"), period, unit="s")
    noise = t.number("noise_nT")
    _positive(r, t.key("noise_nT"), noise, allow_zero=True, unit="nT")
    bias = t.get("bias_nT", lambda v, k: r.scalar_or_list(v, k, 3, "axis"), required=False, default=0.0)
    scale = t.get("scale_factor_ppm", lambda v, k: r.scalar_or_list(v, k, 3, "axis"), required=False, default=0.0)
    for i, v in enumerate(_values(scale)):
        k = t.key("scale_factor_ppm") + (f"[{i}]" if isinstance(scale, tuple) else "")
        r.check(v > -1e6, k, "> -1e6 ppm (a positive gain)", v)
    misalignment = t.get(
        "misalignment_deg", lambda v, k: r.vector(v, k, 3, nonzero=False), required=False, default=(0.0, 0.0, 0.0)
    )
    angle = math.sqrt(sum(v * v for v in misalignment))
    r.check(
        angle <= MAGNETOMETER_MISALIGNMENT_MAX_DEG,
        t.key("misalignment_deg"),
        f"a small rotation, |phi| <= {MAGNETOMETER_MISALIGNMENT_MAX_DEG:g} deg (the error model is first order)",
        misalignment,
    )
    quantization = t.number("quantization_nT", required=False, default=0.0)
    _positive(r, t.key("quantization_nT"), quantization, allow_zero=True, unit="nT")
    config = MagnetometerConfig(period, noise, bias, scale, misalignment, quantization)
    _try_build(r, t.path, lambda: build.magnetometer(config))
    return config


def _read_coarse_sun_sensors(r: _Reader, t: _Table) -> CoarseSunSensorsConfig:
    period = t.number("period_s")
    _positive(r, t.key("period_s"), period, unit="s")
    noise = t.number("noise_percent")
    _positive(r, t.key("noise_percent"), noise, unit="% of full scale")
    normals = None
    if t.has("normals_B"):
        key = t.key("normals_B")
        raw = t.data["normals_B"]
        if not isinstance(raw, list) or len(raw) < 3:
            raise r.error(key, f"expected a list of at least 3 cell normals [[x, y, z], ...], got {_describe(raw)}")
        normals = tuple(r.vector(a, f"{key}[{i}]", 3) for i, a in enumerate(raw))
        unit = np.array(normals) / np.linalg.norm(np.array(normals), axis=1, keepdims=True)
        r.check(
            np.linalg.svd(unit, compute_uv=False)[-1] > 1e-6,
            key,
            "normals spanning three dimensions (a Sun vector has three components; these lie in a plane)",
            [list(n) for n in normals],
        )
    fov = t.number("fov_half_angle_deg", required=False, default=90.0)
    _in_range(r, t.key("fov_half_angle_deg"), fov, 0.0, 90.0, low_open=True, high_open=False)
    albedo = t.number("albedo_percent", required=False, default=0.0)
    _positive(r, t.key("albedo_percent"), albedo, allow_zero=True, unit="% of full scale")
    config = CoarseSunSensorsConfig(period, noise, normals, fov, albedo)
    _try_build(r, t.path, lambda: build.coarse_sun_sensors(config))
    return config


def _read_fine_sun_sensor(r: _Reader, t: _Table) -> FineSunSensorConfig:
    period = t.number("period_s")
    _positive(r, t.key("period_s"), period, unit="s")
    accuracy = t.number("accuracy_deg")
    _positive(r, t.key("accuracy_deg"), accuracy, unit="deg")
    level = t.number("accuracy_sigma_level")
    _positive(r, t.key("accuracy_sigma_level"), level)
    fov = t.number("fov_half_angle_deg")
    _in_range(r, t.key("fov_half_angle_deg"), fov, 0.0, 90.0, low_open=True, high_open=True)
    boresight = t.get("boresight_B", lambda v, k: r.vector(v, k, 3), required=False, default=(0.0, 0.0, 1.0))
    bias = t.get("bias_deg", lambda v, k: r.scalar_or_list(v, k, 2, "angle"), required=False, default=0.0)
    config = FineSunSensorConfig(period, accuracy, level, fov, boresight, bias)
    _try_build(r, t.path, lambda: build.fine_sun_sensor(config))
    return config


def _read_detumble(r: _Reader, t: _Table) -> DetumbleConfig:
    tip_off = t.get("tip_off_rate_deg_per_s", lambda v, k: r.scalar_or_list(v, k, 3, "axis"))
    threshold = t.number("rate_threshold_deg_per_s")
    _positive(r, t.key("rate_threshold_deg_per_s"), threshold, unit="deg/s")
    rates = np.broadcast_to(np.array(tip_off, dtype=float), (3,))
    magnitude = float(np.linalg.norm(rates))
    r.check(
        magnitude > threshold,
        t.key("tip_off_rate_deg_per_s"),
        f"faster than rate_threshold_deg_per_s = {threshold:g} deg/s in magnitude (|w| = {magnitude:.6g} deg/s; "
        "a scalar applies to every axis)",
        tip_off,
    )
    gain: float | str = "auto"
    if t.has("gain_Nms"):
        raw = t.data["gain_Nms"]
        if raw != "auto":
            gain = r.number(raw, t.key("gain_Nms"))
            _positive(r, t.key("gain_Nms"), gain, unit="N m s")
    period = t.number("period_s", required=False, default=1.0)
    _positive(r, t.key("period_s"), period, unit="s")
    duration = t.number("duration_max_orbits", required=False, default=5.0)
    _positive(r, t.key("duration_max_orbits"), duration)
    r.check(duration <= 1000.0, t.key("duration_max_orbits"), "at most 1000 orbits", duration)
    return DetumbleConfig(tip_off, threshold, gain, period, duration)


def _read_momentum(r: _Reader, t: _Table) -> MomentumConfig:
    gain = t.number("unloading_gain_per_s", required=False)
    _positive(r, t.key("unloading_gain_per_s"), gain, unit="1/s")
    period = t.number("period_s", required=False, default=1.0)
    _positive(r, t.key("period_s"), period, unit="s")
    if gain is not None:
        r.check(
            gain * period < 1.0,
            t.key("unloading_gain_per_s"),
            f"below 1 / period_s = {1.0 / period:.6g} 1/s (the sampled law removes a fraction k T of the "
            "excess momentum per step: k T >= 1 over-corrects)",
            gain,
        )
    orbits = t.get("orbits", r.integer, required=False, default=20)
    r.check(1 <= orbits <= 1000, t.key("orbits"), "an integer in [1, 1000] (orbits of the budget)", orbits)
    margin = t.number("wheel_momentum_margin", required=False, default=1.0)
    _in_range(r, t.key("wheel_momentum_margin"), margin, 0.0, 1.0, low_open=True, high_open=False)
    return MomentumConfig(gain, period, orbits, margin)


#: Accepted deviation of a typed quaternion's norm from 1: four significant
#: digits as typed (e.g. 0.7071) are off by ~1e-5; a non-unit quaternion such
#: as [1, 1, 0, 0] is a typo, not an attitude, and is rejected.
QUATERNION_NORM_TOLERANCE = 1e-4


def _read_quaternion(r: _Reader, value: Any, key: str) -> tuple[float, float, float, float]:
    q = r.vector(value, key, 4)
    norm = math.sqrt(sum(v * v for v in q))
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise r.error(
            key,
            f"must be a unit quaternion [w, x, y, z] (| |q| - 1 | <= {QUATERNION_NORM_TOLERANCE:g}); "
            f"got {list(q)} with |q| = {norm:.6g}",
        )
    return q  # type: ignore[return-value]


def _read_slew(r: _Reader, t: _Table) -> SlewRequirement:
    time_max = t.number("time_max_s")
    _positive(r, t.key("time_max_s"), time_max, unit="s")
    start = t.get("start_q_BN", lambda v, k: _read_quaternion(r, v, k), required=False, default=(1.0, 0.0, 0.0, 0.0))
    rate = t.number("rate_max_deg_per_s", required=False)
    _positive(r, t.key("rate_max_deg_per_s"), rate, unit="deg/s")
    angle = axis = target = None
    if t.has("target_q_BN"):
        for name in ("angle_deg", "axis_B"):
            t.forbid(name, "give angle_deg with axis_B, or target_q_BN, not both")
        target = _read_quaternion(r, t.data["target_q_BN"], t.key("target_q_BN"))
    else:
        if not t.has("angle_deg"):
            raise t.missing("angle_deg")
        angle = t.number("angle_deg")
        _in_range(r, t.key("angle_deg"), angle, 0.0, 180.0, low_open=True, high_open=False)
        if not t.has("axis_B"):
            raise t.missing("axis_B", " (the body axis of the angle_deg rotation)")
        axis = r.vector(t.data["axis_B"], t.key("axis_B"), 3)
    slew = SlewRequirement(
        time_max_s=time_max, angle_deg=angle, axis_B=axis, target_q_BN=target, start_q_BN=start, rate_max_deg_per_s=rate
    )
    if target is not None and slew.angle_rad < 1e-9:
        raise r.error(t.key("target_q_BN"), f"equals start_q_BN {list(start)} (a zero slew)")
    return slew


def _read_keep_out(r: _Reader, raw: Any, key: str, sun: Vector | None) -> tuple[KeepOutConfig, ...]:
    if not isinstance(raw, list):
        raise r.error(key, f"expected an array of tables ([[requirements.keep_out]] entries), got {_describe(raw)}")
    cones = []
    for i, entry in enumerate(raw):
        t = _Table(r, entry, f"{key}[{i}]")
        name = t.get("name", r.string, required=False, default=f"keep_out_{i}")
        boresight = t.get("boresight_B", lambda v, k: r.vector(v, k, 3))
        dkey = t.key("direction_N")
        if not t.has("direction_N"):
            raise t.missing("direction_N")
        raw_direction = t.data["direction_N"]
        follows_sun = isinstance(raw_direction, str)
        if follows_sun:
            if raw_direction != "sun":
                raise r.error(dkey, f'expected a list of 3 numbers or "sun", got {_describe(raw_direction)}')
            if sun is None:
                raise r.error(dkey, '"sun" needs environment.sun_direction_N: add it to an [environment] table')
            direction = sun
        else:
            direction = r.vector(raw_direction, dkey, 3)
        half = t.number("half_angle_deg")
        _in_range(r, t.key("half_angle_deg"), half, 0.0, 180.0, low_open=True, high_open=True)
        cones.append(KeepOutConfig(name, boresight, direction, half, follows_sun))
    return tuple(cones)


def _read_requirements(r: _Reader, t: _Table, sun: Vector | None) -> RequirementsConfig:
    accuracy = t.number("pointing_accuracy_deg")
    _in_range(r, t.key("pointing_accuracy_deg"), accuracy, 0.0, 180.0, low_open=True, high_open=False)
    settling = t.number("settling_time_s")
    _positive(r, t.key("settling_time_s"), settling, unit="s")
    slew = _read_slew(r, t.table("slew"))
    keep_out = t.get("keep_out", lambda v, k: _read_keep_out(r, v, k, sun), required=False, default=())
    hold = t.number("hold_time_s", required=False)
    if hold is not None:
        _positive(r, t.key("hold_time_s"), hold, unit="s")
    disk_margin = t.number("disk_margin_min", required=False)
    if disk_margin is not None:
        r.check(
            0.0 < disk_margin < 2.0,
            t.key("disk_margin_min"),
            "in (0, 2): a disk margin of 2 would tolerate a gain of zero and infinite gain, which no loop does",
            disk_margin,
        )
    return RequirementsConfig(accuracy, settling, slew, keep_out, hold, disk_margin)


def _read_dispersion(r: _Reader, t: _Table, name: str) -> Dispersion | None:
    suffix, _, _, extra = DISPERSIONS[name]
    dt = t.table(name, required=False)
    if dt is None:
        return None
    distribution = dt.get("distribution", lambda v, k: r.string(v, k, DISTRIBUTIONS + extra, "distribution"))
    sigma_key, half_key = f"sigma_{suffix}", f"half_width_{suffix}"
    if distribution == "normal":
        dt.forbid(half_key, f"only with distribution = 'uniform' (normal takes {sigma_key})")
        scale = dt.number(sigma_key)
    elif distribution == "uniform":
        dt.forbid(sigma_key, f"only with distribution = 'normal' (uniform takes {half_key})")
        scale = dt.number(half_key)
    else:  # uniform_so3
        for k in (sigma_key, half_key):
            dt.forbid(k, f"distribution = {distribution!r} takes no scale")
        return Dispersion(distribution, None, suffix)
    scale_key = dt.key(sigma_key if distribution == "normal" else half_key)
    _positive(r, scale_key, scale, allow_zero=True, unit=unit_of(scale_key))
    if suffix == "percent":
        what = "the drag coefficients" if name == "drag_scale" else "moments"
        r.check(scale < 100.0, scale_key, f"below 100 percent ({what} must stay positive)", scale)
    axis = 0.0
    if name == "inertia":
        axis = dt.number("axis_sigma_deg", required=False, default=0.0)
        _positive(r, dt.key("axis_sigma_deg"), axis, allow_zero=True, unit="deg")
        r.check(axis <= 30.0, dt.key("axis_sigma_deg"), "at most 30 deg (principal axes known to a few degrees)", axis)
    return Dispersion(distribution, scale, suffix, axis)


def _read_montecarlo(r: _Reader, t: _Table) -> MonteCarloConfig:
    runs = t.get("runs", r.integer)
    r.check(runs >= 1, t.key("runs"), "a positive integer", runs)
    seed = t.get("seed", r.integer)
    r.check(seed >= 0, t.key("seed"), "a non-negative integer", seed)
    return MonteCarloConfig(runs, seed, **{name: _read_dispersion(r, t, name) for name in DISPERSIONS})


def _read_flexible_modes(r: _Reader, raw: Any, key: str, inertia: InertiaConfig) -> tuple[FlexibleModeConfig, ...]:
    if not isinstance(raw, list) or not raw:
        raise r.error(key, f"expected an array of tables ([[flexible_modes]] entries), got {_describe(raw)}")
    out = []
    for i, entry in enumerate(raw):
        t = _Table(r, entry, f"{key}[{i}]")
        frequency = t.number("frequency_Hz")
        _positive(r, t.key("frequency_Hz"), frequency, unit="Hz")
        damping = t.number("damping")
        r.check(
            0.0 <= damping < 1.0,
            t.key("damping"),
            "in [0, 1) (a negative ratio feeds energy into the mode; 1 or more is no longer a vibration)",
            damping,
        )
        participation = t.get("participation_B_sqrt_kg_m", lambda v, k: r.vector(v, k, 3, nonzero=False))
        out.append(FlexibleModeConfig(frequency, damping, participation))
    modes = tuple(out)
    _try_build(
        r,
        f"{key}[].participation_B_sqrt_kg_m",
        lambda: FlexibleBody(build.rigid_body(inertia), build.flexible_modes(modes)),
        "with the [inertia]: ",
    )
    return modes


#: The ``[uncertainty]`` bounds: key -> (largest value, whether it may be reached, why).
_UNCERTAINTY_LIMITS = {
    "inertia_percent": (100.0, False, "the moments must stay positive"),
    "axis_rotation_deg": (180.0, True, "a rotation angle"),
    "wheel_misalignment_deg": (90.0, False, "a wheel tilted 90 deg gives no torque about its axis"),
    "extra_delay_s": (math.inf, False, "finite"),
}


def _read_uncertainty(r: _Reader, t: _Table, inertia: InertiaConfig) -> UncertaintyConfig:
    values = {}
    for name, (high, closed, why) in _UNCERTAINTY_LIMITS.items():
        key = t.key(name)
        value = t.number(name, required=False, default=0.0)
        _positive(r, key, value, allow_zero=True, unit=unit_of(key))
        if math.isfinite(high):
            rule = f"{'at most' if closed else 'below'} {high:g} {unit_of(key)} ({why})"
            r.check(value <= high if closed else value < high, key, rule, value)
        values[name] = value
    # Every corner of the moments' box must still be a body (the rotation leaves the moments alone).
    moments = build.rigid_body(inertia).principal_axes().moments
    p = values["inertia_percent"] / 100.0
    for signs in itertools.product((-1.0, 1.0), repeat=3):
        corner = tuple(float(m * (1.0 + s * p)) for m, s in zip(moments, signs))
        _try_build(
            r,
            t.key("inertia_percent"),
            lambda corner=corner: build.rigid_body(InertiaConfig(moments_kg_m2=corner)),
            f"leaves no physical body at the corner {[f'{s * 100 * p:+g} %' for s in signs]} of the principal "
            f"moments {moments.tolist()} kg m^2: ",
        )
    return UncertaintyConfig(**values)


def _try_build(r: _Reader, key: str, make: Callable[[], Any], context: str = "") -> Any:
    """Build an object to prove the values are consistent; its ValueError becomes a ConfigError on ``key``."""
    try:
        with np.errstate(all="ignore"):
            return make()
    except (ValueError, ArithmeticError) as exc:
        raise r.error(key, context + str(exc)) from exc


def config_from_dict(data: Mapping[str, Any], file: str = "<config>") -> SpacecraftConfig:
    """Validate the parsed contents of a spacecraft file (what :func:`tomllib.loads` returns).

    Parameters
    ----------
    data : mapping
        The TOML document as nested dicts and lists.
    file : str
        Name of the file, for messages.

    Returns
    -------
    SpacecraftConfig

    Raises
    ------
    ConfigError
        For the first problem found, naming the key and the file.
    """
    r = _Reader(str(file))
    top = _Table(r, data, "")
    name = top.get("name", r.string, required=False, default="spacecraft")
    description = top.get("description", r.string, required=False, default="")
    inertia = _read_inertia(r, top.table("inertia"))
    wheels = _read_wheels(r, top.table("wheels"))
    _try_build(
        r,
        "wheels.spin_inertia_kg_m2",
        lambda: build.reaction_wheels(wheels).hub_body(build.rigid_body(inertia)),
        "the wheels' spin inertia leaves no physical body: the hub inertia I - sum(J a a^T) fails the check: ",
    )
    et = top.table("environment", required=False)
    sun = None if et is None else et.get("sun_direction_N", lambda v, k: r.vector(v, k, 3), required=False)
    gyro = _read_gyro(r, top.table("gyro"))
    tracker = _read_star_tracker(r, top.table("star_tracker"), sun)
    control = _read_control(r, top.table("control"))
    ot = top.table("orbit", required=False)
    orbit = None if ot is None else _read_orbit(r, ot)
    st = top.table("surface", required=False)
    surface = None if st is None else _read_surface(r, st)
    environment = _read_environment(r, et, sun, orbit, surface)
    field = orbit is not None and environment.magnetic_field != "none"
    magnetic = "the magnetic field along the orbit: environment.magnetic_field must not be 'none'"
    tt = top.table("magnetorquers", required=False)
    torquers = None
    if tt is not None:
        torquers = _read_magnetorquers(r, tt)
        _needs(r, "magnetorquers", magnetic, orbit=orbit is not None)
        if orbit is not None and not field:
            raise r.error("magnetorquers", "needs a magnetic field: environment.magnetic_field is 'none'")
    mt_ = top.table("magnetometer", required=False)
    magnetometer = None
    if mt_ is not None:
        magnetometer = _read_magnetometer(r, mt_)
        _needs(r, "magnetometer", magnetic, orbit=orbit is not None)
        if orbit is not None and not field:
            raise r.error("magnetometer", "needs a magnetic field: environment.magnetic_field is 'none'")
    sun_sensors = {}
    for table, read in (("coarse_sun_sensors", _read_coarse_sun_sensors), ("fine_sun_sensor", _read_fine_sun_sensor)):
        st_ = top.table(table, required=False)
        sun_sensors[table] = None if st_ is None else read(r, st_)
        if st_ is not None:
            _needs(r, table, "the Sun's direction and the eclipses come from the orbit", orbit=orbit is not None)
    dt = top.table("detumble", required=False)
    detumble = None
    if dt is not None:
        detumble = _read_detumble(r, dt)
        _needs(
            r,
            "detumble",
            "B-dot reads the magnetometer and commands the rods along the orbit",
            orbit=orbit is not None,
            magnetorquers=torquers is not None,
            magnetometer=magnetometer is not None,
        )
    mo = top.table("momentum", required=False)
    momentum = None
    if mo is not None:
        momentum = _read_momentum(r, mo)
        _needs(r, "momentum", "the budget is taken over orbits", orbit=orbit is not None)
        if momentum.unloading_gain_per_s is not None:
            _needs(r, "momentum.unloading_gain_per_s", "the unloading law commands the rods", magnetorquers=torquers)
    requirements = _read_requirements(r, top.table("requirements"), sun)
    mt = top.table("montecarlo", required=False)
    montecarlo = None if mt is None else _read_montecarlo(r, mt)
    flexible = top.get(
        "flexible_modes", lambda v, k: _read_flexible_modes(r, v, k, inertia), required=False, default=()
    )
    for dispersed in SURFACE_DISPERSIONS:
        if montecarlo is not None and getattr(montecarlo, dispersed) is not None:
            _needs(
                r,
                f"montecarlo.{dispersed}",
                "it disperses the surface model flown along the orbit",
                orbit=orbit is not None,
                surface=surface is not None,
            )
    ut = top.table("uncertainty", required=False)
    uncertainty = None if ut is None else _read_uncertainty(r, ut, inertia)
    return SpacecraftConfig(
        name=name,
        description=description,
        inertia=inertia,
        wheels_config=wheels,
        gyro_config=gyro,
        star_tracker_config=tracker,
        control=control,
        requirements=requirements,
        orbit_config=orbit,
        environment=environment,
        montecarlo=montecarlo,
        surface=surface,
        magnetorquers_config=torquers,
        magnetometer_config=magnetometer,
        coarse_sun_sensors_config=sun_sensors["coarse_sun_sensors"],
        fine_sun_sensor_config=sun_sensors["fine_sun_sensor"],
        detumble=detumble,
        momentum=momentum,
        flexible_modes=flexible,
        uncertainty=uncertainty,
        source=str(file),
    )


_TOML_POSITION = re.compile(r"\(at line (\d+), column (\d+)\)")


def parse_config(text: str, file: str = "<config>") -> SpacecraftConfig:
    """Parse and validate the text of a spacecraft file.

    Parameters
    ----------
    text : str
        The TOML text of a spacecraft file.
    file : str, optional
        The file name, for the error messages.

    Raises
    ------
    ConfigError
        For a TOML syntax error (with line and column when tomllib gives
        them) or any validation problem.
    """
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise ConfigError(
            "TOML nested too deeply for Python's parser (a spacecraft file nests a few levels, not hundreds)",
            None,
            file,
        ) from None
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        match = _TOML_POSITION.search(message)
        line = column = None
        if match:
            line, column = int(match.group(1)), int(match.group(2))
            message = message[: match.start()].rstrip()
            where = f"line {line}, column {column}: "
        else:
            message = message.replace("(at end of document)", "").rstrip()
            where = "at the end of the file: "
        raise ConfigError(f"{where}TOML syntax error: {message}", None, file, line, column) from exc
    digest = hashlib.sha256(text.encode("utf-8")).hexdigest()  # of the text parsed, for provenance
    return dataclasses.replace(config_from_dict(data, file), source_sha256=digest)


#: Largest spacecraft file read [bytes]: a thousand times the built-in one. Reading stops there, so a
#: device or a huge file (``/dev/zero``) is refused instead of filling the memory.
CONFIG_SIZE_MAX_BYTES = 16 * 2**20


def load_config(path: str | Path) -> SpacecraftConfig:
    """Read and validate a spacecraft file.

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Raises
    ------
    ConfigError
        If the file cannot be read, is not UTF-8 TOML, or fails validation.
    """
    path = Path(path)
    try:
        with path.open("rb") as handle:
            raw = handle.read(CONFIG_SIZE_MAX_BYTES + 1)
        if len(raw) > CONFIG_SIZE_MAX_BYTES:
            raise ConfigError(
                f"larger than {CONFIG_SIZE_MAX_BYTES // 2**20} MiB: not a spacecraft file (the built-in one is "
                f"{len(default_config_text().encode()) // 1024} kiB)",
                None,
                str(path),
            )
        text = raw.decode("utf-8")
    except OSError as exc:
        raise ConfigError(f"cannot read the file: {exc.strerror or exc}", None, str(path)) from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"not UTF-8 text (TOML files are UTF-8): {exc}", None, str(path)) from exc
    return parse_config(text, str(path))


def default_config_text() -> str:
    """The built-in spacecraft file, with its comments (what ``attitude init`` writes)."""
    return resources.files("attitude").joinpath("data", DEFAULT_CONFIG_FILE).read_text(encoding="utf-8")


def default_config() -> SpacecraftConfig:
    """The built-in default spacecraft (a 12U CubeSat; see the comments of its file)."""
    return parse_config(default_config_text(), _DEFAULT_LABEL)


# ---------------------------------------------------------------------------

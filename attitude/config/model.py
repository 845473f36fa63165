"""The spacecraft description: a TOML file, its validation, and the toolkit objects it builds.

A spacecraft file (read with the standard library's :mod:`tomllib`) holds
the inertia, the reaction wheels, the gyro, the star tracker, the control
design parameters, an optional orbit and Sun direction, the requirements the
design must meet, and an optional Monte Carlo campaign. :func:`load_config`
reads and validates it into a :class:`SpacecraftConfig` (frozen dataclasses
that mirror the file, key for key), whose methods build the toolkit objects:
:meth:`~SpacecraftConfig.body`, :meth:`~SpacecraftConfig.wheels`,
:meth:`~SpacecraftConfig.gyro`, :meth:`~SpacecraftConfig.star_tracker` and
:meth:`~SpacecraftConfig.orbit`.

Key names carry their units
    Every key that holds a physical quantity ends in its unit (``_kg_m2``,
    ``_Nm``, ``_Nms``, ``_s``, ``_deg``, ``_arcsec``, ``_km``, ``_rad_per_s``,
    ``_deg_per_s``, ``_deg_per_h``, ``_deg_per_sqrt_h``, ``_ppm``,
    ``_percent``, ``_per_s`` ...). Values are bare numbers: the unit is fixed
    by the key name, and a string such as ``"0.05 Nm"`` is an error that says
    so. Keys without a unit are dimensionless (``count``, ``damping``,
    ``runs``, ``seed``), names, or vectors whose suffix names their frame
    (``_B`` body axes, ``_N`` inertial axes); quaternions ``q_BN`` are scalar
    first ``[w, x, y, z]``. Direction vectors and quaternions are stored as
    written and normalised where they are used. The values are converted to
    SI only when the objects are built (DESIGN.md: datasheet units only at
    the edges, in explicitly named keys).

Validation
    Every problem raises :class:`ConfigError` (a :class:`ValueError`) whose
    message is ``"FILE: KEY: problem"``, with ``KEY`` the dotted path of the
    offending key (``wheels.torque_max_Nm``, ``requirements.keep_out[0].half_angle_deg``):
    unknown keys (with a "did you mean" suggestion), missing required keys,
    wrong types, units written where a number is expected, physically
    impossible values (an inertia that breaks the triangle inequality,
    negative limits, wheel axes that do not span 3-D space, a wheel set
    whose spin inertia exceeds the body's ...), unknown presets (listing the
    valid ones) and TOML syntax errors (with line and column). The objects
    are built once during validation, so a file that loads always builds.

The built-in default (``attitude/data/default_spacecraft.toml``, read with
:func:`default_config`; :func:`default_config_text` is the commented file
``attitude init`` writes) is a 12U CubeSat; its comments give the source of
every figure. :func:`config_to_toml` writes a resolved file (every default
filled in) that loads back to an equal configuration.
"""

from __future__ import annotations

import datetime
import difflib
import inspect
import json
import math
import re
import tomllib
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.environment.gravity_gradient import CircularOrbit
from attitude.rigid_body import RigidBody
from attitude.sensors import ARCSEC, GYRO_PRESETS, STAR_TRACKER_PRESETS, Gyro, StarTracker

__all__ = [
    "CONFIG_KEYS",
    "DEFAULT_CONFIG_FILE",
    "PYRAMID_ELEVATION_DEG",
    "WHEEL_LAYOUTS",
    "ConfigError",
    "ControlConfig",
    "Dispersion",
    "EnvironmentConfig",
    "GyroConfig",
    "InertiaConfig",
    "KeepOutConfig",
    "LQRBounds",
    "MonteCarloConfig",
    "OrbitConfig",
    "RequirementsConfig",
    "SlewRequirement",
    "SpacecraftConfig",
    "StarTrackerConfig",
    "WheelsConfig",
    "config_from_dict",
    "config_to_toml",
    "default_config",
    "default_config_text",
    "load_config",
    "parse_config",
]

#: Name of the built-in spacecraft file inside the package (``attitude/data/``).
DEFAULT_CONFIG_FILE = "default_spacecraft.toml"

#: Label used as the file name in messages about the built-in default.
_DEFAULT_LABEL = "attitude/data/" + DEFAULT_CONFIG_FILE

#: Wheel layouts: ``pyramid`` (4 wheels, :meth:`ReactionWheels.pyramid`),
#: ``orthogonal`` (3 wheels on the body axes), ``custom`` (``axes_B`` given).
WHEEL_LAYOUTS = ("pyramid", "orthogonal", "custom")

#: Pyramid elevation used when ``wheels.elevation_deg`` is left out: the default of
#: :meth:`ReactionWheels.pyramid`, ``atan(1/sqrt(2))`` (equal torque capacity about x, y, z).
PYRAMID_ELEVATION_DEG: float = inspect.signature(ReactionWheels.pyramid).parameters["elevation_deg"].default

_DISTRIBUTIONS = ("normal", "uniform")

Vector = tuple[float, ...]
PerWheel = float | tuple[float, ...]


# ---------------------------------------------------------------------------
# The schema: every key, its unit and its meaning (messages, resolved-file comments)

#: Every key of a spacecraft file: dotted path -> (unit, meaning). ``[]`` in a
#: path stands for any index of an array of tables. The unit is the one fixed
#: by the key name ("" for dimensionless keys, names and unit vectors).
CONFIG_KEYS: dict[str, tuple[str, str]] = {
    "name": ("", "spacecraft name, used in report titles"),
    "description": ("", "free text shown in the report"),
    # inertia
    "inertia": ("", "inertia about the centre of mass, body axes, wheels included"),
    "inertia.moments_kg_m2": ("kg m^2", "principal moments [Ixx, Iyy, Izz] when the body axes are principal axes"),
    "inertia.tensor_kg_m2": ("kg m^2", "full symmetric inertia tensor (3 rows of 3), products of inertia included"),
    # wheels
    "wheels": ("", "reaction wheels"),
    "wheels.layout": ("", "wheel layout: 'pyramid' (4 wheels), 'orthogonal' (3 wheels on x, y, z) or 'custom'"),
    "wheels.count": ("", "number of wheels (pyramid 4, orthogonal 3, custom: the number of axes_B)"),
    "wheels.axes_B": ("", "custom layout only: spin axis of each wheel in body axes (normalised)"),
    "wheels.elevation_deg": (
        "deg",
        "pyramid only: elevation of the wheel axes above the body x-y plane (default atan(1/sqrt(2)))",
    ),
    "wheels.spin_inertia_kg_m2": ("kg m^2", "wheel spin-axis inertia (one value, or one per wheel)"),
    "wheels.torque_max_Nm": ("N m", "largest motor torque of a wheel (one value, or one per wheel)"),
    "wheels.momentum_max_Nms": ("N m s", "largest wheel momentum relative to the body (one value, or one per wheel)"),
    "wheels.viscous_friction_Nms_per_rad": ("N m s/rad", "viscous friction coefficient (one value, or one per wheel)"),
    "wheels.coulomb_friction_Nm": ("N m", "Coulomb friction torque (one value, or one per wheel)"),
    "wheels.null_space_gain_per_s": ("1/s", "gain of null-space momentum management (0: off)"),
    "wheels.bias_momentum_Nms": (
        "N m s",
        "target wheel momenta of the null-space management (one value, or per wheel)",
    ),
    # gyro
    "gyro": ("", "rate gyro (Farrenkopf model)"),
    "gyro.preset": ("", "gyro grade: " + ", ".join(repr(k) for k in GYRO_PRESETS) + "; figures below override it"),
    "gyro.period_s": ("s", "sample period"),
    "gyro.arw_deg_per_sqrt_h": ("deg/sqrt(h)", "angle random walk"),
    "gyro.rrw_deg_per_h_per_sqrt_h": ("deg/h/sqrt(h)", "rate random walk (or give a bias instability)"),
    "gyro.bias_instability_deg_per_h": ("deg/h", "bias instability (used without a rate random walk)"),
    "gyro.bias_instability_time_s": ("s", "averaging time at the Allan-deviation floor (with the bias instability)"),
    "gyro.bias_deg_per_h": ("deg/h", "constant bias (one value, or one per axis)"),
    "gyro.scale_factor_ppm": ("ppm", "scale-factor error (one value, or one per axis)"),
    "gyro.misalignment_arcsec": ("arcsec", "small rotation vector of the gyro triad from the body axes"),
    "gyro.quantization_deg_per_s": ("deg/s", "output resolution per LSB (0: none)"),
    "gyro.saturation_deg_per_s": ("deg/s", "measurement range (inf: none)"),
    # star tracker
    "star_tracker": ("", "star tracker"),
    "star_tracker.preset": (
        "",
        "star tracker type: " + ", ".join(repr(k) for k in STAR_TRACKER_PRESETS) + "; figures below override it",
    ),
    "star_tracker.period_s": ("s", "sample period"),
    "star_tracker.cross_boresight_arcsec": ("arcsec", "1-sigma error about each cross-boresight axis"),
    "star_tracker.roll_arcsec": ("arcsec", "1-sigma error about the boresight"),
    "star_tracker.boresight_B": ("", "boresight direction in body axes (normalised)"),
    "star_tracker.sun_exclusion_deg": (
        "deg",
        "half-angle of the Sun-exclusion cone about the boresight (applies with environment.sun_direction_N)",
    ),
    # control
    "control": ("", "controller design parameters"),
    "control.period_s": ("s", "controller sample period (1 / control rate)"),
    "control.bandwidth_rad_per_s": ("rad/s", "natural frequency of the PD attitude loop"),
    "control.damping": ("", "damping ratio of the PD attitude loop"),
    "control.lqr": ("", "LQR weights by Bryson's rule (optional)"),
    "control.lqr.max_angle_deg": ("deg", "largest acceptable attitude error (one value, or one per axis)"),
    "control.lqr.max_rate_deg_per_s": ("deg/s", "largest acceptable rate error (one value, or one per axis)"),
    "control.lqr.max_torque_Nm": ("N m", "largest acceptable control torque (one value, or one per axis)"),
    # orbit and environment
    "orbit": ("", "circular orbit (optional: gravity gradient)"),
    "orbit.altitude_km": ("km", "altitude above the Earth's equatorial radius"),
    "orbit.inclination_deg": ("deg", "inclination"),
    "orbit.raan_deg": ("deg", "right ascension of the ascending node"),
    "orbit.argument_of_latitude_deg": ("deg", "argument of latitude at t = 0"),
    "environment": ("", "scene (optional)"),
    "environment.sun_direction_N": ("", "direction to the Sun in inertial axes (normalised)"),
    # requirements
    "requirements": ("", "what the design must achieve"),
    "requirements.pointing_accuracy_deg": ("deg", "largest attitude error angle after settling"),
    "requirements.settling_time_s": ("s", "time after the end of the slew by which the pointing accuracy is met"),
    "requirements.slew": ("", "the required reorientation"),
    "requirements.slew.angle_deg": ("deg", "slew angle about axis_B (with axis_B; or give target_q_BN)"),
    "requirements.slew.axis_B": ("", "slew axis in body axes (normalised)"),
    "requirements.slew.target_q_BN": ("", "target attitude [w, x, y, z] (instead of angle_deg and axis_B)"),
    "requirements.slew.start_q_BN": ("", "start attitude [w, x, y, z]"),
    "requirements.slew.max_time_s": ("s", "largest allowed slew time"),
    "requirements.slew.rate_max_deg_per_s": ("deg/s", "largest allowed body rate during the slew (optional)"),
    "requirements.keep_out": ("", "keep-out cones (array of tables [[requirements.keep_out]])"),
    "requirements.keep_out[].name": ("", "label of the cone"),
    "requirements.keep_out[].boresight_B": ("", "body-fixed boresight that must stay out of the cone"),
    "requirements.keep_out[].direction_N": (
        "",
        'inertial direction to avoid, or "sun" for environment.sun_direction_N',
    ),
    "requirements.keep_out[].half_angle_deg": ("deg", "smallest allowed angle between boresight and direction"),
    # Monte Carlo
    "montecarlo": ("", "Monte Carlo campaign (optional)"),
    "montecarlo.runs": ("", "number of runs"),
    "montecarlo.seed": ("", "master seed (non-negative integer): the same seed reproduces the campaign"),
}

#: Dispersions of a Monte Carlo campaign: name -> (unit suffix, unit, meaning, extra distributions).
_DISPERSIONS: dict[str, tuple[str, str, str, tuple[str, ...]]] = {
    "inertia": ("percent", "%", "of each principal moment, relative", ()),
    "initial_rate": ("deg_per_s", "deg/s", "of the initial body rate, per axis", ()),
    "initial_attitude": (
        "deg",
        "deg",
        "of the initial attitude about the start attitude, per axis ('uniform_so3': any attitude)",
        ("uniform_so3",),
    ),
    "gyro_misalignment": ("arcsec", "arcsec", "of the gyro triad misalignment, per axis", ()),
    "star_tracker_misalignment": ("arcsec", "arcsec", "of the star-tracker mounting misalignment, per axis", ()),
    "gyro_bias": ("deg_per_h", "deg/h", "of the gyro turn-on bias about the file's bias, per axis", ()),
}
for _name, (_suffix, _unit, _meaning, _extra) in _DISPERSIONS.items():
    CONFIG_KEYS[f"montecarlo.{_name}"] = ("", f"dispersion {_meaning} [{_unit}]")
    CONFIG_KEYS[f"montecarlo.{_name}.distribution"] = ("", "one of " + ", ".join(map(repr, _DISTRIBUTIONS + _extra)))
    CONFIG_KEYS[f"montecarlo.{_name}.sigma_{_suffix}"] = (_unit, "standard deviation (normal)")
    CONFIG_KEYS[f"montecarlo.{_name}.half_width_{_suffix}"] = (_unit, "half-width: uniform on [-h, h] (uniform)")
del _name, _suffix, _unit, _meaning, _extra
CONFIG_KEYS["montecarlo.inertia.axis_sigma_deg"] = (
    "deg",
    "standard deviation of a rotation of the principal axes, per axis (normal; default 0: axes kept)",
)


def _children(path: str) -> tuple[str, ...]:
    """Keys allowed directly inside the table at ``path`` ("" for the top level)."""
    prefix = f"{path}." if path else ""
    out = []
    for key in CONFIG_KEYS:
        if key.startswith(prefix):
            rest = key[len(prefix) :]
            if "." not in rest and rest:
                out.append(rest)
    return tuple(out)


def _schema_path(key: str) -> str:
    """``requirements.keep_out[3].name`` -> ``requirements.keep_out[].name``; drop trailing list indices."""
    key = re.sub(r"\[\d+\](?=\.)", "[]", key)
    return re.sub(r"(\[\d+\])+$", "", key)


def _unit_of(key: str) -> str:
    return CONFIG_KEYS.get(_schema_path(key), ("", ""))[0]


def _meaning_of(key: str) -> str:
    unit, meaning = CONFIG_KEYS.get(_schema_path(key), ("", ""))
    return f"{meaning} [{unit}]" if unit else meaning


# ---------------------------------------------------------------------------
# The error


class ConfigError(ValueError):
    """A problem in a spacecraft file: ``"FILE: KEY: problem"``.

    Parameters
    ----------
    problem : str
        What is wrong and, where possible, how to fix it.
    key : str or None
        Dotted path of the offending key (``"wheels.torque_max_Nm"``,
        ``"requirements.keep_out[0].half_angle_deg"``); None for problems of
        the whole file (TOML syntax, unreadable file).
    file : str
        The file (path or label) the problem is in.
    line, column : int or None
        Position of a TOML syntax error (1-based), when known.

    Attributes
    ----------
    key, file, problem, line, column
        As given.
    """

    def __init__(
        self,
        problem: str,
        key: str | None = None,
        file: str = "<config>",
        line: int | None = None,
        column: int | None = None,
    ) -> None:
        self.problem = problem
        self.key = key
        self.file = str(file)
        self.line = line
        self.column = column
        where = self.file if key is None else f"{self.file}: {key}"
        super().__init__(f"{where}: {problem}")

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.problem, self.key, self.file, self.line, self.column))


# ---------------------------------------------------------------------------
# Reading values with messages that name the key


_NUMBER_WITH_TEXT = re.compile(r"^\s*([-+]?(?:\d[\d_]*(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")

_UNIT_ALIASES = {
    "degree": "deg",
    "degrees": "deg",
    "°": "deg",
    "sec": "s",
    "second": "s",
    "seconds": "s",
    "nms": "nms",
    "newtonmetre": "nm",
    "newtonmeter": "nm",
    "kgm2": "kgm2",
    "%": "percent",
    "pct": "percent",
    "arcsecond": "arcsec",
    "arcseconds": "arcsec",
    "rad/sec": "rad/s",
    "deg/sec": "deg/s",
}


def _normalise_unit(unit: str) -> str:
    u = unit.strip().lower().replace("²", "2").replace("·", "").replace("*", "").replace("^", "")
    u = re.sub(r"[\s.\-]", "", u)
    return _UNIT_ALIASES.get(u, u)


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
        unit = _unit_of(key)
        match = _NUMBER_WITH_TEXT.match(text)
        if match is None:
            return f"expected a number, got {_describe(text)}"
        number, written = match.group(1), match.group(2)
        if not written:
            return f"expected a number, got {_describe(text)}: write {number} without quotes"
        if not unit:
            return f"units given where a number is expected: got {text!r}; write {number} (this key takes no unit)"
        if _normalise_unit(written) != _normalise_unit(unit):
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
        allowed = _children(re.sub(r"\[\d+\]", "[]", path))
        for key in data:
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
        meaning = _meaning_of(self.key(name))
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
                meaning = _meaning_of(self.key(name))
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
    unit = _unit_of(key)
    interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    r.check(ok, key, f"in {interval}" + (f" {unit}" if unit else ""), value)


# ---------------------------------------------------------------------------
# The configuration dataclasses


@dataclass(frozen=True)
class InertiaConfig:
    """The ``[inertia]`` table: principal moments or a full tensor [kg m^2], as written.

    Exactly one of the two is set. The tensor is about the centre of mass, in
    body axes, wheels included (the rotor spin inertia is removed for the
    hub by :meth:`attitude.actuators.ReactionWheels.hub_body`).

    Parameters
    ----------
    moments_kg_m2 : tuple of float or None, optional
        Principal moments [Ixx, Iyy, Izz] when the body axes are principal axes [kg m^2] (key
        ``inertia.moments_kg_m2``).
    tensor_kg_m2 : tuple of tuple of float or None, optional
        Full symmetric inertia tensor (3 rows of 3), products of inertia included [kg m^2] (key
        ``inertia.tensor_kg_m2``).
    """

    moments_kg_m2: Vector | None = None
    tensor_kg_m2: tuple[Vector, ...] | None = None

    @property
    def tensor(self) -> NDArray[np.float64]:
        """The inertia tensor (3, 3) [kg m^2]."""
        if self.tensor_kg_m2 is not None:
            return np.array(self.tensor_kg_m2, dtype=np.float64)
        return np.diag(np.array(self.moments_kg_m2, dtype=np.float64))

    def build(self) -> RigidBody:
        """The :class:`RigidBody` (whole spacecraft, wheels included)."""
        return RigidBody(self.tensor)


@dataclass(frozen=True)
class WheelsConfig:
    """The ``[wheels]`` table (units in the field names; per-wheel values as tuples).

    Parameters
    ----------
    layout : str
        Wheel layout: 'pyramid' (4 wheels), 'orthogonal' (3 wheels on x, y, z) or 'custom' (key
        ``wheels.layout``).
    count : int
        Number of wheels (pyramid 4, orthogonal 3, custom: the number of axes_B) (key
        ``wheels.count``).
    spin_inertia_kg_m2 : float or tuple of float
        Wheel spin-axis inertia (one value, or one per wheel) [kg m^2] (key
        ``wheels.spin_inertia_kg_m2``).
    torque_max_Nm : float or tuple of float
        Largest motor torque of a wheel (one value, or one per wheel) [N m] (key
        ``wheels.torque_max_Nm``).
    momentum_max_Nms : float or tuple of float
        Largest wheel momentum relative to the body (one value, or one per wheel) [N m s] (key
        ``wheels.momentum_max_Nms``).
    axes_B : tuple of tuple of float or None, optional
        Custom layout only: spin axis of each wheel in body axes (normalised) (key
        ``wheels.axes_B``).
    elevation_deg : float or None, optional
        Pyramid only: elevation of the wheel axes above the body x-y plane (default
        atan(1/sqrt(2))) [deg] (key ``wheels.elevation_deg``).
    viscous_friction_Nms_per_rad : float or tuple of float, optional
        Viscous friction coefficient (one value, or one per wheel) [N m s/rad] (key
        ``wheels.viscous_friction_Nms_per_rad``).
    coulomb_friction_Nm : float or tuple of float, optional
        Coulomb friction torque (one value, or one per wheel) [N m] (key
        ``wheels.coulomb_friction_Nm``).
    null_space_gain_per_s : float, optional
        Gain of null-space momentum management (0: off) [1/s] (key
        ``wheels.null_space_gain_per_s``).
    bias_momentum_Nms : float or tuple of float, optional
        Target wheel momenta of the null-space management (one value, or per wheel) [N m s] (key
        ``wheels.bias_momentum_Nms``).
    """

    layout: str
    count: int
    spin_inertia_kg_m2: PerWheel
    torque_max_Nm: PerWheel
    momentum_max_Nms: PerWheel
    axes_B: tuple[Vector, ...] | None = None
    elevation_deg: float | None = None
    viscous_friction_Nms_per_rad: PerWheel = 0.0
    coulomb_friction_Nm: PerWheel = 0.0
    null_space_gain_per_s: float = 0.0
    bias_momentum_Nms: PerWheel = 0.0

    def build(self) -> ReactionWheels:
        """The :class:`ReactionWheels` (SI throughout; values here are already SI)."""
        kw: dict[str, Any] = {
            "viscous_friction": np.array(self.viscous_friction_Nms_per_rad, dtype=np.float64),
            "coulomb_friction": np.array(self.coulomb_friction_Nm, dtype=np.float64),
            "null_space_gain": self.null_space_gain_per_s,
            "bias_momentum": np.array(self.bias_momentum_Nms, dtype=np.float64),
        }
        args = tuple(
            np.array(v, dtype=np.float64) for v in (self.spin_inertia_kg_m2, self.torque_max_Nm, self.momentum_max_Nms)
        )
        if self.layout == "pyramid":
            if self.elevation_deg is not None:
                kw["elevation_deg"] = self.elevation_deg
            return ReactionWheels.pyramid(*args, **kw)
        if self.layout == "orthogonal":
            return ReactionWheels.orthogonal(*args, **kw)
        return ReactionWheels(np.array(self.axes_B, dtype=np.float64), *args, **kw)


_GYRO_FIGURES = (
    "arw_deg_per_sqrt_h",
    "rrw_deg_per_h_per_sqrt_h",
    "bias_instability_deg_per_h",
    "bias_instability_time_s",
    "bias_deg_per_h",
    "scale_factor_ppm",
    "misalignment_arcsec",
    "quantization_deg_per_s",
    "saturation_deg_per_s",
)


@dataclass(frozen=True)
class GyroConfig:
    """The ``[gyro]`` table: a preset grade and/or datasheet figures (figures override the preset).

    Parameters
    ----------
    period_s : float
        Sample period [s] (key ``gyro.period_s``).
    preset : str or None, optional
        Gyro grade: 'mems', 'tactical', 'navigation'; figures below override it (key
        ``gyro.preset``).
    arw_deg_per_sqrt_h : float or None, optional
        Angle random walk [deg/sqrt(h)] (key ``gyro.arw_deg_per_sqrt_h``).
    rrw_deg_per_h_per_sqrt_h : float or None, optional
        Rate random walk (or give a bias instability) [deg/h/sqrt(h)] (key
        ``gyro.rrw_deg_per_h_per_sqrt_h``).
    bias_instability_deg_per_h : float or None, optional
        Bias instability (used without a rate random walk) [deg/h] (key
        ``gyro.bias_instability_deg_per_h``).
    bias_instability_time_s : float or None, optional
        Averaging time at the Allan-deviation floor (with the bias instability) [s] (key
        ``gyro.bias_instability_time_s``).
    bias_deg_per_h : float or tuple of float or None, optional
        Constant bias (one value, or one per axis) [deg/h] (key ``gyro.bias_deg_per_h``).
    scale_factor_ppm : float or tuple of float or None, optional
        Scale-factor error (one value, or one per axis) [ppm] (key ``gyro.scale_factor_ppm``).
    misalignment_arcsec : tuple of float or None, optional
        Small rotation vector of the gyro triad from the body axes [arcsec] (key
        ``gyro.misalignment_arcsec``).
    quantization_deg_per_s : float or None, optional
        Output resolution per LSB (0: none) [deg/s] (key ``gyro.quantization_deg_per_s``).
    saturation_deg_per_s : float or None, optional
        Measurement range (inf: none) [deg/s] (key ``gyro.saturation_deg_per_s``).
    """

    period_s: float
    preset: str | None = None
    arw_deg_per_sqrt_h: float | None = None
    rrw_deg_per_h_per_sqrt_h: float | None = None
    bias_instability_deg_per_h: float | None = None
    bias_instability_time_s: float | None = None
    bias_deg_per_h: PerWheel | None = None
    scale_factor_ppm: PerWheel | None = None
    misalignment_arcsec: Vector | None = None
    quantization_deg_per_s: float | None = None
    saturation_deg_per_s: float | None = None

    def figures(self) -> dict[str, Any]:
        """Keywords of :meth:`Gyro.from_datasheet` given in the file (preset figures excluded)."""
        out: dict[str, Any] = {}
        for name in _GYRO_FIGURES:
            value = getattr(self, name)
            if value is None:
                continue
            if name == "misalignment_arcsec":
                out["misalignment_rad"] = np.array(value) * ARCSEC
            else:
                out[name] = np.array(value) if isinstance(value, tuple) else value
        return out

    def build(self, sampling: str = "instantaneous") -> Gyro:
        """The :class:`Gyro` (converted to SI by :meth:`Gyro.from_datasheet`).

        ``sampling`` ("instantaneous" or "mean") chooses what a sample is:
        the rate at the sample time (what the rate EKF models) or the mean
        rate over the interval (an integrating gyro; what the MEKF models).

        Parameters
        ----------
        sampling : {"instantaneous", "mean"}, optional
            What a sample is: the rate at the sample time or the mean rate over the interval.
        """
        if self.preset is not None:
            return Gyro.preset(self.preset, period=self.period_s, sampling=sampling, **self.figures())
        figures = self.figures()
        arw = figures.pop("arw_deg_per_sqrt_h")
        return Gyro.from_datasheet(arw, period=self.period_s, sampling=sampling, **figures)


@dataclass(frozen=True)
class StarTrackerConfig:
    """The ``[star_tracker]`` table: a preset and/or datasheet figures (figures override the preset).

    Parameters
    ----------
    period_s : float
        Sample period [s] (key ``star_tracker.period_s``).
    preset : str or None, optional
        Star tracker type: 'typical'; figures below override it (key ``star_tracker.preset``).
    cross_boresight_arcsec : float or None, optional
        1-sigma error about each cross-boresight axis [arcsec] (key
        ``star_tracker.cross_boresight_arcsec``).
    roll_arcsec : float or None, optional
        1-sigma error about the boresight [arcsec] (key ``star_tracker.roll_arcsec``).
    boresight_B : tuple of float, optional
        Boresight direction in body axes (normalised) (key ``star_tracker.boresight_B``).
    sun_exclusion_deg : float or None, optional
        Half-angle of the Sun-exclusion cone about the boresight (applies with
        environment.sun_direction_N) [deg] (key ``star_tracker.sun_exclusion_deg``).
    """

    period_s: float
    preset: str | None = None
    cross_boresight_arcsec: float | None = None
    roll_arcsec: float | None = None
    boresight_B: Vector = (0.0, 0.0, 1.0)
    sun_exclusion_deg: float | None = None

    @property
    def effective_sun_exclusion_deg(self) -> float | None:
        """The Sun-exclusion half-angle [deg]: the file's, else the preset's, else None."""
        if self.sun_exclusion_deg is not None:
            return self.sun_exclusion_deg
        if self.preset is not None:
            return STAR_TRACKER_PRESETS[self.preset]["figures"].get("sun_exclusion_deg")
        return None

    def build(self, sun_direction_N: Sequence[float] | None = None) -> StarTracker:
        """The :class:`StarTracker`; blinded by the Sun only when a Sun direction is given.

        Parameters
        ----------
        sun_direction_N : sequence of 3 floats, optional
            Direction to the Sun in inertial axes (``environment.sun_direction_N``).
        """
        figures: dict[str, Any] = {"boresight_B": np.array(self.boresight_B, dtype=np.float64)}
        if self.cross_boresight_arcsec is not None:
            figures["cross_boresight_arcsec"] = self.cross_boresight_arcsec
        if self.roll_arcsec is not None:
            figures["roll_arcsec"] = self.roll_arcsec
        sun = None if sun_direction_N is None else np.array(sun_direction_N, dtype=np.float64)
        exclusion = self.effective_sun_exclusion_deg
        if self.preset is not None:
            if sun is not None and exclusion is not None:
                figures["sun_exclusion_deg"] = exclusion
            return StarTracker.preset(self.preset, period=self.period_s, sun_direction_N=sun, **figures)
        if sun is not None and exclusion is not None:
            figures["sun_direction_N"] = sun
            figures["sun_exclusion_deg"] = exclusion
        return StarTracker.from_datasheet(period=self.period_s, **figures)


@dataclass(frozen=True)
class LQRBounds:
    """The ``[control.lqr]`` table: Bryson's-rule bounds (one value or one per axis).

    Parameters
    ----------
    max_angle_deg : float or tuple of float
        Largest acceptable attitude error (one value, or one per axis) [deg] (key
        ``control.lqr.max_angle_deg``).
    max_rate_deg_per_s : float or tuple of float
        Largest acceptable rate error (one value, or one per axis) [deg/s] (key
        ``control.lqr.max_rate_deg_per_s``).
    max_torque_Nm : float or tuple of float
        Largest acceptable control torque (one value, or one per axis) [N m] (key
        ``control.lqr.max_torque_Nm``).
    """

    max_angle_deg: PerWheel
    max_rate_deg_per_s: PerWheel
    max_torque_Nm: PerWheel

    @property
    def max_angle_rad(self) -> NDArray[np.float64]:
        """Largest acceptable attitude error per axis [rad], shape (3,)."""
        return np.radians(np.broadcast_to(np.array(self.max_angle_deg, dtype=np.float64), (3,)))

    @property
    def max_rate_rad_per_s(self) -> NDArray[np.float64]:
        """Largest acceptable rate error per axis [rad/s], shape (3,)."""
        return np.radians(np.broadcast_to(np.array(self.max_rate_deg_per_s, dtype=np.float64), (3,)))

    @property
    def max_torque(self) -> NDArray[np.float64]:
        """Largest acceptable control torque per axis [N m], shape (3,)."""
        return np.broadcast_to(np.array(self.max_torque_Nm, dtype=np.float64), (3,)).copy()


@dataclass(frozen=True)
class ControlConfig:
    """The ``[control]`` table: sample period [s], PD bandwidth [rad/s] and damping, optional LQR bounds.

    Parameters
    ----------
    period_s : float
        Controller sample period (1 / control rate) [s] (key ``control.period_s``).
    bandwidth_rad_per_s : float
        Natural frequency of the PD attitude loop [rad/s] (key ``control.bandwidth_rad_per_s``).
    damping : float
        Damping ratio of the PD attitude loop (key ``control.damping``).
    lqr : LQRBounds or None, optional
        LQR weights by Bryson's rule (optional) (key ``control.lqr``).
    """

    period_s: float
    bandwidth_rad_per_s: float
    damping: float
    lqr: LQRBounds | None = None


@dataclass(frozen=True)
class OrbitConfig:
    """The ``[orbit]`` table: a circular Earth orbit (angles in degrees, altitude in km).

    Parameters
    ----------
    altitude_km : float
        Altitude above the Earth's equatorial radius [km] (key ``orbit.altitude_km``).
    inclination_deg : float, optional
        Inclination [deg] (key ``orbit.inclination_deg``).
    raan_deg : float, optional
        Right ascension of the ascending node [deg] (key ``orbit.raan_deg``).
    argument_of_latitude_deg : float, optional
        Argument of latitude at t = 0 [deg] (key ``orbit.argument_of_latitude_deg``).
    """

    altitude_km: float
    inclination_deg: float = 0.0
    raan_deg: float = 0.0
    argument_of_latitude_deg: float = 0.0

    def build(self) -> CircularOrbit:
        """The :class:`CircularOrbit` (SI: m and rad)."""
        return CircularOrbit.from_altitude(
            self.altitude_km * 1000.0,
            inclination=math.radians(self.inclination_deg),
            raan=math.radians(self.raan_deg),
            argument_of_latitude=math.radians(self.argument_of_latitude_deg),
        )


@dataclass(frozen=True)
class EnvironmentConfig:
    """The ``[environment]`` table: the inertial Sun direction (as written; normalise to use).

    Parameters
    ----------
    sun_direction_N : tuple of float or None, optional
        Direction to the Sun in inertial axes (normalised) (key ``environment.sun_direction_N``).
    """

    sun_direction_N: Vector | None = None

    @property
    def sun_unit_N(self) -> NDArray[np.float64] | None:
        """Unit Sun direction in inertial axes, or None."""
        if self.sun_direction_N is None:
            return None
        v = np.array(self.sun_direction_N, dtype=np.float64)
        return v / np.linalg.norm(v)


@dataclass(frozen=True)
class SlewRequirement:
    """The ``[requirements.slew]`` table.

    The target is either ``angle_deg`` about the body axis ``axis_B`` from
    the start attitude (``q_target = q_start ⊗ q(axis_B, angle)``: a rotation
    about a body axis multiplies on the right, because ``q_BN`` rotates body
    vectors into inertial ones), or ``target_q_BN``.

    Parameters
    ----------
    max_time_s : float
        Largest allowed slew time [s] (key ``requirements.slew.max_time_s``).
    angle_deg : float or None, optional
        Slew angle about axis_B (with axis_B; or give target_q_BN) [deg] (key
        ``requirements.slew.angle_deg``).
    axis_B : tuple of float or None, optional
        Slew axis in body axes (normalised) (key ``requirements.slew.axis_B``).
    target_q_BN : tuple of 4 float or None, optional
        Target attitude [w, x, y, z] (instead of angle_deg and axis_B) (key
        ``requirements.slew.target_q_BN``).
    start_q_BN : tuple of 4 float, optional
        Start attitude [w, x, y, z] (key ``requirements.slew.start_q_BN``).
    rate_max_deg_per_s : float or None, optional
        Largest allowed body rate during the slew (optional) [deg/s] (key
        ``requirements.slew.rate_max_deg_per_s``).
    """

    max_time_s: float
    angle_deg: float | None = None
    axis_B: Vector | None = None
    target_q_BN: tuple[float, float, float, float] | None = None
    start_q_BN: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    rate_max_deg_per_s: float | None = None

    def q_start(self) -> NDArray[np.float64]:
        """Start attitude ``q_BN`` (unit, scalar first)."""
        return quat.normalize(np.array(self.start_q_BN, dtype=np.float64))

    def q_target(self) -> NDArray[np.float64]:
        """Target attitude ``q_BN`` (unit, scalar first)."""
        if self.target_q_BN is not None:
            return quat.normalize(np.array(self.target_q_BN, dtype=np.float64))
        axis = np.array(self.axis_B, dtype=np.float64)
        step = quat.from_axis_angle(axis / np.linalg.norm(axis), math.radians(self.angle_deg))
        return quat.normalize(quat.multiply(self.q_start(), step))

    @property
    def angle_rad(self) -> float:
        """Slew angle [rad] (the shortest rotation from start to target)."""
        return float(quat.error_angle(self.q_start(), self.q_target()))

    @property
    def rate_max_rad_per_s(self) -> float | None:
        """Rate limit [rad/s], or None."""
        return None if self.rate_max_deg_per_s is None else math.radians(self.rate_max_deg_per_s)


@dataclass(frozen=True)
class KeepOutConfig:
    """One ``[[requirements.keep_out]]`` cone: a body boresight kept away from an inertial direction.

    ``direction_N`` is the direction as resolved (the Sun direction when the
    file says ``"sun"``, then ``follows_sun`` is True). Vectors as written.

    Parameters
    ----------
    name : str
        Label of the cone (key ``requirements.keep_out[i].name``).
    boresight_B : tuple of float
        Body-fixed boresight that must stay out of the cone (key
        ``requirements.keep_out[i].boresight_B``).
    direction_N : tuple of float
        Inertial direction to avoid, or "sun" for environment.sun_direction_N (key
        ``requirements.keep_out[i].direction_N``).
    half_angle_deg : float
        Smallest allowed angle between boresight and direction [deg] (key
        ``requirements.keep_out[i].half_angle_deg``).
    follows_sun : bool, optional
        The file gives the direction as ``"sun"``: ``direction_N`` is the Sun direction.
    """

    name: str
    boresight_B: Vector
    direction_N: Vector
    half_angle_deg: float
    follows_sun: bool = False

    @property
    def half_angle_rad(self) -> float:
        """Half-angle [rad]."""
        return math.radians(self.half_angle_deg)

    def separation(self, q_BN: Any) -> NDArray[np.float64]:
        """Angle [rad] between the boresight and the direction at attitudes ``q_BN`` (..., 4).

        Parameters
        ----------
        q_BN : array_like (..., 4)
            Attitudes.
        """
        b = np.array(self.boresight_B, dtype=np.float64)
        d = np.array(self.direction_N, dtype=np.float64)
        b_N = quat.rotate(quat.normalize(q_BN), b / np.linalg.norm(b))
        return np.arccos(np.clip(b_N @ (d / np.linalg.norm(d)), -1.0, 1.0))


@dataclass(frozen=True)
class RequirementsConfig:
    """The ``[requirements]`` table.

    Parameters
    ----------
    pointing_accuracy_deg : float
        Largest attitude error angle after settling [deg] (key
        ``requirements.pointing_accuracy_deg``).
    settling_time_s : float
        Time after the end of the slew by which the pointing accuracy is met [s] (key
        ``requirements.settling_time_s``).
    slew : SlewRequirement
        The required reorientation (key ``requirements.slew``).
    keep_out : tuple of KeepOutConfig, optional
        Keep-out cones (array of tables [[requirements.keep_out]]) (key ``requirements.keep_out``).
    """

    pointing_accuracy_deg: float
    settling_time_s: float
    slew: SlewRequirement
    keep_out: tuple[KeepOutConfig, ...] = ()

    @property
    def pointing_accuracy_rad(self) -> float:
        """Pointing accuracy [rad]."""
        return math.radians(self.pointing_accuracy_deg)


@dataclass(frozen=True)
class Dispersion:
    """One Monte Carlo dispersion: a distribution and its scale in ``unit``.

    ``scale`` is the standard deviation (``normal``) or the half-width
    (``uniform``: uniform on ``[-scale, scale]``), in the unit named by
    ``unit`` (the key suffix: ``percent``, ``deg_per_s``, ``deg``, ``arcsec``);
    None for ``uniform_so3`` (an attitude uniformly distributed on SO(3)).

    Parameters
    ----------
    distribution : str
        ``"normal"``, ``"uniform"`` or ``"uniform_so3"``.
    scale : float or None
        Standard deviation (normal) or half-width (uniform) in ``unit``; None for ``uniform_so3``.
    unit : str
        Unit of ``scale``, the key suffix: ``percent``, ``deg_per_s``, ``deg``, ``deg_per_h`` or
        ``arcsec``.
    axis_sigma_deg : float, optional
        Inertia only: standard deviation of a rotation of the principal axes, per axis [deg].
    """

    distribution: str
    scale: float | None
    unit: str
    axis_sigma_deg: float = 0.0  # inertia only: rotation of the principal axes, per axis (normal) [deg]

    @property
    def scale_si(self) -> float | None:
        """The scale in SI: a fraction for ``percent``, rad, rad/s."""
        if self.scale is None:
            return None
        factor = {
            "percent": 0.01,
            "deg": math.pi / 180.0,
            "deg_per_s": math.pi / 180.0,
            "deg_per_h": math.pi / 180.0 / 3600.0,
            "arcsec": ARCSEC,
        }
        return self.scale * factor[self.unit]


@dataclass(frozen=True)
class MonteCarloConfig:
    """The ``[montecarlo]`` table: runs, master seed and the dispersions (None: not dispersed).

    Parameters
    ----------
    runs : int
        Number of runs (key ``montecarlo.runs``).
    seed : int
        Master seed (non-negative integer): the same seed reproduces the campaign (key
        ``montecarlo.seed``).
    inertia : Dispersion or None, optional
        Dispersion of each principal moment, relative [%] (key ``montecarlo.inertia``).
    initial_rate : Dispersion or None, optional
        Dispersion of the initial body rate, per axis [deg/s] (key ``montecarlo.initial_rate``).
    initial_attitude : Dispersion or None, optional
        Dispersion of the initial attitude about the start attitude, per axis ('uniform_so3':
        any attitude) [deg] (key ``montecarlo.initial_attitude``).
    gyro_misalignment : Dispersion or None, optional
        Dispersion of the gyro triad misalignment, per axis [arcsec] (key
        ``montecarlo.gyro_misalignment``).
    star_tracker_misalignment : Dispersion or None, optional
        Dispersion of the star-tracker mounting misalignment, per axis [arcsec] (key
        ``montecarlo.star_tracker_misalignment``).
    gyro_bias : Dispersion or None, optional
        Dispersion of the gyro turn-on bias about the file's bias, per axis [deg/h] (key
        ``montecarlo.gyro_bias``).
    """

    runs: int
    seed: int
    inertia: Dispersion | None = None
    initial_rate: Dispersion | None = None
    initial_attitude: Dispersion | None = None
    gyro_misalignment: Dispersion | None = None
    star_tracker_misalignment: Dispersion | None = None
    gyro_bias: Dispersion | None = None


@dataclass(frozen=True)
class SpacecraftConfig:
    """A validated spacecraft description, mirroring the TOML file key for key.

    Each table is a field of the same name, except those whose name is taken
    by the method that builds their object: ``[wheels]`` is
    :attr:`wheels_config` (built by :meth:`wheels`), ``[gyro]``
    :attr:`gyro_config`, ``[star_tracker]`` :attr:`star_tracker_config` and
    ``[orbit]`` :attr:`orbit_config`. Values keep the units of their key
    names; the builders convert to SI. ``source`` (the file it came from) is
    not part of equality.

    Parameters
    ----------
    name : str
        Spacecraft name, used in report titles (key ``name``).
    description : str
        Free text shown in the report (key ``description``).
    inertia : InertiaConfig
        Inertia about the centre of mass, body axes, wheels included (key ``inertia``).
    wheels_config : WheelsConfig
        Reaction wheels (key ``wheels``).
    gyro_config : GyroConfig
        Rate gyro (Farrenkopf model) (key ``gyro``).
    star_tracker_config : StarTrackerConfig
        Star tracker (key ``star_tracker``).
    control : ControlConfig
        Controller design parameters (key ``control``).
    requirements : RequirementsConfig
        What the design must achieve (key ``requirements``).
    orbit_config : OrbitConfig or None, optional
        Circular orbit (optional: gravity gradient) (key ``orbit``).
    environment : EnvironmentConfig, optional
        Scene (optional) (key ``environment``).
    montecarlo : MonteCarloConfig or None, optional
        Monte Carlo campaign (optional) (key ``montecarlo``).
    source : str, optional
        The file the configuration was read from (messages only; not compared).
    """

    name: str
    description: str
    inertia: InertiaConfig
    wheels_config: WheelsConfig
    gyro_config: GyroConfig
    star_tracker_config: StarTrackerConfig
    control: ControlConfig
    requirements: RequirementsConfig
    orbit_config: OrbitConfig | None = None
    environment: EnvironmentConfig = EnvironmentConfig()
    montecarlo: MonteCarloConfig | None = None
    source: str = field(default="", compare=False)

    def body(self) -> RigidBody:
        """The whole spacecraft as a :class:`RigidBody` (wheels included) [kg m^2]."""
        return self.inertia.build()

    def hub_body(self) -> RigidBody:
        """The body without the wheels' spin-axis inertia (the plant to pair with the wheel states)."""
        return self.wheels().hub_body(self.body())

    def wheels(self) -> ReactionWheels:
        """The :class:`ReactionWheels`."""
        return self.wheels_config.build()

    def gyro(self, sampling: str = "instantaneous") -> Gyro:
        """A fresh :class:`Gyro` (stateful: build one per run); ``sampling`` as in :class:`Gyro`.

        Parameters
        ----------
        sampling : {"instantaneous", "mean"}, optional
            What a sample is: the rate at the sample time or the mean rate over the interval.
        """
        return self.gyro_config.build(sampling)

    def star_tracker(self) -> StarTracker:
        """The :class:`StarTracker`, blinded by ``environment.sun_direction_N`` when given."""
        return self.star_tracker_config.build(self.environment.sun_direction_N)

    def orbit(self) -> CircularOrbit | None:
        """The :class:`CircularOrbit`, or None without an ``[orbit]`` table."""
        return None if self.orbit_config is None else self.orbit_config.build()


# ---------------------------------------------------------------------------
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
    _build(r, key, config.build)
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
        _positive(r, t.key(name), value, allow_zero=allow_zero, unit=_unit_of(t.key(name)))
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
    )
    _positive(r, t.key("null_space_gain_per_s"), config.null_space_gain_per_s, allow_zero=True, unit="1/s")
    key = t.key("axes_B") if layout == "custom" else t.key("layout")
    _build(r, key, config.build)
    return config


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
        _positive(r, t.key(name), num[name], unit=_unit_of(t.key(name)))
    for name in ("rrw_deg_per_h_per_sqrt_h", "quantization_deg_per_s"):
        _positive(r, t.key(name), num[name], allow_zero=True, unit=_unit_of(t.key(name)))
    _positive(r, t.key("saturation_deg_per_s"), num["saturation_deg_per_s"], unit="deg/s")
    if num["rrw_deg_per_h_per_sqrt_h"] is not None and num["bias_instability_deg_per_h"] is not None:
        raise r.error(
            t.key("bias_instability_deg_per_h"),
            "give rrw_deg_per_h_per_sqrt_h or bias_instability_deg_per_h, not both "
            "(the Farrenkopf model has one bias-driving noise)",
        )
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
    _build(r, t.path, config.build)
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
    _build(r, t.path, lambda: config.build(sun))
    return config


def _read_control(r: _Reader, t: _Table) -> ControlConfig:
    period = t.number("period_s")
    _positive(r, t.key("period_s"), period, unit="s")
    bandwidth = t.number("bandwidth_rad_per_s")
    _positive(r, t.key("bandwidth_rad_per_s"), bandwidth, unit="rad/s")
    nyquist = math.pi / period
    r.check(
        bandwidth < nyquist,
        t.key("bandwidth_rad_per_s"),
        f"below the Nyquist frequency pi / period_s = {nyquist:.6g} rad/s of the {period:g} s controller "
        "(a tenth of the sample rate or less is the usual design range)",
        bandwidth,
    )
    damping = t.number("damping")
    _positive(r, t.key("damping"), damping)
    lqr = None
    lt = t.table("lqr", required=False)
    if lt is not None:
        values = {
            name: lt.get(name, lambda v, k: r.scalar_or_list(v, k, 3, "axis"))
            for name in ("max_angle_deg", "max_rate_deg_per_s", "max_torque_Nm")
        }
        for name, value in values.items():
            _positive(r, lt.key(name), value, unit=_unit_of(lt.key(name)))
        for i, v in enumerate(_values(values["max_angle_deg"])):
            k = lt.key("max_angle_deg") + (f"[{i}]" if isinstance(values["max_angle_deg"], tuple) else "")
            r.check(v <= 180.0, k, "at most 180 deg (the largest attitude error)", v)
        lqr = LQRBounds(**values)
    return ControlConfig(period_s=period, bandwidth_rad_per_s=bandwidth, damping=damping, lqr=lqr)


def _read_orbit(r: _Reader, t: _Table) -> OrbitConfig:
    altitude = t.number("altitude_km")
    _positive(r, t.key("altitude_km"), altitude, unit="km")
    r.check(altitude < 1e9, t.key("altitude_km"), "below 1e9 km (an Earth orbit)", altitude)
    inclination = t.number("inclination_deg", required=False, default=0.0)
    _in_range(r, t.key("inclination_deg"), inclination, 0.0, 180.0, low_open=False, high_open=False)
    angles = {}
    for name in ("raan_deg", "argument_of_latitude_deg"):
        angles[name] = t.number(name, required=False, default=0.0)
        _in_range(r, t.key(name), angles[name], -360.0, 360.0, low_open=False, high_open=False)
    config = OrbitConfig(altitude_km=altitude, inclination_deg=inclination, **angles)
    _build(r, t.path, config.build)
    return config


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
    max_time = t.number("max_time_s")
    _positive(r, t.key("max_time_s"), max_time, unit="s")
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
        max_time_s=max_time, angle_deg=angle, axis_B=axis, target_q_BN=target, start_q_BN=start, rate_max_deg_per_s=rate
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
    return RequirementsConfig(accuracy, settling, slew, keep_out)


def _read_dispersion(r: _Reader, t: _Table, name: str) -> Dispersion | None:
    suffix, _, _, extra = _DISPERSIONS[name]
    dt = t.table(name, required=False)
    if dt is None:
        return None
    distribution = dt.get("distribution", lambda v, k: r.string(v, k, _DISTRIBUTIONS + extra, "distribution"))
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
    _positive(r, scale_key, scale, allow_zero=True, unit=_unit_of(scale_key))
    if suffix == "percent":
        r.check(scale < 100.0, scale_key, "below 100 percent (moments must stay positive)", scale)
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
    return MonteCarloConfig(runs, seed, **{name: _read_dispersion(r, t, name) for name in _DISPERSIONS})


def _build(r: _Reader, key: str, build: Callable[[], Any], context: str = "") -> Any:
    """Build an object to prove the values are consistent; its ValueError becomes a ConfigError on ``key``."""
    try:
        with np.errstate(all="ignore"):
            return build()
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
    _build(
        r,
        "wheels.spin_inertia_kg_m2",
        lambda: wheels.build().hub_body(inertia.build()),
        "the wheels' spin inertia leaves no physical body: the hub inertia I - sum(J a a^T) fails the check: ",
    )
    et = top.table("environment", required=False)
    sun = None if et is None else et.get("sun_direction_N", lambda v, k: r.vector(v, k, 3), required=False)
    gyro = _read_gyro(r, top.table("gyro"))
    tracker = _read_star_tracker(r, top.table("star_tracker"), sun)
    control = _read_control(r, top.table("control"))
    ot = top.table("orbit", required=False)
    orbit = None if ot is None else _read_orbit(r, ot)
    requirements = _read_requirements(r, top.table("requirements"), sun)
    mt = top.table("montecarlo", required=False)
    montecarlo = None if mt is None else _read_montecarlo(r, mt)
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
        environment=EnvironmentConfig(sun),
        montecarlo=montecarlo,
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
    return config_from_dict(data, file)


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
        text = path.read_bytes().decode("utf-8")
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
# Writing a resolved file


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)  # shortest round-trip repr; 'inf' and '1e-05' are valid TOML
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"cannot write {value!r} as TOML")


def _figures_text(preset: Mapping[str, Any]) -> str:
    figures = ", ".join(f"{k} = {v!r}" for k, v in preset["figures"].items())
    return f"{figures} ({preset['source']})"


class _Writer:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def table(self, header: str, *, array: bool = False) -> None:
        self.lines.append("")
        comment = _meaning_of(re.sub(r"\[\d+\]", "[]", header))
        text = f"[[{header}]]" if array else f"[{header}]"
        self.lines.append(f"{text}  # {comment}" if comment else text)

    def key(self, path: str, name: str, value: Any, note: str = "") -> None:
        if value is None:
            return
        meaning = note or _meaning_of(f"{path}.{name}" if path else name)
        line = f"{name} = {_toml_value(value)}"
        self.lines.append(f"{line}  # {meaning}" if meaning else line)

    def comment(self, text: str) -> None:
        self.lines.append(f"# {text}")


def config_to_toml(config: SpacecraftConfig) -> str:
    """The resolved spacecraft file: every value explicit, each key commented with its unit and meaning.

    ``parse_config(config_to_toml(c)) == c`` for every valid configuration
    (floats are written with their shortest round-trip representation).
    Presets are written by name with the figures that override them; the
    preset's own figures appear as a comment.

    Parameters
    ----------
    config : SpacecraftConfig
        A valid configuration.
    """
    w = _Writer()
    w.comment(f"Resolved spacecraft description{f' (from {config.source})' if config.source else ''}.")
    w.comment("Units are part of the key names; every key is commented with its unit and meaning.")
    w.lines.append("")
    w.key("", "name", config.name)
    w.key("", "description", config.description)

    w.table("inertia")
    w.key("inertia", "moments_kg_m2", config.inertia.moments_kg_m2)
    w.key("inertia", "tensor_kg_m2", config.inertia.tensor_kg_m2)

    wc = config.wheels_config
    w.table("wheels")
    for name in (
        "layout",
        "count",
        "axes_B",
        "elevation_deg",
        "spin_inertia_kg_m2",
        "torque_max_Nm",
        "momentum_max_Nms",
        "viscous_friction_Nms_per_rad",
        "coulomb_friction_Nm",
        "null_space_gain_per_s",
        "bias_momentum_Nms",
    ):
        w.key("wheels", name, getattr(wc, name))

    gc = config.gyro_config
    w.table("gyro")
    w.key("gyro", "preset", gc.preset)
    if gc.preset is not None:
        w.comment(f"preset {gc.preset!r}: {_figures_text(GYRO_PRESETS[gc.preset])}")
    w.key("gyro", "period_s", gc.period_s)
    for name in _GYRO_FIGURES:
        w.key("gyro", name, getattr(gc, name))

    sc = config.star_tracker_config
    w.table("star_tracker")
    w.key("star_tracker", "preset", sc.preset)
    if sc.preset is not None:
        w.comment(f"preset {sc.preset!r}: {_figures_text(STAR_TRACKER_PRESETS[sc.preset])}")
    for name in ("period_s", "cross_boresight_arcsec", "roll_arcsec", "boresight_B", "sun_exclusion_deg"):
        w.key("star_tracker", name, getattr(sc, name))

    cc = config.control
    w.table("control")
    for name in ("period_s", "bandwidth_rad_per_s", "damping"):
        w.key("control", name, getattr(cc, name))
    if cc.lqr is not None:
        w.table("control.lqr")
        for name in ("max_angle_deg", "max_rate_deg_per_s", "max_torque_Nm"):
            w.key("control.lqr", name, getattr(cc.lqr, name))

    if config.orbit_config is not None:
        w.table("orbit")
        for name in ("altitude_km", "inclination_deg", "raan_deg", "argument_of_latitude_deg"):
            w.key("orbit", name, getattr(config.orbit_config, name))

    if config.environment.sun_direction_N is not None:
        w.table("environment")
        w.key("environment", "sun_direction_N", config.environment.sun_direction_N)

    rc = config.requirements
    w.table("requirements")
    w.key("requirements", "pointing_accuracy_deg", rc.pointing_accuracy_deg)
    w.key("requirements", "settling_time_s", rc.settling_time_s)
    w.table("requirements.slew")
    for name in ("angle_deg", "axis_B", "target_q_BN", "start_q_BN", "max_time_s", "rate_max_deg_per_s"):
        w.key("requirements.slew", name, getattr(rc.slew, name))
    for i, cone in enumerate(rc.keep_out):
        path = f"requirements.keep_out[{i}]"
        w.table("requirements.keep_out", array=True)
        w.key(path, "name", cone.name)
        w.key(path, "boresight_B", cone.boresight_B)
        w.key(path, "direction_N", "sun" if cone.follows_sun else cone.direction_N)
        w.key(path, "half_angle_deg", cone.half_angle_deg)

    mc = config.montecarlo
    if mc is not None:
        w.table("montecarlo")
        w.key("montecarlo", "runs", mc.runs)
        w.key("montecarlo", "seed", mc.seed)
        for name in _DISPERSIONS:
            d = getattr(mc, name)
            if d is None:
                continue
            entry: dict[str, Any] = {"distribution": d.distribution}
            if d.scale is not None:
                entry[f"{'sigma' if d.distribution == 'normal' else 'half_width'}_{d.unit}"] = d.scale
            if d.axis_sigma_deg:
                entry["axis_sigma_deg"] = d.axis_sigma_deg
            w.key("montecarlo", name, entry)
    return "\n".join(w.lines) + "\n"

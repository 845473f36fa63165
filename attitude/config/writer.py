"""Writing a spacecraft file: :func:`config_to_toml`, the resolved file of a configuration.

Every default filled in and every key commented with its unit and meaning
(from :data:`attitude.config.schema.CONFIG_KEYS`); the result loads back to
an equal configuration.
"""

from __future__ import annotations

import dataclasses
import json
import re
from collections.abc import Mapping
from typing import Any

from attitude.config.build import default_sources
from attitude.config.model import GYRO_FIGURES, ORBIT_KEYS, SpacecraftConfig
from attitude.config.schema import DISPERSIONS, meaning_of
from attitude.sensors import GYRO_PRESETS, STAR_TRACKER_PRESETS

__all__ = ["config_to_toml", "replace_values"]


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
        comment = meaning_of(re.sub(r"\[\d+\]", "[]", header))
        text = f"[[{header}]]" if array else f"[{header}]"
        self.lines.append(f"{text}  # {comment}" if comment else text)

    def key(self, path: str, name: str, value: Any, note: str = "") -> None:
        if value is None:
            return
        meaning = note or meaning_of(f"{path}.{name}" if path else name)
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
        "torque_saturation",
    ):
        w.key("wheels", name, getattr(wc, name))

    gc = config.gyro_config
    w.table("gyro")
    w.key("gyro", "preset", gc.preset)
    if gc.preset is not None:
        w.comment(f"preset {gc.preset!r}: {_figures_text(GYRO_PRESETS[gc.preset])}")
    w.key("gyro", "period_s", gc.period_s)
    for name in GYRO_FIGURES:
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
        for name in ("angle_max_deg", "rate_max_deg_per_s", "torque_max_Nm"):
            w.key("control.lqr", name, getattr(cc.lqr, name))
    for i, filt in enumerate(cc.filters):
        w.table("control.filters", array=True)
        for f in dataclasses.fields(filt):
            w.key(f"control.filters[{i}]", f.name, getattr(filt, f.name))

    oc = config.orbit_config
    if oc is not None:
        w.table("orbit")
        w.key("orbit", "kind", oc.kind)
        for name in ORBIT_KEYS[oc.kind]:
            w.key("orbit", name, getattr(oc, name))

    ec = config.environment
    if ec.sun_direction_N is not None or oc is not None:
        w.table("environment")
        w.key("environment", "sun_direction_N", ec.sun_direction_N)
    if oc is not None:
        for name in ("magnetic_field", "atmosphere", "f107_sfu", "f107_average_sfu", "ap", "eclipse"):
            w.key("environment", name, getattr(ec, name))
        if ec.sources is None:
            w.comment(f"sources left out: {list(default_sources(ec, config.surface))} (the default for this file)")
        w.key("environment", "sources", ec.sources)
        w.key("environment", "sample_period_s", ec.sample_period_s)

    sf = config.surface
    if sf is not None:
        w.table("surface")
        for name in (
            "box_m",
            "centre_of_pressure_offset_B_m",
            "box_specular",
            "box_diffuse",
            "box_drag_coefficient",
            "residual_dipole_Am2",
        ):
            w.key("surface", name, getattr(sf, name))
        for kind, entries in (("plate", sf.plates), ("panel", sf.panels)):
            for i, entry in enumerate(entries):
                w.table(f"surface.{kind}", array=True)
                for f in dataclasses.fields(entry):
                    w.key(f"surface.{kind}[{i}]", f.name, getattr(entry, f.name))

    for table, entry in (
        ("magnetorquers", config.magnetorquers_config),
        ("magnetometer", config.magnetometer_config),
        ("coarse_sun_sensors", config.coarse_sun_sensors_config),
        ("fine_sun_sensor", config.fine_sun_sensor_config),
        ("detumble", config.detumble),
        ("momentum", config.momentum),
    ):
        if entry is not None:
            w.table(table)
            for f in dataclasses.fields(entry):
                w.key(table, f.name, getattr(entry, f.name))

    for i, mode in enumerate(config.flexible_modes):
        w.table("flexible_modes", array=True)
        for f in dataclasses.fields(mode):
            w.key(f"flexible_modes[{i}]", f.name, getattr(mode, f.name))

    rc = config.requirements
    w.table("requirements")
    w.key("requirements", "pointing_accuracy_deg", rc.pointing_accuracy_deg)
    w.key("requirements", "settling_time_s", rc.settling_time_s)
    w.key("requirements", "hold_time_s", rc.hold_time_s)
    w.key("requirements", "disk_margin_min", rc.disk_margin_min)
    w.table("requirements.slew")
    for name in ("angle_deg", "axis_B", "target_q_BN", "start_q_BN", "time_max_s", "rate_max_deg_per_s"):
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
        for name in DISPERSIONS:
            d = getattr(mc, name)
            if d is None:
                continue
            entry: dict[str, Any] = {"distribution": d.distribution}
            if d.scale is not None:
                entry[f"{'sigma' if d.distribution == 'normal' else 'half_width'}_{d.unit}"] = d.scale
            if d.axis_sigma_deg:
                entry["axis_sigma_deg"] = d.axis_sigma_deg
            w.key("montecarlo", name, entry)
    if config.uncertainty is not None:
        w.table("uncertainty")
        for f in dataclasses.fields(config.uncertainty):
            w.key("uncertainty", f.name, getattr(config.uncertainty, f.name))
    return "\n".join(w.lines) + "\n"


# Changing values in a file, its comments kept

_TABLE_LINE = re.compile(r"^\s*\[([^\[\]]+)\]\s*(#.*)?$")


def replace_values(text: str, values: Mapping[str, Any]) -> str:
    """The text of a spacecraft file with some keys' values replaced, every other line (comments too) unchanged.

    Parameters
    ----------
    text : str
        The file's text.
    values : mapping of str to value
        Dotted key (``"control.bandwidth_rad_per_s"``) to its new value (a number, string, bool or list); each
        key must be written in the file on one line, in its table (``[control]``, not inline).

    Raises
    ------
    ValueError
        A key the text does not hold on one line of its table.
    """
    lines = text.splitlines(keepends=True)
    table = ""
    left = dict(values)
    for i, line in enumerate(lines):
        header = _TABLE_LINE.match(line)
        if header:
            table = header.group(1).strip()
            continue
        for key in list(left):
            path, _, name = key.rpartition(".")
            found = re.match(rf"^(\s*{re.escape(name)}\s*=\s*)([^#\n]*?)(\s*(#.*)?)(\r?\n)?$", line)
            if path == table and found:
                value_text = found.group(2)
                if value_text.count("[") != value_text.count("]") or value_text.count("{") != value_text.count("}"):
                    raise ValueError(f"{key}: its value spans several lines; edit it by hand")
                lines[i] = found.group(1) + _toml_value(left.pop(key)) + found.group(3) + (found.group(5) or "")
                break
    if left:
        raise ValueError(f"the file holds no line for {', '.join(sorted(left))} in its table")
    return "".join(lines)

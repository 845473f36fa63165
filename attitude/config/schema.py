"""The schema of a spacecraft file: every key with its unit and meaning, the error type, unit spellings.

:data:`CONFIG_KEYS` is the one table of keys (dotted path -> unit, meaning):
the reader checks keys against it and names units from it, the writer
comments every key with it. :class:`ConfigError` is the error every problem
in a file raises. :func:`normalise_unit` folds the spellings of a unit
(``"Nm"``, ``"N m"``, ``"N·m"``) into one, so a message can say that a
string such as ``"0.05 Nm"`` carries the key's own unit.
"""

from __future__ import annotations

import re
from typing import Any

from attitude.sensors import GYRO_PRESETS, STAR_TRACKER_PRESETS

__all__ = [
    "CONFIG_KEYS",
    "DISPERSIONS",
    "DISTRIBUTIONS",
    "RENAMED_KEYS",
    "ConfigError",
    "children",
    "meaning_of",
    "normalise_unit",
    "unit_of",
]

#: Distributions of a Monte Carlo dispersion (some dispersions add their own, see :data:`DISPERSIONS`).
DISTRIBUTIONS = ("normal", "uniform")


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
    "control.lqr.angle_max_deg": ("deg", "largest acceptable attitude error (one value, or one per axis)"),
    "control.lqr.rate_max_deg_per_s": ("deg/s", "largest acceptable rate error (one value, or one per axis)"),
    "control.lqr.torque_max_Nm": ("N m", "largest acceptable control torque (one value, or one per axis)"),
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
    "requirements.slew.time_max_s": ("s", "largest allowed slew time"),
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
DISPERSIONS: dict[str, tuple[str, str, str, tuple[str, ...]]] = {
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
for _name, (_suffix, _unit, _meaning, _extra) in DISPERSIONS.items():
    CONFIG_KEYS[f"montecarlo.{_name}"] = ("", f"dispersion {_meaning} [{_unit}]")
    CONFIG_KEYS[f"montecarlo.{_name}.distribution"] = ("", "one of " + ", ".join(map(repr, DISTRIBUTIONS + _extra)))
    CONFIG_KEYS[f"montecarlo.{_name}.sigma_{_suffix}"] = (_unit, "standard deviation (normal)")
    CONFIG_KEYS[f"montecarlo.{_name}.half_width_{_suffix}"] = (_unit, "half-width: uniform on [-h, h] (uniform)")
del _name, _suffix, _unit, _meaning, _extra
CONFIG_KEYS["montecarlo.inertia.axis_sigma_deg"] = (
    "deg",
    "standard deviation of a rotation of the principal axes, per axis (normal; default 0: axes kept)",
)

#: Keys renamed to the naming rule (quantity, qualifier, unit; DESIGN.md): old
#: dotted path -> new key name in the same table. A file that still uses an
#: old key gets a message naming the new one, not the unknown-key message.
RENAMED_KEYS: dict[str, str] = {
    "control.lqr.max_angle_deg": "angle_max_deg",
    "control.lqr.max_rate_deg_per_s": "rate_max_deg_per_s",
    "control.lqr.max_torque_Nm": "torque_max_Nm",
    "requirements.slew.max_time_s": "time_max_s",
}


def children(path: str) -> tuple[str, ...]:
    """Keys allowed directly inside the table at ``path`` ("" for the top level).

    Parameters
    ----------
    path : str
        Dotted path of a table (``"control.lqr"``), "" for the top level.
    """
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


def unit_of(key: str) -> str:
    """The unit of ``key`` (a dotted path, indices allowed) fixed by its name; "" when dimensionless.

    Parameters
    ----------
    key : str
        Dotted path of a key (``"wheels.torque_max_Nm"``, ``"wheels.axes_B[2]"``).
    """
    return CONFIG_KEYS.get(_schema_path(key), ("", ""))[0]


def meaning_of(key: str) -> str:
    """The meaning of ``key`` with its unit in brackets (the comment of the resolved file).

    Parameters
    ----------
    key : str
        Dotted path of a key.
    """
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
# Units written as text


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


def normalise_unit(unit: str) -> str:
    """One spelling of a unit: lower case, no spaces, dots, stars or carets (``"N·m"`` -> ``"nm"``).

    Parameters
    ----------
    unit : str
        A unit as written in a file or a message.
    """
    u = unit.strip().lower().replace("²", "2").replace("·", "").replace("*", "").replace("^", "")
    u = re.sub(r"[\s.\-]", "", u)
    return _UNIT_ALIASES.get(u, u)

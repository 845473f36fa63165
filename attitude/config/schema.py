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
    "SURFACE_DISPERSIONS",
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
    "wheels.torque_saturation": (
        "",
        "'scale' (one factor keeps the body torque's direction) or 'clip' (each motor at its own limit alone)",
    ),
    # gyro
    "gyro": ("", "rate gyro (Farrenkopf model)"),
    "gyro.preset": ("", "gyro grade: " + ", ".join(repr(k) for k in GYRO_PRESETS) + "; figures below override it"),
    "gyro.period_s": ("s", "sample period"),
    "gyro.arw_deg_per_sqrt_h": ("deg/sqrt(h)", "angle random walk"),
    "gyro.rrw_deg_per_h_per_sqrt_h": ("deg/h/sqrt(h)", "rate random walk (or give a bias instability)"),
    "gyro.bias_instability_deg_per_h": ("deg/h", "bias instability (a Gauss-Markov bias; an RRW adds to it)"),
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
    "control.bandwidth_rad_per_s": ("rad/s", "natural frequency of the PD attitude loop, one or [x, y, z]"),
    "control.damping": ("", "damping ratio of the PD attitude loop, one or [x, y, z]"),
    "control.lqr": ("", "LQR weights by Bryson's rule (optional)"),
    "control.lqr.angle_max_deg": ("deg", "largest acceptable attitude error (one value, or one per axis)"),
    "control.lqr.rate_max_deg_per_s": ("deg/s", "largest acceptable rate error (one value, or one per axis)"),
    "control.lqr.torque_max_Nm": ("N m", "largest acceptable control torque (one value, or one per axis)"),
    "control.filters": (
        "",
        "notch and low-pass filters on the torque command, applied in order (optional; array of tables "
        "[[control.filters]])",
    ),
    "control.filters[].kind": ("", 'filter kind: "notch" or "low_pass"'),
    "control.filters[].frequency_Hz": ("Hz", "centre (notch) or corner (low-pass) frequency, below Nyquist"),
    "control.filters[].axes": ("", 'body axes filtered, e.g. ["x", "y", "z"]'),
    "control.filters[].depth": ("", "notch: gain at the centre frequency, in [0, 1) (0.1 is 20 dB deep)"),
    "control.filters[].damping": ("", "notch: damping ratio of its poles (its width); low-pass: its damping ratio"),
    "control.filters[].order": ("", "low-pass: 1 or 2"),
    # orbit and environment
    "orbit": ("", "Earth orbit (optional: gravity gradient, and with it the orbit environment)"),
    "orbit.kind": ("", "'circular' (altitude_km), 'kepler' (two-body elements) or 'tle' (two-line elements, SGP4)"),
    "orbit.epoch_utc": (
        "",
        "UTC instant of t = 0, ISO 8601 with a time zone ('2026-03-20T12:00:00Z'; default the toolkit's "
        "DEFAULT_EPOCH); a TLE carries its own",
    ),
    "orbit.altitude_km": ("km", "circular: altitude above the Earth's equatorial radius"),
    "orbit.inclination_deg": ("deg", "inclination (circular and kepler)"),
    "orbit.raan_deg": ("deg", "right ascension of the ascending node (circular and kepler)"),
    "orbit.argument_of_latitude_deg": ("deg", "circular: argument of latitude at t = 0"),
    "orbit.perigee_altitude_km": (
        "km",
        "kepler: perigee altitude above the equatorial radius (with apogee)",
    ),
    "orbit.apogee_altitude_km": (
        "km",
        "kepler: apogee altitude above the equatorial radius (with perigee)",
    ),
    "orbit.semi_major_axis_km": ("km", "kepler: semi-major axis (with eccentricity, instead of the altitudes)"),
    "orbit.eccentricity": ("", "kepler: eccentricity, in [0, 1) (with semi_major_axis_km)"),
    "orbit.argument_of_perigee_deg": ("deg", "kepler: argument of perigee"),
    "orbit.mean_anomaly_deg": ("deg", "kepler: mean anomaly at t = 0"),
    "orbit.tle_line1": ("", "tle: first line of the two-line element set (69 characters)"),
    "orbit.tle_line2": ("", "tle: second line of the two-line element set (69 characters)"),
    "environment": ("", "scene and orbit environment models (optional)"),
    "environment.sun_direction_N": ("", "direction to the Sun in inertial axes (normalised)"),
    "environment.magnetic_field": (
        "",
        "geomagnetic field model with an [orbit]: 'igrf' (IGRF through ppigrf), 'dipole' (tilted dipole) or 'none'",
    ),
    "environment.atmosphere": (
        "",
        "air density model with an [orbit]: 'exponential' (Vallado Table 8-4), 'nrlmsis' (pymsis) or 'none'",
    ),
    "environment.f107_sfu": ("sfu", "nrlmsis only: daily F10.7 solar flux (1 sfu = 1e-22 W m^-2 Hz^-1)"),
    "environment.f107_average_sfu": ("sfu", "nrlmsis only: 81-day average F10.7 solar flux"),
    "environment.ap": ("", "nrlmsis only: daily geomagnetic Ap index"),
    "environment.eclipse": ("", "Earth shadow model with an [orbit]: 'conical' (penumbra), 'cylindrical' or 'none'"),
    "environment.sources": (
        "",
        "disturbance torques flown with an [orbit]: a list drawn from 'gravity_gradient', 'aerodynamic', "
        "'solar_pressure', 'magnetic' (default: all four with a [surface], gravity gradient alone without)",
    ),
    "environment.sample_period_s": ("s", "grid on which the orbit environment is computed and interpolated"),
    # surface
    "surface": ("", "flat-plate surface model and residual dipole (optional: drag, solar pressure, magnetic)"),
    "surface.box_m": ("m", "body box edge lengths [x, y, z]: six plates centred on the centre of mass"),
    "surface.centre_of_pressure_offset_B_m": (
        "m",
        "box only: box centre minus centre of mass, body axes (shifts every box face)",
    ),
    "surface.box_specular": ("", "box only: specular reflection fraction of the faces, in [0, 1]"),
    "surface.box_diffuse": (
        "",
        "box only: diffuse reflection fraction of the faces (specular + diffuse <= 1)",
    ),
    "surface.box_drag_coefficient": ("", "box only: free-molecular drag coefficient of the faces"),
    "surface.residual_dipole_Am2": ("A m^2", "residual magnetic dipole of the spacecraft, body axes"),
    "surface.plate": ("", "one-sided flat plates (array of tables [[surface.plate]])"),
    "surface.plate[].area_m2": ("m^2", "plate area"),
    "surface.plate[].normal_B": ("", "outward normal in body axes (normalised)"),
    "surface.plate[].centre_of_pressure_B_m": ("m", "centre of pressure relative to the centre of mass, body axes"),
    "surface.plate[].specular": ("", "specular reflection fraction, in [0, 1]"),
    "surface.plate[].diffuse": ("", "diffuse reflection fraction, in [0, 1] (specular + diffuse <= 1)"),
    "surface.plate[].drag_coefficient": ("", "free-molecular drag coefficient"),
    "surface.panel": ("", "thin two-sided panels, e.g. solar arrays (array of tables [[surface.panel]])"),
    "surface.panel[].area_m2": ("m^2", "panel area (one face)"),
    "surface.panel[].normal_B": (
        "",
        "front (cell) face normal in body axes (normalised); the back faces away",
    ),
    "surface.panel[].centre_of_pressure_B_m": ("m", "panel centre relative to the centre of mass, body axes"),
    "surface.panel[].specular": ("", "front face specular reflection fraction, in [0, 1]"),
    "surface.panel[].diffuse": ("", "front face diffuse reflection fraction, in [0, 1]"),
    "surface.panel[].back_specular": ("", "back face specular reflection fraction, in [0, 1]"),
    "surface.panel[].back_diffuse": ("", "back face diffuse reflection fraction, in [0, 1]"),
    "surface.panel[].drag_coefficient": ("", "free-molecular drag coefficient of both faces"),
    # magnetorquers and magnetometer
    "magnetorquers": ("", "magnetic torque rods (optional)"),
    "magnetorquers.dipole_max_Am2": ("A m^2", "largest dipole of a rod (one value, or one per rod)"),
    "magnetorquers.quantum_Am2": ("A m^2", "dipole quantisation step of a rod (one value, or one per rod; optional)"),
    "magnetorquers.axes_B": ("", "rod axes in body axes (normalised; default the three body axes)"),
    "magnetorquers.saturation": (
        "",
        "'scale' (one factor keeps the dipole's direction) or 'clip' (each rod saturates alone)",
    ),
    "magnetometer": ("", "three-axis magnetometer (optional; needs a magnetic field model)"),
    "magnetometer.period_s": ("s", "sample period"),
    "magnetometer.noise_nT": ("nT", "1-sigma white noise per axis and sample"),
    "magnetometer.bias_nT": ("nT", "constant bias (one value, or one per axis)"),
    "magnetometer.scale_factor_ppm": ("ppm", "scale-factor error (one value, or one per axis)"),
    "magnetometer.misalignment_deg": ("deg", "small rotation vector of the sensor triad from the body axes"),
    "magnetometer.quantization_nT": ("nT", "output resolution per LSB (0: none)"),
    # sun sensors
    "coarse_sun_sensors": ("", "coarse sun sensor cells (optional; needs an [orbit]: the Sun and eclipse along it)"),
    "coarse_sun_sensors.period_s": ("s", "sample period"),
    "coarse_sun_sensors.noise_percent": ("%", "1-sigma noise per cell and sample, percent of full scale"),
    "coarse_sun_sensors.normals_B": ("", "cell normals in body axes [[x, y, z], ...] (default: six cube faces)"),
    "coarse_sun_sensors.fov_half_angle_deg": ("deg", "field-of-view half-angle of each cell, in (0, 90]"),
    "coarse_sun_sensors.albedo_percent": ("%", "Earth-albedo current at normal incidence, percent of full scale"),
    "fine_sun_sensor": ("", "two-axis fine sun sensor (optional; needs an [orbit]: the Sun and eclipse along it)"),
    "fine_sun_sensor.period_s": ("s", "sample period"),
    "fine_sun_sensor.accuracy_deg": ("deg", "angle accuracy per axis, at accuracy_sigma_level sigma"),
    "fine_sun_sensor.accuracy_sigma_level": ("", "how many sigma accuracy_deg is (1 or 3 on most datasheets)"),
    "fine_sun_sensor.fov_half_angle_deg": ("deg", "half-angle of the conical field of view, in (0, 90)"),
    "fine_sun_sensor.boresight_B": ("", "boresight in body axes (normalised)"),
    "fine_sun_sensor.bias_deg": ("deg", "constant bias on the two angles (one value, or [alpha, beta])"),
    # detumbling and momentum management
    "detumble": ("", "B-dot detumbling study (optional; needs [magnetorquers], [magnetometer] and an [orbit])"),
    "detumble.tip_off_rate_deg_per_s": ("deg/s", "body rate after separation (one value for every axis, or [x, y, z])"),
    "detumble.rate_threshold_deg_per_s": ("deg/s", "detumbled when the body rate magnitude is below this"),
    "detumble.gain_Nms": (
        "N m s",
        "gain k of the normalised B-dot law m = -(k/|B|) db/dt, or 'auto': 2 n (1 + sin i) J_min "
        "(Avanzini and Giulietti 2012)",
    ),
    "detumble.period_s": ("s", "sample period of the B-dot law"),
    "detumble.duration_max_orbits": ("", "longest detumbling simulated, in orbits"),
    "momentum": ("", "momentum budget and magnetic unloading (optional; needs an [orbit])"),
    "momentum.unloading_gain_per_s": (
        "1/s",
        "gain k of the cross-product unloading law m = k (dh x B) / |B|^2 (needs [magnetorquers])",
    ),
    "momentum.period_s": ("s", "sample period of the unloading law"),
    "momentum.orbits": ("", "length of the momentum budget, in orbits"),
    "momentum.wheel_momentum_margin": (
        "",
        "fraction of the wheels' momentum capacity the budget may use, in (0, 1]",
    ),
    # requirements
    "requirements": ("", "what the design must achieve"),
    "requirements.pointing_accuracy_deg": ("deg", "largest error angle to the target over the hold (hold_time_s)"),
    "requirements.settling_time_s": ("s", "time after the end of the slew by which the pointing accuracy is met"),
    "requirements.hold_time_s": (
        "s",
        "time the pointing accuracy is held after the settling time, over which it is judged "
        "(optional; default max(30 s, settling_time_s))",
    ),
    "requirements.disk_margin_min": (
        "",
        "smallest disk margin alpha of the sampled loop at the plant input, in (0, 2) (optional; judged by `attitude "
        "design` and `attitude tune`): gain within [(2 - alpha)/(2 + alpha), (2 + alpha)/(2 - alpha)], phase +-2 "
        "atan(alpha/2)",
    ),
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
    # flexible appendages
    "flexible_modes": (
        "",
        "constrained (cantilevered) modes of flexible appendages (optional; array of tables [[flexible_modes]])",
    ),
    "flexible_modes[].frequency_Hz": ("Hz", "natural frequency of the mode with the appendage clamped to a fixed hub"),
    "flexible_modes[].damping": ("", "modal damping ratio, in [0, 1)"),
    "flexible_modes[].participation_B_sqrt_kg_m": (
        "sqrt(kg) m",
        "modal participation: the mode's coupling to body rotation about x, y, z (I - L^T L must stay positive "
        "definite)",
    ),
    # worst case
    "uncertainty": (
        "",
        "uncertainty set of the worst-case search (optional; sampled uniformly, unlike [montecarlo]'s dispersions)",
    ),
    "uncertainty.inertia_percent": ("%", "each principal moment within +- this, relative (below 100)"),
    "uncertainty.axis_rotation_deg": ("deg", "principal axes turned by a rotation of at most this angle"),
    "uncertainty.wheel_misalignment_deg": ("deg", "each wheel's spin axis tilted by at most this angle"),
    "uncertainty.extra_delay_s": ("s", "extra delay from the controller's sample to the torque, in [0, this]"),
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
    # Flown with the orbit environment only (attitude montecarlo --environment); need [orbit] and [surface].
    "drag_scale": (
        "percent",
        "%",
        "of a common scale on every plate's drag coefficient, relative, about 1 (with --environment)",
        (),
    ),
    "residual_dipole": (
        "Am2",
        "A m^2",
        "of the residual magnetic dipole about surface.residual_dipole_Am2, per axis (with --environment)",
        (),
    ),
    "centre_of_pressure_offset": (
        "m",
        "m",
        "of a common offset of every plate's centre of pressure, per axis (with --environment)",
        (),
    ),
}
#: The dispersions of the surface, flown only with the orbit environment (they need [orbit] and [surface]).
SURFACE_DISPERSIONS = ("drag_scale", "residual_dipole", "centre_of_pressure_offset")
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

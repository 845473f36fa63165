"""The validated spacecraft description: frozen dataclasses that mirror the file, key for key.

One dataclass per table (:class:`InertiaConfig`, :class:`WheelsConfig`,
:class:`GyroConfig`, :class:`StarTrackerConfig`, :class:`ControlConfig`,
:class:`OrbitConfig`, :class:`EnvironmentConfig`,
:class:`RequirementsConfig`, :class:`MonteCarloConfig`, :class:`SurfaceConfig`
with its :class:`PlateConfig` and :class:`PanelConfig`,
:class:`MagnetorquersConfig`, :class:`MagnetometerConfig`,
:class:`DetumbleConfig`, :class:`MomentumConfig`) and
:class:`SpacecraftConfig` for the whole file. They hold data only, in the
units of their key names; :mod:`attitude.config.reader` makes them from a
file, :mod:`attitude.config.writer` writes them back, and
:mod:`attitude.app.assembly` turns them into the toolkit's objects.
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.environment.epoch import DEFAULT_EPOCH
from attitude.environment.surface import DEFAULT_DRAG_COEFFICIENT
from attitude.sensors import ARCSEC, STAR_TRACKER_PRESETS

__all__ = [
    "ATMOSPHERE_MODELS",
    "DEFAULT_EPOCH_UTC",
    "ECLIPSE_MODELS",
    "FILTER_KINDS",
    "GYRO_FIGURES",
    "MAGNETIC_FIELD_MODELS",
    "NRLMSIS_DEFAULTS",
    "ORBIT_KEYS",
    "ORBIT_KINDS",
    "PYRAMID_ELEVATION_DEG",
    "WHEEL_LAYOUTS",
    "CoarseSunSensorsConfig",
    "ControlConfig",
    "ControlFilterConfig",
    "DetumbleConfig",
    "Dispersion",
    "EnvironmentConfig",
    "FineSunSensorConfig",
    "FlexibleModeConfig",
    "GyroConfig",
    "InertiaConfig",
    "KeepOutConfig",
    "LQRBounds",
    "MagnetometerConfig",
    "MagnetorquersConfig",
    "MomentumConfig",
    "MonteCarloConfig",
    "OrbitConfig",
    "PanelConfig",
    "PerWheel",
    "PlateConfig",
    "RequirementsConfig",
    "SlewRequirement",
    "SpacecraftConfig",
    "StarTrackerConfig",
    "SurfaceConfig",
    "UncertaintyConfig",
    "Vector",
    "WheelsConfig",
]

#: Wheel layouts: ``pyramid`` (4 wheels, :meth:`ReactionWheels.pyramid`),
#: ``orthogonal`` (3 wheels on the body axes), ``custom`` (``axes_B`` given).
WHEEL_LAYOUTS = ("pyramid", "orthogonal", "custom")

#: Pyramid elevation used when ``wheels.elevation_deg`` is left out: the default of
#: :meth:`ReactionWheels.pyramid`, ``atan(1/sqrt(2))`` (equal torque capacity about x, y, z).
PYRAMID_ELEVATION_DEG: float = inspect.signature(ReactionWheels.pyramid).parameters["elevation_deg"].default

#: A vector as written in the file (a tuple of floats).
Vector = tuple[float, ...]
#: One value for every wheel (or axis), or one value each.
PerWheel = float | tuple[float, ...]


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
    torque_saturation : str, optional
        'scale' (one factor keeps the body torque's direction) or 'clip' (each motor at its own limit)
        (key ``wheels.torque_saturation``; :data:`attitude.actuators.SATURATION_MODES`).
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
    torque_saturation: str = "scale"


#: The datasheet figures of ``[gyro]`` (keywords of :meth:`attitude.sensors.Gyro.from_datasheet`, in file units).
GYRO_FIGURES = (
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


@dataclass(frozen=True)
class LQRBounds:
    """The ``[control.lqr]`` table: Bryson's-rule bounds (one value or one per axis).

    Parameters
    ----------
    angle_max_deg : float or tuple of float
        Largest acceptable attitude error (one value, or one per axis) [deg] (key
        ``control.lqr.angle_max_deg``).
    rate_max_deg_per_s : float or tuple of float
        Largest acceptable rate error (one value, or one per axis) [deg/s] (key
        ``control.lqr.rate_max_deg_per_s``).
    torque_max_Nm : float or tuple of float
        Largest acceptable control torque (one value, or one per axis) [N m] (key
        ``control.lqr.torque_max_Nm``).
    """

    angle_max_deg: PerWheel
    rate_max_deg_per_s: PerWheel
    torque_max_Nm: PerWheel

    @property
    def angle_max(self) -> NDArray[np.float64]:
        """Largest acceptable attitude error per axis [rad], shape (3,)."""
        return np.radians(np.broadcast_to(np.array(self.angle_max_deg, dtype=np.float64), (3,)))

    @property
    def rate_max(self) -> NDArray[np.float64]:
        """Largest acceptable rate error per axis [rad/s], shape (3,)."""
        return np.radians(np.broadcast_to(np.array(self.rate_max_deg_per_s, dtype=np.float64), (3,)))

    @property
    def torque_max(self) -> NDArray[np.float64]:
        """Largest acceptable control torque per axis [N m], shape (3,)."""
        return np.broadcast_to(np.array(self.torque_max_Nm, dtype=np.float64), (3,)).copy()


#: Kinds of ``[[control.filters]]`` entries.
FILTER_KINDS = ("notch", "low_pass")


@dataclass(frozen=True)
class ControlFilterConfig:
    """One ``[[control.filters]]``: a filter on the torque command of the PD and the LQR.

    Parameters
    ----------
    kind : str
        "notch" or "low_pass" (key ``control.filters[i].kind``).
    frequency_Hz : float
        Centre (notch) or corner (low-pass) frequency [Hz], below the controller's Nyquist frequency
        (key ``control.filters[i].frequency_Hz``).
    axes : tuple of str
        The body axes filtered, among "x", "y", "z" (key ``control.filters[i].axes``).
    depth : float or None
        Notch only: its gain at the centre, in [0, 1) (key ``control.filters[i].depth``).
    damping : float or None
        Notch: the poles' damping ratio (its width); second-order low-pass: its damping ratio
        (key ``control.filters[i].damping``).
    order : int or None
        Low-pass only: 1 or 2 (key ``control.filters[i].order``).
    """

    kind: str
    frequency_Hz: float
    axes: tuple[str, ...] = ("x", "y", "z")
    depth: float | None = None
    damping: float | None = None
    order: int | None = None


@dataclass(frozen=True)
class ControlConfig:
    """The ``[control]`` table: sample period [s], PD bandwidth [rad/s] and damping, optional LQR bounds.

    Parameters
    ----------
    period_s : float
        Controller sample period (1 / control rate) [s] (key ``control.period_s``).
    bandwidth_rad_per_s : float or tuple of float
        Natural frequency of the PD attitude loop [rad/s], one or per body axis ``[x, y, z]`` (key
        ``control.bandwidth_rad_per_s``).
    damping : float or tuple of float
        Damping ratio of the PD attitude loop, one or per body axis (key ``control.damping``).
    lqr : LQRBounds or None, optional
        LQR weights by Bryson's rule (optional) (key ``control.lqr``).
    filters : tuple of ControlFilterConfig, optional
        Notch and low-pass filters on the torque command, in order (optional) (key ``control.filters``).
    """

    period_s: float
    bandwidth_rad_per_s: PerWheel
    damping: PerWheel
    lqr: LQRBounds | None = None
    filters: tuple[ControlFilterConfig, ...] = ()

    @property
    def per_axis(self) -> bool:
        """Whether the PD has a bandwidth or damping per body axis (not one pair for all)."""
        return isinstance(self.bandwidth_rad_per_s, tuple) or isinstance(self.damping, tuple)


#: Kinds of ``[orbit]``: a circular orbit, two-body Keplerian elements, or a TLE flown with SGP4.
ORBIT_KINDS = ("circular", "kepler", "tle")
#: Keys of ``[orbit]`` by kind (``kind`` itself belongs to every kind).
ORBIT_KEYS = {
    "circular": ("altitude_km", "inclination_deg", "raan_deg", "argument_of_latitude_deg", "epoch_utc"),
    "kepler": (
        "perigee_altitude_km",
        "apogee_altitude_km",
        "semi_major_axis_km",
        "eccentricity",
        "inclination_deg",
        "raan_deg",
        "argument_of_perigee_deg",
        "mean_anomaly_deg",
        "epoch_utc",
    ),
    "tle": ("tle_line1", "tle_line2"),
}

#: ``environment.magnetic_field`` models.
MAGNETIC_FIELD_MODELS = ("igrf", "dipole", "none")
#: ``environment.atmosphere`` models.
ATMOSPHERE_MODELS = ("exponential", "nrlmsis", "none")
#: ``environment.eclipse`` models.
ECLIPSE_MODELS = ("conical", "cylindrical", "none")
#: ``orbit.epoch_utc`` when the file leaves it out: :data:`attitude.environment.epoch.DEFAULT_EPOCH` in ISO 8601.
DEFAULT_EPOCH_UTC = DEFAULT_EPOCH.utc.strftime("%Y-%m-%dT%H:%M:%SZ")
#: NRLMSIS space weather when the file leaves it out: mean solar activity (F10.7 = 150 sfu) and a quiet
#: geomagnetic field (Ap = 4), the defaults of :class:`attitude.environment.atmosphere.NRLMSIS`.
NRLMSIS_DEFAULTS = {"f107_sfu": 150.0, "f107_average_sfu": 150.0, "ap": 4.0}


@dataclass(frozen=True)
class OrbitConfig:
    """The ``[orbit]`` table: a circular, Keplerian or TLE Earth orbit (angles in degrees, lengths in km).

    ``kind`` says which keys apply: ``"circular"`` the altitude and the
    angles of the circular orbit; ``"kepler"`` the perigee and apogee
    altitudes or the semi-major axis and eccentricity (whichever the file
    gives; the other pair stays None) and the angles; ``"tle"`` the two lines
    only (the TLE carries its epoch and elements, so the other keys are
    None). Keys that do not apply to the kind are None.

    Parameters
    ----------
    altitude_km : float or None, optional
        Circular: altitude above the Earth's equatorial radius [km] (key ``orbit.altitude_km``).
    inclination_deg : float or None, optional
        Inclination (circular and kepler) [deg] (key ``orbit.inclination_deg``).
    raan_deg : float or None, optional
        Right ascension of the ascending node (circular and kepler) [deg] (key ``orbit.raan_deg``).
    argument_of_latitude_deg : float or None, optional
        Circular: argument of latitude at t = 0 [deg] (key ``orbit.argument_of_latitude_deg``).
    kind : str, optional
        'circular', 'kepler' or 'tle' (key ``orbit.kind``).
    epoch_utc : str or None, optional
        UTC instant of t = 0, ISO 8601 with a time zone (key ``orbit.epoch_utc``); None for a TLE.
    perigee_altitude_km : float or None, optional
        Kepler: perigee altitude above the equatorial radius [km] (key ``orbit.perigee_altitude_km``).
    apogee_altitude_km : float or None, optional
        Kepler: apogee altitude above the equatorial radius [km] (key ``orbit.apogee_altitude_km``).
    semi_major_axis_km : float or None, optional
        Kepler: semi-major axis [km] (key ``orbit.semi_major_axis_km``).
    eccentricity : float or None, optional
        Kepler: eccentricity, in [0, 1) (key ``orbit.eccentricity``).
    argument_of_perigee_deg : float or None, optional
        Kepler: argument of perigee [deg] (key ``orbit.argument_of_perigee_deg``).
    mean_anomaly_deg : float or None, optional
        Kepler: mean anomaly at t = 0 [deg] (key ``orbit.mean_anomaly_deg``).
    tle_line1 : str or None, optional
        TLE: first line (key ``orbit.tle_line1``).
    tle_line2 : str or None, optional
        TLE: second line (key ``orbit.tle_line2``).
    """

    altitude_km: float | None = None
    inclination_deg: float | None = 0.0
    raan_deg: float | None = 0.0
    argument_of_latitude_deg: float | None = 0.0
    kind: str = "circular"
    epoch_utc: str | None = DEFAULT_EPOCH_UTC
    perigee_altitude_km: float | None = None
    apogee_altitude_km: float | None = None
    semi_major_axis_km: float | None = None
    eccentricity: float | None = None
    argument_of_perigee_deg: float | None = None
    mean_anomaly_deg: float | None = None
    tle_line1: str | None = None
    tle_line2: str | None = None


@dataclass(frozen=True)
class EnvironmentConfig:
    """The ``[environment]`` table: the inertial Sun direction, and the models flown with an ``[orbit]``.

    Without an ``[orbit]`` only ``sun_direction_N`` applies (the reader
    refuses the model keys then, rather than ignore them).

    Parameters
    ----------
    sun_direction_N : tuple of float or None, optional
        Direction to the Sun in inertial axes (normalised) (key ``environment.sun_direction_N``).
    magnetic_field : str, optional
        'igrf', 'dipole' or 'none' (key ``environment.magnetic_field``).
    atmosphere : str, optional
        'exponential', 'nrlmsis' or 'none' (key ``environment.atmosphere``).
    f107_sfu : float or None, optional
        NRLMSIS only: daily F10.7 [sfu] (key ``environment.f107_sfu``).
    f107_average_sfu : float or None, optional
        NRLMSIS only: 81-day average F10.7 [sfu] (key ``environment.f107_average_sfu``).
    ap : float or None, optional
        NRLMSIS only: daily Ap index (key ``environment.ap``).
    eclipse : str, optional
        'conical', 'cylindrical' or 'none' (key ``environment.eclipse``).
    sources : tuple of str or None, optional
        Disturbance torques flown (key ``environment.sources``); None: all four with a ``[surface]``,
        gravity gradient alone without.
    sample_period_s : float, optional
        Grid of the orbit environment [s] (key ``environment.sample_period_s``).
    """

    sun_direction_N: Vector | None = None
    magnetic_field: str = "igrf"
    atmosphere: str = "exponential"
    f107_sfu: float | None = None
    f107_average_sfu: float | None = None
    ap: float | None = None
    eclipse: str = "conical"
    sources: tuple[str, ...] | None = None
    sample_period_s: float = 1.0

    @property
    def sun_unit_N(self) -> NDArray[np.float64] | None:
        """Unit Sun direction in inertial axes, or None."""
        if self.sun_direction_N is None:
            return None
        v = np.array(self.sun_direction_N, dtype=np.float64)
        return v / np.linalg.norm(v)


@dataclass(frozen=True)
class PlateConfig:
    """One ``[[surface.plate]]``: a one-sided flat plate.

    Parameters
    ----------
    area_m2 : float
        Plate area [m^2] (key ``surface.plate[i].area_m2``).
    normal_B : tuple of float
        Outward normal in body axes (normalised) (key ``surface.plate[i].normal_B``).
    centre_of_pressure_B_m : tuple of float
        Centre of pressure relative to the centre of mass, body axes [m] (key
        ``surface.plate[i].centre_of_pressure_B_m``).
    specular : float, optional
        Specular reflection fraction (key ``surface.plate[i].specular``).
    diffuse : float, optional
        Diffuse reflection fraction (key ``surface.plate[i].diffuse``).
    drag_coefficient : float, optional
        Free-molecular drag coefficient (key ``surface.plate[i].drag_coefficient``).
    """

    area_m2: float
    normal_B: Vector
    centre_of_pressure_B_m: Vector
    specular: float = 0.0
    diffuse: float = 0.0
    drag_coefficient: float = DEFAULT_DRAG_COEFFICIENT


@dataclass(frozen=True)
class PanelConfig:
    """One ``[[surface.panel]]``: a thin two-sided panel (a front and a back plate).

    Parameters
    ----------
    area_m2 : float
        Panel area, one face [m^2] (key ``surface.panel[i].area_m2``).
    normal_B : tuple of float
        Front face normal in body axes (key ``surface.panel[i].normal_B``).
    centre_of_pressure_B_m : tuple of float
        Panel centre relative to the centre of mass, body axes [m] (key
        ``surface.panel[i].centre_of_pressure_B_m``).
    specular : float, optional
        Front specular fraction (key ``surface.panel[i].specular``).
    diffuse : float, optional
        Front diffuse fraction (key ``surface.panel[i].diffuse``).
    back_specular : float, optional
        Back specular fraction (key ``surface.panel[i].back_specular``).
    back_diffuse : float, optional
        Back diffuse fraction (key ``surface.panel[i].back_diffuse``).
    drag_coefficient : float, optional
        Drag coefficient of both faces (key ``surface.panel[i].drag_coefficient``).
    """

    area_m2: float
    normal_B: Vector
    centre_of_pressure_B_m: Vector
    specular: float = 0.0
    diffuse: float = 0.0
    back_specular: float = 0.0
    back_diffuse: float = 0.0
    drag_coefficient: float = DEFAULT_DRAG_COEFFICIENT


@dataclass(frozen=True)
class SurfaceConfig:
    """The ``[surface]`` table: a box and/or plates, two-sided panels and the residual dipole.

    The surface model is the box's six faces (when ``box_m`` is given), then
    the plates, then the panels' fronts and backs.

    Parameters
    ----------
    box_m : tuple of float or None, optional
        Box edge lengths [m] (key ``surface.box_m``).
    centre_of_pressure_offset_B_m : tuple of float or None, optional
        Box only: box centre minus centre of mass [m] (key ``surface.centre_of_pressure_offset_B_m``).
    box_specular : float or None, optional
        Box only: specular fraction (key ``surface.box_specular``).
    box_diffuse : float or None, optional
        Box only: diffuse fraction (key ``surface.box_diffuse``).
    box_drag_coefficient : float or None, optional
        Box only: drag coefficient (key ``surface.box_drag_coefficient``).
    plates : tuple of PlateConfig, optional
        One-sided plates (key ``surface.plate``).
    panels : tuple of PanelConfig, optional
        Two-sided panels (key ``surface.panel``).
    residual_dipole_Am2 : tuple of float, optional
        Residual dipole, body axes [A m^2] (key ``surface.residual_dipole_Am2``).
    """

    box_m: Vector | None = None
    centre_of_pressure_offset_B_m: Vector | None = None
    box_specular: float | None = None
    box_diffuse: float | None = None
    box_drag_coefficient: float | None = None
    plates: tuple[PlateConfig, ...] = ()
    panels: tuple[PanelConfig, ...] = ()
    residual_dipole_Am2: Vector = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class MagnetorquersConfig:
    """The ``[magnetorquers]`` table.

    Parameters
    ----------
    dipole_max_Am2 : float or tuple of float
        Largest dipole of a rod (one value, or one per rod) [A m^2] (key ``magnetorquers.dipole_max_Am2``).
    quantum_Am2 : float or tuple of float or None, optional
        Quantisation step (key ``magnetorquers.quantum_Am2``) [A m^2]; None: none.
    axes_B : tuple of tuple of float or None, optional
        Rod axes in body axes (key ``magnetorquers.axes_B``); None: the body axes.
    saturation : str, optional
        'scale' or 'clip' (key ``magnetorquers.saturation``; :data:`attitude.actuators.SATURATION_MODES`).
    """

    dipole_max_Am2: PerWheel
    quantum_Am2: PerWheel | None = None
    axes_B: tuple[Vector, ...] | None = None
    saturation: str = "scale"

    @property
    def count(self) -> int:
        """Number of rods."""
        return 3 if self.axes_B is None else len(self.axes_B)


@dataclass(frozen=True)
class MagnetometerConfig:
    """The ``[magnetometer]`` table (datasheet units: nT, ppm, deg).

    Parameters
    ----------
    period_s : float
        Sample period [s] (key ``magnetometer.period_s``).
    noise_nT : float
        1-sigma white noise per axis [nT] (key ``magnetometer.noise_nT``).
    bias_nT : float or tuple of float, optional
        Constant bias [nT] (key ``magnetometer.bias_nT``).
    scale_factor_ppm : float or tuple of float, optional
        Scale-factor error [ppm] (key ``magnetometer.scale_factor_ppm``).
    misalignment_deg : tuple of float, optional
        Small rotation vector of the triad from the body axes [deg] (key ``magnetometer.misalignment_deg``).
    quantization_nT : float, optional
        Output resolution [nT] (key ``magnetometer.quantization_nT``).
    """

    period_s: float
    noise_nT: float
    bias_nT: PerWheel = 0.0
    scale_factor_ppm: PerWheel = 0.0
    misalignment_deg: Vector = (0.0, 0.0, 0.0)
    quantization_nT: float = 0.0


@dataclass(frozen=True)
class CoarseSunSensorsConfig:
    """The ``[coarse_sun_sensors]`` table: cosine cells (datasheet units: deg, percent of full scale).

    Parameters
    ----------
    period_s : float
        Sample period [s] (key ``coarse_sun_sensors.period_s``).
    noise_percent : float
        1-sigma noise per cell and sample [% of full scale] (key ``coarse_sun_sensors.noise_percent``).
    normals_B : tuple of tuple of float, optional
        Cell normals in body axes; None: six cells on the cube faces (key ``coarse_sun_sensors.normals_B``).
    fov_half_angle_deg : float, optional
        Field-of-view half-angle of each cell [deg] (key ``coarse_sun_sensors.fov_half_angle_deg``).
    albedo_percent : float, optional
        Earth-albedo current at normal incidence [% of full scale] (key ``coarse_sun_sensors.albedo_percent``).
    """

    period_s: float
    noise_percent: float
    normals_B: tuple[Vector, ...] | None = None
    fov_half_angle_deg: float = 90.0
    albedo_percent: float = 0.0


@dataclass(frozen=True)
class FineSunSensorConfig:
    """The ``[fine_sun_sensor]`` table: a two-axis fine sun sensor (datasheet units: deg).

    Parameters
    ----------
    period_s : float
        Sample period [s] (key ``fine_sun_sensor.period_s``).
    accuracy_deg : float
        Angle accuracy per axis [deg] (key ``fine_sun_sensor.accuracy_deg``).
    accuracy_sigma_level : float
        How many sigma ``accuracy_deg`` is (key ``fine_sun_sensor.accuracy_sigma_level``).
    fov_half_angle_deg : float
        Half-angle of the conical field of view [deg] (key ``fine_sun_sensor.fov_half_angle_deg``).
    boresight_B : tuple of float, optional
        Boresight in body axes (key ``fine_sun_sensor.boresight_B``).
    bias_deg : float or tuple of float, optional
        Constant bias on the two angles [deg] (key ``fine_sun_sensor.bias_deg``).
    """

    period_s: float
    accuracy_deg: float
    accuracy_sigma_level: float
    fov_half_angle_deg: float
    boresight_B: Vector = (0.0, 0.0, 1.0)
    bias_deg: PerWheel = 0.0


@dataclass(frozen=True)
class DetumbleConfig:
    """The ``[detumble]`` table.

    Parameters
    ----------
    tip_off_rate_deg_per_s : float or tuple of float
        Body rate after separation [deg/s] (key ``detumble.tip_off_rate_deg_per_s``).
    rate_threshold_deg_per_s : float
        Detumbled below this rate magnitude [deg/s] (key ``detumble.rate_threshold_deg_per_s``).
    gain_Nms : float or str, optional
        B-dot gain [N m s] or ``"auto"`` (key ``detumble.gain_Nms``).
    period_s : float, optional
        Sample period of the law [s] (key ``detumble.period_s``).
    duration_max_orbits : float, optional
        Longest detumbling simulated [orbits] (key ``detumble.duration_max_orbits``).
    """

    tip_off_rate_deg_per_s: PerWheel
    rate_threshold_deg_per_s: float
    gain_Nms: float | str = "auto"
    period_s: float = 1.0
    duration_max_orbits: float = 5.0


@dataclass(frozen=True)
class MomentumConfig:
    """The ``[momentum]`` table.

    Parameters
    ----------
    unloading_gain_per_s : float or None, optional
        Cross-product unloading gain [1/s] (key ``momentum.unloading_gain_per_s``); None: no unloading.
    period_s : float, optional
        Sample period of the unloading law [s] (key ``momentum.period_s``).
    orbits : int, optional
        Length of the budget [orbits] (key ``momentum.orbits``).
    wheel_momentum_margin : float, optional
        Fraction of the wheels' capacity the budget may use (key ``momentum.wheel_momentum_margin``).
    """

    unloading_gain_per_s: float | None = None
    period_s: float = 1.0
    orbits: int = 20
    wheel_momentum_margin: float = 1.0


@dataclass(frozen=True)
class FlexibleModeConfig:
    """One ``[[flexible_modes]]``: a constrained (cantilevered) mode of a flexible appendage.

    Parameters
    ----------
    frequency_Hz : float
        Natural frequency with the appendage clamped to a fixed hub [Hz] (key ``flexible_modes[i].frequency_Hz``).
    damping : float
        Modal damping ratio, in [0, 1) (key ``flexible_modes[i].damping``).
    participation_B_sqrt_kg_m : tuple of float
        Coupling to body rotation about x, y, z [sqrt(kg) m] (key ``flexible_modes[i].participation_B_sqrt_kg_m``).
    """

    frequency_Hz: float
    damping: float
    participation_B_sqrt_kg_m: Vector


@dataclass(frozen=True)
class SlewRequirement:
    """The ``[requirements.slew]`` table.

    The target is either ``angle_deg`` about the body axis ``axis_B`` from
    the start attitude (``q_target = q_start ⊗ q(axis_B, angle)``: a rotation
    about a body axis multiplies on the right, because ``q_BN`` rotates body
    vectors into inertial ones), or ``target_q_BN``.

    Parameters
    ----------
    time_max_s : float
        Largest allowed slew time [s] (key ``requirements.slew.time_max_s``).
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

    time_max_s: float
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


#: Shortest hold judged when the file gives no ``requirements.hold_time_s`` [s].
DEFAULT_HOLD_TIME_MIN_S = 30.0


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
    hold_time_s : float, optional
        Time the pointing accuracy is held after the settling time, over which it is judged [s] (key
        ``requirements.hold_time_s``); None: :attr:`hold_time_judged_s`.
    disk_margin_min : float, optional
        Smallest disk margin of the sampled loop at the plant input, in (0, 2) (key
        ``requirements.disk_margin_min``); None: not required.
    """

    pointing_accuracy_deg: float
    settling_time_s: float
    slew: SlewRequirement
    keep_out: tuple[KeepOutConfig, ...] = ()
    hold_time_s: float | None = None
    disk_margin_min: float | None = None

    @property
    def hold_time_judged_s(self) -> float:
        """The hold the pointing accuracy is judged over [s]: ``hold_time_s``, else max(30 s, settling time)."""
        if self.hold_time_s is not None:
            return self.hold_time_s
        return max(DEFAULT_HOLD_TIME_MIN_S, self.settling_time_s)

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
        Unit of ``scale``, the key suffix: ``percent``, ``deg_per_s``, ``deg``, ``deg_per_h``,
        ``arcsec``, ``Am2`` or ``m``.
    axis_sigma_deg : float, optional
        Inertia only: standard deviation of a rotation of the principal axes, per axis [deg].
    """

    distribution: str
    scale: float | None
    unit: str
    axis_sigma_deg: float = 0.0  # inertia only: rotation of the principal axes, per axis (normal) [deg]

    @property
    def scale_si(self) -> float | None:
        """The scale in SI: a fraction for ``percent``, rad, rad/s, A m^2, m."""
        if self.scale is None:
            return None
        factor = {
            "percent": 0.01,
            "deg": math.pi / 180.0,
            "deg_per_s": math.pi / 180.0,
            "deg_per_h": math.pi / 180.0 / 3600.0,
            "arcsec": ARCSEC,
            "Am2": 1.0,
            "m": 1.0,
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
    drag_scale : Dispersion or None, optional
        Dispersion of a common scale on every plate's drag coefficient, relative, about 1 [%]
        (key ``montecarlo.drag_scale``; flown with the orbit environment).
    residual_dipole : Dispersion or None, optional
        Dispersion of the residual magnetic dipole about the file's, per axis [A m^2] (key
        ``montecarlo.residual_dipole``; flown with the orbit environment).
    centre_of_pressure_offset : Dispersion or None, optional
        Dispersion of a common offset of every centre of pressure, per axis [m] (key
        ``montecarlo.centre_of_pressure_offset``; flown with the orbit environment).
    """

    runs: int
    seed: int
    inertia: Dispersion | None = None
    initial_rate: Dispersion | None = None
    initial_attitude: Dispersion | None = None
    gyro_misalignment: Dispersion | None = None
    star_tracker_misalignment: Dispersion | None = None
    gyro_bias: Dispersion | None = None
    drag_scale: Dispersion | None = None
    residual_dipole: Dispersion | None = None
    centre_of_pressure_offset: Dispersion | None = None


@dataclass(frozen=True)
class UncertaintyConfig:
    """The ``[uncertainty]`` table: the bounds of the worst-case search's set (0: known).

    Parameters
    ----------
    inertia_percent : float, optional
        Each principal moment within +- this, relative [%] (key ``uncertainty.inertia_percent``).
    axis_rotation_deg : float, optional
        Principal axes turned by a rotation of at most this angle [deg] (key ``uncertainty.axis_rotation_deg``).
    wheel_misalignment_deg : float, optional
        Each wheel's spin axis tilted by at most this angle [deg] (key ``uncertainty.wheel_misalignment_deg``).
    extra_delay_s : float, optional
        Extra delay from the controller's sample to the torque, in [0, this] [s] (key
        ``uncertainty.extra_delay_s``).
    """

    inertia_percent: float = 0.0
    axis_rotation_deg: float = 0.0
    wheel_misalignment_deg: float = 0.0
    extra_delay_s: float = 0.0


@dataclass(frozen=True)
class SpacecraftConfig:
    """A validated spacecraft description, mirroring the TOML file key for key.

    Each table is a field of the same name, except ``[wheels]``
    (:attr:`wheels_config`), ``[gyro]`` (:attr:`gyro_config`),
    ``[star_tracker]`` (:attr:`star_tracker_config`), ``[orbit]``
    (:attr:`orbit_config`), ``[magnetorquers]`` (:attr:`magnetorquers_config`)
    ``[magnetometer]`` (:attr:`magnetometer_config`), ``[coarse_sun_sensors]``
    (:attr:`coarse_sun_sensors_config`) and ``[fine_sun_sensor]``
    (:attr:`fine_sun_sensor_config`), whose names are those of the objects
    :mod:`attitude.app.assembly` builds from them. Values keep the units of
    their key names; the builders (:mod:`attitude.config.build`) convert to
    SI. ``source`` (the file it came from) is not part of equality.

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
        Earth orbit (optional: gravity gradient, and with it the orbit environment) (key ``orbit``).
    environment : EnvironmentConfig, optional
        Scene and orbit environment models (optional) (key ``environment``).
    surface : SurfaceConfig or None, optional
        Flat-plate surface model and residual dipole (optional) (key ``surface``).
    magnetorquers_config : MagnetorquersConfig or None, optional
        Magnetic torque rods (optional) (key ``magnetorquers``).
    magnetometer_config : MagnetometerConfig or None, optional
        Three-axis magnetometer (optional) (key ``magnetometer``).
    coarse_sun_sensors_config : CoarseSunSensorsConfig or None, optional
        Coarse sun sensor cells (optional) (key ``coarse_sun_sensors``).
    fine_sun_sensor_config : FineSunSensorConfig or None, optional
        Two-axis fine sun sensor (optional) (key ``fine_sun_sensor``).
    detumble : DetumbleConfig or None, optional
        B-dot detumbling study (optional) (key ``detumble``).
    momentum : MomentumConfig or None, optional
        Momentum budget and magnetic unloading (optional) (key ``momentum``).
    montecarlo : MonteCarloConfig or None, optional
        Monte Carlo campaign (optional) (key ``montecarlo``).
    flexible_modes : tuple of FlexibleModeConfig, optional
        Constrained modes of flexible appendages (optional) (key ``flexible_modes``); empty: a rigid spacecraft.
    uncertainty : UncertaintyConfig or None, optional
        Uncertainty set of the worst-case search (optional) (key ``uncertainty``).
    source : str, optional
        The file the configuration was read from (messages only; not compared).
    source_sha256 : str, optional
        SHA-256 of the text parsed (provenance of reports and campaigns; not compared).
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
    surface: SurfaceConfig | None = None
    magnetorquers_config: MagnetorquersConfig | None = None
    magnetometer_config: MagnetometerConfig | None = None
    coarse_sun_sensors_config: CoarseSunSensorsConfig | None = None
    fine_sun_sensor_config: FineSunSensorConfig | None = None
    detumble: DetumbleConfig | None = None
    momentum: MomentumConfig | None = None
    flexible_modes: tuple[FlexibleModeConfig, ...] = ()
    uncertainty: UncertaintyConfig | None = None
    source: str = field(default="", compare=False)
    source_sha256: str = field(default="", compare=False)


# ---------------------------------------------------------------------------

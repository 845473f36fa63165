"""Each table of a spacecraft file as its toolkit object, in SI: the one conversion of file units.

These functions take one table (a dataclass of :mod:`attitude.config.model`)
and return the ground-floor object it describes. Two callers use them: the
reader (:mod:`attitude.config.reader`), which builds every object once to
prove that a file that loads also builds, and the assembly
(:mod:`attitude.app.assembly`), which turns a whole
:class:`~attitude.config.model.SpacecraftConfig` into the objects a design
or a scenario uses. Everything else builds through the assembly. They live
here, in the ground floor, because the reader may not import
:mod:`attitude.app`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from attitude.actuators import Magnetorquers, ReactionWheels
from attitude.config.model import (
    GYRO_FIGURES,
    NRLMSIS_DEFAULTS,
    CoarseSunSensorsConfig,
    EnvironmentConfig,
    FineSunSensorConfig,
    FlexibleModeConfig,
    GyroConfig,
    InertiaConfig,
    MagnetometerConfig,
    MagnetorquersConfig,
    OrbitConfig,
    StarTrackerConfig,
    SurfaceConfig,
    WheelsConfig,
)
from attitude.environment.atmosphere import NRLMSIS, ExponentialAtmosphere
from attitude.environment.epoch import Epoch
from attitude.environment.magnetic_field import IGRF, TiltedDipole
from attitude.environment.orbit import R_EARTH, CircularOrbit, KeplerOrbit, TLEOrbit
from attitude.environment.orbit_environment import DISTURBANCE_SOURCES, OrbitEnvironment
from attitude.environment.surface import SurfaceModel
from attitude.flexible import FlexibleModes
from attitude.rigid_body import RigidBody
from attitude.sensors import ARCSEC, Gyro, Magnetometer, StarTracker
from attitude.sun_sensors import CUBE_NORMALS_B, CoarseSunSensors, FineSunSensor

__all__ = [
    "atmosphere",
    "circular_orbit",
    "coarse_sun_sensors",
    "default_sources",
    "epoch",
    "fine_sun_sensor",
    "flexible_modes",
    "gyro",
    "gyro_figures",
    "kepler_orbit",
    "magnetic_field",
    "magnetometer",
    "magnetorquers",
    "orbit",
    "orbit_environment",
    "reaction_wheels",
    "rigid_body",
    "star_tracker",
    "surface_model",
    "tle_orbit",
]

#: An orbit of the ``[orbit]`` table.
Orbit = CircularOrbit | KeplerOrbit | TLEOrbit


def rigid_body(inertia: InertiaConfig) -> RigidBody:
    """The whole spacecraft (wheels included) as a :class:`RigidBody`.

    Parameters
    ----------
    inertia : InertiaConfig
        The ``[inertia]`` table (moments or tensor [kg m^2], body axes).

    Returns
    -------
    RigidBody
    """
    return RigidBody(inertia.tensor)


def reaction_wheels(wheels: WheelsConfig) -> ReactionWheels:
    """The :class:`ReactionWheels` of the ``[wheels]`` table.

    Parameters
    ----------
    wheels : WheelsConfig
        Layout, spin inertia [kg m^2], torque limit [N m], momentum limit
        [N m s], friction [N m s/rad, N m], null-space gain [1/s], bias
        momentum [N m s] (already SI), pyramid elevation [deg] and torque
        saturation mode.

    Returns
    -------
    ReactionWheels
    """
    kw: dict[str, Any] = {
        "viscous_friction": np.array(wheels.viscous_friction_Nms_per_rad, dtype=np.float64),
        "coulomb_friction": np.array(wheels.coulomb_friction_Nm, dtype=np.float64),
        "null_space_gain": wheels.null_space_gain_per_s,
        "bias_momentum": np.array(wheels.bias_momentum_Nms, dtype=np.float64),
        "torque_saturation": wheels.torque_saturation,
    }
    kw["spin_inertia"] = np.array(wheels.spin_inertia_kg_m2, dtype=np.float64)
    kw["torque_max"] = np.array(wheels.torque_max_Nm, dtype=np.float64)
    kw["momentum_max"] = np.array(wheels.momentum_max_Nms, dtype=np.float64)
    if wheels.layout == "pyramid":
        if wheels.elevation_deg is not None:
            kw["elevation_deg"] = wheels.elevation_deg
        return ReactionWheels.pyramid(**kw)
    if wheels.layout == "orthogonal":
        return ReactionWheels.orthogonal(**kw)
    return ReactionWheels(np.array(wheels.axes_B, dtype=np.float64), **kw)


def gyro_figures(gyro_config: GyroConfig) -> dict[str, Any]:
    """Keywords of :meth:`Gyro.from_datasheet` given in the file (preset figures excluded).

    Parameters
    ----------
    gyro_config : GyroConfig
        The ``[gyro]`` table (datasheet units: deg/sqrt(h), deg/h, ppm, arcsec, deg/s).

    Returns
    -------
    dict
        The figures under their datasheet keyword names, in datasheet units,
        except the misalignment, converted from arcsec to ``misalignment_rad`` [rad].
    """
    out: dict[str, Any] = {}
    for name in GYRO_FIGURES:
        value = getattr(gyro_config, name)
        if value is None:
            continue
        if name == "misalignment_arcsec":
            out["misalignment_rad"] = np.array(value) * ARCSEC
        else:
            out[name] = np.array(value) if isinstance(value, tuple) else value
    return out


def gyro(gyro_config: GyroConfig, sampling: str = "instantaneous", figures: Mapping[str, Any] | None = None) -> Gyro:
    """A fresh :class:`Gyro` (converted to SI by :meth:`Gyro.from_datasheet`; stateful: one per run).

    Parameters
    ----------
    gyro_config : GyroConfig
        The ``[gyro]`` table: preset, sample period [s] and datasheet figures.
    sampling : {"instantaneous", "mean"}
        What a sample is: the rate at the sample time (what the rate EKF
        models) or the mean rate over the interval (an integrating gyro;
        what the MEKF models).
    figures : mapping, optional
        Datasheet keywords to use instead of :func:`gyro_figures` (datasheet
        units, misalignment in rad), e.g. with a dispersed misalignment.

    Returns
    -------
    Gyro
    """
    figures = dict(gyro_figures(gyro_config) if figures is None else figures)
    if gyro_config.preset is not None:
        return Gyro.preset(gyro_config.preset, period=gyro_config.period_s, sampling=sampling, **figures)
    arw = figures.pop("arw_deg_per_sqrt_h")
    return Gyro.from_datasheet(arw_deg_per_sqrt_h=arw, period=gyro_config.period_s, sampling=sampling, **figures)


def star_tracker(tracker: StarTrackerConfig, sun_direction_N: Sequence[float] | None = None) -> StarTracker:
    """The :class:`StarTracker`; blinded by the Sun only when a Sun direction is given.

    Parameters
    ----------
    tracker : StarTrackerConfig
        The ``[star_tracker]`` table: preset, period [s], noise [arcsec],
        boresight (body axes) and Sun exclusion [deg].
    sun_direction_N : sequence of 3 floats, optional
        Direction to the Sun in inertial axes (``environment.sun_direction_N``; any length).

    Returns
    -------
    StarTracker
    """
    figures: dict[str, Any] = {"boresight_B": np.array(tracker.boresight_B, dtype=np.float64)}
    if tracker.cross_boresight_arcsec is not None:
        figures["cross_boresight_arcsec"] = tracker.cross_boresight_arcsec
    if tracker.roll_arcsec is not None:
        figures["roll_arcsec"] = tracker.roll_arcsec
    sun = None if sun_direction_N is None else np.array(sun_direction_N, dtype=np.float64)
    exclusion = tracker.effective_sun_exclusion_deg
    if tracker.preset is not None:
        if sun is not None and exclusion is not None:
            figures["sun_exclusion_deg"] = exclusion
        return StarTracker.preset(tracker.preset, period=tracker.period_s, sun_direction_N=sun, **figures)
    if sun is not None and exclusion is not None:
        figures["sun_direction_N"] = sun
        figures["sun_exclusion_deg"] = exclusion
    return StarTracker.from_datasheet(period=tracker.period_s, **figures)


def epoch(orbit: OrbitConfig) -> Epoch:
    """The epoch (t = 0) of a circular or Keplerian ``[orbit]``: ``epoch_utc`` as an :class:`Epoch`.

    Parameters
    ----------
    orbit : OrbitConfig
        The ``[orbit]`` table (``epoch_utc``, ISO 8601 with a time zone).

    Returns
    -------
    Epoch

    Raises
    ------
    ValueError
        For a TLE (its epoch is in its first line: use :func:`orbit`) or an unreadable instant.
    """
    if orbit.epoch_utc is None:
        raise ValueError("orbit.epoch_utc is None: a TLE carries its own epoch (build the orbit and read its epoch)")
    return Epoch.from_iso(orbit.epoch_utc)


def circular_orbit(orbit: OrbitConfig) -> CircularOrbit:
    """The :class:`CircularOrbit` of a ``kind = "circular"`` ``[orbit]`` table.

    Parameters
    ----------
    orbit : OrbitConfig
        Altitude [km], inclination, RAAN and argument of latitude [deg], epoch (UTC).

    Returns
    -------
    CircularOrbit
        In SI (m, rad), with its epoch.
    """
    built = CircularOrbit.from_altitude(
        orbit.altitude_km * 1000.0,
        inclination=math.radians(orbit.inclination_deg),
        raan=math.radians(orbit.raan_deg),
        argument_of_latitude=math.radians(orbit.argument_of_latitude_deg),
    )
    return dataclasses.replace(built, epoch=epoch(orbit))


def kepler_orbit(orbit: OrbitConfig) -> KeplerOrbit:
    """The :class:`KeplerOrbit` of a ``kind = "kepler"`` ``[orbit]`` table.

    The perigee and apogee altitudes ``h_p``, ``h_a`` (above the equatorial
    radius ``R``) give ``a = R + (h_p + h_a) / 2`` and
    ``e = (h_a - h_p) / (2 a)`` (``r_p = a (1 - e)``, ``r_a = a (1 + e)``).

    Parameters
    ----------
    orbit : OrbitConfig
        Altitudes or semi-major axis [km] and eccentricity, angles [deg], epoch (UTC).

    Returns
    -------
    KeplerOrbit
        In SI (m, rad).
    """
    if orbit.semi_major_axis_km is not None:
        a_m, e = orbit.semi_major_axis_km * 1000.0, float(orbit.eccentricity)
    else:
        r_p = R_EARTH + orbit.perigee_altitude_km * 1000.0
        r_a = R_EARTH + orbit.apogee_altitude_km * 1000.0
        a_m = 0.5 * (r_p + r_a)
        e = (r_a - r_p) / (r_a + r_p)
    return KeplerOrbit(
        semi_major_axis_m=a_m,
        eccentricity=e,
        inclination=math.radians(orbit.inclination_deg),
        raan=math.radians(orbit.raan_deg),
        argument_of_perigee=math.radians(orbit.argument_of_perigee_deg),
        mean_anomaly=math.radians(orbit.mean_anomaly_deg),
        epoch=epoch(orbit),
    )


def tle_orbit(orbit: OrbitConfig) -> TLEOrbit:
    """The :class:`TLEOrbit` (SGP4) of a ``kind = "tle"`` ``[orbit]`` table.

    Parameters
    ----------
    orbit : OrbitConfig
        The two lines (the epoch is the TLE's).

    Returns
    -------
    TLEOrbit
    """
    return TLEOrbit(orbit.tle_line1, orbit.tle_line2)


def orbit(orbit_config: OrbitConfig) -> Orbit:
    """The orbit of the ``[orbit]`` table, by its ``kind``.

    Parameters
    ----------
    orbit_config : OrbitConfig
        The ``[orbit]`` table.

    Returns
    -------
    CircularOrbit, KeplerOrbit or TLEOrbit
    """
    if orbit_config.kind == "kepler":
        return kepler_orbit(orbit_config)
    if orbit_config.kind == "tle":
        return tle_orbit(orbit_config)
    return circular_orbit(orbit_config)


def surface_model(surface: SurfaceConfig) -> SurfaceModel:
    """The :class:`SurfaceModel` of ``[surface]``: box faces, then plates, then panel fronts and backs.

    Parameters
    ----------
    surface : SurfaceConfig
        Box [m] with its optics, plates and panels (areas [m^2], normals and
        centres of pressure [m] in body axes), residual dipole [A m^2].

    Returns
    -------
    SurfaceModel

    Raises
    ------
    ValueError
        For a surface with neither a box nor a plate (panels need a body), or as :class:`SurfaceModel`.
    """
    dipole = np.array(surface.residual_dipole_Am2, dtype=np.float64)
    parts: list[SurfaceModel] = []
    if surface.box_m is not None:
        optics = {
            "specular": surface.box_specular,
            "diffuse": surface.box_diffuse,
            "drag_coefficient": surface.box_drag_coefficient,
        }
        parts.append(
            SurfaceModel.box(
                np.array(surface.box_m, dtype=np.float64),
                centre_of_pressure_offset_B_m=np.array(
                    surface.centre_of_pressure_offset_B_m or (0.0, 0.0, 0.0), dtype=np.float64
                ),
                residual_dipole_Am2=dipole,
                **{k: v for k, v in optics.items() if v is not None},
            )
        )
    if surface.plates:
        plates = surface.plates
        parts.append(
            SurfaceModel(
                area_m2=np.array([p.area_m2 for p in plates], dtype=np.float64),
                normal_B=np.array([p.normal_B for p in plates], dtype=np.float64),
                centre_of_pressure_B_m=np.array([p.centre_of_pressure_B_m for p in plates], dtype=np.float64),
                specular=np.array([p.specular for p in plates], dtype=np.float64),
                diffuse=np.array([p.diffuse for p in plates], dtype=np.float64),
                drag_coefficient=np.array([p.drag_coefficient for p in plates], dtype=np.float64),
                residual_dipole_Am2=dipole,
            )
        )
    if not parts:
        raise ValueError("a surface needs box_m or at least one [[surface.plate]] (panels are added to a body)")
    model = parts[0]
    if len(parts) == 2:
        model = SurfaceModel(
            **{
                name: np.concatenate([getattr(part, name) for part in parts])
                for name in ("area_m2", "normal_B", "centre_of_pressure_B_m", "specular", "diffuse", "drag_coefficient")
            },
            residual_dipole_Am2=dipole,
        )
    if surface.panels:
        panels = surface.panels
        model = model.with_panels(
            np.array([p.area_m2 for p in panels], dtype=np.float64),
            np.array([p.normal_B for p in panels], dtype=np.float64),
            np.array([p.centre_of_pressure_B_m for p in panels], dtype=np.float64),
            specular=np.array([p.specular for p in panels], dtype=np.float64),
            diffuse=np.array([p.diffuse for p in panels], dtype=np.float64),
            back_specular=np.array([p.back_specular for p in panels], dtype=np.float64),
            back_diffuse=np.array([p.back_diffuse for p in panels], dtype=np.float64),
            drag_coefficient=np.array([p.drag_coefficient for p in panels], dtype=np.float64),
        )
    return model


def magnetic_field(environment: EnvironmentConfig, epoch: Epoch) -> IGRF | TiltedDipole | None:
    """The geomagnetic field model of ``environment.magnetic_field``.

    Parameters
    ----------
    environment : EnvironmentConfig
        The ``[environment]`` table.
    epoch : Epoch
        The orbit's epoch (the tilted dipole takes the IGRF degree-1 terms at its date).

    Returns
    -------
    IGRF, TiltedDipole or None
        None for ``"none"``.
    """
    if environment.magnetic_field == "igrf":
        return IGRF()
    if environment.magnetic_field == "dipole":
        return TiltedDipole(epoch)
    return None


def atmosphere(environment: EnvironmentConfig) -> ExponentialAtmosphere | NRLMSIS | None:
    """The air density model of ``environment.atmosphere``.

    Parameters
    ----------
    environment : EnvironmentConfig
        The ``[environment]`` table (NRLMSIS space weather: F10.7 [sfu], Ap).

    Returns
    -------
    ExponentialAtmosphere, NRLMSIS or None
        None for ``"none"``.
    """
    if environment.atmosphere == "exponential":
        return ExponentialAtmosphere()
    if environment.atmosphere == "nrlmsis":
        weather = {
            name: NRLMSIS_DEFAULTS[name] if getattr(environment, name) is None else getattr(environment, name)
            for name in NRLMSIS_DEFAULTS
        }
        return NRLMSIS(**weather)
    return None


def default_sources(environment: EnvironmentConfig, surface: SurfaceConfig | None) -> tuple[str, ...]:
    """The disturbance torques flown when ``environment.sources`` is left out.

    Parameters
    ----------
    environment : EnvironmentConfig
        The ``[environment]`` table (its field and atmosphere models).
    surface : SurfaceConfig or None
        The ``[surface]`` table, if any.

    Returns
    -------
    tuple of str
        Gravity gradient alone without a surface (the other three need the
        plates and the dipole); with one, every source of
        :data:`DISTURBANCE_SOURCES` whose model the file keeps (no
        aerodynamic torque with ``atmosphere = "none"``, no magnetic torque
        with ``magnetic_field = "none"``).
    """
    if surface is None:
        return ("gravity_gradient",)
    dropped = set()
    if environment.atmosphere == "none":
        dropped.add("aerodynamic")
    if environment.magnetic_field == "none":
        dropped.add("magnetic")
    return tuple(s for s in DISTURBANCE_SOURCES if s not in dropped)


def orbit_environment(
    orbit_config: OrbitConfig,
    environment: EnvironmentConfig,
    surface: SurfaceConfig | None,
    built_orbit: Orbit | None = None,
) -> OrbitEnvironment:
    """The :class:`OrbitEnvironment` of ``[orbit]``, ``[environment]`` and ``[surface]``.

    Parameters
    ----------
    orbit_config : OrbitConfig
        The ``[orbit]`` table.
    environment : EnvironmentConfig
        Field, atmosphere and eclipse models, sources and sample period [s].
    surface : SurfaceConfig or None
        The ``[surface]`` table; None flies gravity gradient only.
    built_orbit : orbit, optional
        The orbit already built from ``orbit_config`` (default: built here).

    Returns
    -------
    OrbitEnvironment
    """
    the_orbit = orbit(orbit_config) if built_orbit is None else built_orbit
    sources = environment.sources if environment.sources is not None else default_sources(environment, surface)
    return OrbitEnvironment(
        orbit=the_orbit,
        surface=None if surface is None else surface_model(surface),
        magnetic_field=magnetic_field(environment, the_orbit.epoch),
        atmosphere=atmosphere(environment),
        eclipse=environment.eclipse,
        sources=sources,
        sample_period=environment.sample_period_s,
    )


def magnetorquers(torquers: MagnetorquersConfig) -> Magnetorquers:
    """The :class:`Magnetorquers` of ``[magnetorquers]``.

    Parameters
    ----------
    torquers : MagnetorquersConfig
        Dipole limits and quantum [A m^2] (already SI), axes (body), saturation mode.

    Returns
    -------
    Magnetorquers
    """
    quantum = None if torquers.quantum_Am2 is None else np.array(torquers.quantum_Am2, dtype=np.float64)
    return Magnetorquers(
        None if torquers.axes_B is None else np.array(torquers.axes_B, dtype=np.float64),
        dipole_max_Am2=np.array(torquers.dipole_max_Am2, dtype=np.float64),
        quantum_Am2=quantum,
        saturation=torquers.saturation,
    )


def magnetometer(sensor: MagnetometerConfig) -> Magnetometer:
    """The :class:`Magnetometer` of ``[magnetometer]`` (converted to SI by :meth:`Magnetometer.from_datasheet`).

    Parameters
    ----------
    sensor : MagnetometerConfig
        Period [s], noise, bias and quantisation [nT], scale factor [ppm], misalignment [deg].

    Returns
    -------
    Magnetometer
    """
    return Magnetometer.from_datasheet(
        noise_nT=sensor.noise_nT,
        period=sensor.period_s,
        bias_nT=np.array(sensor.bias_nT, dtype=np.float64),
        scale_factor_ppm=np.array(sensor.scale_factor_ppm, dtype=np.float64),
        misalignment_rad=np.radians(np.array(sensor.misalignment_deg, dtype=np.float64)),
        quantization_nT=sensor.quantization_nT,
    )


def coarse_sun_sensors(sensor: CoarseSunSensorsConfig) -> CoarseSunSensors:
    """The :class:`CoarseSunSensors` of ``[coarse_sun_sensors]`` (by :meth:`CoarseSunSensors.from_datasheet`).

    Parameters
    ----------
    sensor : CoarseSunSensorsConfig
        Period [s], noise and albedo [% of full scale], normals, field of view [deg].

    Returns
    -------
    CoarseSunSensors
        The cells (full scale 1 mA: the estimate uses ratios of currents, so its value is immaterial).
    """
    normals = CUBE_NORMALS_B if sensor.normals_B is None else np.array(sensor.normals_B, dtype=np.float64)
    return CoarseSunSensors.from_datasheet(
        normals,
        period=sensor.period_s,
        fov_half_angle_deg=sensor.fov_half_angle_deg,
        full_scale_mA=1.0,
        noise_percent=sensor.noise_percent,
        albedo_percent=sensor.albedo_percent,
    )


def fine_sun_sensor(sensor: FineSunSensorConfig) -> FineSunSensor:
    """The :class:`FineSunSensor` of ``[fine_sun_sensor]`` (by :meth:`FineSunSensor.from_datasheet`).

    Parameters
    ----------
    sensor : FineSunSensorConfig
        Period [s], accuracy [deg] at its sigma level, field of view [deg], boresight, bias [deg].

    Returns
    -------
    FineSunSensor
    """
    return FineSunSensor.from_datasheet(
        accuracy_deg=sensor.accuracy_deg,
        accuracy_sigma_level=sensor.accuracy_sigma_level,
        period=sensor.period_s,
        fov_half_angle_deg=sensor.fov_half_angle_deg,
        boresight_B=np.array(sensor.boresight_B, dtype=np.float64),
        bias_deg=np.array(sensor.bias_deg, dtype=np.float64),
    )


def flexible_modes(modes: Sequence[FlexibleModeConfig]) -> FlexibleModes | None:
    """The :class:`FlexibleModes` of the ``[[flexible_modes]]`` entries (None when there are none).

    Parameters
    ----------
    modes : sequence of FlexibleModeConfig
        Frequency [Hz], damping ratio and participation [sqrt(kg) m] of each
        constrained mode.

    Returns
    -------
    FlexibleModes or None
    """
    if not modes:
        return None
    return FlexibleModes.from_hz(
        frequency_Hz=[m.frequency_Hz for m in modes],
        damping=[m.damping for m in modes],
        participation=[m.participation_B_sqrt_kg_m for m in modes],
    )

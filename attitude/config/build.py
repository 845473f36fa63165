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

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from attitude.actuators import ReactionWheels
from attitude.config.model import GYRO_FIGURES, GyroConfig, InertiaConfig, OrbitConfig, StarTrackerConfig, WheelsConfig
from attitude.environment.orbit import CircularOrbit
from attitude.rigid_body import RigidBody
from attitude.sensors import ARCSEC, Gyro, StarTracker

__all__ = ["circular_orbit", "gyro", "gyro_figures", "reaction_wheels", "rigid_body", "star_tracker"]


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
        momentum [N m s] (already SI) and pyramid elevation [deg].

    Returns
    -------
    ReactionWheels
    """
    kw: dict[str, Any] = {
        "viscous_friction": np.array(wheels.viscous_friction_Nms_per_rad, dtype=np.float64),
        "coulomb_friction": np.array(wheels.coulomb_friction_Nm, dtype=np.float64),
        "null_space_gain": wheels.null_space_gain_per_s,
        "bias_momentum": np.array(wheels.bias_momentum_Nms, dtype=np.float64),
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


def circular_orbit(orbit: OrbitConfig) -> CircularOrbit:
    """The :class:`CircularOrbit` of the ``[orbit]`` table.

    Parameters
    ----------
    orbit : OrbitConfig
        Altitude [km], inclination, RAAN and argument of latitude [deg].

    Returns
    -------
    CircularOrbit
        In SI (m, rad).
    """
    return CircularOrbit.from_altitude(
        orbit.altitude_km * 1000.0,
        inclination=math.radians(orbit.inclination_deg),
        raan=math.radians(orbit.raan_deg),
        argument_of_latitude=math.radians(orbit.argument_of_latitude_deg),
    )

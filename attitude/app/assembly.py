"""The assembly: a validated spacecraft file turned into the objects it describes (top floor).

One module builds every object the design (:mod:`attitude.app.design`), the
Monte Carlo scenarios (:mod:`attitude.app.scenarios`) and the command line
(:mod:`attitude.app.cli`) take from a
:class:`~attitude.config.model.SpacecraftConfig`: the rigid body and the hub
body, the reaction wheels, the gyro and the star tracker, the orbit and its
environment (field, atmosphere, eclipse, the surface model and the
disturbance sources), the magnetorquers and the magnetometer, the B-dot
and unloading laws with the ``[detumble]`` and ``[momentum]`` settings, the
controllers of the ``[control]`` table (quaternion PD, rate-limited PD,
tracking controller, LQR), the estimators (MEKF and rate EKF) with their
initial covariances and the tuning derived from the gyro, the keep-out cones
of the required slew and the Monte Carlo pass/fail rules of
``[requirements]``. No other module calls those constructors on file data
(``tests/attitude/app/test_assembly.py`` checks it), so the design and the scenarios
cannot drift apart.

The conversion of one table into its ground-floor object (file units to
SI) is :mod:`attitude.config.build`, which the reader also uses to prove a
file builds; this module is its only other caller.

Like the rest of :mod:`attitude.app` it may import :mod:`controllers` and
:mod:`estimation`; nothing in the ground floor imports it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.actuators import Magnetorquers, ReactionWheels
from attitude.config import ConfigError, build
from attitude.config.model import Dispersion, KeepOutConfig, SpacecraftConfig
from attitude.environment.orbit import CircularOrbit, KeplerOrbit, TLEOrbit
from attitude.environment.orbit_environment import OrbitEnvironment
from attitude.environment.surface import SurfaceModel
from attitude.flexible import FlexibleModes
from attitude.linearize import flexible_plant, linearize
from attitude.montecarlo.results import Requirement
from attitude.rigid_body import RigidBody
from attitude.sensors import GYRO_PRESETS, Gyro, Magnetometer, StarTracker
from attitude.simulation.slew_windows import SlewWindows
from attitude.sun_sensors import CoarseSunSensors, FineSunSensor
from controllers.filters import FilteredController, LowPassFilter, NotchFilter
from controllers.lqr import LQRDesign, bryson_weights, design_lqr
from controllers.magnetic import BDotController, CrossProductUnloading, bdot_gain
from controllers.pd import QuaternionPD, RateLimitedPD
from controllers.pointing import NadirPointing
from controllers.slew.keep_out import KeepOutCone
from controllers.tracking import ReferenceTrajectory, TrackingController
from controllers.worst_case import UncertaintySet
from estimation.mekf import MEKF, initial_covariance
from estimation.rate_ekf import RateEKF

__all__ = [
    "ATTITUDE_SIGMA0_DEG",
    "BIAS_SIGMA0_FLOOR_DEG_PER_H",
    "RATE_EKF_TORQUE_NOISE",
    "RATE_SIGMA0_DEG_PER_S",
    "DetumbleSettings",
    "MomentumSettings",
    "attitude_sigma0",
    "bdot_controller",
    "coarse_sun_sensors",
    "command_filtered",
    "command_filters",
    "detumble_settings",
    "direction_sensors",
    "eigenaxis_controller",
    "fine_sun_sensor",
    "flexible_modes",
    "flexible_plant_model",
    "gyro",
    "gyro_bias_sigma0",
    "hub_body",
    "judged_duration",
    "keep_out_cone",
    "lqr",
    "magnetometer",
    "magnetorquers",
    "mekf",
    "mekf_initial_covariance",
    "mekf_tracker_covariance",
    "momentum_settings",
    "monte_carlo_requirements",
    "nadir_pointing",
    "orbit",
    "orbit_environment",
    "pd_from_bandwidth",
    "quaternion_pd",
    "rate_ekf",
    "rate_ekf_initial_covariance",
    "rate_limited_pd",
    "reaction_wheels",
    "rigid_body",
    "slew_windows",
    "star_tracker",
    "surface",
    "tracking_controller",
    "uncertainty_set",
    "unloading_controller",
    "vector_mekf",
]

#: Initial attitude knowledge error of the MEKF, 1 sigma per axis [deg]: the one value of the design and
#: of the Monte Carlo scenarios (when the file does not disperse the initial attitude). The filter starts
#: from the star tracker's first attitude solution (lost-in-space acquisition): a few to a few tens of
#: arcsec about the boresight and up to about 100 arcsec in roll, plus the tracker-to-body alignment known to
#: about 100 arcsec (the default file disperses it by 10 arcsec). 0.1 deg (360 arcsec) covers that with
#: margin, and is small enough that the first update stays in the linear range of the multiplicative error.
#: 1 deg, the scenario's earlier value, is the knowledge of a coarse (Sun sensor, magnetometer) start,
#: which this spacecraft does not fly.
ATTITUDE_SIGMA0_DEG = 0.1
#: Floor of the filters' initial gyro-bias uncertainty, 1 sigma per axis [deg/h]. The filter starts from
#: zero bias, so its prior must cover the turn-on bias (run-to-run repeatability), which datasheets of MEMS
#: parts quote at several times the in-run bias instability (ADIS16470: 8 deg/h instability). The design
#: and the Monte Carlo scenarios take the same prior (:func:`gyro_bias_sigma0`).
BIAS_SIGMA0_FLOOR_DEG_PER_H = 10.0
#: Torque-uncertainty density of the rate EKF [N m / sqrt(Hz)]. The design's filter rebuilds the wheel
#: torque exactly from the tachometers and is given the flight's environment torques as its known
#: external torque (attitude.app.design.estimation), so this is only a floor that keeps the rate
#: covariance from collapsing. Measured on the default spacecraft in orbit (3 seeds x 20 runs): average
#: NEES 5.3-5.8 (band [4.58, 7.61]) with 1e-7, the same with 1e-8, 4.6 (pessimistic) with 1e-6 (40 runs).
#: A flight filter budgets here the error of its environment-torque model; a torque left out entirely
#: cannot be covered consistently by this white density (docs/rate_ekf.md, "Torque inputs").
RATE_EKF_TORQUE_NOISE = 1e-7
#: Initial rate uncertainty of the rate EKF, 1 sigma per axis [deg/s].
RATE_SIGMA0_DEG_PER_S = 0.05

_DEG_PER_H = math.pi / 180.0 / 3600.0  # [rad/s] in one deg/h


# ---------------------------------------------------------------------------
# Plant, actuators and sensors


def rigid_body(config: SpacecraftConfig) -> RigidBody:
    """The whole spacecraft (wheels included and at rest).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file; ``[inertia]`` gives the tensor [kg m^2] in body axes.

    Returns
    -------
    RigidBody
    """
    return build.rigid_body(config.inertia)


def reaction_wheels(config: SpacecraftConfig, torque_fraction: float = 1.0) -> ReactionWheels:
    """The reaction wheels of ``[wheels]``, optionally with a fraction of their torque limit.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (torque limit [N m], momentum limit [N m s], spin inertia [kg m^2]).
    torque_fraction : float
        Scale of every wheel's torque limit [-] (1: the file's); the slew
        planner plans with less than the full torque.

    Returns
    -------
    ReactionWheels
    """
    w = config.wheels_config
    if torque_fraction != 1.0:
        torque = w.torque_max_Nm
        scaled = tuple(torque_fraction * v for v in torque) if isinstance(torque, tuple) else torque_fraction * torque
        w = dataclasses.replace(w, torque_max_Nm=scaled)
    return build.reaction_wheels(w)


def hub_body(config: SpacecraftConfig) -> RigidBody:
    """The body without the wheels' spin-axis inertia (the plant to pair with the wheel states).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (inertia [kg m^2] and wheels).

    Returns
    -------
    RigidBody
    """
    return reaction_wheels(config).hub_body(rigid_body(config))


def gyro(
    config: SpacecraftConfig,
    sampling: str = "instantaneous",
    *,
    misalignment_rad: ArrayLike | None = None,
    bias_rad_per_s: ArrayLike | None = None,
    period: float | None = None,
) -> Gyro:
    """A fresh gyro of ``[gyro]`` (stateful: build one per run), optionally with dispersed errors.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (datasheet figures converted to SI by :meth:`Gyro.from_datasheet`).
    sampling : {"instantaneous", "mean"}
        The rate at the sample time (what the rate EKF models) or the mean
        rate over the interval (an integrating gyro; what the MEKF models).
    misalignment_rad : array_like (3,), optional
        Extra misalignment rotation vector [rad], added to the file's.
    bias_rad_per_s : array_like (3,), optional
        Extra turn-on bias [rad/s], added to the file's constant bias.
    period : float, optional
        Sample period [s] instead of the file's (the same noise densities;
        the determination study reads angle increments over its step).

    Returns
    -------
    Gyro
    """
    table = config.gyro_config if period is None else dataclasses.replace(config.gyro_config, period_s=float(period))
    if misalignment_rad is None and bias_rad_per_s is None:
        return build.gyro(table, sampling)
    figures = build.gyro_figures(table)
    if misalignment_rad is not None:
        figures["misalignment_rad"] = np.asarray(figures.get("misalignment_rad", np.zeros(3))) + misalignment_rad
    if bias_rad_per_s is not None:
        base = np.broadcast_to(np.asarray(figures.get("bias_deg_per_h", 0.0), dtype=float), (3,))
        figures["bias_deg_per_h"] = base + np.degrees(np.asarray(bias_rad_per_s, dtype=float)) * 3600.0
    return build.gyro(table, sampling, figures)


def star_tracker(config: SpacecraftConfig) -> StarTracker:
    """The star tracker of ``[star_tracker]``, blinded by ``environment.sun_direction_N`` when given.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (noise [arcsec], period [s], Sun exclusion [deg]).

    Returns
    -------
    StarTracker
    """
    return build.star_tracker(config.star_tracker_config, config.environment.sun_direction_N)


def orbit(config: SpacecraftConfig) -> CircularOrbit | KeplerOrbit | TLEOrbit | None:
    """The orbit of ``[orbit]`` by its ``kind`` (file units km and deg; SI built), or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    CircularOrbit, KeplerOrbit, TLEOrbit or None
        None without an ``[orbit]`` table; its ``epoch`` is ``orbit.epoch_utc`` (the TLE's own for a TLE).
    """
    return None if config.orbit_config is None else build.orbit(config.orbit_config)


def surface(config: SpacecraftConfig) -> SurfaceModel | None:
    """The flat-plate surface model of ``[surface]`` (areas [m^2], centres of pressure [m], dipole [A m^2]).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    SurfaceModel or None
        None without a ``[surface]`` table.
    """
    return None if config.surface is None else build.surface_model(config.surface)


def orbit_environment(
    config: SpacecraftConfig, orbit: CircularOrbit | KeplerOrbit | TLEOrbit | None = None
) -> OrbitEnvironment | None:
    """The orbit environment of ``[orbit]``, ``[environment]`` and ``[surface]``, or None without an orbit.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (field, atmosphere and eclipse models, the
        disturbance sources, the sample period [s]).
    orbit : orbit, optional
        The orbit to fly, e.g. one already built by :func:`orbit` (default: built here).

    Returns
    -------
    OrbitEnvironment or None
        With the file's sources, or when it leaves them out
        :func:`attitude.config.build.default_sources` (all four with a
        ``[surface]``, gravity gradient alone without).
    """
    if config.orbit_config is None:
        return None
    return build.orbit_environment(config.orbit_config, config.environment, config.surface, orbit)


def magnetorquers(config: SpacecraftConfig) -> Magnetorquers | None:
    """The torque rods of ``[magnetorquers]`` (dipole limits [A m^2]), or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    Magnetorquers or None
        None without a ``[magnetorquers]`` table.
    """
    c = config.magnetorquers_config
    return None if c is None else build.magnetorquers(c)


def magnetometer(config: SpacecraftConfig, *, period: float | None = None) -> Magnetometer | None:
    """The magnetometer of ``[magnetometer]`` (nT, ppm and deg in the file; SI built), or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    period : float, optional
        Sample period [s] instead of the file's ``period_s`` (the detumbling
        study reads the sensor at the B-dot law's period, the only samples the
        law uses).

    Returns
    -------
    Magnetometer or None
        None without a ``[magnetometer]`` table.
    """
    c = config.magnetometer_config
    if c is None:
        return None
    if period is not None:
        c = dataclasses.replace(c, period_s=float(period))
    return build.magnetometer(c)


def coarse_sun_sensors(config: SpacecraftConfig) -> CoarseSunSensors | None:
    """The cells of ``[coarse_sun_sensors]`` (percent of full scale and deg in the file), or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    CoarseSunSensors or None
        None without a ``[coarse_sun_sensors]`` table.
    """
    c = config.coarse_sun_sensors_config
    return None if c is None else build.coarse_sun_sensors(c)


def direction_sensors(config: SpacecraftConfig, *, white_noise_only: bool = False) -> dict[str, Any]:
    """The file's direction sensors by table name (None where the file has none).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    white_noise_only : bool
        Build them with their white noise alone: no magnetometer bias, scale
        factor, misalignment or quantisation, no fine-sensor bias, no albedo
        on the coarse cells (the errors the estimators model).

    Returns
    -------
    dict
        ``{"magnetometer": Magnetometer, "coarse_sun_sensors": CoarseSunSensors,
        "fine_sun_sensor": FineSunSensor}``, each None without its table.
    """
    mag, coarse, fine = config.magnetometer_config, config.coarse_sun_sensors_config, config.fine_sun_sensor_config
    if white_noise_only:
        if mag is not None:
            mag = dataclasses.replace(
                mag, bias_nT=0.0, scale_factor_ppm=0.0, misalignment_deg=(0.0, 0.0, 0.0), quantization_nT=0.0
            )
        if coarse is not None:
            coarse = dataclasses.replace(coarse, albedo_percent=0.0)
        if fine is not None:
            fine = dataclasses.replace(fine, bias_deg=0.0)
    return {
        "magnetometer": None if mag is None else build.magnetometer(mag),
        "coarse_sun_sensors": None if coarse is None else build.coarse_sun_sensors(coarse),
        "fine_sun_sensor": None if fine is None else build.fine_sun_sensor(fine),
    }


def fine_sun_sensor(config: SpacecraftConfig) -> FineSunSensor | None:
    """The sensor of ``[fine_sun_sensor]`` (deg in the file), or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    FineSunSensor or None
        None without a ``[fine_sun_sensor]`` table.
    """
    c = config.fine_sun_sensor_config
    return None if c is None else build.fine_sun_sensor(c)


def flexible_modes(config: SpacecraftConfig) -> FlexibleModes | None:
    """The constrained appendage modes of ``[[flexible_modes]]`` (Hz in the file), or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    FlexibleModes or None
        None without ``[[flexible_modes]]`` entries (a rigid spacecraft).
    """
    return build.flexible_modes(config.flexible_modes)


def flexible_plant_model(config: SpacecraftConfig) -> control.StateSpace | None:
    """The linear model at rest of the file's flexible spacecraft (:func:`attitude.linearize.flexible_plant`), or None.

    The whole spacecraft's inertia (:func:`rigid_body`) with its modes, in the
    coordinates of ``controllers.analysis.rigid_body_at_rest`` (outputs
    ``[q_v, omega]``), so ``loop_gain(plant, controller)`` takes it.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    control.StateSpace or None
        None without ``[[flexible_modes]]`` entries.
    """
    modes = flexible_modes(config)
    return None if modes is None else flexible_plant(rigid_body(config), modes)


@dataclass(frozen=True)
class DetumbleSettings:
    """The ``[detumble]`` study in SI, with the B-dot gain resolved.

    Parameters
    ----------
    tip_off_rate : ndarray (3,)
        Body rate after separation [rad/s].
    rate_threshold : float
        Detumbled below this rate magnitude [rad/s].
    gain : float
        Gain ``k`` of the normalised B-dot law ``m = -(k/|B|) db/dt`` [N m s].
    gain_is_auto : bool
        The gain is :func:`controllers.magnetic.bdot_gain` (the file says ``"auto"``).
    period : float
        Sample period of the law [s].
    duration_max : float
        Longest detumbling simulated [s]: ``duration_max_orbits`` orbital periods.
    duration_max_orbits : float
        The same, in orbits.
    """

    tip_off_rate: NDArray[np.float64]
    rate_threshold: float
    gain: float
    gain_is_auto: bool
    period: float
    duration_max: float
    duration_max_orbits: float


@dataclass(frozen=True)
class MomentumSettings:
    """The ``[momentum]`` budget and unloading in SI.

    Parameters
    ----------
    unloading_gain : float or None
        Gain ``k`` of the cross-product unloading law [1/s]; None: no unloading.
    period : float
        Sample period of the unloading law [s].
    orbits : int
        Length of the budget [orbits].
    duration : float
        Length of the budget [s]: ``orbits`` orbital periods.
    wheel_momentum_margin : float
        Fraction of the wheels' momentum capacity the stored momentum may use.
    """

    unloading_gain: float | None
    period: float
    orbits: int
    duration: float
    wheel_momentum_margin: float


def _inclination(the_orbit: Any) -> float:
    """Inclination of an orbit [rad]: its own, else from the angular momentum ``r x v`` at t = 0."""
    if hasattr(the_orbit, "inclination"):
        return float(the_orbit.inclination)
    h = np.cross(np.asarray(the_orbit.position_N(0.0), dtype=float), np.asarray(the_orbit.velocity_N(0.0), dtype=float))
    return float(np.arccos(np.clip(h[2] / np.linalg.norm(h), -1.0, 1.0)))


def detumble_settings(config: SpacecraftConfig, body: RigidBody | None = None) -> DetumbleSettings | None:
    """The ``[detumble]`` study in SI, the ``"auto"`` gain from the orbit and the inertia, or None.

    ``gain_Nms = "auto"`` is :func:`controllers.magnetic.bdot_gain`,
    ``k = 2 n (1 + sin xi_m) J_min`` (Avanzini and Giulietti 2012), with the
    orbit's mean motion and, for ``xi_m``, its geographic inclination.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (rates in deg/s, gain in N m s, duration in orbits).
    body : RigidBody, optional
        The inertia of the gain [kg m^2] (default: the file's, :func:`rigid_body`).

    Returns
    -------
    DetumbleSettings or None
        None without a ``[detumble]`` table.
    """
    d = config.detumble
    if d is None:
        return None
    the_orbit = orbit(config)
    if d.gain_Nms == "auto":
        body = rigid_body(config) if body is None else body
        gain = bdot_gain(the_orbit, body, magnetic_inclination=_inclination(the_orbit))
    else:
        gain = float(d.gain_Nms)
    return DetumbleSettings(
        tip_off_rate=np.radians(np.broadcast_to(np.array(d.tip_off_rate_deg_per_s, dtype=np.float64), (3,))),
        rate_threshold=math.radians(d.rate_threshold_deg_per_s),
        gain=float(gain),
        gain_is_auto=d.gain_Nms == "auto",
        period=d.period_s,
        duration_max=d.duration_max_orbits * float(the_orbit.period),
        duration_max_orbits=d.duration_max_orbits,
    )


def bdot_controller(config: SpacecraftConfig, *, use_truth_field: bool = False) -> BDotController | None:
    """The ``[detumble]`` B-dot law on the file's rods and magnetometer, or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    use_truth_field : bool
        Read the true field instead of the magnetometer (design studies).

    Returns
    -------
    BDotController or None
        The normalised law (``law="unit"``) with :func:`detumble_settings`' gain [N m s] and
        period [s], limited by :func:`magnetorquers`; None without a ``[detumble]`` table.
    """
    settings = detumble_settings(config)
    if settings is None:
        return None
    return BDotController(
        settings.gain,
        period=settings.period,
        magnetorquers=magnetorquers(config),
        law="unit",
        use_truth_field=use_truth_field,
    )


def momentum_settings(config: SpacecraftConfig) -> MomentumSettings | None:
    """The ``[momentum]`` budget and unloading in SI, or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (gain in 1/s, length in orbits).

    Returns
    -------
    MomentumSettings or None
        None without a ``[momentum]`` table.
    """
    m = config.momentum
    if m is None:
        return None
    the_orbit = orbit(config)
    return MomentumSettings(
        unloading_gain=m.unloading_gain_per_s,
        period=m.period_s,
        orbits=m.orbits,
        duration=m.orbits * float(the_orbit.period),
        wheel_momentum_margin=m.wheel_momentum_margin,
    )


def unloading_controller(
    config: SpacecraftConfig, *, use_truth_field: bool = False, period: float | None = None
) -> CrossProductUnloading | None:
    """The ``[momentum]`` cross-product unloading law on the file's rods, or None.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    use_truth_field : bool
        Read the true field instead of the magnetometer (design studies).
    period : float, optional
        Sample period [s] instead of ``momentum.period_s`` (the design's
        nadir-hold run samples it with the attitude controller, so that the
        compiled engine folds both into one step).

    Returns
    -------
    CrossProductUnloading or None
        Gain [1/s] and period [s] of ``[momentum]``, target momentum zero,
        limited by :func:`magnetorquers`; None without ``momentum.unloading_gain_per_s``.
    """
    settings = momentum_settings(config)
    if settings is None or settings.unloading_gain is None:
        return None
    return CrossProductUnloading(
        settings.unloading_gain,
        period=settings.period if period is None else float(period),
        magnetorquers=magnetorquers(config),
        use_truth_field=use_truth_field,
    )


# ---------------------------------------------------------------------------
# Controllers of the [control] table


def nadir_pointing(config: SpacecraftConfig, the_orbit: Any, body: RigidBody | None = None) -> NadirPointing:
    """Nadir (LVLH) hold with the ``[control]`` bandwidth, damping and period.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    the_orbit : object
        The orbit whose LVLH frame is held (:func:`orbit`).
    body : RigidBody, optional
        Design inertia (default :func:`rigid_body`).

    Returns
    -------
    NadirPointing
        Body axes on the LVLH axes (roll along the velocity, yaw to nadir).
    """
    c = config.control
    return NadirPointing(
        the_orbit,
        rigid_body(config) if body is None else body,
        wn=c.bandwidth_rad_per_s,
        zeta=c.damping,
        period=c.period_s,
    )


def uncertainty_set(config: SpacecraftConfig) -> UncertaintySet | None:
    """The ``[uncertainty]`` table's set for the worst-case search (None without the table).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (moments [%], axis rotation [deg], wheel misalignment [deg], extra delay [s]).

    Returns
    -------
    UncertaintySet or None
    """
    u = config.uncertainty
    if u is None:
        return None
    return UncertaintySet(
        inertia_percent=u.inertia_percent,
        axis_rotation_deg=u.axis_rotation_deg,
        wheel_misalignment_deg=u.wheel_misalignment_deg,
        extra_delay_s=u.extra_delay_s,
    )


def pd_from_bandwidth(
    body: RigidBody,
    *,
    bandwidth_rad_per_s: ArrayLike,
    damping: ArrayLike,
    period_s: float,
    q_ref: ArrayLike | None = None,
) -> QuaternionPD:
    """The quaternion PD with gyroscopic compensation placed at a bandwidth and damping.

    Parameters
    ----------
    body : RigidBody
        The inertia the gains are designed on [kg m^2].
    bandwidth_rad_per_s : float or array_like (3,)
        Natural frequency, one or per body axis [rad/s].
    damping : float or array_like (3,)
        Damping ratio, one or per body axis [-].
    period_s : float
        Controller sample period [s].
    q_ref : array_like (4,), optional
        Reference attitude ``q_BN`` (scalar first); the controller's default when None.

    Returns
    -------
    QuaternionPD
    """
    kw: dict[str, Any] = {} if q_ref is None else {"q_ref": q_ref}
    return QuaternionPD.from_bandwidth(
        body, wn=bandwidth_rad_per_s, zeta=damping, period=period_s, gyroscopic=True, **kw
    )


def quaternion_pd(
    config: SpacecraftConfig, body: RigidBody | None = None, q_ref: ArrayLike | None = None
) -> QuaternionPD:
    """The ``[control]`` table's quaternion PD (bandwidth [rad/s], damping, period [s]).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    body : RigidBody, optional
        The inertia to design on [kg m^2] (default: the file's, :func:`rigid_body`).
    q_ref : array_like (4,), optional
        Reference attitude ``q_BN``.

    Returns
    -------
    QuaternionPD
    """
    c = config.control
    body = rigid_body(config) if body is None else body
    return pd_from_bandwidth(
        body, bandwidth_rad_per_s=c.bandwidth_rad_per_s, damping=c.damping, period_s=c.period_s, q_ref=q_ref
    )


def rate_limited_pd(
    config: SpacecraftConfig,
    *,
    rate_max_rad_per_s: float,
    body: RigidBody | None = None,
    q_ref: ArrayLike | None = None,
) -> RateLimitedPD:
    """The ``[control]`` table's Wie-Lu rate-limited quaternion PD.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (bandwidth [rad/s], damping, period [s]).
    rate_max_rad_per_s : float
        Body-rate limit [rad/s].
    body : RigidBody, optional
        The inertia to design on [kg m^2] (default: the file's).
    q_ref : array_like (4,), optional
        Reference attitude ``q_BN``.

    Returns
    -------
    RateLimitedPD
    """
    c = config.control
    if c.per_axis:
        raise ConfigError(
            "the rate-limited eigenaxis PD (requirements.slew.rate_max_deg_per_s without a planned slew) needs one "
            f"bandwidth and damping for all axes (K = k J keeps the eigenaxis), got {c.bandwidth_rad_per_s} rad/s "
            f"and {c.damping}",
            "control.bandwidth_rad_per_s",
            config.source or "<config>",
        )
    body = rigid_body(config) if body is None else body
    kw: dict[str, Any] = {} if q_ref is None else {"q_ref": q_ref}
    return RateLimitedPD.from_bandwidth(
        body, wn=c.bandwidth_rad_per_s, zeta=c.damping, rate_max=rate_max_rad_per_s, period=c.period_s, **kw
    )


def eigenaxis_controller(
    config: SpacecraftConfig, body: RigidBody, q_target: ArrayLike, rate_margin: float = 1.0
) -> QuaternionPD | RateLimitedPD:
    """The eigenaxis slew controller: rate-limited PD at ``rate_margin`` of the slew limit, else the PD.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (``[control]`` and ``requirements.slew.rate_max_deg_per_s``).
    body : RigidBody
        The inertia to design on [kg m^2].
    q_target : array_like (4,)
        Target attitude ``q_BN``.
    rate_margin : float
        Fraction of the required rate limit the controller holds [-].

    Returns
    -------
    QuaternionPD or RateLimitedPD
    """
    rate_max = config.requirements.slew.rate_max_rad_per_s
    if rate_max is not None:
        return rate_limited_pd(config, rate_max_rad_per_s=rate_margin * rate_max, body=body, q_ref=q_target)
    return quaternion_pd(config, body, q_target)


def tracking_controller(
    config: SpacecraftConfig,
    reference: ReferenceTrajectory,
    body: RigidBody | None = None,
    feedforward: ReferenceTrajectory | None = None,
) -> TrackingController:
    """The ``[control]`` table's tracking controller (bandwidth [rad/s], damping, period [s]).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    reference : ReferenceTrajectory
        The attitude, rate [rad/s] and acceleration [rad/s^2] to follow.
    body : RigidBody, optional
        The inertia to design on [kg m^2] (default: the file's).
    feedforward : ReferenceTrajectory, optional
        The torque feedforward [N m] (a planned slew).

    Returns
    -------
    TrackingController
    """
    c = config.control
    body = rigid_body(config) if body is None else body
    return TrackingController(
        reference, body, wn=c.bandwidth_rad_per_s, zeta=c.damping, period=c.period_s, feedforward=feedforward
    )


def command_filters(config: SpacecraftConfig) -> list[tuple[list[NotchFilter | LowPassFilter], tuple[int, ...]]]:
    """The ``[[control.filters]]`` as chains: consecutive filters on the same axes make one chain.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (frequencies in Hz there, rad/s here).

    Returns
    -------
    list of (filters, axes)
        In the file's order; axes as body indices 0, 1, 2. Empty without filters.
    """
    chains: list[tuple[list[NotchFilter | LowPassFilter], tuple[int, ...]]] = []
    for f in config.control.filters:
        w = 2.0 * np.pi * f.frequency_Hz
        made = (
            NotchFilter(frequency=w, zeta_pole=f.damping, depth=f.depth)
            if f.kind == "notch"
            else LowPassFilter(frequency=w, order=f.order, damping=f.damping)
        )
        axes = tuple(sorted("xyz".index(a) for a in f.axes))
        if chains and chains[-1][1] == axes:
            chains[-1][0].append(made)
        else:
            chains.append(([made], axes))
    return chains


def command_filtered(config: SpacecraftConfig, controller: Any) -> Any:
    """The controller with the file's ``[[control.filters]]`` on its command (itself without filters).

    Chains on different axes nest, the first in the file innermost
    (:class:`controllers.filters.FilteredController`), so the loop analysis and the simulation see the filters
    in the file's order.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    controller : Controller
        The law whose torque command is filtered (with a ``period`` [s]).

    Returns
    -------
    Controller
    """
    for filters, axes in command_filters(config):
        controller = FilteredController(controller, filters, axes=axes)
    return controller


def lqr(config: SpacecraftConfig, body: RigidBody | None = None) -> tuple[Any, LQRDesign] | None:
    """The ``[control.lqr]`` design: Bryson's-rule weights on the linearised plant, at the control period.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (bounds: angle [deg], rate [deg/s], torque [N m]; period [s]).
    body : RigidBody, optional
        The inertia to design on [kg m^2] (default: the file's).

    Returns
    -------
    (plant, LQRDesign) or None
        The linearised plant (:func:`attitude.linearize.linearize`) and the
        discrete LQR; None without a ``[control.lqr]`` table.
    """
    c = config.control
    if c.lqr is None:
        return None
    body = rigid_body(config) if body is None else body
    q_w, r_w = bryson_weights(angle_max=c.lqr.angle_max, rate_max=c.lqr.rate_max, torque_max=c.lqr.torque_max)
    plant = linearize(body)
    return plant, design_lqr(plant, Q=q_w, R=r_w, period=c.period_s)


# ---------------------------------------------------------------------------
# Estimators and their initial covariances


def attitude_sigma0(dispersion: Dispersion | None = None) -> float:
    """Initial attitude uncertainty of the MEKF, 1 sigma per axis [rad].

    :data:`ATTITUDE_SIGMA0_DEG`, unless the start attitude is dispersed
    about the one the filter starts from (a Monte Carlo campaign): then the
    filter's initial error is that dispersion, and its standard deviation.

    Parameters
    ----------
    dispersion : Dispersion, optional
        ``[montecarlo] initial_attitude`` (scale in deg): ``normal`` gives its
        sigma, ``uniform`` on [-h, h] gives h / sqrt(3), ``uniform_so3``
        (any attitude: the tracker's first update decides it) gives pi. A
        zero scale or None gives :data:`ATTITUDE_SIGMA0_DEG`.

    Returns
    -------
    float
        [rad]
    """
    if dispersion is not None and dispersion.distribution == "uniform_so3":
        return math.pi
    spread = None if dispersion is None else dispersion.scale_si
    if not spread:
        return math.radians(ATTITUDE_SIGMA0_DEG)
    if dispersion.distribution == "uniform":
        return spread / math.sqrt(3.0)  # standard deviation of U(-h, h)
    return spread


def gyro_bias_sigma0(config: SpacecraftConfig) -> float:
    """Initial gyro-bias uncertainty of the filters (MEKF and rate EKF), 1 sigma per axis [rad/s].

    The filters start from zero bias. Their uncertainty covers the largest of:
    :data:`BIAS_SIGMA0_FLOOR_DEG_PER_H`, the gyro's bias instability (file or
    preset), the file's largest constant bias, and the dispersed turn-on bias
    (``[montecarlo] gyro_bias``). One rule for the design and the Monte Carlo
    scenarios, so both start from the same knowledge.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (``[gyro]`` figures and dispersion in deg/h).

    Returns
    -------
    float
        [rad/s]
    """
    g = config.gyro_config
    figure = g.bias_instability_deg_per_h
    if figure is None and g.preset is not None and g.rrw_deg_per_h_per_sqrt_h is None:
        figure = GYRO_PRESETS[g.preset]["figures"].get("bias_instability_deg_per_h")
    largest_deg_per_h = max(
        BIAS_SIGMA0_FLOOR_DEG_PER_H, 0.0 if figure is None else float(figure), _constant_bias_deg_per_h(config)
    )
    mc = config.montecarlo
    dispersed = math.sqrt(_variance(None if mc is None else mc.gyro_bias))
    return max(largest_deg_per_h * _DEG_PER_H, dispersed)


def mekf_initial_covariance(*, attitude_sigma_rad: float, bias_sigma_rad_per_s: float) -> NDArray[np.float64]:
    """The MEKF's initial covariance: diagonal, attitude then bias (6, 6).

    Parameters
    ----------
    attitude_sigma_rad : float
        Attitude error, 1 sigma per axis [rad] (:func:`attitude_sigma0`).
    bias_sigma_rad_per_s : float
        Gyro-bias error, 1 sigma per axis [rad/s].

    Returns
    -------
    ndarray (6, 6)
        [rad^2, (rad/s)^2]
    """
    return initial_covariance(attitude_sigma=attitude_sigma_rad, bias_sigma=bias_sigma_rad_per_s)


def mekf(
    gyro: Gyro,
    tracker: StarTracker,
    q0: ArrayLike,
    P0: ArrayLike,
    tracker_covariance: ArrayLike | None = None,
) -> MEKF:
    """The MEKF matched to a gyro and a star tracker: their noise figures, period and names.

    Parameters
    ----------
    gyro : Gyro
        An integrating (``sampling="mean"``) gyro: ARW [rad/sqrt(s)], RRW [rad/s^(3/2)], period [s].
    tracker : StarTracker
        The star tracker (covariance [rad^2] in body axes).
    q0 : array_like (4,)
        Initial attitude estimate ``q_BN``.
    P0 : array_like (6, 6)
        Initial covariance [rad^2, (rad/s)^2] (:func:`mekf_initial_covariance`).
    tracker_covariance : array_like (3, 3), optional
        Measurement covariance [rad^2] to use instead of the tracker's (a
        consider-style inflation for its misalignment).

    Returns
    -------
    MEKF
    """
    if tracker_covariance is None:
        return MEKF.from_sensors(gyro, tracker, q0=q0, P0=P0)
    return MEKF(
        sigma_v=gyro.sigma_v,
        sigma_u=gyro.filter_sigma_u,
        tracker_covariance=tracker_covariance,
        period=gyro.period,
        q0=q0,
        P0=P0,
        gyro_name=gyro.name,
        tracker_name=tracker.name,
    )


def vector_mekf(gyro: Gyro, q0: ArrayLike, P0: ArrayLike, vector_names: Sequence[str]) -> MEKF:
    """An MEKF on a gyro and direction sensors alone (no star tracker).

    Parameters
    ----------
    gyro : Gyro
        An integrating (``sampling="mean"``) gyro: ARW, RRW and period.
    q0 : array_like (4,)
        Initial attitude estimate ``q_BN``.
    P0 : array_like (6, 6)
        Initial covariance (:func:`mekf_initial_covariance`).
    vector_names : sequence of str
        The direction sensors' names, in the order the filter applies them.

    Returns
    -------
    MEKF
    """
    return MEKF(
        sigma_v=gyro.sigma_v,
        sigma_u=gyro.filter_sigma_u,
        tracker_covariance=np.eye(3),  # no tracker flies: never used
        period=gyro.period,
        q0=q0,
        P0=P0,
        gyro_name=gyro.name,
        vector_names=tuple(vector_names),
    )


def tracker_misalignment_covariance(config: SpacecraftConfig) -> NDArray[np.float64]:
    """Covariance of the star tracker's mounting error [rad^2], body axes (3, 3): zero when it is not dispersed.

    The per-axis variance of ``[montecarlo] star_tracker_misalignment``. With
    one attitude sensor the mounting rotation cannot be told from the
    attitude (every measurement carries it alike), so the MEKF converges to
    the tracker's frame and the true attitude error is the filter's error
    plus the misalignment, independent of it: the Schmidt 'consider'
    covariance of an unestimated bias (Markley & Crassidis, *Fundamentals of
    Spacecraft Attitude Determination and Control*, 2014, ch. 6, on
    calibrating sensor alignments). The campaign's NEES adds it to the
    filter's attitude covariance.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.

    Returns
    -------
    ndarray (3, 3)
        [rad^2]
    """
    mc = config.montecarlo
    return _variance(None if mc is None else mc.star_tracker_misalignment) * np.eye(3)


def mekf_tracker_covariance(
    config: SpacecraftConfig, tracker: StarTracker, consider_misalignment: bool = False
) -> NDArray[np.float64]:
    """The star-tracker covariance the MEKF uses [rad^2], body axes (3, 3).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    tracker : StarTracker
        The tracker (its :attr:`~attitude.sensors.StarTracker.covariance_B`).
    consider_misalignment : bool
        Add the variance of the tracker-misalignment dispersion
        (``[montecarlo] star_tracker_misalignment``, arcsec in the file) on
        every axis: the filter then treats the unknown mounting error as
        extra noise.

    Returns
    -------
    ndarray (3, 3)
        [rad^2]
    """
    cov = np.array(tracker.covariance_B, dtype=float)
    if consider_misalignment:
        cov += tracker_misalignment_covariance(config)
    return cov


def rate_ekf_initial_covariance(config: SpacecraftConfig) -> NDArray[np.float64]:
    """The rate EKF's initial covariance: :data:`RATE_SIGMA0_DEG_PER_S` and the gyro-bias sigma (6, 6).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (gyro figures for the bias sigma, deg/h).

    Returns
    -------
    ndarray (6, 6)
        [(rad/s)^2]
    """
    sig_w0 = math.radians(RATE_SIGMA0_DEG_PER_S)
    sig_b0 = gyro_bias_sigma0(config)
    return np.diag([sig_w0**2] * 3 + [sig_b0**2] * 3)


def rate_ekf(
    config: SpacecraftConfig,
    gyro: Gyro,
    x0: ArrayLike,
    t0: float,
    wheels: ReactionWheels | None = None,
    body: RigidBody | None = None,
) -> RateEKF:
    """The rate EKF on the file's body and wheels, tuned from an instantaneous-sampling gyro.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    gyro : Gyro
        The gyro whose ARW [rad/sqrt(s)], RRW [rad/s^(3/2)] and period [s] tune the filter.
    x0 : array_like (6,)
        Initial rate [rad/s] and bias [rad/s] estimate.
    t0 : float
        Time of ``x0`` [s].
    wheels : ReactionWheels, optional
        Default: the file's.
    body : RigidBody, optional
        Default: the file's [kg m^2].

    Returns
    -------
    RateEKF
        With :data:`RATE_EKF_TORQUE_NOISE` [N m/sqrt(Hz)] and :func:`rate_ekf_initial_covariance`.
    """
    return RateEKF.from_gyro(
        rigid_body(config) if body is None else body,
        gyro,
        torque_noise=RATE_EKF_TORQUE_NOISE,
        P0=rate_ekf_initial_covariance(config),
        x0=x0,
        wheels=reaction_wheels(config) if wheels is None else wheels,
        t0=t0,
    )


# ---------------------------------------------------------------------------
# Requirements


def keep_out_cone(cone: KeepOutConfig, margin_deg: float = 0.0) -> KeepOutCone:
    """A ``[[requirements.keep_out]]`` cone for the slew planner, optionally widened.

    Parameters
    ----------
    cone : KeepOutConfig
        Boresight (body axes), direction (inertial axes), half-angle [deg].
    margin_deg : float
        Added to the half-angle [deg].

    Returns
    -------
    KeepOutCone
    """
    return KeepOutCone.from_degrees(cone.boresight_B, cone.direction_N, cone.half_angle_deg + margin_deg, cone.name)


def slew_windows(config: SpacecraftConfig, slew_end_s: float | None = None) -> SlewWindows:
    """The time windows the file's slew requirements are judged over (:mod:`attitude.simulation.slew_windows`).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (its ``[requirements]``).
    slew_end_s : float, optional
        End of the planned slew [s]; None (a guidance that plans no slew, straight to the target): the
        allowed slew time ``requirements.slew.time_max_s``.

    Returns
    -------
    SlewWindows
    """
    req = config.requirements
    return SlewWindows(
        slew_end_s=req.slew.time_max_s if slew_end_s is None else slew_end_s,
        settling_time_s=req.settling_time_s,
        hold_time_s=req.hold_time_judged_s,
        accuracy_rad=req.pointing_accuracy_rad,
    )


def judged_duration(config: SpacecraftConfig, slew_end_s: float | None = None) -> float:
    """The shortest closed-loop run that judges every slew requirement: to the end of the hold [s].

    Rounded up to a whole number of the shortest sample period (controller, gyro, star tracker), the
    engine's tick.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    slew_end_s : float, optional
        End of the planned slew [s] (None: no plan, see :func:`slew_windows`).
    """
    tick = min(config.control.period_s, config.gyro_config.period_s, config.star_tracker_config.period_s)
    end = slew_windows(config, slew_end_s).hold_end_s
    return round(math.ceil(end / tick - 1e-9) * tick, 9)


def monte_carlo_requirements(config: SpacecraftConfig, *, keep_out: bool = True) -> tuple[Requirement, ...]:
    """The file's ``[requirements]`` as Monte Carlo pass/fail rules on the metrics (SI).

    The same rows, metrics and windows as the design's requirement table
    (:mod:`attitude.simulation.slew_windows`, all on the error to the
    target attitude): ``slew_time``: ``slew_time`` (the flown slew time,
    from the start of the run) <= ``slew.time_max_s``; ``settling``:
    ``settling_after_slew`` <= ``settling_time_s``; ``pointing``:
    ``pointing_error_hold`` (largest error over the hold) <= the pointing
    accuracy [rad]; ``rate``: peak rate <= the slew rate limit [rad/s] (when
    given); ``keep_out.<name>``: margin >= 0 [rad] for each keep-out cone.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    keep_out : bool
        False leaves the cones out, for a guidance that does not plan around
        them (``ClosedLoopScenario(guidance="eigenaxis")``).

    Returns
    -------
    tuple of Requirement
    """
    req = config.requirements
    out = [
        Requirement("slew_time", max=req.slew.time_max_s, name="slew_time"),
        Requirement("settling_after_slew", max=req.settling_time_s, name="settling"),
        Requirement("pointing_error_hold", max=req.pointing_accuracy_rad, name="pointing"),
    ]
    if req.slew.rate_max_rad_per_s is not None:
        out.append(Requirement("rate_peak", max=req.slew.rate_max_rad_per_s, name="rate"))
    if keep_out:
        for cone in req.keep_out:
            out.append(Requirement(f"keep_out_margin.{cone.name}", min=0.0, name=f"keep_out.{cone.name}"))
    return tuple(out)


def _constant_bias_deg_per_h(config: SpacecraftConfig) -> float:
    """Largest constant gyro bias of the file, any axis [deg/h] (0 when none)."""
    b = config.gyro_config.bias_deg_per_h
    return 0.0 if b is None else float(np.max(np.abs(np.atleast_1d(b))))


def _variance(entry: Dispersion | None) -> float:
    """Per-axis variance [SI^2] of a ``[montecarlo]`` dispersion (0 when absent)."""
    if entry is None or not entry.scale_si:
        return 0.0
    s = float(entry.scale_si)
    return s * s if entry.distribution == "normal" else s * s / 3.0  # U(-h, h): h^2 / 3

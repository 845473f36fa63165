"""The validated spacecraft description: frozen dataclasses that mirror the file, key for key.

One dataclass per table (:class:`InertiaConfig`, :class:`WheelsConfig`,
:class:`GyroConfig`, :class:`StarTrackerConfig`, :class:`ControlConfig`,
:class:`OrbitConfig`, :class:`EnvironmentConfig`,
:class:`RequirementsConfig`, :class:`MonteCarloConfig`) and
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
from attitude.sensors import ARCSEC, STAR_TRACKER_PRESETS

__all__ = [
    "GYRO_FIGURES",
    "PYRAMID_ELEVATION_DEG",
    "WHEEL_LAYOUTS",
    "ControlConfig",
    "Dispersion",
    "EnvironmentConfig",
    "GyroConfig",
    "InertiaConfig",
    "KeepOutConfig",
    "LQRBounds",
    "MonteCarloConfig",
    "OrbitConfig",
    "PerWheel",
    "RequirementsConfig",
    "SlewRequirement",
    "SpacecraftConfig",
    "StarTrackerConfig",
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
    """The ``[wheels]`` table (units in the field names; per-wheel values as tuples)."""

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
    """The ``[gyro]`` table: a preset grade and/or datasheet figures (figures override the preset)."""

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
    """The ``[star_tracker]`` table: a preset and/or datasheet figures (figures override the preset)."""

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
    """The ``[control.lqr]`` table: Bryson's-rule bounds (one value or one per axis)."""

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
    """The ``[control]`` table: sample period [s], PD bandwidth [rad/s] and damping, optional LQR bounds."""

    period_s: float
    bandwidth_rad_per_s: float
    damping: float
    lqr: LQRBounds | None = None


@dataclass(frozen=True)
class OrbitConfig:
    """The ``[orbit]`` table: a circular Earth orbit (angles in degrees, altitude in km)."""

    altitude_km: float
    inclination_deg: float = 0.0
    raan_deg: float = 0.0
    argument_of_latitude_deg: float = 0.0


@dataclass(frozen=True)
class EnvironmentConfig:
    """The ``[environment]`` table: the inertial Sun direction (as written; normalise to use)."""

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
        """Angle [rad] between the boresight and the direction at attitudes ``q_BN`` (..., 4)."""
        b = np.array(self.boresight_B, dtype=np.float64)
        d = np.array(self.direction_N, dtype=np.float64)
        b_N = quat.rotate(quat.normalize(q_BN), b / np.linalg.norm(b))
        return np.arccos(np.clip(b_N @ (d / np.linalg.norm(d)), -1.0, 1.0))


@dataclass(frozen=True)
class RequirementsConfig:
    """The ``[requirements]`` table."""

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
    """The ``[montecarlo]`` table: runs, master seed and the dispersions (None: not dispersed)."""

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

    Each table is a field of the same name, except ``[wheels]``
    (:attr:`wheels_config`), ``[gyro]`` (:attr:`gyro_config`),
    ``[star_tracker]`` (:attr:`star_tracker_config`) and ``[orbit]``
    (:attr:`orbit_config`), whose names are those of the objects
    :mod:`attitude.app.assembly` builds from them. Values keep the units of
    their key names; the builders (:mod:`attitude.config.build`) convert to
    SI. ``source`` (the file it came from) is not part of equality.
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


# ---------------------------------------------------------------------------

"""The space environment at the spacecraft: epochs, orbits, the Sun and the shadow, and the disturbance torques."""

from attitude.environment.epoch import DEFAULT_EPOCH, Epoch, ecef_to_N
from attitude.environment.gravity_gradient import (
    GravityGradientStability,
    constant_plus_orbital_disturbance,
    gravity_gradient_stability,
    gravity_gradient_torque,
    gravity_gradient_torque_components,
    gravity_gradient_torque_function,
    linearize_gravity_gradient,
    lvlh_relative_dynamics,
)
from attitude.environment.orbit import (
    MU_EARTH,
    R_EARTH,
    CircularOrbit,
    KeplerOrbit,
    Orbit,
    TLEOrbit,
    lvlh_attitude,
    solve_kepler,
)
from attitude.environment.sun import (
    AU_M,
    SUN_RADIUS_M,
    illumination_fraction,
    sun_direction_N,
    sun_position_N,
)

__all__ = [
    "AU_M",
    "DEFAULT_EPOCH",
    "MU_EARTH",
    "R_EARTH",
    "SUN_RADIUS_M",
    "CircularOrbit",
    "Epoch",
    "GravityGradientStability",
    "KeplerOrbit",
    "Orbit",
    "TLEOrbit",
    "constant_plus_orbital_disturbance",
    "ecef_to_N",
    "gravity_gradient_stability",
    "gravity_gradient_torque",
    "gravity_gradient_torque_components",
    "gravity_gradient_torque_function",
    "illumination_fraction",
    "linearize_gravity_gradient",
    "lvlh_attitude",
    "lvlh_relative_dynamics",
    "solve_kepler",
    "sun_direction_N",
    "sun_position_N",
]

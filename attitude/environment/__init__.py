"""The space environment at the spacecraft: orbits and the disturbance torques they bring."""

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
from attitude.environment.orbit import MU_EARTH, R_EARTH, CircularOrbit

__all__ = [
    "MU_EARTH",
    "R_EARTH",
    "CircularOrbit",
    "GravityGradientStability",
    "constant_plus_orbital_disturbance",
    "gravity_gradient_stability",
    "gravity_gradient_torque",
    "gravity_gradient_torque_components",
    "gravity_gradient_torque_function",
    "linearize_gravity_gradient",
    "lvlh_relative_dynamics",
]

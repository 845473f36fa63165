"""Attitude dynamics, kinematics, environment, sensors, actuators and simulation: the ground floor.

The front door: the names a design script needs come from here,
``from attitude import RigidBody, simulate, ReactionWheels, Gyro``, and the
quaternion algebra as ``from attitude import quaternion as quat``. The
functions named like their module are imported from it:
``from attitude.propagate import propagate``,
``from attitude.linearize import linearize``.
They are loaded when first used, so ``import attitude`` stays cheap (the
simulation engine and python-control's linearisation are not imported until
a script asks for them). DESIGN.md lists the conventions (SI units,
scalar-first Hamilton quaternions ``q_BN`` that rotate body vectors into the
inertial frame, ``omega_BN_B`` in body components).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from attitude.rigid_body import RigidBody

__version__ = "0.1.0"

#: Name -> the module that defines it (one home each; loaded on first access).
_FRONT_DOOR = {
    "Trajectory": "attitude.propagate",
    "torque_free_motion": "attitude.analytic",
    "ReactionWheels": "attitude.actuators",
    "Gyro": "attitude.sensors",
    "StarTracker": "attitude.sensors",
    "CircularOrbit": "attitude.environment.orbit",
    "simulate": "attitude.simulation.engine",
    "SimulationResult": "attitude.simulation.engine",
    "Truth": "attitude.simulation.protocols",
    "Estimate": "attitude.simulation.protocols",
    "Controller": "attitude.simulation.protocols",
    "Sensor": "attitude.simulation.protocols",
    "Estimator": "attitude.simulation.protocols",
    "load_config": "attitude.config",
    "default_config": "attitude.config",
}

if TYPE_CHECKING:  # what the lazy names are, for type checkers and editors
    from attitude.actuators import ReactionWheels
    from attitude.analytic import torque_free_motion
    from attitude.config import default_config, load_config
    from attitude.environment.orbit import CircularOrbit
    from attitude.propagate import Trajectory
    from attitude.sensors import Gyro, StarTracker
    from attitude.simulation.engine import SimulationResult, simulate
    from attitude.simulation.protocols import Controller, Estimate, Estimator, Sensor, Truth

__all__ = [
    "CircularOrbit",
    "Controller",
    "Estimate",
    "Estimator",
    "Gyro",
    "ReactionWheels",
    "RigidBody",
    "Sensor",
    "SimulationResult",
    "StarTracker",
    "Trajectory",
    "Truth",
    "__version__",
    "default_config",
    "load_config",
    "simulate",
    "torque_free_motion",
]


def __getattr__(name: str) -> Any:
    """Load a front-door name from its module on first access (PEP 562)."""
    try:
        module = _FRONT_DOOR[name]
    except KeyError:
        raise AttributeError(f"module 'attitude' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_FRONT_DOOR})

"""Attitude dynamics, kinematics and simulation: the ground floor of the toolkit.

Conventions (SI units, scalar-first Hamilton quaternions ``q_BN`` that rotate
body vectors into the inertial frame, ``omega_BN_B`` in body components) are
listed in the README and in ``attitude.quaternion``.
"""

from attitude.rigid_body import RigidBody

__version__ = "0.1.0"

__all__ = ["RigidBody", "__version__"]

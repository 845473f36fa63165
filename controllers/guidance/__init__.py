"""Guidance: the pointing references a controller tracks, and the controller that flies any of them.

Every mode gives ``q_RN``, ``omega_RN_R`` and ``omega_dot_RN_R`` through the
common :class:`PointingReference` protocol (``samples(t)``, ``reference(t)``),
so a mode manager can switch between them. See docs/guidance.md.
"""

from controllers.guidance.alignment import (
    SEPARATION_MIN_DEFAULT,
    VectorAlignmentReference,
    VectorTrack,
    align_two_vectors,
    body_triad,
)
from controllers.guidance.controller import GuidanceController
from controllers.guidance.directions import ORBIT_DIRECTIONS, OrbitMotion, constant_direction, orbit_motion
from controllers.guidance.inertial import InertialReference
from controllers.guidance.nadir import NadirReference
from controllers.guidance.protocol import PointingReference
from controllers.guidance.sun import SunReference
from controllers.guidance.target import GroundTarget, GroundTargetReference

__all__ = [
    "ORBIT_DIRECTIONS",
    "SEPARATION_MIN_DEFAULT",
    "GroundTarget",
    "GroundTargetReference",
    "GuidanceController",
    "InertialReference",
    "NadirReference",
    "OrbitMotion",
    "PointingReference",
    "SunReference",
    "VectorAlignmentReference",
    "VectorTrack",
    "align_two_vectors",
    "body_triad",
    "constant_direction",
    "orbit_motion",
]

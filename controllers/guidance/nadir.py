"""Nadir (LVLH) pointing: the body held at a fixed attitude ``q_BL`` in the orbit's LVLH frame L.

.. math::

    q_{RN} = q_{LN} \\otimes q_{BL},\\qquad
    \\omega_{RN,R} = C(q_{BL})^T \\omega_{LN,L},\\qquad
    \\dot\\omega_{RN,R} = C(q_{BL})^T \\dot\\omega_{LN,L}

with ``q_LN`` and ``omega_LN_L`` the orbit's own (:mod:`attitude.environment.orbit`:
``o3`` to nadir, ``o2`` the negative orbit normal, ``o1`` along the velocity
on a circular orbit) and ``omega_dot_LN_L`` from
:func:`attitude.environment.orbit.lvlh_angular_acceleration` (zero on a
circular orbit, of order ``e n^2`` on an elliptic one). With the identity
``q_BL`` the body axes are the LVLH axes. See docs/guidance.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.environment.orbit import lvlh_angular_acceleration
from controllers.guidance.protocol import SampledReference, Samples, reference_times

__all__ = ["NadirReference"]


def _omega_LN_L(orbit: Any, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``omega_LN_L`` (n, 3) [rad/s] at times ``t`` (n,): a method of ``t`` or a constant property."""
    value = orbit.omega_LN_L
    w = np.asarray(value(t) if callable(value) else value, dtype=float)
    return np.array(np.broadcast_to(w, (t.size, 3)))


class NadirReference(SampledReference):
    """The LVLH frame of an orbit, offset by a fixed ``q_BL`` (module docstring).

    Parameters
    ----------
    orbit : object
        Anything with ``q_LN(t)``, ``omega_LN_L`` (a (3,) property or a
        method of ``t``), ``position_N(t)`` and ``velocity_N(t)``, e.g.
        :class:`attitude.environment.CircularOrbit`, ``KeplerOrbit``,
        ``TLEOrbit``; ``t`` in seconds since its epoch.
    q_BL : array_like, shape (4,)
        Held attitude of the body relative to L; default identity.

    Raises
    ------
    ValueError
        For an orbit without those members or a ``q_BL`` that is not one unit quaternion.
    """

    def __init__(self, orbit: Any, q_BL: ArrayLike = (1.0, 0.0, 0.0, 0.0)) -> None:
        missing = [name for name in ("q_LN", "omega_LN_L", "position_N", "velocity_N") if not hasattr(orbit, name)]
        if missing:
            raise ValueError(
                f"orbit must have q_LN(t), omega_LN_L, position_N(t) and velocity_N(t); "
                f"{type(orbit).__name__} lacks {missing}"
            )
        self.orbit = orbit
        self.q_BL = quat.as_unit_quaternion(q_BL, "q_BL")
        if self.q_BL.shape != (4,):
            raise ValueError(f"q_BL must have shape (4,), got shape {self.q_BL.shape}")

    def samples(self, t: ArrayLike) -> Samples:
        """``q_RN`` (n, 4), ``omega_RN_R`` (n, 3) [rad/s] and ``omega_dot_RN_R`` (n, 3) [rad/s^2].

        Parameters
        ----------
        t : array_like, shape (n,)
            Times since the orbit's epoch [s].
        """
        t = reference_times(t)
        q_LN = np.asarray(self.orbit.q_LN(t), dtype=float).reshape(t.size, 4)
        r = np.asarray(self.orbit.position_N(t), dtype=float).reshape(t.size, 3)
        v = np.asarray(self.orbit.velocity_N(t), dtype=float).reshape(t.size, 3)
        q_ref = quat.multiply(q_LN, self.q_BL)
        w_ref = quat.rotate_inverse(self.q_BL, _omega_LN_L(self.orbit, t))
        w_dot = quat.rotate_inverse(self.q_BL, lvlh_angular_acceleration(r, v))
        return q_ref, w_ref, w_dot

"""Pointing references for an orbit: nadir (LVLH) hold as a quaternion PD tracking the orbit frame.

:class:`NadirPointing` holds the body at a fixed attitude ``q_BL`` in the
orbit's local-vertical local-horizontal frame L (``orbit.q_LN(t)``,
``orbit.omega_LN_L``): the reference is

.. math::

    q_{RN}(t) = q_{LN}(t) \\otimes q_{BL}, \\qquad
    \\omega_{RN,R} = C(q_{BL})^T \\omega_{LN,L}

and the law is :class:`controllers.pd.QuaternionPD` on that moving reference
(its ``torque_components``, gains from natural frequency and damping), with
the gyroscopic term ``omega x (I omega + h)`` on by default: in a steady
hold the body turns at the orbit rate, and that term is the torque the turn
needs. A steady body-fixed disturbance ``d`` then leaves the exact error
``q_e,v = K^-1 d`` (the rate error is zero when the body turns with L). No
feedforward of the reference's angular acceleration: it is zero on a
circular orbit and of order ``e n^2`` on an orbit of eccentricity ``e``.

Inertial pointing needs nothing new: it is :class:`controllers.pd.QuaternionPD`
with a constant ``q_ref``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.rigid_body import Components, RigidBody
from attitude.validation import as_float_array
from controllers.pd import QuaternionPD

__all__ = ["NadirPointing"]


def _omega_LN_L(orbit: Any, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``omega_LN_L`` (n, 3) [rad/s] at times ``t`` (n,): a method of ``t`` or a constant property."""
    value = orbit.omega_LN_L
    w = np.asarray(value(t) if callable(value) else value, dtype=float)
    return np.array(np.broadcast_to(w, (t.size, 3)))


class NadirPointing:
    """Quaternion PD holding the body at ``q_BL`` in the orbit's LVLH frame (module docstring).

    With the identity ``q_BL`` the body axes are the LVLH axes: body z to
    nadir, body y along the negative orbit normal, body x along the velocity
    (on a circular orbit).

    Parameters
    ----------
    orbit : object
        Anything with ``q_LN(t) -> (..., 4)`` and ``omega_LN_L`` (a
        ``(3,)`` property or a method ``t -> (..., 3)``), e.g.
        :class:`attitude.environment.CircularOrbit`; ``t`` in seconds of the
        simulation clock.
    body : RigidBody
        The spacecraft (its inertia [kg m^2] sets the gains and the
        gyroscopic term).
    wn : float or array_like (3,)
        Natural frequency per axis [rad/s].
    zeta : float or array_like (3,)
        Damping ratio per axis.
    period : float
        Controller sample time [s].
    q_BL : array_like (4,)
        Held attitude of the body relative to L (rotates body vectors into
        L); default identity.
    gyroscopic : bool
        Add ``omega x (I omega + h)`` (default True; see the module docstring).

    Raises
    ------
    ValueError
        For an orbit without ``q_LN``/``omega_LN_L``, a ``q_BL`` that is not
        a unit quaternion, or gains as :meth:`QuaternionPD.from_bandwidth`.
    """

    def __init__(
        self,
        orbit: Any,
        body: RigidBody,
        *,
        wn: ArrayLike,
        zeta: ArrayLike,
        period: float,
        q_BL: ArrayLike = (1.0, 0.0, 0.0, 0.0),
        gyroscopic: bool = True,
    ) -> None:
        missing = [name for name in ("q_LN", "omega_LN_L") if not hasattr(orbit, name)]
        if missing:
            raise ValueError(f"orbit must have q_LN(t) and omega_LN_L; {type(orbit).__name__} lacks {missing}")
        self.orbit = orbit
        self.q_BL = quat.as_unit_quaternion(q_BL, "q_BL")
        if self.q_BL.shape != (4,):
            raise ValueError(f"q_BL must have shape (4,), got shape {self.q_BL.shape}")
        self.feedback = QuaternionPD.from_bandwidth(
            body, wn=wn, zeta=zeta, period=period, reference_fn=self.reference, gyroscopic=gyroscopic
        )
        self.period = self.feedback.period

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitudes ``q_RN`` (n, 4) and rates ``omega_RN_R`` (n, 3) [rad/s] at many times.

        Parameters
        ----------
        t : array_like
            Simulation times [s], shape (n,).
        """
        t = np.atleast_1d(as_float_array(t, "t")).reshape(-1)
        q_LN = np.asarray(self.orbit.q_LN(t), dtype=float).reshape(t.size, 4)
        q_ref = quat.multiply(q_LN, self.q_BL)
        w_ref = quat.rotate_inverse(self.q_BL, _omega_LN_L(self.orbit, t))
        return q_ref, w_ref

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitude ``q_RN`` (4,) and rate ``omega_RN_R`` (3,) [rad/s] at ``t``.

        Parameters
        ----------
        t : float
            Simulation time [s].
        """
        q, w = self.reference_samples(t)
        return q[0], w[0]

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """``[q_ref; omega_ref]`` (7, len(t)) for the compiled engine.

        Parameters
        ----------
        t : ndarray
            Tick times [s].
        """
        q, w = self.reference_samples(t)
        return np.concatenate([q, w], axis=1).T

    def torque_components(self, q: Components, omega: Components, h_body: Components, inputs: Components) -> Components:
        """The law on components (any backend): :meth:`QuaternionPD.torque_components`.

        Parameters
        ----------
        q : list
            Attitude components ``[w, x, y, z]`` of ``q_BN``.
        omega : list
            Body rate ``omega_BN_B`` [rad/s].
        h_body : list
            Wheel momentum relative to the body, body axes [N m s].
        inputs : list
            ``[q_ref (4), omega_ref (3)]``, a column of :meth:`compiled_inputs`.
        """
        return self.feedback.torque_components(q, omega, h_body, inputs)

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque (3,) [N m] at ``t`` [s].

        Parameters
        ----------
        t : float
            Simulation time [s].
        estimate : Estimate
            The controller's view (``q``, ``omega`` and ``h_body``).
        """
        return self.feedback.torque(t, estimate)

"""Flying a pointing reference: quaternion PD on the tracking error plus the model's feedforward.

.. math::

    \\tau = -K\\,\\mathrm{sgn}(q_{e,0})\\,q_{e,v} - C\\,\\omega_e
            + I\\,(C_{BR}\\dot\\omega_r - \\omega \\times C_{BR}\\omega_r)
            + \\omega \\times (I\\omega + h)

with ``q_e = q_RN* ⊗ q_BN`` and ``omega_e = omega - C_BR omega_r``. The
feedforward ``I (C_BR omega_dot_r - omega x C_BR omega_r)`` is the
acceleration the reference asks of the body, written in B (the derivative of
``C_BR omega_r`` in B is ``C_BR omega_dot_r - omega_e x C_BR omega_r`` and
``omega_e x C_BR omega_r = omega x C_BR omega_r``); with the gyroscopic term
it turns the closed loop into ``I omega_e' + C omega_e + K q_e,v = 0``
exactly, the Lyapunov tracking law of Schaub and Junkins, *Analytical
Mechanics of Space Systems*, sec. 8.3 (also Basilisk's ``mrpFeedback``,
written here on the quaternion error of Wie, Weiss and Arapostathis 1989).
Gains from natural frequency and damping as
:meth:`controllers.pd.QuaternionPD.from_bandwidth`. Any
:class:`controllers.guidance.PointingReference` can be flown, by the Python
or the compiled engine (``compiled_inputs = [q_r; omega_r; omega_dot_r]``).
See docs/guidance.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.backend import cross
from attitude.rigid_body import Components, RigidBody
from controllers.guidance.protocol import PointingReference, reference_times
from controllers.pd import QuaternionPD, quaternion_error_components

__all__ = ["GuidanceController"]


class GuidanceController:
    """Quaternion PD tracking any pointing reference, with gyroscopic and reference feedforward (module docstring).

    Parameters
    ----------
    guidance : PointingReference
        What to track (anything with ``samples(t) -> (q_RN, omega_RN_R, omega_dot_RN_R)``).
    body : RigidBody
        The spacecraft (its inertia [kg m^2] sets the gains and the feedforward).
    wn : float or array_like (3,)
        Natural frequency per axis [rad/s].
    zeta : float or array_like (3,)
        Damping ratio per axis.
    period : float
        Controller sample time [s].
    gyroscopic : bool
        Add ``omega x (I omega + h)`` (default True).
    feedforward : bool
        Add ``I (C_BR omega_dot_r - omega x C_BR omega_r)`` (default True).

    Raises
    ------
    ValueError
        For a ``guidance`` without ``samples`` or gains as :meth:`QuaternionPD.from_bandwidth`.
    """

    #: The compiled path may keep this law's closed loop by the class and its pickle: the law reads nothing else
    #: (attitude.simulation.engine caches the compiled loop; a user's law without this flag is rebuilt each run).
    compiled_law_cacheable = True

    def __init__(
        self,
        guidance: PointingReference,
        body: RigidBody,
        *,
        wn: ArrayLike,
        zeta: ArrayLike,
        period: float,
        gyroscopic: bool = True,
        feedforward: bool = True,
    ) -> None:
        if not callable(getattr(guidance, "samples", None)):
            raise ValueError(
                f"guidance must be a PointingReference with samples(t) -> (q_RN, omega_RN_R, omega_dot_RN_R), "
                f"got {type(guidance).__name__}"
            )
        self.guidance = guidance
        self.feedback = QuaternionPD.from_bandwidth(
            body, wn=wn, zeta=zeta, period=period, reference_fn=self.reference, gyroscopic=gyroscopic
        )
        self.inertia = self.feedback.inertia
        self.feedforward = bool(feedforward)
        self.period = self.feedback.period

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitudes ``q_RN`` (n, 4) and rates ``omega_RN_R`` (n, 3) [rad/s].

        Parameters
        ----------
        t : array_like
            Simulation times [s], shape (n,).
        """
        q, w, _ = self.guidance.samples(reference_times(t))
        return q, w

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
        """``[q_ref; omega_ref; omega_dot_ref]`` (10, len(t)) for the compiled engine.

        Parameters
        ----------
        t : ndarray
            Tick times [s].
        """
        q, w, w_dot = self.guidance.samples(reference_times(t))
        return np.concatenate([q, w, w_dot], axis=1).T

    def torque_components(self, q: Components, omega: Components, h_body: Components, inputs: Components) -> Components:
        """The law on components (numpy or casadi); ``inputs = [q_ref (4), omega_ref (3), omega_dot_ref (3)]``.

        Parameters
        ----------
        q : list
            Attitude components ``[w, x, y, z]`` of ``q_BN``.
        omega : list
            Body rate ``omega_BN_B`` [rad/s].
        h_body : list
            Wheel momentum relative to the body, body axes [N m s].
        inputs : list
            A column of :meth:`compiled_inputs`.
        """
        tau = self.feedback.torque_components(q, omega, h_body, inputs[:7])
        if not self.feedforward:
            return tau
        q_e, _ = quaternion_error_components(inputs[:4], q)
        w_r = quat.rotate_inverse_components(q_e, inputs[4:7])
        w_dot_r = quat.rotate_inverse_components(q_e, inputs[7:10])
        turn = cross(omega, w_r)
        accel = [a - b for a, b in zip(w_dot_r, turn)]
        inertia = self.inertia
        return [tau[i] + sum(inertia[i, j] * accel[j] for j in range(3) if inertia[i, j] != 0.0) for i in range(3)]

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque (3,) [N m] at ``t`` [s].

        Parameters
        ----------
        t : float
            Simulation time [s].
        estimate : Estimate
            The controller's view (``q``, ``omega`` and ``h_body``).
        """
        q_r, w_r, w_dot = (a[0] for a in self.guidance.samples(reference_times(t)))
        q = quat.as_unit_quaternion(estimate.q, "estimate.q")
        h_b = getattr(estimate, "h_body", None)
        h_b = np.zeros(3) if h_b is None else np.asarray(h_b, dtype=float)
        out = self.torque_components(
            list(q), list(np.asarray(estimate.omega, dtype=float)), list(h_b), [*q_r, *w_r, *w_dot]
        )
        return np.array([float(v) for v in out])

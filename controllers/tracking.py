"""Trajectory tracking: planned torque as feedforward plus quaternion PD feedback.

.. math::

    \\tau = \\tau_{ff}(t) - K\\, \\mathrm{sgn}(q_{e,0}) q_{e,v} - C (\\omega - C_{BR}\\,\\omega_{ref})

``tau_ff`` is the torque of the plan (it already contains the gyroscopic
terms of the nominal motion), ``q_ref`` and ``omega_ref`` the planned
attitude and body rate. On the nominal trajectory the feedback is zero and
the plan is flown open loop; any deviation (initial error, inertia error,
disturbance, saturation) is corrected by the PD, whose gains come from the
same natural-frequency/damping design as :class:`controllers.pd.QuaternionPD`.

The reference is sampled at the controller period: attitude by slerp between
plan nodes, rate linearly, torque held over each plan interval (the plan's own
zero-order hold). At the last node the reference is that node's attitude and
rate; after it the reference holds the final attitude at rest with no
feedforward. That is the right continuation of a rest-to-rest slew; a plan
that ends with a nonzero rate (e.g. ``omegaf`` matching a scan) needs a
following reference, otherwise the feedback brakes the body to rest on the
final attitude.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.backend import cross
from attitude.rigid_body import Components, RigidBody
from attitude.validation import as_float_array, check_time_grid, check_vector
from controllers.pd import QuaternionPD

__all__ = ["ReferenceTrajectory", "TrackingController"]


@dataclass(frozen=True)
class ReferenceTrajectory:
    """A planned attitude trajectory on a time grid.

    Attributes
    ----------
    t : ndarray (n,)
        Node times [s], strictly increasing.
    q : ndarray (n, 4)
        Planned attitude ``q_RN`` at the nodes.
    omega : ndarray (n, 3)
        Planned body rate (in the reference frame R) [rad/s].
    torque : ndarray (n, 3)
        Feedforward torque [N m] held over ``[t[k], t[k+1])``; the last row is
        not used.

    Notes
    -----
    :meth:`sample` at ``t[-1]`` returns the last node's attitude and rate;
    after ``t[-1]`` it holds the final attitude at rest (zero rate, zero
    feedforward), so a trajectory ending with a nonzero rate must be
    followed by another reference.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    torque: NDArray[np.float64]

    def __post_init__(self) -> None:
        t = check_time_grid(self.t, "t")
        q = quat.as_unit_quaternion(self.q, "q")
        omega = check_vector(self.omega, "omega", 3)
        torque = check_vector(self.torque, "torque", 3)
        n = t.size
        for name, arr in (("q", q), ("omega", omega), ("torque", torque)):
            if arr.shape[0] != n or arr.ndim != 2:
                raise ValueError(f"{name} must have one row per node ({n}), got shape {arr.shape}")
        # Make consecutive quaternions take the short way for slerp.
        q = q.copy()
        for k in range(1, n):
            if q[k] @ q[k - 1] < 0:
                q[k] = -q[k]
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "torque", torque)

    @classmethod
    def from_plan(cls, plan: Any) -> ReferenceTrajectory:
        """Build from any object with ``t``, ``q``, ``omega`` and ``torque`` arrays (e.g. a slew plan).

        Parameters
        ----------
        plan : object
            Anything with ``t`` [s], ``q``, ``omega`` [rad/s] and ``torque`` [N m] arrays (e.g. a :class:`SlewPlan`).
        """
        return cls(
            t=np.asarray(plan.t), q=np.asarray(plan.q), omega=np.asarray(plan.omega), torque=np.asarray(plan.torque)
        )

    def torque_integral(self, t: ArrayLike) -> NDArray[np.float64]:
        """``integral_0^t torque dt`` of the held plan torque [N m s], shape (n, 3); constant after the end.

        Parameters
        ----------
        t : array_like
            Times [s], shape (n,).
        """
        t = np.clip(np.atleast_1d(as_float_array(t, "t")), self.t[0], self.t[-1])
        steps = np.diff(self.t)[:, None] * self.torque[:-1]
        cumulative = np.concatenate([np.zeros((1, 3)), np.cumsum(steps, axis=0)])
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, self.t.size - 2)
        return cumulative[k] + self.torque[k] * (t - self.t[k])[:, None]

    def sample(
        self, t: ArrayLike, window: float | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitude (n, 4), rate (n, 3) [rad/s] and feedforward torque (n, 3) [N m] at times ``t``.

        With ``window`` [s] the torque is the plan's average over
        ``[t, t + window)``: held by a controller of that period it delivers
        exactly the plan's angular impulse per sample even where a plan
        switch falls between samples.

        Before ``t[0]`` the reference is the first node (its attitude and
        rate, no torque). At ``t[-1]`` it is the last node's attitude and
        rate with no torque (the plan's torque is held over
        ``[t[k], t[k+1])`` only); after ``t[-1]`` it is the final attitude
        at rest: zero rate and torque (class Notes).

        Parameters
        ----------
        t : array_like (n,)
            Times [s] on the plan's clock.
        window : float, optional
            Averaging window of the torque [s].

        Returns
        -------
        (ndarray (n, 4), ndarray (n, 3), ndarray (n, 3))
            Attitude ``q_RN``, rate [rad/s] and torque [N m].
        """
        t = np.atleast_1d(as_float_array(t, "t"))
        if window is not None:
            q, omega, _ = self.sample(t)
            torque = (self.torque_integral(t + window) - self.torque_integral(t)) / window
            return q, omega, torque
        k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, self.t.size - 2)
        span = self.t[k + 1] - self.t[k]
        frac = np.clip((t - self.t[k]) / span, 0.0, 1.0)
        q = quat.slerp(self.q[k], self.q[k + 1], frac)
        omega = self.omega[k] + frac[:, None] * (self.omega[k + 1] - self.omega[k])
        torque = self.torque[k].copy()
        end = t >= self.t[-1]
        after = t > self.t[-1]
        before = t < self.t[0]
        q[end] = self.q[-1]
        omega[end] = self.omega[-1]
        omega[after] = 0.0
        torque[end | before] = 0.0
        q[before] = self.q[0]
        omega[before] = self.omega[0]
        return q, omega, torque


def _as_reference(value: Any) -> ReferenceTrajectory:
    return value if isinstance(value, ReferenceTrajectory) else ReferenceTrajectory.from_plan(value)


class TrackingController:
    """Feedforward plus quaternion PD tracking of a :class:`ReferenceTrajectory`.

    Parameters
    ----------
    reference : ReferenceTrajectory or object with t, q, omega, torque
        The plan to fly.
    body : RigidBody
        The spacecraft (for the feedback design).
    wn : float or array_like (3,)
        Feedback natural frequency per axis [rad/s].
    zeta : float or array_like (3,)
        Feedback damping ratio per axis.
    period : float
        Controller sample time [s].
    t_start : float
        Simulation time [s] at which the plan's ``t = 0`` is flown.
    feedforward : ReferenceTrajectory or plan, optional
        Source of the feedforward torque when it differs from ``reference``:
        e.g. ``reference=plan.resample(period)`` for exact states at the
        controller rate and ``feedforward=plan`` for the plan's own
        piecewise-constant torque (whose switches need not fall on the
        resampled grid). Default: ``reference``.
    """

    #: The compiled path may keep this law's closed loop by the class and its pickle: the law reads nothing else
    #: (attitude.simulation.engine caches the compiled loop; a user's law without this flag is rebuilt each run).
    compiled_law_cacheable = True

    def __init__(
        self,
        reference: Any,
        body: RigidBody,
        *,
        wn: ArrayLike,
        zeta: ArrayLike,
        period: float,
        t_start: float = 0.0,
        feedforward: Any = None,
    ) -> None:
        self.trajectory = _as_reference(reference)
        self.torque_source = self.trajectory if feedforward is None else _as_reference(feedforward)
        self.t_start = float(as_float_array(t_start, "t_start"))
        self.feedback = QuaternionPD.from_bandwidth(body, wn=wn, zeta=zeta, period=period, reference_fn=self.reference)
        self.period = self.feedback.period

    def _samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitudes (n, 4), rates (n, 3) [rad/s] and period-averaged feedforward (n, 3) [N m]."""
        t_plan = np.atleast_1d(np.asarray(t, dtype=float)) - self.t_start
        q, omega, _ = self.trajectory.sample(t_plan)
        # Feedforward averaged over each controller period (ReferenceTrajectory.sample).
        _, _, torque = self.torque_source.sample(t_plan, window=self.period)
        return q, omega, torque

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Planned attitude ``q_RN`` and rate [rad/s] at simulation time ``t``.

        Parameters
        ----------
        t : float
            Simulation time [s].
        """
        q, w, _ = self._samples(t)
        return q[0], w[0]

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Planned attitudes (n, 4) and rates (n, 3) at many times.

        Parameters
        ----------
        t : array_like
            Simulation times [s], shape (n,).
        """
        q, w, _ = self._samples(t)
        return q, w

    def feedforward(self, t: float) -> NDArray[np.float64]:
        """Planned torque [N m] at simulation time ``t``.

        Parameters
        ----------
        t : float
            Simulation time [s].
        """
        return self._samples(t)[2][0]

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """``[q_ref; omega_ref; torque_ff]`` (10, len(t)) for the compiled engine.

        Parameters
        ----------
        t : ndarray
            Tick times [s].
        """
        q, w, tau = self._samples(t)
        return np.concatenate([q, w, tau], axis=1).T

    def torque_components(self, q: Components, omega: Components, h_body: Components, inputs: Components) -> Components:
        """The law on components; ``inputs = [q_ref (4), omega_ref (3), torque_ff (3)]``.

        Parameters
        ----------
        q : list
            Attitude components ``[w, x, y, z]`` of ``q_BN`` (numbers or casadi expressions).
        omega : list
            Body rate components ``omega_BN_B`` [rad/s].
        h_body : list
            Internal (wheel) momentum in body components [N m s].
        inputs : list
            ``[q_ref (4), omega_ref (3), torque_ff (3)]`` components.
        """
        fb = self.feedback.torque_components(q, omega, h_body, inputs[:7])
        wheel_gyro = cross(omega, h_body)
        return [f + ff + g for f, ff, g in zip(fb, inputs[7:10], wheel_gyro)]

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque [N m]: feedforward plus PD on the tracking error.

        Parameters
        ----------
        t : float
            Simulation time [s].
        estimate : Estimate
            The estimator's output (anything with ``q`` and ``omega``).
        """
        q_r, w_r, tau = (a[0] for a in self._samples(t))
        h_body = getattr(estimate, "h_body", None)
        h_body = [0.0] * 3 if h_body is None else list(np.asarray(h_body, float))
        out = self.torque_components(
            list(np.asarray(estimate.q, float)), list(np.asarray(estimate.omega, float)), h_body, [*q_r, *w_r, *tau]
        )
        return np.array([float(v) for v in out])

"""Optimal slew planning: minimum-time and minimum-energy reorientations (casadi + IPOPT).

:func:`plan_slew` solves

.. math::

    \\min\\; t_f \\;\\text{(objective="time")} \\quad\\text{or}\\quad
    \\min \\int_0^{t_f} |\\tau|^2\\,dt \\;\\text{(objective="energy", } t_f \\text{ fixed)}

subject to the one definition of the rigid-body equations of motion
(:meth:`attitude.rigid_body.RigidBody.state_derivative_components`, reached
through :func:`attitude.integrators.casadi_rk4_step`), the boundary states
``q(0) = q0, omega(0) = omega0, q(t_f) = +-qf, omega(t_f) = omegaf``, a torque
set (per-axis box or the envelope of a reaction-wheel set), a body-rate limit
``|omega| <= rate_max`` and keep-out cones.

Transcription
    Direct multiple shooting: ``nodes`` intervals, the state ``[q, omega]`` a
    decision variable at every node, the torque constant over each interval
    (zero-order hold, exactly what :func:`attitude.propagate.propagate`
    applies to a torque array on the grid), and ``substeps`` RK4 steps per
    interval. The RK4 step renormalises the quaternion, so continuity alone
    keeps every node on the unit sphere: there is no extra ``|q| = 1``
    equality (it would be redundant with the dynamics and make the constraint
    Jacobian rank deficient, which ill-conditions IPOPT).

Final attitude
    ``vec(qf* ⊗ q(t_f)) = 0``: three equations, satisfied by ``q = qf`` and by
    ``q = -qf`` (the same attitude), well conditioned at both.

Scaling
    The NLP is nondimensional: inertia by its largest principal moment
    ``J_s``, torque by the largest per-axis torque ``tau_s``, time by
    ``T_s = sqrt(J_s / tau_s)`` (the time to turn one radian from rest at full
    torque, up to a factor) and rates by ``1 / T_s``. A 5000 kg m^2 spacecraft
    and a unit-inertia body with the same shape and torque ratios give the
    *same* NLP, hence the same iterations.

Keep-out cones
    A body-fixed boresight ``b_B`` must stay more than ``half_angle`` from an
    inertial direction ``s_N``. The constraint is imposed at every RK4
    sub-step boundary (not only at the nodes) with a margin: if the
    separation is at least ``half_angle + delta`` at both ends of a sub-step
    of length ``h`` and the boresight moves at most ``|omega|`` rad/s (it
    does: ``|d b_N / dt| = |omega x b_B| <= |omega|``), the separation inside
    the sub-step is at least ``half_angle + delta - L / 2`` with
    ``L = integral |omega| dt``. The margin ``delta = h (|omega_a| + |omega_b|) / 4``
    is ``L / 2`` by the trapezoid rule (error O(h^3)), so the continuous
    path clears the cone, not only the sampled points: a constraint checked
    at the nodes alone would let the path cut the corner of the cone between
    them. The margin vanishes as the grid is refined.

Rate limit
    ``|omega|^2 <= rate_max^2`` (Euclidean norm, as for the eigenaxis
    bang-coast-bang reference) at every sub-step boundary.

Guess and multi-start
    Starting exactly on the eigenaxis solution traps IPOPT there: for a slew
    about a symmetry axis the eigenaxis path is a KKT point, and the
    off-axis torques that make the time-optimal answer faster have zero
    gradient. The guess is the eigenaxis profile with a smooth random
    perturbation (off-axis torque and an attitude bump vanishing at both
    ends) drawn from ``rng``; ``starts > 1`` solves from several such
    guesses (deterministic for a given seed) and keeps the best converged
    answer, because minimum-time slews have local optima.

Refinement (minimum time)
    A bang-bang answer on a uniform grid places its switches on the nodes
    and converges from above as O(1/N). The refinement reads the switching
    structure off the grid solution (the sign pattern of the active torque
    constraints), then solves a multi-phase NLP: one phase per arc, free
    phase durations, a torque held constant over each saturated phase (a
    vertex of the torque set) and free per interval on unsaturated arcs
    (rate-limit coasts, keep-out boundary arcs). The switch times become
    continuous variables, so for a bang-bang answer the time is the
    grid-converged one up to the RK4 error (O(h^4)). Unsaturated arcs keep
    a piecewise-constant torque on a grid of the original density, whose
    ends now move with the structure: there the refined time is a better
    grid answer, not an exact one. A bang arc must span at least one whole
    interval of the grid to be recognised; when none does (for example a
    short acceleration before a long rate-limited coast on a coarse grid),
    the refinement is skipped and the plan says so. The plan reports both
    ``grid_duration`` and ``refined_duration``.

Smoothing
    ``smoothing`` adds ``smoothing * sum_k |u_{k+1} - u_k|^2`` (``u`` the
    torque in units of ``tau_s``) to the nondimensional objective (the
    duration in units of ``T_s`` or the energy in units of
    ``tau_s^2 T_s``). It suppresses chattering on singular arcs and blurs
    the switches. Comparing the two optima, the unsmoothed objective grows
    by at most ``smoothing * P0``, with ``P0`` the penalty of the unsmoothed
    answer (about 4 per switching axis for a full bang-bang switch inside an
    interval, counted in units of the largest torque); the default 0 adds
    nothing.

Verification
    Every returned plan is re-simulated open loop with the adaptive
    propagator (DOP853, rtol 1e-10) under its own zero-order-hold torque;
    the final attitude and rate errors, the smallest keep-out separation and
    the largest rate (on 8 samples per interval) are stored on the plan. A
    plan whose re-simulation misses the target by more than
    ``verify_tolerance`` (or enters a cone by more than that angle, or
    exceeds the rate limit by more than ``verify_tolerance / T_s``) raises
    :class:`SlewPlanningError`; so does any IPOPT status other than
    ``Solve_Succeeded`` / ``Solved_To_Acceptable_Level``.

Reaction wheels
    With a :class:`attitude.actuators.ReactionWheels` as ``torque_max`` the
    body torque is limited to ``|(A^+ tau)_i| <= u_max,i``: the set that the
    toolkit's direction-preserving minimum-norm allocation
    (:meth:`ReactionWheels.allocate`) delivers without scaling, whose
    per-axis extent is :meth:`ReactionWheels.torque_envelope`. The plant is
    the rigid body with that torque; wheel momentum (the ``omega x A h``
    coupling) and wheel speed limits are not part of the plan.
"""

from __future__ import annotations

import itertools
import math
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from attitude import quaternion as quat
from attitude._validation import as_float_array, check_positive, describe
from attitude.actuators import ReactionWheels
from attitude.integrators import casadi_rk4_step, quaternion_multiply_components
from attitude.propagate import propagate
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody, cross
from attitude.rng import as_generator

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = [
    "PUBLISHED_BILIMORIA_WIE",
    "EigenaxisSlew",
    "InfeasibleSlewError",
    "KeepOutCone",
    "SlewPlan",
    "SlewPlanningError",
    "eigenaxis_slew",
    "plan_slew",
]

#: Bilimoria and Wie (1993), rest-to-rest 180 deg about a body axis, unit
#: inertia, ``|u_i| <= 1``: eigenaxis and time-optimal durations [s].
PUBLISHED_BILIMORIA_WIE = {"eigenaxis": 2.0 * math.sqrt(math.pi), "time_optimal": 3.2431}

OBJECTIVES = ("time", "energy")

#: IPOPT statuses accepted as converged.
CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")

#: IPOPT statuses that point at an infeasible problem.
INFEASIBLE = ("Infeasible_Problem_Detected", "Restoration_Failed", "Local_Infeasibility")

#: Default IPOPT options (overridable with ``ipopt_options``). ``tol`` 1e-9 on
#: the nondimensional problem puts the duration to ~1e-9 T_s, far below the
#: grid error; ``acceptable_tol`` is IPOPT's default. The adaptive barrier
#: update took the 100-node benchmark from 66 to 41 iterations.
IPOPT_DEFAULTS: dict[str, Any] = {
    "print_level": 0,
    "sb": "yes",
    "tol": 1e-9,
    "acceptable_tol": 1e-6,
    "mu_strategy": "adaptive",
}

#: A torque constraint row ``|g . u| <= 1`` counts as saturated on an interval
#: when ``|g . u| >= 1 - SATURATION_TOLERANCE``. IPOPT at tol 1e-9 puts a
#: saturated torque within ~1e-8 of its bound; an interior torque on a
#: singular or boundary arc is farther away than 1e-3 except where it
#: crosses the bound, which the switch detection handles.
SATURATION_TOLERANCE = 1e-3

#: Interior runs of at most this many intervals between opposite
#: saturations are switch transitions (the switch falls inside them).
TRANSITION_INTERVALS = 2

#: Largest number of phases the refinement accepts (a chattering grid
#: solution would give a structure too fine to trust).
MAX_PHASES = 40

#: A refined time above ``grid_duration * (1 + REFINEMENT_SLACK)`` is
#: rejected: the grid solution converges from above, so the refined answer
#: must not be longer, up to RK4 differences (~1e-8 relative here).
REFINEMENT_SLACK = 1e-4

#: Regularisation of ``|omega|`` in the keep-out margin,
#: ``sqrt(omega . omega + eps^2)`` in units of 1/T_s: keeps the square root
#: differentiable at rest and only enlarges the margin (by <= eps h / 2).
SPEED_EPS = 1e-3

#: Samples per interval for the keep-out and rate checks of the verification.
CHECK_SAMPLES = 8


class SlewPlanningError(RuntimeError):
    """The optimiser did not return a trustworthy plan.

    Attributes
    ----------
    status : str
        IPOPT's return status (or ``"verification_failed"``).
    cause : str
        The likely cause, in words.
    details : dict
        Solver statistics (iterations, per-start statuses, constraint
        violation) for diagnosis.
    """

    def __init__(self, message: str, *, status: str = "", cause: str = "", details: dict | None = None) -> None:
        super().__init__(message)
        self.status = status
        self.cause = cause
        self.details = details or {}


class InfeasibleSlewError(SlewPlanningError, ValueError):
    """The requested slew is infeasible for its limits (for example a duration below the minimum time)."""


# ---------------------------------------------------------------------------
# Inputs
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class KeepOutCone:
    """A body-fixed boresight that must stay away from an inertial direction.

    Parameters
    ----------
    boresight_B : array_like (3,)
        Body-fixed boresight (e.g. a star-tracker axis), body components;
        normalised here.
    direction_N : array_like (3,)
        Inertial direction to avoid (e.g. the Sun), inertial components;
        normalised here.
    half_angle : float
        Smallest allowed angle between the two [rad], in ``(0, pi)``.
    name : str
        Label for plots and messages.

    Examples
    --------
    >>> sun = KeepOutCone.from_degrees([0, 0, 1], [1, 0, 0], half_angle_deg=30.0, name="sun")
    """

    boresight_B: NDArray[np.float64]
    direction_N: NDArray[np.float64]
    half_angle: float
    name: str = ""

    def __post_init__(self) -> None:
        for attr in ("boresight_B", "direction_N"):
            v = as_float_array(getattr(self, attr), attr)
            if v.shape != (3,):
                raise ValueError(f"KeepOutCone {attr} must have shape (3,), got shape {v.shape}")
            n = float(np.linalg.norm(v))
            if n == 0.0:
                raise ValueError(f"KeepOutCone {attr} must be a non-zero vector, got {describe(v)}")
            object.__setattr__(self, attr, v / n)
        angle = float(as_float_array(self.half_angle, "half_angle"))
        if not 0.0 < angle < math.pi:
            raise ValueError(f"KeepOutCone half_angle must lie in (0, pi) rad, got {angle!r}")
        object.__setattr__(self, "half_angle", angle)

    @classmethod
    def from_degrees(
        cls, boresight_B: ArrayLike, direction_N: ArrayLike, half_angle_deg: float, name: str = ""
    ) -> KeepOutCone:
        """Build a cone from a half angle in degrees."""
        return cls(
            np.asarray(boresight_B, dtype=float),
            np.asarray(direction_N, dtype=float),
            math.radians(float(as_float_array(half_angle_deg, "half_angle_deg"))),
            name,
        )

    def separation(self, q: ArrayLike) -> NDArray[np.float64]:
        """Angle [rad] between the boresight and the avoided direction at attitudes ``q_BN`` (..., 4)."""
        b_n = quat.rotate(quat.normalize(q), self.boresight_B)
        return np.arccos(np.clip(b_n @ self.direction_N, -1.0, 1.0))


@dataclass(frozen=True)
class _TorqueSet:
    """Body torques with ``|rows @ tau| <= 1`` (rows in 1/(N m))."""

    rows: NDArray[np.float64]
    envelope: NDArray[np.float64]
    is_box: bool
    label: str

    @classmethod
    def make(cls, torque_max: ArrayLike | ReactionWheels) -> _TorqueSet:
        if isinstance(torque_max, ReactionWheels):
            rows = torque_max.allocation / torque_max.torque_max[:, None]
            return cls(rows, torque_max.torque_envelope(), False, f"{torque_max.n_wheels} reaction wheels")
        arr = check_positive(torque_max, "torque_max")
        if arr.shape not in ((), (1,), (3,)):
            raise ValueError(
                f"torque_max must be a scalar, 3 per-axis limits or a ReactionWheels, got shape {arr.shape}"
            )
        env = np.broadcast_to(arr, (3,)).astype(float).copy()
        return cls(np.diag(1.0 / env), env, True, "box")

    def ratio(self, tau: NDArray[np.float64]) -> NDArray[np.float64]:
        """Largest ``|rows @ tau|`` per torque (..., 3) -> (...): <= 1 inside the set."""
        return np.max(np.abs(tau @ self.rows.T), axis=-1)


def _vector3(value: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = as_float_array(value, name)
    if arr.shape not in ((), (3,)):
        raise ValueError(f"{name} must be a scalar or shape (3,) in rad/s, got shape {arr.shape}")
    return np.broadcast_to(arr, (3,)).astype(float).copy()


def _rotate_components(q: list, v: NDArray[np.float64]) -> list:
    """``q ⊗ v ⊗ q*`` for a unit quaternion on components and a constant vector."""
    w, u = q[0], q[1:]
    t = cross(u, list(v))
    tt = cross(u, t)
    return [float(v[i]) + 2.0 * w * t[i] + 2.0 * tt[i] for i in range(3)]


@dataclass
class _Problem:
    """Validated inputs in nondimensional form."""

    body: RigidBody
    body_s: RigidBody
    q0: NDArray[np.float64]
    qf: NDArray[np.float64]
    omega0: NDArray[np.float64]
    omegaf: NDArray[np.float64]
    torque_set: _TorqueSet
    rows_s: NDArray[np.float64]
    rate_max: float | None
    cones: tuple[KeepOutCone, ...]
    substeps: int
    j_s: float
    tau_s: float
    t_s: float

    @property
    def x0(self) -> NDArray[np.float64]:
        return np.concatenate([self.q0, self.omega0 * self.t_s])

    @property
    def rate_max_s(self) -> float | None:
        return None if self.rate_max is None else self.rate_max * self.t_s

    def u_bounds(self) -> NDArray[np.float64]:
        """Per-axis torque bounds in units of tau_s (box sets)."""
        return self.torque_set.envelope / self.tau_s


# ---------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------


def _cone_arrays(cones: Sequence[KeepOutCone]) -> tuple[NDArray, NDArray, NDArray]:
    if not cones:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    return (
        np.array([c.boresight_B for c in cones]),
        np.array([c.direction_N for c in cones]),
        np.array([c.half_angle for c in cones]),
    )


@dataclass
class SlewPlan(ResultIO):
    """An optimal slew: states and torque on the plan grid, and how it was obtained.

    ``torque[k]`` is held over ``[t[k], t[k+1])`` (zero-order hold, as
    :func:`attitude.propagate.propagate` applies a torque array); the last
    row repeats the final interval's torque so that all arrays share ``t``.

    Attributes
    ----------
    t : ndarray (n,)
        Time [s], from 0 to ``duration``; uniform on the node grid,
        piecewise uniform (one block per phase) after refinement.
    q : ndarray (n, 4)
        Attitude ``q_BN`` (the final one is ``qf`` or ``-qf``).
    omega : ndarray (n, 3)
        Body rate ``omega_BN_B`` [rad/s].
    torque : ndarray (n, 3)
        Body torque [N m].
    duration : float
        Duration of this trajectory [s] (the refined one when refined).
    objective : str
        ``"time"`` or ``"energy"``.
    objective_value : float
        Duration [s] or ``integral |tau|^2 dt`` [N^2 m^2 s] of this trajectory.
    status : str
        IPOPT return status of the solve that produced this trajectory.
    iterations : int
        IPOPT iterations of that solve.
    wall_time : float
        Wall time of the whole planning call [s] (all starts, refinement
        and verification).
    solve_time : float
        Wall time inside IPOPT solves [s], all starts and refinement.
    grid_duration : float
        Duration [s] of the best solution on the uniform node grid.
    refined_duration : float or None
        Grid-converged duration [s] from the switch-time refinement (None
        if not refined).
    switch_times : ndarray (p,)
        Phase boundaries [s] found by the refinement (empty if not refined).
    final_attitude_error : float
        Angle [rad] between the target and the open-loop re-simulated final attitude.
    final_rate_error : float
        ``|omega_sim(t_f) - omegaf|`` [rad/s] of the re-simulation.
    min_separation : ndarray (m,)
        Smallest keep-out separation [rad] per cone along the re-simulation.
    max_rate : float
        Largest ``|omega|`` [rad/s] along the re-simulation.
    q_target, omega_target : ndarray
        The requested final attitude and rate [rad/s].
    inertia : ndarray (3, 3)
        Inertia of the planned body [kg m^2].
    torque_envelope : ndarray (3,)
        Largest torque per body axis of the torque set [N m].
    torque_rows : ndarray (m, 3)
        The torque set ``|torque_rows @ tau| <= 1`` [1/(N m)].
    rate_max : float or None
        Body-rate limit [rad/s].
    keep_out_boresight_B, keep_out_direction_N, keep_out_half_angle : ndarray
        The keep-out cones (unit vectors; half angles [rad]).
    eigenaxis_duration : float or None
        Duration [s] of the eigenaxis reference slew (rest to rest only).
    info : dict
        Scaling, grid, per-start results, refinement details, verification.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    torque: NDArray[np.float64]
    duration: float
    objective: str
    objective_value: float
    status: str
    iterations: int
    wall_time: float
    solve_time: float
    grid_duration: float
    refined_duration: float | None
    switch_times: NDArray[np.float64]
    final_attitude_error: float
    final_rate_error: float
    min_separation: NDArray[np.float64]
    max_rate: float
    q_target: NDArray[np.float64]
    omega_target: NDArray[np.float64]
    inertia: NDArray[np.float64]
    torque_envelope: NDArray[np.float64]
    torque_rows: NDArray[np.float64]
    rate_max: float | None
    keep_out_boresight_B: NDArray[np.float64]
    keep_out_direction_N: NDArray[np.float64]
    keep_out_half_angle: NDArray[np.float64]
    eigenaxis_duration: float | None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def final_attitude_error_deg(self) -> float:
        """:attr:`final_attitude_error` in degrees."""
        return math.degrees(self.final_attitude_error)

    @property
    def keep_out(self) -> tuple[KeepOutCone, ...]:
        """The keep-out cones as :class:`KeepOutCone` objects."""
        names = list(self.info.get("keep_out_names", [])) + [""] * self.keep_out_half_angle.size
        return tuple(
            KeepOutCone(b, s, float(a), str(name))
            for b, s, a, name in zip(
                self.keep_out_boresight_B, self.keep_out_direction_N, self.keep_out_half_angle, names
            )
        )

    def separation(self) -> NDArray[np.float64]:
        """Keep-out separation [rad] at the plan's times, shape (n, m)."""
        if not self.keep_out_half_angle.size:
            return np.zeros((self.t.size, 0))
        return np.stack([c.separation(self.q) for c in self.keep_out], axis=-1)

    def resample(self, dt: float) -> SlewPlan:
        """The plan on a uniform grid of step ``dt`` [s] (plus the final time).

        States between nodes are integrated from the preceding node with the
        plan's torque (RK4, 8 sub-steps over at most one interval: exact to
        ~1e-12 for these step sizes), so they lie on the planned trajectory
        rather than on an interpolation. ``torque`` holds the plan's torque
        at each new time; fed back as a zero-order hold on the new grid it
        differs from the plan on new intervals that straddle a plan node.
        """
        dt = float(check_positive(dt, "dt"))
        t_new = np.arange(0.0, self.duration, dt)
        if self.duration - t_new[-1] > 1e-9 * self.duration:
            t_new = np.append(t_new, self.duration)
        else:
            t_new[-1] = self.duration
        x = _states_between(RigidBody(self.inertia), self.t, self.q, self.omega, self.torque, t_new)
        k = np.clip(np.searchsorted(self.t, t_new, side="right") - 1, 0, self.t.size - 2)
        info = dict(self.info)
        info["resampled_dt_s"] = dt
        return replace(self, t=t_new, q=x[:, :4], omega=x[:, 4:], torque=self.torque[k].copy(), info=info)

    def plot(self) -> matplotlib.figure.Figure:
        """Torque and rate profiles, attitude path and keep-out separation over time."""
        return _plot_plan(self)


@dataclass
class EigenaxisSlew(ResultIO):
    """The time-optimal rotation about the fixed eigenaxis (rest to rest).

    The body turns about the eigenaxis ``e`` (the same in B and N) with
    ``omega = w(t) e``; the torque ``tau = alpha I e + w^2 (e x I e)`` must
    stay in the torque set, which fixes the largest acceleration and
    deceleration at each rate (the gyroscopic part vanishes about a
    principal axis). The profile is bang-bang, or bang-coast-bang when the
    rate limit is reached.

    Attributes
    ----------
    t : ndarray (n,)
        Time [s].
    q : ndarray (n, 4)
        Attitude ``q_BN``.
    omega : ndarray (n, 3)
        Body rate [rad/s].
    torque : ndarray (n, 3)
        Body torque [N m] (sampled, continuous within each arc).
    angle : ndarray (n,)
        Rotation angle about the eigenaxis [rad].
    duration : float
        Slew time [s].
    axis_B : ndarray (3,)
        Eigenaxis (unit, body components).
    total_angle : float
        Eigenaxis rotation angle [rad], in ``[0, pi]``.
    peak_rate : float
        Largest rate [rad/s].
    accel_duration : float
        End of the acceleration arc [s] (the first switch).
    coast_duration : float
        Time spent at the rate limit [s].
    inertia : ndarray (3, 3)
        Inertia [kg m^2].
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    torque: NDArray[np.float64]
    angle: NDArray[np.float64]
    duration: float
    axis_B: NDArray[np.float64]
    total_angle: float
    peak_rate: float
    accel_duration: float
    coast_duration: float
    inertia: NDArray[np.float64]

    def plot(self) -> matplotlib.figure.Figure:
        """Torque, rate and angle profiles."""
        from matplotlib.figure import Figure

        from attitude.plotting import AXIS_COLORS

        fig = Figure(figsize=(9, 7), layout="constrained")
        axes = fig.subplots(3, 1, sharex=True)
        for i, name in enumerate("xyz"):
            axes[0].plot(self.t, self.torque[:, i], color=AXIS_COLORS[i], label=rf"$\tau_{name}$")
            axes[1].plot(self.t, np.degrees(self.omega[:, i]), color=AXIS_COLORS[i], label=rf"$\omega_{name}$")
        axes[0].set_ylabel("torque [N m]")
        axes[1].set_ylabel("body rate [deg/s]")
        axes[2].plot(self.t, np.degrees(self.angle), color="black")
        axes[2].set_ylabel("eigenaxis angle [deg]")
        axes[2].set_xlabel("time [s]")
        for ax in axes[:2]:
            ax.legend(loc="upper right", ncols=3)
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(
            f"eigenaxis slew: {math.degrees(self.total_angle):.2f} deg in {self.duration:.4g} s "
            f"(peak {math.degrees(self.peak_rate):.3g} deg/s, coast {self.coast_duration:.4g} s)"
        )
        return fig


# ---------------------------------------------------------------------------
# Eigenaxis reference
# ---------------------------------------------------------------------------


def _axis_angle(q0: NDArray, qf: NDArray) -> tuple[NDArray[np.float64], float]:
    """Body-fixed eigenaxis and angle in [0, pi] taking q0 to qf (``qf = q0 ⊗ exp(e phi / 2)``)."""
    rel = quat.multiply(quat.conjugate(q0), qf)
    if rel[0] < 0:
        rel = -rel
    s = float(np.linalg.norm(rel[1:]))
    angle = 2.0 * math.atan2(s, float(rel[0]))
    axis = rel[1:] / s if s > 0 else np.array([1.0, 0.0, 0.0])
    return axis, angle


def _eigenaxis_profile(
    inertia: NDArray, rows: NDArray, axis: NDArray, angle: float, rate_max: float | None, n_points: int
) -> dict[str, Any]:
    """Bang(-coast)-bang profile along ``axis`` with gyroscopic-aware acceleration limits."""
    ie = inertia @ axis
    g0 = np.cross(axis, ie)
    c = rows @ ie
    d = rows @ g0
    # With z = w^2 each row |c_j alpha + d_j z| <= 1 bounds the acceleration:
    # accel(z) = min_j (A_j - B_j z), decel(z) = min_j (A_j + B_j z) with
    # A_j = 1/|c_j| and B_j = d_j/c_j; a row with c_j = 0 only requires |d_j| z <= 1.
    on = np.abs(c) > 1e-12 * np.max(np.abs(c))
    a_coef = 1.0 / np.abs(c[on])
    b_coef = d[on] / c[on]
    caps = [a / abs(b) for a, b in zip(a_coef, b_coef) if b != 0]
    caps += [1.0 / abs(dj) for dj in d[~on] if dj != 0]
    z_cap = min(caps, default=math.inf)
    w_cap = math.sqrt(z_cap)

    def accel(w: float) -> float:
        return float(np.min(a_coef - b_coef * (w * w)))

    def decel(w: float) -> float:
        return float(np.min(a_coef + b_coef * (w * w)))

    def integrals(sign: float, w: float) -> tuple[float, float]:
        """Exact ``(integral s / alpha(s) ds, integral 1 / alpha(s) ds)`` over ``[0, w]``.

        ``alpha(s) = min_j (A_j - sign B_j s^2)``; on each piece between
        kinks one row is active and both integrands have closed forms.
        """
        if w <= 0:
            return 0.0, 0.0
        bs = sign * b_coef
        cuts = {0.0, w}
        for i in range(a_coef.size):
            for j in range(i + 1, a_coef.size):
                if bs[i] != bs[j]:
                    z = (a_coef[i] - a_coef[j]) / (bs[i] - bs[j])
                    if 0.0 < z < w * w:
                        cuts.add(math.sqrt(z))
        cuts = sorted(cuts)
        dist = dur = 0.0
        for s0, s1 in itertools.pairwise(cuts):
            zm = (0.5 * (s0 + s1)) ** 2
            k = int(np.argmin(a_coef - bs * zm))
            a, b = float(a_coef[k]), float(bs[k])
            if b == 0.0:
                dist += (s1 * s1 - s0 * s0) / (2.0 * a)
                dur += (s1 - s0) / a
                continue
            dist += -math.log1p(-b * (s1 * s1 - s0 * s0) / (a - b * s0 * s0)) / (2.0 * b)
            r = math.sqrt(abs(b) / a)
            if b > 0:
                dur += (math.atanh(r * s1) - math.atanh(r * s0)) / math.sqrt(a * b)
            else:
                dur += (math.atan(r * s1) - math.atan(r * s0)) / math.sqrt(-a * b)
        return dist, dur

    def dist(fun: Any, w: float) -> float:
        return integrals(1.0 if fun is accel else -1.0, w)[0]

    def duration_of(fun: Any, w: float) -> float:
        return integrals(1.0 if fun is accel else -1.0, w)[1]

    def both(w: float) -> float:
        return dist(accel, w) + dist(decel, w)

    coast = 0.0
    rate_limited = rate_max is not None and rate_max < w_cap
    if angle <= 0:
        w_peak = 0.0
    elif rate_limited and both(rate_max) <= angle:
        w_peak = rate_max  # bang-coast-bang
        coast = (angle - both(rate_max)) / rate_max
    else:
        if rate_limited:
            top = rate_max
        elif math.isfinite(w_cap):
            # Capacity runs out at w_cap (acceleration or deceleration -> 0): the peak must stay below.
            top = w_cap * (1.0 - 1e-9)
            if both(top) < angle:
                raise ValueError(
                    f"eigenaxis slew infeasible: the gyroscopic torque uses up the torque limits at "
                    f"{w_cap:.6g} rad/s before the slew angle is covered"
                )
        else:
            top = 1.0
            while both(top) < angle:
                top *= 2.0
        w_peak = brentq(lambda w: both(w) - angle, 0.0, top, xtol=1e-15, rtol=1e-14)
    t_acc = duration_of(accel, w_peak)
    t_dec = duration_of(decel, w_peak)
    total = t_acc + coast + t_dec

    # Sample the profile: integrate the arcs with dense output.
    t = np.linspace(0.0, total, n_points) if total > 0 else np.zeros(1)
    theta = np.zeros_like(t)
    w = np.zeros_like(t)
    alpha = np.zeros_like(t)
    opts = {"method": "DOP853", "rtol": 1e-12, "atol": 1e-14, "dense_output": True}
    if t_acc > 0:
        acc = solve_ivp(lambda _s, y: [y[1], accel(y[1])], (0.0, t_acc), [0.0, 0.0], **opts)
        m = t <= t_acc
        y = acc.sol(t[m])
        theta[m], w[m] = y[0], y[1]
        alpha[m] = [accel(v) for v in y[1]]
    th_acc = dist(accel, w_peak)
    m = (t > t_acc) & (t <= t_acc + coast)
    theta[m] = th_acc + w_peak * (t[m] - t_acc)
    w[m] = w_peak
    if t_dec > 0:
        dec = solve_ivp(lambda _s, y: [y[1], -decel(max(y[1], 0.0))], (0.0, t_dec), [0.0, w_peak], **opts)
        m = t > t_acc + coast
        y = dec.sol(t[m] - t_acc - coast)
        theta[m], w[m] = th_acc + w_peak * coast + y[0], np.maximum(y[1], 0.0)
        alpha[m] = [-decel(v) for v in w[m]]
    torque = alpha[:, None] * ie[None, :] + (w * w)[:, None] * g0[None, :]
    return {
        "t": t,
        "angle": theta,
        "rate": w,
        "torque": torque,
        "duration": total,
        "peak_rate": w_peak,
        "coast": coast,
        "t_acc": t_acc,
    }


def eigenaxis_slew(
    body: RigidBody,
    q0: ArrayLike,
    qf: ArrayLike,
    *,
    torque_max: ArrayLike | ReactionWheels,
    rate_max: float | None = None,
    n_points: int = 201,
) -> EigenaxisSlew:
    """Time-optimal rest-to-rest rotation about the fixed eigenaxis, for comparison.

    Parameters
    ----------
    body : RigidBody
        The spacecraft (a single body).
    q0, qf : array_like (4,)
        Initial and final attitude ``q_BN`` (unit norm); the shorter way
        (angle <= pi) is taken.
    torque_max : float, array_like (3,) or ReactionWheels
        Per-axis torque limits [N m], or a wheel set (module docstring).
    rate_max : float, optional
        Body-rate limit [rad/s] (bang-coast-bang when reached).
    n_points : int
        Samples of the profile.

    Returns
    -------
    EigenaxisSlew
        For unit inertia, ``|u_i| <= 1`` and 180 degrees about a body axis the
        duration is ``2 sqrt(pi)`` = 3.5449 s (Bilimoria and Wie, 1993).

    Raises
    ------
    ValueError
        For bad attitudes or limits, or when the gyroscopic torque of the
        eigenaxis rotation exceeds the torque set before the angle is covered.
    """
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single RigidBody, got {body!r}")
    q0 = quat.as_unit_quaternion(q0, "q0")
    qf = quat.as_unit_quaternion(qf, "qf")
    if q0.shape != (4,) or qf.shape != (4,):
        raise ValueError(f"q0 and qf must have shape (4,), got {q0.shape} and {qf.shape}")
    tset = _TorqueSet.make(torque_max)
    if rate_max is not None:
        rate_max = float(check_positive(rate_max, "rate_max"))
    if int(n_points) < 2:
        raise ValueError(f"n_points must be at least 2, got {n_points}")
    axis, angle = _axis_angle(q0, qf)
    prof = _eigenaxis_profile(body.inertia, tset.rows, axis, angle, rate_max, int(n_points))
    q = quat.multiply(q0, quat.from_axis_angle(axis, prof["angle"]))
    return EigenaxisSlew(
        t=prof["t"],
        q=q,
        omega=prof["rate"][:, None] * axis[None, :],
        torque=prof["torque"],
        angle=prof["angle"],
        duration=float(prof["duration"]),
        axis_B=axis,
        total_angle=float(angle),
        peak_rate=float(prof["peak_rate"]),
        accel_duration=float(prof["t_acc"]),
        coast_duration=float(prof["coast"]),
        inertia=body.inertia,
    )


# ---------------------------------------------------------------------------
# Transcription
# ---------------------------------------------------------------------------


def _interval_function(prob: _Problem) -> ca.Function:
    """One multiple-shooting interval: ``(x, u, h, x_next) -> (defect, path constraints <= 0)``.

    The step is :func:`casadi_rk4_step` of the nondimensional body, so the
    dynamics are the one definition in :mod:`attitude.rigid_body`.
    """
    m = prob.substeps
    step = casadi_rk4_step(prob.body_s, substeps=1)
    x = ca.SX.sym("x", 7)
    u = ca.SX.sym("u", 3)
    h = ca.SX.sym("h")
    x_next = ca.SX.sym("x_next", 7)
    states = [x]
    for _ in range(m):
        states.append(step(states[-1], u, h / m))
    defect = states[-1] - x_next
    points = [*states[:-1], x_next]
    g = []
    if prob.rate_max_s is not None:
        g += [ca.sumsqr(p[4:]) - prob.rate_max_s**2 for p in points[1:]]
    if prob.cones:
        speed = [ca.sqrt(ca.sumsqr(p[4:]) + SPEED_EPS**2) for p in points]
        for cone in prob.cones:
            cos_sep = [
                ca.dot(ca.vertcat(*_rotate_components([p[i] for i in range(4)], cone.boresight_B)), cone.direction_N)
                for p in points
            ]
            for j in range(m):
                margin = (h / m) * (speed[j] + speed[j + 1]) / 4.0
                bound = ca.cos(ca.fmin(cone.half_angle + margin, math.pi))
                g += [cos_sep[j] - bound, cos_sep[j + 1] - bound]
    return ca.Function("slew_interval", [x, u, h, x_next], [defect, ca.vertcat(*g) if g else ca.SX(0, 1)])


@dataclass
class _Solution:
    status: str
    iterations: int
    solve_time: float
    X: NDArray[np.float64]
    U: NDArray[np.float64]
    H: NDArray[np.float64]
    objective: float

    @property
    def converged(self) -> bool:
        return self.status in CONVERGED

    @property
    def duration(self) -> float:
        return float(np.sum(self.H))


class _Transcription:
    """An Opti problem over ``n`` intervals with given interval-length and torque expressions."""

    def __init__(self, prob: _Problem, n: int, options: Mapping[str, Any]) -> None:
        self.prob = prob
        self.n = n
        self.opti = ca.Opti()
        self.X = self.opti.variable(7, n + 1)
        self.options = options

    def constrain(self, U: Any, H: Any) -> None:
        """Dynamics, boundary conditions and path constraints for torques ``U`` and lengths ``H``."""
        prob, opti, X = self.prob, self.opti, self.X
        fun = _interval_function(prob).map(self.n)
        defect, g = fun(X[:, :-1], U, H, X[:, 1:])
        opti.subject_to(ca.vec(defect) == 0)
        if g.numel():
            opti.subject_to(ca.vec(g) <= 0)
        opti.subject_to(X[:, 0] == prob.x0)
        opti.subject_to(X[4:, -1] == prob.omegaf * prob.t_s)
        w, x, y, z = prob.qf
        err = quaternion_multiply_components([w, -x, -y, -z], [X[i, -1] for i in range(4)])
        opti.subject_to(ca.vertcat(*err[1:]) == 0)

    def torque_set(self, U: Any) -> None:
        """Keep the torque variables ``U`` (3 x k) in the torque set."""
        prob = self.prob
        if prob.torque_set.is_box:
            lim = prob.u_bounds()
            for i in range(3):
                self.opti.subject_to(self.opti.bounded(-lim[i], U[i, :], lim[i]))
        else:
            self.opti.subject_to(self.opti.bounded(-1.0, ca.vec(ca.mtimes(prob.rows_s, U)), 1.0))

    def solve(self, initial: list[tuple[Any, Any]], values: dict[str, Any]) -> tuple[str, int, float, dict]:
        """Solve from ``initial`` (variable, value) pairs; returns status, iterations, time, values."""
        opti = self.opti
        for var, val in initial:
            opti.set_initial(var, val)
        start = time.perf_counter()
        try:
            opti.solve()
        except RuntimeError:
            pass
        elapsed = time.perf_counter() - start
        stats = opti.stats()
        out = {k: np.atleast_1d(np.asarray(opti.debug.value(v), dtype=float)) for k, v in values.items()}
        return str(stats.get("return_status", "unknown")), int(stats.get("iter_count", -1)), elapsed, out


def _ipopt_setup(tr: _Transcription, max_iter: int) -> None:
    opts = dict(IPOPT_DEFAULTS)
    opts["max_iter"] = int(max_iter)
    opts.update(tr.options)
    tr.opti.solver("ipopt", {"print_time": False, "detect_simple_bounds": True}, opts)


# ---------------------------------------------------------------------------
# Guesses
# ---------------------------------------------------------------------------


def _smooth_noise(rng: np.random.Generator, s: NDArray, dims: int, modes: int = 3) -> NDArray[np.float64]:
    """Smooth random functions of ``s`` in [0, 1] vanishing at both ends, O(1) amplitude, shape (len(s), dims)."""
    coef = rng.normal(size=(modes, dims)) / np.arange(1, modes + 1)[:, None]
    basis = np.sin(np.pi * np.outer(s, np.arange(1, modes + 1)))
    return basis @ coef


def _base_guess(prob: _Problem, n: int, duration_s: float | None) -> tuple[NDArray, NDArray, float]:
    """Eigenaxis-based guess (nondimensional): states (7, n+1), torques (3, n), duration."""
    axis, angle = _axis_angle(prob.q0, prob.qf)
    inertia_s = prob.body_s.inertia
    eig = None
    try:
        eig = _eigenaxis_profile(inertia_s, prob.rows_s, axis, angle, prob.rate_max_s, 401)
    except ValueError:
        eig = None
    if duration_s is None:
        base = eig["duration"] if eig is not None and eig["duration"] > 0 else 2.0 * math.sqrt(max(angle, 0.1))
        extra = (np.linalg.norm(prob.omega0) + np.linalg.norm(prob.omegaf)) * prob.t_s
        duration_s = base + extra
    s = np.linspace(0.0, 1.0, n + 1)
    t = s * duration_s
    if eig is not None and duration_s == eig["duration"] and eig["duration"] > 0:
        theta = np.interp(t, eig["t"], eig["angle"])
        rate = np.interp(t, eig["t"], eig["rate"])
    else:
        # Cubic angle profile: the minimum-energy rest-to-rest double integrator.
        theta = angle * (3 * s**2 - 2 * s**3)
        rate = angle * (6 * s - 6 * s**2) / duration_s
    q = quat.multiply(prob.q0, quat.from_axis_angle(axis, theta))
    w = rate[:, None] * axis[None, :]
    w = w + np.outer(1 - s, prob.omega0 * prob.t_s) + np.outer(s, prob.omegaf * prob.t_s)
    dw = np.diff(w, axis=0) / (duration_s / n)
    wm = 0.5 * (w[1:] + w[:-1])
    u = dw @ inertia_s.T + np.cross(wm, wm @ inertia_s.T)
    return np.vstack([q.T, w.T]), u.T, duration_s


def _perturbed(
    prob: _Problem, X: NDArray, U: NDArray, amplitude: float, rng: np.random.Generator
) -> tuple[NDArray, NDArray]:
    """Perturb a guess smoothly: torque noise and an attitude bump, both vanishing at the ends."""
    n = U.shape[1]
    if amplitude == 0:
        return X.copy(), _project(prob, U)
    s_nodes = np.linspace(0.0, 1.0, n + 1)
    s_mid = (np.arange(n) + 0.5) / n
    U = U + amplitude * _smooth_noise(rng, s_mid, 3).T * np.max(prob.u_bounds())
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    bump = amplitude * (math.pi / 4) * np.sin(np.pi * s_nodes)
    q = quat.multiply(X[:4].T, quat.from_axis_angle(axis, bump))
    X = X.copy()
    X[:4] = q.T
    return X, _project(prob, U)


def _project(prob: _Problem, U: NDArray) -> NDArray[np.float64]:
    """Scale each torque column into the torque set (direction kept)."""
    ratio = np.max(np.abs(prob.rows_s @ U), axis=0)
    return U / np.maximum(ratio, 1.0)


def _guess_from_plan(prob: _Problem, plan: SlewPlan, n: int) -> tuple[NDArray, NDArray, float]:
    t = np.linspace(0.0, plan.duration, n + 1)
    x = _states_between(prob.body, plan.t, plan.q, plan.omega, plan.torque, t)
    mid = 0.5 * (t[1:] + t[:-1])
    k = np.clip(np.searchsorted(plan.t, mid, side="right") - 1, 0, plan.t.size - 2)
    X = np.vstack([x[:, :4].T, (x[:, 4:] * prob.t_s).T])
    return X, plan.torque[k].T / prob.tau_s, plan.duration / prob.t_s


# ---------------------------------------------------------------------------
# Grid solve and refinement
# ---------------------------------------------------------------------------


def _solve_grid(
    prob: _Problem,
    n: int,
    objective: str,
    duration_s: float | None,
    smoothing: float,
    guesses: list[tuple[NDArray, NDArray, float]],
    max_iter: int,
    options: Mapping[str, Any],
) -> tuple[_Solution | None, list[_Solution]]:
    tr = _Transcription(prob, n, options)
    opti = tr.opti
    U = opti.variable(3, n)
    if objective == "time":
        T = opti.variable()
        H = ca.repmat(T / n, 1, n)
        t_guess = max(g[2] for g in guesses)
        opti.subject_to(opti.bounded(1e-3 * t_guess, T, 1e3 * t_guess))
        cost = T
    else:
        T = None
        H = ca.DM.ones(1, n) * (duration_s / n)
        cost = ca.sum2(ca.sum1(U * U) * H)
    if smoothing > 0:
        cost = cost + smoothing * ca.sumsqr(U[:, 1:] - U[:, :-1])
    opti.minimize(cost)
    tr.constrain(U, H)
    tr.torque_set(U)
    _ipopt_setup(tr, max_iter)
    values = {"X": tr.X, "U": U, "cost": cost}
    if T is not None:
        values["T"] = T
    results = []
    for X0, U0, T0 in guesses:
        init = [(tr.X, X0), (U, U0)]
        if T is not None:
            init.append((T, T0))
        status, iters, elapsed, val = tr.solve(init, values)
        t_total = float(val["T"][0]) if T is not None else duration_s
        results.append(
            _Solution(
                status=status,
                iterations=iters,
                solve_time=elapsed,
                X=val["X"].reshape(7, n + 1),
                U=val["U"].reshape(3, n),
                H=np.full(n, t_total / n),
                objective=float(val["cost"][0]),
            )
        )
    good = [r for r in results if r.converged]
    best = min(good, key=lambda r: r.objective) if good else None
    return best, results


def _row_segments(t: NDArray, s: NDArray) -> list[tuple[float, float, int]]:
    """Piecewise saturation label (-1, 0, +1) of one constraint row over time, switches located.

    ``s`` holds ``g . u`` per interval (in [-1, 1]). An interior run of at
    most :data:`TRANSITION_INTERVALS` intervals between opposite saturations
    is a switch: its time follows from the interval averages,
    ``sum s h = sL tau + sR (L - tau)``.
    """
    labels = np.where(s >= 1 - SATURATION_TOLERANCE, 1, np.where(s <= -1 + SATURATION_TOLERANCE, -1, 0))
    runs = []
    k = 0
    while k < labels.size:
        j = k
        while j < labels.size and labels[j] == labels[k]:
            j += 1
        runs.append((int(labels[k]), k, j))
        k = j
    h = np.diff(t)
    segs: list[tuple[float, float, int]] = []
    start = float(t[0])
    for r, (lab, k0, k1) in enumerate(runs):
        if (
            lab == 0
            and 0 < r < len(runs) - 1
            and k1 - k0 <= TRANSITION_INTERVALS
            and runs[r - 1][0] * runs[r + 1][0] == -1
        ):
            sl, sr = runs[r - 1][0], runs[r + 1][0]
            span = float(t[k1] - t[k0])
            tau = (float(np.sum(s[k0:k1] * h[k0:k1])) - sr * span) / (sl - sr)
            t_switch = float(t[k0]) + min(max(tau, 0.0), span)
            segs[-1] = (segs[-1][0], t_switch, segs[-1][2])
            start = t_switch
            continue
        segs.append((start, float(t[k1]), lab))
        start = float(t[k1])
    return segs


def _label_at(segs: list[tuple[float, float, int]], t: float) -> int:
    for a, b, lab in segs:
        if a <= t <= b:
            return lab
    return 0


def _refine(
    prob: _Problem, grid: _Solution, n_steps: int, max_iter: int, options: Mapping[str, Any]
) -> tuple[_Solution | None, dict[str, Any]]:
    """Multi-phase re-solve with free switch times (module docstring)."""
    t = np.concatenate([[0.0], np.cumsum(grid.H)])
    total = t[-1]
    signal = prob.rows_s @ grid.U  # (m, n)
    row_segs = [_row_segments(t, signal[j]) for j in range(signal.shape[0])]
    bounds = sorted({b for segs in row_segs for seg in segs for b in seg[:2]})
    merged = [0.0]
    for b in bounds:
        if b - merged[-1] > 1e-6 * total:
            merged.append(b)
    merged[-1] = total
    edges = np.array(merged)
    n_phase = edges.size - 1
    info: dict[str, Any] = {"phases": n_phase}
    if n_phase > MAX_PHASES:
        info["status"] = f"skipped: {n_phase} phases (more than {MAX_PHASES}); switching structure too fine to trust"
        return None, info
    modes, vertex = [], []
    for p in range(n_phase):
        mid = 0.5 * (edges[p] + edges[p + 1])
        labels = np.array([_label_at(segs, mid) for segs in row_segs])
        active = labels != 0
        if active.sum() >= 3 and np.linalg.matrix_rank(prob.rows_s[active]) == 3:
            modes.append("constant")
            vertex.append(np.linalg.lstsq(prob.rows_s[active], labels[active].astype(float), rcond=None)[0])
        else:
            modes.append("free")
            vertex.append(None)
    info["modes"] = modes
    if "constant" not in modes:
        info["status"] = "skipped: no saturated (bang) arc spans a whole interval; nothing to refine"
        return None, info
    fractions = np.diff(edges) / total
    steps = [max(2, math.ceil(n_steps * f)) for f in fractions]
    n_int = int(sum(steps))
    info["steps"] = steps

    tr = _Transcription(prob, n_int, options)
    opti = tr.opti
    Tp = opti.variable(n_phase)
    opti.subject_to(opti.bounded(0.0, Tp, 10.0 * total))
    u_cols, h_cols, init = [], [], []
    u_vars = []
    for p in range(n_phase):
        if modes[p] == "constant":
            v = opti.variable(3)
            u_cols.append(ca.repmat(v, 1, steps[p]))
            init.append((v, vertex[p]))
        else:
            v = opti.variable(3, steps[p])
            u_cols.append(v)
            tp = edges[p] + (np.arange(steps[p]) + 0.5) * (edges[p + 1] - edges[p]) / steps[p]
            k = np.clip(np.searchsorted(t, tp, side="right") - 1, 0, grid.U.shape[1] - 1)
            init.append((v, grid.U[:, k]))
        u_vars.append(v)
        h_cols.append(ca.repmat(Tp[p] / steps[p], 1, steps[p]))
    U = ca.horzcat(*u_cols)
    H = ca.horzcat(*h_cols)
    opti.minimize(ca.sum1(Tp))
    tr.constrain(U, H)
    for v in u_vars:
        tr.torque_set(v)
    _ipopt_setup(tr, max_iter)
    t_new = np.concatenate([[0.0], np.cumsum(np.repeat(np.diff(edges) / steps, steps))])
    X0 = _interp_states(t, grid.X, t_new)
    init += [(Tp, np.diff(edges)), (tr.X, X0)]
    status, iters, elapsed, val = tr.solve(init, {"X": tr.X, "U": U, "H": H, "Tp": Tp})
    sol = _Solution(
        status=status,
        iterations=iters,
        solve_time=elapsed,
        X=val["X"].reshape(7, n_int + 1),
        U=val["U"].reshape(3, n_int),
        H=val["H"].reshape(n_int),
        objective=float(np.sum(val["Tp"])),
    )
    info.update({"status": status, "iterations": iters, "solve_time_s": elapsed})
    info["phase_durations"] = (np.maximum(val["Tp"], 0.0) * prob.t_s).tolist()
    return sol, info


def _interp_states(t: NDArray, X: NDArray, t_new: NDArray) -> NDArray[np.float64]:
    out = np.stack([np.interp(t_new, t, X[i]) for i in range(7)])
    out[:4] /= np.linalg.norm(out[:4], axis=0, keepdims=True)
    return out


def _drop_empty(sol: _Solution) -> _Solution:
    """Remove intervals of (numerically) zero length so the time grid increases strictly."""
    keep = sol.H > 1e-9 * sol.duration
    if np.all(keep):
        return sol
    idx_nodes = np.concatenate([[0], np.nonzero(keep)[0] + 1])
    # node k+1 ends interval k; dropping interval k merges node k+1 into node k
    X = sol.X[:, idx_nodes]
    X[:, -1] = sol.X[:, -1]
    return replace(sol, X=X, U=sol.U[:, keep], H=sol.H[keep])


# ---------------------------------------------------------------------------
# Verification
# ---------------------------------------------------------------------------


def _states_between(
    body: RigidBody, t: NDArray, q: NDArray, omega: NDArray, torque: NDArray, t_new: NDArray
) -> NDArray[np.float64]:
    """States at ``t_new`` integrated from the preceding node of ``t`` under the ZOH torque (RK4, 8 sub-steps)."""
    k = np.clip(np.searchsorted(t, t_new, side="right") - 1, 0, t.size - 2)
    dt = t_new - t[k]
    x0 = np.concatenate([q[k], omega[k]], axis=1)
    step = casadi_rk4_step(body, substeps=8).map(t_new.size)
    out = np.asarray(step(x0.T, torque[k].T, dt[None, :])).T
    exact = dt == 0
    out[exact] = x0[exact]
    return out


def _verify(prob: _Problem, t: NDArray, torque: NDArray, cones: Sequence[KeepOutCone]) -> dict[str, Any]:
    traj = propagate(prob.body, prob.q0, prob.omega0, t, torque, method="adaptive", rtol=1e-10, atol=1e-12)
    att_err = float(quat.error_angle(prob.qf, quat.normalize(traj.q[-1])))
    rate_err = float(np.linalg.norm(traj.omega[-1] - prob.omegaf))
    frac = np.arange(CHECK_SAMPLES) / CHECK_SAMPLES
    t_fine = np.concatenate([(t[:-1, None] + frac[None, :] * np.diff(t)[:, None]).ravel(), t[-1:]])
    x = _states_between(prob.body, t, traj.q, traj.omega, torque, t_fine)
    q_fine = quat.normalize(x[:, :4])
    sep = np.array([float(np.min(c.separation(q_fine))) for c in cones]) if cones else np.zeros(0)
    return {
        "final_attitude_error": att_err,
        "final_rate_error": rate_err,
        "min_separation": sep,
        "max_rate": float(np.max(np.linalg.norm(x[:, 4:], axis=1))),
        "nfev": traj.info.get("nfev"),
    }


# ---------------------------------------------------------------------------
# The planner
# ---------------------------------------------------------------------------


def _validate(
    body: Any,
    q0: ArrayLike,
    qf: ArrayLike,
    omega0: ArrayLike,
    omegaf: ArrayLike,
    torque_max: Any,
    rate_max: Any,
    keep_out: Sequence[KeepOutCone],
    substeps: int,
) -> _Problem:
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single (unbatched) RigidBody, got {body!r}")
    q0 = quat.as_unit_quaternion(q0, "q0")
    qf = quat.as_unit_quaternion(qf, "qf")
    if q0.shape != (4,) or qf.shape != (4,):
        raise ValueError(f"q0 and qf must have shape (4,), got {q0.shape} and {qf.shape}")
    omega0 = _vector3(omega0, "omega0")
    omegaf = _vector3(omegaf, "omegaf")
    tset = _TorqueSet.make(torque_max)
    if rate_max is not None:
        rate_max = float(check_positive(rate_max, "rate_max"))
        for name, w in (("omega0", omega0), ("omegaf", omegaf)):
            if np.linalg.norm(w) > rate_max:
                raise ValueError(
                    f"{name} must respect rate_max: |{name}| = {np.linalg.norm(w):.6g} rad/s > {rate_max:.6g} rad/s"
                )
    cones = (keep_out,) if isinstance(keep_out, KeepOutCone) else tuple(keep_out)
    for i, cone in enumerate(cones):
        if not isinstance(cone, KeepOutCone):
            raise ValueError(f"keep_out[{i}] must be a KeepOutCone, got {type(cone).__name__}")
        for name, q in (("q0", q0), ("qf", qf)):
            sep = float(cone.separation(q))
            if sep <= cone.half_angle:
                raise ValueError(
                    f"keep_out[{i}] {cone.name!r} contains the boresight at {name}: separation "
                    f"{math.degrees(sep):.4f} deg <= half angle {math.degrees(cone.half_angle):.4f} deg"
                )
    if isinstance(substeps, bool) or not isinstance(substeps, (int, np.integer)) or substeps < 1:
        raise ValueError(f"substeps must be a positive integer, got {substeps!r}")
    j_s = float(np.max(body.principal_axes().moments))
    tau_s = float(np.max(tset.envelope))
    t_s = math.sqrt(j_s / tau_s)
    return _Problem(
        body=body,
        body_s=RigidBody(body.inertia / j_s),
        q0=q0,
        qf=qf,
        omega0=omega0,
        omegaf=omegaf,
        torque_set=tset,
        rows_s=tset.rows * tau_s,
        rate_max=rate_max,
        cones=cones,
        substeps=int(substeps),
        j_s=j_s,
        tau_s=tau_s,
        t_s=t_s,
    )


def plan_slew(
    body: RigidBody,
    q0: ArrayLike,
    qf: ArrayLike,
    *,
    omega0: ArrayLike = 0.0,
    omegaf: ArrayLike = 0.0,
    torque_max: ArrayLike | ReactionWheels,
    objective: str = "time",
    duration: float | None = None,
    rate_max: float | None = None,
    keep_out: Sequence[KeepOutCone] = (),
    nodes: int = 50,
    substeps: int = 2,
    refine: bool | None = None,
    refine_steps: int | None = None,
    smoothing: float = 0.0,
    starts: int = 1,
    perturbation: float = 0.2,
    rng: object = 0,
    initial_guess: SlewPlan | None = None,
    max_iter: int = 1000,
    ipopt_options: Mapping[str, Any] | None = None,
    verify_tolerance: float = 1e-4,
) -> SlewPlan:
    """Plan a minimum-time or minimum-energy slew (module docstring for the method).

    Parameters
    ----------
    body : RigidBody
        The spacecraft (a single body) [kg m^2].
    q0, qf : array_like (4,)
        Initial and final attitude ``q_BN`` (unit norm, scalar first); ``qf``
        and ``-qf`` are the same target.
    omega0, omegaf : float or array_like (3,)
        Initial and final body rate ``omega_BN_B`` [rad/s] (default rest).
    torque_max : float, array_like (3,) or ReactionWheels
        Per-axis torque bound [N m] (box), or a wheel set whose allocation
        envelope limits the body torque.
    objective : {"time", "energy"}
        Minimum time (free final time) or minimum ``integral |tau|^2 dt``
        over a fixed ``duration``.
    duration : float, optional
        Slew duration [s]; required for "energy", not allowed for "time".
    rate_max : float, optional
        Limit on ``|omega|`` [rad/s].
    keep_out : sequence of KeepOutCone
        Boresight exclusion cones, enforced between nodes too.
    nodes : int
        Intervals of the uniform grid (>= 4).
    substeps : int
        RK4 steps per interval (2-4 keeps the RK4 error far below the grid
        error).
    refine : bool, optional
        Recover the switch times with a multi-phase re-solve (default: True
        for "time", not available for "energy").
    refine_steps : int, optional
        Intervals of the refined problem, spread over the phases in
        proportion to their durations (at least 2 each; default ``nodes``).
    smoothing : float
        Weight of the torque-increment penalty (module docstring), >= 0.
    starts : int
        Number of perturbed starts; the best converged solution is kept.
    perturbation : float
        Size of the guess perturbation: torque noise as a fraction of the
        largest torque, and an attitude bump of ``perturbation * pi / 4`` rad.
        Zero starts exactly on the eigenaxis guess.
    rng : numpy.random.Generator, int or None
        Source of the perturbations (default seed 0: reproducible plans).
    initial_guess : SlewPlan, optional
        Warm start (e.g. a previous plan); used for the first start.
    max_iter : int
        IPOPT iteration limit per solve.
    ipopt_options : mapping, optional
        Extra IPOPT options (override :data:`IPOPT_DEFAULTS`).
    verify_tolerance : float
        Largest accepted final attitude error [rad] of the open-loop
        re-simulation; the final rate error is accepted up to
        ``verify_tolerance / T_s`` [rad/s].

    Returns
    -------
    SlewPlan
        Verified plan (module docstring).

    Raises
    ------
    ValueError
        Bad input: non-unit or non-finite quaternions, non-positive limits,
        boundary rates above ``rate_max``, a keep-out cone containing the
        initial or final boresight, inconsistent objective/duration.
    InfeasibleSlewError
        The problem is infeasible, e.g. a ``duration`` shorter than the
        minimum time for these limits (also a ValueError).
    SlewPlanningError
        IPOPT failed on every start, or the re-simulation missed the target.

    Examples
    --------
    The benchmark of Bilimoria and Wie (1993), 180 degrees about body x:

    >>> from attitude import RigidBody, quaternion as quat
    >>> plan = plan_slew(RigidBody([1.0, 1.0, 1.0]), [1.0, 0.0, 0.0, 0.0],
    ...                  quat.from_axis_angle([1.0, 0.0, 0.0], np.pi), torque_max=1.0)
    >>> round(plan.refined_duration, 4), round(plan.eigenaxis_duration, 4)
    (3.2431, 3.5449)
    """
    wall_start = time.perf_counter()
    prob = _validate(body, q0, qf, omega0, omegaf, torque_max, rate_max, keep_out, substeps)
    if objective not in OBJECTIVES:
        raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
    if objective == "time" and duration is not None:
        raise ValueError(f"duration must be None for objective='time' (the final time is free), got {duration!r}")
    if objective == "energy":
        if duration is None:
            raise ValueError("duration [s] is required for objective='energy'")
        duration = float(check_positive(duration, "duration"))
    if refine is None:
        refine = objective == "time"
    if refine and objective != "time":
        raise ValueError("refine is only available for objective='time' (switch-time refinement of bang-bang arcs)")
    for name, value, low in (("nodes", nodes, 4), ("starts", starts, 1), ("max_iter", max_iter, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    refine_steps = int(nodes if refine_steps is None else refine_steps)
    if refine_steps < 4:
        raise ValueError(f"refine_steps must be an integer >= 4, got {refine_steps!r}")
    smoothing = float(check_positive(smoothing, "smoothing", allow_zero=True))
    perturbation = float(check_positive(perturbation, "perturbation", allow_zero=True))
    verify_tolerance = float(check_positive(verify_tolerance, "verify_tolerance"))
    if initial_guess is not None and not isinstance(initial_guess, SlewPlan):
        raise ValueError(f"initial_guess must be a SlewPlan, got {type(initial_guess).__name__}")
    if objective == "time" and np.allclose(prob.omega0, prob.omegaf) and _axis_angle(prob.q0, prob.qf)[1] == 0:
        raise ValueError("q0 equals qf and omega0 equals omegaf: the minimum-time slew is empty")
    gen = as_generator(rng)
    options = dict(ipopt_options or {})
    n = int(nodes)
    duration_s = None if duration is None else duration / prob.t_s

    base_X, base_U, base_T = _base_guess(prob, n, duration_s)
    guesses = []
    for i in range(int(starts)):
        if i == 0 and initial_guess is not None:
            X0, U0, T0 = _guess_from_plan(prob, initial_guess, n)
            guesses.append((X0, _project(prob, U0), T0 if duration_s is None else duration_s))
            continue
        # Later starts perturb more: they are there to explore other local optima.
        X0, U0 = _perturbed(prob, base_X, base_U, perturbation * (1.0 + 0.5 * i), gen)
        guesses.append((X0, U0, base_T))

    best, results = _solve_grid(prob, n, objective, duration_s, smoothing, guesses, int(max_iter), options)
    starts_info = [
        {
            "status": r.status,
            "iterations": r.iterations,
            "solve_time_s": r.solve_time,
            "objective": r.objective,
            "duration_s": r.duration * prob.t_s,
        }
        for r in results
    ]
    solve_time = sum(r.solve_time for r in results)
    if best is None:
        _raise_failure(prob, objective, duration, results, n, options, int(max_iter))

    grid_duration = best.duration * prob.t_s
    chosen = best
    refined_duration = None
    switch_times = np.zeros(0)
    refine_info: dict[str, Any] = {"requested": bool(refine)}
    if refine:
        sol, rinfo = _refine(prob, best, refine_steps, int(max_iter), options)
        refine_info.update(rinfo)
        if sol is not None:
            solve_time += sol.solve_time
            if not sol.converged:
                refine_info["status"] = f"rejected: IPOPT {sol.status}"
            elif sol.duration > best.duration * (1 + REFINEMENT_SLACK):
                refine_info["status"] = (
                    f"rejected: refined time {sol.duration * prob.t_s:.6g} s exceeds the grid time "
                    f"{grid_duration:.6g} s (the detected switching structure is wrong)"
                )
            else:
                chosen = _drop_empty(sol)
                refined_duration = sol.duration * prob.t_s
                # Boundaries between phases of non-zero length (empty phases collapse onto a neighbour).
                d = np.asarray(rinfo["phase_durations"])
                tol = 1e-9 * refined_duration
                after = np.cumsum(d[::-1])[::-1]
                keep = (d > tol) & (after - d > tol)
                switch_times = np.cumsum(d)[keep]
        if refined_duration is None and not str(refine_info.get("status", "")).startswith("skipped"):
            warnings.warn(
                f"slew refinement not used ({refine_info.get('status')}); returning the {n}-node grid solution",
                RuntimeWarning,
                stacklevel=2,
            )

    t = np.concatenate([[0.0], np.cumsum(chosen.H)]) * prob.t_s
    torque = chosen.U.T * prob.tau_s
    ratio = prob.torque_set.ratio(torque)
    torque = torque / np.maximum(ratio, 1.0)[:, None]
    torque = np.vstack([torque, torque[-1:]])
    check = _verify(prob, t, torque, prob.cones)
    rate_tol = verify_tolerance / prob.t_s
    problems = []
    if check["final_attitude_error"] > verify_tolerance:
        problems.append(f"final attitude error {check['final_attitude_error']:.3g} rad > {verify_tolerance:.3g}")
    if check["final_rate_error"] > rate_tol:
        problems.append(f"final rate error {check['final_rate_error']:.3g} rad/s > {rate_tol:.3g}")
    if prob.rate_max is not None and check["max_rate"] > prob.rate_max + rate_tol:
        problems.append(f"largest rate {check['max_rate']:.6g} rad/s > rate_max {prob.rate_max:.6g}")
    for i, cone in enumerate(prob.cones):
        if check["min_separation"][i] < cone.half_angle - verify_tolerance:
            problems.append(
                f"keep_out[{i}] separation {check['min_separation'][i]:.6g} rad < half angle {cone.half_angle:.6g}"
            )
    if problems:
        raise SlewPlanningError(
            f"the plan failed its open-loop re-simulation: {'; '.join(problems)}; increase substeps or nodes",
            status="verification_failed",
            cause="transcription error of the RK4 grid too large for this slew",
            details=check,
        )
    h = np.diff(t)
    energy = float(np.sum(np.sum(torque[:-1] ** 2, axis=1) * h))
    duration_out = float(t[-1])
    eig_duration = None
    if not np.any(prob.omega0) and not np.any(prob.omegaf):
        try:
            eig_duration = eigenaxis_slew(
                prob.body, prob.q0, prob.qf, torque_max=torque_max, rate_max=prob.rate_max, n_points=2
            ).duration
        except ValueError:
            eig_duration = None
    bore, direc, half = _cone_arrays(prob.cones)
    info = {
        "scaling": {"inertia_kg_m2": prob.j_s, "torque_n_m": prob.tau_s, "time_s": prob.t_s},
        "nodes": n,
        "substeps": prob.substeps,
        "smoothing": smoothing,
        "perturbation": perturbation,
        "torque_set": prob.torque_set.label,
        "keep_out_names": [c.name for c in prob.cones],
        "starts": starts_info,
        "best_start": int(results.index(best)),
        "grid_status": best.status,
        "grid_iterations": best.iterations,
        "refinement": refine_info,
        "energy_n2m2s": energy,
        "torque_clip_ratio": float(np.max(ratio)),
        "verification": {k: v for k, v in check.items() if k != "min_separation"},
    }
    return SlewPlan(
        t=t,
        q=chosen.X[:4].T.copy(),
        omega=chosen.X[4:].T / prob.t_s,
        torque=torque,
        duration=duration_out,
        objective=objective,
        objective_value=duration_out if objective == "time" else energy,
        status=chosen.status,
        iterations=chosen.iterations,
        wall_time=time.perf_counter() - wall_start,
        solve_time=solve_time,
        grid_duration=grid_duration,
        refined_duration=refined_duration,
        switch_times=switch_times,
        final_attitude_error=check["final_attitude_error"],
        final_rate_error=check["final_rate_error"],
        min_separation=check["min_separation"],
        max_rate=check["max_rate"],
        q_target=prob.qf.copy(),
        omega_target=prob.omegaf.copy(),
        inertia=prob.body.inertia,
        torque_envelope=prob.torque_set.envelope.copy(),
        torque_rows=prob.torque_set.rows.copy(),
        rate_max=prob.rate_max,
        keep_out_boresight_B=bore,
        keep_out_direction_N=direc,
        keep_out_half_angle=half,
        eigenaxis_duration=eig_duration,
        info=info,
    )


def _raise_failure(
    prob: _Problem,
    objective: str,
    duration: float | None,
    results: list[_Solution],
    n: int,
    options: Mapping[str, Any],
    max_iter: int,
) -> None:
    """Explain why no start converged, and raise."""
    statuses = [r.status for r in results]
    details = {"statuses": statuses, "iterations": [r.iterations for r in results]}
    status = statuses[0]
    infeasible = any(s in INFEASIBLE for s in statuses)
    if objective == "energy" and duration is not None:
        # Is the duration shorter than the minimum time? Solve the minimum-time problem coarsely to find out.
        g = _base_guess(prob, min(n, 40), None)
        Xg, Ug = _perturbed(prob, g[0], g[1], 0.2, np.random.default_rng(0))
        best, _ = _solve_grid(prob, min(n, 40), "time", None, 0.0, [(Xg, Ug, g[2])], max_iter, options)
        if best is not None and best.duration * prob.t_s > duration:
            t_min = best.duration * prob.t_s
            cause = (
                f"the requested duration {duration:.6g} s is shorter than the minimum time "
                f"(about {t_min:.6g} s on a {min(n, 40)}-node grid) for these torque, rate and keep-out limits"
            )
            details["minimum_time_s"] = t_min
            raise InfeasibleSlewError(
                f"slew infeasible (IPOPT: {', '.join(sorted(set(statuses)))}): {cause}",
                status=status,
                cause=cause,
                details=details,
            )
    if infeasible:
        cause = (
            "the constraints admit no slew: keep-out cones may block every path between q0 and qf, or the "
            "rate limit and boundary rates are incompatible with the torque limits"
        )
        raise InfeasibleSlewError(
            f"slew infeasible (IPOPT: {', '.join(sorted(set(statuses)))}): {cause}",
            status=status,
            cause=cause,
            details=details,
        )
    if any(s == "Maximum_Iterations_Exceeded" for s in statuses):
        cause = f"IPOPT reached max_iter={max_iter} without converging; raise max_iter, add starts or smoothing"
    else:
        cause = "IPOPT stopped without converging; try more starts, another perturbation or more nodes"
    raise SlewPlanningError(
        f"slew planning failed (IPOPT: {', '.join(sorted(set(statuses)))} on {len(statuses)} start(s)): {cause}",
        status=status,
        cause=cause,
        details=details,
    )


# ---------------------------------------------------------------------------
# Plot
# ---------------------------------------------------------------------------


def _plot_plan(plan: SlewPlan) -> matplotlib.figure.Figure:
    from matplotlib.figure import Figure

    from attitude.plotting import AXIS_COLORS

    fine = plan.resample(plan.duration / 400.0) if plan.t.size < 400 else plan
    fig = Figure(figsize=(11, 7.5), layout="constrained")
    ax = fig.subplots(2, 2, sharex=True)
    for i, name in enumerate("xyz"):
        ax[0, 0].step(plan.t, plan.torque[:, i], where="post", color=AXIS_COLORS[i], label=rf"$\tau_{name}$")
        ax[0, 0].axhline(plan.torque_envelope[i], color=AXIS_COLORS[i], ls=":", lw=0.8)
        ax[0, 0].axhline(-plan.torque_envelope[i], color=AXIS_COLORS[i], ls=":", lw=0.8)
        ax[0, 1].plot(fine.t, np.degrees(fine.omega[:, i]), color=AXIS_COLORS[i], label=rf"$\omega_{name}$")
    ax[0, 0].set_ylabel("torque [N m]")
    ax[0, 0].set_title("torque (dotted: per-axis limits)")
    ax[0, 1].plot(fine.t, np.degrees(np.linalg.norm(fine.omega, axis=1)), color="black", label=r"$|\omega|$")
    if plan.rate_max is not None:
        ax[0, 1].axhline(math.degrees(plan.rate_max), color="black", ls="--", lw=0.8, label="rate limit")
    ax[0, 1].set_ylabel("body rate [deg/s]")
    ax[0, 1].set_title("body rate")
    for i, name in enumerate("wxyz"):
        ax[1, 0].plot(fine.t, fine.q[:, i], color=("black", *AXIS_COLORS)[i], label=f"$q_{name}$")
    to_go = np.degrees(quat.error_angle(plan.q_target, quat.normalize(fine.q)))
    twin = ax[1, 0].twinx()
    twin.plot(fine.t, to_go, color="0.5", ls="--", label="angle to go")
    twin.set_ylabel("angle to go [deg]")
    ax[1, 0].set_ylabel(r"attitude $q_{BN}$")
    ax[1, 0].set_title("attitude path")
    sep = fine.separation()
    if sep.shape[1]:
        for j, cone in enumerate(plan.keep_out):
            line = ax[1, 1].plot(fine.t, np.degrees(sep[:, j]), label=cone.name or f"cone {j}")[0]
            ax[1, 1].axhline(math.degrees(cone.half_angle), color=line.get_color(), ls="--", lw=0.8)
        ax[1, 1].set_title("keep-out separation (dashed: cone half angle)")
    else:
        ax[1, 1].text(0.5, 0.5, "no keep-out cones", transform=ax[1, 1].transAxes, ha="center", va="center")
        ax[1, 1].set_title("keep-out separation")
    ax[1, 1].set_ylabel("separation [deg]")
    for a in ax.ravel():
        a.grid(True, alpha=0.3)
        a.margins(x=0)
        if a.get_legend_handles_labels()[0]:
            a.legend(loc="best", fontsize="small")
    for a in ax[1]:
        a.set_xlabel("time [s]")
    refined = "" if plan.refined_duration is None else f", grid {plan.grid_duration:.5g} s"
    eig = "" if plan.eigenaxis_duration is None else f", eigenaxis {plan.eigenaxis_duration:.5g} s"
    fig.suptitle(f"{plan.objective}-optimal slew: {plan.duration:.5g} s{refined}{eig} ({plan.status})")
    return fig

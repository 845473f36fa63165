"""Inputs of the slew planner: errors, the torque set, and validated nondimensional problems.

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.rigid_body import RigidBody
from attitude.validation import as_float_array, check_positive
from controllers.slew.keep_out import KeepOutCone

__all__ = [
    "CONVERGED",
    "INFEASIBLE",
    "OBJECTIVES",
    "SLEW_SPAN_MAX",
    "InfeasibleSlewError",
    "Problem",
    "SlewPlanningError",
    "TorqueSet",
    "check_count",
    "momentum_rate_max",
    "validate",
    "vector3",
]

OBJECTIVES = ("time", "energy")

#: IPOPT statuses accepted as converged.
CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")

#: Longest slew in units of the time scale ``T_s`` (docs/slew_planning.md,
#: Scaling): a slew longer than this many torque times ``sqrt(J_s / tau_max)``
#: (a long fixed duration, a tight rate limit) stretches ``T_s`` to a tenth
#: of the slew. The benchmark slews take 2.6 to 6.8 torque times, so they keep
#: the torque time; the 90 deg slews with 0.02 N m over 1e4 s, or at 1e-4
#: rad/s, took 408 and 641 of them, and IPOPT found no answer.
SLEW_SPAN_MAX = 10.0

#: IPOPT statuses that point at an infeasible problem.
INFEASIBLE = ("Infeasible_Problem_Detected", "Restoration_Failed", "Local_Infeasibility")


class SlewPlanningError(RuntimeError):
    """The optimiser did not return a trustworthy plan.

    Parameters
    ----------
    message : str
        The error message.
    status : str, optional
        IPOPT's return status (or ``"verification_failed"``, ``"keep_out_blocked"``).
    cause : str, optional
        The likely cause, in words.
    details : dict, optional
        Solver statistics for diagnosis.

    Attributes
    ----------
    status : str
        IPOPT's return status (or ``"verification_failed"``, ``"keep_out_blocked"``).
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


@dataclass(frozen=True)
class TorqueSet:
    """Body torques with ``|rows @ tau| <= 1`` (rows in 1/(N m)).

    Parameters
    ----------
    rows : ndarray
        Rows ``R`` of the set ``|R @ tau| <= 1`` [1/(N m)], shape (m, 3).
    envelope : ndarray
        Largest torque per body axis [N m] (3,).
    is_box : bool
        True for a per-axis box (``rows`` diagonal).
    label : str
        Description in words (e.g. ``"4 reaction wheels"``).
    """

    rows: NDArray[np.float64]
    envelope: NDArray[np.float64]
    is_box: bool
    label: str

    @classmethod
    def make(cls, torque_max: ArrayLike | ReactionWheels) -> TorqueSet:
        """The set of a per-axis bound [N m] (scalar or 3) or of a wheel set's allocation.

        Parameters
        ----------
        torque_max : array_like or ReactionWheels
            Per-axis torque bound [N m] (scalar or 3 values), or a wheel set.
        """
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
        """Largest ``|rows @ tau|`` per torque (..., 3) -> (...): <= 1 inside the set.

        Parameters
        ----------
        tau : ndarray
            Body torques [N m], shape (..., 3).
        """
        return np.max(np.abs(tau @ self.rows.T), axis=-1)


def vector3(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A rate [rad/s] given as a scalar or 3 components, as a (3,) array.

    Parameters
    ----------
    value : array_like
        A rate [rad/s]: a scalar or 3 components.
    name : str
        Argument name, for the error message.
    """
    arr = as_float_array(value, name)
    if arr.shape not in ((), (3,)):
        raise ValueError(f"{name} must be a scalar or shape (3,) in rad/s, got shape {arr.shape}")
    return np.broadcast_to(arr, (3,)).astype(float).copy()


def check_count(value: Any, name: str, low: int) -> int:
    """An integer option ``>= low`` (bools, floats and NaN are rejected, not truncated).

    Parameters
    ----------
    value : int
        The option's value.
    name : str
        The option's name, for the error message.
    low : int
        Smallest accepted value.
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    return int(value)


@dataclass
class Problem:
    """Validated inputs in nondimensional form.

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    body_s : RigidBody
        The spacecraft with its inertia divided by ``j_s`` (nondimensional).
    q0 : ndarray
        Initial attitude ``q_BN`` (4,).
    qf : ndarray
        Final attitude ``q_BN`` (4,).
    omega0 : ndarray
        Initial body rate [rad/s] (3,).
    omegaf : ndarray
        Final body rate [rad/s] (3,).
    torque_set : TorqueSet
        The admissible body torques [N m].
    rows_s : ndarray
        Rows of the torque set in units of ``1 / tau_s``.
    rate_max : float or None
        Body-rate limit [rad/s]; None for no limit.
    cones : tuple of KeepOutCone
        Keep-out cones.
    substeps : int
        RK4 steps per interval, >= 1.
    j_s : float
        Inertia scale: the largest principal moment [kg m^2].
    tau_s : float
        Torque scale ``j_s / t_s^2`` [N m]: the largest per-axis torque as
        validated, smaller after :meth:`scaled_to` lengthens ``t_s`` for a
        long slew (the torque bounds are then ``>= 1`` in its units).
    t_s : float
        Time scale [s]: ``sqrt(j_s / tau_max)`` for the largest per-axis
        torque ``tau_max``, or longer after :meth:`scaled_to`; always
        ``sqrt(j_s / tau_s)``.
    keep_out_margin : bool, optional
        Add the second-order margin between checkpoints (docs/keep_out.md).
    """

    body: RigidBody
    body_s: RigidBody
    q0: NDArray[np.float64]
    qf: NDArray[np.float64]
    omega0: NDArray[np.float64]
    omegaf: NDArray[np.float64]
    torque_set: TorqueSet
    rows_s: NDArray[np.float64]
    rate_max: float | None
    cones: tuple[KeepOutCone, ...]
    substeps: int
    j_s: float
    tau_s: float
    t_s: float
    keep_out_margin: bool = True

    @property
    def x0(self) -> NDArray[np.float64]:
        """Initial state ``[q0, omega0 T_s]`` (nondimensional)."""
        return np.concatenate([self.q0, self.omega0 * self.t_s])

    @property
    def rate_max_scaled(self) -> float | None:
        """Rate limit in units of 1/T_s."""
        return None if self.rate_max is None else self.rate_max * self.t_s

    def u_bounds(self) -> NDArray[np.float64]:
        """Per-axis torque bounds in units of tau_s (box sets)."""
        return self.torque_set.envelope / self.tau_s

    def scaled_to(self, slew_time: float | None) -> Problem:
        """The problem with its time scale fitted to a slew of about ``slew_time`` [s] (docs/slew_planning.md).

        ``T_s = max(sqrt(J_s / tau_max), slew_time / SLEW_SPAN_MAX)`` and
        ``tau_s = J_s / T_s^2``, so the nondimensional body and equations of
        motion are the same; only the torque bounds (``tau_max / tau_s >= 1``)
        and the rate limit in units of ``1 / T_s`` change.

        Parameters
        ----------
        slew_time : float or None
            Expected slew duration [s] (the fixed duration, or the eigenaxis
            time); None or a non-finite value keeps the torque time.
        """
        t_torque = math.sqrt(self.j_s / float(np.max(self.torque_set.envelope)))
        t_s = t_torque
        if slew_time is not None and math.isfinite(slew_time):
            t_s = max(t_torque, slew_time / SLEW_SPAN_MAX)
        if t_s == self.t_s:
            return self
        tau_s = self.j_s / t_s**2
        return replace(self, t_s=t_s, tau_s=tau_s, rows_s=self.torque_set.rows * tau_s)


def validate(
    body: Any,
    q0: ArrayLike,
    qf: ArrayLike,
    omega0: ArrayLike,
    omegaf: ArrayLike,
    torque_max: Any,
    rate_max: Any,
    keep_out: Sequence[KeepOutCone] | KeepOutCone,
    substeps: Any,
    keep_out_margin: Any = True,
) -> Problem:
    """Check the physical inputs of :func:`controllers.slew.plan_slew` and scale them (docs/slew_planning.md).

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    q0 : array_like
        Initial attitude ``q_BN`` (4,).
    qf : array_like
        Final attitude ``q_BN`` (4,).
    omega0 : array_like
        Initial body rate [rad/s], scalar or (3,).
    omegaf : array_like
        Final body rate [rad/s], scalar or (3,).
    torque_max : array_like or ReactionWheels
        Per-axis torque bound [N m] (scalar or 3 values), or a wheel set.
    rate_max : float or None
        Body-rate limit [rad/s], > 0; None for no limit.
    keep_out : KeepOutCone or sequence of KeepOutCone
        Keep-out cones.
    substeps : int
        RK4 steps per interval, >= 1.
    keep_out_margin : bool, optional
        Add the second-order margin between checkpoints (docs/keep_out.md).
    """
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single (unbatched) RigidBody, got {body!r}")
    q0 = quat.as_unit_quaternion(q0, "q0")
    qf = quat.as_unit_quaternion(qf, "qf")
    if q0.shape != (4,) or qf.shape != (4,):
        raise ValueError(f"q0 and qf must have shape (4,), got {q0.shape} and {qf.shape}")
    omega0 = vector3(omega0, "omega0")
    omegaf = vector3(omegaf, "omegaf")
    tset = TorqueSet.make(torque_max)
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
    if not isinstance(keep_out_margin, (bool, np.bool_)):
        raise ValueError(f"keep_out_margin must be True or False, got {keep_out_margin!r}")
    j_s = float(np.max(body.principal_axes().moments))
    tau_s = float(np.max(tset.envelope))
    t_s = math.sqrt(j_s / tau_s)
    return Problem(
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
        keep_out_margin=bool(keep_out_margin),
    )


def momentum_rate_max(body: RigidBody, wheels: ReactionWheels, axis: ArrayLike | None = None) -> float:
    """Largest body rate [rad/s] whose wheel momentum stays inside ``wheels.momentum_max``.

    A rest-to-rest slew that starts with zero wheel momentum conserves the
    total angular momentum, so the wheels hold ``-I omega`` (body frame); the
    minimum-norm wheel momenta are ``h = -A^+ I omega``. For every rate with
    ``|omega| <= r`` each ``|h_i| <= r |row_i(A^+ I)|``, so
    ``r = min_i momentum_max_i / |row_i(A^+ I)|`` is a sufficient rate limit
    for any path (conservative: it takes the worst direction of every row).
    With ``axis`` (an eigenaxis slew, ``omega = w axis``) the bound is exact
    along that axis: ``min_i momentum_max_i / |(A^+ I axis)_i|``.

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    wheels : ReactionWheels
        The wheel set (its ``momentum_max`` [N m s] and allocation).
    axis : array_like, optional
        Unit eigenaxis in body components (3,) for an eigenaxis slew; None for any path.
    """
    if not isinstance(wheels, ReactionWheels):
        raise ValueError(f"wheels must be a ReactionWheels, got {type(wheels).__name__}")
    m = wheels.allocation @ np.asarray(body.inertia, dtype=float)
    if axis is None:
        gain = np.linalg.norm(m, axis=1)
    else:
        a = vector3(axis, "axis")
        n = float(np.linalg.norm(a))
        if not n > 0:
            raise ValueError(f"axis must be a non-zero vector, got {a}")
        gain = np.abs(m @ (a / n))
    with np.errstate(divide="ignore"):
        limits = np.where(gain > 0, wheels.momentum_max / np.where(gain > 0, gain, 1.0), np.inf)
    return float(np.min(limits))

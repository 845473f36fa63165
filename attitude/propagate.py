"""Attitude propagation: ``propagate(body, q0, omega0, t, torque, method=...)``.

Three methods, one set of equations (:mod:`attitude.rigid_body`):

========== ================================================================
method     what it is for
========== ================================================================
"rk4"      fixed-step RK4 with quaternion renormalisation
"geometric" fixed-step RKMK4 (order 4), ``|q| = 1`` to rounding error with
           no renormalisation
"adaptive" scipy ``solve_ivp`` (DOP853) with ``rtol``/``atol``: the accuracy
           reference
========== ================================================================

Both fixed-step methods run a single body with a constant or sampled torque
entirely in compiled casadi code (``Function.mapaccum`` of
:func:`attitude.integrators.casadi_rk4_step` or
:func:`attitude.integrators.casadi_rkmk4_step`), and a batch (or a callable
torque) as one vectorised numpy step for all bodies: the same step
definition, evaluated by the two backends.

Torque may be None (torque-free), a constant ``(3,)`` or ``batch + (3,)``,
an array on the time grid ``(len(t),) + batch + (3,)`` held constant over
each interval ``[t[k], t[k+1])`` (zero-order hold, as a digital controller
applies it; the last row is not used), or a callable ``torque(t, q, omega)``
returning ``batch + (3,)`` [N m], evaluated at every integrator stage. The
callable receives each stage's attitude normalised to unit length (a
Runge-Kutta stage is off the unit sphere by the truncation error), so it may
pass ``q`` straight to :mod:`attitude.quaternion`.
"""

from __future__ import annotations

import time
import warnings
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.integrators import (
    ATTITUDE_ERROR_BUDGET_RAD,
    MAX_RULE_SUBSTEPS,
    StepSizeWarning,
    attitude_error_text,
    casadi_rk4_step,
    casadi_rkmk4_step,
    check_error_budget,
    normalize_quaternion_components,
    predicted_attitude_error,
    rk4_step,
    rkmk4_step,
    rule_formula,
    rule_rates,
    substeps_for_budget,
    warn_outside_calibration,
)
from attitude.results import ResultIO
from attitude.rigid_body import Components, RigidBody
from attitude.validation import as_float_array, check_positive, check_time_grid, check_vector

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = ["METHODS", "Trajectory", "propagate"]

METHODS = ("rk4", "geometric", "adaptive")

TorqueInput = None | ArrayLike | Callable[[float, NDArray[np.float64], NDArray[np.float64]], ArrayLike]


@dataclass
class Trajectory(ResultIO):
    """Attitude trajectory of one body or a batch of bodies.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Time grid [s].
    q : ndarray, shape batch + (n, 4)
        Attitude quaternions ``q_BN`` (scalar first).
    omega : ndarray, shape batch + (n, 3)
        Body rates ``omega_BN_B`` [rad/s].
    inertia : ndarray, shape batch + (3, 3) or (3, 3)
        Inertia tensor(s) of the propagated body [kg m^2].
    method : str
        Integration method used.
    info : dict
        Method details (step size, substeps, solver statistics, wall time [s]).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    inertia: NDArray[np.float64]
    method: str
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def body(self) -> RigidBody:
        """The propagated body."""
        return RigidBody(self.inertia)

    def check_loaded(self, path: str) -> None:
        """A loaded trajectory must hold finite unit quaternions, finite rates and a valid inertia.

        Parameters
        ----------
        path : str
            The file read, named in the error.

        Raises
        ------
        ValueError
            For NaN or infinite values, quaternions off the unit norm, or an invalid inertia.
        """
        for name in ("t", "q", "omega"):
            values = np.asarray(getattr(self, name), dtype=float)
            if not np.all(np.isfinite(values)):
                raise ValueError(
                    f"{path}: {name} must be finite everywhere, found {int(np.sum(~np.isfinite(values)))} NaN/inf"
                )
        quat.as_unit_quaternion(self.q, f"{path}: q")
        RigidBody(self.inertia)

    def _inertia_b(self) -> NDArray[np.float64]:
        return self.inertia[..., None, :, :]

    def angular_momentum_B(self) -> NDArray[np.float64]:
        """Body-frame angular momentum ``I omega`` along the trajectory.

        Returns
        -------
        ndarray, shape batch + (n, 3)
            ``H_B`` in body components [N m s].
        """
        return np.einsum("...ij,...j->...i", self._inertia_b(), self.omega)

    def angular_momentum_N(self) -> NDArray[np.float64]:
        """Inertial angular momentum, constant for torque-free motion.

        Returns
        -------
        ndarray, shape batch + (n, 3)
            ``H_N = rotate(q_BN, I omega)`` in inertial components [N m s]
            (``q`` is normalised first).
        """
        return quat.rotate(quat.normalize(self.q), self.angular_momentum_B())

    def kinetic_energy(self) -> NDArray[np.float64]:
        """Rotational kinetic energy ``0.5 omega . I omega`` along the trajectory.

        Returns
        -------
        ndarray, shape batch + (n,)
            Kinetic energy [J].
        """
        return 0.5 * np.sum(self.omega * self.angular_momentum_B(), axis=-1)

    def invariant_drift(self) -> dict[str, float]:
        """Worst drift of the torque-free invariants over the trajectory.

        Returns
        -------
        dict
            ``energy`` (max relative change of kinetic energy),
            ``momentum`` (max ``|H_N(t) - H_N(0)| / |H_N(0)|``) and
            ``quaternion_norm`` (max ``abs(|q| - 1)``). Meaningful for
            torque-free motion only.
        """
        energy = self.kinetic_energy()
        h_n = quat.rotate(quat.normalize(self.q), self.angular_momentum_B())
        e0 = energy[..., :1]
        h0 = h_n[..., :1, :]
        return {
            "energy": float(np.max(np.abs(energy - e0) / np.where(e0 > 0, e0, 1.0))),
            "momentum": float(
                np.max(np.linalg.norm(h_n - h0, axis=-1) / np.maximum(np.linalg.norm(h0, axis=-1), 1e-300))
            ),
            "quaternion_norm": float(np.max(np.abs(np.linalg.norm(self.q, axis=-1) - 1.0))),
        }

    def plot(self, index: tuple[int, ...] | int = ()) -> matplotlib.figure.Figure:
        """Rates, attitude and invariants over time (one body of a batch by ``index``).

        Parameters
        ----------
        index : int or tuple of int
            Which body of a batch to show (ignored for a single body).

        Returns
        -------
        matplotlib.figure.Figure
            The figure (see :func:`attitude.plotting.plot_trajectory`).
        """
        from attitude.plotting import plot_trajectory

        return plot_trajectory(self, index=index)


def _torque_kind(torque: TorqueInput, n_t: int, batch: tuple[int, ...]) -> tuple[str, Any]:
    """Classify and validate the torque argument.

    Parameters
    ----------
    torque : None, array_like or callable
        Torque input of :func:`propagate` [N m].
    n_t : int
        Number of time-grid points.
    batch : tuple of int
        Broadcast batch shape of the initial states.

    Returns
    -------
    kind : {"const", "grid", "callable"}
        ``"const"`` for None (zeros) or a torque of shape ``(3,)``/``batch + (3,)``;
        ``"grid"`` for a zero-order-hold torque of shape ``(n_t,) + batch + (3,)``;
        ``"callable"`` for ``torque(t, q, omega)``.
    value : ndarray or callable
        The torque array [N m] (float64) or the callable itself.

    Raises
    ------
    ValueError
        If the array is non-finite, its last axis is not 3, its first axis
        does not match ``n_t`` on a grid, or its batch does not broadcast.
    """
    if torque is None:
        return "const", np.zeros(3)
    if callable(torque):
        return "callable", torque
    arr = as_float_array(torque, "torque")
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"torque must have shape (..., 3) in N m, got shape {arr.shape}")
    if arr.ndim == len(batch) + 2:
        if arr.shape[0] != n_t:
            raise ValueError(
                f"torque on the time grid must have shape (len(t)={n_t},) + batch + (3,), got shape {arr.shape}"
            )
        try:
            np.broadcast_shapes(arr.shape[1:-1], batch)
        except ValueError as exc:
            raise ValueError(f"torque batch shape {arr.shape[1:-1]} does not broadcast to {batch}") from exc
        return "grid", arr
    if arr.ndim > len(batch) + 2:
        raise ValueError(f"torque has too many dimensions for batch {batch}: shape {arr.shape}")
    try:
        np.broadcast_shapes(arr.shape[:-1], batch)
    except ValueError as exc:
        raise ValueError(f"torque shape {arr.shape} does not broadcast to batch {batch}") from exc
    return "const", arr


#: Most fixed steps one call may take (about an hour of CPU time at the
#: measured speeds); a larger count is almost surely a mistyped max_step.
MAX_FIXED_STEPS = 10**9


def _substeps(t: NDArray[np.float64], max_step: float | None) -> NDArray[np.int64]:
    """Number of equal fixed steps per output interval.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Strictly increasing time grid [s].
    max_step : float or None
        Largest step [s]; None gives one step per interval.

    Returns
    -------
    ndarray of int64, shape (n - 1,)
        Sub-steps per interval ``[t[k], t[k+1]]`` (at least 1).

    Raises
    ------
    ValueError
        If the total exceeds :data:`MAX_FIXED_STEPS`.
    """
    dt = np.diff(t)
    if max_step is None:
        return np.ones(dt.size, dtype=np.int64)
    counts = np.maximum(1.0, np.ceil(dt / max_step * (1 - 1e-12)))
    if np.sum(counts) > MAX_FIXED_STEPS:
        raise ValueError(
            f"max_step = {max_step!r} s makes {np.sum(counts):.3g} steps over the time grid; "
            f"the limit is {MAX_FIXED_STEPS:.0e} (check the units of max_step)"
        )
    return counts.astype(np.int64)


def propagate(
    body: RigidBody,
    q0: ArrayLike,
    omega0: ArrayLike,
    t: ArrayLike,
    torque: TorqueInput = None,
    *,
    method: str = "rk4",
    max_step: float | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    attitude_error_budget_rad: float = ATTITUDE_ERROR_BUDGET_RAD,
) -> Trajectory:
    """Propagate attitude and body rate of one body or a batch of bodies.

    Parameters
    ----------
    body : RigidBody
        The plant; a batched body (``body.batch_shape``) pairs its inertias
        with the batch of initial states.
    q0 : array_like, shape batch + (4,)
        Initial attitude ``q_BN`` (unit norm, scalar first).
    omega0 : array_like, shape batch + (3,)
        Initial body rate ``omega_BN_B`` [rad/s]; broadcast against ``q0``.
    t : array_like, shape (n,)
        Strictly increasing output times [s]; the state at ``t[0]`` is the
        initial state.
    torque : None, array_like or callable
        Torque in body components [N m]; see the module docstring.
    method : {"rk4", "geometric", "adaptive"}
        Integrator (module docstring).
    max_step : float, optional
        Largest fixed step [s]; each output interval is split into equal
        sub-steps no longer than this. Default: one step per output interval.
        Ignored by "adaptive" (which controls its error with ``rtol``/``atol``).
    rtol, atol : float
        Tolerances of the adaptive method.
    attitude_error_budget_rad : float
        Accumulated attitude error [rad] the fixed-step methods may make over
        the run (default :data:`attitude.integrators.ATTITUDE_ERROR_BUDGET_RAD`,
        1e-6 rad). The step-size rule (docs/rk4_step_rule.md) is checked
        before the run on the initial rates and after it on the rates
        reached at every internal step, the applied torque's turn of the
        rate included; where it is broken the steps are sub-stepped (and the
        run repeated) with a :class:`attitude.integrators.StepSizeWarning`.
        ``inf`` turns the rule off. Outside the rule: a callable torque that
        changes strongly *within* one step (a jump, or a time scale shorter
        than the step), because RK4 samples it at the step's start, middle
        and end. Put a discontinuity on the output grid and pass the torque
        as an array on that grid (held over each interval), or shorten
        ``max_step`` below its time scale. A smooth callable with a time
        scale ``T`` under about 20 steps is not covered either (its rate of
        change is not counted; docs/rk4_step_rule.md): pass
        ``max_step <= T / 20`` or ``method="adaptive"``.

    Returns
    -------
    Trajectory
        ``q`` of shape batch + (n, 4) and ``omega`` of shape batch + (n, 3);
        ``info["step_rule"]`` holds the predicted error [rad], the budget and
        whether the rule added steps.

    Raises
    ------
    ValueError
        For a non-unit or non-finite ``q0``, non-finite ``omega0``, a time
        grid that is not strictly increasing, a torque of the wrong shape, an
        unknown method, non-positive ``max_step``/tolerances/budget, or a
        fixed step so long for the rates that the rule would need more than
        :data:`attitude.integrators.MAX_RULE_SUBSTEPS` steps per step asked.

    Warns
    -----
    StepSizeWarning
        When the step-size rule sub-stepped the run (one warning per call,
        with the final figures), or, saying "NOT within the budget", when
        the steps it asked for could not be run.
    """
    if not isinstance(body, RigidBody):
        raise ValueError(f"body must be a RigidBody, got {type(body).__name__}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    q0 = quat.as_unit_quaternion(q0, "q0")
    omega0 = check_vector(omega0, "omega0", 3)
    t = check_time_grid(t, "t")
    if max_step is not None:
        max_step = float(check_positive(max_step, "max_step"))
    check_positive(rtol, "rtol")
    check_positive(atol, "atol")
    budget = check_error_budget(attitude_error_budget_rad)
    try:
        batch = np.broadcast_shapes(q0.shape[:-1], omega0.shape[:-1], body.batch_shape)
    except ValueError as exc:
        raise ValueError(
            f"q0 batch {q0.shape[:-1]}, omega0 batch {omega0.shape[:-1]} and body batch {body.batch_shape} "
            "must broadcast together"
        ) from exc
    q0 = np.broadcast_to(q0, (*batch, 4))
    omega0 = np.broadcast_to(omega0, (*batch, 3))
    kind, tq = _torque_kind(torque, t.size, batch)

    start = time.perf_counter()
    if method == "adaptive":
        q, omega, info = _propagate_adaptive(body, q0, omega0, t, kind, tq, batch, rtol, atol)
    else:
        warn_outside_calibration(body, budget, f"propagate(method={method!r})")
        q, omega, info = _propagate_fixed(body, q0, omega0, t, kind, tq, batch, max_step, method, budget)
    info["wall_time_s"] = time.perf_counter() - start
    _check_finite(q, omega, t, method, max_step)
    inertia = np.broadcast_to(body.inertia, (*batch, 3, 3)).copy() if body.batch_shape else body.inertia
    return Trajectory(t=t.copy(), q=q, omega=omega, inertia=inertia, method=method, info=info)


#: Most runs of one propagation under the step-size rule: the first, and repeats when the rates reached
#: ask for more steps than the initial rates did (a torque spinning the body up).
RULE_PASSES = 3


def _propagate_fixed(
    body: RigidBody,
    q0: NDArray[np.float64],
    omega0: NDArray[np.float64],
    t: NDArray[np.float64],
    kind: str,
    tq: Any,
    batch: tuple[int, ...],
    max_step: float | None,
    method: str,
    budget: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """RK4 or RKMK4 under the step-size rule (:func:`attitude.integrators.substeps_for_budget`).

    The rule is checked before the run on the initial rates, held over the
    run, and after it on the rates reached at the output samples (the larger
    of each interval's two ends); a run that broke it is repeated with the
    steps the rule asks for, up to :data:`RULE_PASSES` runs. Where the rule
    holds on the first check the run is exactly the one asked for.

    Parameters
    ----------
    body : RigidBody
        The plant (single or batched).
    q0 : ndarray, shape batch + (4,)
        Unit initial attitudes ``q_BN``.
    omega0 : ndarray, shape batch + (3,)
        Initial body rates [rad/s].
    t : ndarray, shape (n,)
        Output time grid [s].
    kind : {"const", "grid", "callable"}
        Torque kind from :func:`_torque_kind`.
    tq : ndarray or callable
        Torque [N m] of that kind.
    batch : tuple of int
        Batch shape.
    max_step : float or None
        Largest fixed step asked for [s].
    method : {"rk4", "geometric"}
        The fixed-step method.
    budget : float
        Accumulated attitude-error budget [rad].

    Returns
    -------
    q, omega, info
        As the fixed-step engines, ``info["step_rule"]`` added.

    Raises
    ------
    ValueError
        If the rule needs more than :data:`attitude.integrators.MAX_RULE_SUBSTEPS` steps per step asked.
    """
    asked = _substeps(t, max_step)
    dt = np.diff(t)
    tau0 = None if kind == "callable" else (tq if kind == "const" else tq[0])
    rates = tuple(value[..., None] for value in rule_rates(body, omega0, torque=tau0))
    subs, message = _rule_substeps(rates, dt, asked, asked, method, budget, max_step)
    sampled_body = body if not body.batch_shape else RigidBody(body.inertia[..., None, :, :])
    met = True
    for passes in range(1, RULE_PASSES + 1):
        if not batch and kind != "callable":
            q, omega, info, peaks = _propagate_casadi(body, q0, omega0, t, kind, tq, subs, method)
        else:
            # A diverging run overflows; _check_finite reports it as an error.
            with np.errstate(over="ignore", invalid="ignore"):
                q, omega, info, peaks = _propagate_fixed_numpy(body, q0, omega0, t, kind, tq, batch, subs, method)
        if not (np.all(np.isfinite(omega)) and np.all(np.isfinite(q))):
            break  # _check_finite names the divergence
        rates = _flown_rates(sampled_body, omega, kind, tq, peaks)
        needed, again = _rule_substeps(rates, dt, subs, asked, method, budget, max_step)
        if np.all(needed <= subs):
            break
        message = again
        if passes == RULE_PASSES:
            met = False  # the count the rates flown ask for was never run: say so rather than rerun forever
        else:
            subs = needed
    rate, turn, excess = rates
    error = float(
        np.max(
            predicted_attitude_error(rate, dt, turn, substeps=subs, method=method, excess_rad5_s5=excess), initial=0.0
        )
    )
    if message is not None:
        if met:
            note = (
                f"; sub-stepped to {int(np.max(subs))} steps per output interval (step {float(np.min(dt / subs)):.3g}"
                f" s), predicted error {error:.4g} rad within the budget {budget:.4g} rad"
            )
        else:
            note = (
                f"; after {RULE_PASSES} runs, sub-stepped to {int(np.max(subs))} steps per output interval, the "
                f"result is NOT within the budget: predicted error {attitude_error_text(error, 4)} against "
                f"{budget:.4g} rad (pass a smaller max_step)"
            )
        warnings.warn(
            f"{message}{note}. {_other_methods(method)}; attitude_error_budget_rad sets the budget",
            StepSizeWarning,
            stacklevel=3,
        )
    scale = info.pop("torque_time_scale_s", np.inf)
    h_min = float(np.min(dt / subs))
    if scale < TORQUE_STEPS_MIN * h_min:
        warnings.warn(
            f"the callable torque changed on a time scale of {scale:.3g} s, {scale / h_min:.3g} steps of "
            f"{h_min:.3g} s: the step-size rule does not count a torque's rate of change (docs/rk4_step_rule.md), "
            f"so the attitude may be off by more than the budget; pass max_step <= {scale / TORQUE_STEPS_MIN:.3g} s "
            "or method='adaptive'",
            StepSizeWarning,
            stacklevel=3,
        )
    info["step_rule"] = {
        "predicted_error_rad": error,
        "budget_rad": budget,
        "substeps_added": bool(np.any(subs > asked)),
    }
    return q, omega, info


def _flown_rates(
    sampled_body: RigidBody, omega: NDArray[np.float64], kind: str, tq: Any, peaks: tuple[NDArray, ...]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The rule's rates (:func:`attitude.integrators.rule_rates`) over each output interval, the largest at its
    ends and every step inside.

    Parameters
    ----------
    sampled_body : RigidBody
        The body, batched inertias given an axis for the samples.
    omega : ndarray, shape batch + (n, 3)
        Body rates at the output samples [rad/s].
    kind : {"const", "grid", "callable"}
        Torque kind; a callable's torque is in ``peaks`` (evaluated at the samples during the run).
    tq : ndarray or callable
        Torque [N m] of that kind.
    peaks : (ndarray, ndarray, ndarray), shape batch + (n - 1,)
        Largest ``|omega|``, turn rate [rad/s] and varying-rate term [rad^5/s^5] at the step starts inside
        each interval.

    Returns
    -------
    rate, turn, excess : ndarray, shape batch + (n - 1,)
        [rad/s], [rad/s], [rad^5/s^5].
    """
    if kind != "grid":
        # Every sample under the same torque (none counted for a callable): each is evaluated once, as the end
        # of one interval and the start of the next.
        ends = rule_rates(sampled_body, omega, torque=None if kind == "callable" else np.asarray(tq)[..., None, :])
        flown = [np.maximum(value[..., :-1], value[..., 1:]) for value in ends]
    else:
        held = np.moveaxis(tq[:-1], 0, -2)  # interval k flies under tq[k]
        starts = rule_rates(sampled_body, omega[..., :-1, :], torque=held)
        stops = rule_rates(sampled_body, omega[..., 1:, :], torque=held)
        flown = [np.maximum(a, b) for a, b in zip(starts, stops)]
    rate, turn, excess = (np.maximum(value, peak) for value, peak in zip(flown, peaks))
    return rate, turn, excess


def _rule_substeps(
    rates: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]],
    dt: NDArray[np.float64],
    subs: NDArray[np.int64],
    asked: NDArray[np.int64],
    method: str,
    budget: float,
    max_step: float | None,
) -> tuple[NDArray[np.int64], str | None]:
    """Steps per interval the rule asks for, refusing when it adds too many.

    Parameters
    ----------
    rates : (ndarray, ndarray, ndarray), shape batch + (1,) or batch + (n - 1,)
        ``|omega|``, the gyroscopic turn rate [rad/s] and the varying-rate term [rad^5/s^5] over each
        interval (:func:`attitude.integrators.rule_rates`).
    dt : ndarray, shape (n - 1,)
        Interval lengths [s].
    subs : ndarray of int, shape (n - 1,)
        Steps per interval of the run so far.
    asked : ndarray of int, shape (n - 1,)
        Steps per interval the caller asked for (``max_step``).
    method : {"rk4", "geometric"}
        The fixed-step method.
    budget : float
        Accumulated attitude-error budget [rad].
    max_step : float or None
        The caller's ``max_step`` [s] (for the messages).

    Returns
    -------
    needed : ndarray of int, shape (n - 1,)
        Steps per interval (``subs`` itself when the rule holds).
    message : str or None
        The broken rule, for the caller's one warning (None when it holds).
    """
    rate = np.broadcast_to(rates[0], (*rates[0].shape[:-1], dt.size))
    turn, excess = (np.broadcast_to(value, rate.shape) for value in rates[1:])
    needed = substeps_for_budget(rate, dt, turn, substeps=subs, budget_rad=budget, method=method, excess_rad5_s5=excess)
    if np.all(needed <= subs):
        return subs, None
    needed = np.maximum(needed, subs)
    worst = int(np.argmax(needed / asked))
    rate_max = float(np.max(rate[..., worst]))
    h_asked = float(dt[worst] / asked[worst])
    h_new = float(np.min(dt / needed))
    error = float(
        np.max(predicted_attitude_error(rate, dt, turn, substeps=asked, method=method, excess_rad5_s5=excess))
    )
    rule = (
        f"method={method!r} breaks the step-size rule {rule_formula(method)} <= {budget:.3g} rad "
        f"(docs/rk4_step_rule.md): |omega| up to {rate_max:.3g} rad/s with a "
        f"step of {h_asked:.3g} s (|omega| h = {rate_max * h_asked:.3g} rad per step) predicts an accumulated "
        f"attitude error of {attitude_error_text(error)}"
    )
    if np.max(needed / asked) > MAX_RULE_SUBSTEPS:
        raise ValueError(
            f"{rule}; meeting it needs {int(np.max(needed / asked))} steps per step asked, more than "
            f"{MAX_RULE_SUBSTEPS}: pass max_step <= {h_new:.3g} s (max_step = {max_step!r}); "
            f"{_other_methods(method)}"
        )
    return needed, rule


def _other_methods(method: str) -> str:
    """What the messages of a fixed-step run that broke the rule recommend besides a smaller step.

    ``geometric`` is recommended to an RK4 run only: a geometric run breaks
    the rule only where its rate varies (it is exact for a constant rate).
    """
    if method == "geometric":
        return (
            "method='geometric' (in use) is exact only for a constant rate and this one varies: "
            "method='adaptive' controls its own error"
        )
    return "method='geometric' is exact for a constant rate and method='adaptive' controls its own error"


#: Fewest steps per time scale of a callable torque below which propagate warns that the rule does not cover it
#: (docs/rk4_step_rule.md: measured 2.5e-8 to 3.3e-8 rad at 20 steps per time scale, up to 1.1e-5 rad at 3.3).
TORQUE_STEPS_MIN = 20.0


class PropagationDivergedError(FloatingPointError):
    """A fixed-step propagation blew up (the step is too long for the rates)."""


def _check_finite(q: NDArray, omega: NDArray, t: NDArray, method: str, max_step: float | None) -> None:
    """Raise instead of returning NaN/inf when a fixed-step run diverges.

    Parameters
    ----------
    q, omega : ndarray, shape batch + (n, 4) and batch + (n, 3)
        Propagated quaternions and body rates [rad/s].
    t : ndarray, shape (n,)
        Time grid [s].
    method : str
        Integration method (for the message).
    max_step : float or None
        Largest fixed step [s] (for the message).

    Raises
    ------
    PropagationDivergedError
        If any state is non-finite; the message names the first such time.
    """
    bad = ~(np.all(np.isfinite(q), axis=-1) & np.all(np.isfinite(omega), axis=-1))
    if not np.any(bad):
        return
    k = int(np.argmax(np.any(bad.reshape(-1, t.size), axis=0)))
    with np.errstate(over="ignore", invalid="ignore"):
        rate0 = float(np.max(np.linalg.norm(omega[..., 0, :], axis=-1)))
    step = float(np.min(np.diff(t))) if max_step is None else max_step
    raise PropagationDivergedError(
        f"{method} propagation diverged at t = {float(t[k]):.6g} s (non-finite state): initial body rate "
        f"{rate0:.3g} rad/s with a step of {step:.3g} s (|omega| h = {rate0 * step:.3g}); "
        "use a smaller max_step (the step-size rule of docs/rk4_step_rule.md)"
        + ("" if method == "adaptive" else f"; {_other_methods(method)}")
    )


def _call_torque(
    fun: Callable[..., ArrayLike],
    t: float,
    q: NDArray[np.float64],
    omega: NDArray[np.float64],
    batch: tuple[int, ...],
) -> NDArray[np.float64]:
    """Evaluate a user torque ``fun(t, q, omega)`` and check its shape.

    Parameters
    ----------
    fun : callable
        ``fun(t, q, omega) -> tau`` [N m] in body components.
    t : float
        Time [s].
    q : ndarray, shape batch + (4,)
        Unit attitude quaternions ``q_BN``.
    omega : ndarray, shape batch + (3,)
        Body rates ``omega_BN_B`` [rad/s].
    batch : tuple of int
        Batch shape the result is broadcast to.

    Returns
    -------
    ndarray, shape batch + (3,)
        Torque [N m] (a read-only broadcast view).

    Raises
    ------
    ValueError
        If the result is non-numeric, non-finite, its last axis is not 3, or
        it does not broadcast to ``batch + (3,)``.
    """
    out = as_float_array(fun(t, q, omega), "torque(t, q, omega)")
    if out.shape[-1:] != (3,):
        raise ValueError(f"torque(t, q, omega) must return shape batch + (3,), got {out.shape}")
    return np.broadcast_to(out, (*batch, 3))


# Steps per compiled casadi call for a single body. The accumulated map is
# built once per body and method and reused; the last call is padded with
# dt = 0 steps, which leave the state unchanged (an RKMK4 step of dt = 0
# multiplies by exp(0) = [1, 0, 0, 0] exactly).
CASADI_CHUNK = 1024
_CASADI_CACHE: weakref.WeakKeyDictionary[RigidBody, dict[str, ca.Function]] = weakref.WeakKeyDictionary()
_CASADI_STEPS = {"rk4": casadi_rk4_step, "geometric": casadi_rkmk4_step}


def _casadi_chunk(body: RigidBody, method: str) -> ca.Function:
    """Cached ``step(body).mapaccum(CASADI_CHUNK)`` of a fixed-step method for a single body.

    Parameters
    ----------
    body : RigidBody
        A single (not batched) body; the cache holds it weakly.
    method : {"rk4", "geometric"}
        :func:`attitude.integrators.casadi_rk4_step` or :func:`attitude.integrators.casadi_rkmk4_step`.

    Returns
    -------
    casadi.Function
        ``(x[7], tau[3 x CASADI_CHUNK], dt[1 x CASADI_CHUNK]) -> x[7 x CASADI_CHUNK]``
        (the states after each step; ``tau`` [N m], ``dt`` [s]).
    """
    funs = _CASADI_CACHE.setdefault(body, {})
    if method not in funs:
        funs[method] = _CASADI_STEPS[method](body).mapaccum(CASADI_CHUNK)
    return funs[method]


def _propagate_casadi(
    body: RigidBody,
    q0: NDArray[np.float64],
    omega0: NDArray[np.float64],
    t: NDArray[np.float64],
    kind: str,
    tq: NDArray[np.float64],
    subs: NDArray[np.int64],
    method: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """Fixed-step RK4 or RKMK4 of a single body in compiled casadi code (``mapaccum``).

    Parameters
    ----------
    body : RigidBody
        A single (not batched) body.
    q0 : ndarray, shape (4,)
        Unit initial attitude ``q_BN``.
    omega0 : ndarray, shape (3,)
        Initial body rate [rad/s].
    t : ndarray, shape (n,)
        Output time grid [s].
    kind : {"const", "grid"}
        Torque kind from :func:`_torque_kind` (not ``"callable"``).
    tq : ndarray, shape (3,) or (n, 3)
        Constant torque, or torque on the time grid held over each interval [N m].
    subs : ndarray of int, shape (n - 1,)
        Equal steps per output interval.
    method : {"rk4", "geometric"}
        RK4 with renormalisation, or RKMK4.

    Returns
    -------
    q : ndarray, shape (n, 4)
        Attitude quaternions at ``t``.
    omega : ndarray, shape (n, 3)
        Body rates at ``t`` [rad/s].
    info : dict
        ``steps``, ``substeps_max`` and ``engine``.
    """
    dt_fine = np.repeat(np.diff(t) / subs, subs)
    n_fine = dt_fine.size
    n_pad = -n_fine % CASADI_CHUNK
    dt_fine = np.concatenate([dt_fine, np.zeros(n_pad)])
    if kind == "const":
        tau_fine = np.broadcast_to(tq, (n_fine + n_pad, 3))
    else:
        tau_fine = np.concatenate([np.repeat(tq[:-1], subs, axis=0), np.zeros((n_pad, 3))])
    tau_fine = np.ascontiguousarray(tau_fine.T)
    chunk = _casadi_chunk(body, method)
    xs = np.empty((7, n_fine + n_pad))
    x = np.concatenate([q0, omega0])
    for lo in range(0, n_fine + n_pad, CASADI_CHUNK):
        hi = lo + CASADI_CHUNK
        xs[:, lo:hi] = chunk(x, tau_fine[:, lo:hi], dt_fine[None, lo:hi]).full()
        x = xs[:, hi - 1]
    ends = np.cumsum(subs) - 1
    out = np.concatenate([np.concatenate([q0, omega0])[None, :], xs[:, ends].T], axis=0)
    info = {"steps": int(n_fine), "substeps_max": int(subs.max()), "engine": "casadi mapaccum"}
    if subs.max() == 1:
        peaks = (np.zeros(subs.size), np.zeros(subs.size), np.zeros(subs.size))
    else:  # the state after every step (the ends included): the rule's rates between the samples
        starts = ends + 1 - subs
        fine = rule_rates(body, xs[4:, :n_fine].T, torque=tau_fine[:, :n_fine].T)
        peaks = tuple(np.maximum.reduceat(value, starts) for value in fine)
    return out[:, :4], out[:, 4:], info, peaks


# Largest number of bodies advanced together per vectorised step. Component
# arrays of a few thousand doubles stay in cache and keep numpy temporaries
# off the allocator's slow path; measured for 10,000 bodies on 2 cores (RK4,
# 0.1 s step): chunks of 1024 -> 0.43M, 2048 -> 0.57M, 4096 -> 0.66M
# body-simulated-seconds per CPU second, flat beyond.
BATCH_CHUNK = 4096


def _propagate_fixed_numpy(
    body: RigidBody,
    q0: NDArray[np.float64],
    omega0: NDArray[np.float64],
    t: NDArray[np.float64],
    kind: str,
    tq: Any,
    batch: tuple[int, ...],
    subs: NDArray[np.int64],
    method: str,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """Fixed-step RK4 or RKMK4 in vectorised numpy.

    Without a callable torque a batch is flattened, moved to the principal
    frame when the inertia has products of inertia, and advanced in chunks of
    at most :data:`BATCH_CHUNK` bodies.

    Parameters
    ----------
    body : RigidBody
        The plant (single or batched).
    q0 : ndarray, shape batch + (4,)
        Unit initial attitudes ``q_BN``.
    omega0 : ndarray, shape batch + (3,)
        Initial body rates [rad/s].
    t : ndarray, shape (n,)
        Output time grid [s].
    kind : {"const", "grid", "callable"}
        Torque kind from :func:`_torque_kind`.
    tq : ndarray or callable
        Torque [N m] of that kind.
    batch : tuple of int
        Batch shape.
    subs : ndarray of int, shape (n - 1,)
        Equal steps per output interval.
    method : {"rk4", "geometric"}
        RK4 with renormalisation, or RKMK4.
    output_frame : (q_PB (..., 4), C_PB (..., 3, 3)), optional
        When the state is propagated in the principal frame P: each stored
        sample is mapped back to the body frame (``q_BN = q_PN ⊗ q_PB*``,
        ``omega_B = C_PB^T omega_P``) while it is still in cache (the
        initial row too: ``q0`` and ``omega0`` are then in P).

    Returns
    -------
    q : ndarray, shape batch + (n, 4)
        Attitude quaternions at ``t``.
    omega : ndarray, shape batch + (n, 3)
        Body rates at ``t`` [rad/s].
    info : dict
        ``steps``, ``substeps_max``, ``engine`` and ``batch_chunk``.
    """
    if kind == "callable" or not batch:
        # A user's callable sees the whole batch at once, as documented.
        scale: list[float] | None = [] if kind == "callable" else None
        q, w, steps, peaks = _run_fixed(body, q0, omega0, t, subs, kind, tq, batch, method, torque_time_scale=scale)
        info = _fixed_info(steps, subs)
        if scale and scale[1] > 0.0:
            info["torque_time_scale_s"] = scale[0] / scale[1]
        return np.moveaxis(q, 0, -2), np.moveaxis(w, 0, -2), info, peaks
    size = int(np.prod(batch))
    q0f = q0.reshape(size, 4)
    w0f = omega0.reshape(size, 3)
    if kind == "const":
        tqf = np.broadcast_to(tq, (*batch, 3)).reshape(size, 3)
    else:
        tqf = np.broadcast_to(tq, (t.size, *batch, 3)).reshape(t.size, size, 3)
    principal = None
    if not body.is_diagonal:
        # Exact change of variables to the principal frame P, where the
        # inertia is diagonal and Euler's equations cost a third of the
        # products: q_PN = q_BN ⊗ q_PB, omega_P = C_PB omega_B, tau_P = C_PB tau_B.
        axes = body.principal_axes()
        q_pb = np.broadcast_to(axes.q_PB, (*batch, 4)).reshape(size, 4)
        c_pb = np.broadcast_to(axes.C_PB, (*batch, 3, 3)).reshape(size, 3, 3)
        principal = (q_pb, c_pb)
        q0f = quat.multiply(q0f, q_pb)
        w0f = np.einsum("nij,nj->ni", c_pb, w0f)
        tqf = np.einsum("nij,...nj->...ni", c_pb, tqf)
        moments = np.broadcast_to(axes.moments, (*batch, 3)).reshape(size, 3)
        inertia = moments if body.batch_shape else None
        body = RigidBody(axes.moments) if not body.batch_shape else body
    else:
        inertia = np.broadcast_to(body.inertia, (*batch, 3, 3)).reshape(size, 3, 3) if body.batch_shape else None
    q_out = np.empty((t.size, size, 4))
    w_out = np.empty((t.size, size, 3))
    peak_rate, peak_turn, peak_excess = (np.zeros((size, t.size - 1)) for _ in range(3))
    steps = 0
    n_chunks = -(-size // BATCH_CHUNK)
    chunk = -(-size // n_chunks)  # balanced chunks, none larger than BATCH_CHUNK
    for lo in range(0, size, chunk):
        sl = slice(lo, min(lo + chunk, size))
        chunk_body = body if inertia is None else RigidBody(inertia[sl])
        chunk_tq = tqf[sl] if kind == "const" else tqf[:, sl]
        n = sl.stop - sl.start
        frame = None if principal is None else (principal[0][sl], principal[1][sl])
        q_out[:, sl], w_out[:, sl], steps, (peak_rate[sl], peak_turn[sl], peak_excess[sl]) = _run_fixed(
            chunk_body, q0f[sl], w0f[sl], t, subs, kind, chunk_tq, (n,), method, output_frame=frame
        )
    q = np.moveaxis(q_out.reshape(t.size, *batch, 4), 0, -2)
    w = np.moveaxis(w_out.reshape(t.size, *batch, 3), 0, -2)
    peaks = tuple(peak.reshape(*batch, t.size - 1) for peak in (peak_rate, peak_turn, peak_excess))
    return q, w, _fixed_info(steps, subs), peaks


def _fixed_info(steps: int, subs: NDArray[np.int64]) -> dict[str, Any]:
    """Trajectory ``info`` of the numpy fixed-step engine (step count, largest sub-step count)."""
    return {"steps": steps, "substeps_max": int(subs.max()), "engine": "numpy", "batch_chunk": BATCH_CHUNK}


def _run_fixed(
    body: RigidBody,
    q0: NDArray[np.float64],
    omega0: NDArray[np.float64],
    t: NDArray[np.float64],
    subs: NDArray[np.int64],
    kind: str,
    tq: Any,
    batch: tuple[int, ...],
    method: str,
    output_frame: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    torque_time_scale: list[float] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Fixed-step time loop on structure-of-arrays components; outputs are time-first.

    ``torque_time_scale``, a list, receives a callable torque's largest
    ``|tau|`` and ``|d tau / dt|`` over the run (:func:`_torque_variation`);
    their ratio is its time scale.

    Parameters
    ----------
    body : RigidBody
        The plant, batch compatible with ``batch``.
    q0 : ndarray, shape batch + (4,)
        Unit initial attitudes ``q_BN``.
    omega0 : ndarray, shape batch + (3,)
        Initial body rates [rad/s].
    t : ndarray, shape (n,)
        Output time grid [s].
    subs : ndarray of int, shape (n - 1,)
        Equal sub-steps per output interval (:func:`_substeps`).
    kind : {"const", "grid", "callable"}
        Torque kind from :func:`_torque_kind`.
    tq : ndarray or callable
        Torque [N m] of that kind.
    batch : tuple of int
        Batch shape.
    method : {"rk4", "geometric"}
        RK4 with renormalisation, or RKMK4.
    output_frame : (q_PB (..., 4), C_PB (..., 3, 3)), optional
        When the state is propagated in the principal frame P: each stored
        sample is mapped back to the body frame (``q_BN = q_PN ⊗ q_PB*``,
        ``omega_B = C_PB^T omega_P``) while it is still in cache (the
        initial row too: ``q0`` and ``omega0`` are then in P).

    Returns
    -------
    q : ndarray, shape (n,) + batch + (4,)
        Attitude quaternions at ``t``.
    omega : ndarray, shape (n,) + batch + (3,)
        Body rates at ``t`` [rad/s].
    steps : int
        Number of integrator steps taken.
    """
    n = t.size
    # Outputs are filled component by component (contiguous rows, no
    # per-step temporaries) and transposed once at the end.
    q_soa = np.empty((n, 4, *batch))
    w_soa = np.empty((n, 3, *batch))
    q_soa[0] = np.moveaxis(q0, -1, 0)
    w_soa[0] = np.moveaxis(omega0, -1, 0)
    if output_frame is not None:
        q_pb, c_pb = output_frame
        conj = [q_pb[..., 0], -q_pb[..., 1], -q_pb[..., 2], -q_pb[..., 3]]
        c = [[np.ascontiguousarray(c_pb[..., i, j]) for j in range(3)] for i in range(3)]
        row0 = quat.multiply_components([q_soa[0, i] for i in range(4)], conj)
        for i in range(4):
            q_soa[0, i] = row0[i]
        w0_b = [c[0][j] * w_soa[0, 0] + c[1][j] * w_soa[0, 1] + c[2][j] * w_soa[0, 2] for j in range(3)]
        for j in range(3):
            w_soa[0, j] = w0_b[j]
    qc = [np.array(q0[..., i]) for i in range(4)]
    wc = [np.array(omega0[..., i]) for i in range(3)]

    def torque_components(k: int) -> Callable[[float, Components, Components], Components | None]:
        if kind == "callable":

            def fun(ts: float, qs: Components, ws: Components) -> Components:
                q_arr = np.stack(np.broadcast_arrays(*qs), axis=-1)
                q_arr = q_arr / np.linalg.norm(q_arr, axis=-1, keepdims=True)
                w_arr = np.stack(np.broadcast_arrays(*ws), axis=-1)
                out = _call_torque(tq, ts, q_arr, w_arr, batch)
                return [out[..., i] for i in range(3)]

            return fun
        value = np.broadcast_to(tq if kind == "const" else tq[k], (*batch, 3))
        comps = None if not np.any(value) else [np.array(value[..., i]) for i in range(3)]
        return lambda _t, _q, _w: comps

    steps = 0
    # The rule's rates at every step start not on the output grid (and, for a callable torque, at the
    # samples too, with the torque the step used): the peaks between samples the after-run check needs.
    peaks = np.zeros((3, n - 1, *batch))  # |omega|, turn rate, varying-rate term
    seen: list[Components | None] = []
    stages: list[Components | None] = []
    if torque_time_scale is not None:
        torque_time_scale[:] = [0.0, 0.0]  # largest |tau| [N m] and |d tau / dt| [N m/s] of the run
    for k in range(n - 1):
        tau_fun = torque_components(k)
        h = (t[k + 1] - t[k]) / subs[k]
        track = kind == "callable" or subs[k] > 1
        if track:
            plain_fun = tau_fun

            def tau_fun(
                tt: float, qs: Components, ws: Components, plain_fun: Callable = plain_fun
            ) -> Components | None:
                value = plain_fun(tt, qs, ws)
                if not seen:
                    seen.append(value)
                stages.append(value)
                return value

        for j in range(subs[k]):
            ts = t[k] + j * h
            if track:
                seen.clear()
                stages.clear()
                w_start = wc
            if method == "geometric":
                qc, wc = rkmk4_step(body, tau_fun, ts, qc, wc, h)
            else:

                def derivative(
                    tt: float,
                    xc: Components,
                    tau_fun: Callable[[float, Components, Components], Components | None] = tau_fun,
                ) -> Components:
                    return body.state_derivative_components(xc, tau_fun(tt, xc[:4], xc[4:]))

                xc = normalize_quaternion_components(rk4_step(derivative, ts, [*qc, *wc], h))
                qc, wc = xc[:4], xc[4:]
            steps += 1
            if track and (j > 0 or kind == "callable"):
                peaks[:, k] = np.maximum(peaks[:, k], _rule_rates(body, w_start, seen[0] if seen else None))
            if torque_time_scale is not None and len(stages) == 4:
                size, change = _torque_variation(stages, h)
                torque_time_scale[0] = max(torque_time_scale[0], size)
                torque_time_scale[1] = max(torque_time_scale[1], change)
        if kind == "callable":  # the end sample, with the torque of the last step
            peaks[:, k] = np.maximum(peaks[:, k], _rule_rates(body, wc, seen[0] if seen else None))
        q_store, w_store = qc, wc
        if output_frame is not None:
            q_store = quat.multiply_components(qc, conj)
            w_store = [c[0][j] * wc[0] + c[1][j] * wc[1] + c[2][j] * wc[2] for j in range(3)]
        for i in range(4):
            q_soa[k + 1, i] = q_store[i]
        for i in range(3):
            w_soa[k + 1, i] = w_store[i]
    return np.moveaxis(q_soa, 1, -1), np.moveaxis(w_soa, 1, -1), steps, tuple(np.moveaxis(peaks, 1, -1))


def _torque_variation(stages: list[Any], h: float) -> tuple[float, float]:
    """Largest ``|tau|`` [N m] and ``|d tau / dt|`` [N m/s] of a torque over one RK4 step, over a batch.

    From its stage values at ``0, h/2, h/2, h``: the change over the first
    half-step and over the whole step.
    """
    values = [np.stack(np.broadcast_arrays(*[np.asarray(c, dtype=float) for c in v])) for v in stages]
    size = max(float(np.max(np.sqrt(np.sum(v**2, axis=0)))) for v in values)
    change = max(
        float(np.max(np.sqrt(np.sum((values[1] - values[0]) ** 2, axis=0)))) / (0.5 * h),
        float(np.max(np.sqrt(np.sum((values[3] - values[0]) ** 2, axis=0)))) / h,
    )
    return size, change


def _rule_rates(body: RigidBody, omega: Components, tau: Components | None) -> NDArray[np.float64]:
    """:func:`attitude.integrators.rule_rates` of a state on components, stacked (3, ...)."""
    w = np.stack(np.broadcast_arrays(*omega), axis=-1)
    torque = None if tau is None else np.stack(np.broadcast_arrays(*tau), axis=-1)
    return np.stack(rule_rates(body, w, torque=torque))


def _propagate_adaptive(
    body: RigidBody,
    q0: NDArray[np.float64],
    omega0: NDArray[np.float64],
    t: NDArray[np.float64],
    kind: str,
    tq: Any,
    batch: tuple[int, ...],
    rtol: float,
    atol: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], dict[str, Any]]:
    """Adaptive reference propagation with scipy ``solve_ivp`` (DOP853).

    A torque on the time grid is integrated interval by interval so that
    the zero-order hold's jumps fall on segment boundaries.

    Parameters
    ----------
    body : RigidBody
        The plant (single or batched).
    q0 : ndarray, shape batch + (4,)
        Unit initial attitudes ``q_BN``.
    omega0 : ndarray, shape batch + (3,)
        Initial body rates [rad/s].
    t : ndarray, shape (n,)
        Output time grid [s].
    kind : {"const", "grid", "callable"}
        Torque kind from :func:`_torque_kind`.
    tq : ndarray or callable
        Torque [N m] of that kind.
    batch : tuple of int
        Batch shape.
    rtol, atol : float
        Relative and absolute tolerances of ``solve_ivp``.

    Returns
    -------
    q : ndarray, shape batch + (n, 4)
        Attitude quaternions at ``t`` (not renormalised).
    omega : ndarray, shape batch + (n, 3)
        Body rates at ``t`` [rad/s].
    info : dict
        ``nfev``, ``rtol``, ``atol`` and ``engine``.

    Raises
    ------
    RuntimeError
        If ``solve_ivp`` fails.
    """
    x0 = np.concatenate([q0, omega0], axis=-1).reshape(-1)

    def rhs_factory(tau_value: Callable[[float, NDArray], NDArray]) -> Callable:
        def rhs(ts: float, y: NDArray) -> NDArray:
            x = y.reshape((*batch, 7))
            return body.state_derivative(x, tau_value(ts, x)).reshape(-1)

        return rhs

    if kind == "callable":

        def tau_callable(ts: float, x: NDArray[np.float64]) -> NDArray[np.float64]:
            q = x[..., :4] / np.linalg.norm(x[..., :4], axis=-1, keepdims=True)
            return _call_torque(tq, ts, q, x[..., 4:], batch)

        segments = [(0, t.size - 1, tau_callable)]
    elif kind == "const":
        segments = [(0, t.size - 1, lambda _ts, _x: np.broadcast_to(tq, (*batch, 3)))]
    else:
        segments = [
            (k, k + 1, (lambda v: lambda _ts, _x: np.broadcast_to(v, (*batch, 3)))(tq[k])) for k in range(t.size - 1)
        ]

    ys = np.empty((t.size, x0.size))
    ys[0] = x0
    nfev = 0
    y = x0
    from scipy.integrate import solve_ivp  # imported when used: it costs a quarter second of start-up

    for i0, i1, tau_value in segments:
        sol = solve_ivp(
            rhs_factory(tau_value), (t[i0], t[i1]), y, method="DOP853", t_eval=t[i0 : i1 + 1], rtol=rtol, atol=atol
        )
        if not sol.success:
            raise RuntimeError(f"adaptive propagation failed at t = {sol.t[-1]!r} s: {sol.message}")
        nfev += sol.nfev
        ys[i0 : i1 + 1] = sol.y.T
        y = sol.y[:, -1]
    x = np.moveaxis(ys.reshape((t.size, *batch, 7)), 0, -2)
    return x[..., :4], x[..., 4:], {"nfev": int(nfev), "rtol": rtol, "atol": atol, "engine": "scipy DOP853"}

"""Direct multiple shooting of the slew: the interval constraints, the Opti problem, the grid solve.

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import signal
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from attitude.integrators import casadi_rk4_step
from attitude.quaternion import multiply_components
from controllers.slew.keep_out import cone_rows
from controllers.slew.problem import CONVERGED, Problem

__all__ = [
    "IPOPT_DEFAULTS",
    "USER_STOP",
    "IntervalFunction",
    "Solution",
    "Transcription",
    "check_ipopt_options",
    "interval_function",
    "ipopt_setup",
    "objective_terms",
    "sigint_guard",
    "solve_grid",
    "solve_nlp",
]

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


@dataclass(frozen=True)
class IntervalFunction:
    """``fun(x, u, h, x_next) -> (defect, path, from_start, from_end)``, all path rows ``<= 0``.

    ``path`` holds the rate-limit rows and the keep-out rows of sub-steps
    free at both ends; on the first (last) interval of the slew the rows
    ``first_drop`` (``last_drop``) of ``path`` are replaced by
    ``from_start`` (``from_end``), the keep-out bound next to the fixed end
    (:mod:`controllers.slew.keep_out`).

    Parameters
    ----------
    fun : casadi.Function
        ``fun(x, u, h, x_next) -> (defect, path, from_start, from_end)``.
    first_drop : tuple of int
        Rows of ``path`` replaced by ``from_start`` on the first interval.
    last_drop : tuple of int
        Rows of ``path`` replaced by ``from_end`` on the last interval.
    """

    fun: ca.Function
    first_drop: tuple[int, ...]
    last_drop: tuple[int, ...]


def interval_function(prob: Problem) -> IntervalFunction:
    """One multiple-shooting interval with its rate-limit and keep-out rows.

    The step is :func:`casadi_rk4_step` of the nondimensional body, so the
    dynamics are the one definition in :mod:`attitude.rigid_body`. The
    path constraints are imposed at every RK4 sub-step boundary (the
    checkpoints).

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
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
    if prob.rate_max_scaled is not None:
        g += [ca.sumsqr(p[4:]) - prob.rate_max_scaled**2 for p in points[1:]]
    first_drop: tuple[int, ...] = ()
    last_drop: tuple[int, ...] = ()
    start = end = ca.SX(0, 1)
    if prob.cones:
        rows = cone_rows(prob.body_s, points, u, h / m, prob.cones, margin=prob.keep_out_margin)
        per_cone = rows.inner.numel() // len(prob.cones)
        offsets = [len(g) + c * per_cone for c in range(len(prob.cones))]
        first_drop = tuple(o + i for o in offsets for i in rows.first_drop)
        last_drop = tuple(o + i for o in offsets for i in rows.last_drop)
        g += [rows.inner[i] for i in range(rows.inner.numel())]
        start, end = rows.from_start, rows.from_end
    path = ca.vertcat(*g) if g else ca.SX(0, 1)
    fun = ca.Function("slew_interval", [x, u, h, x_next], [defect, path, start, end])
    return IntervalFunction(fun, first_drop, last_drop)


@dataclass
class Solution:
    """One IPOPT answer: states ``X`` (7, n+1), torques ``U`` (3, n), interval lengths ``H`` (n), nondimensional.

    Parameters
    ----------
    status : str
        IPOPT's return status.
    iterations : int
        IPOPT iterations.
    solve_time : float
        Wall-clock time of the solve [s].
    X : ndarray
        Node states ``[q, omega T_s]`` (7, n + 1), nondimensional.
    U : ndarray
        Interval torques in units of ``tau_s`` (3, n).
    H : ndarray
        Interval lengths in units of ``T_s`` (n,).
    objective : float
        Value of the nondimensional objective.
    costate : ndarray, optional
        Multipliers of the continuity constraints (7, n + 1), nondimensional:
        column ``k`` estimates the costate at node ``k`` (docs/slew_planning.md,
        Optimality evidence); column 0 is minus the multiplier of the initial
        state. None when not asked for.
    path_multiplier : ndarray, optional
        Largest multiplier of a path constraint (rate limit, keep-out) per
        interval (n,), zero on intervals where none is active.
    path_row_multiplier : ndarray, optional
        Multiplier of every path row of every interval (m, n), rows in the
        order of the outputs ``path``, ``from_start``, ``from_end`` of
        :func:`interval_function` stacked, zero for a row not imposed on that
        interval (docs/slew_planning.md, Optimality evidence).
    """

    status: str
    iterations: int
    solve_time: float
    X: NDArray[np.float64]
    U: NDArray[np.float64]
    H: NDArray[np.float64]
    objective: float
    costate: NDArray[np.float64] | None = None
    path_multiplier: NDArray[np.float64] | None = None
    path_row_multiplier: NDArray[np.float64] | None = None

    @property
    def converged(self) -> bool:
        """IPOPT reported convergence."""
        return self.status in CONVERGED

    @property
    def duration(self) -> float:
        """Total duration (units of T_s)."""
        return float(np.sum(self.H))


class Transcription:
    """An Opti problem over ``n`` intervals with given interval-length and torque expressions.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    n : int
        Number of intervals.
    options : mapping
        IPOPT options of the caller (override :data:`IPOPT_DEFAULTS`).
    state_size : int
        Rows of the state ``[q, omega T_s, ...]``: 7, or ``7 + n_wheels`` with
        the wheel momenta as states (:mod:`controllers.slew.wheel_states`).
    """

    def __init__(self, prob: Problem, n: int, options: Mapping[str, Any], state_size: int = 7) -> None:
        self.prob = prob
        self.n = n
        self.opti = ca.Opti()
        self.X = self.opti.variable(state_size, n + 1)
        self.options = options
        self.continuity: Any = None
        self.initial: Any = None
        self.path: list[tuple[Any, list[int], list[int]]] = []
        self.path_rows = 0

    def constrain(self, U: Any, H: Any, interval: IntervalFunction | None = None, x0: Any = None) -> None:
        """Dynamics, boundary conditions and path constraints for torques ``U`` and lengths ``H``.

        Parameters
        ----------
        U : casadi.MX
            Control expressions (3, n) body torques in units of ``tau_s``, or
            the controls of ``interval``.
        H : casadi.MX
            Interval-length expressions (1, n), units of ``T_s``.
        interval : IntervalFunction, optional
            The interval's defect and path rows; default
            :func:`interval_function` of the rigid body.
        x0 : array_like, optional
            The initial state (nondimensional); default ``prob.x0``.
        """
        prob, opti, X = self.prob, self.opti, self.X
        n = self.n
        f = interval_function(prob) if interval is None else interval
        defect, g, g_start, g_end = f.fun.map(n)(X[:, :-1], U, H, X[:, 1:])
        self.continuity = ca.vec(defect) == 0
        opti.subject_to(self.continuity)
        # Path constraints with the interval and the row (of path, from_start, from_end stacked) of each entry.
        path: list[tuple[Any, list[int], list[int]]] = []
        rows, rows_start = g.shape[0], g_start.shape[0]
        if rows:
            first = [i for i in range(rows) if i not in f.first_drop]
            last = [i for i in range(rows) if i not in f.last_drop]
            if first:
                path.append((g[first, 0] <= 0, [0] * len(first), first))
            if n > 2:
                path.append(
                    (
                        ca.vec(g[:, 1 : n - 1]) <= 0,
                        list(np.repeat(np.arange(1, n - 1), rows)),
                        list(range(rows)) * (n - 2),
                    )
                )
            if last:
                path.append((g[last, n - 1] <= 0, [n - 1] * len(last), last))
        if rows_start:
            path.append((g_start[:, 0] <= 0, [0] * rows_start, list(range(rows, rows + rows_start))))
            end_rows = list(range(rows + rows_start, rows + rows_start + g_end.shape[0]))
            path.append((g_end[:, n - 1] <= 0, [n - 1] * g_end.shape[0], end_rows))
        self.path_rows = rows + rows_start + g_end.shape[0]
        for con, _, _ in path:
            opti.subject_to(con)
        self.path = path
        self.initial = X[:, 0] == (prob.x0 if x0 is None else x0)
        opti.subject_to(self.initial)
        opti.subject_to(X[4:7, -1] == prob.omegaf * prob.t_s)
        w, x, y, z = prob.qf
        err = multiply_components([w, -x, -y, -z], [X[i, -1] for i in range(4)])
        opti.subject_to(ca.vertcat(*err[1:]) == 0)

    def torque_set(self, U: Any) -> None:
        """Keep the torque variables ``U`` (3 x k) in the torque set.

        Parameters
        ----------
        U : casadi.MX
            Torque variables (3, k), units of ``tau_s``.
        """
        prob = self.prob
        if prob.torque_set.is_box:
            lim = prob.u_bounds()
            for i in range(3):
                self.opti.subject_to(self.opti.bounded(-lim[i], U[i, :], lim[i]))
        else:
            self.opti.subject_to(self.opti.bounded(-1.0, ca.vec(ca.mtimes(prob.rows_s, U)), 1.0))

    def solve(
        self, initial: list[tuple[Any, Any]], values: dict[str, Any]
    ) -> tuple[str, int, float, dict[str, NDArray[np.float64]]]:
        """Solve from ``initial`` (variable, value) pairs; returns status, iterations, time, values.

        Parameters
        ----------
        initial : list of (variable, value)
            Initial guesses of the Opti variables.
        values : dict of str to casadi.MX
            Expressions to evaluate at the answer, by name.
        """
        opti = self.opti
        for var, val in initial:
            opti.set_initial(var, val)
        start = time.perf_counter()
        stats = solve_nlp(opti)
        elapsed = time.perf_counter() - start
        out = {k: np.atleast_1d(np.asarray(opti.debug.value(v), dtype=float)) for k, v in values.items()}
        if self.continuity is not None:
            out.update(self._multipliers())
        return str(stats.get("return_status", "unknown")), int(stats.get("iter_count", -1)), elapsed, out

    def _multipliers(self) -> dict[str, NDArray[np.float64]]:
        """Costate estimates (7, n + 1) and the largest path-constraint multiplier per interval (n,).

        IPOPT's Lagrangian is ``f + nu^T g``; with the continuity defect
        ``F(x_k, u_k, h_k) - x_{k+1}``, stationarity in ``x_{k+1}`` reads
        ``nu_k = (dF_{k+1}/dx)^T nu_{k+1}``, the discrete adjoint equation: ``nu_k``
        is the costate at node ``k + 1`` (docs/slew_planning.md, Optimality evidence).
        Stationarity in ``x_0`` gives the costate at node 0 as minus the
        multiplier of ``x_0 = x0``.
        """
        opti, n = self.opti, self.n
        rows = self.X.shape[0]
        nu = np.asarray(opti.debug.value(opti.dual(self.continuity)), dtype=float).reshape(rows, n, order="F")
        nu0 = -np.asarray(opti.debug.value(opti.dual(self.initial)), dtype=float).reshape(rows, 1)
        path, per_row = np.zeros(n), np.zeros((self.path_rows, n))
        for con, intervals, rows in self.path:
            mu = np.atleast_1d(np.asarray(opti.debug.value(opti.dual(con)), dtype=float))
            np.maximum.at(path, np.asarray(intervals, dtype=int), np.abs(mu))
            per_row[np.asarray(rows, dtype=int), np.asarray(intervals, dtype=int)] = mu
        return {"costate": np.hstack([nu0, nu]), "path_multiplier": path, "path_row_multiplier": per_row}


#: IPOPT's status when its intermediate callback asks it to stop. The planner
#: installs no callback of its own, so only casadi's interrupt check (Ctrl-C
#: reaching a callback) stops a solve this way.
USER_STOP = "User_Requested_Stop"


#: The flags of the SIGINT guards active in the main thread, innermost last.
_GUARDS: list[list[bool]] = []


@contextmanager
def _sigint_seen() -> Iterator[list[bool]]:
    """Note whether SIGINT raised KeyboardInterrupt inside the block (casadi may swallow it).

    casadi polls for Ctrl-C inside IPOPT's callbacks, runs the Python handler
    there, and turns the KeyboardInterrupt into an aborted solve
    (``NonIpopt_Exception_Thrown`` in casadi 3.8) with no Python exception
    left; while it builds a problem, its SWIG layer discards a
    KeyboardInterrupt raised in a Python callback (an array's ``shape``): the
    flag is what remains of it. Handlers other than a Python callable
    (SIG_IGN in a campaign's worker, SIG_DFL) and threads other than the main
    one (where Python sets no handlers) are left alone.
    """
    seen = [False]
    previous = signal.getsignal(signal.SIGINT)
    if threading.current_thread() is not threading.main_thread() or not callable(previous):
        yield seen
        return

    def handler(signum: int, frame: Any) -> None:
        try:
            previous(signum, frame)
        except KeyboardInterrupt:
            seen[0] = True
            raise

    signal.signal(signal.SIGINT, handler)
    _GUARDS.append(seen)
    try:
        yield seen
    finally:
        _GUARDS.pop()  # guards nest: this one is the innermost
        signal.signal(signal.SIGINT, previous)


@contextmanager
def sigint_guard(what: str) -> Iterator[None]:
    """Raise KeyboardInterrupt at the end of the block if SIGINT arrived in it, whatever casadi did with it.

    The planner runs inside one guard (:func:`controllers.slew.planner.plan_slew`)
    and each solve inside another (:func:`solve_nlp`), which also refuses to
    start once an enclosing guard has seen Ctrl-C: a Ctrl-C swallowed while a
    problem was being built stops the planning at its next solve at the
    latest. An exception that replaced the interrupt (casadi turns some into
    a TypeError) gives way to KeyboardInterrupt. The previous handler is
    restored on every path.

    Parameters
    ----------
    what : str
        The KeyboardInterrupt's message.

    Raises
    ------
    KeyboardInterrupt
        SIGINT arrived inside the block.
    """
    with _sigint_seen() as seen:
        try:
            yield
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            if seen[0]:
                raise KeyboardInterrupt(what) from exc
            raise
    if seen[0]:
        raise KeyboardInterrupt(what)


def _raise_if_interrupted(what: str) -> None:
    """KeyboardInterrupt if an enclosing guard has seen SIGINT (swallowed by casadi since)."""
    if any(seen[0] for seen in _GUARDS):
        raise KeyboardInterrupt(what)


def solve_nlp(opti: ca.Opti) -> dict[str, Any]:
    """Run ``opti.solve()`` and return its statistics; Ctrl-C during the solve raises KeyboardInterrupt.

    Every IPOPT solve of the planner goes through here. A solve that fails
    (any IPOPT status) returns normally, its status in the statistics; a
    solve stopped by Ctrl-C raises KeyboardInterrupt instead of coming back
    as one more failed start (or a rejected refinement) from which the
    planner would go on and return another plan. No solve starts once an
    enclosing :func:`sigint_guard` has seen Ctrl-C.

    Parameters
    ----------
    opti : casadi.Opti
        The problem, with its solver attached.

    Raises
    ------
    KeyboardInterrupt
        SIGINT arrived during the solve or before it inside an enclosing
        :func:`sigint_guard`, or IPOPT stopped on the user's request
        (:data:`USER_STOP`).
    """
    what = "slew planning interrupted (Ctrl-C during an IPOPT solve)"
    _raise_if_interrupted("slew planning interrupted (Ctrl-C while the problem was built)")
    with sigint_guard(what):
        try:
            opti.solve()
        except RuntimeError:
            pass  # not converged: the status says why
    stats = opti.stats()
    if stats.get("return_status") == USER_STOP:
        raise KeyboardInterrupt(what)
    return stats


def check_ipopt_options(options: Any) -> dict[str, Any]:
    """The caller's IPOPT options, checked by IPOPT itself on a one-variable problem.

    An unknown option or a value of the wrong type made every solve fail
    with casadi's "not solved"; it is refused up front instead.

    Parameters
    ----------
    options : mapping or None
        IPOPT options (names and values as IPOPT documents them).

    Returns
    -------
    dict
        The options as a plain dict.

    Raises
    ------
    ValueError
        Naming ``ipopt_options``, the option IPOPT refused and its message.
    """
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(f"ipopt_options must be a mapping of IPOPT option names to values, got {options!r}")
    opts = dict(options)
    x = ca.SX.sym("x")
    quiet = {"print_level": 0, "sb": "yes"}
    try:
        ca.nlpsol(
            "ipopt_options_check", "ipopt", {"x": x, "f": x * x}, {"print_time": False, "ipopt": {**opts, **quiet}}
        )
    except RuntimeError as exc:
        reason = str(exc).strip().splitlines()[-1].split(": ", 1)[-1]
        raise ValueError(f"ipopt_options {opts!r}: IPOPT refuses them: {reason}") from None
    return opts


def ipopt_setup(tr: Transcription, max_iter: int) -> None:
    """Attach IPOPT with :data:`IPOPT_DEFAULTS`, ``max_iter`` and the caller's options.

    Parameters
    ----------
    tr : Transcription
        The problem.
    max_iter : int
        IPOPT iteration limit.
    """
    opts = dict(IPOPT_DEFAULTS)
    opts["max_iter"] = int(max_iter)
    opts.update(tr.options)
    tr.opti.solver("ipopt", {"print_time": False, "detect_simple_bounds": True}, opts)


def objective_terms(
    opti: ca.Opti, U: Any, n: int, objective: str, duration_s: float | None, guesses: list[tuple[Any, Any, float]]
) -> tuple[Any, Any, Any]:
    """The duration variable (None for a fixed duration), the interval lengths and the cost of a uniform grid.

    Minimum time: a free duration ``T`` (within ``1e-3`` to ``1e3`` times the longest guess), ``H = T / n``,
    cost ``T``. Minimum energy: the fixed ``duration_s``, cost ``sum |U|^2 H`` (the controls' squares).

    Parameters
    ----------
    opti : casadi.Opti
        The problem.
    U : casadi.MX
        The controls (m, n).
    n : int
        Intervals.
    objective : str
        ``"time"`` or ``"energy"``.
    duration_s : float or None
        The fixed duration in units of ``T_s`` (energy).
    guesses : list of (X0, U0, T0)
        The guesses (their durations bound the free one).
    """
    if objective == "time":
        T = opti.variable()
        t_guess = max(g[2] for g in guesses)
        opti.subject_to(opti.bounded(1e-3 * t_guess, T, 1e3 * t_guess))
        return T, ca.repmat(T / n, 1, n), T
    H = ca.DM.ones(1, n) * (duration_s / n)
    return None, H, ca.sum2(ca.sum1(U * U) * H)


def solve_grid(
    prob: Problem,
    n: int,
    objective: str,
    duration_s: float | None,
    smoothing: float,
    guesses: list[tuple[NDArray, NDArray, float]],
    max_iter: int,
    options: Mapping[str, Any],
    solved: Callable[[], None] | None = None,
) -> tuple[Solution | None, list[Solution]]:
    """Solve the uniform-grid problem from each guess ``(X0, U0, T0)``; the best converged answer and all answers.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    n : int
        Number of intervals of the uniform grid.
    objective : str
        ``"time"`` or ``"energy"``.
    duration_s : float or None
        Fixed duration in units of ``T_s`` (energy objective); None for minimum time.
    smoothing : float
        Weight of the torque-increment penalty, >= 0 (docs/slew_planning.md).
    guesses : list of (X0, U0, T0)
        Initial guesses: states (7, n + 1), torques (3, n) and duration, nondimensional.
    max_iter : int
        IPOPT iteration limit.
    options : mapping
        IPOPT options of the caller (override :data:`IPOPT_DEFAULTS`).
    solved : callable, optional
        Called with no argument after each guess is solved (a progress bar over the starts).
    """
    tr = Transcription(prob, n, options)
    opti = tr.opti
    U = opti.variable(3, n)
    T, H, cost = objective_terms(opti, U, n, objective, duration_s, guesses)
    if smoothing > 0:
        cost = cost + smoothing * ca.sumsqr(U[:, 1:] - U[:, :-1])
    opti.minimize(cost)
    tr.constrain(U, H)
    tr.torque_set(U)
    ipopt_setup(tr, max_iter)
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
            Solution(
                status=status,
                iterations=iters,
                solve_time=elapsed,
                X=val["X"].reshape(7, n + 1),
                U=val["U"].reshape(3, n),
                H=np.full(n, t_total / n),
                objective=float(val["cost"][0]),
                costate=val["costate"],
                path_multiplier=val["path_multiplier"],
                path_row_multiplier=val["path_row_multiplier"],
            )
        )
        if solved is not None:
            solved()
    good = [r for r in results if r.converged]
    best = min(good, key=lambda r: r.objective) if good else None
    return best, results

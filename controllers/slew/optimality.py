"""Evidence of optimality: Pontryagin's necessary conditions checked from the NLP's multipliers.

Part of :mod:`controllers.slew.planner` (import the public names from there).

For the minimum-time slew, ``min t_f`` with ``x = [q, omega]``,
``x_dot = f(x, tau)`` and a torque box ``|tau_i| <= tau_max_i``, the
minimum principle with ``lambda_0 = 1`` reads (docs/slew_planning.md,
Optimality evidence):

* ``H = 1 + lambda_q . q_dot + lambda_omega . omega_dot`` is constant and,
  the final time being free, zero;
* ``H`` depends on the torque through ``sigma . tau`` with the switching
  function ``sigma = I^-1 lambda_omega`` (``omega_dot = I^-1 (tau - omega x I
  omega)``, ``I`` symmetric), so ``tau_i = -tau_max_i sign(sigma_i)`` wherever
  ``sigma_i != 0`` (bang-bang); ``sigma_i = 0`` over an arc is a singular arc.

With a rate limit or keep-out cone active, the constraints are adjoined
directly (Hartl, Sethi and Vickson, SIAM Review 37(2), 1995): the costate
jumps where the path meets the boundary, ``H`` (equal to ``H + mu^T g`` on
the trajectory) is still zero, and the torque still minimises ``H`` over the
box; each interval's ``H`` is taken with its own continuity multiplier
(:func:`interval_costates`), and the switching function is not checked on
intervals where a path row is active.

The costates are the multipliers of the continuity constraints of the
multiple-shooting NLP (:meth:`controllers.slew.transcription.Transcription.solve`):
no fit, no extra solve. A converged answer meets the *discrete* conditions by
construction; the continuous ones above hold only to the grid's accuracy for
a true extremal, and fail by O(1) for the answer of a different problem (an
extra constraint, a smaller torque box) checked as if it solved this one.
Necessary conditions only: a local optimum that is not the global one (the
long way round, the eigenaxis slew of a symmetric body with its singular
off-axis arcs) passes them; the multi-start is what tells those apart.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.rigid_body import RigidBody
from controllers.slew.problem import Problem
from controllers.slew.refine import SATURATION_TOLERANCE
from controllers.slew.transcription import interval_function

__all__ = [
    "HAMILTONIAN_GRID_FACTOR",
    "HAMILTONIAN_TOLERANCE",
    "SWITCHING_TOLERANCE",
    "SWITCHING_ZERO_FRACTION",
    "check_solution",
    "costate_physical",
    "interval_costates",
    "pontryagin_check",
    "summary_words",
]

#: A switch-time refined, grid-converged plan is flagged when ``max |H|`` over
#: the checked intervals exceeds this (``H`` is dimensionless: the ``1`` of
#: ``lambda_0``). Measured: 6e-8 to 2.4e-6 on 20 nodes (Bilimoria-Wie 180 and
#: 90 deg, an asymmetric body, a small satellite).
HAMILTONIAN_TOLERANCE = 1e-4

#: A uniform-grid answer (or a refined one that is not grid-converged) is
#: flagged when ``max |H|`` exceeds ``HAMILTONIAN_GRID_FACTOR / n``: an interval
#: holding a switch carries an intermediate torque, so ``|H|`` at its ends is
#: of order ``|sigma_dot| h tau_max``, O(1/n). Measured ``n max |H|`` <= 1.95 on
#: 8 to 50 nodes over the same four slews; 4 leaves a factor 2.
HAMILTONIAN_GRID_FACTOR = 4.0

#: A switching function ``sigma_i`` counts as away from its zeros on an
#: interval when ``|sigma_i| tau_max_i`` at both ends is at least this
#: fraction of its largest value over the intervals checked (no path row
#: active) and all axes, with one sign.
SWITCHING_ZERO_FRACTION = 0.05

#: A path constraint's multiplier counts as active above this fraction of
#: ``1 + max |nu|`` (an inactive one is of the order of IPOPT's barrier
#: parameter over the slack, ~1e-9 at tol 1e-9).
PATH_ACTIVE = 1e-6

#: Largest accepted fraction of (interval, axis) pairs, away from the zeros
#: of the switching function, whose torque is not ``-tau_max sign(sigma)``.
SWITCHING_TOLERANCE = 0.02


def costate_physical(prob: Problem, costate: NDArray[np.float64]) -> NDArray[np.float64]:
    """The NLP's nondimensional costates (7, n + 1) in physical units (n + 1, 7).

    ``H = 1 + nu . dx_s/dt_s`` is the same number in both unit systems: with
    ``q_dot_s = T_s q_dot`` and ``omega_dot_s = T_s^2 omega_dot``,
    ``lambda_q = T_s nu_q`` [s] and ``lambda_omega = T_s^2 nu_omega`` [s^2].

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    costate : ndarray
        Nondimensional costates (7, n + 1) (:class:`controllers.slew.transcription.Solution`).
    """
    scale = np.array([prob.t_s] * 4 + [prob.t_s**2] * 3)
    return (costate * scale[:, None]).T.copy()


def pontryagin_check(
    body: RigidBody,
    q: ArrayLike,
    omega: ArrayLike,
    torque: ArrayLike,
    costate: ArrayLike,
    torque_box: ArrayLike | None,
    checked: ArrayLike | None = None,
    hamiltonian_tolerance: float = HAMILTONIAN_TOLERANCE,
    costate_start: ArrayLike | None = None,
    path_active: ArrayLike | None = None,
) -> dict[str, Any]:
    """Pontryagin's conditions of a minimum-time plan on its nodes (module docstring).

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    q : array_like
        Node attitudes ``q_BN`` (n + 1, 4).
    omega : array_like
        Node body rates [rad/s] (n + 1, 3).
    torque : array_like
        Torque held over each interval [N m] (n, 3) or (n + 1, 3) (the last row ignored).
    costate : array_like
        Costates at the nodes (n + 1, 7): ``lambda_q`` [s], ``lambda_omega`` [s^2]
        (:func:`costate_physical`).
    torque_box : array_like (3,) or None
        Per-axis torque bound [N m] for the switching check; None skips it
        (a torque set that is not a box: only the Hamiltonian is checked).
    checked : array_like of bool (n,), optional
        Intervals to check (default all).
    hamiltonian_tolerance : float
        Largest accepted ``max |H|`` (:data:`HAMILTONIAN_TOLERANCE` for a
        grid-converged plan, ``HAMILTONIAN_GRID_FACTOR / n`` for a grid answer).
    costate_start : array_like (n, 7), optional
        Costate at the start of each interval, carried back from its end
        through the interval's flow (:func:`interval_costates`); default the
        node costates ``costate[:-1]``, which hold the jumps of the path
        constraints active at the node (the same where none is active).
    path_active : array_like of bool (n,), optional
        Intervals where a path constraint (rate limit, keep-out cone) is
        active: ``H`` is checked there, the switching function is not (the
        torque there also answers to the constraint, docs/slew_planning.md).

    Returns
    -------
    dict
        ``hamiltonian_residual`` (``max |H|`` at both ends of the checked
        intervals), ``hamiltonian_mean``, ``hamiltonian_spread``
        (``max |H - mean|``), ``switching_disagreement`` (fraction of the
        decided (interval, axis) pairs whose torque is not
        ``-tau_max sign(sigma)``; None without a box), ``switching_decided``
        (their number), ``intervals_checked``, ``intervals``, ``passes`` and
        ``note`` (why a part was skipped, or empty).
    """
    q = np.asarray(q, dtype=float)
    omega = np.asarray(omega, dtype=float)
    lam = np.asarray(costate, dtype=float)
    n = q.shape[0] - 1
    tau = np.asarray(torque, dtype=float)[:n]
    mask = np.ones(n, dtype=bool) if checked is None else np.asarray(checked, dtype=bool)
    active = np.zeros(n, dtype=bool) if path_active is None else np.asarray(path_active, dtype=bool)
    lam_start = lam[:-1] if costate_start is None else np.asarray(costate_start, dtype=float)
    x = np.concatenate([q, omega], axis=1)
    notes = []
    if not np.any(mask):
        raise ValueError("checked must select at least one interval, got none")
    if not np.all(mask):
        notes.append(f"checked on {int(np.sum(mask))} of {n} intervals")
    # H at both ends of each interval with the interval's torque.
    h_start = 1.0 + np.sum(lam_start * body.state_derivative(x[:-1], tau), axis=1)
    h_end = 1.0 + np.sum(lam[1:] * body.state_derivative(x[1:], tau), axis=1)
    h = np.concatenate([h_start[mask], h_end[mask]])
    out: dict[str, Any] = {
        "hamiltonian_residual": float(np.max(np.abs(h))),
        "hamiltonian_mean": float(np.mean(h)),
        "hamiltonian_spread": float(np.max(np.abs(h - np.mean(h)))),
        "switching_disagreement": None,
        "switching_decided": 0,
        "intervals_checked": int(np.sum(mask)),
        "intervals": n,
        "intervals_path_active": int(np.sum(active & mask)),
    }
    out["hamiltonian_tolerance"] = float(hamiltonian_tolerance)
    passes = out["hamiltonian_residual"] <= hamiltonian_tolerance
    if np.any(active & mask):
        notes.append(
            f"a path constraint is active on {int(np.sum(active & mask))} of {n} intervals: H checked there, "
            "the switching function not"
        )
    if torque_box is None:
        notes.append("switching check skipped: the torque set is not a per-axis box")
    else:
        box = np.broadcast_to(np.asarray(torque_box, dtype=float), (3,))
        # I^-1 lambda_omega at both ends of each interval, with the interval's own costates, (n, 3) each.
        s0 = lam_start[:, 4:] @ body.inertia_inv.T
        s1 = lam[1:, 4:] @ body.inertia_inv.T
        w0, w1 = np.abs(s0) * box, np.abs(s1) * box
        free = mask & ~active
        scale = float(np.max(np.maximum(w0, w1)[free])) if np.any(free) else 0.0
        decided = (np.sign(s0) == np.sign(s1)) & (np.minimum(w0, w1) >= SWITCHING_ZERO_FRACTION * scale)
        decided &= free[:, None]
        wrong = tau * np.sign(s1) > -(1.0 - SATURATION_TOLERANCE) * box
        count = int(np.sum(decided))
        out["switching_decided"] = count
        out["switching_disagreement"] = float(np.sum(decided & wrong) / count) if count else 0.0
        passes = passes and out["switching_disagreement"] <= SWITCHING_TOLERANCE
    out["passes"] = bool(passes)
    out["note"] = "; ".join(notes)
    return out


def interval_costates(prob: Problem, sol: Any) -> NDArray[np.float64]:
    """Costate at the start of each interval, carried back from its end through the interval's flow (7, n + 1).

    Column ``k < n`` is ``(dF_k / dx_k)^T nu_k``: the multiplier ``nu_k`` of
    interval ``k``'s continuity defect (the costate at its end, node
    ``k + 1``) carried back through the RK4 flow ``F_k`` of that interval
    alone. Where no path constraint is active at node ``k`` this is the node
    costate ``nu_{k-1}``; where one is, ``nu_{k-1}`` also holds the
    constraint's jump (its multiplier times its gradient, docs/slew_planning.md,
    Optimality evidence), which belongs to the costate just *before* the
    node. The last column is the final node's costate, unchanged.
    Nondimensional, like ``sol.costate``.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    sol : Solution
        The answer, with its ``costate`` (7, n + 1).
    """
    fun = interval_function(prob).fun
    x, u, h, x_next = (ca.SX.sym(name, fun.size1_in(i)) for i, name in enumerate(("x", "u", "h", "x_next")))
    defect = fun(x, u, h, x_next)[0]
    # dF/dx of the defect F(x, u, h) - x_next, as its transpose times nu: the carried-back costate.
    nu = ca.SX.sym("nu", 7)
    back = ca.Function("carry_back", [x, u, h, x_next, nu], [ca.mtimes(ca.jacobian(defect, x).T, nu)])
    n = sol.U.shape[1]
    out = np.asarray(
        back.map(n)(sol.X[:, :-1], sol.U, sol.H.reshape(1, n), sol.X[:, 1:], sol.costate[:, 1:]), dtype=float
    )
    return np.hstack([out, sol.costate[:, -1:]])


def summary_words(check: dict[str, Any] | None) -> str:
    """The Pontryagin check in a few words for a plan's summary line (empty when not checked).

    Parameters
    ----------
    check : dict or None
        The result of :func:`pontryagin_check` (``plan.info["pontryagin"]``).
    """
    if not check or check.get("passes") is None:
        return ""
    text = f"Pontryagin residual {check['hamiltonian_residual']:.2g}"
    if check.get("switching_disagreement") is not None:
        text += f", switching disagreement {100 * check['switching_disagreement']:.2g} %"
    if not check["passes"]:
        return f"NOT an extremal ({text}): flagged"
    return f"{text} (passes)"


def check_solution(
    prob: Problem, sol: Any, torque: NDArray[np.float64], objective: str, grid_converged: bool
) -> dict[str, Any]:
    """Pontryagin check of one NLP answer (its multipliers as costates); skipped, with a note, where it does not apply.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    sol : Solution
        The answer, with its ``costate`` and ``path_multiplier``.
    torque : ndarray
        The plan's torque [N m] (n + 1, 3) (held per interval, last row repeated).
    objective : str
        ``"time"`` or ``"energy"``.
    grid_converged : bool
        The answer is switch-time refined and bang-bang (the tight tolerance applies).
    """
    if objective != "time" or sol.costate is None:
        return {"passes": None, "note": "not checked: the Pontryagin check is for minimum-time plans"}
    path = sol.path_multiplier if sol.path_multiplier is not None else np.zeros(sol.U.shape[1])
    active = path > PATH_ACTIVE * (1.0 + float(np.max(np.abs(sol.costate))))
    box = prob.torque_set.envelope if prob.torque_set.is_box else None
    out = pontryagin_check(
        prob.body,
        sol.X[:4].T,
        sol.X[4:].T / prob.t_s,
        torque,
        costate_physical(prob, sol.costate),
        box,
        hamiltonian_tolerance=HAMILTONIAN_TOLERANCE if grid_converged else HAMILTONIAN_GRID_FACTOR / sol.U.shape[1],
        costate_start=costate_physical(prob, interval_costates(prob, sol))[:-1],
        path_active=active,
    )
    out["tolerances"] = {
        "hamiltonian": out["hamiltonian_tolerance"],
        "switching_disagreement": SWITCHING_TOLERANCE,
        "switching_zero_fraction": SWITCHING_ZERO_FRACTION,
    }
    return out

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
box. Each interval's ``H`` is taken with the costate just after its start and
just before its end, plus its path rows' ``mu^T dg/dh``
(:func:`interval_costates`); intervals within :data:`JUNCTION_INTERVALS` of a
junction are left out, and the switching function is not checked on
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
    "HAMILTONIAN_PATH_FACTOR",
    "HAMILTONIAN_TOLERANCE",
    "JUNCTION_INTERVALS",
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

#: With a path constraint active somewhere, a refined plan (bang-bang or not:
#: the refinement frees the switch times, not the junctions) is flagged when
#: ``max |H|`` over the intervals checked exceeds ``HAMILTONIAN_PATH_FACTOR / n``.
#: Measured ``n max |H|`` up to 1.94 on 20 to 80 nodes over four slews (the
#: small satellite's keep-out slew); 8 leaves a factor 4. A uniform-grid
#: answer has its ``H`` reported, not judged: the grid puts the junctions on
#: its nodes, and ``H`` is constant on each arc but offset between them (0.13
#: on the 3-interval accelerations of the small satellite's 1 deg/s slew on
#: 100 nodes, -0.008 on its coast).
HAMILTONIAN_PATH_FACTOR = 8.0

#: Intervals on each side of a junction (where a path constraint's activity
#: starts or ends, or a boundary arc meets the slew's start or end) left out
#: of the check: the grid smears the junction over them, the torque there
#: neither the arc's before nor after it, and ``|H|`` reaches 0.06 (refined,
#: 60 nodes) to 0.5 (uniform grid, 30 nodes) whatever the grid.
JUNCTION_INTERVALS = 2

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
    costate_end: ArrayLike | None = None,
    path_active: ArrayLike | None = None,
    path_length_term: ArrayLike | None = None,
    hamiltonian_decides: bool = True,
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
    costate_start, costate_end : array_like (n, 7), optional
        Costates just after the start and just before the end of each
        interval, in the units of ``costate`` (:func:`interval_costates`);
        default the node costates ``costate[:-1]`` and ``costate[1:]``, the
        same where no path constraint is active at the node.
    path_active : array_like of bool (n,), optional
        Intervals where a path constraint (rate limit, keep-out cone) is
        active: ``H`` is checked there, the switching function is not (the
        torque there also answers to the constraint, docs/slew_planning.md).
    path_length_term : array_like (n,), optional
        ``mu_k^T dg_k/dh_k`` of each interval (dimensionless, like ``H``),
        added to its ``H`` (:func:`interval_costates`); default zero.
    hamiltonian_decides : bool
        ``max |H|`` above its tolerance fails the plan (default); False
        reports it only (a uniform-grid answer with a path constraint active).

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
    lam_end = lam[1:] if costate_end is None else np.asarray(costate_end, dtype=float)
    term = np.zeros(n) if path_length_term is None else np.asarray(path_length_term, dtype=float)
    x = np.concatenate([q, omega], axis=1)
    notes = []
    if not np.any(mask):
        raise ValueError("checked must select at least one interval, got none")
    if not np.all(mask):
        notes.append(f"checked on {int(np.sum(mask))} of {n} intervals (not within {JUNCTION_INTERVALS} of a junction)")
    # H at both ends of each interval with the interval's torque.
    h_start = 1.0 + np.sum(lam_start * body.state_derivative(x[:-1], tau), axis=1) + term
    h_end = 1.0 + np.sum(lam[1:] * body.state_derivative(x[1:], tau), axis=1) + term
    h = np.concatenate([h_start[mask], h_end[mask]])
    out: dict[str, Any] = {
        "hamiltonian_residual": float(np.max(np.abs(h))),
        "hamiltonian_mean": float(np.mean(h)),
        "hamiltonian_spread": float(np.max(np.abs(h - np.mean(h)))),
        "switching_disagreement": None,
        "switching_decided": 0,
        "intervals_checked": int(np.sum(mask)),
        "intervals": n,
        "intervals_path_active": int(np.sum(active)),
    }
    out["hamiltonian_tolerance"] = float(hamiltonian_tolerance)
    passes = out["hamiltonian_residual"] <= hamiltonian_tolerance or not hamiltonian_decides
    if not hamiltonian_decides:
        notes.append(
            "H reported, not judged: a uniform grid puts the junctions of the path constraint on its nodes, so H is "
            "constant on each arc but not the same on all"
        )
    if np.any(active):
        notes.append(
            f"a path constraint is active on {int(np.sum(active))} of {n} intervals: the switching function not "
            "checked there"
        )
    if torque_box is None:
        notes.append("switching check skipped: the torque set is not a per-axis box")
    else:
        box = np.broadcast_to(np.asarray(torque_box, dtype=float), (3,))
        # I^-1 lambda_omega at both ends of each interval, with the interval's own costates, (n, 3) each.
        s0 = lam_start[:, 4:] @ body.inertia_inv.T
        s1 = lam_end[:, 4:] @ body.inertia_inv.T
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


def interval_costates(prob: Problem, sol: Any) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Costates just after and just before each interval's ends, and its path rows' length term (nondimensional).

    The continuity multipliers satisfy the discrete adjoint equation with
    the path rows' jumps (docs/slew_planning.md, Optimality evidence):
    ``nu_{k-1} = (dF_k/dx)^T nu_k + G_k + E_{k-1}``, where
    ``G_k = d(mu_k^T g_k)/dx_k`` collects the rows of interval ``k`` inside
    it (its sub-steps, carried back to node ``k``) and
    ``E_{k-1} = d(mu_{k-1}^T g_{k-1})/dx_k`` the row of interval ``k - 1`` at
    node ``k`` (the jump at the node). The costate just after node ``k`` is
    ``nu_{k-1} - E_{k-1}`` (column 0: the node-0 costate) and just before
    node ``k + 1`` it is ``nu_k - G_{k+1}`` (the last: ``nu_{n-1}``); the
    length term ``mu_k^T dg_k/dh_k`` is the rows' share of the Lagrangian's
    derivative in the interval length, which completes the interval's ``H``.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    sol : Solution
        The answer, with its ``costate`` (7, n + 1) and ``path_row_multiplier``.

    Returns
    -------
    tuple of ndarray
        Costates after the start and before the end of each interval (7, n)
        each, and the length term (n,).
    """
    nu = sol.costate
    n = sol.U.shape[1]
    start, end, term = nu[:, :-1].copy(), nu[:, 1:].copy(), np.zeros(n)
    mu = sol.path_row_multiplier
    if mu is None or mu.shape[0] == 0:
        return start, end, term
    fun = interval_function(prob).fun
    x, u, h, x_next = (ca.SX.sym(name, fun.size1_in(i)) for i, name in enumerate(("x", "u", "h", "x_next")))
    rows = ca.vertcat(*fun(x, u, h, x_next)[1:])
    m = ca.SX.sym("mu", rows.numel())
    lagrangian = ca.dot(m, rows)
    parts = ca.Function(
        "path_terms",
        [x, u, h, x_next, m],
        [ca.gradient(lagrangian, x), ca.gradient(lagrangian, x_next), ca.gradient(lagrangian, h)],
    ).map(n)
    inside, at_end, length = (
        np.asarray(v, dtype=float) for v in parts(sol.X[:, :-1], sol.U, sol.H.reshape(1, n), sol.X[:, 1:], mu)
    )
    start[:, 1:] -= at_end[:, :-1]
    end[:, :-1] -= inside[:, 1:]
    return start, end, length.ravel()


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
    prob: Problem,
    sol: Any,
    torque: NDArray[np.float64],
    objective: str,
    grid_converged: bool,
    refined: bool = True,
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
    refined : bool
        The answer has free phase durations (the refinement's); a
        uniform-grid answer with a path constraint active has its ``H``
        reported, not judged.
    """
    if objective != "time" or sol.costate is None:
        return {"passes": None, "note": "not checked: the Pontryagin check is for minimum-time plans"}
    n = sol.U.shape[1]
    path = sol.path_multiplier if sol.path_multiplier is not None else np.zeros(n)
    active = path > PATH_ACTIVE * (1.0 + float(np.max(np.abs(sol.costate))))
    # Node indices where the activity changes (node k + 1 between intervals k and k + 1; the slew's ends when active).
    flags = np.concatenate([[False], active, [False]]).astype(int)
    junctions = np.nonzero(np.diff(flags))[0]
    checked = np.ones(n, dtype=bool)
    for node in junctions:
        checked[max(0, node - JUNCTION_INTERVALS) : node + JUNCTION_INTERVALS] = False
    if not np.any(checked):
        return {
            "passes": None,
            "note": (
                f"not checked: every interval lies within {JUNCTION_INTERVALS} intervals of a junction of a path "
                "constraint (rate limit or keep-out cone)"
            ),
        }
    # Refinement frees the switch times, not the junctions of a path constraint: with one active the grid bound.
    if np.any(active):
        tolerance = HAMILTONIAN_PATH_FACTOR / n
    elif grid_converged:
        tolerance = HAMILTONIAN_TOLERANCE
    else:
        tolerance = HAMILTONIAN_GRID_FACTOR / n
    box = prob.torque_set.envelope if prob.torque_set.is_box else None
    start, end, term = interval_costates(prob, sol)
    out = pontryagin_check(
        prob.body,
        sol.X[:4].T,
        sol.X[4:].T / prob.t_s,
        torque,
        costate_physical(prob, sol.costate),
        box,
        checked=checked,
        hamiltonian_tolerance=tolerance,
        costate_start=costate_physical(prob, np.hstack([start, end[:, -1:]]))[:-1],
        costate_end=costate_physical(prob, np.hstack([start[:, :1], end]))[1:],
        path_active=active,
        path_length_term=term,
        hamiltonian_decides=refined or not np.any(active),
    )
    out["tolerances"] = {
        "hamiltonian": out["hamiltonian_tolerance"],
        "switching_disagreement": SWITCHING_TOLERANCE,
        "switching_zero_fraction": SWITCHING_ZERO_FRACTION,
    }
    return out

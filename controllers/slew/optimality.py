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
  On a polytope ``|R tau|_inf <= 1`` (a wheel set's allocation envelope) the
  torque minimises ``sigma . tau`` over the set: ``sigma . tau`` equals the
  support value, attained at a vertex (:func:`torque_set_vertices`).

The headline residual (``plan.pontryagin_residual``) is
``max(max |H| / its tolerance, switching disagreement / SWITCHING_TOLERANCE)``
over the parts judged: above 1 the plan is flagged
(:func:`pontryagin_conditions`). The wheel-state plans are checked the same
way on their motor torques (:mod:`controllers.slew.wheel_states`).

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
from scipy.spatial import HalfspaceIntersection

from attitude.rigid_body import RigidBody
from controllers.slew.problem import Problem
from controllers.slew.refine import SATURATION_TOLERANCE
from controllers.slew.transcription import IntervalFunction, interval_function

__all__ = [
    "HAMILTONIAN_GRID_FACTOR",
    "HAMILTONIAN_PATH_FACTOR",
    "HAMILTONIAN_TOLERANCE",
    "JUNCTION_INTERVALS",
    "NOT_CHECKED_JUNCTIONS",
    "SWITCHING_TOLERANCE",
    "SWITCHING_ZERO_FRACTION",
    "check_solution",
    "costate_physical",
    "hamiltonian_tolerance_of",
    "interval_costates",
    "intervals_to_check",
    "pontryagin_check",
    "pontryagin_conditions",
    "summary_words",
    "torque_set_vertices",
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
    """The NLP's nondimensional costates (7 [+ n_wheels], n + 1) in physical units (n + 1, 7 [+ n_wheels]).

    ``H = 1 + nu . dx_s/dt_s`` is the same number in both unit systems: with
    ``q_dot_s = T_s q_dot`` and ``omega_dot_s = T_s^2 omega_dot``,
    ``lambda_q = T_s nu_q`` [s] and ``lambda_omega = T_s^2 nu_omega`` [s^2];
    wheel momenta as states (in units of ``J_s / T_s``, :mod:`controllers.slew.wheel_states`):
    ``lambda_h = T_s^2 / J_s nu_h`` [1/(N m)].

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    costate : ndarray
        Nondimensional costates (7, n + 1), or (7 + n_wheels, n + 1) with the wheel
        momenta as states (:class:`controllers.slew.transcription.Solution`).
    """
    extra = costate.shape[0] - 7
    scale = np.array([prob.t_s] * 4 + [prob.t_s**2] * 3 + [prob.t_s**2 / prob.j_s] * extra)
    return (costate * scale[:, None]).T.copy()


def torque_set_vertices(rows: ArrayLike) -> NDArray[np.float64]:
    """The vertices of the torque polytope ``{tau : |rows @ tau|_inf <= 1}`` (scipy's Qhull half-space intersection).

    Parameters
    ----------
    rows : array_like (m, 3)
        Rows ``R`` of the set [1/(N m)]; bounded (``R`` of rank 3).

    Returns
    -------
    ndarray (p, 3)
        The vertices [N m] (a vertex where more than three facets meet may repeat).
    """
    r = np.asarray(rows, dtype=float)
    if r.ndim != 2 or r.shape[1] != 3 or np.linalg.matrix_rank(r) < 3:
        raise ValueError(f"rows must be an (m, 3) array of rank 3 (a bounded torque set), got shape {r.shape}")
    halfspaces = np.hstack([np.vstack([r, -r]), -np.ones((2 * r.shape[0], 1))])
    return np.asarray(HalfspaceIntersection(halfspaces, np.zeros(3)).intersections, dtype=float)


def pontryagin_conditions(
    h_start: ArrayLike,
    h_end: ArrayLike,
    sigma_start: ArrayLike,
    sigma_end: ArrayLike,
    control: ArrayLike,
    *,
    control_box: ArrayLike | None = None,
    control_rows: ArrayLike | None = None,
    checked: ArrayLike | None = None,
    hamiltonian_tolerance: float = HAMILTONIAN_TOLERANCE,
    path_active: ArrayLike | None = None,
    hamiltonian_decides: bool = True,
) -> dict[str, Any]:
    """Judge Pontryagin's conditions from ``H`` and the switching function at both ends of each interval.

    Shared by the rigid-body plans (:func:`pontryagin_check`) and the wheel-state plans
    (:func:`controllers.slew.wheel_states.wheel_pontryagin_check`): the control ``u``
    held over interval ``k`` must minimise ``sigma . u`` over the control set at both
    of its ends (``sigma = (df/du)^T lambda``), and ``H`` must be zero.

    * A box ``|u_i| <= u_max_i``: per (interval, component) pair away from the zeros of
      ``sigma_i`` (one sign at both ends, ``|sigma_i| u_max_i`` at least
      :data:`SWITCHING_ZERO_FRACTION` of its largest value), the pair disagrees when
      ``u_i`` is not ``-u_max_i sign(sigma_i)`` (within the refinement's saturation
      tolerance).
    * A polytope ``|R u|_inf <= 1``: the support value ``s = min over the set of
      sigma . u`` (at a vertex, :func:`torque_set_vertices`) at both ends; an interval
      is decided when one vertex attains both minima (no switch inside it) and
      ``|s|`` is at least :data:`SWITCHING_ZERO_FRACTION` of its largest value; it
      disagrees when the relative gap ``(sigma . u - s) / |s|`` at either end exceeds
      the saturation tolerance. A minimiser that is a whole edge or facet (``sigma``
      normal to it) still has gap zero, so the gap needs no unique vertex.

    ``switching_disagreement`` is the fraction of decided pairs (box) or intervals
    (polytope) that disagree. The headline ``residual`` is
    ``max(hamiltonian_residual / hamiltonian_tolerance, switching_disagreement /
    SWITCHING_TOLERANCE)`` over the parts that are judged: above 1 the plan fails.

    Parameters
    ----------
    h_start, h_end : array_like (n,)
        ``H`` (dimensionless) with each interval's control, just after its start and just before its end.
    sigma_start, sigma_end : array_like (n, m)
        The switching function at the same points (units of 1 / control).
    control : array_like (n, m)
        The control held over each interval.
    control_box : array_like (m,), optional
        Per-component bound of a box control set.
    control_rows : array_like (k, 3), optional
        Rows ``R`` of a polytope control set ``|R u|_inf <= 1`` (three components), when not a box.
        Neither given: the switching function is not checked.
    checked : array_like of bool (n,), optional
        Intervals to check (default all).
    hamiltonian_tolerance : float
        Largest accepted ``max |H|``.
    path_active : array_like of bool (n,), optional
        Intervals where a path constraint is active: ``H`` checked there, the switching function not.
    hamiltonian_decides : bool
        ``max |H|`` above its tolerance fails the plan (default); False reports it only.

    Returns
    -------
    dict
        ``residual`` (the normalised headline above), ``hamiltonian_residual``
        (``max |H|``), ``hamiltonian_mean``, ``hamiltonian_spread``
        (``max |H - mean|``), ``switching_disagreement`` (None when not checked),
        ``switching_decided``, ``switching_gap`` (polytope: largest relative gap on
        the decided intervals), ``intervals_checked``, ``intervals``,
        ``intervals_path_active``, ``hamiltonian_tolerance``, ``passes`` and
        ``note`` (why a part was skipped, or empty).
    """
    h0, h1 = np.asarray(h_start, dtype=float), np.asarray(h_end, dtype=float)
    n = h0.size
    mask = np.ones(n, dtype=bool) if checked is None else np.asarray(checked, dtype=bool)
    active = np.zeros(n, dtype=bool) if path_active is None else np.asarray(path_active, dtype=bool)
    if not np.any(mask):
        raise ValueError("checked must select at least one interval, got none")
    notes = []
    if not np.all(mask):
        notes.append(f"checked on {int(np.sum(mask))} of {n} intervals (not within {JUNCTION_INTERVALS} of a junction)")
    h = np.concatenate([h0[mask], h1[mask]])
    out: dict[str, Any] = {
        "residual": None,
        "hamiltonian_residual": float(np.max(np.abs(h))),
        "hamiltonian_mean": float(np.mean(h)),
        "hamiltonian_spread": float(np.max(np.abs(h - np.mean(h)))),
        "switching_disagreement": None,
        "switching_decided": 0,
        "switching_gap": None,
        "intervals_checked": int(np.sum(mask)),
        "intervals": n,
        "intervals_path_active": int(np.sum(active)),
        "hamiltonian_tolerance": float(hamiltonian_tolerance),
    }
    parts = []
    if hamiltonian_decides:
        parts.append(out["hamiltonian_residual"] / hamiltonian_tolerance)
    else:
        notes.append(
            "H reported, not judged: a uniform grid puts the junctions of the path constraint on its nodes, so H is "
            "constant on each arc but not the same on all"
        )
    if np.any(active):
        notes.append(
            f"a path constraint is active on {int(np.sum(active))} of {n} intervals: the switching function not "
            "checked there"
        )
    free = mask & ~active
    u = np.asarray(control, dtype=float)[:n]
    s0, s1 = np.asarray(sigma_start, dtype=float), np.asarray(sigma_end, dtype=float)
    if control_box is not None:
        box = np.broadcast_to(np.asarray(control_box, dtype=float), (u.shape[1],))
        w0, w1 = np.abs(s0) * box, np.abs(s1) * box
        scale = float(np.max(np.maximum(w0, w1)[free])) if np.any(free) else 0.0
        decided = (np.sign(s0) == np.sign(s1)) & (np.minimum(w0, w1) >= SWITCHING_ZERO_FRACTION * scale)
        decided &= free[:, None]
        wrong = u * np.sign(s1) > -(1.0 - SATURATION_TOLERANCE) * box
    elif control_rows is not None:
        vertices = torque_set_vertices(control_rows)
        values0, values1 = s0 @ vertices.T, s1 @ vertices.T  # (n, p): sigma . v at each vertex
        low0, low1 = np.min(values0, axis=1), np.min(values1, axis=1)
        size = float(np.max(np.abs(vertices)))
        # One vertex minimises at both ends: no switch inside the interval.
        apart = vertices[np.argmin(values0, axis=1)] - vertices[np.argmin(values1, axis=1)]
        same = np.all(np.abs(apart) <= 1e-9 * size, axis=1)
        scale = float(np.max(np.maximum(np.abs(low0), np.abs(low1))[free])) if np.any(free) else 0.0
        decided = free & same & (np.minimum(np.abs(low0), np.abs(low1)) >= SWITCHING_ZERO_FRACTION * scale)
        with np.errstate(divide="ignore", invalid="ignore"):
            gap = np.maximum(
                (np.sum(s0 * u, axis=1) - low0) / np.abs(low0), (np.sum(s1 * u, axis=1) - low1) / np.abs(low1)
            )
        wrong = gap > SATURATION_TOLERANCE
        out["switching_gap"] = float(np.max(gap[decided])) if np.any(decided) else 0.0
    else:
        decided = wrong = None
        notes.append("switching check skipped: no control set given")
    if decided is not None:
        count = int(np.sum(decided))
        out["switching_decided"] = count
        if count:
            out["switching_disagreement"] = float(np.sum(decided & wrong) / count)
            parts.append(out["switching_disagreement"] / SWITCHING_TOLERANCE)
        else:
            notes.append("the switching function is decided on no interval: not judged")
    # Nothing judged (H only reported, no interval decided): neither passed nor flagged.
    out["residual"] = float(max(parts)) if parts else None
    out["passes"] = bool(out["residual"] <= 1.0) if parts else None
    out["note"] = "; ".join(notes)
    return out


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
    torque_rows: ArrayLike | None = None,
) -> dict[str, Any]:
    """Pontryagin's conditions of a minimum-time plan on its nodes (module docstring).

    ``H = 1 + lambda . f(x, tau)`` and ``sigma = I^-1 lambda_omega`` at both ends of
    each interval, judged by :func:`pontryagin_conditions`.

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
        Per-axis torque bound [N m] of a box torque set; None for a polytope
        (``torque_rows``) or to skip the switching check.
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
    torque_rows : array_like (m, 3), optional
        The torque set ``|torque_rows @ tau|_inf <= 1`` [1/(N m)] when it is
        not a box (a wheel set's allocation envelope), with ``torque_box`` None.

    Returns
    -------
    dict
        As :func:`pontryagin_conditions`.
    """
    q = np.asarray(q, dtype=float)
    omega = np.asarray(omega, dtype=float)
    lam = np.asarray(costate, dtype=float)
    n = q.shape[0] - 1
    tau = np.asarray(torque, dtype=float)[:n]
    lam_start = lam[:-1] if costate_start is None else np.asarray(costate_start, dtype=float)
    lam_end = lam[1:] if costate_end is None else np.asarray(costate_end, dtype=float)
    term = np.zeros(n) if path_length_term is None else np.asarray(path_length_term, dtype=float)
    x = np.concatenate([q, omega], axis=1)
    # H at both ends of each interval with the interval's torque and its own costates.
    h_start = 1.0 + np.sum(lam_start * body.state_derivative(x[:-1], tau), axis=1) + term
    h_end = 1.0 + np.sum(lam_end * body.state_derivative(x[1:], tau), axis=1) + term
    return pontryagin_conditions(
        h_start,
        h_end,
        lam_start[:, 4:] @ body.inertia_inv.T,
        lam_end[:, 4:] @ body.inertia_inv.T,
        tau,
        control_box=torque_box,
        control_rows=None if torque_box is not None else torque_rows,
        checked=checked,
        hamiltonian_tolerance=hamiltonian_tolerance,
        path_active=path_active,
        hamiltonian_decides=hamiltonian_decides,
    )


def interval_costates(
    prob: Problem, sol: Any, interval: IntervalFunction | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
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
    interval : IntervalFunction, optional
        The interval of the transcription that produced ``sol``; default
        :func:`controllers.slew.transcription.interval_function` of the rigid
        body (the wheel-state planner passes its own).

    Returns
    -------
    tuple of ndarray
        Costates after the start and before the end of each interval (rows, n)
        each, and the length term (n,).
    """
    nu = sol.costate
    n = sol.U.shape[1]
    start, end, term = nu[:, :-1].copy(), nu[:, 1:].copy(), np.zeros(n)
    mu = sol.path_row_multiplier
    if mu is None or mu.shape[0] == 0:
        return start, end, term
    fun = (interval_function(prob) if interval is None else interval).fun
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
    if check and check.get("passes") is None and check.get("hamiltonian_residual") is not None:
        h = check["hamiltonian_residual"]
        return f"Pontryagin conditions NOT judged (max |H| {h:.2g} reported; why: info['pontryagin']['note'])"
    if not check or check.get("passes") is None:
        return ""
    parts = [f"max |H| {check['hamiltonian_residual']:.2g}"]
    if check.get("switching_disagreement") is not None:
        parts.append(f"switching disagreement {100 * check['switching_disagreement']:.2g} %")
    text = f"Pontryagin residual {check['residual']:.2g} ({', '.join(parts)})"
    if not check["passes"]:
        return f"NOT an extremal ({text}): flagged"
    return f"{text} (passes)"


#: The check's answer when every interval lies next to a junction.
NOT_CHECKED_JUNCTIONS: dict[str, Any] = {
    "passes": None,
    "note": (
        f"not checked: every interval lies within {JUNCTION_INTERVALS} intervals of a junction of a path "
        "constraint (rate limit, keep-out cone or wheel-speed limit)"
    ),
}


def intervals_to_check(sol: Any) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Intervals with a path constraint active, and those checked (not within JUNCTION_INTERVALS of a junction).

    Parameters
    ----------
    sol : Solution
        The answer, with its ``costate`` and ``path_multiplier``.

    Returns
    -------
    tuple of ndarray of bool (n,)
        ``active`` and ``checked``.
    """
    n = sol.U.shape[1]
    path = sol.path_multiplier if sol.path_multiplier is not None else np.zeros(n)
    active = path > PATH_ACTIVE * (1.0 + float(np.max(np.abs(sol.costate))))
    # Node indices where the activity changes (node k + 1 between intervals k and k + 1; the slew's ends when active).
    flags = np.concatenate([[False], active, [False]]).astype(int)
    junctions = np.nonzero(np.diff(flags))[0]
    checked = np.ones(n, dtype=bool)
    for node in junctions:
        checked[max(0, node - JUNCTION_INTERVALS) : node + JUNCTION_INTERVALS] = False
    return active, checked


def hamiltonian_tolerance_of(n: int, path_active: bool, grid_converged: bool) -> float:
    """The largest accepted ``max |H|`` of a plan on ``n`` intervals (the constants' comments say why).

    Parameters
    ----------
    n : int
        Intervals of the plan.
    path_active : bool
        A path constraint is active somewhere: :data:`HAMILTONIAN_PATH_FACTOR` ``/ n``
        (refinement frees the switch times, not the junctions).
    grid_converged : bool
        Switch-time refined and bang-bang: :data:`HAMILTONIAN_TOLERANCE`; otherwise
        :data:`HAMILTONIAN_GRID_FACTOR` ``/ n``.
    """
    if path_active:
        return HAMILTONIAN_PATH_FACTOR / n
    if grid_converged:
        return HAMILTONIAN_TOLERANCE
    return HAMILTONIAN_GRID_FACTOR / n


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
    active, checked = intervals_to_check(sol)
    if not np.any(checked):
        return NOT_CHECKED_JUNCTIONS.copy()
    tolerance = hamiltonian_tolerance_of(sol.U.shape[1], bool(np.any(active)), grid_converged)
    box = prob.torque_set.envelope if prob.torque_set.is_box else None
    rows = None if prob.torque_set.is_box else prob.torque_set.rows
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
        torque_rows=rows,
    )
    out["tolerances"] = {
        "hamiltonian": out["hamiltonian_tolerance"],
        "switching_disagreement": SWITCHING_TOLERANCE,
        "switching_zero_fraction": SWITCHING_ZERO_FRACTION,
    }
    return out

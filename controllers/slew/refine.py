"""Refinement of a minimum-time grid answer: a multi-phase re-solve with free phase durations.

Part of :mod:`controllers.slew.planner` (import the public names from there).

A uniform-grid answer places its switches on the nodes and converges from
above as O(1/N). The refinement reads the arc structure off the grid answer
(per torque-constraint row: saturated high, saturated low, or inside, with
switches located inside transition intervals; and the runs of nodes at the
rate limit, the coasts), cuts the slew into phases at every change, and
re-solves with one free duration per phase. On a coarse grid a short
acceleration to the rate limit need not saturate any torque row over a
whole interval; the coast ends still give it a phase of its own, whose
duration then shrinks to what full torque needs. In each phase
the rows saturated on the grid are held at their bound and the rest of the
torque is free per interval:

* ``"constant"``: three independent rows saturated (a vertex of the torque
  set, a bang arc), one constant torque over the phase;
* ``"partial"``: one or two rows saturated (e.g. full torque about the slew
  axis while the others trim the gyroscopic coupling during the acceleration
  to a rate limit), those rows held at their bound, the rest free per
  interval;
* ``"free"``: no row saturated (a coast at the rate limit, a keep-out
  boundary arc, a singular arc), the torque free per interval.

When every phase is ``"constant"`` (a pure bang-bang answer) the switch
times are continuous variables and the refined time is the grid-converged
one up to the RK4 error (O(h^4)): ``grid_converged`` is True. Otherwise the
phase ends still move freely, but the torque on the unsaturated arcs stays
piecewise constant on a grid of the original density: the refined time is
the best answer on that grid, better than the uniform grid's but not
grid-converged.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from controllers.slew.problem import Problem
from controllers.slew.transcription import Solution, Transcription, ipopt_setup

__all__ = ["MAX_PHASES", "REFINEMENT_SLACK", "drop_empty", "refine_phases"]

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


def _rate_max_edges(prob: Problem, t: NDArray, X: NDArray) -> list[float]:
    """Start and end times of the runs of nodes at the rate limit spanning at least one interval."""
    if prob.rate_max_scaled is None:
        return []
    at_limit = np.linalg.norm(X[4:], axis=0) >= prob.rate_max_scaled * (1.0 - SATURATION_TOLERANCE)
    edges = []
    k = 0
    while k < at_limit.size:
        if not at_limit[k]:
            k += 1
            continue
        j = k
        while j + 1 < at_limit.size and at_limit[j + 1]:
            j += 1
        if j > k:
            edges += [float(t[k]), float(t[j])]
        k = j + 1
    return [e for e in edges if 0.0 < e < t[-1]]


def _label_at(segs: list[tuple[float, float, int]], t: float) -> int:
    """Label of the segment containing ``t`` (0 outside all)."""
    for a, b, lab in segs:
        if a <= t <= b:
            return lab
    return 0


def _phase_torque(prob: Problem, labels: NDArray) -> tuple[str, NDArray | None, NDArray | None]:
    """Mode of a phase from its row labels: ``(mode, particular torque, null-space basis)``.

    The torques with the saturated rows at their bound are ``u_p + N z``
    (``N`` an orthonormal basis of the null space of those rows); an
    inconsistent set of saturated rows (dependent rows of a wheel set)
    leaves the phase free.
    """
    active = labels != 0
    if not np.any(active):
        return "free", None, None
    a = prob.rows_s[active]
    target = labels[active].astype(float)
    u_p = np.linalg.lstsq(a, target, rcond=None)[0]
    if np.max(np.abs(a @ u_p - target)) > 1e-9:
        return "free", None, None
    _, sv, vt = np.linalg.svd(a)
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    if rank == 3:
        return "constant", u_p, None
    return "partial", u_p, vt[rank:].T


def refine_phases(
    prob: Problem, grid: Solution, n_steps: int, max_iter: int, options: Mapping[str, Any]
) -> tuple[Solution | None, dict[str, Any]]:
    """Multi-phase re-solve with free phase durations (module docstring).

    Parameters
    ----------
    prob : Problem
        The validated problem.
    grid : Solution
        The converged uniform-grid answer.
    n_steps : int
        Intervals of the refined problem, spread over the phases in
        proportion to their durations (at least 2 each).
    max_iter : int
        IPOPT iteration limit.
    options : mapping
        Extra IPOPT options.

    Returns
    -------
    (Solution or None, dict)
        The refined answer (None when skipped) and what was done:
        ``phases``, ``modes``, ``steps``, ``grid_converged``, ``kind``,
        ``status``, ``iterations``, ``phase_durations`` [s].
    """
    t = np.concatenate([[0.0], np.cumsum(grid.H)])
    total = t[-1]
    signal = prob.rows_s @ grid.U  # (m, n)
    row_segs = [_row_segments(t, signal[j]) for j in range(signal.shape[0])]
    bounds = {b for segs in row_segs for seg in segs for b in seg[:2]}
    # Ends of arcs at the rate limit (coasts), unless a torque switch lies within about an interval.
    switches = [b for b in bounds if 0.0 < b < total]
    h_max = float(np.max(grid.H))
    for b in _rate_max_edges(prob, t, grid.X):
        if all(abs(b - e) > 1.5 * h_max for e in switches):
            bounds.add(b)
    bounds = sorted(bounds)
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
    phases = []
    for p in range(n_phase):
        mid = 0.5 * (edges[p] + edges[p + 1])
        labels = np.array([_label_at(segs, mid) for segs in row_segs])
        phases.append((labels, *_phase_torque(prob, labels)))
    modes = [ph[1] for ph in phases]
    info["modes"] = modes
    if n_phase == 1:
        info["status"] = (
            "skipped: no torque constraint saturated and no rate-limited arc over a whole interval; nothing to refine"
        )
        return None, info
    info["grid_converged"] = all(m == "constant" for m in modes)
    info["kind"] = (
        "switch times of a bang-bang answer (grid-converged)"
        if info["grid_converged"]
        else "free phase durations with piecewise-constant torque on unsaturated arcs (best grid answer)"
    )
    fractions = np.diff(edges) / total
    steps = [max(2, math.ceil(n_steps * f)) for f in fractions]
    n_int = int(sum(steps))
    info["steps"] = steps

    tr = Transcription(prob, n_int, options)
    opti = tr.opti
    Tp = opti.variable(n_phase)
    opti.subject_to(opti.bounded(0.0, Tp, 10.0 * total))
    u_cols, h_cols, init = [], [], []
    for p, (labels, mode, u_p, null) in enumerate(phases):
        tp = edges[p] + (np.arange(steps[p]) + 0.5) * (edges[p + 1] - edges[p]) / steps[p]
        k = np.clip(np.searchsorted(t, tp, side="right") - 1, 0, grid.U.shape[1] - 1)
        u_grid = grid.U[:, k]
        if mode == "constant":
            v = opti.variable(3)
            u_cols.append(ca.repmat(v, 1, steps[p]))
            init.append((v, u_p))
            tr.torque_set(v)
        elif mode == "partial":
            z = opti.variable(null.shape[1], steps[p])
            u_phase = ca.repmat(ca.DM(u_p), 1, steps[p]) + ca.mtimes(ca.DM(null), z)
            u_cols.append(u_phase)
            init.append((z, null.T @ (u_grid - u_p[:, None])))
            free_rows = prob.rows_s[labels == 0]
            opti.subject_to(opti.bounded(-1.0, ca.vec(ca.mtimes(ca.DM(free_rows), u_phase)), 1.0))
        else:
            v = opti.variable(3, steps[p])
            u_cols.append(v)
            init.append((v, u_grid))
            tr.torque_set(v)
        h_cols.append(ca.repmat(Tp[p] / steps[p], 1, steps[p]))
    U = ca.horzcat(*u_cols)
    H = ca.horzcat(*h_cols)
    opti.minimize(ca.sum1(Tp))
    tr.constrain(U, H)
    ipopt_setup(tr, max_iter)
    t_new = np.concatenate([[0.0], np.cumsum(np.repeat(np.diff(edges) / steps, steps))])
    X0 = _interp_states(t, grid.X, t_new)
    init += [(Tp, np.diff(edges)), (tr.X, X0)]
    status, iters, elapsed, val = tr.solve(init, {"X": tr.X, "U": U, "H": H, "Tp": Tp})
    sol = Solution(
        status=status,
        iterations=iters,
        solve_time=elapsed,
        X=val["X"].reshape(7, n_int + 1),
        U=val["U"].reshape(3, n_int),
        H=val["H"].reshape(n_int),
        objective=float(np.sum(val["Tp"])),
        costate=val["costate"],
        path_multiplier=val["path_multiplier"],
        path_row_multiplier=val["path_row_multiplier"],
    )
    info.update({"status": status, "iterations": iters, "solve_time_s": elapsed})
    info["phase_durations"] = (np.maximum(val["Tp"], 0.0) * prob.t_s).tolist()
    return sol, info


def _interp_states(t: NDArray, X: NDArray, t_new: NDArray) -> NDArray[np.float64]:
    """States (7, n) interpolated linearly to ``t_new``, quaternions renormalised (a guess only)."""
    out = np.stack([np.interp(t_new, t, X[i]) for i in range(7)])
    out[:4] /= np.linalg.norm(out[:4], axis=0, keepdims=True)
    return out


def drop_empty(sol: Solution) -> Solution:
    """Remove intervals of (numerically) zero length so the time grid increases strictly.

    Parameters
    ----------
    sol : Solution
        An IPOPT answer (nondimensional).
    """
    keep = sol.H > 1e-9 * sol.duration
    if np.all(keep):
        return sol
    idx_nodes = np.concatenate([[0], np.nonzero(keep)[0] + 1])
    # node k+1 ends interval k; dropping interval k merges node k+1 into node k
    X = sol.X[:, idx_nodes]
    X[:, -1] = sol.X[:, -1]
    costate = None
    if sol.costate is not None:
        costate = sol.costate[:, idx_nodes]
        costate[:, -1] = sol.costate[:, -1]
    path = None if sol.path_multiplier is None else sol.path_multiplier[keep]
    rows = None if sol.path_row_multiplier is None else sol.path_row_multiplier[:, keep]
    return replace(
        sol, X=X, U=sol.U[:, keep], H=sol.H[keep], costate=costate, path_multiplier=path, path_row_multiplier=rows
    )

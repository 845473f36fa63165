"""Checks around the slew solve: blocked paths, open-loop verification, eigenaxis comparison, failure causes.

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.propagate import propagate
from controllers.slew.guess import base_guess, perturbed
from controllers.slew.keep_out import blocked_boresights
from controllers.slew.plan import states_between
from controllers.slew.problem import INFEASIBLE, InfeasibleSlewError, Problem, SlewPlanningError
from controllers.slew.reference import axis_angle, eigenaxis_slew
from controllers.slew.transcription import Solution, solve_grid

__all__ = [
    "CHECK_SAMPLES",
    "check_not_blocked",
    "check_rate_reaches",
    "eigenaxis_comparison",
    "raise_failure",
    "slower_than_eigenaxis",
    "verify",
]

#: Samples per interval for the keep-out and rate checks of the verification.
CHECK_SAMPLES = 8

#: A minimum-time plan more than this fraction slower than a feasible
#: eigenaxis slew is flagged (below it the difference is the RK4 and IPOPT
#: tolerance of a plan that *is* the eigenaxis slew).
EIGENAXIS_SLACK = 1e-6

#: Samples of the eigenaxis path (rotation angle) for its keep-out check:
#: at most 0.09 deg of boresight travel between samples for a 180 deg slew.
EIGENAXIS_PATH_SAMPLES = 2001


def check_not_blocked(prob: Problem) -> None:
    """Raise :class:`InfeasibleSlewError` when the cones provably block every path (before any solve).

    Parameters
    ----------
    prob : Problem
        The validated problem.
    """
    if not prob.cones:
        return
    blocked = blocked_boresights(prob.cones, prob.q0, prob.qf)
    if not blocked:
        return
    names = "; ".join(f"boresight {np.round(b['boresight_B'], 4).tolist()}: {', '.join(b['names'])}" for b in blocked)
    cause = (
        f"the keep-out cones leave no path: they split the sky of a boresight into pieces, its initial and final "
        f"directions in different ones ({names}); no slew exists, whatever the torque, rate or grid"
    )
    raise InfeasibleSlewError(
        f"slew infeasible: {cause}", status="keep_out_blocked", cause=cause, details={"blocked": blocked}
    )


def check_rate_reaches(prob: Problem, duration: float) -> None:
    """Raise :class:`InfeasibleSlewError` when ``rate_max * duration`` is below the rotation angle (before any solve).

    Any path between two attitudes has length ``integral |omega| dt`` at least
    their rotation angle ``phi`` (the geodesic distance on SO(3) under the
    bi-invariant metric, which the path's length bounds from above), and
    ``|omega| <= rate_max`` throughout, so a slew of ``duration`` needs
    ``rate_max * duration >= phi``, whatever the torque, the boundary rates or
    the grid. Necessary only: a duration that passes may still be too short
    for the torque limit (then the solve fails and
    :func:`raise_failure` names the minimum time).

    Parameters
    ----------
    prob : Problem
        The validated problem.
    duration : float
        The fixed slew duration [s].
    """
    if prob.rate_max is None:
        return
    phi = axis_angle(prob.q0, prob.qf)[1]
    if prob.rate_max * duration >= phi:
        return
    cause = (
        f"rate_max * duration must be at least the rotation angle phi between q0 and qf (any path covers "
        f"integral |omega| dt >= phi): rate_max={prob.rate_max:.6g} rad/s times duration={duration:.6g} s is "
        f"{prob.rate_max * duration:.6g} rad < phi = {phi:.6g} rad ({math.degrees(phi):.6g} deg); raise rate_max to at "
        f"least {phi / duration:.6g} rad/s or duration to at least {phi / prob.rate_max:.6g} s"
    )
    raise InfeasibleSlewError(
        f"slew infeasible: {cause}",
        status="rate_limit_too_low",
        cause=cause,
        details={"phi_rad": phi, "rate_max": prob.rate_max, "duration_s": duration},
    )


def verify(prob: Problem, t: NDArray, torque: NDArray, tolerance: float) -> dict[str, Any]:
    """Open-loop re-simulation of the plan (module docstring); raises if it misses a limit.

    Parameters
    ----------
    prob : Problem
        The validated problem.
    t : ndarray
        Node times of the plan [s], shape (N + 1,).
    torque : ndarray
        Body torque held over each interval [N m], shape (N, 3).
    tolerance : float
        Largest accepted final attitude error [rad] (rate: ``tolerance / T_s`` [rad/s]).
    """
    traj = propagate(prob.body, prob.q0, prob.omega0, t, torque, method="adaptive", rtol=1e-10, atol=1e-12)
    att_err = float(quat.error_angle(prob.qf, quat.normalize(traj.q[-1])))
    rate_err = float(np.linalg.norm(traj.omega[-1] - prob.omegaf))
    frac = np.arange(CHECK_SAMPLES) / CHECK_SAMPLES
    t_fine = np.concatenate([(t[:-1, None] + frac[None, :] * np.diff(t)[:, None]).ravel(), t[-1:]])
    x = states_between(prob.body, t, traj.q, traj.omega, torque, t_fine)
    q_fine = quat.normalize(x[:, :4])
    cones = prob.cones
    sep = np.array([float(np.min(c.separation(q_fine))) for c in cones]) if cones else np.zeros(0)
    check = {
        "final_attitude_error": att_err,
        "final_rate_error": rate_err,
        "separation_min": sep,
        "rate_peak": float(np.max(np.linalg.norm(x[:, 4:], axis=1))),
        "nfev": traj.info.get("nfev"),
    }
    rate_tol = tolerance / prob.t_s
    problems = []
    if att_err > tolerance:
        problems.append(f"final attitude error {att_err:.3g} rad > {tolerance:.3g}")
    if rate_err > rate_tol:
        problems.append(f"final rate error {rate_err:.3g} rad/s > {rate_tol:.3g}")
    if prob.rate_max is not None and check["rate_peak"] > prob.rate_max + rate_tol:
        problems.append(f"largest rate {check['rate_peak']:.6g} rad/s > rate_max {prob.rate_max:.6g}")
    for i, cone in enumerate(cones):
        if sep[i] < cone.half_angle - tolerance:
            problems.append(f"keep_out[{i}] separation {sep[i]:.6g} rad < half angle {cone.half_angle:.6g}")
    if problems:
        raise SlewPlanningError(
            f"the plan failed its open-loop re-simulation: {'; '.join(problems)}; increase substeps or nodes",
            status="verification_failed",
            cause="transcription error of the RK4 grid too large for this slew",
            details=check,
        )
    return check


def eigenaxis_comparison(prob: Problem, torque_max: ArrayLike | ReactionWheels) -> dict[str, Any]:
    """Eigenaxis reference time (rest to rest only) and whether its path enters a keep-out cone.

    Parameters
    ----------
    prob : Problem
        The validated problem.
    torque_max : array_like or ReactionWheels
        Per-axis torque bound [N m] (scalar or 3 values), or a wheel set.
    """
    if np.any(prob.omega0) or np.any(prob.omegaf):
        return {}
    try:
        duration = eigenaxis_slew(
            prob.body, prob.q0, prob.qf, torque_max=torque_max, rate_max=prob.rate_max, n_points=2
        ).duration
    except ValueError:
        return {}
    out: dict[str, Any] = {"duration_s": duration, "enters_keep_out": False, "separation_min_deg": []}
    if prob.cones:
        # The path is q0 ⊗ exp(e theta / 2), theta in [0, angle], whatever the timing along it.
        axis, angle = axis_angle(prob.q0, prob.qf)
        q = quat.multiply(prob.q0, quat.from_axis_angle(axis, np.linspace(0.0, angle, EIGENAXIS_PATH_SAMPLES)))
        seps = [float(np.min(c.separation(q))) for c in prob.cones]
        out["separation_min_deg"] = [math.degrees(s) for s in seps]
        out["enters_keep_out"] = any(s < c.half_angle for s, c in zip(seps, prob.cones))
    return out


def raise_failure(
    prob: Problem,
    objective: str,
    duration: float | None,
    results: list[Solution],
    n: int,
    options: Mapping[str, Any],
    max_iter: int,
    eigenaxis: Mapping[str, Any] | None = None,
) -> None:
    """Explain why no start converged, and raise.

    Parameters
    ----------
    prob : Problem
        The validated problem.
    objective : str
        ``"time"`` or ``"energy"``.
    duration : float or None
        Requested duration [s] of an energy-optimal slew; None for minimum time.
    results : list of Solution
        The answers of every start.
    n : int
        Number of intervals.
    options : mapping
        IPOPT options of the caller.
    max_iter : int
        IPOPT iteration limit.
    eigenaxis : mapping, optional
        The result of :func:`eigenaxis_comparison`: a minimum-time slew whose
        eigenaxis slew meets every limit is feasible, and its failure is said
        to be the transcription's, not the problem's.
    """
    statuses = [r.status for r in results]
    details = {"statuses": statuses, "iterations": [r.iterations for r in results]}
    status = statuses[0]
    infeasible = any(s in INFEASIBLE for s in statuses)
    if objective == "energy" and duration is not None:
        _raise_if_rate_limited(prob, duration, n, statuses, details)
        # Is the duration shorter than the minimum time? Solve the minimum-time problem coarsely to find out.
        g = base_guess(prob, min(n, 40), None)
        Xg, Ug = perturbed(prob, g[0], g[1], 0.2, np.random.default_rng(0))
        best, _ = solve_grid(prob, min(n, 40), "time", None, 0.0, [(Xg, Ug, g[2])], max_iter, options)
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
    cones = ""
    if prob.cones:
        names = ", ".join(c.name or f"keep_out[{i}]" for i, c in enumerate(prob.cones))
        cones = (
            f"the keep-out cones ({names}) may block or nearly block every path between q0 and qf (no blocked "
            f"path was proven before solving, but a corridor narrower than the grid can resolve looks blocked "
            f"to the optimiser): check the cone geometry first"
        )
    if objective == "time" and prob.rate_max is not None:
        _raise_if_rate_unresolved(prob, eigenaxis or {}, n, statuses, details)
    if infeasible:
        cause = cones or "the constraints admit no slew"
        cause += (
            "; or the rate limit and boundary rates are incompatible with the torque limits"
            if prob.rate_max is not None or np.any(prob.omega0) or np.any(prob.omegaf)
            else ""
        )
        raise InfeasibleSlewError(
            f"slew infeasible (IPOPT: {', '.join(sorted(set(statuses)))}): {cause}",
            status=status,
            cause=cause,
            details=details,
        )
    if any(s == "Maximum_Iterations_Exceeded" for s in statuses):
        cause = f"IPOPT reached max_iter={max_iter} without converging"
        cause += f"; {cones}; otherwise" if cones else ";"
        cause += " raise max_iter, add starts or smoothing"
    else:
        cause = "IPOPT stopped without converging"
        cause += f"; {cones}; otherwise" if cones else ";"
        cause += " try more starts, another perturbation or more nodes"
    raise SlewPlanningError(
        f"slew planning failed (IPOPT: {', '.join(sorted(set(statuses)))} on {len(statuses)} start(s)): {cause}",
        status=status,
        cause=cause,
        details=details,
    )


def grid_rate_time(prob: Problem, n: int) -> float | None:
    """The least duration [s] of any slew of the problem on a uniform grid of ``n`` intervals, by its rate limit.

    Any path between the attitudes covers their rotation angle ``phi`` with
    ``integral |omega| dt >= phi``. On the grid the torque is held over each
    interval, so from the boundary rate ``omega0`` the rate changes linearly
    over the first interval (up to gyroscopic terms of order
    ``|J| rate_max^2``): it covers at most ``h (|omega0| + rate_max) / 2``
    there, as much at the end, and ``h rate_max`` in each interval between.
    Hence ``T >= n phi / (rate_max (n - 1) + (|omega0| + |omegaf|) / 2)``,
    above the continuous bound ``phi / rate_max`` by the factor ``n / (n - 1)``
    for a rest-to-rest slew.

    Parameters
    ----------
    prob : Problem
        The validated problem.
    n : int
        Number of intervals.

    Returns
    -------
    float or None
        The bound [s]; None without a rate limit.
    """
    if prob.rate_max is None:
        return None
    phi = axis_angle(prob.q0, prob.qf)[1]
    ends = 0.5 * (np.linalg.norm(prob.omega0) + np.linalg.norm(prob.omegaf))
    return float(n * phi / (prob.rate_max * (n - 1) + ends))


def _raise_if_rate_limited(prob: Problem, duration: float, n: int, statuses: list[str], details: dict) -> None:
    """InfeasibleSlewError when the duration is below the grid's rate-limited time (:func:`grid_rate_time`)."""
    grid_time = grid_rate_time(prob, n)
    if prob.rate_max is None or grid_time is None or duration >= grid_time:
        return
    rate = prob.rate_max
    phi = axis_angle(prob.q0, prob.qf)[1]
    ends = 0.5 * (np.linalg.norm(prob.omega0) + np.linalg.norm(prob.omegaf))
    details["grid_minimum_time_s"] = grid_time
    if duration * rate > phi:
        # The smallest n with n phi <= duration (rate (n - 1) + ends).
        fits = max(n + 1, math.ceil(duration * (rate - ends) / (duration * rate - phi) - 1e-9))
        cause = (
            f"the requested duration {duration:.6g} s is shorter than any slew of {math.degrees(phi):.6g} deg on a "
            f"{n}-interval grid at rate_max={rate:.6g} rad/s: the torque is held over each interval, so the first "
            f"and last intervals cover at most half an interval at the rate limit, and the grid needs at least "
            f"{grid_time:.6g} s (a continuous slew needs at least phi / rate_max = {phi / rate:.6g} s); use "
            f"nodes >= {fits} or duration >= {math.ceil(grid_time)} s"
        )
        details["nodes_that_fit"] = fits
    else:
        cause = (
            f"the requested duration {duration:.6g} s is shorter than any slew of {math.degrees(phi):.6g} deg at "
            f"rate_max={rate:.6g} rad/s: it needs at least {grid_time:.6g} s on a {n}-interval grid and "
            f"phi / rate_max = {phi / rate:.6g} s in continuous time"
        )
    raise InfeasibleSlewError(
        f"slew infeasible (IPOPT: {', '.join(sorted(set(statuses)))}): {cause}",
        status=statuses[0],
        cause=cause,
        details=details,
    )


def _raise_if_rate_unresolved(
    prob: Problem, eigenaxis: Mapping[str, Any], n: int, statuses: list[str], details: dict
) -> None:
    """SlewPlanningError naming rate_max when a feasible rate-limited slew failed (eigenaxis slew feasible).

    At a tight rate limit the accelerations last about ``J_s rate_max /
    tau_max``, a vanishing fraction of the slew ``phi / rate_max``; with the
    time scale stretched to the slew (docs/slew_planning.md, Scaling) the
    torque bound grows as the square of that ratio in the NLP's units, and
    IPOPT can fail on a slew that plainly exists. Said so, with the bounds of
    the minimum time, rather than "infeasible".
    """
    ref = eigenaxis.get("duration_s")
    if ref is None or eigenaxis.get("enters_keep_out"):
        return
    rate = prob.rate_max
    phi = axis_angle(prob.q0, prob.qf)[1]
    accel = prob.j_s * rate / float(np.min(prob.torque_set.envelope))
    cause = (
        f"the slew exists (the eigenaxis slew at rate_max={rate:.6g} rad/s meets every limit in {ref:.6g} s, and no "
        f"slew is faster than phi / rate_max = {phi / rate:.6g} s), but the optimiser found none on {n} intervals: at "
        f"this rate_max the accelerations last about J_s rate_max / tau_max = {accel:.3g} s, {accel / ref:.2g} of the "
        "slew, too short for the transcription to resolve; fly the eigenaxis slew "
        "(controllers.slew.reference.eigenaxis_slew), within "
        f"{100 * (ref * rate / phi - 1):.2g} % of the bound, or raise rate_max"
    )
    details["eigenaxis_duration_s"] = ref
    raise SlewPlanningError(
        f"slew planning failed (IPOPT: {', '.join(sorted(set(statuses)))}): {cause}",
        status="rate_limit_unresolved",
        cause=cause,
        details=details,
    )


def slower_than_eigenaxis(eig: Mapping[str, Any], duration: float, nodes: int, refinement: str) -> str | None:
    """The warning for a minimum-time plan slower than a feasible eigenaxis slew (None if it is not).

    Parameters
    ----------
    eig : mapping
        The result of :func:`eigenaxis_comparison` (``duration_s`` [s], ``enters_keep_out``).
    duration : float
        Duration of the plan [s].
    nodes : int
        Number of intervals of the plan.
    refinement : str
        What the refinement did, in words.
    """
    if eig.get("duration_s") is None or eig.get("enters_keep_out"):
        return None
    excess = duration - eig["duration_s"]
    if excess <= EIGENAXIS_SLACK * eig["duration_s"]:
        return None
    return (
        f"the {nodes}-node plan ({duration:.6g} s) is {excess:.3g} s slower than the eigenaxis slew "
        f"({eig['duration_s']:.6g} s), which meets the same torque, rate and keep-out limits: the grid is "
        f"too coarse for this slew's arcs (refinement: {refinement}); raise nodes"
    )

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

This module is the public entry point; the work is split by job:

* :mod:`controllers.slew.problem`: errors, torque set, validated nondimensional problem;
* :mod:`controllers.slew.keep_out`: :class:`KeepOutCone`, its between-checkpoint bound, the blocked-path check;
* :mod:`controllers.slew.reference`: the eigenaxis reference (:func:`eigenaxis_slew`);
* :mod:`controllers.slew.transcription`: multiple shooting, IPOPT, the uniform-grid solve;
* :mod:`controllers.slew.guess`: initial guesses and perturbations;
* :mod:`controllers.slew.refine`: multi-phase refinement of a minimum-time answer;
* :mod:`controllers.slew.plan`: :class:`SlewPlan`, its resampling and figure;
* :mod:`controllers.slew.checks`: blocked paths, verification, eigenaxis comparison, failure causes.

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
    sub-step boundary (the checkpoints), with a second-order margin that
    keeps the continuous path out of the cone between checkpoints: with
    ``f`` the cosine of the separation, ``|f''| <= M = |omega| |omega x b| +
    |omega_dot x b|`` (``<= |omega|^2 + |omega_dot|``), so ``f`` rises at most
    ``M eta^2 / 8`` above the chord of a sub-step of length ``eta``, and
    checkpoints at ``f <= cos(half_angle) - M eta^2 / 8`` keep the sub-step
    outside the cone (to a third-order remainder; derivation in
    :mod:`controllers.slew.keep_out`). The fixed start and final nodes get no
    margin (they are checked at input validation): their sub-step uses the
    Taylor bound from the fixed end, so a start close to a cone is fine when
    the initial rate carries the boresight away. ``keep_out_margin=False``
    drops the margin (checkpoints only; the path may cut a cone's corner).
    Before any optimisation, a cheap check on a sphere grid proves when the
    cones of one boresight leave no path between its initial and final
    directions (:class:`InfeasibleSlewError`, status ``"keep_out_blocked"``).

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
    A uniform grid places the switches on the nodes and converges from
    above as O(1/N). The refinement (:mod:`controllers.slew.refine`) reads
    the arc structure off the grid answer and re-solves with free phase
    durations: saturated torque rows held at their bound, the rest free per
    interval. For a pure bang-bang answer (every phase a vertex of the torque
    set) the refined time is grid-converged up to the RK4 error (O(h^4));
    with rate-limited coasts, partly saturated or keep-out boundary arcs it
    is the best answer on the refined grid (``info["refinement"]["kind"]``).
    The plan reports both ``grid_duration`` and ``refined_duration``.

Comparison with the eigenaxis slew
    For rest-to-rest slews the plan carries the eigenaxis reference time
    (:func:`eigenaxis_slew`, same torque set and rate limit) and whether
    that slew enters a keep-out cone. If the eigenaxis slew meets every
    constraint and the returned plan is slower, the plan says so in
    ``info["warnings"]`` and a :class:`RuntimeWarning` (the grid is too
    coarse for the structure of this slew: raise ``nodes``).

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

import time
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from attitude.actuators import ReactionWheels
from attitude.rigid_body import RigidBody
from attitude.rng import as_generator
from attitude.validation import check_positive
from controllers.slew.checks import (
    check_not_blocked,
    eigenaxis_comparison,
    raise_failure,
    slower_than_eigenaxis,
    verify,
)
from controllers.slew.guess import base_guess, guess_from_plan, perturbed, project
from controllers.slew.keep_out import KeepOutCone
from controllers.slew.plan import SlewPlan, cone_arrays
from controllers.slew.problem import (
    OBJECTIVES,
    InfeasibleSlewError,
    SlewPlanningError,
    check_count,
    momentum_rate_limit,
    validate,
)
from controllers.slew.reference import PUBLISHED_BILIMORIA_WIE, EigenaxisSlew, axis_angle, eigenaxis_slew
from controllers.slew.refine import REFINEMENT_SLACK, drop_empty, refine_phases
from controllers.slew.transcription import IPOPT_DEFAULTS, solve_grid

__all__ = [
    "IPOPT_DEFAULTS",
    "PUBLISHED_BILIMORIA_WIE",
    "EigenaxisSlew",
    "InfeasibleSlewError",
    "KeepOutCone",
    "SlewPlan",
    "SlewPlanningError",
    "eigenaxis_slew",
    "momentum_rate_limit",
    "plan_slew",
]


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
    keep_out_margin: bool = True,
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
        Boresight exclusion cones, enforced between checkpoints too.
    nodes : int
        Intervals of the uniform grid (>= 4).
    substeps : int
        RK4 steps per interval (2-4 keeps the RK4 error far below the grid
        error).
    refine : bool, optional
        Re-solve with free phase durations (default: True for "time", not
        available for "energy").
    refine_steps : int, optional
        Intervals of the refined problem (>= 4), spread over the phases in
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
        Largest accepted final attitude error and keep-out intrusion [rad] of
        the open-loop re-simulation; the final rate error and rate-limit
        excess are accepted up to ``verify_tolerance / T_s`` [rad/s].
    keep_out_margin : bool
        Keep the path out of the cones between checkpoints (module
        docstring). False constrains the checkpoints only: cheaper to state,
        but the path may cut a cone's corner by up to about
        ``(|omega|^2 + |omega_dot|) eta^2 / (8 sin(half_angle))`` rad, which
        the verification then rejects unless ``verify_tolerance`` allows it;
        for studies of what the margin costs.

    Returns
    -------
    SlewPlan
        Verified plan (module docstring).

    Raises
    ------
    ValueError
        Bad input: non-unit or non-finite quaternions, non-positive limits,
        boundary rates above ``rate_max``, a keep-out cone containing the
        initial or final boresight, inconsistent objective/duration,
        non-integer counts.
    InfeasibleSlewError
        The problem is infeasible, e.g. a ``duration`` shorter than the
        minimum time for these limits, or keep-out cones that separate a
        boresight's initial and final directions (also a ValueError).
    SlewPlanningError
        IPOPT failed on every start, or the re-simulation missed the target.

    Warns
    -----
    RuntimeWarning
        The refinement was rejected, or a minimum-time plan is slower than
        the eigenaxis slew although that slew meets every constraint (both
        also listed in ``plan.info["warnings"]``).

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
    prob = validate(body, q0, qf, omega0, omegaf, torque_max, rate_max, keep_out, substeps, keep_out_margin)
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
    n = check_count(nodes, "nodes", 4)
    starts = check_count(starts, "starts", 1)
    max_iter = check_count(max_iter, "max_iter", 1)
    refine_steps = n if refine_steps is None else check_count(refine_steps, "refine_steps", 4)
    smoothing = float(check_positive(smoothing, "smoothing", allow_zero=True))
    perturbation = float(check_positive(perturbation, "perturbation", allow_zero=True))
    verify_tolerance = float(check_positive(verify_tolerance, "verify_tolerance"))
    if initial_guess is not None and not isinstance(initial_guess, SlewPlan):
        raise ValueError(f"initial_guess must be a SlewPlan, got {type(initial_guess).__name__}")
    if objective == "time" and np.allclose(prob.omega0, prob.omegaf) and axis_angle(prob.q0, prob.qf)[1] == 0:
        raise ValueError("q0 equals qf and omega0 equals omegaf: the minimum-time slew is empty")
    check_not_blocked(prob)
    gen = as_generator(rng)
    options = dict(ipopt_options or {})
    duration_s = None if duration is None else duration / prob.t_s
    notes: list[str] = []

    base_X, base_U, base_T = base_guess(prob, n, duration_s)
    guesses = []
    for i in range(starts):
        if i == 0 and initial_guess is not None:
            X0, U0, T0 = guess_from_plan(prob, initial_guess, n)
            guesses.append((X0, project(prob, U0), T0 if duration_s is None else duration_s))
            continue
        # Later starts perturb more: they are there to explore other local optima.
        X0, U0 = perturbed(prob, base_X, base_U, perturbation * (1.0 + 0.5 * i), gen)
        guesses.append((X0, U0, base_T))

    best, results = solve_grid(prob, n, objective, duration_s, smoothing, guesses, max_iter, options)
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
        raise_failure(prob, objective, duration, results, n, options, max_iter)

    grid_duration = best.duration * prob.t_s
    chosen = best
    refined_duration = None
    switch_times = np.zeros(0)
    refine_info: dict[str, Any] = {"requested": bool(refine)}
    if refine:
        sol, rinfo = refine_phases(prob, best, refine_steps, max_iter, options)
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
                chosen = drop_empty(sol)
                refined_duration = sol.duration * prob.t_s
                # Boundaries between phases of non-zero length (empty phases collapse onto a neighbour).
                d = np.asarray(rinfo["phase_durations"])
                tol = 1e-9 * refined_duration
                after = np.cumsum(d[::-1])[::-1]
                keep = (d > tol) & (after - d > tol)
                switch_times = np.cumsum(d)[keep]
        if refined_duration is None and not str(refine_info.get("status", "")).startswith("skipped"):
            notes.append(
                f"slew refinement not used ({refine_info.get('status')}); returning the {n}-node grid solution"
            )

    t = np.concatenate([[0.0], np.cumsum(chosen.H)]) * prob.t_s
    torque = chosen.U.T * prob.tau_s
    ratio = prob.torque_set.ratio(torque)
    torque = torque / np.maximum(ratio, 1.0)[:, None]
    torque = np.vstack([torque, torque[-1:]])
    check = verify(prob, t, torque, verify_tolerance)
    h = np.diff(t)
    energy = float(np.sum(np.sum(torque[:-1] ** 2, axis=1) * h))
    duration_out = float(t[-1])
    eig = eigenaxis_comparison(prob, torque_max)
    if objective == "time":
        note = slower_than_eigenaxis(eig, duration_out, n, str(refine_info.get("status", "not requested")))
        if note:
            notes.append(note)
    for note in notes:
        warnings.warn(note, RuntimeWarning, stacklevel=2)
    bore, direc, half = cone_arrays(prob.cones)
    info = {
        "scaling": {"inertia_kg_m2": prob.j_s, "torque_n_m": prob.tau_s, "time_s": prob.t_s},
        "nodes": n,
        "substeps": prob.substeps,
        "smoothing": smoothing,
        "perturbation": perturbation,
        "keep_out_margin": prob.keep_out_margin,
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
        "eigenaxis_enters_keep_out": eig.get("enters_keep_out"),
        "eigenaxis_min_separation_deg": eig.get("min_separation_deg"),
        "warnings": notes,
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
        eigenaxis_duration=eig.get("duration_s"),
        info=info,
    )

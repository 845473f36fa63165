"""Optimal slew planning: minimum-time and minimum-energy reorientations (casadi + IPOPT).

:func:`plan_slew` solves a minimum-time or minimum-energy reorientation by
direct multiple shooting on the one definition of the rigid-body equations
of motion, subject to boundary states, a torque set (per-axis box or the
envelope of a reaction-wheel set), a body-rate limit and keep-out cones; or
on the wheels themselves, their momenta as states (``wheel_states=True``).

This module is the public entry point; the work is split by job:

* :mod:`controllers.slew.problem`: errors, torque set, validated nondimensional problem;
* :mod:`controllers.slew.keep_out`: :class:`KeepOutCone`, its between-checkpoint bound, the blocked-path check;
* :mod:`controllers.slew.reference`: the eigenaxis reference (:func:`eigenaxis_slew`);
* :mod:`controllers.slew.transcription`: multiple shooting, IPOPT, the uniform-grid solve;
* :mod:`controllers.slew.guess`: initial guesses, perturbations and the start families;
* :mod:`controllers.slew.multistart`: the starts solved (in worker processes when asked) and reported;
* :mod:`controllers.slew.optimality`: Pontryagin's conditions checked from the NLP's multipliers;
* :mod:`controllers.slew.refine`: multi-phase refinement of a minimum-time answer;
* :mod:`controllers.slew.wheel_states`: the plan on the wheels (``wheel_states=True``);
* :mod:`controllers.slew.plan`: :class:`SlewPlan`, its resampling and figure;
* :mod:`controllers.slew.checks`: blocked paths, verification, eigenaxis comparison, failure causes.

See docs/slew_planning.md for the formulation (transcription, final
attitude, scaling, keep-out margins, rate limit, guesses, refinement,
smoothing, verification, reaction wheels, the wheel polytope and momentum).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping, Sequence
from contextlib import ExitStack
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from attitude.actuators import ReactionWheels
from attitude.progress import progress_bar
from attitude.rigid_body import RigidBody
from attitude.rng import as_generator
from attitude.validation import check_positive
from controllers.slew.checks import (
    check_not_blocked,
    check_rate_reaches,
    eigenaxis_comparison,
    raise_failure,
    slower_than_eigenaxis,
    verify,
)
from controllers.slew.guess import (
    base_guess,
    eigenaxis_start,
    expand_starts,
    family_guess,
    guess_from_plan,
    perturbed,
    project,
)
from controllers.slew.keep_out import KeepOutCone
from controllers.slew.multistart import energy_start, solve_starts, start_report, worker_count
from controllers.slew.optimality import check_solution, costate_physical
from controllers.slew.plan import SlewPlan, cone_arrays
from controllers.slew.problem import (
    OBJECTIVES,
    Problem,
    SlewPlanningError,
    check_count,
    validate,
)
from controllers.slew.reference import axis_angle, eigenaxis_profile
from controllers.slew.refine import REFINEMENT_SLACK, drop_empty, refine_phases
from controllers.slew.transcription import check_ipopt_options, sigint_guard, solve_grid
from controllers.slew.wheel_states import check_wheel_state_options, plan_with_wheel_states

__all__ = [
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
    starts: int | str | Sequence[str] = 1,
    workers: int | None = 1,
    perturbation: float = 0.2,
    rng: object = 0,
    initial_guess: SlewPlan | None = None,
    max_iter: int = 1000,
    ipopt_options: Mapping[str, Any] | None = None,
    verify_tolerance: float = 1e-4,
    keep_out_margin: bool = True,
    progress: bool | None = False,
    wheel_states: bool = False,
    h_wheels0: ArrayLike | None = None,
) -> SlewPlan:
    """Plan a minimum-time or minimum-energy slew (docs/slew_planning.md for the method).

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
        Weight of the torque-increment penalty (docs/slew_planning.md), >= 0.
    starts : int, str or sequence of str
        The starts (docs/slew_planning.md, Multi-start): a count ``k`` (the
        perturbed eigenaxis slew and ``k - 1`` random perturbations of it), or
        family names from :data:`controllers.slew.guess.START_FAMILIES`
        (``"eigenaxis"``, ``"eigenaxis_long"``, ``"energy"``, ``"principal"``
        (three starts), ``"random"`` (repeat for more));
        :data:`controllers.slew.guess.MULTI_START` is all of them. The best
        converged answer is kept (plus the eigenaxis slew as a fallback
        start); ``info["starts"]`` and ``info["multi_start"]`` report each
        start and how many reached the best. A larger start set repeats every
        start of a smaller one, so it never reports a worse optimum.
    workers : int or None
        Worker processes for the starts (forked; each builds its own NLP):
        1 (default) solves them here, None uses up to
        :data:`controllers.slew.multistart.MAX_WORKERS` cores. The answers do
        not depend on it.
    perturbation : float
        Size of the guess perturbation: torque noise as a fraction of the
        largest torque (of the torque unit ``J_s / T_s^2`` for a slew longer
        than ten torque times, docs/slew_planning.md), and an attitude bump of
        ``perturbation * pi / 4`` rad. Zero starts exactly on the eigenaxis guess.
    rng : numpy.random.Generator, int or None
        Source of the perturbations (default seed 0: reproducible plans).
    initial_guess : SlewPlan, optional
        Warm start (e.g. a previous plan of the same slew on another grid),
        solved as one more start (``"warm"``) before the others: a plan on
        more nodes warm-started from a coarser plan keeps its optimum.
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
    progress : bool or None
        A progress bar on stderr over the starts, with more than one start
        (:func:`attitude.progress.progress_bar`; erased when the plan is
        done): None draws it when stderr is a terminal, True always,
        False (default) never.
    wheel_states : bool
        With ``torque_max`` a ReactionWheels: plan the motor torques within
        the wheels' torque polytope, with the wheel momenta as states, their
        gyroscopic coupling and the wheel-speed limit ``momentum_max``
        (:mod:`controllers.slew.wheel_states`; docs/slew_planning.md,
        Reaction-wheel polytope and wheel momentum). Keep-out cones,
        refinement, warm starts, smoothing and worker processes are refused;
        ``body`` is the whole spacecraft, wheels included. Default False:
        the allocation envelope bounds the body torque, no wheel momentum.
    h_wheels0 : array_like (n_wheels,), optional
        Initial absolute wheel momenta [N m s] with ``wheel_states`` (default
        zero, as :func:`attitude.simulation.simulate`'s ``h_wheels0``).

    Returns
    -------
    SlewPlan
        Verified plan (docs/slew_planning.md).

    Raises
    ------
    ValueError
        Bad input: non-unit or non-finite quaternions, non-positive limits,
        boundary rates above ``rate_max``, a keep-out cone containing the
        initial or final boresight, inconsistent objective/duration,
        non-integer counts.
    InfeasibleSlewError
        The problem is infeasible, e.g. a ``duration`` shorter than the
        minimum time for these limits, ``rate_max * duration`` below the
        rotation angle (refused before any solve), keep-out cones that
        separate a boresight's initial and final directions, or (wheel
        states) a final state whose conserved angular momentum the wheels
        cannot hold within ``momentum_max`` (also a ValueError).
    SlewPlanningError
        IPOPT failed on every start (and on the eigenaxis fallback start), or
        the re-simulation missed the target.
    KeyboardInterrupt
        Ctrl-C during the planning, a solve or the building of a problem
        (docs/slew_planning.md, Interrupts): the planning stops; no plan of
        the starts solved so far is returned.

    Warns
    -----
    RuntimeWarning
        The refinement was rejected, or a minimum-time plan is slower than
        the eigenaxis slew although that slew meets every constraint, or than
        its warm start, or fails Pontryagin's conditions (all also listed in
        ``plan.info["warnings"]``).

    Examples
    --------
    The benchmark of Bilimoria and Wie (1993), 180 degrees about body x:

    >>> from attitude import RigidBody, quaternion as quat
    >>> plan = plan_slew(RigidBody([1.0, 1.0, 1.0]), [1.0, 0.0, 0.0, 0.0],
    ...                  quat.from_axis_angle([1.0, 0.0, 0.0], np.pi), torque_max=1.0)
    >>> round(plan.refined_duration, 4), round(plan.eigenaxis_duration, 4)
    (3.2431, 3.5449)
    """
    with sigint_guard("slew planning interrupted (Ctrl-C)"), ExitStack() as cleanup:
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
        if not isinstance(wheel_states, (bool, np.bool_)):
            raise ValueError(f"wheel_states must be True or False, got {wheel_states!r}")
        if wheel_states:
            check_wheel_state_options(torque_max, keep_out, refine, initial_guess, smoothing, workers)
            refine = False
        elif h_wheels0 is not None:
            raise ValueError("h_wheels0 is only used with wheel_states=True (the wheel momenta as states)")
        if refine is None:
            refine = objective == "time"
        if refine and objective != "time":
            raise ValueError("refine is only available for objective='time' (switch-time refinement of bang-bang arcs)")
        n = check_count(nodes, "nodes", 4)
        specs = expand_starts(starts)
        worker_count(workers, 1)  # the argument checked before any solve
        max_iter = check_count(max_iter, "max_iter", 1)
        refine_steps = n if refine_steps is None else check_count(refine_steps, "refine_steps", 4)
        smoothing = float(check_positive(smoothing, "smoothing", allow_zero=True))
        perturbation = float(check_positive(perturbation, "perturbation", allow_zero=True))
        verify_tolerance = float(check_positive(verify_tolerance, "verify_tolerance"))
        if progress is not None and not isinstance(progress, bool):
            raise ValueError(f"progress must be True, False or None (a bar on a terminal only), got {progress!r}")
        if initial_guess is not None and not isinstance(initial_guess, SlewPlan):
            raise ValueError(f"initial_guess must be a SlewPlan, got {type(initial_guess).__name__}")
        if objective == "time" and np.allclose(prob.omega0, prob.omegaf) and axis_angle(prob.q0, prob.qf)[1] == 0:
            raise ValueError("q0 equals qf and omega0 equals omegaf: the minimum-time slew is empty")
        check_not_blocked(prob)
        if duration is not None:
            check_rate_reaches(prob, duration)
        gen = as_generator(rng)
        options = check_ipopt_options(ipopt_options)
        prob = prob.scaled_to(duration if duration is not None else _eigenaxis_time(prob))
        duration_s = None if duration is None else duration / prob.t_s
        if wheel_states:
            return plan_with_wheel_states(
                prob,
                torque_max,
                h_wheels0,
                objective,
                duration_s,
                n,
                specs,
                perturbation,
                gen,
                max_iter,
                options,
                verify_tolerance,
                wall_start,
            )
        notes: list[str] = []

        base_X, base_U, base_T = base_guess(prob, n, duration_s)
        # The eigenaxis start draws from the caller's generator first (the planner's single start); every other
        # start from one seed drawn after it, with its family and index: a start does not depend on the others.
        first = perturbed(prob, base_X, base_U, perturbation, gen)
        seed = int(gen.integers(2**63))
        guesses, used, extra = [], [], []
        if initial_guess is not None:
            X0, U0, T0 = guess_from_plan(prob, initial_guess, n)
            guesses.append((X0, project(prob, U0), T0 if duration_s is None else duration_s))
            used.append(("warm", 0))
            extra.append({})
        energy, energy_status = None, None
        if objective == "time" and any(f == "energy" for f, _ in specs):
            energy, energy_status = energy_start(prob, n, base_T, max_iter, options)
        for spec in specs:
            if spec[0] == "eigenaxis":
                guesses.append((*first, base_T))
            else:
                guesses.append(family_guess(prob, n, spec, perturbation, seed, duration_s, energy))
            used.append(spec)
            extra.append({"energy_presolve": energy_status} if spec[0] == "energy" and energy_status else {})

        count = len(guesses)
        bar = cleanup.enter_context(
            progress_bar(
                count, desc="slew planning", unit="start", enabled=progress if count > 1 else False, leave=False
            )
        )
        n_workers = worker_count(workers, count)
        results, how = solve_starts(
            prob, n, objective, duration_s, smoothing, guesses, max_iter, options, n_workers, solved=bar.update
        )
        good = [r for r in results if r.converged]
        best = min(good, key=lambda r: r.objective) if good else None
        eig = eigenaxis_comparison(prob, torque_max)
        # The eigenaxis slew itself as one more start (docs/slew_planning.md, Guess and multi-start): when no start
        # converged, or when the best minimum-time answer is slower than an eigenaxis slew that meets every limit by
        # more than the grid error.
        fallback = None
        if best is None or (objective == "time" and _wrong_optimum(eig, best.duration * prob.t_s, n)):
            fallback = eigenaxis_start(prob, n, duration_s)
            if fallback is not None:
                bar.total += 1
                alt, more = solve_grid(
                    prob, n, objective, duration_s, smoothing, [fallback], max_iter, options, solved=bar.update
                )
                results += more
                used.append(("eigenaxis_fallback", 0))
                extra.append({})
                if alt is not None and (best is None or alt.objective < best.objective):
                    best = alt
        starts_info, multi = start_report(results, used, prob.t_s, extra)
        multi["solved"] = how
        solve_time = sum(r.solve_time for r in results)
        if best is None:
            raise_failure(prob, objective, duration, results, n, options, max_iter, eig)

        grid_duration = best.duration * prob.t_s
        chosen = best
        refined_duration = None
        switch_times = np.zeros(0)
        refine_info: dict[str, Any] = {"requested": bool(refine)}
        if refine:
            bar.set_postfix_str("refining the switch times")
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
        t, torque, ratio = _trajectory(prob, chosen)
        try:
            check = verify(prob, t, torque, verify_tolerance)
        except SlewPlanningError as exc:
            if chosen is best:
                raise
            # The refined answer misses the target on re-simulation (a phase far shorter than the slew, e.g. the
            # accelerations of a slew at a tight rate limit, at an acceptable-level IPOPT answer): keep the grid one.
            refine_info["status"] = f"rejected: {exc}"
            chosen, refined_duration, switch_times = best, None, np.zeros(0)
            t, torque, ratio = _trajectory(prob, chosen)
            check = verify(prob, t, torque, verify_tolerance)
        if refine and refined_duration is None and not str(refine_info.get("status", "")).startswith("skipped"):
            status = refine_info.get("status")
            notes.append(f"slew refinement not used ({status}); returning the {n}-node grid solution")
        grid_converged = refined_duration is not None and bool(refine_info.get("grid_converged"))
        pontryagin = check_solution(prob, chosen, torque, objective, grid_converged, refined_duration is not None)
        if pontryagin.get("passes") is False:
            notes.append(
                f"the plan fails Pontryagin's necessary conditions (residual {pontryagin['residual']:.3g} > 1: max |H| "
                f"{pontryagin['hamiltonian_residual']:.3g}, switching disagreement "
                f"{pontryagin['switching_disagreement']}): not a time-optimal extremal "
                "(docs/slew_planning.md, Optimality evidence)"
            )
        h = np.diff(t)
        energy = float(np.sum(np.sum(torque[:-1] ** 2, axis=1) * h))
        duration_out = float(t[-1])
        if objective == "time":
            note = slower_than_eigenaxis(eig, duration_out, n, str(refine_info.get("status", "not requested")))
            if note:
                notes.append(note)
            # Compared when both are switch-time refined (grid-converged up to the RK4 error): a uniform-grid answer
            # is longer than the converged time by its grid error.
            if (
                initial_guess is not None
                and refined_duration is not None
                and initial_guess.refined_duration is not None
                and duration_out > initial_guess.duration * (1.0 + REFINEMENT_SLACK)
            ):
                notes.append(
                    f"the plan ({duration_out:.6g} s) is slower than its warm start ({initial_guess.duration:.6g} s): "
                    "the warm start is a plan of another slew, or this grid cannot fly its path"
                )
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
            "multi_start": multi,
            "best_start": int(results.index(best)),
            "pontryagin": pontryagin,
            "eigenaxis_fallback": fallback is not None,
            "grid_status": best.status,
            "grid_iterations": best.iterations,
            "refinement": refine_info,
            "energy_n2m2s": energy,
            "torque_clip_ratio": float(np.max(ratio)),
            "verification": {k: v for k, v in check.items() if k != "separation_min"},
            "eigenaxis_enters_keep_out": eig.get("enters_keep_out"),
            "eigenaxis_separation_min_deg": eig.get("separation_min_deg"),
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
            separation_min=check["separation_min"],
            rate_peak=check["rate_peak"],
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
            costate=None if chosen.costate is None else costate_physical(prob, chosen.costate),
            pontryagin_residual=pontryagin.get("residual"),
            optimality_flagged=pontryagin.get("passes") is False,
        )


def _eigenaxis_time(prob: Problem) -> float | None:
    """Duration [s] of the eigenaxis slew between the problem's attitudes under its limits (None if impossible)."""
    axis, angle = axis_angle(prob.q0, prob.qf)
    try:
        prof = eigenaxis_profile(
            prob.body.inertia, prob.torque_set.rows, axis, angle, prob.rate_max, 2, timing_only=True
        )
    except ValueError:
        return None
    return float(prof["duration"])


#: A uniform grid answer converges from above: its time exceeds the
#: grid-converged one by at most a few intervals, ``T / nodes`` each (the
#: switches fall on nodes). A minimum-time grid answer slower than a feasible
#: eigenaxis slew by more than GRID_EXCESS_INTERVALS intervals is another
#: local optimum (e.g. the long way round), not grid error.
GRID_EXCESS_INTERVALS = 2.0


def _wrong_optimum(eig: Mapping[str, Any], duration: float, nodes: int) -> bool:
    """The grid time [s] exceeds a feasible eigenaxis slew's by more than the grid error (GRID_EXCESS_INTERVALS)."""
    ref = eig.get("duration_s")
    if ref is None or eig.get("enters_keep_out"):
        return False
    return duration > ref * (1.0 + GRID_EXCESS_INTERVALS / nodes)


def _trajectory(prob: Problem, sol: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node times [s], torques [N m] (held per interval, last repeated) and torque-set ratios of an answer."""
    t = np.concatenate([[0.0], np.cumsum(sol.H)]) * prob.t_s
    torque = sol.U.T * prob.tau_s
    ratio = prob.torque_set.ratio(torque)
    torque = torque / np.maximum(ratio, 1.0)[:, None]
    return t, np.vstack([torque, torque[-1:]]), ratio

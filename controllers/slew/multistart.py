"""Multi-start of the uniform-grid solve: the start families solved (in worker processes when asked) and reported.

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

import numpy as np
from numpy.typing import NDArray

from controllers.slew.guess import ENERGY_START_STRETCH, StartSpec, base_guess
from controllers.slew.problem import Problem
from controllers.slew.transcription import Solution, solve_grid

__all__ = ["MATCH_TOLERANCE", "MAX_WORKERS", "solve_starts", "start_report", "worker_count"]

#: Two starts reach the same optimum when their grid objectives agree to this
#: relative tolerance: IPOPT at tol 1e-9 puts two solves of one local optimum
#: within ~1e-8 of each other; distinct local optima of the benchmark slews
#: differ by 1e-3 and more.
MATCH_TOLERANCE = 1e-6

#: Most worker processes of a multi-start (``workers=None``): docs/slew_planning.md, Multi-start.
MAX_WORKERS = 2

Guess = tuple[NDArray, NDArray, float]


def worker_count(workers: Any, starts: int) -> int:
    """The worker processes of a multi-start: ``workers`` checked, at most one per start and per core.

    Parameters
    ----------
    workers : int or None
        Requested worker processes (>= 1); None for ``min(cores, MAX_WORKERS)``.
    starts : int
        Number of minimum-time solves.

    Raises
    ------
    ValueError
        Naming ``workers``: not None nor an integer >= 1.
    """
    cores = os.cpu_count() or 1
    if workers is None:
        workers = min(cores, MAX_WORKERS)
    elif isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1 or None (up to {MAX_WORKERS} cores), got {workers!r}")
    return int(max(1, min(workers, starts, cores)))


def energy_start(
    prob: Problem, n: int, eigenaxis_duration_s: float, max_iter: int, options: Mapping[str, Any]
) -> tuple[tuple[NDArray, NDArray] | None, str]:
    """The minimum-energy answer over ``ENERGY_START_STRETCH`` eigenaxis times (the ``"energy"`` start) and its status.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    n : int
        Number of intervals.
    eigenaxis_duration_s : float
        The eigenaxis time in units of ``T_s``.
    max_iter : int
        IPOPT iteration limit.
    options : mapping
        IPOPT options of the caller.
    """
    duration = eigenaxis_duration_s * ENERGY_START_STRETCH
    best, results = solve_grid(prob, n, "energy", duration, 0.0, [base_guess(prob, n, duration)], max_iter, options)
    if best is None:
        return None, results[0].status
    return (best.X, best.U), best.status


def _solve_chunk(
    prob: Problem,
    n: int,
    objective: str,
    duration_s: float | None,
    smoothing: float,
    guesses: list[Guess],
    max_iter: int,
    options: Mapping[str, Any],
) -> list[Solution]:
    """One worker's share of the starts, on its own NLP."""
    return solve_grid(prob, n, objective, duration_s, smoothing, guesses, max_iter, options)[1]


def solve_starts(
    prob: Problem,
    n: int,
    objective: str,
    duration_s: float | None,
    smoothing: float,
    guesses: list[Guess],
    max_iter: int,
    options: Mapping[str, Any],
    workers: int,
    solved: Callable[[], None] | None = None,
) -> tuple[list[Solution], str]:
    """Solve the grid problem from every guess, in ``workers`` processes; the answers in order and how they ran.

    With more than one worker the guesses are dealt round-robin to forked
    processes, each building its own NLP (casadi's objects stay in the
    process that made them; the answers come back as arrays). Any failure of
    the pool (no ``fork`` on this platform, a worker lost) falls back to
    solving in this process, saying so.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    n : int
        Number of intervals.
    objective : str
        ``"time"`` or ``"energy"``.
    duration_s : float or None
        Fixed duration in units of ``T_s``; None for minimum time.
    smoothing : float
        Weight of the torque-increment penalty.
    guesses : list of (X0, U0, T0)
        The starts.
    max_iter : int
        IPOPT iteration limit.
    options : mapping
        IPOPT options of the caller.
    workers : int
        Worker processes (:func:`worker_count`); 1 solves here.
    solved : callable, optional
        Called after each solve (a progress bar).
    """
    if workers > 1 and "fork" in multiprocessing.get_all_start_methods():
        chunks = [list(range(w, len(guesses), workers)) for w in range(workers)]
        try:
            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
                futures = [
                    pool.submit(
                        _solve_chunk,
                        prob,
                        n,
                        objective,
                        duration_s,
                        smoothing,
                        [guesses[i] for i in chunk],
                        max_iter,
                        options,
                    )
                    for chunk in chunks
                ]
                answers: list[Solution | None] = [None] * len(guesses)
                for chunk, future in zip(chunks, futures):
                    for i, sol in zip(chunk, future.result()):
                        answers[i] = sol
                        if solved is not None:
                            solved()
            return [a for a in answers if a is not None], f"{workers} worker processes"
        except (BrokenProcessPool, OSError) as exc:
            how = f"in this process (the worker pool failed: {type(exc).__name__})"
    else:
        how = "in this process"
    results = solve_grid(prob, n, objective, duration_s, smoothing, guesses, max_iter, options, solved=solved)[1]
    return results, how


def start_report(
    results: Sequence[Solution], specs: Sequence[StartSpec], t_s: float, extra: Sequence[Mapping[str, Any]]
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Per-start records and the multi-start summary (how many reached the best, the spread of the others).

    Parameters
    ----------
    results : sequence of Solution
        The answers, one per start.
    specs : sequence of (str, int)
        Family and index of each start.
    t_s : float
        Time scale [s].
    extra : sequence of mapping
        More fields per start (e.g. the status of the energy pre-solve).
    """
    records = []
    for sol, (family, index), more in zip(results, specs, extra):
        records.append(
            {
                "family": family,
                "index": index,
                "status": sol.status,
                "converged": sol.converged,
                "iterations": sol.iterations,
                "solve_time_s": sol.solve_time,
                "objective": sol.objective,
                "duration_s": sol.duration * t_s,
                **more,
            }
        )
    good = [r for r in records if r["converged"]]
    summary: dict[str, Any] = {
        "starts": len(records),
        "converged": len(good),
        "tolerance_rel": MATCH_TOLERANCE,
        "reached_best": 0,
        "best_families": [],
        "others_excess_rel": None,
    }
    if not good:
        return records, summary
    best = min(r["objective"] for r in good)
    scale = max(abs(best), 1e-300)
    for r in records:
        r["excess_rel"] = (r["objective"] - best) / scale if r["converged"] else None
        r["reached_best"] = bool(r["converged"] and r["excess_rel"] <= MATCH_TOLERANCE)
    others = [r["excess_rel"] for r in records if r["converged"] and not r["reached_best"]]
    summary["reached_best"] = sum(r["reached_best"] for r in records)
    summary["best_families"] = sorted({r["family"] for r in records if r["reached_best"]})
    if others:
        summary["others_excess_rel"] = {"min": min(others), "median": float(np.median(others)), "max": max(others)}
    return records, summary

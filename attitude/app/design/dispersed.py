"""The design's dispersed check: a small vectorised campaign on the file's ``[montecarlo]`` dispersions.

Top floor (DESIGN.md), like :mod:`attitude.app.design.run`. A design that
passes on the nominal spacecraft but fails on the dispersed ones is not a
PASS: the requirement table gets one row, "no run of a small campaign fails
a campaign requirement", with the number of failures and the one-sided
Clopper-Pearson bound on the probability of success
(:func:`attitude.montecarlo.statistics.success_lower_bound`).

The campaign is ``attitude montecarlo FILE --runs N --vectorized`` with the
planner nodes the row names: the same scenario (the planned slew, tracked,
with wheels, gyro, star tracker and MEKF), the file's dispersions and seed
(``montecarlo.seed``), the same requirements as the design's table, on the
same windows (:func:`attitude.app.assembly.monte_carlo_requirements`,
:mod:`attitude.simulation.slew_windows`), run in this process. Each run
lasts the planned slew, the required settling time and the hold
(:func:`attitude.app.assembly.judged_duration`, the campaign's default and
the design's flight; the vectorised loop's cost is per tick, not per run).
Each failing run is listed with the requirements it missed, so the
failure explains itself, and the command reruns the campaign to look at it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude.app import assembly
from attitude.app.scenarios import ScenarioError, run_campaign_from_config
from attitude.app.slew_study import SlewStudy
from attitude.config import SpacecraftConfig, default_config
from attitude.montecarlo.statistics import success_lower_bound
from attitude.plain import plain_float as _f
from controllers.slew.problem import SlewPlanningError

__all__ = ["CONFIDENCE", "FAILING_RUNS_LISTED", "dispersed_check"]

#: Confidence of the success bound.
CONFIDENCE = 0.95
#: Failing runs listed by number in the results and the report.
FAILING_RUNS_LISTED = 5


def dispersed_check(
    config: SpacecraftConfig, runs: int, slew_s: float | None, nodes: int, study: SlewStudy | None = None
) -> dict[str, Any] | None:
    """Fly ``runs`` dispersed runs and judge them; None without a ``[montecarlo]`` table.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    runs : int
        Number of runs (>= 1).
    slew_s : float or None
        The planned slew's duration [s]; None when none was planned (the
        campaign's planning then fails and says why).
    nodes : int
        Planner intervals of the campaign's slew (the design's).
    study : SlewStudy, optional
        The design's planned slew (the campaign flies it instead of planning it again); None plans it.

    Returns
    -------
    dict or None
        JSON-ready: runs, seed, duration, failures, errors, the success
        bound and its statement, each requirement's passes, the first failing
        runs with what they missed, and the command that reruns the campaign;
        ``{"runs", "error", "command"}`` when it could not be flown.
    """
    mc = config.montecarlo
    if mc is None:
        return None
    # The campaign's own default (None below): to the end of the hold of the slew it plans, which is the
    # design's plan (same file, same nodes); here for the report.
    duration = assembly.judged_duration(config, slew_s)
    # The built-in spacecraft is the command's default (its path inside the package is no file to give).
    source = "" if config.source is None or config.source == default_config().source else f" {config.source}"
    command = f"attitude montecarlo{source} --runs {runs} --vectorized --nodes {nodes}"
    try:
        result = run_campaign_from_config(
            config,
            runs=runs,
            workers=1,
            out_dir=None,
            duration=None,
            nodes=nodes,
            # In the file's orbit when it has one, as the design's flight and `attitude montecarlo` fly.
            environment=config.orbit_config is not None,
            study=study,
            progress=False,
            figures=False,
            vectorized=True,
            resume=False,
        )
    except (ScenarioError, SlewPlanningError) as exc:
        return {"runs": runs, "error": str(exc), "command": command}
    passed = np.asarray(result.passed)
    status = np.asarray(result.status)
    successes = int(np.sum(passed))
    failing = []
    for i in np.nonzero(~passed)[0][:FAILING_RUNS_LISTED]:
        missed = [r.name for r in result.requirements if not result.requirement_passed(r)[i]]
        failing.append(
            {"run": int(i), "missed": missed, "error": str(result.errors[i]) if status[i] == "error" else ""}
        )
    bound = success_lower_bound(successes, runs, CONFIDENCE)
    return {
        "runs": runs,
        "seed": int(result.seed),
        "duration_s": _f(float(duration)),
        "failures": runs - successes,
        "errors": int(np.sum(status == "error")),
        "success_lower_bound": _f(bound),
        "confidence_percent": 100.0 * CONFIDENCE,
        "statement": (
            f"{runs} runs, {runs - successes} failures: with {100 * CONFIDENCE:g} % confidence the probability of "
            f"success is at least {100 * bound:.2f} %"
        ),
        "requirements": {
            r.name: {"metric": r.metric, "passed": int(np.sum(result.requirement_passed(r)))}
            for r in result.requirements
        },
        "failing_runs": failing,
        "command": command,
    }

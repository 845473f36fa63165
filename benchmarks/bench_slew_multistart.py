"""Multi-start slew planning (#15): wall time, how many starts reach the best, Pontryagin residual.

``pontryagin_residual`` is the plan's normalised residual (``max |H|`` and the switching
disagreement, each over its tolerance: above 1 flags the plan); ``hamiltonian_residual``
is ``max |H|`` itself.

The Bilimoria-Wie benchmark (unit inertia, ``|u_i| <= 1``, rest-to-rest 180 deg about x,
published optimum 3.2431 s) planned from every start family
(:data:`controllers.slew.guess.MULTI_START`: eight minimum-time solves and one
minimum-energy solve) on 50 nodes, solved in this process and in two forked worker
processes. Target: under 5 s wall time (median) on 2 cores.

Also: an asymmetric body and torque box (inertia diag(1, 2, 2.9), torque 1, 0.4, 0.7,
120 deg about (1, -1, 0.5)), where the eigenaxis start ends in a slower local optimum:
the single-start and multi-start times and the gap.

Times are wall-clock seconds (``time.perf_counter``): worker processes spend CPU
outside this process, so its CPU time would not count them.
"""

from __future__ import annotations

import math
import statistics
import time
from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from controllers.slew.guess import MULTI_START
from controllers.slew.plan import SlewPlan
from controllers.slew.planner import plan_slew
from controllers.slew.reference import PUBLISHED_BILIMORIA_WIE

UNIT = RigidBody([1.0, 1.0, 1.0])
Q_ID = np.array([1.0, 0.0, 0.0, 0.0])
Q_180X = quat.from_axis_angle([1.0, 0.0, 0.0], math.pi)
TARGET_WALL_S = 5.0


def _wall_median(fun: Any, repeats: int) -> tuple[SlewPlan, dict[str, float]]:
    """Run ``fun`` once to warm up, then ``repeats`` times; wall seconds."""
    plan = fun()
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        plan = fun()
        samples.append(time.perf_counter() - start)
    return plan, {"median_s": statistics.median(samples), "min_s": min(samples), "max_s": max(samples)}


def bilimoria_wie(repeats: int = 3) -> dict[str, Any]:
    """The 180 deg benchmark from every start family, serial and in two worker processes."""
    published = PUBLISHED_BILIMORIA_WIE["time_optimal"]
    out: dict[str, Any] = {
        "case": "Bilimoria-Wie 180 deg, unit inertia, |u_i| <= 1, 50 nodes, starts=MULTI_START",
        "published_s": published,
        "target_wall_s": TARGET_WALL_S,
    }
    for workers in (1, 2):
        plan, timing = _wall_median(
            lambda w=workers: plan_slew(UNIT, Q_ID, Q_180X, torque_max=1.0, nodes=50, starts=MULTI_START, workers=w),
            repeats,
        )
        multi = plan.info["multi_start"]
        out[f"workers_{workers}"] = {
            "wall_s": timing,
            "meets_target": timing["median_s"] < TARGET_WALL_S,
            "solved": multi["solved"],
            "duration_s": plan.duration,
            "error_rel": (plan.duration - published) / published,
            "starts": multi["starts"],
            "reached_best": multi["reached_best"],
            "others_excess_rel": multi["others_excess_rel"],
            "per_start": [(r["family"], r["index"], r["status"], r["duration_s"]) for r in plan.info["starts"]],
            "pontryagin_residual": plan.pontryagin_residual,
            "hamiltonian_residual": plan.info["pontryagin"]["hamiltonian_residual"],
            "switching_disagreement": plan.info["pontryagin"]["switching_disagreement"],
            "ipopt_s": plan.solve_time,
        }
    return out


def asymmetric_body() -> dict[str, Any]:
    """Single eigenaxis start against every family on an asymmetric body (20 and 40 nodes)."""
    body = RigidBody([1.0, 2.0, 2.9])
    qf = quat.from_axis_angle([1.0, -1.0, 0.5], math.radians(120.0))
    rows = []
    for nodes in (20, 40):
        single = plan_slew(body, Q_ID, qf, torque_max=[1.0, 0.4, 0.7], nodes=nodes, starts=1)
        multi = plan_slew(body, Q_ID, qf, torque_max=[1.0, 0.4, 0.7], nodes=nodes, starts=MULTI_START)
        rows.append(
            {
                "nodes": nodes,
                "single_start_s": single.duration,
                "multi_start_s": multi.duration,
                "single_slower_percent": 100.0 * (single.duration / multi.duration - 1.0),
                "best_families": multi.info["multi_start"]["best_families"],
                "reached_best": multi.info["multi_start"]["reached_best"],
                "pontryagin_residual_single": single.pontryagin_residual,
                "pontryagin_residual_multi": multi.pontryagin_residual,
                "hamiltonian_residual_single": single.info["pontryagin"]["hamiltonian_residual"],
                "hamiltonian_residual_multi": multi.info["pontryagin"]["hamiltonian_residual"],
            }
        )
    return {"case": "diag(1, 2, 2.9) kg m^2, torque (1, 0.4, 0.7) N m, 120 deg about (1, -1, 0.5)", "per_nodes": rows}


def run() -> dict[str, Any]:
    return {"bilimoria_wie": bilimoria_wie(), "asymmetric_body": asymmetric_body()}


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

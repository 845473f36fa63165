"""Optimal slew planning: solve time, iterations and accuracy (issue: optimal slews).

Published reference (Bilimoria and Wie, 1993): unit inertia, ``|u_i| <= 1``,
rest-to-rest 180 deg about a body axis; eigenaxis 3.5449 s (``2 sqrt(pi)``),
time-optimal 3.2431 s. Targets: the grid-converged (refined) time within
0.05 % of 3.2431 s; the 100-node case under 2 s CPU (median, one core).

Times are CPU seconds (``time.process_time``) of the whole ``plan_slew``
call: building the NLP, IPOPT, the switch-time refinement and the open-loop
re-simulation that verifies the plan. ``ipopt_s`` is the wall time inside
IPOPT alone.

Also measured: what the between-checkpoint keep-out margin costs on a
coarse grid against checkpoints only (and how far the latter cuts into the
cone on an independent fine re-simulation), a rate-limited slew on coarse
grids against its eigenaxis reference, and how fast cones that block every
path are rejected.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.propagate import propagate
from controllers.slew.keep_out import KeepOutCone
from controllers.slew.plan import SlewPlan
from controllers.slew.planner import plan_slew
from controllers.slew.problem import InfeasibleSlewError
from controllers.slew.reference import PUBLISHED_BILIMORIA_WIE

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

UNIT = RigidBody([1.0, 1.0, 1.0])
Q_ID = np.array([1.0, 0.0, 0.0, 0.0])
Q_180X = quat.from_axis_angle([1.0, 0.0, 0.0], math.pi)
NODES = (25, 50, 100, 200)
TARGET_100_NODES_S = 2.0

SMALLSAT = RigidBody(np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]))
SUN_N = np.array([-1.0, 1.0, 0.15]) / np.linalg.norm([-1.0, 1.0, 0.15])


def _timed(fun: Any, repeats: int) -> tuple[SlewPlan, dict[str, float]]:
    plans: list[SlewPlan] = []
    timing = cpu_time_median(lambda: plans.append(fun()), repeats=repeats)
    return plans[-1], timing


def _figures(plan: SlewPlan) -> dict[str, Any]:
    ref = plan.info["refinement"]
    return {
        "grid_duration_s": plan.grid_duration,
        "refined_duration_s": plan.refined_duration,
        "grid_iterations": plan.info["grid_iterations"],
        "refine_iterations": ref.get("iterations"),
        "refine_status": ref.get("status"),
        "refine_grid_converged": ref.get("grid_converged"),
        "ipopt_s": plan.solve_time,
        "final_attitude_error_deg": plan.final_attitude_error_deg,
        "final_rate_error_rad_s": plan.final_rate_error,
        "warnings": plan.warnings,
    }


def _fine_separation_min_deg(plan: SlewPlan, cone: KeepOutCone, per_interval: int = 20) -> float:
    """Smallest separation [deg] on an adaptive re-simulation, ``per_interval`` samples per plan interval."""
    frac = np.arange(per_interval) / per_interval
    t = np.concatenate([(plan.t[:-1, None] + frac * np.diff(plan.t)[:, None]).ravel(), plan.t[-1:]])
    tau = np.repeat(plan.torque[:-1], per_interval, axis=0)
    tau = np.vstack([tau, tau[-1:]])
    traj = propagate(RigidBody(plan.inertia), Q_ID, np.zeros(3), t, tau, method="adaptive", rtol=1e-11, atol=1e-13)
    return float(np.degrees(np.min(cone.separation(quat.normalize(traj.q)))))


def published_benchmark(repeats: int = 3) -> dict[str, Any]:
    """The 180-degree benchmark per node count: time error against the published value."""
    published = PUBLISHED_BILIMORIA_WIE["time_optimal"]
    cases = []
    for n in NODES:
        plan, timing = _timed(lambda n=n: plan_slew(UNIT, Q_ID, Q_180X, torque_max=1.0, nodes=n), repeats)
        _, timing_grid = _timed(
            lambda n=n: plan_slew(UNIT, Q_ID, Q_180X, torque_max=1.0, nodes=n, refine=False), repeats
        )
        cases.append(
            {
                "nodes": n,
                "cpu_s": timing,
                "cpu_s_without_refinement": timing_grid["median_s"],
                **_figures(plan),
                "grid_time_error_rel": (plan.grid_duration - published) / published,
                "refined_time_error_rel": (plan.duration - published) / published,
                "eigenaxis_s": plan.eigenaxis_duration,
                "faster_than_eigenaxis": 1.0 - plan.duration / plan.eigenaxis_duration,
            }
        )
    at_100 = next(c for c in cases if c["nodes"] == 100)
    return {
        "case": "Bilimoria-Wie: unit inertia, |u_i| <= 1, rest-to-rest 180 deg about x, minimum time",
        "published_s": published,
        "published_eigenaxis_s": PUBLISHED_BILIMORIA_WIE["eigenaxis"],
        "per_nodes": cases,
        "target_100_nodes_cpu_s": TARGET_100_NODES_S,
        "meets_100_nodes_target": at_100["cpu_s"]["median_s"] < TARGET_100_NODES_S,
        "refined_time_error_max_rel": max(abs(c["refined_time_error_rel"]) for c in cases),
        "target_error_rel": 5e-4,
    }


def small_satellite(repeats: int = 3) -> dict[str, Any]:
    """A realistic small satellite: rate limit, Sun keep-out, reaction wheels, minimum energy."""
    q90 = quat.from_axis_angle([0.0, 0.0, 1.0], math.pi / 2)
    q60 = quat.from_axis_angle([1.0, 2.0, 3.0], math.radians(60.0))
    rate = math.radians(1.0)
    sun = KeepOutCone.from_degrees([0.0, 1.0, 0.0], SUN_N, half_angle_deg=30.0, name="sun")
    wheels = ReactionWheels.pyramid(spin_inertia=0.01, torque_max=0.02, momentum_max=0.5)
    cases = {
        "90 deg, 1 deg/s limit, 50 nodes": lambda: plan_slew(
            SMALLSAT, Q_ID, q90, torque_max=0.05, rate_max=rate, nodes=50
        ),
        "90 deg, 1 deg/s limit, 30 deg Sun keep-out, 50 nodes": lambda: plan_slew(
            SMALLSAT, Q_ID, q90, torque_max=0.05, rate_max=rate, keep_out=[sun], nodes=50
        ),
        "60 deg, pyramid of 4 wheels (20 mN m), 50 nodes": lambda: plan_slew(
            SMALLSAT, Q_ID, q60, torque_max=wheels, nodes=50
        ),
        "60 deg, minimum energy over 40 s, 50 nodes": lambda: plan_slew(
            SMALLSAT, Q_ID, q60, torque_max=0.05, objective="energy", duration=40.0, nodes=50
        ),
    }
    out = {}
    for name, fun in cases.items():
        plan, timing = _timed(fun, repeats)
        entry = {
            "cpu_s": timing,
            "duration_s": plan.duration,
            "objective_value": plan.objective_value,
            "eigenaxis_s": plan.eigenaxis_duration,
            "eigenaxis_enters_keep_out": plan.info.get("eigenaxis_enters_keep_out"),
            **_figures(plan),
            "rate_peak_deg_per_s": math.degrees(plan.rate_peak),
        }
        if plan.separation_min.size:
            entry["keep_out_separation_min_deg"] = np.degrees(plan.separation_min).tolist()
        out[name] = entry
    return {"case": "small satellite, inertia [[10,1.2,-0.5],[1.2,12,0.3],[-0.5,0.3,8]] kg m^2", **out}


def keep_out_margin() -> dict[str, Any]:
    """Cost of the between-checkpoint keep-out margin on coarse grids, against checkpoints only."""
    q90 = quat.from_axis_angle([0.0, 0.0, 1.0], math.pi / 2)
    cases = {
        "unit body, +y past the Sun (review case)": (
            UNIT,
            1.0,
            KeepOutCone.from_degrees([0, 1, 0], [-1, 1, 0.15], 30.0),
        ),
        "small satellite, no rate limit": (SMALLSAT, 0.05, KeepOutCone.from_degrees([0, 1, 0], SUN_N, 30.0)),
    }
    out = {}
    for name, (body, tau, cone) in cases.items():
        rows = []
        for nodes, substeps in ((10, 1), (10, 2), (20, 2), (50, 2)):
            kw = {"torque_max": tau, "keep_out": [cone], "nodes": nodes, "substeps": substeps, "refine": False}
            margin = plan_slew(body, Q_ID, q90, **kw)
            bare = plan_slew(body, Q_ID, q90, keep_out_margin=False, verify_tolerance=0.1, **kw)
            rows.append(
                {
                    "nodes": nodes,
                    "substeps": substeps,
                    "duration_s": margin.duration,
                    "duration_checkpoints_only_s": bare.duration,
                    "margin_cost_rel": margin.duration / bare.duration - 1.0,
                    "separation_min_deg": _fine_separation_min_deg(margin, cone),
                    "separation_min_checkpoints_only_deg": _fine_separation_min_deg(bare, cone),
                }
            )
        out[name] = rows
    return {"case": "90 deg about z, 30 deg cone, minimum time, no refinement; separations re-simulated", **out}


def rate_limited_coarse_grids() -> dict[str, Any]:
    """A rate-limited slew on coarse grids: grid and refined time against the eigenaxis slew."""
    q90 = quat.from_axis_angle([0.0, 0.0, 1.0], math.pi / 2)
    rows = []
    for nodes in (20, 30, 50):
        plan = plan_slew(SMALLSAT, Q_ID, q90, torque_max=0.05, rate_max=math.radians(1.0), nodes=nodes)
        rows.append(
            {
                "nodes": nodes,
                "grid_duration_s": plan.grid_duration,
                "duration_s": plan.duration,
                "eigenaxis_s": plan.eigenaxis_duration,
                "faster_than_eigenaxis": 1.0 - plan.duration / plan.eigenaxis_duration,
                "refine_modes": plan.info["refinement"].get("modes"),
                "refine_grid_converged": plan.info["refinement"].get("grid_converged"),
                "warnings": plan.warnings,
            }
        )
    return {"case": "small satellite, 90 deg about z, 0.05 N m, 1 deg/s limit, minimum time", "per_nodes": rows}


def blocked_keep_out(repeats: int = 3) -> dict[str, Any]:
    """Four 89 deg cones that leave the boresight two disconnected caps: time to reject."""
    cones = [KeepOutCone.from_degrees([0, 1, 0], d, 89.0) for d in ([1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1])]
    errors: list[InfeasibleSlewError] = []

    def attempt() -> None:
        try:
            plan_slew(UNIT, Q_ID, Q_180X, torque_max=1.0, keep_out=cones, nodes=30)
        except InfeasibleSlewError as exc:
            errors.append(exc)

    timing = cpu_time_median(attempt, repeats=repeats)
    return {
        "case": "unit body, 180 deg about x, boresight +y, 89 deg cones on +-x and +-z",
        "cpu_s": timing,
        "status": errors[-1].status if errors else None,
        "cause": errors[-1].cause if errors else None,
    }


def run() -> dict[str, Any]:
    return {
        "bilimoria_wie": published_benchmark(),
        "small_satellite": small_satellite(),
        "keep_out_margin": keep_out_margin(),
        "rate_limited_coarse_grids": rate_limited_coarse_grids(),
        "blocked_keep_out": blocked_keep_out(),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

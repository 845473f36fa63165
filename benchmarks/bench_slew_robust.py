"""Robust (unscented) slew planning (#15): solve time, and the Monte Carlo spread against the nominal plan.

The case of ``examples/robust_slew.py``: a small satellite (inertia with products, 50 mN m per axis)
slews 90 deg about (1, -1, 0.5) within a time bound of 56 s (twice its minimum time, 28.1 s), its
principal moments uniform within +-10 %. The robust plan (:func:`controllers.slew.plan_robust_slew`,
the seven sigma points of the moments, ``"expected"`` and ``"worst"`` objectives, 30 nodes) against
the nominal minimum-energy plan over the same 56 s, each flown over 200 inertias drawn from the same
set (seed 1): open loop, and tracked by feedforward plus quaternion PD (0.3 rad/s, 0.7, 0.5 s).

Figures: the CPU time of the whole planning call (the minimum-time solve that checks the time bound,
the nominal minimum-energy solve, the robust solve and the re-simulations; median, one core), IPOPT's
iterations, the energy against the nominal plan's, and the median / 95th percentile / max of the terminal
attitude and rate errors of the four flights. Claim checked: the robust plan's open-loop spread (95th
percentile of the combined terminal error ``sqrt(angle^2 + (56 s rate)^2)``) is smaller than the nominal
plan's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from controllers.slew.robust import RobustSlewPlan, plan_robust_slew
from controllers.slew.robust_comparison import compare_robust_slew
from controllers.worst_case import UncertaintySet

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

BODY = RigidBody(np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]))
TORQUE_MAX_NM = 0.05
Q0 = np.array([1.0, 0.0, 0.0, 0.0])
QF = quat.from_axis_angle(np.array([1.0, -1.0, 0.5]) / np.linalg.norm([1.0, -1.0, 0.5]), math.radians(90.0))
DURATION_S = 56.0
NODES = 30
UNCERTAINTY = UncertaintySet(inertia_percent=10.0)
SAMPLES = 200
TRACKING = {"wn": 0.3, "zeta": 0.7, "period": 0.5}


def _case(objective: str, repeats: int) -> dict[str, Any]:
    plans: list[RobustSlewPlan] = []

    def solve() -> None:
        plans.append(
            plan_robust_slew(
                BODY,
                Q0,
                QF,
                torque_max=TORQUE_MAX_NM,
                duration=DURATION_S,
                inertia_uncertainty=UNCERTAINTY,
                objective=objective,
                nodes=NODES,
            )
        )

    timing = cpu_time_median(solve, repeats=repeats)
    plan = plans[-1]
    comparison = compare_robust_slew(plan, inertia_uncertainty=UNCERTAINTY, samples=SAMPLES, rng=1, **TRACKING)
    spread = comparison.spread()
    return {
        "cpu_s": timing,
        "robust_ipopt_s": plan.solve_time,
        "iterations": plan.iterations,
        "minimum_time_s": plan.info["minimum_time_s"],
        "energy_ratio_to_nominal": plan.energy / plan.nominal_energy,
        "sigma_terminal_error_deg": math.degrees(math.sqrt(plan.objective_value)),
        "nominal_sigma_terminal_error_deg": math.degrees(math.sqrt(plan.nominal_objective_value)),
        "monte_carlo": spread,
        "open_loop_spread_smaller": spread["robust_open_loop"]["terminal_p95_deg"]
        < spread["nominal_open_loop"]["terminal_p95_deg"],
    }


def run(repeats: int = 3) -> dict[str, Any]:
    return {
        "case": (
            f"inertia with products, {TORQUE_MAX_NM * 1e3:g} mN m box, 90 deg about (1, -1, 0.5) in {DURATION_S:g} s, "
            f"moments uniform within +-{UNCERTAINTY.inertia_percent:g} %, {NODES} nodes, {SAMPLES} Monte Carlo samples"
        ),
        "expected": _case("expected", repeats),
        "worst": _case("worst", repeats),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

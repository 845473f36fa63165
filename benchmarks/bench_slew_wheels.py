"""Slews planned on the reaction wheels (``plan_slew(..., wheel_states=True)``): solve time and what they gain.

Case: a four-wheel pyramid (20 mN m, spin inertia 0.005 kg m^2) on the
example's microsatellite (inertia [[12,0.4,-0.3],[0.4,10.5,0.2],[-0.3,0.2,8.5]]
kg m^2), rest to rest, 90 deg, 3 deg/s rate limit, minimum time on a 50-node
grid. Times are CPU seconds (``time.process_time``) of the whole
``plan_slew`` call: building the NLP (11 states, 4 controls per node), IPOPT
and the re-simulation on the wheel model (scipy DOP853) that verifies the
plan. Beside them, the same slew under the largest guaranteed box and under
the minimum-norm allocation envelope (uniform grids, no refinement: like
against like), about body x (the polytope reaches twice the box) and about
the vertex ``u = (1, 1, 1, -1)`` axis (1.5 times the allocation), and the
slew about x with wheels whose 0.1 N m s speed limit binds.

No Basilisk case does this work (Basilisk has no trajectory optimiser), so
no peer ratio is given.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from controllers.slew.plan import SlewPlan
from controllers.slew.planner import plan_slew
from controllers.slew.wheel_states import wheel_torque_box

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

BODY = RigidBody(np.array([[12.0, 0.4, -0.3], [0.4, 10.5, 0.2], [-0.3, 0.2, 8.5]]))
NODES = 50
RATE_MAX = math.radians(3.0)
Q0 = np.array([1.0, 0.0, 0.0, 0.0])


def _wheels(momentum_max: float) -> ReactionWheels:
    return ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.02, momentum_max=momentum_max)


def _timed(fun: Any, repeats: int) -> tuple[SlewPlan, dict[str, float]]:
    plans: list[SlewPlan] = []
    timing = cpu_time_median(lambda: plans.append(fun()), repeats=repeats)
    return plans[-1], timing


def run(repeats: int = 3) -> dict[str, Any]:
    wheels = _wheels(0.5)
    vertex = wheels.body_torque(np.array([1.0, 1.0, 1.0, -1.0]))
    out: dict[str, Any] = {
        "case": "4-wheel pyramid 20 mN m, microsatellite, rest to rest 90 deg, 3 deg/s, minimum time, 50 nodes",
        "per_axis": {},
    }
    common = {"rate_max": RATE_MAX, "nodes": NODES}
    for name, axis in (("x", np.array([1.0, 0.0, 0.0])), ("vertex", vertex / np.linalg.norm(vertex))):
        qf = quat.from_axis_angle(axis, math.pi / 2)
        plan, timing = _timed(
            lambda qf=qf: plan_slew(BODY, Q0, qf, torque_max=wheels, wheel_states=True, **common), repeats
        )
        box = plan_slew(BODY, Q0, qf, torque_max=wheel_torque_box(wheels), refine=False, **common)
        allocation = plan_slew(BODY, Q0, qf, torque_max=wheels, refine=False, **common)
        check = plan.info["verification"]
        out["per_axis"][name] = {
            "cpu_s": timing,
            "ipopt_iterations": plan.iterations,
            "duration_s": plan.duration,
            "box_duration_s": box.duration,
            "allocation_duration_s": allocation.duration,
            "faster_than_box": 1.0 - plan.duration / box.duration,
            "faster_than_allocation": 1.0 - plan.duration / allocation.duration,
            "final_attitude_error_rad": check["final_attitude_error"],
            "torque_ratio_max": check["torque_ratio_max"],
            "momentum_ratio_max": check["momentum_ratio_max"],
        }
    qf = quat.from_axis_angle([1.0, 0.0, 0.0], math.pi / 2)
    limited, timing = _timed(
        lambda: plan_slew(BODY, Q0, qf, torque_max=_wheels(0.1), wheel_states=True, rate_max=RATE_MAX, nodes=NODES),
        repeats,
    )
    out["momentum_limited_x"] = {
        "momentum_max_nms": 0.1,
        "cpu_s": timing,
        "duration_s": limited.duration,
        "slower_than_unlimited": limited.duration / out["per_axis"]["x"]["duration_s"] - 1.0,
        "momentum_ratio_max": limited.info["verification"]["momentum_ratio_max"],
    }
    return out


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

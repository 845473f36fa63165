"""Closed-loop speed (issue: control design).

Target: the built-in quaternion PD with 4 reaction wheels at a 0.1 s step,
600 s simulated, at least 9,000 simulated seconds per CPU second (a compiled
C++ peer runs its reference MRP-feedback loop at about that).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.simulation.engine import simulate
from controllers.pd import QuaternionPD

try:
    from benchmarks._timing import cpu_time_median, memory_peak_mib
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median, memory_peak_mib

BODY = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
WHEELS = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8, viscous_friction=2e-6)


def pd_with_wheels(duration_s: float = 600.0) -> dict[str, Any]:
    target = quat.from_axis_angle([1.0, 0.5, 0.0], np.radians(30.0))
    pd = QuaternionPD.from_bandwidth(BODY, wn=0.1, zeta=0.7, period=0.1, q_ref=target, gyroscopic=True)

    def run(engine: str):
        return simulate(BODY, quat.identity(), np.zeros(3), duration_s, controller=pd, wheels=WHEELS, engine=engine)

    compiled = cpu_time_median(lambda: run("compiled"), repeats=7)
    python = cpu_time_median(lambda: run("python"), repeats=1)
    return {
        "case": "quaternion PD + 4-wheel pyramid, 0.1 s step, 600 s, full inertia tensor",
        "compiled": {"cpu_s": compiled, "sim_s_per_cpu_s": duration_s / compiled["median_s"]},
        "python_protocol_path": {"cpu_s": python, "sim_s_per_cpu_s": duration_s / python["median_s"]},
        "target_sim_s_per_cpu_s": 9_000,
        "memory_peak_mib": memory_peak_mib(lambda: run("compiled")),
    }


def run() -> dict[str, Any]:
    return {"pd_with_wheels": pd_with_wheels()}


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

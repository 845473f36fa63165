"""The spacecraft in orbit: closed-loop speed with the environment, and the momentum budget (issue: orbit environment).

Targets:

* one orbit (about 5,700 s) of a nadir-pointing closed loop with four wheels, three magnetorquers under
  cross-product unloading, all four disturbance torques and IGRF at a 0.1 s tick: at least 3,000 simulated
  seconds per CPU second. The environment's attitude-independent part (position, Sun, shadow, field,
  density) is evaluated every second and interpolated (:class:`attitude.environment.OrbitEnvironment`,
  ``sample_period``); the torques are evaluated at every tick from the attitude.
* the 20-orbit momentum budget of the built-in spacecraft (no dumping and unloading): under 30 s.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude import RigidBody
from attitude.actuators import Magnetorquers, ReactionWheels
from attitude.app.design.orbit import momentum_budget
from attitude.config import default_config
from attitude.environment import CircularOrbit, OrbitEnvironment, SurfaceModel
from attitude.simulation.engine import simulate
from controllers import CrossProductUnloading, NadirPointing

try:
    from benchmarks._timing import cpu_time_median, memory_peak_mib
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median, memory_peak_mib

BODY = RigidBody([[10.0, 0.2, -0.1], [0.2, 12.0, 0.3], [-0.1, 0.3, 8.0]])
WHEELS = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8)
RODS = Magnetorquers.orthogonal(dipole_max_Am2=1.0)
ORBIT = CircularOrbit.from_altitude(500e3, inclination=np.radians(97.4))
SURFACE = SurfaceModel.box(
    [1.0, 1.0, 1.5],
    specular=0.2,
    diffuse=0.3,
    centre_of_pressure_offset_B_m=[0.02, 0.01, 0.05],
    residual_dipole_Am2=[0.01, 0.0, 0.02],
)


def nadir_orbit(engine: str = "compiled") -> dict[str, Any]:
    env = OrbitEnvironment(ORBIT, surface=SURFACE, sample_period=1.0)
    pointing = NadirPointing(ORBIT, BODY, wn=0.2, zeta=0.7, period=0.1)
    unloading = CrossProductUnloading(1e-3, period=0.1, magnetorquers=RODS, use_truth_field=True)
    duration = float(np.floor(ORBIT.period / 0.1) * 0.1)
    q0 = ORBIT.q_LN(0.0)
    w0 = np.array([0.0, -ORBIT.mean_motion, 0.0])

    def run(which: str):
        return simulate(
            BODY,
            q0,
            w0,
            duration,
            controller=pointing,
            wheels=WHEELS,
            environment=env,
            magnetorquers=RODS,
            dipole_controller=unloading,
            engine=which,
        )

    compiled = cpu_time_median(lambda: run("compiled"), repeats=5)
    out = {
        "case": "nadir PD + 4-wheel pyramid + 3 rods (cross-product unloading), GG + aero + SRP + dipole, IGRF-13 "
        "sampled every 1 s, 0.1 s tick, one orbit",
        "duration_s": duration,
        "compiled": {"cpu_s": compiled, "sim_s_per_cpu_s": duration / compiled["median_s"]},
        "target_sim_s_per_cpu_s": 3_000,
        "memory_peak_mib": memory_peak_mib(lambda: run("compiled")),
    }
    if engine == "both":
        python = cpu_time_median(lambda: run("python"), repeats=1)
        out["python_path"] = {"cpu_s": python, "sim_s_per_cpu_s": duration / python["median_s"]}
    return out


def budget_20_orbits() -> dict[str, Any]:
    config = default_config()
    cpu = cpu_time_median(lambda: momentum_budget(config, 20.0), repeats=3)
    return {
        "case": "built-in spacecraft, 20 orbits, nadir hold, no dumping and cross-product unloading, 10 s steps",
        "cpu_s": cpu,
        "target_cpu_s_max": 30.0,
    }


def run() -> dict[str, Any]:
    return {"nadir_orbit_closed_loop": nadir_orbit("both"), "momentum_budget_20_orbits": budget_20_orbits()}


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

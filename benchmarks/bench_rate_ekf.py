"""Rate EKF speed (issue: rate EKF): filter steps per CPU second.

Cases: a tumbling body with the tactical gyro at 10 Hz (exact Farrenkopf
update and the uncorrelated one), a full inertia tensor with a 4-wheel
pyramid, and the filter inside the closed-loop engine (simulated seconds
per CPU second, the engine's Python path included).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.sensors import Gyro
from attitude.simulation import simulate
from estimation.rate_ekf import RateEKF, run_rate_ekf

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

N_STEPS = 3000
BODY = RigidBody([4.0, 8.0, 10.0])
FULL = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
WHEELS = ReactionWheels.pyramid(0.005, 0.05, 0.8)


def _history(seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(N_STEPS) * 0.1
    rng = np.random.default_rng(seed)
    return t, np.radians([5.0, -3.0, 4.0]) + rng.standard_normal((N_STEPS, 3)) * 1e-4


def batch(noise_model: str, wheels: bool = False) -> dict[str, Any]:
    gyro = Gyro.preset("tactical", period=0.1)
    t, z = _history()
    body = FULL if wheels else BODY
    h = np.tile([0.1, -0.2, 0.05, 0.3], (N_STEPS, 1)) + np.arange(N_STEPS)[:, None] * 1e-5 if wheels else None

    def run():
        ekf = RateEKF.from_gyro(
            body,
            gyro,
            torque_noise=1e-5,
            P0=np.full(6, 1e-6),
            noise_model=noise_model,
            wheels=WHEELS if wheels else None,
        )
        return run_rate_ekf(ekf, t, z, torque=np.full((N_STEPS, 3), 1e-3), wheel_momentum=h)

    cpu = cpu_time_median(run, repeats=5)
    return {"cpu_s": cpu, "steps": N_STEPS, "steps_per_cpu_s": N_STEPS / cpu["median_s"]}


def closed_loop(duration_s: float = 60.0) -> dict[str, Any]:
    gyro = Gyro.preset("tactical", period=0.1)

    class Damper:
        period = 0.1

        def torque(self, t, estimate):
            return -0.5 * estimate.omega

    def run():
        ekf = RateEKF.from_gyro(BODY, gyro, torque_noise=1e-5, P0=np.full(6, 1e-6))
        return simulate(
            BODY,
            quat.identity(),
            np.radians([5.0, -3.0, 4.0]),
            duration_s,
            controller=Damper(),
            sensors=[gyro],
            estimator=ekf,
            rng=1,
        )

    cpu = cpu_time_median(run, repeats=3)
    return {"cpu_s": cpu, "sim_s_per_cpu_s": duration_s / cpu["median_s"]}


def run() -> dict[str, Any]:
    return {
        "case": "6-state rate EKF (rate + bias), tactical gyro at 10 Hz, 3000 steps",
        "farrenkopf": batch("farrenkopf"),
        "uncorrelated": batch("uncorrelated"),
        "full_inertia_4_wheels": batch("farrenkopf", wheels=True),
        "engine_closed_loop_60s": closed_loop(),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

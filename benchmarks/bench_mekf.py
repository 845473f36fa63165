"""MEKF speed (issue: estimation): filter steps per CPU second.

One filter stepped through filterpy's machinery, and 64 Monte Carlo runs
advanced together by the batched numpy path of ``run_mekf``. Gyro at 10 Hz,
star tracker at 2 Hz, a slowly rotating body.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude import quaternion as quat
from attitude.sensors import Gyro, StarTracker
from estimation.mekf import MEKF, initial_covariance, run_mekf

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

N_STEPS = 3000
N_RUNS = 64


def _data(n_runs: int) -> tuple[MEKF, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    gyro = Gyro.preset("tactical", period=0.1)
    tracker = StarTracker.preset("typical", period=0.5)
    t = np.arange(N_STEPS) * 0.1
    omega = np.radians([0.1, -0.05, 0.2])
    q_true = quat.multiply(quat.identity(), quat.from_rotation_vector(t[:, None] * omega))
    gyro_meas = np.empty((n_runs, N_STEPS, 3))
    tracker_meas = np.full((n_runs, N_STEPS, 4), np.nan)
    for r in range(n_runs):
        gyro_meas[r] = gyro.measure_history(t, np.tile(omega, (N_STEPS, 1)), rng)
        tracker_meas[r, ::5] = tracker.add_noise(q_true[::5], rng)
    mekf = MEKF.from_sensors(gyro, tracker, q0=q_true[0], P0=initial_covariance(np.radians(0.1), np.radians(0.01)))
    return mekf, t, gyro_meas, tracker_meas, q_true


def run() -> dict[str, Any]:
    mekf, t, gyro_meas, tracker_meas, _ = _data(N_RUNS)
    mask = ~np.isnan(tracker_meas[..., 0])
    single = cpu_time_median(lambda: run_mekf(mekf, t, gyro_meas[0], tracker_meas[0], tracker_mask=mask[0]), repeats=3)
    batch = cpu_time_median(lambda: run_mekf(mekf, t, gyro_meas, tracker_meas, tracker_mask=mask), repeats=3)
    return {
        "case": f"MEKF, tactical gyro 10 Hz, star tracker 2 Hz, {N_STEPS} steps",
        "single_filter": {"cpu_s": single, "filter_steps_per_s": N_STEPS / single["median_s"]},
        f"batched_{N_RUNS}_runs": {"cpu_s": batch, "filter_steps_per_s": N_RUNS * N_STEPS / batch["median_s"]},
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

"""MEKF speed (issue: estimation): filter steps per CPU second, and the Monte Carlo wall time.

One filter stepped through filterpy's machinery, and 64 Monte Carlo runs
advanced together by the batched numpy path of ``run_mekf``. Gyro at 10 Hz
(integrating: interval-mean samples, what the MEKF models), star tracker at
2 Hz, a slowly rotating body. The Monte Carlo case times a 50-run campaign
through the batched path, measurement generation included and apart, in wall
seconds (``time.perf_counter``) and CPU seconds (``time.process_time``).
"""

from __future__ import annotations

import time
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
    gyro = Gyro.preset("tactical", period=0.1, sampling="mean")
    tracker = StarTracker.preset("typical", period=0.5)
    t = np.arange(N_STEPS) * 0.1
    omega = np.radians([0.1, -0.05, 0.2])
    q_true = quat.multiply(quat.identity(), quat.from_rotation_vector(t[:, None] * omega))
    gyro_meas = np.empty((n_runs, N_STEPS, 3))
    tracker_meas = np.full((n_runs, N_STEPS, 4), np.nan)
    for r in range(n_runs):
        gyro_meas[r] = gyro.measure_history(t, np.tile(omega, (N_STEPS, 1)), rng, q_BN=q_true)
        tracker_meas[r, ::5] = tracker.add_noise(q_true[::5], rng)
    mekf = MEKF.from_sensors(
        gyro, tracker, q0=q_true[0], P0=initial_covariance(attitude_sigma=np.radians(0.1), bias_sigma=np.radians(0.01))
    )
    return mekf, t, gyro_meas, tracker_meas, q_true


def _wall_and_cpu(fun: Any) -> tuple[Any, float, float]:
    """Run ``fun`` once; its result, wall seconds and CPU seconds."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    out = fun()
    return out, time.perf_counter() - wall0, time.process_time() - cpu0


def monte_carlo(n_runs: int = 50) -> dict[str, Any]:
    """A 50-run campaign of N_STEPS steps through the batched path (generation timed apart)."""
    (mekf, t, gyro_meas, tracker_meas, _), gen_wall, gen_cpu = _wall_and_cpu(lambda: _data(n_runs))
    mask = ~np.isnan(tracker_meas[..., 0])
    run_mekf(mekf, t, gyro_meas[:2], tracker_meas[:2], tracker_mask=mask[:2])  # warm-up
    res, wall, cpu = _wall_and_cpu(lambda: run_mekf(mekf, t, gyro_meas, tracker_meas, tracker_mask=mask))
    return {
        "runs": n_runs,
        "steps_per_run": N_STEPS,
        "path": res.info["path"],
        "filter_wall_s": wall,
        "filter_cpu_s": cpu,
        "filter_steps_per_wall_s": n_runs * N_STEPS / wall,
        "generation_wall_s": gen_wall,
        "generation_cpu_s": gen_cpu,
        "total_wall_s": wall + gen_wall,
    }


def run() -> dict[str, Any]:
    mekf, t, gyro_meas, tracker_meas, _ = _data(N_RUNS)
    mask = ~np.isnan(tracker_meas[..., 0])
    single = cpu_time_median(lambda: run_mekf(mekf, t, gyro_meas[0], tracker_meas[0], tracker_mask=mask[0]), repeats=3)
    batch = cpu_time_median(lambda: run_mekf(mekf, t, gyro_meas, tracker_meas, tracker_mask=mask), repeats=3)
    return {
        "case": f"MEKF, tactical gyro 10 Hz, star tracker 2 Hz, {N_STEPS} steps",
        "single_filter": {"cpu_s": single, "filter_steps_per_s": N_STEPS / single["median_s"]},
        f"batched_{N_RUNS}_runs": {"cpu_s": batch, "filter_steps_per_s": N_RUNS * N_STEPS / batch["median_s"]},
        "monte_carlo_50_runs": monte_carlo(),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

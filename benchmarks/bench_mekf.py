"""MEKF speed (issue: estimation): filter steps per CPU second, and the Monte Carlo wall time.

One filter stepped through filterpy's machinery, and 64 Monte Carlo runs
advanced together by the batched numpy path of ``run_mekf``. Gyro at 10 Hz
(integrating: interval-mean samples, what the MEKF models), star tracker at
2 Hz, a slowly rotating body. The Monte Carlo case times a 50-run campaign
through the batched path, measurement generation included and apart, in wall
seconds (``time.perf_counter``) and CPU seconds (``time.process_time``).

Vector measurements: one filter stepped by ``MEKF.step`` with the tracker
only, then with the tracker and two vectors (a Sun sensor and a
magnetometer, each a ``VectorMeasurement`` at every gyro step, the worst
case), medians of interleaved repeats in one run, side by side; the
requirement is a ratio of at least 0.5. The same comparison for the batched
path (``run_mekf`` over 64 runs, the vectors as ``VectorSamples`` histories).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from attitude import quaternion as quat
from attitude.sensors import Gyro, StarTracker
from attitude.simulation.protocols import VectorMeasurement
from estimation.mekf import MEKF, initial_covariance, run_mekf
from estimation.mekf.batch import VectorSamples

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


#: Required ratio of steps per second, tracker + two vectors over tracker only.
VECTOR_SPEED_RATIO_MIN = 0.5


def vector_measurements(repeats: int = 5) -> dict[str, Any]:
    """Steps per CPU second of one filter, tracker only vs tracker + Sun sensor + magnetometer (medians)."""
    mekf, t, gyro_meas, tracker_meas, q_true = _data(1)
    rng = np.random.default_rng(1)
    sun_N = np.array([0.6, 0.7, 0.39])
    c_BN = quat.to_dcm(q_true)
    vectors = []
    for k in range(N_STEPS):
        field_N = np.array([np.cos(1e-3 * t[k]), 0.8 * np.sin(1e-3 * t[k]), 0.6])
        vectors.append(
            {
                "sun_sensor": VectorMeasurement(c_BN[k] @ sun_N + 1e-3 * rng.standard_normal(3), sun_N, sigma=1e-3),
                "magnetometer": VectorMeasurement(
                    c_BN[k] @ field_N + 5e-3 * rng.standard_normal(3), field_N, sigma=5e-3
                ),
            }
        )
    trackers = [None if np.isnan(y[0]) else y for y in tracker_meas[0]]
    base = mekf.copy()
    with_vectors = MEKF(
        sigma_v=base.sigma_v,
        sigma_u=base.sigma_u,
        tracker_covariance=base.tracker_covariance,
        period=base.period,
        q0=base.q,
        P0=base.P,
        vector_names=("sun_sensor", "magnetometer"),
    )

    def loop(use_vectors: bool) -> None:
        f = (with_vectors if use_vectors else base).copy()
        for k in range(N_STEPS):
            f.step(t[k], gyro_meas[0, k], trackers[k], vectors[k] if use_vectors else None)
        assert f.counts["vector_updates"] == (2 * N_STEPS if use_vectors else 0)

    # Interleaved so that both see the same machine load.
    times: dict[bool, list[float]] = {False: [], True: []}
    loop(False), loop(True)  # warm-up
    for _ in range(repeats):
        for use_vectors in (False, True):
            start = time.process_time()
            loop(use_vectors)
            times[use_vectors].append(time.process_time() - start)
    tracker_only = N_STEPS / float(np.median(times[False]))
    tracker_vectors = N_STEPS / float(np.median(times[True]))
    ratio = tracker_vectors / tracker_only
    return {
        "case": f"MEKF.step, {N_STEPS} steps, gyro 10 Hz, tracker 2 Hz, two vectors at 10 Hz",
        "tracker_only_steps_per_s": tracker_only,
        "tracker_and_two_vectors_steps_per_s": tracker_vectors,
        "ratio": ratio,
        "ratio_min": VECTOR_SPEED_RATIO_MIN,
        "ratio_ok": bool(ratio >= VECTOR_SPEED_RATIO_MIN),
        "repeats": repeats,
    }


def batch_vector_measurements(repeats: int = 3) -> dict[str, Any]:
    """Filter steps per CPU second of the batched path, tracker only vs tracker + two vectors (medians)."""
    mekf, t, gyro_meas, tracker_meas, q_true = _data(N_RUNS)
    mask = ~np.isnan(tracker_meas[..., 0])
    rng = np.random.default_rng(2)
    sun_N = np.array([0.6, 0.7, 0.39]) / np.linalg.norm([0.6, 0.7, 0.39])
    field_N = np.stack([np.cos(1e-3 * t), 0.8 * np.sin(1e-3 * t), np.full(t.size, 0.6)], axis=-1)
    c_BN = quat.to_dcm(q_true)
    sun_B = np.einsum("kij,j->ki", c_BN, sun_N) + 1e-3 * rng.standard_normal((N_RUNS, N_STEPS, 3))
    field_B = np.einsum("kij,kj->ki", c_BN, field_N) + 5e-3 * rng.standard_normal((N_RUNS, N_STEPS, 3))
    vectors = {
        "sun_sensor": VectorSamples(sun_B, sun_N, sigma=1e-3),
        "magnetometer": VectorSamples(field_B, field_N, sigma=5e-3),
    }
    with_vectors = MEKF(
        sigma_v=mekf.sigma_v,
        sigma_u=mekf.sigma_u,
        tracker_covariance=mekf.tracker_covariance,
        period=mekf.period,
        q0=mekf.q,
        P0=mekf.P,
        vector_names=tuple(vectors),
    )
    times: dict[bool, list[float]] = {False: [], True: []}
    for _ in range(repeats):  # interleaved: both see the same machine load
        for use_vectors in (False, True):
            start = time.process_time()
            if use_vectors:
                res = run_mekf(with_vectors, t, gyro_meas, tracker_meas, tracker_mask=mask, vectors=vectors)
                assert sum(res.info["vector_updates"]) == 2 * N_RUNS * N_STEPS
            else:
                run_mekf(mekf, t, gyro_meas, tracker_meas, tracker_mask=mask)
            times[use_vectors].append(time.process_time() - start)
    tracker_only = N_RUNS * N_STEPS / float(np.median(times[False]))
    tracker_vectors = N_RUNS * N_STEPS / float(np.median(times[True]))
    ratio = tracker_vectors / tracker_only
    return {
        "case": f"run_mekf batched, {N_RUNS} runs x {N_STEPS} steps, tracker 2 Hz, two vectors at 10 Hz",
        "tracker_only_filter_steps_per_s": tracker_only,
        "tracker_and_two_vectors_filter_steps_per_s": tracker_vectors,
        "ratio": ratio,
        "ratio_min": VECTOR_SPEED_RATIO_MIN,
        "ratio_ok": bool(ratio >= VECTOR_SPEED_RATIO_MIN),
        "repeats": repeats,
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
        "vector_measurements": vector_measurements(),
        "batch_vector_measurements": batch_vector_measurements(),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

"""Rate EKF speed (issue: rate EKF): filter steps per CPU second, and the Monte Carlo wall time.

Cases: a tumbling body with the tactical gyro at 10 Hz (exact Farrenkopf
update and the uncorrelated one), a full inertia tensor with a 4-wheel
pyramid, the filter inside the closed-loop engine (simulated seconds per CPU
second, the engine's Python path included), and a 50-run Monte Carlo
campaign (the per-run loop: one filterpy filter per run; truth and gyro
errors generated vectorised, timed apart) in wall seconds
(``time.perf_counter``) and CPU seconds (``time.process_time``).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.sensors import Gyro
from attitude.simulation.engine import simulate
from estimation.rate_ekf import RateEKF, run_rate_ekf

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

N_STEPS = 3000
BODY = RigidBody([4.0, 8.0, 10.0])
FULL = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
WHEELS = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8)


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


def _wall_and_cpu(fun: Any) -> tuple[Any, float, float]:
    """Run ``fun`` once; its result, wall seconds and CPU seconds."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    out = fun()
    return out, time.perf_counter() - wall0, time.process_time() - cpu0


def monte_carlo(n_runs: int = 50, duration_s: float = 100.0, seed: int = 7) -> dict[str, Any]:
    """A consistency campaign as the tests run it: ``n_runs`` tumbles, one filter per run (filterpy)."""
    gyro = Gyro.preset("tactical", period=0.1)
    deg_h = np.pi / 180.0 / 3600.0
    p0 = np.diag([np.radians(0.5) ** 2] * 3 + [(10 * deg_h) ** 2] * 3)
    n = round(duration_s / gyro.period) + 1
    t = np.arange(n) * gyro.period
    w0 = np.radians([5.0, -3.0, 4.0])

    def generate():
        rng = np.random.default_rng(seed)
        omega0 = w0 + rng.standard_normal((n_runs, 3)) * np.sqrt(p0[0, 0])
        # Torque-free truth, RK4 at the gyro rate for all runs at once (the filter does not see how).
        rates = np.empty((n_runs, n, 3))
        rates[:, 0] = w = omega0
        h = gyro.period
        for k in range(1, n):
            k1 = BODY.omega_dot(w, np.zeros(3))
            k2 = BODY.omega_dot(w + 0.5 * h * k1, np.zeros(3))
            k3 = BODY.omega_dot(w + 0.5 * h * k2, np.zeros(3))
            k4 = BODY.omega_dot(w + h * k3, np.zeros(3))
            rates[:, k] = w = w + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        bias0 = rng.standard_normal((n_runs, 3)) * np.sqrt(p0[3, 3])
        errors, _ = gyro.sample_errors(n, rng, bias0=bias0, n_runs=n_runs)
        return rates + errors

    z, gen_wall, gen_cpu = _wall_and_cpu(generate)

    def filters():
        for r in range(n_runs):
            ekf = RateEKF.from_gyro(BODY, gyro, torque_noise=1e-5, P0=p0, x0=np.r_[w0, 0.0, 0.0, 0.0])
            run_rate_ekf(ekf, t, z[r])

    filters()  # warm-up (imports, caches) so the timed campaign is the steady state
    _, wall, cpu = _wall_and_cpu(filters)
    return {
        "runs": n_runs,
        "steps_per_run": n,
        "path": "per-run loop (one filterpy RateEKF per run)",
        "filter_wall_s": wall,
        "filter_cpu_s": cpu,
        "filter_steps_per_wall_s": n_runs * n / wall,
        "generation_wall_s": gen_wall,
        "generation_cpu_s": gen_cpu,
        "total_wall_s": wall + gen_wall,
    }


def run() -> dict[str, Any]:
    return {
        "case": "6-state rate EKF (rate + bias), tactical gyro at 10 Hz, 3000 steps",
        "farrenkopf": batch("farrenkopf"),
        "uncorrelated": batch("uncorrelated"),
        "full_inertia_4_wheels": batch("farrenkopf", wheels=True),
        "engine_closed_loop_60s": closed_loop(),
        "monte_carlo_50_runs_100s": monte_carlo(),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

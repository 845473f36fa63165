"""Propagation speed and accuracy (issue: foundation).

Targets: one body, RK4 at 0.1 s, >= 10,000 simulated seconds per CPU second
(a plain numpy RK4 loop runs ~600); a batch of 10,000 bodies, >= 500,000
body-simulated-seconds per CPU second. ``one_body_methods`` times both
fixed-step methods side by side on the torque-free case of the compiled peer
(Basilisk's ``torquefree``: RK4 at 0.1 s) and writes each one's ratio to it
(``benchmarks/basilisk_reference.json``, :mod:`benchmarks._peer`); target:
at least 1.0x for both.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.integrators import StepSizeWarning
from attitude.propagate import propagate

try:
    from benchmarks._peer import versus_basilisk
    from benchmarks._timing import cpu_time_median, memory_peak_mib
except ImportError:  # run as a script from the benchmarks folder
    from _peer import versus_basilisk
    from _timing import cpu_time_median, memory_peak_mib

# A small satellite in its principal frame [kg m^2] (the torque-free case).
BODY = RigidBody([8.0, 10.0, 12.0])
STEP_S = 0.1


def _largest_angle_between(q_a: np.ndarray, q_b: np.ndarray) -> float:
    """Largest rotation angle between two attitude histories [rad]."""
    q_err = quat.multiply(quat.conjugate(q_b), q_a)
    return float(np.max(2.0 * np.arctan2(np.linalg.norm(q_err[..., 1:], axis=-1), np.abs(q_err[..., 0]))))


def single_body(duration_s: float = 6000.0) -> dict[str, Any]:
    t = np.arange(0.0, duration_s + STEP_S / 2, STEP_S)
    q0 = quat.from_axis_angle([1.0, 2.0, 3.0], 0.4)
    w0 = np.array([0.05, 0.3, -0.02])
    with warnings.catch_warnings():
        # The step-size rule sub-steps this tumble (docs/rk4_step_rule.md); its warning is the point of the
        # "step_rule" figures below, not noise in the timing.
        warnings.simplefilter("ignore", StepSizeWarning)
        timing = cpu_time_median(lambda: propagate(BODY, q0, w0, t, method="rk4"))
        ruled = propagate(BODY, q0, w0, t, method="rk4")
    # The same step with the rule off, measured in the same run: the integrator's own speed.
    timing_off = cpu_time_median(lambda: propagate(BODY, q0, w0, t, method="rk4", attitude_error_budget_rad=np.inf))
    unruled = propagate(BODY, q0, w0, t, method="rk4", attitude_error_budget_rad=np.inf)
    reference = propagate(BODY, q0, w0, t, method="adaptive", rtol=1e-13, atol=1e-15)
    numpy_path = cpu_time_median(lambda: propagate(BODY, q0[None], w0[None], t[:6001], method="rk4"), repeats=3)
    return {
        "case": "one body, RK4, 0.1 s step, torque-free",
        "simulated_s": duration_s,
        "cpu_s": timing,
        "sim_s_per_cpu_s": duration_s / timing["median_s"],
        "target_sim_s_per_cpu_s": 10_000,
        "step_rule": {
            "predicted_error_rad": ruled.info.get("step_rule"),
            "error_vs_adaptive_rad": _largest_angle_between(ruled.q, reference.q),
        },
        "step_rule_off": {
            "cpu_s": timing_off,
            "sim_s_per_cpu_s": duration_s / timing_off["median_s"],
            "error_vs_adaptive_rad": _largest_angle_between(unruled.q, reference.q),
            "slowdown_of_the_rule": timing["median_s"] / timing_off["median_s"],
        },
        "memory_peak_mib": memory_peak_mib(lambda: propagate(BODY, q0, w0, t, method="rk4")),
        "numpy_loop_sim_s_per_cpu_s": 600.0 / numpy_path["median_s"],
    }


#: The compiled peer's torque-free case (Basilisk): inertia [kg m^2], initial rate [rad/s], duration [s].
PEER_INERTIA = np.diag([100.0, 200.0, 300.0])
PEER_OMEGA0 = np.array([0.1, 0.01, 0.01])
PEER_DURATION_S = 600.0


def one_body_methods(repeats: int = 7) -> dict[str, Any]:
    """RK4 and the geometric method (RKMK4) for one body, the peer's case, CPU-time medians measured in one run."""
    body = RigidBody(PEER_INERTIA)
    t = np.arange(0.0, PEER_DURATION_S + STEP_S / 2, STEP_S)
    out: dict[str, Any] = {
        "case": "one body, I = diag(100, 200, 300) kg m^2, omega0 = [0.1, 0.01, 0.01] rad/s, 0.1 s step, "
        "600 s, torque-free",
        "simulated_s": PEER_DURATION_S,
        "target_ratio_to_basilisk": 1.0,
    }
    runs = iter(range(1, 10**6))

    def fresh_body() -> RigidBody:
        # A body built afresh for every run (inertia changed by a part in 10^9), as Basilisk builds its
        # simulation for every run: nothing compiled for an earlier body is reused.
        return RigidBody(PEER_INERTIA * (1.0 + 1e-9 * next(runs)))

    for method in ("rk4", "geometric"):
        timing = cpu_time_median(
            lambda m=method: propagate(fresh_body(), quat.identity(), PEER_OMEGA0, t, method=m), repeats
        )
        traj = propagate(body, quat.identity(), PEER_OMEGA0, t, method=method)
        out[method] = {
            "cpu_s": timing,
            "sim_s_per_cpu_s": PEER_DURATION_S / timing["median_s"],
            "engine": traj.info["engine"],
            "substeps_added": traj.info["step_rule"]["substeps_added"],
            **versus_basilisk(PEER_DURATION_S / timing["median_s"], "torquefree"),
        }
    return out


def batch(n_bodies: int = 10_000, duration_s: float = 20.0) -> dict[str, Any]:
    rng = np.random.default_rng(0)
    q0 = quat.random(n_bodies, rng=rng)
    w0 = rng.normal(scale=0.1, size=(n_bodies, 3))
    t = np.arange(0.0, duration_s + STEP_S / 2, STEP_S)
    out = {"case": f"batch of {n_bodies} bodies, 0.1 s step, torque-free", "simulated_s_per_body": duration_s}
    for method in ("rk4", "geometric"):
        timing = cpu_time_median(lambda m=method: propagate(BODY, q0, w0, t, method=m), repeats=3)
        out[method] = {
            "cpu_s": timing,
            "body_sim_s_per_cpu_s": n_bodies * duration_s / timing["median_s"],
        }
    # Robustness of the figure: a full inertia tensor (propagated in its
    # principal frame) and a 5x longer run (output every step: 560 MB).
    full = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
    timing = cpu_time_median(lambda: propagate(full, q0, w0, t, method="rk4"), repeats=3)
    out["rk4_full_tensor"] = {"cpu_s": timing, "body_sim_s_per_cpu_s": n_bodies * duration_s / timing["median_s"]}
    t_long = np.arange(0.0, 5 * duration_s + STEP_S / 2, STEP_S)
    timing = cpu_time_median(lambda: propagate(BODY, q0, w0, t_long, method="rk4"), repeats=1)
    out["rk4_100_s"] = {"cpu_s": timing, "body_sim_s_per_cpu_s": n_bodies * 5 * duration_s / timing["median_s"]}
    out["target_body_sim_s_per_cpu_s"] = 500_000
    out["memory_peak_mib"] = memory_peak_mib(lambda: propagate(BODY, q0, w0, t, method="rk4"))
    out["output_memory_mib"] = (q0.nbytes + w0.nbytes) * t.size / 2**20
    return out


def accuracy() -> dict[str, Any]:
    """Invariant drift per method over 1000 s of a tumble near the major axis."""
    tensor = np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
    body = RigidBody(tensor)
    q0 = quat.from_axis_angle([1.0, 0.0, 0.0], 0.3)
    w0 = np.array([0.05, 0.1, 0.3])
    t = np.arange(0.0, 1000.0 + STEP_S / 2, STEP_S)
    out = {}
    for method, kwargs in (("rk4", {}), ("geometric", {}), ("adaptive", {"rtol": 1e-12, "atol": 1e-14})):
        traj = propagate(body, q0, w0, t, method=method, **kwargs)
        out[method] = traj.invariant_drift() | {"wall_time_s": traj.info["wall_time_s"]}
    return {"case": "drift of energy, |H_N| and |q| over 1000 s at 0.1 s output (relative)", **out}


def run() -> dict[str, Any]:
    return {
        "single_body": single_body(),
        "one_body_methods": one_body_methods(),
        "batch": batch(),
        "invariant_drift": accuracy(),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

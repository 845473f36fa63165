"""Closed-loop speed against the compiled peer (issue: speed where users feel it).

Cases, each 600 s simulated at a 0.1 s step, CPU-time medians, with the
Basilisk case it is compared with (``benchmarks/basilisk_reference.json``,
measured on this kind of machine: Basilisk is not a dependency):

* ``plugin_mrp``: a user's plain-Python controller object, Basilisk's MRP
  feedback law ``u = -K sigma - P omega + omega x (I omega + h)`` (K = 3.5,
  P = 30) on Basilisk's ``closed`` case (I = diag(900, 800, 600) kg m^2,
  sigma0 = [0.1, 0.2, -0.3], omega0 = [0.001, -0.01, 0.03] rad/s, no wheels):
  the protocol engine (the controller in Python every tick). Peer:
  ``closed_nodelay``. Target: at least 1.0x.
* ``plugin_mrp_wheels``: the same law through three HR16-class wheels on the
  body axes (Js = 0.0796 kg m^2, 0.2 N m clipped per wheel, 50 N m s) spinning
  at 100, 200, 300 rpm, as Basilisk's ``rw`` case. Peer: ``rw_no_earth``.
  Target: at least 1.0x.
* ``builtin_pd`` and ``builtin_pd_wheels``: the built-in quaternion PD on the
  compiled path (plant, wheels and controller in casadi, no Python per tick),
  without wheels and with a four-wheel pyramid. Peers: ``closed_nodelay`` and
  ``rw_no_earth``. Target: at least 3x.

Every run builds its spacecraft and controller afresh, as Basilisk's figure
builds its simulation for every run: the body's inertia and the law's gains
are changed by a part in 10^9 from run to run, so nothing built for an
earlier run's numbers is reused (what is kept is what depends on the wheels
alone: the compiled protocol tick, the parametric hold step and allocation).
Every figure is the median of seven such runs after one warm-up run;
``first_run_cpu_s`` is that first run of the process (it builds the
parametric functions and, the first time on a machine, compiles the tick to
C), and ``same_objects_sim_s_per_cpu_s`` the same case flown again with the
same objects (the compiled path then reuses its loop).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.simulation.engine import simulate
from controllers.pd import QuaternionPD

try:
    from benchmarks._peer import versus_basilisk
    from benchmarks._timing import cpu_time_median, memory_peak_mib
except ImportError:  # run as a script from the benchmarks folder
    from _peer import versus_basilisk
    from _timing import cpu_time_median, memory_peak_mib

DURATION_S = 600.0
PEER_INERTIA = np.diag([900.0, 800.0, 600.0])
SIGMA0 = np.array([0.1, 0.2, -0.3])
OMEGA0 = np.array([0.001, -0.01, 0.03])
HR16_SPIN_INERTIA = 50.0 / (6000.0 * 2.0 * np.pi / 60.0)  # 50 N m s at 6000 rpm [kg m^2]
HR16_SPEEDS_RPM = np.array([100.0, 200.0, 300.0])

BODY = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
PYRAMID = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8, viscous_friction=2e-6)


class MRPFeedback:
    """Basilisk's ``mrpFeedback`` (no integral term) as a user writes it in plain Python.

    ``u = -K sigma - P omega + omega x (I omega + h_body)`` with ``sigma`` the
    shadow-set MRP of the attitude (the reference is the inertial frame).
    """

    period = 0.1

    def __init__(self, inertia: np.ndarray, k: float = 3.5, p: float = 30.0) -> None:
        self.inertia = np.asarray(inertia, dtype=float).tolist()
        self.k, self.p = k, p

    def torque(self, t: float, estimate: Any) -> np.ndarray:
        q0, q1, q2, q3 = estimate.q.tolist()
        w1, w2, w3 = estimate.omega.tolist()
        h1, h2, h3 = estimate.h_body.tolist()
        scale = 1.0 / (1.0 + q0) if q0 >= 0.0 else -1.0 / (1.0 - q0)  # MRP, shadow set beyond 180 deg
        (i11, i12, i13), (i21, i22, i23), (i31, i32, i33) = self.inertia
        m1 = i11 * w1 + i12 * w2 + i13 * w3 + h1
        m2 = i21 * w1 + i22 * w2 + i23 * w3 + h2
        m3 = i31 * w1 + i32 * w2 + i33 * w3 + h3
        k, p = self.k, self.p
        return np.array(
            [
                -k * q1 * scale - p * w1 + (w2 * m3 - w3 * m2),
                -k * q2 * scale - p * w2 + (w3 * m1 - w1 * m3),
                -k * q3 * scale - p * w3 + (w1 * m2 - w2 * m1),
            ]
        )


def _mrp_to_quaternion(sigma: np.ndarray) -> np.ndarray:
    s2 = float(sigma @ sigma)
    return np.concatenate([[(1.0 - s2) / (1.0 + s2)], 2.0 * sigma / (1.0 + s2)])


def _hr16_wheels() -> ReactionWheels:
    return ReactionWheels(
        np.eye(3), spin_inertia=HR16_SPIN_INERTIA, torque_max=0.2, momentum_max=50.0, torque_saturation="clip"
    )


def _case(fresh: Any, peer: str, target: float, description: str) -> dict[str, Any]:
    """Time ``fresh(i)()``: run ``i`` built afresh (module docstring), and the same objects flown again."""
    counter = iter(range(1, 10**6))

    def cold() -> Any:
        return fresh(next(counter))()

    start = time.process_time()
    cold()
    first = time.process_time() - start
    cpu = cpu_time_median(cold, repeats=7)
    same = cpu_time_median(fresh(0), repeats=7)
    rate = DURATION_S / cpu["median_s"]
    figure = {
        "case": description,
        "first_run_cpu_s": first,
        "cpu_s": cpu,
        "sim_s_per_cpu_s": rate,
        "sim_s_per_cpu_s_spread": [DURATION_S / cpu["max_s"], DURATION_S / cpu["min_s"]],
        "same_objects_sim_s_per_cpu_s": DURATION_S / same["median_s"],
    }
    figure.update(versus_basilisk(rate, peer))
    ratio = figure.get("ratio_to_basilisk")
    figure["target_ratio_to_basilisk"] = target
    figure["target_met"] = None if ratio is None else bool(ratio >= target)
    return figure


def _nudge(i: int) -> float:
    """Run ``i``'s relative change of the inertia and the gains (a part in 10^9 per run)."""
    return 1.0 + 1e-9 * i


def plugin_mrp() -> dict[str, Any]:
    def fresh(i: int) -> Any:
        inertia = PEER_INERTIA * _nudge(i)
        body, law = RigidBody(inertia), MRPFeedback(inertia, k=3.5 * _nudge(i))
        return lambda: simulate(body, _mrp_to_quaternion(SIGMA0), OMEGA0, DURATION_S, controller=law, engine="python")

    return _case(fresh, "closed_nodelay", 1.0, "a user's plain-Python MRP feedback object, no wheels")


def plugin_mrp_wheels() -> dict[str, Any]:
    h0 = HR16_SPIN_INERTIA * HR16_SPEEDS_RPM * 2.0 * np.pi / 60.0 + HR16_SPIN_INERTIA * OMEGA0

    def fresh(i: int) -> Any:
        wheels = _hr16_wheels()
        # Basilisk's balanced wheels carry no inertia of their own: the hub is diag(900, 800, 600).
        body = RigidBody(PEER_INERTIA * _nudge(i) + HR16_SPIN_INERTIA * np.eye(3))
        law = MRPFeedback(body.inertia, k=3.5 * _nudge(i))
        return lambda: simulate(
            body,
            _mrp_to_quaternion(SIGMA0),
            OMEGA0,
            DURATION_S,
            controller=law,
            wheels=wheels,
            h_wheels0=h0,
            engine="python",
        )

    return _case(fresh, "rw_no_earth", 1.0, "the same object through 3 HR16-class wheels (clipped per wheel)")


def builtin_pd(wheels: ReactionWheels | None) -> dict[str, Any]:
    target = quat.from_axis_angle([1.0, 0.5, 0.0], np.radians(30.0))

    def fresh(i: int) -> Any:
        body = RigidBody(BODY.inertia * _nudge(i))
        pd = QuaternionPD.from_bandwidth(body, wn=0.1 * _nudge(i), zeta=0.7, period=0.1, q_ref=target, gyroscopic=True)
        return lambda: simulate(
            body, quat.identity(), np.zeros(3), DURATION_S, controller=pd, wheels=wheels, engine="compiled"
        )

    what = "no wheels" if wheels is None else "a 4-wheel pyramid"
    figure = _case(fresh, "closed_nodelay" if wheels is None else "rw_no_earth", 3.0, f"built-in quaternion PD, {what}")
    figure["memory_peak_mib"] = memory_peak_mib(fresh(0))
    return figure


def run() -> dict[str, Any]:
    return {
        "plugin_mrp": plugin_mrp(),
        "plugin_mrp_wheels": plugin_mrp_wheels(),
        "builtin_pd": builtin_pd(None),
        "builtin_pd_wheels": builtin_pd(PYRAMID),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

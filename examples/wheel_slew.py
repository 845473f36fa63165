"""Minimum-time slews planned on the reaction wheels: the torque polytope and the wheel-speed limit.

A 100 kg class microsatellite (the inertia of ``design_pd_lqr.py``) slews 90
degrees with a four-wheel pyramid of 20 mN m wheels, at rest
before and after, under a 3 deg/s body-rate limit (a separate requirement).

1. Three torque models of the same wheels, minimum time on the same grid,
   about body x (where the polytope reaches twice the box) and about the
   axis of the vertex ``u = (1, 1, 1, -1) torque_max`` (where it reaches 1.5
   times the allocation envelope):
   the largest per-axis box the wheels guarantee in every direction
   (``wheel_torque_box``), the minimum-norm allocation envelope
   (``plan_slew(torque_max=wheels)``), and the wheels themselves with their
   momenta as states (``wheel_states=True``: the full torque polytope).
2. The slew about x with wheels whose speed limit (``momentum_max``) is below
   what the slew needs: the plan keeps each wheel's momentum at its limit
   and is slower; the figure shows every wheel torque and momentum against
   its limit.

Run ``python examples/wheel_slew.py --out DIR`` (``--quick`` for fewer nodes).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from attitude import ReactionWheels, RigidBody
from attitude import quaternion as quat
from controllers import plan_slew
from controllers.slew.wheel_states import wheel_torque_box

INERTIA = np.array([[12.0, 0.4, -0.3], [0.4, 10.5, 0.2], [-0.3, 0.2, 8.5]])  # kg m^2
WHEEL_TORQUE_NM = 0.02
SPIN_INERTIA = 0.005  # kg m^2
RATE_MAX_DEG_PER_S = 3.0
MOMENTUM_MAX_NMS = 0.5  # enough for this slew
MOMENTUM_TIGHT_NMS = 0.1  # below what the slew needs at the rate limit


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures/wheel_slew"), help="folder for the figures")
    parser.add_argument("--quick", action="store_true", help="fewer nodes (for the test suite)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    nodes = 30 if args.quick else 60

    body = RigidBody(INERTIA)
    wheels = ReactionWheels.pyramid(
        spin_inertia=SPIN_INERTIA, torque_max=WHEEL_TORQUE_NM, momentum_max=MOMENTUM_MAX_NMS
    )
    tight = ReactionWheels.pyramid(
        spin_inertia=SPIN_INERTIA, torque_max=WHEEL_TORQUE_NM, momentum_max=MOMENTUM_TIGHT_NMS
    )
    q0 = quat.identity()
    common = {"rate_max": np.radians(RATE_MAX_DEG_PER_S), "nodes": nodes}
    box = wheel_torque_box(wheels)
    vertex = wheels.body_torque(WHEEL_TORQUE_NM * np.array([1.0, 1.0, 1.0, -1.0]))
    reach = np.abs(wheels.distribution) @ wheels.torque_max
    print(f"4-wheel pyramid of {1e3 * WHEEL_TORQUE_NM:g} mN m, {RATE_MAX_DEG_PER_S:g} deg/s limit, 90 deg slews")
    print(
        f"body torque about x: box {1e3 * box[0]:.2f} mN m, allocation {1e3 * wheels.torque_envelope()[0]:.2f} mN m, "
        f"polytope {1e3 * reach[0]:.2f} mN m; along the vertex u = (+, +, +, -): box corner and polytope "
        f"{1e3 * np.linalg.norm(vertex):.2f} mN m, allocation 2/3 of it"
    )
    print(f"{nodes}-node grids, no refinement (the wheel-state plan has none): like against like")
    print(
        "   slew axis   plan                                time [s]   peak rate [deg/s]   peak wheel momentum / limit"
    )
    plans = {}
    for axis_name, axis in (("x", np.array([1.0, 0.0, 0.0])), ("vertex", vertex / np.linalg.norm(vertex))):
        qf = quat.from_axis_angle(axis, np.radians(90.0))
        cases = {
            "box inside the polytope": {"torque_max": box, "refine": False},
            "allocation envelope": {"torque_max": wheels, "refine": False},
            "wheel states (polytope)": {"torque_max": wheels, "wheel_states": True},
        }
        if axis_name == "x":
            cases[f"wheel states, {1e3 * MOMENTUM_TIGHT_NMS:g} mN m s wheels"] = {
                "torque_max": tight,
                "wheel_states": True,
            }
        for name, kw in cases.items():
            plan = plan_slew(body, q0, qf, **kw, **common)
            plans[axis_name, name] = plan
            ratio = plan.info["verification"].get("momentum_ratio_max")
            words = "(not planned)" if ratio is None else f"{ratio:.3f}"
            print(f"   {axis_name:10s}  {name:35s} {plan.duration:9.2f}   {np.degrees(plan.rate_peak):17.3f}   {words}")
    limited = plans["x", f"wheel states, {1e3 * MOMENTUM_TIGHT_NMS:g} mN m s wheels"]
    check = limited.info["verification"]
    print(
        f"   momentum-limited plan re-simulated (scipy DOP853 on the wheel model): final error "
        f"{np.degrees(check['final_attitude_error']):.1e} deg, torque/limit {check['torque_ratio_max']:.6f}, "
        f"momentum/limit {check['momentum_ratio_max']:.6f}, "
        f"total momentum drift {check['angular_momentum_drift']:.1e} N m s"
    )
    plans["vertex", "wheel states (polytope)"].plot_wheels().savefig(args.out / "wheel_states_polytope.png", dpi=110)
    limited.plot_wheels().savefig(args.out / "wheel_states_momentum_limited.png", dpi=110)
    limited.plot().savefig(args.out / "wheel_states_momentum_limited_plan.png", dpi=110)
    print(f"\nfigures in {args.out}; done in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()

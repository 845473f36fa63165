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

Figures: the angle to go and the body torque along the slew axis of every
plan (``wheel_states_against_box_and_allocation.png``), and the wheel
torques and momenta against their limits of the polytope plan and of the
momentum-limited plan.

Run ``python examples/wheel_slew.py --out DIR`` (``--quick`` for fewer nodes).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from attitude import ReactionWheels, RigidBody
from attitude import quaternion as quat
from controllers import SlewPlan, plan_slew
from controllers.slew.reference import axis_angle
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
    comparison_figure(plans).savefig(args.out / "wheel_states_against_box_and_allocation.png", dpi=110)
    plans["vertex", "wheel states (polytope)"].plot_wheels().savefig(args.out / "wheel_states_polytope.png", dpi=110)
    limited.plot_wheels().savefig(args.out / "wheel_states_momentum_limited.png", dpi=110)
    limited.plot().savefig(args.out / "wheel_states_momentum_limited_plan.png", dpi=110)
    print(f"\nfigures in {args.out}; done in {time.perf_counter() - start:.1f} s")


def comparison_figure(plans: dict[tuple[str, str], SlewPlan]) -> Figure:
    """Angle to go and body torque along the slew axis of each plan, one panel per slew axis."""
    axes_names = sorted({axis for axis, _ in plans}, key=["x", "vertex"].index)
    fig = Figure(figsize=(11, 6.5), layout="constrained")
    ax = fig.subplots(2, len(axes_names), sharex="col", squeeze=False)
    # Wider lines under narrower ones: plans that coincide (the polytope reaches the allocation about x and the
    # box about the vertex axis) stay visible.
    styles = {"box": ("tab:gray", 4.0), "allocation": ("tab:orange", 2.6), "polytope": ("tab:blue", 1.3)}
    for col, axis_name in enumerate(axes_names):
        for (name_axis, name), plan in plans.items():
            if name_axis != axis_name:
                continue
            key = next((k for k in styles if k in name), None)
            color, width = styles[key] if key is not None and "mN m s" not in name else ("tab:red", 1.3)
            ls = "--" if "mN m s" in name else "-"
            fine = plan.resample(plan.duration / 400.0)
            to_go = np.degrees(quat.error_angle(plan.q_target, quat.normalize(fine.q)))
            label = f"{name}: {plan.duration:.1f} s"
            ax[0, col].plot(fine.t, to_go, color=color, ls=ls, lw=width, label=label)
            axis, _ = axis_angle(plan.q[0], plan.q_target)
            ax[1, col].step(plan.t, 1e3 * plan.torque @ axis, where="post", color=color, ls=ls, lw=width, label=name)
        ax[0, col].set_title(f"90 deg about {'body x' if axis_name == 'x' else 'the vertex (+, +, +, -) axis'}")
        ax[0, col].set_ylabel("angle to go [deg]")
        ax[1, col].set_ylabel("body torque along the slew axis [mN m]")
        ax[1, col].set_xlabel("time [s]")
        ax[0, col].legend(fontsize="small")
        for a in ax[:, col]:
            a.grid(True, alpha=0.3)
    fig.suptitle("minimum-time slews of one wheel set under three torque models (same grid, no refinement)")
    return fig


if __name__ == "__main__":
    main()

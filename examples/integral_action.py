"""Integral action and anti-windup: PD vs PID vs PID with back-calculation, on the nonlinear plant.

The spacecraft and wheels are those of ``design_pd_lqr.py`` (a 100 kg class
microsatellite, four 0.02 N m pyramid wheels, a 10 Hz controller). The
script shows the two sides of integral action:

1. **A constant disturbance torque.** The quaternion PD holds the target
   with the steady error ``2 asin|K^-1 tau_d|`` (about ``|tau_d| / (J wn^2)``);
   the PID, placed at ``(s + a)(s^2 + 2 zeta wn s + wn^2)`` per axis, removes
   it at the rate of its slowest pole ``a``; the LQI does the same.
2. **A 60 degree slew that saturates the wheels.** The plain integral winds
   up over the long saturated stretch and overshoots far past the target; the
   back-calculation anti-windup (and, less well, clamping) keeps the overshoot
   at the level of the PD part alone.

It prints the margins of the sampled PID loop (the integrator makes the loop
type 3: a lower gain margin appears) and saves the figures.

Run ``python examples/integral_action.py --out DIR`` (``--quick`` for a short run).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import scipy.linalg

from attitude import ReactionWheels, RigidBody, simulate
from attitude import quaternion as quat
from attitude.linearize import linearize
from controllers import (
    LQIController,
    QuaternionPID,
    bryson_weights,
    design_lqi,
    loop_gain,
    margins,
    plot_bode,
)

INERTIA = np.array([[12.0, 0.4, -0.3], [0.4, 10.5, 0.2], [-0.3, 0.2, 8.5]])  # kg m^2
PERIOD_S = 0.1  # 10 Hz controller
WN_RAD_PER_S = 0.2
ZETA = 0.8
INTEGRAL_POLE_RAD_PER_S = WN_RAD_PER_S / 4.0
DISTURBANCE_NM = np.array([2e-5, -1.5e-5, 1e-5])  # constant, body axes
SLEW_DEG = 60.0
ARCSEC_PER_RAD = 180.0 / np.pi * 3600.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures/integral_action"), help="folder for the figures")
    parser.add_argument("--quick", action="store_true", help="shorter simulations (for the test suite)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()

    body = RigidBody(INERTIA)
    # No wheel friction here: its torque grows with the wheel speed the disturbance builds up (a ramp), which
    # would blur the constant-torque comparison (one integrator leaves a ramp a constant error).
    wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.02, momentum_max=0.5)

    def pid(anti_windup: str, **kwargs) -> QuaternionPID:
        return QuaternionPID.from_bandwidth(
            body,
            wn=WN_RAD_PER_S,
            zeta=ZETA,
            integral_pole=INTEGRAL_POLE_RAD_PER_S,
            period=PERIOD_S,
            anti_windup=anti_windup,
            wheels=None if anti_windup == "none" else wheels,
            **kwargs,
        )

    # 1. The linear loop ---------------------------------------------------------------------
    design = pid("back_calculation")
    print(
        f"PID placed at (s + {INTEGRAL_POLE_RAD_PER_S:g})(s^2 + 2 {ZETA:g} {WN_RAD_PER_S:g} s + "
        f"{WN_RAD_PER_S:g}^2) per axis; back-calculation tracking time {design.tracking_time:.2f} s"
    )
    loops = loop_gain(body, design)  # the sampled loop that flies (10 Hz zero-order hold)
    for name, loop in zip("xyz", loops):
        m = margins(loop)
        print(f"   {name}: {m.summary()}; lower gain margin {m.gain_margin_lower_db:.1f} dB")
    fig = plot_bode(loops, labels=[f"{a} axis" for a in "xyz"])
    fig.suptitle("Quaternion PID: loop gain broken at the plant input, sampled at 10 Hz (type 3 loop)", fontsize=11)
    fig.savefig(args.out / "pid_bode.png", dpi=110)

    # 2. Constant disturbance torque: hold the target -----------------------------------------
    hold_s = 200.0 if args.quick else 400.0
    pd = design.pd
    q_lqi, r_lqi = bryson_weights(angle_max=np.radians(2.0), rate_max=np.radians(0.5), torque_max=0.015)
    lqi = LQIController(
        design_lqi(linearize(body), Q=scipy.linalg.block_diag(q_lqi, 0.01 * q_lqi[:3, :3]), R=r_lqi, period=PERIOD_S),
        wheels=wheels,
    )
    holds = {
        "PD": pd,
        "PID (back-calculation)": design,
        "LQI (back-calculation)": lqi,
    }
    pd_error = 2.0 * np.arcsin(np.linalg.norm(np.linalg.solve(pd.K, DISTURBANCE_NM)))
    fig, ax = plt.subplots(figsize=(9, 5))
    print(f"\nHold against a constant torque {1e6 * DISTURBANCE_NM} uN m, pyramid wheels:")
    for name, ctrl in holds.items():
        run = simulate(
            body, quat.identity(), np.zeros(3), hold_s, controller=ctrl, wheels=wheels, disturbance=DISTURBANCE_NM
        )
        error = np.maximum(run.error_angle * ARCSEC_PER_RAD, 1e-9)
        ax.semilogy(run.t, error, label=name)
        print(f"   {name:24s} final error {error[-1]:.3g} arcsec")
    print(f"   PD analytic steady error 2 asin|K^-1 tau_d| = {pd_error * ARCSEC_PER_RAD:.3g} arcsec")
    ax.axhline(pd_error * ARCSEC_PER_RAD, color="0.6", lw=5, alpha=0.5, zorder=0, label="PD analytic steady error")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("error angle [arcsec]")
    ax.set_ylim(1e-6, 1e2)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    ax.set_title(
        f"Holding the target against a constant torque {np.round(1e6 * DISTURBANCE_NM, 1)} uN m "
        "(pyramid wheels, no friction)\n"
        f"PID removes the PD's steady error at the rate of its integral pole a = {INTEGRAL_POLE_RAD_PER_S:g} rad/s"
    )
    fig.tight_layout()
    fig.savefig(args.out / "disturbance_hold.png", dpi=110)

    # 3. A slew that saturates the wheels -------------------------------------------------------
    axis = np.array([1.0, 1.0, 0.5]) / np.linalg.norm([1.0, 1.0, 0.5])
    target = quat.from_axis_angle(axis, np.radians(SLEW_DEG))
    slew_s = 250.0 if args.quick else 400.0
    slews = {
        "PD part alone": pid("back_calculation", q_ref=target).pd,
        "PID, no anti-windup": pid("none", q_ref=target),
        "PID, clamping": pid("clamping", q_ref=target),
        "PID, back-calculation": pid("back_calculation", q_ref=target),
    }
    fig, (ax_angle, ax_torque) = plt.subplots(2, 1, figsize=(10, 8), sharex=True)
    print(f"\n{SLEW_DEG:g} deg slew, pyramid wheels saturated at 0.02 N m each:")
    for name, ctrl in slews.items():
        run = simulate(body, quat.identity(), np.zeros(3), slew_s, controller=ctrl, wheels=wheels, substeps=2)
        e = quat.error_quaternion(target, run.q)
        signed_deg = np.degrees(2.0 * np.arctan2(e[:, 1:] @ axis, e[:, 0]))  # < 0 before the target
        overshoot = max(0.0, float(np.max(signed_deg))) / SLEW_DEG
        saturated_s = np.sum(np.max(np.abs(run.torque_command - run.torque_applied), axis=1) > 1e-9) * PERIOD_S
        print(
            f"   {name:24s} overshoot {100 * overshoot:6.1f} %, saturated {saturated_s:5.1f} s, "
            f"final error {np.degrees(run.error_angle[-1]):.2e} deg"
        )
        ax_angle.plot(run.t, signed_deg, label=f"{name} (overshoot {100 * overshoot:.0f} %)")
        ax_torque.plot(run.t, 1e3 * np.linalg.norm(run.torque_applied, axis=1), label=name)
    ax_angle.axhline(0.0, color="k", lw=0.8)
    ax_angle.set_ylabel("angle past the target, along the slew axis [deg]")
    ax_angle.grid(True, alpha=0.3)
    ax_angle.legend(fontsize=9)
    ax_angle.set_title(f"{SLEW_DEG:g} deg slew with saturating pyramid wheels (0.02 N m each), 10 Hz PID")
    ax_torque.set_ylabel("|applied torque| [mN m]")
    ax_torque.set_xlabel("time [s]")
    ax_torque.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(args.out / "saturating_slew.png", dpi=110)
    print(f"\nfigures in {args.out}; done in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()

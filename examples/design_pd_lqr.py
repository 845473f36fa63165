"""Controller design script: linearise, design PD and LQR, read margins, prove it nonlinear.

The spacecraft is a 100 kg class microsatellite (illustrative figures of that
class: about 0.6 x 0.6 x 0.8 m, principal moments 8-12 kg m^2 with small
products of inertia from an off-centre payload) with four small reaction
wheels in a pyramid (0.02 N m, 0.5 N m s each: the class of commercially
available 0.5 N m s microsatellite wheels) and a 10 Hz attitude controller.

The script walks the designer's path:

1. linear model at rest (exact Jacobian of the one definition of the
   dynamics), checked against python-control's finite-difference linearisation;
2. quaternion-feedback PD from natural frequency and damping: the closed-loop
   poles show the designed ``wn`` and ``zeta`` (``q_v`` is half the angle);
3. loop gain broken at the plant input per axis: gain, phase and delay
   margins from python-control, checked by an independent frequency sweep,
   and what the 10 Hz zero-order hold and a 20 ms computation delay cost;
4. discrete LQR at the controller sample time with Bryson's rule;
5. the nonlinear proof: a 60 degree slew with the rate-limited (Wie-Lu) PD on
   the full plant with wheel torque and momentum limits, and the LQR holding
   the target against a small disturbance.

Run ``python examples/design_pd_lqr.py --out DIR`` (``--quick`` for a short run).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from attitude import ReactionWheels, RigidBody, simulate
from attitude import quaternion as quat
from attitude.linearize import linearize
from controllers import (
    LQRController,
    QuaternionPD,
    RateLimitedPD,
    attitude_closed_loop,
    bryson_weights,
    design_lqr,
    loop_gain,
    margins,
    plot_bode,
    plot_step,
    sample_time_study,
)
from controllers.analysis import sweep_margins

INERTIA = np.array([[12.0, 0.4, -0.3], [0.4, 10.5, 0.2], [-0.3, 0.2, 8.5]])  # kg m^2
PERIOD_S = 0.1  # 10 Hz controller
WN_RAD_PER_S = 0.2  # PD natural frequency per axis
ZETA = 0.8
RATE_MAX_DEG_PER_S = 1.0
COMPUTATION_DELAY_S = 0.02


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures/design_pd_lqr"), help="folder for the figures")
    parser.add_argument("--quick", action="store_true", help="shorter simulations (for the test suite)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()

    body = RigidBody(INERTIA)
    wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.02, momentum_max=0.5, viscous_friction=1e-6)
    print(f"Spacecraft: principal moments {np.round(body.principal_axes().moments, 3)} kg m^2")
    print(f"Wheels: 4-wheel pyramid, body torque envelope {np.round(1e3 * wheels.torque_envelope(), 2)} mN m per axis")

    # 1. Linear model ------------------------------------------------------------
    plant = linearize(body)
    plant_fd = linearize(body, method="finite-difference")
    print("\n1. Linear model at rest (6 states: q_e,v and omega)")
    print(f"   exact vs one-sided finite differences: max |dA| = {np.max(np.abs(plant.A - plant_fd.A)):.1e}")

    # 2. PD from wn and zeta --------------------------------------------------------
    pd = QuaternionPD.from_bandwidth(body, wn=WN_RAD_PER_S, zeta=ZETA, period=PERIOD_S, gyroscopic=True)
    closed = attitude_closed_loop(body, pd)
    poles = np.linalg.eigvals(closed.A)
    wn_cl = np.abs(poles)
    zeta_cl = -poles.real / wn_cl
    print("\n2. Quaternion PD from wn = 0.2 rad/s, zeta = 0.8 (K = 2 I wn^2, C = 2 I zeta wn)")
    print(f"   closed-loop wn   {np.round(np.unique(np.round(wn_cl, 9)), 6)} rad/s")
    print(f"   closed-loop zeta {np.round(np.unique(np.round(zeta_cl, 9)), 6)}")
    fig = plot_step(closed)
    fig.savefig(args.out / "pd_step.png", dpi=110)

    # 3. Margins per axis -------------------------------------------------------------
    loops = loop_gain(body, pd, sampled=False)
    print("\n3. Loop gain broken at the plant input, per axis (continuous, asked for: sampled=False)")
    print("   axis   GM [dB]   PM [deg]   delay margin [s]   crossover [rad/s]   (independent sweep: PM, wc)")
    for name, loop in zip("xyz", loops):
        m = margins(loop)
        s = sweep_margins(loop)
        print(
            f"   {name}      {m.gain_margin_db:7.2f}   {m.phase_margin_deg:8.3f}   {m.delay_margin_s:16.3f}"
            f"   {m.gain_crossover:17.4f}   ({s.phase_margin_deg:.3f} deg, {s.gain_crossover:.4f} rad/s)"
        )
    study = sample_time_study(loops[0], periods=[0.05, 0.1, 0.2, 0.5], computation_delay=COMPUTATION_DELAY_S)
    print(f"   x axis sampled with a {1e3 * COMPUTATION_DELAY_S:.0f} ms computation delay:")
    for period, pm, pm_pred, gm in zip(
        study.period, study.phase_margin_deg, study.predicted_phase_margin_deg, study.gain_margin
    ):
        print(
            f"     T = {period:4.2f} s: PM {pm:7.3f} deg (classical estimate {pm_pred:7.3f}), "
            f"GM {20 * np.log10(gm):6.2f} dB"
        )
    plot_bode(loops).savefig(args.out / "pd_bode.png", dpi=110)
    # The loop that flies (every axis held by the 10 Hz ZOH), plus a 20 ms computation delay.
    sampled = loop_gain(body, pd, computation_delay=COMPUTATION_DELAY_S)
    plot_bode(sampled, labels=[f"{a} axis, 10 Hz ZOH + 20 ms delay" for a in "xyz"]).savefig(
        args.out / "pd_bode_sampled.png", dpi=110
    )
    study.plot().savefig(args.out / "pd_sample_time_study.png", dpi=110)

    # 4. Discrete LQR (Bryson) ---------------------------------------------------------
    q_w, r_w = bryson_weights(angle_max=np.radians(2.0), rate_max=np.radians(0.5), torque_max=0.015)
    lqr = design_lqr(plant, Q=q_w, R=r_w, period=PERIOD_S)
    print("\n4. Discrete LQR at 10 Hz, Bryson: 2 deg, 0.5 deg/s, 15 mN m")
    s_poles = lqr.s_poles
    print(f"   closed-loop poles (s-plane equivalents): {np.round(np.sort_complex(s_poles), 4)}")
    lqr_loops = loop_gain(plant, lqr)  # sampled at the design's period: the loop that flies
    for name, loop in zip("xyz", lqr_loops):
        print(f"   {name}: {margins(loop).summary()}")
    fig = plot_bode(lqr_loops, labels=[f"{a} axis" for a in "xyz"])
    fig.suptitle(
        "Discrete LQR (10 Hz, Bryson: 2 deg, 0.5 deg/s, 15 mN m): loop gain broken at the plant input, "
        "sampled loop (zero-order hold at 10 Hz)",
        fontsize=11,
    )
    fig.savefig(args.out / "lqr_bode.png", dpi=110)

    # 5. Nonlinear proof ------------------------------------------------------------------
    target = quat.from_axis_angle([1.0, 1.0, 0.5], np.radians(60.0))
    slew_ctrl = RateLimitedPD.from_bandwidth(
        body, wn=WN_RAD_PER_S, zeta=ZETA, rate_max=np.radians(RATE_MAX_DEG_PER_S), period=PERIOD_S, q_ref=target
    )
    duration = 120.0 if args.quick else 200.0
    slew = simulate(body, quat.identity(), np.zeros(3), duration, controller=slew_ctrl, wheels=wheels)
    rate_peak = np.degrees(np.max(np.linalg.norm(slew.omega, axis=1)))
    h = slew.momentum_N
    print("\n5. Nonlinear 60 deg slew, Wie-Lu PD (1 deg/s limit), pyramid wheels")
    print(f"   peak body rate {rate_peak:.4f} deg/s (limit {RATE_MAX_DEG_PER_S})")
    print(
        f"   settling (0.05 deg) at {slew.settling_time(np.radians(0.05)):.1f} s, final error "
        f"{np.degrees(slew.error_angle[-1]):.2e} deg"
    )
    print(
        f"   peak wheel speed {np.max(np.abs(slew.wheel_speed)) * 30 / np.pi:.0f} rpm, "
        f"total momentum conserved to {np.max(np.linalg.norm(h - h[0], axis=1)):.1e} N m s"
    )
    print(f"   {slew.info['engine']} engine: {duration / slew.info['wall_time_s']:.0f} simulated s per s")
    fig = slew.plot()
    fig.suptitle(
        f"60 deg slew with the rate-limited (Wie-Lu) PD (wn {WN_RAD_PER_S:g} rad/s, zeta {ZETA:g}, "
        f"{RATE_MAX_DEG_PER_S:g} deg/s), no disturbance;\npyramid wheels with limits, {slew.info['engine']} engine, "
        f"dt = {slew.info['dt']:g} s"
    )
    fig.savefig(args.out / "nonlinear_slew.png", dpi=110)

    disturbance_Nm = np.array([2e-5, -1e-5, 1e-5])  # constant, body axes
    omega0 = np.radians([0.05, -0.03, 0.02])
    hold = simulate(
        body,
        target,
        omega0,
        60.0 if args.quick else 120.0,
        controller=LQRController(lqr, q_ref=target),
        wheels=wheels,
        disturbance=disturbance_Nm,
    )
    torque_text = f"[{', '.join(f'{1e6 * x:g}' for x in disturbance_Nm)}] uN m"
    print(
        f"   LQR hold under a constant body torque {torque_text}: final error "
        f"{np.degrees(hold.error_angle[-1]) * 3600:.2f} arcsec"
    )
    fig = hold.plot()
    fig.suptitle(
        f"Discrete LQR (10 Hz, Bryson) holding the slew's target against a constant body torque {torque_text},\n"
        f"from an initial rate of {np.degrees(np.linalg.norm(omega0)):.3g} deg/s; pyramid wheels with limits, "
        f"{hold.info['engine']} engine, dt = {hold.info['dt']:g} s"
    )
    fig.savefig(args.out / "lqr_hold.png", dpi=110)
    print(f"\nfigures in {args.out}; done in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()

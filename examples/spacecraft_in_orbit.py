"""Fly a spacecraft in its orbit: disturbance torques, momentum build-up, magnetic unloading and detumbling.

The spacecraft is a 12U-class CubeSat (illustrative: 0.23 x 0.24 x 0.34 m,
principal moments 0.2-0.35 kg m^2) on a 500 km sun-synchronous orbit, with
four small wheels in a pyramid and three 0.2 A m^2 torque rods. The script
walks the designer's path:

1. the environment: orbit, Sun and Earth shadow, IGRF field, exponential
   atmosphere, and a surface model of flat plates with a centre-of-pressure
   offset and a residual dipole;
2. the disturbance torques per source over one orbit on the nadir (LVLH)
   attitude, and the wheel momentum a perfect attitude control would store
   over several orbits, without dumping and under cross-product unloading
   (:func:`attitude.environment.held_attitude_momentum`);
3. the closed loop that proves it: nadir pointing with the wheels, the rods
   running the cross-product unloading law beside the wheel controller, all
   four torques flown (:func:`attitude.simulate` with ``environment=``,
   ``magnetorquers=``, ``dipole_controller=``), compared with the budget;
4. detumbling after separation: B-dot on the magnetometer's samples with the
   literature gain (:func:`controllers.bdot_gain`), the rods saturating.

Run ``python examples/spacecraft_in_orbit.py --out DIR`` (``--quick`` for a short run).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from attitude import ReactionWheels, RigidBody, simulate
from attitude.actuators import Magnetorquers
from attitude.environment import CircularOrbit, OrbitEnvironment, SurfaceModel, held_attitude_momentum
from attitude.sensors import Magnetometer
from controllers import BDotController, CrossProductUnloading, NadirPointing, bdot_gain

INERTIA = np.array([[0.30, 0.004, -0.002], [0.004, 0.35, 0.003], [-0.002, 0.003, 0.21]])  # kg m^2
ALTITUDE_M = 500e3
INCLINATION_DEG = 97.4  # sun-synchronous at 500 km
DIPOLE_MAX_AM2 = 0.2
UNLOADING_GAIN_PER_S = 5e-4  # excess momentum across the field decays with 1/k = 2000 s
TIP_OFF_DEG_PER_S = np.array([4.0, -3.0, 5.0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures/spacecraft_in_orbit"), help="folder for the figures")
    parser.add_argument("--quick", action="store_true", help="shorter runs (for the test suite)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()

    # 1. The environment.
    body = RigidBody(INERTIA)
    orbit = CircularOrbit.from_altitude(ALTITUDE_M, inclination=np.radians(INCLINATION_DEG))
    surface = SurfaceModel.box(
        [0.23, 0.24, 0.34],
        specular=0.1,
        diffuse=0.4,
        centre_of_pressure_offset_B_m=[0.005, 0.01, 0.015],
        residual_dipole_Am2=[0.002, -0.001, 0.003],
    )
    env = OrbitEnvironment(orbit, surface=surface)
    print(f"orbit: {orbit.describe()}")
    print(f"environment: {env.describe()}")

    # 2. Torques over one orbit on the nadir attitude, and the momentum budget.
    t1 = np.arange(0.0, orbit.period, 10.0)
    torques = env.torques_B(body, orbit.q_LN(t1), env.track(t1))
    for source, tau in torques.items():
        print(f"  {source:<17} peak {1e6 * np.linalg.norm(tau, axis=1).max():8.4f} uN m")
    orbits = 2 if args.quick else 10
    t = np.arange(0.0, orbits * orbit.period, 10.0)
    q_ref, omega_ref = orbit.q_LN(t), orbit.omega_LN_L(t)
    free = held_attitude_momentum(env, body, t, q_ref, omega_ref)
    rods = Magnetorquers.orthogonal(dipole_max_Am2=DIPOLE_MAX_AM2)
    unloading = CrossProductUnloading(UNLOADING_GAIN_PER_S, period=1.0, magnetorquers=rods, use_truth_field=True)

    def law(field_B: np.ndarray, h_B: np.ndarray) -> np.ndarray:
        return np.array([float(v) for v in unloading.dipole_components(list(field_B), list(h_B), [0.0, 0.0, 0.0])])

    dumped = held_attitude_momentum(env, body, t, q_ref, omega_ref, dipole_law=law)
    # In the inertial frame: the body components across the orbit normal turn with a nadir-pointing body.
    per_orbit = 1e6 * free.secular_rate_N * orbit.period
    print(f"budget over {orbits} orbits: secular build-up {np.round(per_orbit, 1)} uN m s per orbit (inertial)")
    print(f"  peak |h| without dumping {1e3 * free.peak_B:.3f} mN m s, with unloading {1e3 * dumped.peak_B:.3f}")

    # 3. The closed loop: nadir pointing, wheels, rods unloading beside it, all four torques.
    wheels = ReactionWheels.pyramid(spin_inertia=2e-5, torque_max=2e-3, momentum_max=0.02)
    pointing = NadirPointing(orbit, body, wn=0.1, zeta=0.8, period=0.1)
    loop_unloading = CrossProductUnloading(UNLOADING_GAIN_PER_S, period=0.1, magnetorquers=rods, use_truth_field=True)
    span = orbit.period if args.quick else 2 * orbit.period
    flown = simulate(
        body,
        orbit.q_LN(0.0),
        orbit.omega_LN_L(0.0),
        round(span / 0.1) * 0.1,
        controller=pointing,
        wheels=wheels,
        environment=env,
        magnetorquers=rods,
        dipole_controller=loop_unloading,
    )
    fig = flown.plot()
    fig.savefig(args.out / "nadir_closed_loop.png", dpi=110)
    error = np.degrees(flown.error_angle[flown.t > 600.0])
    print(f"closed loop ({flown.info['engine']} engine): pointing error after 600 s <= {error.max():.2e} deg")

    # The closed loop stores the momentum the budget predicts (the pointing error is tiny).
    # Wheel momentum relative to the body, in body axes: sum J_i Omega_i a_i.
    h_flown = (flown.wheel_speed[::100] * wheels.spin_inertia) @ wheels.axes_B
    t_flown = flown.t[::100]
    budget = held_attitude_momentum(
        env, body, t_flown, flown.q[::100], flown.omega[::100], h_wheels0_B=h_flown[0], dipole_law=law
    )

    from matplotlib.figure import Figure

    cmp = Figure(figsize=(9, 4), layout="constrained")
    ax = cmp.subplots()
    for i, name in enumerate("xyz"):
        ax.plot(t_flown / orbit.period, 1e3 * h_flown[:, i], label=f"flown h_{name}")
        ax.plot(t_flown / orbit.period, 1e3 * budget.h_wheels_B[:, i], "k:", lw=1)
    ax.set_xlabel("time [orbits]")
    ax.set_ylabel("wheel momentum, body axes [mN m s]")
    ax.set_title("Flown wheel momentum (solid) and the held-attitude budget on the flown attitude (dotted)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    cmp.savefig(args.out / "momentum_flown_vs_budget.png", dpi=110)

    # 4. Detumbling with B-dot on the magnetometer.
    magnetometer = Magnetometer.from_datasheet(noise_nT=20.0, period=1.0, bias_nT=[200.0, -150.0, 100.0])
    bdot = BDotController(bdot_gain(orbit, body), period=1.0, magnetorquers=rods)
    detumble_orbits = 1 if args.quick else 5
    detumble = simulate(
        body,
        [1.0, 0.0, 0.0, 0.0],
        np.radians(TIP_OFF_DEG_PER_S),
        round(detumble_orbits * orbit.period),
        sensors=[magnetometer],
        environment=env,
        magnetorquers=rods,
        dipole_controller=bdot,
        dt=1.0,
        rng=1,
    )
    rate = np.degrees(np.linalg.norm(detumble.omega, axis=1))
    print(f"detumbling (gain {bdot_gain(orbit, body):.3g} N m s): {rate[0]:.2f} -> {rate[-1]:.2f} deg/s "
          f"in {detumble_orbits} orbits")  # fmt: skip
    fig = Figure(figsize=(9, 4), layout="constrained")
    ax = fig.subplots()
    for i, name in enumerate("xyz"):
        ax.plot(detumble.t / orbit.period, np.degrees(detumble.omega[:, i]), lw=0.7, label=f"omega_{name}")
    ax.plot(detumble.t / orbit.period, rate, "k", label="|omega|")
    ax.set_xlabel("time [orbits]")
    ax.set_ylabel("body rate [deg/s]")
    ax.set_title("B-dot detumbling (magnetometer samples, IGRF, 0.2 A m^2 rods)")
    ax.grid(True, alpha=0.3)
    ax.legend(ncols=4)
    fig.savefig(args.out / "detumbling.png", dpi=110)
    print(f"figures in {args.out}/ ({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()

"""Fly a mode sequence: B-dot detumbling, Sun acquisition on the wheels, then nadir pointing.

The 12U-class CubeSat of ``spacecraft_in_orbit.py`` (0.2-0.35 kg m^2, four
small wheels in a pyramid, three 0.2 A m^2 torque rods) separates on a
500 km sun-synchronous orbit tumbling at about 3 deg/s. A
:class:`controllers.modes.ModeSequence` flies it through

1. **detumble** -- B-dot on the magnetometer's samples, wheels idle, until
   the body rate stays below 0.3 deg/s for 60 s;
2. **sun acquisition** -- the +z face (the solar array) to the Sun, +y
   towards the orbit normal, on the wheels (:class:`controllers.guidance.SunReference`
   and :class:`controllers.guidance.GuidanceController`), until the array is
   within 2 deg of the Sun for 120 s (in eclipse the reference holds the
   Sun's direction all the same);
3. **nadir** -- the LVLH frame (:class:`controllers.guidance.NadirReference`),
   to the end.

The controllers see the truth (no estimator: the point is the sequencing).
The script prints the timeline (when each mode was entered and why it was
left) and saves ``mode_timeline.png``: the modes, the body rate and the
error to each mode's reference.

Run ``python examples/mode_sequence.py --out DIR`` (``--quick`` for a short run).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from attitude import ReactionWheels, RigidBody, simulate
from attitude.actuators import Magnetorquers
from attitude.environment import CircularOrbit, OrbitEnvironment, SurfaceModel
from attitude.sensors import Magnetometer
from controllers import BDotController, bdot_gain
from controllers.guidance import GuidanceController, NadirReference, SunReference
from controllers.modes import Mode, ModeSequence, PointingWithin, RateBelow

INERTIA = np.array([[0.30, 0.004, -0.002], [0.004, 0.35, 0.003], [-0.002, 0.003, 0.21]])  # kg m^2
ALTITUDE_M = 500e3
INCLINATION_DEG = 97.4  # sun-synchronous at 500 km
TIP_OFF_DEG_PER_S = np.array([1.5, -1.0, 2.5])
PERIOD_S = 1.0  # every law samples at 1 Hz; the pointing bandwidth is 0.05 rad/s, far below it


def build(orbit: CircularOrbit, body: RigidBody, rods: Magnetorquers) -> ModeSequence:
    """The three modes, their laws and the conditions to leave them."""
    bdot = BDotController(bdot_gain(orbit, body), period=PERIOD_S, magnetorquers=rods)
    sun = SunReference(orbit, primary_axis_B=[0.0, 0.0, 1.0], secondary_axis_B=[0.0, 1.0, 0.0])
    nadir = NadirReference(orbit)
    gains = {"wn": 0.05, "zeta": 0.9, "period": PERIOD_S}
    return ModeSequence(
        [
            Mode("detumble", dipole_controller=bdot, until=RateBelow(np.radians(0.3), hold_s=60.0)),
            Mode("sun acquisition", controller=GuidanceController(sun, body, **gains),
                 until=PointingWithin(np.radians(2.0), hold_s=120.0), timeout_s=3000.0),
            Mode("nadir", controller=GuidanceController(nadir, body, **gains)),
        ],
        period=PERIOD_S,
    )  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures/mode_sequence"), help="folder for the figures")
    parser.add_argument("--quick", action="store_true", help="a shorter run (for the test suite)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()

    body = RigidBody(INERTIA)
    orbit = CircularOrbit.from_altitude(ALTITUDE_M, inclination=np.radians(INCLINATION_DEG))
    surface = SurfaceModel.box(
        [0.23, 0.24, 0.34],
        specular=0.1,
        diffuse=0.4,
        centre_of_pressure_offset_B_m=[0.005, 0.01, 0.015],
        residual_dipole_Am2=[0.002, -0.001, 0.003],
    )
    environment = OrbitEnvironment(orbit, surface=surface)  # IGRF, shadow and the four disturbance torques
    rods = Magnetorquers.orthogonal(dipole_max_Am2=0.2)
    wheels = ReactionWheels.pyramid(spin_inertia=2e-5, torque_max=2e-3, momentum_max=0.02)
    magnetometer = Magnetometer.from_datasheet(noise_nT=20.0, period=PERIOD_S, bias_nT=[200.0, -150.0, 100.0])
    sequence = build(orbit, body, rods)
    duration = 4000.0 if args.quick else 2.0 * orbit.period
    run = simulate(
        body,
        [1.0, 0.0, 0.0, 0.0],
        np.radians(TIP_OFF_DEG_PER_S),
        round(duration),
        controller=sequence,
        dipole_controller=sequence.dipole_law,
        wheels=wheels,
        magnetorquers=rods,
        sensors=[magnetometer],
        environment=environment,
        dt=PERIOD_S,
        substeps=8,  # the tip-off at 1 s ticks over two orbits: 8 RK4 steps per tick meet the step-size rule
        rng=1,
    )
    print(f"{sequence!r} flown for {run.t[-1]:.0f} s ({run.info['engine']} engine)")
    for row in sequence.timeline(run.t[-1]):
        left = row["left_because"] or "(still active at the end)"
        print(f"  {row['mode']:<16} {row['start_s']:7.0f} s -> {row['end_s']:7.0f} s   left: {left}")
    final = sequence.mode_at(run.t) == len(sequence.modes) - 1
    if np.any(final & (run.t > run.t[-1] - 600.0)):
        last = np.degrees(run.error_angle[final][-1])
        print(f"  error to the nadir reference at the end: {last:.3g} deg")
    fig = sequence.plot_timeline(run, args.out / "mode_timeline.png")
    print(f"figure: {args.out / 'mode_timeline.png'} ({len(fig.axes)} panels); {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()

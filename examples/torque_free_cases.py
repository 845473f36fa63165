"""The four classic cases of torque-free rigid-body motion, simulated and checked.

A spacecraft coasting with no external torque keeps its angular momentum
``H`` (fixed in inertial space) and its kinetic energy ``T``, yet its body
rates need not be constant: Euler's equations

    I1 w1' = (I2 - I3) w2 w3,   I2 w2' = (I3 - I1) w3 w1,   I3 w3' = (I1 - I2) w1 w2

(principal axes, moments ``I1 <= I2 <= I3``) couple the three rates. This
script propagates the full nonlinear plant (:func:`attitude.propagate.propagate`,
fixed-step RK4) and holds each result against a closed form nobody tuned
(:mod:`attitude.analytic`), printing predicted and measured figures side by
side with their relative error:

1. **A sphere keeps any spin.** ``I = c 1`` makes ``w x I w = 0``: the rates
   are constant whatever their direction.
2. **Spin about a principal axis holds.** A small satellite with products of
   inertia spins about each of the three principal axes returned by
   :meth:`attitude.RigidBody.principal_axes`; ``I w`` is parallel to ``w``, so
   the rates stay constant again.
3. **A symmetric top precesses.** With ``I1 = I2``, ``w3`` is constant and the
   transverse rate ``w1 + i w2`` turns in the body frame at
   ``lam = (I3 - I1) / I1 * w3`` (with the spin for an oblate body, against
   it for a prolate one). The rate is measured from the unwrapped phase of
   ``w1 + i w2``. The named example is the Earth: Euler (1765) predicted that
   its rotation axis circles the figure axis every ``A / (C - A)`` days,
   about 305 days; Chandler (1891) found the wobble at about 433 days,
   because the real Earth is not rigid (elastic mantle, oceans, fluid core).
4. **The tennis-racket (Dzhanibekov) effect.** Spins about the minor and
   major axes are stable; about the middle axis, a perturbation grows like
   ``exp(k t)`` with ``k = w2 sqrt((I2 - I1)(I3 - I2) / (I1 I3))`` until the
   body flips, and flips back, periodically. The flip period is measured from
   the zero crossings of ``w2`` and compared with the exact elliptic
   ``2 K(m) / lam`` (:func:`attitude.analytic.flip_period`); the growth rate
   from a fit to the early transverse rate.

The figures (rates against the closed forms, the polhodes on the energy
ellipsoid, the flip) go to ``--out``. ``--quick`` runs shorter simulations
(the test suite uses it); the full run takes a few seconds.

Run::

    python examples/torque_free_cases.py --out figures/torque_free
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.analytic import (
    EARTH_PRINCIPAL_MOMENTS,
    EARTH_ROTATION_RATE,
    axisymmetric_precession,
    earth_euler_period,
    intermediate_axis_growth_rate,
    torque_free_motion,
)
from attitude.plotting import plot_flip, plot_polhodes, plot_rates_comparison
from attitude.propagate import propagate

#: A small satellite with products of inertia, body components [kg m^2].
SATELLITE_INERTIA = [[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]
PRINCIPAL_LABELS = (r"$\omega_1$ (minor)", r"$\omega_2$ (middle)", r"$\omega_3$ (major)")
#: Observed Chandler wobble period [days]: Chandler (1891) found ~428 d; modern polar-motion fits give 430-435 d.
CHANDLER_OBSERVED_DAYS = 433.0
DAY = 86400.0
#: Largest transverse rate, as a fraction of the spin, at which the middle-axis motion is taken as linear.
LINEAR_LIMIT = 0.03


@dataclass(frozen=True)
class Settings:
    """Run lengths and steps of one run (full or ``--quick``)."""

    sphere_spins: int
    sphere_duration: float  # [s]
    principal_duration: float  # [s]
    top_duration: float  # [s]
    top_step: float  # [s]
    earth_periods: float  # Euler periods simulated
    earth_step: float  # [s]
    flips: int  # flip intervals measured
    flip_step: float  # [s]


FULL = Settings(200, 300.0, 600.0, 60.0, 0.01, 2.0, 3600.0, 4, 0.05)
QUICK = Settings(20, 60.0, 120.0, 30.0, 0.02, 1.0, 7200.0, 2, 0.1)


def relative_error(measured: float, predicted: float) -> float:
    return abs(measured - predicted) / abs(predicted)


def compare(label: str, predicted: float, measured: float, unit: str) -> None:
    """Print one predicted-vs-measured line."""
    print(
        f"  {label:<34} predicted {predicted:>12.6g} {unit:<6} measured {measured:>12.6g} {unit:<6}"
        f" rel. error {relative_error(measured, predicted):.1e}"
    )


def save(fig, out: Path, name: str, written: list[Path]) -> None:
    path = out / name
    fig.savefig(path, dpi=150)
    written.append(path)


# ---------------------------------------------------------------------------
# 1. Sphere
# ---------------------------------------------------------------------------


def case_sphere(s: Settings, out: Path, written: list[Path]) -> None:
    print("\n1. A sphere keeps any spin (I = 10 kg m^2 about every axis)")
    body = RigidBody([10.0, 10.0, 10.0])
    rng = np.random.default_rng(1)
    omega0 = rng.normal(scale=0.1, size=(s.sphere_spins, 3))  # rad/s, random directions
    t = np.arange(0.0, s.sphere_duration + 1e-9, 0.1)
    traj = propagate(body, quat.identity(), omega0, t)  # one vectorised run for the whole batch
    exact = np.stack([torque_free_motion(body, w).omega(t) for w in omega0])  # regime "sphere": constant
    deviation = np.max(np.abs(traj.omega - omega0[:, None, :]))
    print(
        f"  {s.sphere_spins} random spins of up to {np.degrees(np.linalg.norm(omega0, axis=1).max()):.1f} deg/s, "
        f"{s.sphere_duration:.0f} s: closed-form regime '{torque_free_motion(body, omega0[0]).regime}'"
    )
    print(
        f"  max |omega(t) - omega(0)| = {deviation:.2e} rad/s "
        f"({deviation / np.linalg.norm(omega0, axis=1).min():.1e} of the slowest spin; prediction: 0)"
    )
    fig = plot_rates_comparison(
        t,
        traj.omega[:3],
        exact[:3],
        f"Case 1: a sphere keeps any spin (three of the {s.sphere_spins} random spins)",
        panel_titles=[f"spin {j + 1}" for j in range(3)],
    )
    save(fig, out, "case1_sphere_rates.png", written)


# ---------------------------------------------------------------------------
# 2. Principal-axis spins
# ---------------------------------------------------------------------------


def case_principal_spins(s: Settings, out: Path, written: list[Path]) -> RigidBody:
    body = RigidBody(SATELLITE_INERTIA)
    axes = body.principal_axes()
    print("\n2. Spin about each principal axis holds")
    print(f"  satellite inertia with products of inertia; principal moments {np.round(axes.moments, 4)} kg m^2")
    spin = 0.2  # rad/s
    t = np.arange(0.0, s.principal_duration + 1e-9, 0.1)
    sims, exacts, titles = [], [], []
    for i, name in enumerate(("minor", "middle", "major")):
        omega0 = spin * axes.axes_B[:, i]  # body components of the principal axis
        traj = propagate(body, quat.identity(), omega0, t)
        motion = torque_free_motion(body, omega0)
        sims.append(traj.omega)
        exacts.append(motion.omega(t))
        deviation = np.max(np.linalg.norm(traj.omega - omega0, axis=-1)) / spin
        print(
            f"  {name:>6} axis {np.round(axes.axes_B[:, i], 3)}: closed-form regime '{motion.regime}', "
            f"max |omega(t) - omega(0)| / |omega| = {deviation:.1e}"
        )
        titles.append(f"{name} axis, {np.degrees(spin):.1f} deg/s")
    k = intermediate_axis_growth_rate(body, spin)
    # Rounding leaves omega_dot ~ 1e-17 rad/s^2 at a computed principal axis; one step changes omega by far less
    # than its last bit, so the fixed-step integrator keeps the rate exactly.
    step_change = np.linalg.norm(body.omega_dot(spin * axes.axes_B[:, 1])) * (t[1] - t[0])
    print(
        f"  note: the middle-axis spin holds only because nothing disturbs it: the per-step change of the rate\n"
        f"  ({step_change:.0e} rad/s) is below its rounding unit ({np.spacing(spin):.0e} rad/s). The axis is unstable: "
        f"any tilt grows by\n  exp(k t) = {math.exp(k * t[-1]):.1e} over this run (k = {k:.4f} 1/s, case 4)."
    )
    fig = plot_rates_comparison(
        t,
        np.stack(sims),
        np.stack(exacts),
        "Case 2: spin about each principal axis holds (satellite with products of inertia, body components)",
        panel_titles=titles,
    )
    save(fig, out, "case2_principal_spins_rates.png", written)
    return body


# ---------------------------------------------------------------------------
# 3. Symmetric top and the Chandler wobble
# ---------------------------------------------------------------------------


def transverse_rate(t: np.ndarray, omega: np.ndarray) -> float:
    """Measured turning rate [rad/s] of ``w1 + i w2``: slope of its unwrapped phase (least squares)."""
    phase = np.unwrap(np.angle(omega[:, 0] + 1j * omega[:, 1]))
    return float(np.polyfit(t, phase, 1)[0])


def case_symmetric_top(s: Settings, out: Path, written: list[Path]) -> None:
    print("\n3. A symmetric top: the transverse rate turns at lam = (I3 - I1) / I1 * w3 in the body frame")
    t = np.arange(0.0, s.top_duration + 1e-9, s.top_step)
    omega0 = np.array([0.05, 0.0, 1.0])  # rad/s: a 9.5 rpm spinner with a 2.9 deg nutation of the rate
    for shape, moments in (("oblate", [8.0, 8.0, 12.0]), ("prolate", [12.0, 12.0, 8.0])):
        body = RigidBody(moments)
        traj = propagate(body, quat.identity(), omega0, t)
        exact = axisymmetric_precession(body, quat.identity(), omega0, t)
        lam = (moments[2] - moments[0]) / moments[0] * omega0[2]
        measured = transverse_rate(t, traj.omega)
        print(f"  {shape} spinner, moments {moments} kg m^2, w3 = {omega0[2]} rad/s:")
        compare("transverse rate lam", lam, measured, "rad/s")
        compare("lam from axisymmetric_precession", exact.body_precession_rate, measured, "rad/s")
        attitude_error = np.degrees(np.max(quat.error_angle(exact.q, traj.q)))
        spin_change = np.max(np.abs(traj.omega[:, 2] - omega0[2]))
        print(
            f"  {'':<34} max |omega - closed form| = {np.max(np.abs(traj.omega - exact.omega)):.1e} rad/s, "
            f"attitude error {attitude_error:.1e} deg, w3 constant to {spin_change:.1e} rad/s"
        )
        if shape == "oblate":
            fig = plot_rates_comparison(  # w3 is left out: it is constant and 20 times larger
                t,
                traj.omega[:, :2],
                exact.omega[:, :2],
                f"Case 3: oblate symmetric top, moments {moments} kg m$^2$, spin $\\omega_3$ = {omega0[2]:g} rad/s "
                f"({'exactly constant' if spin_change == 0 else f'constant to {spin_change:.0e} rad/s'}): "
                f"the transverse rate turns at $\\lambda = (I_3 - I_1) / I_1\\,\\omega_3$ = {lam:.4g} rad/s, "
                f"measured {measured:.6f} rad/s (rel. error {relative_error(measured, lam):.0e})",
                labels=(r"$\omega_1$ (transverse)", r"$\omega_2$ (transverse)"),
            )
            save(fig, out, "case3_symmetric_top_rates.png", written)

    # The Earth: an oblate rigid body (A, A, C) spinning once a sidereal day.
    earth = RigidBody(EARTH_PRINCIPAL_MOMENTS)
    a_moment, _, c_moment = EARTH_PRINCIPAL_MOMENTS
    tilt = 1e-6  # rad (0.21 arcsec, 6 m at the pole): the size of the observed wobble
    omega0 = EARTH_ROTATION_RATE * np.array([tilt, 0.0, 1.0])
    predicted = earth_euler_period()
    t = np.arange(0.0, s.earth_periods * predicted, s.earth_step)
    traj = propagate(earth, quat.identity(), omega0, t)
    exact = axisymmetric_precession(earth, quat.identity(), omega0, t)
    measured = 2.0 * math.pi / abs(transverse_rate(t, traj.omega))
    print(
        f"  Earth (rigid), A = {a_moment:.5g}, C = {c_moment:.5g} kg m^2, (C - A) / A = "
        f"{(c_moment - a_moment) / a_moment:.4e}, rotation axis {tilt * 206264.8:.2f} arcsec off the figure axis:"
    )
    compare("free Euler (Chandler) period", predicted / DAY, measured / DAY, "days")
    print(f"  {'':<34} = {predicted / DAY * DAY / 86164.1:.1f} sidereal days: Euler's 'about 305 days'.")
    print(
        f"  The observed Chandler wobble period is ~{CHANDLER_OBSERVED_DAYS:.0f} days, "
        f"{CHANDLER_OBSERVED_DAYS / (predicted / DAY):.2f} x the rigid value:\n"
        "  the Earth is not rigid (its elastic mantle yields, the oceans and the fluid core respond),\n"
        "  which a rigid-body model cannot reproduce."
    )
    fig = plot_rates_comparison(
        t,
        traj.omega[:, :2],
        exact.omega[:, :2],
        f"Case 3: the Earth as a rigid body: the free Euler (Chandler) wobble of the equatorial rates, "
        f"period {measured / DAY:.1f} days (observed: ~{CHANDLER_OBSERVED_DAYS:.0f} days, because the Earth "
        "is not rigid)",
        labels=(r"$\omega_1$ (equatorial)", r"$\omega_2$ (equatorial)"),
        time_unit="day",
        rate_unit="arcsec/day",
    )
    save(fig, out, "case3_earth_chandler_wobble.png", written)


# ---------------------------------------------------------------------------
# 4. Tennis-racket effect
# ---------------------------------------------------------------------------


def zero_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Times where ``x`` changes sign, by linear interpolation [s]."""
    k = np.nonzero(np.signbit(x[:-1]) != np.signbit(x[1:]))[0]
    return t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])


def case_tennis_racket(body: RigidBody, s: Settings, out: Path, written: list[Path]) -> None:
    print("\n4. The tennis-racket effect: the middle axis is unstable, the minor and major axes are not")
    axes = body.principal_axes()
    spin = 0.2  # rad/s
    # Relative perturbation. Not much smaller: the flip period ln(16 / (1 - m)) / k depends on the distance to the
    # separatrix 1 - m ~ eps^2, and at eps = 1e-6 that (1e-12) is only ~100 times the rounding noise (~1e-14) that
    # any double-precision integrator leaves on the invariants H^2 and 2 T I2: the measured flip period then
    # wanders by ~0.1 s from flip to flip, a property of the problem, not of the integrator or the closed form.
    eps = 1e-4
    starts = {  # principal components of the initial rate
        "minor": np.array([spin, eps * spin, 0.0]),
        "middle": np.array([eps * spin, spin, 0.0]),
        "major": np.array([0.0, eps * spin, spin]),
    }
    middle = torque_free_motion(body, axes.axes_B @ starts["middle"])
    k = intermediate_axis_growth_rate(body, spin)
    t_first = (2.0 * middle.K - middle.u0) / middle.lam  # first zero of w2 = s B sn(lam t + u0)
    t = np.arange(0.0, t_first + (s.flips + 0.5) * middle.flip_period, s.flip_step)

    sims, exacts = {}, {}
    for name, w_p in starts.items():
        omega0 = axes.axes_B @ w_p  # body components
        traj = propagate(body, quat.identity(), omega0, t)
        sims[name] = traj.omega @ axes.C_PB.T  # principal components
        exacts[name] = torque_free_motion(body, omega0).omega_principal(t)

    # Growth rate: fit log|transverse| once the decaying mode has died out (t > 4/k, exp(-2kt) < 4e-4)
    # and while the motion is still linear (transverse < 3 % of the spin).
    w = sims["middle"]
    transverse = np.hypot(w[:, 0], w[:, 2])
    window = (t > 4.0 / k) & (t < t_first) & (transverse < LINEAR_LIMIT * spin)
    k_measured = float(np.polyfit(t[window], np.log(transverse[window]), 1)[0])
    print(f"  spin {spin} rad/s about the middle axis, perturbed by {eps:g} of it towards the minor axis:")
    compare("growth rate k", k, k_measured, "1/s")
    crossings = zero_crossings(t, w[:, 1])
    flips_measured = np.diff(crossings)
    compare("first flip at", t_first, crossings[0], "s")
    compare(f"flip period (mean of {flips_measured.size})", middle.flip_period, float(np.mean(flips_measured)), "s")
    print(
        f"  {'':<34} spread of the measured flip intervals {np.ptp(flips_measured):.1e} s; "
        f"ln(16 / (1 - m)) / k = {math.log(16.0 / middle.mc) / k:.1f} s (asymptotic form)"
    )

    print("  max transverse excursion (rate off the spin axis) from the same relative perturbation:")
    for i, name in enumerate(("minor", "middle", "major")):
        w = sims[name]
        measured = float(np.max(np.sqrt(np.maximum(np.sum(w**2, axis=-1) - w[:, i] ** 2, 0.0))))
        predicted = float(np.max(np.sqrt(np.maximum(np.sum(exacts[name] ** 2, axis=-1) - exacts[name][:, i] ** 2, 0))))
        initial = eps * spin
        print(
            f"    {name:>6} axis: predicted {predicted:.4e} rad/s, measured {measured:.4e} rad/s "
            f"(rel. error {relative_error(measured, predicted):.1e}), {measured / initial:10.4g} x the initial "
            f"{initial:.0e} rad/s -> {'BOUNDED' if measured < 10 * initial else 'FLIPS'}"
        )

    names = ("minor", "middle", "major")
    fig = plot_rates_comparison(
        t,
        np.stack([sims[n] for n in names]),
        np.stack([exacts[n] for n in names]),
        f"Case 4: spins of {np.degrees(spin):.1f} deg/s near each principal axis, perturbed by {eps:g} "
        "(principal components)",
        panel_titles=[f"near the {n} axis" for n in names],
        labels=PRINCIPAL_LABELS,
    )
    save(fig, out, "case4_near_axis_spins_rates.png", written)

    flip_times = t_first + middle.flip_period * np.arange(s.flips + 1)
    fig = plot_flip(
        t,
        sims["middle"],
        k,
        flip_period=middle.flip_period,
        flip_times=flip_times,
        omega_exact=exacts["middle"],
        labels=PRINCIPAL_LABELS,
        linear_limit=LINEAR_LIMIT,
        title=f"Case 4: the middle-axis flip (spin {np.degrees(spin):.1f} deg/s, perturbation {eps:g}): "
        f"flip period {middle.flip_period:.3f} s predicted, {np.mean(flips_measured):.3f} s measured",
    )
    save(fig, out, "case4_middle_axis_flip.png", written)

    fig = plot_polhodes(
        body,
        spin,
        rate_unit="deg/s",
        overlays={"simulated (case 4): a spin near the middle axis follows the separatrix": sims["middle"]},
        title="Polhodes of the satellite on its kinetic-energy ellipsoid (principal rate space)",
    )
    save(fig, out, "polhodes_energy_ellipsoid.png", written)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures/torque_free"), help="directory for the figures")
    parser.add_argument("--quick", action="store_true", help="shorter simulations (used by the tests)")
    args = parser.parse_args(argv)
    settings = QUICK if args.quick else FULL
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    written: list[Path] = []
    np.set_printoptions(precision=4, suppress=True)

    case_sphere(settings, args.out, written)
    body = case_principal_spins(settings, args.out, written)
    case_symmetric_top(settings, args.out, written)
    case_tennis_racket(body, settings, args.out, written)

    print(f"\nfigures ({len(written)}) in {args.out}:")
    for path in written:
        print(f"  {path.name}")
    print(f"done in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

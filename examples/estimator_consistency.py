"""Estimator testing: a datasheet gyro, a rate EKF and an MEKF, proved consistent before they fly.

The third daily job of the toolkit (see the design notes): put in a gyro
datasheet, estimate the body rate (and the gyro bias, and the attitude) with
an EKF, and prove the filter consistent over Monte Carlo runs. The script
walks that path on a small satellite (about 70 kg, full inertia tensor with
clearly different principal moments, so the gyroscopic coupling is strong)
and prints, for each claim, what the theory or the filter predicts next to
what the runs measure:

1. **Sensors from datasheets.** A tactical-grade fibre-optic gyro of the
   Northrop Grumman LN-200 class built with :meth:`Gyro.from_datasheet`
   (ARW 0.07 deg/sqrt(h), bias instability 1 deg/h at an assumed 300 s Allan
   minimum, a turn-on bias drawn per run from an assumed 5 deg/h 1-sigma
   repeatability), and the typical small-satellite star tracker
   (:meth:`StarTracker.preset`: 6 arcsec cross-boresight, 40 arcsec roll,
   5 Hz, boresight on body +z).
2. **Rate EKF on a tumble** (:class:`estimation.rate_ekf.RateEKF`, filterpy):
   body rate and gyro bias from the gyro alone and Euler's equations. The
   satellite tumbles at about 5 deg/s under a small unknown white disturbance
   torque (the filter's ``torque_noise``). One run's errors with their
   +-3 sigma bounds; the RMS rate error against the raw gyro noise of one
   sample (the filter beats the gyro by averaging through the dynamics);
   then a Monte Carlo campaign: the NEES averaged over the runs against its
   95 % chi-square band.
3. **MEKF on the same tumble** (:mod:`estimation.mekf.filter`): attitude and bias
   from gyro and star tracker. One run's errors (arcsec, deg/h) with +-3
   sigma; the steady-state attitude sigma of the filter and of the runs
   against the closed form :func:`steady_state_attitude_sigma` (Farrenkopf;
   Markley and Reynolds); the Monte Carlo NEES through the batched
   many-runs path of :func:`run_mekf` (one numpy step for all runs). The
   closed form is a single axis at rest with the bias converged; on the
   tumble the error turns from roll into the well-measured cross-boresight
   axes. Measured over the second half of the runs (closed form 3.12 arcsec
   cross, 8.84 roll): in the full run (100 to 200 s) the filter's sigma is
   3.13 cross and 8.67 roll, 2 % *below* the closed form in roll; in the
   ``--quick`` run (30 to 60 s, the bias sigma still converging: 1.0 to
   0.64 deg/h) it is 3.14 cross and 8.92 roll, 1 % *above*. The runs' RMS
   errors agree with the filter to within their sampling error (8.87 and
   9.32 arcsec roll).
4. **Closed loop.** A 45 deg slew with :class:`controllers.pd.QuaternionPD`
   flying on the MEKF estimate (:func:`attitude.simulation.engine.simulate` with the
   gyro and the star tracker as sensors, the MEKF as estimator, a four-wheel
   pyramid as actuators): the true pointing error against the one the
   controller sees, and the estimation error against the filter's 3 sigma.
   Once settled, the pointing error is not the estimator's few arcsec: the
   MEKF passes the gyro rate through unfiltered (``omega_meas - b_hat``) and
   the PD's rate gain turns its white noise into torque. For ``I theta'' +
   C theta' + K theta / 2 = -C n`` with ``C = 2 I zeta wn``, ``K = 2 I wn**2``
   and ``n`` of density ``sigma_v``, the variance per axis is
   ``zeta sigma_v**2 / wn`` (whatever the inertia); the script prints that
   prediction, plus the estimation error, against the measured hold. The
   slew is flown twice: with an integrating gyro (``sampling="mean"``, what
   the MEKF models) and with a point-sampling one, to show the mismatch.
5. **Closed loop on the rate EKF.** The same slew with the PD on the rate
   EKF: the filtered rate (Euler's equations with the wheel tachometers'
   reaction torque), and the attitude of the latest star-tracker sample
   propagated with it (what a rate filter can offer, see
   :mod:`estimation.rate_ekf`). The gyro samples the instantaneous rate (the
   rate EKF's model) and the truth carries the white disturbance torque the
   filter assumes. The rate the PD sees is about a quarter of the raw gyro
   noise (the MEKF passes the raw noise through), but the bias is learned
   only through the weak gyroscopic coupling of a slow slew: at rest
   ``omega_hat - omega`` is minus the bias error ``db``, which the PD
   balances with a pointing offset ``2 zeta |db| / wn``. The script prints
   that prediction against the measured hold (about 85 against 90 arcsec,
   versus 25 to 32 on the MEKF) and plots it with the rate and bias errors
   and their +-3 sigma (``closed_loop_slew_rate_ekf.png``).

Truth and measurements (sections 2 and 3) are generated independently of the
filters and vectorised over the runs: the tumbles by one batched RK4
propagation (:func:`attitude.propagate.propagate`) with a random torque held
over each gyro interval (variance ``torque_noise**2 / dt``, so the impulse
over any interval has the variance of the filter's white-noise model); the
gyro errors by :meth:`Gyro.sample_errors` (the exact Farrenkopf sampling),
the tracker errors by one :meth:`StarTracker.add_noise` call for all runs.
Each filter is initialised the way flight software does it, from the first
samples (rate from the first gyro sample, attitude from the first tracker
quaternion), with the matching initial covariance, so every run's initial
error is a draw from ``P0`` and the NEES needs no transient discarded.

The two filters read a gyro sample differently. The MEKF takes it as the
mean rate over the interval just ended (what the angle increment of an
integrating gyro gives), the rate EKF as the rate at the sample time. The two
differ by about ``dt/2 * d(omega)/dt``: on this tumble about 15 deg/h RMS, as
much as the white noise of one sample. So each filter is fed the sample it
models (the same gyro errors, only the true-rate part differs), and the
script prints what the rate EKF makes of interval-mean samples. In the
closed loop the slew is flown with ``Gyro(sampling="mean")`` (an integrating
gyro's angle increments, what the MEKF models), and once more with
``sampling="instantaneous"`` to show what the MEKF makes of point samples
while the body accelerates (``closed_loop_slew_point_gyro.png``); the rate
EKF's slew uses ``sampling="instantaneous"``. ``RateEKF.from_gyro`` and
``MEKF.from_sensors`` check the gyro's ``sampling`` (``sampling_check``):
the script builds each filter from the gyro it models and says
``sampling_check="ignore"`` only for the deliberate mismatch.

Run ``python examples/estimator_consistency.py --out DIR`` (``--quick`` for the
short run of the test suite, about 13 s; the full run takes under a minute).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from attitude import Gyro, ReactionWheels, RigidBody, StarTracker, simulate
from attitude import quaternion as quat
from attitude.propagate import propagate
from attitude.sensors import ARCSEC, arw_from_sigma_v
from controllers import QuaternionPD
from estimation import (
    MEKF,
    RateEKF,
    chi2_band,
    nees,
    plot_errors_with_bounds,
    plot_nees,
    run_mekf,
    run_rate_ekf,
    steady_state_attitude_sigma,
)
from estimation.consistency import fraction_inside_band

#: Small satellite, body axes, wheels included [kg m^2] (illustrative; principal moments ~6, 9, 11).
INERTIA = np.array([[6.0, 0.3, -0.2], [0.3, 9.0, 0.15], [-0.2, 0.15, 11.0]])
#: Nominal tumble [rad/s]; each run draws its own around it.
OMEGA_TUMBLE = np.radians([3.0, -2.5, 4.0])
OMEGA_SPREAD = np.radians(0.5)  # 1 sigma per axis [rad/s]
#: White disturbance torque density [N m / sqrt(Hz)] (truth) = the rate EKF's torque_noise.
TORQUE_NOISE = 1e-5
GYRO_PERIOD = 0.1  # [s], 10 Hz
#: Tactical FOG, LN-200 class (Northrop Grumman LN-200/LN-200S datasheets; Allan minimum time assumed).
GYRO_DATASHEET = {
    "arw_deg_per_sqrt_h": 0.07,
    "bias_instability_deg_per_h": 1.0,
    "bias_instability_time_s": 300.0,
    "saturation_deg_per_s": 1000.0,
}
#: Turn-on bias repeatability, 1 sigma per axis [deg/h] (assumed: a few times the datasheet's 1 deg/h,
#: for a gyro after storage and launch).
TURN_ON_BIAS_DEG_H = 5.0
DEG_H = np.pi / 180.0 / 3600.0  # one deg/h [rad/s]
PD_WN, PD_ZETA = 0.1, 0.9  # slew controller natural frequency [rad/s] and damping
SLEW_DEG, SLEW_AXIS = 45.0, (1.0, -1.0, 0.5)
HOLD_START_S = 150.0  # the slew transient has died out (< 1 arcsec) by then; the hold is measured after it [s]
CONFIDENCE = 0.95


def datasheet_gyro(bias_deg_per_h: float | np.ndarray = 0.0, sampling: str = "instantaneous") -> Gyro:
    """The LN-200 class gyro from its datasheet figures (``sampling``: see :class:`Gyro`)."""
    return Gyro.from_datasheet(period=GYRO_PERIOD, bias_deg_per_h=bias_deg_per_h, sampling=sampling, **GYRO_DATASHEET)


def save(fig: Figure, path: Path, written: list[Path]) -> None:
    fig.savefig(path, dpi=120)
    written.append(path)


def tumble_campaign(body: RigidBody, gyro: Gyro, tracker: StarTracker, t: np.ndarray, n_runs: int, seed: int):
    """Truth and measurements of ``n_runs`` independent tumbles, vectorised over the runs.

    Returns a dict: ``q`` (runs, n, 4) and ``omega`` (runs, n, 3) true attitude and rate;
    ``bias`` (runs, n, 3) true gyro bias at each sample time;
    ``gyro_point`` (rate at the sample time + error) and ``gyro_mean`` (mean rate over the interval
    ending at the sample + error) [rad/s]; ``tracker`` (runs, n, 4) with NaN rows where the tracker
    does not sample (and at t = 0, whose sample initialises the MEKF: ``q0_meas``).
    """
    dt = t[1] - t[0]
    n = t.size
    seeds = np.random.SeedSequence(seed).spawn(n_runs + 1)
    rng = np.random.default_rng(seeds[0])
    omega0 = OMEGA_TUMBLE + rng.standard_normal((n_runs, 3)) * OMEGA_SPREAD
    q0 = quat.random(n_runs, rng)
    # Disturbance torque held over each gyro interval: impulse variance TORQUE_NOISE**2 dt.
    torque = rng.standard_normal((n, n_runs, 3)) * (TORQUE_NOISE / np.sqrt(dt))
    traj = propagate(body, q0, omega0, t, torque, method="rk4", max_step=dt / 2)
    q, omega = quat.normalize(traj.q), traj.omega
    # Gyro: exact Farrenkopf errors (bias random walk + white noise), one turn-on bias per run.
    errors = np.empty((n_runs, n, 3))
    bias = np.empty((n_runs, n, 3))
    for r in range(n_runs):
        run_rng = np.random.default_rng(seeds[r + 1])
        b0 = run_rng.standard_normal(3) * TURN_ON_BIAS_DEG_H * DEG_H
        errors[r], biases = gyro.sample_errors(n, run_rng, bias0=b0)
        bias[r] = biases[1:]  # the bias at each sample time
    # Mean rate over (t[k-1], t[k]]: the rotation vector of the attitude increment over dt.
    mean_rate = np.empty_like(omega)
    mean_rate[:, 1:] = quat.to_rotation_vector(quat.multiply(quat.conjugate(q[:, :-1]), q[:, 1:])) / dt
    mean_rate[:, 0] = omega[:, 0]  # row 0 only seeds the MEKF's first rate estimate
    every = round(tracker.period / dt)
    tracker_meas = np.full((n_runs, n, 4), np.nan)
    tracker_meas[:, every::every] = tracker.add_noise(q[:, every::every], rng)
    return {
        "q": q,
        "omega": omega,
        "bias": bias,
        "gyro_point": omega + errors,
        "gyro_mean": mean_rate + errors,
        "tracker": tracker_meas,
        "q0_meas": tracker.add_noise(q[:, 0], rng),
    }


def rate_ekf_runs(body, gyro, t, gyro_samples, mc):
    """Rate EKF over every run, initialised from each run's first gyro sample (returns the results)."""
    r_var = gyro.rate_noise_variance()
    b_var = (TURN_ON_BIAS_DEG_H * DEG_H) ** 2
    # Error of x0 = [z0, 0]: omega - z0 = -beta - noise, beta: so P0 = [[R + B, -B], [-B, B]].
    p0 = np.block([[(r_var + b_var) * np.eye(3), -b_var * np.eye(3)], [-b_var * np.eye(3), b_var * np.eye(3)]])
    results = []
    for r in range(gyro_samples.shape[0]):
        ekf = RateEKF.from_gyro(body, gyro, torque_noise=TORQUE_NOISE, P0=p0, x0=np.r_[gyro_samples[r, 0], 0, 0, 0])
        results.append(
            run_rate_ekf(ekf, t[1:], gyro_samples[r, 1:], omega_true=mc["omega"][r, 1:], bias_true=mc["bias"][r, 1:])
        )
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--out", type=Path, default=Path("figures/estimator_consistency"), help="folder for the figures"
    )
    parser.add_argument("--quick", action="store_true", help="fewer runs, shorter runs (for the test suite)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    written: list[Path] = []
    n_runs = 50 if args.quick else 100
    duration = 60.0 if args.quick else 200.0
    body = RigidBody(INERTIA)
    rows: list[tuple[str, str, str]] = []  # summary: quantity, predicted, measured

    # 1. Sensors ------------------------------------------------------------------------------
    gyro = datasheet_gyro()
    tracker = StarTracker.preset("typical")
    raw = np.sqrt(gyro.rate_noise_variance())  # white noise of one gyro sample [rad/s]
    print(f"Spacecraft: principal moments {np.round(body.principal_axes().moments, 3)} kg m^2")
    print("\n1. Sensors from datasheets")
    print(
        f"   gyro (LN-200 class FOG, {1 / GYRO_PERIOD:g} Hz): ARW {GYRO_DATASHEET['arw_deg_per_sqrt_h']} deg/sqrt(h)"
        f" -> sigma_v = {gyro.sigma_v:.3e} rad/s^0.5 (back: {arw_from_sigma_v(gyro.sigma_v):.3f} deg/sqrt(h));"
    )
    print(
        f"   bias instability {GYRO_DATASHEET['bias_instability_deg_per_h']} deg/h at "
        f"{GYRO_DATASHEET['bias_instability_time_s']:g} s -> Gauss-Markov bias sigma_b = {gyro.sigma_b:.3e} rad/s, "
        f"T = {gyro.correlation_time:.0f} s (the filter's random walk sigma_u = {gyro.filter_sigma_u:.3e} rad/s^1.5); "
        f"turn-on bias {TURN_ON_BIAS_DEG_H} deg/h (1 sigma)"
    )
    print(f"   white noise of one sample sqrt(sigma_v^2/dt + sigma_u^2 dt/12) = {raw / DEG_H:.2f} deg/h")
    print(
        f"   star tracker (typical): {tracker.sigma_cross / ARCSEC:g} arcsec cross-boresight, "
        f"{tracker.sigma_roll / ARCSEC:g} arcsec roll (1 sigma), {1 / tracker.period:g} Hz, boresight +z"
    )

    # Truth and measurements for sections 2 and 3 -----------------------------------------------
    t = np.arange(round(duration / GYRO_PERIOD) + 1) * GYRO_PERIOD
    tick = time.perf_counter()
    mc = tumble_campaign(body, gyro, tracker, t, n_runs, seed=2024)
    rate_deg = np.degrees(np.linalg.norm(mc["omega"], axis=-1))
    print(
        f"\nTruth: {n_runs} tumbles of {duration:g} s, |omega| {rate_deg.min():.1f} to {rate_deg.max():.1f} deg/s,"
        f" generated in {time.perf_counter() - tick:.2f} s (one batched RK4 propagation)"
    )

    # 2. Rate EKF -------------------------------------------------------------------------------
    print("\n2. Rate EKF (rate + bias from the gyro and Euler's equations), tumbling")
    tick = time.perf_counter()
    ekf_results = rate_ekf_runs(body, gyro, t, mc["gyro_point"], mc)
    ekf_time = time.perf_counter() - tick
    t_ekf = t[1:]
    err = np.stack([res.errors() for res in ekf_results])
    cov = np.stack([res.covariance for res in ekf_results])
    steady = t_ekf >= duration / 2
    rms_rate = np.sqrt(np.mean(err[:, steady, :3] ** 2))
    sigma_rate = np.sqrt(np.mean(np.diagonal(cov[:, steady, :3, :3], axis1=-2, axis2=-1)))
    print(f"   {n_runs} runs x {t_ekf.size} steps through filterpy in {ekf_time:.1f} s")
    print(
        f"   second half of the runs: RMS rate error {rms_rate / DEG_H:.2f} deg/h (filter sigma "
        f"{sigma_rate / DEG_H:.2f} deg/h) vs raw gyro noise {raw / DEG_H:.2f} deg/h: "
        f"ratio {rms_rate / raw:.3f} (predicted {sigma_rate / raw:.3f})"
    )
    sigma_b_end = np.sqrt(np.mean(np.diagonal(cov[:, -1, 3:, 3:], axis1=-2, axis2=-1))) / DEG_H
    rms_b_end = np.sqrt(np.mean(err[:, -1, 3:] ** 2)) / DEG_H
    print(
        f"   bias: sigma {TURN_ON_BIAS_DEG_H:.1f} -> {sigma_b_end:.2f} deg/h at {duration:g} s "
        f"(RMS error over the runs {rms_b_end:.2f} deg/h)"
    )
    fig = ekf_results[0].plot("errors")
    fig.suptitle(
        rf"Rate EKF errors with $\pm 3\sigma$ bounds (run 1 of {n_runs}, tumbling at {rate_deg[0, 0]:.1f} deg/s)"
    )
    save(fig, args.out / "rate_ekf_errors.png", written)
    avg = nees(err, cov).mean(axis=0)
    inside, (lo, hi) = report_nees("Rate EKF", t_ekf, avg, n_runs, args.out / "rate_ekf_nees.png", written)
    rows.append(("rate EKF RMS rate error / gyro noise", f"{sigma_rate / raw:.3f}", f"{rms_rate / raw:.3f}"))
    rows.append(("rate EKF average NEES (6 dof)", f"6 [{lo:.2f}, {hi:.2f}]", f"{avg.mean():.2f}"))
    rows.append(("rate EKF steps inside the NEES band", f"{100 * CONFIDENCE:.0f} %", f"{100 * inside:.1f} %"))

    # What the rate EKF makes of interval-mean samples (a few runs).
    k = min(10, n_runs)
    mean_results = rate_ekf_runs(body, gyro, t, mc["gyro_mean"][:k], {key: v[:k] for key, v in mc.items()})
    err_m = np.stack([res.errors() for res in mean_results])
    cov_m = np.stack([res.covariance for res in mean_results])
    rms_m = np.sqrt(np.mean(err_m[:, steady, :3] ** 2))
    lag = np.sqrt(np.mean((mc["gyro_mean"] - mc["gyro_point"])[:, 1:] ** 2))
    print(
        f"   fed interval-mean samples instead (they lag by {lag / DEG_H:.1f} deg/h RMS): RMS rate error "
        f"{rms_m / DEG_H:.1f} deg/h, average NEES {nees(err_m, cov_m).mean():.0f} over {k} runs"
    )

    # 3. MEKF ----------------------------------------------------------------------------------
    print("\n3. MEKF (attitude + bias from gyro and star tracker), same tumble")
    b_var = (TURN_ON_BIAS_DEG_H * DEG_H) ** 2
    p0 = np.zeros((6, 6))
    p0[:3, :3] = tracker.covariance_B  # attitude from the first tracker quaternion
    p0[3:, 3:] = b_var * np.eye(3)
    # The MEKF reads the interval-mean samples: build it from the same datasheet as an integrating gyro.
    mekf = MEKF.from_sensors(datasheet_gyro(sampling="mean"), tracker, q0=mc["q0_meas"][0], P0=p0)
    single = run_mekf(mekf, t, mc["gyro_mean"][0], mc["tracker"][0])
    save(plot_mekf_run(single, mc["q"][0], mc["bias"][0]), args.out / "mekf_errors.png", written)
    tick = time.perf_counter()
    batch = run_mekf(mekf, t, mc["gyro_mean"], mc["tracker"], q0=mc["q0_meas"])
    mekf_time = time.perf_counter() - tick
    e_mekf = batch.errors(mc["q"], mc["bias"])
    print(
        f"   {n_runs} runs x {t.size} steps in {mekf_time:.2f} s through the batched path "
        f"({batch.info['filter_steps_per_s']:.3g} filter steps/s)"
    )
    late = batch.updated[0] & (t >= duration / 2)
    sig_filter = np.sqrt(np.mean(np.diagonal(batch.P[:, late, :3, :3], axis1=-2, axis2=-1), axis=(0, 1)))
    sig_runs = np.sqrt(np.mean(e_mekf[:, late, :3] ** 2, axis=(0, 1)))
    cross = steady_state_attitude_sigma(
        sigma_v=gyro.sigma_v, sigma_u=gyro.filter_sigma_u, sigma_n=tracker.sigma_cross, dt=tracker.period
    )
    roll = steady_state_attitude_sigma(
        sigma_v=gyro.sigma_v, sigma_u=gyro.filter_sigma_u, sigma_n=tracker.sigma_roll, dt=tracker.period
    )
    print("   steady-state attitude sigma just after an update [arcsec] (second half of the runs):")
    print("     axis            closed form   filter   runs (RMS)")
    for i, (name, closed) in enumerate(zip(["x (cross)", "y (cross)", "z (roll)"], [cross, cross, roll])):
        print(f"     {name:<14}{closed / ARCSEC:12.2f}{sig_filter[i] / ARCSEC:9.2f}{sig_runs[i] / ARCSEC:12.2f}")
        rows.append(
            (
                f"MEKF attitude sigma {name} [arcsec]",
                f"{closed / ARCSEC:.2f}",
                f"{sig_runs[i] / ARCSEC:.2f} (filter {sig_filter[i] / ARCSEC:.2f})",
            )
        )
    sig_b = np.sqrt(np.mean(np.diagonal(batch.P[:, -1, 3:, 3:], axis1=-2, axis2=-1))) / DEG_H
    rms_b = np.sqrt(np.mean(e_mekf[:, -1, 3:] ** 2)) / DEG_H
    print(f"   bias: sigma {TURN_ON_BIAS_DEG_H:.1f} -> {sig_b:.2f} deg/h at {duration:g} s (RMS over runs {rms_b:.2f})")
    avg_m = nees(e_mekf, batch.P).mean(axis=0)
    inside_m, _ = report_nees("MEKF", t, avg_m, n_runs, args.out / "mekf_nees.png", written)
    rows.append(("MEKF average NEES (6 dof)", f"6 [{lo:.2f}, {hi:.2f}]", f"{avg_m.mean():.2f}"))
    rows.append(("MEKF steps inside the NEES band", f"{100 * CONFIDENCE:.0f} %", f"{100 * inside_m:.1f} %"))

    # 4. Closed loop ---------------------------------------------------------------------------
    slew_time = 250.0 if args.quick else 500.0
    print(f"\n4. Closed loop: {SLEW_DEG:g} deg slew, QuaternionPD on the MEKF estimate, four-wheel pyramid")
    print(f"   PD wn = {PD_WN} rad/s, zeta = {PD_ZETA}, 10 Hz; gyro and tracker as in 1; {slew_time:g} s simulated")
    cl = {sampling: fly_slew(body, tracker, p0, sampling, slew_time) for sampling in ("mean", "point")}
    res = cl["mean"]["result"]
    print(
        f"   integrating gyro: peak rate {np.degrees(np.linalg.norm(res.omega, axis=1).max()):.2f} deg/s, "
        f"peak wheel speed {np.abs(res.wheel_speed).max() * 30 / np.pi:.0f} rpm, "
        f"settled below 0.05 deg at {res.settling_time(np.radians(0.05)):.0f} s"
    )
    sig_end = cl["mean"]["sigma"][-1]
    print(
        f"   final pointing error: true {res.error_angle[-1] / ARCSEC:.1f} arcsec, seen by the controller "
        f"{cl['mean']['seen'][-1] / ARCSEC:.1f} arcsec"
    )
    print(
        f"   final estimation error {np.round(cl['mean']['error'][-1] / ARCSEC, 1)} arcsec vs the MEKF's 3 sigma "
        f"{np.round(3 * sig_end / ARCSEC, 1)} arcsec (x, y cross-boresight, z roll)"
    )
    hold = res.t >= HOLD_START_S
    floor = np.sqrt(3 * PD_ZETA / PD_WN) * gyro.sigma_v  # error angle from the gyro noise alone [rad]
    measured_hold = np.sqrt(np.mean(res.error_angle[hold] ** 2))
    cl["mean"]["floor"] = floor
    print(
        f"   hold after {HOLD_START_S:g} s: RMS pointing error {measured_hold / ARCSEC:.1f} arcsec, of which the gyro "
        f"noise through the rate gain gives sigma_v sqrt(3 zeta/wn) = {floor / ARCSEC:.1f} arcsec "
        "(the estimation error adds the rest)"
    )
    for sampling, label in (("mean", "integrating gyro (interval mean)"), ("point", "point-sampling gyro")):
        c = cl[sampling]
        print(
            f"   {label}: estimation error outside +-3 sigma at {100 * c['outside']:.2f} % of the "
            f"{c['updated'].sum()} tracker updates (0.27 % expected), largest {c['worst']:.1f} sigma"
        )
    fmt = "/".join(["{:.1f}"] * 3)
    rows.append(
        (
            "slew: final estimation error x/y/z [arcsec]",
            "within 3 sigma " + fmt.format(*(3 * sig_end / ARCSEC)),
            fmt.format(*(cl["mean"]["error"][-1] / ARCSEC)),
        )
    )
    rows.append(
        (
            "slew: pointing error, final (hold RMS) [arcsec]",
            f"RMS {floor / ARCSEC:.1f} from gyro noise",
            f"{res.error_angle[-1] / ARCSEC:.1f} ({measured_hold / ARCSEC:.1f})",
        )
    )
    rows.append(
        (
            "slew: updates with error outside 3 sigma",
            "0.27 %",
            f"{100 * cl['mean']['outside']:.2f} % (point-sampled gyro {100 * cl['point']['outside']:.2f} %)",
        )
    )
    save(plot_closed_loop(cl["mean"], "integrating gyro"), args.out / "closed_loop_slew.png", written)
    save(res.plot(), args.out / "closed_loop_review.png", written)
    save(
        plot_closed_loop(cl["point"], "a point-sampling gyro"),
        args.out / "closed_loop_slew_point_gyro.png",
        written,
    )

    # 5. Closed loop on the rate EKF ------------------------------------------------------------
    print("\n5. Closed loop: the same slew, QuaternionPD on the rate EKF (rate filtered, attitude from the tracker)")
    print(
        f"   point-sampling gyro, wheel tachometers into the filter, white disturbance torque "
        f"{TORQUE_NOISE:g} N m/sqrt(Hz); {slew_time:g} s simulated"
    )
    tick = time.perf_counter()
    rl = fly_slew_rate_ekf(body, tracker, slew_time)
    rres = rl["result"]
    print(f"   flown in {time.perf_counter() - tick:.1f} s")
    rhold = rres.t >= HOLD_START_S
    r_hold_rms = np.sqrt(np.mean(rres.error_angle[rhold] ** 2))
    rate_err, bias_err, rsig = rl["rate_error"], rl["bias_error"], rl["sigma"]
    rate_out = float(np.mean(np.abs(rate_err) > 3 * rsig[:, :3]))
    bias_out = float(np.mean(np.abs(bias_err) > 3 * rsig[:, 3:]))
    rms_rate_hold = np.sqrt(np.mean(rate_err[rhold] ** 2))
    sig_rate_hold = np.sqrt(np.mean(rsig[rhold, :3] ** 2))
    offset = rl["offset"][rhold]
    print(
        f"   settled below 0.05 deg at {rres.settling_time(np.radians(0.05)):.0f} s; final pointing error: true "
        f"{rres.error_angle[-1] / ARCSEC:.1f} arcsec, seen by the controller {rl['seen'][-1] / ARCSEC:.1f} arcsec"
    )
    print(
        f"   hold after {HOLD_START_S:g} s: RMS rate error {rms_rate_hold / DEG_H:.2f} deg/h (filter sigma "
        f"{sig_rate_hold / DEG_H:.2f} deg/h) vs raw gyro noise {raw / DEG_H:.2f} deg/h: the PD sees "
        f"{rms_rate_hold / raw:.2f} of the raw noise (the MEKF passes it through: 1)"
    )
    print(
        f"   errors outside +-3 sigma: rate {100 * rate_out:.2f} %, bias {100 * bias_out:.2f} % of the samples "
        f"(0.27 % expected); bias sigma {TURN_ON_BIAS_DEG_H:.1f} -> {np.mean(rsig[-1, 3:]) / DEG_H:.2f} deg/h"
    )
    print(
        f"   hold RMS pointing error {r_hold_rms / ARCSEC:.1f} arcsec; the bias residual "
        f"({np.sqrt(np.mean(bias_err[rhold] ** 2)) / DEG_H:.2f} deg/h RMS per axis) predicts 2 zeta |db| / wn = "
        f"{np.sqrt(np.mean(offset**2)) / ARCSEC:.1f} arcsec RMS; gated samples {rl['gated']}, "
        f"health-flagged steps {rl['flagged']}"
    )
    rows.append(
        (
            "rate-EKF slew: rate error outside 3 sigma",
            "0.27 %",
            f"{100 * rate_out:.2f} % (bias {100 * bias_out:.2f} %)",
        )
    )
    rows.append(
        (
            "rate-EKF slew: hold pointing RMS [arcsec]",
            f"{np.sqrt(np.mean(offset**2)) / ARCSEC:.1f} from the bias residual",
            f"{r_hold_rms / ARCSEC:.1f} (MEKF {measured_hold / ARCSEC:.1f})",
        )
    )
    save(plot_rate_ekf_slew(rl, raw), args.out / "closed_loop_slew_rate_ekf.png", written)

    # Summary ----------------------------------------------------------------------------------
    print("\nSummary")
    w1 = max(len(r[0]) for r in rows)
    w2 = max(len(r[1]) for r in rows)
    print(f"  {'quantity':<{w1}}  {'predicted':<{w2}}  measured")
    for name, predicted, measured in rows:
        print(f"  {name:<{w1}}  {predicted:<{w2}}  {measured}")
    print(f"\nfigures ({len(written)}) in {args.out}:")
    for path in written:
        print(f"  {path.name}")
    print(f"done in {time.perf_counter() - start:.1f} s")


def fly_slew(
    body: RigidBody, tracker: StarTracker, p0: np.ndarray, sampling: str, duration: float, seed: int = 7
) -> dict:
    """The closed-loop slew on the MEKF estimate; ``sampling`` "mean" (integrating gyro) or "point" (Gyro)."""
    rng = np.random.default_rng(seed)
    gyro = datasheet_gyro(
        rng.standard_normal(3) * TURN_ON_BIAS_DEG_H, sampling="mean" if sampling == "mean" else "instantaneous"
    )
    target = quat.from_axis_angle(SLEW_AXIS, np.radians(SLEW_DEG))
    wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.02, momentum_max=0.5, viscous_friction=1e-6)
    pd = QuaternionPD.from_bandwidth(body, wn=PD_WN, zeta=PD_ZETA, period=GYRO_PERIOD, q_ref=target, gyroscopic=True)
    q_start = quat.identity()
    # The point-sampling case is the deliberate mismatch this section shows: tell from_sensors so.
    check = "raise" if sampling == "mean" else "ignore"
    mekf = MEKF.from_sensors(gyro, tracker, q0=tracker.add_noise(q_start, rng), P0=p0, t0=0.0, sampling_check=check)
    res = simulate(
        body,
        q_start,
        np.zeros(3),
        duration,
        controller=pd,
        wheels=wheels,
        sensors=[gyro, tracker],
        estimator=mekf,
        rng=rng,
    )
    error = quat.to_rotation_vector(quat.multiply(quat.conjugate(res.estimate_q), res.q))  # truth vs estimate
    sigma = np.sqrt(res.logs["estimator.P_diag"][:, :3])
    updates = res.logs["estimator.updates"][:, 0]
    updated = np.diff(updates, prepend=0.0) > 0  # steps with a tracker update (a gated sample has a NIS too)
    ratio = np.abs(error[updated]) / sigma[updated]
    return {
        "result": res,
        "seen": quat.error_angle(target, res.estimate_q),
        "error": error,
        "sigma": sigma,
        "updated": updated,
        "outside": float(np.mean(ratio > 3)),
        "worst": float(ratio.max()),
        "gated": int(mekf.counts["tracker_gated"]),
    }


class BiasLoggingGyro:
    """A gyro sensor that also records its true bias at each sample (the engine logs only the samples)."""

    def __init__(self, gyro: Gyro) -> None:
        self.gyro, self.name, self.period = gyro, gyro.name, gyro.period
        self.biases: list[np.ndarray] = []

    def reset(self) -> None:
        self.gyro.reset()
        self.biases = []

    def measure(self, t: float, truth, rng) -> np.ndarray:
        sample = self.gyro.measure(t, truth, rng)
        self.biases.append(self.gyro.bias)
        return sample


class WhiteTorque:
    """Disturbance: white torque of density ``TORQUE_NOISE`` held over each tick (the rate EKF's model)."""

    def __init__(self, dt: float, rng: np.random.Generator) -> None:
        self.scale, self.rng = TORQUE_NOISE / np.sqrt(dt), rng

    def __call__(self, t: float, q: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return self.rng.standard_normal(3) * self.scale


def fly_slew_rate_ekf(body: RigidBody, tracker: StarTracker, duration: float, seed: int = 7) -> dict:
    """The same slew with the PD on the rate EKF: its filtered rate, and the latest tracker attitude.

    The gyro samples the instantaneous rate (what the rate EKF models), the wheel tachometers give the
    filter the reaction torque, and the truth carries the white disturbance torque the filter assumes.
    """
    rng = np.random.default_rng(seed)
    gyro = BiasLoggingGyro(datasheet_gyro(rng.standard_normal(3) * TURN_ON_BIAS_DEG_H))
    target = quat.from_axis_angle(SLEW_AXIS, np.radians(SLEW_DEG))
    wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.02, momentum_max=0.5, viscous_friction=1e-6)
    pd = QuaternionPD.from_bandwidth(body, wn=PD_WN, zeta=PD_ZETA, period=GYRO_PERIOD, q_ref=target, gyroscopic=True)
    q_start = quat.identity()
    # At rest at t = 0 (rate known to 0.01 deg/s); turn-on bias from the datasheet repeatability.
    p0 = np.diag([np.radians(0.01) ** 2] * 3 + [(TURN_ON_BIAS_DEG_H * DEG_H) ** 2] * 3)
    ekf = RateEKF.from_gyro(
        body,
        gyro.gyro,
        torque_noise=TORQUE_NOISE,
        P0=p0,
        wheels=wheels,
        attitude_name=tracker.name,
        q0=tracker.add_noise(q_start, rng),
        sampling_check="raise",
    )
    res = simulate(
        body,
        q_start,
        np.zeros(3),
        duration,
        controller=pd,
        wheels=wheels,
        sensors=[gyro, tracker],
        estimator=ekf,
        disturbance=WhiteTorque(GYRO_PERIOD, np.random.default_rng(seed + 1)),
        rng=rng,
    )
    sigma = res.logs["estimator.sigma"]
    bias_error = np.array(gyro.biases) - res.logs["estimator.bias"]
    return {
        "result": res,
        "seen": quat.error_angle(target, res.estimate_q),
        "rate_error": res.omega - res.estimate_omega,
        "bias_error": bias_error,
        # At rest the PD balances K q_v = -C omega_hat with omega_hat - omega = -(bias error): a pointing
        # offset of 2 zeta |bias error| / wn (the bias is learned only through the gyroscopic coupling).
        "offset": 2 * PD_ZETA / PD_WN * np.linalg.norm(bias_error, axis=1),
        "sigma": sigma,
        "gated": int(ekf.n_gated),
        "flagged": int(np.nansum(res.logs["estimator.health_flag"])),
    }


def report_nees(
    label: str, t: np.ndarray, avg: np.ndarray, n_runs: int, path: Path, written: list[Path]
) -> tuple[float, tuple[float, float]]:
    """Print and plot a 6-dof NEES averaged over the runs against its chi-square band; (fraction inside, band)."""
    lo, hi = chi2_band(6, n_runs, CONFIDENCE)
    inside = fraction_inside_band(avg, 6, n_runs, CONFIDENCE)
    print(
        f"   NEES averaged over {n_runs} runs: mean {avg.mean():.2f} (expected 6), "
        f"{100 * inside:.1f} % of steps inside the 95 % band [{lo:.2f}, {hi:.2f}]"
    )
    title = f"{label}, tumbling: NEES over {n_runs} runs, {100 * inside:.1f} % of steps inside the 95 % band"
    fig = plot_nees(t, avg, 6, n_runs, title=title)
    tidy_nees(fig, avg, hi)
    save(fig, path, written)
    return inside, (lo, hi)


def tidy_nees(fig: Figure, avg: np.ndarray, hi: float) -> None:
    """Room above the band and the legend in the empty lower part, clear of the curve."""
    ax = fig.axes[0]
    ax.set_ylim(0, max(1.4 * hi, 1.1 * float(np.nanmax(avg))))
    ax.legend(loc="lower right")


def plot_mekf_run(res, q_true, bias_true) -> Figure:
    """One MEKF run's errors at the tracker updates (the post-update sigma applies there), with +-3 sigma."""
    upd = res.updated
    err = res.errors(q_true, bias_true)[upd]
    names = ["x (cross)", "y (cross)", "z (roll)"]
    return plot_errors_with_bounds(
        res.t[upd],
        err,
        res.sigma[upd],
        labels=[f"attitude {n}" for n in names] + [f"bias {a}" for a in "xyz"],
        units=["arcsec"] * 3 + ["deg/h"] * 3,
        scale=[1 / ARCSEC] * 3 + [1 / DEG_H] * 3,
        title=r"MEKF errors with $\pm 3\sigma$ bounds at the tracker updates (run 1, tumbling)",
    )


def plot_closed_loop(cl: dict, gyro_label: str) -> Figure:
    """True vs estimated pointing error, and the estimation error at the tracker updates with the MEKF's +-3 sigma."""
    res = cl["result"]
    fig = Figure(figsize=(10, 9), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True, height_ratios=[1.4, 1, 1, 1])
    t = res.t
    axes[0].semilogy(t, np.degrees(res.error_angle), color="black", label="true (truth vs reference)")
    axes[0].semilogy(
        t, np.degrees(cl["seen"]), color="tab:orange", ls="--", label="seen by the controller (estimate vs reference)"
    )
    if "floor" in cl:
        axes[0].axhline(
            np.degrees(cl["floor"]),
            color="tab:green",
            ls=":",
            lw=1.2,
            label="RMS from gyro noise through the rate gain",
        )
    axes[0].set_ylabel("pointing error [deg]")
    axes[0].legend(loc="upper right")
    upd = cl["updated"]
    tu = t[upd]
    for i, name in enumerate(["x (cross-boresight)", "y (cross-boresight)", "z (roll)"]):
        ax = axes[i + 1]
        bound = 3 * cl["sigma"][upd, i] / ARCSEC
        ax.fill_between(tu, -bound, bound, color="tab:red", alpha=0.12, lw=0, label=r"$\pm 3\sigma$ (MEKF)")
        ax.plot(tu, bound, color="tab:red", lw=0.8)
        ax.plot(tu, -bound, color="tab:red", lw=0.8)
        err = cl["error"][upd, i] / ARCSEC
        ax.plot(tu, err, color="tab:blue", lw=0.7, label="estimation error (truth)")
        ax.set_ylabel(f"{name}\n[arcsec]")
        # Fit the errors and the settled band (the larger bound of the first seconds is clipped); the
        # first panel gets room above for the legend.
        m = max(float(np.abs(err).max()), float(bound[tu >= 10.0].max()))
        ax.set_ylim(-1.15 * m, (1.7 if i == 0 else 1.15) * m)
    axes[1].legend(loc="upper right", ncols=2)
    axes[1].set_title(
        f"estimation error at the tracker updates: outside $\\pm 3\\sigma$ at {100 * cl['outside']:.2f} % "
        "of them (0.27 % expected)",
        fontsize=10,
    )
    axes[-1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.margins(x=0)
    fig.suptitle(f"{SLEW_DEG:g} deg slew flown on the MEKF estimate, {gyro_label}")
    return fig


def plot_rate_ekf_slew(cl: dict, raw_noise: float) -> Figure:
    """Pointing error (true and seen) and the rate EKF's rate and bias errors with their +-3 sigma."""
    res = cl["result"]
    t = res.t
    fig = Figure(figsize=(10, 11), layout="constrained")
    axes = fig.subplots(5, 1, sharex=True, height_ratios=[1.3, 1, 1, 1, 1.2])
    axes[0].semilogy(t, np.degrees(res.error_angle), color="black", label="true (truth vs reference)")
    axes[0].semilogy(
        t, np.degrees(cl["seen"]), color="tab:orange", ls="--", lw=0.8, label="seen by the controller (tracker)"
    )
    late = t >= 0.4 * t[-1]
    axes[0].semilogy(
        t[late],
        np.degrees(cl["offset"][late]),
        color="tab:green",
        ls=":",
        lw=1.5,
        label=r"offset from the bias residual, $2\zeta|\delta b|/\omega_n$",
    )
    axes[0].set_ylabel("pointing error [deg]")
    axes[0].legend(loc="upper right")
    sig = cl["sigma"] / DEG_H
    settled = t >= 10.0
    for i, name in enumerate(["x", "y", "z"]):
        ax = axes[i + 1]
        bound = 3 * sig[:, i]
        ax.fill_between(t, -bound, bound, color="tab:red", alpha=0.12, lw=0, label=r"$\pm 3\sigma$ (rate EKF)")
        err = cl["rate_error"][:, i] / DEG_H
        ax.plot(t, err, color="tab:blue", lw=0.5, label="rate error (truth - estimate)")
        ax.axhline(raw_noise / DEG_H, color="tab:gray", ls=":", lw=1.0, label="raw gyro noise (1 sample, 1 sigma)")
        ax.axhline(-raw_noise / DEG_H, color="tab:gray", ls=":", lw=1.0)
        m = max(float(np.abs(err[settled]).max()), float(bound[settled].max()), raw_noise / DEG_H)
        ax.set_ylim(-1.15 * m, (1.9 if i == 0 else 1.15) * m)
        ax.set_ylabel(f"rate {name}\n[deg/h]")
    axes[1].legend(loc="upper right", ncols=3, fontsize=8)
    ax = axes[4]
    colors = ["tab:blue", "tab:green", "tab:purple"]
    for i, name in enumerate(["x", "y", "z"]):
        ax.plot(t, cl["bias_error"][:, i] / DEG_H, color=colors[i], lw=0.9, label=f"bias error {name}")
        ax.plot(t, 3 * sig[:, 3 + i], color=colors[i], ls="--", lw=0.7)
        ax.plot(t, -3 * sig[:, 3 + i], color=colors[i], ls="--", lw=0.7)
    ax.set_ylabel("bias [deg/h]")
    ax.legend(loc="upper right", ncols=3, fontsize=8, title=r"dashed: $\pm 3\sigma$", title_fontsize=8)
    axes[-1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.margins(x=0)
    fig.suptitle(f"{SLEW_DEG:g} deg slew flown on the rate EKF (filtered rate, star-tracker attitude)")
    return fig


if __name__ == "__main__":
    main()

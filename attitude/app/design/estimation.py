"""Section 5 of the design report: the rate EKF and the MEKF over a small Monte Carlo set.

Top floor (DESIGN.md), like :mod:`attitude.app.design.run` and :mod:`attitude.app.cli`:
it imports :mod:`estimation`; no ground-floor module imports it.

The truth is the slew flown in closed loop in section 4 (attitude, body rate
and wheel momenta at the gyro sample times). Each run draws its own gyro
errors from the file's gyro (angle random walk, the bias instability as a
Gauss-Markov bias, rate random walk: :meth:`attitude.sensors.Gyro.sample_errors`;
the filters model the bias as a random walk tuned by ``Gyro.filter_sigma_u``), its star-tracker noise
and its initial estimation errors from the filters' initial covariance, so a
consistent filter has an average NEES inside the chi-square band from the
first step on. The gyro's deterministic errors (scale factor, misalignment,
quantisation), which neither filter models, are left out: the check
isolates the noise model the filters are built on. (The closed loop of
section 4 flies the full gyro model.)

* MEKF (:func:`estimation.mekf.run_mekf`, batched numpy path): each gyro
  sample is the mean rate over the interval ending at it, taken from the
  true attitude increment (what the filter assumes), plus the errors; the
  tracker samples every ``period / gyro period`` steps, except while the Sun
  blinds it.
* Rate EKF (:func:`estimation.rate_ekf.run_rate_ekf`, one filterpy filter
  per run): each gyro sample is the true rate at the sample time plus the
  errors (its model); the wheel momenta come from the flight (tachometers)
  and the torque from outside the wheels (in orbit: the environment torques,
  :attr:`SimulationResult.external_torque`) is the filter's known external
  torque, exactly (a flight filter takes it from its on-board environment
  model and budgets that model's error in its torque noise), so
  :data:`RATE_EKF_TORQUE_NOISE` is only a floor. Left out, that torque
  (0.4 uN m at the peak on the default spacecraft) is integrated by the
  flight but not by the filter's Euler's equations: a rate error common to
  every run, which the filter does not allow for (the average NEES leaves
  its band during the hold; docs/rate_ekf.md, "Torque inputs").
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.app.assembly import ATTITUDE_SIGMA0_DEG, RATE_EKF_TORQUE_NOISE, RATE_SIGMA0_DEG_PER_S
from attitude.config import SpacecraftConfig
from attitude.sensors import ARCSEC
from attitude.simulation.engine import SimulationResult
from estimation.consistency import chi2_band, fraction_inside_band, plot_errors_with_bounds, plot_nees
from estimation.mekf import run_mekf
from estimation.rate_ekf import run_rate_ekf

__all__ = ["CONFIDENCE", "FRACTION_INSIDE_MIN", "estimation_study"]

#: Confidence of the chi-square band of the average NEES.
CONFIDENCE = 0.95
#: Advisory threshold on the fraction of steps inside the band: the NEES of neighbouring steps is
#: strongly correlated, so even a consistent filter leaves the band for stretches; the MEKF tests use
#: 0.80 for 64 runs (tests/estimation/mekf/test_filter.py, where it sits below the 5th percentile of 100 campaigns).
FRACTION_INSIDE_MIN = 0.80

_DEG_PER_H = math.pi / 180.0 / 3600.0  # [rad/s] in one deg/h


def _consistency(label: str, nees_runs: np.ndarray, runs: int) -> dict[str, Any]:
    avg = nees_runs.mean(axis=0)
    lo, hi = chi2_band(6, runs, CONFIDENCE)
    inside = float(fraction_inside_band(avg, 6, runs, CONFIDENCE))
    return {
        "label": label,
        "runs": runs,
        "steps": int(avg.size),
        "dof": 6,
        "nees_mean": float(np.mean(avg)),
        "band_low": lo,
        "band_high": hi,
        "fraction_inside": inside,
        "percent_inside": 100.0 * inside,
    }, avg


def estimation_study(
    config: SpacecraftConfig, flight: SimulationResult | None, mekf_runs: int, rate_ekf_runs: int, seed: Any
) -> tuple[dict[str, Any] | None, dict[str, Figure]]:
    """Section 5: errors with 3-sigma bounds and the average NEES of both filters (module docstring).

    Returns None and no figures when there is no flight to use as the truth.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    flight : SimulationResult or None
        The closed-loop flight of section 4 (the truth); None when there is none.
    mekf_runs : int
        Number of MEKF Monte Carlo runs.
    rate_ekf_runs : int
        Number of rate-EKF Monte Carlo runs.
    seed : int, numpy.random.SeedSequence or None
        Root of the runs' random streams.
    """
    if flight is None:
        return None, {}
    gyro, tracker = assembly.gyro(config), assembly.star_tracker(config)
    tick = float(flight.info["dt"])
    every = max(1, round(gyro.period / tick))
    t = flight.t[::every]
    q_true = flight.q[::every]
    n = t.size
    dt = gyro.period
    tracker_every = max(1, round(tracker.period / gyro.period))
    blind = np.array([tracker.sun_blinded(tt, qq) for tt, qq in zip(t, q_true)])
    mask = np.zeros(n, dtype=bool)
    mask[::tracker_every] = True
    mask &= ~blind
    sig_a0 = assembly.attitude_sigma0()
    sig_b0 = assembly.gyro_bias_sigma0(config)
    sig_w0 = math.radians(RATE_SIGMA0_DEG_PER_S)
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    seed_mekf, seed_rate = root.spawn(2)

    # MEKF, batched.
    runs = mekf_runs
    w_inc = quat.to_rotation_vector(quat.multiply(quat.conjugate(q_true[:-1]), q_true[1:])) / dt
    g = np.empty((runs, n, 3))
    y = np.full((runs, n, 4), np.nan)
    bias = np.empty((runs, n, 3))
    q0 = np.empty((runs, 4))
    for r, child in enumerate(seed_mekf.spawn(runs)):
        rng = np.random.default_rng(child)
        errors, biases = gyro.sample_errors(n - 1, rng, bias0=rng.standard_normal(3) * sig_b0)
        g[r, 1:] = w_inc + errors
        g[r, 0] = g[r, 1]  # row 0 only sets the first rate estimate
        bias[r] = biases
        y[r, mask] = tracker.add_noise(q_true[mask], rng)
        q0[r] = quat.multiply(q_true[0], quat.from_rotation_vector(rng.standard_normal(3) * sig_a0))
    # The samples above are interval means (angle increments): the MEKF's gyro model.
    p0 = assembly.mekf_initial_covariance(attitude_sigma_rad=sig_a0, bias_sigma_rad_per_s=sig_b0)
    mekf = assembly.mekf(assembly.gyro(config, sampling="mean"), tracker, q0=q_true[0], P0=p0)
    res = run_mekf(mekf, t, g, y, tracker_mask=np.broadcast_to(mask, (runs, n)), q0=q0)
    mekf_nees = res.nees(q_true, bias)
    mekf_out, mekf_avg = _consistency("MEKF (attitude and gyro bias)", mekf_nees, runs)
    err = res.errors(q_true, bias)
    sigma = res.sigma
    mekf_out.update(
        {
            "tracker_updates_per_run": int(np.sum(mask)),
            "attitude_error_rms_end_arcsec": float(np.sqrt(np.mean(np.sum(err[:, -1, :3] ** 2, axis=-1))) / ARCSEC),
            "attitude_3sigma_end_arcsec": float(3.0 * np.max(np.mean(sigma[:, -1, :3], axis=0)) / ARCSEC),
            "bias_error_rms_end_deg_per_h": float(np.sqrt(np.mean(np.sum(err[:, -1, 3:] ** 2, axis=-1))) / _DEG_PER_H),
            "bias_3sigma_end_deg_per_h": float(3.0 * np.max(np.mean(sigma[:, -1, 3:], axis=0)) / _DEG_PER_H),
        }
    )

    # Rate EKF, one filter per run.
    runs_r = rate_ekf_runs
    omega, h = flight.omega[::every], flight.h_wheels[::every]
    external = _interval_means(flight.external_torque, every, n)
    wheels, body = assembly.reaction_wheels(config), assembly.rigid_body(config)
    nees_r, results_r = [], []
    for child in seed_rate.spawn(runs_r):
        rng = np.random.default_rng(child)
        errors, biases = gyro.sample_errors(n, rng, bias0=rng.standard_normal(3) * sig_b0)
        x0 = np.concatenate([omega[0] + rng.standard_normal(3) * sig_w0, biases[1] + rng.standard_normal(3) * sig_b0])
        ekf = assembly.rate_ekf(config, gyro, x0=x0, t0=float(t[0]), wheels=wheels, body=body)
        rr = run_rate_ekf(
            ekf,
            t,
            omega + errors,
            wheel_momentum=h,
            external_torque=external,
            omega_true=omega,
            bias_true=biases[1:],
        )
        nees_r.append(rr.nees())
        results_r.append(rr)
    rate_out, rate_avg = _consistency("rate EKF (body rate and gyro bias)", np.array(nees_r), runs_r)
    err_r = np.array([rr.errors() for rr in results_r])
    sig_r = np.array([rr.sigma for rr in results_r])
    rate_out.update(
        {
            "torque_noise_Nm_per_sqrt_Hz": RATE_EKF_TORQUE_NOISE,
            "external_torque_peak_uNm": float(np.max(np.linalg.norm(external, axis=1)) * 1e6),
            "rate_error_rms_end_deg_per_h": float(
                np.sqrt(np.mean(np.sum(err_r[:, -1, :3] ** 2, axis=-1))) / _DEG_PER_H
            ),
            "rate_3sigma_end_deg_per_h": float(3.0 * np.max(np.mean(sig_r[:, -1, :3], axis=0)) / _DEG_PER_H),
            "bias_error_rms_end_deg_per_h": float(
                np.sqrt(np.mean(np.sum(err_r[:, -1, 3:] ** 2, axis=-1))) / _DEG_PER_H
            ),
            "bias_3sigma_end_deg_per_h": float(3.0 * np.max(np.mean(sig_r[:, -1, 3:], axis=0)) / _DEG_PER_H),
            "healthy_runs": int(sum(rr.healthy for rr in results_r)),
        }
    )
    out = {
        "truth": "the closed-loop slew of section 4",
        "steps": n,
        "gyro_period_s": dt,
        "tracker_every_steps": tracker_every,
        "tracker_blinded_steps": int(np.sum(blind)),
        "attitude_sigma0_deg": ATTITUDE_SIGMA0_DEG,
        "bias_sigma0_deg_per_h": sig_b0 / _DEG_PER_H,
        "rate_sigma0_deg_per_s": RATE_SIGMA0_DEG_PER_S,
        "confidence": CONFIDENCE,
        "confidence_percent": 100.0 * CONFIDENCE,
        # The mount error the campaign disperses and judges as a consider covariance (sections._estimation).
        "tracker_mount_sigma_arcsec": float(np.sqrt(assembly.tracker_misalignment_covariance(config)[0, 0]) / ARCSEC),
        "mekf": mekf_out,
        "rate_ekf": rate_out,
    }
    figures = {
        "mekf_errors": _mekf_error_figure(t, err, sigma[0], tracker_every),
        "rate_ekf_errors": results_r[0].plot("errors"),
        "mekf_nees": plot_nees(t, mekf_avg, 6, runs, confidence=CONFIDENCE, title=_nees_title("MEKF", mekf_out)),
        "rate_ekf_nees": plot_nees(
            t, rate_avg, 6, runs_r, confidence=CONFIDENCE, title=_nees_title("rate EKF", rate_out)
        ),
    }
    return out, figures


def _interval_means(torque_ticks: np.ndarray, every: int, n: int) -> np.ndarray:
    """Torque held over each gyro interval [N m], (n, 3): row ``k`` the mean over ``(t[k-1], t[k]]``, row 0 zero.

    ``torque_ticks`` is held from each tick's time (a :class:`SimulationResult`
    row), ``every`` ticks make one gyro interval: what
    :func:`estimation.rate_ekf.run_rate_ekf` takes as ``external_torque``.
    """
    out = np.zeros((n, 3))
    out[1:] = torque_ticks[: (n - 1) * every].reshape(n - 1, every, 3).mean(axis=1)
    return out


def _mekf_error_figure(t: np.ndarray, errors: np.ndarray, sigma: np.ndarray, tracker_every: int) -> Figure:
    """Run 1's errors, the spread of all runs and the 3-sigma envelope: the largest sigma between two tracker updates.

    Between updates the attitude sigma saw-tooths (it grows with the gyro
    noise and drops at each update); drawn at every step it fills a band.
    The envelope, the largest sigma within ``tracker_every - 1`` steps either
    side, holds the pre-update value: the bound every error must respect.
    The attitude error is the MEKF's ``delta_theta`` (``q_true = q_est ⊗
    exp(delta_theta / 2)``), a small rotation in body axes; the bias error
    is in body axes too (the gyro's axes as the filter models them).
    """
    n = sigma.shape[0]
    envelope = sigma.copy()
    for shift in range(1, min(tracker_every, n)):
        envelope[: n - shift] = np.maximum(envelope[: n - shift], sigma[shift:])
        envelope[shift:] = np.maximum(envelope[shift:], sigma[: n - shift])
    return plot_errors_with_bounds(
        t,
        errors,
        envelope,
        labels=[f"δθ{a} (body)" for a in "xyz"] + [f"δb{a} (body)" for a in "xyz"],
        units=["arcsec"] * 3 + ["deg/h"] * 3,
        scale=[1.0 / ARCSEC] * 3 + [1.0 / _DEG_PER_H] * 3,
        title=(
            f"MEKF errors, {errors.shape[0]} runs: attitude as a small rotation in body axes "
            r"($q_{true} = \hat q \otimes \delta q(\delta\theta)$), gyro bias in body axes"
            "\n"
            r"filter's $\pm 3\sigma$: its envelope, the largest between tracker updates"
        ),
    )


def _nees_title(name: str, e: dict[str, Any]) -> str:
    return (
        f"{name}: average NEES of {e['runs']} runs, mean {e['nees_mean']:.2f}, "
        f"{100 * e['fraction_inside']:.0f}% of steps inside the band"
    )

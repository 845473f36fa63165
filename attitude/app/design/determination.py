"""The design report's determination section: attitude from the Sun and the magnetic field over an orbit.

Top floor (DESIGN.md), like :mod:`attitude.app.design.estimation`: it imports
:mod:`estimation`; no ground-floor module imports it. It runs when the file
has an ``[orbit]`` and a direction sensor (``[magnetometer]``,
``[coarse_sun_sensors]``, ``[fine_sun_sensor]``).

**Truth.** One orbit of the nadir (LVLH) hold, the attitude and rate of the
orbit's LVLH frame (:meth:`orbit.q_LN`), sampled every :data:`STEP_S` (or
the gyro's period when longer), with the environment track of the file
(Sun direction, eclipse, field). The sensors sample at every step that is a
multiple of their period (a sensor faster than the step is read once per
step: the figures are those of the step, conservative for faster sensors).

**Two sensor models.** ``noise``: each sensor's white noise alone, which is
what QUEST and the MEKF model; their consistency (NEES) is judged on it.
``file``: the sensors as the file builds them (the magnetometer's bias,
scale factor and misalignment, the fine sensor's bias, the cells' Earth
albedo): the accuracy the hardware gives. The estimators do not estimate
those errors, so with them the filter is over-confident; the section says by
how much rather than hide it (see docs/sensors.md).

**Static determination.** At each step with a Sun direction (the fine
sensor in view, else the coarse cells' least squares) and the field: QUEST
(Shuster and Oh 1981) with the QUEST covariance, and TRIAD with the more
accurate vector as primary. The coarse cells' covariance enters QUEST as
the scalar ``sqrt(largest eigenvalue)``: exact for cells in opposite pairs
(a cube's covariance is isotropic in the plane), conservative otherwise. Its NEES (3 degrees of freedom) over all
samples and runs is judged against the chi-square band of that mean
(independent samples: white noise).

**MEKF.** The batch MEKF (:func:`estimation.mekf.run_mekf`) with the gyro's
angle increments over each step (the file's noise figures) and the vector
sensors, no star tracker (the Sun-and-field determination of a spacecraft
without one, or with it blinded); initial errors drawn from its initial
covariance (:data:`ATTITUDE_SIGMA0_DEG`, a coarse start). Average NEES
(6 degrees of freedom) against its band, errors in sunlight and eclipse.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.app.design.estimation import FRACTION_INSIDE_MIN
from attitude.config import SpacecraftConfig
from attitude.plain import plain_float as _f
from attitude.simulation.direction_sensors import field_direction_sigma
from estimation.consistency import band_verdict, chi2_band, fraction_inside_band, nees, plot_nees
from estimation.determination.quest import quest
from estimation.determination.triad import triad
from estimation.determination.vectors import OBSERVABILITY_MIN, observability
from estimation.mekf import run_mekf
from estimation.mekf.batch import VectorSamples

__all__ = ["ATTITUDE_SIGMA0_DEG", "CONFIDENCE", "STEP_S", "determination_figures", "determination_study"]

#: Step of the study [s]: the MEKF's step and the sensors' sampling grid over one orbit (about 5,700 steps
#: in LEO: the batch filter runs the orbit in seconds).
STEP_S = 1.0
#: Initial attitude knowledge of the direction-sensor MEKF, 1 sigma per axis [deg]: a coarse start (the
#: knowledge of a coarse Sun sensor and magnetometer; see attitude.app.assembly.ATTITUDE_SIGMA0_DEG).
ATTITUDE_SIGMA0_DEG = 1.0
#: Confidence of the chi-square bands.
CONFIDENCE = 0.95
MODELS = ("noise", "file")
#: Runs drawn in the MEKF figure (more only thicken the cloud).
RUNS_DRAWN = 5

_DEG = math.pi / 180.0


def systematic_errors(config: SpacecraftConfig, sensors: list[str]) -> list[str]:
    """The errors of the flown sensors that the estimators do not model (what the ``file`` model adds), as text.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    sensors : list of str
        The direction sensors flown (table names).

    Returns
    -------
    list of str
        One entry per error; empty when the sensors have white noise only.
    """
    out = []
    m = config.magnetometer_config if "magnetometer" in sensors else None
    if m is not None:
        bias = np.broadcast_to(np.asarray(m.bias_nT, dtype=float), (3,))
        if np.any(bias):
            out.append(f"magnetometer bias {np.linalg.norm(bias):.0f} nT")
        scale = np.broadcast_to(np.asarray(m.scale_factor_ppm, dtype=float), (3,))
        if np.any(scale):
            out.append(f"magnetometer scale factor up to {np.max(np.abs(scale)):.0f} ppm")
        if np.any(m.misalignment_deg):
            out.append(f"magnetometer misalignment {np.linalg.norm(m.misalignment_deg):.2f} deg")
        if m.quantization_nT:
            out.append(f"magnetometer quantisation {m.quantization_nT:g} nT")
    c = config.coarse_sun_sensors_config if "coarse_sun_sensors" in sensors else None
    if c is not None and c.albedo_percent:
        out.append(f"Earth albedo on the coarse cells, {c.albedo_percent:g} % of full scale")
    f = config.fine_sun_sensor_config if "fine_sun_sensor" in sensors else None
    if f is not None and np.any(f.bias_deg):
        out.append(f"fine Sun sensor bias {np.max(np.abs(f.bias_deg)):g} deg")
    return out


def _truth(config: SpacecraftConfig) -> dict[str, np.ndarray] | None:
    """One orbit of the nadir hold: times, attitudes, interval-mean rates and the environment in N and B."""
    env = assembly.orbit_environment(config)
    if env is None:
        return None
    gyro_period = config.gyro_config.period_s
    step = max(STEP_S, gyro_period)
    orbit = env.orbit
    n = round(float(orbit.period) / step) + 1
    t = step * np.arange(n)
    q = np.asarray(orbit.q_LN(t), dtype=float)
    track = env.track(t)
    nadir_N = -track.position_N / np.linalg.norm(track.position_N, axis=-1, keepdims=True)
    # The mean rate over each interval from the attitude increment (what an integrating gyro measures).
    w_inc = quat.to_rotation_vector(quat.multiply(quat.conjugate(q[:-1]), q[1:])) / step
    return {
        "step": np.float64(step),
        "t": t,
        "q": q,
        "w_inc": w_inc,
        "sun_N": track.sun_N,
        "field_N": track.field_N,
        "illumination": track.illumination,
        "sun_B": quat.rotate_inverse(q, track.sun_N),
        "field_B": quat.rotate_inverse(q, track.field_N),
        "nadir_B": quat.rotate_inverse(q, nadir_N),
    }


def _every(period: float, step: float) -> int:
    return max(1, round(period / step))


def _draw(
    sensors: dict[str, Any], truth: dict[str, np.ndarray], runs: int, seeds: list[np.random.SeedSequence]
) -> dict[str, VectorSamples]:
    """Each sensor's samples for every run (``VectorSamples`` histories (runs, n, ...), NaN rows: none)."""
    n, step = truth["t"].size, float(truth["step"])
    rngs = [np.random.default_rng(s) for s in seeds]
    out: dict[str, VectorSamples] = {}
    mag = sensors["magnetometer"]
    if mag is not None:
        normals = np.stack([g.standard_normal((n, 3)) for g in rngs])
        field_B = np.broadcast_to(truth["field_B"], (runs, n, 3))
        sample = mag.measure_batch(0.0, field_B.reshape(-1, 3), normals.reshape(-1, 3)).reshape(runs, n, 3)
        sample[:, np.arange(n) % _every(mag.period, step) != 0] = np.nan
        sigma = np.broadcast_to(field_direction_sigma(mag.sigma, truth["field_B"]), (runs, n))
        out["magnetometer"] = VectorSamples(sample, truth["field_N"], sigma=sigma)
    coarse = sensors["coarse_sun_sensors"]
    if coarse is not None:
        ideal = coarse.ideal_currents(truth["sun_B"], truth["illumination"], truth["nadir_B"])
        currents = ideal + coarse.noise * coarse.full_scale * np.stack(
            [g.standard_normal((n, coarse.n_cells)) for g in rngs]
        )
        sun_B, valid, _, cov = coarse.sun_vectors(currents)
        valid &= (np.arange(n) % _every(coarse.period, step) == 0)[None]
        sun_B = np.where(valid[..., None], sun_B, np.nan)
        # A valid estimate's covariance is rank 2 (none along the vector); invalid rows get any PSD filler.
        cov = np.where(valid[..., None, None], cov, np.eye(3))
        out["coarse_sun_sensors"] = VectorSamples(sun_B, truth["sun_N"], covariance=cov)
    fine = sensors["fine_sun_sensor"]
    if fine is not None:
        normals = np.stack([g.standard_normal((n, 2)) for g in rngs])
        sample = fine.sample_batch(np.broadcast_to(truth["sun_B"], (runs, n, 3)), truth["illumination"], normals)
        sample[:, np.arange(n) % _every(fine.period, step) != 0] = np.nan
        out["fine_sun_sensor"] = VectorSamples(sample, truth["sun_N"], sigma=fine.sigma)
    return out


def _sun_and_field(samples: dict[str, VectorSamples]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Per step and run: the Sun vector (fine if in view, else coarse), its sigma [rad], and a mask (None: no Sun)."""
    fine, coarse = samples.get("fine_sun_sensor"), samples.get("coarse_sun_sensors")
    if fine is None and coarse is None:
        return None
    shape = (fine or coarse).vector_B.shape
    sun = np.full(shape, np.nan)
    sigma = np.full(shape[:-1], np.nan)
    if coarse is not None:
        sun = np.array(coarse.vector_B, dtype=float)
        # The coarse covariance is anisotropic; its largest axis as QUEST's scalar sigma (conservative).
        sigma = np.sqrt(np.linalg.eigvalsh(coarse.covariance)[..., -1])
    if fine is not None:
        seen = ~np.isnan(fine.vector_B[..., 0])
        sun = np.where(seen[..., None], fine.vector_B, sun)
        sigma = np.where(seen, fine.sigma, sigma)
    return sun, sigma, ~np.isnan(sun[..., 0])


def _static(samples: dict[str, VectorSamples], truth: dict[str, np.ndarray]) -> dict[str, Any] | None:
    """QUEST and TRIAD at every step with a Sun vector and the field (None without both kinds of sensor)."""
    sun = _sun_and_field(samples)
    mag = samples.get("magnetometer")
    if sun is None or mag is None:
        return None
    sun_B, sun_sigma, has_sun = sun
    ok = has_sun & ~np.isnan(mag.vector_B[..., 0])
    runs, n = ok.shape
    sun_N = np.broadcast_to(truth["sun_N"], (runs, n, 3))
    field_N = np.broadcast_to(truth["field_N"], (runs, n, 3))
    vb = np.stack([sun_B, mag.vector_B], axis=-2)[ok]
    vn = np.stack([sun_N, field_N], axis=-2)[ok]
    sig = np.stack([sun_sigma, np.broadcast_to(mag.sigma, (runs, n))], axis=-1)[ok]
    weak = observability(vb, 1.0 / sig**2) < OBSERVABILITY_MIN
    keep = np.flatnonzero(ok)[~weak]
    vb, vn, sig = vb[~weak], vn[~weak], sig[~weak]
    error_q = np.full((runs * n,), np.nan)
    error_t = np.full((runs * n,), np.nan)
    three_sigma = np.full((runs * n,), np.nan)
    nees_values = np.array([])
    if keep.size:
        q_true = np.broadcast_to(truth["q"], (runs, n, 4)).reshape(-1, 4)[keep]
        sol = quest(vb, vn, sigma=sig)
        err = quat.to_rotation_vector(quat.multiply(quat.conjugate(q_true), sol.q_BN))
        error_q[keep] = np.linalg.norm(err, axis=-1)
        nees_values = np.einsum("ki,kij,kj->k", err, np.linalg.inv(sol.covariance), err)
        three_sigma[keep] = 3.0 * np.sqrt(np.linalg.eigvalsh(sol.covariance)[..., -1])
        first = sig[:, 0] <= sig[:, 1]  # the more accurate vector is TRIAD's primary
        p = np.where(first[:, None], 0, 1)
        s_ = 1 - p
        pick = np.take_along_axis
        tri = triad(
            pick(vb, p[..., None], axis=1)[:, 0],
            pick(vn, p[..., None], axis=1)[:, 0],
            pick(vb, s_[..., None], axis=1)[:, 0],
            pick(vn, s_[..., None], axis=1)[:, 0],
        )
        error_t[keep] = quat.error_angle(q_true, tri.q_BN)
    return {
        "available": ok,
        "weak": int(np.sum(weak)),
        "quest_error_rad": error_q.reshape(runs, n),
        "triad_error_rad": error_t.reshape(runs, n),
        "quest_3sigma_rad": three_sigma.reshape(runs, n),
        "nees": nees_values,
    }


def _static_summary(st: dict[str, Any]) -> dict[str, Any]:
    e = np.degrees(st["quest_error_rad"])
    e = e[~np.isnan(e)]
    if e.size == 0:
        return {"solutions": 0}
    # Independent samples (white noise): the band of the mean of that many chi-square(3) values.
    low, high = chi2_band(3, st["nees"].size, CONFIDENCE)
    mean = float(np.mean(st["nees"]))
    tri = np.degrees(st["triad_error_rad"])
    tri = tri[~np.isnan(tri)]
    return {
        "solutions": int(e.size),
        "quest_error_rms_deg": _f(float(np.sqrt(np.mean(e**2)))),
        "quest_error_p95_deg": _f(float(np.percentile(e, 95))),
        "quest_error_max_deg": _f(float(e.max())),
        "quest_3sigma_median_deg": _f(float(np.nanmedian(np.degrees(st["quest_3sigma_rad"])))),
        "triad_error_rms_deg": _f(float(np.sqrt(np.mean(tri**2)))),
        "nees_mean": _f(mean),
        "nees_band_low": _f(low),
        "nees_band_high": _f(high),
        "verdict": band_verdict(mean, low, high),
    }


def _stacked(models: list[dict[str, VectorSamples]]) -> dict[str, VectorSamples]:
    """The models' samples one after the other along the runs axis (one batch filter flies them all)."""
    out = {}
    for name, first in models[0].items():
        parts = [m[name] for m in models]
        shape = first.vector_B.shape[:-1]
        out[name] = VectorSamples(
            np.concatenate([p.vector_B for p in parts]),
            first.reference_N,
            None if first.sigma is None else np.concatenate([np.broadcast_to(p.sigma, shape) for p in parts]),
            None
            if first.covariance is None
            else np.concatenate([np.broadcast_to(p.covariance, (*shape, 3, 3)) for p in parts]),
        )
    return out


def _mekf_runs(
    config: SpacecraftConfig,
    truth: dict[str, np.ndarray],
    samples: dict[str, VectorSamples],
    runs: int,
    seed: np.random.SeedSequence,
) -> tuple[Any, np.ndarray]:
    """The batch MEKF over the orbit; returns its result and the true biases (runs, n, 3).

    ``samples`` may hold several models' runs one after the other (:func:`_stacked`): every block of
    ``runs`` rows gets the same gyro errors and initial errors, so the blocks differ by their sensors alone.
    """
    step = float(truth["step"])
    gyro = assembly.gyro(config, "mean", period=step)
    t, q_true, w_inc = truth["t"], truth["q"], truth["w_inc"]
    n = t.size
    sig_a0 = ATTITUDE_SIGMA0_DEG * _DEG
    sig_b0 = assembly.gyro_bias_sigma0(config)
    g = np.empty((runs, n, 3))
    bias = np.empty((runs, n, 3))
    q0 = np.empty((runs, 4))
    for r, child in enumerate(seed.spawn(runs)):
        rng = np.random.default_rng(child)
        errors, bias[r] = gyro.sample_errors(n - 1, rng, bias0=rng.standard_normal(3) * sig_b0)
        g[r, 1:] = w_inc + errors
        g[r, 0] = g[r, 1]
        q0[r] = quat.multiply(q_true[0], quat.from_rotation_vector(rng.standard_normal(3) * sig_a0))
    p0 = assembly.mekf_initial_covariance(attitude_sigma_rad=sig_a0, bias_sigma_rad_per_s=sig_b0)
    mekf = assembly.vector_mekf(gyro, q_true[0], p0, tuple(samples))
    copies = next(iter(samples.values())).vector_B.shape[0] // runs
    g, bias, q0 = (np.concatenate([a] * copies) for a in (g, bias, q0))
    result = run_mekf(mekf, t, g, np.full((runs * copies, n, 4), np.nan), q0=q0, vectors=samples)
    return result, bias


def _mekf_summary(
    result: Any, block: slice, truth: dict[str, np.ndarray], bias: np.ndarray
) -> tuple[dict[str, Any], dict]:
    """NEES, errors and sigmas of the runs ``block`` of the batch result."""
    P = result.P[block]
    runs = P.shape[0]
    err = result.errors(truth["q"], np.concatenate([bias] * (result.q.shape[0] // runs)))[block]
    nees_runs = nees(err, P)
    avg = nees_runs.mean(axis=0)
    lo, hi = chi2_band(6, runs, CONFIDENCE)
    angle = np.degrees(np.linalg.norm(err[..., :3], axis=-1))
    sigma_max = np.degrees(np.sqrt(np.linalg.eigvalsh(P[..., :3, :3])[..., -1]))
    # Errors and sigmas past the first tenth of the orbit (the convergence from the coarse start); the NEES
    # over every step (the initial errors are drawn from the filter's P0, so it holds from the start).
    settled = truth["t"] >= 0.1 * truth["t"][-1]
    lit = truth["illumination"] > 0.5
    parts_lo, parts_hi = chi2_band(3, runs, CONFIDENCE)
    attitude_nees = nees(err[..., :3], P[..., :3, :3]).mean(axis=0)
    bias_nees = nees(err[..., 3:], P[..., 3:, 3:]).mean(axis=0)
    out: dict[str, Any] = {
        "runs": runs,
        "nees_mean": _f(float(np.mean(avg))),
        "band_low": _f(lo),
        "band_high": _f(hi),
        "fraction_inside": _f(float(fraction_inside_band(avg, 6, runs, CONFIDENCE))),
        # One-sided: the steps whose average NEES is not above the band (the covariance not too small).
        "fraction_not_above": _f(float(np.mean(avg <= hi))),
        # The attitude alone (3 dof): a weakly observed axis (one direction) can hide in the 6-dof sum.
        "attitude_fraction_inside": _f(float(fraction_inside_band(attitude_nees, 3, runs, CONFIDENCE))),
        "attitude_fraction_not_above": _f(float(np.mean(attitude_nees <= parts_hi))),
        "attitude_nees_mean": _f(float(np.mean(attitude_nees))),
        "bias_nees_mean": _f(float(np.mean(bias_nees))),
        "part_band_low": _f(parts_lo),
        "part_band_high": _f(parts_hi),
    }
    # Neighbouring steps' NEES are correlated, so the verdict is the fraction of steps inside the band (the
    # rule of section 5), for the whole state and for the attitude alone; when it fails, the side it fails on.
    out["fraction_not_above_min"] = min(out["fraction_not_above"], out["attitude_fraction_not_above"])
    if min(out["fraction_inside"], out["attitude_fraction_inside"]) >= FRACTION_INSIDE_MIN:
        out["verdict"] = "consistent"
    elif out["fraction_not_above_min"] < FRACTION_INSIDE_MIN:
        out["verdict"] = "over-confident"
    else:
        out["verdict"] = "conservative"
    for name, where in (("sunlit", settled & lit), ("eclipse", settled & ~lit)):
        if not np.any(where):
            out[f"error_rms_{name}_deg"] = None
            out[f"error_max_{name}_deg"] = None
            out[f"sigma_rms_{name}_deg"] = None
            continue
        out[f"error_rms_{name}_deg"] = _f(float(np.sqrt(np.mean(angle[:, where] ** 2))))
        out[f"error_max_{name}_deg"] = _f(float(angle[:, where].max()))
        # The filter's own 1-sigma of the error angle, sqrt(trace P_att), to set beside the RMS error.
        trace = np.trace(P[:, where, :3, :3], axis1=-2, axis2=-1)
        out[f"sigma_rms_{name}_deg"] = _f(float(np.degrees(np.sqrt(np.mean(trace)))))
    histories = {"nees_avg": avg, "angle_deg": angle, "sigma_max_deg": sigma_max}
    return out, histories


def determination_study(config: SpacecraftConfig, runs: int, seed: Any) -> tuple[dict[str, Any] | None, dict[str, Any]]:
    """The section (module docstring): JSON-ready results and the histories its figures need.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    runs : int
        Monte Carlo runs of each sensor model (>= 2).
    seed : int, numpy.random.SeedSequence or None
        Root of the runs' random streams.

    Returns
    -------
    tuple
        ``(results or None, histories)``; None (and no histories) without an
        ``[orbit]`` or a direction sensor.
    """
    tables = (
        ("magnetometer", config.magnetometer_config),
        ("coarse_sun_sensors", config.coarse_sun_sensors_config),
        ("fine_sun_sensor", config.fine_sun_sensor_config),
    )
    names = [name for name, table in tables if table is not None]
    excluded = []
    if config.magnetometer_config is not None and config.magnetometer_config.noise_nT == 0.0:
        # A noise-free direction has no weight an estimator could give it (1 / sigma^2 is infinite).
        names.remove("magnetometer")
        excluded.append("magnetometer (noise_nT = 0: a noise-free direction cannot be weighted)")
    truth = _truth(config) if names else None
    if truth is None:
        return None, {}
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    sample_seeds, filter_seed = root.spawn(2)
    run_seeds = sample_seeds.spawn(runs)
    out: dict[str, Any] = {
        "sensors": names,
        "step_s": _f(float(truth["step"])),
        "duration_s": _f(float(truth["t"][-1])),
        "steps": int(truth["t"].size),
        "runs": runs,
        "eclipse_fraction": _f(float(np.mean(truth["illumination"] < 0.5))),
        "attitude_sigma0_deg": ATTITUDE_SIGMA0_DEG,
        "confidence_percent": 100.0 * CONFIDENCE,
        "sensor_labels": [SENSOR_NAMES[n] for n in names],
        "excluded_sensors": excluded,
        "systematic_errors": systematic_errors(config, names),
        "static": {},
        "mekf": {},
    }
    histories: dict[str, Any] = {"t": truth["t"], "illumination": truth["illumination"]}
    field_size = np.linalg.norm(truth["field_N"], axis=-1)
    if np.all(field_size > 0.0):
        cosine = np.sum(truth["sun_N"] * truth["field_N"], axis=-1) / field_size
        histories["sun_field_angle_deg"] = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    else:
        histories["sun_field_angle_deg"] = None
    # The file's sensors with white noise alone would repeat the noise model.
    models = [m for m in MODELS if m == "noise" or out["systematic_errors"]]
    drawn = []
    for model in models:
        # The same streams for both models: the file model's samples differ from the noise model's by
        # the systematic errors alone.
        sensors = assembly.direction_sensors(config, white_noise_only=model == "noise")
        samples = _draw({k: (v if k in names else None) for k, v in sensors.items()}, truth, runs, run_seeds)
        drawn.append(samples)
        if model == "noise":
            # Over the steps the sensor samples with at least half the Sun's disk.
            sunlit = truth["illumination"] >= 0.5
            step = float(truth["step"])
            found = {}
            for name in ("coarse_sun_sensors", "fine_sun_sensor"):
                if name in samples:
                    read = sunlit & (np.arange(truth["t"].size) % _every(sensors[name].period, step) == 0)
                    found[name] = _f(float(np.mean(~np.isnan(samples[name].vector_B[:, read, 0]))))
            out["sun_vector_fraction_of_sunlit"] = found
        static = _static(samples, truth)
        if static is not None:
            out["static"][model] = _static_summary(static)
            out["static"][model]["available_fraction"] = _f(float(np.mean(static["available"])))
            histories[f"static_{model}"] = static
    result, bias = _mekf_runs(config, truth, _stacked(drawn), runs, filter_seed)
    for i, model in enumerate(models):
        block = slice(i * runs, (i + 1) * runs)
        out["mekf"][model], histories[f"mekf_{model}"] = _mekf_summary(result, block, truth, bias[block])
    if not out["static"]:
        out["static"] = None
    return out, histories


#: The direction sensors by table name, as the report names them.
SENSOR_NAMES = {
    "magnetometer": "magnetometer",
    "coarse_sun_sensors": "coarse Sun sensors",
    "fine_sun_sensor": "fine Sun sensor",
}


def _sensor_text(names: list[str]) -> str:
    """``"the gyro, magnetometer and coarse Sun sensors"`` for the flown direction sensors."""
    return (
        "the gyro, " + ", ".join(SENSOR_NAMES[n] for n in names[:-1]) + " and " + SENSOR_NAMES[names[-1]]
        if len(names) > 1
        else f"the gyro and {SENSOR_NAMES[names[0]]}"
    )


def _shade_eclipse(ax: Any, t_min: np.ndarray, illumination: np.ndarray) -> None:
    dark = illumination < 0.5
    if not np.any(dark):
        return
    edges = np.flatnonzero(np.diff(np.concatenate([[0], dark.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2]):
        ax.axvspan(
            t_min[start], t_min[stop - 1], color="0.85", zorder=0, label="eclipse" if start == edges[0] else None
        )


def determination_figures(out: dict[str, Any], histories: dict[str, Any]) -> dict[str, Figure]:
    """The section's figures: static errors, MEKF errors with 3-sigma, MEKF NEES.

    Parameters
    ----------
    out : dict
        :func:`determination_study`'s results.
    histories : dict
        Its histories.

    Returns
    -------
    dict of str to Figure
    """
    t_min = histories["t"] / 60.0
    light = histories["illumination"]
    figures: dict[str, Figure] = {}
    models = [m for m in MODELS if f"mekf_{m}" in histories]
    if out["static"] is not None:
        fig = Figure(figsize=(9.0, 6.0), layout="constrained")
        ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[3, 1])
        # The file model first, so the noise model's points stay visible on top.
        for model, colour in reversed(list(zip(models, ("C0", "C3"), strict=False))):
            st = histories[f"static_{model}"]
            ax.semilogy(
                t_min,
                np.degrees(st["quest_error_rad"][0]),
                ".",
                ms=1.5,
                color=colour,
                label=f"QUEST error, {model} model (run 1)",
            )
        ax.semilogy(
            t_min,
            np.degrees(histories["static_noise"]["quest_3sigma_rad"][0]),
            "k-",
            lw=0.8,
            label=r"QUEST $3\sigma$ (largest axis)",
        )
        _shade_eclipse(ax, t_min, light)
        ax.set_ylabel("attitude error [deg]")
        ax.set_title("Static determination (QUEST) from the Sun and the field over one orbit, nadir hold")
        ax.legend(fontsize=8, loc="upper right", markerscale=5)
        if histories["sun_field_angle_deg"] is not None:
            ax2.plot(t_min, histories["sun_field_angle_deg"], "k-", lw=0.8)
        _shade_eclipse(ax2, t_min, light)
        ax2.set_ylabel("Sun-field angle [deg]")
        ax2.set_xlabel("time [min]")
        ax2.set_ylim(0.0, 180.0)
        figures["determination_static"] = fig
    fig = Figure(figsize=(9.0, 3.2 * len(models)), layout="constrained")
    axes = np.atleast_1d(fig.subplots(len(models), 1, sharex=True))
    for ax, model in zip(axes, models):
        h = histories[f"mekf_{model}"]
        drawn = min(RUNS_DRAWN, h["angle_deg"].shape[0])
        for r in range(drawn):
            ax.semilogy(t_min, h["angle_deg"][r], lw=0.6, label=f"error angle ({drawn} runs)" if r == 0 else None)
        ax.semilogy(t_min, 3.0 * h["sigma_max_deg"][0], "k-", lw=1.0, label=r"$3\sigma$ (largest axis, run 1)")
        _shade_eclipse(ax, t_min, light)
        ax.set_ylabel("attitude error [deg]")
        ax.set_title(f"MEKF on {_sensor_text(out['sensors'])}, no star tracker: {model} model")
        ax.legend(fontsize=8, loc="upper right")
    axes[-1].set_xlabel("time [min]")
    figures["determination_mekf"] = fig
    e = out["mekf"]["noise"]
    figures["determination_nees"] = plot_nees(
        histories["t"],
        histories["mekf_noise"]["nees_avg"],
        6,
        e["runs"],
        confidence=CONFIDENCE,
        title=f"Direction-sensor MEKF, noise model: average NEES of {e['runs']} runs, mean {e['nees_mean']:.2f}",
    )
    return figures

"""The batch MEKF with vector measurements (estimation.mekf.batch, run_mekf(vectors=...)).

What each test checks against:

- the batch against the single filter (:class:`estimation.mekf.filter.MEKF`,
  stepped run by run), whose vector update is itself checked against central
  differences and an independent three-axis update
  (tests/estimation/mekf/test_filter_vectors.py): the same estimates,
  covariances and NIS to rounding, with gaps (eclipse), failed (NaN)
  samples, gated samples, a full covariance and the second-order reset;
- :meth:`MEKFBatch.step` stepped by hand against ``run_mekf(vectorized=True)``:
  bit for bit (one definition of the batch equations);
- a vector-only campaign of the batch: the run-average NEES (6 dof) inside
  its chi-square band (Bar-Shalom, Li and Kirubarajan, *Estimation with
  Applications to Tracking and Navigation*, 2001, sec. 5.4), band from
  ``scipy.stats.chi2``;
- bad input names the argument.

Truth and samples are those of test_filter_vectors.py (a slew and a hold,
exact interval-mean gyro samples, vector samples ``normalise(A r + sigma n)``).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from attitude import quaternion as quat
from attitude.simulation.protocols import VectorMeasurement
from estimation.consistency import nees
from estimation.mekf import MEKFBatch, run_mekf
from estimation.mekf.batch import VectorSamples
from estimation.mekf.filter import MEKF, initial_covariance
from tests.estimation.mekf.test_filter_vectors import (
    DEG_PER_H,
    DT,
    EVERY,
    GYRO,
    SIG_MAG,
    SIG_SUN,
    SUN_N,
    TRACKER,
    mag_N,
    slew_hold_truth,
)


def histories(n_runs, duration, seed, *, sig_a0, eclipse=(), tracker=False):
    """Gyro, tracker and vector histories of ``n_runs`` runs over the slew-and-hold truth."""
    t, q_true, w = slew_hold_truth(duration)
    n = t.size
    c_bn = Rotation.from_quat(q_true, scalar_first=True).as_matrix().transpose(0, 2, 1)
    mag_ref = np.array([mag_N(tk) for tk in t])
    sun_B = np.full((n_runs, n, 3), np.nan)
    mag_B = np.full((n_runs, n, 3), np.nan)
    g = np.empty((n_runs, n, 3))
    y = np.full((n_runs, n, 4), np.nan)
    bias = np.empty((n_runs, n, 3))
    q0 = np.empty((n_runs, 4))
    sampled = np.arange(n) % EVERY == 0
    lit = sampled & ~np.any([(t >= a) & (t < b) for a, b in eclipse] or [np.zeros(n, bool)], axis=0)
    for r, child in enumerate(np.random.SeedSequence(seed).spawn(n_runs)):
        rng = np.random.default_rng(child)
        errors, bias[r] = GYRO.sample_errors(n - 1, rng, bias0=rng.standard_normal(3) * 10.0 * DEG_PER_H)
        g[r, 1:] = w + errors
        g[r, 0] = g[r, 1]
        q0[r] = quat.multiply(q_true[0], quat.from_rotation_vector(rng.standard_normal(3) * sig_a0))
        sun_B[r, lit] = (c_bn[lit] @ SUN_N) + SIG_SUN * rng.standard_normal((int(lit.sum()), 3))
        mag_B[r, sampled] = np.einsum("kij,kj->ki", c_bn[sampled], mag_ref[sampled]) + SIG_MAG * rng.standard_normal(
            (int(sampled.sum()), 3)
        )
        if tracker:
            y[r, sampled] = TRACKER.add_noise(q_true[sampled], rng)
    vectors = {
        "sun_sensor": VectorSamples(sun_B, SUN_N, sigma=SIG_SUN),
        "magnetometer": VectorSamples(mag_B, mag_ref, sigma=SIG_MAG),
    }
    return t, q_true, g, y, bias, q0, vectors


def make_filter(q0, sig_a0, **options):
    return MEKF(
        sigma_v=GYRO.sigma_v,
        sigma_u=GYRO.sigma_u,
        tracker_covariance=TRACKER.covariance_B,
        period=DT,
        q0=q0,
        P0=initial_covariance(attitude_sigma=sig_a0, bias_sigma=10.0 * DEG_PER_H),
        vector_names=("sun_sensor", "magnetometer"),
        **options,
    )


@pytest.mark.parametrize("reset", ["first_order", "second_order"])
def test_the_batch_is_the_single_filter_with_gaps_failures_and_gated_samples(reset):
    sig_a0 = np.radians(2.0)
    t, q_true, g, y, _, q0, vectors = histories(3, 40.0, seed=5, sig_a0=sig_a0, eclipse=[(10.0, 20.0)], tracker=True)
    sun = vectors["sun_sensor"].vector_B.copy()
    sun[1, 50] = [np.nan, 1.0, 0.0]  # a failed sample: skipped and counted
    sun[2, 250] = -sun[2, 250]  # the Sun 180 deg off: gated
    vectors["sun_sensor"] = vectors["sun_sensor"]._replace(vector_B=sun)
    # The magnetometer with a full covariance (anisotropic), which the filter projects onto the plane.
    cov = np.diag([1.0, 2.0, 3.0]) * SIG_MAG**2
    vectors["magnetometer"] = vectors["magnetometer"]._replace(sigma=None, covariance=cov)
    f = make_filter(q_true[0], sig_a0, covariance_reset=reset)
    batch = run_mekf(f, t, g, y, q0=q0, vectors=vectors, vectorized=True)
    single = run_mekf(f, t, g, y, q0=q0, vectors=vectors, vectorized=False)
    # Rounding: the same equations in another order of operations, over 401 steps; a wrong sign, index or
    # noise term moves the estimates by the size of the update (~1e-3 rad), nine orders above this bound.
    np.testing.assert_allclose(batch.q, single.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(batch.P, single.P, rtol=1e-9, atol=1e-20)
    for name in vectors:
        np.testing.assert_array_equal(np.isnan(batch.vector_nis[name]), np.isnan(single.vector_nis[name]))
        np.testing.assert_allclose(batch.vector_nis[name], single.vector_nis[name], rtol=1e-8)
    for key in ("vector_updates", "vector_nan", "vector_gated", "updates"):
        assert batch.info[key] == single.info[key], key
    assert batch.info["vector_nan"] == [0, 1, 0]
    assert batch.info["vector_gated"][2] >= 1
    # No Sun sample in eclipse: NaN NIS there, numbers outside it.
    eclipse = (t >= 10.0) & (t < 20.0)
    assert np.all(np.isnan(batch.vector_nis["sun_sensor"][:, eclipse]))
    assert np.all(np.isfinite(batch.vector_nis["magnetometer"][:, ::EVERY]))


def test_hand_stepped_batch_equals_run_mekf_bit_for_bit():
    sig_a0 = np.radians(1.0)
    t, q_true, g, y, _, q0, vectors = histories(4, 10.0, seed=3, sig_a0=sig_a0, tracker=True)
    f = make_filter(q_true[0], sig_a0)
    res = run_mekf(f, t, g, y, q0=q0, vectors=vectors, vectorized=True)
    b = MEKFBatch(f, 4, q0=q0)
    for k in range(t.size):
        step = {
            name: VectorSamples(v.vector_B[:, k], np.broadcast_to(v.reference_N, (t.size, 3))[k], sigma=v.sigma)
            for name, v in vectors.items()
        }
        tracker = y[:, k]
        b.step(t[k], g[:, k], tracker, vectors=step)
        np.testing.assert_array_equal(b.q, res.q[:, k])
        np.testing.assert_array_equal(b.P, res.P[:, k])
        for name in vectors:
            np.testing.assert_array_equal(b.vector_nis[name], res.vector_nis[name][:, k])
    assert b.counts["vector_updates"].tolist() == res.info["vector_updates"]


def test_a_vector_only_batch_campaign_is_consistent():
    # 40 runs, Sun sensor and magnetometer only, 2 deg initial errors, a 30 s eclipse (magnetometer alone).
    runs, sig_a0 = 40, np.radians(2.0)
    t, q_true, g, y, bias, q0, vectors = histories(runs, 120.0, seed=21, sig_a0=sig_a0, eclipse=[(70.0, 100.0)])
    res = run_mekf(make_filter(q_true[0], sig_a0), t, g, y, q0=q0, vectors=vectors)
    values = nees(res.errors(q_true, bias), res.P)
    avg = values.mean(axis=0)
    lo, hi = stats.chi2.ppf([0.005, 0.995], 6 * runs) / runs
    # 0.85: as test_filter_vectors.MIN_FRACTION (correlated steps; a filter off by 2 in its noise is far out).
    assert np.mean((avg >= lo) & (avg <= hi)) >= 0.85
    assert lo <= avg.mean() <= hi
    # The vector NIS (2 dof) averages 2 over the campaign; its sampling error over ~40 x 200 samples of
    # each sensor is about 2 sqrt(1/4000) ~ 0.03, and the start (2 deg prior) adds little: 5 % allowed.
    for name in vectors:
        assert np.nanmean(res.vector_nis[name]) == pytest.approx(2.0, rel=0.05)


@pytest.mark.parametrize(
    ("samples", "match"),
    [
        (VectorSamples(np.zeros((2, 3)), SUN_N, sigma=1e-3), "vector_B must have non-zero rows"),
        (VectorSamples(np.ones((2, 2)), SUN_N, sigma=1e-3), r"vector_B must broadcast to shape \(2, 3\)"),
        (
            VectorSamples(np.ones((2, 3)), [0, 0, 0], sigma=1e-3),
            r"reference_N must be finite and non-zero .* row \[0\]",
        ),
        (
            VectorSamples(np.ones((2, 3)), SUN_N, sigma=[1e-3, np.nan]),
            r"sigma must be finite and > 0 .* row \[1\] is nan",
        ),
        (
            VectorSamples(np.ones((2, 3)), SUN_N, sigma=[np.inf, 1e-3]),
            r"sigma must be finite and > 0 .* row \[0\] is inf",
        ),
        (VectorSamples(np.ones((2, 3)), SUN_N), "exactly one of sigma and covariance"),
        (VectorSamples(np.ones((2, 3)), SUN_N, sigma=[1e-3, 0.0]), r"sigma must be finite and > 0"),
        (VectorSamples(np.ones((2, 3)), SUN_N, covariance=-np.eye(3)), "semi-definite"),
        (VectorSamples([[0, 0, 1.0]] * 2, SUN_N, covariance=np.diag([1.0, 0, 0])), "perpendicular to vector_B"),
        ((np.ones((2, 3)), SUN_N, 1e-3), "must be a VectorSamples"),
    ],
)
def test_bad_vector_samples_name_the_sensor_and_the_rule(samples, match):
    f = make_filter(quat.identity(), 1e-2)
    b = MEKFBatch(f, 2)
    with pytest.raises(ValueError, match=match) as info:
        b.step(0.0, np.zeros((2, 3)), vectors={"sun_sensor": samples})
    assert "sun_sensor" in str(info.value)
    assert b.counts["steps"].tolist() == [0, 0]  # checked before the state changes


def test_run_mekf_refuses_vector_histories_of_the_wrong_length():
    f = make_filter(quat.identity(), 1e-2)
    t = np.arange(5) * DT
    with pytest.raises(ValueError, match=r"vectors\['mag'\].vector_B must broadcast to shape \(1, 5, 3\)"):
        run_mekf(
            f,
            t,
            np.zeros((5, 3)),
            np.full((5, 4), np.nan),
            vectors={"mag": VectorSamples(np.ones((4, 3)), SUN_N, sigma=1e-3)},
        )


def test_the_batch_takes_the_single_filters_rules_for_failed_and_absent_samples():
    # A review found the batch refusing what the single filter counts (an inf sample) or accepts (a
    # covariance asymmetric by rounding, NaN noise figures at steps without a sample).
    f = make_filter(quat.identity(), 1e-2)
    b = MEKFBatch(f, 3)
    vb = np.array([[np.inf, 0.0, 1.0], [np.nan] * 3, [0.0, 0.0, 1.0]])
    cov = np.broadcast_to(np.eye(3) * 1e-6, (3, 3, 3)).copy()
    cov[2, 2, 0] += 1e-25  # asymmetric by rounding
    cov[1] = np.nan  # no sample in run 1: its noise figure is never read
    ref = np.array([[0.0, 0.0, 1.0], [np.nan] * 3, [0.0, 0.0, 1.0]])
    b.step(0.0, np.zeros((3, 3)), vectors={"sun_sensor": VectorSamples(vb, ref, covariance=cov)})
    assert b.counts["vector_nan"].tolist() == [1, 0, 0]
    assert b.counts["vector_updates"].tolist() == [0, 0, 1]
    single = make_filter(quat.identity(), 1e-2)
    single.step(0.0, np.zeros(3), None, {"sun_sensor": VectorMeasurement(vb[0], ref[0], covariance=cov[0])})
    assert single.counts["vector_nan"] == 1
    single.step(0.0, None, None, {"sun_sensor": VectorMeasurement(vb[2], ref[2], covariance=cov[2])})
    np.testing.assert_allclose(single.P, b.P[2], rtol=1e-12)


def test_run_mekf_without_a_tracker_and_with_names_other_than_the_filters():
    sig_a0 = np.radians(1.0)
    t, q_true, g, _, _, q0, vectors = histories(2, 5.0, seed=4, sig_a0=sig_a0)
    f = make_filter(q_true[0], sig_a0)
    none = run_mekf(f, t, g, None, q0=q0, vectors=vectors)
    nan = run_mekf(f, t, g, np.full((2, t.size, 4), np.nan), q0=q0, vectors=vectors)
    np.testing.assert_array_equal(none.q, nan.q)
    with pytest.raises(ValueError, match="tracker_mask was given without tracker samples"):
        run_mekf(f, t, g, None, tracker_mask=np.ones(t.size, dtype=bool), q0=q0, vectors=vectors)
    # A new user's trial: a sensor the filter does not name was applied silently (twice the updates).
    with pytest.warns(UserWarning, match=r"vector_names are \['sun_sensor', 'magnetometer'\]"):
        run_mekf(f, t, g, None, q0=q0, vectors={**vectors, "extra": vectors["sun_sensor"]})

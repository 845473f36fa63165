"""MEKF vector measurements (estimation.mekf.filter): Jacobian, observability, consistency, blinded tracker.

What each test checks against (nobody tuned it):

- the Jacobian of the vector measurement model, ``[[A r] x, 0]`` (Markley
  and Crassidis, *Fundamentals of Spacecraft Attitude Determination and
  Control*, 2014, sec. 6.2; Crassidis and Junkins, *Optimal Estimation of
  Dynamic Systems*, 2nd ed., sec. 7.2), against central differences of the
  measurement function built with ``scipy.spatial.transform.Rotation``;
- a single vector leaves the rotation about it unobservable: the variance
  about that axis follows the open-loop Farrenkopf covariance
  ``P0 + sv^2 t + Pb0 t^2 + su^2 t^3 / 3`` exactly (Crassidis and Junkins,
  sec. 7.2.1: the propagation without measurements at zero rate);
- vector-only and blinded-tracker Monte Carlo campaigns: the average NEES
  (6 dof) inside its chi-square band (Bar-Shalom, Li and Kirubarajan,
  *Estimation with Applications to Tracking and Navigation*, 2001, sec.
  5.4), band from ``scipy.stats.chi2``; and, for the blinded tracker, the
  information ordering of the Riccati equation (more measurements never
  increase the covariance: P with the tracker <= P blinded <= P without it);
- bad input names the argument.

Truth: a rest-to-rest slew followed by a hold, the attitude stepped exactly
with a piecewise-constant rate at the gyro period, so each gyro sample's
true part (the interval-mean rate) is exact; gyro errors are the exact
Farrenkopf samples of :meth:`attitude.sensors.Gyro.sample_errors`; vector
samples are ``normalise(A r + sigma n)``, ``n ~ N(0, I3)``, whose error
perpendicular to the vector has covariance ``sigma^2 (I - b b^T)`` to first
order (the QUEST model; second order ~ sigma^2 = 1e-5 relative).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from attitude import quaternion as quat
from attitude.rigid_body import RigidBody
from attitude.sensors import Gyro, StarTracker
from attitude.simulation.engine import simulate
from attitude.simulation.protocols import VectorMeasurement
from estimation.consistency import nees
from estimation.mekf.filter import MEKF, initial_covariance, vector_update_model

DT = 0.1  # gyro period [s]
EVERY = 5  # tracker and vector samples every 5 gyro steps (2 Hz)
DEG_PER_H = np.pi / 180.0 / 3600.0
SIG_SUN = 1e-3  # Sun sensor [rad] (0.06 deg)
SIG_MAG = 5e-3  # magnetometer direction [rad] (0.3 deg: ~100 nT on a 20000 nT field)
SUN_N = np.array([0.6, 0.7, 0.39]) / np.linalg.norm([0.6, 0.7, 0.39])
ORBIT_RATE = 2.0 * np.pi / 5400.0  # [rad/s]
NAMES = ("sun_sensor", "magnetometer")


def mag_N(t):
    """A field direction turning at twice the orbit rate about an inclined axis (the dipole field seen in orbit)."""
    a = 2.0 * ORBIT_RATE * t
    return np.array([np.cos(a), 0.8 * np.sin(a), 0.6 * np.sin(a)])


def c_BN(q):
    """``C_BN`` from scipy (independent of attitude.quaternion): maps N components to B components."""
    return Rotation.from_quat(q, scalar_first=True).as_matrix().T


@functools.cache
def slew_hold_truth(duration, slew_time=60.0, angle_deg=60.0):
    """Rest-to-rest slew of ``angle`` about a fixed axis with rate ``(angle/T)(1 - cos 2 pi t/T)``, then a hold."""
    n = round(duration / DT) + 1
    t = np.arange(n) * DT
    axis = np.array([1.0, -2.0, 2.0]) / 3.0
    mid = t[1:] - 0.5 * DT
    rate = np.where(mid < slew_time, np.radians(angle_deg) / slew_time * (1.0 - np.cos(2 * np.pi * mid / slew_time)), 0)
    w = rate[:, None] * axis  # the constant rate over each interval (k-1, k]
    q = np.empty((n, 4))
    q[0] = quat.from_axis_angle([0.2, 0.5, -1.0], 0.4)
    for k in range(1, n):
        q[k] = quat.normalize(quat.multiply(q[k - 1], quat.from_rotation_vector(w[k - 1] * DT)))
    return t, q, w


def vector_sample(q, r_N, sigma, rng):
    b = c_BN(q) @ r_N + sigma * rng.standard_normal(3)
    return VectorMeasurement(b, r_N, sigma=sigma)


GYRO = Gyro.preset("tactical", bias_instability_model="random_walk", period=DT, sampling="mean")
TRACKER = StarTracker.preset("typical", period=EVERY * DT)


def run_campaign(duration, n_runs, seed, *, sig_a0, tracker_on, vectors_on=NAMES):
    """Run ``n_runs`` filters over one truth; return the 6-dof NEES (runs, steps) and the covariances.

    ``tracker_on(t)`` says whether the tracker samples at ``t`` (on the 2 Hz grid). Each run has its own
    ``SeedSequence.spawn`` child, initial attitude and bias errors drawn from ``P0``.
    """
    t, q_true, w = slew_hold_truth(duration)
    n = t.size
    p0 = initial_covariance(attitude_sigma=sig_a0, bias_sigma=10.0 * DEG_PER_H)
    out_q = np.empty((n_runs, n, 4))
    out_b = np.empty((n_runs, n, 3))
    out_p = np.empty((n_runs, n, 6, 6))
    bias_true = np.empty((n_runs, n, 3))
    for r, child in enumerate(np.random.SeedSequence(seed).spawn(n_runs)):
        rng = np.random.default_rng(child)
        b0 = rng.standard_normal(3) * 10.0 * DEG_PER_H
        errors, bias_true[r] = GYRO.sample_errors(n - 1, rng, bias0=b0)
        q0 = quat.multiply(q_true[0], quat.from_rotation_vector(rng.standard_normal(3) * sig_a0))
        f = MEKF(
            sigma_v=GYRO.sigma_v,
            sigma_u=GYRO.sigma_u,
            tracker_covariance=TRACKER.covariance_B,
            period=DT,
            q0=q0,
            P0=p0,
            vector_names=NAMES,
        )
        for k in range(n):
            g = w[k - 1] + errors[k - 1] if k > 0 else w[0] + errors[0]
            tracker = vectors = None
            if k % EVERY == 0:
                if tracker_on(t[k]):
                    tracker = TRACKER.add_noise(q_true[k], rng)
                vectors = {}
                if "sun_sensor" in vectors_on:
                    vectors["sun_sensor"] = vector_sample(q_true[k], SUN_N, SIG_SUN, rng)
                if "magnetometer" in vectors_on:
                    vectors["magnetometer"] = vector_sample(q_true[k], mag_N(t[k]), SIG_MAG, rng)
            est = f.step(t[k], g, tracker, vectors)
            out_q[r, k], out_b[r, k], out_p[r, k] = est.q, f.bias, est.covariance
    # The error state x = [rotvec(q_hat* (x) q), b - b_hat] (the filter's own definition of delta_theta).
    err = np.concatenate(
        [quat.to_rotation_vector(quat.multiply(quat.conjugate(out_q), q_true)), bias_true - out_b], axis=-1
    )
    return t, nees(err, out_p), out_p


def nees_band(n_runs, confidence=0.99):
    """Band of the run average of ``n_runs`` chi2(6) values: ``chi2.ppf([a/2, 1 - a/2], 6 n) / n``."""
    a = 1.0 - confidence
    return stats.chi2.ppf([a / 2, 1 - a / 2], 6 * n_runs) / n_runs


N_RUNS = 12
# Fraction of steps whose 12-run average NEES must lie in the 99% band: 0.99 for white steps, but
# consecutive steps are strongly correlated (the bias error wanders over hundreds of steps), so a
# campaign's fraction scatters; the threshold leaves room for that, while a filter off by a factor 2 in
# its noise puts the average far outside the band nearly everywhere.
MIN_FRACTION = 0.85


@pytest.mark.slow
def test_vector_only_filter_converges_with_consistent_nees():
    # Sun sensor and magnetometer only, 2 deg initial attitude error per axis, through a 60 deg slew and a hold.
    _, values, p = run_campaign(90.0, N_RUNS, seed=11, sig_a0=np.radians(2.0), tracker_on=lambda _t: False)
    sig_att = np.sqrt(np.trace(p[:, :, :3, :3], axis1=-2, axis2=-1) / 3.0)
    # Converges: from 2 deg to the vectors' level (sigma_sun = 0.06 deg bounds the two axes it sees, the
    # magnetometer's 0.3 deg the third) within the run.
    assert sig_att[:, -1].max() < np.radians(0.2)
    assert sig_att[:, -1].max() < np.radians(2.0) / 50.0
    avg = values.mean(axis=0)
    lo, hi = nees_band(N_RUNS)
    assert np.mean((avg >= lo) & (avg <= hi)) >= MIN_FRACTION
    # Grand mean: a run's time average has the mean of one chi2(6) value and at most its variance, so
    # the 99% band of the 12-run average bounds it.
    assert lo <= avg.mean() <= hi


@pytest.mark.slow
def test_blinded_tracker_covariance_grows_and_shrinks_with_consistent_nees():
    # Tracker out from 30 s to 80 s (blinded) while the Sun sensor and magnetometer continue.
    duration, out0, out1 = 120.0, 30.0, 80.0
    sig_a0 = np.radians(0.1)
    t, values, p = run_campaign(duration, N_RUNS, seed=5, sig_a0=sig_a0, tracker_on=lambda s: not out0 <= s < out1)
    _, _, p_full = run_campaign(duration, 1, seed=5, sig_a0=sig_a0, tracker_on=lambda _s: True)
    _, _, p_vec = run_campaign(duration, 1, seed=5, sig_a0=sig_a0, tracker_on=lambda _s: False)
    sig = np.sqrt(np.trace(p[0, :, :3, :3], axis1=-2, axis2=-1) / 3.0)
    sig_full = np.sqrt(np.trace(p_full[0, :, :3, :3], axis1=-2, axis2=-1) / 3.0)
    sig_vec = np.sqrt(np.trace(p_vec[0, :, :3, :3], axis1=-2, axis2=-1) / 3.0)
    before = (t > out0 - 5.0) & (t < out0)
    during_end = (t > out1 - 5.0) & (t < out1)
    after = (t > out1 + 2.0) & (t < out1 + 10.0)
    # Grows: from the tracker's level to well above it (the vectors alone hold ~10x larger errors).
    assert sig[during_end].min() > 3.0 * sig[before].max()
    # Information ordering (Riccati monotonicity): with the tracker <= blinded <= never a tracker. The
    # filters linearise about slightly different estimates (differences ~ the attitude error, 1e-3 rad,
    # relative), hence the 1% margin.
    assert np.all(sig >= sig_full * 0.99)
    assert np.all(sig <= sig_vec * 1.01)
    # Shrinks: 2 s (four tracker samples) after the tracker is back, from 4x and more above the level of
    # the filter that never lost it to within a factor 1.5 of it, and 10 s after to within 5% (what remains
    # in between is the bias uncertainty gathered in the outage, which the tracker learns again over ~10 s).
    end = (t > out1 - 1.0) & (t < out1)
    assert sig[end].min() > 4.0 * sig_full[end].max()
    assert np.all(sig[after] < 1.5 * sig_full[after])
    np.testing.assert_allclose(sig[t >= out1 + 10.0], sig_full[t >= out1 + 10.0], rtol=0.05)
    avg = values.mean(axis=0)
    lo, hi = nees_band(N_RUNS)
    assert np.mean((avg >= lo) & (avg <= hi)) >= MIN_FRACTION
    window = (t >= out0) & (t < out1)
    assert lo <= avg[window].mean() <= hi
    assert lo <= avg.mean() <= hi


def test_single_vector_leaves_rotation_about_it_unobservable():
    # Static body, noise-free samples of one fixed vector, q_hat = truth: every residual is zero, so the
    # estimate stays put and the variance about the vector follows the open-loop covariance exactly.
    q = quat.from_axis_angle([1.0, 1.0, 0.0], 0.3)
    r_N = np.array([0.0, 0.6, 0.8])
    b = c_BN(q) @ r_N
    sv, su = 1e-4, 1e-6
    pa, pb = 1e-6, 1e-8
    f = MEKF(
        sigma_v=sv,
        sigma_u=su,
        tracker_covariance=np.eye(3) * 1e-8,
        period=DT,
        q0=q,
        P0=np.diag([pa] * 3 + [pb] * 3),
        t0=0.0,
    )
    m = VectorMeasurement(b, r_N, sigma=1e-4)
    n = 600
    for k in range(1, n + 1):
        f.step(k * DT, np.zeros(3), None, [m])
    t_end = n * DT
    p_att = f.P[:3, :3]
    about = b @ p_att @ b
    # Farrenkopf covariance without measurements at zero rate: Pa + sv^2 t + Pb t^2 + su^2 t^3 / 3 (the
    # discrete Q is exact at zero rate, so this holds at the sample times to rounding).
    expected = pa + sv**2 * t_end + pb * t_end**2 + su**2 * t_end**3 / 3.0
    assert about == pytest.approx(expected, rel=1e-9)
    assert about > 10.0 * pa  # grew
    # Across the vector the samples bound it: below the initial variance and far below the variance about it.
    t1 = np.cross(b, [1.0, 0.0, 0.0])
    t1 /= np.linalg.norm(t1)
    for e in (t1, np.cross(b, t1)):
        assert e @ p_att @ e < min(pa, 0.01 * about)
    np.testing.assert_allclose(f.q, q, atol=1e-15)
    assert f.counts["vector_updates"] == n


@pytest.mark.parametrize("seed", range(5))
def test_vector_jacobian_matches_central_differences(seed):
    rng = np.random.default_rng(seed)
    q_hat = quat.random(1, rng)[0]
    r_N = rng.standard_normal(3)
    r_N /= np.linalg.norm(r_N)
    _, h, r = vector_update_model(q_hat, VectorMeasurement(c_BN(q_hat) @ r_N, r_N, sigma=1e-3))
    np.testing.assert_array_equal(h[:, 3:], 0.0)
    np.testing.assert_allclose(r, 1e-6 * np.eye(2), rtol=1e-15)
    # z(dtheta) for the noise-free sample of q = q_hat (x) exp(dtheta / 2), basis fixed at q_hat.
    eps = 1e-6
    fd = np.empty((2, 3))
    for i in range(3):
        zs = []
        for s in (1.0, -1.0):
            dq = Rotation.from_rotvec(s * eps * np.eye(3)[i])
            q = (Rotation.from_quat(q_hat, scalar_first=True) * dq).as_quat(scalar_first=True)
            zs.append(vector_update_model(q_hat, VectorMeasurement(c_BN(q) @ r_N, r_N, sigma=1e-3))[0])
        fd[:, i] = (zs[0] - zs[1]) / (2 * eps)
    # Central differences: truncation eps^2 ~ 1e-12, rounding 1e-16 / eps ~ 1e-10.
    np.testing.assert_allclose(h[:, :3], fd, atol=1e-9)
    # H = T [b x] with T orthonormal, perpendicular to b: H H^T = I and H b = 0.
    b = c_BN(q_hat) @ r_N
    np.testing.assert_allclose(h[:, :3] @ h[:, :3].T, np.eye(2), atol=1e-14)
    np.testing.assert_allclose(h[:, :3] @ b, 0.0, atol=1e-14)


def test_full_covariance_projects_onto_the_plane():
    # A full 3x3 covariance sigma^2 I has, on the plane perpendicular to the vector, sigma^2 I2: the QUEST model.
    rng = np.random.default_rng(1)
    q_hat = quat.random(1, rng)[0]
    r_N = np.array([0.0, 0.0, 1.0])
    b = c_BN(q_hat) @ r_N
    _, h1, r1 = vector_update_model(q_hat, VectorMeasurement(b, r_N, covariance=4e-6 * np.eye(3)))
    _, h2, r2 = vector_update_model(q_hat, VectorMeasurement(b, r_N, sigma=2e-3))
    # T (s^2 I) T^T = s^2 I2 to rounding of the basis products (1e-16 relative).
    np.testing.assert_allclose(r1, r2, rtol=0, atol=1e-15 * 4e-6)
    np.testing.assert_array_equal(h1, h2)


def test_gate_nan_and_absent_vector_samples():
    q = quat.identity()
    f = MEKF(
        sigma_v=1e-5,
        sigma_u=1e-7,
        tracker_covariance=np.eye(3) * 1e-8,
        period=DT,
        q0=q,
        P0=initial_covariance(attitude_sigma=1e-3, bias_sigma=1e-5),
        t0=0.0,
        vector_names=NAMES,
    )
    p_before = f.P
    # 90 deg off: NIS ~ 1 / (P + sigma^2) ~ 5e5, far above the 2-dof gate chi2.ppf(1 - 1e-9, 2) = 41.4.
    off = VectorMeasurement([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], sigma=1e-3)
    f.update(0.0, {"sun_sensor": off, "magnetometer": None, "gyro": np.zeros(3)})
    assert f.counts["vector_gated"] == 1 and f.counts["vector_updates"] == 0
    np.testing.assert_array_equal(f.q, q)
    np.testing.assert_array_equal(f.P, p_before)
    assert f.vector_gate_threshold == pytest.approx(stats.chi2.ppf(1 - 1e-9, 2))
    _, names, values = f.vector_nis_history
    assert names == ("sun_sensor",) and values[0] > 1e5
    # A failed sample (NaN) is skipped and counted; a mapping of the fields is accepted.
    f.update(0.0, {"magnetometer": {"vector_B": [np.nan, 0, 0], "reference_N": [1, 0, 0], "sigma": 1e-2}})
    assert f.counts["vector_nan"] == 1
    f.update(0.0, {"magnetometer": {"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0], "sigma": 1e-2}})
    assert f.counts["vector_updates"] == 1
    assert f.log()["vector_updates"] == 1.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"vector_B": [0.0, 0.0, 0.0], "reference_N": [1, 0, 0], "sigma": 1e-3}, "vector_B must have a non-zero"),
        ({"vector_B": [1.0, 0.0], "reference_N": [1, 0, 0], "sigma": 1e-3}, r"vector_B must have shape \(3,\)"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [0, 0, 0], "sigma": 1e-3}, "reference_N must have a non-zero"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [np.nan, 0, 0], "sigma": 1e-3}, "reference_N"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0], "sigma": 0.0}, "sigma"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0], "sigma": -1e-3}, "sigma"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0]}, "exactly one of sigma"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0], "sigma": 1e-3, "covariance": np.eye(3)}, "exactly one"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0], "covariance": np.eye(2)}, r"covariance must have shape"),
        ({"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0], "covariance": -np.eye(3)}, "semi-definite"),
        (
            {"vector_B": [1.0, 0, 0], "reference_N": [1, 0, 0], "covariance": np.diag([1.0, 1.0, 0.0])},
            "perpendicular to vector_B",
        ),
    ],
)
def test_bad_vector_measurement_names_the_argument(kwargs, match):
    with pytest.raises(ValueError, match=match):
        VectorMeasurement(**kwargs)


def test_bad_vector_input_to_the_filter_names_the_argument():
    kw = {
        "sigma_v": 1e-5,
        "sigma_u": 1e-7,
        "tracker_covariance": np.eye(3) * 1e-8,
        "period": DT,
        "q0": [1, 0, 0, 0],
        "P0": np.eye(6) * 1e-6,
    }
    with pytest.raises(ValueError, match="vector_names must be a sequence"):
        MEKF(**kw, vector_names="sun_sensor")
    with pytest.raises(ValueError, match="vector_names must be distinct"):
        MEKF(**kw, vector_names=("gyro",))
    f = MEKF(**kw, vector_names=NAMES)
    with pytest.raises(ValueError, match="vector measurement 'sun_sensor' must have the keys"):
        f.update(0.0, {"sun_sensor": {"vector_B": [1, 0, 0]}})
    with pytest.raises(ValueError, match="vector measurement 'sun_sensor': sigma"):
        f.update(0.0, {"sun_sensor": {"vector_B": [1, 0, 0], "reference_N": [1, 0, 0], "sigma": -1.0}})
    with pytest.raises(ValueError, match="vector measurement 'magnetometer' must be"):
        f.update(0.0, {"magnetometer": np.array([1.0, 0.0, 0.0])})
    with pytest.raises(ValueError, match="vectors must be a mapping"):
        f.step(0.0, None, None, np.ones(3))
    assert f.counts["steps"] == 0  # every check runs before the state changes


def test_projected_update_equals_the_unprojected_three_axis_update():
    # Crassidis and Junkins (sec. 7.2) update a vector with H3 = [[b_hat x] 0] and R = sigma^2 I3: b_hat is
    # then an eigenvector of S that H3^T annihilates, so state and covariance updates equal the projected
    # 2-dof ones (docs/mekf.md). Independent 3-axis computation here, Joseph form.
    rng = np.random.default_rng(7)
    q_hat = quat.random(1, rng)[0]
    a = rng.standard_normal((6, 6))
    p0 = a @ a.T * 1e-6 + np.eye(6) * 1e-7
    r_N = np.array([0.3, -0.4, 0.866])
    sigma = 2e-3
    q_true = quat.multiply(q_hat, quat.from_rotation_vector([1e-3, -2e-3, 5e-4]))
    b = c_BN(q_true) @ r_N
    b /= np.linalg.norm(b)
    f = MEKF(sigma_v=1e-5, sigma_u=1e-7, tracker_covariance=np.eye(3) * 1e-8, period=DT, q0=q_hat, P0=p0, t0=0.0)
    f.step(0.0, None, None, [VectorMeasurement(b, r_N, sigma=sigma)])
    b_hat = c_BN(q_hat) @ r_N / np.linalg.norm(r_N)
    h3 = np.hstack(
        [np.array([[0, -b_hat[2], b_hat[1]], [b_hat[2], 0, -b_hat[0]], [-b_hat[1], b_hat[0], 0]]), np.zeros((3, 3))]
    )
    s3 = h3 @ p0 @ h3.T + sigma**2 * np.eye(3)
    k3 = p0 @ h3.T @ np.linalg.inv(s3)
    dx = k3 @ (b - b_hat)
    ikh = np.eye(6) - k3 @ h3
    p3 = ikh @ p0 @ ikh.T + sigma**2 * k3 @ k3.T
    # Equal to rounding (|dx| ~ 4e-4, |P| ~ 1e-5; cond(S3) ~ 1e3 bounds the relative rounding by ~1e-13):
    # the radial part of b - b_hat is an eigenvector of S3 that H3^T annihilates exactly.
    np.testing.assert_allclose(f.bias, dx[3:], rtol=0, atol=1e-13 * np.abs(dx).max())
    q_expected = quat.normalize(quat.multiply(q_hat, quat.from_rotation_vector(dx[:3])))
    np.testing.assert_allclose(f.q, q_expected, atol=1e-15)
    np.testing.assert_allclose(f.P, p3, rtol=0, atol=1e-13 * np.abs(p0).max())


class SunSensorForTest:
    """A user's vector sensor for the engine (no sun-sensor import): ``VectorMeasurement`` of a fixed Sun."""

    name = "sun_sensor"

    def __init__(self, period, sigma):
        self.period, self.sigma = period, sigma

    def measure(self, t, truth, rng):
        return VectorMeasurement(c_BN(truth.q) @ SUN_N + self.sigma * rng.standard_normal(3), SUN_N, sigma=self.sigma)


class RotatingFieldSensorForTest(SunSensorForTest):
    name = "magnetometer"

    def measure(self, t, truth, rng):
        r_N = mag_N(t)
        return VectorMeasurement(c_BN(truth.q) @ r_N + self.sigma * rng.standard_normal(3), r_N, sigma=self.sigma)


def test_engine_hands_vector_samples_to_the_filter_without_a_tracker():
    # The convention end to end: sensors return VectorMeasurement, the engine hands them to MEKF.update under
    # their names (None between samples), the filter runs on gyro + two vectors with no tracker at all.
    body = RigidBody(np.diag([10.0, 12.0, 8.0]))
    sun = SunSensorForTest(0.5, SIG_SUN)
    mag = RotatingFieldSensorForTest(0.5, SIG_MAG)
    q0 = quat.from_axis_angle([1.0, 0.0, 0.0], 0.2)
    f = MEKF(
        sigma_v=GYRO.sigma_v,
        sigma_u=GYRO.sigma_u,
        tracker_covariance=TRACKER.covariance_B,
        period=DT,
        q0=quat.multiply(q0, quat.from_rotation_vector([0.01, -0.01, 0.005])),
        P0=initial_covariance(attitude_sigma=0.02, bias_sigma=10.0 * DEG_PER_H),
        vector_names=NAMES,
    )
    res = simulate(body, q0, [0.0, 0.01, -0.005], 60.0, sensors=[GYRO, sun, mag], estimator=f, rng=4)
    # 121 samples of each vector (every 0.5 s, t = 0 included), every one applied (none gated).
    assert f.counts["vector_updates"] == 2 * 121 and f.counts["vector_gated"] == 0
    assert f.counts["tracker_missing"] == f.counts["steps"]
    err = quat.to_rotation_vector(quat.multiply(quat.conjugate(res.estimate_q), res.q))
    sigma = np.sqrt(res.logs["estimator.P_diag"][:, :3])
    # From 0.8 deg of initial error to within the filter's 3 sigma (0.27 % outside for a consistent filter;
    # the ~120 independent values per axis make 1 % a loose bound) and to below 0.1 deg at the end.
    assert np.mean(np.abs(err) > 3 * sigma) < 0.01
    assert np.degrees(np.linalg.norm(err[-1])) < 0.1
    # The engine logs the samples as numbers: the unit vector and its reference.
    logged = res.logs["sensor.sun_sensor"]
    np.testing.assert_allclose(np.linalg.norm(logged[::5], axis=-1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(res.logs["sensor.sun_sensor.reference_N"][::5], np.tile(SUN_N, (121, 1)), rtol=1e-15)


@pytest.mark.parametrize("gate_probability", [1 - 1e-9, None])
def test_a_reversed_vector_is_rejected_even_without_a_gate(gate_probability):
    # A sign error (a magnetometer axis wired backwards) reverses the vector: its projection on the plane
    # perpendicular to the prediction is as small as a good sample's, so the NIS alone would pass it.
    f = MEKF(
        sigma_v=1e-5,
        sigma_u=1e-7,
        tracker_covariance=np.eye(3) * 1e-8,
        period=DT,
        q0=quat.identity(),
        P0=initial_covariance(attitude_sigma=1e-3, bias_sigma=1e-5),
        t0=0.0,
        vector_names=NAMES,
        gate_probability=gate_probability,
    )
    p_before = f.P
    f.step(0.0, np.zeros(3), None, {"sun_sensor": VectorMeasurement([-1.0, 1e-4, 0.0], [1.0, 0.0, 0.0], sigma=1e-3)})
    assert f.counts["vector_gated"] == 1 and f.counts["vector_updates"] == 0
    np.testing.assert_array_equal(f.P, p_before)
    assert f.last_vector_nis["sun_sensor"] >= 1e300

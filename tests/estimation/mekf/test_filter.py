"""MEKF (estimation.mekf.filter): kinematics, Riccati steady state, Monte Carlo consistency, bad input, closed loop.

References nobody tuned: ``scipy.linalg.expm`` (transition matrix), the
Van Loan integral (process noise), ``scipy.linalg.solve_discrete_are`` and
the classical scalar random-walk and continuous Farrenkopf Riccati solutions
(steady state), ``attitude.quaternion`` (quaternion helpers), exact
torque-free and torque-driven truth from ``attitude.propagate`` (adaptive
DOP853), and chi-square statistics (NEES, NIS). Every tolerance says where it
comes from.

Measurement generation for the Monte Carlo tests: the truth is sampled at
the gyro rate; each gyro sample is the rotation vector of the true attitude
increment over its interval divided by the interval (the mean rate that the
filter's constant-rate step reproduces exactly), plus the exact Farrenkopf
errors of :meth:`attitude.sensors.Gyro.sample_errors`; tracker samples come
from :meth:`attitude.sensors.StarTracker.add_noise`. Each run has its own
``SeedSequence.spawn`` child, its own initial attitude and bias errors drawn
from ``P0``.

References: the filter is the MEKF of Markley and Crassidis (*Fundamentals
of Spacecraft Attitude Determination and Control*, 2014, ch. 6) and
Crassidis and Junkins (*Optimal Estimation of Dynamic Systems*, 2nd ed.,
sec. 7.2); the steady-state attitude sigma is Farrenkopf's closed form (J.
Guidance and Control 1(4), 1978); NEES and NIS bands are those of
Bar-Shalom, Li and Kirubarajan (*Estimation with Applications to Tracking
and Navigation*, 2001, sec. 5.4).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from matplotlib.figure import Figure
from scipy.linalg import expm

from attitude import quaternion as quat
from attitude.propagate import propagate
from attitude.rigid_body import RigidBody, skew
from attitude.sensors import ARCSEC, Gyro, GyroSamplingWarning, StarTracker
from attitude.simulation.engine import simulate
from attitude.simulation.protocols import Estimate
from estimation.consistency import chi2_band, fraction_inside_band
from estimation.mekf import filter as mk
from estimation.mekf.filter import MEKF, initial_covariance, process_noise, transition_matrix
from estimation.mekf.runner import MEKFResult, run_mekf
from estimation.mekf.steady_state import steady_state_attitude_sigma

#: The filters are tested against the truth of their own model: the Farrenkopf random walk (a datasheet
#: bias instability as its rate-random-walk approximation), so a mismatch is the filter's, not the model's.
RW = "random_walk"


DT = 0.1  # gyro period [s]
DEG_PER_H = np.pi / 180.0 / 3600.0
BODY = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
SIG_A0 = np.radians(0.1)  # initial attitude error per axis [rad]
SIG_B0 = 10.0 * DEG_PER_H  # initial bias error per axis [rad/s]


def make_filter(gyro, tracker, q0=(1.0, 0.0, 0.0, 0.0), **kwargs):
    # The campaigns below feed interval-mean rates, what a gyro with sampling="mean" reports: insist on it.
    kwargs.setdefault("sampling_check", "raise")
    return MEKF.from_sensors(
        gyro, tracker, q0=q0, P0=initial_covariance(attitude_sigma=SIG_A0, bias_sigma=SIG_B0), **kwargs
    )


def increments_rate(q, dt):
    """Mean rate [rad/s] reproducing each true attitude increment exactly, shape (n - 1, 3)."""
    return quat.to_rotation_vector(quat.multiply(quat.conjugate(q[:-1]), q[1:])) / dt


@functools.cache
def tumbling_truth(duration=300.0):
    t = np.arange(round(duration / DT) + 1) * DT
    q0 = quat.from_axis_angle([1.0, 2.0, 3.0], 0.7)
    traj = propagate(BODY, q0, [0.1, -0.05, 0.08], t, method="adaptive", rtol=1e-12, atol=1e-14)
    return t, quat.normalize(traj.q), traj.omega


@functools.cache
def slew_truth(duration=300.0, slew_time=120.0, angle_deg=90.0):
    """Rest-to-rest eigenaxis slew driven by a precomputed smooth torque ``I a sin(2 pi t / T) e``.

    ``e`` is the major principal axis, so ``omega x I omega = 0`` all along: the rate stays on ``e``,
    peaks at ``2 angle / T`` (1.5 deg/s) and returns to zero at ``T``, after ``angle`` (90 deg).
    The attitude then holds for the rest of the run.
    """
    t = np.arange(round(duration / DT) + 1) * DT
    axis = BODY.principal_axes().axes_B[:, 2]
    peak = 2.0 * np.pi * np.radians(angle_deg) / slew_time**2  # [rad/s^2]: integrates twice to `angle` about `axis`
    torque_axis = BODY.inertia @ axis * peak

    def torque(tt, _q, _w):
        return torque_axis * np.sin(2.0 * np.pi * tt / slew_time) if tt < slew_time else np.zeros(3)

    traj = propagate(BODY, quat.identity(), np.zeros(3), t, torque, method="adaptive", rtol=1e-12, atol=1e-14)
    return t, quat.normalize(traj.q), traj.omega


def test_slew_truth_is_the_intended_slew():
    t, q, omega = slew_truth()
    assert quat.error_angle(q[0], q[-1]) == pytest.approx(np.radians(90.0), rel=1e-8)
    assert np.linalg.norm(omega, axis=-1).max() == pytest.approx(2 * np.radians(90.0) / 120.0, rel=1e-6)
    assert np.abs(omega[t >= 120.0]).max() < 1e-9


def campaign(t, q_true, gyro, tracker, tracker_every, n_runs, seed, sig_a0=SIG_A0, sig_b0=SIG_B0):
    """Measurements of ``n_runs`` independent runs over one truth; initial errors drawn from P0."""
    n = t.size
    w_eq = increments_rate(q_true, t[1] - t[0])
    g = np.empty((n_runs, n, 3))
    y = np.full((n_runs, n, 4), np.nan)
    bias = np.empty((n_runs, n, 3))
    q0 = np.empty((n_runs, 4))
    for r, child in enumerate(np.random.SeedSequence(seed).spawn(n_runs)):
        rng = np.random.default_rng(child)
        b0 = rng.standard_normal(3) * sig_b0
        errors, biases = gyro.sample_errors(n - 1, rng, bias0=b0)
        g[r, 1:] = w_eq + errors
        g[r, 0] = g[r, 1]  # row 0 only sets the first rate estimate
        bias[r] = biases  # bias at each sample time: what the filter's bias state estimates
        y[r, ::tracker_every] = tracker.add_noise(q_true[::tracker_every], rng)
        q0[r] = quat.multiply(q_true[0], quat.from_rotation_vector(rng.standard_normal(3) * sig_a0))
    return g, y, bias, q0


def random_unit_quaternions(rng, n):
    return quat.random(n, rng)


# ---------------------------------------------------------------------------
# Building blocks against independent references


class TestHelpers:
    @given(st.integers(0, 2**32 - 1), st.sampled_from([1e-9, 1e-6, 1e-3, 1.0, 3.0]))
    def test_quaternion_helpers_match_attitude_quaternion(self, seed, scale):
        rng = np.random.default_rng(seed)
        p, q = random_unit_quaternions(rng, 8), random_unit_quaternions(rng, 8)
        phi = rng.standard_normal((8, 3)) * scale
        # Same formulas, different code: rounding-level agreement (unit quaternions, |phi| <= ~10 rad).
        np.testing.assert_allclose(mk._qmul(p, q), quat.multiply(p, q), atol=1e-15)
        np.testing.assert_allclose(mk._exp_rotvec(phi), quat.from_rotation_vector(phi), atol=1e-15)
        np.testing.assert_allclose(mk._log_rotvec(q), quat.to_rotation_vector(q), atol=1e-14)
        np.testing.assert_allclose(mk._log_rotvec(-q), quat.to_rotation_vector(q), atol=1e-14)
        for k in range(8):
            expected = quat.normalize(quat.multiply(p[k], quat.from_rotation_vector(phi[k])))
            np.testing.assert_allclose(mk._compose_one(p[k], phi[k]), expected, atol=1e-15)

    @given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 1e-8, 1e-4, 3e-3, 0.02, 0.5, 2.0, 6.0]))
    def test_transition_matrix_is_the_matrix_exponential(self, seed, angle):
        rng = np.random.default_rng(seed)
        axis = rng.standard_normal(3)
        dt = float(rng.uniform(0.01, 2.0))
        w = axis / np.linalg.norm(axis) * angle / dt
        a = np.zeros((6, 6))
        a[:3, :3] = -skew(w)
        a[:3, 3:] = -np.eye(3)
        reference = expm(a * dt)
        # expm (Pade) and the closed form agree to rounding: entries are O(1) and O(dt).
        np.testing.assert_allclose(transition_matrix(w, dt), reference, atol=1e-13)
        np.testing.assert_allclose(mk._transition_one(w, dt), reference, atol=1e-13)
        # Phi11 is the transpose of the rotation over the step.
        np.testing.assert_allclose(reference[:3, :3], quat.to_dcm(quat.from_rotation_vector(w * dt)), atol=1e-13)

    @given(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 1e-6, 5e-3, 0.05, 1.0]))
    def test_one_propagation_step_is_the_textbook_one(self, seed, angle):
        # The per-step propagation (Python floats, cached Q) against an independent evaluation: Phi by
        # expm, Q by the Farrenkopf formula (tested against Van Loan above), q by attitude.quaternion.
        # Angles per step on both sides of the series threshold (1e-2 rad). Tolerances: entries of P are
        # sums of a few dozen products, rounding ~1e-15 relative; q is O(1).
        rng = np.random.default_rng(seed)
        f, gyro, _ = small_filter(q0=quat.random(rng=rng), bias0=rng.normal(scale=1e-4, size=3))
        f.step(1.0, np.zeros(3))
        axis = rng.standard_normal(3)
        # A step long enough that the rate stays within the gyro's range (gyro_rate_max, with a 20 % margin for
        # the bias): beyond it the filter rejects the sample and coasts, which is not the step under test.
        dt = float(rng.uniform(max(0.01, 1.2 * angle / f.gyro_rate_max), 0.5))
        rate = f.bias + axis / np.linalg.norm(axis) * angle / dt
        q_prior, p_prior, b = f.q, f.P, f.bias
        f.step(1.0 + dt, rate)
        assert f.counts["gyro_rejected"] == 0
        w = rate - b
        a = np.zeros((6, 6))
        a[:3, :3] = -skew(w)
        a[:3, 3:] = -np.eye(3)
        phi = expm(a * (1.0 + dt - 1.0))
        q_noise = process_noise(sigma_v=gyro.sigma_v, sigma_u=f.sigma_u, dt=1.0 + dt - 1.0)
        # Compared as correlations (P scaled by its standard deviations): entries O(1) whatever their unit, so
        # that an off-diagonal term that cancels to ~1e-24 is judged against its row's and column's scale.
        expected = phi @ p_prior @ phi.T + q_noise
        scale = 1.0 / np.sqrt(np.outer(np.diag(expected), np.diag(expected)))
        np.testing.assert_allclose(f.P * scale, expected * scale, rtol=0, atol=1e-12)
        expected_q = quat.normalize(quat.multiply(q_prior, quat.from_rotation_vector(w * (1.0 + dt - 1.0))))
        np.testing.assert_allclose(f.q, expected_q, atol=1e-15)
        np.testing.assert_allclose(f.omega, w, rtol=0, atol=1e-18)

    @given(st.integers(0, 2**32 - 1), st.sampled_from([1e-12, 1e-6, 1e-3, 1.0, 3.0]))
    def test_residual_of_one_pair_is_attitude_residual(self, seed, angle):
        # The per-step residual (Python floats, math.atan2) against the array function; w < 0 included
        # (the measured quaternion's sign is arbitrary). Rotation vectors up to pi: rounding ~1e-15.
        rng = np.random.default_rng(seed)
        q_ref = quat.random(rng=rng)
        q = quat.multiply(q_ref, quat.from_axis_angle(rng.standard_normal(3), angle))
        for sign in (1.0, -1.0):
            got = mk._residual_floats(q_ref.tolist(), (sign * q).tolist())
            np.testing.assert_allclose(got, mk.attitude_residual(q_ref, sign * q), rtol=1e-13, atol=1e-15)
        assert np.abs(mk._residual_floats(q_ref.tolist(), q_ref.tolist())).max() < 1e-15  # rounding of q* ⊗ q
        for q_same in ([1.0, 0.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0]):  # no vector part at all: no rotation
            assert mk._residual_floats([1.0, 0.0, 0.0, 0.0], q_same) == [0.0, 0.0, 0.0]

    @given(st.integers(0, 2**32 - 1))
    def test_innovation_covariance_inverse_is_numpys(self, seed):
        # S = P_att + R with P from a micro-radian to a degree and R the tracker's: condition numbers up to
        # ~1e7, where the cofactor formula and LU both keep ~1e-9 relative accuracy or better.
        rng = np.random.default_rng(seed)
        m = rng.standard_normal((3, 3)) * 10.0 ** rng.uniform(-6, -2)
        s = m @ m.T + StarTracker.preset().covariance_B
        inv = np.array(mk._inverse_3x3(s.tolist()))
        np.testing.assert_allclose(inv, np.linalg.inv(s), rtol=1e-9, atol=0)
        np.testing.assert_allclose(inv @ s, np.eye(3), atol=1e-8)

    def test_transition_matrix_batches(self):
        rng = np.random.default_rng(3)
        w = rng.standard_normal((4, 5, 3))
        batch = transition_matrix(w, 0.3)
        assert batch.shape == (4, 5, 6, 6)
        np.testing.assert_allclose(batch[2, 3], transition_matrix(w[2, 3], 0.3), atol=1e-15)

    def test_process_noise_is_the_gyro_model_and_the_van_loan_integral(self):
        gyro = Gyro.preset("mems", bias_instability_model=RW, period=0.1, sampling="mean")
        for dt in (0.01, 0.1, 2.0):
            np.testing.assert_array_equal(
                process_noise(sigma_v=gyro.sigma_v, sigma_u=gyro.sigma_u, dt=dt), gyro.process_noise(dt)
            )
            # Van Loan: Q = int_0^dt Phi(s) G Qc G^T Phi(s)^T ds for the continuous Farrenkopf model at zero rate.
            f = np.zeros((6, 6))
            f[:3, 3:] = -np.eye(3)
            qc = np.diag([gyro.sigma_v**2] * 3 + [gyro.sigma_u**2] * 3)
            m = np.block([[-f, qc], [np.zeros((6, 6)), f.T]]) * dt
            e = expm(m)
            van_loan = e[6:, 6:].T @ e[:6, 6:]
            np.testing.assert_allclose(
                process_noise(sigma_v=gyro.sigma_v, sigma_u=gyro.sigma_u, dt=dt), van_loan, rtol=1e-12, atol=0
            )

    def test_initial_covariance(self):
        np.testing.assert_array_equal(
            np.diag(initial_covariance(attitude_sigma=2.0, bias_sigma=3.0)), [4.0] * 3 + [9.0] * 3
        )


@pytest.mark.slow
@pytest.mark.parametrize("grade", ["tactical", "mems"])
def test_mekf_steady_state_matches_closed_form(grade):
    """Inertial pointing, 10 Hz gyro, isotropic 6 arcsec tracker at 1 Hz: the MEKF reaches the closed form."""
    gyro = Gyro.preset(grade, bias_instability_model=RW, period=DT, sampling="mean")
    tracker = StarTracker(6 * ARCSEC, 6 * ARCSEC, period=1.0)
    t = np.arange(12_001) * DT  # 1200 s
    q_true = np.broadcast_to(quat.from_axis_angle([1.0, 1.0, 0.0], 0.3), (t.size, 4))
    g, y, bias, q0 = campaign(t, q_true, gyro, tracker, 10, 16, seed=2024, sig_a0=np.radians(0.01), sig_b0=DEG_PER_H)
    res = run_mekf(make_filter(gyro, tracker, q0=q_true[0]), t, g, y, q0=q0)
    sigma = steady_state_attitude_sigma(sigma_v=gyro.sigma_v, sigma_u=gyro.sigma_u, sigma_n=tracker.sigma_cross, dt=1.0)
    sigma_pre = steady_state_attitude_sigma(
        sigma_v=gyro.sigma_v, sigma_u=gyro.sigma_u, sigma_n=tracker.sigma_cross, dt=1.0, when="pre"
    )
    late = res.updated[0] & (t >= 400.0)
    # The filter's own covariance at the updates: at zero rate each axis is exactly the closed form's
    # problem. The Riccati transient has decayed by |l|^(2k) < 1e-8 after 400 updates; the estimated
    # rate (noise ~1e-4 rad/s) rotates Phi11 by ~1e-5 rad per step, which enters the diagonal at
    # second order (1e-10). Hence 1e-6.
    p_att = np.diagonal(res.P[:, late][..., :3, :3], axis1=-2, axis2=-1)
    np.testing.assert_allclose(np.sqrt(p_att), sigma, rtol=1e-6)
    # The innovation covariance is the pre-update variance plus R.
    s_diag = np.diagonal(res.innovation_covariance[:, late], axis1=-2, axis2=-1)
    np.testing.assert_allclose(s_diag, sigma_pre**2 + tracker.sigma_cross**2, rtol=1e-6)
    # Empirical error of 16 runs x 800 updates x 3 axes: the 10% requirement. (Measured: within
    # 2% per axis, 0.5% overall; the sampling error of a standard deviation from ~10^4 weakly correlated
    # samples is ~1%, so a 10% miss is a real modelling error, not chance.)
    err = res.errors(q_true, bias)[:, late, :3]
    assert err.std() == pytest.approx(sigma, rel=0.10)
    np.testing.assert_allclose(err.std(axis=(0, 1)), sigma, rtol=0.10)
    assert np.abs(err.mean()) < 0.05 * sigma  # zero mean: 0.05 sigma is ~5 standard errors of the mean


# ---------------------------------------------------------------------------
# Filter mechanics


def small_filter(**kwargs):
    gyro = Gyro.preset("tactical", bias_instability_model=RW, period=DT, sampling="mean")
    tracker = StarTracker.preset("typical", period=0.5)
    return make_filter(gyro, tracker, **kwargs), gyro, tracker


class TestMechanics:
    def test_noise_free_propagation_reproduces_the_tumbling_truth(self):
        t, q_true, _ = tumbling_truth()
        f, *_ = small_filter(q0=q_true[0])
        w_eq = increments_rate(q_true, DT)
        worst = 0.0
        f.step(t[0])  # the first step sets the filter's time
        for k in range(1, t.size):
            f.step(t[k], w_eq[k - 1])
            worst = max(worst, quat.error_angle(q_true[k], f.q))
        # 3000 exact constant-rate steps: only rounding accumulates (~3000 x 1e-16 rad).
        assert worst < 1e-11
        # The other multiplication order (q <- exp(w dt/2) ⊗ q) would be off by radians here.
        wrong = quat.multiply(quat.from_rotation_vector(w_eq[0] * DT), q_true[0])
        assert quat.error_angle(q_true[1], wrong) > 1e-3

    def test_one_update_is_the_kalman_update_and_the_reset(self):
        f, _, tracker = small_filter()
        rng = np.random.default_rng(5)
        f.step(0.0, np.zeros(3))
        f.step(0.1, np.array([1e-3, -2e-3, 5e-4]))
        q_prior, b_prior, p_prior = f.q, f.bias, f.P
        q_meas = quat.multiply(q_prior, quat.from_rotation_vector(rng.standard_normal(3) * 1e-3))
        f.step(0.1, None, q_meas)
        # Independent evaluation of the textbook equations (Joseph form).
        r = tracker.covariance_B
        h = np.hstack([np.eye(3), np.zeros((3, 3))])
        z = quat.to_rotation_vector(quat.multiply(quat.conjugate(q_prior), q_meas))
        s = h @ p_prior @ h.T + r
        k = p_prior @ h.T @ np.linalg.inv(s)
        x = k @ z
        ikh = np.eye(6) - k @ h
        p_post = ikh @ p_prior @ ikh.T + k @ r @ k.T
        np.testing.assert_allclose(f.P, p_post, rtol=1e-12, atol=1e-30)
        np.testing.assert_allclose(f.bias, b_prior + x[3:], rtol=0, atol=1e-18)
        expected_q = quat.normalize(quat.multiply(q_prior, quat.from_rotation_vector(x[:3])))
        np.testing.assert_allclose(f.q, expected_q, atol=1e-15)
        assert f.nis_history[1][-1] == pytest.approx(z @ np.linalg.solve(s, z), rel=1e-12)
        np.testing.assert_array_equal(f._kf.x, np.zeros(6))  # error state zeroed by the reset

    def test_second_order_covariance_reset_is_the_reset_jacobian(self):
        dtheta_hat = np.array([4e-3, -7e-3, 2e-3])

        def reset_map(dtheta):
            return quat.to_rotation_vector(
                quat.multiply(quat.from_rotation_vector(-dtheta_hat), quat.from_rotation_vector(dtheta))
            )

        h = 1e-7
        jac = np.column_stack(
            [(reset_map(dtheta_hat + h * e) - reset_map(dtheta_hat - h * e)) / (2 * h) for e in np.eye(3)]
        )
        k = skew(dtheta_hat)
        g = np.eye(3) - 0.5 * k
        # The exact Jacobian is the right Jacobian of SO(3),
        # I - (1 - cos a)/a^2 [a x] + (a - sin a)/a^3 [a x]^2 = I - [a x]/2 + [a x]^2/6 + O(a^3);
        # central differences with h = 1e-7 are good to ~1e-9 (rounding 1e-16 / h).
        a = np.linalg.norm(dtheta_hat)
        right_jacobian = np.eye(3) - (1 - np.cos(a)) / a**2 * k + (a - np.sin(a)) / a**3 * k @ k
        np.testing.assert_allclose(jac, right_jacobian, atol=1e-9)
        # So G = I - [a x]/2 misses by |a|^2/6 = 1.15e-5 at most, the identity by |a|/2 = 3.5e-3.
        a2 = dtheta_hat @ dtheta_hat
        assert np.abs(jac - g).max() <= a2 / 6.0 * 1.01
        assert np.abs(jac - np.eye(3)).max() > 0.4 * np.sqrt(a2)

        # The filter applies exactly G P G^T with the update's dtheta_hat.
        first, *_ = small_filter()
        second, *_ = small_filter(covariance_reset="second_order")
        q_meas = quat.from_rotation_vector([2e-3, -1e-3, 3e-3])
        for f in (first, second):
            f.step(0.0, np.zeros(3), q_meas)
        dth = quat.to_rotation_vector(quat.multiply(quat.conjugate(quat.identity()), first.q))
        gm = np.eye(6)
        gm[:3, :3] -= 0.5 * skew(dth)
        np.testing.assert_allclose(second.P, gm @ first.P @ gm.T, rtol=1e-12, atol=1e-30)
        np.testing.assert_array_equal(second.q, first.q)

    def test_long_run_unit_norm_and_positive_definite_covariance(self):
        t, q_true, _ = tumbling_truth()
        gyro = Gyro.preset("mems", bias_instability_model=RW, period=DT, sampling="mean")
        tracker = StarTracker.preset("typical", period=0.5)
        g, y, _, q0 = campaign(t, q_true, gyro, tracker, 5, 1, seed=11)
        res = run_mekf(make_filter(gyro, tracker, q0=q0[0]), t, g[0], y[0])
        assert res.info["path"] == "filterpy steps"
        assert np.abs(np.linalg.norm(res.q, axis=-1) - 1).max() < 1e-12
        # Symmetric to rounding (the update symmetrises; F P F^T + Q keeps it to ~1e-16 relative).
        scale = np.abs(res.P).max(axis=(-1, -2))
        assert (np.abs(res.P - np.swapaxes(res.P, -1, -2)).max(axis=(-1, -2)) / scale).max() < 1e-12
        assert np.linalg.eigvalsh(res.P).min() > 0
        assert res.updated.sum() == 601 and res.info["updates"] == 601

    def test_covariance_grows_without_tracker_and_shrinks_at_updates(self):
        f, *_ = small_filter()
        traces = []
        for k in range(11):
            f.step(k * DT, np.zeros(3), None)
            traces.append(np.trace(f.P[:3, :3]))
        assert np.all(np.diff(traces) > 0)
        f.step(1.1, np.zeros(3), quat.identity())
        assert np.trace(f.P[:3, :3]) < traces[-1] / 100  # 0.1 deg prior, 6-40 arcsec tracker
        assert f.counts["tracker_missing"] == 11 and f.counts["updates"] == 1

    def test_estimate_and_log(self):
        f, *_ = small_filter(q0=quat.from_axis_angle([0, 0, 1], 0.2), bias0=[1e-5, 0, 0])
        est = f.update(0.0, {"gyro": np.array([0.01, 0.0, 0.0]), "star_tracker": None, "torque_command": 0})
        assert isinstance(est, Estimate)
        np.testing.assert_allclose(est.omega, [0.01 - 1e-5, 0.0, 0.0])
        np.testing.assert_array_equal(est.covariance, f.P)
        log = f.log()
        assert set(log) >= {"bias", "P_diag", "nis", "updates", "tracker_nan", "gyro_nan"}
        assert np.isnan(log["nis"])
        f.update(0.1, {"gyro": np.zeros(3), "star_tracker": f.q})
        assert f.log()["nis"] >= 0 and f.log()["updates"] == 1.0


class TestBadInput:
    @pytest.mark.parametrize("bad", [0.0, -1e-6, np.nan, np.inf])
    @pytest.mark.parametrize("which", ["sigma_v", "sigma_u", "period"])
    def test_noise_figures_must_be_positive(self, bad, which):
        kwargs = {"sigma_v": 2e-5, "sigma_u": 3e-7, "period": 0.1}
        kwargs[which] = bad
        with pytest.raises(ValueError, match=which):
            MEKF(
                sigma_v=kwargs["sigma_v"],
                sigma_u=kwargs["sigma_u"],
                tracker_covariance=np.eye(3) * 1e-9,
                period=kwargs["period"],
                q0=quat.identity(),
                P0=np.eye(6),
            )

    def test_constant_bias_gyro_is_refused_with_advice(self):
        gyro = Gyro(2e-5, 0.0, period=0.1, sampling="mean")
        with pytest.raises(ValueError, match="sigma_u must be strictly positive"):
            MEKF.from_sensors(gyro, StarTracker.preset(), q0=quat.identity(), P0=np.eye(6))

    @pytest.mark.parametrize(
        ("cov", "match"),
        [
            (np.diag([1e-9, 1e-9, -1e-9]), "positive definite; its smallest eigenvalue is -1e-09"),
            (np.diag([1e-9, 1e-9, 0.0]), "positive definite"),
            (np.array([[1e-9, 5e-10, 0], [0, 1e-9, 0], [0, 0, 1e-9]]), "symmetric"),
            (np.full((3, 3), np.nan), "finite"),
            (np.eye(2), r"shape \(3, 3\)"),
        ],
    )
    def test_tracker_covariance_must_be_symmetric_positive_definite(self, cov, match):
        with pytest.raises(ValueError, match="tracker_covariance") as info:
            MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=cov, period=0.1, q0=quat.identity(), P0=np.eye(6))
        assert info.match(match)

    def test_initial_state_checks(self):
        kw = {"period": 0.1, "q0": quat.identity(), "P0": np.eye(6)}
        with pytest.raises(ValueError, match="P0 must be positive definite"):
            MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), **{**kw, "P0": -np.eye(6)})
        with pytest.raises(ValueError, match="q0 must be a unit quaternion"):
            MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), **{**kw, "q0": [1.0, 0.1, 0.0, 0.0]})
        with pytest.raises(ValueError, match="bias0"):
            MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), **kw, bias0=[1.0, 2.0])
        with pytest.raises(ValueError, match="covariance_reset"):
            MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), **kw, covariance_reset="exact")
        with pytest.raises(ValueError, match="gyro_name"):
            MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), **kw, gyro_name="")
        with pytest.raises(ValueError, match="attitude_sigma must be strictly positive"):
            initial_covariance(attitude_sigma=0.0, bias_sigma=1.0)

    def test_time_must_not_go_backwards_and_state_is_untouched(self):
        f, *_ = small_filter()
        f.step(1.0, np.zeros(3))
        before = (f.q, f.bias, f.P, f.counts)
        with pytest.raises(ValueError, match=r"t must not go backwards: t = 0.5 s < previous time 1.0 s"):
            f.step(0.5, np.zeros(3), quat.identity())
        with pytest.raises(ValueError, match="t must be finite"):
            f.step(np.nan, np.zeros(3))
        after = (f.q, f.bias, f.P, f.counts)
        for a, b in zip(before[:3], after[:3]):
            np.testing.assert_array_equal(a, b)
        assert before[3] == after[3] and f.t == 1.0
        f.step(1.0, np.zeros(3))  # a repeated time is allowed: nothing to propagate

    def test_malformed_samples_raise(self):
        f, *_ = small_filter()
        with pytest.raises(ValueError, match=r"gyro sample must have shape \(3,\)"):
            f.step(0.0, np.zeros(4))
        with pytest.raises(ValueError, match=r"tracker sample must have shape \(4,\)"):
            f.step(0.0, np.zeros(3), np.zeros(3))
        with pytest.raises(ValueError, match=r"tracker sample must be a unit quaternion .* found \|q\| = 2.0"):
            f.step(0.0, np.zeros(3), [2.0, 0.0, 0.0, 0.0])
        assert f.t is None  # nothing happened

    def test_nan_tracker_is_skipped_counted_and_never_reaches_the_state(self):
        f, *_ = small_filter()
        ref = f.copy()
        for k in range(6):
            sample = np.array([np.nan, 0.0, 0.0, 1.0]) if k == 3 else None
            f.step(k * DT, np.full(3, 1e-3), sample)
            ref.step(k * DT, np.full(3, 1e-3), None)
        assert f.counts["tracker_nan"] == 1 and f.counts["updates"] == 0
        np.testing.assert_array_equal(f.q, ref.q)
        np.testing.assert_array_equal(f.P, ref.P)
        assert np.all(np.isfinite(f.P)) and np.all(np.isfinite(f.q))
        assert f.log()["tracker_nan"] == 1.0

    def test_nan_gyro_holds_the_last_sample_and_is_counted(self):
        f, *_ = small_filter()
        ref = f.copy()
        rates = np.array([[1e-3, 0, 0], [2e-3, 1e-3, 0], [np.nan, 0, 0], [3e-3, 0, 1e-3]])
        held = rates.copy()
        held[2] = held[1]
        for k in range(4):
            f.step(k * DT, rates[k])
            ref.step(k * DT, held[k])
        assert f.counts["gyro_nan"] == 1
        np.testing.assert_array_equal(f.q, ref.q)
        np.testing.assert_array_equal(f.P, ref.P)

    def test_run_mekf_bad_input(self):
        f, *_ = small_filter()
        t = np.arange(5) * DT
        g = np.zeros((5, 3))
        y = np.full((5, 4), np.nan)
        with pytest.raises(ValueError, match=r"t must not go backwards; t\[3\]"):
            run_mekf(f, t[[0, 1, 2, 1, 4]], g, y)
        with pytest.raises(ValueError, match="gyro_meas must have shape"):
            run_mekf(f, t, g[:4], y)
        with pytest.raises(ValueError, match="tracker_meas must have shape"):
            run_mekf(f, t, g, y[:, :3])
        y_bad = y.copy()
        y_bad[2] = [0.5, 0.0, 0.0, 0.0]
        with pytest.raises(ValueError, match=r"unit quaternions .* at index \(2,\)"):
            run_mekf(f, t, g, y_bad)
        with pytest.raises(ValueError, match="inf"):
            run_mekf(f, t, np.full((5, 3), np.inf), y)
        with pytest.raises(ValueError, match="tracker_mask"):
            run_mekf(f, t, g, y, tracker_mask=np.ones(5))
        with pytest.raises(ValueError, match="q0 must have shape"):
            run_mekf(f, t, g, y, q0=np.tile(quat.identity(), (2, 1)))


# ---------------------------------------------------------------------------
# Batch API


class TestRunMekf:
    def setup_method(self):
        self.t, q_true, _ = tumbling_truth(60.0)
        self.q_true = q_true
        self.gyro = Gyro.preset("tactical", bias_instability_model=RW, period=DT, sampling="mean")
        self.tracker = StarTracker.preset("typical", period=0.5)
        self.g, self.y, self.bias, self.q0 = campaign(self.t, q_true, self.gyro, self.tracker, 5, 3, seed=8)
        # Gaps and corruption: NaN gyro rows, NaN tracker samples, a run-specific tracker mask.
        self.g[0, 100] = np.nan
        self.g[1, 200:205] = np.nan
        self.y[2, 50, 1] = np.nan
        self.mask = ~np.all(np.isnan(self.y), axis=-1)
        self.mask[1, 301] = True  # an all-NaN sample flagged as taken: a NaN measurement

    @pytest.mark.parametrize("reset", ["first_order", "second_order"])
    def test_vectorized_path_matches_filterpy_steps(self, reset):
        f = make_filter(self.gyro, self.tracker, covariance_reset=reset)
        kw = {"tracker_mask": self.mask, "q0": self.q0, "bias0": 1e-6}
        vec = run_mekf(f, self.t, self.g, self.y, **kw)
        steps = run_mekf(f, self.t, self.g, self.y, vectorized=False, **kw)
        assert vec.info["path"] == "vectorized" and steps.info["path"] == "filterpy steps"
        # Same equations, different summation order in the 6x6 products: rounding-level differences.
        np.testing.assert_allclose(vec.q, steps.q, atol=1e-14)
        np.testing.assert_allclose(vec.bias, steps.bias, atol=1e-18)
        np.testing.assert_allclose(vec.P, steps.P, rtol=1e-10, atol=1e-24)
        np.testing.assert_allclose(vec.nis, steps.nis, rtol=1e-8)
        for flag in ("updated", "tracker_nan", "gyro_nan"):
            np.testing.assert_array_equal(getattr(vec, flag), getattr(steps, flag))
        assert vec.info["gyro_nan"] == [1, 5, 0]
        assert vec.info["tracker_nan"] == [0, 1, 1]
        # Run 1's 0.5 s gyro outage (the last rate held; its error is not in Q) leaves the filter over-confident:
        # the next two tracker samples have NIS 47.8 and 49.1, just above the 1 - 1e-9 gate (44.8), and are
        # rejected on both paths; the third (NIS 41) is applied and the filter is back.
        assert vec.info["updates"] == [121, 119, 120]
        assert vec.info["gated"] == steps.info["gated"] == [0, 2, 0]
        np.testing.assert_array_equal(vec.gated, steps.gated)
        # A single run through the vectorised path is the same run.
        one = run_mekf(f, self.t, self.g[2], self.y[2], q0=self.q0[2], bias0=1e-6, vectorized=True)
        np.testing.assert_allclose(one.q, steps.q[2], atol=1e-14)

    def test_matches_the_engine_protocol_steps_and_leaves_the_filter_alone(self):
        f = make_filter(self.gyro, self.tracker, q0=self.q0[0])
        res = run_mekf(f, self.t, self.g[0], self.y[0])
        assert f.t is None and f.counts["steps"] == 0
        g = f.copy()
        for k in range(self.t.size):
            tracker = None if np.all(np.isnan(self.y[0, k])) else self.y[0, k]
            est = g.update(self.t[k], {"gyro": self.g[0, k], "star_tracker": tracker})
        np.testing.assert_array_equal(est.q, res.q[-1])
        np.testing.assert_array_equal(est.covariance, res.P[-1])

    def test_save_load_and_plots(self, tmp_path):
        f = make_filter(self.gyro, self.tracker)
        res = run_mekf(f, self.t, self.g, self.y, tracker_mask=self.mask, q0=self.q0)
        path = res.save(tmp_path / "mekf")
        back = MEKFResult.load(path)
        for name in ("q", "bias", "P", "nis", "updated", "gyro_nan", "innovation_covariance"):
            np.testing.assert_array_equal(getattr(back, name), getattr(res, name))
        assert back.info["updates"] == res.info["updates"]
        assert back.n_runs == 3 and res.sigma.shape == (3, self.t.size, 6)
        fig = res.plot(self.q_true, self.bias)
        assert isinstance(fig, Figure) and len(fig.axes) == 6
        assert isinstance(res.plot(run=1), Figure)
        single = run_mekf(f, self.t, self.g[0], self.y[0], q0=self.q0[0])
        assert single.n_runs is None and isinstance(single.plot(), Figure)
        with pytest.raises(ValueError, match="together"):
            res.plot(self.q_true)

    def test_nis_health_flags_a_biased_tracker(self):
        f = make_filter(self.gyro, self.tracker)
        clean = run_mekf(f, self.t, self.g[0], self.y[0], q0=self.q0[0])
        # 121 updates, windows of 20: ~6 independent windows at 0.999 each: false alarm ~0.6%.
        assert clean.nis_health(window=20).healthy
        biased = self.y[0].copy()
        rows = ~np.all(np.isnan(biased), axis=-1)
        # A 60 arcsec misalignment appearing at t = 30 s (10 sigma cross-boresight).
        late = rows & (self.t >= 30.0)
        biased[late] = quat.multiply(biased[late], quat.from_rotation_vector([60 * ARCSEC, 0, 0]))
        health = run_mekf(f, self.t, self.g[0], biased, q0=self.q0[0]).nis_health(window=20)
        assert not health.healthy
        assert health.interval_times[0][1] >= 30.0


# ---------------------------------------------------------------------------
# Monte Carlo consistency

N_RUNS = 64
# Fraction of steps whose 64-run average NEES must lie in the 95% chi-square band. For a consistent
# filter the expected fraction is 0.95, but consecutive steps are strongly correlated (the bias error
# wanders over hundreds of steps), so one campaign's fraction scatters: over 100 independent campaigns
# of each scenario below (seeds 0-99, run offline with nees_campaign) it ranged 0.836-0.99 (mean 0.950,
# 5th percentile 0.90). The threshold sits below that range; the over-confident filter of the negative
# control scores far below it. The average NIS, whose updates are 5 steps apart and nearly white,
# scatters less: fraction 0.93-0.97 over the same campaigns.
MIN_FRACTION_NEES = 0.80
MIN_FRACTION_NIS = 0.88


def nees_campaign(truth, seed, **filter_overrides):
    t, q_true, _ = truth
    gyro = Gyro.preset("tactical", bias_instability_model=RW, period=DT, sampling="mean")
    tracker = StarTracker.preset("typical", period=0.5)
    g, y, bias, q0 = campaign(t, q_true, gyro, tracker, 5, N_RUNS, seed)
    kw = {"sigma_v": gyro.sigma_v, "sigma_u": gyro.sigma_u, **filter_overrides}
    f = MEKF(
        sigma_v=kw["sigma_v"],
        sigma_u=kw["sigma_u"],
        tracker_covariance=tracker.covariance_B,
        period=DT,
        q0=q_true[0],
        P0=initial_covariance(attitude_sigma=SIG_A0, bias_sigma=SIG_B0),
    )
    res = run_mekf(f, t, g, y, q0=q0)
    return res, res.nees(q_true, bias)


@pytest.mark.slow
@pytest.mark.parametrize("truth", [tumbling_truth, slew_truth], ids=["tumbling", "slew"])
def test_average_nees_and_nis_inside_chi2_band(truth):
    res, nees_values = nees_campaign(truth(), seed=1)
    avg = nees_values.mean(axis=0)
    # All steps from t = 0: the initial errors are drawn from P0, so there is no transient to discard.
    assert fraction_inside_band(avg, 6, N_RUNS) >= MIN_FRACTION_NEES
    # Grand mean over 3001 steps x 64 runs: 6 for a consistent filter. The criterion: inside the 95%
    # chi-square band, counting one independent value per run (a run's time average has the mean of one
    # chi2(6) value and at most its variance, so the band is conservative for time-correlated steps).
    lo, hi = chi2_band(6, N_RUNS)
    assert lo <= avg.mean() <= hi
    # Tighter: over the 100 offline campaigns it ranged 5.70-6.36 (standard deviation 0.14, time
    # correlation again); +-10% is 4 of those.
    assert avg.mean() == pytest.approx(6.0, rel=0.10)
    # NIS at the update times (the same for every run here), 3 dof.
    upd = res.updated[0]
    assert np.all(res.updated == upd)
    avg_nis = res.nis[:, upd].mean(axis=0)
    assert fraction_inside_band(avg_nis, 3, N_RUNS) >= MIN_FRACTION_NIS
    # Grand mean of 601 x 64 NIS values: 2.97-3.03 offline (standard deviation ~0.3%); 3% is ~10 of those.
    assert avg_nis.mean() == pytest.approx(3.0, rel=0.03)


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.5, 2.0], ids=["overconfident", "pessimistic"])
def test_nees_check_rejects_a_mistuned_filter(factor):
    # The same campaign with the filter's sigma_v off by a factor 2 either way. (Offline, even a
    # factor 0.8 drops the fraction inside the band to 0.13: the check has power.)
    gyro = Gyro.preset("tactical", bias_instability_model=RW, period=DT, sampling="mean")
    _, nees_values = nees_campaign(tumbling_truth(), seed=1, sigma_v=gyro.sigma_v * factor)
    avg = nees_values.mean(axis=0)
    assert fraction_inside_band(avg, 6, N_RUNS) < 0.2
    lo, hi = chi2_band(6, N_RUNS)
    assert avg.mean() > 1.3 * hi if factor < 1 else avg.mean() < lo / 1.3


# ---------------------------------------------------------------------------
# Closed loop


class QuaternionPDForTest:
    """A minimal PD (no controllers import): ``-kp sign(w_e) vec(q_e) - kd omega`` on the estimate."""

    period = DT

    def __init__(self, q_ref, kp, kd):
        self.q_ref, self.kp, self.kd = q_ref, kp, kd

    def torque(self, t, estimate):
        e = quat.error_quaternion(self.q_ref, estimate.q)
        return -self.kp * e[1:] - self.kd * estimate.omega

    def reference(self, t):
        return self.q_ref, np.zeros(3)


@pytest.mark.slow
def test_closed_loop_controller_flies_on_the_mekf_estimate():
    body = RigidBody(np.diag([10.0, 12.0, 8.0]))
    gyro = Gyro.preset(
        "tactical", bias_instability_model=RW, period=DT, bias_deg_per_h=[3.0, -2.0, 1.0], sampling="mean"
    )
    tracker = StarTracker.preset("typical", period=0.5)
    q_ref = quat.from_axis_angle([0.0, 0.0, 1.0], np.radians(20.0))
    wn, zeta = 0.05, 0.8  # [rad/s], -: small-angle closed loop I th'' = -kp/2 th - kd th'
    pd = QuaternionPDForTest(q_ref, 2 * 10 * wn**2, 2 * zeta * wn * 10)
    f = make_filter(gyro, tracker)
    res = simulate(
        body, quat.identity(), np.zeros(3), 300.0, controller=pd, sensors=[gyro, tracker], estimator=f, rng=3
    )
    # The controller saw the estimate, not the truth: its commands are the PD of the estimate.
    k = 1234
    est = Estimate(res.t[k], res.estimate_q[k], res.estimate_omega[k])
    np.testing.assert_allclose(res.torque_command[k], pd.torque(res.t[k], est), rtol=1e-12)
    assert np.abs(res.estimate_omega - res.omega).max() > 1e-6  # gyro noise and bias residual are there
    # Estimation errors against the filter's own sigma. The gyro integrates (sampling="mean"), which is
    # what the filter models, so each error component is N(0, sigma^2): outside +-3 sigma with probability
    # 0.27 %. The 3001 steps x 3 axes are correlated in time (the tracker resets the error every 5 steps,
    # the roll every few updates), so take ~600 independent values: 1.6 +- 1.3 expected outside, i.e.
    # 0.27 +- 0.21 %; 1 % is 3.5 of those above. Measured 0.14 % here (0.14 to 0.58 % over seeds 3 to 5).
    err = quat.to_rotation_vector(quat.multiply(quat.conjugate(res.estimate_q), res.q))
    sigma = np.sqrt(res.logs["estimator.P_diag"][:, :3])
    assert np.mean(np.abs(err) > 3 * sigma) < 0.01
    assert f.counts["tracker_gated"] == 0 and np.all(res.logs["estimator.gated"] == 0)
    # The slew converges on estimates: final pointing within the 40 arcsec roll noise class.
    assert res.error_angle[-1] < 60 * ARCSEC
    assert res.logs["estimator.updates"][-1, 0] == 601
    assert f.counts["tracker_missing"] == 2400 and f.counts["tracker_nan"] == 0


# ---------------------------------------------------------------------------
# Outliers: the innovation gate, implausible gyro samples, gyro sampling


class TestGate:
    def setup_method(self):
        self.t, self.q_true, _ = tumbling_truth(60.0)
        self.gyro = Gyro.preset("tactical", bias_instability_model=RW, period=DT, sampling="mean")
        self.tracker = StarTracker.preset("typical", period=0.5)
        self.g, self.y, self.bias, self.q0 = campaign(self.t, self.q_true, self.gyro, self.tracker, 5, 2, seed=21)
        self.k = 300  # a tracker sample time (30 s: the filter has converged)
        assert not np.isnan(self.y[0, self.k, 0])

    def flipped(self):
        """The tracker samples with sample k turned by 180 deg about the body x axis (a frame/sign error)."""
        y = self.y.copy()
        y[:, self.k] = quat.multiply(y[:, self.k], quat.from_axis_angle([1.0, 0.0, 0.0], np.pi))
        return y

    def dropped(self):
        y = self.y.copy()
        y[:, self.k] = np.nan
        return y

    @pytest.mark.parametrize("vectorized", [False, True])
    def test_a_tracker_sample_180_deg_off_is_gated_counted_and_seen_by_the_health_check(self, vectorized):
        f = make_filter(self.gyro, self.tracker)
        kw = {"q0": self.q0, "vectorized": vectorized}
        bad = run_mekf(f, self.t, self.g, self.flipped(), **kw)
        ref = run_mekf(f, self.t, self.g, self.dropped(), **kw)
        assert bad.info["gated"] == [1, 1] and ref.info["gated"] == [0, 0]
        assert np.all(bad.gated[:, self.k]) and not np.any(bad.updated[:, self.k]) and bad.gated.sum() == 2
        # NIS ~ pi^2 / (prior sigma^2 + R) with arcsecond sigmas: measured 6.9e9 (gate: 44.8).
        assert np.all(bad.nis[:, self.k] > 1e9)
        # Not applied: the same run as without that sample, bit for bit.
        np.testing.assert_array_equal(bad.q, ref.q)
        np.testing.assert_array_equal(bad.P, ref.P)
        # The NIS health check sees it (20-sample windows, 0.999: the clean run is healthy).
        assert ref.nis_health(window=20).healthy and not bad.nis_health(window=20).healthy

    def test_the_filter_object_counts_logs_and_keeps_the_gated_nis(self):
        f = make_filter(self.gyro, self.tracker, q0=self.q0[0])
        ref = f.copy()
        y = self.flipped()
        for k in range(self.k + 1):
            tracker = None if np.isnan(y[0, k, 0]) else y[0, k]
            f.step(self.t[k], self.g[0, k], tracker)
            ref.step(self.t[k], self.g[0, k], None if k == self.k else tracker)
        assert f.counts["tracker_gated"] == 1 and f.counts["updates"] == ref.counts["updates"]
        log = f.log()
        assert log["gated"] == 1.0 and log["tracker_gated"] == 1.0 and log["nis"] > 1e7
        assert f.nis_history[1][-1] == log["nis"] and f.nis_history[0][-1] == self.t[self.k]
        np.testing.assert_array_equal(f.q, ref.q)
        np.testing.assert_array_equal(f.P, ref.P)
        f.step(self.t[self.k + 1], self.g[0, self.k + 1])
        assert f.log()["gated"] == 0.0 and np.isnan(f.log()["nis"])

    def test_without_the_gate_the_flipped_sample_throws_the_attitude_off(self):
        f = make_filter(self.gyro, self.tracker, gate_probability=None)
        res = run_mekf(f, self.t, self.g, self.flipped(), q0=self.q0)
        assert res.info["gated"] == [0, 0] and res.info["gate_threshold"] is None
        err = np.linalg.norm(res.errors(self.q_true, self.bias)[..., :3], axis=-1)
        # The linearised update pulls the estimate a large part of the way towards the flipped sample: the
        # attitude error jumps from a few arcsec (3-sigma 14 to 37 arcsec) to 76 deg, and 30 s later it is
        # still 0.6 to 0.7 deg (the gated run: 3 to 4 arcsec).
        assert np.all(err[:, self.k] > np.radians(10.0))
        assert np.all(err[:, -1] > np.radians(0.1))

    @pytest.mark.parametrize("value", [1e3, 1e200])
    def test_an_implausible_gyro_sample_is_rejected_like_a_nan_one(self, value):
        f = make_filter(self.gyro, self.tracker)
        assert f.gyro_rate_max == pytest.approx(np.pi / DT)
        g = self.g.copy()
        g[:, 200] = [value, 0.0, 0.0]
        g_nan = self.g.copy()
        g_nan[:, 200] = np.nan
        for vectorized in (False, True):
            bad = run_mekf(f, self.t, g, self.y, q0=self.q0, vectorized=vectorized)
            ref = run_mekf(f, self.t, g_nan, self.y, q0=self.q0, vectorized=vectorized)
            assert bad.info["gyro_rejected"] == [1, 1] and bad.info["gyro_nan"] == [0, 0]
            np.testing.assert_array_equal(bad.q, ref.q)
            np.testing.assert_array_equal(bad.P, ref.P)
        # The step API (before: "math domain error" from the quaternion step at 1e200 rad/s).
        one = make_filter(self.gyro, self.tracker)
        one.step(0.0, np.zeros(3))
        one.step(0.1, [value, 0.0, 0.0])
        assert one.counts["gyro_rejected"] == 1 and one.log()["gyro_rejected"] == 1.0
        np.testing.assert_array_equal(one.q, quat.identity())

    def test_gate_settings_are_validated(self):
        kw = {"period": 0.1, "q0": quat.identity(), "P0": np.eye(6)}
        for bad in (0.0, 1.0, np.nan):
            with pytest.raises(ValueError, match="gate_probability must be"):
                MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), gate_probability=bad, **kw)
        with pytest.raises(ValueError, match="gyro_rate_max must be strictly positive"):
            MEKF(sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), gyro_rate_max=0.0, **kw)
        assert MEKF(
            sigma_v=2e-5, sigma_u=3e-7, tracker_covariance=np.eye(3), gate_probability=0.999, **kw
        ).gate_threshold == pytest.approx(16.266, abs=1e-3)  # chi2.ppf(0.999, 3), tables: 16.27


class TestGyroSampling:
    def test_from_sensors_requires_an_integrating_gyro(self):
        point = Gyro.preset("tactical", bias_instability_model=RW, period=DT, name="fog")
        tracker = StarTracker.preset("typical", period=0.5)
        kw = {"q0": quat.identity(), "P0": initial_covariance(attitude_sigma=SIG_A0, bias_sigma=SIG_B0)}
        with pytest.raises(ValueError, match=r"gyro\.sampling must be 'mean' for MEKF\.from_sensors") as info:
            MEKF.from_sensors(point, tracker, sampling_check="raise", **kw)
        assert info.match("got 'instantaneous'") and info.match("gyro 'fog'")
        with pytest.warns(GyroSamplingWarning, match=r"gyro\.sampling must be 'mean'"):
            MEKF.from_sensors(point, tracker, **kw)  # the default warns
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            MEKF.from_sensors(point, tracker, sampling_check="ignore", **kw)
            MEKF.from_sensors(
                Gyro.preset("tactical", bias_instability_model=RW, period=DT, sampling="mean"), tracker, **kw
            )
        with pytest.raises(ValueError, match=r"gyro must be an attitude\.sensors\.Gyro"):
            MEKF.from_sensors(object(), tracker, **kw)
        # A duck-typed gyro (noise figures only) is accepted unchecked, as before.
        fake = type("FakeGyro", (), {"sigma_v": 2e-5, "sigma_u": 3e-7, "period": DT, "name": "g"})()
        assert MEKF.from_sensors(fake, tracker, **kw).period == DT

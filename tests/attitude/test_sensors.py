"""Sensors: the Farrenkopf gyro against its own exact statistics, the star tracker, the engine protocol.

Statistical checks run at fixed seeds, so they are deterministic; each
tolerance is a stated multiple (4 to 5) of the sampling standard deviation
of the estimate, so a correct model passes with a wide margin and a model
that is wrong by the size of the alternatives discussed fails.

References: the gyro model and its discrete statistics are Farrenkopf's
(R. L. Farrenkopf, "Analytic steady-state accuracy solutions for two common
spacecraft attitude estimators", J. Guidance and Control 1(4), 1978;
Markley and Crassidis, *Fundamentals of Spacecraft Attitude Determination
and Control*, 2014, sec. 6.2.2); the datasheet conversions (angle random
walk, rate random walk, bias instability and the Allan-deviation floor)
follow IEEE Std 952-1997, Annex C. The star-tracker noise is checked against
its own covariance (cross-boresight and roll sigmas).
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.sensors import (
    ARCSEC,
    GYRO_PRESETS,
    Gyro,
    GyroSamplingWarning,
    StarTracker,
    arw_from_sigma_v,
    arw_to_sigma_v,
    bias_instability_to_sigma_u,
    deg_per_h_to_rad_per_s,
    rrw_from_sigma_u,
    rrw_to_sigma_u,
)
from attitude.simulation.engine import simulate
from attitude.simulation.protocols import Truth

DEG = np.pi / 180.0


def truth(omega=(0.0, 0.0, 0.0), q=(1.0, 0.0, 0.0, 0.0), t=0.0):
    return Truth(t, np.asarray(q, float), np.asarray(omega, float), np.zeros(0))


def allan_variance(y, m):
    """Non-overlapping Allan variance of rate samples ``y`` (n, axes) at cluster size ``m``, pooled over axes."""
    n = (y.shape[0] // m) * m
    clusters = y[:n].reshape(-1, m, y.shape[1]).mean(axis=1)
    d = np.diff(clusters, axis=0)
    return 0.5 * np.mean(d**2), d.size


# ---------------------------------------------------------------------------
# Datasheet conversions


class TestConversions:
    def test_hand_computed_conversions(self):
        # 0.15 deg/sqrt(h) * 0.0174533 rad/deg / 60 sqrt(s)/sqrt(h) = 4.3633e-5 rad/s^0.5 (by hand, 5 digits).
        assert arw_to_sigma_v(0.15) == pytest.approx(4.3633e-5, rel=1e-4)
        # 1 deg/h/sqrt(h) = 0.0174533 / 3600 / 60 = 8.0802e-8 rad/s^1.5.
        assert rrw_to_sigma_u(1.0) == pytest.approx(8.0802e-8, rel=1e-4)
        # 36 deg/h = 0.01 deg/s = 1.74533e-4 rad/s.
        assert deg_per_h_to_rad_per_s(36.0) == pytest.approx(1.74533e-4, rel=1e-5)
        # B = 8 deg/h = 3.8785e-5 rad/s; 0.66428 * B * sqrt(3 / 100 s) = 4.4625e-6 rad/s^1.5.
        assert bias_instability_to_sigma_u(8.0, 100.0) == pytest.approx(4.4625e-6, rel=1e-4)
        # 6 arcsec = 6 pi / 648000 = 2.90888e-5 rad.
        assert 6 * ARCSEC == pytest.approx(2.90888e-5, rel=1e-5)

    def test_inverse_converters_round_trip(self):
        assert arw_from_sigma_v(arw_to_sigma_v(0.34)) == pytest.approx(0.34, rel=1e-14)
        assert rrw_from_sigma_u(rrw_to_sigma_u(0.02)) == pytest.approx(0.02, rel=1e-14)

    def test_bias_instability_rrw_meets_the_flicker_floor_at_the_given_time(self):
        # The defining property: Allan deviation of the RRW, sigma_u sqrt(tau/3), equals 0.664 B at tau_c.
        b_rad = 5.0 * DEG / 3600.0
        for tau_c in (30.0, 300.0):
            sigma_u = bias_instability_to_sigma_u(5.0, tau_c)
            assert sigma_u * np.sqrt(tau_c / 3.0) == pytest.approx(np.sqrt(2 * np.log(2) / np.pi) * b_rad, rel=1e-14)

    def test_from_datasheet_applies_every_conversion(self):
        g = Gyro.from_datasheet(
            arw_deg_per_sqrt_h=0.15,
            period=0.05,
            rrw_deg_per_h_per_sqrt_h=1.0,
            bias_deg_per_h=[36.0, -36.0, 0.0],
            scale_factor_ppm=[1000.0, -500.0, 0.0],
            quantization_deg_per_s=0.01,
            saturation_deg_per_s=300.0,
            name="imu",
        )
        assert g.sigma_v == pytest.approx(4.3633e-5, rel=1e-4)
        assert g.sigma_u == pytest.approx(8.0802e-8, rel=1e-4)
        np.testing.assert_allclose(g.initial_bias, [1.74533e-4, -1.74533e-4, 0.0], rtol=1e-5)
        np.testing.assert_allclose(g.scale_factor, [1e-3, -5e-4, 0.0], rtol=1e-14)
        assert g.quantization == pytest.approx(0.01 * DEG, rel=1e-14)
        assert g.saturation == pytest.approx(300 * DEG, rel=1e-14)
        assert (g.period, g.name) == (0.05, "imu")

    def test_presets_carry_their_datasheet_figures(self):
        mems = Gyro.preset("mems", period=0.01)
        assert mems.sigma_v == pytest.approx(0.34 * DEG / 60, rel=1e-14)
        # The bias instability is a Gauss-Markov term (no rate random walk is published for it).
        assert mems.sigma_u == 0.0 and mems.sigma_b > 0.0
        old_mapping = Gyro.preset("mems", period=0.01, bias_instability_model="random_walk")
        assert old_mapping.sigma_u == pytest.approx(bias_instability_to_sigma_u(8.0, 100.0), rel=1e-14)
        assert old_mapping.sigma_b == 0.0
        assert mems.saturation == pytest.approx(2000 * DEG, rel=1e-14)
        assert mems.period == 0.01
        tactical = Gyro.preset("tactical")
        assert tactical.sigma_v == pytest.approx(0.07 * DEG / 60, rel=1e-14)
        nav = Gyro.preset("navigation")
        assert nav.sigma_v == pytest.approx(0.002 * DEG / 60, rel=1e-14)
        # The grades are ordered as their names say.
        assert mems.sigma_v > tactical.sigma_v > nav.sigma_v
        assert mems.filter_sigma_u > tactical.filter_sigma_u > nav.filter_sigma_u
        assert all("source" in entry for entry in GYRO_PRESETS.values())
        # An RRW override adds its own random walk to the Gauss-Markov bias; with the random-walk model it
        # replaces the bias-instability pair (one bias-driving noise).
        with_rrw = Gyro.preset("mems", rrw_deg_per_h_per_sqrt_h=1.0)
        assert with_rrw.sigma_u == pytest.approx(rrw_to_sigma_u(1.0)) and with_rrw.sigma_b > 0.0
        replaced = Gyro.preset("mems", rrw_deg_per_h_per_sqrt_h=1.0, bias_instability_model="random_walk")
        assert replaced.sigma_u == pytest.approx(rrw_to_sigma_u(1.0)) and replaced.sigma_b == 0.0

    def test_star_tracker_preset_and_datasheet_constructor(self):
        st = StarTracker.preset("typical")
        assert st.sigma_cross == pytest.approx(6 * ARCSEC, rel=1e-14)
        assert st.sigma_roll == pytest.approx(40 * ARCSEC, rel=1e-14)
        assert st.period == 0.2 and st.sun_direction_N is None
        blinded = StarTracker.preset("typical", sun_direction_N=[1, 0, 0], period=0.1)
        assert blinded.sun_exclusion == pytest.approx(45 * DEG, rel=1e-14)
        assert blinded.period == 0.1


# ---------------------------------------------------------------------------
# Gyro noise statistics


class TestGyroNoise:
    # ARW and RRW contribute equally to the Allan variance at tau = dt = 1 s (1e-8 rad^2/s^2 each), so
    # the exact discretisation is distinguishable from the usual approximations:
    #   exact                 AVAR(dt) = sv^2/dt + su^2 dt/3  = 2.00e-8
    #   Euler (b_k + sv/sqrt(dt) N)    = sv^2/dt + su^2 dt/2  = 2.50e-8  (ADEV +12 %)
    #   mid-point without the dt/12    = sv^2/dt + su^2 dt/4  = 1.75e-8  (ADEV -6.5 %)
    SV, SU, DT = 1e-4, np.sqrt(3.0) * 1e-4, 1.0
    N = 100_000

    def gyro(self):
        return Gyro(self.SV, self.SU, period=self.DT)

    def test_allan_variance_matches_the_continuous_model_at_tau_dt_and_10_dt(self):
        errors, _ = self.gyro().sample_errors(self.N, rng=20240601)
        for m in (1, 10):
            tau = m * self.DT
            expected = self.SV**2 / tau + self.SU**2 * tau / 3.0
            avar, n_diff = allan_variance(errors, m)
            # Successive cluster differences are correlated at lag 1 only (they share one cluster), so
            # the relative std of the AVAR estimate is <= sqrt(2 (1 + 2 rho^2) / n) <= sqrt(6 / n):
            # 0.45 % at m = 1 (n = 3e5), 1.4 % at m = 10. Allow 5 of those.
            tol = 5 * np.sqrt(6.0 / n_diff)
            assert abs(avar / expected - 1) < tol, (m, avar / expected, tol)
        # At m = 1 the bound (2.2 % in AVAR) excludes both approximations listed above (+25 %, -12.5 %).

    def test_allan_deviation_at_the_sample_time_is_sigma_v_over_sqrt_dt_for_a_real_gyro(self):
        gyro = Gyro.preset("mems", period=0.01)
        errors, _ = gyro.sample_errors(self.N, rng=7)
        adev = np.sqrt(allan_variance(errors, 1)[0])
        # The RRW term adds su^2 dt / 3 = 7e-8 of the ARW term here: negligible. ADEV relative std
        # <= 0.5 sqrt(6 / 3e5) = 0.22 %; 5 of those is 1.1 %.
        assert adev / (gyro.sigma_v / np.sqrt(gyro.period)) == pytest.approx(1.0, abs=0.011)

    def test_bias_increments_and_white_noise_have_the_documented_variances(self):
        gyro = self.gyro()
        errors, biases = gyro.sample_errors(self.N, rng=99)
        steps = np.diff(biases, axis=0)
        white = errors - 0.5 * (biases[:-1] + biases[1:])
        n = steps.size
        # Independent Gaussian samples: the relative std of a variance estimate is sqrt(2 / n) = 0.26 %.
        tol = 5 * np.sqrt(2.0 / n)
        assert np.mean(steps**2) / gyro.bias_step_variance() == pytest.approx(1.0, abs=tol)
        assert np.mean(white**2) / gyro.rate_noise_variance() == pytest.approx(1.0, abs=tol)
        assert gyro.bias_step_variance() == pytest.approx(self.SU**2 * self.DT, rel=1e-15)
        assert gyro.rate_noise_variance() == pytest.approx(self.SV**2 / self.DT + self.SU**2 * self.DT / 12)
        # The white term is independent of the bias step (correlation std 1 / sqrt(n)).
        corr = np.mean(steps * white) / np.sqrt(np.mean(steps**2) * np.mean(white**2))
        assert abs(corr) < 5 / np.sqrt(n)

    def test_process_noise_matrix_matches_the_sampled_attitude_and_bias_errors(self):
        gyro = self.gyro()
        errors, biases = gyro.sample_errors(self.N, rng=3)
        # Attitude error over one step when propagating with omega_meas - b_k (true rate 0), and the bias error.
        dtheta = -self.DT * (errors - biases[:-1])
        dbias = np.diff(biases, axis=0)
        q = gyro.process_noise()
        q11, q12, q22 = q[0, 0], q[0, 3], q[3, 3]
        assert (q11, q12, q22) == pytest.approx((2e-8, -1.5e-8, 3e-8), rel=1e-12)  # by hand from the formula
        n = dtheta.size
        s11, s12, s22 = np.mean(dtheta**2), np.mean(dtheta * dbias), np.mean(dbias**2)
        # Std of a sample (co)variance of Gaussians: sqrt((s_ii s_jj + s_ij^2) / n); allow 5.
        assert abs(s11 - q11) < 5 * np.sqrt(2 / n) * q11
        assert abs(s22 - q22) < 5 * np.sqrt(2 / n) * q22
        assert abs(s12 - q12) < 5 * np.sqrt((q11 * q22 + q12**2) / n)
        # Axes are independent: the off-diagonal blocks are diagonal.
        np.testing.assert_array_equal(q[:3, 3:], q12 * np.eye(3))

    def test_same_seed_is_bit_identical_and_batch_equals_sequential(self):
        gyro = Gyro.preset("tactical", period=0.1)
        a = gyro.sample_errors(500, rng=42)
        b = gyro.sample_errors(500, rng=42)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
        assert not np.array_equal(a[0], gyro.sample_errors(500, rng=43)[0])

        t = 0.1 * np.arange(200)
        omega = np.column_stack([np.sin(t), np.cos(t), 0.1 * t]) * 0.01
        batch = gyro.measure_history(t, omega, rng=5)
        gen = np.random.default_rng(5)
        sequential = np.array([gyro.measure(tk, truth(wk), gen) for tk, wk in zip(t, omega)])
        np.testing.assert_array_equal(batch, sequential)

    def test_measure_refuses_time_going_backwards_until_reset(self):
        gyro = Gyro(1e-4, 1e-6, period=0.1, bias=[1e-3, 0, 0])
        gen = np.random.default_rng(0)
        gyro.measure(0.0, truth(), gen)
        gyro.measure(0.1, truth(), gen)
        assert not np.array_equal(gyro.bias, gyro.initial_bias)  # the bias walked
        with pytest.raises(ValueError, match=r"t must come after the previous sample.*reset\(\)"):
            gyro.measure(0.1, truth(), gen)
        gyro.reset()
        np.testing.assert_array_equal(gyro.bias, [1e-3, 0, 0])
        gyro.measure(0.0, truth(), gen)

    def test_first_sample_uses_the_initial_bias_and_one_period_of_white_noise(self):
        gyro = Gyro(1e-4, 1e-3, period=0.5, bias=[0.01, -0.02, 0.03])
        gen = np.random.default_rng(11)
        normals = np.random.default_rng(11).standard_normal((2, 3))
        out = gyro.measure(0.0, truth(), gen)
        np.testing.assert_allclose(
            out, gyro.initial_bias + np.sqrt(gyro.rate_noise_variance()) * normals[1], rtol=1e-14
        )
        np.testing.assert_array_equal(gyro.bias, gyro.initial_bias)


# ---------------------------------------------------------------------------
# Gyro deterministic errors


class TestGyroDeterministicErrors:
    OMEGA = np.array([0.1, -0.2, 0.3])

    def ideal(self, **kw):
        return Gyro(0.0, 0.0, period=0.1, **kw)

    def test_noise_free_gyro_with_bias_and_scale_factor(self):
        sf = np.array([1e-3, -2e-3, 5e-4])
        b = np.array([1e-4, 0.0, -3e-4])
        out = self.ideal(scale_factor=sf, bias=b).measure(0.0, truth(self.OMEGA))
        np.testing.assert_allclose(out, self.OMEGA * (1 + sf) + b, rtol=1e-15, atol=1e-18)

    def test_misalignment_vector_is_the_first_order_rotation_of_the_gyro_triad(self):
        theta = np.array([1e-3, -2e-3, 1.5e-3])  # [rad]
        out = self.ideal(misalignment=theta).measure(0.0, truth(self.OMEGA))
        # A triad rotated by theta reads C(theta)^T omega; the model keeps the first order, so the
        # difference is the second-order term, at most |theta|^2 |omega| / 2 = 7.25e-6 * 0.374 / 2 = 1.4e-6 rad/s.
        exact = Rotation.from_rotvec(theta).as_matrix().T @ self.OMEGA
        np.testing.assert_allclose(out, exact, rtol=0, atol=1.4e-6)
        assert np.max(np.abs(out - self.OMEGA)) > 100 * 1.4e-6  # the first-order effect is 3e-4 rad/s

    def test_misalignment_matrix_is_used_as_given(self):
        m = np.array([[0.0, 1e-3, -2e-3], [5e-4, 0.0, 1e-3], [0.0, -1e-3, 0.0]])
        out = self.ideal(misalignment=m).measure(0.0, truth(self.OMEGA))
        np.testing.assert_allclose(out, (np.eye(3) + m) @ self.OMEGA, rtol=1e-15)
        np.testing.assert_allclose(self.ideal(misalignment=m).transfer_matrix, np.eye(3) + m, rtol=0)

    def test_quantisation_rounds_to_the_lsb(self):
        lsb = 0.01 * DEG
        gyro = Gyro(1e-3, 0.0, period=0.1, quantization=lsb)
        t = 0.1 * np.arange(1000)
        omega = np.random.default_rng(1).uniform(-0.5, 0.5, (1000, 3))
        out = gyro.measure_history(t, omega, rng=2)
        counts = out / lsb
        np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
        # Without quantisation the same draws give the raw value; rounding moves it by at most LSB/2.
        raw = Gyro(1e-3, 0.0, period=0.1).measure_history(t, omega, rng=2)
        assert np.max(np.abs(out - raw)) <= 0.5 * lsb * (1 + 1e-9)
        assert np.max(np.abs(out - raw)) > 0.45 * lsb  # rounding errors fill the interval

    def test_saturation_clips_each_axis(self):
        gyro = self.ideal(saturation=5.0, quantization=0.3)
        out = gyro.measure(0.0, truth([10.0, -10.0, 0.1]))
        # 0.1 rounds to 0 counts of 0.3; +-10 round to +-9.9 and clip to +-5.
        np.testing.assert_allclose(out, [5.0, -5.0, 0.0], rtol=0, atol=1e-15)


class TestGyroValidation:
    @pytest.mark.parametrize(
        ("kwargs", "match"),
        [
            ({"sigma_v": -1e-4}, "sigma_v must be non-negative"),
            ({"sigma_v": np.nan}, "sigma_v must be finite"),
            ({"sigma_u": -1.0}, "sigma_u must be non-negative"),
            ({"period": 0.0}, "period must be strictly positive"),
            ({"period": -0.1}, "period must be strictly positive"),
            ({"bias": [1.0, 2.0]}, r"bias must be a scalar or have shape \(3,\)"),
            ({"scale_factor": -1.0}, "scale_factor must be > -1"),
            ({"misalignment": np.eye(3)}, "zero diagonal"),
            ({"misalignment": [1.0, 2.0]}, "misalignment must be a small rotation vector"),
            ({"quantization": -1e-3}, "quantization must be non-negative"),
            ({"saturation": 0.0}, "saturation must be a positive scalar"),
            ({"saturation": np.nan}, "saturation must be a positive scalar"),
            ({"name": ""}, "name must be a non-empty string"),
        ],
    )
    def test_bad_gyros_are_rejected(self, kwargs, match):
        args = {"sigma_v": 1e-4, "sigma_u": 1e-6, "period": 0.1} | kwargs
        with pytest.raises(ValueError, match=match):
            Gyro(**args)

    @pytest.mark.parametrize(
        ("kwargs", "match"),
        [
            ({"arw_deg_per_sqrt_h": 0.0}, "arw_deg_per_sqrt_h must be strictly positive"),
            ({"arw_deg_per_sqrt_h": -0.1}, "arw_deg_per_sqrt_h must be strictly positive"),
            (
                {
                    "rrw_deg_per_h_per_sqrt_h": 0.1,
                    "bias_instability_deg_per_h": 1.0,
                    "bias_instability_time_s": 300.0,
                    "bias_instability_model": "random_walk",
                },
                "not both",
            ),
            (
                {
                    "bias_instability_deg_per_h": 1.0,
                    "bias_instability_time_s": 1.0,
                    "bias_instability_model": "flicker",
                },
                "bias_instability_model must be one of",
            ),
            # The floor 0.664 B = 0.0664 deg/h at 300 s sits below sqrt(2) x the ARW line 6/sqrt(300) deg/h.
            ({"bias_instability_deg_per_h": 0.1, "bias_instability_time_s": 300.0}, "within sqrt\\(2\\) of the angle"),
            # ... and below sqrt(2) x the RRW line (60 deg/h/sqrt(h) = 1 deg/h/sqrt(s): 10 deg/h at 300 s).
            (
                {
                    "bias_instability_deg_per_h": 10.0,
                    "bias_instability_time_s": 300.0,
                    "rrw_deg_per_h_per_sqrt_h": 60.0,
                },
                "within sqrt\\(2\\) of the rate random walk",
            ),
            ({"bias_instability_deg_per_h": 1.0}, "bias_instability_time_s .* is required"),
            ({"bias_instability_deg_per_h": 0.0, "bias_instability_time_s": 10.0}, "strictly positive"),
            ({"bias_instability_deg_per_h": 1.0, "bias_instability_time_s": -1.0}, "bias_instability_time_s"),
            ({"saturation_deg_per_s": -5.0}, "saturation_deg_per_s must be a positive"),
        ],
    )
    def test_bad_datasheets_are_rejected(self, kwargs, match):
        args = {"arw_deg_per_sqrt_h": 0.1, "period": 0.1} | kwargs
        with pytest.raises(ValueError, match=match):
            Gyro.from_datasheet(**args)

    def test_bad_calls_are_rejected(self):
        gyro = Gyro(1e-4, period=0.1)
        with pytest.raises(ValueError, match="grade must be one of"):
            Gyro.preset("consumer")
        with pytest.raises(ValueError, match="n_steps must be a positive integer"):
            gyro.sample_errors(0)
        with pytest.raises(ValueError, match=r"truth\.omega must be finite"):
            gyro.measure(0.0, truth([np.nan, 0, 0]))
        with pytest.raises(ValueError, match="t must be strictly increasing"):
            gyro.measure_history([0.0, 0.0], np.zeros((2, 3)))


# ---------------------------------------------------------------------------
# Star tracker


class TestStarTracker:
    BORESIGHT = np.array([1.0, 2.0, -2.0]) / 3.0  # not along a body axis
    N = 20_000

    def tracker(self, **kw):
        return StarTracker.from_datasheet(
            cross_boresight_arcsec=6.0, roll_arcsec=40.0, period=0.2, boresight_B=self.BORESIGHT, **kw
        )

    def errors_B(self, tracker, rng):
        q_true = quat.random(self.N, rng=rng)
        q_meas = tracker.add_noise(q_true, rng=rng)
        return quat.to_rotation_vector(quat.multiply(quat.conjugate(q_true), q_meas))

    def test_sensor_frame_is_right_handed_with_the_boresight_third(self):
        c = self.tracker().C_BS
        np.testing.assert_allclose(c.T @ c, np.eye(3), atol=1e-15)
        assert np.linalg.det(c) == pytest.approx(1.0, abs=1e-15)
        np.testing.assert_allclose(c[:, 2], self.BORESIGHT, rtol=1e-15)

    def test_per_axis_noise_in_the_sensor_frame_has_the_configured_sigmas(self):
        tracker = self.tracker()
        err_S = self.errors_B(tracker, np.random.default_rng(2024)) @ tracker.C_BS  # rows: C_BS^T dtheta_B
        std = err_S.std(axis=0)
        # A sample std of n = 20000 Gaussians has relative std 1/sqrt(2n) = 0.5 %: 2 % is 4 of those.
        np.testing.assert_allclose(std / ARCSEC, [6.0, 6.0, 40.0], rtol=0.02)
        # Zero mean: |mean| < 4 sigma / sqrt(n).
        assert np.all(np.abs(err_S.mean(axis=0)) < 4 * np.array([6.0, 6.0, 40.0]) * ARCSEC / np.sqrt(self.N))
        # The large (roll) error is about the boresight: its body-frame component along b.
        roll = self.errors_B(tracker, np.random.default_rng(5)) @ self.BORESIGHT
        assert roll.std() / ARCSEC == pytest.approx(40.0, rel=0.02)

    def test_body_covariance_matches_the_sample_covariance(self):
        tracker = self.tracker()
        err = self.errors_B(tracker, np.random.default_rng(77))
        sample = err.T @ err / self.N  # zero-mean model: no mean subtracted
        cov = tracker.covariance_B
        d = np.sqrt(np.diag(cov))
        # Std of a sample covariance entry: sqrt((C_ii C_jj + C_ij^2) / n); allow 4.5 of those.
        tol = 4.5 * np.sqrt((np.outer(d**2, d**2) + cov**2) / self.N)
        assert np.all(np.abs(sample - cov) < tol), (sample - cov) / tol
        np.testing.assert_allclose(np.linalg.eigvalsh(cov), np.array([6.0, 6.0, 40.0]) ** 2 * ARCSEC**2, rtol=1e-12)

    def test_batch_noise_equals_sequential_measurements_and_same_seed_repeats(self):
        tracker = self.tracker()
        q = quat.random(50, rng=1)
        batch = tracker.add_noise(q, rng=9)
        gen = np.random.default_rng(9)
        sequential = np.array([tracker.measure(0.0, truth(q=qk), gen) for qk in q])
        np.testing.assert_array_equal(batch, sequential)
        np.testing.assert_array_equal(batch, tracker.add_noise(q, rng=9))

    def test_dropout_happens_exactly_when_the_sun_is_inside_the_cone(self):
        half = 30 * DEG
        rng = np.random.default_rng(4)
        q = quat.random(400, rng=rng)
        # Sun directions at known angles from the boresight (in body), mapped to N by each attitude.
        angles = np.concatenate([rng.uniform(0, np.pi, 392), half + np.array([-1e-9, 1e-9, -1e-6, 1e-6])])
        angles = np.concatenate([angles, [0.0, np.pi, half - 1e-3, half + 1e-3]])
        perp = np.cross(self.BORESIGHT, rng.standard_normal((400, 3)))
        perp /= np.linalg.norm(perp, axis=1, keepdims=True)
        sun_B = np.cos(angles)[:, None] * self.BORESIGHT + np.sin(angles)[:, None] * perp
        sun_N = quat.rotate(q, sun_B)
        gen = np.random.default_rng(0)
        for qk, sk, angle in zip(q, sun_N, angles):
            tracker = self.tracker(sun_direction_N=sk, sun_exclusion_deg=30.0)
            sample = tracker.measure(0.0, truth(q=qk), gen)
            assert (sample is None) == (angle < half), angle / DEG

    def test_time_varying_sun_direction(self):
        # Sun circling in the N x-y plane once per 360 s; identity attitude; boresight +x (body = N).
        tracker = StarTracker.preset(
            period=1.0,
            boresight_B=[1.0, 0.0, 0.0],
            sun_direction_N=lambda t: [np.cos(t * DEG), np.sin(t * DEG), 0.0],
        )
        gen = np.random.default_rng(1)
        t = np.arange(0.0, 360.0, 1.0)
        blinded = np.array([tracker.measure(tk, truth(t=tk), gen) is None for tk in t])
        angle = np.minimum(t, 360.0 - t)  # Sun-boresight angle [deg]
        np.testing.assert_array_equal(blinded, angle < 45.0)

    def test_no_random_numbers_are_drawn_while_blinded(self):
        tracker = self.tracker(sun_direction_N=self.BORESIGHT, sun_exclusion_deg=10.0)
        gen = np.random.default_rng(3)
        assert tracker.measure(0.0, truth(), gen) is None
        assert gen.standard_normal() == np.random.default_rng(3).standard_normal()

    @pytest.mark.parametrize(
        ("kwargs", "match"),
        [
            ({"sigma_cross_rad": 0.0}, "sigma_cross_rad must be strictly positive"),
            ({"sigma_roll_rad": -1e-5}, "sigma_roll_rad must be strictly positive"),
            ({"sigma_roll_rad": np.nan}, "sigma_roll_rad must be finite"),
            ({"period": 0.0}, "period must be strictly positive"),
            ({"boresight_B": [0.0, 0.0, 0.0]}, "boresight_B must be a non-zero vector"),
            ({"boresight_B": [0.0, np.nan, 1.0]}, "boresight_B must be finite"),
            ({"sun_direction_N": [1.0, 0.0, 0.0]}, "must be given together"),
            ({"sun_exclusion_rad": 0.3}, "must be given together"),
            ({"sun_direction_N": [1.0, 0.0, 0.0], "sun_exclusion_rad": np.pi}, r"in \(0, pi\)"),
            ({"sun_direction_N": [0.0, 0.0, 0.0], "sun_exclusion_rad": 0.5}, "sun_direction_N must be a non-zero"),
        ],
    )
    def test_bad_trackers_are_rejected(self, kwargs, match):
        args = {"sigma_cross_rad": 3e-5, "sigma_roll_rad": 2e-4, "period": 0.2} | kwargs
        with pytest.raises(ValueError, match=match):
            StarTracker(**args)

    def test_non_unit_boresight_is_normalised_and_bad_sun_callables_are_caught(self):
        tracker = StarTracker(3e-5, 2e-4, period=0.2, boresight_B=[0.0, 0.0, 5.0])
        np.testing.assert_array_equal(tracker.boresight_B, [0.0, 0.0, 1.0])
        bad = StarTracker(3e-5, 2e-4, period=0.2, sun_direction_N=lambda t: [0.0, 0.0, 0.0], sun_exclusion_rad=0.5)
        with pytest.raises(ValueError, match=r"sun_direction_N\(t\) must be a non-zero vector"):
            bad.measure(0.0, truth(), 0)
        with pytest.raises(ValueError, match="kind must be one of"):
            StarTracker.preset("hubble")


# ---------------------------------------------------------------------------
# In the closed-loop engine


class TestInSimulation:
    # Diagonal inertia with x the major axis: a spin about x stays a pure spin about x.
    BODY = RigidBody(np.diag([12.0, 10.0, 8.0]))
    RATE = 0.2  # [rad/s] about x

    def sensors(self):
        gyro = Gyro.preset("tactical", period=0.1)
        # Boresight z_B sweeps through the y-z plane of N: at time t it points at angle 0.2 t from z_N.
        # The Sun at 0.6 rad from z_N (same plane) is within 0.25 rad of the boresight for t in (1.75, 4.25) s.
        sun_N = [0.0, -np.sin(0.6), np.cos(0.6)]
        tracker = StarTracker.preset(period=0.5, sun_direction_N=sun_N, sun_exclusion_deg=0.25 / DEG)
        return gyro, tracker

    def run(self, rng=7):
        gyro, tracker = self.sensors()
        return simulate(self.BODY, quat.identity(), [self.RATE, 0, 0], 6.0, sensors=[gyro, tracker], rng=rng), gyro

    def test_logs_have_one_row_per_tick_and_nan_where_the_sensor_did_not_sample(self):
        result, gyro = self.run()
        assert result.info["engine"] == "python" and result.info["dt"] == pytest.approx(0.1)
        w = result.logs["sensor.gyro"]
        st = result.logs["sensor.star_tracker"]
        assert w.shape == (61, 3) and st.shape == (61, 4)
        assert np.all(np.isfinite(w))
        # Gyro errors: bias (0 initially, walks ~1e-7 rad/s here) plus white noise of std 6.4e-5 rad/s;
        # 6 sigma bounds every one of 183 samples.
        assert np.max(np.abs(w - result.omega)) < 6 * np.sqrt(gyro.rate_noise_variance())
        tracker_rows = np.arange(61) % 5 == 0
        expected_blind = (result.t > 1.75) & (result.t < 4.25) & tracker_rows
        np.testing.assert_array_equal(np.isnan(st[:, 0]), ~tracker_rows | expected_blind)
        assert expected_blind.sum() == 5  # t = 2.0, 2.5, 3.0, 3.5, 4.0
        ok = ~np.isnan(st[:, 0])
        # Tracker error angle: 40 arcsec roll and 6 arcsec cross 1-sigma; 200 arcsec is 5 sigma.
        assert np.max(quat.error_angle(result.q[ok], st[ok])) < 200 * ARCSEC

    def test_same_seed_reproduces_the_sensor_logs(self):
        a, _ = self.run(rng=3)
        b, _ = self.run(rng=3)
        np.testing.assert_array_equal(a.logs["sensor.gyro"], b.logs["sensor.gyro"])
        np.testing.assert_array_equal(a.logs["sensor.star_tracker"], b.logs["sensor.star_tracker"])
        c, _ = self.run(rng=4)
        assert not np.array_equal(a.logs["sensor.gyro"], c.logs["sensor.gyro"])

    def test_simulate_resets_the_sensors_so_a_seed_reproduces_a_run(self):
        gyro, tracker = self.sensors()
        args = (self.BODY, quat.identity(), [self.RATE, 0, 0], 1.0)
        first = simulate(*args, sensors=[gyro, tracker], rng=1)
        second = simulate(*args, sensors=[gyro, tracker], rng=1)
        np.testing.assert_array_equal(first.logs["sensor.gyro"], second.logs["sensor.gyro"])
        # Outside simulate, measuring twice at the same time still needs a reset.
        with pytest.raises(ValueError, match="reset"):
            gyro.measure(0.0, truth(t=0.0), np.random.default_rng(0))


class TestMeanRateSampling:
    def test_a_mean_rate_gyro_reports_the_attitude_increment_over_the_interval(self):
        # Noise-free gyro on a body accelerating about z: the mean rate over
        # [t0, t1] is the angle increment / dt, not the rate at t1.
        gyro = Gyro(0.0, 0.0, period=0.1, sampling="mean")
        alpha = 0.2  # rad/s^2
        t0, t1 = 1.0, 1.1

        def state(t):
            angle = 0.5 * alpha * t * t
            return truth(omega=(0.0, 0.0, alpha * t), q=quat.from_axis_angle([0, 0, 1], angle), t=t)

        first = gyro.measure(t0, state(t0), 0)
        np.testing.assert_allclose(first, [0.0, 0.0, alpha * t0], atol=1e-15)  # first sample: instantaneous
        second = gyro.measure(t1, state(t1), 0)
        mean_rate = 0.5 * alpha * (t1**2 - t0**2) / (t1 - t0)
        np.testing.assert_allclose(second, [0.0, 0.0, mean_rate], atol=1e-12)
        assert abs(second[2] - alpha * t1) > 1e-3  # distinguishable from the instantaneous rate

    @staticmethod
    def tumbling_history(n=300):
        """Truth of an accelerating tumble on an uneven time grid (exact, adaptive integration)."""
        from attitude.propagate import propagate

        t = np.cumsum(np.r_[0.0, 0.1 + 0.02 * np.sin(np.arange(n - 1))])
        traj = propagate(
            RigidBody([4.0, 8.0, 10.0]),
            quat.from_axis_angle([1.0, 2.0, 3.0], 0.4),
            np.radians([20.0, -30.0, 15.0]),
            t,
            method="adaptive",
        )
        return t, traj.q, traj.omega

    @pytest.mark.parametrize("sampling", ["instantaneous", "mean"])
    def test_measure_history_is_bit_identical_to_measure(self, sampling):
        # Every deterministic error switched on, uneven steps, a body whose rate changes by degrees/s per sample.
        t, q, omega = self.tumbling_history()
        kw = {"bias_deg_per_h": [50.0, -20.0, 10.0], "scale_factor_ppm": 300.0, "quantization_deg_per_s": 1e-4}
        gyro = Gyro.preset("mems", period=0.1, sampling=sampling, misalignment_rad=[1e-3, 0.0, -2e-3], **kw)
        batch = gyro.measure_history(t, omega, 5, q_BN=q)
        gen = np.random.default_rng(5)
        sequential = np.array([gyro.measure(tk, truth(wk, qk, tk), gen) for tk, qk, wk in zip(t, q, omega)])
        np.testing.assert_array_equal(batch, sequential)
        # The two samplings really differ here (the interval mean lags by dt/2 times the acceleration).
        other = Gyro.preset("mems", period=0.1, misalignment_rad=[1e-3, 0.0, -2e-3], **kw).measure_history(t, omega, 5)
        assert (np.abs(other - batch).max() > 1e-3) == (sampling == "mean")

    def test_measure_history_of_a_mean_gyro_needs_the_attitude(self):
        t, q, omega = self.tumbling_history(10)
        gyro = Gyro(1e-4, period=0.1, sampling="mean", name="fog")
        with pytest.raises(ValueError, match=r"q_BN is required: gyro 'fog' has sampling='mean'"):
            gyro.measure_history(t, omega, 1)
        with pytest.raises(ValueError, match=r"q_BN must have shape \(10, 4\)"):
            gyro.measure_history(t, omega, 1, q_BN=q[:5])
        with pytest.raises(ValueError, match="q_BN must be a unit quaternion"):
            gyro.measure_history(t, omega, 1, q_BN=2 * q)
        # An instantaneous gyro checks the attitude but does not need it.
        plain = Gyro(1e-4, period=0.1)
        np.testing.assert_array_equal(plain.measure_history(t, omega, 1, q_BN=q), plain.measure_history(t, omega, 1))

    def test_sample_errors_runs_axis_is_bit_identical_to_consecutive_runs(self):
        gyro = Gyro.preset("tactical", period=0.1)
        b0 = np.random.default_rng(3).standard_normal((4, 3)) * 1e-5
        errors, biases = gyro.sample_errors(200, 9, bias0=b0, n_runs=4)
        assert errors.shape == (4, 200, 3) and biases.shape == (4, 201, 3)
        gen = np.random.default_rng(9)
        for r in range(4):
            e1, b1 = gyro.sample_errors(200, gen, bias0=b0[r])
            np.testing.assert_array_equal(errors[r], e1)
            np.testing.assert_array_equal(biases[r], b1)
        shared, _ = gyro.sample_errors(5, 1, bias0=[1e-5, 0.0, 0.0], n_runs=2)  # one bias0 for every run
        assert shared.shape == (2, 5, 3)
        with pytest.raises(ValueError, match=r"bias0 must be a scalar or have shape \(3,\) or \(4, 3\)"):
            gyro.sample_errors(5, 1, bias0=np.zeros((2, 3)), n_runs=4)
        with pytest.raises(ValueError, match="n_runs must be a positive integer"):
            gyro.sample_errors(5, 1, n_runs=0)

    def test_check_sampling(self):
        gyro = Gyro(1e-4, period=0.1, sampling="mean", name="fog")
        assert gyro.check_sampling("mean", consumer="X")
        with pytest.raises(
            ValueError, match=r"gyro\.sampling must be 'instantaneous' for X, got 'mean' \(gyro 'fog'\)"
        ):
            gyro.check_sampling("instantaneous", consumer="X")
        with pytest.warns(GyroSamplingWarning, match=r"gyro\.sampling must be 'instantaneous'"):
            assert not gyro.check_sampling("instantaneous", consumer="X", action="warn")
        assert not gyro.check_sampling("instantaneous", consumer="X", action="ignore")
        with pytest.raises(ValueError, match="sampling_check must be one of"):
            gyro.check_sampling("mean", consumer="X", action="loud")

    def test_sampling_is_validated_and_passed_by_the_datasheet_constructor(self):
        with pytest.raises(ValueError, match="sampling must be one of"):
            Gyro(1e-5, period=0.1, sampling="average")
        assert Gyro.from_datasheet(arw_deg_per_sqrt_h=0.07, period=0.1, sampling="mean").sampling == "mean"
        assert Gyro.preset("tactical", sampling="mean").sampling == "mean"


# ---------------------------------------------------------------------------
# The Gauss-Markov bias (the datasheet bias instability)


class TestGaussMarkov:
    def test_peak_constants_by_a_bounded_search(self):
        from scipy.optimize import minimize_scalar

        from attitude.sensors import GAUSS_MARKOV_PEAK_FACTOR, GAUSS_MARKOV_PEAK_RATIO, gauss_markov_allan_variance

        best = minimize_scalar(
            lambda u: -gauss_markov_allan_variance(u, 1.0, 1.0),
            bounds=(0.1, 10.0),
            method="bounded",
            options={"xatol": 1e-10},
        )
        # Stated to 5 significant digits.
        assert best.x == pytest.approx(GAUSS_MARKOV_PEAK_RATIO, abs=1e-4)
        assert np.sqrt(-best.fun) == pytest.approx(GAUSS_MARKOV_PEAK_FACTOR, abs=1e-4)

    def test_closed_form_is_the_spectral_integral(self):
        # IEEE 952 eq. C.2: avar = 4 int_0^inf S(f) sin^4(pi f tau) / (pi f tau)^2 df, with the two-sided PSD of a
        # Gauss-Markov process S(f) = 2 sigma^2 T / (1 + (2 pi f T)^2); quad to 1e-10 relative.
        from scipy.integrate import quad

        from attitude.sensors import gauss_markov_allan_variance

        sigma, big_t = 3e-6, 150.0
        for tau in (0.5, 20.0, 280.0, 5000.0):

            def integrand(x, tau=tau):  # x = pi f tau
                f = x / (np.pi * tau)
                return 2 * sigma**2 * big_t / (1 + (2 * np.pi * f * big_t) ** 2) * np.sin(x) ** 4 / x**2 / (np.pi * tau)

            value = 4 * sum(quad(integrand, k * np.pi, (k + 1) * np.pi, epsabs=0, epsrel=1e-12)[0] for k in range(600))
            # The tail beyond 600 pi falls as x^-4 (S ~ 1/f^2); 4000 intervals agree to 1e-8, so 600 hold 1e-7.
            assert gauss_markov_allan_variance(tau, sigma, big_t) == pytest.approx(value, rel=1e-7)

    def test_without_a_bias_instability_the_numbers_are_the_farrenkopf_ones(self):
        # The random layout is unchanged: [N_u, N_v] per step, and the errors follow docs/sensors.md exactly.
        g = Gyro.from_datasheet(arw_deg_per_sqrt_h=0.1, rrw_deg_per_h_per_sqrt_h=0.5, period=0.1)
        assert g.sigma_b == 0.0 and g.filter_sigma_u == g.sigma_u
        errors, biases = g.sample_errors(50, np.random.default_rng(3))
        n = np.random.default_rng(3).standard_normal((50, 2, 3))
        b = np.cumsum(np.concatenate([np.zeros((1, 3)), g.sigma_u * np.sqrt(0.1) * n[:, 0]]), axis=0)
        white = np.sqrt(g.sigma_v**2 / 0.1 + g.sigma_u**2 * 0.1 / 12)
        np.testing.assert_array_equal(biases, b)
        np.testing.assert_array_equal(errors, 0.5 * (b[:-1] + b[1:]) + white * n[:, 1])

    def test_filter_random_walk_bounds_the_bias_increment(self):
        from attitude.sensors import gauss_markov_equivalent_sigma_u

        g = Gyro.preset("tactical")
        horizons = np.geomspace(0.01, 1e5, 200)
        increment = 2 * g.sigma_b**2 * -np.expm1(-horizons / g.correlation_time)  # Var[b(t + D) - b(t)]
        assert np.all(increment <= g.filter_sigma_u**2 * horizons * (1 + 1e-12))
        d = 500.0
        matched = gauss_markov_equivalent_sigma_u(g.sigma_b, g.correlation_time, horizon_s=d)
        assert matched**2 * d == pytest.approx(2 * g.sigma_b**2 * -np.expm1(-d / g.correlation_time), rel=1e-12)

    def test_the_navigation_preset_is_consistent(self):
        # Its assumed 3 h keeps the floor more than sqrt(2) above the ARW line (the 1 h it had is refused).
        assert Gyro.preset("navigation").sigma_b > 0
        with pytest.raises(ValueError, match="within sqrt"):
            Gyro.preset("navigation", bias_instability_time_s=3600.0)


# ---------------------------------------------------------------------------
# The per-tick float path against the array path


class TestFloatPathIsTheArrayPath:
    """``measure`` on float64 arrays runs one sample in Python floats; on anything else, the array code.

    Both must give the same numbers bit for bit (a batch of runs relies on it). The reference is the
    array path of the same sensor, reached by handing it the truth as Python lists (which the float
    path does not take), with its own copy of the generator and sensor state.
    """

    @staticmethod
    def wandering_truth(n, seed, scale=1.0):
        """Attitudes turning by ~0.1 ``scale`` rad per sample, rates of ~0.5 ``scale`` rad/s, at uneven times.

        A small ``scale`` leaves the samples made of the noise terms alone, whose last bits the true rate
        would otherwise round away: a change of operation order shows there.
        """
        rng = np.random.default_rng(seed)
        t = np.cumsum(rng.uniform(0.01, 0.3, n))
        q = [quat.random(rng=rng)]
        for _ in range(n - 1):
            q.append(quat.multiply(q[-1], quat.from_rotation_vector(rng.normal(scale=0.1 * scale, size=3))))
        omega = rng.normal(scale=0.5 * scale, size=(n, 3))
        return t, np.array(q), omega

    @pytest.mark.parametrize("sampling", ["mean", "instantaneous"])
    @pytest.mark.parametrize("bias_model", ["gauss_markov", "random_walk"])  # with and without a Gauss-Markov term
    @pytest.mark.parametrize("deterministic", [False, True])
    @pytest.mark.parametrize("motion", [1.0, 1e-7])
    def test_gyro(self, sampling, bias_model, deterministic, motion):
        kw = {"bias_instability_model": bias_model}
        if deterministic:  # scale factor, misalignment, quantisation and a saturation the rates reach
            kw |= {"scale_factor_ppm": [300.0, -100.0, 50.0], "misalignment_rad": [1e-3, 0.0, -2e-3]}
            kw |= {"quantization_deg_per_s": 1e-3, "saturation_deg_per_s": 40.0}
        fast, slow = (Gyro.preset("mems", period=0.1, sampling=sampling, **kw) for _ in range(2))
        assert (fast.sigma_b > 0) == (bias_model == "gauss_markov")
        t, q, omega = self.wandering_truth(300, seed=7, scale=motion)
        gen_fast, gen_slow = np.random.default_rng(3), np.random.default_rng(3)
        for tk, qk, wk in zip(t, q, omega):
            a = fast.measure(float(tk), Truth(tk, qk, wk, np.zeros(0)), gen_fast)
            b = slow.measure(float(tk), Truth(tk, qk.tolist(), wk.tolist(), np.zeros(0)), gen_slow)
            np.testing.assert_array_equal(a, b)
            np.testing.assert_array_equal(fast.bias, slow.bias)
        if deterministic and motion == 1.0:
            assert np.any(np.abs(omega) > 40.0 * DEG), "the test should reach saturation"

    def test_gyro_refuses_bad_truth_on_either_path(self):
        gyro = Gyro.preset("mems", period=0.1, sampling="mean")
        with pytest.raises(ValueError, match=r"truth\.omega must be finite"):
            gyro.measure(0.0, truth(omega=[np.nan, 0.0, 0.0]))
        with pytest.raises(ValueError, match=r"truth\.q must be a unit quaternion"):
            gyro.measure(0.0, truth(q=[2.0, 0.0, 0.0, 0.0]))
        assert gyro.measure(0.0, truth()).shape == (3,)  # nothing was consumed by the refusals

    def test_star_tracker_noise_near_the_identity(self):
        # Near the identity the measured vector part is the noise rotation alone: its last bits show (with a
        # tilted boresight, every sensor axis has three non-zero body components).
        tracker = StarTracker.preset(period=0.2, boresight_B=[0.3, -0.5, 0.8])
        gen_fast, gen_slow = np.random.default_rng(6), np.random.default_rng(6)
        for qk in quat.from_rotation_vector(np.random.default_rng(2).normal(scale=1e-9, size=(200, 3))):
            a = tracker.measure(0.0, Truth(0.0, qk, np.zeros(3), np.zeros(0)), gen_fast)
            np.testing.assert_array_equal(a, tracker.measure(0.0, Truth(0.0, qk.tolist(), np.zeros(3), []), gen_slow))

    @pytest.mark.parametrize("sun", ["fixed", "moving", "none"])
    def test_star_tracker(self, sun):
        # A 60 deg cone about +z and a Sun the wandering attitudes bring in and out of it.
        kw = {}
        if sun != "none":
            kw = {"sun_direction_N": [0.3, -0.2, 0.9], "sun_exclusion_deg": 60.0}
            if sun == "moving":
                kw["sun_direction_N"] = lambda t: [np.cos(0.1 * t), np.sin(0.1 * t), 0.5]
        tracker = StarTracker.preset(period=0.2, **kw)
        t, q, _ = self.wandering_truth(400, seed=11)
        gen_fast, gen_slow = np.random.default_rng(5), np.random.default_rng(5)
        blinded = 0
        for tk, qk in zip(t, q):
            a = tracker.measure(float(tk), Truth(tk, qk, np.zeros(3), np.zeros(0)), gen_fast)
            b = tracker.measure(float(tk), Truth(tk, qk.tolist(), np.zeros(3), np.zeros(0)), gen_slow)
            assert (a is None) == (b is None)
            if a is None:
                blinded += 1
            else:
                np.testing.assert_array_equal(a, b)
        assert (blinded > 20) == (sun != "none") and blinded < 380  # both branches were taken

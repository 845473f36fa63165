"""Consistency tools: NEES/NIS against chi-square draws, published quantiles, filterpy, and a Monte Carlo filter.

References: the NEES/NIS tests of Bar-Shalom, Li and Kirubarajan, *Estimation with Applications to
Tracking and Navigation*, 2001, sec. 5.4 (as in :mod:`estimation.consistency`); ``filterpy.stats.NEES``
as the independent library; published chi-square quantiles (NIST/SEMATECH e-Handbook of Statistical
Methods, sec. 1.3.6.7.4); Monte Carlo averages of ``numpy`` chi-square draws for the averaged-NEES band;
and a scalar gyro-bias Kalman filter fed by the exact Farrenkopf gyro model (consistent) against a naive one (not).

Every random check runs at a fixed seed; each tolerance is a stated multiple
(4 to 5) of the sampling standard deviation of the statistic it bounds.
"""

import numpy as np
import pytest
from filterpy.stats import NEES as filterpy_nees
from matplotlib.figure import Figure

from attitude.sensors import Gyro
from estimation.consistency import (
    NisHealth,
    average_nees,
    average_nis,
    chi2_band,
    fraction_inside_band,
    nees,
    nis,
    nis_health,
    plot_errors_with_bounds,
    plot_nees,
)


def random_spd(rng, shape, n):
    a = rng.standard_normal((*shape, n, n))
    return a @ np.swapaxes(a, -1, -2) + 0.1 * np.eye(n)


def draws(rng, cov):
    """Zero-mean Gaussian vectors with the given covariances (..., n, n)."""
    chol = np.linalg.cholesky(cov)
    return (chol @ rng.standard_normal((*cov.shape[:-1], 1)))[..., 0]


class TestNeesNis:
    def test_nees_of_correct_covariances_averages_to_the_dimension(self):
        rng = np.random.default_rng(1)
        cov = random_spd(rng, (50_000,), 6)
        e = draws(rng, cov)
        values = nees(e, cov)
        # Mean of n chi2(6) values: std sqrt(2 * 6 / n) = 0.0155; allow 5 of those.
        assert values.mean() == pytest.approx(6.0, abs=5 * np.sqrt(12 / 50_000))
        # Variance 2 dof = 12 (relative std of a sample variance of chi2(6) ~ sqrt((2 + 12/6)/n) = 0.9 %; 5 of those).
        assert values.var() / 12.0 == pytest.approx(1.0, abs=5 * np.sqrt(4 / 50_000))
        # A covariance twice too large halves the NEES: the test detects it.
        assert nees(e, 2 * cov).mean() == pytest.approx(3.0, abs=5 * np.sqrt(12 / 50_000) / 2)

    def test_agrees_with_filterpy_nees(self):
        rng = np.random.default_rng(2)
        cov = random_spd(rng, (200,), 4)
        x_true = rng.standard_normal((200, 4))
        x_est = x_true - draws(rng, cov)
        ours = nees(x_true - x_est, cov)
        theirs = np.array(filterpy_nees(x_true, x_est, cov))
        # Same quantity; they invert P, we solve with its Cholesky factor: rounding-level differences.
        np.testing.assert_allclose(ours, theirs, rtol=1e-10)

    def test_batches_broadcast_and_nis_is_the_same_quadratic_form(self):
        rng = np.random.default_rng(3)
        cov = random_spd(rng, (7,), 3)  # one covariance history shared by all runs
        e = rng.standard_normal((5, 7, 3))  # runs x times x n
        values = nees(e, cov)
        assert values.shape == (5, 7)
        expected = np.einsum("rti,tij,rtj->rt", e, np.linalg.inv(cov), e)
        np.testing.assert_allclose(values, expected, rtol=1e-10)
        np.testing.assert_array_equal(nis(e, cov), values)
        np.testing.assert_allclose(average_nees(e, cov), expected.mean(axis=0), rtol=1e-10)
        np.testing.assert_allclose(average_nis(e, cov), expected.mean(axis=0), rtol=1e-10)

    @pytest.mark.parametrize(
        ("errors", "cov", "match"),
        [
            (np.ones(3), np.eye(2), r"covariances must have shape \(\.\.\., 3, 3\)"),
            (np.ones(2), [[1.0, 2.0], [2.0, 1.0]], "positive definite"),
            (np.ones(2), [[1.0, 0.5], [0.0, 1.0]], "symmetric"),
            (np.ones((4, 2)), np.broadcast_to(np.eye(2), (3, 2, 2)), "do not broadcast"),
            ([np.nan, 0.0], np.eye(2), "errors must be finite"),
            (np.ones(2), [[np.inf, 0.0], [0.0, 1.0]], "covariances must be finite"),
        ],
    )
    def test_bad_inputs_are_rejected(self, errors, cov, match):
        with pytest.raises(ValueError, match=match):
            nees(errors, cov)


class TestChi2Band:
    def test_published_quantiles(self):
        # chi-square table (e.g. NIST/SEMATECH e-Handbook 1.3.6.7.4): dof 1 -> 0.000982, 5.024; dof 10 -> 3.247, 20.483.
        lo, hi = chi2_band(1, 1, 0.95)
        assert (lo, hi) == pytest.approx((0.000982, 5.024), rel=1e-3)
        lo, hi = chi2_band(10, 1, 0.95)
        assert (lo, hi) == pytest.approx((3.247, 20.483), rel=1e-3)
        # Averaging 2 runs of dof 5 is chi2(10) / 2.
        assert chi2_band(5, 2, 0.95) == pytest.approx((3.247 / 2, 20.483 / 2), rel=1e-3)

    def test_band_matches_a_monte_carlo_of_averaged_chi_square_draws(self):
        dof, n_runs, m = 3, 20, 200_000
        rng = np.random.default_rng(4)
        averages = rng.chisquare(dof, size=(m, n_runs)).mean(axis=1)
        lo, hi = chi2_band(dof, n_runs, 0.95)
        below, above = np.mean(averages < lo), np.mean(averages > hi)
        # Binomial proportions of 0.025 out of 2e5: std sqrt(0.025 * 0.975 / 2e5) = 3.5e-4; allow 5.
        tol = 5 * np.sqrt(0.025 * 0.975 / m)
        assert below == pytest.approx(0.025, abs=tol)
        assert above == pytest.approx(0.025, abs=tol)
        assert fraction_inside_band(averages, dof, n_runs, 0.95) == pytest.approx(0.95, abs=2 * tol)

    def test_band_narrows_around_the_dimension_as_runs_are_added(self):
        widths = [np.diff(chi2_band(6, n))[0] for n in (1, 10, 100, 1000)]
        assert widths == sorted(widths, reverse=True)
        lo, hi = chi2_band(6, 1000)
        assert lo < 6 < hi and hi - lo < 0.5  # ~ 2 * 1.96 * sqrt(12 / 1000) = 0.43

    @pytest.mark.parametrize(
        ("args", "match"),
        [
            ((0, 1, 0.95), "dof must be a positive integer"),
            ((3, 0, 0.95), "n_runs must be a positive integer"),
            ((3, 1, 1.0), r"confidence must be a scalar in \(0, 1\)"),
            ((3, 1, 0.0), r"confidence must be a scalar in \(0, 1\)"),
            ((2.5, 1, 0.95), "dof must be a positive integer"),
        ],
    )
    def test_bad_arguments(self, args, match):
        with pytest.raises(ValueError, match=match):
            chi2_band(*args)


class TestNisHealth:
    DOF, N, WINDOW, CONF = 3, 2000, 50, 0.9999

    def clean_nis(self, seed):
        rng = np.random.default_rng(seed)
        cov = random_spd(rng, (self.N,), self.DOF)
        return rng, cov, draws(rng, cov)

    def test_clean_run_is_healthy(self):
        for seed in (10, 11, 12):
            _, cov, nu = self.clean_nis(seed)
            health = nis_health(nis(nu, cov), self.DOF, self.WINDOW, self.CONF)
            # ~N / window = 40 independent windows at 1e-4 each: a false alarm in 0.4 % of clean runs.
            assert isinstance(health, NisHealth) and health.healthy, health.intervals
            assert not health.flagged.any()
            assert health.window_mean.shape == (self.N - self.WINDOW + 1,)

    def test_biased_stretch_is_flagged_and_located(self):
        _, cov, nu = self.clean_nis(20)
        chol = np.linalg.cholesky(cov)
        # Samples 800..999: a bias of 1.5 sigma on every whitened component: mean NIS 3 + 3 * 2.25 = 9.75,
        # far above the window band's upper end (4.54 for 50 samples at 0.9999).
        nu[800:1000] += 1.5 * (chol[800:1000] @ np.ones(self.DOF))
        t = 0.5 * np.arange(self.N)
        health = nis_health(nis(nu, cov), self.DOF, self.WINDOW, self.CONF, t=t)
        assert not health.healthy
        assert len(health.intervals) == 1
        start, stop = health.intervals[0]
        # The flagged stretch covers the biased one and extends at most window - 1 samples either side.
        assert 800 - (self.WINDOW - 1) <= start <= 800 and 1000 <= stop <= 1000 + self.WINDOW - 1
        assert health.interval_times == [(t[start], t[stop - 1])]
        assert health.flagged[800:1000].all() and health.flagged.sum() == stop - start

    def test_over_pessimistic_stretch_is_flagged_below_the_band(self):
        _, cov, nu = self.clean_nis(30)
        nu[300:500] *= 0.4  # the filter's S is 6x too large there: mean NIS 0.48, below the lower end 1.84
        health = nis_health(nis(nu, cov), self.DOF, self.WINDOW, self.CONF)
        assert len(health.intervals) == 1
        assert np.min(health.window_mean) < health.band[0]

    def test_missing_samples_are_skipped_and_indices_refer_to_the_input(self):
        _, cov, nu = self.clean_nis(40)
        values = nis(nu, cov)
        values[1000:1200] += 20.0
        with_gaps = np.full(2 * self.N, np.nan)
        with_gaps[::2] = values  # a measurement every other sample
        a = nis_health(values, self.DOF, self.WINDOW, self.CONF)
        b = nis_health(with_gaps, self.DOF, self.WINDOW, self.CONF)
        np.testing.assert_array_equal(b.window_mean, a.window_mean)
        assert [(2 * s, 2 * (e - 1) + 1) for s, e in a.intervals] == b.intervals
        np.testing.assert_array_equal(b.window_start, 2 * a.window_start)

    def test_bad_inputs(self):
        with pytest.raises(ValueError, match="fewer than window"):
            nis_health(np.ones(10), 3, 20)
        with pytest.raises(ValueError, match="non-negative"):
            nis_health(-np.ones(100), 3, 20)
        with pytest.raises(ValueError, match="found inf"):
            nis_health(np.full(100, np.inf), 3, 20)
        with pytest.raises(ValueError, match="window must be a positive integer"):
            nis_health(np.ones(100), 3, 0)
        with pytest.raises(ValueError, match="t must have the shape"):
            nis_health(np.ones(100), 3, 20, t=np.arange(99.0))


class TestMonteCarloFilter:
    """A bias filter fed by the exact gyro model is consistent over independent runs; a naive one is not.

    One gyro axis at zero true rate measures ``z_{k+1} = (b_k + b_{k+1})/2 + w``. With the state
    ``b_{k+1}`` the measurement error is ``-(b_{k+1} - b_k)/2 + w``: variance
    ``sigma_v^2/dt + sigma_u^2 dt/3`` and covariance ``-Q/2`` with the process noise, as
    ``Gyro.rate_noise_variance`` documents. The exact filter uses both (S = P + Q + R - Q,
    K = (P + Q - Q/2) / S); the naive one takes ``R = rate_noise_variance`` and no correlation.
    ARW and RRW are of equal size here so the difference matters.
    """

    N_RUNS, N_STEPS = 50, 1000
    GYRO = Gyro(1e-4, 1e-4, period=1.0)
    P0 = 1e-6  # initial bias variance [rad^2/s^2]

    def run(self, exact):
        g = self.GYRO
        q = g.bias_step_variance()
        r = g.sigma_v**2 / g.period + g.sigma_u**2 * g.period / 3.0
        err = np.empty((self.N_RUNS, self.N_STEPS, 3))
        innov = np.empty_like(err)
        p_hist = np.empty(self.N_STEPS)
        s_hist = np.empty(self.N_STEPS)
        for i, seed in enumerate(np.random.SeedSequence(2024).spawn(self.N_RUNS)):  # independent seeds
            rng = np.random.default_rng(seed)
            errors, biases = g.sample_errors(self.N_STEPS, rng, bias0=rng.normal(0.0, np.sqrt(self.P0), 3))
            x, p = np.zeros(3), self.P0
            for k in range(self.N_STEPS):
                pm = p + q
                if exact:
                    s = pm + r - q
                    gain = (pm - q / 2) / s
                else:
                    s = pm + g.rate_noise_variance()
                    gain = pm / s
                innov[i, k] = errors[k] - x
                x = x + gain * innov[i, k]
                p = pm - gain**2 * s
                err[i, k], p_hist[k], s_hist[k] = biases[k + 1] - x, p, s
        cov_p = p_hist[:, None, None] * np.eye(3)
        cov_s = s_hist[:, None, None] * np.eye(3)
        return nees(err, cov_p), average_nees(err, cov_p), average_nis(innov, cov_s)

    def test_exact_filter_is_consistent_and_naive_filter_is_not(self):
        per_run, avg_nees, avg_nis = self.run(exact=True)
        # Runs are independent, so the standard error of the grand mean comes from the spread of the
        # per-run time averages; allow 5 standard errors.
        run_means = per_run.mean(axis=1)
        se = run_means.std(ddof=1) / np.sqrt(self.N_RUNS)
        assert abs(run_means.mean() - 3.0) < 5 * se
        # Innovations are white: the grand mean of 50000 chi2(3) values has std sqrt(6 / 50000) = 0.011.
        assert abs(avg_nis.mean() - 3.0) < 5 * np.sqrt(6 / (self.N_RUNS * self.N_STEPS))
        # Fraction of times inside the 95 % band: expected 0.95; the filter's error decorrelates in ~2 steps
        # (gain ~0.6), so ~300 effective samples and a std of ~0.013; 0.89 is ~5 of those below.
        assert fraction_inside_band(avg_nees, 3, self.N_RUNS) > 0.89
        assert fraction_inside_band(avg_nis, 3, self.N_RUNS) > 0.89

        naive_per_run, naive_avg, _ = self.run(exact=False)
        assert abs(naive_per_run.mean() - 3.0) > 20 * se  # about 4.8: over-confident
        assert fraction_inside_band(naive_avg, 3, self.N_RUNS) < 0.5


class TestPlots:
    def test_plot_nees_draws_the_band(self):
        t = np.arange(100.0)
        avg = np.random.default_rng(5).chisquare(60, 100) / 20
        fig = plot_nees(t, avg, 3, 20)
        assert isinstance(fig, Figure)
        ax = fig.axes[0]
        lo, hi = chi2_band(3, 20)
        assert len(ax.patches) == 1
        band = ax.patches[0]  # axhspan: a rectangle from y = lo of height hi - lo
        assert (band.get_y(), band.get_y() + band.get_height()) == pytest.approx((lo, hi), rel=1e-12)
        assert "inside the band" in ax.get_title()
        nis_fig = plot_nees(t, avg, 3, 20, quantity="NIS")
        assert nis_fig.axes[0].get_ylabel() == "average NIS"

    def test_plot_errors_with_bounds_one_panel_per_component(self):
        t = np.arange(50.0)
        rng = np.random.default_rng(6)
        sig = np.full((50, 3), 2.0)
        fig = plot_errors_with_bounds(t, rng.normal(0, 2, (50, 3)), sig, ["x", "y", "z"], "arcsec")
        assert len(fig.axes) == 3
        # Error, +3 sigma, -3 sigma per panel (the first panel also holds two legend proxies).
        lines = fig.axes[1].get_lines()
        assert len(lines) == 3
        np.testing.assert_allclose(lines[1].get_ydata(), 6.0)
        np.testing.assert_allclose(lines[2].get_ydata(), -6.0)
        assert fig.axes[2].get_ylabel() == "z [arcsec]"
        runs = plot_errors_with_bounds(t, rng.normal(0, 2, (4, 50, 2)), sig[:, :2], scale=[1.0, 10.0])
        assert len(runs.axes) == 2
        # Several runs: run 1's error, then +3 sigma * 10 (the others are in the spread band, not drawn as lines).
        assert len(runs.axes[1].get_lines()) == 3
        np.testing.assert_allclose(runs.axes[1].get_lines()[1].get_ydata(), 60.0)
        with pytest.raises(ValueError, match="sigmas must have shape"):
            plot_errors_with_bounds(t, np.zeros((50, 3)), np.zeros((50, 2)))
        with pytest.raises(ValueError, match="labels must name the 3 components"):
            plot_errors_with_bounds(t, np.zeros((50, 3)), sig, ["a"])

    def test_plot_errors_with_bounds_shows_one_run_and_the_spread_of_all(self):
        """Several runs: one line (run 1) and a band of +-3 RMS over the runs, not a cloud of lines.

        The band's upper edge is checked against the RMS over the runs
        computed here with numpy (50 steps: the pooling window is one step).
        """
        t = np.arange(50.0)
        rng = np.random.default_rng(7)
        e = rng.normal(0.0, 2.0, (6, 50, 1))
        fig = plot_errors_with_bounds(t, e, np.full((50, 1), 2.0), scale=10.0)
        ax = fig.axes[0]
        np.testing.assert_array_equal(ax.get_lines()[0].get_ydata(), 10.0 * e[0, :, 0])
        (band,) = [c for c in ax.collections if len(c.get_paths())]
        vertices = band.get_paths()[0].vertices
        upper = np.array([vertices[vertices[:, 0] == tj, 1].max() for tj in t])
        np.testing.assert_allclose(upper, 3.0 * 10.0 * np.sqrt(np.mean(e[:, :, 0] ** 2, axis=0)), rtol=1e-12)
        assert "RMS error of 6 runs" in ax.get_legend_handles_labels()[1][1]

    def test_plot_errors_with_bounds_limits_show_the_steady_state(self):
        """A bound that starts 100 times above its steady level does not set the axis; the clip is noted.

        sigma = 1 + 99 exp(-t / 2 s) over 100 s; the error stays within it.
        The transient ends where the bound falls to 1.5 times its final
        level, 3 (1 + 99 exp(-t / 2)) <= 4.5, i.e. t >= 2 ln 198 s (closed
        form); the limits are 1.15 times the bound at the first step from
        there (the errors stay below it). A bound that never leaves its level
        (the second component), and one that settles only at 8 ln 198 = 42 s,
        past a quarter of the run (the third), leave the limits to matplotlib.
        """
        t = np.linspace(0.0, 100.0, 501)
        decay = 1.0 + 99.0 * np.exp(-t / 2.0)
        sig = np.stack([decay, np.ones_like(t), 1.0 + 99.0 * np.exp(-t / 8.0)], axis=-1)
        err = 0.5 * sig * np.sin(t)[:, None]
        fig = plot_errors_with_bounds(t, err, sig, units="deg/h")
        low, high = fig.axes[0].get_ylim()
        start = t[t >= 2.0 * np.log(198.0)][0]
        steady = 3.0 * (1.0 + 99.0 * np.exp(-start / 2.0))
        assert (low, high) == pytest.approx((-1.15 * steady, 1.15 * steady), rel=1e-9)
        assert high < 0.02 * 300.0  # the transient's 3 sigma = 300 no longer sets the axis
        notes = [x.get_text() for x in fig.axes[0].texts]
        assert len(notes) == 1 and "initial transient (to ±300 deg/h" in notes[0] and "clipped" in notes[0]
        assert fig.axes[1].get_ylim()[1] >= 3.0 and not fig.axes[1].texts
        assert fig.axes[2].get_ylim()[1] >= 300.0 and not fig.axes[2].texts

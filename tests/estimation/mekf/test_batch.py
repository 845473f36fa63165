"""MEKFBatch (estimation.mekf.filter): N filters stepped together from outside, as a vectorised closed loop does.

References: :func:`run_mekf` with ``vectorized=True`` (bit for bit: it runs
the same :meth:`MEKFBatch._step`, and its results were checked bit-identical
to the code before MEKFBatch existed when the batch equations moved there),
and the filterpy-based :meth:`MEKF.step` run by run (the same equations
evaluated in another order: rounding-level agreement, tolerances below).

Run ``python tests/estimation/mekf/test_batch.py`` for the cost of one batch step at
N = 1000 (a print, not a test).
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from attitude import quaternion as quat
from attitude.sensors import Gyro, StarTracker
from estimation.mekf.batch import MEKFBatch
from estimation.mekf.filter import MEKF, initial_covariance
from estimation.mekf.runner import run_mekf

DT = 0.1  # gyro period [s]
N_RUNS = 4
N_STEPS = 400
TRACKER_EVERY = 5
SIG_A0 = np.radians(0.1)  # initial attitude error per axis [rad]
SIG_B0 = 1e-5  # initial bias error per axis [rad/s]


def make_filter(reset="first_order", q0=(1.0, 0.0, 0.0, 0.0), **kwargs):
    gyro = Gyro.preset("tactical", period=DT, sampling="mean")
    tracker = StarTracker.preset("typical", period=DT * TRACKER_EVERY)
    return MEKF.from_sensors(
        gyro,
        tracker,
        q0=q0,
        P0=initial_covariance(attitude_sigma=SIG_A0, bias_sigma=SIG_B0),
        covariance_reset=reset,
        sampling_check="raise",
        **kwargs,
    )


def campaign(seed=4, same_start=False):
    """Samples of N_RUNS spinning spacecraft, with every kind of bad sample the filter handles.

    Truth: a constant rate per run, so the interval-mean rate is that rate exactly; gyro samples add the
    Farrenkopf errors of :meth:`Gyro.sample_errors`, tracker samples (every TRACKER_EVERY steps) the noise
    of :meth:`StarTracker.add_noise`. Returns t, gyro (N, n, 3), tracker (N, n, 4) (NaN: no sample),
    the initial estimates q0 (N, 4) (the truth off by about SIG_A0). ``same_start``: every run starts
    from the same true attitude (so one filter's initial estimate suits all).
    """
    rng = np.random.default_rng(seed)
    gyro = Gyro.preset("tactical", period=DT, sampling="mean")
    tracker = StarTracker.preset("typical", period=DT * TRACKER_EVERY)
    t = DT * np.arange(N_STEPS)
    t[41] = t[40]  # a repeated time: no propagation, the sample still counts
    w = 0.02 * rng.standard_normal((N_RUNS, 3))
    q_start = quat.random(1 if same_start else N_RUNS, rng) * np.ones((N_RUNS, 1))
    q_true = quat.multiply(q_start[:, None], quat.from_rotation_vector(w[:, None] * t[:, None]))
    errors, _ = gyro.sample_errors(N_STEPS, rng, bias0=SIG_B0 * rng.standard_normal((N_RUNS, 3)), n_runs=N_RUNS)
    g = w[:, None] + errors
    y = np.full((N_RUNS, N_STEPS, 4), np.nan)
    y[:, ::TRACKER_EVERY] = tracker.add_noise(q_true[:, ::TRACKER_EVERY], rng)
    g[0, 100] = np.nan  # a NaN gyro sample: the last rate is held
    g[1, 200:204] = np.nan  # a short outage
    g[2, 150, 1] = 1e3  # implausible (above pi / DT): rejected like a NaN
    g[3, 0] = np.nan  # no first rate: zero held until one comes
    y[2, 50, 1] = np.nan  # a NaN tracker sample: skipped and counted
    y[3, 300] = quat.multiply(y[3, 300], [0.0, 1.0, 0.0, 0.0])  # 180 deg off: gated
    y[1, 35] = -y[1, 35]  # -q is the same measurement
    q0 = quat.multiply(q_start, quat.from_rotation_vector(SIG_A0 * rng.standard_normal((N_RUNS, 3))))
    return t, g, y, q0


def step_by_hand(f, t, g, y, mask=None, **kw):
    """MEKFBatch stepped one time at a time; histories stacked like MEKFResult's fields."""
    batch = MEKFBatch(f, g.shape[0], **kw)
    names = ("innovation", "innovation_covariance", "nis", "updated", "gated", "tracker_nan", "gyro_nan")
    out = {k: [] for k in ("q", "omega", "bias", "P", *names, "gyro_rejected")}
    for k in range(t.size):
        q, omega = batch.step(t[k], g[:, k], y[:, k], None if mask is None else mask[:, k])
        out["q"].append(q)
        out["omega"].append(omega)
        out["bias"].append(batch.bias)
        out["P"].append(batch.P)
        for name in (*names, "gyro_rejected"):
            out[name].append(getattr(batch, name))
    return batch, {k: np.stack(v, axis=1) for k, v in out.items()}


class TestAgainstRunMekf:
    @pytest.mark.parametrize("reset", ["first_order", "second_order"])
    def test_hand_stepped_batch_is_run_mekf_bit_for_bit(self, reset):
        f = make_filter(reset)
        t, g, y, q0 = campaign()
        mask = ~np.all(np.isnan(y), axis=-1)
        mask[0, 61] = True  # an all-NaN row flagged as a sample: a NaN measurement
        ref = run_mekf(f, t, g, y, tracker_mask=mask, q0=q0, bias0=1e-6, vectorized=True)
        batch, got = step_by_hand(f, t, g, y, mask, q0=q0, bias0=1e-6)
        for name in ("q", "omega", "bias", "P", "innovation", "innovation_covariance", "nis"):
            np.testing.assert_array_equal(got[name], getattr(ref, name), err_msg=name)
        for name in ("updated", "gated", "tracker_nan", "gyro_nan"):
            np.testing.assert_array_equal(got[name], getattr(ref, name), err_msg=name)
        counts = batch.counts
        assert counts["steps"].tolist() == [N_STEPS] * N_RUNS
        assert counts["updates"].tolist() == ref.info["updates"]
        assert counts["tracker_gated"].tolist() == ref.info["gated"] == [0, 0, 0, 1]
        assert counts["tracker_nan"].tolist() == ref.info["tracker_nan"] == [1, 0, 1, 0]
        assert counts["gyro_nan"].tolist() == ref.info["gyro_nan"] == [1, 4, 0, 1]
        assert counts["gyro_rejected"].tolist() == ref.info["gyro_rejected"] == [0, 0, 1, 0]
        assert got["gyro_rejected"][2, 150] and got["gated"][3, 300] and got["tracker_nan"][0, 61]
        # Every run ends consistent with its truth: the bad samples did not throw any run off.
        assert np.all(counts["updates"] >= N_STEPS // TRACKER_EVERY - 2)
        np.testing.assert_array_equal(batch.q, ref.q[:, -1])
        assert batch.t == t[-1]

    def test_default_mask_and_a_filter_that_already_ran(self):
        # The batch starts from the filter's state: its time, covariance and held gyro rate.
        t, g, y, q0 = campaign(seed=5, same_start=True)
        f = make_filter(q0=q0[0], t0=-0.2)
        f.step(-0.1, [1e-3, -2e-3, 5e-4], None)
        before = (f.q, f.P, f.t, f.counts)
        ref = run_mekf(f, t, g, y, vectorized=True)
        _, got = step_by_hand(f, t, g, y)
        for name in ("q", "omega", "P", "nis"):
            np.testing.assert_array_equal(got[name], getattr(ref, name), err_msg=name)
        # Run 3 has no gyro sample at t[0]: the filter's held rate is used, not zero.
        np.testing.assert_array_equal(got["omega"][3, 0], np.array([1e-3, -2e-3, 5e-4]) - got["bias"][3, 0])
        assert min(ref.info["updates"]) >= N_STEPS // TRACKER_EVERY - 2  # every run is tracked
        # The filter is not modified.
        assert f.t == before[2] and f.counts == before[3]
        np.testing.assert_array_equal(f.q, before[0])
        np.testing.assert_array_equal(f.P, before[1])


class TestAgainstFilterpySteps:
    @pytest.mark.parametrize("reset", ["first_order", "second_order"])
    def test_each_run_is_the_filterpy_mekf(self, reset):
        f = make_filter(reset)
        t, g, y, q0 = campaign(seed=6)
        _, got = step_by_hand(f, t, g, y, q0=q0)
        for r in range(N_RUNS):
            one = make_filter(reset, q0=q0[r])
            for k in range(N_STEPS):
                tracker = None if np.all(np.isnan(y[r, k])) else y[r, k]
                est = one.step(t[k], g[r, k], tracker)
                # Same equations, other evaluation order: filterpy forms F P F^T + Q, K = P H^T S^-1 and the
                # Joseph form with its own matrix products (BLAS on one 6x6 vs numpy's stacked matmul), and
                # MEKF composes quaternions in Python floats. Each step rounds at ~1e-16 relative and the filter
                # is stable (updates contract the differences), so they stay at a few ulps: measured over these
                # 400 steps, 3e-16 on q, 4e-17 rad/s on omega, 6e-16 on P_ij / sqrt(P_ii P_jj), 9e-16 rad on
                # the innovation. Bounds of 1e-12 (relative to each quantity's scale) leave 3 orders of margin.
                # The innovation is the rotation vector between two nearly equal unit quaternions (|z| ~ 4e-5
                # rad), so its ~1e-16 absolute rounding is ~1e-11 relative, and so is the NIS formed from it
                # (measured 3e-11): bounded at 1e-14 rad (1e-9 of the 6 arcsec tracker sigma) and 1e-9.
                np.testing.assert_allclose(got["q"][r, k], est.q, rtol=0, atol=1e-12)
                np.testing.assert_allclose(got["omega"][r, k], est.omega, rtol=0, atol=1e-12 * 0.1)
                P = est.covariance
                scale = np.sqrt(np.outer(np.diag(P), np.diag(P)))
                assert np.all(np.abs(got["P"][r, k] - P) <= 1e-12 * scale), (r, k)
                if not np.isnan(got["nis"][r, k]):
                    np.testing.assert_allclose(got["innovation"][r, k], one.last_innovation, rtol=0, atol=1e-14)
                    assert got["nis"][r, k] == pytest.approx(one.log()["nis"], rel=1e-9, abs=1e-9)
            counts = one.counts
            assert int(got["updated"][r].sum()) == counts["updates"]
            assert int(got["gated"][r].sum()) == counts["tracker_gated"]
            assert int(got["tracker_nan"][r].sum()) == counts["tracker_nan"]
            assert int(got["gyro_nan"][r].sum()) == counts["gyro_nan"]
            assert int(got["gyro_rejected"][r].sum()) == counts["gyro_rejected"]


class TestStepInput:
    def setup_method(self):
        self.f = make_filter()
        self.batch = MEKFBatch(self.f, 3)
        self.g = np.zeros((3, 3))
        self.y = np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))
        self.batch.step(1.0, self.g, self.y)

    def test_bad_construction_names_the_argument(self):
        with pytest.raises(ValueError, match="mekf must be an MEKF"):
            MEKFBatch("filter", 3)
        for bad in (0, -1, 2.5, True, None):
            with pytest.raises(ValueError, match="n_runs must be a positive integer"):
                MEKFBatch(self.f, bad)
        with pytest.raises(ValueError, match=r"q0 must have shape \(4,\) or \(3, 4\)"):
            MEKFBatch(self.f, 3, q0=np.tile([1.0, 0.0, 0.0, 0.0], (2, 1)))
        with pytest.raises(ValueError, match="q0 must be a unit quaternion"):
            MEKFBatch(self.f, 3, q0=[2.0, 0.0, 0.0, 0.0])
        with pytest.raises(ValueError, match=r"bias0 must be a scalar or have shape \(3,\) or \(3, 3\)"):
            MEKFBatch(self.f, 3, bias0=np.zeros((2, 3)))
        with pytest.raises(ValueError, match="bias0 must be finite"):
            MEKFBatch(self.f, 3, bias0=[0.0, np.nan, 0.0])

    def test_bad_steps_name_the_argument_and_change_nothing(self):
        b = self.batch
        state = (b.q, b.P, b.bias, b.t, b.counts["steps"])
        y_bad = self.y.copy()
        y_bad[1] = [0.5, 0.0, 0.0, 0.0]
        cases = [
            ((0.5, self.g, self.y), "t must not go backwards"),
            ((np.nan, self.g, self.y), "t must be finite"),
            (([1.0, 2.0], self.g, self.y), "t must be a scalar"),
            ((2.0, self.g[:2], self.y), r"gyro must have shape \(3, 3\)"),
            ((2.0, self.g, self.y[:, :3]), r"tracker must have shape \(3, 4\)"),
            ((2.0, self.g, y_bad), r"tracker must hold unit quaternions .* in row 1"),
            ((2.0, self.g, self.y, np.ones(3)), r"mask must be a boolean array of shape \(3,\)"),
            ((2.0, self.g, self.y, np.ones(2, dtype=bool)), r"mask must be a boolean array of shape \(3,\)"),
            ((2.0, self.g, None, np.ones(3, dtype=bool)), "mask was given without tracker"),
        ]
        for args, match in cases:
            with pytest.raises(ValueError, match=match):
                b.step(*args)
        assert b.t == state[3] and b.counts["steps"].tolist() == [state[4][0]] * 3
        np.testing.assert_array_equal(b.q, state[0])
        np.testing.assert_array_equal(b.P, state[1])
        np.testing.assert_array_equal(b.bias, state[2])
        # A non-unit row outside the mask is not a sample and is not checked.
        b.step(2.0, self.g, y_bad, np.array([True, False, True]))

    def test_missing_and_non_finite_samples_are_skipped_like_mekf_step(self):
        b = self.batch
        g = np.array([[1e-3, 0.0, 0.0], [np.inf, 0.0, 0.0], [np.nan, 0.0, 0.0]])
        y = self.y.copy()
        y[0] = np.inf
        b.step(1.1, g, y)
        assert b.gyro_nan.tolist() == [False, True, True] and b.tracker_nan.tolist() == [True, False, False]
        b.step(1.2, None)  # no samples at all: held rates, propagation only
        assert not b.updated.any() and np.isnan(b.nis).all()
        one = self.f.copy()
        one.step(1.0, self.g[0], self.y[0])
        one.step(1.1, g[0], y[0])
        one.step(1.2, None, None)
        np.testing.assert_allclose(b.q[0], one.q, atol=1e-15)
        np.testing.assert_allclose(b.omega[0], one.omega, atol=1e-18)
        assert one.counts["tracker_nan"] == b.counts["tracker_nan"][0] == 1


def _timing(n_runs: int = 1000, n_steps: int = 300) -> None:
    """Print the cost of MEKFBatch.step for n_runs runs (gyro only, and with a tracker sample in every run)."""
    rng = np.random.default_rng(0)
    f = make_filter()
    q = quat.random(n_runs, rng)
    g = 1e-3 * rng.standard_normal((n_runs, 3))
    y = quat.multiply(q, quat.from_rotation_vector(1e-5 * rng.standard_normal((n_runs, 3))))
    for label, tracker in (("gyro only", None), ("gyro + tracker in every run", y)):
        batch = MEKFBatch(f, n_runs, q0=q)
        batch.step(0.0, g, tracker)
        start = time.perf_counter()
        for k in range(1, n_steps + 1):
            batch.step(k * DT, g, tracker)
        wall = time.perf_counter() - start
        print(
            f"MEKFBatch.step, N = {n_runs}, {label}: {n_steps / wall:.0f} steps/s "
            f"({1e3 * wall / n_steps:.2f} ms per step, {n_runs * n_steps / wall:.3g} filter steps/s)"
        )


if __name__ == "__main__":
    _timing()

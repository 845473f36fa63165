"""Batched sensor sampling for vectorised Monte Carlo loops: each run is, bit for bit, the single-run sensor.

The reference nobody tuned is the single-run code itself: :meth:`Gyro.measure`
and :meth:`StarTracker.measure` called in sequence with one Generator per
run, as the closed-loop engine calls them. :class:`attitude.rng.NormalStreams`
is checked against plain sequential ``Generator.standard_normal`` calls. Every
comparison is exact (``assert_array_equal``): the batch paths run the same
elementwise code with a leading runs axis, so there is no rounding to allow for.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from attitude import quaternion as quat
from attitude.rng import NormalStreams
from attitude.sensors import Gyro, GyroBatch, StarTracker
from attitude.simulation.protocols import Truth

DEG = np.pi / 180.0
SEEDS = [11, 12, 13, 14, 15]


def generators(seeds=SEEDS):
    return [np.random.default_rng(s) for s in seeds]


def tumbling(n_runs, n_steps, dt, seed):
    """Per-run attitude and rate histories (n_runs, n_steps, 4) and (n_runs, n_steps, 3) with varying rates."""
    rng = np.random.default_rng(seed)
    q = np.empty((n_runs, n_steps, 4))
    w = np.empty((n_runs, n_steps, 3))
    q[:, 0] = quat.random(n_runs, rng)
    w[:, 0] = 0.05 * rng.standard_normal((n_runs, 3))
    for k in range(1, n_steps):
        w[:, k] = w[:, k - 1] + 0.01 * rng.standard_normal((n_runs, 3))
        q[:, k] = quat.normalize(
            quat.multiply(q[:, k - 1], quat.from_rotation_vector(0.5 * (w[:, k - 1] + w[:, k]) * dt))
        )
    return q, w


def truth(t, q, w):
    return Truth(t, q, w, np.zeros(0))


# ---------------------------------------------------------------------------
# NormalStreams


class TestNormalStreams:
    def test_standard_normal_consumes_the_stream_sequentially(self):
        # The premise of the buffering, checked rather than assumed: a + b numbers in two calls are the
        # a + b numbers of one call, for sizes that straddle the ziggurat's rejection paths (many draws).
        for split in ([1, 1], [3, 5], [6, 3, 6, 3], [4096, 7], [0, 5, 0, 9], [1000, 1, 2000]):
            one = np.random.default_rng(5).standard_normal(sum(split))
            gen = np.random.default_rng(5)
            parts = np.concatenate([gen.standard_normal(s) for s in split])
            np.testing.assert_array_equal(parts, one)
        # The gyro's (1, 2, 3) draws are six numbers in C order.
        np.testing.assert_array_equal(
            np.random.default_rng(2).standard_normal((1, 2, 3)).ravel(), np.random.default_rng(2).standard_normal(6)
        )

    @given(
        block=st.sampled_from([1, 2, 5, 8, 64, 4096]),
        calls=st.lists(
            st.tuples(st.integers(0, 12), st.lists(st.booleans(), min_size=5, max_size=5)), min_size=1, max_size=40
        ),
    )
    def test_draws_equal_sequential_generator_calls(self, block, calls):
        streams = NormalStreams(generators(), block=block)
        reference = generators()
        for size, active in calls:
            act = np.array(active)
            got = streams.draw(act, size)
            assert got.shape == (5, size)
            for r in range(5):
                if act[r]:
                    np.testing.assert_array_equal(got[r], reference[r].standard_normal(size))
                else:
                    assert np.all(np.isnan(got[r]))

    def test_long_interleaved_campaign_across_many_refills(self):
        # Gyro-like (6) and tracker-like (3) requests, the tracker blinded at random: ~3000 refills at block 7.
        rng = np.random.default_rng(0)
        streams = NormalStreams(generators(), block=7)
        reference = generators()
        for _ in range(2000):
            got = streams.draw(None, 6)
            for r in range(5):
                np.testing.assert_array_equal(got[r], reference[r].standard_normal(6))
            active = rng.random(5) < 0.6
            got = streams.draw(active, 3)
            for r in np.nonzero(active)[0]:
                np.testing.assert_array_equal(got[r], reference[r].standard_normal(3))

    def test_bad_input_names_the_argument(self):
        with pytest.raises(ValueError, match="generators must hold at least one"):
            NormalStreams([])
        with pytest.raises(ValueError, match=r"generators\[1\] is int"):
            NormalStreams([np.random.default_rng(0), 3])
        for bad in (0, -2, 2.5, True):
            with pytest.raises(ValueError, match="block must be a positive integer"):
                NormalStreams(generators(), block=bad)
        streams = NormalStreams(generators())
        with pytest.raises(ValueError, match=r"active must be a boolean array of shape \(5,\)"):
            streams.draw(np.ones(5), 3)
        with pytest.raises(ValueError, match=r"active must be a boolean array of shape \(5,\)"):
            streams.draw(np.ones(4, dtype=bool), 3)
        for bad in (-1, 2.0, None):
            with pytest.raises(ValueError, match="size must be a non-negative integer"):
                streams.draw(None, bad)


# ---------------------------------------------------------------------------
# GyroBatch


def dispersed_gyros(sampling, n_runs=5, seed=3, **kwargs):
    """Tactical gyros with per-run misalignment, scale factor and turn-on bias, quantised, with a saturation."""
    rng = np.random.default_rng(seed)
    kwargs.setdefault("quantization_deg_per_s", 1e-4)
    kwargs.setdefault("saturation_deg_per_s", 8.0)
    return [
        Gyro.preset(
            "tactical",
            period=0.1,
            sampling=sampling,
            misalignment_rad=1e-3 * rng.standard_normal(3),
            scale_factor_ppm=300.0 * rng.standard_normal(3),
            bias_deg_per_h=rng.standard_normal(3),
            **kwargs,
        )
        for _ in range(n_runs)
    ]


def normal_rows(gyro):
    """Standard normals per axis and sample: [N_u, N_v], plus the Gauss-Markov pair with a bias instability."""
    return 4 if gyro.sigma_b > 0 else 2


class TestGyroBatch:
    # The Gauss-Markov bias (the default for a bias instability) and the Farrenkopf random walk alone.
    @pytest.mark.parametrize("model", ["gauss_markov", "random_walk"])
    @pytest.mark.parametrize("sampling", ["mean", "instantaneous"])
    @pytest.mark.parametrize("source", ["streams", "array"])
    def test_every_run_is_its_gyro_bit_for_bit(self, sampling, source, model):
        gyros = dispersed_gyros(sampling, bias_instability_model=model)
        assert (gyros[0].sigma_b > 0) == (model == "gauss_markov")
        batch = GyroBatch(gyros)
        n_steps = 300
        # Irregular sample times: the bias propagates over each actual interval.
        t = np.cumsum(np.concatenate([[0.3], 0.1 + 0.02 * np.random.default_rng(1).random(n_steps - 1)]))
        q, w = tumbling(5, n_steps, 0.1, seed=2)
        w[:, 150:160] *= 40.0  # fast enough that some components saturate at 8 deg/s
        gens = generators()
        streams = NormalStreams(generators(), block=50)
        samples = np.empty((5, n_steps, 3))
        expected = np.empty_like(samples)
        for k in range(n_steps):
            if source == "streams":
                normals = streams
            else:
                normals = np.stack([g.standard_normal((1, normal_rows(gyros[0]), 3))[0] for g in gens])
            samples[:, k] = batch.measure(t[k], q[:, k], w[:, k], normals)
        ref_gens = generators()
        for r in range(5):
            for k in range(n_steps):
                expected[r, k] = gyros[r].measure(t[k], truth(t[k], q[r, k], w[r, k]), ref_gens[r])
            np.testing.assert_array_equal(batch.bias[r], gyros[r].bias)
        np.testing.assert_array_equal(samples, expected)
        sat = gyros[0].saturation
        assert np.any(np.abs(samples) == sat), "the test should reach saturation"
        lsb = gyros[0].quantization
        np.testing.assert_allclose(samples / lsb, np.round(samples / lsb), atol=1e-6)  # on the LSB grid
        # The runs really differ in their transfer matrices (else the test proves little).
        assert not np.array_equal(batch.transfer_matrix[0], batch.transfer_matrix[1])

    def test_interleaved_with_the_tracker_on_one_stream_per_run_as_the_engine_draws(self):
        # The engine calls the gyro, then the tracker (every other tick), with one Generator per run.
        gyros = dispersed_gyros("mean")
        tracker = StarTracker.preset(period=0.2, sun_direction_N=[1.0, 0.0, 0.0], sun_exclusion_deg=60.0)
        batch = GyroBatch(gyros)
        q, w = tumbling(5, 200, 0.1, seed=7)
        t = 0.1 * np.arange(200)
        streams = NormalStreams(generators(), block=64)
        got_g = np.empty((5, 200, 3))
        got_s = np.full((5, 200, 4), np.nan)
        for k in range(200):
            got_g[:, k] = batch.measure(t[k], q[:, k], w[:, k], streams)
            if k % 2 == 0:
                got_s[:, k], _ = tracker.measure_batch(t[k], q[:, k], streams)
        ref_gens = generators()
        for r in range(5):
            for k in range(200):
                tr = truth(t[k], q[r, k], w[r, k])
                np.testing.assert_array_equal(got_g[r, k], gyros[r].measure(t[k], tr, ref_gens[r]))
                if k % 2 == 0:
                    sample = tracker.measure(t[k], tr, ref_gens[r])
                    np.testing.assert_array_equal(got_s[r, k], np.full(4, np.nan) if sample is None else sample)
        blinded = np.isnan(got_s[:, ::2, 0])
        assert 0 < blinded.sum() < blinded.size, "some, not all, samples should be blinded"

    def test_reset_restarts_and_the_gyros_are_untouched(self):
        gyros = dispersed_gyros("mean", n_runs=2)
        batch = GyroBatch(gyros)
        q, w = tumbling(2, 3, 0.1, seed=1)
        normals = np.random.default_rng(0).standard_normal((3, 2, normal_rows(gyros[0]), 3))
        first = [batch.measure(0.1 * k, q[:, k], w[:, k], normals[k]) for k in range(3)]
        assert gyros[0].bias.tolist() == gyros[0].initial_bias.tolist()
        assert batch.t_last == pytest.approx(0.2)
        batch.reset()
        assert batch.t_last is None
        np.testing.assert_array_equal(batch.bias, batch.initial_bias)
        again = [batch.measure(0.1 * k, q[:, k], w[:, k], normals[k]) for k in range(3)]
        np.testing.assert_array_equal(first, again)

    def test_shared_settings_are_enforced_by_name(self):
        base = {"period": 0.1, "sampling": "mean"}
        ok = [Gyro(1e-5, 1e-8, misalignment=[1e-3, 0.0, 0.0], bias=1e-5, **base), Gyro(1e-5, 1e-8, **base)]
        GyroBatch(ok)  # transfer matrix and initial bias may differ
        for name, kwargs in [
            ("sigma_v", {"sigma_v": 2e-5}),
            ("sigma_u", {"sigma_u": 2e-8}),
            ("period", {"period": 0.2}),
            ("sampling", {"sampling": "instantaneous"}),
            ("quantization", {"quantization": 1e-6}),
            ("saturation", {"saturation": 1.0}),
        ]:
            figures = {"sigma_v": 1e-5, "sigma_u": 1e-8, **base}
            figures.update(kwargs)
            with pytest.raises(ValueError, match=rf"gyros must share {name}.*gyros\[1\]\.{name}"):
                GyroBatch([ok[0], Gyro(**figures)])
        with pytest.raises(ValueError, match="gyros must hold at least one Gyro"):
            GyroBatch([])
        with pytest.raises(ValueError, match=r"gyros\[1\] is StarTracker"):
            GyroBatch([ok[0], StarTracker.preset()])

    def test_bad_samples_raise_naming_the_argument_and_change_nothing(self):
        batch = GyroBatch(dispersed_gyros("mean", n_runs=3))
        q, w = tumbling(3, 2, 0.1, seed=4)
        nrm = np.zeros((3, 4, 3))  # [N_u, N_v, N_b1, N_b2]: the tactical preset has a Gauss-Markov bias
        batch.measure(1.0, q[:, 0], w[:, 0], nrm)
        bias = batch.bias
        cases = [
            ((1.0, q[:, 1], w[:, 1], nrm), "t must come after the previous sample"),
            ((0.5, q[:, 1], w[:, 1], nrm), "t must come after the previous sample"),
            ((np.nan, q[:, 1], w[:, 1], nrm), "t must be finite"),
            (([1.1, 1.2], q[:, 1], w[:, 1], nrm), "t must be a scalar"),
            ((1.1, q[:, 1], w[:2, 1], nrm), r"omega must have shape \(3, 3\)"),
            ((1.1, q[:, 1], np.full((3, 3), np.nan), nrm), "omega must be finite"),
            ((1.1, None, w[:, 1], nrm), "q is required"),
            ((1.1, q[:2, 1], w[:, 1], nrm), r"q must have shape \(3, 4\)"),
            ((1.1, 2.0 * q[:, 1], w[:, 1], nrm), "q must be a unit quaternion"),
            ((1.1, q[:, 1], w[:, 1], np.zeros((3, 6))), r"normals must have shape \(3, 4, 3\)"),
            ((1.1, q[:, 1], w[:, 1], np.full((3, 4, 3), np.nan)), "normals must be finite"),
            ((1.1, q[:, 1], w[:, 1], NormalStreams(generators()[:2])), "normals must have 3 streams"),
        ]
        for args, match in cases:
            with pytest.raises(ValueError, match=match):
                batch.measure(*args)
        assert batch.t_last == 1.0
        np.testing.assert_array_equal(batch.bias, bias)
        # An instantaneous gyro needs no attitude.
        inst = GyroBatch(dispersed_gyros("instantaneous", n_runs=3))
        assert inst.measure(0.0, None, w[:, 0], nrm).shape == (3, 3)


# ---------------------------------------------------------------------------
# StarTracker.measure_batch


class TestStarTrackerBatch:
    @pytest.mark.parametrize("sun", ["fixed", "moving", "none"])
    @pytest.mark.parametrize("source", ["streams", "array"])
    def test_every_run_is_the_single_tracker_bit_for_bit(self, sun, source):
        kwargs = {
            "fixed": {"sun_direction_N": [0.3, -0.5, 0.8], "sun_exclusion_deg": 70.0},
            "moving": {
                "sun_direction_N": lambda t: [np.cos(0.05 * t), np.sin(0.05 * t), 0.2],
                "sun_exclusion_deg": 70.0,
            },
            "none": {},
        }[sun]
        tracker = StarTracker.from_datasheet(
            cross_boresight_arcsec=6.0, roll_arcsec=40.0, period=0.2, boresight_B=[0.2, -0.3, 1.0], **kwargs
        )
        q, _ = tumbling(5, 150, 0.2, seed=9)
        t = 0.2 * np.arange(150)
        streams = NormalStreams(generators(), block=10)
        gens = generators()
        got = np.empty((5, 150, 4))
        taken = np.empty((5, 150), dtype=bool)
        for k in range(150):
            if source == "streams":
                normals = streams
            else:
                # Draw for the runs that sample only (the tracker says which); blinded rows stay NaN.
                blind = tracker.sun_blinded(t[k], q[:, k])
                normals = np.full((5, 3), np.nan)
                for r in np.nonzero(~blind)[0]:
                    normals[r] = gens[r].standard_normal(3)
            got[:, k], taken[:, k] = tracker.measure_batch(t[k], q[:, k], normals)
        ref_gens = generators()
        for r in range(5):
            for k in range(150):
                sample = tracker.measure(t[k], truth(t[k], q[r, k], np.zeros(3)), ref_gens[r])
                assert taken[r, k] == (sample is not None)
                np.testing.assert_array_equal(got[r, k], np.full(4, np.nan) if sample is None else sample)
        if sun == "none":
            assert taken.all()
        else:
            assert 0.05 < taken.mean() < 0.95, taken.mean()  # a real mix of blinded and sampled runs
        # The streams are where the single runs' generators are: the next numbers agree.
        if source == "streams":
            nxt = streams.draw(None, 4)
            for r in range(5):
                np.testing.assert_array_equal(nxt[r], ref_gens[r].standard_normal(4))

    def test_sun_blinded_batch_decides_as_one_attitude_at_a_time(self):
        tracker = StarTracker.preset(sun_direction_N=[0.0, 0.6, 0.8])
        q = quat.random(2000, np.random.default_rng(3))
        batch = tracker.sun_blinded(0.0, q)
        assert batch.dtype == bool and batch.shape == (2000,)
        single = [tracker.sun_blinded(0.0, qk) for qk in q]
        assert all(type(s) is bool for s in single)
        np.testing.assert_array_equal(batch, single)
        assert 0 < batch.sum() < 2000

    def test_bad_input_names_the_argument(self):
        tracker = StarTracker.preset(sun_direction_N=[0.0, 0.0, 1.0])
        q = quat.random(3, np.random.default_rng(0))
        q[0] = [1.0, 0.0, 0.0, 0.0]  # boresight on the Sun: blinded
        with pytest.raises(ValueError, match=r"q_BN must have shape \(N, 4\)"):
            tracker.measure_batch(0.0, q[0], np.zeros((1, 3)))
        with pytest.raises(ValueError, match="q_BN must be a unit quaternion"):
            tracker.measure_batch(0.0, 2.0 * q, np.zeros((3, 3)))
        with pytest.raises(ValueError, match=r"normals must have shape \(3, 3\)"):
            tracker.measure_batch(0.0, q, np.zeros((3, 2)))
        with pytest.raises(ValueError, match="normals must have 3 streams"):
            tracker.measure_batch(0.0, q, NormalStreams(generators()))
        bad = np.zeros((3, 3))
        bad[1, 2] = np.nan
        with pytest.raises(ValueError, match="normals must be finite in the rows of runs that sample; row 1"):
            tracker.measure_batch(0.0, q, bad)
        bad[1, 2] = 0.0
        bad[0] = np.nan  # the blinded run's row is not used
        out, taken = tracker.measure_batch(0.0, q, bad)
        assert taken.tolist() == [False, True, True] and np.isnan(out[0]).all()


def _timing(n_runs: int = 1000, n_steps: int = 2000) -> None:
    """Print the cost per tick of the batch sensors and streams for n_runs runs (a print, not a test)."""
    import time

    gyros = dispersed_gyros("mean", n_runs=n_runs)
    tracker = StarTracker.preset(period=0.1, sun_direction_N=[1.0, 0.0, 0.0])
    q, w = tumbling(n_runs, 2, 0.1, seed=0)
    streams = NormalStreams([np.random.default_rng(s) for s in range(n_runs)])
    batch = GyroBatch(gyros)
    for label, call in (
        ("NormalStreams.draw(all, 6)", lambda k: streams.draw(None, 6)),
        ("GyroBatch.measure (mean, streams)", lambda k: batch.measure(0.1 * k, q[:, k % 2], w[:, k % 2], streams)),
        ("StarTracker.measure_batch (streams)", lambda k: tracker.measure_batch(0.1 * k, q[:, k % 2], streams)),
    ):
        call(0)
        start = time.perf_counter()
        for k in range(1, n_steps + 1):
            call(k)
        wall = time.perf_counter() - start
        print(f"{label}, N = {n_runs}: {1e3 * wall / n_steps:.3f} ms per tick (refills included)")


if __name__ == "__main__":
    _timing()

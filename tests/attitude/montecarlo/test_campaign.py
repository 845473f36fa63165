"""Monte Carlo campaigns: seeds, dispersions, executors, faults, checkpoints, statistics and an analytic check.

What each group checks against:

* Seeds: numpy's ``SeedSequence.spawn`` (run ``i`` draws from the ``i``-th spawned child), and each
  dispersion's draws independent of the others in the campaign.
* Dispersions: physical validity of dispersed inertias (triangle inequality, symmetry), eigenvalues
  unchanged by an axis rotation (``numpy.linalg.eigvalsh``); uniform attitudes against the Haar
  measure on SO(3) by Kolmogorov-Smirnov tests (``scipy.stats.kstest``): a rotated fixed vector is
  uniform on the sphere, so each component is uniform on [-1, 1] (Archimedes' hat-box theorem), and
  the rotation angle has the density ``(1 - cos t) / pi``; normal spreads within 4 standard errors
  of the sample standard deviation; file units converted to SI.
* Statistics: the one-sided Clopper-Pearson bound (Clopper and Pearson, *Biometrika* 26, 1934)
  against ``scipy.stats.beta.ppf`` and ``scipy.stats.binomtest(...).proportion_ci(method="exact")``
  as the independent library; the classical zero-failure run counts (59 runs for 95 % at 95 %,
  2,995 for 99.9 % at 95 %, from ``p^N = 1 - C``).
* Campaigns, executors, Dask, checkpoints: agreement between execution paths (one worker, a
  process pool, a Dask ``LocalCluster``, resumed and killed workers): the result tables are
  identical bit for bit; a raising run is recorded as a failure; files round trip bit for bit.
* Vectorised path: agreement between two independent implementations of the PD + wheels closed
  loop, :func:`attitude.simulation.batch.simulate_batch` (numpy per component) and the per-run
  engine (casadi per run), to rounding; chunked runs bit for bit.
* Analytic check: the fraction of torque-free spins near the middle axis (dispersed phase of the
  off-axis rate) that flip within a given time, against the exact flip period ``2 K(m) / lambda``
  of the Jacobi elliptic solution (:func:`attitude.analytic.flip_period`; Landau & Lifshitz,
  *Mechanics*, sec. 37), run by run and as a binomial proportion within 4 standard errors.
* The summary: review units (degrees on the page, SI inside; :mod:`attitude.montecarlo.units`).
"""

from __future__ import annotations

import math
import os
import re
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import stats
from scipy.optimize import brentq

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.analytic import flip_period
from attitude.app import assembly
from attitude.app.scenarios import (
    ClosedLoopScenario,
    PDWheelsScenario,
    requirements_from_config,
    run_campaign_from_config,
)
from attitude.config import default_config
from attitude.montecarlo.campaign import Campaign, run_campaign
from attitude.montecarlo.dispersions import (
    AttitudeDispersion,
    InertiaDispersion,
    Misalignment,
    Normal,
    RandomAttitude,
    Uniform,
    dispersions_from_config,
    draw_parameters,
    run_seed_sequence,
)
from attitude.montecarlo.executors import RunOutput
from attitude.montecarlo.plots import save_figures
from attitude.montecarlo.results import EXECUTION_COLUMNS, CampaignResult, Requirement
from attitude.montecarlo.statistics import (
    percentiles,
    runs_for_zero_failures,
    success_lower_bound,
    zero_failure_bound,
)
from attitude.propagate import propagate

CONFIG = default_config()


def _short_requirements(config):
    """``config`` judged over 20 s: an allowed slew of 10 s, 5 s of settling and a 5 s hold (fast runs)."""
    import dataclasses

    req = config.requirements
    short = dataclasses.replace(
        req, slew=dataclasses.replace(req.slew, time_max_s=10.0), settling_time_s=5.0, hold_time_s=5.0
    )
    return dataclasses.replace(config, requirements=short)


#: The default file with requirements a 20 s eigenaxis run can judge (it cannot meet them: a 60 deg slew).
SHORT = _short_requirements(CONFIG)
NOMINAL = assembly.rigid_body(CONFIG).inertia
DISPERSIONS = dispersions_from_config(CONFIG.montecarlo, NOMINAL, CONFIG.requirements.slew.q_start())


def reproducible(result: CampaignResult) -> dict[str, np.ndarray]:
    """The table without the execution columns (CPU time, attempts), which vary from run to run."""
    return {k: v for k, v in result.table().items() if k not in EXECUTION_COLUMNS}


def assert_tables_identical(a: CampaignResult, b: CampaignResult) -> None:
    ta, tb = reproducible(a), reproducible(b)
    assert list(ta) == list(tb)
    for k in ta:
        # Bit-identical (a failed run's NaN equals NaN).
        assert np.array_equal(ta[k], tb[k], equal_nan=ta[k].dtype.kind == "f"), k


def short_closed_loop() -> Campaign:
    """The default closed loop (MEKF, gyro and tracker noise from the run's generator), 20 s per run.

    The eigenaxis guidance (no planning) on :data:`SHORT`, whose requirements end their hold at 20 s.
    """
    return Campaign(
        ClosedLoopScenario(SHORT, duration=20.0, guidance="eigenaxis"),
        DISPERSIONS,
        runs=6,
        seed=2024,
        requirements=requirements_from_config(SHORT, keep_out=False),
    )


# ---------------------------------------------------------------------------
# Test scenarios (module level, so worker processes can unpickle them)


class Quadratic:
    """Cheap scenario: metrics from the parameters and the run's generator."""

    fingerprint = "Quadratic"

    def __call__(self, params, rng):
        return {"y": float(params["x"] ** 2 + rng.standard_normal()), "x_seen": float(params["x"])}


class Failing(Quadratic):
    fingerprint = "Failing"

    def __call__(self, params, rng):
        if params["x"] > 1.0:
            raise RuntimeError(f"bad run at x = {params['x']:.3f}")
        return super().__call__(params, rng)


class Dies(Quadratic):
    """Kills its worker process (``os._exit``) when it runs the run whose parameter is ``victim_x``.

    With a ``marker`` path it dies only the first time (the file remembers); without, every time.
    """

    fingerprint = "Dies"

    def __init__(self, victim_x: float, marker: Path | None = None) -> None:
        self.victim_x = victim_x
        self.marker = None if marker is None else str(marker)

    def __call__(self, params, rng):
        if params["x"] == self.victim_x:
            if self.marker is None:
                os._exit(3)
            if not os.path.exists(self.marker):
                Path(self.marker).write_text("died")
                os._exit(3)
        return super().__call__(params, rng)


class Slow(Quadratic):
    fingerprint = "Slow"

    def __call__(self, params, rng):
        time.sleep(0.1)
        return super().__call__(params, rng)


class Interrupted(Quadratic):
    """Raises KeyboardInterrupt (a Ctrl-C) at run ``stop``; counts the runs it executed."""

    fingerprint = "Interrupted"

    def __init__(self, stop: int | None) -> None:
        self.stop = stop
        self.calls: list[float] = []

    def __call__(self, params, rng):
        if self.stop is not None and len(self.calls) == self.stop:
            raise KeyboardInterrupt
        self.calls.append(params["x"])
        return super().__call__(params, rng)


X = {"x": Normal(0.0, 1.0)}


# ---------------------------------------------------------------------------
# Seeds and dispersions


class TestSeedsAndDispersions:
    def test_run_streams_are_the_spawned_children(self):
        spawned = np.random.SeedSequence(77).spawn(10)[7]
        assert np.random.default_rng(spawned).random() == np.random.default_rng(run_seed_sequence(77, 7)).random()

    def test_a_dispersion_draws_the_same_values_whatever_the_others(self):
        alone = draw_parameters({"x": Normal(1.0, 2.0)}, 5, 3)
        more = draw_parameters({"a": Uniform(0.0, 1.0), "x": Normal(1.0, 2.0), "z": RandomAttitude()}, 5, 3)
        assert alone["x"] == more["x"]
        assert draw_parameters(X, 5, 3) != draw_parameters(X, 5, 4)

    def test_inertia_dispersion_is_always_physically_valid(self):
        # A nearly flat plate (I3 = 0.98 (I1 + I2)): 10 % moment dispersions break the triangle
        # inequality in about a third of the raw draws, which are rejected and redrawn.
        d = InertiaDispersion([1.0, 1.0, 1.96], moment_sigma=0.1, axis_sigma=math.radians(5.0))
        rng = np.random.default_rng(1)
        tensors = np.array([d.sample(rng) for _ in range(500)])
        moments = RigidBody(tensors).principal_axes().moments  # raises if any were invalid
        assert np.all(moments[:, 2] <= moments[:, 0] + moments[:, 1] + 1e-12)
        assert np.max(np.abs(tensors - np.swapaxes(tensors, 1, 2))) == 0.0

    def test_inertia_axis_rotation_keeps_the_moments(self):
        d = InertiaDispersion(NOMINAL, moment_sigma=0.0, axis_sigma=0.1)
        tensor = d.sample(np.random.default_rng(3))
        np.testing.assert_allclose(np.linalg.eigvalsh(tensor), np.linalg.eigvalsh(NOMINAL), rtol=1e-13)
        assert np.max(np.abs(tensor - NOMINAL)) > 1e-3  # the axes did turn

    def test_inertia_dispersion_too_wide_for_the_body_raises(self):
        with pytest.raises(ValueError, match="too wide"):
            for seed in range(50):  # each draw is rejected with probability ~1/2
                InertiaDispersion([1.0, 1.0, 2.0], moment_half_width=0.5, max_tries=1).sample(
                    np.random.default_rng(seed)
                )

    def test_random_attitude_is_uniform_on_so3(self):
        # Haar measure: a rotated fixed vector is uniform on the sphere, so each of its
        # components is uniform on [-1, 1] (Archimedes): mean 0, variance 1/3.
        rng = np.random.default_rng(11)
        q = np.array([RandomAttitude().sample(rng) for _ in range(4000)])
        z = quat.rotate(q, np.array([0.0, 0.0, 1.0]))
        for k in range(3):
            assert stats.kstest(z[:, k], stats.uniform(-1, 2).cdf).pvalue > 1e-3
        # ... and the rotation angle has the Haar density (1 - cos t) / pi on [0, pi], CDF (t - sin t) / pi,
        # which a distribution right about one axis but wrong in roll would not have.
        angle = np.asarray(quat.error_angle(quat.identity(), q))
        assert stats.kstest(angle, lambda t: (t - np.sin(t)) / np.pi).pvalue > 1e-3

    def test_attitude_and_misalignment_dispersions_have_the_asked_spread(self):
        rng = np.random.default_rng(4)
        d = AttitudeDispersion(quat.from_axis_angle([0, 0, 1], 0.5), sigma=0.01)
        theta = np.array(
            [quat.to_rotation_vector(quat.multiply(quat.conjugate(d.nominal), d.sample(rng))) for _ in range(2000)]
        )
        # Standard deviation of 2000 normal samples: relative standard error 1/sqrt(2 * 2000) = 1.6 %; 4 sigma.
        np.testing.assert_allclose(np.std(theta, axis=0), 0.01, rtol=0.064)
        m = np.array([Misalignment(half_width=1e-4).sample(rng) for _ in range(2000)])
        assert np.max(np.abs(m)) <= 1e-4

    def test_config_dispersions_are_converted_to_si(self):
        assert set(DISPERSIONS) == {
            "inertia",
            "initial_rate",
            "initial_attitude",
            "gyro_misalignment",
            "star_tracker_misalignment",
        }
        assert DISPERSIONS["inertia"].scale == pytest.approx(0.05)
        assert DISPERSIONS["initial_rate"].sigma == pytest.approx(math.radians(0.05))
        assert DISPERSIONS["gyro_misalignment"].scale[0] == pytest.approx(100.0 * math.pi / 180 / 3600)


# ---------------------------------------------------------------------------
# Statistics


class TestStatistics:
    def test_zero_failure_bound_is_the_clopper_pearson_bound(self):
        for n in (1, 59, 2995):
            assert zero_failure_bound(n, 0.95) == pytest.approx(stats.beta.ppf(0.05, n, 1), rel=1e-12)
        # The classical figures: 59 runs prove 95 % at 95 % (ln 0.05 / ln 0.95 = 58.4), and
        # ln 0.05 / ln 0.999 = 2994.2 runs 99.9 % at 95 % (the often quoted "3000" rounded up).
        assert runs_for_zero_failures(0.95, 0.95) == 59
        assert runs_for_zero_failures(0.999, 0.95) == 2995
        assert zero_failure_bound(2995, 0.95) >= 0.999 > zero_failure_bound(2994, 0.95)

    def test_bound_with_failures_matches_scipy_exact_interval(self):
        for k, n in ((90, 100), (1, 10), (999, 1000)):
            ci = stats.binomtest(k, n, alternative="greater").proportion_ci(0.95, method="exact")
            assert success_lower_bound(k, n, 0.95) == pytest.approx(ci.low, rel=1e-10)
        assert success_lower_bound(0, 10) == 0.0

    def test_percentiles_leave_out_non_finite_values(self):
        s = percentiles([1.0, 2.0, 3.0, np.inf, np.nan], q=(50,))
        assert s["count"] == 3 and s["nonfinite"] == 2 and s["p50"] == 2.0 and s["max"] == 3.0


# ---------------------------------------------------------------------------
# Campaigns


class TestCampaign:
    def test_bad_input_is_rejected(self):
        with pytest.raises(ValueError, match="runs"):
            Campaign(Quadratic(), X, runs=0)
        with pytest.raises(ValueError, match="seed"):
            Campaign(Quadratic(), X, runs=1, seed=-1)
        with pytest.raises(ValueError, match="callable"):
            Campaign(42, X)
        with pytest.raises(ValueError, match="run_batch"):
            run_campaign(Campaign(Quadratic(), X, runs=2), vectorized=True)
        with pytest.raises(ValueError, match="max or a min"):
            Requirement("y")

    def test_seed_none_is_drawn_and_recorded(self):
        c = Campaign(Quadratic(), X, runs=3)
        again = Campaign(Quadratic(), X, runs=3, seed=c.seed)
        assert_tables_identical(run_campaign(c, workers=1), run_campaign(again, workers=1))

    def test_a_raising_run_is_recorded_and_the_campaign_goes_on(self):
        result = run_campaign(
            Campaign(Failing(), X, runs=40, seed=3, requirements=[Requirement("y", max=5.0)]), workers=1
        )
        bad = result.parameters["x"] > 1.0
        assert np.any(bad) and np.all(result.status[bad] == "error") and np.all(result.status[~bad] == "ok")
        assert all("RuntimeError: bad run at x" in e for e in result.errors[bad])
        assert np.all(np.isnan(result.metrics["y"][bad])) and not np.any(result.passed[bad])
        stats_ = result.statistics()
        assert stats_["errors"] == int(bad.sum())
        # A raising run is a failure of the campaign's success statement.
        assert stats_["success"]["passed"] == int(result.passed.sum()) <= 40 - int(bad.sum())

    def test_longer_campaign_keeps_the_first_runs(self):
        short = run_campaign(Campaign(Quadratic(), X, runs=5, seed=9), workers=1)
        long = run_campaign(Campaign(Quadratic(), X, runs=8, seed=9), workers=1)
        assert np.array_equal(short.metrics["y"], long.metrics["y"][:5])

    def test_files_round_trip_bit_for_bit(self, tmp_path):
        result = run_campaign(
            Campaign(
                Failing(), {**X, "q": RandomAttitude()}, runs=12, seed=5, requirements=[Requirement("y", max=1.0)]
            ),
            workers=1,
            out_dir=tmp_path,
        )
        for name in ("results.csv", "campaign.json", "statistics.json", "summary.txt", "checkpoint.jsonl"):
            assert (tmp_path / name).stat().st_size > 0
        loaded = CampaignResult.load(tmp_path)
        assert_tables_identical(result, loaded)
        header = (tmp_path / "results.csv").read_text().splitlines()[0].split(",")
        assert header[:5] == ["run", "seed", "spawn_key", "status", "error"] and "pass.y" in header and "q.w" in header

    def test_progress_bar_goes_to_stderr(self, capsys):
        # progress=True draws even on a stream that is not a terminal (pytest's capture); the bar's
        # behaviour (terminals, resume, batches in flight) is tested in test_executors.py.
        run_campaign(Campaign(Quadratic(), X, runs=3, seed=1), workers=1, progress=True)
        captured = capsys.readouterr()
        assert "Monte Carlo: 100%" in captured.err and "3/3" in captured.err and "0 errors" in captured.err
        assert captured.out == ""

    def test_ctrl_c_keeps_completed_runs_and_resume_does_not_redo_them(self, tmp_path):
        reference = run_campaign(Campaign(Interrupted(None), X, runs=8, seed=4), workers=1)
        scenario = Interrupted(stop=3)
        first = run_campaign(Campaign(scenario, X, runs=8, seed=4), workers=1, out_dir=tmp_path)
        assert first.info["interrupted"]
        assert list(first.status) == ["ok"] * 3 + ["not run"] * 5
        assert "interrupted" in (tmp_path / "summary.txt").read_text()
        resumed_scenario = Interrupted(stop=None)
        second = run_campaign(Campaign(resumed_scenario, X, runs=8, seed=4), workers=1, out_dir=tmp_path)
        assert len(resumed_scenario.calls) == 5  # runs 0-2 came from the checkpoint
        assert second.info["resumed_runs"] == 3
        assert_tables_identical(second, reference)

    def test_checkpoint_of_another_campaign_is_refused(self, tmp_path):
        run_campaign(Campaign(Quadratic(), X, runs=2, seed=1), workers=1, out_dir=tmp_path)
        with pytest.raises(ValueError, match="different campaign"):
            run_campaign(Campaign(Quadratic(), X, runs=2, seed=2), workers=1, out_dir=tmp_path)
        fresh = run_campaign(Campaign(Quadratic(), X, runs=2, seed=2), workers=1, out_dir=tmp_path, resume=False)
        assert fresh.info["resumed_runs"] == 0


class TestExecutors:
    @pytest.mark.slow
    def test_one_worker_and_two_processes_give_identical_tables(self):
        serial = run_campaign(short_closed_loop(), workers=1)
        pool = run_campaign(short_closed_loop(), workers=2)
        assert pool.info["executor"] == "processes" and serial.info["executor"] == "serial"
        assert np.all(serial.status == "ok")
        assert_tables_identical(serial, pool)

    @pytest.mark.slow
    def test_a_killed_worker_is_survived_with_nothing_lost(self, tmp_path):
        campaign = Campaign(Quadratic(), X, runs=8, seed=6)
        reference = run_campaign(campaign, workers=1)
        scenario = Dies(campaign.parameters(5)["x"], tmp_path / "marker")
        result = run_campaign(Campaign(scenario, X, runs=8, seed=6), workers=2, out_dir=tmp_path / "out")
        assert (tmp_path / "marker").exists()  # the worker did die once
        assert np.all(result.status == "ok")
        assert_tables_identical(result, reference)
        assert len((tmp_path / "out" / "checkpoint.jsonl").read_text().splitlines()) == 1 + 8

    @pytest.mark.slow
    def test_ctrl_c_stops_the_pool_and_keeps_completed_runs(self, tmp_path):
        campaign = Campaign(Slow(), X, runs=40, seed=2)
        checkpoint = tmp_path / "checkpoint.jsonl"
        stop = threading.Event()

        def press_ctrl_c():  # once a few runs are in the checkpoint (bounded wait)
            deadline = time.monotonic() + 60.0
            while not stop.is_set() and time.monotonic() < deadline:
                if checkpoint.exists() and len(checkpoint.read_text().splitlines()) >= 4:
                    os.kill(os.getpid(), signal.SIGINT)
                    return
                time.sleep(0.02)

        presser = threading.Thread(target=press_ctrl_c)
        presser.start()
        try:
            result = run_campaign(campaign, workers=2, out_dir=tmp_path)
        finally:
            stop.set()
            presser.join()
        assert result.info["interrupted"]
        done = result.status == "ok"
        assert 0 < done.sum() < 40 and np.all(result.status[~done] == "not run")
        assert len((tmp_path / "checkpoint.jsonl").read_text().splitlines()) == 1 + int(done.sum())
        reference = run_campaign(Campaign(Quadratic(), X, runs=40, seed=2), workers=1)
        assert np.array_equal(result.metrics["y"][done], reference.metrics["y"][done])

    @pytest.mark.slow
    def test_a_run_that_always_kills_its_worker_is_recorded(self, tmp_path):
        scenario = Dies(Campaign(Quadratic(), X, runs=4, seed=8).parameters(1)["x"])
        result = run_campaign(Campaign(scenario, X, runs=4, seed=8), workers=2, max_retries=1, out_dir=tmp_path)
        assert list(result.status) == ["ok", "error", "ok", "ok"]
        assert "worker process died" in result.errors[1] and result.attempts[1] == 2
        # A run lost to the infrastructure is tried again on resume (here it dies again).
        again = run_campaign(Campaign(scenario, X, runs=4, seed=8), workers=2, max_retries=0, out_dir=tmp_path)
        assert again.info["resumed_runs"] == 3 and again.attempts[1] == 1


# ---------------------------------------------------------------------------
# Dask


@pytest.fixture(scope="module")
def dask_client():
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1", dashboard_address=":0"
    )
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


@pytest.mark.slow
def test_local_cluster_gives_the_same_table_as_one_worker(dask_client):
    serial = run_campaign(short_closed_loop(), workers=1)
    cluster = run_campaign(short_closed_loop(), scheduler=dask_client)
    assert cluster.info["executor"] == "dask"
    assert_tables_identical(serial, cluster)
    address = run_campaign(Campaign(Quadratic(), X, runs=4, seed=1), scheduler=dask_client.scheduler.address)
    assert_tables_identical(address, run_campaign(Campaign(Quadratic(), X, runs=4, seed=1), workers=1))


@pytest.mark.slow
def test_local_cluster_survives_a_killed_worker(dask_client, tmp_path):
    campaign = Campaign(Quadratic(), X, runs=6, seed=12)
    scenario = Dies(campaign.parameters(4)["x"], tmp_path / "marker")
    result = run_campaign(Campaign(scenario, X, runs=6, seed=12), scheduler=dask_client)
    assert (tmp_path / "marker").exists()
    assert np.all(result.status == "ok")
    assert_tables_identical(result, run_campaign(campaign, workers=1))


@pytest.mark.slow
def test_a_one_worker_cluster_whose_worker_dies_loses_nothing(tmp_path):
    # The only worker holds the scenario when it dies: the scheduler must be able to rebuild it.
    distributed = pytest.importorskip("distributed")
    campaign = Campaign(Quadratic(), X, runs=6, seed=12)
    scenario = Dies(campaign.parameters(4)["x"], tmp_path / "marker")
    with (
        distributed.LocalCluster(
            n_workers=1, processes=True, threads_per_worker=1, host="127.0.0.1", dashboard_address=":0"
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        result = run_campaign(Campaign(scenario, X, runs=6, seed=12), scheduler=client)
    assert (tmp_path / "marker").exists()
    assert np.all(result.status == "ok")
    assert_tables_identical(result, run_campaign(campaign, workers=1))


# ---------------------------------------------------------------------------
# Vectorised path and built-in scenarios


PD_DISPERSIONS = {k: DISPERSIONS[k] for k in ("inertia", "initial_rate", "initial_attitude")}


def test_vectorised_pd_wheels_agrees_with_the_per_run_engine():
    scenario = PDWheelsScenario.from_config(CONFIG, duration=120.0, history_stride=50)
    # PDWheelsScenario's own metrics (settling over the whole run, final error): not the file's windowed rows.
    rules = [Requirement("final_pointing_error", max=math.radians(0.05)), Requirement("settling_time", max=180.0)]
    campaign = Campaign(scenario, PD_DISPERSIONS, runs=6, seed=21, requirements=rules)
    per_run = run_campaign(campaign, workers=1)
    batch = run_campaign(campaign, vectorized=True)
    chunked = run_campaign(campaign, vectorized=True, runs_per_task=4, workers=2)
    for m in ("final_pointing_error", "rate_peak", "wheel_speed_peak"):
        # Same definitions, numpy per component vs casadi per run: rounding only (measured ~1e-17).
        np.testing.assert_allclose(batch.metrics[m], per_run.metrics[m], rtol=1e-9, atol=1e-15)
    np.testing.assert_array_equal(batch.metrics["settling_time"], per_run.metrics["settling_time"])
    np.testing.assert_allclose(batch.histories[3]["error_angle"], per_run.histories[3]["error_angle"], atol=1e-12)
    # Chunks of 4 runs in two processes: the same elementwise arithmetic, so bit-identical.
    assert_tables_identical(batch, chunked)


def test_config_campaign_writes_table_statistics_and_figures(tmp_path):
    # The eigenaxis guidance on SHORT: 20 s runs (the planned slew needs slew, settling and hold:
    # tests/attitude/app/test_scenarios.py).
    result = run_campaign_from_config(SHORT, runs=3, workers=1, out_dir=tmp_path, duration=20.0, guidance="eigenaxis")
    assert np.all(result.status == "ok")
    assert {"slew_time", "nees", "wheel_speed_peak", "keep_out_margin.sun on star tracker"} <= set(result.metrics)
    assert result.histories[0]["t"][-1] == pytest.approx(20.0)
    figures = sorted(p.name for p in (tmp_path / "figures").glob("*.png"))
    assert {"histograms.png", "envelope_error_angle.png", "envelope_wheel_speed.png"} <= set(figures)
    assert any(name.startswith("scatter_") for name in figures)
    assert all((tmp_path / "figures" / name).stat().st_size > 1000 for name in figures)
    assert save_figures(result, tmp_path / "again")


# ---------------------------------------------------------------------------
# Analytic check: the middle-axis flip


class FlipScenario:
    """Torque-free spin near the middle axis; measures the time between middle-axis reversals.

    ``omega0 = (eps cos phi, W, eps sin phi)`` in principal axes with the
    dispersed phase ``phi``; vectorised through the batched propagation.
    """

    fingerprint = "FlipScenario"
    moments = np.array([2.0, 3.0, 4.0])
    spin = 1.0  # W [rad/s]
    eps = 0.02  # [rad/s]
    dt = 0.05
    duration = 80.0

    def omega0(self, phi):
        return np.stack([self.eps * np.cos(phi), np.full_like(phi, self.spin), self.eps * np.sin(phi)], axis=-1)

    def _measure(self, t, w2):
        s = np.signbit(w2)
        k = np.nonzero(s[:-1] != s[1:])[0]
        if k.size < 2:
            return math.inf
        crossings = t[k] + w2[k] / (w2[k] - w2[k + 1]) * (t[k + 1] - t[k])
        return float(crossings[1] - crossings[0])

    def _run(self, phis):
        t = np.arange(0.0, self.duration + self.dt / 2, self.dt)
        q0 = np.tile(quat.identity(), (phis.size, 1))
        traj = propagate(RigidBody(self.moments), q0, self.omega0(phis), t)
        return [RunOutput({"flip_period": self._measure(t, traj.omega[i, :, 1])}) for i in range(phis.size)]

    def __call__(self, params, rng):
        return self._run(np.array([params["phase"]]))[0]

    def run_batch(self, params_list, rngs):
        return self._run(np.array([p["phase"] for p in params_list]))


@pytest.mark.slow
def test_fraction_of_spins_that_flip_within_a_time_matches_the_closed_form():
    s = FlipScenario()
    body = RigidBody(s.moments)

    def exact(phi):
        return flip_period(body, s.omega0(np.array(phi)))

    # The time: 10 % above the flip period of the phase-0 spin. The flip period grows without
    # bound toward the separatrix phase phi* (D2 = 0) and falls on either side of it, so within
    # [0, pi/2] the set {T_flip <= tau} is [0, a] U [b, pi/2], the same in the four quadrants
    # (T_flip depends on cos^2 and sin^2 only).
    tau = 1.1 * exact(0.0)
    i1, i2, i3 = s.moments
    phi_star = math.atan(math.sqrt(i1 * (i2 - i1) / (i3 * (i3 - i2))))
    a = brentq(lambda p: exact(p) - tau, 0.0, phi_star - 1e-9)
    b = brentq(lambda p: exact(p) - tau, phi_star + 1e-9, math.pi / 2)
    p_exact = (a + (math.pi / 2 - b)) / (math.pi / 2)

    n = 400
    campaign = Campaign(s, {"phase": Uniform(0.0, 2.0 * math.pi)}, runs=n, seed=31)
    result = run_campaign(campaign, vectorized=True)
    measured = result.metrics["flip_period"]
    phases = result.parameters["phase"]
    truth = np.array([exact(p) for p in phases])
    # Run by run: RK4 at 0.05 s and linear interpolation of the zero crossings of omega_2
    # time the flip to 1e-6 s (measured; at a crossing omega_2 is nearly linear in t), so a
    # 5 ms tolerance is loose; runs whose exact period exceeds the 80 s window show fewer
    # than two reversals (inf).
    finite = np.isfinite(measured)
    assert np.all(truth[~finite] > tau)
    np.testing.assert_allclose(measured[finite], truth[finite], atol=5e-3)
    # The campaign's fraction: a binomial proportion with standard error sqrt(p (1-p) / n)
    # (<= 0.025 for n = 400); 4 standard errors leave a 6e-5 chance of a false failure.
    p_hat = float(np.mean(measured <= tau))
    assert abs(p_hat - p_exact) <= 4.0 * math.sqrt(p_exact * (1 - p_exact) / n)
    # And no run sits within the 5 ms timing error of the threshold, so the count is exact.
    assert np.mean(truth <= tau) == p_hat


def test_the_summary_speaks_review_units():
    class Pointing:
        def __call__(self, params, rng):
            return {"final_pointing_error": math.radians(0.01 + 0.001 * rng.standard_normal()), "rate_peak": 0.1}

    rule = Requirement("final_pointing_error", max=math.radians(0.05), name="pointing")
    result = run_campaign(Campaign(Pointing(), {}, runs=20, seed=3, requirements=[rule]), workers=1)
    text = result.summary()
    # SI inside, degrees on the page: 0.05 deg, not 0.000872665 rad.
    assert "requirement pointing (final_pointing_error <= 0.05 deg): 20/20 passed" in text
    median = np.degrees(np.median(result.metrics["final_pointing_error"]))
    assert f"final_pointing_error [deg]: median {median:.4g}" in text
    assert "rate_peak [deg/s]: median 5.73" in text  # 0.1 rad/s


# ---------------------------------------------------------------------------
# Reserved metric names and the run count (issue 13, items 5 and 8)


class ReturnsMetric:
    """Returns one metric of the given name (e.g. ``seed``, which names a column of the table)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.fingerprint = f"ReturnsMetric({name})"

    def __call__(self, params, rng):
        return {"y": 1.0, self.name: 7.0}


class CountingNormal(Normal):
    """A normal dispersion that counts its draws (class-wide, so copies count too)."""

    draws = 0

    def sample(self, rng):
        type(self).draws += 1
        return super().sample(rng)


class StopsAtOnce(Quadratic):
    """Notes how many parameters had been drawn when the first run started, then stops (Ctrl-C)."""

    fingerprint = "StopsAtOnce"

    def __init__(self) -> None:
        self.draws_at_first_run: int | None = None

    def __call__(self, params, rng):
        self.draws_at_first_run = CountingNormal.draws
        raise KeyboardInterrupt


class TestReservedMetricNames:
    @pytest.mark.parametrize("name", ["run", "seed", "spawn_key", "status", "error", "pass", "cpu_s", "q", "q.w", "x"])
    def test_a_metric_named_like_a_column_fails_its_run_and_the_table_loads(self, name, tmp_path):
        dispersions = {"x": Normal(0.0, 1.0), "q": RandomAttitude()}
        result = run_campaign(Campaign(ReturnsMetric(name), dispersions, runs=3, seed=5), workers=1, out_dir=tmp_path)
        assert list(result.status) == ["error"] * 3
        for message in result.errors:
            assert message.startswith("ValueError: metric")
            assert repr(name) in message and "reserved" in message
        assert name not in result.metrics
        table = result.table()
        assert list(table["run"]) == [0, 1, 2] and list(table["seed"]) == [5, 5, 5]
        loaded = CampaignResult.load(tmp_path)
        assert list(loaded.status) == ["error"] * 3
        assert np.array_equal(loaded.parameters["x"], result.parameters["x"])

    def test_a_requirement_on_a_reserved_name_is_refused(self):
        with pytest.raises(ValueError, match=r"requirements.*'x'.*reserved"):
            Campaign(Quadratic(), X, runs=2, requirements=[Requirement("x", max=1.0)])
        with pytest.raises(ValueError, match=r"requirements.*'wall_s'.*reserved"):
            Campaign(Quadratic(), X, runs=2, requirements=[Requirement("wall_s", max=1.0)])

    def test_a_result_whose_metric_shadows_a_column_refuses_to_make_a_table(self):
        result = run_campaign(Campaign(Quadratic(), X, runs=2, seed=1), workers=1)
        result.metrics["status"] = np.zeros(2)
        with pytest.raises(ValueError, match=r"metrics.*'status'.*column"):
            result.table()


class TestRunCount:
    def test_an_absurd_run_count_is_refused_with_the_bound(self):
        with pytest.raises(ValueError, match=r"runs must be at most 10000000.*999999999999999999"):
            Campaign(Quadratic(), X, runs=999999999999999999)

    def test_the_bound_itself_is_accepted(self):
        from attitude.montecarlo.campaign import MAX_RUNS

        assert Campaign(Quadratic(), X, runs=MAX_RUNS).runs == MAX_RUNS

    def test_parameters_are_drawn_as_the_runs_start_not_all_before(self):
        CountingNormal.draws = 0
        scenario = StopsAtOnce()
        result = run_campaign(Campaign(scenario, {"x": CountingNormal(0.0, 1.0)}, runs=2000, seed=3), workers=1)
        assert result.info["interrupted"]
        # Today's code drew all 2000 before the first run; lazily, only the first run's.
        assert scenario.draws_at_first_run == 1
        # The table still holds every run's parameters, as a campaign run to the end would.
        reference = [Campaign(Quadratic(), X, runs=2000, seed=3).parameters(r)["x"] for r in range(2000)]
        assert list(result.parameters["x"]) == reference


# ---------------------------------------------------------------------------
# What a resume says (issue 12): the runs it took, and which part of a refused checkpoint's campaign differs


class Tuned(Quadratic):
    """A scenario whose ``fingerprint`` names its settings, with a batched path (the vectorised mode)."""

    def __init__(self, gain: float = 1.0) -> None:
        self.gain = gain
        self.fingerprint = f"Tuned(gain={gain!r}, stride=10)"

    def run_batch(self, params_list, rngs):
        return [RunOutput(self(p, rng)) for p, rng in zip(params_list, rngs)]


class TestResumeMessages:
    def test_a_resume_says_how_many_runs_it_took_from_the_checkpoint(self, tmp_path, caplog):
        import logging

        run_campaign(Campaign(Quadratic(), X, runs=2, seed=1), workers=1, out_dir=tmp_path)
        with caplog.at_level(logging.INFO, logger="attitude.montecarlo"):
            fresh = run_campaign(Campaign(Quadratic(), X, runs=5, seed=1), workers=1, out_dir=tmp_path / "other")
            assert caplog.messages == []  # nothing was resumed: nothing said
            longer = run_campaign(Campaign(Quadratic(), X, runs=5, seed=1), workers=1, out_dir=tmp_path)
        # The first campaign wrote 2 runs; the longer one (same seed, so its first runs are those) takes them.
        assert caplog.messages == [f"resuming: 2 of 5 runs from the checkpoint in {tmp_path}"]
        assert longer.info["resumed_runs"] == 2 and fresh.info["resumed_runs"] == 0

    @pytest.mark.parametrize(
        ("second", "vectorized", "differs"),
        [
            (Campaign(Tuned(), X, runs=2, seed=2), False, "it differs in the seed (1 in the checkpoint, 2 now)"),
            (Campaign(Tuned(), X, runs=2, seed=1), True, "it differs in the mode (per run in the checkpoint, "
             "vectorized (run_batch) now)"),
            (Campaign(Tuned(), {"x": Normal(0.0, 2.0)}, runs=2, seed=1), False, "it differs in the dispersion 'x' "
             "('Normal(mean=0.0, sigma=1.0)' in the checkpoint, 'Normal(mean=0.0, sigma=2.0)' now)"),
            (Campaign(Tuned(), {**X, "z": Normal(0.0, 1.0)}, runs=2, seed=1), False,
             "it differs in the dispersion 'z' (new)"),
            (Campaign(Tuned(2.0), X, runs=2, seed=1), False, "it differs in the scenario's fingerprint "
             "('Tuned(gain=1.0, stride=10)' in the checkpoint, 'Tuned(gain=2.0, stride=10)' now)"),
            (Campaign(Tuned(2.0), X, runs=2, seed=3), False, "it differs in the seed (1 in the checkpoint, 3 now) "
             "and the scenario's fingerprint"),
        ],
        ids=["seed", "mode", "dispersion changed", "dispersion added", "scenario", "two parts"],
    )  # fmt: skip
    def test_a_refused_checkpoint_names_the_part_that_differs(self, tmp_path, second, vectorized, differs):
        # Before: every refusal listed every possible cause ("other seed, dispersions, scenario code or
        # parameters, or mode"). The campaign written first differs from each second one in the named part only.
        run_campaign(Campaign(Tuned(), X, runs=2, seed=1), workers=1, out_dir=tmp_path)
        with pytest.raises(ValueError, match="holds the checkpoint of a different campaign") as refused:
            run_campaign(second, workers=1, out_dir=tmp_path, vectorized=vectorized)
        message = str(refused.value)
        assert f"different campaign: {differs}" in message
        assert "resume=False to start afresh" in message
        # The same campaign still resumes: the parts kept in the header do not change its fingerprint.
        again = run_campaign(Campaign(Tuned(), X, runs=2, seed=1), workers=1, out_dir=tmp_path)
        assert again.info["resumed_runs"] == 2

    def test_a_long_fingerprint_is_quoted_around_its_first_difference(self, tmp_path):
        # A built-in scenario's fingerprint holds the whole spacecraft file: the refusal quotes its two versions
        # around the first character that differs, not thousands of characters.
        padding = "k=1.0, " * 200
        first, second = Tuned(), Tuned()
        first.fingerprint = f"Scenario({padding}duration=159.0, {padding})"
        second.fingerprint = f"Scenario({padding}duration=200.0, {padding})"
        run_campaign(Campaign(first, X, runs=1, seed=1), workers=1, out_dir=tmp_path)
        with pytest.raises(ValueError) as refused:
            run_campaign(Campaign(second, X, runs=1, seed=1), workers=1, out_dir=tmp_path)
        message = str(refused.value)
        quoted = r"'\.\.\.[^']{{30,}}duration={}[^']{{30,}}\.\.\.'"
        assert re.search(quoted.format("159.0") + " in the checkpoint, " + quoted.format("200.0") + " now", message)
        assert len(message) < 600  # each fingerprint alone holds 2,826 characters

    def test_a_checkpoint_without_the_parts_gets_the_general_refusal(self, tmp_path):
        # A checkpoint written before the header kept the parts: nothing says which differs, so every cause is named.
        (tmp_path / "checkpoint.jsonl").write_text('{"fingerprint": "0123", "format": 1}\n')
        with pytest.raises(ValueError, match=r"different campaign \(other seed, dispersions, scenario code"):
            run_campaign(Campaign(Tuned(), X, runs=2, seed=1), workers=1, out_dir=tmp_path)

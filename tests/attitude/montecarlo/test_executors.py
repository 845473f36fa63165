"""Executors: a scenario that exits is a failed run, not the end of the campaign.

What each test checks against: the campaign's own rule (module docstring of
:mod:`attitude.montecarlo.executors`: "a task never raises because a scenario
raised"), applied to ``SystemExit`` (``sys.exit`` in a scenario, or a library
calling it), which is a ``BaseException`` and not an ``Exception``. Ctrl-C
(``KeyboardInterrupt``) still stops the campaign. And a history that cannot be stored without pickle
(an object array) is refused when the run returns it, so a checkpoint always resumes.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from attitude.montecarlo.campaign import Campaign, run_campaign
from attitude.montecarlo.dispersions import Normal
from attitude.montecarlo.executors import execute_task

X = {"x": Normal(0.0, 1.0)}


class Exits:
    """Calls ``sys.exit`` on the runs whose parameter is above 0.5."""

    fingerprint = "Exits"

    def __call__(self, params, rng):
        if params["x"] > 0.5:
            sys.exit(f"solver gave up at x = {params['x']:.3f}")
        return {"y": float(params["x"])}


class BatchExits:
    """A vectorised scenario whose batch calls ``sys.exit(3)``."""

    fingerprint = "BatchExits"

    def __call__(self, params, rng):  # pragma: no cover - only the batch path is used
        return {"y": 0.0}

    def run_batch(self, params_list, rngs):
        sys.exit(3)


def test_system_exit_in_a_run_is_that_runs_failure_and_the_campaign_goes_on():
    campaign = Campaign(Exits(), X, runs=12, seed=3)
    result = run_campaign(campaign, workers=1)
    exited = [r for r in range(12) if campaign.parameters(r)["x"] > 0.5]
    assert exited and len(exited) < 12  # the seed gives both kinds of run
    for r in range(12):
        if r in exited:
            assert result.status[r] == "error"
            assert result.errors[r] == f"SystemExit: solver gave up at x = {campaign.parameters(r)['x']:.3f}"
        else:
            assert result.status[r] == "ok"
    assert not result.info["interrupted"]


def test_system_exit_in_a_pool_worker_is_that_runs_failure():
    campaign = Campaign(Exits(), X, runs=6, seed=3)
    serial = run_campaign(campaign, workers=1)
    pool = run_campaign(campaign, workers=2)
    assert list(pool.status) == list(serial.status)
    assert list(pool.errors) == list(serial.errors)
    assert pool.info["executor"] == "processes"


def test_system_exit_in_a_batch_fails_the_batch_runs_with_the_exit_code():
    records = execute_task(BatchExits(), 1, [(0, {"x": 0.0}), (1, {"x": 1.0})], vectorized=True)
    assert [r.status for r in records] == ["error", "error"]
    assert all(r.error == "batch failed: SystemExit: exit code 3" for r in records)


def test_keyboard_interrupt_still_stops_the_task():
    def stop(params, rng):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        execute_task(stop, 1, [(0, {})], vectorized=False)


def test_a_bare_system_exit_names_its_code():
    def bare(params, rng):
        raise SystemExit

    (record,) = execute_task(bare, 1, [(0, {})], vectorized=False)
    assert (record.status, record.error) == ("error", "SystemExit: exit code None")


class ObjectHistory:
    """Returns a history holding Python objects (what ``np.asarray`` of a list of dicts gives)."""

    fingerprint = "ObjectHistory"

    def __call__(self, params, rng):
        from attitude.montecarlo.executors import RunOutput

        t = np.arange(3.0)
        return RunOutput({"y": float(params["x"])}, {"t": t, "events": np.array([{"a": 1}] * 3, dtype=object)})


def test_object_history_is_refused_when_written_and_the_campaign_resumes(tmp_path):
    """Issue 13, item 12: an object-array history was checkpointed with pickle, then refused on resume."""
    campaign = Campaign(ObjectHistory(), X, runs=3, seed=1)
    first = run_campaign(campaign, workers=1, out_dir=tmp_path / "mc")
    assert list(first.status) == ["error"] * 3
    assert all("history['events'] must be an array of numbers" in e and "dtype object" in e for e in first.errors)
    # Nothing pickled was written: the same command resumes (and redoes the failed runs the same way).
    again = run_campaign(campaign, workers=1, out_dir=tmp_path / "mc")
    assert list(again.status) == ["error"] * 3

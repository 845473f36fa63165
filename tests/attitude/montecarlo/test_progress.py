"""A campaign's progress bar (:class:`attitude.montecarlo.executors.Progress`, module docstring "Progress").

What each test checks against: what the bar writes on stderr, read back. On
a terminal (a stderr whose ``isatty()`` is True) the default draws it, on a
pipe or log it does not, and ``progress=False`` never does; it counts the
runs and the errors (the runs that raised, known from the scenario); a
resumed campaign's bar starts at the runs its checkpoint holds (3 of 8,
known from the interrupted first campaign); a vectorised batch moves the bar
before it ends, in this process and in a pool worker (a scenario that
reports half of its batch done and then waits, longer than the bar's
refresh period); and the bar never touches the numbers: the result tables
are bit-identical with and without it, per run and vectorised.
"""

from __future__ import annotations

import io
import re
import sys
import time

import numpy as np
import pytest

from attitude.montecarlo.campaign import Campaign, run_campaign
from attitude.montecarlo.dispersions import Normal
from attitude.montecarlo.executors import RunOutput
from attitude.montecarlo.results import EXECUTION_COLUMNS, CampaignResult
from attitude.progress import REFRESH_PERIOD_S

X = {"x": Normal(0.0, 1.0)}


class Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


class Quadratic:
    """Cheap scenario; runs with ``x > 1`` raise. Batches through ``run_batch`` report their progress."""

    fingerprint = "progress.Quadratic"

    def __call__(self, params, rng):
        if params["x"] > 1.0:
            raise RuntimeError(f"bad run at x = {params['x']:.3f}")
        return {"y": float(params["x"] ** 2 + rng.standard_normal())}

    def run_batch(self, params_list, rngs, progress=None):
        outputs = []
        for i, (p, r) in enumerate(zip(params_list, rngs)):
            y = float(p["x"] ** 2 + r.standard_normal())
            outputs.append(RunOutput({"y": y}) if p["x"] <= 1.0 else RunOutput(error="bad run"))
            if progress is not None:
                progress((i + 1) / len(params_list))
        return outputs


class HalfThenWait(Quadratic):
    """A batch that reports half of it simulated, then waits ``wait_s`` before it ends."""

    fingerprint = "progress.HalfThenWait"

    def __init__(self, wait_s: float) -> None:
        self.wait_s = wait_s

    def run_batch(self, params_list, rngs, progress=None):
        time.sleep(self.wait_s)  # past the bar's refresh period since its last frame
        if progress is not None:
            progress(0.5)
        time.sleep(self.wait_s)
        return [RunOutput({"y": float(p["x"])}) for p in params_list]


def frames(text: str) -> list[str]:
    """The successive frames of a bar (tqdm redraws its line after a carriage return)."""
    return [f for f in re.split(r"[\r\n]", text) if f.strip()]


def counts(text: str, total: int) -> list[int]:
    """The run counts the frames show, ``N`` of ``N/total``, in order."""
    return [int(m.group(1)) for f in frames(text) if (m := re.search(rf"(\d+)/{total}\b", f))]


def reproducible(result: CampaignResult) -> dict[str, np.ndarray]:
    return {k: v for k, v in result.table().items() if k not in EXECUTION_COLUMNS}


def assert_identical(a: CampaignResult, b: CampaignResult) -> None:
    ta, tb = reproducible(a), reproducible(b)
    assert list(ta) == list(tb)
    for k in ta:
        assert np.array_equal(ta[k], tb[k], equal_nan=ta[k].dtype.kind == "f"), k


def test_the_bar_is_drawn_on_a_terminal_with_the_runs_and_errors(monkeypatch):
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    result = run_campaign(Campaign(Quadratic(), X, runs=30, seed=3), workers=1)
    errors = int(np.sum(result.status == "error"))
    assert errors > 0  # P(x > 1) = 16 %: seed 3 draws some
    last = frames(stderr.getvalue())[-1]
    assert last.startswith("Monte Carlo: 100%") and "30/30" in last and f"{errors} errors" in last


def test_no_bar_on_a_pipe_nor_with_progress_false(monkeypatch, capsys):
    run_campaign(Campaign(Quadratic(), X, runs=5, seed=3), workers=1)  # stderr captured: not a terminal
    assert capsys.readouterr().err == ""
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    run_campaign(Campaign(Quadratic(), X, runs=5, seed=3), workers=1, progress=False)
    assert stderr.getvalue() == ""


class StopsAfter(Quadratic):
    """Ctrl-C at run ``stop`` (None: never)."""

    fingerprint = "progress.StopsAfter"

    def __init__(self, stop: int | None) -> None:
        self.stop = stop
        self.calls = 0

    def __call__(self, params, rng):
        if self.stop is not None and self.calls == self.stop:
            raise KeyboardInterrupt
        self.calls += 1
        return {"y": float(params["x"])}


def test_a_resumed_campaign_starts_at_the_runs_already_done(monkeypatch, tmp_path):
    first = run_campaign(Campaign(StopsAfter(3), X, runs=8, seed=4), workers=1, out_dir=tmp_path, progress=False)
    assert first.info["interrupted"] and int(np.sum(first.status == "ok")) == 3
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    again = run_campaign(Campaign(StopsAfter(None), X, runs=8, seed=4), workers=1, out_dir=tmp_path)
    assert again.info["resumed_runs"] == 3
    shown = counts(stderr.getvalue(), 8)
    assert shown[0] == 3 and shown[-1] == 8 and shown == sorted(shown)


@pytest.mark.parametrize("vectorized", [False, True])
def test_the_results_are_bit_identical_with_and_without_the_bar(vectorized, monkeypatch):
    campaign = Campaign(Quadratic(), X, runs=12, seed=8)
    quiet = run_campaign(campaign, workers=1, vectorized=vectorized, runs_per_task=5, progress=False)
    monkeypatch.setattr(sys, "stderr", Terminal())
    drawn = run_campaign(campaign, workers=1, vectorized=vectorized, runs_per_task=5)
    assert_identical(quiet, drawn)


def test_a_batch_in_this_process_moves_the_bar_before_it_ends(monkeypatch):
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    wait_s = 1.5 * REFRESH_PERIOD_S
    run_campaign(Campaign(HalfThenWait(wait_s), X, runs=4, seed=1), workers=1, vectorized=True)
    # Half of the one batch of 4 runs: 2 runs shown while it still runs, then all 4.
    shown = counts(stderr.getvalue(), 4)
    assert sorted(set(shown)) == [0, 2, 4] and shown == sorted(shown)


@pytest.mark.slow
def test_a_batch_in_a_pool_worker_moves_the_bar_before_it_ends(monkeypatch):
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    # The parent reads the worker's report when it wakes (every REFRESH_PERIOD_S): wait several periods.
    wait_s = 4 * REFRESH_PERIOD_S
    result = run_campaign(Campaign(HalfThenWait(wait_s), X, runs=4, seed=1), workers=2, vectorized=True)
    assert result.info["executor"] == "processes"
    shown = counts(stderr.getvalue(), 4)
    assert 2 in shown and shown[-1] == 4 and shown == sorted(shown)

"""Histories streamed to disk (``histories_on_disk``, :mod:`attitude.montecarlo.histories`).

Checked against the campaign that keeps its histories in memory, the path
the toolkit had before: the same runs have histories, with the same names,
dtypes, shapes and bytes (bit for bit), read back from the checkpoint's
files, from a saved folder, after a resume (on disk and in memory), and from
a checkpoint written in the older one-file-per-run format. The scenario's
histories mix float, integer and boolean series whose lengths differ by run,
and some runs fail without a history, so a mix-up of runs, batches or dtypes
shows; the built-in PD-with-wheels scenario's batch histories (views into
one array per batch) are checked too. That a streamed campaign lets each
batch's arrays go is checked directly: when a batch starts, no array the
scenario returned for an earlier batch is still alive (weak references;
kept in memory, they all are).
"""

from __future__ import annotations

import gc
import json
import weakref

import numpy as np
import pytest

from attitude.app.scenarios import PDWheelsScenario
from attitude.config import default_config
from attitude.montecarlo.campaign import Campaign, run_campaign
from attitude.montecarlo.dispersions import Normal, dispersions_from_config
from attitude.montecarlo.executors import RunOutput
from attitude.montecarlo.histories import StoredHistories, history_member, write_histories
from attitude.montecarlo.results import CampaignResult

RUNS, PER_TASK = 11, 4  # three batches, the last one short
X = {"x": Normal(0.0, 1.0)}


class NoisyBatch:
    """A vectorised scenario whose histories come from each run's generator; runs with x > 0.9 fail.

    Keeps weak references to the arrays it returns, and counts at the start
    of each batch how many of the earlier batches' are still alive
    (``alive``); raises KeyboardInterrupt (a Ctrl-C) when asked for batch
    ``stop``.
    """

    fingerprint = "NoisyBatch"

    def __init__(self, stop: int | None = None) -> None:
        self.stop = stop
        self.batches = 0
        self.returned: list[weakref.ref] = []
        self.alive: list[int] = []

    def __call__(self, params, rng):
        return self.run_batch([params], [rng])[0]

    def run_batch(self, params_list, rngs):
        if self.stop is not None and self.batches == self.stop:
            raise KeyboardInterrupt
        self.batches += 1
        gc.collect()
        self.alive.append(sum(ref() is not None for ref in self.returned))
        outputs = []
        for params, rng in zip(params_list, rngs):
            if params["x"] > 0.9:
                outputs.append(RunOutput(error=f"x = {params['x']:.3f} is too large"))
                continue
            n = 5 + int(rng.integers(0, 4))
            history = {
                "t": np.arange(n) * 0.1,
                "error_angle": rng.standard_normal(n),
                "omega": rng.standard_normal((n, 3)),
                "saturated": rng.random(n) > 0.5,
                "mode": rng.integers(0, 3, n),
            }
            self.returned.extend(weakref.ref(v) for v in history.values())
            outputs.append(RunOutput({"y": float(params["x"]) ** 2}, history))
        return outputs


def campaign(scenario=None) -> Campaign:
    return Campaign(NoisyBatch() if scenario is None else scenario, X, runs=RUNS, seed=7)


def assert_same_histories(got, expected) -> None:
    """The same runs, series names, dtypes, shapes and bytes."""
    assert list(got) == list(expected)
    for run in expected:
        a, b = got[run], expected[run]
        assert sorted(a) == sorted(b), run
        for name in b:
            assert a[name].dtype == b[name].dtype and a[name].shape == b[name].shape, (run, name)
            assert a[name].tobytes() == b[name].tobytes(), (run, name)


@pytest.fixture(scope="module")
def in_memory():
    result = run_campaign(campaign(), vectorized=True, runs_per_task=PER_TASK)
    assert not result.info["histories_on_disk"]
    assert 0 < len(result.histories) < RUNS  # some runs failed without a history, the others kept one
    return result


def test_streamed_histories_are_the_in_memory_ones_bit_for_bit(in_memory, tmp_path):
    """On disk by default with an out_dir: one file per batch, the same arrays, no earlier batch's kept."""
    scenario = NoisyBatch()
    streamed = run_campaign(campaign(scenario), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path)
    assert streamed.info["histories_on_disk"] and isinstance(streamed.histories, StoredHistories)
    assert_same_histories(streamed.histories, in_memory.histories)
    batches = [range(lo, min(lo + PER_TASK, RUNS)) for lo in range(0, RUNS, PER_TASK)]
    expected = [f"runs_{min(r for r in b if r in in_memory.histories):06d}.npz" for b in batches]
    assert sorted(p.name for p in (tmp_path / "checkpoint_histories").iterdir()) == expected
    assert scenario.alive == [0, 0, 0]


def test_kept_in_memory_when_asked_with_an_out_dir(in_memory, tmp_path):
    """histories_on_disk=False: the arrays the scenario returned are the result's (the former behaviour)."""
    scenario = NoisyBatch()
    kept = run_campaign(
        campaign(scenario), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path, histories_on_disk=False
    )
    assert isinstance(kept.histories, dict)
    assert_same_histories(kept.histories, in_memory.histories)
    assert 0 < scenario.alive[1] < scenario.alive[2]  # every earlier batch's arrays held


def test_the_saved_folder_reads_them_back(in_memory, tmp_path):
    """CampaignResult.load reads histories.npz a run at a time, equal to the campaign's, both ways."""
    run_campaign(campaign(), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path / "disk")
    in_memory.save(tmp_path / "memory")
    for folder in ("disk", "memory"):
        loaded = CampaignResult.load(tmp_path / folder)
        assert isinstance(loaded.histories, StoredHistories)
        assert_same_histories(loaded.histories, in_memory.histories)
    # Saving a loaded result again (into its own folder) keeps them.
    loaded.save(tmp_path / "memory")
    assert_same_histories(CampaignResult.load(tmp_path / "memory").histories, in_memory.histories)


@pytest.mark.parametrize("resume_on_disk", [True, False], ids=["resumed-on-disk", "resumed-in-memory"])
def test_an_interrupted_streamed_campaign_resumes_with_its_histories(in_memory, tmp_path, resume_on_disk):
    """Ctrl-C in the third batch, then a resume: the first two batches come from the checkpoint's files."""
    first = run_campaign(campaign(NoisyBatch(stop=2)), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path)
    assert first.info["interrupted"]
    done = [r for r in range(2 * PER_TASK) if r in in_memory.histories]
    assert_same_histories(first.histories, {r: in_memory.histories[r] for r in done})
    scenario = NoisyBatch()
    second = run_campaign(
        campaign(scenario),
        vectorized=True,
        runs_per_task=PER_TASK,
        out_dir=tmp_path,
        histories_on_disk=resume_on_disk,
    )
    assert second.info["resumed_runs"] == 2 * PER_TASK and scenario.batches == 1
    assert isinstance(second.histories, StoredHistories if resume_on_disk else dict)
    assert_same_histories(second.histories, in_memory.histories)


def test_a_checkpoint_in_the_one_file_per_run_format_still_resumes(in_memory, tmp_path):
    """Format 1 (``run_NNNNNN.npz`` with bare members, ``"history": true``): every run resumed, same arrays."""
    run_campaign(campaign(), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path)
    folder = tmp_path / "checkpoint_histories"
    lines = (tmp_path / "checkpoint.jsonl").read_text().splitlines()
    header, records = json.loads(lines[0]), [json.loads(line) for line in lines[1:]]
    header["format"] = 1
    for record in records:
        if record["history"]:
            np.savez(folder / f"run_{record['run']:06d}.npz", **in_memory.histories[record["run"]])
            record["history"] = True
    for path in folder.glob("runs_*.npz"):
        path.unlink()
    (tmp_path / "checkpoint.jsonl").write_text("\n".join(json.dumps(d) for d in [header, *records]) + "\n")
    for on_disk in (True, False):
        scenario = NoisyBatch(stop=0)  # a Ctrl-C if any run were flown again
        resumed = run_campaign(
            campaign(scenario), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path, histories_on_disk=on_disk
        )
        assert resumed.info["resumed_runs"] == RUNS and not resumed.info["interrupted"]
        assert_same_histories(resumed.histories, in_memory.histories)


def test_a_missing_history_file_redoes_its_runs(in_memory, tmp_path):
    """A checkpoint line whose history file is gone is not trusted: that batch's runs are flown again."""
    run_campaign(campaign(), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path)
    first_batch = min((tmp_path / "checkpoint_histories").iterdir())
    first_batch.unlink()
    again = run_campaign(campaign(), vectorized=True, runs_per_task=PER_TASK, out_dir=tmp_path)
    lost = [r for r in range(PER_TASK) if r in in_memory.histories]
    assert again.info["resumed_runs"] == RUNS - len(lost)
    assert_same_histories(again.histories, in_memory.histories)


def test_pd_wheels_batches_stream_bit_for_bit(tmp_path):
    """The built-in vectorised scenario: its per-run histories are views into one array per batch."""
    config = default_config()
    scenario = PDWheelsScenario.from_config(config, duration=120.0, history_stride=50)
    dispersions = dispersions_from_config(config.montecarlo, scenario.nominal.inertia, scenario.q_start)
    dispersions = {k: dispersions[k] for k in ("inertia", "initial_rate", "initial_attitude")}
    c = Campaign(scenario, dispersions, runs=6, seed=3)
    memory = run_campaign(c, vectorized=True, runs_per_task=4)
    streamed = run_campaign(c, vectorized=True, runs_per_task=4, out_dir=tmp_path)
    assert len(memory.histories) == 6 and set(memory.histories[0]) >= {"t", "error_angle", "omega", "wheel_speed"}
    assert_same_histories(streamed.histories, memory.histories)


def test_on_disk_needs_an_out_dir_and_a_boolean():
    with pytest.raises(ValueError, match="histories_on_disk=True needs an out_dir"):
        run_campaign(campaign(), vectorized=True, histories_on_disk=True)
    with pytest.raises(ValueError, match="histories_on_disk must be True, False or None, got 'yes'"):
        run_campaign(campaign(), vectorized=True, histories_on_disk="yes")


def test_a_history_that_needs_pickle_is_refused_and_no_file_is_left(tmp_path):
    """write_histories names the run and series; the half-written file is removed, the old one kept."""
    path = tmp_path / "h.npz"
    write_histories(path, [(0, {"t": np.arange(3.0)})])
    with pytest.raises(ValueError, match="run 5's series 'events' must be an array of numbers"):
        write_histories(path, [(4, {"t": np.arange(2.0)}), (5, {"events": np.array([{}, {}], dtype=object)})])
    assert [p.name for p in tmp_path.iterdir()] == ["h.npz"]
    stored = StoredHistories.from_file(path)
    assert list(stored) == [0] and np.array_equal(stored[0]["t"], np.arange(3.0))


def test_stored_histories_is_a_read_mapping_of_runs(tmp_path):
    """len, in, order and KeyError as a dict of the same runs; members named run000012/<series>."""
    first, second = tmp_path / "a.npz", tmp_path / "b.npz"
    write_histories(first, [(3, {"t": np.arange(2.0)}), (1, {"t": np.arange(4.0), "w": np.ones((4, 3))})])
    write_histories(second, [(12, {"t": np.zeros(1)})])
    with np.load(first) as data:
        assert sorted(data.files) == sorted([history_member(3, "t"), history_member(1, "t"), history_member(1, "w")])
    stored = StoredHistories({12: second, 3: first, 1: first})
    assert len(stored) == 3 and list(stored) == [1, 3, 12] and 3 in stored and 2 not in stored
    assert stored[1]["w"].shape == (4, 3) and stored[12]["t"].shape == (1,) and stored[3]["t"].shape == (2,)
    with pytest.raises(KeyError):
        stored[2]
    with pytest.raises(KeyError, match="holds no history of run 4"):
        StoredHistories({4: first})[4]

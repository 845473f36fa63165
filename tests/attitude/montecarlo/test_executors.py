"""Executors: a scenario that exits is a failed run, not the end of the campaign.

What each test checks against: the campaign's own rule (module docstring of
:mod:`attitude.montecarlo.executors`: "a task never raises because a scenario
raised"), applied to ``SystemExit`` (``sys.exit`` in a scenario, or a library
calling it), which is a ``BaseException`` and not an ``Exception``. Ctrl-C
(``KeyboardInterrupt``) still stops the campaign. And a history that cannot be stored without pickle
(an object array) is refused when the run returns it, so a checkpoint always resumes.

No worker process outlives its pool (module docstring, "Faults"): whichever way the pool ends
(normally, by an exception in the parent, by Ctrl-C), and when the parent itself is killed, every
worker is gone within a few seconds, read from the kernel's process table (``/proc/PID/stat``: a
zombie, dead but not yet reaped by its new parent, counts as gone).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from attitude.montecarlo.campaign import Campaign, run_campaign
from attitude.montecarlo.dispersions import Normal
from attitude.montecarlo.executors import Checkpoint, execute_task

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


# ---------------------------------------------------------------------------
# No pool worker outlives its campaign: every way out of the pool, and the parent's death.


def alive(pid: int) -> bool:
    """Whether process ``pid`` still runs (a zombie, dead but not yet reaped, does not)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return False
    return stat.rpartition(")")[2].split()[0] not in ("Z", "X")


def wait_until_gone(pids: list[int], timeout_s: float) -> list[int]:
    """The processes of ``pids`` still alive after waiting up to ``timeout_s`` for them to go."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and any(alive(p) for p in pids):
        time.sleep(0.05)
    return [p for p in pids if alive(p)]


def recorded_pids(directory: Path) -> list[int]:
    return sorted(int(p.name) for p in directory.iterdir())


class RecordsPid:
    """Leaves a file named after its worker's pid in ``directory``, then works ``sleep_s``."""

    fingerprint = "RecordsPid"

    def __init__(self, directory: Path, sleep_s: float) -> None:
        self.directory = str(directory)
        self.sleep_s = sleep_s

    def __call__(self, params, rng):
        Path(self.directory, str(os.getpid())).touch()
        time.sleep(self.sleep_s)
        return {"y": float(params["x"])}


needs_proc = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads process states from /proc")


@needs_proc
@pytest.mark.parametrize("way_out", ["normal", "exception", "ctrl-c"])
def test_no_worker_outlives_the_pool_whichever_way_it_ends(way_out, tmp_path, monkeypatch):
    """Normal end, an exception in the parent (a checkpoint that cannot be written), and Ctrl-C."""
    pids_dir = tmp_path / "pids"
    pids_dir.mkdir()
    append = Checkpoint.append
    calls = []

    def failing_append(self, records):  # the third task's records cannot be written
        calls.append(1)
        if len(calls) == 3 and way_out == "exception":
            raise OSError(28, "No space left on device")
        if len(calls) == 3 and way_out == "ctrl-c":
            raise KeyboardInterrupt
        append(self, records)

    monkeypatch.setattr(Checkpoint, "append", failing_append)
    campaign = Campaign(RecordsPid(pids_dir, 0.05), X, runs=12, seed=1)
    if way_out == "exception":
        # The traceback keeps the pool object alive, as it does in a notebook or a debugger.
        with pytest.raises(OSError, match="No space left") as excinfo:
            run_campaign(campaign, workers=2, out_dir=tmp_path / "out")
        assert excinfo.traceback
    else:
        result = run_campaign(campaign, workers=2, out_dir=tmp_path / "out")
        assert result.info["interrupted"] == (way_out == "ctrl-c")
    pids = recorded_pids(pids_dir)
    assert pids
    # Stopping a pool takes milliseconds; 5 s leaves room on a loaded machine.
    assert wait_until_gone(pids, 5.0) == []


def echo_x(params, rng):
    """A scenario returning its draw (module level, so worker processes can unpickle it)."""
    return {"x": params["x"]}


@pytest.mark.parametrize("workers", [1, 2])
def test_an_error_escaping_the_run_loop_closes_the_checkpoint_file(workers, tmp_path, monkeypatch):
    """The checkpoint's open file is closed and the runs written before the error stay readable.

    Before, ``run_campaign`` closed the checkpoint only after a normal end: an error escaping the
    executor left the file handle open for as long as the traceback lived.
    """
    append, close = Checkpoint.append, Checkpoint.close
    calls, closed = [], []

    def failing_append(self, records):  # the second task's records cannot be written
        calls.append(1)
        if len(calls) == 2:
            raise OSError(28, "No space left on device")
        append(self, records)

    def recording_close(self):
        closed.append(self._file is not None)  # True: there was an open file to close
        close(self)

    monkeypatch.setattr(Checkpoint, "append", failing_append)
    monkeypatch.setattr(Checkpoint, "close", recording_close)
    campaign = Campaign(echo_x, X, runs=4, seed=1)
    with pytest.raises(OSError, match="No space left"):
        run_campaign(campaign, workers=workers, out_dir=tmp_path / "out")
    assert closed == [True]
    monkeypatch.setattr(Checkpoint, "append", append)
    assert len(Checkpoint(tmp_path / "out", campaign.fingerprint()).load()) == 1  # the first task's run, on disk


KILLED_PARENT = """
import multiprocessing, os, sys, time
from pathlib import Path
import attitude.montecarlo.executors as executors
from attitude.montecarlo.campaign import Campaign, run_campaign
from attitude.montecarlo.dispersions import Normal


class Sleeps:
    fingerprint = "Sleeps"

    def __call__(self, params, rng):
        Path(sys.argv[1], str(os.getpid())).touch()
        time.sleep(60.0)  # a long run: the worker is busy when its parent dies
        return {"y": 0.0}


if __name__ == "__main__":
    if sys.argv[3] == "polling":  # as where the kernel offers neither a parent-death signal nor pidfds
        executors._set_parent_death_signal = lambda: False
        executors._open_pidfd = lambda pid: None
    elif sys.argv[3] == "pidfd":  # the watching thread alone
        executors._set_parent_death_signal = lambda: False
    campaign = Campaign(Sleeps(), {"x": Normal(0.0, 1.0)}, runs=4, seed=1)
    run_campaign(campaign, workers=2, mp_context=multiprocessing.get_context(sys.argv[2]))
"""


@needs_proc
@pytest.mark.slow
@pytest.mark.parametrize(
    ("method", "mechanism"),
    [("fork", "all"), ("fork", "pidfd"), ("fork", "polling"), ("forkserver", "all"), ("forkserver", "polling")],
)
def test_pool_workers_exit_when_the_parent_is_killed(method, mechanism, tmp_path):
    pids_dir = tmp_path / "pids"
    pids_dir.mkdir()
    script = tmp_path / "campaign.py"
    script.write_text(KILLED_PARENT)
    repo = str(Path(__file__).resolve().parents[3])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [repo, os.environ.get("PYTHONPATH")]))}
    parent = subprocess.Popen(
        [sys.executable, str(script), str(pids_dir), method, mechanism],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    pids: list[int] = []
    try:
        deadline = time.monotonic() + 60.0  # start-up and imports on a loaded machine
        while time.monotonic() < deadline and len(pids) < 2 and parent.poll() is None:
            time.sleep(0.05)
            pids = recorded_pids(pids_dir)
        assert len(pids) == 2, parent.stderr.read().decode() if parent.poll() is not None else "workers never ran"
        parent.send_signal(signal.SIGKILL)
        parent.wait(timeout=10)
        # The kernel and a pidfd act at once, polling within 0.25 s: 5 s leaves room on a loaded machine.
        assert wait_until_gone(pids, 5.0) == []
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()
        for pid in pids:  # on failure, leave no orphan behind
            if alive(pid):
                os.kill(pid, signal.SIGKILL)
        parent.stderr.close()

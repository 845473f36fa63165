"""Where the runs of a campaign execute: in process, in local processes, or on a Dask cluster.

Every executor runs the same task function, :func:`execute_task`, on a list
of ``(run, parameters)`` pairs: one pair per task for per-run execution, a
batch of pairs for the vectorised path (the scenario's ``run_batch``). A
task never raises because a scenario raised: the exception becomes an
``"error"`` record with its message, and the campaign goes on.

Faults
------
* **A run that raises**: recorded (status ``"error"``, the exception type and
  message, the run index and so its seed); the others continue. ``SystemExit``
  (``sys.exit`` in a scenario or in a library it calls) is a failed run too,
  recorded with its message or exit code; only ``KeyboardInterrupt`` stops
  the campaign.
* **A metric named like a column of the table** (``run``, ``seed``,
  ``status``, a dispersion's name or columns:
  :func:`attitude.montecarlo.results.check_metric_name`): the run is recorded
  as an error with the ``ValueError`` that names it, instead of silently
  replacing the column.
* **A worker process that dies** (segfault, out-of-memory kill,
  ``os._exit``): under :class:`concurrent.futures.ProcessPoolExecutor` every
  unfinished future fails with ``BrokenProcessPool``. The pool is rebuilt,
  and the tasks that were in flight (one of which killed the worker, but
  which one is unknown) are *quarantined*: each is retried alone in the new
  pool, so a task that kills its worker again is identified for certain.
  Only such a lone death counts as an attempt; after ``max_retries``
  further lone deaths the task's runs are recorded as errors ("worker
  died"). Tasks that never ran are simply resubmitted. Under Dask the
  scheduler reschedules the tasks of a dead worker itself (up to
  ``distributed.scheduler.allowed-failures`` deaths, then ``KilledWorker``,
  recorded as an error), and ``retries=max_retries`` is passed to
  ``Client.submit`` for tasks that fail for infrastructure reasons.
* **Ctrl-C** (``KeyboardInterrupt`` in the parent): pending tasks are
  cancelled, worker processes stopped, and the runs completed so far are
  returned (and were already appended to the checkpoint). Pool workers
  ignore SIGINT so that only the parent decides.
* **An exception in the parent** (a checkpoint that cannot be written, a
  pool that keeps breaking): the worker processes are stopped, as after
  Ctrl-C, and the exception propagates; no worker outlives ``run_processes``.
* **The parent process dies** (killed, crashed): its pool workers exit too,
  whatever the start method. On Linux the kernel kills them at once
  (``prctl(PR_SET_PDEATHSIG, SIGKILL)``, for fork and spawn); and a thread
  in each worker watches the campaign's process, through a pidfd where the
  kernel offers one (Linux >= 5.3: at once), else by polling every
  ``_PARENT_POLL_PERIOD_S`` (0.25 s), and exits the worker when it is gone.

Checkpoint
----------
With an output directory, every completed record is appended to
``checkpoint.jsonl`` (one JSON line per run, flushed at once; floats are
written with ``repr`` so they load back bit for bit), and the time histories
of a finished task's runs to one file, ``checkpoint_histories/runs_NNNNNN.npz``
(NNNNNN its first run; :mod:`attitude.montecarlo.histories`), written before
their lines, whose ``history`` names it. The campaign may then let the
histories go from memory (:class:`Collector`, ``keep_histories=False``) and
read them back from these files. The first line holds the campaign
fingerprint, and what it hashes part by part (the seed, each dispersion, the
scenario's identity, the mode); a later campaign with the same fingerprint in
the same directory skips the runs found there, except those lost to a dead
worker or a failed cluster task, which are run again. A campaign with another
fingerprint is refused, naming the parts that differ (the run count is not
one: a longer campaign resumes a shorter one's runs, which are its first).

Progress
--------
:class:`Progress` is a tqdm bar on stderr (:func:`attitude.progress.progress_bar`:
drawn on a terminal only unless asked) of the runs completed, with the
errors, elapsed time and ETA; a resumed campaign's bar starts at the runs
found in the checkpoint. A vectorised task's runs all finish together, so
its bar also counts the runs simulated so far of the batches in flight:
``run_batch`` is given a ``progress`` callable (when it has that keyword)
that it calls with the fraction of the batch simulated, at most every
``REFRESH_PERIOD_S``. In this process the call moves the bar; in a pool
worker it writes the fraction into the task's slot of a table of doubles in
shared memory, which the parent reads when it wakes to redraw the bar (as
often). On a Dask cluster the bar moves as tasks finish. The bar never
touches the runs' numbers: a campaign's table is the same with and without it.
"""

from __future__ import annotations

import ctypes
import inspect
import json
import math
import multiprocessing
import os
import pickle
import select
import signal
import sys
import threading
import time
import uuid
from collections import defaultdict, deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from attitude.montecarlo.dispersions import scenario_generator
from attitude.montecarlo.histories import StoredHistories, write_histories
from attitude.progress import REFRESH_PERIOD_S, progress_bar

__all__ = [
    "CHECKPOINT_FILE",
    "Checkpoint",
    "Progress",
    "RunOutput",
    "RunRecord",
    "execute_task",
    "run_dask",
    "run_processes",
    "run_serial",
]

#: Name of the checkpoint file in a campaign's output directory.
CHECKPOINT_FILE = "checkpoint.jsonl"
#: Error messages of runs lost to the infrastructure, not to the scenario: redone on resume.
WORKER_DIED = "worker process died"
CLUSTER_FAILED = "task failed on the cluster"
_HISTORY_DIR = "checkpoint_histories"
#: Format of the checkpoint (its header's ``format``): 2 names each run's history file (1: one file per run).
_CHECKPOINT_FORMAT = 2
#: Fewest tasks kept in flight on a Dask cluster (``run_dask``); more with more worker threads.
_DASK_WINDOW_MIN = 256

Task = list[tuple[int, dict[str, Any]]]


@dataclass
class RunOutput:
    """What a scenario returns for one run.

    Attributes
    ----------
    metrics : dict of float
        Scalar results (SI units; the name should say which, e.g.
        ``settling_time`` [s]).
    history : dict of ndarray, optional
        Time histories (``"t"`` [s] plus any series whose first axis is time).
    error : str, optional
        Set by a batch scenario for a run that failed inside the batch (e.g.
        diverged); the run is recorded as an error.
    """

    metrics: dict[str, float] = field(default_factory=dict)
    history: dict[str, np.ndarray] | None = None
    error: str | None = None


@dataclass
class RunRecord:
    """The outcome of one run, as stored in the table and the checkpoint.

    Parameters
    ----------
    run : int
        Run index.
    status : str
        ``"ok"`` or ``"error"``.
    metrics : dict of float
        Scalar results of the run (SI units).
    error : str, optional
        The exception type and message of a failed run.
    attempts : int, optional
        Number of attempts the run took.
    cpu_s : float, optional
        CPU time of the run [s].
    wall_s : float, optional
        Wall-clock time of the run [s].
    history : dict of ndarray, optional
        Time histories of the run (``"t"`` [s] plus series whose first axis is time).
    """

    run: int
    status: str  # "ok" or "error"
    metrics: dict[str, float]
    error: str = ""
    attempts: int = 1
    cpu_s: float = math.nan
    wall_s: float = math.nan
    history: dict[str, np.ndarray] | None = None

    def to_json(self, history_file: str | None = None) -> str:
        """The record as one JSON line of the checkpoint (``history``: the file holding its history, or null).

        Parameters
        ----------
        history_file : str, optional
            Name of the file of ``checkpoint_histories/`` that holds the run's history.
        """
        return json.dumps(
            {
                "run": self.run,
                "status": self.status,
                "metrics": self.metrics,
                "error": self.error,
                "attempts": self.attempts,
                "cpu_s": self.cpu_s,
                "wall_s": self.wall_s,
                "history": history_file,
            }
        )


def _as_output(value: Any) -> RunOutput:
    if isinstance(value, RunOutput):
        out = value
    elif isinstance(value, Mapping):
        out = RunOutput(dict(value))
    else:
        raise ValueError(
            f"the scenario must return a RunOutput or a mapping of metric names to floats, got {type(value).__name__}"
        )
    metrics = {}
    for key, v in out.metrics.items():
        if not isinstance(key, str) or not key:
            raise ValueError(f"metric names must be non-empty strings, got {key!r}")
        try:
            metrics[key] = float(v)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"metric {key!r} must be a float, got {v!r}") from exc
    history = None
    if out.history is not None:
        history = {str(k): np.asarray(v) for k, v in out.history.items()}
        for key, v in history.items():
            # Checkpoints store histories without pickle (safe to load): object arrays cannot go there.
            if v.dtype.kind not in "biufcUS":
                raise ValueError(
                    f"history[{key!r}] must be an array of numbers, booleans or strings (histories are stored "
                    f"without pickle), got dtype {v.dtype}"
                )
    return RunOutput(metrics, history, out.error)


def _describe_error(exc: BaseException) -> str:
    if isinstance(exc, SystemExit) and not isinstance(exc.code, str):
        text = f"SystemExit: exit code {exc.code}"  # str(SystemExit()) is empty, str(SystemExit(3)) a bare "3"
    else:
        text = f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def _identity(value: Any) -> Any:
    return value


def execute_task(
    scenario: Any, seed: int, items: Task, vectorized: bool, report: Callable[[float], None] | None = None
) -> list[RunRecord]:
    """Run the runs of one task and return their records (never raises for a scenario error).

    Parameters
    ----------
    scenario : callable or object
        ``scenario(params, rng) -> RunOutput | mapping``; with ``vectorized``,
        ``scenario.run_batch(params_list, rngs) -> list[RunOutput]``.
    seed : int
        The campaign's master seed (each run's generator comes from it and the run index).
    items : list of (run, params)
        The runs of the task.
    vectorized : bool
        Run the items together with ``run_batch``.
    report : callable, optional
        ``report(fraction)``: passed to ``run_batch`` as its ``progress``
        keyword when it has one, for the fraction of the batch simulated
        (the progress bar of a vectorised campaign). Not used per run.
    """
    if vectorized:
        return _execute_batch(scenario, seed, items, report)
    records = []
    for run, params in items:
        cpu0, wall0 = time.process_time(), time.perf_counter()
        try:
            out = _as_output(scenario(params, scenario_generator(seed, run)))
            status, error = ("error", out.error) if out.error else ("ok", "")
            record = RunRecord(run, status, out.metrics, error, history=out.history)
        except (Exception, SystemExit) as exc:  # a failing run is data, not a crash of the campaign
            # SystemExit too: a scenario (or a library) calling sys.exit fails its run, not the campaign.
            # KeyboardInterrupt is left to propagate: Ctrl-C means stop.
            record = RunRecord(run, "error", {}, _describe_error(exc))
        record.cpu_s = time.process_time() - cpu0
        record.wall_s = time.perf_counter() - wall0
        records.append(record)
    return records


def _takes_progress(run_batch: Any) -> bool:
    """True when ``run_batch`` has a ``progress`` parameter (the optional keyword of the scenario protocol)."""
    try:
        return "progress" in inspect.signature(run_batch).parameters
    except (TypeError, ValueError):  # no signature to read (a C callable): call it without
        return False


def _execute_batch(scenario: Any, seed: int, items: Task, report: Callable[[float], None] | None) -> list[RunRecord]:
    cpu0, wall0 = time.process_time(), time.perf_counter()
    runs = [run for run, _ in items]
    try:
        extra = {"progress": report} if report is not None and _takes_progress(scenario.run_batch) else {}
        outputs = scenario.run_batch([p for _, p in items], [scenario_generator(seed, r) for r in runs], **extra)
        outputs = [_as_output(o) for o in outputs]
        if len(outputs) != len(items):
            raise ValueError(f"run_batch returned {len(outputs)} outputs for {len(items)} runs")
    except (Exception, SystemExit) as exc:  # as in execute_task: only KeyboardInterrupt stops the campaign
        message = "batch failed: " + _describe_error(exc)
        outputs = [RunOutput({}, None, message) for _ in items]
    cpu = (time.process_time() - cpu0) / len(items)
    wall = (time.perf_counter() - wall0) / len(items)
    return [
        RunRecord(run, "error" if out.error else "ok", out.metrics, out.error or "", 1, cpu, wall, out.history)
        for run, out in zip(runs, outputs)
    ]


# ---------------------------------------------------------------------------
# Progress and checkpoint


class Progress:
    """The campaign's progress bar on stderr (tqdm, :func:`attitude.progress.progress_bar`): runs done, errors, ETA.

    Parameters
    ----------
    total : int
        Number of runs of the campaign.
    enabled : bool or None
        True: draw the bar; False: stay silent; None: draw it when the stream is a terminal.
    stream : text stream, optional
        Where to draw (default ``sys.stderr``).
    initial : int, optional
        Runs already done (resumed from a checkpoint): the bar starts there,
        and its rate and ETA count only the runs done after.
    """

    def __init__(self, total: int, enabled: bool | None, stream: TextIO | None = None, initial: int = 0) -> None:
        self.total = total
        self.done: float = initial
        self.errors = 0
        self._bar = progress_bar(
            total,
            desc="Monte Carlo",
            unit="run",
            enabled=enabled if total > 0 else False,
            initial=initial,
            postfix="0 errors",
            file=stream,
        )

    @property
    def enabled(self) -> bool:
        """True when the bar is drawn."""
        return not self._bar.disable

    def update(self, done: float, errors: int, force: bool = False) -> None:
        """Record the progress and redraw the bar (at most every ``REFRESH_PERIOD_S`` unless ``force``).

        Parameters
        ----------
        done : float
            Runs completed so far, plus the fraction simulated of the batches
            in flight (shown as whole runs).
        errors : int
            Runs that failed so far.
        force : bool, optional
            Redraw now, whatever the time since the last redraw.
        """
        if errors != self.errors:
            self._bar.set_postfix_str(f"{errors} errors", refresh=False)
        self.done, self.errors = done, errors
        self._bar.update(math.floor(done) - self._bar.n)
        if force:
            self._bar.refresh()

    def close(self) -> None:
        """Draw the final state and end the bar's line."""
        self._bar.close()


class Checkpoint:
    """Append-only record of completed runs in ``out_dir`` (module docstring).

    Parameters
    ----------
    out_dir : path
        The campaign's output directory (created).
    fingerprint : str or None
        Identity of the campaign; a checkpoint written by another campaign
        raises ValueError instead of being mixed in. None: the campaign cannot
        be identified, so it may start a checkpoint but never resume one.
    unidentified : str, optional
        Why the campaign cannot be identified (with ``fingerprint=None``), for the refusal.
    identity : mapping, optional
        What the fingerprint hashes, part by part (``seed``, ``dispersions``
        name -> description, ``scenario``, ``vectorized``: JSON values), kept in
        the header so that a refusal says which part differs.
    """

    def __init__(
        self,
        out_dir: str | Path,
        fingerprint: str | None,
        unidentified: str = "",
        identity: Mapping[str, Any] | None = None,
    ) -> None:
        self.dir = Path(out_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.path = self.dir / CHECKPOINT_FILE
        self.fingerprint = fingerprint
        self.unidentified = unidentified
        self.identity = None if identity is None else dict(identity)
        #: Run -> the file of ``checkpoint_histories/`` holding its history (the runs loaded and appended).
        self.history_files: dict[int, Path] = {}
        self._file: TextIO | None = None

    def load(self, read_histories: bool = True) -> dict[int, RunRecord]:
        """Records already in the checkpoint (a torn last line, from a crash mid-write, is ignored).

        A record whose history file is missing is left out (the run is done again).

        Parameters
        ----------
        read_histories : bool, optional
            Read the runs' histories into their records; False leaves them in
            their files (:attr:`history_files`; the records' ``history`` None).
        """
        if not self.path.exists():
            return {}
        records: dict[int, RunRecord] = {}
        with self.path.open() as f:
            lines = f.read().splitlines()
        if not lines:
            return {}
        try:
            header = json.loads(lines[0])
        except json.JSONDecodeError:
            header = {}
        if self.fingerprint is None:
            raise ValueError(
                f"out_dir {str(self.dir)!r} holds a checkpoint, but this campaign cannot resume it: its scenario "
                f"cannot be identified by its content ({self.unidentified}), so its runs could be mixed with those "
                "of another scenario; give the scenario a `fingerprint` string attribute that names its code and "
                "settings, or use resume=False to start afresh"
            )
        if not isinstance(header, dict) or header.get("fingerprint") != self.fingerprint:
            differs = _what_differs(header, self.identity)
            raise ValueError(
                f"out_dir {str(self.dir)!r} holds the checkpoint of a different campaign{differs}; use another "
                "out_dir, or resume=False to start afresh"
            )
        files: dict[int, Path] = {}
        for line in lines[1:]:
            try:
                d = json.loads(line)
            except json.JSONDecodeError:
                continue
            run = d["run"]
            if d.get("history"):
                # A file name; True in a checkpoint of format 1, whose files held one run each.
                name = d["history"]
                path = self._history_path(run) if name is True else self.dir / _HISTORY_DIR / str(name)
                if (name is not True and Path(str(name)).name != name) or not path.exists():
                    records.pop(run, None)
                    files.pop(run, None)
                    continue  # the run's history was lost: redo the run
                files[run] = path
            else:
                files.pop(run, None)
            records[run] = RunRecord(run, d["status"], d["metrics"], d["error"], d["attempts"], d["cpu_s"], d["wall_s"])
        self.history_files.update(files)
        if read_histories:
            stored = StoredHistories(files)  # in run order: each file is opened once
            for run in stored:
                records[run].history = stored[run]
            stored.close()
        return records

    def start(self, resume: bool) -> None:
        """Open for appending; without ``resume`` (or no file yet) start a new file with the header.

        Parameters
        ----------
        resume : bool
            Keep the runs already in a checkpoint of the same campaign.
        """
        if resume and self.path.exists() and self.path.stat().st_size > 0:
            self._file = self.path.open("a")
            return
        self._file = self.path.open("w")
        header: dict[str, Any] = {"fingerprint": self.fingerprint, "format": _CHECKPOINT_FORMAT}
        if self.fingerprint is None:
            header["unidentified"] = self.unidentified
        if self.identity is not None:
            header["identity"] = self.identity
        self._file.write(json.dumps(header) + "\n")
        self._file.flush()

    def _history_path(self, run: int) -> Path:
        return self.dir / _HISTORY_DIR / f"run_{run:06d}.npz"

    def append(self, records: Iterable[RunRecord]) -> None:
        """Append completed records to the checkpoint, flushed at once; their histories go to one file first.

        Parameters
        ----------
        records : iterable of RunRecord
            The completed runs (a finished task's).
        """
        assert self._file is not None
        records = list(records)
        kept = [r for r in records if r.history is not None]
        name = None
        if kept:
            # Before the lines that name it: a line on disk always has its history.
            name = f"runs_{min(r.run for r in kept):06d}.npz"
            path = self.dir / _HISTORY_DIR / name
            path.parent.mkdir(exist_ok=True)
            write_histories(path, ((r.run, r.history) for r in kept))
            self.history_files.update(dict.fromkeys((r.run for r in kept), path))
        for r in records:
            self._file.write(r.to_json(None if r.history is None else name) + "\n")
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


#: Characters shown on each side of the first difference between two long descriptions (a refused checkpoint).
_DIFFERENCE_CONTEXT = 40


def _what_differs(header: Any, identity: Mapping[str, Any] | None) -> str:
    """What tells a checkpoint's campaign from this one, as the end of the refusal's first clause."""
    if isinstance(header, dict) and header.get("fingerprint") is None and "unidentified" in header:
        return (
            f": its scenario could not be identified by its content when it was written ({header['unidentified']}), "
            "so nothing says it is this one"
        )
    old = header.get("identity") if isinstance(header, dict) else None
    if not isinstance(old, dict) or identity is None:  # a checkpoint written before its header kept the parts
        return " (other seed, dispersions, scenario code or parameters, or mode)"
    parts = []
    if old.get("seed") != identity.get("seed"):
        parts.append(f"the seed ({old.get('seed')!r} in the checkpoint, {identity.get('seed')!r} now)")
    vectorized = (old.get("vectorized"), identity.get("vectorized"))
    if vectorized[0] != vectorized[1]:
        modes = ["vectorized (run_batch)" if v else "per run" for v in vectorized]
        parts.append(f"the mode ({modes[0]} in the checkpoint, {modes[1]} now)")
    before, after = old.get("dispersions") or {}, identity.get("dispersions") or {}
    for name in sorted(set(before) | set(after)):
        if name not in after:
            parts.append(f"the dispersion {name!r} (in the checkpoint only)")
        elif name not in before:
            parts.append(f"the dispersion {name!r} (new)")
        elif before[name] != after[name]:
            was, now = _first_difference(str(before[name]), str(after[name]))
            parts.append(f"the dispersion {name!r} ({was} in the checkpoint, {now} now)")
    if old.get("scenario") != identity.get("scenario"):
        parts.append(_scenario_difference(str(old.get("scenario")), str(identity.get("scenario"))))
    if not parts:
        return " (other seed, dispersions, scenario code or parameters, or mode)"
    return ": it differs in " + (parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1])


def _scenario_difference(was: str, now: str) -> str:
    """How two scenario identities (a ``fingerprint`` string, or ``"content "`` and a digest) differ."""
    content = "content "
    if was.startswith(content) and now.startswith(content):
        return "the scenario's code or the values it holds (identified by its content)"
    if was.startswith(content) != now.startswith(content):
        how = ["its content" if x.startswith(content) else "its `fingerprint`" for x in (was, now)]
        return f"the scenario (identified by {how[0]} in the checkpoint, by {how[1]} now)"
    was, now = _first_difference(was, now)
    return f"the scenario's fingerprint ({was} in the checkpoint, {now} now)"


def _first_difference(was: str, now: str) -> tuple[str, str]:
    """The two texts quoted around their first difference (``...`` where cut)."""
    first = next((i for i, (a, b) in enumerate(zip(was, now)) if a != b), min(len(was), len(now)))
    start = max(0, first - _DIFFERENCE_CONTEXT)

    def cut(text: str) -> str:
        end = first + _DIFFERENCE_CONTEXT
        return ("..." if start else "") + repr(text[start:end])[1:-1] + ("..." if end < len(text) else "")

    return f"'{cut(was)}'", f"'{cut(now)}'"


class Collector:
    """Gathers records as tasks finish: progress bar and checkpoint.

    The bar counts the completed runs; a vectorised campaign's bar also
    counts the runs simulated so far of the batches in flight (their runs
    times the fraction of their ticks done, :meth:`in_flight`), since the
    runs of a batch all finish together.

    Parameters
    ----------
    progress : Progress
        The progress bar.
    checkpoint : Checkpoint or None
        Where completed records are appended.
    records : dict of int to RunRecord
        Records already complete (resumed); completed ones are added to it.
    check_metric : callable, optional
        ``check_metric(name)`` raises ValueError for a metric name the table
        reserves; a run that returns one is recorded as an error with that
        message (module docstring).
    keep_histories : bool, optional
        Keep each record's history in memory (default). False (needs a
        checkpoint): once the checkpoint has written a task's histories to
        its file, the records let them go (``history`` None), so memory does
        not grow with them; they stay in ``checkpoint.history_files``.
    """

    def __init__(
        self,
        progress: Progress,
        checkpoint: Checkpoint | None,
        records: dict[int, RunRecord],
        check_metric: Callable[[str], None] | None = None,
        keep_histories: bool = True,
    ) -> None:
        if not keep_histories and checkpoint is None:
            raise ValueError("keep_histories=False needs a checkpoint: the histories would be lost")
        self.progress = progress
        self.checkpoint = checkpoint
        self.records = records
        self.check_metric = check_metric
        self.keep_histories = keep_histories
        self.errors = sum(r.status != "ok" for r in records.values())
        self.progress.update(len(records), self.errors)

    def reporter(self, runs: int) -> Callable[[float], None] | None:
        """The ``report(fraction)`` of a batch of ``runs`` runs simulated in this process (None: no bar drawn).

        Parameters
        ----------
        runs : int
            Runs of the batch.
        """
        if not self.progress.enabled:
            return None
        return lambda fraction: self.in_flight(fraction * runs)

    def in_flight(self, runs: float) -> None:
        """Show on the bar the runs simulated so far of the tasks still running.

        Parameters
        ----------
        runs : float
            Sum over the tasks in flight of their runs times the fraction of them simulated.
        """
        self.progress.update(len(self.records) + runs, self.errors)

    def _checked(self, record: RunRecord) -> RunRecord:
        if self.check_metric is None:
            return record
        try:
            for name in record.metrics:
                self.check_metric(name)
        except ValueError as exc:
            return RunRecord(
                record.run, "error", {}, _describe_error(exc), record.attempts, record.cpu_s, record.wall_s
            )
        return record

    def add(self, records: Sequence[RunRecord], attempts: int = 1, in_flight: float = 0.0) -> None:
        """Record completed runs: table, checkpoint and progress bar.

        Parameters
        ----------
        records : sequence of RunRecord
            The runs of a finished task.
        attempts : int, optional
            Attempts the task took.
        in_flight : float, optional
            Runs simulated so far of the tasks still running (:meth:`in_flight`).
        """
        records = [self._checked(r) for r in records]
        for r in records:
            r.attempts = attempts
            self.records[r.run] = r
            self.errors += r.status != "ok"
        if self.checkpoint is not None:
            self.checkpoint.append(records)
            if not self.keep_histories:
                for r in records:
                    r.history = None  # on disk now (checkpoint.history_files)
        self.progress.update(len(self.records) + in_flight, self.errors)


# ---------------------------------------------------------------------------
# Executors. Each returns True when it was interrupted (Ctrl-C).


def run_serial(scenario: Any, seed: int, tasks: Sequence[Task], vectorized: bool, collector: Collector) -> bool:
    """Run every task in this process, in order.

    Parameters
    ----------
    scenario : object
        The campaign's scenario.
    seed : int
        The campaign seed.
    tasks : sequence of Task
        Lists of ``(run, parameters)`` pairs, one list per task.
    vectorized : bool
        Run each task through the scenario's ``run_batch``.
    collector : Collector
        Receives the records (progress bar, checkpoint).
    """
    try:
        for task in tasks:
            report = collector.reporter(len(task)) if vectorized else None
            collector.add(execute_task(scenario, seed, task, vectorized, report))
    except KeyboardInterrupt:
        return True
    return False


class _TaskQueue:
    """Indices ``0 .. n - 1`` in order, with a few handed back to the front; O(1) memory in ``n``.

    Parameters
    ----------
    n : int
        Number of tasks.
    """

    def __init__(self, n: int) -> None:
        self._next = 0
        self._n = n
        self._back: deque[int] = deque()

    def __bool__(self) -> bool:
        return bool(self._back) or self._next < self._n

    def popleft(self) -> int:
        """The next index (IndexError when none is left)."""
        if self._back:
            return self._back.popleft()
        if self._next >= self._n:
            raise IndexError("pop from an empty task queue")
        self._next += 1
        return self._next - 1

    def appendleft(self, i: int) -> None:
        """Hand index ``i`` back: it comes out next.

        Parameters
        ----------
        i : int
            A task index taken from this queue.
        """
        self._back.appendleft(i)


_WORKER_SCENARIO: Any = None
#: A pool worker's view of the shared table of the fraction simulated of each task in flight (None: no bar).
_WORKER_FRACTIONS: Any = None


#: How often a pool worker checks that its parent is still alive [s] (the bound on an orphan's life
#: where the kernel cannot be asked to kill it).
_PARENT_POLL_PERIOD_S = 0.25
_PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def _set_parent_death_signal() -> bool:
    """Linux: have the kernel SIGKILL this process when its parent dies. True when it was set.

    The signal follows the parent *thread* that started the worker: the pool's workers are started by the
    thread that runs the campaign (``submit``), which outlives the pool.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):  # no libc with prctl (another C library): the watcher alone
        return False


def _open_pidfd(pid: int) -> int | None:
    """A file descriptor that becomes readable when process ``pid`` exits (Linux >= 5.3), else None.

    Raises ProcessLookupError when the process is already gone.
    """
    if not hasattr(os, "pidfd_open"):
        return None
    try:
        return os.pidfd_open(pid)
    except ProcessLookupError:
        raise
    except OSError:  # an older kernel, or a sandbox that forbids the call: poll instead
        return None


def _parent_gone(parent_pid: int, ppid: int) -> bool:
    if os.getppid() != ppid:  # reparented: the process that started this one died
        return True
    if ppid != parent_pid and os.name == "posix":  # started by a fork server: probe the campaign's process
        try:
            os.kill(parent_pid, 0)  # (on Windows this would kill, not probe)
        except ProcessLookupError:
            return True
        except PermissionError:
            pass
    return False


def _watch_parent(parent_pid: int, ppid: int, pidfd: int | None) -> None:
    if pidfd is not None:
        select.select([pidfd], [], [])  # returns when the parent exits
        os._exit(1)
    while not _parent_gone(parent_pid, ppid):
        time.sleep(_PARENT_POLL_PERIOD_S)
    os._exit(1)


def _exit_with_parent(parent_pid: int) -> None:
    """Make this worker exit when the campaign's process dies (killed, crashed): never an orphan asleep.

    Two mechanisms, as neither covers every case alone. The kernel's parent-death signal (Linux) acts at
    once, even while a run holds the GIL in C code, but follows the process that started the worker,
    which under forkserver is the fork server, and that server outlives the campaign's process for as
    long as its workers live. So a daemon thread also watches the campaign's process itself: it waits on
    a pidfd where the kernel has them, else it polls every ``_PARENT_POLL_PERIOD_S`` whether this worker was
    reparented or the campaign's process is gone, and exits the worker.

    Parameters
    ----------
    parent_pid : int
        Process id of the campaign's process.
    """
    _set_parent_death_signal()
    ppid = os.getppid()
    try:
        pidfd = _open_pidfd(parent_pid)
    except ProcessLookupError:  # died before this worker could watch it
        os._exit(1)
    if _parent_gone(parent_pid, ppid):
        os._exit(1)
    threading.Thread(
        target=_watch_parent, args=(parent_pid, ppid, pidfd), name="attitude-watch-parent", daemon=True
    ).start()


def _init_worker(payload: bytes, parent_pid: int, fractions: Any = None) -> None:
    global _WORKER_SCENARIO, _WORKER_FRACTIONS
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    _exit_with_parent(parent_pid)
    _WORKER_SCENARIO = pickle.loads(payload)
    _WORKER_FRACTIONS = fractions


def _pool_task(seed: int, items: Task, vectorized: bool, slot: int | None = None) -> list[RunRecord]:
    report = None
    if slot is not None and _WORKER_FRACTIONS is not None:
        fractions = _WORKER_FRACTIONS

        def report(fraction: float) -> None:
            fractions[slot] = fraction  # one double in shared memory, read by the parent for its bar

    return execute_task(_WORKER_SCENARIO, seed, items, vectorized, report)


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    processes = list(getattr(pool, "_processes", {}).values())  # private, but the only handle on the workers
    pool.shutdown(wait=False, cancel_futures=True)
    for p in processes:
        if p.is_alive():
            p.terminate()
    for p in processes:
        p.join(timeout=5)


def run_processes(
    scenario: Any,
    seed: int,
    tasks: Sequence[Task],
    vectorized: bool,
    collector: Collector,
    *,
    workers: int,
    max_retries: int,
    mp_context: Any,
) -> bool:
    """Run the tasks in a pool of ``workers`` local processes (faults: module docstring).

    Parameters
    ----------
    scenario : object
        The campaign's scenario (picklable).
    seed : int
        The campaign seed.
    tasks : sequence of Task
        Lists of ``(run, parameters)`` pairs, one list per task.
    vectorized : bool
        Run each task through the scenario's ``run_batch``.
    collector : Collector
        Receives the records (progress bar, checkpoint).
    workers : int
        Number of worker processes, >= 1.
    max_retries : int
        Lone deaths of a worker a task may cause before its runs are recorded as errors, >= 0.
    mp_context : multiprocessing context or None
        Start method of the workers (None: the platform default).
    """
    try:
        payload = pickle.dumps(scenario)
    except Exception as exc:
        raise ValueError(
            "the scenario must be picklable to run in worker processes (define it at module level, not as a "
            f"lambda or a local function), or use workers=1: {_describe_error(exc)}"
        ) from exc

    limit = 2 * workers
    # The progress of the batches in flight (a vectorised campaign with a bar): each task gets a slot of a
    # table in shared memory where its worker writes the fraction of its batch simulated (at most every
    # REFRESH_PERIOD_S), and the parent, woken as often, shows the sum on the bar. A slot is cleared when
    # its task ends or is lost, so a dead worker's last value is never counted.
    fractions = None
    if vectorized and collector.progress.enabled:
        fractions = (mp_context or multiprocessing.get_context()).RawArray("d", limit)
    free_slots = list(range(limit))
    slots: dict[Future, tuple[int | None, int]] = {}  # future -> (its slot, its runs)

    def new_pool() -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            workers, mp_context=mp_context, initializer=_init_worker, initargs=(payload, os.getpid(), fractions)
        )

    def release(fut: Future) -> None:
        slot, _ = slots.pop(fut)
        if slot is not None:
            fractions[slot] = 0.0
            free_slots.append(slot)

    def running() -> float:
        if fractions is None:
            return 0.0
        return sum(fractions[slot] * runs for slot, runs in slots.values() if slot is not None)

    # Task indices are handed out by a counter (and a deque of the few handed back), not a deque of
    # every index: memory must not grow with the run count before the runs start (tasks is lazy).
    queue = _TaskQueue(len(tasks))
    suspects: deque[int] = deque()
    lone_deaths: defaultdict[int, int] = defaultdict(int)  # only the tasks whose worker died
    in_flight: dict[Future, int] = {}
    pool = new_pool()
    empty_breaks = 0

    def submit(i: int) -> bool:
        task = tasks[i]
        slot = None
        if fractions is not None:
            slot = free_slots.pop()
            fractions[slot] = 0.0
        try:
            fut = pool.submit(_pool_task, seed, task, vectorized, slot)
        except BrokenProcessPool:  # a worker died since the last look
            if slot is not None:
                free_slots.append(slot)
            return False
        in_flight[fut] = i
        slots[fut] = (slot, len(task))
        return True

    finished = False
    try:
        while queue or suspects or in_flight:
            healthy = True
            if suspects:
                if not in_flight:  # a suspect runs alone, so a death is its own
                    i = suspects.popleft()
                    if not submit(i):
                        suspects.appendleft(i)
                        healthy = False
            else:
                while healthy and queue and len(in_flight) < limit:
                    i = queue.popleft()
                    if not submit(i):
                        queue.appendleft(i)
                        healthy = False
            broken: list[int] = []
            if healthy:
                # With a bar, wake up to redraw it (elapsed time, batches in flight) even while no task ends.
                timeout = REFRESH_PERIOD_S if collector.progress.enabled else None
                done, _ = wait(list(in_flight), timeout=timeout, return_when=FIRST_COMPLETED)
                for fut in done:
                    i = in_flight.pop(fut)
                    release(fut)
                    try:
                        collector.add(fut.result(), attempts=lone_deaths[i] + 1, in_flight=running())
                    except BrokenProcessPool:
                        broken.append(i)
                if not done:
                    collector.in_flight(running())
            if broken or not healthy:
                # Every unfinished future of a broken pool fails: collect them all.
                for fut in list(slots):
                    release(fut)
                for fut, i in list(in_flight.items()):
                    try:
                        collector.add(fut.result(), attempts=lone_deaths[i] + 1)
                    except BrokenProcessPool:
                        broken.append(i)
                in_flight.clear()
                pool.shutdown(wait=True)
                empty_breaks = 0 if broken else empty_breaks + 1
                if empty_breaks > max_retries + 2:
                    raise RuntimeError(
                        "the worker pool keeps breaking before any task runs: can a fresh worker process import the "
                        "scenario (and run the initializer)? Try workers=1 to see the error"
                    )
                if len(broken) == 1:  # it was the only unfinished task: the death is its own
                    i = broken[0]
                    lone_deaths[i] += 1
                    if lone_deaths[i] > max_retries:
                        message = f"{WORKER_DIED} on each of {lone_deaths[i]} attempts"
                        collector.add(
                            [RunRecord(run, "error", {}, message) for run, _ in tasks[i]], attempts=lone_deaths[i]
                        )
                    else:
                        suspects.appendleft(i)
                else:
                    suspects.extend(sorted(broken))
                pool = new_pool()
        pool.shutdown(wait=True)
        finished = True
    except KeyboardInterrupt:
        return True
    finally:
        # Every other way out (Ctrl-C, a checkpoint that cannot be written, a pool that keeps breaking,
        # any exception) stops the workers: left running, they would finish their queued tasks and then
        # wait for work as long as the pool object lives (a traceback keeps it).
        if not finished:
            _stop_pool(pool)
    return False


def run_dask(
    scenario: Any,
    seed: int,
    tasks: Sequence[Task],
    vectorized: bool,
    collector: Collector,
    *,
    scheduler: Any,
    max_retries: int,
) -> bool:
    """Run the tasks on a Dask cluster: ``scheduler`` is an address ``"tcp://HOST:PORT"`` or a ``Client``.

    Parameters
    ----------
    scenario : object
        The campaign's scenario (``scenario(params, rng)``, optionally ``run_batch``).
    seed : int
        The campaign seed.
    tasks : sequence of Task
        Lists of ``(run, parameters)`` pairs, one list per task.
    vectorized : bool
        Run each task through the scenario's ``run_batch``.
    collector : Collector
        Receives the records (progress bar, checkpoint).
    scheduler : str or distributed.Client
        Address ``"tcp://HOST:PORT"`` of the scheduler, or a client.
    max_retries : int
        Retries of a task that fails for infrastructure reasons, >= 0.
    """
    try:
        from distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "a Dask scheduler needs the 'distributed' package: pip install 'attitude-toolkit[cluster]'"
        ) from exc
    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else scheduler
    tag = uuid.uuid4().hex[:8]
    futures: dict[Any, Task] = {}
    try:
        # The scenario (a planned slew, a spacecraft) goes to the cluster once, not once per task, as the
        # result of a task: unlike scattered data, the scheduler can compute it again if every worker
        # holding it dies.
        shared = client.submit(_identity, scenario, pure=False, key=f"attitude-montecarlo-{tag}-scenario")
        # A window of tasks in flight, not every task at once: submitting all of them would draw every run's
        # parameters and hold a future per task (here and on the scheduler) before the first run completes,
        # so memory would grow with the run count. The window keeps each worker thread busy with a few
        # queued tasks; its floor covers workers that join later.
        window = max(_DASK_WINDOW_MIN, 4 * sum(client.nthreads().values()))
        pending = as_completed()
        next_task = 0

        def submit_next() -> None:
            nonlocal next_task
            task = tasks[next_task]
            next_task += 1
            fut = client.submit(
                execute_task,
                shared,
                seed,
                task,
                vectorized,
                key=f"attitude-montecarlo-{tag}-{task[0][0]}",
                pure=False,
                retries=max_retries,
            )
            futures[fut] = task
            pending.add(fut)

        while next_task < len(tasks) and len(futures) < window:
            submit_next()
        for fut in pending:
            task = futures.pop(fut)
            try:
                collector.add(fut.result())
            except Exception as exc:  # KilledWorker, lost data, cancelled ...
                message = f"{CLUSTER_FAILED}: {_describe_error(exc)}"
                collector.add([RunRecord(run, "error", {}, message) for run, _ in task])
            if next_task < len(tasks):
                submit_next()
    except KeyboardInterrupt:
        client.cancel(list(futures))
        return True
    finally:
        if own:
            client.close()
    return False

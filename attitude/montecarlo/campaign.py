"""Monte Carlo campaigns: dispersed closed-loop runs, locally, vectorised, or on a Dask cluster.

A :class:`Campaign` is a *scenario* (what one run does), *dispersions* (how
its parameters are drawn, :mod:`attitude.montecarlo.dispersions`), a number
of runs, a master seed and the *requirements* each run must meet.
:func:`run_campaign` executes it and returns a :class:`CampaignResult`
(:mod:`attitude.montecarlo.results`): a tidy table with one row per run
(index, seed and spawn key, status, dispersed parameters, metrics, pass/fail
per requirement; saved in review units named in the columns), statistics (percentiles and the success probability the
campaign proves, :mod:`attitude.montecarlo.statistics`), optional time
histories and figures.

Scenario protocol (duck-typed; this module never imports ``controllers`` or
``estimation``: built-in scenarios live in :mod:`attitude.app.scenarios`)

``scenario(params, rng) -> RunOutput | mapping``
    ``params`` maps each dispersion's name to the value drawn for this run
    (SI units); ``rng`` is the run's own :class:`numpy.random.Generator` for
    sensor noise and the like. Return the metrics (a mapping of floats, or a
    :class:`RunOutput` with time histories). Raise to fail the run.
``scenario.run_batch(params_list, rngs) -> list[RunOutput]`` (optional)
    All runs of a batch at once (``vectorized=True``): one batched numpy
    state for all runs (:func:`attitude.simulation.batch.simulate_batch`).
    A run that fails inside the batch gets ``RunOutput(error=...)``. With a
    ``progress`` keyword (``run_batch(params_list, rngs, progress=None)``)
    it is given, when a progress bar is drawn, a callable to call with the
    fraction of the batch simulated (at most a few times a second:
    :class:`attitude.progress.Throttle`), so the bar moves while the runs of
    a batch advance together.
``scenario.fingerprint`` (optional str)
    A stable description of the scenario's code and settings; it guards
    checkpoint resumption. Without it the scenario is identified by its
    content (:mod:`attitude.montecarlo.identity`): a function by its code,
    defaults, closure and the globals it names, a callable object by its
    class's code and its state, never by its name alone, so editing the
    scenario and resuming its old checkpoint is refused instead of mixing old
    and new runs. A scenario whose content cannot be identified (it holds a
    lock, an open file, a C callable...) runs afresh but never resumes, and
    an :class:`~attitude.montecarlo.identity.UnidentifiableScenarioWarning`
    says so when the campaign starts: give it a ``fingerprint`` then.

Executors (:mod:`attitude.montecarlo.executors`, faults and checkpoint there)

* ``workers=1``: in this process, in order;
* ``workers=K`` (default :func:`usable_cpus`, the CPUs this process may run
  on): a pool of K local processes;
* ``scheduler="tcp://HOST:PORT"`` or a ``dask.distributed.Client``: a Dask
  cluster. To start one on several machines (each with this package and the
  same versions installed)::

      host-a$ dask scheduler                       # listens on tcp://host-a:8786
      host-b$ dask worker tcp://host-a:8786 --nworkers 8 --nthreads 1
      host-c$ dask worker tcp://host-a:8786 --nworkers 8 --nthreads 1

  then ``run_campaign(campaign, scheduler="tcp://host-a:8786")`` (or
  ``attitude montecarlo --scheduler tcp://host-a:8786``). One thread per
  worker process: a run is Python-bound, so threads would only share a GIL.
  Needs the optional ``cluster`` extra (``dask[distributed]``).
* ``vectorized=True``: tasks of ``runs_per_task`` runs (default 1000) go to
  ``scenario.run_batch`` on whichever executor above.

Reproducibility: run ``i`` draws from ``SeedSequence(seed).spawn(runs)[i]``
only, so the same seed gives bit-identical metrics with any number of
workers, on a cluster, in any completion order, after a resume, and for the
first runs of a longer campaign. (The vectorised path evaluates the same
equations in another order, so it agrees with the per-run path to rounding,
not bit for bit; every run's arithmetic is independent of the other runs of
its batch, so it is itself bit-reproducible whatever ``runs_per_task``, for
one back end of :func:`attitude.simulation.batch.simulate_batch`.)
"""

from __future__ import annotations

import hashlib
import json
import logging
import multiprocessing
import os
import threading
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from attitude.montecarlo.dispersions import (
    Dispersion,
    draw_parameters,
    flatten_parameters,
    parameter_columns,
    scenario_generator,
)
from attitude.montecarlo.executors import (
    CLUSTER_FAILED,
    WORKER_DIED,
    Checkpoint,
    Collector,
    Progress,
    RunOutput,
    RunRecord,
    run_dask,
    run_processes,
    run_serial,
)
from attitude.montecarlo.histories import StoredHistories
from attitude.montecarlo.identity import UnidentifiableScenario, UnidentifiableScenarioWarning, scenario_identity
from attitude.montecarlo.results import CampaignResult, Requirement, RunReplay, check_metric_name
from attitude.results import provenance

#: Most runs a campaign may have. What a run costs the parent process until the table is written: its
#: RunRecord with a dict of metrics (about 1 kB of Python objects for ten metrics) and its row of the table
#: (8 bytes per column, some 30 columns, plus the status and error strings: about 0.3 kB), so 10**7 runs
#: hold some 13 GB, the memory of a large workstation, and write a CSV of several GB. Statistically,
#: 10**7 runs without a failure prove a failure probability below 3e-7 at 95 % confidence (rule of three),
#: beyond any attitude requirement. A larger count is a typing mistake, refused before anything is drawn.
MAX_RUNS = 10_000_000
#: Where :func:`run_campaign` says what it resumes (INFO); the ``attitude montecarlo`` command prints it.
_log = logging.getLogger(__name__)

__all__ = [
    "MAX_RUNS",
    "Campaign",
    "run_campaign",
    "usable_cpus",
]


@dataclass(frozen=True)
class Campaign:
    """A Monte Carlo campaign (module docstring).

    Parameters
    ----------
    scenario : callable or object
        ``scenario(params, rng)`` (and optionally ``run_batch``); see the module docstring.
    dispersions : mapping of str to Dispersion
        Name -> dispersion; the names are the keys of ``params``.
    runs : int
        Number of runs (>= 1).
    seed : int, optional
        Master seed (non-negative). None draws one from the OS and keeps it
        (``campaign.seed``), so the campaign can still be reproduced.
    requirements : sequence of Requirement
        Pass/fail rules on the metrics.
    input_file : (str, str), optional
        The input the campaign was built from, ``(source, SHA-256)`` (e.g. the
        spacecraft file's name and ``SpacecraftConfig.source_sha256``), for the
        result's provenance (``info["provenance"]``). Not part of the
        campaign's identity.
    """

    scenario: Any
    dispersions: Mapping[str, Dispersion] = field(default_factory=dict)
    runs: int = 100
    seed: int | None = None
    requirements: Sequence[Requirement] = ()
    input_file: tuple[str, str] | None = None

    def __post_init__(self) -> None:
        if not callable(self.scenario):
            raise ValueError(f"scenario must be callable as scenario(params, rng), got {type(self.scenario).__name__}")
        if isinstance(self.runs, bool) or not isinstance(self.runs, (int, np.integer)) or self.runs < 1:
            raise ValueError(f"runs must be a positive integer, got {self.runs!r}")
        if self.runs > MAX_RUNS:
            raise ValueError(
                f"runs must be at most {MAX_RUNS} (the table and records of more runs outgrow a workstation's "
                f"memory; see MAX_RUNS), got {self.runs!r}"
            )
        for name, d in self.dispersions.items():
            if not isinstance(name, str) or not name:
                raise ValueError(f"dispersion names must be non-empty strings, got {name!r}")
            if not hasattr(d, "sample") or not hasattr(d, "columns"):
                raise ValueError(f"dispersion {name!r} must be a Dispersion (sample, columns, flatten), got {d!r}")
        seed = np.random.SeedSequence().entropy if self.seed is None else self.seed
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise ValueError(f"seed must be a non-negative integer or None, got {self.seed!r}")
        reqs = tuple(self.requirements)
        for r in reqs:
            if not isinstance(r, Requirement):
                raise ValueError(f"requirements must be Requirement objects, got {r!r}")
        names = [r.name for r in reqs]
        if len(set(names)) != len(names):
            raise ValueError(f"requirement names must be distinct, got {names}")
        object.__setattr__(self, "seed", int(seed))
        object.__setattr__(self, "runs", int(self.runs))
        object.__setattr__(self, "dispersions", dict(self.dispersions))
        object.__setattr__(self, "requirements", reqs)
        for r in reqs:  # a requirement on a reserved name could only ever read a column, never a metric
            check_metric_name(r.metric, self.parameter_columns(), what="requirements: metric")

    def parameter_columns(self) -> dict[str, list[str]]:
        """Each dispersion's name -> its columns in the table (``{"inertia": ["inertia.xx", ...]}``)."""
        return {name: list(d.columns(name)) for name, d in self.dispersions.items()}

    def parameters(self, run: int) -> dict[str, Any]:
        """The dispersed parameters of run ``run`` (the same on every machine).

        Parameters
        ----------
        run : int
            Run index, ``0 <= run < runs``.
        """
        return draw_parameters(self.dispersions, self.seed, run)

    def generator(self, run: int) -> np.random.Generator:
        """The generator the scenario of run ``run`` receives.

        Parameters
        ----------
        run : int
            Run index, ``0 <= run < runs``.
        """
        return scenario_generator(self.seed, run)

    def replay(self, run: int, *, vectorized: bool = False) -> RunReplay:
        """Run one run again, alone, in this process (exceptions propagate: for debugging a failed run).

        The run's parameters and generator depend on the seed and ``run``
        only, so the replay is that run of the campaign: bit for bit on the
        path the campaign took (``vectorized`` as the campaign's; each run's
        arithmetic in a batch is independent of the other runs), to rounding
        on the other (module docstring).

        Parameters
        ----------
        run : int
            Run index, ``0 <= run < runs``.
        vectorized : bool, optional
            Fly it through the scenario's ``run_batch`` (a batch of one), as a
            ``vectorized=True`` campaign did.

        Returns
        -------
        RunReplay
            Its parameters, metrics, history and verdicts (``metrics`` and
            ``history`` as the scenario's :class:`RunOutput`).
        """
        if isinstance(run, bool) or not isinstance(run, (int, np.integer)) or not 0 <= run < self.runs:
            raise ValueError(f"run must be an integer with 0 <= run < runs = {self.runs}, got {run!r}")
        if vectorized and not callable(getattr(self.scenario, "run_batch", None)):
            raise ValueError("vectorized=True needs a scenario with run_batch(params_list, rngs)")
        run = int(run)
        params = self.parameters(run)
        if vectorized:
            out = self.scenario.run_batch([params], [self.generator(run)])[0]
        else:
            out = self.scenario(params, self.generator(run))
        out = out if isinstance(out, RunOutput) else RunOutput(dict(out))
        return RunReplay(
            run=run,
            seed=self.seed,
            parameters=dict(zip(parameter_columns(self.dispersions), flatten_parameters(self.dispersions, params))),
            metrics={k: float(v) for k, v in out.metrics.items()},
            history=out.history,
            requirements=tuple(self.requirements),
            error=out.error,
            info={"vectorized": bool(vectorized)},
        )

    def fingerprint(self, vectorized: bool = False) -> str:
        """A hash of what determines the results: seed, dispersions, scenario and mode.

        Parameters
        ----------
        vectorized : bool, optional
            Whether the campaign runs the vectorised path (``run_batch``); part of the hash.

        Raises
        ------
        UnidentifiableScenario
            A ValueError: the scenario has no ``fingerprint`` string and its content cannot be identified
            (:mod:`attitude.montecarlo.identity`).
        """
        return _digest(self._identity(vectorized))

    def _identity(self, vectorized: bool) -> dict[str, Any]:
        """What :meth:`fingerprint` hashes, part by part (a checkpoint keeps it to say which part changed)."""
        ident = getattr(self.scenario, "fingerprint", None)
        if not isinstance(ident, str):
            ident = "content " + scenario_identity(self.scenario)
        return {
            "seed": self.seed,
            "dispersions": {k: repr(v) for k, v in self.dispersions.items()},
            "scenario": ident,
            "vectorized": bool(vectorized),
        }


def _digest(identity: dict[str, Any]) -> str:
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask, which container limits set), at least 1."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def _default_context() -> Any:
    """The platform's default start method, unless this process runs other threads.

    Fork (the Linux default before Python 3.14) needs no ``if __name__ ==
    "__main__"`` guard in the user's script, but a forked child inherits the
    locks other threads held at that instant (a Dask client's event loop, a
    GUI); then forkserver, whose workers come from a clean single-threaded
    server, is used instead (it needs the guard, as spawn does everywhere).
    """
    methods = multiprocessing.get_all_start_methods()
    if threading.active_count() > 1 and multiprocessing.get_start_method() == "fork" and "forkserver" in methods:
        return multiprocessing.get_context("forkserver")
    return multiprocessing.get_context()


def run_campaign(
    campaign: Campaign,
    *,
    workers: int | None = None,
    scheduler: Any = None,
    vectorized: bool = False,
    runs_per_task: int | None = None,
    out_dir: str | Path | None = None,
    resume: bool = True,
    histories_on_disk: bool | None = None,
    progress: bool | None = None,
    max_retries: int = 2,
    mp_context: Any = None,
) -> CampaignResult:
    """Execute a campaign and return its results (saved to ``out_dir`` when given).

    Parameters
    ----------
    campaign : Campaign
    workers : int, optional
        Local worker processes (default :func:`usable_cpus`: the CPUs in
        this process's affinity mask, which taskset and container limits
        set; 1 runs in this process). Ignored with a ``scheduler``. With
        ``vectorized`` the default is 1 (this process flies the batches of
        ``runs_per_task`` runs one after the other; ``attitude montecarlo
        --vectorized`` uses :func:`usable_cpus` workers).
    scheduler : str or dask.distributed.Client, optional
        Run on a Dask cluster (module docstring).
    vectorized : bool
        Use the scenario's ``run_batch`` (all runs of a task as one batched state).
    runs_per_task : int, optional
        Runs per task: default 1 (per-run) or 1000 (vectorised).
    out_dir : path, optional
        Directory for the checkpoint and the result files.
    resume : bool
        Skip the runs already in ``out_dir``'s checkpoint (same campaign only).
    histories_on_disk : bool, optional
        Where the runs' time histories stay (when the scenario returns them).
        True (needs ``out_dir``): in the checkpoint's files, each task's
        written as it finishes (:mod:`attitude.montecarlo.histories`), so the
        campaign's memory does not grow with them; ``result.histories`` reads
        a run's back when asked for (the files must stay). False: in memory,
        as ``result.histories`` dicts of arrays. Default: True with an
        ``out_dir``, False without. On disk, memory holds about one task's
        histories at a time: with ``vectorized``, lower ``runs_per_task`` to
        lower it.
    progress : bool, optional
        Progress bar on stderr (tqdm): runs done of the total, errors,
        elapsed time and ETA; a resumed campaign's bar starts at the runs
        already done. With ``vectorized``, it also counts the runs simulated
        so far of the batches in flight (serial and local processes; on a
        Dask cluster it moves batch by batch). Default: when stderr is a
        terminal; False: never.
    max_retries : int
        Extra attempts for a task whose worker process died (module
        :mod:`attitude.montecarlo.executors`).
    mp_context : multiprocessing context, optional
        For the local pool (default: the platform's, or forkserver when this
        process runs other threads; see ``_default_context``). With spawn or
        forkserver the calling script needs the ``if __name__ == "__main__":``
        guard, and the scenario must be importable by the workers.

    Returns
    -------
    CampaignResult
        ``info["interrupted"]`` is True after Ctrl-C (completed runs kept);
        ``info["resumed_runs"]`` is the number of runs taken from the
        checkpoint, also logged when the campaign starts (INFO, logger
        ``attitude.montecarlo.campaign``: "resuming: 37 of 200 runs from the
        checkpoint in DIR").

    Warns
    -----
    UnidentifiableScenarioWarning
        With ``out_dir``, when the scenario has no ``fingerprint`` and its
        content cannot be identified: the campaign runs afresh, but its
        checkpoint can never be resumed.
    """
    if not isinstance(campaign, Campaign):
        raise ValueError(f"campaign must be a Campaign, got {type(campaign).__name__}")
    if vectorized and not callable(getattr(campaign.scenario, "run_batch", None)):
        raise ValueError("vectorized=True needs a scenario with run_batch(params_list, rngs)")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1):
        raise ValueError(f"workers must be a positive integer, got {workers!r}")
    if not isinstance(max_retries, int) or max_retries < 0:
        raise ValueError(f"max_retries must be a non-negative integer, got {max_retries!r}")
    if runs_per_task is None:
        runs_per_task = 1000 if vectorized else 1
    if isinstance(runs_per_task, bool) or not isinstance(runs_per_task, int) or runs_per_task < 1:
        raise ValueError(f"runs_per_task must be a positive integer, got {runs_per_task!r}")
    if workers is None:
        workers = 1 if vectorized else usable_cpus()
    if histories_on_disk is None:
        histories_on_disk = out_dir is not None
    if not isinstance(histories_on_disk, bool):
        raise ValueError(f"histories_on_disk must be True, False or None, got {histories_on_disk!r}")
    if histories_on_disk and out_dir is None:
        raise ValueError("histories_on_disk=True needs an out_dir to write the histories to, got out_dir=None")

    wall0, cpu0 = time.perf_counter(), time.process_time()
    checkpoint = None
    done: dict[int, RunRecord] = {}
    if out_dir is not None:
        try:
            identity = campaign._identity(vectorized)
            checkpoint = Checkpoint(out_dir, _digest(identity), identity=identity)
        except UnidentifiableScenario as exc:  # a fresh run is fine; resuming it is refused (Checkpoint.load)
            checkpoint = Checkpoint(out_dir, None, unidentified=str(exc))
        if resume:
            lost = (WORKER_DIED, CLUSTER_FAILED)  # infrastructure, not the scenario: try again
            done = {
                r: rec
                for r, rec in checkpoint.load(read_histories=not histories_on_disk).items()
                if r < campaign.runs and not rec.error.startswith(lost)
            }
        checkpoint.start(resume)
        if checkpoint.fingerprint is None:
            warnings.warn(
                f"the scenario {_scenario_name(campaign.scenario)} has no `fingerprint` and cannot be identified by "
                f"its content ({checkpoint.unidentified}): this campaign runs afresh, but its checkpoint in "
                f"{str(out_dir)!r} can never be resumed (interrupted, it starts again from its first run); give the "
                "scenario a `fingerprint` string attribute that names its code and settings",
                UnidentifiableScenarioWarning,
                stacklevel=2,
            )
    resumed = len(done)
    if resumed:
        _log.info("resuming: %d of %d runs from the checkpoint in %s", resumed, campaign.runs, out_dir)
    rows: dict[int, list[float]] = {}
    tasks = _Tasks(campaign, done, runs_per_task, rows)
    bar = Progress(campaign.runs, None if progress is None else bool(progress), initial=resumed)
    reserved = campaign.parameter_columns()
    collector = Collector(
        bar,
        checkpoint,
        done,
        check_metric=lambda name: check_metric_name(name, reserved),
        keep_histories=not histories_on_disk,
    )
    # Whatever ends the loop (an error, Ctrl-C), the bar's line is finished and the
    # checkpoint's file handle closed: what was appended is already on disk.
    try:
        if scheduler is not None:
            executor = "dask"
            interrupted = run_dask(
                campaign.scenario,
                campaign.seed,
                tasks,
                vectorized,
                collector,
                scheduler=scheduler,
                max_retries=max_retries,
            )
        elif workers == 1 or not tasks:  # workers > 1 isolates even one task: it may kill its process
            executor = "serial"
            interrupted = run_serial(campaign.scenario, campaign.seed, tasks, vectorized, collector)
        else:
            executor = "processes"
            interrupted = run_processes(
                campaign.scenario,
                campaign.seed,
                tasks,
                vectorized,
                collector,
                workers=workers,
                max_retries=max_retries,
                mp_context=mp_context or _default_context(),
            )
    finally:
        bar.close()
        if checkpoint is not None:
            checkpoint.close()
    info = {
        "executor": executor,
        "workers": None if scheduler is not None else workers,
        "scheduler": _scheduler_address(scheduler),
        "vectorized": vectorized,
        "runs_per_task": runs_per_task,
        "interrupted": interrupted,
        "resumed_runs": resumed,
        "histories_on_disk": histories_on_disk,
        "wall_time_s": time.perf_counter() - wall0,
        "parent_cpu_time_s": time.process_time() - cpu0,
        "provenance": provenance(*(campaign.input_file or ())),  # versions, date, the input's hash
    }
    on_disk = checkpoint.history_files if histories_on_disk and checkpoint is not None else None
    result = _assemble(campaign, rows, collector.records, info, on_disk)
    if out_dir is not None:
        result.save(out_dir)
    return result


def _scenario_name(scenario: Any) -> str:
    """A scenario's module and qualified name (a callable object's class), for messages."""
    named = scenario if hasattr(scenario, "__qualname__") else type(scenario)
    module = getattr(named, "__module__", None)
    return f"{module}.{named.__qualname__}" if module else str(named.__qualname__)


def _scheduler_address(scheduler: Any) -> str | None:
    if scheduler is None or isinstance(scheduler, str):
        return scheduler
    return str(getattr(getattr(scheduler, "scheduler", None), "address", None) or repr(scheduler))


class _Tasks(Sequence[list[tuple[int, dict[str, Any]]]]):
    """The tasks of a campaign, drawn when asked for: memory does not grow with the run count.

    Task ``i`` holds the runs ``runs_per_task * i ...`` of the runs not yet done, in order (the same
    chunks as a list of every run would give), with their parameters drawn only when the task is
    taken. Each drawn run's flattened parameters go to ``rows`` for the table (they grow with the runs
    that ran, like their records).

    Parameters
    ----------
    campaign : Campaign
        The campaign.
    done : collection of int
        Runs already complete (resumed from a checkpoint).
    runs_per_task : int
        Runs per task, >= 1.
    rows : dict of int to list of float
        Receives each drawn run's flattened parameters.
    """

    def __init__(self, campaign: Campaign, done: Any, runs_per_task: int, rows: dict[int, list[float]]) -> None:
        self._campaign = campaign
        self._per_task = runs_per_task
        self._rows = rows
        finished = np.array(sorted(done), dtype=np.int64)
        # finished[k] - k runs are left to do before the k-th finished one: the j-th run to do is j plus
        # the number of finished runs whose count is <= j (binary search; memory in the finished runs only).
        self._before = finished - np.arange(finished.size)
        self._todo = campaign.runs - finished.size

    def __len__(self) -> int:
        return -(-self._todo // self._per_task)

    def _run(self, j: int) -> int:
        return j + int(np.searchsorted(self._before, j, side="right"))

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        n = len(self)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"task index {i} out of range for {n} tasks")
        items = []
        for j in range(i * self._per_task, min((i + 1) * self._per_task, self._todo)):
            run = self._run(j)
            params = self._campaign.parameters(run)
            self._rows[run] = flatten_parameters(self._campaign.dispersions, params)
            items.append((run, params))
        return items


def _assemble(
    campaign: Campaign,
    rows: dict[int, list[float]],
    records: dict[int, RunRecord],
    info: dict[str, Any],
    history_files: dict[int, Path] | None = None,
) -> CampaignResult:
    n = campaign.runs
    columns = parameter_columns(campaign.dispersions)
    # Row by row: the runs drawn for their tasks, and the others (resumed, not run) drawn now, the same values.
    table = np.empty((n, len(columns)))
    for r in range(n):
        row = rows.get(r)
        table[r] = row if row is not None else flatten_parameters(campaign.dispersions, campaign.parameters(r))
    names: list[str] = []
    for r in sorted(records):
        names.extend(k for k in records[r].metrics if k not in names)
    metrics = {m: np.full(n, np.nan) for m in names}
    status = np.full(n, "not run", dtype=object)
    errors = np.full(n, "", dtype=object)
    attempts = np.zeros(n, dtype=np.int64)
    cpu = np.full(n, np.nan)
    wall = np.full(n, np.nan)
    in_memory = {}
    for r, rec in records.items():
        status[r], errors[r], attempts[r], cpu[r], wall[r] = rec.status, rec.error, rec.attempts, rec.cpu_s, rec.wall_s
        for m, v in rec.metrics.items():
            metrics[m][r] = v
        if rec.history is not None:
            in_memory[r] = rec.history
    histories: Mapping[int, Mapping[str, np.ndarray]] = dict(sorted(in_memory.items()))
    if history_files is not None:  # on disk: the records let them go (histories_on_disk)
        histories = StoredHistories({r: history_files[r] for r in records if r in history_files})
    return CampaignResult(
        seed=campaign.seed,
        parameters={c: table[:, j].copy() for j, c in enumerate(columns)},
        metrics=metrics,
        status=status,
        errors=errors,
        attempts=attempts,
        cpu_s=cpu,
        wall_s=wall,
        requirements=tuple(campaign.requirements),
        histories=histories,
        info=info,
    )

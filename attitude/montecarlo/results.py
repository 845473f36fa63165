"""The result of a campaign: a tidy table (one row per run), statistics, histories and figures.

Files written by :meth:`CampaignResult.save` into the output directory:

================== ==========================================================
``results.csv``     the tidy table, standard-library :mod:`csv`; floats are
                    written with ``repr`` so they load back bit for bit
``results.parquet`` the same table, only when ``pyarrow`` is installed (it
                    is not a dependency)
``campaign.json``   seed, column roles, requirements, executor details
``statistics.json`` percentiles per metric and the success bounds
``summary.txt``     the statistics in words
``histories.npz``   time histories (``run000012/t``, ``run000012/error_angle``
                    ...), when the scenario returned them
================== ==========================================================

Why ``.npz`` and not netCDF: the histories are a handful of arrays per run
with a time axis; numpy reads and writes them with no new dependency
(xarray + netCDF4 or h5netcdf would add three packages and a C library for
no gain here), the format is the one the toolkit's other results use
(:mod:`attitude.results`), and ``allow_pickle=False`` keeps loading safe.
Converting to xarray later is a one-liner per run for whoever needs it.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from attitude.montecarlo.units import display_unit

if TYPE_CHECKING:
    from matplotlib.figure import Figure
from attitude.montecarlo.statistics import DEFAULT_PERCENTILES, percentiles, success_lower_bound, success_statement

__all__ = ["EXECUTION_COLUMNS", "RESERVED_COLUMNS", "CampaignResult", "Requirement", "check_metric_name"]

#: Columns that describe how a run executed (they vary from one execution to another).
EXECUTION_COLUMNS = ("attempts", "cpu_s", "wall_s")
#: Columns of every table that are not metrics (and ``pass.<requirement>``): no metric may take these names.
RESERVED_COLUMNS = ("run", "seed", "status", "error", "pass", *EXECUTION_COLUMNS)


def check_metric_name(name: str, parameters: Mapping[str, Sequence[str]] | None = None, what: str = "metric") -> None:
    """Refuse a metric name that the table reserves (ValueError naming it and the rule).

    A metric shares the table with the run's index, seed, status, error, pass
    flags, execution details and dispersed parameters; one named like any of
    them would replace that column (and the saved table would not load back).

    Parameters
    ----------
    name : str
        The metric's name.
    parameters : mapping of str to sequence of str, optional
        Each dispersion's name -> its table columns (``{"inertia": ["inertia.xx", ...]}``).
    what : str, optional
        How the name is introduced in the message (``"metric"``, ``"requirements: metric"``).
    """
    if name in RESERVED_COLUMNS:
        reason = f"it names a column of every table ({', '.join(RESERVED_COLUMNS)})"
    elif name.startswith("pass."):
        reason = "names starting with 'pass.' are the requirement columns (pass.<requirement>)"
    else:
        reason = ""
        for dispersion, columns in (parameters or {}).items():
            if name == dispersion:
                reason = f"it is the name of the dispersion {dispersion!r}"
            elif name in columns:
                reason = f"it names a column of the dispersion {dispersion!r} ({', '.join(columns)})"
            if reason:
                break
    if reason:
        raise ValueError(f"{what} {name!r} is reserved: {reason}; rename the metric")


_STATUS = ("ok", "error", "not run")


@dataclass(frozen=True)
class Requirement:
    """A pass/fail rule on one metric: ``min <= value <= max`` (either bound optional).

    A run that failed (no value, NaN) fails every requirement.

    Parameters
    ----------
    metric : str
        Metric name.
    max, min : float, optional
        Bounds, in the metric's unit.
    name : str, optional
        Label (column ``pass.<name>``); default the metric name.
    """

    metric: str
    max: float | None = None
    min: float | None = None
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.metric, str) or not self.metric:
            raise ValueError(f"metric must be a non-empty string, got {self.metric!r}")
        if self.max is None and self.min is None:
            raise ValueError(f"requirement on {self.metric!r} needs a max or a min")
        for bound in ("max", "min"):
            value = getattr(self, bound)
            if value is not None and math.isnan(float(value)):
                raise ValueError(f"{bound} must not be NaN")
        if not self.name:
            object.__setattr__(self, "name", self.metric)

    def passed(self, values: Any) -> NDArray[np.bool_]:
        """Element-wise pass (NaN fails).

        Parameters
        ----------
        values : array_like
            Values of the metric, one per run, in the metric's unit.
        """
        v = np.asarray(values, dtype=float)
        ok = ~np.isnan(v)
        if self.max is not None:
            ok &= v <= self.max
        if self.min is not None:
            ok &= v >= self.min
        return ok

    def __str__(self) -> str:
        parts = []
        if self.min is not None:
            parts.append(f"{self.min:g} <=")
        parts.append(self.metric)
        if self.max is not None:
            parts.append(f"<= {self.max:g}")
        return " ".join(parts)


@dataclass
class CampaignResult:
    """Outcome of :func:`attitude.montecarlo.campaign.run_campaign`.

    Attributes
    ----------
    seed : int
        Master seed: run ``i`` is reproduced by ``SeedSequence(seed).spawn(runs)[i]``.
    parameters : dict of ndarray (runs,)
        Dispersed parameters, one column per scalar (``inertia.xx`` ...), SI.
    metrics : dict of ndarray (runs,)
        One column per metric (NaN where a run has no value).
    status : ndarray (runs,) of str
        ``"ok"``, ``"error"`` (the scenario raised, diverged or its worker
        died) or ``"not run"`` (interrupted campaign).
    errors : ndarray (runs,) of str
        The error of each failed run (empty otherwise).
    attempts, cpu_s, wall_s : ndarray (runs,)
        Execution details: attempts (worker deaths retried), CPU and wall
        time of the run in its worker [s] (a vectorised batch's time is
        shared equally by its runs).
    requirements : tuple of Requirement
    histories : dict
        Run index -> dict of time histories (only runs that returned one).
    info : dict
        Executor, workers, wall time, interruption, resumed runs ...
    """

    seed: int
    parameters: dict[str, NDArray[np.float64]]
    metrics: dict[str, NDArray[np.float64]]
    status: NDArray[Any]
    errors: NDArray[Any]
    attempts: NDArray[np.int64]
    cpu_s: NDArray[np.float64]
    wall_s: NDArray[np.float64]
    requirements: tuple[Requirement, ...] = ()
    histories: dict[int, dict[str, NDArray[Any]]] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)

    # -- the table --------------------------------------------------------------

    @property
    def runs(self) -> int:
        return int(self.status.size)

    def requirement_passed(self, requirement: Requirement) -> NDArray[np.bool_]:
        """Pass of one requirement per run (a run without the metric fails).

        Parameters
        ----------
        requirement : Requirement
            The pass/fail rule.
        """
        values = self.metrics.get(requirement.metric, np.full(self.runs, np.nan))
        return requirement.passed(values) & (self.status == "ok")

    @property
    def passed(self) -> NDArray[np.bool_]:
        """Overall pass per run: it completed and met every requirement."""
        ok = self.status == "ok"
        for r in self.requirements:
            ok = ok & self.requirement_passed(r)
        return ok

    def table(self) -> dict[str, NDArray[Any]]:
        """The tidy table: column name -> array (one row per run), in file order."""
        cols: dict[str, NDArray[Any]] = {
            "run": np.arange(self.runs),
            "seed": np.full(self.runs, self.seed, dtype=object),
            "status": self.status,
            "error": self.errors,
        }
        cols.update(self.parameters)
        for m in self.metrics:  # a metric must never silently replace a column (check_metric_name)
            if m in cols or m in RESERVED_COLUMNS or m.startswith("pass."):
                raise ValueError(
                    f"metrics: {m!r} names a column of the table (reserved: {', '.join(RESERVED_COLUMNS)}, "
                    "pass.<requirement> and the dispersed parameters); rename the metric"
                )
        cols.update(self.metrics)
        for r in self.requirements:
            cols[f"pass.{r.name}"] = self.requirement_passed(r)
        cols["pass"] = self.passed
        cols["attempts"] = self.attempts
        cols["cpu_s"] = self.cpu_s
        cols["wall_s"] = self.wall_s
        return cols

    def to_csv(self, path: str | Path) -> Path:
        """Write the tidy table as CSV (floats via ``repr``: exact round trip).

        Parameters
        ----------
        path : str or Path
            Destination CSV file.
        """
        path = Path(path)
        cols = self.table()
        with path.open("w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(cols)
            for i in range(self.runs):
                writer.writerow([_cell(c[i]) for c in cols.values()])
        return path

    def to_parquet(self, path: str | Path) -> Path | None:
        """Write the table as Parquet if ``pyarrow`` is installed; return None otherwise.

        Parameters
        ----------
        path : str or Path
            Destination Parquet file.
        """
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError:
            return None
        cols = {k: (v.astype(str) if v.dtype == object else v) for k, v in self.table().items()}
        pq.write_table(pa.table(cols), Path(path))
        return Path(path)

    # -- statistics ---------------------------------------------------------------

    def statistics(self, q: Sequence[float] = DEFAULT_PERCENTILES, confidence: float = 0.95) -> dict[str, Any]:
        """Percentiles of every metric (completed runs) and success bounds (runs that ran).

        A run that raised counts as a failure of every requirement; runs not
        run (interrupted campaign) are left out of the bounds.

        Parameters
        ----------
        q : sequence of float, optional
            Percentiles to report [%], each in ``[0, 100]``.
        confidence : float, optional
            Confidence level of the success bounds, in (0, 1).
        """
        ran = self.status != "not run"
        n = int(np.sum(ran))
        out: dict[str, Any] = {
            "runs": self.runs,
            "completed": int(np.sum(self.status == "ok")),
            "errors": int(np.sum(self.status == "error")),
            "not_run": self.runs - n,
            "confidence": confidence,
            "metrics": {m: percentiles(v[self.status == "ok"], q) for m, v in self.metrics.items()},
            "requirements": {},
        }
        for r in self.requirements:
            k = int(np.sum(self.requirement_passed(r)[ran]))
            out["requirements"][r.name] = {
                "rule": str(r),
                "passed": k,
                "runs": n,
                "success_lower_bound": success_lower_bound(k, n, confidence) if n else math.nan,
            }
        k = int(np.sum(self.passed[ran]))
        out["success"] = {
            "passed": k,
            "runs": n,
            "success_lower_bound": success_lower_bound(k, n, confidence) if n else math.nan,
            "statement": success_statement(k, n, confidence) if n else "no run completed",
        }
        return out

    def summary(self, confidence: float = 0.95) -> str:
        """The statistics in a few lines of text.

        Parameters
        ----------
        confidence : float, optional
            Confidence level of the success bounds, in (0, 1).
        """
        s = self.statistics(confidence=confidence)
        lines = [
            f"Monte Carlo campaign: {s['runs']} runs (seed {self.seed}), {s['completed']} completed, "
            f"{s['errors']} errors, {s['not_run']} not run",
        ]
        for m, st in s["metrics"].items():
            scale, unit = display_unit(m)
            label = f"{m} [{unit}]" if unit else m
            lines.append(
                f"  {label}: median {scale * st.get('p50', math.nan):.4g}, p95 {scale * st.get('p95', math.nan):.4g}, "
                f"max {scale * st['max']:.4g} ({int(st['nonfinite'])} non-finite)"
            )
        for r in self.requirements:
            scale, unit = display_unit(r.metric)
            parts = [r.metric]
            if r.min is not None:
                parts.insert(0, f"{scale * r.min:.4g} {unit} <=".replace("  ", " "))
            if r.max is not None:
                parts.append(f"<= {scale * r.max:.4g} {unit}".rstrip())
            rule = " ".join(parts)
            counts = s["requirements"][r.name]  # over the runs that ran (all of them unless interrupted)
            lines.append(f"  requirement {r.name} ({rule}): {counts['passed']}/{counts['runs']} passed")
        lines.append("  " + s["success"]["statement"])
        first_errors = [f"    run {i}: {self.errors[i]}" for i in np.nonzero(self.status == "error")[0][:5]]
        if first_errors:
            lines.append("  first errors:")
            lines.extend(first_errors)
        if self.info.get("interrupted"):
            lines.append("  (interrupted: the completed runs are kept; run again with the same out_dir to resume)")
        return "\n".join(lines)

    # -- figures ------------------------------------------------------------------

    def plot_histograms(self, metrics: Sequence[str] | None = None) -> Figure:
        """One histogram per metric, with the requirement bounds (:mod:`attitude.montecarlo.plots`).

        Parameters
        ----------
        metrics : sequence of str, optional
            Metrics to show; default every metric.
        """
        from attitude.montecarlo.plots import plot_histograms

        return plot_histograms(self, metrics)

    def plot_envelope(self, key: str, component: int | None = None) -> Figure:
        """Percentile bands of a time history over the runs (:mod:`attitude.montecarlo.plots`).

        Parameters
        ----------
        key : str
            History name (``"error_angle"``, ``"omega"`` ...).
        component : int, optional
            For a vector history, the component to show; default its norm.
        """
        from attitude.montecarlo.plots import plot_envelope

        return plot_envelope(self, key, component)

    def plot_scatter(self, metric: str, parameter: str) -> Figure:
        """A metric against a dispersed parameter, failures marked (:mod:`attitude.montecarlo.plots`).

        Parameters
        ----------
        metric : str
            Name of the metric (vertical axis).
        parameter : str
            Table column of the dispersed parameter (horizontal axis).
        """
        from attitude.montecarlo.plots import plot_scatter

        return plot_scatter(self, metric, parameter)

    # -- files ----------------------------------------------------------------------

    def save(self, out_dir: str | Path) -> Path:
        """Write the files listed in the module docstring into ``out_dir``; return it.

        Parameters
        ----------
        out_dir : str or Path
            Output directory (created).
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        self.to_csv(out / "results.csv")
        self.to_parquet(out / "results.parquet")
        meta = {
            "seed": self.seed,
            "parameters": list(self.parameters),
            "metrics": list(self.metrics),
            "requirements": [
                {"metric": r.metric, "max": r.max, "min": r.min, "name": r.name} for r in self.requirements
            ],
            "info": _jsonable(self.info),
        }
        (out / "campaign.json").write_text(json.dumps(meta, indent=2) + "\n")
        (out / "statistics.json").write_text(json.dumps(self.statistics(), indent=2) + "\n")
        (out / "summary.txt").write_text(self.summary() + "\n")
        if self.histories:
            arrays = {f"run{run:06d}/{k}": v for run, h in sorted(self.histories.items()) for k, v in h.items()}
            np.savez_compressed(out / "histories.npz", **arrays)
        return out

    @classmethod
    def load(cls, out_dir: str | Path) -> CampaignResult:
        """Read a directory written by :meth:`save`.

        Parameters
        ----------
        out_dir : str or Path
            Directory written by :meth:`save`.
        """
        out = Path(out_dir)
        meta = json.loads((out / "campaign.json").read_text())
        with (out / "results.csv").open(newline="") as f:
            rows = list(csv.DictReader(f))

        def column(name: str, kind: type = float) -> NDArray[Any]:
            return np.array([kind(r[name]) for r in rows]) if rows else np.zeros(0)

        histories: dict[int, dict[str, NDArray[Any]]] = {}
        if (out / "histories.npz").exists():
            with np.load(out / "histories.npz", allow_pickle=False) as data:
                for key in data.files:
                    run, name = key.split("/", 1)
                    histories.setdefault(int(run[3:]), {})[name] = np.array(data[key])
        return cls(
            seed=int(meta["seed"]),
            parameters={c: column(c) for c in meta["parameters"]},
            metrics={c: column(c) for c in meta["metrics"]},
            status=np.array([r["status"] for r in rows], dtype=object),
            errors=np.array([r["error"] for r in rows], dtype=object),
            attempts=column("attempts", int),
            cpu_s=column("cpu_s"),
            wall_s=column("wall_s"),
            requirements=tuple(Requirement(**r) for r in meta["requirements"]),
            histories=histories,
            info=meta["info"],
        )


def _cell(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (str, int, float, bool)):
        return value
    return repr(value)

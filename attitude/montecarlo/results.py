"""The result of a campaign: a tidy table (one row per run), statistics, histories and figures.

Files written by :meth:`CampaignResult.save` into the output directory:

================== ==========================================================
``results.csv``     the tidy table, standard-library :mod:`csv`, one row per
                    run (columns below)
``results.parquet`` the same table, only when ``pyarrow`` is installed (it
                    is not a dependency)
``campaign.json``   seed, the column schema (``"columns"``), requirements,
                    executor details and provenance
``statistics.json`` percentiles per metric (SI) and the success bounds
``summary.txt``     the statistics in words (review units)
``histories.npz``   time histories (``run000012/t``, ``run000012/error_angle``
                    ...), when the scenario returned them; written a run at a
                    time and read back a run at a time
                    (:mod:`attitude.montecarlo.histories`)
================== ==========================================================

The table's columns: ``run``; ``seed`` (the master seed) and ``spawn_key``
(``"(12, 1)"``): ``numpy.random.default_rng(numpy.random.SeedSequence(seed,
spawn_key=(12, 1)))`` is the very generator run 12's scenario received
(:func:`attitude.montecarlo.dispersions.scenario_spawn_key`); ``status`` and
``error``; the dispersed parameters and the metrics; ``pass.<requirement>``
and ``pass``; ``attempts``, ``cpu_s`` and ``wall_s``. A parameter or metric
is written in the review unit :meth:`CampaignResult.summary` prints, named
in its column (:func:`attitude.montecarlo.units.table_column`):
``final_pointing_error_deg``, ``wheel_speed_peak_rpm``, ``inertia.xx_kg_m2``;
a dimensionless one keeps its name (``nees``); a user's metric of unknown
unit keeps its name and its value as the scenario returned it (SI by the
scenario protocol). ``campaign.json`` ``"columns"`` gives each column's role,
quantity, unit, SI unit and ``scale_from_si`` (column value = scale * SI
value; unit ``null`` for an unknown one). In memory everything stays SI and
named as the scenario named it (``result.metrics["final_pointing_error"]``
[rad], requirements on ``"final_pointing_error"``).

Each scaled value is written with the fewest digits (17 or a few more) from
which :meth:`CampaignResult.load` gets the SI value back bit for bit: it
divides the exact decimal by the scale in 60-digit arithmetic. A spreadsheet
reading the column as a float sees the review value to the last digit.

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
from decimal import Context, Decimal
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from attitude.montecarlo.dispersions import scenario_spawn_key
from attitude.montecarlo.histories import StoredHistories, write_histories
from attitude.montecarlo.statistics import DEFAULT_PERCENTILES, percentiles, success_lower_bound, success_statement
from attitude.montecarlo.units import display_unit, quantity_of_column, table_column

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "EXECUTION_COLUMNS",
    "RESERVED_COLUMNS",
    "CampaignResult",
    "Requirement",
    "RunReplay",
    "check_metric_name",
]

#: Columns that describe how a run executed (they vary from one execution to another).
EXECUTION_COLUMNS = ("attempts", "cpu_s", "wall_s")
#: Columns of every table that are not metrics (and ``pass.<requirement>``): no metric may take these names.
RESERVED_COLUMNS = ("run", "seed", "spawn_key", "status", "error", "pass", *EXECUTION_COLUMNS)
#: What the schema (``campaign.json`` ``"columns"``) says of the columns that are neither metrics nor parameters.
_FIXED_COLUMNS: dict[str, dict[str, Any]] = {
    "run": {"role": "run", "meaning": "run index, from 0"},
    "seed": {"role": "seed", "meaning": "the campaign's master seed (numpy SeedSequence entropy)"},
    "spawn_key": {
        "role": "seed",
        "meaning": "spawn key of the generator the run's scenario received: "
        "numpy.random.default_rng(numpy.random.SeedSequence(seed, spawn_key=spawn_key))",
    },
    "status": {"role": "status", "meaning": "ok, error (the run raised, diverged or its worker died) or not run"},
    "error": {"role": "status", "meaning": "the exception of a failed run, empty otherwise"},
    "pass": {"role": "requirement", "meaning": "the run completed and met every requirement"},
    "attempts": {"role": "execution", "unit": "1", "meaning": "attempts the run took (worker deaths retried)"},
    "cpu_s": {"role": "execution", "unit": "s", "meaning": "CPU time of the run in its worker"},
    "wall_s": {"role": "execution", "unit": "s", "meaning": "wall-clock time of the run in its worker"},
}
#: Arithmetic of the exact unit conversion of the table (module docstring): the product of two doubles has at
#: most 34 significant digits, and 60 leave the quotient of a 40-digit text by a double far inside half an ulp.
_EXACT = Context(prec=60)


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
    elif (quantity := quantity_of_column(name)) is not None:
        reason = (
            f"it is the table column of {quantity!r} in {table_column(quantity).unit} "
            f"(attitude.montecarlo.units); return {quantity!r}, in SI, instead"
        )
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

    def review_rule(self) -> str:
        """The rule in the metric's review unit, as the summary prints it (``final_pointing_error <= 0.05 deg``)."""
        scale, unit = display_unit(self.metric)
        parts = [self.metric]
        if self.min is not None:
            parts.insert(0, f"{scale * self.min:.4g} {unit} <=".replace("  ", " "))
        if self.max is not None:
            parts.append(f"<= {scale * self.max:.4g} {unit}".rstrip())
        return " ".join(parts)


@dataclass
class CampaignResult:
    """Outcome of :func:`attitude.montecarlo.campaign.run_campaign`.

    The toolkit's result protocol, as :class:`attitude.simulation.engine.SimulationResult`'s:
    :meth:`summary` (text, review units), :meth:`plot` (the main figure: one
    histogram per metric with its requirement bounds; :meth:`plot_envelope`,
    :meth:`plot_scatter` and :func:`attitude.montecarlo.plots.save_figures`
    for the others), :meth:`save` and :meth:`load`. A campaign is a table and
    its histories, so it is saved to a directory (CSV, JSON, ``.npz``: module
    docstring) rather than one ``.npz`` file.

    Attributes
    ----------
    seed : int
        Master seed: run ``i``'s scenario draws from
        ``default_rng(SeedSequence(seed, spawn_key=(i, 1)))`` (the table's
        ``seed`` and ``spawn_key`` columns), its parameters from
        ``SeedSequence(seed, spawn_key=(i, 0, crc32(name)))``
        (:mod:`attitude.montecarlo.dispersions`).
    parameters : dict of ndarray (runs,)
        Dispersed parameters, one column per scalar (``inertia.xx`` ...), SI.
    metrics : dict of ndarray (runs,)
        One column per metric (NaN where a run has no value), SI.
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
    histories : mapping
        Run index -> dict of time histories (only runs that returned one). A
        dict in memory, or a :class:`attitude.montecarlo.histories.StoredHistories`
        that reads a run's from its file when asked for (a campaign run with
        ``histories_on_disk``, and every :meth:`load`).
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
    histories: Mapping[int, Mapping[str, NDArray[Any]]] = field(default_factory=dict)
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
        """The tidy table in memory: column name -> array (one row per run), SI, named as inside.

        The columns of ``results.csv`` in file order, but with the metrics and
        parameters under their own names and in SI (``final_pointing_error``
        [rad]); the file names them with their review unit and holds review
        values (:meth:`file_columns`, module docstring).
        """
        cols: dict[str, NDArray[Any]] = {
            "run": np.arange(self.runs),
            "seed": np.full(self.runs, self.seed, dtype=object),
            "spawn_key": np.array([repr(scenario_spawn_key(r)) for r in range(self.runs)], dtype=object),
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

    def file_columns(self) -> dict[str, dict[str, Any]]:
        """The schema of the saved table: file column -> its role, quantity, unit and scale from SI, in file order.

        A metric or parameter column is named and scaled by
        :func:`attitude.montecarlo.units.table_column` (the summary's review
        unit); the others are described in words. This is ``campaign.json``
        ``"columns"``.

        Raises
        ------
        ValueError
            When two quantities would share a column (a metric named like
            another's column, e.g. ``settling_time_s`` beside ``settling_time``).
        """
        schema: dict[str, dict[str, Any]] = {}
        quantity_of: dict[str, str] = {}
        roles = {**dict.fromkeys(self.parameters, "parameter"), **dict.fromkeys(self.metrics, "metric")}
        for name in self.table():
            role = roles.get(name)
            if role is None:
                if name.startswith("pass."):
                    entry = {"role": "requirement", "meaning": f"the run met requirement {name[5:]!r}"}
                else:
                    entry = dict(_FIXED_COLUMNS[name])
                schema[name] = entry
                quantity_of[name] = name
                continue
            column = table_column(name)
            if column.column in quantity_of:
                raise ValueError(
                    f"{role}s: {name!r} would be written as the column {column.column!r}, which holds "
                    f"{quantity_of[column.column]!r}; rename the metric"
                )
            schema[column.column] = column.schema(role)
            quantity_of[column.column] = name
        return schema

    def to_csv(self, path: str | Path) -> Path:
        """Write the tidy table as CSV, metrics and parameters in review units (module docstring).

        Values load back bit for bit (:meth:`load`, with the schema that
        :meth:`save` writes beside it).

        Parameters
        ----------
        path : str or Path
            Destination CSV file.
        """
        path = Path(path)
        cols = list(self.table().values())
        schema = self.file_columns()
        scales = [entry.get("scale_from_si") for entry in schema.values()]
        with path.open("w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(schema)
            for i in range(self.runs):
                writer.writerow(
                    [_cell(c[i]) if scale is None else _review_text(c[i], scale) for c, scale in zip(cols, scales)]
                )
        return path

    def to_parquet(self, path: str | Path) -> Path | None:
        """Write the table as Parquet if ``pyarrow`` is installed; return None otherwise.

        The columns and review units of the CSV (to rounding: a float cannot
        hold the CSV's extra digits).

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
        cols = {}
        for (column, entry), v in zip(self.file_columns().items(), self.table().values()):
            scale = entry.get("scale_from_si")
            cols[column] = v.astype(str) if v.dtype == object else (v if scale is None else v * scale)
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
            counts = s["requirements"][r.name]  # over the runs that ran (all of them unless interrupted)
            lines.append(f"  requirement {r.name} ({r.review_rule()}): {counts['passed']}/{counts['runs']} passed")
            reason = self.failure_reason(r)
            if reason:
                lines.append(f"    FAIL {r.name}: {reason}")
        lines.append("  " + s["success"]["statement"])
        first_errors = [f"    run {i}: {self.errors[i]}" for i in np.nonzero(self.status == "error")[0][:5]]
        if first_errors:
            lines.append("  first errors:")
            lines.extend(first_errors)
        if self.info.get("interrupted"):
            lines.append("  (interrupted: the completed runs are kept; run again with the same out_dir to resume)")
        return "\n".join(lines)

    def failure_reason(self, requirement: Requirement) -> str | None:
        """Why ``requirement`` failed, in one line: how many runs, the worst one and its value (None: no failure).

        Runs that ended in an error are counted apart (their message is in the table).

        Parameters
        ----------
        requirement : Requirement
            One of the campaign's requirements.
        """
        ok = self.status == "ok"
        failed = ok & ~self.requirement_passed(requirement)
        if not np.any(failed):
            return None
        values = self.metrics.get(requirement.metric, np.full(self.runs, np.nan))
        scale, unit = display_unit(requirement.metric)
        # The worst run: the furthest past its bound (a missing or NaN value first).
        high = math.inf if requirement.max is None else requirement.max
        low = -math.inf if requirement.min is None else requirement.min
        with np.errstate(invalid="ignore"):
            excess = np.where(np.isnan(values), np.inf, np.maximum(values - high, low - values))
        worst = int(np.flatnonzero(failed)[np.argmax(excess[failed])])
        value = float(values[worst])
        seen = "no value" if math.isnan(value) else f"{scale * value:.4g} {unit}".rstrip()
        return (
            f"{int(np.sum(failed))} of {int(np.sum(ok))} runs; the worst, run {worst}, has {requirement.metric} = "
            f"{seen} ({requirement.review_rule()}); fly it again at full rate with `attitude montecarlo ... "
            f"--replay {worst}` or Campaign.replay({worst})"
        )

    # -- figures ------------------------------------------------------------------

    def plot(self) -> Figure:
        """The campaign's main figure: one histogram per metric with its requirement bounds (review units).

        The same figure as :meth:`plot_histograms` with every metric
        (``figures/histograms.png`` of ``attitude montecarlo``).
        """
        return self.plot_histograms()

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
            "columns": self.file_columns(),
            "requirements": [
                {"metric": r.metric, "max": r.max, "min": r.min, "name": r.name} for r in self.requirements
            ],
            "info": _jsonable(self.info),
        }
        (out / "campaign.json").write_text(json.dumps(meta, indent=2) + "\n")
        (out / "statistics.json").write_text(json.dumps(self.statistics(), indent=2) + "\n")
        (out / "summary.txt").write_text(self.summary() + "\n")
        if self.histories:
            # A run at a time: histories on disk are never all in memory at once.
            runs = ((run, self.histories[run]) for run in sorted(self.histories))
            write_histories(out / "histories.npz", runs, compress=True)
        return out

    @classmethod
    def load(cls, out_dir: str | Path) -> CampaignResult:
        """Read a directory written by :meth:`save`.

        The histories stay in ``histories.npz``: ``result.histories[run]``
        reads that run's when asked for (:class:`attitude.montecarlo.histories.StoredHistories`).

        Parameters
        ----------
        out_dir : str or Path
            Directory written by :meth:`save`.
        """
        out = Path(out_dir)
        meta = json.loads((out / "campaign.json").read_text())
        with (out / "results.csv").open(newline="") as f:
            rows = list(csv.DictReader(f))
        # Quantity -> (its column, the scale from SI). A campaign saved before the schema existed has SI
        # columns named as the quantities.
        columns = {
            entry["quantity"]: (name, entry["scale_from_si"])
            for name, entry in meta.get("columns", {}).items()
            if entry["role"] in ("metric", "parameter")
        }

        def column(name: str, kind: type = float) -> NDArray[Any]:
            return np.array([kind(r[name]) for r in rows]) if rows else np.zeros(0)

        def quantity(name: str) -> NDArray[Any]:
            file_column, scale = columns.get(name, (name, 1.0))
            return np.array([_si_value(r[file_column], scale) for r in rows]) if rows else np.zeros(0)

        histories: Mapping[int, Mapping[str, NDArray[Any]]] = {}
        if (out / "histories.npz").exists():  # read a run at a time, when asked for
            histories = StoredHistories.from_file(out / "histories.npz")
        return cls(
            seed=int(meta["seed"]),
            parameters={c: quantity(c) for c in meta["parameters"]},
            metrics={c: quantity(c) for c in meta["metrics"]},
            status=np.array([r["status"] for r in rows], dtype=object),
            errors=np.array([r["error"] for r in rows], dtype=object),
            attempts=column("attempts", int),
            cpu_s=column("cpu_s"),
            wall_s=column("wall_s"),
            requirements=tuple(Requirement(**r) for r in meta["requirements"]),
            histories=histories,
            info=meta["info"],
        )


@dataclass
class RunReplay:
    """One run of a campaign flown again, alone (:meth:`attitude.montecarlo.campaign.Campaign.replay`).

    What ``attitude montecarlo FILE --replay RUN`` prints and writes: the
    run's dispersed parameters, its metrics and its pass or fail per
    requirement (:meth:`summary`), its figures (:meth:`figures`) and its
    files (:meth:`save`). Its ``metrics``, ``history`` and ``error`` are
    those of the :class:`attitude.montecarlo.executors.RunOutput` the
    scenario returned.

    Attributes
    ----------
    run : int
        Run index in the campaign.
    seed : int
        The campaign's master seed.
    parameters : dict of float
        The run's dispersed parameters, one per table column (``inertia.xx`` ...), SI.
    metrics : dict of float
        The run's metrics, SI (empty when it failed).
    history : dict of ndarray or None
        Its time histories (``t`` [s] and series whose first axis is time), when the scenario kept them.
    requirements : tuple of Requirement
        The campaign's requirements.
    error : str or None
        Why the run failed (the scenario returned an error, e.g. a diverged batch run); None when it ran.
    info : dict
        How it was flown (``vectorized``) and what the figures need (``wheel_speed_limit`` [rad/s] per wheel).
    """

    run: int
    seed: int
    parameters: dict[str, float]
    metrics: dict[str, float]
    history: dict[str, NDArray[Any]] | None = None
    requirements: tuple[Requirement, ...] = ()
    error: str | None = None
    info: dict[str, Any] = field(default_factory=dict)

    #: Files :meth:`save` may write (the figures only with their histories).
    FILES: ClassVar[tuple[str, ...]] = (
        "replay.json",
        "history.npz",
        "pointing_error.png",
        "rates.png",
        "wheel_speeds.png",
    )

    @property
    def spawn_key(self) -> tuple[int, int]:
        """The spawn key of the run's scenario generator (the table's ``spawn_key``)."""
        return scenario_spawn_key(self.run)

    def requirement_passed(self, requirement: Requirement) -> bool:
        """Whether the run met one requirement (a failed run, or one without the metric, did not).

        Parameters
        ----------
        requirement : Requirement
            The pass/fail rule.
        """
        if self.error:
            return False
        return bool(requirement.passed([self.metrics.get(requirement.metric, math.nan)])[0])

    @property
    def passed(self) -> bool:
        """The run completed and met every requirement."""
        return not self.error and all(self.requirement_passed(r) for r in self.requirements)

    def to_dict(self) -> dict[str, Any]:
        """The replay as plain values: SI values, the review-unit table row, the verdicts (``replay.json``)."""
        row = {}
        for name, value in {**self.parameters, **self.metrics}.items():
            column = table_column(name)
            row[column.column] = float(value) * column.scale
        return {
            "run": self.run,
            "seed": self.seed,
            "spawn_key": list(self.spawn_key),
            "path": "vectorised" if self.info.get("vectorized") else "per-run",
            "status": "error" if self.error else "ok",
            "error": self.error or "",
            "parameters": {k: float(v) for k, v in self.parameters.items()},
            "metrics": {k: float(v) for k, v in self.metrics.items()},
            "row": row,
            "requirements": {
                r.name: {"rule": r.review_rule(), "passed": self.requirement_passed(r)} for r in self.requirements
            },
            "passed": self.passed,
            "provenance": self.info.get("provenance"),
        }

    def summary(self) -> str:
        """The run in a few lines: how it was flown, its parameters, metrics and verdicts (review units)."""
        path = "the vectorised path" if self.info.get("vectorized") else "the per-run engine"
        lines = [f"Replay of run {self.run} (seed {self.seed}, spawn_key {self.spawn_key}), flown alone on {path}"]
        groups: dict[str, list[str]] = {}
        for name, value in self.parameters.items():
            quantity, _, component = name.partition(".")
            scale, unit = display_unit(name)
            label = f"{quantity} [{unit}]" if unit else quantity
            groups.setdefault(label, []).append(f"{component} {scale * value:.6g}".lstrip())
        for label, values in groups.items():
            lines.append(f"  {label}: {', '.join(values)}")
        if self.error:
            lines.append(f"  the run failed: {self.error}")
        for name, value in self.metrics.items():
            scale, unit = display_unit(name)
            lines.append(f"  {name}: {scale * value:.6g} {unit}".rstrip())
        for r in self.requirements:
            verdict = "PASS" if self.requirement_passed(r) else "FAIL"
            value = self.metrics.get(r.metric, math.nan)
            scale, unit = display_unit(r.metric)
            seen = f"{scale * value:.6g} {unit}".rstrip()
            lines.append(f"  requirement {r.name} ({r.review_rule()}): {verdict} ({seen})")
        missed = [r.name for r in self.requirements if not self.requirement_passed(r)]
        verdict = "PASS" if self.passed else "FAIL" + (f" ({', '.join(missed)})" if missed else "")
        lines.append(f"  run {self.run}: {verdict}")
        return "\n".join(lines)

    def figures(self) -> dict[str, Figure]:
        """Pointing error to the target, rates and wheel speeds (:func:`attitude.montecarlo.plots.plot_run`)."""
        from attitude.montecarlo.plots import plot_run

        if not self.history or "t" not in self.history:
            return {}
        return plot_run(
            self.history,
            self.requirements,
            metrics=self.metrics,
            title=f"run {self.run} (seed {self.seed})",
            wheel_speed_limit=self.info.get("wheel_speed_limit"),
            windows=self.info.get("windows"),
        )

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``replay.json``, ``history.npz`` and the figures (``<name>.png``) into ``out_dir``; return the paths.

        Parameters
        ----------
        out_dir : str or Path
            Output directory (created); files of the same names in it are replaced.
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = [out / "replay.json"]
        paths[0].write_text(json.dumps(_jsonable(self.to_dict()), indent=2) + "\n")
        if self.history:
            np.savez_compressed(out / "history.npz", **self.history)
            paths.append(out / "history.npz")
        for name, fig in self.figures().items():
            fig.savefig(out / f"{name}.png", dpi=110)
            paths.append(out / f"{name}.png")
        return paths


def _cell(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


def _same_float(a: float, b: float) -> bool:
    """Bit for bit: NaN is NaN, and -0.0 is not 0.0."""
    if math.isnan(a) or math.isnan(b):
        return math.isnan(a) and math.isnan(b)
    return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


def _review_text(value: Any, scale: float) -> str:
    """``scale * value`` as the shortest text from which :func:`_si_value` gives ``value`` back bit for bit."""
    value = float(value)
    if scale == 1.0 or not math.isfinite(value) or value == 0.0:
        return repr(value * scale)
    text = repr(value * scale)
    if _same_float(_si_value(text, scale), value):
        return text
    exact = _EXACT.multiply(Decimal(value), Decimal(scale))  # both doubles are exact decimals: an exact product
    for digits in range(17, 41):
        text = format(_EXACT.plus(exact).normalize(Context(prec=digits)), "g")
        if _same_float(_si_value(text, scale), value):
            return text
    raise AssertionError(f"no decimal text of {value!r} * {scale!r} converts back")  # 40 digits always do


def _si_value(text: str, scale: float) -> float:
    """The SI value of a review-unit cell: the exact decimal divided by ``scale``, rounded once."""
    if scale == 1.0:
        return float(text)
    return float(_EXACT.divide(Decimal(text), Decimal(scale)))


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

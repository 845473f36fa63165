"""Figures of a Monte Carlo campaign; each function returns its ``matplotlib.figure.Figure``.

Built with the object-oriented API (no pyplot state), as :mod:`attitude.plotting`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from attitude.montecarlo.units import display_unit
from attitude.plotting import AXIS_COLORS


class CampaignData(Protocol):
    """What the figures read of a campaign (:class:`attitude.montecarlo.CampaignResult` meets it).

    A protocol, not an import, so that the result can draw itself with these
    functions without the two modules importing each other.
    """

    seed: int
    parameters: dict[str, NDArray[np.float64]]
    metrics: dict[str, NDArray[np.float64]]
    status: NDArray[Any]
    requirements: tuple[Any, ...]
    histories: Mapping[int, Mapping[str, NDArray[Any]]]

    @property
    def runs(self) -> int: ...

    @property
    def passed(self) -> NDArray[np.bool_]: ...


__all__ = [
    "ENVELOPE_BANDS",
    "ENVELOPE_REQUIREMENTS",
    "NEES_DEGREES_OF_FREEDOM",
    "NORM_BOUNDED_HISTORIES",
    "PER_COMPONENT_HISTORIES",
    "CampaignData",
    "chi2_counts",
    "most_influential_parameter",
    "plot_envelope",
    "plot_histograms",
    "plot_run",
    "plot_scatter",
    "save_figures",
]

#: Colours of the wheels in :func:`plot_run` (no red: red is the limit).
_WHEEL_COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:olive", "tab:cyan")

#: Percentile bands drawn by :func:`plot_envelope` [%] (outermost first) and the median.
ENVELOPE_BANDS = ((0.0, 100.0), (5.0, 95.0), (25.0, 75.0))
#: Degrees of freedom of the built-in NEES metrics (``nees``: the run's time-averaged attitude NEES of
#: :class:`attitude.app.scenarios.ClosedLoopScenario`): their histogram carries the chi-square density.
NEES_DEGREES_OF_FREEDOM = {"nees": 3}
#: The metrics whose requirement bounds a time history (the history's largest value over a run or over
#: the hold, or its value at the end, is that metric; the first with a requirement is drawn): the envelope
#: draws the requirement's upper bound. It bounds each
#: component of a vector history (the peak wheel speed: every wheel), except for the histories of
#: :data:`NORM_BOUNDED_HISTORIES`.
ENVELOPE_REQUIREMENTS = {
    "error_angle": ("pointing_error_hold", "final_pointing_error"),
    "omega": ("rate_peak",),
    "wheel_speed": ("wheel_speed_peak",),
}
#: Vector histories whose requirement bounds the norm (the peak rate bounds ``|omega|``), drawn on the norm only.
NORM_BOUNDED_HISTORIES = frozenset({"omega"})
#: Vector histories drawn one panel per component by :func:`save_figures` (the norm of four wheel speeds
#: means nothing against a wheel's speed limit).
PER_COMPONENT_HISTORIES = frozenset({"wheel_speed"})


def _label(name: str) -> str:
    unit = display_unit(name)[1]
    return f"{name} [{unit}]" if unit else name


def plot_histograms(result: CampaignData, metrics: Sequence[str] | None = None) -> Figure:
    """One histogram per metric over the completed runs, with requirement bounds (dashed red).

    Non-finite values (a run that never settled has ``settling_time = inf``)
    are counted in the panel title, not drawn. Counts are whole runs (an
    integer axis). A NEES metric (:data:`NEES_DEGREES_OF_FREEDOM`) carries
    the chi-square density of its degrees of freedom scaled to the
    histogram (runs x bin width x density): the distribution of a run whose
    samples are fully correlated, the one the campaign's NEES band assumes;
    a time average of independent samples would be narrower about the same
    mean.

    Parameters
    ----------
    result : CampaignData
        The campaign.
    metrics : sequence of str, optional
        Metrics to show; default every metric.
    """
    names = list(result.metrics) if metrics is None else list(metrics)
    for m in names:
        if m not in result.metrics:
            raise ValueError(f"metric {m!r} is not in the result; metrics are {list(result.metrics)}")
    cols = min(3, max(1, len(names)))
    rows = max(1, math.ceil(len(names) / cols))
    fig = Figure(figsize=(4.2 * cols, 3.2 * rows), layout="constrained")
    ok = result.status == "ok"
    for i, m in enumerate(names):
        ax = fig.add_subplot(rows, cols, i + 1)
        scale = display_unit(m)[0]
        v = result.metrics[m][ok] * scale
        finite = v[np.isfinite(v)]
        if finite.size:
            edges = ax.hist(finite, bins=min(50, max(5, int(math.sqrt(finite.size)))), color="tab:blue", alpha=0.8)[1]
            ax.axvline(float(np.median(finite)), color="black", lw=1, label="median")
            if m in NEES_DEGREES_OF_FREEDOM:
                _chi2_reference(ax, finite, edges, NEES_DEGREES_OF_FREEDOM[m])
        for r in result.requirements:
            if r.metric == m:
                for bound in (r.min, r.max):
                    if bound is not None:
                        ax.axvline(bound * scale, color="tab:red", ls="--", lw=1.5, label=f"requirement {r.name}")
        extra = f", {v.size - finite.size} non-finite" if v.size > finite.size else ""
        ax.set_title(f"{m} ({finite.size} runs{extra})", fontsize=9)
        ax.set_xlabel(_label(m), fontsize=8)
        ax.set_ylabel("runs")
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        if finite.size:
            ax.legend(fontsize=7)
    fig.suptitle(f"Monte Carlo: {result.runs} runs, seed {result.seed}")
    return fig


def chi2_counts(x: ArrayLike, dof: int, runs: int, bin_width: float) -> NDArray[np.float64]:
    """Expected runs per bin of width ``bin_width`` at ``x`` for ``runs`` chi-square(``dof``) draws (scipy.stats.chi2).

    Parameters
    ----------
    x : array_like
        Where to evaluate (the NEES, >= 0).
    dof : int
        Degrees of freedom, >= 1.
    runs : int
        Number of runs in the histogram.
    bin_width : float
        Width of the histogram's bins (same unit as ``x``), > 0.
    """
    if int(dof) != dof or dof < 1:
        raise ValueError(f"dof must be a whole number >= 1, got {dof!r}")
    if not bin_width > 0.0:
        raise ValueError(f"bin_width must be > 0, got {bin_width!r}")
    return runs * bin_width * stats.chi2.pdf(np.asarray(x, dtype=float), int(dof))


def _chi2_reference(ax: Any, values: NDArray, edges: NDArray, dof: int) -> None:
    width = float(np.mean(np.diff(edges)))
    x = np.linspace(0.0, max(float(edges[-1]), float(stats.chi2.ppf(0.99, dof))), 300)
    # A run's NEES is a time average: chi-square(dof) if its samples were fully correlated, narrower about the
    # same mean otherwise; the widest distribution a consistent filter's runs can have.
    label = f"chi-square {dof} dof (fully correlated run)"
    ax.plot(x, chi2_counts(x, dof, values.size, width), color="tab:green", lw=1.5, label=label)
    ax.axvline(
        float(dof), color="tab:green", ls=":", lw=1, label=f"expected mean {dof} (these runs {np.mean(values):.2f})"
    )
    ax.set_ylim(top=1.5 * ax.get_ylim()[1])  # room for the legend above the bars


def _stack(result: CampaignData, key: str, component: int | None) -> tuple[NDArray, NDArray, str]:
    runs = [r for r, h in result.histories.items() if key in h and "t" in h]
    if not runs:
        raise ValueError(f"no run has a time history {key!r} (run the scenario with histories)")
    t = np.asarray(result.histories[runs[0]]["t"], dtype=float)
    series = []
    label = key
    for r in runs:
        h = result.histories[r]
        if h["t"].shape != t.shape or not np.array_equal(h["t"], t):
            raise ValueError(f"run {r} has another time grid; envelopes need one grid for all runs")
        v = np.asarray(h[key], dtype=float)
        if v.ndim == 2:
            v = np.linalg.norm(v, axis=-1) if component is None else v[:, component]
            label = f"|{key}|" if component is None else f"{key}[{component}]"
        series.append(v)
    return t, np.array(series), label


def _requirement_bound(result: CampaignData, key: str, norm: bool) -> tuple[str, float] | None:
    """Label and upper bound [SI] of the requirement on the metric that bounds history ``key`` (None if none).

    ``norm``: the envelope shows the norm of a vector history (else a
    component or a scalar history).
    """
    if norm != (key in NORM_BOUNDED_HISTORIES):
        return None
    for metric in ENVELOPE_REQUIREMENTS.get(key, ()):
        for r in result.requirements:
            if r.metric == metric and r.max is not None:
                return f"requirement {r.name} ({metric})", float(r.max)
    return None


def _draw_bands(ax: Any, t: NDArray, values: NDArray) -> None:
    with np.errstate(invalid="ignore"):
        for (lo, hi), alpha in zip(ENVELOPE_BANDS, (0.15, 0.3, 0.45)):
            band = np.nanpercentile(values, [lo, hi], axis=0)
            ax.fill_between(t, band[0], band[1], color="tab:blue", alpha=alpha, lw=0, label=f"{lo:g}-{hi:g} %")
        ax.plot(t, np.nanmedian(values, axis=0), color="black", lw=1.2, label="median")


def plot_envelope(
    result: CampaignData,
    key: str,
    component: int | str | None = None,
    *,
    lines: Mapping[str, ArrayLike] | None = None,
    overlays: Mapping[int, Mapping[str, ArrayLike]] | None = None,
    windows: Mapping[str, float] | None = None,
) -> Figure:
    """Percentile bands over the runs of a time history (min-max, 5-95 %, 25-75 %, median), with its limits.

    The upper bound of the requirement on the metric that bounds the
    history (:data:`ENVELOPE_REQUIREMENTS`: the largest error over the hold (or the final one) for
    ``error_angle``, the peak rate for ``|omega|``, the peak wheel speed for
    each wheel) is drawn dashed red, and ``lines`` add the limits the
    campaign has no requirement for (a wheel's speed limit).

    Parameters
    ----------
    result : CampaignData
        The campaign.
    key : str
        History name (``"error_angle"``, ``"omega"``, ``"wheel_speed"`` ...).
    component : int, "each" or None
        For a vector history: the component to show, ``"each"`` for one
        panel per component, or None for its norm.
    lines : mapping of str to float or array_like, optional
        Labelled horizontal limits in the history's SI unit; an array gives
        one value per component (with ``"each"``). On components they are
        drawn at plus and minus the value (a limit on the magnitude).
    overlays : mapping of int to mapping, optional
        Runs drawn as lines over the bands, by run number: each a history with ``t`` and ``key`` (for
        instance a failing run flown again at every tick, whose excursion the thinned bands can miss).
    windows : mapping of str to float, optional
        The requirements' windows [s] (``slew_end_s``, ``hold_start_s``, ``hold_end_s``): on the error
        histories the settling allowance and the hold are shaded (the pointing requirement holds over the hold).
    """
    if component == "each":
        return _plot_envelope_each(result, key, lines or {})
    if isinstance(component, str):
        raise ValueError(f"component must be an integer, 'each' or None, got {component!r}")
    t, values, what = _stack(result, key, component)
    scale, unit = display_unit(key)
    values = values * scale
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    _draw_bands(ax, t, values)
    vector = np.ndim(next(h[key] for h in result.histories.values() if key in h and "t" in h)) == 2
    norm = component is None and vector
    bound = _requirement_bound(result, key, norm)
    if bound is not None:
        ax.axhline(bound[1] * scale, color="tab:red", ls="--", lw=1.2, label=bound[0])
    for label, value in (lines or {}).items():
        if vector and component is not None:  # a limit on one component's magnitude
            level = float(np.ravel(np.asarray(value, dtype=float))[component if np.size(value) > 1 else 0])
            ax.axhline(-level * scale, color="tab:red", ls="-.", lw=1.0)
        else:
            level = float(np.max(value))
        ax.axhline(level * scale, color="tab:red", ls="-.", lw=1.0, label=label)
    if windows is not None and key in ("error_angle", "tracking_error"):
        ax.axvspan(windows["slew_end_s"], windows["hold_start_s"], color="tab:orange", alpha=0.08, label="settling")
        ax.axvspan(windows["hold_start_s"], windows["hold_end_s"], color="tab:green", alpha=0.08, label="hold")
    for run, history in (overlays or {}).items():
        if key in history and "t" in history:
            y = np.asarray(history[key], dtype=float)
            if y.ndim == 2:
                y = np.linalg.norm(y, axis=1) if component is None else y[:, component]
            ax.plot(history["t"], y * scale, lw=0.8, label=f"run {run} (fails; every tick)")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"{what} [{unit}]" if unit else what)
    if key in ("error_angle", "tracking_error", "estimation_error") and np.nanmin(values) > 0:
        ax.set_yscale("log")
    ax.set_title(f"{what}: envelope of {values.shape[0]} runs")
    ax.legend(fontsize=8)
    return fig


def _plot_envelope_each(result: CampaignData, key: str, lines: Mapping[str, ArrayLike]) -> Figure:
    """One envelope panel per component of a vector history, each with its limits at plus and minus."""
    first = next((h[key] for h in result.histories.values() if key in h and "t" in h), None)
    if first is None:
        raise ValueError(f"no run has a time history {key!r} (run the scenario with histories)")
    if np.ndim(first) != 2:
        raise ValueError(f"component='each' needs a vector history; {key!r} has shape {np.shape(first)}")
    n = int(np.shape(first)[1])
    scale, unit = display_unit(key)
    bound = _requirement_bound(result, key, norm=False)
    fig = Figure(figsize=(8, 1.9 * n + 0.9), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for i, ax in enumerate(axes):
        t, values, what = _stack(result, key, i)
        _draw_bands(ax, t, values * scale)
        drawn = [] if bound is None else [(bound[0], bound[1], "--")]
        for label, value in lines.items():
            per = np.broadcast_to(np.asarray(value, dtype=float), (n,))
            drawn.append((label, float(per[i]), "-."))
        for label, value, style in drawn:
            for sign in (1.0, -1.0):
                ax.axhline(sign * value * scale, color="tab:red", ls=style, lw=1.0, label=label if sign > 0 else None)
        peak = float(np.nanmax(np.abs(values))) * scale
        note = f"peak |{what}| {peak:.4g} {unit}".rstrip()
        if drawn:
            label, value, _ = min(drawn, key=lambda d: d[1])
            note += f": {100.0 * peak / (value * scale):.3g} % of the {label}"
        box = {"facecolor": "white", "alpha": 0.8, "lw": 0}
        ax.text(0.99, 0.75, note, transform=ax.transAxes, ha="right", va="center", fontsize=7, color="0.25", bbox=box)
        ax.set_ylabel(f"{what} [{unit}]" if unit else what, fontsize=8)
        ax.grid(True, alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncols=5, fontsize=7)
    axes[-1].set_xlabel("t [s]")
    runs = sum(1 for h in result.histories.values() if key in h)
    fig.suptitle(f"{key}: envelope of {runs} runs, one panel per component")
    return fig


def plot_scatter(result: CampaignData, metric: str, parameter: str) -> Figure:
    """A metric against a dispersed parameter; runs that failed a requirement in red.

    Parameters
    ----------
    result : CampaignData
        The campaign.
    metric : str
        Name of the metric (vertical axis).
    parameter : str
        Table column of the dispersed parameter (horizontal axis).
    """
    if metric not in result.metrics:
        raise ValueError(f"metric {metric!r} is not in the result; metrics are {list(result.metrics)}")
    if parameter not in result.parameters:
        raise ValueError(f"parameter {parameter!r} is not in the result; parameters are {list(result.parameters)}")
    fig = Figure(figsize=(6, 4.5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    x = result.parameters[parameter] * display_unit(parameter)[0]
    y_scale = display_unit(metric)[0]
    y = result.metrics[metric] * y_scale
    passed = result.passed
    ax.scatter(x[passed], y[passed], s=8, color="tab:blue", label=f"pass ({int(passed.sum())})")
    failed = ~passed & (result.status == "ok")
    if np.any(failed):
        ax.scatter(x[failed], y[failed], s=12, color="tab:red", marker="x", label=f"fail ({int(failed.sum())})")
    for r in result.requirements:
        if r.metric == metric:
            for bound in (r.min, r.max):
                if bound is not None:
                    ax.axhline(bound * y_scale, color="tab:red", ls="--", lw=1, label=f"requirement {r.name}")
    ax.set_xlabel(_label(parameter))
    ax.set_ylabel(_label(metric))
    ax.legend(fontsize=8)
    return fig


def most_influential_parameter(result: CampaignData, metric: str) -> str | None:
    """The dispersed parameter with the largest |Spearman rank correlation| with ``metric`` (None if undecidable).

    Parameters
    ----------
    result : CampaignData
        The campaign.
    metric : str
        Name of the metric.
    """
    y = result.metrics[metric]
    ok = (result.status == "ok") & np.isfinite(y)
    best, score = None, -1.0
    for name, x in result.parameters.items():
        if ok.sum() < 3 or np.ptp(x[ok]) == 0 or np.ptp(y[ok]) == 0:
            continue
        rho = abs(float(stats.spearmanr(x[ok], y[ok]).statistic))
        if np.isfinite(rho) and rho > score:
            best, score = name, rho
    return best


def save_figures(
    result: CampaignData,
    directory: str | Path,
    *,
    lines: Mapping[str, Mapping[str, ArrayLike]] | None = None,
    overlays: Mapping[int, Mapping[str, ArrayLike]] | None = None,
    windows: Mapping[str, float] | None = None,
) -> list[Path]:
    """Histograms, an envelope per history, and per requirement metric a scatter against its most influential parameter.

    Returns the paths written (PNG). The histories of
    :data:`PER_COMPONENT_HISTORIES` are drawn one panel per component.

    Parameters
    ----------
    result : CampaignData
        The campaign.
    directory : str or Path
        Folder for the PNG files (created).
    lines : mapping, optional
        Per history name, labelled limits for its envelope (:func:`plot_envelope`),
        e.g. ``{"wheel_speed": {"wheel speed limit": speed_max}}`` [SI].
    overlays : mapping of int to mapping, optional
        Runs drawn as lines on the envelopes of scalar histories (:func:`plot_envelope`), by run number.
    windows : mapping of str to float, optional
        The requirements' windows [s], shaded on the error envelopes (:func:`plot_envelope`).
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = []

    def save(fig: Figure, name: str) -> None:
        path = out / name
        fig.savefig(path, dpi=110)
        paths.append(path)

    if result.metrics:
        save(plot_histograms(result), "histograms.png")
    keys = sorted({k for h in result.histories.values() for k in h if k != "t"})
    for key in keys:
        try:
            component = "each" if key in PER_COMPONENT_HISTORIES else None
            drawn = None if component == "each" else overlays
            fig = plot_envelope(result, key, component, lines=(lines or {}).get(key), overlays=drawn, windows=windows)
            save(fig, f"envelope_{key}.png")
        except ValueError:
            continue
    for metric in dict.fromkeys(r.metric for r in result.requirements):
        if metric in result.metrics:
            parameter = most_influential_parameter(result, metric)
            if parameter is not None:
                save(plot_scatter(result, metric, parameter), f"scatter_{metric}.png")
    return paths


def _requirement(requirements: Sequence[Any], metric: str) -> Any:
    """The first requirement on ``metric`` (None if none)."""
    return next((r for r in requirements if r.metric == metric), None)


def plot_run(
    history: dict[str, NDArray[Any]],
    requirements: Sequence[Any] = (),
    *,
    metrics: dict[str, float] | None = None,
    title: str = "",
    wheel_speed_limit: Sequence[float] | None = None,
    windows: dict[str, float] | None = None,
) -> dict[str, Figure]:
    """The figures of one run: pointing error to the target, body rates, wheel speeds (review units).

    ``pointing_error``: the error angle to the target attitude [deg] (log
    scale) with the pointing accuracy (the requirement on
    ``pointing_error_hold``, else on ``final_pointing_error``), the time by
    which ``settling_time`` must be reached, the run's own settling time
    and, with ``windows``, the settling allowance and the hold shaded.
    ``rates``: the body rates and their norm [deg/s] with the
    requirement on ``rate_peak``. ``wheel_speeds``: each wheel's speed
    relative to the body [rpm] with its limit (``+-`` the speed at which it
    holds its largest momentum). A figure whose history is missing is left out.

    Parameters
    ----------
    history : dict of ndarray
        ``t`` [s], ``error_angle`` (n,) [rad] to the target, ``omega`` (n, 3)
        [rad/s], ``wheel_speed`` (n, n_wheels) [rad/s].
    requirements : sequence of Requirement, optional
        The campaign's requirements (those on ``final_pointing_error``,
        ``settling_time`` and ``rate_peak`` are drawn, in SI).
    metrics : dict of float, optional
        The run's metrics, SI (its ``settling_time`` [s] is marked).
    title : str, optional
        What the run is (``"run 12 of the campaign, seed 12345"``), above each figure.
    wheel_speed_limit : sequence of float, optional
        Each wheel's speed limit [rad/s] (``momentum_max / spin_inertia``).
    windows : dict of float, optional
        The requirements' windows [s]: ``slew_end_s``, ``hold_start_s``, ``hold_end_s``
        (:class:`attitude.simulation.slew_windows.SlewWindows`).

    Returns
    -------
    dict of str to Figure
        ``pointing_error``, ``rates``, ``wheel_speeds`` (those with a history).
    """
    t = np.asarray(history["t"], dtype=float)
    metrics = metrics or {}
    figures: dict[str, Figure] = {}
    deg = 180.0 / math.pi

    def new(what: str) -> Any:
        fig = Figure(figsize=(9, 4.2), layout="constrained")
        ax = fig.add_subplot(1, 1, 1)
        ax.set_title(f"{title}: {what}" if title else what, fontsize=10)
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
        ax.set_xlim(t[0], t[-1])
        return fig, ax

    def legend(ax: Any) -> None:  # beside the axes: nothing drawn is hidden under it
        ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)

    if "error_angle" in history:
        fig, ax = new("pointing error to the target attitude")
        error = np.asarray(history["error_angle"], dtype=float) * deg
        ax.semilogy(t, np.where(error > 0.0, error, np.nan), color="black", lw=1.0, label="error to the target")
        pointing = _requirement(requirements, "pointing_error_hold") or _requirement(
            requirements, "final_pointing_error"
        )
        if windows is not None:
            ax.axvspan(
                windows["slew_end_s"], windows["hold_start_s"], color="tab:orange", alpha=0.10, label="settling allowed"
            )
            ax.axvspan(
                windows["hold_start_s"],
                windows["hold_end_s"],
                color="tab:green",
                alpha=0.12,
                label="hold: pointing judged",
            )
        if pointing is not None and pointing.max is not None:
            accuracy = pointing.max * deg
            ax.axhline(accuracy, color="tab:red", ls="--", lw=1.2, label=f"{pointing.name}: {accuracy:.4g} deg")
        settling = _requirement(requirements, "slew_time") or _requirement(requirements, "settling_time")
        if settling is not None and settling.max is not None:
            label = f"{settling.name}: settled by {settling.max:.4g} s"
            if settling.max <= t[-1]:
                ax.axvline(settling.max, color="tab:red", ls=":", lw=1.5, label=label)
            else:  # after the end of the run: named, not drawn (the axis keeps the run's time)
                ax.plot([], [], " ", label=f"{label} (after this run's end)")
        settled = metrics.get("slew_time", metrics.get("settling_time"))
        if settled is not None:
            if math.isfinite(settled):
                ax.axvline(settled, color="tab:green", ls="-.", lw=1.2, label=f"settled at {settled:.4g} s")
            else:
                ax.plot([], [], " ", label="never settled")
        ax.set_ylabel("error to the target [deg]")
        legend(ax)
        figures["pointing_error"] = fig
    if "omega" in history:
        fig, ax = new("body rates")
        omega = np.asarray(history["omega"], dtype=float) * deg
        for i, name in enumerate("xyz"):
            ax.plot(t, omega[:, i], color=AXIS_COLORS[i], lw=1.0, label=rf"$\omega_{name}$")
        ax.plot(t, np.linalg.norm(omega, axis=1), color="black", lw=1.0, label=r"$|\omega|$")
        rate = _requirement(requirements, "rate_peak")
        if rate is not None and rate.max is not None:
            limit = rate.max * deg
            ax.axhline(
                limit, color="tab:red", ls="--", lw=1.2, label=rf"{rate.name}: $|\omega|$ at most {limit:.4g} deg/s"
            )
        ax.set_ylabel("body rate [deg/s]")
        legend(ax)
        figures["rates"] = fig
    speeds = np.asarray(history.get("wheel_speed", np.zeros((t.size, 0))), dtype=float)
    if speeds.ndim == 2 and speeds.shape[1] > 0:
        fig, ax = new("wheel speeds relative to the body")
        rpm = speeds * 30.0 / math.pi
        for i in range(rpm.shape[1]):
            ax.plot(t, rpm[:, i], color=_WHEEL_COLORS[i % len(_WHEEL_COLORS)], lw=1.0, label=f"wheel {i + 1}")
        if wheel_speed_limit is not None:
            limits = sorted({round(float(v) * 30.0 / math.pi, 9) for v in np.atleast_1d(wheel_speed_limit)})
            for limit in limits:
                ax.axhline(limit, color="tab:red", ls="--", lw=1.2, label=f"limit +-{limit:.4g} rpm")
                ax.axhline(-limit, color="tab:red", ls="--", lw=1.2)
        ax.set_ylabel("wheel speed [rpm]")
        legend(ax)
        figures["wheel_speeds"] = fig
    return figures

"""Figures of a Monte Carlo campaign; each function returns its ``matplotlib.figure.Figure``.

Built with the object-oriented API (no pyplot state), as :mod:`attitude.plotting`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray
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
    histories: dict[int, dict[str, NDArray[Any]]]

    @property
    def runs(self) -> int: ...

    @property
    def passed(self) -> NDArray[np.bool_]: ...


__all__ = [
    "CampaignData",
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


def _label(name: str) -> str:
    unit = display_unit(name)[1]
    return f"{name} [{unit}]" if unit else name


def plot_histograms(result: CampaignData, metrics: Sequence[str] | None = None) -> Figure:
    """One histogram per metric over the completed runs, with requirement bounds (dashed red).

    Non-finite values (a run that never settled has ``settling_time = inf``)
    are counted in the panel title, not drawn.

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
            ax.hist(finite, bins=min(50, max(5, int(math.sqrt(finite.size)))), color="tab:blue", alpha=0.8)
            ax.axvline(float(np.median(finite)), color="black", lw=1, label="median")
        for r in result.requirements:
            if r.metric == m:
                for bound in (r.min, r.max):
                    if bound is not None:
                        ax.axvline(bound * scale, color="tab:red", ls="--", lw=1.5, label=f"requirement {r.name}")
        extra = f", {v.size - finite.size} non-finite" if v.size > finite.size else ""
        ax.set_title(f"{m} ({finite.size} runs{extra})", fontsize=9)
        ax.set_xlabel(_label(m), fontsize=8)
        ax.set_ylabel("runs")
        if finite.size:
            ax.legend(fontsize=7)
    fig.suptitle(f"Monte Carlo: {result.runs} runs, seed {result.seed}")
    return fig


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


def plot_envelope(result: CampaignData, key: str, component: int | None = None) -> Figure:
    """Percentile bands over the runs of a time history (min-max, 5-95 %, 25-75 %, median).

    Parameters
    ----------
    result : CampaignData
    key : str
        History name (``"error_angle"``, ``"omega"`` ...).
    component : int, optional
        For a vector history, the component to show; default its norm.
    """
    t, values, what = _stack(result, key, component)
    scale, unit = display_unit(key)
    values = values * scale
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    with np.errstate(invalid="ignore"):
        for (lo, hi), alpha in zip(ENVELOPE_BANDS, (0.15, 0.3, 0.45)):
            band = np.nanpercentile(values, [lo, hi], axis=0)
            ax.fill_between(t, band[0], band[1], color="tab:blue", alpha=alpha, lw=0, label=f"{lo:g}-{hi:g} %")
        ax.plot(t, np.nanmedian(values, axis=0), color="black", lw=1.2, label="median")
    ax.set_xlabel("t [s]")
    ax.set_ylabel(f"{what} [{unit}]" if unit else what)
    if key in ("error_angle", "tracking_error", "estimation_error") and np.nanmin(values) > 0:
        ax.set_yscale("log")
    ax.set_title(f"{what}: envelope of {values.shape[0]} runs")
    ax.legend(fontsize=8)
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


def save_figures(result: CampaignData, directory: str | Path) -> list[Path]:
    """Histograms, an envelope per history, and per requirement metric a scatter against its most influential parameter.

    Returns the paths written (PNG).

    Parameters
    ----------
    result : CampaignData
        The campaign.
    directory : str or Path
        Folder for the PNG files (created).
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
            save(plot_envelope(result, key), f"envelope_{key}.png")
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
) -> dict[str, Figure]:
    """The figures of one run: pointing error to the target, body rates, wheel speeds (review units).

    ``pointing_error``: the error angle to the target attitude [deg] (log
    scale) with the requirement on ``final_pointing_error`` (the accuracy),
    the time by which ``settling_time`` must be reached and the run's own
    settling time. ``rates``: the body rates and their norm [deg/s] with the
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
        pointing = _requirement(requirements, "final_pointing_error")
        if pointing is not None and pointing.max is not None:
            accuracy = pointing.max * deg
            ax.axhline(accuracy, color="tab:red", ls="--", lw=1.2, label=f"{pointing.name}: {accuracy:.4g} deg")
        settling = _requirement(requirements, "settling_time")
        if settling is not None and settling.max is not None:
            label = f"{settling.name}: settled by {settling.max:.4g} s"
            if settling.max <= t[-1]:
                ax.axvline(settling.max, color="tab:red", ls=":", lw=1.5, label=label)
            else:  # after the end of the run: named, not drawn (the axis keeps the run's time)
                ax.plot([], [], " ", label=f"{label} (after this run's end)")
        settled = metrics.get("settling_time")
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

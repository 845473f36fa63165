"""Filter consistency: NEES and NIS, chi-square bands, Monte Carlo averages and plots.

A filter is consistent when its errors are zero-mean and its covariance is
the covariance of its errors (Bar-Shalom, Li and Kirubarajan, *Estimation
with Applications to Tracking and Navigation*, 2001, sec. 5.4). Two tests
follow:

- NEES, the normalised estimation error squared ``e^T P^-1 e`` with
  ``e = x_true - x_est`` (needs the truth: simulation only), is chi-square
  with ``n`` degrees of freedom (``n`` the state dimension);
- NIS, the normalised innovation squared ``nu^T S^-1 nu`` with ``nu`` the
  innovation and ``S`` its covariance (flight data too), is chi-square with
  ``m`` degrees of freedom (``m`` the measurement dimension).

Averaged over ``N`` independent Monte Carlo runs (independent seeds), ``N``
times the average is chi-square with ``N n`` degrees of freedom, so the
two-sided band at confidence ``1 - a`` for the average is
``chi2.ppf([a/2, 1 - a/2], N n) / N`` (:func:`chi2_band`, scipy.stats.chi2).
The same holds for a moving average of ``w`` consecutive NIS values of one
run, because the innovations of an optimal filter are white
(:func:`nis_health`).

``filterpy.stats.NEES`` (named ``NESS`` before filterpy 2.0.0) computes the
same number, but loops over the samples of one run in Python and inverts
``P``. :func:`nees` and :func:`nis` take any batch shape (runs x times) in
one call and use a Cholesky factor and a linear solve, which is better
conditioned and rejects a covariance that is not positive definite instead
of returning a meaningless number. The tests check that both agree.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from attitude.validation import as_float_array, describe

__all__ = [
    "GATE_PROBABILITY",
    "NIS_CAP",
    "SPREAD_WINDOW_FRACTION",
    "TRANSIENT_FRACTION_MAX",
    "TRANSIENT_RATIO",
    "NisHealth",
    "average_nees",
    "average_nis",
    "band_verdict",
    "chi2_band",
    "fraction_inside_band",
    "gate_threshold",
    "nees",
    "nis",
    "nis_health",
    "plot_errors_with_bounds",
    "plot_nees",
]

#: Default probability of the filters' innovation gate: chi-square(3) gate at NIS 44.8
#: (one good sample in 10^9 rejected).
GATE_PROBABILITY = 1.0 - 1e-9
#: NIS recorded for a gated sample whose NIS is not finite in float64 (keeps window sums finite).
NIS_CAP = 1e300


def _check_confidence(confidence: float) -> float:
    c = as_float_array(confidence, "confidence")
    if c.ndim != 0 or not 0.0 < float(c) < 1.0:
        raise ValueError(f"confidence must be a scalar in (0, 1), got {describe(c)}")
    return float(c)


def _check_count(value: int, name: str) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def _normalised_squares(
    vectors: ArrayLike, covariances: ArrayLike, vec_name: str, cov_name: str
) -> NDArray[np.float64]:
    """``v^T C^-1 v`` over broadcast batches, through a Cholesky factor and a solve."""
    v = as_float_array(vectors, vec_name)
    c = as_float_array(covariances, cov_name)
    if v.ndim < 1:
        raise ValueError(f"{vec_name} must have shape (..., n), got a scalar")
    n = v.shape[-1]
    if c.ndim < 2 or c.shape[-2:] != (n, n):
        raise ValueError(f"{cov_name} must have shape (..., {n}, {n}) to match {vec_name} (..., {n}), got {c.shape}")
    try:
        batch = np.broadcast_shapes(v.shape[:-1], c.shape[:-2])
    except ValueError as exc:
        raise ValueError(
            f"{vec_name} batch shape {v.shape[:-1]} and {cov_name} batch shape {c.shape[:-2]} do not broadcast"
        ) from exc
    asym = np.abs(c - np.swapaxes(c, -1, -2))
    scale = np.maximum(np.abs(c).max(axis=(-1, -2), keepdims=True), np.finfo(float).tiny)
    if np.any(asym > 1e-9 * scale):
        raise ValueError(f"{cov_name} must be symmetric; found a relative asymmetry of {np.max(asym / scale):.3g}")
    try:
        chol = np.linalg.cholesky(c)
    except np.linalg.LinAlgError as exc:
        raise ValueError(f"{cov_name} must be positive definite; a Cholesky factorisation failed") from exc
    chol = np.broadcast_to(chol, (*batch, n, n))
    vb = np.broadcast_to(v, (*batch, n))
    z = np.linalg.solve(chol, vb[..., None])[..., 0]
    return np.sum(z * z, axis=-1)


def nees(errors: ArrayLike, covariances: ArrayLike) -> NDArray[np.float64]:
    """Normalised estimation error squared ``e^T P^-1 e`` (dimensionless).

    Parameters
    ----------
    errors : array_like (..., n)
        Estimation errors ``x_true - x_est`` (any consistent units; for
        attitude, the error rotation vector [rad]).
    covariances : array_like (..., n, n)
        The filter's error covariances, in the squared units of ``errors``;
        batch shapes broadcast.

    Returns
    -------
    ndarray (...)
        One NEES per error vector; chi-square with ``n`` degrees of freedom
        for a consistent filter.

    Raises
    ------
    ValueError
        For mismatched shapes, non-finite values, or a covariance that is not
        symmetric (to 1e-9 of its largest entry) positive definite.
    """
    return _normalised_squares(errors, covariances, "errors", "covariances")


def nis(innovations: ArrayLike, innovation_covariances: ArrayLike) -> NDArray[np.float64]:
    """Normalised innovation squared ``nu^T S^-1 nu`` (dimensionless).

    Parameters
    ----------
    innovations : array_like (..., m)
        Innovations ``z - h(x_pred)`` in measurement units.
    innovation_covariances : array_like (..., m, m)
        Their predicted covariances ``S = H P H^T + R``.

    Returns
    -------
    ndarray (...)
        Chi-square with ``m`` degrees of freedom for a consistent filter.
    """
    return _normalised_squares(innovations, innovation_covariances, "innovations", "innovation_covariances")


def chi2_band(dof: int, n_runs: int = 1, confidence: float = 0.95) -> tuple[float, float]:
    """Two-sided band for the average of ``n_runs`` independent chi-square(``dof``) values.

    ``chi2.ppf([a/2, 1 - a/2], dof * n_runs) / n_runs`` with ``a = 1 - confidence``.

    Parameters
    ----------
    dof : int
        Degrees of freedom of each value (state or measurement dimension).
    n_runs : int
        Number of independent values averaged (Monte Carlo runs, or the
        window of a moving average of a white sequence).
    confidence : float
        Probability that the average lies inside the band, in (0, 1).

    Returns
    -------
    (float, float)
        Lower and upper bound.
    """
    dof = _check_count(dof, "dof")
    n_runs = _check_count(n_runs, "n_runs")
    a = 1.0 - _check_confidence(confidence)
    lo, hi = stats.chi2.ppf([a / 2.0, 1.0 - a / 2.0], dof * n_runs) / n_runs
    return float(lo), float(hi)


def band_verdict(mean: float, low: float, high: float) -> str:
    """A mean NEES (or NIS) against its band: ``"consistent"``, ``"over-confident"`` or ``"conservative"``.

    Parameters
    ----------
    mean : float
        The averaged statistic.
    low, high : float
        Its band (:func:`chi2_band`).

    Returns
    -------
    str
        ``"over-confident"`` above the band (the covariance too small),
        ``"conservative"`` below it, ``"consistent"`` inside.
    """
    if mean > high:
        return "over-confident"
    if mean < low:
        return "conservative"
    return "consistent"


def gate_threshold(gate_probability: float | None, dof: int) -> float:
    """The innovation gate: the NIS below which a measurement of ``dof`` components is applied.

    ``chi2.ppf(gate_probability, dof)``: a consistent filter rejects a good
    sample with probability ``1 - gate_probability``.

    Parameters
    ----------
    gate_probability : float or None
        Probability in (0, 1) that a good sample passes (checked by the caller); None disables the gate.
    dof : int
        Components of the measurement.

    Returns
    -------
    float
        The NIS threshold (inf when disabled).
    """
    if gate_probability is None:
        return math.inf
    return float(stats.chi2.ppf(gate_probability, dof))


def average_nees(errors: ArrayLike, covariances: ArrayLike, axis: int = 0) -> NDArray[np.float64]:
    """NEES averaged over Monte Carlo runs.

    Parameters
    ----------
    errors : array_like (n_runs, n_times, n)
        Estimation errors of each run (runs along ``axis``).
    covariances : array_like (n_runs, n_times, n, n) or (n_times, n, n)
        Covariances of each run, or one shared history.
    axis : int
        The runs axis of the NEES array ``(n_runs, n_times)``.

    Returns
    -------
    ndarray (n_times,)
        Compare with :func:`chi2_band` ``(n, n_runs)``.
    """
    return np.mean(nees(errors, covariances), axis=axis)


def average_nis(innovations: ArrayLike, innovation_covariances: ArrayLike, axis: int = 0) -> NDArray[np.float64]:
    """NIS averaged over Monte Carlo runs (see :func:`average_nees`).

    Parameters
    ----------
    innovations : array_like (n_runs, n_times, m) or (n_times, m)
        Innovations of each run (runs along ``axis``).
    innovation_covariances : array_like (n_runs, n_times, m, m) or (n_times, m, m)
        Innovation covariances of each run, or one shared history.
    axis : int
        The runs axis of the NIS array ``(n_runs, n_times)``.
    """
    return np.mean(nis(innovations, innovation_covariances), axis=axis)


def fraction_inside_band(values: ArrayLike, dof: int, n_runs: int = 1, confidence: float = 0.95) -> float:
    """Fraction of ``values`` (averaged NEES or NIS) inside :func:`chi2_band` ``(dof, n_runs, confidence)``.

    About ``confidence`` for a consistent filter. NaN entries (no sample)
    are left out; infinite ones count as outside.

    Parameters
    ----------
    values : array_like
        Averaged NEES or NIS values.
    dof : int
        Degrees of freedom (state or measurement dimension).
    n_runs : int, optional
        Number of runs averaged in each value.
    confidence : float, optional
        Two-sided confidence of the band, in (0, 1).
    """
    v = as_float_array(values, "values", allow_nonfinite=True).ravel()
    v = v[~np.isnan(v)]
    if v.size == 0:
        raise ValueError("values must hold at least one non-NaN entry")
    lo, hi = chi2_band(dof, n_runs, confidence)
    return float(np.mean((v >= lo) & (v <= hi)))


@dataclass(frozen=True)
class NisHealth:
    """Result of :func:`nis_health`.

    Attributes
    ----------
    window_mean : ndarray (n_valid - window + 1,)
        Mean NIS of each window of ``window`` consecutive valid samples.
    window_start : ndarray (n_valid - window + 1,) of int
        Index (into the input sequence) of each window's first sample.
    band : (float, float)
        The chi-square band of a window mean.
    flagged : ndarray (n,) of bool
        Samples belonging to at least one out-of-band window.
    intervals : list of (int, int)
        Runs of flagged samples as ``(start, stop)`` indices into the input,
        ``stop`` exclusive.
    interval_times : list of (float, float)
        The same as ``(t[start], t[stop - 1])`` [s] when ``t`` was given.
    """

    window_mean: NDArray[np.float64]
    window_start: NDArray[np.int64]
    band: tuple[float, float]
    flagged: NDArray[np.bool_]
    intervals: list[tuple[int, int]] = field(default_factory=list)
    interval_times: list[tuple[float, float]] = field(default_factory=list)

    @property
    def healthy(self) -> bool:
        """True when no window left the band."""
        return not self.intervals


def nis_health(
    nis_sequence: ArrayLike,
    dof: int,
    window: int,
    confidence: float = 0.99999,
    t: ArrayLike | None = None,
) -> NisHealth:
    """Flag stretches where the moving-window mean NIS leaves its chi-square band.

    For a consistent filter the innovations are white, so the mean of
    ``window`` consecutive NIS values is chi-square(``dof * window``) /
    ``window``; a window outside :func:`chi2_band` ``(dof, window,
    confidence)`` is flagged (above: the filter is over-confident or the
    measurements are biased; below: it is too pessimistic). Every sample of a
    flagged window is flagged, so an interval can extend up to ``window - 1``
    samples beyond the offending stretch on each side.

    ``confidence`` applies to each window, and the windows slide one sample
    at a time, so overlapping windows give many more chances of a false alarm
    than ``n / window`` independent ones would. Measured on white
    chi-square(3) NIS sequences of 2000 samples with a 50-sample window
    (400 runs): a clean run is flagged somewhere 25% of the time at
    confidence 0.999, 5% at 0.9999 and 0.5% at the default 0.99999.

    Parameters
    ----------
    nis_sequence : array_like (n,)
        NIS values of one run in time order; NaN marks samples without a
        measurement (skipped: windows run over the valid samples).
    dof : int
        Measurement dimension.
    window : int
        Number of valid samples per window (>= 1).
    confidence : float
        Per-window confidence in (0, 1).
    t : array_like (n,), optional
        Sample times [s], for :attr:`NisHealth.interval_times`.

    Returns
    -------
    NisHealth

    Raises
    ------
    ValueError
        For a negative or infinite NIS, fewer valid samples than ``window``,
        or a ``t`` of another length.
    """
    values = as_float_array(nis_sequence, "nis_sequence", allow_nonfinite=True)
    if values.ndim != 1:
        raise ValueError(f"nis_sequence must be 1-D (one run in time order), got shape {values.shape}")
    valid = ~np.isnan(values)
    if np.any(np.isinf(values)):
        raise ValueError("nis_sequence must be finite (NaN marks a missing sample); found inf")
    if np.any(values[valid] < 0):
        raise ValueError(f"nis_sequence must be non-negative, found {values[valid].min()!r}")
    window = _check_count(window, "window")
    index = np.nonzero(valid)[0]
    if index.size < window:
        raise ValueError(f"nis_sequence has {index.size} valid samples, fewer than window = {window}")
    times = None
    if t is not None:
        times = as_float_array(t, "t")
        if times.shape != values.shape:
            raise ValueError(f"t must have the shape of nis_sequence {values.shape}, got {times.shape}")
    lo, hi = chi2_band(dof, window, confidence)
    csum = np.concatenate([[0.0], np.cumsum(values[valid])])
    means = (csum[window:] - csum[:-window]) / window
    out = (means < lo) | (means > hi)
    # Mark the valid samples of every out-of-band window (difference array over valid positions).
    marks = np.zeros(index.size + 1, dtype=np.int64)
    bad = np.nonzero(out)[0]
    np.add.at(marks, bad, 1)
    np.add.at(marks, bad + window, -1)
    flagged_valid = np.cumsum(marks[:-1]) > 0
    flagged = np.zeros(values.size, dtype=bool)
    flagged[index[flagged_valid]] = True
    intervals: list[tuple[int, int]] = []
    if np.any(flagged_valid):
        fv = flagged_valid.astype(np.int8)
        edges = np.diff(np.concatenate([[0], fv, [0]]))
        starts = np.nonzero(edges == 1)[0]
        stops = np.nonzero(edges == -1)[0]
        intervals = [(int(index[a]), int(index[b - 1]) + 1) for a, b in zip(starts, stops)]
    interval_times = [] if times is None else [(float(times[a]), float(times[b - 1])) for a, b in intervals]
    return NisHealth(
        window_mean=means,
        window_start=index[: means.size],
        band=(lo, hi),
        flagged=flagged,
        intervals=intervals,
        interval_times=interval_times,
    )


# ---------------------------------------------------------------------------
# Plots


def plot_nees(
    t: ArrayLike,
    avg_nees: ArrayLike,
    dof: int,
    n_runs: int,
    *,
    confidence: float = 0.95,
    quantity: str = "NEES",
    title: str | None = None,
) -> Figure:
    """Monte-Carlo-averaged NEES (or NIS) against time with its chi-square band.

    Parameters
    ----------
    t : array_like (n,)
        Time [s].
    avg_nees : array_like (n,)
        Average over ``n_runs`` runs (NaN where there is no sample).
    dof : int
        Degrees of freedom of one value (state or measurement dimension).
    n_runs : int
        Number of runs averaged.
    confidence : float
        Confidence of the band.
    quantity : str
        Name on the axis ("NEES" or "NIS").
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = as_float_array(t, "t")
    v = as_float_array(avg_nees, "avg_nees", allow_nonfinite=True)
    if t.ndim != 1 or v.shape != t.shape:
        raise ValueError(f"avg_nees must have the shape of t {t.shape}, got {v.shape}")
    lo, hi = chi2_band(dof, n_runs, confidence)
    inside = fraction_inside_band(v, dof, n_runs, confidence)
    fig = Figure(figsize=(9, 4.5), layout="constrained")
    ax = fig.subplots()
    ok = ~np.isnan(v)
    ax.plot(t[ok], v[ok], lw=1.0, color="tab:blue", label=f"average {quantity} ({n_runs} runs)")
    ax.axhspan(lo, hi, color="tab:green", alpha=0.15, label=f"{100 * confidence:g}% band [{lo:.3g}, {hi:.3g}]")
    ax.axhline(dof, color="k", ls="--", lw=1.0, label=f"expected value {dof}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"average {quantity}")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.margins(x=0)
    ax.legend(loc="lower right")
    ax.set_title(title or f"{quantity} consistency: {100 * inside:.1f}% of samples inside the band")
    return fig


#: Ratio of a 3-sigma bound to its level over the last quarter of the run above which the start of the run
#: counts as the initial transient (:func:`plot_errors_with_bounds` sets its axis limits from after it).
TRANSIENT_RATIO = 1.5
#: ... when that transient ends within this fraction of the run; a bound still settling later makes the whole
#: run the story, drawn in full.
TRANSIENT_FRACTION_MAX = 0.25
#: Fraction of the run over which the spread of several runs' errors is pooled (a centred window of steps).
SPREAD_WINDOW_FRACTION = 0.005


def _transient_end(bound: NDArray[np.float64]) -> int:
    """First step from which ``bound`` stays within TRANSIENT_RATIO of its level over the last quarter (0: none)."""
    finite = np.isfinite(bound)
    if not np.any(finite[-max(1, bound.size // 4) :]):
        return 0
    level = float(np.nanmedian(bound[-max(1, bound.size // 4) :]))
    above = np.nonzero(~(bound <= TRANSIENT_RATIO * level) & finite)[0]
    return 0 if above.size == 0 else int(above[-1]) + 1


def _pooled_rms(e: NDArray[np.float64], window: int) -> NDArray[np.float64]:
    """RMS over the runs (axis 0) and a centred window of ``window`` steps, per step and component."""
    square = np.nanmean(e**2, axis=0)
    if window <= 1:
        return np.sqrt(square)
    kernel = np.ones(window)
    valid = np.isfinite(square)
    total = np.apply_along_axis(np.convolve, 0, np.where(valid, square, 0.0), kernel, "same")
    count = np.apply_along_axis(np.convolve, 0, valid.astype(float), kernel, "same")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(total / count)


def plot_errors_with_bounds(
    t: ArrayLike,
    errors: ArrayLike,
    sigmas: ArrayLike,
    labels: Sequence[str] | None = None,
    units: str | Sequence[str] = "",
    *,
    scale: float | Sequence[float] = 1.0,
    title: str | None = None,
) -> Figure:
    """Estimation errors with their +-3 sigma bounds, one panel per component.

    One run is drawn as a line. With several runs, the first is drawn and
    the spread of all of them as a band of +-3 times the RMS error over the
    runs (pooled over a centred window of
    :data:`SPREAD_WINDOW_FRACTION` of the run), to compare with the filter's
    +-3 sigma (with per-run sigmas, their RMS over the runs): for a
    consistent filter the band's edges follow the dashed bounds.

    The vertical limits show the steady state: where the bound starts more
    than :data:`TRANSIENT_RATIO` times above its level over the last quarter
    of the run and comes down within :data:`TRANSIENT_FRACTION_MAX` of the
    run, the limits come from after that initial transient, and the panel
    says how far the clipped transient goes.

    Parameters
    ----------
    t : array_like (n,)
        Time [s].
    errors : array_like (n, k) or (n_runs, n, k)
        Errors ``x_true - x_est`` in SI units.
    sigmas : array_like (n, k) or (n_runs, n, k)
        Standard deviations from the filter covariance (square roots of its
        diagonal), same units.
    labels : sequence of str, optional
        Component names (default ``x1 ... xk``).
    units : str or sequence of str
        Unit label(s) after conversion by ``scale``, e.g. "arcsec".
    scale : float or sequence of float
        Factor(s) from SI to the displayed unit (e.g. ``1 / ARCSEC``).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = as_float_array(t, "t")
    e = as_float_array(errors, "errors", allow_nonfinite=True)
    s = as_float_array(sigmas, "sigmas", allow_nonfinite=True)
    if e.ndim == 2:
        e = e[None]
    if s.ndim == 2:
        s = s[None]
    if e.ndim != 3 or e.shape[1] != t.size:
        raise ValueError(f"errors must have shape (len(t)={t.size}, k) or (n_runs, len(t), k), got {e.shape}")
    if s.shape[1:] != e.shape[1:] or s.shape[0] not in (1, e.shape[0]):
        raise ValueError(f"sigmas must have shape {e.shape[1:]} or (n_runs, *{e.shape[1:]}), got {s.shape}")
    if np.any(s[~np.isnan(s)] < 0):
        raise ValueError("sigmas must be non-negative standard deviations")
    k = e.shape[2]
    names = [f"x{i + 1}" for i in range(k)] if labels is None else list(labels)
    if len(names) != k:
        raise ValueError(f"labels must name the {k} components, got {len(names)}")
    unit_list = [units] * k if isinstance(units, str) else list(units)
    if len(unit_list) != k:
        raise ValueError(f"units must be one string or one per component ({k}), got {len(unit_list)}")
    factors = np.broadcast_to(as_float_array(scale, "scale"), (k,))
    runs = e.shape[0]
    with np.errstate(invalid="ignore"):
        sigma = s[0] if s.shape[0] == 1 else np.sqrt(np.nanmean(s**2, axis=0))
    window = max(1, round(SPREAD_WINDOW_FRACTION * t.size))
    spread = _pooled_rms(e, window) if runs > 1 else None
    fig = Figure(figsize=(9, 2.2 * k + 0.8), layout="constrained")
    axes = fig.subplots(k, 1, sharex=True, squeeze=False)[:, 0]
    for i, ax in enumerate(axes):
        f = factors[i]
        unit = f" [{unit_list[i]}]" if unit_list[i] else ""
        bound = 3.0 * sigma[:, i] * abs(f)
        drawn = [np.abs(e[0, :, i] * f), bound]
        if spread is not None:
            band = 3.0 * spread[:, i] * abs(f)
            ax.fill_between(t, -band, band, color="tab:blue", alpha=0.2, lw=0)
            drawn.append(band)
        ax.plot(t, e[0, :, i] * f, lw=0.8, color="tab:blue")
        ax.plot(t, bound, color="tab:red", ls="--", lw=0.9)
        ax.plot(t, -bound, color="tab:red", ls="--", lw=0.9)
        start = _transient_end(bound)
        with np.errstate(invalid="ignore"):
            reach = np.nanmax(np.stack(drawn), axis=0)
        if 0 < start <= TRANSIENT_FRACTION_MAX * t.size and np.any(np.isfinite(reach[start:])):
            steady = float(np.nanmax(reach[start:]))
            early = float(np.nanmax(reach[:start])) if np.any(np.isfinite(reach[:start])) else 0.0
            if steady > 0.0 and early > TRANSIENT_RATIO * steady:
                ax.set_ylim(-1.15 * steady, 1.15 * steady)
                ax.text(
                    0.995,
                    0.03,
                    f"initial transient (to ±{early:.3g} {unit_list[i]}, until {t[start] - t[0]:.3g} s) clipped",
                    transform=ax.transAxes,
                    ha="right",
                    va="bottom",
                    fontsize=7,
                    color="0.3",
                    bbox={"facecolor": "white", "alpha": 0.8, "lw": 0},
                )
        ax.set_ylabel(f"{names[i]}{unit}")
        ax.grid(True, alpha=0.3)
        ax.margins(x=0)
    axes[-1].set_xlabel("time [s]")
    axes[0].plot([], [], color="tab:blue", lw=0.8, label="error" + (" (run 1)" if runs > 1 else ""))
    if spread is not None:
        axes[0].fill_between([], [], [], color="tab:blue", alpha=0.2, lw=0, label=rf"$\pm 3$ RMS error of {runs} runs")
    sigma_label = r"filter's $\pm 3\sigma$" + (f" (RMS over {s.shape[0]} runs)" if s.shape[0] > 1 else "")
    axes[0].plot([], [], color="tab:red", ls="--", label=sigma_label)
    axes[0].legend(loc="upper right", ncols=3, fontsize=8)
    fig.suptitle(title or r"estimation errors with $\pm 3\sigma$ bounds")
    return fig

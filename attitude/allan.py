"""Allan deviation of rate data: users' own gyro records and the simulated gyros.

:func:`allan_deviation` wraps ``allantools`` (the overlapping Allan deviation,
NIST SP 1065 eq. 11) and adds its chi-square confidence intervals (the
equivalent degrees of freedom of Greenhall and Riley, ``allantools.edf_greenhall``,
for the power-law noise identified at each averaging time by the lag-1
autocorrelation, ``allantools.autocorr_noise_id``); :func:`gyro_allan_deviation`
simulates a stationary :class:`attitude.sensors.Gyro` and returns the same
result, with the datasheet lines and the model's exact curve for the figure.
Rates are in rad/s inside; the figure speaks deg/h, as datasheets do. See
docs/sensors.md (the bias instability and its Allan floor).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.results import ResultIO
from attitude.rng import as_generator
from attitude.sensors import BIAS_INSTABILITY_FLOOR_FACTOR, Gyro, arw_from_sigma_v, rrw_from_sigma_u
from attitude.validation import as_float_array, positive_scalar

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["AllanDeviation", "allan_deviation", "gyro_allan_deviation", "plateau_index"]

_DEG_PER_H = np.pi / 180.0 / 3600.0  # 1 deg/h in rad/s
_ONE_SIGMA = 0.6826894921370859  # erf(1 / sqrt(2))
#: Fewest averaged samples for the lag-1 autocorrelation noise identification. Below it the identified
#: exponent scatters (with 39 samples a Gauss-Markov record read as flicker phase noise, alpha = +1, and an
#: interval 5 times too narrow), so the random walk (alpha = -2, the fewest degrees of freedom) is used.
_MIN_ID_SAMPLES = 100


def plateau_index(adev: ArrayLike) -> int:
    """Index of the first point where an Allan curve stops falling (the bias-instability plateau).

    Parameters
    ----------
    adev : array_like (k,)
        Allan deviation on increasing averaging times.

    Returns
    -------
    int
        The index; the last one when the curve falls all the way (no plateau in the record).
    """
    adev = np.asarray(adev, dtype=float)
    rising = np.flatnonzero(np.diff(adev) >= 0.0)
    return int(rising[0]) if rising.size else adev.size - 1


@dataclasses.dataclass(frozen=True)
class AllanDeviation(ResultIO):
    """An overlapping Allan deviation with its confidence band (rates in rad/s, times in s).

    Attributes
    ----------
    tau : ndarray (k,)
        Averaging times [s].
    adev : ndarray (k,)
        Overlapping Allan deviation [rad/s].
    adev_low, adev_high : ndarray (k,)
        Bounds of the ``confidence`` interval [rad/s] (chi-square, Greenhall's edf).
    edf : ndarray (k,)
        Equivalent degrees of freedom at each ``tau``.
    noise_alpha : ndarray (k,) of int
        Power-law exponent used for the edf (0 white rate noise, -1 flicker, -2 random walk).
    confidence : float
        Probability of the interval.
    period : float
        Sample period of the data [s].
    n_samples : int
        Length of the record.
    model_adev : ndarray (k,) or None
        Exact Allan deviation of the model that made the data [rad/s] (simulated gyros).
    datasheet : dict
        Datasheet figures drawn as lines (any of ``arw_deg_per_sqrt_h``,
        ``bias_instability_deg_per_h``, ``bias_instability_time_s``, ``rrw_deg_per_h_per_sqrt_h``).
    """

    tau: NDArray[np.float64]
    adev: NDArray[np.float64]
    adev_low: NDArray[np.float64]
    adev_high: NDArray[np.float64]
    edf: NDArray[np.float64]
    noise_alpha: NDArray[np.int64]
    confidence: float
    period: float
    n_samples: int
    model_adev: NDArray[np.float64] | None = None
    datasheet: dict[str, float] = dataclasses.field(default_factory=dict)

    def floor(self) -> tuple[float, float]:
        """The smallest deviation of the curve and its averaging time: ``(tau [s], adev [rad/s])``.

        Divide the deviation by :data:`attitude.sensors.BIAS_INSTABILITY_FLOOR_FACTOR`
        (0.664) for the bias instability ``B`` of IEEE Std 952-1997. For a
        real sensor's flicker floor the minimum is the floor; for a
        Gauss-Markov bias (the toolkit's gyro model) the curve falls again as
        ``tau^-1/2`` beyond a few correlation times, so on a long record the
        minimum lies past the floor and understates ``B`` (four times on a
        10 h record of the MEMS preset): read :meth:`plateau` instead.
        """
        i = int(np.argmin(self.adev))
        return float(self.tau[i]), float(self.adev[i])

    def plateau(self) -> tuple[float, float]:
        """The first point where the curve stops falling: ``(tau [s], adev [rad/s])`` (:func:`plateau_index`).

        The bias-instability plateau after the angle-random-walk slope;
        divide the deviation by 0.664 for ``B`` as with :meth:`floor`.
        """
        i = plateau_index(self.adev)
        return float(self.tau[i]), float(self.adev[i])

    def plot(self, ax: Any = None, title: str | None = None) -> Figure:
        """Log-log figure in deg/h: the curve, its confidence band, the model's curve and the datasheet lines.

        The datasheet lines (IEEE Std 952-1997, Annex C): angle random walk
        ``N / sqrt(tau)`` (slope -1/2; ``N`` [deg/h sqrt(s)] = ARW [deg/sqrt(h)] x 60,
        its value at ``tau = 1 s``), the bias-instability floor ``0.664 B``
        (marked at its averaging time) and rate random walk ``K sqrt(tau / 3)``
        (slope +1/2; ``K`` [deg/h/sqrt(s)] = RRW [deg/h/sqrt(h)] / 60).

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Axes to draw on (default a new figure).
        title : str, optional
            Figure title.

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt

        if ax is None:
            fig, ax = plt.subplots(figsize=(7.5, 5.0), layout="constrained")
        else:
            fig = ax.figure
        tau = self.tau
        ax.fill_between(
            tau,
            self.adev_low / _DEG_PER_H,
            self.adev_high / _DEG_PER_H,
            color="C0",
            alpha=0.25,
            label=f"{100 * self.confidence:.0f} % confidence (chi-square)",
        )
        ax.loglog(tau, self.adev / _DEG_PER_H, "o-", color="C0", ms=3, label="Allan deviation of the data")
        if self.model_adev is not None:
            ax.loglog(tau, self.model_adev / _DEG_PER_H, "k-", lw=1, label="model (exact)")
        lines = np.geomspace(tau[0], tau[-1], 200)
        sheet = self.datasheet
        if sheet.get("arw_deg_per_sqrt_h"):
            n = sheet["arw_deg_per_sqrt_h"] * 60.0
            ax.loglog(
                lines, n / np.sqrt(lines), "--", color="C2", label=f"ARW {sheet['arw_deg_per_sqrt_h']:g} deg/sqrt(h)"
            )
        if sheet.get("bias_instability_deg_per_h"):
            b = sheet["bias_instability_deg_per_h"]
            ax.axhline(BIAS_INSTABILITY_FLOOR_FACTOR * b, ls="--", color="C3", label=f"floor 0.664 B, B = {b:g} deg/h")
            if sheet.get("bias_instability_time_s"):
                ax.plot(
                    [sheet["bias_instability_time_s"]],
                    [BIAS_INSTABILITY_FLOOR_FACTOR * b],
                    "D",
                    color="C3",
                    ms=7,
                    label=f"datasheet averaging time {sheet['bias_instability_time_s']:g} s",
                )
        if sheet.get("rrw_deg_per_h_per_sqrt_h"):
            k = sheet["rrw_deg_per_h_per_sqrt_h"] / 60.0
            ax.loglog(
                lines,
                k * np.sqrt(lines / 3.0),
                "--",
                color="C4",
                label=f"RRW {sheet['rrw_deg_per_h_per_sqrt_h']:g} deg/h/sqrt(h)",
            )
        ax.set_xlabel("averaging time tau [s]")
        ax.set_ylabel("Allan deviation [deg/h]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        if title:
            ax.set_title(title)
        return fig

    def save_figure(self, path: str | Path, title: str | None = None) -> Path:
        """Draw :meth:`plot` and write it to ``path`` (a PNG, or any format matplotlib knows); returns the path.

        Parameters
        ----------
        path : str or pathlib.Path
            Target file (parent directories are created).
        title : str, optional
            Figure title.
        """
        import matplotlib.pyplot as plt

        out = Path(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        fig = self.plot(title=title)
        fig.savefig(out, dpi=120)
        plt.close(fig)
        return out


def _octave_taus(period: float, n: int) -> NDArray[np.float64]:
    """Averaging times ``2^j period`` up to a tenth of the record (at least ~10 independent clusters)."""
    m = 2 ** np.arange(0, int(np.floor(np.log2(max(n // 10, 1)))) + 1)
    return m * period


def allan_deviation(
    rate_samples: ArrayLike,
    period: float,
    *,
    taus: ArrayLike | None = None,
    confidence: float = _ONE_SIGMA,
    noise_alpha: int | None = None,
    datasheet: dict[str, float] | None = None,
) -> AllanDeviation:
    """Overlapping Allan deviation of evenly sampled rates, with chi-square confidence intervals.

    Parameters
    ----------
    rate_samples : array_like (n,)
        One gyro axis [rad/s], sampled every ``period`` (a rate, i.e. "frequency" data).
    period : float
        Sample period [s] (> 0).
    taus : array_like, optional
        Averaging times [s], each a multiple of ``period`` and at most a third of the
        record (default octaves up to a tenth of it).
    confidence : float, optional
        Probability of the interval, in (0, 1) (default 0.683, one sigma).
    noise_alpha : int, optional
        Power-law exponent for the degrees of freedom at every ``tau`` (0 white rate
        noise, -1 flicker, -2 random walk); default identified at each ``tau`` from the
        data's lag-1 autocorrelation (Riley and Greenhall, 2004), rounded and clipped to
        [-2, 2] (random walk, the widest interval, when fewer than 100 averages remain to identify it).
    datasheet : dict, optional
        Figures to draw as lines in :meth:`AllanDeviation.plot` (keys as in
        :attr:`AllanDeviation.datasheet`).

    Returns
    -------
    AllanDeviation

    Raises
    ------
    ValueError
        For a record that is not 1-D and finite or shorter than 16 samples, a
        ``period`` <= 0, ``taus`` that are not multiples of ``period`` in
        ``[period, n period / 3]``, or a ``confidence`` outside (0, 1).
    """
    import allantools

    y = as_float_array(rate_samples, "rate_samples")
    if y.ndim != 1 or y.size < 16:
        raise ValueError(f"rate_samples must be a 1-D record of at least 16 samples, got shape {y.shape}")
    dt = positive_scalar(period, "period")
    c = float(confidence)
    if not 0.0 < c < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    n = y.size
    if taus is None:
        m = np.rint(_octave_taus(dt, n) / dt).astype(int)
    else:
        t = as_float_array(taus, "taus").ravel()
        m = np.rint(t / dt).astype(int)
        if np.any(m < 1) or np.any(np.abs(m * dt - t) > 1e-9 * t) or np.any(m > n // 3):
            raise ValueError(
                f"taus must be multiples of period = {dt!r} s in [period, n period / 3] = [{dt!r}, {n // 3 * dt!r}] s, "
                f"got {t!r}"
            )
        m = np.unique(m)
    tau, adev, _, _ = allantools.oadev(y, rate=1.0 / dt, data_type="freq", taus=m * dt)
    m = np.rint(tau / dt).astype(int)
    phase_len = n + 1  # allantools integrates the rates to n + 1 phase points
    alphas = np.empty(m.size, dtype=np.int64)
    edf = np.empty(m.size)
    low = np.empty(m.size)
    high = np.empty(m.size)
    for i, mi in enumerate(m):
        if noise_alpha is not None:
            alpha = int(noise_alpha)
        elif n // mi >= _MIN_ID_SAMPLES:
            alpha = int(np.clip(allantools.autocorr_noise_id(y, int(mi), data_type="freq", dmin=0, dmax=2)[0], -2, 2))
        else:
            alpha = -2
        alphas[i] = alpha
        edf[i] = allantools.edf_greenhall(alpha=alpha, d=2, m=int(mi), N=phase_len, overlapping=True, modified=False)
        low[i], high[i] = allantools.confidence_interval(adev[i], edf[i], ci=c)
    return AllanDeviation(
        tau=np.asarray(tau, dtype=np.float64),
        adev=np.asarray(adev, dtype=np.float64),
        adev_low=low,
        adev_high=high,
        edf=edf,
        noise_alpha=alphas,
        confidence=c,
        period=dt,
        n_samples=int(n),
        datasheet=dict(datasheet or {}),
    )


def gyro_allan_deviation(
    gyro: Gyro,
    duration_s: float,
    rng: Any = None,
    *,
    axis: int = 0,
    taus: ArrayLike | None = None,
    confidence: float = _ONE_SIGMA,
    datasheet: dict[str, float] | None = None,
) -> AllanDeviation:
    """Allan deviation of one axis of a stationary gyro at rest, simulated for ``duration_s``.

    The record is :meth:`attitude.sensors.Gyro.sample_errors` (the exact
    sampling of the noise model, the Gauss-Markov bias started from its
    stationary distribution) at the gyro's period; scale factor, misalignment,
    quantisation and saturation do not act at rest. The result carries the
    model's exact curve (:meth:`attitude.sensors.Gyro.allan_variance`) and, by
    default, the gyro's own ARW and RRW as datasheet lines (pass the
    datasheet's figures to draw its bias-instability floor too).

    Parameters
    ----------
    gyro : attitude.sensors.Gyro
        The gyro.
    duration_s : float
        Record length [s] (at least 48 periods); the longest useful ``tau`` is about a tenth of it.
    rng : Generator, int or None
        Random source.
    axis : {0, 1, 2}
        Gyro axis.
    taus : array_like, optional
        Averaging times [s] (see :func:`allan_deviation`).
    confidence : float, optional
        Probability of the confidence interval.
    datasheet : dict, optional
        Figures drawn as lines (default the gyro's ARW and, if any, RRW).

    Returns
    -------
    AllanDeviation
    """
    if not isinstance(gyro, Gyro):
        raise ValueError(f"gyro must be an attitude.sensors.Gyro, got {type(gyro).__name__}")
    duration = positive_scalar(duration_s, "duration_s")
    n = int(duration // gyro.period)
    if n < 48:
        raise ValueError(f"duration_s must cover at least 48 periods of {gyro.period!r} s, got {duration!r} s")
    if axis not in (0, 1, 2):
        raise ValueError(f"axis must be 0, 1 or 2, got {axis!r}")
    errors, _ = gyro.sample_errors(n, as_generator(rng))
    if datasheet is None:
        datasheet = {"arw_deg_per_sqrt_h": arw_from_sigma_v(gyro.sigma_v)}
        if gyro.sigma_u > 0:
            datasheet["rrw_deg_per_h_per_sqrt_h"] = rrw_from_sigma_u(gyro.sigma_u)
    result = allan_deviation(errors[:, axis], gyro.period, taus=taus, confidence=confidence, datasheet=datasheet)
    return dataclasses.replace(result, model_adev=np.sqrt(gyro.allan_variance(result.tau)))

"""When and how the slew requirements are judged: one definition for the design and the campaigns.

A slew requirement set (``[requirements]`` of the spacecraft file) names a
pointing accuracy, a settling time after the slew, an allowed slew time and
a hold. :class:`SlewWindows` turns it into time windows, and
:meth:`SlewWindows.metrics` (one run, or many with the same sample times)
and :class:`SlewWindowsTracker` (tick by tick, for the vectorised loops)
reduce the error angle to the TARGET attitude into the figures every
verdict of the toolkit judges:

``slew_time`` [s], from the start of the run
    The start of the first stretch of samples over which the error stays
    within the pointing accuracy for at least the dwell
    (:data:`SETTLING_DWELL_FRACTION` of the hold) and that is still going
    at the start of the hold, ``slew_end_s + settling_time_s``, or begins
    after it: the flown slew time. Only samples up to the end of the hold
    count. The dwell makes a dip into the band no settling (a loop that
    limit-cycles through the band never settles), and the settling is
    judged by that stretch alone, so a later excursion during the hold is
    judged where it happens (by the pointing row, with its size) and does
    not move the settling time. ``inf`` when no stretch qualifies.
``settling_after_slew`` [s]
    ``max(0, slew_time - slew_end_s)``: the settling after the end of
    the planned slew.
``pointing_error_hold`` [rad]
    The largest error over the hold, the samples with
    ``hold_start_s <= t <= hold_end_s``.

The requirements on them (:func:`attitude.app.assembly.monte_carlo_requirements`
and the design's table): slew time ``slew_time <= time_max_s``;
settling ``settling_after_slew <= settling_time_s``; pointing
``pointing_error_hold <= accuracy``. Samples are the simulation's ticks
(the full rate), never a thinned history.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["SETTLING_DWELL_FRACTION", "SLEW_METRICS", "SlewWindows", "SlewWindowsTracker"]

#: Dwell of the settling, as a fraction of the hold: the error must stay within the accuracy this long to
#: count as settled. Long against a dip into the band (a limit cycle dips for a fraction of a second), short
#: enough that one excursion in the second half of the hold is the pointing row's alone.
SETTLING_DWELL_FRACTION = 0.5
#: The metrics of :meth:`SlewWindows.metrics`, SI (module docstring).
SLEW_METRICS = ("slew_time", "settling_after_slew", "pointing_error_hold")


def _finite_non_negative(value: float, name: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return value


@dataclass(frozen=True)
class SlewWindows:
    """The time windows of a slew's requirements (module docstring).

    Parameters
    ----------
    slew_end_s : float
        End of the slew [s]: the planned slew's duration, or the allowed slew
        time when the guidance plans none (a slew straight to the target).
    settling_time_s : float
        Allowed settling after the end of the slew [s].
    hold_time_s : float
        Length of the hold over which the pointing accuracy is judged [s].
    accuracy_rad : float
        Pointing accuracy [rad].
    """

    slew_end_s: float
    settling_time_s: float
    hold_time_s: float
    accuracy_rad: float

    def __post_init__(self) -> None:
        for name in ("slew_end_s", "settling_time_s", "hold_time_s"):
            object.__setattr__(self, name, _finite_non_negative(getattr(self, name), name))
        accuracy = float(self.accuracy_rad)
        if not (math.isfinite(accuracy) and 0.0 < accuracy <= math.pi):
            raise ValueError(f"accuracy_rad must be in (0, pi], got {self.accuracy_rad!r}")
        object.__setattr__(self, "accuracy_rad", accuracy)

    @property
    def hold_start_s(self) -> float:
        """Start of the hold [s]: the end of the slew plus the allowed settling."""
        return self.slew_end_s + self.settling_time_s

    @property
    def hold_end_s(self) -> float:
        """End of the hold [s]: the shortest run that judges every requirement."""
        return self.hold_start_s + self.hold_time_s

    def check_covers(self, t_end_s: float, what: str = "duration") -> None:
        """Refuse a run that ends before the hold does.

        Parameters
        ----------
        t_end_s : float
            End of the run [s].
        what : str
            Name of the argument that set it, for the message.
        """
        if t_end_s < self.hold_end_s - 1e-9:
            raise ValueError(
                f"{what} must cover the slew ({self.slew_end_s:.4g} s), the settling time "
                f"({self.settling_time_s:.4g} s) and the hold ({self.hold_time_s:.4g} s): at least "
                f"{self.hold_end_s:.10g} s; got {t_end_s:.10g} s"
            )

    @property
    def dwell_s(self) -> float:
        """How long the error must stay within the accuracy to count as settled [s] (module docstring)."""
        return SETTLING_DWELL_FRACTION * self.hold_time_s

    def describe(self) -> str:
        """How each requirement is judged, in one paragraph (for reports and summaries)."""
        return (
            "All judged on the error angle to the target attitude at every tick. Slew time: the start of the first "
            f"stretch over which the error stays within the accuracy ({math.degrees(self.accuracy_rad):.4g} deg) "
            f"for at least {self.dwell_s:.4g} s (half the hold) that is still going at the start of the hold "
            f"({self.hold_start_s:.4g} s) or begins after it. Settling: that time after the end of the slew "
            f"({self.slew_end_s:.4g} s). Pointing: the largest error over the hold, {self.hold_start_s:.4g} to "
            f"{self.hold_end_s:.4g} s; an excursion there fails the pointing, not the settling."
        )

    def metrics(self, t: ArrayLike, error_rad: ArrayLike) -> dict[str, Any]:
        """The windowed metrics of one run or of runs sharing their sample times.

        Parameters
        ----------
        t : array_like (n,)
            Sample times [s], increasing, covering the hold.
        error_rad : array_like (n,) or (runs, n)
            Error angle to the target at each sample [rad].

        Returns
        -------
        dict
            ``slew_time`` [s], ``settling_after_slew`` [s] and
            ``pointing_error_hold`` [rad]: floats for one run, arrays
            ``(runs,)`` for many.
        """
        t = np.asarray(t, dtype=float)
        error = np.asarray(error_rad, dtype=float)
        if t.ndim != 1 or t.size == 0 or error.ndim not in (1, 2) or error.shape[-1] != t.size:
            raise ValueError(
                f"error_rad must have shape (n,) or (runs, n) with n = len(t) = {t.size}, got {error.shape}"
            )
        self.check_covers(float(t[-1]), "the run")
        tracker = SlewWindowsTracker(self, 1 if error.ndim == 1 else error.shape[0])
        for k in range(t.size):
            tracker.update(float(t[k]), error[..., k])
        out = tracker.metrics()
        return {name: float(v[0]) for name, v in out.items()} if error.ndim == 1 else out


class SlewWindowsTracker:
    """:meth:`SlewWindows.metrics` reduced sample by sample, for loops that never keep the history.

    Parameters
    ----------
    windows : SlewWindows
        The windows.
    runs : int
        Number of runs advancing together (>= 1).
    """

    def __init__(self, windows: SlewWindows, runs: int) -> None:
        if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 1:
            raise ValueError(f"runs must be an integer >= 1, got {runs!r}")
        self.windows = windows
        self._runs = int(runs)
        self._streak_start = np.full(runs, np.nan)  # start of the current stretch within the accuracy (nan: outside)
        self._settled = np.full(runs, np.inf)  # start of the first qualifying stretch (inf: none yet)
        self._hold_max = np.full(runs, -np.inf)
        self._last_t = -math.inf

    def update(self, t: float, error_rad: ArrayLike) -> None:
        """Fold in one sample.

        Parameters
        ----------
        t : float
            Sample time [s] (increasing).
        error_rad : array_like (runs,) or float
            Error angle to the target [rad].
        """
        w = self.windows
        t = float(t)
        if not t > self._last_t:
            raise ValueError(f"t must increase from sample to sample, got {t!r} after {self._last_t!r}")
        error = np.asarray(error_rad, dtype=float)
        if error.shape not in ((), (self._runs,)):
            raise ValueError(f"error_rad must be a number or have shape ({self._runs},), got {error.shape}")
        error = np.broadcast_to(error, (self._runs,))
        self._last_t = t
        if t > w.hold_end_s + 1e-9:  # after the hold: flown, not judged
            return
        inside = error <= w.accuracy_rad  # NaN counts as outside
        self._streak_start[~inside] = np.nan
        self._streak_start[inside & np.isnan(self._streak_start)] = t
        # 1e-9 s: the rounding of tick times accumulated over a run (ticks are 1e-3 s and longer).
        if t >= w.hold_start_s - 1e-9:
            np.fmax(self._hold_max, np.where(np.isnan(error), np.inf, error), out=self._hold_max)
            # A stretch going at the start of the hold (or begun after it) that has lasted the dwell: settled.
            long_enough = inside & (t - self._streak_start >= w.dwell_s - 1e-9)
            first = long_enough & np.isinf(self._settled)
            self._settled[first] = self._streak_start[first]

    def metrics(self) -> dict[str, NDArray[np.float64]]:
        """The metrics (module docstring), arrays ``(runs,)``; refused before the hold has ended."""
        w = self.windows
        if not self._last_t >= w.hold_end_s - 1e-9:
            raise ValueError(
                f"the run ended at {self._last_t:.4g} s, before the end of the hold at {w.hold_end_s:.4g} s"
            )
        settling = self._settled.copy()
        return {
            "slew_time": settling,
            "settling_after_slew": np.maximum(0.0, settling - w.slew_end_s),
            "pointing_error_hold": self._hold_max.copy(),
        }

"""Progress of long work: the one home of the progress bars (tqdm) and of the rate limit of progress reports.

Every long job of the toolkit (a Monte Carlo campaign, a vectorised batch,
the design's steps, a slew planned from several starts) shows a tqdm bar
on stderr made by :func:`progress_bar`, so they all share one rule:

* ``enabled=None`` (the default of the callers): a bar only when the stream
  is a terminal, so logs, pipes and CI output stay clean; ``True`` draws it
  on any stream, ``False`` never (``--quiet``);
* redrawn at most every :data:`REFRESH_PERIOD_S`, with the ETA from the
  average rate since the bar started (the runs of a process pool finish in
  bursts, which a moving average would turn into a jumpy ETA);
* no monitor thread: tqdm's default starts one with the first bar, and a
  thread in the campaign's process makes
  :func:`attitude.montecarlo.campaign.run_campaign` start its workers by
  forkserver instead of fork.

A loop that runs somewhere a bar cannot be drawn (inside a batch, in a
worker process) reports the fraction done to a callback through
:class:`Throttle`, which calls it at most every :data:`REFRESH_PERIOD_S`:
one clock reading per step of the loop, nothing that shows beside a tick
of a simulation.

tqdm is imported when the first bar is made, not with this module.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import IO, Any

__all__ = ["REFRESH_PERIOD_S", "Throttle", "progress_bar"]

#: Shortest wall time between two redraws of a bar, or two reports of a :class:`Throttle` [s].
REFRESH_PERIOD_S = 0.2

_BAR_CLASS: Any = None


def _bar_class() -> Any:
    global _BAR_CLASS
    if _BAR_CLASS is None:
        from tqdm import tqdm

        class Bar(tqdm):  # type: ignore[misc]  # tqdm is untyped
            # No monitor thread (module docstring): the miniters it would tune are not used here.
            monitor_interval = 0

        _BAR_CLASS = Bar
    return _BAR_CLASS


def progress_bar(
    total: float | None,
    *,
    desc: str,
    unit: str,
    enabled: bool | None = None,
    initial: float = 0,
    leave: bool = True,
    postfix: str | None = None,
    file: IO[str] | None = None,
) -> Any:
    """A tqdm progress bar with the toolkit's settings (module docstring).

    Parameters
    ----------
    total : float or None
        Number of units of the whole job (None: unknown, no bar and no ETA).
    desc : str
        What the bar counts, shown before it (``"Monte Carlo"``).
    unit : str
        Name of one unit (``"run"``), for the rate.
    enabled : bool or None
        None: draw only when ``file`` is a terminal; True: always; False: never.
    initial : float
        Units already done before the bar starts (a resumed campaign); the
        rate and the ETA count only the units done after.
    leave : bool
        Keep the finished bar on the screen (False: erase it when closed).
    postfix : str, optional
        Text after the counts (``"0 errors"``; ``set_postfix_str`` changes it).
    file : text stream, optional
        Where to draw (default ``sys.stderr`` at the time of the call).

    Returns
    -------
    tqdm.tqdm
        The bar (a context manager; ``disable`` is True when it draws nothing).
    """
    if enabled is not None and not isinstance(enabled, bool):
        raise ValueError(f"enabled must be True, False or None (a bar on a terminal only), got {enabled!r}")
    return _bar_class()(
        total=total,
        desc=desc,
        unit=unit,
        initial=initial,
        leave=leave,
        postfix=postfix,
        file=file,
        disable=None if enabled is None else not enabled,
        mininterval=REFRESH_PERIOD_S,
        miniters=0,  # fixed (not tuned by a monitor): every update checks the clock against mininterval
        smoothing=0.0,  # the ETA from the average rate since the start
        dynamic_ncols=True,
    )


class Throttle:
    """Report the fraction of a loop done, at most once every :data:`REFRESH_PERIOD_S` of wall time.

    Call it with the index of each step; it calls ``report(done / total)``
    when at least the period has passed since the last report (never on the
    first call, so a loop shorter than the period reports nothing).

    Parameters
    ----------
    report : callable
        ``report(fraction)``, fraction in [0, 1].
    total : int
        Number of steps of the whole loop (> 0).
    period_s : float, optional
        Shortest wall time between two reports [s] (default :data:`REFRESH_PERIOD_S`).
    """

    def __init__(self, report: Callable[[float], None], total: int, period_s: float | None = None) -> None:
        if not callable(report):
            raise ValueError(f"report must be callable as report(fraction), got {report!r}")
        if isinstance(total, bool) or not isinstance(total, int) or total < 1:
            raise ValueError(f"total must be a positive integer (steps of the loop), got {total!r}")
        self.report = report
        self.total = total
        self.period_s = REFRESH_PERIOD_S if period_s is None else float(period_s)
        if not self.period_s >= 0.0:
            raise ValueError(f"period_s must be a non-negative number of seconds, got {period_s!r}")
        self._next = time.perf_counter() + self.period_s

    def __call__(self, done: int) -> None:
        """Report ``done / total`` if the period has passed since the last report.

        Parameters
        ----------
        done : int
            Steps completed so far.
        """
        now = time.perf_counter()
        if now >= self._next:
            self._next = now + self.period_s
            self.report(min(1.0, done / self.total))

"""Progress bars and throttled progress reports (:mod:`attitude.progress`).

What each test checks against: the module's rules, read off the stream the
bar writes to. A bar is drawn on a terminal (a stream whose ``isatty()`` is
True) and not on a pipe or file unless asked; ``enabled=False`` draws
nothing anywhere; ``initial`` starts the count (a resumed campaign) and the
rate counts only what came after; no monitor thread is started (a thread in
the campaign's process would switch its pool from fork to forkserver,
:func:`attitude.montecarlo.campaign._default_context`). The throttle is
checked on a fake clock: at most one report per period, each the exact
fraction ``done / total``.
"""

from __future__ import annotations

import io
import threading

import pytest

import attitude.progress as progress_module
from attitude.progress import REFRESH_PERIOD_S, Throttle, progress_bar


class Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


def draw(stream: io.StringIO, enabled: bool | None, **kwargs) -> str:
    with progress_bar(3, desc="work", unit="item", enabled=enabled, file=stream, **kwargs) as bar:
        for _ in range(3):
            bar.update(1)
    return stream.getvalue()


def test_a_bar_is_drawn_on_a_terminal_only_unless_asked():
    assert "work: 100%" in draw(Terminal(), None) and "3/3" in draw(Terminal(), None)
    assert draw(io.StringIO(), None) == ""  # a pipe, a log file: nothing
    assert draw(Terminal(), False) == ""  # --quiet: nothing, even on a terminal
    assert "3/3" in draw(io.StringIO(), True)  # asked for: drawn anywhere


def test_initial_starts_the_count_and_the_postfix_is_shown():
    stream = Terminal()
    bar = progress_bar(10, desc="Monte Carlo", unit="run", initial=4, postfix="0 errors", file=stream)
    first = stream.getvalue()
    bar.close()
    # The first frame already shows the 4 units done before, and no rate yet (none done since).
    assert "4/10" in first and "?run/s" in first and "0 errors" in first


def test_no_monitor_thread_is_started():
    before = {t.ident for t in threading.enumerate()}
    with progress_bar(5, desc="work", unit="item", enabled=True, file=io.StringIO()) as bar:
        bar.update(5)
        during = {t.ident for t in threading.enumerate()}
    assert during <= before


def test_bad_enabled_is_named():
    with pytest.raises(ValueError, match="enabled must be True, False or None"):
        progress_bar(3, desc="work", unit="item", enabled="yes")


def test_throttle_reports_the_fraction_at_most_once_per_period(monkeypatch):
    clock = [100.0]
    monkeypatch.setattr(progress_module.time, "perf_counter", lambda: clock[0])
    seen: list[float] = []
    # Times in binary fractions, exact in floating point: a step every 1/16 s, a period of 1/4 s.
    throttle = Throttle(seen.append, 40, period_s=0.25)
    for k in range(41):
        throttle(k)
        clock[0] += 0.0625
    assert seen == [k / 40 for k in range(4, 41, 4)]  # every 4th step, first after one period
    assert Throttle(seen.append, 40).period_s == REFRESH_PERIOD_S


def test_throttle_of_a_short_loop_reports_nothing(monkeypatch):
    seen: list[float] = []
    throttle = Throttle(seen.append, 1000, period_s=3600.0)
    for k in range(1001):
        throttle(k)
    assert seen == []


def test_throttle_bad_arguments_are_named():
    with pytest.raises(ValueError, match="report must be callable"):
        Throttle(None, 10)
    with pytest.raises(ValueError, match="total must be a positive integer"):
        Throttle(print, 0)
    with pytest.raises(ValueError, match="period_s must be a non-negative"):
        Throttle(print, 10, period_s=-1.0)

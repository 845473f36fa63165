"""The slew requirements' windows: one definition of settling and hold pointing (attitude.simulation.slew_windows).

Each case is a hand-built error history whose answer follows from the
definitions in the module docstring, worked out in the comments.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from attitude.simulation.slew_windows import SlewWindows, SlewWindowsTracker

ACC = 1e-3  # pointing accuracy [rad]
# Slew ends at 10 s, settling allowed 5 s, hold 5 s: settling window t < 15 s, hold 15 <= t <= 20 s.
W = SlewWindows(slew_end_s=10.0, settling_time_s=5.0, hold_time_s=5.0, accuracy_rad=ACC)
T = np.arange(0.0, 20.0 + 1e-9, 1.0)  # samples every second, 0 ... 20 s


def _error(outside_at: list[float], inside: float = 0.5 * ACC, outside: float = 2.0 * ACC) -> np.ndarray:
    e = np.full(T.size, inside)
    for t in outside_at:
        e[np.isclose(T, t)] = outside
    return e


def test_settling_is_the_sample_after_the_last_one_outside_in_the_settling_window():
    # Outside until 11 s: the error stays within from 12 s on.
    m = W.metrics(T, _error([0, 1, 2, 11]))
    assert m["settling_time"] == 12.0
    assert m["settling_after_slew"] == 2.0
    assert m["pointing_error_hold"] == 0.5 * ACC


def test_an_excursion_in_the_hold_fails_the_pointing_not_the_settling():
    # The case: settled at 6 s, then one sample 0.0004 deg too high at 18 s, in the hold.
    e = _error([0, 5])
    e[np.isclose(T, 18.0)] = ACC + math.radians(0.0004)
    m = W.metrics(T, e)
    assert m["settling_time"] == 6.0  # not 19 s: the settling window ended at 15 s
    assert m["settling_after_slew"] == 0.0  # settled before the slew ended
    assert m["pointing_error_hold"] == pytest.approx(ACC + math.radians(0.0004), rel=0, abs=0)


def test_still_outside_at_the_start_of_the_hold_settles_when_it_stays_within_to_the_end_of_the_hold():
    # Outside at 14 s (the last sample of the settling window) and at 16 s: within from 17 s to 20 s.
    m = W.metrics(T, _error([14, 16]))
    assert m["settling_time"] == 17.0
    assert m["settling_after_slew"] == 7.0  # > 5 s allowed: the settling fails by 2 s
    assert m["pointing_error_hold"] == 2.0 * ACC


def test_outside_at_the_end_of_the_hold_never_settles():
    m = W.metrics(T, _error([14, 20]))
    assert m["settling_time"] == math.inf
    assert m["settling_after_slew"] == math.inf


def test_samples_after_the_hold_are_not_judged():
    # A run longer than the hold: an excursion at 25 s is outside every window.
    t = np.arange(0.0, 30.0 + 1e-9, 1.0)
    e = np.full(t.size, 0.5 * ACC)
    e[t == 25.0] = 10 * ACC
    m = W.metrics(t, e)
    assert m["settling_time"] == 0.0 and m["pointing_error_hold"] == 0.5 * ACC


def test_never_outside_settles_at_the_first_sample_and_nan_counts_as_outside():
    assert W.metrics(T, _error([]))["settling_time"] == 0.0
    e = _error([])
    e[np.isclose(T, 16.0)] = np.nan
    m = W.metrics(T, e)
    assert m["settling_time"] == 0.0  # settled within the settling window
    assert m["pointing_error_hold"] == math.inf  # a NaN in the hold is never a pass


def test_many_runs_at_once_equal_each_run_alone():
    rng = np.random.default_rng(3)
    e = rng.uniform(0.0, 1.6 * ACC, (40, T.size))
    together = W.metrics(T, e)
    for r in range(e.shape[0]):
        alone = W.metrics(T, e[r])
        for name, value in alone.items():
            assert together[name][r] == value


def test_the_tracker_equals_a_direct_reading_of_the_definition():
    """Random histories against a transparent implementation written from the module docstring."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        e = rng.uniform(0.0, 1.3 * ACC, T.size) * (rng.uniform(size=T.size) < 0.7)
        window = T < W.hold_start_s
        out_w = np.nonzero(window & (e > ACC))[0]
        if not window.any() or (out_w.size and out_w[-1] == np.nonzero(window)[0][-1]):
            span = T <= W.hold_end_s
            out_s = np.nonzero(span & (e > ACC))[0]
            last_span = np.nonzero(span)[0][-1]
            expected = T[0] if out_s.size == 0 else (math.inf if out_s[-1] == last_span else T[out_s[-1] + 1])
        else:
            expected = T[0] if out_w.size == 0 else T[out_w[-1] + 1]
        hold = (T >= W.hold_start_s) & (T <= W.hold_end_s)
        m = W.metrics(T, e)
        assert m["settling_time"] == expected
        assert m["pointing_error_hold"] == np.max(e[hold])


def test_bad_windows_and_short_runs_are_refused_by_name():
    with pytest.raises(ValueError, match="settling_time_s must be a finite number >= 0"):
        SlewWindows(10.0, -1.0, 5.0, ACC)
    with pytest.raises(ValueError, match=r"accuracy_rad must be in \(0, pi\]"):
        SlewWindows(10.0, 5.0, 5.0, 0.0)
    with pytest.raises(ValueError, match="must cover the slew"):
        W.metrics(T[T <= 18.0], _error([])[T <= 18.0])
    tracker = SlewWindowsTracker(W, 2)
    tracker.update(0.0, [0.0, 0.0])
    with pytest.raises(ValueError, match="t must increase"):
        tracker.update(0.0, [0.0, 0.0])
    with pytest.raises(ValueError, match="before the end of the hold"):
        tracker.metrics()

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
# Slew ends at 10 s, settling allowed 5 s, hold 5 s: hold 15 <= t <= 20 s; the settling dwell is 2.5 s.
W = SlewWindows(slew_end_s=10.0, settling_time_s=5.0, hold_time_s=5.0, accuracy_rad=ACC)
T = np.arange(0.0, 20.0 + 1e-9, 1.0)  # samples every second, 0 ... 20 s


def _error(outside_at: list[float], inside: float = 0.5 * ACC, outside: float = 2.0 * ACC) -> np.ndarray:
    e = np.full(T.size, inside)
    for t in outside_at:
        e[np.isclose(T, t)] = outside
    return e


def test_settling_is_the_start_of_the_stretch_within_that_is_going_at_the_hold():
    # Outside until 11 s: within from 12 s on, 3 s by the start of the hold (>= the 2.5 s dwell).
    m = W.metrics(T, _error([0, 1, 2, 11]))
    assert W.dwell_s == 2.5
    assert m["slew_time"] == 12.0
    assert m["settling_after_slew"] == 2.0
    assert m["pointing_error_hold"] == 0.5 * ACC


def test_an_excursion_in_the_hold_fails_the_pointing_not_the_settling():
    # The case: settled at 6 s, then one sample 0.0004 deg too high at 18 s, in the hold.
    e = _error([0, 5])
    e[np.isclose(T, 18.0)] = ACC + math.radians(0.0004)
    m = W.metrics(T, e)
    assert m["slew_time"] == 6.0  # not 19 s: the stretch from 6 s had lasted 12 s at the start of the hold
    assert m["settling_after_slew"] == 0.0  # settled before the slew ended
    assert m["pointing_error_hold"] == pytest.approx(ACC + math.radians(0.0004), rel=0, abs=0)


def test_still_outside_in_the_hold_settles_at_the_first_stretch_that_lasts_the_dwell():
    # Outside at 14 s and 16 s: the stretch from 15 s is 0 s long when it breaks; the one from 17 s lasts
    # 3 s by 20 s.
    m = W.metrics(T, _error([14, 16]))
    assert m["slew_time"] == 17.0
    assert m["settling_after_slew"] == 7.0  # > 5 s allowed: the settling fails by 2 s
    assert m["pointing_error_hold"] == 2.0 * ACC
    # Outside at 14 s and at the end (20 s): the stretch from 15 s lasted 3 s at 18 s: settled at 15 s, and
    # the excursion at 20 s is the pointing's.
    m = W.metrics(T, _error([14, 20]))
    assert m["slew_time"] == 15.0 and m["pointing_error_hold"] == 2.0 * ACC


def test_a_limit_cycle_or_a_dip_into_the_band_is_not_settling():
    # The new-user trial's case: an error cycling through the band (within 1 s of every 2) never settles,
    # and neither does one that dips in just before the hold (within at 14 s only).
    cycling = W.metrics(T, _error([float(k) for k in range(0, 21, 2)]))
    assert cycling["slew_time"] == math.inf and cycling["settling_after_slew"] == math.inf
    dip = W.metrics(T, _error([float(k) for k in range(21) if k != 14]))
    assert dip["slew_time"] == math.inf


def test_samples_after_the_hold_are_not_judged():
    # A run longer than the hold: an excursion at 25 s is outside every window.
    t = np.arange(0.0, 30.0 + 1e-9, 1.0)
    e = np.full(t.size, 0.5 * ACC)
    e[t == 25.0] = 10 * ACC
    m = W.metrics(t, e)
    assert m["slew_time"] == 0.0 and m["pointing_error_hold"] == 0.5 * ACC


def test_never_outside_settles_at_the_first_sample_and_nan_counts_as_outside():
    assert W.metrics(T, _error([]))["slew_time"] == 0.0
    e = _error([])
    e[np.isclose(T, 16.0)] = np.nan
    m = W.metrics(T, e)
    assert m["slew_time"] == 0.0  # the stretch from 0 s had lasted 15 s at the start of the hold
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
    span = T <= W.hold_end_s
    for _ in range(300):
        e = rng.uniform(0.0, 1.3 * ACC, T.size) * (rng.uniform(size=T.size) < 0.7)
        inside = e <= ACC
        expected, k = math.inf, 0
        while k < span.sum():  # each maximal stretch within the accuracy, in time order
            if not inside[k]:
                k += 1
                continue
            start = k
            while k < span.sum() and inside[k]:
                k += 1
            stretch = range(start, k)
            if any(T[j] >= W.hold_start_s and T[j] - T[start] >= W.dwell_s for j in stretch):
                expected = T[start]
                break
        hold = (T >= W.hold_start_s) & (T <= W.hold_end_s)
        m = W.metrics(T, e)
        assert m["slew_time"] == expected
        assert m["pointing_error_hold"] == np.max(e[hold])


def test_bad_windows_and_short_runs_are_refused_by_name():
    with pytest.raises(ValueError, match="settling_time_s must be a finite number >= 0"):
        SlewWindows(10.0, -1.0, 5.0, ACC)
    with pytest.raises(ValueError, match=r"accuracy_rad must be in \(0, pi\]"):
        SlewWindows(10.0, 5.0, 5.0, 0.0)
    with pytest.raises(ValueError, match="must cover the slew"):
        W.metrics(T[T <= 18.0], _error([])[T <= 18.0])
    with pytest.raises(ValueError, match="runs must be an integer >= 1, got 0"):
        SlewWindowsTracker(W, 0)
    tracker = SlewWindowsTracker(W, 2)
    with pytest.raises(ValueError, match=r"error_rad must be a number or have shape \(2,\), got \(3,\)"):
        tracker.update(0.0, [0.0, 0.0, 0.0])
    tracker.update(0.0, [0.0, 0.0])
    with pytest.raises(ValueError, match="t must increase"):
        tracker.update(0.0, [0.0, 0.0])
    with pytest.raises(ValueError, match="before the end of the hold"):
        tracker.metrics()

"""Campaign figures: integer run counts, the NEES chi-square reference, envelopes with their limits.

What each test checks against:

* Histogram counts are whole runs: the y axis uses an integer locator, so every tick is an integer.
* The NEES reference is the chi-square density with 3 degrees of freedom scaled to the histogram
  (runs x bin width x density), checked against the closed form ``sqrt(x) exp(-x / 2) / sqrt(2 pi)``
  of that density (not scipy, which the figure uses).
* Envelopes draw the limits they are given and the campaign's requirement on the metric that bounds
  the history, in the history's review unit (rpm, deg, deg/s), checked against the inputs converted
  by hand; a wheel-speed history is drawn one panel per wheel, not as the norm of the four wheels.

Synthetic campaigns (no simulation) keep these tests fast.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from matplotlib.ticker import MaxNLocator

from attitude.montecarlo.plots import chi2_counts, plot_envelope, plot_histograms
from attitude.montecarlo.results import CampaignResult, Requirement

RUNS = 40
RPM_PER_RAD_S = 30.0 / math.pi


def campaign(requirements=()) -> CampaignResult:
    """40 runs: a NEES metric drawn from chi-square(3), a peak wheel speed, and histories on one grid."""
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 10.0, 21)
    histories = {
        r: {
            "t": t,
            "error_angle": np.radians(0.01) * (1.0 + rng.random(t.size)),
            "omega": np.radians(0.5) * rng.standard_normal((t.size, 3)),
            "wheel_speed": 50.0 * rng.standard_normal((t.size, 4)),
        }
        for r in range(RUNS)
    }
    return CampaignResult(
        seed=1,
        parameters={},
        metrics={"nees": rng.chisquare(3, RUNS), "wheel_speed_peak": 100.0 + rng.random(RUNS)},
        status=np.array(["ok"] * RUNS),
        errors=np.array([""] * RUNS),
        attempts=np.ones(RUNS, dtype=np.int64),
        cpu_s=np.zeros(RUNS),
        wall_s=np.zeros(RUNS),
        requirements=tuple(requirements),
        histories=histories,
    )


def test_histogram_counts_are_whole_runs():
    fig = plot_histograms(campaign())
    for ax in fig.axes:
        locator = ax.yaxis.get_major_locator()
        assert isinstance(locator, MaxNLocator) and locator._integer
        ticks = locator.tick_values(*ax.get_ylim())
        np.testing.assert_array_equal(ticks, np.round(ticks))


def test_nees_histogram_carries_the_chi_square_density_scaled_to_the_counts():
    fig = plot_histograms(campaign(), ["nees"])
    ax = fig.axes[0]
    (curve,) = [line for line in ax.get_lines() if line.get_label().startswith("chi-square 3 dof")]
    x, y = np.asarray(curve.get_xdata()), np.asarray(curve.get_ydata())
    widths = {round(p.get_width(), 12) for p in ax.patches}
    assert len(widths) == 1  # equal bins
    width = widths.pop()
    density = np.sqrt(x) * np.exp(-x / 2.0) / math.sqrt(2.0 * math.pi)  # chi-square(3), closed form
    np.testing.assert_allclose(y, RUNS * width * density, rtol=1e-9, atol=1e-12)
    assert any("expected mean 3" in line.get_label() for line in ax.get_lines())


def test_chi2_counts_refuses_bad_arguments():
    with pytest.raises(ValueError, match="dof must be a whole number >= 1, got 0"):
        chi2_counts([1.0], 0, 10, 0.5)
    with pytest.raises(ValueError, match="bin_width must be > 0, got -1"):
        chi2_counts([1.0], 3, 10, -1.0)


def test_wheel_speed_envelope_is_per_wheel_with_the_limit_and_the_requirement():
    limit = np.array([600.0, 610.0, 620.0, 630.0])  # rad/s, per wheel
    req = Requirement("wheel_speed_peak", max=500.0, name="wheels")
    result = campaign([req])
    fig = plot_envelope(result, "wheel_speed", "each", lines={"wheel speed limit": limit})
    assert len(fig.axes) == 4  # one panel per wheel, not |wheel_speed|
    for i, ax in enumerate(fig.axes):
        speeds = sorted(float(line.get_ydata()[0]) for line in ax.get_lines() if line.get_linestyle() == "-.")
        np.testing.assert_allclose(speeds, [-limit[i] * RPM_PER_RAD_S, limit[i] * RPM_PER_RAD_S], rtol=1e-12)
        bound = sorted(float(line.get_ydata()[0]) for line in ax.get_lines() if line.get_linestyle() == "--")
        np.testing.assert_allclose(bound, [-500.0 * RPM_PER_RAD_S, 500.0 * RPM_PER_RAD_S], rtol=1e-12)
        # The margin to the nearer limit (the requirement, 500 rad/s), from the histories.
        peak = max(np.max(np.abs(h["wheel_speed"][:, i])) for h in result.histories.values())
        assert f"{100.0 * peak / 500.0:.3g} % of the requirement wheels" in ax.texts[0].get_text()


def test_envelopes_draw_the_requirement_of_their_metric_where_it_applies():
    reqs = [
        Requirement("final_pointing_error", max=math.radians(0.05), name="pointing"),
        Requirement("rate_peak", max=math.radians(2.0), name="rate"),
    ]
    result = campaign(reqs)

    def dashed(fig):
        return [float(line.get_ydata()[0]) for line in fig.axes[0].get_lines() if line.get_linestyle() == "--"]

    np.testing.assert_allclose(dashed(plot_envelope(result, "error_angle")), [0.05], rtol=1e-12)  # deg
    np.testing.assert_allclose(dashed(plot_envelope(result, "omega")), [2.0], rtol=1e-12)  # |omega|, deg/s
    assert dashed(plot_envelope(result, "omega", 0)) == []  # the peak rate bounds the norm, not a component
    with pytest.raises(ValueError, match="component must be an integer, 'each' or None, got 'all'"):
        plot_envelope(result, "omega", "all")

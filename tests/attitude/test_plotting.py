"""The lower limit of the figures' log axes (:func:`attitude.plotting.log_axis_floor`).

Checked against hand-computed powers of ten: the floor is one decade below
the decade holding the chosen percentile of the positive values, so zeros,
negatives and NaN (an exact start, a sign change) never pull the axis down.
"""

import numpy as np
import pytest

from attitude.plotting import log_axis_floor


def test_floor_is_one_decade_below_the_small_end():
    # Smallest positive value 3e-3 lies in the decade [1e-3, 1e-2): one decade below is 1e-4.
    assert log_axis_floor([0.0, 3e-3, 0.02, 0.05], percentile=0.0) == pytest.approx(1e-4, rel=1e-12)
    # Exactly a power of ten stays in its own decade: 1e-3 -> 1e-4.
    assert log_axis_floor([1e-3, 1.0], percentile=0.0) == pytest.approx(1e-4, rel=1e-12)


def test_isolated_tiny_values_do_not_stretch_the_axis():
    # 1000 values between 0.01 and 0.1 plus one rounding-level 1e-16: the 1st percentile ignores the outlier.
    values = np.concatenate([[1e-16, 0.0, np.nan, -1.0], np.linspace(0.01, 0.1, 1000)])
    assert log_axis_floor(values) == pytest.approx(1e-3, rel=1e-12)


def test_no_positive_value_and_bad_percentile():
    assert log_axis_floor([0.0, -1.0, np.nan]) is None
    with pytest.raises(ValueError, match="percentile must lie in \\[0, 100\\], got 150"):
        log_axis_floor([1.0], percentile=150.0)

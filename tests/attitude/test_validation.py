"""Argument checks (:mod:`attitude.validation`): the per-tick fast check :func:`finite_floats`.

It must accept exactly the finite float64 vectors of the asked length, as
Python floats equal to the entries, and hand everything else (NaN, inf, other
shapes, dtypes and types) back as None for the caller's full check.
"""

from __future__ import annotations

import numpy as np
import pytest

from attitude.validation import check_vector, finite_floats


def test_finite_vectors_come_back_as_the_same_floats():
    v = np.array([1.5, -2.0e-300, 3.0e300])
    out = finite_floats(v, 3)
    assert out == [1.5, -2.0e-300, 3.0e300] and all(type(c) is float for c in out)
    np.testing.assert_array_equal(out, check_vector(v, "v", 3))  # what the full check returns


@pytest.mark.parametrize(
    "value",
    [
        np.array([1.0, np.nan, 0.0]),
        np.array([np.inf, 0.0, 0.0]),
        np.array([0.0, 0.0, -np.inf]),
        np.zeros(4),  # another length
        np.zeros((1, 3)),  # another shape
        np.zeros(3, dtype=np.float32),  # another dtype
        np.array([1, 2, 3]),  # integers: the full check converts them
        [1.0, 2.0, 3.0],  # not an array
        None,
    ],
)
def test_anything_else_is_left_to_the_full_check(value):
    assert finite_floats(value, 3) is None

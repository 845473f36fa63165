"""Plain Python numbers for JSON results (``results.json`` of the design report)."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["plain_float", "plain_matrix", "plain_vector"]


def plain_float(x: Any) -> float:
    """A numpy scalar or 0-d array as a Python float.

    Parameters
    ----------
    x : scalar or 0-d array
        The value to convert.
    """
    return float(x)


def plain_vector(x: Any) -> list[float]:
    """Any array as a flat list of Python floats.

    Parameters
    ----------
    x : array_like
        An array of any shape (flattened).
    """
    return [float(v) for v in np.asarray(x, dtype=float).ravel()]


def plain_matrix(x: Any) -> list[list[float]]:
    """A 2-D array as a list of rows of Python floats.

    Parameters
    ----------
    x : array_like
        A 2-D array.
    """
    return [[float(v) for v in row] for row in np.asarray(x, dtype=float)]

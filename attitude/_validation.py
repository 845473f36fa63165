"""Input checks shared by every module.

Every public function validates its arguments with these helpers so that bad
input raises a :class:`ValueError` whose message names the argument, the rule
broken and the offending value, instead of propagating NaN.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "as_float_array",
    "check_positive",
    "check_time_grid",
    "check_vector",
    "describe",
]


def describe(value: Any, max_items: int = 6) -> str:
    """Return a short printable description of ``value`` for error messages."""
    arr = np.asarray(value)
    if arr.ndim == 0 or arr.size <= max_items:
        return np.array2string(arr, precision=6, threshold=max_items) if arr.ndim else repr(arr.item())
    return f"array of shape {arr.shape}"


def as_float_array(value: ArrayLike, name: str, *, allow_nonfinite: bool = False) -> NDArray[np.float64]:
    """Convert ``value`` to a float64 array (a copy-free view when possible).

    Raises
    ------
    ValueError
        If ``value`` cannot be converted to floats, or holds NaN/inf while
        ``allow_nonfinite`` is False.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {value!r}") from exc
    if not allow_nonfinite and not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))
        where = tuple(int(i) for i in bad[0]) if arr.ndim else ()
        raise ValueError(
            f"{name} must be finite (no NaN or inf); found {arr[where] if arr.ndim else arr} at index {where}"
        )
    return arr


def check_vector(value: ArrayLike, name: str, length: int) -> NDArray[np.float64]:
    """Check that ``value`` is a finite array whose last axis has ``length`` entries."""
    arr = as_float_array(value, name)
    if arr.ndim == 0 or arr.shape[-1] != length:
        raise ValueError(f"{name} must have shape (..., {length}), got shape {arr.shape}")
    return arr


def check_positive(value: ArrayLike, name: str, *, allow_zero: bool = False) -> NDArray[np.float64]:
    """Check that every entry of ``value`` is finite and > 0 (>= 0 with ``allow_zero``)."""
    arr = as_float_array(value, name)
    bad = arr < 0 if allow_zero else arr <= 0
    if np.any(bad):
        rule = "non-negative" if allow_zero else "strictly positive"
        raise ValueError(f"{name} must be {rule}, got {describe(arr)}")
    return arr


def check_time_grid(t: ArrayLike, name: str = "t") -> NDArray[np.float64]:
    """Check a 1-D, finite, strictly increasing time grid with at least two points [s]."""
    arr = as_float_array(t, name)
    if arr.ndim != 1 or arr.size < 2:
        raise ValueError(f"{name} must be a 1-D time grid with at least 2 points, got shape {arr.shape}")
    steps = np.diff(arr)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise ValueError(
            f"{name} must be strictly increasing; {name}[{i + 1}]={arr[i + 1]!r} <= {name}[{i}]={arr[i]!r}"
        )
    return arr

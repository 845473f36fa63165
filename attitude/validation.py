"""Input checks shared by every module.

Every public function validates its arguments with these helpers so that bad
input raises a :class:`ValueError` whose message names the argument, the rule
broken and the offending value, instead of propagating NaN.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "as_float_array",
    "check_covariance",
    "check_direction",
    "check_positive",
    "check_time_grid",
    "check_vector",
    "describe",
    "finite_floats",
    "gain_matrix",
    "positive_per_axis",
    "positive_scalar",
    "scalar_angle",
    "scalar_time",
]


def describe(value: Any, max_items: int = 6) -> str:
    """Return a short printable description of ``value`` for error messages.

    Parameters
    ----------
    value : object
        Anything ``numpy.asarray`` accepts.
    max_items : int
        Largest array size printed in full; bigger arrays are described by
        their shape.

    Returns
    -------
    str
        The values (6 significant digits) or ``"array of shape (...)"``.
    """
    arr = np.asarray(value)
    if arr.ndim == 0 or arr.size <= max_items:
        return np.array2string(arr, precision=6, threshold=max_items) if arr.ndim else repr(arr.item())
    return f"array of shape {arr.shape}"


def as_float_array(value: ArrayLike, name: str, *, allow_nonfinite: bool = False) -> NDArray[np.float64]:
    """Convert ``value`` to a float64 array (a copy-free view when possible).

    Parameters
    ----------
    value : array_like
        Input of any shape.
    name : str
        Argument name used in error messages.
    allow_nonfinite : bool
        Accept NaN and inf.

    Returns
    -------
    ndarray of float64
        ``value`` with its shape; may share memory with ``value``.

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
    """Check that ``value`` is a finite array whose last axis has ``length`` entries.

    Parameters
    ----------
    value : array_like, shape (..., length)
        Vector(s) to check.
    name : str
        Argument name used in error messages.
    length : int
        Required size of the last axis.

    Returns
    -------
    ndarray of float64, shape (..., length)
        ``value`` as a float array (may share memory with it).

    Raises
    ------
    ValueError
        If ``value`` is non-numeric, holds NaN/inf, is a scalar, or its last
        axis is not ``length`` long.
    """
    arr = as_float_array(value, name)
    if arr.ndim == 0 or arr.shape[-1] != length:
        raise ValueError(f"{name} must have shape (..., {length}), got shape {arr.shape}")
    return arr


def finite_floats(value: Any, length: int) -> list[float] | None:
    """``value`` as ``length`` Python floats when it is a finite float64 array of shape ``(length,)``, else None.

    The per-tick fast check of a sensor or filter input: a caller that gets
    None takes its array path, whose checks (:func:`check_vector`) raise the
    error that names the argument (or accept the other shapes it allows).

    Parameters
    ----------
    value : object
        The input (typically an ndarray of shape ``(length,)``).
    length : int
        Required number of entries.

    Returns
    -------
    list of float or None
        The entries, all finite; None for anything else (NaN or inf included).
    """
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (length,):
        out = value.tolist()
        if all(map(math.isfinite, out)):
            return out
    return None


def check_direction(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A finite, non-zero 3-vector, normalised: a direction given by any vector along it.

    Parameters
    ----------
    value : array_like, shape (3,)
        The vector (any length but zero).
    name : str
        Argument name for the error message.

    Returns
    -------
    ndarray, shape (3,)
        The unit vector along ``value``.

    Raises
    ------
    ValueError
        If ``value`` is not a finite 3-vector or is zero.
    """
    arr = check_vector(value, name, 3)
    if arr.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got shape {arr.shape}")
    n = float(np.linalg.norm(arr))
    if n == 0.0:
        raise ValueError(f"{name} must be a non-zero vector (it is normalised), got {describe(arr)}")
    return arr / n


def check_positive(value: ArrayLike, name: str, *, allow_zero: bool = False) -> NDArray[np.float64]:
    """Check that every entry of ``value`` is finite and > 0 (>= 0 with ``allow_zero``).

    Parameters
    ----------
    value : array_like
        Value(s) of any shape.
    name : str
        Argument name used in error messages.
    allow_zero : bool
        Accept zero entries.

    Returns
    -------
    ndarray of float64
        ``value`` as a float array (may share memory with it).

    Raises
    ------
    ValueError
        If ``value`` is non-numeric, holds NaN/inf, or has an entry that is
        negative (or zero without ``allow_zero``).
    """
    arr = as_float_array(value, name)
    bad = arr < 0 if allow_zero else arr <= 0
    if np.any(bad):
        rule = "non-negative" if allow_zero else "strictly positive"
        raise ValueError(f"{name} must be {rule}, got {describe(arr)}")
    return arr


def positive_per_axis(value: ArrayLike, name: str, unit: str = "") -> NDArray[np.float64]:
    """A strictly positive value per body axis: one for all three, or three.

    Parameters
    ----------
    value : array_like
        A scalar, or shape (1,) or (3,).
    name : str
        Argument name used in error messages.
    unit : str
        Unit named in the error message ("" for none).

    Returns
    -------
    ndarray (3,)
        A new float array, the scalar repeated.

    Raises
    ------
    ValueError
        For a non-positive or non-finite entry, or another shape.
    """
    arr = check_positive(value, name)
    if arr.shape not in ((), (1,), (3,)):
        where = f" [{unit}]" if unit else ""
        raise ValueError(f"{name} must be a scalar or one value per axis (3,){where}, got shape {arr.shape}")
    return np.broadcast_to(arr.reshape(-1), (3,)).astype(np.float64)


def gain_matrix(value: ArrayLike, name: str) -> NDArray[np.float64]:
    """A positive-definite 3x3 gain (its symmetric part), or three diagonal gains.

    Parameters
    ----------
    value : array_like
        Shape (3,) (the diagonal) or (3, 3).
    name : str
        Argument name used in error messages.

    Returns
    -------
    ndarray (3, 3)

    Raises
    ------
    ValueError
        For another shape, or a symmetric part that is not positive definite.
    """
    arr = as_float_array(value, name)
    if arr.shape == (3,):
        arr = np.diag(arr)
    if arr.shape != (3, 3):
        raise ValueError(f"{name} must be 3 diagonal gains or a 3x3 matrix, got shape {arr.shape}")
    eig = np.linalg.eigvalsh(0.5 * (arr + arr.T))
    if eig[0] <= 0:
        raise ValueError(f"{name} must be positive definite, got eigenvalues {describe(eig)}")
    return arr


def positive_scalar(value: ArrayLike, name: str, *, allow_zero: bool = False, why: str = "") -> float:
    """A finite scalar > 0 (>= 0 with ``allow_zero``) as a float.

    Parameters
    ----------
    value : array_like
        The value.
    name : str
        Argument name used in error messages.
    allow_zero : bool
        Accept zero.
    why : str
        Reason appended to the message when ``value`` is not a scalar.

    Raises
    ------
    ValueError
        As :func:`check_positive`, or if ``value`` is not a scalar.
    """
    arr = check_positive(value, name, allow_zero=allow_zero)
    if arr.ndim != 0:
        raise ValueError(f"{name} must be a scalar{f' ({why})' if why else ''}, got shape {arr.shape}")
    return float(arr)


def scalar_time(value: ArrayLike, name: str = "t") -> float:
    """A finite scalar time [s] as a float (any sign).

    Parameters
    ----------
    value : array_like
        The time [s]: a finite scalar.
    name : str, optional
        Argument name used in the error message.

    Raises
    ------
    ValueError
        If ``value`` is not numeric, not finite or not a scalar.
    """
    arr = as_float_array(value, name)
    if arr.ndim != 0:
        raise ValueError(f"{name} must be a scalar time [s], got shape {arr.shape}")
    return float(arr)


def check_covariance(value: ArrayLike, name: str, n: int, *, variances: bool = False) -> NDArray[np.float64]:
    """A finite, symmetric, positive-definite (n, n) matrix, symmetrised.

    Parameters
    ----------
    value : array_like (n, n), or (n,) with ``variances``
        The covariance (any unit); ``(n,)`` variances make a diagonal one.
    name : str
        Argument name used in error messages.
    n : int
        Dimension.
    variances : bool
        Accept ``(n,)`` variances.

    Raises
    ------
    ValueError
        For the wrong shape, NaN/inf, an asymmetry beyond 1e-9 of the
        largest entry (rounding of a typed-in matrix passes), or a matrix
        that is not positive definite (its eigenvalues are named).
    """
    c = as_float_array(value, name)
    if variances and c.shape == (n,):
        c = np.diag(c)
    if c.shape != (n, n):
        alternative = f" or ({n},) (variances)" if variances else ""
        raise ValueError(f"{name} must have shape ({n}, {n}){alternative}, got shape {c.shape}")
    scale = max(float(np.abs(c).max()), np.finfo(float).tiny)
    asym = float(np.abs(c - c.T).max())
    if asym > 1e-9 * scale:
        raise ValueError(f"{name} must be symmetric; found a relative asymmetry of {asym / scale:.3g}")
    c = 0.5 * (c + c.T)
    try:
        np.linalg.cholesky(c)
    except np.linalg.LinAlgError:
        eig = np.linalg.eigvalsh(c)
        raise ValueError(
            f"{name} must be positive definite; its smallest eigenvalue is {eig.min():.6g} "
            f"(eigenvalues {describe(eig)})"
        ) from None
    return c


def check_time_grid(t: ArrayLike, name: str = "t") -> NDArray[np.float64]:
    """Check a 1-D, finite, strictly increasing time grid with at least two points [s].

    Parameters
    ----------
    t : array_like, shape (n,)
        Time grid [s].
    name : str
        Argument name used in error messages.

    Returns
    -------
    ndarray of float64, shape (n,)
        The grid [s] (may share memory with ``t``).

    Raises
    ------
    ValueError
        If ``t`` is non-numeric, holds NaN/inf, is not 1-D with ``n >= 2``,
        or is not strictly increasing.
    """
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


def scalar_angle(value: ArrayLike, name: str) -> float:
    """A finite scalar angle [rad], or a ValueError naming ``name``.

    Parameters
    ----------
    value : float
        The angle [rad].
    name : str
        Argument name used in the error message.

    Returns
    -------
    float
        The angle as a float.
    """
    arr = as_float_array(value, name)
    if arr.ndim != 0:
        raise ValueError(f"{name} must be a scalar angle in rad, got shape {arr.shape}")
    return float(arr)

"""Backend-neutral elementary functions for the one-definition models.

The models (rigid body, wheels, built-in control laws) are written once on
lists of components and evaluate on numpy arrays (batched simulation) and on
casadi symbols (exact Jacobians, optimisation, compiled closed loops). Plain
``+ - * / **`` work on both; the few functions below dispatch on the type of
their argument so that saturation, square roots, smooth signs and the sine
and cosine of the quaternion exponential have one definition too.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

__all__ = [
    "atan2",
    "clip",
    "cos",
    "cross",
    "fabs",
    "floor",
    "fmax",
    "fmin",
    "if_else",
    "is_finite",
    "is_symbolic",
    "sin",
    "sqrt",
    "tanh",
]

_CASADI_TYPES = (ca.SX, ca.MX, ca.DM)


def is_symbolic(*values: Any) -> bool:
    """True if any value is a casadi object.

    Parameters
    ----------
    *values : object
        Values to inspect.

    Returns
    -------
    bool
        Whether any value is a casadi ``SX``, ``MX`` or ``DM``.
    """
    return any(isinstance(v, _CASADI_TYPES) for v in values)


def sqrt(x: Any) -> Any:
    """Square root.

    Parameters
    ----------
    x : numpy array_like or casadi SX/MX/DM
        Non-negative argument.

    Returns
    -------
    ndarray or casadi object
        ``sqrt(x)``, casadi if ``x`` is symbolic.
    """
    return ca.sqrt(x) if is_symbolic(x) else np.sqrt(x)


def sin(x: Any) -> Any:
    """Sine.

    Parameters
    ----------
    x : numpy array_like or casadi SX/MX/DM
        Angle [rad].

    Returns
    -------
    ndarray or casadi object
        ``sin(x)``, casadi if ``x`` is symbolic.
    """
    return ca.sin(x) if is_symbolic(x) else np.sin(x)


def cos(x: Any) -> Any:
    """Cosine.

    Parameters
    ----------
    x : numpy array_like or casadi SX/MX/DM
        Angle [rad].

    Returns
    -------
    ndarray or casadi object
        ``cos(x)``, casadi if ``x`` is symbolic.
    """
    return ca.cos(x) if is_symbolic(x) else np.cos(x)


def tanh(x: Any) -> Any:
    """Hyperbolic tangent (the smooth sign used for Coulomb friction).

    Parameters
    ----------
    x : numpy array_like or casadi SX/MX/DM
        Dimensionless argument.

    Returns
    -------
    ndarray or casadi object
        ``tanh(x)`` in ``[-1, 1]``, casadi if ``x`` is symbolic.
    """
    return ca.tanh(x) if is_symbolic(x) else np.tanh(x)


def fabs(x: Any) -> Any:
    """Absolute value.

    Parameters
    ----------
    x : numpy array_like or casadi SX/MX/DM
        Argument (any units).

    Returns
    -------
    ndarray or casadi object
        ``|x|``, casadi if ``x`` is symbolic.
    """
    return ca.fabs(x) if is_symbolic(x) else np.abs(x)


def floor(x: Any) -> Any:
    """Largest integer not above ``x`` (used for quantisation).

    Parameters
    ----------
    x : numpy array_like or casadi SX/MX/DM
        Argument (dimensionless).

    Returns
    -------
    ndarray or casadi object
        ``floor(x)``, casadi if ``x`` is symbolic.
    """
    return ca.floor(x) if is_symbolic(x) else np.floor(x)


def atan2(y: Any, x: Any) -> Any:
    """Four-quadrant arc tangent of ``y / x`` [rad].

    Parameters
    ----------
    y, x : numpy array_like or casadi SX/MX/DM

    Returns
    -------
    ndarray or casadi object
        Angle in ``[-pi, pi]``, casadi if either argument is symbolic.
    """
    return ca.atan2(y, x) if is_symbolic(y, x) else np.arctan2(y, x)


def is_finite(x: Any) -> Any:
    """True where ``x`` is neither NaN nor infinite.

    Written as ``|x| < inf`` (false for NaN and inf under IEEE rules), which
    casadi keeps as a comparison: ``x - x == 0`` would be simplified away.

    Parameters
    ----------
    x : numpy array_like or casadi SX/MX/DM

    Returns
    -------
    ndarray of bool or casadi object
        The test, casadi (1/0) if ``x`` is symbolic.
    """
    return fabs(x) < np.inf


def fmin(a: Any, b: Any) -> Any:
    """Elementwise minimum.

    Parameters
    ----------
    a, b : numpy array_like or casadi SX/MX/DM
        Arguments in the same units (numpy arrays broadcast).

    Returns
    -------
    ndarray or casadi object
        ``min(a, b)``, casadi if either argument is symbolic.
    """
    return ca.fmin(a, b) if is_symbolic(a, b) else np.minimum(a, b)


def fmax(a: Any, b: Any) -> Any:
    """Elementwise maximum.

    Parameters
    ----------
    a, b : numpy array_like or casadi SX/MX/DM
        Arguments in the same units (numpy arrays broadcast).

    Returns
    -------
    ndarray or casadi object
        ``max(a, b)``, casadi if either argument is symbolic.
    """
    return ca.fmax(a, b) if is_symbolic(a, b) else np.maximum(a, b)


def clip(x: Any, lower: Any, upper: Any) -> Any:
    """Clamp ``x`` to ``[lower, upper]``.

    Parameters
    ----------
    x, lower, upper : numpy array_like or casadi SX/MX/DM
        Value and bounds in the same units, ``lower <= upper``.

    Returns
    -------
    ndarray or casadi object
        ``min(max(x, lower), upper)``, casadi if any argument is symbolic.
    """
    return fmin(fmax(x, lower), upper)


def if_else(condition: Any, if_true: Any, if_false: Any) -> Any:
    """``if_true`` where ``condition`` holds, else ``if_false`` (both evaluated).

    Parameters
    ----------
    condition : numpy array_like of bool or casadi SX/MX/DM
        Selector.
    if_true, if_false : numpy array_like or casadi SX/MX/DM
        Values selected where ``condition`` holds and where it does not.

    Returns
    -------
    ndarray or casadi object
        The selection, casadi if any argument is symbolic.
    """
    if is_symbolic(condition, if_true, if_false):
        return ca.if_else(condition, if_true, if_false)
    return np.where(condition, if_true, if_false)


def cross(a: Any, b: Any) -> list[Any]:
    """Cross product ``a x b`` of two 3-component lists (numpy arrays or casadi scalars).

    Parameters
    ----------
    a, b : list of 3 numpy arrays or casadi scalars
        Vector components (any units; numpy entries broadcast).

    Returns
    -------
    list of 3
        Components of ``a x b`` (units of ``a`` times units of ``b``).
    """
    return [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]

"""Backend-neutral elementary functions for the one-definition models.

The models (rigid body, wheels, built-in control laws) are written once on
lists of components and evaluate on numpy arrays (batched simulation) and on
casadi symbols (exact Jacobians, optimisation, compiled closed loops). Plain
``+ - * / **`` work on both; the few functions below dispatch on the type of
their argument so that saturation, square roots and smooth signs have one
definition too.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

__all__ = ["clip", "fabs", "fmax", "fmin", "if_else", "is_symbolic", "sqrt", "tanh"]

_CASADI_TYPES = (ca.SX, ca.MX, ca.DM)


def is_symbolic(*values: Any) -> bool:
    """True if any value is a casadi object."""
    return any(isinstance(v, _CASADI_TYPES) for v in values)


def sqrt(x: Any) -> Any:
    """Square root."""
    return ca.sqrt(x) if is_symbolic(x) else np.sqrt(x)


def tanh(x: Any) -> Any:
    """Hyperbolic tangent (the smooth sign used for Coulomb friction)."""
    return ca.tanh(x) if is_symbolic(x) else np.tanh(x)


def fabs(x: Any) -> Any:
    """Absolute value."""
    return ca.fabs(x) if is_symbolic(x) else np.abs(x)


def fmin(a: Any, b: Any) -> Any:
    """Elementwise minimum."""
    return ca.fmin(a, b) if is_symbolic(a, b) else np.minimum(a, b)


def fmax(a: Any, b: Any) -> Any:
    """Elementwise maximum."""
    return ca.fmax(a, b) if is_symbolic(a, b) else np.maximum(a, b)


def clip(x: Any, lower: Any, upper: Any) -> Any:
    """Clamp ``x`` to ``[lower, upper]``."""
    return fmin(fmax(x, lower), upper)


def if_else(condition: Any, if_true: Any, if_false: Any) -> Any:
    """``if_true`` where ``condition`` holds, else ``if_false`` (both evaluated)."""
    if is_symbolic(condition, if_true, if_false):
        return ca.if_else(condition, if_true, if_false)
    return np.where(condition, if_true, if_false)

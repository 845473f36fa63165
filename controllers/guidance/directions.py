"""Directions the guidance modes point at, with their inertial rates and accelerations: the orbit's and constants.

The spacecraft's motion comes from the orbit (``position_N``,
``velocity_N``) with the two-body acceleration and jerk of
:func:`attitude.environment.orbit.two_body_motion` and the orbit's ``mu``:
exact for :class:`~attitude.environment.CircularOrbit` and
:class:`~attitude.environment.KeplerOrbit`; for a
:class:`~attitude.environment.TLEOrbit` the position and velocity are SGP4's
and the acceleration leaves out J2, the other zonal terms and drag (about
1e-3 of the central term in low orbit), so rates are exact to the state and
angular accelerations to about that fraction. Orbit-normal directions then
ignore the slow turn of the plane (J2 nodal regression), as
:meth:`attitude.environment.TLEOrbit.omega_LN_L` does.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.environment.orbit import two_body_motion
from attitude.validation import check_vector, describe
from controllers.guidance.alignment import VectorTrack

__all__ = ["ORBIT_DIRECTIONS", "OrbitMotion", "check_orbit", "constant_direction", "direction_source", "orbit_motion"]

#: Named directions of the orbit a secondary axis can be turned towards.
ORBIT_DIRECTIONS = ("orbit_normal", "velocity", "nadir", "zenith")


class OrbitMotion(NamedTuple):
    """Position [m], velocity [m/s], acceleration [m/s^2] and jerk [m/s^3] in N, each (n, 3).

    Parameters
    ----------
    r : ndarray
        Position from the Earth's centre.
    v : ndarray
        Inertial velocity.
    a : ndarray
        Acceleration (two-body).
    jerk : ndarray
        Its rate (two-body).
    """

    r: NDArray[np.float64]
    v: NDArray[np.float64]
    a: NDArray[np.float64]
    jerk: NDArray[np.float64]


def check_orbit(orbit: Any) -> Any:
    """An orbit checked for what guidance needs: ``position_N``, ``velocity_N`` and ``mu``.

    Parameters
    ----------
    orbit : object
        E.g. :class:`attitude.environment.CircularOrbit`, ``KeplerOrbit`` or ``TLEOrbit``.

    Returns
    -------
    object
        ``orbit``.

    Raises
    ------
    ValueError
        If a member is missing.
    """
    missing = [name for name in ("position_N", "velocity_N", "mu", "epoch") if not hasattr(orbit, name)]
    if missing:
        raise ValueError(
            f"orbit must have position_N(t), velocity_N(t), mu and epoch (an attitude.environment orbit); "
            f"{type(orbit).__name__} lacks {missing}"
        )
    return orbit


def orbit_motion(orbit: Any, t: NDArray[np.float64]) -> OrbitMotion:
    """The spacecraft's motion at times ``t`` (n,) [s] (module docstring for the model).

    Parameters
    ----------
    orbit : object
        Anything with ``position_N(t)``, ``velocity_N(t)`` and ``mu``.
    t : ndarray, shape (n,)
        Times since the orbit's epoch [s].

    Returns
    -------
    OrbitMotion
    """
    r = np.asarray(orbit.position_N(t), dtype=float).reshape(-1, 3)
    v = np.asarray(orbit.velocity_N(t), dtype=float).reshape(-1, 3)
    a, jerk = two_body_motion(r, v, orbit.mu)
    return OrbitMotion(r, v, a, jerk)


def _orbit_direction(motion: OrbitMotion, name: str) -> VectorTrack:
    r, v, a, jerk = motion
    if name == "orbit_normal":
        return VectorTrack(np.cross(r, v), np.cross(r, a), np.cross(v, a) + np.cross(r, jerk))
    if name == "velocity":
        return VectorTrack(v, a, jerk)
    if name == "nadir":
        return VectorTrack(-r, -v, -a)
    return VectorTrack(r, v, a)  # zenith


def constant_direction(vector_N: ArrayLike, name: str = "direction") -> Callable[[NDArray[np.float64]], VectorTrack]:
    """A fixed inertial direction as a function of time (zero derivatives).

    Parameters
    ----------
    vector_N : array_like, shape (3,)
        The direction in N (non-zero).
    name : str
        Argument name for errors.

    Returns
    -------
    callable
        ``t (n,) -> VectorTrack`` of (n, 3) arrays.

    Raises
    ------
    ValueError
        If ``vector_N`` is not one non-zero (3,) vector.
    """
    v = check_vector(vector_N, name, 3)
    if v.shape != (3,) or not np.linalg.norm(v) > 0.0:
        raise ValueError(f"{name} must be one non-zero vector in N of shape (3,), got {describe(v)}")
    v = v.copy()

    def track(t: NDArray[np.float64]) -> VectorTrack:
        n = np.size(t)
        return VectorTrack(np.tile(v, (n, 1)), np.zeros((n, 3)), np.zeros((n, 3)))

    return track


def direction_source(orbit: Any, spec: Any, name: str = "secondary") -> Callable[[NDArray[np.float64]], VectorTrack]:
    """A direction named by ``spec``: one of :data:`ORBIT_DIRECTIONS` or a constant vector in N.

    Parameters
    ----------
    orbit : object
        The orbit for the named directions.
    spec : str or array_like (3,)
        ``"orbit_normal"`` (``r x v``), ``"velocity"``, ``"nadir"`` (``-r``),
        ``"zenith"`` (``r``) or a fixed direction in N (e.g. ``[0, 0, 1]``,
        the Earth's pole).
    name : str
        Argument name for errors.

    Returns
    -------
    callable
        ``t (n,) -> VectorTrack``.

    Raises
    ------
    ValueError
        For an unknown name or a bad vector.
    """
    if isinstance(spec, str):
        if spec not in ORBIT_DIRECTIONS:
            raise ValueError(f"{name} must be one of {ORBIT_DIRECTIONS} or a (3,) vector in N, got {spec!r}")
        return lambda t: _orbit_direction(orbit_motion(orbit, t), spec)
    return constant_direction(spec, name)

"""Primary/secondary vector alignment: the reference frame R from two body axes and two target directions.

The primary body axis ``b1`` is put exactly on the primary direction ``p``;
the secondary body axis ``b2`` is turned as close as it can get to the
secondary direction ``s`` (into the plane of ``p`` and ``s``, on ``s``'s
side). It is the TRIAD construction (Black 1964; Shuster and Oh 1981;
Markley and Crassidis, *Fundamentals of Spacecraft Attitude Determination
and Control*, 2014, sec. 5.2) applied to a commanded attitude, the
two-vector pointing of Basilisk's ``velocityPointing``/``hillPoint`` modules
generalised to any pair:

.. math::

    t_1 = \\hat p,\\quad t_2 = \\widehat{p \\times s},\\quad t_3 = t_1 \\times t_2;\\qquad
    m_1 = \\hat b_1,\\quad m_2 = \\widehat{b_1 \\times b_2},\\quad m_3 = m_1 \\times m_2

and ``C_RN = M T^T`` (columns ``m_i`` in body components, ``t_i`` in N).
The rates are analytic: with the derivatives of ``p`` and ``s`` (in N) the
triad's derivatives follow from those of a unit vector, ``u = v/|v|``,
``u' = (v' - u (u.v'))/|v|``, ``u'' = (v'' - u |v|'' - 2 u' |v|')/|v|``;
the triad's angular velocity in its own axes is
``omega_T = [t2'.t3, t3'.t1, t1'.t2]`` and its derivative
``[t2''.t3 + t2'.t3', t3''.t1 + t3'.t1', t1''.t2 + t1'.t2']``; R is the
triad turned by the constant ``M``, so ``omega_RN_R = M omega_T`` and
``omega_dot_RN_R = M omega_dot_T``.

Singularity: when ``p`` and ``s`` are parallel ``p x s`` vanishes and the
rotation about ``p`` is undefined; near it the rates grow as ``1/sin`` of
their separation. Separations below ``separation_min`` are refused with a
ValueError naming the times (no NaN). See docs/guidance.md.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.validation import check_vector, describe, positive_scalar
from controllers.guidance.protocol import SampledReference, Samples, reference_times

__all__ = ["SEPARATION_MIN_DEFAULT", "VectorAlignmentReference", "VectorTrack", "align_two_vectors", "body_triad"]

#: Default smallest angle [rad] between the two target (or the two body) directions: 1 deg, where the
#: frame's rate about the primary direction is already 57 times the secondary direction's own rate.
SEPARATION_MIN_DEFAULT = float(np.radians(1.0))


class VectorTrack(NamedTuple):
    """A direction in N and its first two inertial time derivatives, each shape (..., 3).

    The vector need not be a unit vector (e.g. a line of sight in metres):
    only its direction is used, with the derivatives of that direction
    computed from these.

    Parameters
    ----------
    vector : ndarray
        The vector in N (non-zero).
    rate : ndarray
        Its time derivative [unit/s].
    acceleration : ndarray
        Its second time derivative [unit/s^2].
    """

    vector: NDArray[np.float64]
    rate: NDArray[np.float64]
    acceleration: NDArray[np.float64]


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.sum(a * b, axis=-1, keepdims=True)


def _unit_with_derivatives(
    v: NDArray[np.float64], v1: NDArray[np.float64], v2: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``u = v/|v|`` and its first two derivatives (module docstring); ``v`` non-zero."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    u = v / n
    n1 = _dot(u, v1)
    u1 = (v1 - u * n1) / n
    n2 = _dot(u1, v1) + _dot(u, v2)
    u2 = (v2 - u * n2 - 2.0 * u1 * n1) / n
    return u, u1, u2


def _separation_sine(p: NDArray[np.float64], s: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.linalg.norm(np.cross(p, s), axis=-1) / (np.linalg.norm(p, axis=-1) * np.linalg.norm(s, axis=-1))


def body_triad(
    primary_axis_B: ArrayLike, secondary_axis_B: ArrayLike, separation_min: float = SEPARATION_MIN_DEFAULT
) -> NDArray[np.float64]:
    """The body triad ``M = [m1 m2 m3]`` (columns, body components) of the two body axes.

    Parameters
    ----------
    primary_axis_B : array_like, shape (3,)
        Body axis put on the primary direction (non-zero; normalised).
    secondary_axis_B : array_like, shape (3,)
        Body axis turned towards the secondary direction.
    separation_min : float
        Smallest accepted angle between the two axes [rad].

    Returns
    -------
    ndarray, shape (3, 3)

    Raises
    ------
    ValueError
        If an axis is not a non-zero (3,) vector or the two are within ``separation_min`` of parallel.
    """
    b1 = check_vector(primary_axis_B, "primary_axis_B", 3)
    b2 = check_vector(secondary_axis_B, "secondary_axis_B", 3)
    for name, b in (("primary_axis_B", b1), ("secondary_axis_B", b2)):
        if b.shape != (3,) or not np.linalg.norm(b) > 0.0:
            raise ValueError(f"{name} must be one non-zero body vector of shape (3,), got {describe(b)}")
    if _separation_sine(b1, b2) < np.sin(separation_min):
        raise ValueError(
            f"primary_axis_B and secondary_axis_B must be at least separation_min = {separation_min!r} rad from "
            f"parallel (the rotation about the primary axis is undefined otherwise), got {describe(b1)} and "
            f"{describe(b2)}"
        )
    m1 = b1 / np.linalg.norm(b1)
    m2 = np.cross(b1, b2)
    m2 = m2 / np.linalg.norm(m2)
    return np.stack([m1, m2, np.cross(m1, m2)], axis=-1)


def _checked_track(track: VectorTrack, name: str) -> VectorTrack:
    parts = [check_vector(x, f"{name}.{field}", 3) for x, field in zip(track, VectorTrack._fields)]
    shape = np.broadcast_shapes(*(x.shape for x in parts))
    v, v1, v2 = (np.broadcast_to(x, shape) for x in parts)
    if np.any(np.linalg.norm(v, axis=-1) == 0.0):
        raise ValueError(f"{name}.vector must be non-zero (a direction), got {describe(v)}")
    return VectorTrack(v, v1, v2)


def align_two_vectors(
    body_axes: NDArray[np.float64],
    primary: VectorTrack,
    secondary: VectorTrack,
    *,
    separation_min: float = SEPARATION_MIN_DEFAULT,
    t: ArrayLike | None = None,
) -> Samples:
    """``q_RN``, ``omega_RN_R`` and ``omega_dot_RN_R`` of the two-vector alignment (module docstring).

    Parameters
    ----------
    body_axes : ndarray, shape (3, 3)
        The body triad from :func:`body_triad`.
    primary : VectorTrack
        Primary direction in N with its derivatives, shape (..., 3) each.
    secondary : VectorTrack
        Secondary direction in N with its derivatives, broadcasting against ``primary``.
    separation_min : float
        Smallest accepted angle between the two directions [rad].
    t : array_like, optional
        Times [s] of the samples, only to name them in an error.

    Returns
    -------
    q_RN : ndarray, shape (..., 4)
        Attitude of R (scalar part ``>= 0``).
    omega_RN_R : ndarray, shape (..., 3)
        [rad/s].
    omega_dot_RN_R : ndarray, shape (..., 3)
        [rad/s^2].

    Raises
    ------
    ValueError
        If a direction is zero or not (..., 3), or the two are within
        ``separation_min`` of parallel (naming the times when ``t`` is given).
    """
    separation_min = positive_scalar(separation_min, "separation_min")
    p, p1, p2 = _checked_track(primary, "primary")
    s, s1, s2 = _checked_track(secondary, "secondary")
    sine = _separation_sine(p, s)
    close = sine < np.sin(separation_min)
    if np.any(close):
        where = ""
        if t is not None:
            where = f"at t = {describe(np.broadcast_to(np.asarray(t, float), close.shape)[close])} s"
        raise ValueError(
            f"the primary and secondary directions must be at least separation_min = {separation_min!r} rad "
            f"({np.degrees(separation_min):.3g} deg) from parallel, got "
            f"{describe(np.degrees(np.arcsin(np.clip(sine[close], 0.0, 1.0))))} deg {where}: the rotation "
            "about the primary direction is undefined there; choose another secondary direction"
        )
    t1, t1d, t1dd = _unit_with_derivatives(p, p1, p2)
    w = np.cross(p, s)
    w1 = np.cross(p1, s) + np.cross(p, s1)
    w2 = np.cross(p2, s) + 2.0 * np.cross(p1, s1) + np.cross(p, s2)
    t2, t2d, t2dd = _unit_with_derivatives(w, w1, w2)
    t3 = np.cross(t1, t2)
    t3d = np.cross(t1d, t2) + np.cross(t1, t2d)
    t3dd = np.cross(t1dd, t2) + 2.0 * np.cross(t1d, t2d) + np.cross(t1, t2dd)
    omega_T = np.concatenate([_dot(t2d, t3), _dot(t3d, t1), _dot(t1d, t2)], axis=-1)
    omega_dot_T = np.concatenate(
        [_dot(t2dd, t3) + _dot(t2d, t3d), _dot(t3dd, t1) + _dot(t3d, t1d), _dot(t1dd, t2) + _dot(t1d, t2d)], axis=-1
    )
    triad_N = np.stack([t1, t2, t3], axis=-1)  # columns t_i in N: C_NT
    C_RN = body_axes @ np.swapaxes(triad_N, -1, -2)
    q_RN = quat.from_dcm(C_RN)
    return q_RN, omega_T @ body_axes.T, omega_dot_T @ body_axes.T


class VectorAlignmentReference(SampledReference):
    """The general two-vector pointing reference: any primary and secondary direction functions of time.

    Parameters
    ----------
    primary_axis_B : array_like, shape (3,)
        Body axis put exactly on the primary direction.
    primary : callable
        ``primary(t) -> VectorTrack`` for times ``t`` (n,) [s]: the primary
        direction in N with its first two derivatives, each (n, 3).
    secondary_axis_B : array_like, shape (3,)
        Body axis turned as close as possible to the secondary direction.
    secondary : callable
        ``secondary(t) -> VectorTrack``, as ``primary``.
    separation_min : float
        Smallest accepted angle [rad] between the two body axes and between
        the two directions (default 1 deg).

    Raises
    ------
    ValueError
        At construction for bad axes; at sampling for directions within
        ``separation_min`` of parallel (module docstring).
    """

    def __init__(
        self,
        primary_axis_B: ArrayLike,
        primary: Callable[[NDArray[np.float64]], VectorTrack],
        secondary_axis_B: ArrayLike,
        secondary: Callable[[NDArray[np.float64]], VectorTrack],
        *,
        separation_min: float = SEPARATION_MIN_DEFAULT,
    ) -> None:
        self.separation_min = positive_scalar(separation_min, "separation_min")
        for name, fn in (("primary", primary), ("secondary", secondary)):
            if not callable(fn):
                raise ValueError(f"{name} must be a callable t -> VectorTrack, got {fn!r}")
        self.body_axes = body_triad(primary_axis_B, secondary_axis_B, self.separation_min)
        self.primary_axis_B = self.body_axes[:, 0]
        self.primary = primary
        self.secondary = secondary

    def samples(self, t: ArrayLike) -> Samples:
        """``q_RN`` (n, 4), ``omega_RN_R`` (n, 3) [rad/s] and ``omega_dot_RN_R`` (n, 3) [rad/s^2].

        Parameters
        ----------
        t : array_like, shape (n,)
            Times [s].
        """
        t = reference_times(t)
        return align_two_vectors(
            self.body_axes,
            VectorTrack(*self.primary(t)),
            VectorTrack(*self.secondary(t)),
            separation_min=self.separation_min,
            t=t,
        )

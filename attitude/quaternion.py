"""Unit quaternions: Hamilton product, scalar first, batch-aware.

Convention (see README and ``DESIGN.md``): ``q = [w, x, y, z]`` with the
scalar first and the Hamilton product. ``q_BN`` is the attitude of the body
frame B relative to the inertial frame N; it rotates body vectors into
inertial ones, ``v_N = q ⊗ [0, v_B] ⊗ q*``. This is exactly
``scipy.spatial.transform.Rotation.from_quat(q, scalar_first=True).apply(v_B)``.
The direction cosine matrix ``C_BN`` maps N components to B components, so
``C_BN = Rotation.from_quat(q_BN, scalar_first=True).as_matrix().T``.

Every function accepts leading batch dimensions (``(..., 4)`` quaternions,
``(..., 3)`` vectors, ``(..., 3, 3)`` matrices), broadcasts them, and never
mutates its inputs; the exceptions say so in their names: ``*_components``
(the one definition of the algebra, on lists of numbers, arrays or casadi
expressions) and ``*_floats`` (one quaternion in Python floats, rounded
exactly as the array function, for code that runs at every tick). Quaternions passed in as attitudes must have unit norm
to within :data:`UNIT_NORM_TOLERANCE`; functions that accept any non-zero
quaternion say so.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import backend as bk
from attitude.backend import cross
from attitude.rng import as_generator
from attitude.validation import as_float_array, check_vector

__all__ = [
    "UNIT_NORM_TOLERANCE",
    "as_unit_quaternion",
    "conjugate",
    "derivative",
    "error_angle",
    "error_angle_components",
    "error_quaternion",
    "exp",
    "from_axis_angle",
    "from_dcm",
    "from_mrp",
    "from_rotation_vector",
    "from_rotation_vector_floats",
    "identity",
    "inverse",
    "log",
    "mrp_shadow",
    "multiply",
    "norm",
    "normalize",
    "random",
    "rotate",
    "rotate_inverse",
    "rotation_vector_floats",
    "shortest",
    "slerp",
    "to_axis_angle",
    "to_dcm",
    "to_mrp",
    "to_rotation_vector",
    "unit_floats",
    "unit_vector_angle",
]

#: Largest accepted deviation of ``|q|`` from 1 for an attitude quaternion.
#: Loose enough for quaternions read from files with ~8 significant digits,
#: tight enough that the rotation matrix is orthonormal to about 1e-6.
UNIT_NORM_TOLERANCE = 1e-6

# Below this rotation angle [rad] series expansions replace sin(x)/x etc.;
# the truncation error of the series used is below 1e-20 there.
_SMALL_ANGLE = 1e-5

# Largest scalar part whose exponential is finite in float64 (e^709.78 ~ 1.8e308).
_EXP_MAX = 709.0


# ---------------------------------------------------------------------------
# The one definition of the quaternion algebra, on component lists.
#
# Lists of 4 (or 3) components that are numpy arrays of any common batch
# shape or casadi scalars, combined with + - * only (``exp`` is numpy only).
# The array API below and every model (rigid body, integrators, controllers,
# filters, planners) use these; no checks here (the callers validate).
# ---------------------------------------------------------------------------


def multiply_components(p: list, q: list) -> list:
    """Hamilton product ``p ⊗ q`` on components ``[w, x, y, z]``."""
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    return [
        pw * qw - px * qx - py * qy - pz * qz,
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
    ]


def conjugate_components(q: list) -> list:
    """Conjugate ``[w, -x, -y, -z]`` on components."""
    return [q[0], -q[1], -q[2], -q[3]]


def derivative_components(q: list, omega: list) -> list:
    """Kinematics ``0.5 q ⊗ [0, omega]`` on components (the product with the zero terms left out) [1/s]."""
    qw, qx, qy, qz = q
    wx, wy, wz = omega
    return [
        -0.5 * (qx * wx + qy * wy + qz * wz),
        0.5 * (qw * wx + qy * wz - qz * wy),
        0.5 * (qw * wy - qx * wz + qz * wx),
        0.5 * (qw * wz + qx * wy - qy * wx),
    ]


def rotate_components(q: list, v: list) -> list:
    """``q ⊗ v ⊗ q*`` for a unit quaternion: body components to inertial ones for ``q = q_BN``.

    Uses ``v + w t + u x t`` with ``t = 2 u x v`` (``u`` the vector part).
    """
    w, u = q[0], q[1:]
    t = [2.0 * c for c in cross(u, v)]
    ut = cross(u, t)
    return [vi + w * ti + ci for vi, ti, ci in zip(v, t, ut)]


def rotate_inverse_components(q: list, v: list) -> list:
    """``q* ⊗ v ⊗ q`` for a unit quaternion: inertial components to body ones for ``q = q_BN``."""
    return rotate_components(conjugate_components(q), v)


#: Half-angle [rad] below which sin(h)/h is replaced by its series 1 - h^2/6.
_EXP_SERIES_HALF_ANGLE = 1e-4


def exp_rotation_vector_components(phi: list, half_angle: Any = None) -> list:
    """Unit quaternion ``[cos(|phi|/2), sin(|phi|/2) phi/|phi|]`` of a rotation vector [rad].

    Backend-neutral (:mod:`attitude.backend`): numpy arrays, Python floats or
    casadi symbols, the same arithmetic on each (the compiled geometric
    propagation evaluates it in casadi). A series replaces ``sin(h)/h`` for
    half-angles ``h < 1e-4`` rad (``1 - h^2/6``; the omitted ``h^4/120`` is
    below 1e-18), so ``phi = 0`` is exact. ``half_angle`` (``|phi|/2``) may be
    given when already known (e.g. from a scale-safe norm).
    """
    if half_angle is None:
        squared = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]
        # numpy evaluates an array's ** 0.5 as sqrt; casadi would keep it a pow: sqrt on both.
        half = 0.5 * (squared**0.5 if type(squared) is float else bk.sqrt(squared))
    else:
        half = half_angle
    if type(half) is float:  # one rotation in Python floats (not numpy scalars): math, no per-call overhead
        sinc = 1.0 - half * half / 6.0 if half < _EXP_SERIES_HALF_ANGLE else math.sin(half) / half
        return [math.cos(half), 0.5 * sinc * phi[0], 0.5 * sinc * phi[1], 0.5 * sinc * phi[2]]
    small = half < _EXP_SERIES_HALF_ANGLE
    tiny = bk.if_else(small, half, 0.0)  # keeps the unused series branch finite for huge angles
    sinc = bk.if_else(small, 1.0 - tiny * tiny / 6.0, bk.sin(half) / bk.if_else(small, 1.0, half))
    s = 0.5 * sinc
    return [bk.cos(half), s * phi[0], s * phi[1], s * phi[2]]


def log_vector_components(q: list) -> list:
    """Vector part ``theta v/|v|`` of ``log(q)``, ``theta = atan2(|v|, w)`` in ``[0, pi]`` (numpy).

    Scale-invariant (any non-zero ``q``); half the rotation vector for a unit
    ``q`` taken the way it points (flip ``q`` to ``w >= 0`` first for the
    shortest way). ``hypot`` does not underflow, and atan2 keeps full relative
    precision for any ``|v| > 0`` (no series needed; theta -> pi when w < 0).
    For ``v = 0`` and ``w < 0`` the axis is arbitrary: x is used, as in
    :func:`to_axis_angle`.
    """
    w, x, y, z = q
    vn = np.hypot(np.hypot(x, y), z)
    theta = np.arctan2(vn, w)
    zero = vn == 0
    scale = np.where(zero, 0.0, theta / np.where(zero, 1.0, vn))
    return [np.where(zero, theta, scale * x), scale * y, scale * z]


# ---------------------------------------------------------------------------
# One quaternion in Python floats, rounded exactly as the array functions round it.
#
# A sensor sampled at every tick would pay numpy's per-call overhead dozens of times for four
# numbers. These run the array functions' operations in the same order on Python floats (+ - * /
# and sqrt are correctly rounded either way) and call numpy's ufuncs for atan2, hypot, sin and cos
# (numpy's kernels need not agree with the math module's to the last bit), so a sample formed
# through them is bit-identical to one formed by the array functions, and to a batch of runs
# (tests/attitude/test_quaternion.py checks each against its array function). No checks: the
# callers pass finite floats (attitude.validation.finite_floats).
# ---------------------------------------------------------------------------


def _norm_floats(v: list[float]) -> float:
    """:func:`_norm` of one 3- or 4-vector of Python floats, rounded as it (scaled by the largest magnitude)."""
    if len(v) == 4:
        a, b, c, d = v
        scale = max(abs(a), abs(b), abs(c), abs(d))
        if scale > 0:  # (the array function divides by 1.0 otherwise: exact)
            a, b, c, d = a / scale, b / scale, c / scale, d / scale
        return scale * math.sqrt(a * a + b * b + c * c + d * d)
    a, b, c = v
    scale = max(abs(a), abs(b), abs(c))
    if scale > 0:
        a, b, c = a / scale, b / scale, c / scale
    return scale * math.sqrt(a * a + b * b + c * c)


def unit_floats(q: list[float], tolerance: float = UNIT_NORM_TOLERANCE) -> list[float] | None:
    """:func:`as_unit_quaternion` of one quaternion of finite Python floats, bit for bit; None if not unit.

    Parameters
    ----------
    q : list of 4 float
        Finite components ``[w, x, y, z]``.
    tolerance : float
        Accepted deviation of ``|q|`` from 1.

    Returns
    -------
    list of 4 float or None
        ``q / |q|``; None when ``| |q| - 1 | > tolerance`` (the caller lets
        :func:`as_unit_quaternion` raise its error).
    """
    n = _norm_floats(q)
    if abs(n - 1.0) > tolerance:
        return None
    return [c / n for c in q]


def rotation_vector_floats(q: list[float]) -> list[float] | None:
    """:func:`to_rotation_vector` of one quaternion of finite Python floats [rad], bit for bit; None if not unit.

    Parameters
    ----------
    q : list of 4 float
        Components ``[w, x, y, z]`` of a unit quaternion (normalised here, as
        :func:`to_rotation_vector` does).

    Returns
    -------
    list of 3 float or None
        The rotation vector on the shortest way [rad]; None when ``q`` is
        not unit within :data:`UNIT_NORM_TOLERANCE`.
    """
    unit = unit_floats(q)
    if unit is None:
        return None
    w, x, y, z = unit if unit[0] >= 0 else [-c for c in unit]
    vn = float(np.hypot(np.hypot(x, y), z))
    theta = float(np.arctan2(vn, w))
    if vn == 0:
        return [2.0 * theta, 2.0 * (0.0 * y), 2.0 * (0.0 * z)]
    scale = theta / vn
    return [2.0 * (scale * x), 2.0 * (scale * y), 2.0 * (scale * z)]


def from_rotation_vector_floats(rotvec: list[float]) -> list[float]:
    """:func:`from_rotation_vector` of one rotation vector of finite Python floats [rad], bit for bit.

    Parameters
    ----------
    rotvec : list of 3 float
        Rotation vector ``angle * axis`` [rad].

    Returns
    -------
    list of 4 float
        The unit quaternion ``[w, x, y, z]``.
    """
    v = [0.5 * c for c in rotvec]
    half = _norm_floats(v)
    if half < _EXP_SERIES_HALF_ANGLE:
        sinc = 1.0 - half * half / 6.0
    else:
        sinc = float(np.sin(half)) / half
    s = 0.5 * sinc
    return [float(np.cos(half)), s * (2.0 * v[0]), s * (2.0 * v[1]), s * (2.0 * v[2])]


def _split(x: NDArray[np.float64]) -> list:
    return [x[..., i] for i in range(x.shape[-1])]


def _join(parts: list) -> NDArray[np.float64]:
    return np.stack(np.broadcast_arrays(*parts), axis=-1)


def _norm(x: NDArray[np.float64], keepdims: bool = False) -> NDArray[np.float64]:
    """Euclidean norm over the last axis that neither overflows nor underflows.

    Scaling by the largest magnitude first keeps ``|x|`` exact for entries
    near 1e300 or 1e-300, where ``sqrt(sum x^2)`` returns inf or 0.
    """
    scale = np.max(np.abs(x), axis=-1, keepdims=True)
    y = x / np.where(scale > 0, scale, 1.0)
    # Component by component (not np.linalg.norm, whose summation order
    # differs between 1-D and batched input): a batch is bit-identical to a loop.
    total = y[..., 0] * y[..., 0]
    for i in range(1, x.shape[-1]):
        total = total + y[..., i] * y[..., i]
    out = scale[..., 0] * np.sqrt(total)
    return out[..., None] if keepdims else out


def as_unit_quaternion(q: ArrayLike, name: str = "q", *, tolerance: float = UNIT_NORM_TOLERANCE) -> NDArray[np.float64]:
    """Validate an attitude quaternion and return it normalised.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternion(s) ``[w, x, y, z]``.
    name : str
        Argument name used in error messages.
    tolerance : float
        Accepted deviation of ``|q|`` from 1.

    Returns
    -------
    ndarray, shape (..., 4)
        ``q / |q|`` as a new float64 array.

    Raises
    ------
    ValueError
        If ``q`` has the wrong shape, holds NaN/inf, or its norm differs from 1
        by more than ``tolerance``.
    """
    arr = check_vector(q, name, 4)
    n = _norm(arr)
    bad = np.abs(n - 1.0) > tolerance
    if np.any(bad):
        first = np.asarray(n)[bad].flat[0] if np.ndim(n) else float(n)
        raise ValueError(
            f"{name} must be a unit quaternion (| |q| - 1 | <= {tolerance:g}); found |q| = {first!r}"
            + (" (a zero quaternion is not an attitude)" if first == 0 else "")
        )
    return arr / n[..., None]


def _nonzero_quaternion(q: ArrayLike, name: str) -> NDArray[np.float64]:
    """Check ``q`` is a finite ``(..., 4)`` quaternion of non-zero norm; raise ValueError otherwise."""
    arr = check_vector(q, name, 4)
    n = _norm(arr)
    if np.any(n == 0):
        raise ValueError(f"{name} must be non-zero; found a quaternion with norm 0")
    return arr


def identity(shape: tuple[int, ...] = ()) -> NDArray[np.float64]:
    """Return identity quaternion(s) ``[1, 0, 0, 0]`` with batch ``shape``.

    Parameters
    ----------
    shape : tuple of int
        Batch shape; ``()`` gives a single quaternion.

    Returns
    -------
    ndarray, shape shape + (4,)
        Identity attitude(s), scalar first.
    """
    out = np.zeros((*shape, 4))
    out[..., 0] = 1.0
    return out


def multiply(p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product ``p ⊗ q`` of any (not necessarily unit) quaternions.

    ``q_CN = multiply(q_BN, q_CB)`` composes attitudes: C relative to B,
    then B relative to N.

    Parameters
    ----------
    p, q : array_like, shape (..., 4)
        Left and right factors ``[w, x, y, z]``; batch dimensions broadcast.

    Returns
    -------
    ndarray, shape (..., 4)
        The product ``p ⊗ q``.

    Raises
    ------
    ValueError
        If ``p`` or ``q`` is not of shape ``(..., 4)`` or holds NaN/inf.
    """
    p = check_vector(p, "p", 4)
    q = check_vector(q, "q", 4)
    return _join(multiply_components(_split(p), _split(q)))


def conjugate(q: ArrayLike) -> NDArray[np.float64]:
    """Quaternion conjugate ``[w, -x, -y, -z]`` (the inverse rotation for unit ``q``).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Any quaternion ``[w, x, y, z]``.

    Returns
    -------
    ndarray, shape (..., 4)
        ``q*``; for an attitude ``q_BN`` this is ``q_NB``.

    Raises
    ------
    ValueError
        If ``q`` is not of shape ``(..., 4)`` or holds NaN/inf.
    """
    q = check_vector(q, "q", 4)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def norm(q: ArrayLike) -> NDArray[np.float64]:
    """Euclidean norm ``|q|`` (computed without overflow or underflow).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Any quaternion ``[w, x, y, z]``.

    Returns
    -------
    ndarray, shape (...)
        ``|q|`` (dimensionless).

    Raises
    ------
    ValueError
        If ``q`` is not of shape ``(..., 4)`` or holds NaN/inf.
    """
    return _norm(check_vector(q, "q", 4))


def inverse(q: ArrayLike) -> NDArray[np.float64]:
    """Multiplicative inverse ``q* / |q|^2`` of a non-zero quaternion.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternion ``[w, x, y, z]`` (not required to be unit).

    Returns
    -------
    ndarray, shape (..., 4)
        ``q^-1`` with ``q ⊗ q^-1 = [1, 0, 0, 0]``; equal to :func:`conjugate`
        for a unit quaternion.

    Raises
    ------
    ValueError
        If ``q`` is not of shape ``(..., 4)``, holds NaN/inf, or has zero norm.
    """
    q = _nonzero_quaternion(q, "q")
    n = _norm(q, keepdims=True)
    return conjugate(q) / n / n


def normalize(q: ArrayLike) -> NDArray[np.float64]:
    """Return ``q / |q|`` for any non-zero quaternion.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternion ``[w, x, y, z]``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion (the sign of ``q`` is kept).

    Raises
    ------
    ValueError
        If ``q`` is not of shape ``(..., 4)``, holds NaN/inf, or has zero norm.
    """
    q = _nonzero_quaternion(q, "q")
    return q / _norm(q, keepdims=True)


def rotate(q: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Rotate body vectors into the inertial frame: ``v_N = q ⊗ v_B ⊗ q*``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternion ``q_BN``.
    v : array_like, shape (..., 3)
        Vector(s) in body components (any unit; the result has the same).

    Returns
    -------
    ndarray, shape (..., 3)
        ``v_N``, the same vector(s) in inertial components; batch dimensions
        of ``q`` and ``v`` broadcast.

    Raises
    ------
    ValueError
        If ``q`` is not a unit quaternion of shape ``(..., 4)``, or ``v`` is
        not of shape ``(..., 3)``, or either holds NaN/inf.
    """
    q = as_unit_quaternion(q, "q")
    v = check_vector(v, "v", 3)
    return _join(rotate_components(_split(q), _split(v)))


def rotate_inverse(q: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Express inertial vectors in body components: ``v_B = q* ⊗ v_N ⊗ q``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternion ``q_BN``.
    v : array_like, shape (..., 3)
        Vector(s) in inertial components (any unit; the result has the same).

    Returns
    -------
    ndarray, shape (..., 3)
        ``v_B = C_BN v_N``; batch dimensions of ``q`` and ``v`` broadcast.

    Raises
    ------
    ValueError
        If ``q`` is not a unit quaternion of shape ``(..., 4)``, or ``v`` is
        not of shape ``(..., 3)``, or either holds NaN/inf.
    """
    return rotate(conjugate(as_unit_quaternion(q, "q")), v)


def exp(q: ArrayLike) -> NDArray[np.float64]:
    """Quaternion exponential of a general quaternion ``[s, v]``.

    ``exp([s, v]) = e^s [cos|v|, sin|v| v/|v|]``. For a pure quaternion
    ``[0, phi/2]`` this is the unit quaternion of the rotation vector ``phi``
    (see :func:`from_rotation_vector`).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Any quaternion ``[s, v]``; ``|v|`` is an angle [rad].

    Returns
    -------
    ndarray, shape (..., 4)
        ``exp(q)``, of norm ``e^s``.

    Raises
    ------
    ValueError
        If ``q`` is not of shape ``(..., 4)``, holds NaN/inf, or has a scalar
        part above 709 (``e^s`` would overflow).
    """
    q = check_vector(q, "q", 4)
    s = q[..., 0]
    v = q[..., 1:]
    if np.any(s > _EXP_MAX):
        raise ValueError(f"q scalar part must be at most {_EXP_MAX} (e^s overflows beyond); got {np.max(s)!r}")
    # exp([0, v]) is the unit quaternion of the rotation vector 2 v; |v| from the scale-safe norm.
    out = _join(exp_rotation_vector_components(_split(2.0 * v), half_angle=_norm(v)))
    return np.exp(s)[..., None] * out


def log(q: ArrayLike) -> NDArray[np.float64]:
    """Quaternion logarithm of a non-zero quaternion: ``[ln|q|, theta * v/|v|]``.

    ``theta = atan2(|v|, w)`` lies in ``[0, pi]``, so ``exp(log(q)) == q``. For a
    unit quaternion the result is the pure quaternion ``[0, phi/2]`` with
    ``phi`` the rotation vector taken the way ``q`` (not ``-q``) points.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Non-zero quaternion ``[w, x, y, z]`` (not required to be unit).

    Returns
    -------
    ndarray, shape (..., 4)
        ``[ln|q|, theta v/|v|]``; the vector part has length ``theta`` [rad],
        half the rotation angle. For ``v = 0`` and ``w < 0`` the axis is x.

    Raises
    ------
    ValueError
        If ``q`` is not of shape ``(..., 4)``, holds NaN/inf, or has zero norm.
    """
    q = _nonzero_quaternion(q, "q")
    vec = _join(log_vector_components(_split(q)))
    return np.concatenate([np.log(_norm(q))[..., None], vec], axis=-1)


def shortest(q: ArrayLike) -> NDArray[np.float64]:
    """Return ``q`` or ``-q``, whichever has a non-negative scalar part.

    Both represent the same attitude; the one with ``w >= 0`` rotates by at
    most pi.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Any quaternion ``[w, x, y, z]``.

    Returns
    -------
    ndarray, shape (..., 4)
        ``-q`` where ``w < 0``, else ``q`` (new array).

    Raises
    ------
    ValueError
        If ``q`` is not of shape ``(..., 4)`` or holds NaN/inf.
    """
    q = check_vector(q, "q", 4)
    return np.where(q[..., :1] < 0, -q, q)


def error_quaternion(q_ref: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Attitude error ``q_err = q_ref* ⊗ q`` on the shortest way (``w_err >= 0``).

    ``q_err`` is the attitude of the body relative to the reference frame; its
    vector part is about half the rotation-vector error for small errors.

    Parameters
    ----------
    q_ref : array_like, shape (..., 4)
        Unit reference attitude ``q_RN``.
    q : array_like, shape (..., 4)
        Unit attitude ``q_BN``; batch dimensions broadcast with ``q_ref``.

    Returns
    -------
    ndarray, shape (..., 4)
        ``q_BR`` with scalar part ``w_err >= 0``.

    Raises
    ------
    ValueError
        If either quaternion is not unit, not of shape ``(..., 4)``, or holds
        NaN/inf.
    """
    q_ref = as_unit_quaternion(q_ref, "q_ref")
    q = as_unit_quaternion(q, "q")
    return shortest(multiply(conjugate(q_ref), q))


def error_angle(q_ref: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Rotation angle [rad] from ``q_ref`` to ``q`` on the shortest way, in ``[0, pi]``.

    Equal to ``2 * arccos(|w_err|)`` but computed as
    ``2 * atan2(|v_err|, |w_err|)``, which keeps full precision for tiny errors.

    Parameters
    ----------
    q_ref : array_like, shape (..., 4)
        Unit reference attitude ``q_RN``.
    q : array_like, shape (..., 4)
        Unit attitude ``q_BN``; batch dimensions broadcast with ``q_ref``.

    Returns
    -------
    ndarray, shape (...)
        Error angle [rad] in ``[0, pi]``.

    Raises
    ------
    ValueError
        If either quaternion is not unit, not of shape ``(..., 4)``, or holds
        NaN/inf.
    """
    q_ref = as_unit_quaternion(q_ref, "q_ref")
    q = as_unit_quaternion(q, "q")
    angle = error_angle_components(_split(q_ref), _split(q))
    return np.broadcast_to(angle, np.broadcast_shapes(q_ref.shape[:-1], q.shape[:-1])).copy()


def error_angle_components(q_ref: list, q: list) -> Any:
    """Error angle ``2 atan2(|v_err|, |w_err|)`` [rad] of ``q_err = q_ref* ⊗ q`` on components (any backend).

    The one definition behind :func:`error_angle` and the compiled Monte
    Carlo kernels (unit quaternions: the plain square root cannot overflow).

    Parameters
    ----------
    q_ref : list
        Components ``[w, x, y, z]`` of the reference quaternion (numbers, casadi or numpy expressions).
    q : list
        Components ``[w, x, y, z]`` of the attitude quaternion, same backend.
    """
    e = multiply_components(conjugate_components(q_ref), q)
    return 2.0 * bk.atan2(bk.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]), bk.fabs(e[0]))


def slerp(q0: ArrayLike, q1: ArrayLike, fraction: ArrayLike) -> NDArray[np.float64]:
    """Spherical linear interpolation on the shortest way.

    Parameters
    ----------
    q0, q1 : array_like, shape (..., 4)
        Unit quaternions at ``fraction = 0`` and ``fraction = 1``.
    fraction : array_like, shape (...)
        Interpolation parameter (0 gives ``q0``, 1 gives ``q1`` or ``-q1``);
        broadcast against the batch of ``q0`` and ``q1``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion(s) a fraction of the way along the shortest rotation
        from ``q0`` to ``q1`` (constant angular rate in ``fraction``).

    Raises
    ------
    ValueError
        If ``q0`` or ``q1`` is not a unit quaternion of shape ``(..., 4)``,
        or an input holds NaN/inf.
    """
    q0 = as_unit_quaternion(q0, "q0")
    q1 = as_unit_quaternion(q1, "q1")
    s = as_float_array(fraction, "fraction")
    delta = shortest(multiply(conjugate(q0), q1))
    return multiply(q0, exp(s[..., None] * log(delta)))


def derivative(q: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
    """Quaternion kinematics ``q_dot = 0.5 * q ⊗ [0, omega]`` [1/s].

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Attitude ``q_BN`` (not required to be exactly unit).
    omega : array_like, shape (..., 3)
        Angular velocity of B relative to N in B components [rad/s].

    Returns
    -------
    ndarray, shape (..., 4)
        ``q_dot`` [1/s]; batch dimensions of ``q`` and ``omega`` broadcast.

    Raises
    ------
    ValueError
        If ``q`` is not ``(..., 4)``, ``omega`` not ``(..., 3)``, or either
        holds NaN/inf.
    """
    q = check_vector(q, "q", 4)
    omega = check_vector(omega, "omega", 3)
    return _join(derivative_components(_split(q), _split(omega)))


def to_dcm(q: ArrayLike) -> NDArray[np.float64]:
    """Direction cosine matrix ``C_BN`` of attitude ``q_BN``, shape ``(..., 3, 3)``.

    ``C_BN @ v_N`` gives body components of an inertial vector; its transpose
    rotates body vectors into N (it is scipy's ``Rotation.as_matrix()``).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternion ``q_BN``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``C_BN`` (orthonormal, ``det = +1``).

    Raises
    ------
    ValueError
        If ``q`` is not a unit quaternion of shape ``(..., 4)`` or holds NaN/inf.
    """
    q = as_unit_quaternion(q, "q")
    w, x, y, z = np.moveaxis(q, -1, 0)
    c_nb = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )
    return np.swapaxes(c_nb, -1, -2)


#: Largest accepted ``|C C^T - 1|`` entry for a direction cosine matrix.
DCM_ORTHONORMAL_TOLERANCE = 1e-6


def from_dcm(dcm: ArrayLike) -> NDArray[np.float64]:
    """Attitude ``q_BN`` (scalar part >= 0) of a direction cosine matrix ``C_BN``.

    Uses Shepperd's method (largest of the four squared components) so that no
    attitude loses precision.

    Parameters
    ----------
    dcm : array_like, shape (..., 3, 3)
        Direction cosine matrix ``C_BN`` (maps N components to B components).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion ``q_BN`` with scalar part ``>= 0``.

    Raises
    ------
    ValueError
        If ``dcm`` is not ``(..., 3, 3)``, not orthonormal to
        :data:`DCM_ORTHONORMAL_TOLERANCE`, or a reflection (``det < 0``).
    """
    c_bn = as_float_array(dcm, "dcm")
    if c_bn.ndim < 2 or c_bn.shape[-2:] != (3, 3):
        raise ValueError(f"dcm must have shape (..., 3, 3), got shape {c_bn.shape}")
    gram_error = np.abs(c_bn @ np.swapaxes(c_bn, -1, -2) - np.eye(3)).max(axis=(-1, -2))
    if np.any(gram_error > DCM_ORTHONORMAL_TOLERANCE):
        raise ValueError(
            f"dcm must be orthonormal (|C C^T - I| <= {DCM_ORTHONORMAL_TOLERANCE:g}); "
            f"found a deviation of {np.max(gram_error):.3g}"
        )
    if np.any(np.linalg.det(c_bn) < 0):
        raise ValueError("dcm must be a proper rotation (det = +1); found a reflection (det = -1)")
    m = np.swapaxes(c_bn, -1, -2)  # C_NB, the matrix that rotates body vectors
    trace = m[..., 0, 0] + m[..., 1, 1] + m[..., 2, 2]
    diag = np.stack([trace, m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]], axis=-1)
    choice = np.argmax(diag, axis=-1)
    cand = np.empty((*m.shape[:-2], 4, 4))
    # Row k: the quaternion computed with component k as the pivot (times 4 q_k).
    cand[..., 0, :] = np.stack(
        [1 + trace, m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], axis=-1
    )
    cand[..., 1, :] = np.stack(
        [
            m[..., 2, 1] - m[..., 1, 2],
            1 + 2 * m[..., 0, 0] - trace,
            m[..., 0, 1] + m[..., 1, 0],
            m[..., 0, 2] + m[..., 2, 0],
        ],
        axis=-1,
    )
    cand[..., 2, :] = np.stack(
        [
            m[..., 0, 2] - m[..., 2, 0],
            m[..., 0, 1] + m[..., 1, 0],
            1 + 2 * m[..., 1, 1] - trace,
            m[..., 1, 2] + m[..., 2, 1],
        ],
        axis=-1,
    )
    cand[..., 3, :] = np.stack(
        [
            m[..., 1, 0] - m[..., 0, 1],
            m[..., 0, 2] + m[..., 2, 0],
            m[..., 1, 2] + m[..., 2, 1],
            1 + 2 * m[..., 2, 2] - trace,
        ],
        axis=-1,
    )
    q = np.take_along_axis(cand, choice[..., None, None], axis=-2)[..., 0, :]
    return shortest(q / _norm(q, keepdims=True))


def unit_vector_angle(u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Angle [rad] in ``[0, pi]`` between unit vectors ``u`` (..., 3) and one unit vector ``v`` (3,).

    ``arccos(clip(u . v, -1, 1))``, e.g. the separation of a boresight (rotated
    into the frame of ``v``) from an avoided direction. No checks (both are
    taken as unit vectors).

    Parameters
    ----------
    u : array_like (..., 3)
        Unit vectors.
    v : array_like (3,)
        One unit vector, in the same frame as ``u``.

    Returns
    -------
    ndarray (...)
        The angles [rad].
    """
    return np.arccos(np.clip(np.asarray(u) @ np.asarray(v), -1.0, 1.0))


def to_rotation_vector(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector ``phi`` [rad] of ``q`` on the shortest way (``|phi| <= pi``).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternion ``q_BN``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``phi = angle * axis`` [rad] of ``q`` or ``-q`` (whichever has
        ``w >= 0``), so ``|phi| <= pi``.

    Raises
    ------
    ValueError
        If ``q`` is not a unit quaternion of shape ``(..., 4)`` or holds NaN/inf.
    """
    q = shortest(as_unit_quaternion(q, "q"))
    return 2.0 * _join(log_vector_components(_split(q)))


def from_rotation_vector(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion of the rotation vector ``rotvec`` [rad]: ``exp([0, rotvec/2])``.

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vector ``angle * axis`` [rad]; any length (no wrapping).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion ``[cos(|rotvec|/2), sin(|rotvec|/2) rotvec/|rotvec|]``;
        its scalar part is negative for ``|rotvec| > pi``.

    Raises
    ------
    ValueError
        If ``rotvec`` is not of shape ``(..., 3)`` or holds NaN/inf.
    """
    rotvec = check_vector(rotvec, "rotvec", 3)
    pure = np.concatenate([np.zeros((*rotvec.shape[:-1], 1)), 0.5 * rotvec], axis=-1)
    return exp(pure)


def to_axis_angle(q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit axis and angle [rad] of ``q`` on the shortest way, angle in ``[0, pi]``.

    For a zero rotation the axis is undefined; ``[1, 0, 0]`` is returned.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternion ``q_BN``.

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit rotation axis (the same in B and N components).
    angle : ndarray, shape (...)
        Rotation angle [rad] in ``[0, pi]``.

    Raises
    ------
    ValueError
        If ``q`` is not a unit quaternion of shape ``(..., 4)`` or holds NaN/inf.
    """
    q = shortest(as_unit_quaternion(q, "q"))
    v = q[..., 1:]
    # The axis from the vector part scaled to O(1) first: a subnormal |v| has
    # few digits, so dividing by it (or by the rotation vector's norm) loses them.
    vn = _norm(v)
    angle = 2.0 * np.arctan2(vn, q[..., 0])
    big = np.max(np.abs(v), axis=-1, keepdims=True)
    y = v / np.where(big > 0, big, 1.0)
    yn = _norm(y, keepdims=True)
    axis = np.where(vn[..., None] > 0, y / np.where(yn > 0, yn, 1.0), np.array([1.0, 0.0, 0.0]))
    return axis, angle


def from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion rotating by ``angle`` [rad] about ``axis`` (normalised here).

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Rotation axis of any non-zero length.
    angle : array_like, shape (...)
        Rotation angle [rad] (right-handed about ``axis``); broadcast against
        the batch of ``axis``.

    Returns
    -------
    ndarray, shape (..., 4)
        ``[cos(angle/2), sin(angle/2) axis/|axis|]``.

    Raises
    ------
    ValueError
        If ``axis`` has zero length or is not of shape ``(..., 3)``, or an
        input holds NaN/inf.
    """
    axis = check_vector(axis, "axis", 3)
    angle = as_float_array(angle, "angle")
    n = _norm(axis)
    if np.any(n == 0):
        raise ValueError("axis must be a non-zero vector; found a zero-length axis")
    half = 0.5 * angle
    return np.concatenate(
        [
            np.broadcast_to(np.cos(half), np.broadcast_shapes(half.shape, n.shape))[..., None],
            (np.sin(half) / n)[..., None] * axis,
        ],
        axis=-1,
    )


def to_mrp(q: ArrayLike) -> NDArray[np.float64]:
    """Modified Rodrigues parameters ``sigma = v / (1 + w)`` with ``|sigma| <= 1``.

    The shadow set is chosen automatically: using ``q`` or ``-q`` with
    ``w >= 0`` gives the MRP of the short rotation (``|sigma| <= 1``).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit attitude quaternion ``q_BN``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``sigma = axis tan(angle/4)`` (dimensionless), ``|sigma| <= 1``.

    Raises
    ------
    ValueError
        If ``q`` is not a unit quaternion of shape ``(..., 4)`` or holds NaN/inf.
    """
    q = shortest(as_unit_quaternion(q, "q"))
    return q[..., 1:] / (1.0 + q[..., :1])


def mrp_shadow(sigma: ArrayLike) -> NDArray[np.float64]:
    """Shadow MRP set ``-sigma / |sigma|^2`` (the same attitude).

    Parameters
    ----------
    sigma : array_like, shape (..., 3)
        Modified Rodrigues parameters (dimensionless), non-zero.

    Returns
    -------
    ndarray, shape (..., 3)
        The shadow set; ``|shadow| = 1 / |sigma|``.

    Raises
    ------
    ValueError
        If ``sigma`` is zero (its shadow is at infinity), not of shape
        ``(..., 3)``, or holds NaN/inf.
    """
    sigma = check_vector(sigma, "sigma", 3)
    n = _norm(sigma, keepdims=True)
    if np.any(n == 0):
        raise ValueError("sigma must be non-zero for its shadow set (the shadow of 0 is at infinity)")
    return -sigma / n / n


def from_mrp(sigma: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion (``w >= 0``) of modified Rodrigues parameters ``sigma``.

    A set with ``|sigma| > 1`` is first replaced by its shadow (the same
    attitude), which keeps ``|sigma|^2`` from overflowing for huge inputs.

    Parameters
    ----------
    sigma : array_like, shape (..., 3)
        Modified Rodrigues parameters (dimensionless), any length.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion ``q_BN`` with scalar part ``>= 0``.

    Raises
    ------
    ValueError
        If ``sigma`` is not of shape ``(..., 3)`` or holds NaN/inf.
    """
    sigma = check_vector(sigma, "sigma", 3)
    n = _norm(sigma, keepdims=True)
    big = n > 1.0
    n_big = np.where(big, n, 1.0)
    sigma = np.where(big, -sigma / n_big / n_big, sigma)
    s2 = np.sum(sigma * sigma, axis=-1, keepdims=True)
    q = np.concatenate([1.0 - s2, 2.0 * sigma], axis=-1) / (1.0 + s2)
    return shortest(q)


def random(shape: int | tuple[int, ...] = (), rng: object = None) -> NDArray[np.float64]:
    """Unit quaternions uniformly distributed on SO(3).

    Normalised 4-D Gaussian samples are uniform on the 3-sphere, which is the
    Haar measure on SO(3).

    Parameters
    ----------
    shape : int or tuple of int
        Batch shape.
    rng : numpy.random.Generator, int or None
        Random source or seed (see :func:`attitude.rng.as_generator`).

    Returns
    -------
    ndarray, shape shape + (4,)
        Unit quaternions (either sign of the scalar part).

    Raises
    ------
    ValueError
        If ``rng`` is not a generator, seed sequence, non-negative int or None.
    """
    gen = as_generator(rng)
    shape = (shape,) if isinstance(shape, int) else tuple(shape)
    g = gen.standard_normal((*shape, 4))
    return g / _norm(g, keepdims=True)

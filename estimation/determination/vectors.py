"""Vector observations for static attitude determination: checks, Wahba's matrices, observability.

A set of ``m`` observations is ``m`` unit vectors measured in the body frame,
``vectors_B`` (sun, field, star directions), the same directions known in the
inertial frame, ``vectors_N``, and positive weights ``a_i`` (or measurement
standard deviations ``sigma_i`` [rad], with ``a_i = 1 / sigma_i**2``: the
QUEST measurement model of Shuster and Oh, 1981). Wahba's loss is
``L(C_BN) = 0.5 * sum_i a_i |b_i - C_BN r_i|^2`` (Markley and Crassidis,
*Fundamentals of Spacecraft Attitude Determination and Control*, 2014, ch. 5,
Wahba's problem); its maximiser solves it through the attitude profile matrix
``B = sum_i a_i b_i r_i^T`` and Davenport's matrix ``K`` (the q method).

Every function takes leading batch dimensions, ``(..., m, 3)`` vectors and
``(..., m)`` weights, broadcast against each other. See
docs/attitude_determination.md for the algorithms and conventions.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.validation import as_float_array, check_positive, check_vector, describe

__all__ = [
    "OBSERVABILITY_MIN",
    "VectorPairs",
    "attitude_profile_matrix",
    "check_observable",
    "check_vector_pairs",
    "davenport_matrix",
    "det3",
    "information_matrix",
    "observability",
    "unit_vectors",
]

#: Smallest accepted observability ``rho`` (see :func:`observability`). Below it
#: the vectors are parallel to within about ``2 sqrt(rho)`` rad (2e-6 rad for
#: two equally weighted vectors) and the rotation about them is not determined.
OBSERVABILITY_MIN = 1e-12


class VectorPairs(NamedTuple):
    """Checked observations, broadcast to one batch shape (fields in order).

    Parameters
    ----------
    vectors_B : ndarray, shape (..., m, 3)
        Measured directions in the body frame, unit norm.
    vectors_N : ndarray, shape (..., m, 3)
        The same directions in the inertial frame, unit norm.
    weights : ndarray, shape (..., m)
        Positive weights ``a_i`` (``1 / sigma_i**2`` when ``sigma`` was given) [1/rad^2].
    sigma : ndarray, shape (..., m), or None
        Measurement standard deviations [rad], when given.
    """

    vectors_B: NDArray[np.float64]
    vectors_N: NDArray[np.float64]
    weights: NDArray[np.float64]
    sigma: NDArray[np.float64] | None


def unit_vectors(vectors: ArrayLike, name: str) -> NDArray[np.float64]:
    """Normalise directions ``(..., 3)`` to unit length, refusing zero vectors.

    Measured directions need not be unit vectors (a magnetometer gives the
    field in tesla); only their direction is used.

    Parameters
    ----------
    vectors : array_like, shape (..., 3)
        Non-zero, finite vectors.
    name : str
        Argument name used in error messages.

    Returns
    -------
    ndarray, shape (..., 3)
        The unit vectors (a new array).

    Raises
    ------
    ValueError
        If ``vectors`` is not ``(..., 3)``, holds NaN/inf, or holds a zero
        vector (or one too small to normalise in float64).
    """
    arr = check_vector(vectors, name, 3)
    norm = np.linalg.norm(arr, axis=-1, keepdims=True)
    if np.any(norm == 0.0):
        where = tuple(int(i) for i in np.argwhere(norm[..., 0] == 0.0)[0])
        raise ValueError(
            f"{name} must be non-zero directions; the vector at index {where} is {describe(arr[where])} (norm 0)"
        )
    return arr / norm


def check_vector_pairs(
    vectors_B: ArrayLike,
    vectors_N: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    sigma: ArrayLike | None = None,
    minimum: int = 2,
) -> VectorPairs:
    """Check, normalise and broadcast body and inertial vectors and their weights.

    Parameters
    ----------
    vectors_B : array_like, shape (..., m, 3)
        Measured directions in the body frame (normalised here).
    vectors_N : array_like, shape (..., m, 3)
        The same directions in the inertial frame (normalised here); broadcast
        against ``vectors_B`` (e.g. one ``(m, 3)`` catalogue for a batch).
    weights : array_like, shape (..., m), optional
        Positive weights ``a_i``; any common scale gives the same attitude.
        Exclusive with ``sigma``; equal weights when both are omitted.
    sigma : array_like, shape (..., m), optional
        Measurement standard deviations [rad] (> 0); the weights are then
        ``1 / sigma**2`` and the covariance can be computed.
    minimum : int
        Fewest vector pairs accepted.

    Returns
    -------
    VectorPairs
        Unit vectors, weights and ``sigma`` broadcast to one shape.

    Raises
    ------
    ValueError
        If a vector array is not ``(..., m, 3)`` with ``m >= minimum``, holds
        NaN/inf or a zero vector; if the shapes do not broadcast; if both
        ``weights`` and ``sigma`` are given; if a weight or ``sigma`` is not
        finite and strictly positive.
    """
    b = unit_vectors(vectors_B, "vectors_B")
    r = unit_vectors(vectors_N, "vectors_N")
    for name, arr in (("vectors_B", b), ("vectors_N", r)):
        if arr.ndim < 2 or arr.shape[-2] < minimum:
            raise ValueError(
                f"{name} must have shape (..., m, 3) with at least {minimum} vectors (m >= {minimum}), "
                f"got shape {arr.shape}"
            )
    try:
        shape = np.broadcast_shapes(b.shape, r.shape)
    except ValueError:
        raise ValueError(
            f"vectors_B and vectors_N must have broadcastable shapes (..., m, 3), got {b.shape} and {r.shape}"
        ) from None
    if weights is not None and sigma is not None:
        raise ValueError("give weights or sigma, not both (the weights are 1 / sigma**2)")
    sigma_arr = None
    if sigma is not None:
        sigma_arr = _per_vector(check_positive(sigma, "sigma"), "sigma", shape)
        a = sigma_arr**-2.0
        if not np.all(np.isfinite(a)):
            raise ValueError(f"sigma must be large enough that 1 / sigma**2 is finite, got {describe(sigma_arr)}")
    elif weights is not None:
        a = _per_vector(check_positive(weights, "weights"), "weights", shape)
    else:
        a = np.ones(shape[:-1])
    shape = np.broadcast_shapes(shape, (*a.shape, 3))
    b, r = np.broadcast_to(b, shape), np.broadcast_to(r, shape)
    a = np.broadcast_to(a, shape[:-1])
    if sigma_arr is not None:
        sigma_arr = np.broadcast_to(sigma_arr, shape[:-1])
    return VectorPairs(b, r, a, sigma_arr)


def _per_vector(values: NDArray[np.float64], name: str, shape: tuple[int, ...]) -> NDArray[np.float64]:
    """``values`` (..., m) that broadcast against the vectors ``shape`` (..., m, 3)."""
    try:
        np.broadcast_shapes((*values.shape, 3), shape)
    except ValueError:
        raise ValueError(
            f"{name} must have one entry per vector pair, shape (..., {shape[-2]}) broadcastable to "
            f"{shape[:-1]}; got shape {values.shape}"
        ) from None
    if values.ndim == 0:
        return np.broadcast_to(values, shape[-2:-1])
    return values


def attitude_profile_matrix(vectors_B: ArrayLike, vectors_N: ArrayLike, weights: ArrayLike) -> NDArray[np.float64]:
    """Attitude profile matrix ``B = sum_i a_i b_i r_i^T``, shape ``(..., 3, 3)``.

    Wahba's gain is ``g(C_BN) = trace(C_BN B^T)`` and the loss
    ``L = sum_i a_i - g`` (Markley and Crassidis, 2014, ch. 5).

    Parameters
    ----------
    vectors_B : array_like, shape (..., m, 3)
        Unit body-frame vectors ``b_i``.
    vectors_N : array_like, shape (..., m, 3)
        Unit inertial vectors ``r_i``.
    weights : array_like, shape (..., m)
        Weights ``a_i``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``B``.
    """
    b = as_float_array(vectors_B, "vectors_B")
    r = as_float_array(vectors_N, "vectors_N")
    a = as_float_array(weights, "weights")
    return np.einsum("...i,...ij,...ik->...jk", a, b, r)


def davenport_matrix(profile: ArrayLike) -> NDArray[np.float64]:
    """Davenport's symmetric matrix ``K`` (..., 4, 4) for scalar-first quaternions ``q_BN``.

    ``q^T K q`` is Wahba's gain ``trace(C_BN(q) B^T)``, so the attitude is the
    eigenvector of the largest eigenvalue (Davenport's q method; Markley and
    Crassidis, 2014, ch. 5). With ``S = B + B^T``, ``sigma = trace(B)`` and
    ``z = [B23 - B32, B31 - B13, B12 - B21]``, ``K = [[sigma, z^T], [z,
    S - sigma I]]``: the textbook's matrix with the scalar moved first (its
    quaternion, vector part first, is this module's ``q_BN`` reordered).

    Parameters
    ----------
    profile : array_like, shape (..., 3, 3)
        Attitude profile matrix ``B`` (:func:`attitude_profile_matrix`).

    Returns
    -------
    ndarray, shape (..., 4, 4)
        ``K``.
    """
    bm = as_float_array(profile, "profile")
    trace = np.trace(bm, axis1=-2, axis2=-1)
    z = np.stack([bm[..., 1, 2] - bm[..., 2, 1], bm[..., 2, 0] - bm[..., 0, 2], bm[..., 0, 1] - bm[..., 1, 0]], axis=-1)
    k = np.empty((*bm.shape[:-2], 4, 4))
    k[..., 0, 0] = trace
    k[..., 0, 1:] = z
    k[..., 1:, 0] = z
    k[..., 1:, 1:] = bm + np.swapaxes(bm, -1, -2) - trace[..., None, None] * np.eye(3)
    return k


def observability(vectors_B: ArrayLike, weights: ArrayLike) -> NDArray[np.float64]:
    """Observability ``rho`` (...,) in ``[0, 2/9]`` of a set of weighted directions.

    With the information matrix ``F = sum_i a_i (I - b_i b_i^T)``
    (:func:`information_matrix`), ``rho = det(F) / (kappa(F) sum_i a_i)``,
    ``kappa`` the sum of its principal 2x2 minors: between a third of and
    the smallest eigenvalue of ``F / sum_i a_i`` (closed form, cheaper than
    an eigenvalue solver). It is 0 when all directions are parallel (the
    rotation about them is unobserved), ``(1 - c^2) / (5 - c^2)`` for two
    equally weighted directions with ``c`` the cosine of their angle
    (``theta^2 / 4`` for a small angle ``theta``), and 2/9 for an isotropic
    set (a third of its smallest eigenvalue, 2/3). For exact vectors the gap
    between the two largest eigenvalues of Davenport's matrix, relative to
    the largest, is twice that eigenvalue: between ``2 rho`` and ``6 rho``.

    Parameters
    ----------
    vectors_B : array_like, shape (..., m, 3)
        Unit directions.
    weights : array_like, shape (..., m)
        Positive weights.

    Returns
    -------
    ndarray, shape (...)
        ``rho``.
    """
    a = as_float_array(weights, "weights")
    info = information_matrix(vectors_B, a)
    minors = (
        info[..., 0, 0] * info[..., 1, 1]
        - info[..., 0, 1] ** 2
        + info[..., 0, 0] * info[..., 2, 2]
        - info[..., 0, 2] ** 2
        + info[..., 1, 1] * info[..., 2, 2]
        - info[..., 1, 2] ** 2
    )
    return np.maximum(det3(info), 0.0) / (minors * a.sum(axis=-1))


def det3(matrix: ArrayLike) -> NDArray[np.float64]:
    """Determinants (...,) of 3x3 matrices (..., 3, 3), by the cofactor expansion (no LAPACK call per matrix).

    Parameters
    ----------
    matrix : array_like, shape (..., 3, 3)
        The matrices.

    Returns
    -------
    ndarray, shape (...)
        Their determinants.
    """
    m = as_float_array(matrix, "matrix")
    return (
        m[..., 0, 0] * (m[..., 1, 1] * m[..., 2, 2] - m[..., 1, 2] * m[..., 2, 1])
        - m[..., 0, 1] * (m[..., 1, 0] * m[..., 2, 2] - m[..., 1, 2] * m[..., 2, 0])
        + m[..., 0, 2] * (m[..., 1, 0] * m[..., 2, 1] - m[..., 1, 1] * m[..., 2, 0])
    )


def information_matrix(vectors_B: ArrayLike, weights: ArrayLike) -> NDArray[np.float64]:
    """``sum_i a_i (I - b_i b_i^T)`` (..., 3, 3): the attitude information of weighted directions.

    With ``a_i = 1 / sigma_i**2`` it is the Fisher information of the QUEST
    measurement model, the inverse of the attitude-error covariance
    (:func:`estimation.determination.covariance.wahba_covariance`).

    Parameters
    ----------
    vectors_B : array_like, shape (..., m, 3)
        Unit directions.
    weights : array_like, shape (..., m)
        Weights ``a_i``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        The information matrix (symmetric, positive semi-definite).
    """
    b = as_float_array(vectors_B, "vectors_B")
    a = as_float_array(weights, "weights")
    return a.sum(axis=-1)[..., None, None] * np.eye(3) - np.einsum("...i,...ij,...ik->...jk", a, b, b)


def check_observable(pairs: VectorPairs) -> NDArray[np.float64]:
    """Refuse sets whose directions are all (nearly) parallel; return their observability.

    Parameters
    ----------
    pairs : VectorPairs
        Checked observations (:func:`check_vector_pairs`).

    Returns
    -------
    ndarray, shape (...)
        :func:`observability` of each set.

    Raises
    ------
    ValueError
        If a set's observability is below :data:`OBSERVABILITY_MIN` (in the
        body or the inertial frame).
    """
    rho = observability(pairs.vectors_B, pairs.weights)
    rho_n = observability(pairs.vectors_N, pairs.weights)
    for name, value in (("vectors_B", rho), ("vectors_N", rho_n)):
        bad = ~(value >= OBSERVABILITY_MIN)
        if np.any(bad):
            where = tuple(int(i) for i in np.argwhere(bad)[0]) if value.ndim else ()
            raise ValueError(
                f"{name} must hold at least two non-parallel directions with positive weight "
                f"(observability >= {OBSERVABILITY_MIN:g}); the set at batch index {where} has "
                f"observability {float(value[where]):.3g}: the rotation about its common direction is undetermined"
            )
    return rho

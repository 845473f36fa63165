"""Davenport's q method: the optimal attitude as the top eigenvector of Davenport's matrix.

Wahba's gain ``trace(C_BN B^T)`` is the quadratic form ``q^T K q`` of the
quaternion, so its maximum over unit quaternions is the eigenvector of ``K``'s
largest eigenvalue (Davenport; Markley and Crassidis, *Fundamentals of
Spacecraft Attitude Determination and Control*, 2014, ch. 5, Davenport's q
method). Solved here by ``numpy.linalg.eigh`` over the whole batch: the
robust reference the faster QUEST (:mod:`estimation.determination.quest`)
falls back on. The eigenvector's rounding error is about ``1e-16 / rho`` rad
about the worst-observed axis (``rho`` of
:func:`estimation.determination.vectors.observability`).

See docs/attitude_determination.md for the conventions and the covariance.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimation.determination.solution import AttitudeSolution, wahba_solution
from estimation.determination.vectors import (
    VectorPairs,
    attitude_profile_matrix,
    check_observable,
    check_vector_pairs,
    davenport_matrix,
)

__all__ = ["q_method", "q_method_quaternion"]


def q_method(
    vectors_B: ArrayLike,
    vectors_N: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    sigma: ArrayLike | None = None,
) -> AttitudeSolution:
    """Attitude ``q_BN`` minimising Wahba's loss over any number of vector pairs (Davenport's q method).

    Parameters
    ----------
    vectors_B : array_like, shape (..., m, 3)
        Measured directions in the body frame, ``m >= 2`` (normalised here).
    vectors_N : array_like, shape (..., m, 3)
        The same directions in the inertial frame (normalised here);
        broadcast against ``vectors_B``.
    weights : array_like, shape (..., m), optional
        Positive weights ``a_i`` (any common scale). Exclusive with ``sigma``;
        equal weights when both are omitted.
    sigma : array_like, shape (..., m), optional
        Measurement standard deviations [rad] (> 0): weights ``1 / sigma**2``
        and the covariance of the QUEST measurement model.

    Returns
    -------
    AttitudeSolution
        ``q_BN`` (scalar part >= 0), covariance (with ``sigma``), loss, gain.

    Raises
    ------
    ValueError
        If the vectors are not ``(..., m, 3)`` finite non-zero with ``m >= 2``,
        the shapes do not broadcast, weights or ``sigma`` are not positive or
        both are given, or a set's directions are all parallel (observability
        below :data:`estimation.determination.vectors.OBSERVABILITY_MIN`).

    Examples
    --------
    >>> import numpy as np
    >>> sol = q_method([[0, 0, 1], [1, 0, 0]], [[1, 0, 0], [0, 1, 0]])
    >>> np.round(sol.q_BN, 6)
    array([0.5, 0.5, 0.5, 0.5])
    """
    pairs = check_vector_pairs(vectors_B, vectors_N, weights=weights, sigma=sigma)
    check_observable(pairs)
    return wahba_solution(q_method_quaternion(pairs), pairs)


def q_method_quaternion(pairs: VectorPairs) -> NDArray[np.float64]:
    """Top eigenvector (..., 4) of Davenport's matrix for checked observations (no checks).

    Parameters
    ----------
    pairs : VectorPairs
        Checked observations (:func:`estimation.determination.vectors.check_vector_pairs`).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion ``q_BN`` (either sign).
    """
    weights = pairs.weights / pairs.weights.sum(axis=-1, keepdims=True)
    k = davenport_matrix(attitude_profile_matrix(pairs.vectors_B, pairs.vectors_N, weights))
    _, vectors = np.linalg.eigh(k)
    return vectors[..., :, -1]

"""The result of a static attitude determination: attitude, covariance, Wahba's loss."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from attitude import quaternion as quat
from estimation.determination.covariance import wahba_covariance
from estimation.determination.vectors import VectorPairs

__all__ = ["AttitudeSolution", "wahba_loss", "wahba_solution"]


@dataclass(frozen=True)
class AttitudeSolution:
    """Attitude estimated from vector observations (TRIAD, q method, QUEST).

    Attributes
    ----------
    q_BN : ndarray, shape (..., 4)
        Attitude quaternion, scalar first, scalar part >= 0 (rotates body
        vectors into N).
    covariance : ndarray, shape (..., 3, 3), or None
        Covariance [rad^2] of the attitude error ``delta_theta =
        rotvec(q_true* ⊗ q_BN)`` in body axes (the MEKF's attitude error),
        when the measurement standard deviations ``sigma`` were given; None
        with bare weights.
    loss : ndarray, shape (...)
        Wahba's loss ``0.5 * sum_i a_i |b_i - C_BN r_i|^2`` of ``q_BN``. With
        ``a_i = 1 / sigma_i**2`` and Gaussian noise, ``2 * loss`` is
        chi-square with ``2 m - 3`` degrees of freedom: a consistency check of
        the measurements.
    gain : ndarray, shape (...)
        ``sum_i a_i - loss = trace(C_BN B^T)``: for the q method and QUEST the
        largest eigenvalue of Davenport's matrix ``K``.
    """

    q_BN: NDArray[np.float64]
    covariance: NDArray[np.float64] | None
    loss: NDArray[np.float64]
    gain: NDArray[np.float64]


def wahba_loss(q_BN: NDArray[np.float64], pairs: VectorPairs) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Wahba's loss and gain of attitudes ``q_BN`` (..., 4) for checked observations.

    The loss is summed from the residuals (no cancellation against
    ``sum_i a_i``), so it is accurate when it is tiny (noise-free vectors).

    Parameters
    ----------
    q_BN : ndarray, shape (..., 4)
        Unit attitude quaternions.
    pairs : VectorPairs
        Checked observations (:func:`estimation.determination.vectors.check_vector_pairs`).

    Returns
    -------
    loss : ndarray, shape (...)
        ``0.5 * sum_i a_i |b_i - C_BN r_i|^2``.
    gain : ndarray, shape (...)
        ``sum_i a_i - loss``.
    """
    predicted = quat.rotate_inverse(q_BN[..., None, :], pairs.vectors_N)
    residual = pairs.vectors_B - predicted
    loss = 0.5 * np.einsum("...i,...ij,...ij->...", pairs.weights, residual, residual)
    return loss, pairs.weights.sum(axis=-1) - loss


def wahba_solution(q_BN: NDArray[np.float64], pairs: VectorPairs) -> AttitudeSolution:
    """The solution of Wahba's problem ``q_BN`` with its loss and, given ``sigma``, its covariance.

    The covariance is :func:`estimation.determination.covariance.wahba_covariance`
    at the estimated directions ``C_BN r_i``.

    Parameters
    ----------
    q_BN : ndarray, shape (..., 4)
        Optimal unit quaternions; returned with the scalar part >= 0.
    pairs : VectorPairs
        The checked observations they solve.

    Returns
    -------
    AttitudeSolution
        Attitude, covariance (None without ``pairs.sigma``), loss and gain.
    """
    q_BN = quat.shortest(q_BN)
    covariance = None
    if pairs.sigma is not None:
        covariance = wahba_covariance(quat.rotate_inverse(q_BN[..., None, :], pairs.vectors_N), pairs.sigma)
    loss, gain = wahba_loss(q_BN, pairs)
    return AttitudeSolution(q_BN=q_BN, covariance=covariance, loss=loss, gain=gain)

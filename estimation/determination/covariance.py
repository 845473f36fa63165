"""Attitude-error covariance of the Wahba optimum (QUEST, q method) and of TRIAD.

Measurement model (Shuster and Oh, "Three-axis attitude determination from
vector observations", J. Guidance and Control 4(1), 1981; the QUEST
measurement model): each measured unit vector is ``b_i = C_BN r_i + v_i``
with ``v_i`` perpendicular to ``C_BN r_i`` and covariance
``sigma_i^2 (I - b_i b_i^T)``. To first order in the ``sigma_i``, the error
``delta_theta = rotvec(q_true* ⊗ q_hat)`` (body axes, the MEKF's attitude
error) has covariance

* for the minimiser of Wahba's loss with ``a_i = 1 / sigma_i^2`` (QUEST,
  q method): ``P = [sum_i sigma_i^-2 (I - b_i b_i^T)]^-1``, the inverse
  Fisher information (Shuster and Oh 1981; Markley and Crassidis,
  *Fundamentals of Spacecraft Attitude Determination and Control*, 2014,
  ch. 5, covariance of the Wahba solution);
* for TRIAD, which trusts the primary vector ``b_1`` entirely (Shuster and
  Oh 1981): ``P = sigma_1^2 I + [(sigma_2^2 - sigma_1^2) b_1 b_1^T +
  sigma_1^2 (b_1 . b_2)(b_1 b_2^T + b_2 b_1^T)] / |b_1 x b_2|^2``.

See docs/attitude_determination.md for the derivation of the TRIAD formula.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.validation import check_positive
from estimation.determination.vectors import OBSERVABILITY_MIN, information_matrix, observability, unit_vectors

__all__ = ["triad_covariance", "wahba_covariance"]


def wahba_covariance(vectors_B: ArrayLike, sigma: ArrayLike) -> NDArray[np.float64]:
    """Covariance [rad^2] (..., 3, 3) of the optimal (QUEST, q method) attitude error in body axes.

    ``P = [sum_i sigma_i^-2 (I - b_i b_i^T)]^-1`` (Shuster and Oh 1981; see the
    module docstring), first order in ``sigma``. Use the estimated directions
    ``C_BN r_i`` (or the measured ones: the difference is of order ``sigma``).

    Parameters
    ----------
    vectors_B : array_like, shape (..., m, 3)
        Body-frame directions (normalised here).
    sigma : array_like, shape (..., m)
        Measurement standard deviations [rad] (> 0).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        The covariance.

    Raises
    ------
    ValueError
        If ``vectors_B`` is not ``(..., m, 3)`` of finite non-zero vectors, if
        ``sigma`` is not positive or does not broadcast, or if the directions
        are all parallel (the information matrix is singular).
    """
    b = unit_vectors(vectors_B, "vectors_B")
    s = check_positive(sigma, "sigma")
    if b.ndim < 2:
        raise ValueError(f"vectors_B must have shape (..., m, 3), got shape {b.shape}")
    try:
        a = np.broadcast_to(s**-2.0, b.shape[:-1])
    except ValueError:
        raise ValueError(
            f"sigma must have one entry per vector, shape broadcastable to {b.shape[:-1]}; got shape {s.shape}"
        ) from None
    rho = observability(b, a)
    bad = ~(rho >= OBSERVABILITY_MIN)
    if np.any(bad):
        where = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
        raise ValueError(
            f"vectors_B must hold at least two non-parallel directions for a finite covariance "
            f"(observability >= {OBSERVABILITY_MIN:g}); the set at batch index {where} has {float(rho[where]):.3g}"
        )
    return np.linalg.inv(information_matrix(b, a))


def triad_covariance(
    primary_B: ArrayLike, secondary_B: ArrayLike, sigma_primary: ArrayLike, sigma_secondary: ArrayLike
) -> NDArray[np.float64]:
    """Covariance [rad^2] (..., 3, 3) of the TRIAD attitude error in body axes (Shuster and Oh 1981).

    ``P = s1^2 I + [(s2^2 - s1^2) b1 b1^T + s1^2 (b1 . b2)(b1 b2^T + b2 b1^T)] / |b1 x b2|^2``,
    first order in the standard deviations, with ``b1`` the primary vector
    (the one TRIAD trusts: its error enters every axis but the one about b1).

    Parameters
    ----------
    primary_B : array_like, shape (..., 3)
        Primary body-frame direction ``b1`` (normalised here).
    secondary_B : array_like, shape (..., 3)
        Secondary body-frame direction ``b2`` (normalised here).
    sigma_primary : array_like, shape (...)
        Standard deviation [rad] of the primary measurement (> 0).
    sigma_secondary : array_like, shape (...)
        Standard deviation [rad] of the secondary measurement (> 0).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        The covariance.

    Raises
    ------
    ValueError
        If a vector is not ``(..., 3)``, finite and non-zero, a standard
        deviation is not positive, or the two directions are parallel.
    """
    b1 = unit_vectors(primary_B, "primary_B")
    b2 = unit_vectors(secondary_B, "secondary_B")
    s1 = check_positive(sigma_primary, "sigma_primary")[..., None, None]
    s2 = check_positive(sigma_secondary, "sigma_secondary")[..., None, None]
    sine2 = np.sum(np.cross(b1, b2) ** 2, axis=-1)[..., None, None]
    if np.any(sine2 == 0.0):
        raise ValueError("primary_B and secondary_B must not be parallel (TRIAD's covariance is infinite)")
    cosine = np.sum(b1 * b2, axis=-1)[..., None, None]
    outer11 = b1[..., :, None] * b1[..., None, :]
    outer12 = b1[..., :, None] * b2[..., None, :]
    cross_terms = outer12 + np.swapaxes(outer12, -1, -2)
    return s1**2 * np.eye(3) + ((s2**2 - s1**2) * outer11 + s1**2 * cosine * cross_terms) / sine2

"""QUEST: Shuster's quaternion estimator, vectorised over a batch of vector sets.

Shuster and Oh, "Three-axis attitude determination from vector
observations", J. Guidance and Control 4(1), 1981; Markley and Crassidis,
*Fundamentals of Spacecraft Attitude Determination and Control*, 2014, ch. 5
(QUEST). With the weights scaled to ``sum_i a_i = 1``, ``S = B + B^T``,
``sigma = trace(B)``, ``kappa = trace(adj S)``, ``Delta = det S`` and
``z = sum_i a_i b_i x r_i``, the largest eigenvalue of Davenport's matrix is
the largest root of Shuster's characteristic equation

    psi(lam) = lam^4 - (a + b) lam^2 - c lam + (a b + c sigma - d) = 0,
    a = sigma^2 - kappa, b = sigma^2 + z.z, c = Delta + z.S z, d = z.S^2 z,

found by Newton-Raphson from ``lam = 1`` (an upper bound: Newton then
decreases monotonically onto the root), until the step is below
:data:`NEWTON_TOLERANCE` or after :data:`NEWTON_MAX_ITERATIONS` steps.

The quaternion is the column of ``adj(K - lam I)`` with the largest diagonal
entry, normalised (every column is proportional to the eigenvector; the
fourth, in the textbook's vector-first order, is Shuster's ``[x; gamma]``,
and choosing the largest one replaces his sequential rotations near a 180
degree attitude). The root's rounding error ``~1e-16 / gap`` would cost
``~1e-16 / gap^2`` rad in the quaternion, so the eigenvalue is refined once by
the Rayleigh quotient ``q^T K q`` and the column taken again (error
``~1e-16 / gap``, that of an eigenvalue solver).

Near the degenerate case (observability ``rho`` below :data:`QUEST_RHO_MIN`:
widely differing weights or nearly parallel vectors) and where Newton did not
converge, those sets are solved by Davenport's q method
(:func:`estimation.determination.q_method.q_method_quaternion`, ``eigh``)
instead; sets below :data:`estimation.determination.vectors.OBSERVABILITY_MIN`
are refused.

See docs/attitude_determination.md for the conventions and the covariance.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from estimation.determination.q_method import q_method_quaternion
from estimation.determination.solution import AttitudeSolution, wahba_solution
from estimation.determination.vectors import (
    VectorPairs,
    attitude_profile_matrix,
    check_observable,
    check_vector_pairs,
    davenport_matrix,
    det3,
)

__all__ = ["NEWTON_MAX_ITERATIONS", "NEWTON_TOLERANCE", "QUEST_RHO_MIN", "quest", "quest_quaternion"]

#: Newton-Raphson stops when every step is below this (the eigenvalue of the
#: weights scaled to sum 1). The Rayleigh refinement makes the quaternion's
#: error second order in the remaining eigenvalue error.
NEWTON_TOLERANCE = 1e-12
#: At most this many Newton steps; a set that has not converged is solved by
#: the q method. Far from the root Newton halves the distance per step at
#: worst, so 60 steps cover any start at this tolerance.
NEWTON_MAX_ITERATIONS = 60
#: Sets with observability below this are solved by the q method: with a
#: relative eigenvalue gap ``g >= 2 rho`` the adjugate's error after one
#: refinement, ``1e-16 / g + (1e-16 / g^2)^2``, stays at the solver's
#: ``1e-16 / g`` only above it.
QUEST_RHO_MIN = 1e-5

# Row/column indices kept in the 3x3 minors of a 4x4 matrix (row k drops k).
_KEEP = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])
_SIGN = (-1.0) ** np.arange(4)


def quest(
    vectors_B: ArrayLike,
    vectors_N: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    sigma: ArrayLike | None = None,
) -> AttitudeSolution:
    """Attitude ``q_BN`` minimising Wahba's loss over any number of vector pairs, by QUEST.

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
        and the QUEST covariance.

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
    >>> sol = quest([[0, 0, 1], [1, 0, 0]], [[1, 0, 0], [0, 1, 0]], sigma=[1e-4, 1e-3])
    >>> np.round(sol.q_BN, 6)
    array([0.5, 0.5, 0.5, 0.5])
    >>> np.round(np.sqrt(np.diag(sol.covariance)) * 1e3, 4)  # 1-sigma per body axis [mrad]
    array([0.1   , 0.0995, 1.    ])
    """
    pairs = check_vector_pairs(vectors_B, vectors_N, weights=weights, sigma=sigma)
    rho = check_observable(pairs)
    return wahba_solution(quest_quaternion(pairs, rho), pairs)


def quest_quaternion(pairs: VectorPairs, rho: NDArray[np.float64]) -> NDArray[np.float64]:
    """QUEST's quaternions (..., 4) for checked observations, the q method where QUEST is unreliable.

    Parameters
    ----------
    pairs : VectorPairs
        Checked observations (:func:`estimation.determination.vectors.check_vector_pairs`).
    rho : ndarray, shape (...)
        Their observability (:func:`estimation.determination.vectors.observability`).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions ``q_BN`` (either sign).
    """
    weights = pairs.weights / pairs.weights.sum(axis=-1, keepdims=True)
    profile = attitude_profile_matrix(pairs.vectors_B, pairs.vectors_N, weights)
    lam, converged = _largest_root(profile)
    k = davenport_matrix(profile)
    q = _adjugate_column(k, lam)
    q = _adjugate_column(k, np.einsum("...i,...ij,...j->...", q, k, q))
    fallback = ~(converged & (rho >= QUEST_RHO_MIN) & np.all(np.isfinite(q), axis=-1))
    if np.any(fallback):
        q[fallback] = q_method_quaternion(
            VectorPairs(pairs.vectors_B[fallback], pairs.vectors_N[fallback], pairs.weights[fallback], None)
        )
    return q


def _largest_root(profile: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Largest root of Shuster's characteristic equation by Newton from 1, and whether it converged."""
    s = profile + np.swapaxes(profile, -1, -2)
    trace = np.trace(profile, axis1=-2, axis2=-1)
    z = np.stack(
        [
            profile[..., 1, 2] - profile[..., 2, 1],
            profile[..., 2, 0] - profile[..., 0, 2],
            profile[..., 0, 1] - profile[..., 1, 0],
        ],
        axis=-1,
    )
    kappa = (
        s[..., 0, 0] * s[..., 1, 1]
        - s[..., 0, 1] ** 2
        + s[..., 0, 0] * s[..., 2, 2]
        - s[..., 0, 2] ** 2
        + s[..., 1, 1] * s[..., 2, 2]
        - s[..., 1, 2] ** 2
    )
    sz = np.einsum("...ij,...j->...i", s, z)
    coef_a = trace**2 - kappa
    coef_b = trace**2 + np.einsum("...i,...i->...", z, z)
    coef_c = det3(s) + np.einsum("...i,...i->...", z, sz)
    coef_d = np.einsum("...i,...i->...", sz, sz)
    quadratic = coef_a + coef_b
    constant = coef_a * coef_b + coef_c * trace - coef_d
    lam = np.ones(trace.shape)
    converged = np.zeros(trace.shape, dtype=bool)
    for _ in range(NEWTON_MAX_ITERATIONS):
        psi = (lam**2 - quadratic) * lam**2 - coef_c * lam + constant
        slope = 4.0 * lam**3 - 2.0 * quadratic * lam - coef_c
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(converged, 0.0, psi / slope)
        lam = lam - step
        converged |= np.abs(step) <= NEWTON_TOLERANCE
        if np.all(converged):
            break
    return lam, converged & np.isfinite(lam)


def _adjugate_column(k: NDArray[np.float64], lam: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit column of ``adj(K - lam I)`` with the largest diagonal entry (the top eigenvector of K)."""
    h = k - lam[..., None, None] * np.eye(4)
    diagonal = det3(h[..., _KEEP[:, :, None], _KEEP[:, None, :]])
    pivot = np.argmax(np.abs(diagonal), axis=-1)
    rows = np.take_along_axis(h, _KEEP[pivot][..., :, None], axis=-2)  # (..., 3, 4): row `pivot` dropped
    minors = det3(np.moveaxis(rows[..., :, _KEEP], -2, -3))  # (..., 4): column j dropped
    column = minors * _SIGN * _SIGN[pivot][..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        return column / np.linalg.norm(column, axis=-1, keepdims=True)

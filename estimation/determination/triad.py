"""TRIAD: the attitude from two vector observations, trusting the primary one.

Black's TRIAD as in Shuster and Oh, "Three-axis attitude determination from
vector observations", J. Guidance and Control 4(1), 1981, and Markley and
Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*,
2014, ch. 5 (TRIAD): build the orthonormal triads ``t1 = v1``,
``t2 = v1 x v2 / |v1 x v2|``, ``t3 = t1 x t2`` from the primary and secondary
vectors in both frames; ``C_BN = [t1 t2 t3]_B [t1 t2 t3]_N^T``. The primary
body vector is matched exactly (``C_BN r1 = b1``); the secondary only fixes
the rotation about it. Make the more accurate measurement the primary one.

See docs/attitude_determination.md for the conventions and the covariance.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.validation import check_positive
from estimation.determination.covariance import triad_covariance
from estimation.determination.solution import AttitudeSolution, wahba_loss
from estimation.determination.vectors import check_vector_pairs, unit_vectors

__all__ = ["SINE_MIN", "triad"]

#: Smallest accepted sine of the angle between the primary and secondary
#: vectors (0.2 arcsec). TRIAD's rounding error grows like 1e-16 / sine rad,
#: 1e-10 rad at this bound; its noise error like sigma_secondary / sine.
SINE_MIN = 1e-6


def triad(
    primary_B: ArrayLike,
    primary_N: ArrayLike,
    secondary_B: ArrayLike,
    secondary_N: ArrayLike,
    *,
    sigma_primary: ArrayLike | None = None,
    sigma_secondary: ArrayLike | None = None,
) -> AttitudeSolution:
    """Attitude ``q_BN`` from two vector pairs by TRIAD; the primary vector is matched exactly.

    Parameters
    ----------
    primary_B : array_like, shape (..., 3)
        Primary (the more accurate) measured direction in the body frame;
        normalised here.
    primary_N : array_like, shape (..., 3)
        The primary direction in the inertial frame; normalised here.
    secondary_B : array_like, shape (..., 3)
        Secondary measured direction in the body frame; normalised here.
    secondary_N : array_like, shape (..., 3)
        The secondary direction in the inertial frame; normalised here.
    sigma_primary : array_like, shape (...), optional
        Standard deviation [rad] of the primary measurement (> 0). With
        ``sigma_secondary`` it gives the covariance (Shuster and Oh 1981) and
        weights ``1 / sigma**2`` for the loss.
    sigma_secondary : array_like, shape (...), optional
        Standard deviation [rad] of the secondary measurement (> 0).

    Returns
    -------
    AttitudeSolution
        ``q_BN`` (scalar part >= 0), the covariance (None without the two
        standard deviations), Wahba's loss and gain of the TRIAD attitude
        (equal weights without the standard deviations).

    Raises
    ------
    ValueError
        If a vector is not ``(..., 3)``, finite and non-zero, the shapes do not
        broadcast, only one standard deviation is given or one is not
        positive, or the two directions are parallel or antiparallel (sine of
        their angle below :data:`SINE_MIN`) in either frame.

    Examples
    --------
    >>> import numpy as np
    >>> sol = triad([0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 1, 0])
    >>> np.round(sol.q_BN, 6)
    array([0.5, 0.5, 0.5, 0.5])
    """
    if (sigma_primary is None) != (sigma_secondary is None):
        raise ValueError("give both sigma_primary and sigma_secondary (for the covariance), or neither")
    sigma = None
    if sigma_primary is not None:
        sigma_1 = check_positive(sigma_primary, "sigma_primary")
        sigma_2 = check_positive(sigma_secondary, "sigma_secondary")
        sigma = np.stack(np.broadcast_arrays(sigma_1, sigma_2), axis=-1)
    vectors = {"primary_B": primary_B, "primary_N": primary_N, "secondary_B": secondary_B, "secondary_N": secondary_N}
    pairs = check_vector_pairs(
        _stack_pair(vectors, "primary_B", "secondary_B"), _stack_pair(vectors, "primary_N", "secondary_N"), sigma=sigma
    )
    triads = {}
    for frame, vecs in (("B", pairs.vectors_B), ("N", pairs.vectors_N)):
        first, second = vecs[..., 0, :], vecs[..., 1, :]
        normal = np.cross(first, second)
        sine = np.linalg.norm(normal, axis=-1)
        bad = ~(sine >= SINE_MIN)
        if np.any(bad):
            where = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
            raise ValueError(
                f"primary_{frame} and secondary_{frame} must not be parallel or antiparallel for TRIAD "
                f"(sine of their angle >= {SINE_MIN:g}); got sine {float(sine[where]):.3g} at batch index {where}"
            )
        t2 = normal / sine[..., None]
        triads[frame] = np.stack([first, t2, np.cross(first, t2)], axis=-1)
    c_bn = triads["B"] @ np.swapaxes(triads["N"], -1, -2)
    q_bn = quat.from_dcm(c_bn)
    covariance = None
    if sigma is not None:
        covariance = triad_covariance(
            pairs.vectors_B[..., 0, :], pairs.vectors_B[..., 1, :], pairs.sigma[..., 0], pairs.sigma[..., 1]
        )
    loss, gain = wahba_loss(q_bn, pairs)
    return AttitudeSolution(q_BN=q_bn, covariance=covariance, loss=loss, gain=gain)


def _stack_pair(vectors: dict[str, ArrayLike], first: str, second: str) -> NDArray[np.float64]:
    """Stack two (..., 3) vectors into (..., 2, 3), each checked under its own name."""
    a, b = unit_vectors(vectors[first], first), unit_vectors(vectors[second], second)
    try:
        a, b = np.broadcast_arrays(a, b)
    except ValueError:
        raise ValueError(
            f"{first} and {second} must have broadcastable shapes (..., 3), got {a.shape} and {b.shape}"
        ) from None
    return np.stack([a, b], axis=-2)

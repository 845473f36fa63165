"""Inertial hold: a fixed attitude ``q_RN`` at rest in N (zero rate and acceleration)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from attitude import quaternion as quat
from controllers.guidance.protocol import SampledReference, Samples, reference_times

__all__ = ["InertialReference"]


class InertialReference(SampledReference):
    """Hold the body at a fixed attitude ``q_RN``.

    Parameters
    ----------
    q_RN : array_like, shape (4,)
        The held attitude (scalar first, unit norm).

    Raises
    ------
    ValueError
        If ``q_RN`` is not one unit quaternion.
    """

    def __init__(self, q_RN: ArrayLike) -> None:
        q = quat.as_unit_quaternion(q_RN, "q_RN")
        if q.shape != (4,):
            raise ValueError(f"q_RN must be one quaternion of shape (4,), got shape {q.shape}")
        self.q_RN = q

    def samples(self, t: ArrayLike) -> Samples:
        """``q_RN`` (n, 4) and zero rates and accelerations (n, 3).

        Parameters
        ----------
        t : array_like, shape (n,)
            Times [s].
        """
        n = reference_times(t).size
        return np.tile(self.q_RN, (n, 1)), np.zeros((n, 3)), np.zeros((n, 3))

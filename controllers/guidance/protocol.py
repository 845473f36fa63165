"""The common face of every pointing reference: ``q_RN``, ``omega_RN_R`` and ``omega_dot_RN_R`` at times ``t``.

A pointing reference (guidance mode) says where the body frame B should be:
the attitude ``q_RN`` of a reference frame R, its angular velocity relative
to N in R components ``omega_RN_R`` [rad/s] and that vector's time derivative
``omega_dot_RN_R`` [rad/s^2] (the same whether taken in N or in R, since
``omega x omega = 0``). Every mode of :mod:`controllers.guidance` meets
:class:`PointingReference`, so a controller
(:class:`controllers.guidance.GuidanceController`) or a mode manager can hold
any of them and switch between them without knowing which it is.
See docs/guidance.md.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.validation import as_float_array

__all__ = ["PointingReference", "SampledReference", "reference_times"]

Samples = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


@runtime_checkable
class PointingReference(Protocol):
    """What a controller needs of a guidance mode (module docstring).

    Times are seconds on the simulation clock (for orbit-based modes, seconds
    since the orbit's epoch).
    """

    def samples(self, t: ArrayLike) -> Samples:
        """The reference at many times.

        Parameters
        ----------
        t : array_like, shape (n,)
            Times [s].

        Returns
        -------
        q_RN : ndarray, shape (n, 4)
            Attitude of R relative to N (scalar first).
        omega_RN_R : ndarray, shape (n, 3)
            Angular velocity of R relative to N, R components [rad/s].
        omega_dot_RN_R : ndarray, shape (n, 3)
            Its time derivative [rad/s^2].
        """
        ...

    def reference(self, t: float) -> Samples:
        """The reference at one time: ``q_RN`` (4,), ``omega_RN_R`` (3,) [rad/s], ``omega_dot_RN_R`` (3,) [rad/s^2].

        Parameters
        ----------
        t : float
            Time [s].
        """
        ...


def reference_times(t: ArrayLike) -> NDArray[np.float64]:
    """Times as a flat, finite float array (n,) [s].

    Parameters
    ----------
    t : array_like
        A time or times [s].

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    ValueError
        If ``t`` is not numeric or not finite.
    """
    return np.atleast_1d(as_float_array(t, "t")).reshape(-1)


class SampledReference:
    """Mixin: :meth:`reference` at one time from the subclass's batched :meth:`samples`."""

    def samples(self, t: ArrayLike) -> Samples:
        """The reference at many times (:class:`PointingReference`).

        Parameters
        ----------
        t : array_like, shape (n,)
            Times [s].
        """
        raise NotImplementedError

    def reference(self, t: float) -> Samples:
        """``q_RN`` (4,), ``omega_RN_R`` (3,) [rad/s] and ``omega_dot_RN_R`` (3,) [rad/s^2] at ``t``.

        Parameters
        ----------
        t : float
            Time [s].
        """
        q, w, w_dot = self.samples(t)
        return q[0], w[0], w_dot[0]

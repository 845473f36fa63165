"""Quaternion-feedback PD control (Wie, Weiss and Arapostathis, 1989).

.. math::

    \\tau = -K\\, \\mathrm{sgn}(q_{e,0})\\, q_{e,v} - C\\, \\omega_e
            \\;[+\\; \\omega \\times (I \\omega + h)]

with ``q_e = q_ref* ⊗ q`` (attitude of B relative to the reference R),
``omega_e = omega - C_BR omega_ref`` and the sign of the scalar part choosing
the shortest way (a 359 degree error is a 1 degree error). The optional
gyroscopic term cancels ``omega x H`` exactly.

Design from natural frequency and damping: for small errors
``q_e,v ≈ theta / 2``, so each axis obeys
``I theta'' + C theta' + (K/2) theta = 0``: ``K = 2 I wn^2`` and
``C = 2 I zeta wn`` (with ``I`` the diagonal inertia in the control axes; the
full tensor is used when the products of inertia are not zero, so
``I^-1 K/2 = wn^2`` holds as a matrix). The factor 2 is the whole point of
:meth:`QuaternionPD.from_bandwidth`: forgetting it gives sqrt(2) too slow a
loop.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import backend as bk
from attitude import quaternion as quat
from attitude._validation import as_float_array, check_positive
from attitude.integrators import quaternion_multiply_components
from attitude.rigid_body import Components, RigidBody, cross

__all__ = ["QuaternionPD", "quaternion_error_components"]

Reference = Callable[[float], tuple[ArrayLike, ArrayLike]]


def quaternion_error_components(q_ref: Components, q: Components) -> tuple[Components, Components]:
    """Shortest-way error quaternion ``q_ref* ⊗ q`` on components.

    Returns the error quaternion with non-negative scalar part, and its raw
    (unsigned) form.
    """
    conj = [q_ref[0], -q_ref[1], -q_ref[2], -q_ref[3]]
    e = quaternion_multiply_components(conj, q)
    sign = bk.if_else(e[0] < 0, -1.0, 1.0)
    return [sign * c for c in e], e


def _rotate_ref_to_body(q_e: Components, v_r: Components) -> Components:
    """``C_BR v_R``: body components of a reference-frame vector (q_e = q_BR)."""
    w, u = q_e[0], q_e[1:]
    # v_B = q_e* ⊗ v_R ⊗ q_e = v - 2 w (u x v) + 2 u x (u x v)
    t = cross(u, v_r)
    tt = cross(u, t)
    return [v - 2.0 * w * a + 2.0 * b for v, a, b in zip(v_r, t, tt)]


def _matrix(value: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = as_float_array(value, name)
    if arr.shape == (3,):
        arr = np.diag(arr)
    if arr.shape != (3, 3):
        raise ValueError(f"{name} must be 3 diagonal gains or a 3x3 matrix, got shape {arr.shape}")
    sym = 0.5 * (arr + arr.T)
    if np.min(np.linalg.eigvalsh(sym)) <= 0:
        raise ValueError(f"{name} must be positive definite, got eigenvalues {np.linalg.eigvalsh(sym)}")
    return arr


@dataclass
class QuaternionPD:
    """Quaternion-feedback PD controller (module docstring).

    Parameters
    ----------
    K : array_like (3,) or (3, 3)
        Attitude gain on the error quaternion vector part [N m].
    C : array_like (3,) or (3, 3)
        Rate gain [N m s].
    period : float
        Sample time [s].
    q_ref : array_like (4,)
        Constant reference attitude ``q_RN`` (ignored if ``reference`` given).
    reference : callable, optional
        ``reference(t) -> (q_RN, omega_RN_R)`` for a moving reference.
    inertia : array_like (3, 3), optional
        Needed for the gyroscopic compensation.
    gyroscopic : bool
        Add ``omega x (I omega + h)`` (requires ``inertia``).
    """

    K: NDArray[np.float64]
    C: NDArray[np.float64]
    period: float
    q_ref: NDArray[np.float64] = field(default_factory=lambda: quat.identity())
    reference_fn: Reference | None = None
    inertia: NDArray[np.float64] | None = None
    gyroscopic: bool = False

    def __post_init__(self) -> None:
        self.K = _matrix(self.K, "K")
        self.C = _matrix(self.C, "C")
        self.period = float(check_positive(self.period, "period"))
        self.q_ref = quat.as_unit_quaternion(self.q_ref, "q_ref")
        if self.gyroscopic and self.inertia is None:
            raise ValueError("inertia is required when gyroscopic=True")
        if self.inertia is not None:
            self.inertia = RigidBody(self.inertia).inertia

    @classmethod
    def from_bandwidth(
        cls,
        body: RigidBody,
        wn: ArrayLike,
        zeta: ArrayLike,
        period: float,
        **kwargs: Any,
    ) -> QuaternionPD:
        """Gains that place each axis at natural frequency ``wn`` [rad/s] and damping ``zeta``.

        ``K = 2 I Wn^2`` and ``C = 2 I Z Wn`` with diagonal ``Wn``, ``Z`` (the
        factor 2 because ``q_v`` is half the angle). Warns when ``wn`` exceeds
        a tenth of the sample rate ``2 pi / period``, where the continuous
        design no longer predicts the sampled loop.
        """
        wn = np.broadcast_to(check_positive(wn, "wn"), (3,)).astype(float)
        zeta = np.broadcast_to(check_positive(zeta, "zeta"), (3,)).astype(float)
        period = float(check_positive(period, "period"))
        sample_rate = 2.0 * np.pi / period
        if np.max(wn) > 0.1 * sample_rate:
            warnings.warn(
                f"wn = {np.max(wn):.4g} rad/s is above a tenth of the sample rate ({sample_rate:.4g} rad/s): "
                "sampling and delay will erode the designed damping",
                stacklevel=2,
            )
        inertia = body.inertia
        K = 2.0 * inertia @ np.diag(wn**2)
        C = 2.0 * inertia @ np.diag(zeta * wn)
        kwargs.setdefault("inertia", inertia)
        return cls(K=K, C=C, period=period, **kwargs)

    # -- reference --------------------------------------------------------------

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitude ``q_RN`` and rate ``omega_RN_R`` [rad/s] at ``t``."""
        if self.reference_fn is None:
            return self.q_ref, np.zeros(3)
        q_r, w_r = self.reference_fn(t)
        return quat.as_unit_quaternion(q_r, "reference q"), np.asarray(w_r, dtype=float)

    # -- law ------------------------------------------------------------------------

    def torque_components(self, q: Components, omega: Components, h_body: Components, inputs: Components) -> Components:
        """The control law on components; ``inputs = [q_ref (4), omega_ref (3)]``."""
        q_e, _ = quaternion_error_components(inputs[:4], q)
        w_ref_b = _rotate_ref_to_body(q_e, inputs[4:7])
        w_e = [w - r for w, r in zip(omega, w_ref_b)]
        tau = []
        for i in range(3):
            acc = 0.0 * omega[0]
            for j in range(3):
                if self.K[i, j] != 0.0:
                    acc = acc - self.K[i, j] * q_e[1 + j]
                if self.C[i, j] != 0.0:
                    acc = acc - self.C[i, j] * w_e[j]
            tau.append(acc)
        if self.gyroscopic:
            h_tot = [sum(self.inertia[i, j] * omega[j] for j in range(3)) + h_body[i] for i in range(3)]
            tau = [a + b for a, b in zip(tau, cross(omega, h_tot))]
        return tau

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """References at many times: ``q_ref`` (n, 4) and ``omega_ref`` (n, 3)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.reference_fn is None:
            return np.tile(self.q_ref, (t.size, 1)), np.zeros((t.size, 3))
        pairs = [self.reference(float(tk)) for tk in t]
        return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Reference samples ``[q_ref; omega_ref]`` (7, len(t)) for the compiled engine."""
        q_r, w_r = self.reference_samples(t)
        return np.concatenate([q_r, w_r], axis=1).T

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque [N m] for an estimate with ``q``, ``omega`` (and ``h_wheels``)."""
        q_r, w_r = self.reference(t)
        q = np.asarray(estimate.q, dtype=float)
        w = np.asarray(estimate.omega, dtype=float)
        h_b = getattr(estimate, "h_body", None)
        h_b = np.zeros(3) if h_b is None else np.asarray(h_b, dtype=float)
        out = self.torque_components(list(q), list(w), list(h_b), [*q_r, *w_r])
        return np.array([float(v) for v in out])

"""The wheel momentum a held attitude needs in orbit: secular and cyclic build-up, with and without unloading.

While the attitude control holds the spacecraft on its reference
``(q_ref(t), omega_ref(t))``, the total angular momentum ``H`` (body plus
wheels) changes only by the external torques:

.. math::

    \\dot H_N = R(q_{ref}) \\, (\\tau_{dist,B} + m_B \\times B_B),
    \\qquad h_B = R(q_{ref})^T H_N - I \\, \\omega_{ref}

(Wertz, *Spacecraft Attitude Determination and Control*, 1978, sec. 19.1;
Markley & Crassidis, *Fundamentals of Spacecraft Attitude Determination and
Control*, 2014, sec. 7.5: the momentum budget). ``h_B`` is the wheels'
momentum relative to the body in body axes: whatever the body itself does not
carry, the wheels must. The part of the disturbance that is constant in body
axes accumulates (the *secular* build-up), the rest oscillates (the *cyclic*
part). A magnetic unloading law ``m_B(B_B, h_B)`` (e.g. the cross-product
law) feeds back on ``h_B`` and keeps it bounded.

This is the budget of a perfect attitude control: the closed loop differs by
the pointing error's effect on the torques (a test compares it with the
engine over an orbit). Without unloading the build-up is a quadrature of the
torques; with it an ODE in ``H_N`` integrated by RK4 on the track's grid.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.environment.orbit_environment import OrbitEnvironment
from attitude.environment.torques import magnetic_torque_components
from attitude.progress import Throttle
from attitude.rigid_body import RigidBody
from attitude.validation import as_float_array, check_vector

__all__ = ["MomentumBuildUp", "held_attitude_momentum"]

#: A dipole law for the budget: ``(field_B (3,) [T], h_B (3,) [N m s]) -> dipole_B (3,) [A m^2]``.
DipoleLaw = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


@dataclass(frozen=True)
class MomentumBuildUp:
    """Wheel momentum along a held attitude.

    Attributes
    ----------
    t : ndarray (n,)
        Times since the orbit's epoch [s].
    h_wheels_B : ndarray (n, 3)
        Wheel momentum relative to the body in body axes [N m s].
    disturbance_torques : dict of ndarray (n, 3)
        Each source's torque in body axes [N m].
    torque_magnetorquer : ndarray (n, 3)
        The unloading torque ``m x B`` [N m] (zeros without unloading).
    dipole : ndarray (n, 3)
        The unloading dipole [A m^2] (zeros without unloading).
    momentum_N : ndarray (n, 3)
        Total angular momentum of the spacecraft (body and wheels) in N [N m s].
    """

    t: NDArray[np.float64]
    h_wheels_B: NDArray[np.float64]
    disturbance_torques: dict[str, NDArray[np.float64]]
    torque_magnetorquer: NDArray[np.float64]
    dipole: NDArray[np.float64]
    momentum_N: NDArray[np.float64]

    @property
    def secular_rate_B(self) -> NDArray[np.float64]:
        """Least-squares slope of ``h_wheels_B`` over the whole span [N m s / s].

        Meaningful for an attitude fixed in N; for a rotating one (nadir hold)
        the components across the rotation axis turn with the body and their
        slope depends on the span: use :attr:`secular_rate_N`.
        """
        return _slope(self.t, self.h_wheels_B)

    @property
    def secular_rate_N(self) -> NDArray[np.float64]:
        """Least-squares slope of the total momentum in N [N m s / s]: the secular build-up, any attitude."""
        return _slope(self.t, self.momentum_N)

    @property
    def peak_B(self) -> float:
        """Largest norm of ``h_wheels_B`` [N m s]."""
        return float(np.max(np.linalg.norm(self.h_wheels_B, axis=-1)))


def held_attitude_momentum(
    environment: OrbitEnvironment,
    body: RigidBody,
    t: ArrayLike,
    q_ref: ArrayLike,
    omega_ref: ArrayLike,
    *,
    h_wheels0_B: ArrayLike = (0.0, 0.0, 0.0),
    dipole_law: DipoleLaw | None = None,
    parameters: ArrayLike | None = None,
    progress: Callable[[float], None] | None = None,
) -> MomentumBuildUp:
    """Wheel momentum while the attitude is held on a reference (module docstring).

    Parameters
    ----------
    environment : OrbitEnvironment
        The orbit and its disturbance models.
    body : RigidBody
        The whole spacecraft [kg m^2] (gravity gradient, and ``I omega_ref``).
    t : array_like (n,)
        Uniform grid of times since the orbit's epoch [s].
    q_ref : array_like (n, 4)
        Reference attitude ``q_BN`` at ``t``.
    omega_ref : array_like (n, 3) or (3,)
        Reference body rate [rad/s] at ``t``.
    h_wheels0_B : array_like (3,)
        Wheel momentum at ``t[0]`` in body axes [N m s].
    dipole_law : callable, optional
        ``(field_B, h_B) -> dipole_B`` [A m^2] (after the rods' limits):
        magnetic unloading. None: no unloading (the momentum is a quadrature).
        The grid must resolve the law's time constant: for a gain ``k`` [1/s],
        ``k dt <= 0.5`` keeps RK4 within 3e-4 per step (it goes unstable near 2.8).
    parameters : array_like (7,), optional
        Surface parameters (:meth:`OrbitEnvironment.surface_parameters`).
    progress : callable, optional
        ``progress(fraction)`` of the unloading integration done (with a
        ``dipole_law``: the long part), at most every
        :data:`attitude.progress.REFRESH_PERIOD_S` (:class:`attitude.progress.Throttle`).

    Returns
    -------
    MomentumBuildUp

    Raises
    ------
    ValueError
        For a grid that is not uniform and increasing, or shapes that do not match.
    """
    t = as_float_array(t, "t").reshape(-1)
    steps = np.diff(t)
    if t.size < 2 or np.any(steps <= 0.0) or np.ptp(steps) > 1e-9 * max(1.0, float(t[-1])):
        raise ValueError("t must be a uniform increasing grid of at least 2 times [s]")
    n = t.size
    q = quat.as_unit_quaternion(q_ref, "q_ref")
    if q.shape != (n, 4):
        raise ValueError(f"q_ref must have shape ({n}, 4), got {q.shape}")
    w = np.broadcast_to(check_vector(omega_ref, "omega_ref", 3), (n, 3))
    h0 = check_vector(h_wheels0_B, "h_wheels0_B", 3).reshape(3)
    dt = float(steps[0])
    # The track at half steps too: RK4 needs the torques at the midpoints.
    fine = environment.track(np.linspace(t[0], t[-1], 2 * n - 1))
    torques_fine = environment.torques_B(body, _midpoint_attitudes(q), fine, parameters)
    total_fine = sum(torques_fine.values()) if torques_fine else np.zeros((2 * n - 1, 3))
    rot_fine = np.swapaxes(quat.to_dcm(_midpoint_attitudes(q)), -1, -2)  # C_NB: body vectors into N
    i_w = w @ body.inertia.T
    H0 = rot_fine[0] @ (h0 + i_w[0])
    torques = {k: v[::2] for k, v in torques_fine.items()}
    field_B = np.einsum("nji,nj->ni", rot_fine, fine.field_N)  # R^T B_N
    if dipole_law is None:
        tau_N = np.einsum("nij,nj->ni", rot_fine, total_fine)
        # Simpson on each pair of steps is exact for the quadratic interpolant through the midpoint.
        increments = dt / 6.0 * (tau_N[0:-2:2] + 4.0 * tau_N[1:-1:2] + tau_N[2::2])
        H = H0 + np.concatenate([np.zeros((1, 3)), np.cumsum(increments, axis=0)])
        h = np.einsum("nji,nj->ni", rot_fine[::2], H) - i_w
        zeros = np.zeros((n, 3))
        return MomentumBuildUp(t, h, torques, zeros, zeros.copy(), H)

    w_fine = np.concatenate([np.repeat(w[:-1], 2, axis=0), w[-1:]])
    i_w_fine = w_fine @ body.inertia.T

    def rate(H_N: NDArray, j: int) -> tuple[NDArray, NDArray, NDArray]:
        h_B = rot_fine[j].T @ H_N - i_w_fine[j]
        m_B = check_vector(dipole_law(field_B[j], h_B), "dipole_law(field_B, h_B)", 3).reshape(3)
        tau_m = np.array(magnetic_torque_components(list(m_B), list(field_B[j])))
        return rot_fine[j] @ (total_fine[j] + tau_m), m_B, tau_m

    H = np.empty((n, 3))
    dipole = np.zeros((n, 3))
    tau_mag = np.zeros((n, 3))
    H[0] = H0
    report = None if progress is None else Throttle(progress, n - 1)
    for k in range(n - 1):
        if report is not None:
            report(k)
        j = 2 * k
        k1, dipole[k], tau_mag[k] = rate(H[k], j)
        k2 = rate(H[k] + 0.5 * dt * k1, j + 1)[0]
        k3 = rate(H[k] + 0.5 * dt * k2, j + 1)[0]
        k4 = rate(H[k] + dt * k3, j + 2)[0]
        H[k + 1] = H[k] + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    if not np.all(np.isfinite(H)):
        raise FloatingPointError(
            "the momentum under dipole_law became non-finite: the grid step t[1] - t[0] = "
            f"{dt:g} s is too long for the law's time constant (RK4 needs k dt well below 2.8)"
        )
    _, dipole[-1], tau_mag[-1] = rate(H[-1], 2 * (n - 1))
    h = np.einsum("nji,nj->ni", rot_fine[::2], H) - i_w
    return MomentumBuildUp(t, h, torques, tau_mag, dipole, H)


def _slope(t: NDArray[np.float64], values: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least-squares slope of each column of ``values`` against ``t``."""
    tc = t - t.mean()
    return (tc @ (values - values.mean(axis=0))) / (tc @ tc)


def _midpoint_attitudes(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """The attitudes at the grid and halfway between its points (slerp), shape (2n - 1, 4)."""
    mid = quat.slerp(q[:-1], q[1:], 0.5)
    out = np.empty((2 * q.shape[0] - 1, 4))
    out[0::2] = q
    out[1::2] = mid
    return out

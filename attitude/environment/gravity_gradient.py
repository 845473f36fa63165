"""Gravity-gradient environment on a circular orbit, its linearisation and stability regions.

The torque ``tau_B = 3 mu / |r|^5 r_B x (I r_B)`` [N m] on a rigid body at
``r`` [m] from the centre of a spherical planet (Wie, *Space Vehicle
Dynamics and Control*; Hughes, *Spacecraft Attitude Dynamics*), in the
local-vertical local-horizontal (LVLH) frame L of a circular orbit, its
linearisation about the LVLH-aligned attitude and the classical stability
regions.

See docs/gravity_gradient.md for the derivation (physics, frames,
linearisation).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.backend import cross
from attitude.environment.orbit import MU_EARTH, CircularOrbit, check_mu
from attitude.rigid_body import Components, ParametricBody, RigidBody
from attitude.validation import as_float_array, check_positive, check_vector, describe, scalar_angle

__all__ = [
    "GravityGradientStability",
    "constant_plus_orbital_disturbance",
    "gravity_gradient_stability",
    "gravity_gradient_torque",
    "gravity_gradient_torque_components",
    "gravity_gradient_torque_function",
    "linearize_gravity_gradient",
    "lvlh_relative_dynamics",
]

TorqueFunction = Callable[[float, NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


# ---------------------------------------------------------------------------
# Gravity-gradient torque
# ---------------------------------------------------------------------------


def _check_body(body: Any, name: str = "body") -> RigidBody:
    if not isinstance(body, RigidBody):
        raise ValueError(f"{name} must be a RigidBody, got {type(body).__name__}")
    return body


def gravity_gradient_torque_components(
    body: RigidBody | ParametricBody, r_components: Components, mu: float = MU_EARTH
) -> Components:
    """Gravity-gradient torque on components, ``3 mu |r|^-5 (r x I r)`` [N m].

    Backend-neutral like :mod:`attitude.rigid_body`: only ``+ - *`` and ``**``
    are used, so the same code evaluates on numpy arrays of any batch shape
    and on casadi ``SX``/``MX`` scalars (exact derivatives).

    Parameters
    ----------
    body : RigidBody or ParametricBody
        The body (its inertia tensor in body components [kg m^2]); a batch of
        bodies only with numpy components; a :class:`ParametricBody` (inertia
        entries as casadi symbols) in the compiled kernels.
    r_components : list of 3 numpy arrays or casadi scalars
        Position of the centre of mass relative to the planet's centre, in
        body components [m]. Must not be zero (not checked on symbols).
    mu : float
        Gravitational parameter of the planet [m^3/s^2].

    Returns
    -------
    list of 3
        Torque about the centre of mass in body components [N m], same
        backend as ``r_components``.
    """
    if not isinstance(body, ParametricBody):
        body = _check_body(body)
    mu = check_mu(mu)
    if len(r_components) != 3:
        raise ValueError(f"r_components must hold 3 components (x, y, z) in m, got {len(r_components)}")
    symbolic = any(isinstance(c, (ca.SX, ca.MX, ca.DM)) for c in r_components)
    if symbolic and isinstance(body, RigidBody) and body.batch_shape:
        raise ValueError("casadi evaluation needs a single body, not a batch of inertias")
    x, y, z = r_components
    r2 = x * x + y * y + z * z
    scale = 3.0 * mu * r2**-2.5
    i_r = body.inertia_times_components(list(r_components))
    return [scale * c for c in cross(list(r_components), i_r)]


def gravity_gradient_torque(body: RigidBody, r_B: ArrayLike, mu: float = MU_EARTH) -> NDArray[np.float64]:
    """Gravity-gradient torque ``3 mu / |r|^5 (r_B x I r_B)`` [N m] in body components.

    Parameters
    ----------
    body : RigidBody
        The body; a batched body broadcasts against the batch of ``r_B``.
    r_B : array_like, shape (..., 3)
        Position of the centre of mass relative to the planet's centre in body
        components [m] (``rotate_inverse(q_BN, r_N)``).
    mu : float
        Gravitational parameter [m^3/s^2]; Earth by default.

    Returns
    -------
    ndarray, shape broadcast(batch) + (3,)
        Torque about the centre of mass in body components [N m].

    Raises
    ------
    ValueError
        If ``body`` is not a RigidBody, ``r_B`` is not finite, not ``(..., 3)``
        or zero, or ``mu`` is not a positive scalar.
    """
    body = _check_body(body)
    r_B = check_vector(r_B, "r_B", 3)
    mu = check_mu(mu)
    r2 = np.sum(r_B * r_B, axis=-1)
    if np.any(r2 == 0.0):
        raise ValueError("r_B must be non-zero (the position from the planet's centre); found a zero vector")
    torque = gravity_gradient_torque_components(body, [r_B[..., i] for i in range(3)], mu)
    return np.stack(np.broadcast_arrays(*torque), axis=-1)


# ---------------------------------------------------------------------------
# Relative dynamics about LVLH and its exact linearisation
# ---------------------------------------------------------------------------


def _check_lvlh_body(body: Any) -> RigidBody:
    body = _check_body(body)
    if body.batch_shape:
        raise ValueError(f"body must be a single body for the LVLH linearisation, got a batch {body.batch_shape}")
    if not body.is_diagonal:
        raise ValueError(
            "body must be given in its principal frame (diagonal inertia: roll, pitch, yaw moments), so that the "
            f"LVLH-aligned attitude is an equilibrium; got inertia {describe(body.inertia)} kg m^2"
        )
    return body


def _check_orbit(orbit: Any) -> CircularOrbit:
    if not isinstance(orbit, CircularOrbit):
        raise ValueError(f"orbit must be a CircularOrbit, got {type(orbit).__name__}")
    return orbit


def lvlh_relative_dynamics(body: RigidBody, orbit: CircularOrbit) -> ca.Function:
    """Nonlinear attitude motion relative to LVLH as a casadi Function ``f(x[6], u[3]) -> x_dot[6]``.

    State ``x = [e (3), w (3)]``: ``e`` the vector part of ``q_BL`` (scalar
    part ``sqrt(1 - |e|^2) >= 0``), ``w = omega_BL_B`` [rad/s]. Input ``u``:
    control torque in body components [N m]. Gravity gradient is the only
    environmental torque; the orbit is prescribed (circular).

    With ``omega_BN_B = w + C_BL omega_LN_L`` and ``omega_LN_L`` constant::

        e_dot = vec(0.5 q_BL ⊗ [0, w])
        w_dot = omega_dot(omega_BN_B, tau_gg + u) + w x (C_BL omega_LN_L)

    where ``omega_dot`` is :meth:`RigidBody.omega_dot_components` and
    ``tau_gg`` is :func:`gravity_gradient_torque_components` at
    ``r_B = C_BL [0, 0, -|r|]`` (the spacecraft is at zenith, ``-o3``, from
    the planet's centre).

    Parameters
    ----------
    body : RigidBody
        A single body in its principal frame (diagonal inertia: ``I1`` roll,
        ``I2`` pitch, ``I3`` yaw) [kg m^2].
    orbit : CircularOrbit
        The orbit (its radius, mean motion and ``mu``).

    Returns
    -------
    casadi.Function
        ``f(x, u) -> x_dot`` with inputs named ``"x"``, ``"u"`` and output ``"x_dot"``.
    """
    body = _check_lvlh_body(body)
    orbit = _check_orbit(orbit)
    x = ca.SX.sym("x", 6)
    u = ca.SX.sym("u", 3)
    e = [x[i] for i in range(3)]
    w = [x[3 + i] for i in range(3)]
    q_BL = [ca.sqrt(1.0 - (e[0] * e[0] + e[1] * e[1] + e[2] * e[2])), *e]
    r_B = quat.rotate_inverse_components(q_BL, [0.0, 0.0, -orbit.radius_m])
    tau = [t + u[i] for i, t in enumerate(gravity_gradient_torque_components(body, r_B, orbit.mu))]
    omega_LN_B = quat.rotate_inverse_components(q_BL, list(orbit.omega_LN_L))
    omega_BN_B = [a + b for a, b in zip(w, omega_LN_B)]
    omega_BN_dot = body.omega_dot_components(omega_BN_B, tau)
    transport = cross(w, omega_LN_B)
    w_dot = [a + b for a, b in zip(omega_BN_dot, transport)]
    e_dot = quat.derivative_components(q_BL, w)[1:]
    return ca.Function("lvlh_relative_dynamics", [x, u], [ca.vertcat(*e_dot, *w_dot)], ["x", "u"], ["x_dot"])


def linearize_gravity_gradient(
    body: RigidBody, orbit: CircularOrbit
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exact linearisation about the LVLH-aligned attitude under gravity gradient.

    Jacobians of :func:`lvlh_relative_dynamics` at ``x = 0, u = 0`` (casadi
    automatic differentiation, no finite differences).

    Parameters
    ----------
    body : RigidBody
        A single body in its principal frame; body axes 1, 2, 3 are aligned
        with roll ``o1``, pitch ``o2`` and yaw ``o3`` at the equilibrium.
    orbit : CircularOrbit
        The circular orbit.

    Returns
    -------
    A : ndarray, shape (6, 6)
        ``d x_dot / d x`` for ``x = [e1, e2, e3, w1, w2, w3]`` (``e`` the vector
        part of ``q_BL`` [-], ``w = omega_BL_B`` [rad/s]) [1/s].
    B : ndarray, shape (6, 3)
        ``d x_dot / d u`` for the body torque ``u`` [N m]: zeros over ``diag(1/I)``.

    Raises
    ------
    ValueError
        If ``body`` is batched or not diagonal (then LVLH alignment is not an
        equilibrium), or ``orbit`` is not a CircularOrbit.
    """
    f = lvlh_relative_dynamics(body, orbit)
    x = ca.SX.sym("x", 6)
    u = ca.SX.sym("u", 3)
    x_dot = f(x, u)
    jac = ca.Function("gravity_gradient_jacobian", [x, u], [ca.jacobian(x_dot, x), ca.jacobian(x_dot, u)])
    a, b = jac(np.zeros(6), np.zeros(3))
    return np.array(a.full()), np.array(b.full())


# ---------------------------------------------------------------------------
# Stability regions
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class GravityGradientStability:
    """Linear gravity-gradient stability of an LVLH-aligned body (circular orbit).

    Attributes
    ----------
    moments : ndarray, shape (3,)
        ``[I1, I2, I3]`` about roll, pitch, yaw [kg m^2].
    k1, k3 : float
        ``k1 = (I2 - I3) / I1`` (roll) and ``k3 = (I2 - I1) / I3`` (yaw) [-].
    pitch_stable : bool
        ``I1 > I3`` (pitch stiffness ``3 n^2 (I1 - I3)`` positive); for a
        realisable body with ``I1 + I3 > I2`` this is ``k1 > k3``.
    roll_yaw_stable : bool
        ``k1 k3 > 0``, ``1 + 3 k1 + k1 k3 > 0`` and ``(1 + 3 k1 + k1 k3)^2 > 16 k1 k3``
        (both roots of the quartic in ``s^2`` real and negative, distinct).
    stable : bool
        Both, i.e. all six linear eigenvalues distinct and on the imaginary axis.
    region : str
        ``"Lagrange"`` (stable with ``k1 > k3 > 0``, i.e. ``I2 > I1 > I3``:
        pitch axis major, yaw axis minor), ``"DeBra-Delp"`` (stable with
        ``k1, k3 < 0``, i.e. ``I1 > I3 > I2``) or ``"unstable"``.
    pitch_frequency_ratio : float or None
        Pitch libration frequency over the mean motion, ``sqrt(3 (I1 - I3) / I2)``;
        None unless pitch is stable.
    roll_yaw_frequency_ratios : tuple of 2 floats or None
        Roll-yaw natural frequencies over the mean motion, ascending; None
        unless roll-yaw is stable.
    mean_motion : float or None
        Orbit rate ``n`` [rad/s] if an orbit was given.
    pitch_frequency : float or None
        ``n * pitch_frequency_ratio`` [rad/s] (None without orbit or if unstable).
    roll_yaw_frequencies : tuple of 2 floats or None
        ``n * roll_yaw_frequency_ratios`` [rad/s] (None without orbit or if unstable).
    """

    moments: NDArray[np.float64]
    k1: float
    k3: float
    pitch_stable: bool
    roll_yaw_stable: bool
    stable: bool
    region: str
    pitch_frequency_ratio: float | None
    roll_yaw_frequency_ratios: tuple[float, float] | None
    mean_motion: float | None
    pitch_frequency: float | None
    roll_yaw_frequencies: tuple[float, float] | None


def gravity_gradient_stability(
    body_or_moments: RigidBody | ArrayLike, orbit: CircularOrbit | None = None
) -> GravityGradientStability:
    """Classify the gravity-gradient stability of an LVLH-aligned body.

    Conditions from the linear equations in docs/gravity_gradient.md (Wie, *Space
    Vehicle Dynamics and Control*, gravity-gradient stabilisation; Hughes,
    *Spacecraft Attitude Dynamics*, gravitational stabilisation; DeBra and
    Delp, J. Astronaut. Sci. 8, 1961): pitch needs ``I1 > I3``; roll-yaw needs
    ``k1 k3 > 0``, ``b = 1 + 3 k1 + k1 k3 > 0`` and ``b^2 > 16 k1 k3``. The
    roll-yaw frequencies are ``n sqrt((b ± sqrt(b^2 - 16 k1 k3)) / 2)``.
    All inequalities are strict: a body on a boundary is "unstable".

    Parameters
    ----------
    body_or_moments : RigidBody or array_like, shape (3,)
        A single body with diagonal inertia, or principal moments
        ``[I1, I2, I3]`` [kg m^2]; in both cases axis 1 is roll (along track),
        axis 2 pitch (orbit normal), axis 3 yaw (nadir), in the given order.
    orbit : CircularOrbit, optional
        Supplies the mean motion for frequencies in rad/s.

    Returns
    -------
    GravityGradientStability

    Raises
    ------
    ValueError
        If the body is batched or not diagonal, the moments are not three
        realisable principal moments, or ``orbit`` is not a CircularOrbit.
    """
    if isinstance(body_or_moments, RigidBody):
        body = _check_lvlh_body(body_or_moments)
    else:
        moments_in = as_float_array(body_or_moments, "body_or_moments")
        if moments_in.shape != (3,):
            raise ValueError(
                f"body_or_moments must be a RigidBody or 3 principal moments [I1, I2, I3] in kg m^2, "
                f"got shape {moments_in.shape}"
            )
        try:
            body = RigidBody(moments_in)
        except ValueError as exc:
            raise ValueError(f"body_or_moments: {exc}") from exc
    n = None if orbit is None else _check_orbit(orbit).mean_motion
    i1, i2, i3 = (float(v) for v in np.diagonal(body.inertia))
    k1 = (i2 - i3) / i1
    k3 = (i2 - i1) / i3
    pitch_stable = i1 > i3
    b = 1.0 + 3.0 * k1 + k1 * k3
    c = 4.0 * k1 * k3
    roll_yaw_stable = bool(k1 * k3 > 0.0 and b > 0.0 and b * b > 4.0 * c)
    stable = pitch_stable and roll_yaw_stable
    if stable:
        region = "Lagrange" if k1 > 0.0 else "DeBra-Delp"
    else:
        region = "unstable"
    pitch_ratio = float(np.sqrt(3.0 * (i1 - i3) / i2)) if pitch_stable else None
    ry_ratios = None
    if roll_yaw_stable:
        root = np.sqrt(b * b - 4.0 * c)
        ry_ratios = (float(np.sqrt(0.5 * (b - root))), float(np.sqrt(0.5 * (b + root))))
    return GravityGradientStability(
        moments=np.array([i1, i2, i3]),
        k1=k1,
        k3=k3,
        pitch_stable=bool(pitch_stable),
        roll_yaw_stable=roll_yaw_stable,
        stable=bool(stable),
        region=region,
        pitch_frequency_ratio=pitch_ratio,
        roll_yaw_frequency_ratios=ry_ratios,
        mean_motion=n,
        pitch_frequency=None if (n is None or pitch_ratio is None) else n * pitch_ratio,
        roll_yaw_frequencies=None if (n is None or ry_ratios is None) else (n * ry_ratios[0], n * ry_ratios[1]),
    )


# ---------------------------------------------------------------------------
# Torque callables for attitude.propagate.propagate
# ---------------------------------------------------------------------------


def gravity_gradient_torque_function(body: RigidBody, orbit: CircularOrbit) -> TorqueFunction:
    """Gravity-gradient torque as a callable ``torque(t, q_BN, omega) -> (..., 3)`` [N m].

    The position ``orbit.position_N(t)`` [m] is rotated into the body with
    ``q_BN`` and passed to :func:`gravity_gradient_torque`; ``omega`` is not
    used. ``q_BN`` is normalised first, because integrator stages evaluate
    the torque at quaternions slightly off unit norm. The orbit is prescribed: attitude does not perturb it. Usable as
    ``propagate(body, q0, omega0, t, torque=gravity_gradient_torque_function(body, orbit))``.

    Parameters
    ----------
    body : RigidBody
        The body (may be batched, matching the batch of ``q_BN``).
    orbit : CircularOrbit
        The circular orbit; times are seconds since its epoch.
    """
    body = _check_body(body)
    orbit = _check_orbit(orbit)

    def torque(t: float, q_BN: NDArray[np.float64], omega: NDArray[np.float64]) -> NDArray[np.float64]:
        # Runge-Kutta stages pass quaternions off the unit sphere by ~(n h)^2; the attitude they
        # stand for is the normalised one (normalize still rejects a zero quaternion).
        r_B = quat.rotate_inverse(quat.normalize(q_BN), orbit.position_N(t))
        return gravity_gradient_torque(body, r_B, orbit.mu)

    return torque


def constant_plus_orbital_disturbance(
    bias_Nm: ArrayLike, amplitude_Nm: ArrayLike, orbit_rate: float, phase: float = 0.0
) -> TorqueFunction:
    """Body-fixed disturbance ``bias + amplitude * sin(orbit_rate t + phase)`` as a torque callable.

    A common first model of environmental torques (solar pressure, residual
    magnetic dipole) for a nadir-pointing spacecraft: a secular part and a
    cyclic part at the orbital frequency.

    Parameters
    ----------
    bias_Nm : array_like, shape (3,)
        Constant torque in body components [N m].
    amplitude_Nm : array_like, shape (3,)
        Amplitude of the cyclic torque in body components [N m].
    orbit_rate : float
        Angular frequency of the cyclic part [rad/s], ``>= 0`` (usually
        ``orbit.mean_motion``).
    phase : float
        Phase of the cyclic part at ``t = 0`` [rad].

    Returns
    -------
    callable
        ``torque(t, q, omega)`` returning ``q.shape[:-1] + (3,)`` [N m]; ``q``
        and ``omega`` only set the batch shape.
    """
    bias = check_vector(bias_Nm, "bias_Nm", 3)
    amplitude = check_vector(amplitude_Nm, "amplitude_Nm", 3)
    for name, arr in (("bias_Nm", bias), ("amplitude_Nm", amplitude)):
        if arr.shape != (3,):
            raise ValueError(f"{name} must have shape (3,) in N m, got shape {arr.shape}")
    rate = check_positive(orbit_rate, "orbit_rate", allow_zero=True)
    if rate.ndim != 0:
        raise ValueError(f"orbit_rate must be a scalar in rad/s, got shape {rate.shape}")
    rate_f = float(rate)
    phase_f = scalar_angle(phase, "phase")
    bias = bias.copy()
    amplitude = amplitude.copy()

    def torque(t: float, q: NDArray[np.float64], omega: NDArray[np.float64]) -> NDArray[np.float64]:
        value = bias + amplitude * np.sin(rate_f * float(t) + phase_f)
        return np.broadcast_to(value, (*np.shape(q)[:-1], 3)).copy()

    return torque

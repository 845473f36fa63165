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
from attitude.rigid_body import Components, RigidBody, cross, quaternion_rate
from attitude.validation import as_float_array, check_positive, check_vector, describe

__all__ = [
    "MU_EARTH",
    "R_EARTH",
    "CircularOrbit",
    "GravityGradientStability",
    "constant_plus_orbital_disturbance",
    "gravity_gradient_stability",
    "gravity_gradient_torque",
    "gravity_gradient_torque_components",
    "gravity_gradient_torque_function",
    "linearize_gravity_gradient",
    "lvlh_relative_dynamics",
]

#: Earth's gravitational parameter [m^3/s^2], WGS-84 value including the
#: atmosphere (NIMA TR8350.2, 3rd ed., 2000, Table 3.1; same value in EGM-96).
MU_EARTH = 3.986004418e14

#: Earth's equatorial radius [m], the WGS-84 semi-major axis (NIMA TR8350.2, Table 3.1).
R_EARTH = 6378137.0

#: Attitude of the LVLH frame L relative to the rotating orbit frame O whose
#: x axis is the radial direction, y the along-track direction and z the orbit
#: normal: o1 = y_O, o2 = -z_O, o3 = -x_O, a 120 degree rotation about
#: (-1, -1, 1)/sqrt(3). Tested against the position and velocity vectors.
_Q_LO = np.array([0.5, -0.5, -0.5, 0.5])

TorqueFunction = Callable[[float, NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]


# ---------------------------------------------------------------------------
# Gravity-gradient torque
# ---------------------------------------------------------------------------


def _inertia_entries(body: RigidBody) -> list[list[Any]]:
    """Nested 3x3 list of the inertia entries (floats or batch arrays); None marks entries zero everywhere."""
    tensor = body.inertia
    rows = []
    for i in range(3):
        row = []
        for j in range(3):
            e = tensor[..., i, j]
            row.append(None if np.all(e == 0.0) else (float(e) if e.ndim == 0 else e))
        rows.append(row)
    return rows


def _check_body(body: Any, name: str = "body") -> RigidBody:
    if not isinstance(body, RigidBody):
        raise ValueError(f"{name} must be a RigidBody, got {type(body).__name__}")
    return body


def _check_mu(mu: Any) -> float:
    arr = check_positive(mu, "mu")
    if arr.ndim != 0:
        raise ValueError(f"mu must be a scalar gravitational parameter in m^3/s^2, got shape {arr.shape}")
    return float(arr)


def gravity_gradient_torque_components(body: RigidBody, r_components: Components, mu: float = MU_EARTH) -> Components:
    """Gravity-gradient torque on components, ``3 mu |r|^-5 (r x I r)`` [N m].

    Backend-neutral like :mod:`attitude.rigid_body`: only ``+ - *`` and ``**``
    are used, so the same code evaluates on numpy arrays of any batch shape
    and on casadi ``SX``/``MX`` scalars (exact derivatives).

    Parameters
    ----------
    body : RigidBody
        The body (its inertia tensor in body components [kg m^2]); a batch of
        bodies only with numpy components.
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
    body = _check_body(body)
    mu = _check_mu(mu)
    if len(r_components) != 3:
        raise ValueError(f"r_components must hold 3 components (x, y, z) in m, got {len(r_components)}")
    symbolic = any(isinstance(c, (ca.SX, ca.MX, ca.DM)) for c in r_components)
    if symbolic and body.batch_shape:
        raise ValueError("casadi evaluation needs a single body, not a batch of inertias")
    x, y, z = r_components
    r2 = x * x + y * y + z * z
    scale = 3.0 * mu * r2**-2.5
    i_r = []
    for row in _inertia_entries(body):
        acc = None
        for e, rj in zip(row, r_components):
            if e is not None:
                acc = e * rj if acc is None else acc + e * rj
        i_r.append(acc if acc is not None else 0.0 * x)
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
    mu = _check_mu(mu)
    r2 = np.sum(r_B * r_B, axis=-1)
    if np.any(r2 == 0.0):
        raise ValueError("r_B must be non-zero (the position from the planet's centre); found a zero vector")
    torque = gravity_gradient_torque_components(body, [r_B[..., i] for i in range(3)], mu)
    return np.stack(np.broadcast_arrays(*torque), axis=-1)


# ---------------------------------------------------------------------------
# Circular orbit and the LVLH frame
# ---------------------------------------------------------------------------


def _check_angle(value: Any, name: str) -> float:
    arr = as_float_array(value, name)
    if arr.ndim != 0:
        raise ValueError(f"{name} must be a scalar angle in rad, got shape {arr.shape}")
    return float(arr)


def _axis_rotation(axis: int, angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Quaternions of rotations by ``angle`` [rad] about coordinate axis 0, 1 or 2."""
    q = np.zeros((*np.shape(angle), 4))
    q[..., 0] = np.cos(0.5 * angle)
    q[..., 1 + axis] = np.sin(0.5 * angle)
    return q


@dataclass(frozen=True)
class CircularOrbit:
    """A circular Keplerian orbit and its LVLH frame.

    The orbit plane is placed by the classical angles (N is an Earth-centred
    inertial frame with z to the north pole): the ascending node lies at
    ``raan`` from the x axis about z, the plane is tilted by ``inclination``
    about the node line, and the spacecraft is at argument of latitude
    ``u(t) = argument_of_latitude + n t`` from the node.

    LVLH axes (Wie; Hughes): ``o3`` (yaw) to nadir, ``o2`` (pitch) along the
    negative orbit normal, ``o1 = o2 x o3`` (roll) along the velocity. L
    rotates relative to N with ``omega_LN_L = [0, -n, 0]``.

    Parameters
    ----------
    radius_m : float
        Orbit radius from the planet's centre [m]; must exceed
        ``central_body_radius_m``. Use :meth:`from_altitude` to give an altitude.
    inclination : float
        Inclination [rad], in ``[0, pi]`` (above ``pi/2`` is retrograde).
    raan : float
        Right ascension of the ascending node [rad].
    argument_of_latitude : float
        Angle from the ascending node to the spacecraft at ``t = 0`` [rad].
    mu : float
        Gravitational parameter [m^3/s^2].
    central_body_radius_m : float
        Radius of the planet [m], for :attr:`altitude_m` and the check that
        the orbit is above the surface; 0 allows any positive radius.

    Raises
    ------
    ValueError
        For a non-finite value, ``radius_m <= 0`` or below the planet's
        surface, an inclination outside ``[0, pi]`` or ``mu <= 0``.
    """

    radius_m: float
    inclination: float = 0.0
    raan: float = 0.0
    argument_of_latitude: float = 0.0
    mu: float = MU_EARTH
    central_body_radius_m: float = R_EARTH

    def __post_init__(self) -> None:
        radius = check_positive(self.radius_m, "radius_m")
        if radius.ndim != 0:
            raise ValueError(f"radius_m must be a scalar in m, got shape {radius.shape}")
        planet = check_positive(self.central_body_radius_m, "central_body_radius_m", allow_zero=True)
        if planet.ndim != 0:
            raise ValueError(f"central_body_radius_m must be a scalar in m, got shape {planet.shape}")
        if radius <= planet:
            raise ValueError(
                f"radius_m must exceed central_body_radius_m = {float(planet)!r} m (positive altitude), "
                f"got {float(radius)!r} m (altitude {float(radius - planet)!r} m)"
            )
        incl = _check_angle(self.inclination, "inclination")
        if not 0.0 <= incl <= np.pi:
            raise ValueError(f"inclination must be in [0, pi] rad, got {incl!r}")
        object.__setattr__(self, "radius_m", float(radius))
        object.__setattr__(self, "central_body_radius_m", float(planet))
        object.__setattr__(self, "inclination", incl)
        object.__setattr__(self, "raan", _check_angle(self.raan, "raan"))
        object.__setattr__(
            self, "argument_of_latitude", _check_angle(self.argument_of_latitude, "argument_of_latitude")
        )
        object.__setattr__(self, "mu", _check_mu(self.mu))

    @classmethod
    def from_altitude(
        cls,
        altitude_m: float,
        inclination: float = 0.0,
        raan: float = 0.0,
        argument_of_latitude: float = 0.0,
        mu: float = MU_EARTH,
        central_body_radius_m: float = R_EARTH,
    ) -> CircularOrbit:
        """Orbit at ``altitude_m`` [m] above a planet of radius ``central_body_radius_m`` [m].

        Parameters
        ----------
        altitude_m : float
            Altitude above the planet's surface [m], > 0.
        inclination : float, optional
            Orbit inclination [rad].
        raan : float, optional
            Right ascension of the ascending node [rad].
        argument_of_latitude : float, optional
            Argument of latitude at ``t = 0`` [rad].
        mu : float, optional
            Gravitational parameter of the planet [m^3/s^2] (default: Earth).
        central_body_radius_m : float, optional
            Radius of the planet [m] (default: Earth's equatorial radius).

        Raises
        ------
        ValueError
            If ``altitude_m`` is not finite and strictly positive (or for the
            checks of the class).
        """
        alt = check_positive(altitude_m, "altitude_m")
        if alt.ndim != 0:
            raise ValueError(f"altitude_m must be a scalar in m, got shape {alt.shape}")
        planet = check_positive(central_body_radius_m, "central_body_radius_m", allow_zero=True)
        return cls(float(planet + alt), inclination, raan, argument_of_latitude, mu, float(planet))

    @property
    def altitude_m(self) -> float:
        """Height above the planet's radius [m]."""
        return self.radius_m - self.central_body_radius_m

    @property
    def mean_motion(self) -> float:
        """Orbital rate ``n = sqrt(mu / r^3)`` [rad/s]."""
        return float(np.sqrt(self.mu / self.radius_m**3))

    @property
    def period(self) -> float:
        """Orbital period ``2 pi / n`` [s]."""
        return 2.0 * np.pi / self.mean_motion

    @property
    def omega_LN_L(self) -> NDArray[np.float64]:
        """Angular velocity of L relative to N in L components, ``[0, -n, 0]`` [rad/s]."""
        return np.array([0.0, -self.mean_motion, 0.0])

    def _plane_axes(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Node direction, in-plane normal to it, and orbit normal, in N."""
        co, so = np.cos(self.raan), np.sin(self.raan)
        ci, si = np.cos(self.inclination), np.sin(self.inclination)
        node = np.array([co, so, 0.0])
        in_plane = np.array([-so * ci, co * ci, si])
        normal = np.array([so * si, -co * si, ci])
        return node, in_plane, normal

    def _argument_of_latitude(self, t: ArrayLike) -> NDArray[np.float64]:
        t = as_float_array(t, "t")
        return self.argument_of_latitude + self.mean_motion * t

    def position_N(self, t: ArrayLike) -> NDArray[np.float64]:
        """Position of the spacecraft from the planet's centre in N [m].

        Parameters
        ----------
        t : array_like, shape (...)
            Time since epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)
        """
        u = self._argument_of_latitude(t)[..., None]
        node, in_plane, _ = self._plane_axes()
        return self.radius_m * (np.cos(u) * node + np.sin(u) * in_plane)

    def velocity_N(self, t: ArrayLike) -> NDArray[np.float64]:
        """Inertial velocity in N [m/s], shape ``(..., 3)`` for times ``t`` [s] of shape ``(...)``.

        Parameters
        ----------
        t : array_like
            Times [s], any shape ``(...)``.
        """
        u = self._argument_of_latitude(t)[..., None]
        node, in_plane, _ = self._plane_axes()
        return self.radius_m * self.mean_motion * (-np.sin(u) * node + np.cos(u) * in_plane)

    def q_LN(self, t: ArrayLike) -> NDArray[np.float64]:
        """Attitude of the LVLH frame relative to N (rotates L vectors into N).

        Built as ``R_z(raan) ⊗ R_x(inclination) ⊗ R_z(u(t)) ⊗ q_LO``, so it is
        smooth in ``t`` (its sign is not normalised to ``w >= 0``).

        Parameters
        ----------
        t : array_like, shape (...)
            Time since epoch [s].

        Returns
        -------
        ndarray, shape (..., 4)
            Scalar-first unit quaternion ``q_LN``.
        """
        u = self._argument_of_latitude(t)
        q_plane = quat.multiply(
            _axis_rotation(2, np.asarray(self.raan)), _axis_rotation(0, np.asarray(self.inclination))
        )
        return quat.multiply(q_plane, quat.multiply(_axis_rotation(2, u), _Q_LO))


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
    e_dot = quaternion_rate(q_BL, w)[1:]
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
    phase_f = _check_angle(phase, "phase")
    bias = bias.copy()
    amplitude = amplitude.copy()

    def torque(t: float, q: NDArray[np.float64], omega: NDArray[np.float64]) -> NDArray[np.float64]:
        value = bias + amplitude * np.sin(rate_f * float(t) + phase_f)
        return np.broadcast_to(value, (*np.shape(q)[:-1], 3)).copy()

    return torque

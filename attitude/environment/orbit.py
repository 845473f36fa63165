"""Orbits of the spacecraft about the Earth: circular, Keplerian and TLE (SGP4), their LVLH frame and Earth's constants.

Frames and angles are those of :mod:`attitude.environment.gravity_gradient`
(N Earth-centred inertial with z to the north pole, for the ephemerides TEME of
date, see :mod:`attitude.environment.epoch`; L the local-vertical
local-horizontal frame of Wie and Hughes: ``o3`` to nadir, ``o2`` the negative
orbit normal, ``o1 = o2 x o3`` along the velocity). Every orbit meets the
:class:`Orbit` protocol; :func:`lvlh_attitude` builds L from a position and a
velocity. Kepler's equation is solved by Newton's method (Vallado, 4th ed.,
Algorithm 2); the elements become a state through the perifocal frame
(Vallado, Algorithm 10, COE2RV); TLEs go through the ``sgp4`` package.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sgp4.api import SGP4_ERRORS, Satrec
from sgp4.conveniences import sat_epoch_datetime
from sgp4.earth_gravity import wgs72
from sgp4.io import twoline2rv as io_twoline2rv
from sgp4.io import verify_checksum

from attitude import quaternion as quat
from attitude.environment.epoch import DEFAULT_EPOCH, SECONDS_PER_DAY, Epoch
from attitude.validation import as_float_array, check_positive, check_vector, scalar_angle

__all__ = [
    "MU_EARTH",
    "R_EARTH",
    "CircularOrbit",
    "ConstantRate",
    "KeplerOrbit",
    "Orbit",
    "TLEOrbit",
    "check_mu",
    "lvlh_angular_acceleration",
    "lvlh_attitude",
    "solve_kepler",
    "two_body_motion",
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


def check_mu(mu: Any) -> float:
    """A gravitational parameter checked: a positive scalar [m^3/s^2].

    Parameters
    ----------
    mu : float
        Gravitational parameter of the central body [m^3/s^2].

    Returns
    -------
    float
        ``mu`` as a float.

    Raises
    ------
    ValueError
        If ``mu`` is not a positive finite scalar.
    """
    arr = check_positive(mu, "mu")
    if arr.ndim != 0:
        raise ValueError(f"mu must be a scalar gravitational parameter in m^3/s^2, got shape {arr.shape}")
    return float(arr)


# ---------------------------------------------------------------------------
# Circular orbit and the LVLH frame
# ---------------------------------------------------------------------------


def _axis_rotation(axis: int, angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Quaternions of rotations by ``angle`` [rad] about coordinate axis 0, 1 or 2."""
    q = np.zeros((*np.shape(angle), 4))
    q[..., 0] = np.cos(0.5 * angle)
    q[..., 1 + axis] = np.sin(0.5 * angle)
    return q


class ConstantRate(np.ndarray):
    """A constant angular velocity (3,) [rad/s] that is also callable as a function of time.

    :attr:`CircularOrbit.omega_LN_L` has always been the constant vector
    ``[0, -n, 0]``; the :class:`Orbit` protocol asks for ``omega_LN_L(t)``.
    This read-only array is both: used as an array it is the vector (arithmetic
    on it gives plain arrays), called with times ``t`` of shape ``(...)`` it
    returns the vector repeated, shape ``(..., 3)``.

    Parameters
    ----------
    value : array_like, shape (3,)
        The angular velocity [rad/s].
    """

    def __new__(cls, value: ArrayLike) -> ConstantRate:
        obj = np.array(value, dtype=np.float64).view(cls)
        obj.flags.writeable = False
        return obj

    def __array_wrap__(self, array: Any, context: Any = None, return_scalar: bool = False) -> Any:
        plain = np.asarray(array)
        return plain[()] if return_scalar else plain

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """The constant rate at times ``t``.

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)
            Angular velocity [rad/s], the same at every time.
        """
        t = as_float_array(t, "t")
        return np.broadcast_to(np.asarray(self), (*t.shape, 3)).copy()


def _check_epoch(epoch: Any) -> None:
    if not isinstance(epoch, Epoch):
        raise ValueError(f"epoch must be an attitude.environment.epoch.Epoch (UTC), got {epoch!r}")


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
    epoch : Epoch
        UTC instant of ``t = 0`` (default :data:`~attitude.environment.epoch.DEFAULT_EPOCH`).

    Raises
    ------
    ValueError
        For a non-finite value, ``radius_m <= 0`` or below the planet's
        surface, an inclination outside ``[0, pi]``, ``mu <= 0`` or an
        ``epoch`` that is not an :class:`~attitude.environment.epoch.Epoch`.
    """

    radius_m: float
    inclination: float = 0.0
    raan: float = 0.0
    argument_of_latitude: float = 0.0
    mu: float = MU_EARTH
    central_body_radius_m: float = R_EARTH
    epoch: Epoch = DEFAULT_EPOCH

    def __post_init__(self) -> None:
        _check_epoch(self.epoch)
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
        incl = scalar_angle(self.inclination, "inclination")
        if not 0.0 <= incl <= np.pi:
            raise ValueError(f"inclination must be in [0, pi] rad, got {incl!r}")
        object.__setattr__(self, "radius_m", float(radius))
        object.__setattr__(self, "central_body_radius_m", float(planet))
        object.__setattr__(self, "inclination", incl)
        object.__setattr__(self, "raan", scalar_angle(self.raan, "raan"))
        object.__setattr__(
            self, "argument_of_latitude", scalar_angle(self.argument_of_latitude, "argument_of_latitude")
        )
        object.__setattr__(self, "mu", check_mu(self.mu))

    @classmethod
    def from_altitude(
        cls,
        altitude_m: float,
        inclination: float = 0.0,
        raan: float = 0.0,
        argument_of_latitude: float = 0.0,
        mu: float = MU_EARTH,
        central_body_radius_m: float = R_EARTH,
        epoch: Epoch = DEFAULT_EPOCH,
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
        epoch : Epoch, optional
            UTC instant of ``t = 0``.

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
        return cls(float(planet + alt), inclination, raan, argument_of_latitude, mu, float(planet), epoch)

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
    def omega_LN_L(self) -> ConstantRate:
        """Angular velocity of L relative to N in L components, ``[0, -n, 0]`` [rad/s].

        A constant (3,) array that may also be called, ``omega_LN_L(t) -> (..., 3)``,
        as the :class:`Orbit` protocol asks (see :class:`ConstantRate`).
        """
        return ConstantRate([0.0, -self.mean_motion, 0.0])

    def describe(self) -> str:
        """One line for reports: altitude, inclination, period and epoch.

        Returns
        -------
        str
        """
        return (
            f"circular orbit, altitude {self.altitude_m / 1e3:.1f} km, inclination "
            f"{np.degrees(self.inclination):.2f} deg, period {self.period / 60:.2f} minutes, "
            f"epoch {self.epoch.describe()}"
        )

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
# What every orbit offers, and the LVLH frame from a state
# ---------------------------------------------------------------------------


@runtime_checkable
class Orbit(Protocol):
    """What the environment, the pointing laws and the reports need of an orbit.

    Times ``t`` are seconds since :attr:`epoch`, any shape ``(...)``.
    """

    @property
    def epoch(self) -> Epoch:
        """UTC instant of ``t = 0``."""
        ...

    @property
    def mu(self) -> float:
        """Gravitational parameter of the central body [m^3/s^2] (gravity gradient)."""
        ...

    @property
    def mean_motion(self) -> float:
        """Mean motion [rad/s]."""
        ...

    @property
    def period(self) -> float:
        """Mean (anomalistic) period [s]."""
        ...

    def position_N(self, t: ArrayLike) -> NDArray[np.float64]:
        """Position from the Earth's centre in N [m].

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)
        """
        ...

    def velocity_N(self, t: ArrayLike) -> NDArray[np.float64]:
        """Inertial velocity in N [m/s].

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)
        """
        ...

    def q_LN(self, t: ArrayLike) -> NDArray[np.float64]:
        """Attitude of the LVLH frame relative to N.

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 4)
        """
        ...

    def omega_LN_L(self, t: ArrayLike) -> NDArray[np.float64]:
        """Angular velocity of L relative to N in L [rad/s].

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)
        """
        ...

    def describe(self) -> str:
        """One line for reports."""
        ...


def _unit(x: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    if np.any(norm == 0.0):
        raise ValueError(f"{name} must be non-zero (a position and a velocity that are not parallel), got {x!r}")
    return x / norm


def lvlh_attitude(r_N: ArrayLike, v_N: ArrayLike) -> NDArray[np.float64]:
    """Attitude ``q_LN`` of the LVLH frame of a position and velocity (the one home of this construction).

    ``o3 = -r/|r|`` (nadir), ``o2 = -h/|h|`` with ``h = r x v`` (negative
    orbit normal), ``o1 = o2 x o3`` (along the velocity for a circular orbit).

    Parameters
    ----------
    r_N : array_like, shape (..., 3)
        Position from the Earth's centre in N [m].
    v_N : array_like, shape (..., 3)
        Inertial velocity in N [m/s].

    Returns
    -------
    ndarray, shape (..., 4)
        Scalar-first unit quaternion ``q_LN`` (rotates L vectors into N),
        scalar part ``>= 0``.

    Raises
    ------
    ValueError
        If the shapes are not ``(..., 3)``, or ``r_N`` is zero or parallel to ``v_N``.
    """
    r = check_vector(r_N, "r_N", 3)
    v = check_vector(v_N, "v_N", 3)
    o3 = -_unit(r, "r_N")
    o2 = -_unit(np.cross(r, v), "r_N x v_N")
    o1 = np.cross(o2, o3)
    c_NL = np.stack([o1, o2, o3], axis=-1)  # columns: the L axes in N
    return quat.from_dcm(np.swapaxes(c_NL, -1, -2))


def lvlh_angular_acceleration(r_N: ArrayLike, v_N: ArrayLike) -> NDArray[np.float64]:
    """Angular acceleration of the LVLH frame, ``omega_dot_LN_L = [0, 2 |h| (r . v) / |r|^4, 0]`` [rad/s^2].

    The time derivative of ``omega_LN_L = [0, -|h| / |r|^2, 0]`` under
    two-body motion (``h = r x v`` constant, ``d|r|/dt = r . v / |r|``):
    zero on a circular orbit, of order ``e n^2`` on an orbit of eccentricity
    ``e``. L turns about its fixed ``o2`` axis only, so the derivative in L
    and in N agree. For a TLE it is the osculating state's, without the slow
    turn of the plane (as :meth:`TLEOrbit.omega_LN_L`).

    Parameters
    ----------
    r_N : array_like, shape (..., 3)
        Position from the Earth's centre in N [m].
    v_N : array_like, shape (..., 3)
        Inertial velocity in N [m/s].

    Returns
    -------
    ndarray, shape (..., 3)
        ``omega_dot_LN_L`` [rad/s^2].

    Raises
    ------
    ValueError
        If the shapes are not ``(..., 3)`` or ``r_N`` is zero.
    """
    r = check_vector(r_N, "r_N", 3)
    v = check_vector(v_N, "v_N", 3)
    r2 = np.sum(r * r, axis=-1)
    if np.any(r2 == 0.0):
        raise ValueError(f"r_N must be non-zero (a position from the Earth's centre), got {r!r}")
    h = np.linalg.norm(np.cross(r, v), axis=-1)
    out = np.zeros(np.broadcast_shapes(r.shape, v.shape))
    out[..., 1] = 2.0 * h * np.sum(r * v, axis=-1) / (r2 * r2)
    return out


def two_body_motion(r_N: ArrayLike, v_N: ArrayLike, mu: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Acceleration ``a = -mu r / |r|^3`` and its rate (the jerk) of two-body motion.

    ``da/dt = -mu (v / |r|^3 - 3 (r . v) r / |r|^5)`` (Newton's two-body
    equation, differentiated once). Exact for :class:`CircularOrbit` and :class:`KeplerOrbit`
    with their own ``mu``; for a TLE it leaves out what SGP4 adds to the
    central term (J2 and the other zonal terms, drag: about 1e-3 of ``a`` in
    low orbit).

    Parameters
    ----------
    r_N : array_like, shape (..., 3)
        Position from the central body's centre in N [m], non-zero.
    v_N : array_like, shape (..., 3)
        Inertial velocity in N [m/s].
    mu : float
        Gravitational parameter [m^3/s^2].

    Returns
    -------
    a_N : ndarray, shape (..., 3)
        Acceleration [m/s^2].
    jerk_N : ndarray, shape (..., 3)
        Its time derivative [m/s^3].

    Raises
    ------
    ValueError
        If the shapes are not ``(..., 3)``, ``r_N`` is zero or ``mu`` is not positive.
    """
    r = check_vector(r_N, "r_N", 3)
    v = check_vector(v_N, "v_N", 3)
    mu = check_mu(mu)
    radius = np.linalg.norm(r, axis=-1, keepdims=True)
    if np.any(radius == 0.0):
        raise ValueError(f"r_N must be non-zero (a position from the central body's centre), got {r!r}")
    a = -mu * r / radius**3
    jerk = -mu * (v / radius**3 - 3.0 * np.sum(r * v, axis=-1, keepdims=True) * r / radius**5)
    return a, jerk


def _omega_from_state(r: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``[0, -|r x v| / |r|^2, 0]``: the rate of L about its ``o2`` axis for a Keplerian state."""
    rate = np.linalg.norm(np.cross(r, v), axis=-1) / np.sum(r * r, axis=-1)
    out = np.zeros((*rate.shape, 3))
    out[..., 1] = -rate
    return out


# ---------------------------------------------------------------------------
# Keplerian (two-body) orbit
# ---------------------------------------------------------------------------

#: Newton's iteration stops when every correction is below this [rad]: a few
#: ulps of pi, i.e. machine precision on an eccentric anomaly in (-pi, pi].
_KEPLER_TOLERANCE = 4.0 * np.finfo(np.float64).eps * np.pi
_KEPLER_MAX_ITERATIONS = 50


def solve_kepler(mean_anomaly: ArrayLike, eccentricity: float) -> NDArray[np.float64]:
    """Eccentric anomaly ``E`` of Kepler's equation ``M = E - e sin E``, to machine precision.

    Newton's method (Vallado, 4th ed., Algorithm 2, KepEqtnE) from Danby's
    start ``E0 = M + 0.85 e sign(sin M)``, vectorised, with ``M`` reduced to
    ``(-pi, pi]`` first; ``E`` is returned in the same revolution as ``M``.

    Parameters
    ----------
    mean_anomaly : array_like, shape (...)
        Mean anomaly ``M`` [rad].
    eccentricity : float
        Eccentricity ``e`` in ``[0, 1)``.

    Returns
    -------
    ndarray, shape (...)
        Eccentric anomaly [rad].

    Raises
    ------
    ValueError
        If ``eccentricity`` is outside ``[0, 1)``.
    RuntimeError
        If Newton's method has not converged in 50 iterations (never seen for
        ``e < 1``; raised rather than returning an inaccurate value).
    """
    e = _check_eccentricity(eccentricity)
    m = as_float_array(mean_anomaly, "mean_anomaly")
    turns = np.round(m / (2.0 * np.pi))
    m_reduced = m - 2.0 * np.pi * turns
    big_e = m_reduced + 0.85 * e * np.sign(np.sin(m_reduced))
    for _ in range(_KEPLER_MAX_ITERATIONS):
        step = (big_e - e * np.sin(big_e) - m_reduced) / (1.0 - e * np.cos(big_e))
        big_e = big_e - step
        if np.all(np.abs(step) <= _KEPLER_TOLERANCE):
            return big_e + 2.0 * np.pi * turns
    raise RuntimeError(
        f"Kepler's equation did not converge in {_KEPLER_MAX_ITERATIONS} Newton iterations "
        f"(eccentricity {e!r}, largest last correction {float(np.max(np.abs(step)))!r} rad)"
    )


def _check_eccentricity(eccentricity: Any) -> float:
    e = as_float_array(eccentricity, "eccentricity")
    if e.ndim != 0:
        raise ValueError(f"eccentricity must be a scalar, got shape {e.shape}")
    if not 0.0 <= float(e) < 1.0:
        raise ValueError(f"eccentricity must be in [0, 1) for a closed orbit, got {float(e)!r}")
    return float(e)


class _StateOrbit:
    """Position, velocity and the LVLH frame of an orbit that computes its state ``(r_N, v_N)`` in ``_state(t)``.

    The one home of these members for :class:`KeplerOrbit` and :class:`TLEOrbit`
    (the circular orbit builds its LVLH frame by rotations instead).
    """

    def _state(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        raise NotImplementedError

    def position_N(self, t: ArrayLike) -> NDArray[np.float64]:
        """Position from the Earth's centre in N [m] (for a TLE: SGP4's, in TEME).

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)

        Raises
        ------
        ValueError
            For a TLE, if sgp4 reports an error at one of the times (e.g. decayed).
        """
        return self._state(t)[0]

    def velocity_N(self, t: ArrayLike) -> NDArray[np.float64]:
        """Inertial velocity in N [m/s] (for a TLE: SGP4's, in TEME).

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)
        """
        return self._state(t)[1]

    def q_LN(self, t: ArrayLike) -> NDArray[np.float64]:
        """Attitude of the LVLH frame relative to N, from the state (:func:`lvlh_attitude`).

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 4)
            Scalar-first ``q_LN``, scalar part ``>= 0``.
        """
        return lvlh_attitude(*self._state(t))

    def omega_LN_L(self, t: ArrayLike) -> NDArray[np.float64]:
        """Angular velocity of L relative to N in L: ``[0, -|r x v| / |r|^2, 0]`` [rad/s].

        Two-body motion keeps the orbit plane fixed, so L turns about ``o2``
        only, at the rate of the true anomaly (for a TLE the osculating state's,
        without the slow J2 turn of the plane).

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (..., 3)
        """
        return _omega_from_state(*self._state(t))


@dataclass(frozen=True)
class KeplerOrbit(_StateOrbit):
    """A two-body Keplerian orbit from its classical elements, with its LVLH frame.

    The plane is placed as in :class:`CircularOrbit` (``raan`` about z, then
    ``inclination`` about the node line); the perigee lies at
    ``argument_of_perigee`` from the node, and the mean anomaly grows as
    ``M(t) = mean_anomaly + n t``. With ``eccentricity = 0`` and
    ``argument_of_perigee = 0`` the orbit is :class:`CircularOrbit` with
    ``argument_of_latitude = mean_anomaly``.

    Parameters
    ----------
    semi_major_axis_m : float
        Semi-major axis ``a`` [m].
    eccentricity : float
        Eccentricity ``e`` in ``[0, 1)``.
    inclination : float
        Inclination [rad], in ``[0, pi]``.
    raan : float
        Right ascension of the ascending node [rad].
    argument_of_perigee : float
        Angle from the ascending node to the perigee [rad].
    mean_anomaly : float
        Mean anomaly at ``t = 0`` [rad].
    epoch : Epoch
        UTC instant of ``t = 0``.
    mu : float
        Gravitational parameter [m^3/s^2].
    central_body_radius_m : float
        Radius of the planet [m]; the perigee must be above it.

    Raises
    ------
    ValueError
        For a non-finite value, ``semi_major_axis_m <= 0``, an eccentricity
        outside ``[0, 1)``, a perigee at or below the surface, an inclination
        outside ``[0, pi]``, ``mu <= 0`` or an ``epoch`` that is not an ``Epoch``.
    """

    semi_major_axis_m: float
    eccentricity: float = 0.0
    inclination: float = 0.0
    raan: float = 0.0
    argument_of_perigee: float = 0.0
    mean_anomaly: float = 0.0
    epoch: Epoch = DEFAULT_EPOCH
    mu: float = MU_EARTH
    central_body_radius_m: float = R_EARTH

    def __post_init__(self) -> None:
        _check_epoch(self.epoch)
        a = check_positive(self.semi_major_axis_m, "semi_major_axis_m")
        if a.ndim != 0:
            raise ValueError(f"semi_major_axis_m must be a scalar in m, got shape {a.shape}")
        e = _check_eccentricity(self.eccentricity)
        planet = check_positive(self.central_body_radius_m, "central_body_radius_m", allow_zero=True)
        if planet.ndim != 0:
            raise ValueError(f"central_body_radius_m must be a scalar in m, got shape {planet.shape}")
        perigee = float(a) * (1.0 - e)
        if perigee <= float(planet):
            raise ValueError(
                f"semi_major_axis_m and eccentricity must put the perigee above the surface "
                f"(central_body_radius_m = {float(planet)!r} m), got semi_major_axis_m = {float(a)!r} m, "
                f"eccentricity = {e!r}: perigee altitude {perigee - float(planet)!r} m"
            )
        incl = scalar_angle(self.inclination, "inclination")
        if not 0.0 <= incl <= np.pi:
            raise ValueError(f"inclination must be in [0, pi] rad, got {incl!r}")
        object.__setattr__(self, "semi_major_axis_m", float(a))
        object.__setattr__(self, "eccentricity", e)
        object.__setattr__(self, "central_body_radius_m", float(planet))
        object.__setattr__(self, "inclination", incl)
        for name in ("raan", "argument_of_perigee", "mean_anomaly"):
            object.__setattr__(self, name, scalar_angle(getattr(self, name), name))
        object.__setattr__(self, "mu", check_mu(self.mu))

    @classmethod
    def from_altitudes(
        cls,
        perigee_altitude_m: float,
        apogee_altitude_m: float,
        inclination: float = 0.0,
        raan: float = 0.0,
        argument_of_perigee: float = 0.0,
        mean_anomaly: float = 0.0,
        epoch: Epoch = DEFAULT_EPOCH,
        mu: float = MU_EARTH,
        central_body_radius_m: float = R_EARTH,
    ) -> KeplerOrbit:
        """Orbit with its perigee and apogee at the given altitudes above the planet's radius.

        Parameters
        ----------
        perigee_altitude_m : float
            Perigee altitude [m], > 0.
        apogee_altitude_m : float
            Apogee altitude [m], ``>= perigee_altitude_m``.
        inclination : float, optional
            Inclination [rad].
        raan : float, optional
            Right ascension of the ascending node [rad].
        argument_of_perigee : float, optional
            Argument of perigee [rad].
        mean_anomaly : float, optional
            Mean anomaly at ``t = 0`` [rad].
        epoch : Epoch, optional
            UTC instant of ``t = 0``.
        mu : float, optional
            Gravitational parameter [m^3/s^2].
        central_body_radius_m : float, optional
            Radius of the planet [m].

        Returns
        -------
        KeplerOrbit

        Raises
        ------
        ValueError
            If an altitude is not positive or the apogee is below the perigee.
        """
        hp = float(check_positive(perigee_altitude_m, "perigee_altitude_m"))
        ha = float(check_positive(apogee_altitude_m, "apogee_altitude_m"))
        if ha < hp:
            raise ValueError(f"apogee_altitude_m must be >= perigee_altitude_m = {hp!r} m, got {ha!r} m")
        planet = float(check_positive(central_body_radius_m, "central_body_radius_m", allow_zero=True))
        rp, ra = planet + hp, planet + ha
        return cls(
            0.5 * (rp + ra), (ra - rp) / (ra + rp), inclination, raan, argument_of_perigee, mean_anomaly,
            epoch, mu, planet,
        )  # fmt: skip

    @property
    def mean_motion(self) -> float:
        """Mean motion ``n = sqrt(mu / a^3)`` [rad/s]."""
        return float(np.sqrt(self.mu / self.semi_major_axis_m**3))

    @property
    def period(self) -> float:
        """Orbital period ``2 pi / n`` [s]."""
        return 2.0 * np.pi / self.mean_motion

    @property
    def perigee_altitude_m(self) -> float:
        """Perigee height above the planet's radius [m]."""
        return self.semi_major_axis_m * (1.0 - self.eccentricity) - self.central_body_radius_m

    @property
    def apogee_altitude_m(self) -> float:
        """Apogee height above the planet's radius [m]."""
        return self.semi_major_axis_m * (1.0 + self.eccentricity) - self.central_body_radius_m

    def _perifocal_axes(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Unit vectors to the perigee (P) and 90 deg ahead of it in the plane (Q), in N."""
        co, so = np.cos(self.raan), np.sin(self.raan)
        ci, si = np.cos(self.inclination), np.sin(self.inclination)
        node = np.array([co, so, 0.0])
        in_plane = np.array([-so * ci, co * ci, si])
        cw, sw = np.cos(self.argument_of_perigee), np.sin(self.argument_of_perigee)
        return cw * node + sw * in_plane, -sw * node + cw * in_plane

    def _state(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        t = as_float_array(t, "t")
        e, a = self.eccentricity, self.semi_major_axis_m
        big_e = solve_kepler(self.mean_anomaly + self.mean_motion * t, e)
        cos_e, sin_e = np.cos(big_e)[..., None], np.sin(big_e)[..., None]
        root = np.sqrt(1.0 - e * e)
        p_axis, q_axis = self._perifocal_axes()
        r = a * ((cos_e - e) * p_axis + root * sin_e * q_axis)
        speed_scale = np.sqrt(self.mu * a) / (a * (1.0 - e * cos_e))
        v = speed_scale * (-sin_e * p_axis + root * cos_e * q_axis)
        return r, v

    def describe(self) -> str:
        """One line for reports: perigee and apogee altitudes, inclination, period, epoch.

        Returns
        -------
        str
        """
        return (
            f"Keplerian orbit, perigee {self.perigee_altitude_m / 1e3:.1f} km, apogee "
            f"{self.apogee_altitude_m / 1e3:.1f} km, inclination {np.degrees(self.inclination):.2f} deg, "
            f"period {self.period / 60:.2f} minutes, epoch {self.epoch.describe()}"
        )


# ---------------------------------------------------------------------------
# Two-line elements through sgp4
# ---------------------------------------------------------------------------

_KM = 1000.0
_SECONDS_PER_MINUTE = 60.0


@dataclass(frozen=True)
class TLEOrbit(_StateOrbit):
    """An orbit from a NORAD two-line element set, propagated by SGP4/SDP4 (the ``sgp4`` package).

    Positions and velocities are SGP4's, in TEME of date (the frame N of the
    environment), converted from km and km/s to m and m/s. The epoch is the
    TLE's (rounded by ``sgp4.conveniences.sat_epoch_datetime`` to the
    microsecond; ``t`` is minutes since the TLE epoch times 60 exactly). The
    LVLH rate uses the osculating state, ``[0, -|r x v|/|r|^2, 0]``: it leaves
    out the slow turn of the plane (J2 nodal regression, about 1e-3 of ``n``).

    Parameters
    ----------
    line1 : str
        First line of the TLE (``"1 ..."``).
    line2 : str
        Second line of the TLE (``"2 ..."``).

    Raises
    ------
    ValueError
        If the lines do not parse as a TLE (naming ``line1``/``line2`` and
        sgp4's reason) or sgp4 refuses the elements at the epoch.
    """

    line1: str
    line2: str
    _satrec: Any = field(init=False, repr=False, compare=False)
    _epoch: Epoch = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in ("line1", "line2"):
            value = getattr(self, name)
            if not isinstance(value, str):
                raise ValueError(f"{name} must be a str (one line of a TLE), got {value!r}")
        if not self.line1.lstrip().startswith("1 "):
            raise ValueError(f"line1 must be the first TLE line, starting with '1 ', got {self.line1!r}")
        if not self.line2.lstrip().startswith("2 "):
            raise ValueError(f"line2 must be the second TLE line, starting with '2 ', got {self.line2!r}")
        for name in ("line1", "line2"):
            try:
                verify_checksum(getattr(self, name))
            except ValueError as exc:
                raise ValueError(f"{name} fails its TLE checksum: {exc}") from exc
        try:
            # sgp4's pure-Python reader checks the column format that the
            # compiled Satrec.twoline2rv does not; its record is not used.
            io_twoline2rv(self.line1, self.line2, wgs72)
            satrec = Satrec.twoline2rv(self.line1, self.line2)
        except (ValueError, IndexError) as exc:
            name = "line2" if "for line 2" in str(exc) else "line1" if "for line 1" in str(exc) else "line1/line2"
            raise ValueError(f"{name} does not parse as a TLE line: {exc}") from exc
        if satrec.error:
            raise ValueError(
                f"line1/line2: sgp4 refuses these elements at the epoch (error {satrec.error}: "
                f"{SGP4_ERRORS.get(satrec.error, 'unknown')})"
            )
        object.__setattr__(self, "_satrec", satrec)
        object.__setattr__(self, "_epoch", Epoch(sat_epoch_datetime(satrec)))

    @property
    def epoch(self) -> Epoch:
        """The TLE's epoch (UTC), the ``t = 0`` of :meth:`position_N`."""
        return self._epoch

    def __reduce__(self) -> tuple:
        # sgp4's compiled Satrec does not pickle: rebuild from the two lines (Monte Carlo worker processes).
        return (type(self), (self.line1, self.line2))

    @property
    def mu(self) -> float:
        """Earth's gravitational parameter for the gravity gradient [m^3/s^2] (WGS-84; SGP4 uses WGS-72's inside)."""
        return MU_EARTH

    @property
    def mean_motion(self) -> float:
        """SGP4's mean motion (Kozai, from the TLE) [rad/s]."""
        return float(self._satrec.no_kozai) / _SECONDS_PER_MINUTE

    @property
    def period(self) -> float:
        """Mean period ``2 pi / n`` [s]."""
        return 2.0 * np.pi / self.mean_motion

    def _state(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        t = as_float_array(t, "t")
        flat = t.reshape(-1)
        jd = np.full(flat.shape, self._satrec.jdsatepoch)
        fraction = self._satrec.jdsatepochF + flat / SECONDS_PER_DAY
        errors, r, v = self._satrec.sgp4_array(jd, fraction)
        if np.any(errors):
            k = int(np.flatnonzero(errors)[0])
            code = int(errors[k])
            raise ValueError(
                f"t = {float(flat[k])!r} s after the TLE epoch: sgp4 error {code}: {SGP4_ERRORS.get(code, 'unknown')}"
            )
        return r.reshape(*t.shape, 3) * _KM, v.reshape(*t.shape, 3) * _KM

    def describe(self) -> str:
        """One line for reports: catalogue number, epoch, inclination, eccentricity, period.

        Returns
        -------
        str
        """
        s = self._satrec
        return (
            f"TLE orbit (SGP4), satellite {s.satnum_str}, epoch {self.epoch.describe()}, inclination "
            f"{np.degrees(s.inclo):.2f} deg, eccentricity {s.ecco:.5f}, period {self.period / 60:.2f} minutes"
        )

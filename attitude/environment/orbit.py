"""Orbits of the spacecraft about the Earth: the circular Keplerian orbit, its LVLH frame and Earth's constants.

Frames and angles are those of :mod:`attitude.environment.gravity_gradient`
(N Earth-centred inertial with z to the north pole; L the local-vertical
local-horizontal frame of Wie and Hughes: ``o3`` to nadir, ``o2`` the negative
orbit normal, ``o1 = o2 x o3`` along the velocity).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.validation import as_float_array, check_positive, scalar_angle

__all__ = ["MU_EARTH", "R_EARTH", "CircularOrbit", "check_mu"]

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

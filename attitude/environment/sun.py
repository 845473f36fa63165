"""The Sun seen from the Earth: a low-precision ephemeris and the Earth's shadow at the spacecraft.

Ephemeris: the low-precision formulae of The Astronomical Almanac (section C,
"Low precision formulas for the Sun", 0.01 deg from 1950 to 2050) with the
coefficients of Vallado, *Fundamentals of Astrodynamics and Applications*,
4th ed., 2013, Algorithm 29 (SUN). The result is the apparent Sun (annual
aberration is folded into the mean longitude) on the mean equator and equinox
of date; the frame N of the environment is TEME (true equator, mean equinox),
which differs by the nutation of the equator (< 0.005 deg), well inside the
formula's 0.01 deg. The time argument is taken as UTC for both UT1 and TDB
(``TT - UTC`` of about 69 s moves the Sun by 0.0008 deg).

Shadow: the Earth is a sphere of radius :data:`~attitude.environment.orbit.R_EARTH`.
``"cylindrical"``: the spacecraft is in shadow (0) when it is behind the
Earth, ``r.s < 0``, and within ``R_E`` of the Earth-Sun line. ``"conical"``:
the visible fraction of the solar disk occulted by the Earth's disk
(Montenbruck and Gill, *Satellite Orbits*, 2000, sec. 3.4.2, eqs. 3.85-3.87),
1 in full sun, 0 in the umbra, between them in the penumbra.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.environment.epoch import SECONDS_PER_DAY
from attitude.environment.orbit import R_EARTH
from attitude.validation import as_float_array, check_vector

__all__ = ["AU_M", "SUN_RADIUS_M", "illumination_fraction", "sun_direction_N", "sun_motion_N", "sun_position_N"]

#: The astronomical unit [m] (IAU 2012 Resolution B2, exact).
AU_M = 149_597_870_700.0

#: Nominal solar radius [m] (IAU 2015 Resolution B3).
SUN_RADIUS_M = 6.957e8

_J2000_JD = 2451545.0
_DAYS_PER_CENTURY = 36525.0
_SHADOW_MODELS = ("conical", "cylindrical")


def _ecliptic(julian_date: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Ecliptic longitude [rad], distance [AU] and obliquity [rad] (Vallado Algorithm 29)."""
    jd = as_float_array(julian_date, "julian_date")
    centuries = (jd - _J2000_JD) / _DAYS_PER_CENTURY
    mean_longitude = np.radians(280.460 + 36000.771 * centuries)
    mean_anomaly = np.radians(357.5291092 + 35999.05034 * centuries)
    longitude = mean_longitude + np.radians(
        1.914666471 * np.sin(mean_anomaly) + 0.019994643 * np.sin(2.0 * mean_anomaly)
    )
    distance_au = 1.000140612 - 0.016708617 * np.cos(mean_anomaly) - 0.000139589 * np.cos(2.0 * mean_anomaly)
    obliquity = np.radians(23.439291 - 0.0130042 * centuries)
    return longitude, distance_au, obliquity


def sun_position_N(julian_date: ArrayLike) -> NDArray[np.float64]:
    """Position of the Sun from the Earth's centre in N [m] (Astronomical Almanac low-precision formulae).

    Accuracy 0.01 deg in direction from 1950 to 2050 (the Almanac's figure;
    see the module docstring for the frame and time scale).

    Parameters
    ----------
    julian_date : array_like, shape (...)
        UTC Julian date [days] (:meth:`attitude.environment.epoch.Epoch.julian_date`).

    Returns
    -------
    ndarray, shape (..., 3)
        Earth-Sun vector [m].

    Examples
    --------
    >>> r = sun_position_N(2451545.0)  # J2000.0: the Sun near longitude 280 deg
    >>> bool(abs(np.linalg.norm(r) / AU_M - 0.9833) < 1e-3)
    True
    """
    longitude, distance_au, obliquity = _ecliptic(julian_date)
    c_lon, s_lon = np.cos(longitude), np.sin(longitude)
    unit = np.stack([c_lon, np.cos(obliquity) * s_lon, np.sin(obliquity) * s_lon], axis=-1)
    return (distance_au * AU_M)[..., None] * unit


def sun_motion_N(julian_date: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Position of the Sun [m] and its first two time derivatives [m/s, m/s^2] in N.

    The exact derivatives of :func:`sun_position_N`'s formulae (chain rule
    through the ecliptic longitude, distance and obliquity, each a function
    of the Julian centuries ``T``), so a pointing reference built on the Sun
    has rates consistent with its attitude. The apparent motion is about
    1 deg/day (2e-7 rad/s).

    Parameters
    ----------
    julian_date : array_like, shape (...)
        UTC Julian date [days].

    Returns
    -------
    position : ndarray, shape (..., 3)
        Earth-Sun vector [m] (:func:`sun_position_N`).
    velocity : ndarray, shape (..., 3)
        Its rate [m/s].
    acceleration : ndarray, shape (..., 3)
        Its second derivative [m/s^2].
    """
    jd = as_float_array(julian_date, "julian_date")
    centuries = (jd - _J2000_JD) / _DAYS_PER_CENTURY
    anomaly = np.radians(357.5291092 + 35999.05034 * centuries)
    anomaly_rate = np.radians(35999.05034)  # [rad per century], as the two below
    longitude_rate_mean = np.radians(36000.771)
    obliquity_rate = np.radians(-0.0130042)
    longitude, distance_au, obliquity = _ecliptic(jd)
    s1, c1, s2, c2 = np.sin(anomaly), np.cos(anomaly), np.sin(2.0 * anomaly), np.cos(2.0 * anomaly)
    lam1 = longitude_rate_mean + np.radians(1.914666471 * c1 + 2.0 * 0.019994643 * c2) * anomaly_rate
    lam2 = -np.radians(1.914666471 * s1 + 4.0 * 0.019994643 * s2) * anomaly_rate**2
    d1 = (0.016708617 * s1 + 2.0 * 0.000139589 * s2) * anomaly_rate
    d2 = (0.016708617 * c1 + 4.0 * 0.000139589 * c2) * anomaly_rate**2
    sl, cl, se, ce = np.sin(longitude), np.cos(longitude), np.sin(obliquity), np.cos(obliquity)
    e1 = obliquity_rate
    u0 = np.stack([cl, ce * sl, se * sl], axis=-1)
    u1 = np.stack([-sl * lam1, -se * e1 * sl + ce * cl * lam1, ce * e1 * sl + se * cl * lam1], axis=-1)
    u2 = np.stack(
        [
            -cl * lam1**2 - sl * lam2,
            -ce * e1**2 * sl - 2.0 * se * e1 * cl * lam1 - ce * sl * lam1**2 + ce * cl * lam2,
            -se * e1**2 * sl + 2.0 * ce * e1 * cl * lam1 - se * sl * lam1**2 + se * cl * lam2,
        ],
        axis=-1,
    )
    d0, d1, d2 = (x[..., None] for x in (distance_au, d1, d2))
    per_second = 1.0 / (_DAYS_PER_CENTURY * SECONDS_PER_DAY)
    position = AU_M * d0 * u0
    velocity = AU_M * (d1 * u0 + d0 * u1) * per_second
    acceleration = AU_M * (d2 * u0 + 2.0 * d1 * u1 + d0 * u2) * per_second**2
    return position, velocity, acceleration


def sun_direction_N(julian_date: ArrayLike) -> NDArray[np.float64]:
    """Unit vector from the Earth's centre to the Sun in N.

    Parameters
    ----------
    julian_date : array_like, shape (...)
        UTC Julian date [days].

    Returns
    -------
    ndarray, shape (..., 3)
        Unit vector (see :func:`sun_position_N`).
    """
    r = sun_position_N(julian_date)
    return r / np.linalg.norm(r, axis=-1, keepdims=True)


def illumination_fraction(r_N: ArrayLike, sun_N: ArrayLike, model: str = "conical") -> NDArray[np.float64]:
    """Fraction of the solar disk seen from the spacecraft: 1 in full sun, 0 in the Earth's umbra.

    Parameters
    ----------
    r_N : array_like, shape (..., 3)
        Spacecraft position from the Earth's centre [m], outside the Earth.
    sun_N : array_like, shape (..., 3)
        Sun position from the Earth's centre [m] (:func:`sun_position_N`), in
        the same frame; broadcast against ``r_N``.
    model : {"conical", "cylindrical"}
        ``"cylindrical"``: 0 or 1, shadow where ``r.s < 0`` and the distance to
        the Earth-Sun line is below ``R_E``. ``"conical"``: the occulted
        fraction of the solar disk from the apparent radii of the Sun and the
        Earth and their separation (Montenbruck and Gill 2000, eqs. 3.85-3.87).

    Returns
    -------
    ndarray, shape (...)
        Illumination fraction in ``[0, 1]``.

    Raises
    ------
    ValueError
        For an unknown ``model``, vectors not of shape ``(..., 3)``, or a
        spacecraft at or below the Earth's surface.
    """
    if model not in _SHADOW_MODELS:
        raise ValueError(f"model must be one of {_SHADOW_MODELS}, got {model!r}")
    r = check_vector(r_N, "r_N", 3)
    sun = check_vector(sun_N, "sun_N", 3)
    r_norm = np.linalg.norm(r, axis=-1)
    if np.any(r_norm <= R_EARTH):
        raise ValueError(
            f"r_N must be outside the Earth (|r_N| > R_EARTH = {R_EARTH} m), got |r_N| = {float(np.min(r_norm))!r} m"
        )
    if model == "cylindrical":
        s = sun / np.linalg.norm(sun, axis=-1, keepdims=True)
        along = np.sum(r * s, axis=-1)
        across = np.linalg.norm(r - along[..., None] * s, axis=-1)
        return np.where((along < 0.0) & (across < R_EARTH), 0.0, 1.0)
    to_sun = sun - r
    to_sun_norm = np.linalg.norm(to_sun, axis=-1)
    a = np.arcsin(SUN_RADIUS_M / to_sun_norm)  # apparent radius of the Sun (eq. 3.85)
    b = np.arcsin(R_EARTH / r_norm)  # apparent radius of the Earth (eq. 3.86)
    cos_c = -np.sum(r * to_sun, axis=-1) / (r_norm * to_sun_norm)
    c = np.arccos(np.clip(cos_c, -1.0, 1.0))  # separation of the two centres (eq. 3.87)
    # Area of overlap of two disks of radii a and b at distance c (M&G, after eq. 3.87).
    c_safe = np.where(c > 0.0, c, 1.0)
    x = (c_safe**2 + a**2 - b**2) / (2.0 * c_safe)
    y = np.sqrt(np.clip(a**2 - x**2, 0.0, None))
    overlap = (
        a**2 * np.arccos(np.clip(x / a, -1.0, 1.0))
        + b**2 * np.arccos(np.clip((c_safe - x) / b, -1.0, 1.0))
        - c_safe * y
    )
    fraction = 1.0 - overlap / (np.pi * a**2)
    fraction = np.where(c >= a + b, 1.0, fraction)  # disks apart: full sun
    fraction = np.where(c <= b - a, 0.0, fraction)  # solar disk inside the Earth's: umbra
    fraction = np.where(c <= a - b, 1.0 - (b / a) ** 2, fraction)  # Earth's disk inside the Sun's: annular
    return np.clip(fraction, 0.0, 1.0)

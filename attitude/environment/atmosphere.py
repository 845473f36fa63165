"""Air density at the spacecraft: the exponential model of Vallado's Table 8-4 and, optionally, NRLMSIS.

Both models offer ``density(r_N, epoch, t) -> (...)`` kg/m^3 and ``describe()``.

* :class:`ExponentialAtmosphere`: piecewise exponential in the altitude ``h``
  above the WGS-84 ellipsoid, ``rho = rho0 exp(-(h - h0) / H)`` with the base
  altitude ``h0``, nominal density ``rho0`` and scale height ``H`` of the band
  ``h0 <= h < h1`` (Vallado, *Fundamentals of Astrodynamics and Applications*,
  4th ed., 2013, Table 8-4, from the U.S. Standard Atmosphere 1976 below
  25 km and CIRA-72 above, mean solar activity). The 28 rows were checked
  against a second copy, ``src/exponential/constants.jl`` of
  SatelliteToolboxAtmosphericModels.jl (JuliaSpace, citing the same table):
  identical. The scale heights are fitted between consecutive rows, so the
  density is continuous at the band edges to the table's four significant
  figures (jumps below 1e-4), except at 25 km where the 0-25 km band misses
  the 25 km row by 0.14 %; the tests measure it.
  Above 1000 km the last band (h0 = 1000 km, H = 268 km) is extended, which
  only bounds the density (it is 10^-15 kg/m^3 and below).
* :class:`NRLMSIS`: the NRLMSIS 2.1 empirical model (Emmert et al., Earth and
  Space Science 8, 2021) through the optional ``pymsis`` package, with
  constant solar and geomagnetic indices.

Geodetic coordinates come from :func:`geodetic_coordinates`: N is turned into
the Earth-fixed frame by the Greenwich mean sidereal time (``epoch.gmst(t)``;
see :mod:`attitude.environment.magnetic_field` for the frame conventions) and
the geocentric position into geodetic latitude and height with
``ppigrf.ppigrf.geoc2geod`` (N. Olsen's series on the WGS-84 ellipsoid,
sub-millimetre at satellite altitudes).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.environment.epoch import earth_fixed_positions, utc_naive
from attitude.validation import as_float_array, check_vector, describe, positive_scalar

__all__ = ["NRLMSIS", "ExponentialAtmosphere", "geodetic_coordinates"]

#: Vallado (2013), Table 8-4: base altitude [km], nominal density [kg/m^3], scale height [km].
_TABLE_8_4 = np.array(
    [
        (0.0, 1.225, 7.249),
        (25.0, 3.899e-2, 6.349),
        (30.0, 1.774e-2, 6.682),
        (40.0, 3.972e-3, 7.554),
        (50.0, 1.057e-3, 8.382),
        (60.0, 3.206e-4, 7.714),
        (70.0, 8.770e-5, 6.549),
        (80.0, 1.905e-5, 5.799),
        (90.0, 3.396e-6, 5.382),
        (100.0, 5.297e-7, 5.877),
        (110.0, 9.661e-8, 7.263),
        (120.0, 2.438e-8, 9.473),
        (130.0, 8.484e-9, 12.636),
        (140.0, 3.845e-9, 16.149),
        (150.0, 2.070e-9, 22.523),
        (180.0, 5.464e-10, 29.740),
        (200.0, 2.789e-10, 37.105),
        (250.0, 7.248e-11, 45.546),
        (300.0, 2.418e-11, 53.628),
        (350.0, 9.518e-12, 53.298),
        (400.0, 3.725e-12, 58.515),
        (450.0, 1.585e-12, 60.828),
        (500.0, 6.967e-13, 63.822),
        (600.0, 1.454e-13, 71.835),
        (700.0, 3.614e-14, 88.667),
        (800.0, 1.170e-14, 124.64),
        (900.0, 5.245e-15, 181.05),
        (1000.0, 3.019e-15, 268.00),
    ]
)
_BASE_ALTITUDE_M = 1e3 * _TABLE_8_4[:, 0]
_NOMINAL_DENSITY = _TABLE_8_4[:, 1]
_SCALE_HEIGHT_M = 1e3 * _TABLE_8_4[:, 2]


def geodetic_coordinates(r_E: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Geodetic latitude, longitude and height above the WGS-84 ellipsoid of Earth-fixed positions.

    Through ``ppigrf.ppigrf.geoc2geod`` (WGS-84: a = 6378.137 km,
    e^2 = 0.00669437999014).

    Parameters
    ----------
    r_E : array_like, shape (..., 3)
        Positions in the Earth-fixed frame [m], away from the Earth's centre.

    Returns
    -------
    latitude : ndarray, shape (...)
        Geodetic latitude [rad].
    longitude : ndarray, shape (...)
        East longitude [rad], in (-pi, pi].
    altitude : ndarray, shape (...)
        Height above the ellipsoid [m].

    Raises
    ------
    ValueError
        If ``r_E`` is not (..., 3) or finite, or a position is at the centre.
    """
    from ppigrf import ppigrf

    r = check_vector(r_E, "r_E", 3)
    radius = np.linalg.norm(r, axis=-1)
    if np.any(radius <= 0.0):
        raise ValueError(f"r_E must be away from the Earth's centre (|r_E| > 0), got {describe(r[radius <= 0])}")
    colatitude_deg = np.degrees(np.arccos(np.clip(r[..., 2] / radius, -1.0, 1.0)))
    zeros = np.zeros_like(radius)
    latitude_deg, height_km, _, _ = ppigrf.geoc2geod(colatitude_deg, radius / 1e3, zeros, zeros)
    longitude = np.arctan2(r[..., 1], r[..., 0])
    return np.radians(latitude_deg), longitude, 1e3 * np.asarray(height_km)


def _altitudes_above_ground(r_E: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    latitude, longitude, altitude = geodetic_coordinates(r_E)
    if np.any(altitude < 0.0):
        raise ValueError(
            "r_N must be above the WGS-84 ellipsoid (altitude >= 0 m), "
            f"got altitudes {describe(altitude[altitude < 0])} m"
        )
    return latitude, longitude, altitude


@dataclass(frozen=True)
class ExponentialAtmosphere:
    """Piecewise-exponential air density of Vallado (2013), Table 8-4 (mean solar activity).

    Altitudes are above the WGS-84 ellipsoid, 0 km and up; above 1000 km the
    last band (1000 km, 3.019e-15 kg/m^3, H = 268 km) is extended.
    """

    def density(self, r_N: ArrayLike, epoch: Any, t: ArrayLike) -> NDArray[np.float64]:
        """Air density [kg/m^3] at positions ``r_N``.

        Parameters
        ----------
        r_N : array_like, shape (..., 3)
            Positions in N [m].
        epoch : Epoch
            The time origin of ``t``: ``epoch.gmst(t)`` [rad] turns N into
            the Earth-fixed frame (the altitude above the ellipsoid depends on
            the latitude only, so the rotation matters little here).
        t : array_like
            Times since the epoch [s], broadcast against ``r_N[..., 0]``.

        Returns
        -------
        ndarray, shape (...)
            Density [kg/m^3].

        Raises
        ------
        ValueError
            If a position is below the ellipsoid (altitude < 0).
        """
        r_E, _, _, shape = earth_fixed_positions(r_N, epoch, t)
        _, _, altitude = _altitudes_above_ground(r_E)
        return self.density_at_altitude(altitude).reshape(shape)

    def density_at_altitude(self, altitude: ArrayLike) -> NDArray[np.float64]:
        """Air density [kg/m^3] at heights above the ellipsoid.

        Parameters
        ----------
        altitude : array_like
            Height above the WGS-84 ellipsoid [m], >= 0.

        Returns
        -------
        ndarray
            Density [kg/m^3], the shape of ``altitude``.

        Raises
        ------
        ValueError
            If an altitude is negative or not finite.
        """
        h = as_float_array(altitude, "altitude")
        if np.any(h < 0.0):
            raise ValueError(f"altitude must be >= 0 m (above the WGS-84 ellipsoid), got {describe(h[h < 0])}")
        band = np.searchsorted(_BASE_ALTITUDE_M, h, side="right") - 1
        return _NOMINAL_DENSITY[band] * np.exp(-(h - _BASE_ALTITUDE_M[band]) / _SCALE_HEIGHT_M[band])

    def describe(self) -> str:
        """One line for reports.

        Returns
        -------
        str
            The model and its source.
        """
        return "exponential atmosphere (Vallado 2013, Table 8-4, mean solar activity)"


@dataclass(frozen=True)
class NRLMSIS:
    """NRLMSIS 2.1 air density through ``pymsis`` (optional: ``pip install attitude-toolkit[msis]``).

    The solar and geomagnetic indices are held constant over a run.

    Parameters
    ----------
    f107_sfu : float
        Daily 10.7 cm solar radio flux of the previous day [sfu, 1e-22 W/m^2/Hz].
    f107_average_sfu : float
        Its 81-day average centred on the date [sfu].
    ap : float
        Daily geomagnetic Ap index (0 to 400; 4 is quiet).

    Raises
    ------
    ValueError
        If a flux is not positive or ``ap`` is outside [0, 400].
    """

    f107_sfu: float = 150.0
    f107_average_sfu: float = 150.0
    ap: float = 4.0

    def __post_init__(self) -> None:
        positive_scalar(self.f107_sfu, "f107_sfu")
        positive_scalar(self.f107_average_sfu, "f107_average_sfu")
        ap = positive_scalar(self.ap, "ap", allow_zero=True)
        if ap > 400.0:
            raise ValueError(f"ap must be in [0, 400] (the Ap index's range), got {ap!r}")

    def density(self, r_N: ArrayLike, epoch: Any, t: ArrayLike) -> NDArray[np.float64]:
        """Total mass density [kg/m^3] at positions ``r_N``.

        Parameters
        ----------
        r_N : array_like, shape (..., 3)
            Positions in N [m].
        epoch : Epoch
            The time origin of ``t``: ``epoch.gmst(t)`` [rad] and ``epoch.utc``
            (the date and local solar time drive the model).
        t : array_like
            Times since the epoch [s], broadcast against ``r_N[..., 0]``.

        Returns
        -------
        ndarray, shape (...)
            Density [kg/m^3].

        Raises
        ------
        ImportError
            If ``pymsis`` is not installed.
        ValueError
            If a position is below the ellipsoid (altitude < 0).
        """
        try:
            import pymsis
        except ImportError as exc:
            raise ImportError("NRLMSIS needs the optional pymsis package: pip install attitude-toolkit[msis]") from exc
        r_E, times, _, shape = earth_fixed_positions(r_N, epoch, t)
        latitude, longitude, altitude = _altitudes_above_ground(r_E)
        start = np.datetime64(utc_naive(epoch), "us")
        dates = start + np.round(times * 1e6).astype("timedelta64[us]")
        n = times.size
        out = pymsis.calculate(
            dates,
            np.degrees(longitude),
            np.degrees(latitude),
            altitude / 1e3,
            np.full(n, float(self.f107_sfu)),
            np.full(n, float(self.f107_average_sfu)),
            np.full((n, 7), float(self.ap)),
        )
        return np.asarray(out, dtype=float).reshape(n, -1)[:, pymsis.Variable.MASS_DENSITY].reshape(shape)

    def describe(self) -> str:
        """One line for reports.

        Returns
        -------
        str
            The model and its indices.
        """
        return (
            f"NRLMSIS 2.1 (pymsis), F10.7 {self.f107_sfu:g} sfu, 81-day {self.f107_average_sfu:g} sfu, Ap {self.ap:g}"
        )

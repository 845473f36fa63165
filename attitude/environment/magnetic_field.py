"""The geomagnetic field at the spacecraft, in the inertial frame N: IGRF and a tilted dipole.

Two models with one interface, ``field_N(r_N, epoch, t) -> (..., 3)`` tesla:

* :class:`IGRF`, the International Geomagnetic Reference Field through the
  ``ppigrf`` package (Laundal, MIT licence), which reads its own copy of the
  IGRF-14 coefficient file (Alken et al., IGRF-14, 2024,
  doi:10.5281/zenodo.14012302). No coefficient is written here.
* :class:`TiltedDipole`, the degree-1 part of the same model: the dipole whose
  moment is read from the same file (g10, g11, h11) at the epoch, evaluated
  with the exact dipole formula
  ``B = (mu0 / 4 pi) [3 (m . r_hat) r_hat - m] / r^3``
  (Wertz, *Spacecraft Attitude Determination and Control*, 1978, appendix H;
  Markley and Crassidis, *Fundamentals of Spacecraft Attitude Determination
  and Control*, 2014, sec. 3.3.5). Cheap, for fast studies.

Frames: N is TEME of date (DESIGN.md, issue 11). The Earth-fixed frame E is N
turned about z by the Greenwich mean sidereal time, ``r_E = R3(gmst) r_N``
(UT1 taken as UTC, polar motion ignored: below 0.004 deg of Earth rotation and
0.5 arcsec, far below what a field model of 10-100 nT accuracy resolves). The
epoch is any object with ``gmst(t)`` [rad] and ``utc`` (a timezone-aware
``datetime``), e.g. :class:`attitude.environment.epoch.Epoch`.

Secular variation: the IGRF coefficients change by up to about 150 nT/yr at
the surface (the IGRF-14 secular-variation terms, e.g. the dipole g10 by
+12.6 nT/yr in 2025-2030). :class:`IGRF` evaluates the coefficients on a grid
of ``date_resolution`` seconds (default one day), so the coefficients it uses
are at most half a day from the true date: under 0.25 nT, against a model
accuracy of order 10 nT. :class:`TiltedDipole` freezes its moment at its
epoch: over a run of a few days the dipole moves by a few nT.

Cost (measured, one CPU): 5,700 points (one LEO orbit at 1 s) take 0.17-0.22 s with
:class:`IGRF` at degree 13 (ppigrf's Legendre recursion dominates; degree 1 costs
the same), 0.011 s with :class:`TiltedDipole` including reading the coefficient
file. Sample the field on a coarse grid and interpolate for long runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.environment.epoch import earth_fixed_positions, ecef_to_N, utc_naive
from attitude.validation import as_float_array, describe

__all__ = ["IGRF", "IGRF_REFERENCE_RADIUS_M", "MU0_OVER_4PI", "TiltedDipole"]

#: mu0 / (4 pi) [T m / A]: exact in the SI before 2019 and within 1e-9 of it since (CODATA 2018).
MU0_OVER_4PI = 1e-7

#: Reference radius of the IGRF spherical-harmonic expansion [m] (the mean Earth radius 6371.2 km).
IGRF_REFERENCE_RADIUS_M = 6371.2e3

#: Highest degree of the IGRF main-field expansion (IGRF-14 from 2000 on).
_IGRF_MAX_DEGREE = 13

#: Colatitudes closer than this to a pole [deg] are moved onto it by this much: ppigrf divides by
#: sin(colatitude) for the eastward component. The move is 1e-9 rad, 7 mm at 7000 km: the field
#: changes by about 1e-12 of itself.
_POLE_GUARD_DEG = math.degrees(1e-9)


def _coefficient_file(coefficient_file: str | None) -> str:
    from ppigrf import ppigrf

    return ppigrf.shc_fn if coefficient_file is None else coefficient_file


def _check_date(date: datetime, index: Any, name: str) -> None:
    first, last = index[0].to_pydatetime(), index[-1].to_pydatetime()
    if not first <= date <= last:
        raise ValueError(
            f"{name} must fall inside the IGRF coefficient file's span {first.date()} to {last.date()}, "
            f"got {date.isoformat()} UTC"
        )


@dataclass(frozen=True)
class IGRF:
    """The International Geomagnetic Reference Field through ``ppigrf``.

    Parameters
    ----------
    max_degree : int
        Highest spherical-harmonic degree kept, 1 to 13 (13 is the full
        model; 1 is the tilted dipole).
    date_resolution : float
        Spacing [s] of the dates at which the coefficients are evaluated
        (ppigrf takes one date per call): every sample uses the coefficients
        at the multiple of ``date_resolution`` after the epoch nearest to its
        time. The default, one day, is off by at most half a day of secular
        variation (under 0.25 nT).
    coefficient_file : str or None
        A ``.shc`` coefficient file; None reads ppigrf's IGRF-14 file.

    Raises
    ------
    ValueError
        If ``max_degree`` is not an integer in [1, 13] or ``date_resolution``
        is not positive.
    """

    max_degree: int = _IGRF_MAX_DEGREE
    date_resolution: float = 86400.0
    coefficient_file: str | None = None

    def __post_init__(self) -> None:
        degree = self.max_degree
        if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or not 1 <= degree <= _IGRF_MAX_DEGREE:
            raise ValueError(
                f"max_degree must be an integer in [1, {_IGRF_MAX_DEGREE}] (IGRF's degrees), got {degree!r}"
            )
        resolution = as_float_array(self.date_resolution, "date_resolution")
        if resolution.ndim != 0 or resolution <= 0.0:
            raise ValueError(f"date_resolution must be a positive number of seconds, got {describe(resolution)}")

    def field_N(self, r_N: ArrayLike, epoch: Any, t: ArrayLike) -> NDArray[np.float64]:
        """The geomagnetic field [T] at positions ``r_N``, in N components.

        Parameters
        ----------
        r_N : array_like, shape (..., 3)
            Positions in N [m], away from the Earth's centre.
        epoch : Epoch
            The time origin: ``epoch.gmst(t)`` [rad] and ``epoch.utc`` (UTC datetime).
        t : array_like
            Times since the epoch [s], broadcast against ``r_N[..., 0]``.

        Returns
        -------
        ndarray, shape (..., 3)
            Field in N [T].

        Raises
        ------
        ValueError
            If ``r_N`` is not (..., 3), is at the Earth's centre, or a date is
            outside the coefficient file's span (1900-2030 for IGRF-14).
        """
        from ppigrf import ppigrf

        r_E, times, gmst, shape = earth_fixed_positions(r_N, epoch, t)
        radius = np.linalg.norm(r_E, axis=-1)
        theta = np.clip(
            np.degrees(np.arccos(np.clip(r_E[:, 2] / radius, -1.0, 1.0))), _POLE_GUARD_DEG, 180.0 - _POLE_GUARD_DEG
        )
        phi = np.degrees(np.arctan2(r_E[:, 1], r_E[:, 0]))

        coefficient_file = _coefficient_file(self.coefficient_file)
        g, _ = ppigrf.read_shc(coefficient_file)
        start = utc_naive(epoch)
        steps = np.round(times / self.date_resolution).astype(np.int64)
        b_spherical = np.empty((times.size, 3))
        for step in np.unique(steps):
            rows = steps == step
            date = start + timedelta(seconds=float(step) * float(self.date_resolution))
            _check_date(date, g.index, "epoch.utc + t")
            b_r, b_theta, b_phi = ppigrf.igrf_gc(
                radius[rows] / 1e3, theta[rows], phi[rows], date, coeff_fn=coefficient_file, max_degree=self.max_degree
            )
            b_spherical[rows] = np.stack((b_r[0], b_theta[0], b_phi[0]), axis=-1)

        th, ph = np.radians(theta), np.radians(phi)
        st, ct, sp, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
        r_hat = np.stack((st * cp, st * sp, ct), axis=-1)
        theta_hat = np.stack((ct * cp, ct * sp, -st), axis=-1)
        phi_hat = np.stack((-sp, cp, np.zeros_like(sp)), axis=-1)
        b_E = 1e-9 * (b_spherical[:, :1] * r_hat + b_spherical[:, 1:2] * theta_hat + b_spherical[:, 2:] * phi_hat)
        return np.einsum("nij,nj->ni", ecef_to_N(gmst), b_E).reshape(*shape, 3)

    def describe(self) -> str:
        """One line for reports.

        Returns
        -------
        str
            The model, its degree and its date resolution.
        """
        source = "IGRF-14" if self.coefficient_file is None else f"IGRF ({self.coefficient_file})"
        return f"{source} to degree {self.max_degree} (ppigrf), coefficients every {self.date_resolution / 3600:g} h"


@dataclass(frozen=True)
class TiltedDipole:
    """The Earth's field as the IGRF dipole (degree 1) at an epoch.

    The moment is ``m = (4 pi / mu0) a^3 (g11, h11, g10)`` in Earth-fixed
    axes, with ``a`` the IGRF reference radius and the Gauss coefficients
    read through ``ppigrf.ppigrf.read_shc`` and interpolated linearly in time
    to the epoch (as ppigrf does): the degree-1 potential
    ``a (a/r)^2 (g10 cos(theta) + (g11 cos(phi) + h11 sin(phi)) sin(theta))``
    is the potential ``(mu0 / 4 pi) m . r / r^3`` of that dipole.

    Parameters
    ----------
    epoch : Epoch
        The date at which the moment is taken (``epoch.utc``).
    coefficient_file : str or None
        A ``.shc`` coefficient file; None reads ppigrf's IGRF-14 file.

    Raises
    ------
    ValueError
        If the epoch is outside the coefficient file's span.
    """

    epoch: Any
    coefficient_file: str | None = None
    _moment_E: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from ppigrf import ppigrf

        g, h = ppigrf.read_shc(_coefficient_file(self.coefficient_file))
        date = utc_naive(self.epoch)
        _check_date(date, g.index, "epoch.utc")
        known = (g.index - g.index[0]).total_seconds().to_numpy()
        at = (date - g.index[0].to_pydatetime()).total_seconds()
        g10, g11, h11 = (
            float(np.interp(at, known, table[key].to_numpy())) for table, key in ((g, (1, 0)), (g, (1, 1)), (h, (1, 1)))
        )
        moment = IGRF_REFERENCE_RADIUS_M**3 / MU0_OVER_4PI * 1e-9 * np.array([g11, h11, g10])
        object.__setattr__(self, "_moment_E", moment)

    @property
    def dipole_moment_Am2(self) -> NDArray[np.float64]:
        """Dipole moment in Earth-fixed axes [A m^2] (about 7.7e22 A m^2, pointing to the south)."""
        return self._moment_E.copy()

    @property
    def tilt_rad(self) -> float:
        """Angle between the dipole axis (towards the north geomagnetic pole, ``-m``) and the Earth's axis [rad]."""
        return float(np.arccos(-self._moment_E[2] / np.linalg.norm(self._moment_E)))

    def field_N(self, r_N: ArrayLike, epoch: Any, t: ArrayLike) -> NDArray[np.float64]:
        """The dipole field [T] at positions ``r_N``, in N components.

        Parameters
        ----------
        r_N : array_like, shape (..., 3)
            Positions in N [m], away from the Earth's centre.
        epoch : Epoch
            The time origin of ``t``: ``epoch.gmst(t)`` [rad] turns the
            Earth-fixed moment into N.
        t : array_like
            Times since the epoch [s], broadcast against ``r_N[..., 0]``.

        Returns
        -------
        ndarray, shape (..., 3)
            Field in N [T].
        """
        r_E, _, gmst, shape = earth_fixed_positions(r_N, epoch, t)
        radius = np.linalg.norm(r_E, axis=-1, keepdims=True)
        r_hat = r_E / radius
        m_dot_r = np.sum(self._moment_E * r_hat, axis=-1, keepdims=True)
        b_E = MU0_OVER_4PI * (3.0 * m_dot_r * r_hat - self._moment_E) / radius**3
        return np.einsum("nij,nj->ni", ecef_to_N(gmst), b_E).reshape(*shape, 3)

    def describe(self) -> str:
        """One line for reports.

        Returns
        -------
        str
            The dipole's strength, tilt and date.
        """
        return (
            f"tilted dipole {np.linalg.norm(self._moment_E):.4g} A m^2, tilt {math.degrees(self.tilt_rad):.2f} deg "
            f"(IGRF degree 1 at {utc_naive(self.epoch).date()})"
        )

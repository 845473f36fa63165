"""Time of the environment: the UTC epoch, Julian dates and the Earth's rotation angle (GMST).

Time inside the toolkit is seconds since an :class:`Epoch` (UTC). The inertial
frame N of the environment is TEME of date (true equator, mean equinox: the
frame SGP4 works in); the Earth-fixed frame (ECEF) turns relative to it by the
Greenwich mean sidereal time, taken from ``sgp4.propagation.gstime`` (the
IAU-82 expression of Vallado et al. 2006, "Revisiting Spacetrack Report #3",
AIAA 2006-6753), not written again here. UT1 is taken equal to UTC
(``|UT1 - UTC| < 0.9 s``, at most 0.004 deg of Earth rotation) and polar motion
is ignored (< 0.5 arcsec).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from sgp4.functions import jday
from sgp4.propagation import gstime

from attitude.validation import as_float_array, check_vector, describe

__all__ = [
    "DEFAULT_EPOCH",
    "SECONDS_PER_DAY",
    "Epoch",
    "earth_fixed_positions",
    "ecef_to_N",
    "utc_naive",
]

#: Seconds in a (UTC) day; leap seconds inside a run are ignored.
SECONDS_PER_DAY = 86400.0

#: ``gstime`` of sgp4 is written for one float at a time; this maps it over arrays.
_gstime = np.vectorize(gstime, otypes=[np.float64])


@dataclass(frozen=True)
class Epoch:
    """An instant in UTC: the ``t = 0`` of a simulation and of its ephemerides.

    Attributes
    ----------
    utc : datetime.datetime
        Timezone-aware instant. An aware time in another zone is converted to
        UTC (same instant); a naive one is refused, since its zone is unknown.

    Raises
    ------
    ValueError
        If ``utc`` is not a ``datetime`` or is naive (no ``tzinfo``).
    """

    utc: datetime

    def __post_init__(self) -> None:
        if not isinstance(self.utc, datetime):
            raise ValueError(f"utc must be a timezone-aware datetime.datetime, got {self.utc!r}")
        if self.utc.tzinfo is None or self.utc.utcoffset() is None:
            raise ValueError(
                f"utc must be timezone-aware (e.g. tzinfo=datetime.timezone.utc), got naive {self.utc.isoformat()!r}"
            )
        object.__setattr__(self, "utc", self.utc.astimezone(UTC))

    @classmethod
    def from_iso(cls, text: str) -> Epoch:
        """The epoch written as ISO 8601 text with its zone, e.g. ``"2026-03-20T12:00:00Z"``.

        Parameters
        ----------
        text : str
            Date and time with a zone designator (``Z`` or ``+hh:mm``).

        Returns
        -------
        Epoch

        Raises
        ------
        ValueError
            If ``text`` is not ISO 8601 or carries no zone.
        """
        try:
            moment = datetime.fromisoformat(str(text))
        except ValueError as exc:
            raise ValueError(
                f"text must be an ISO 8601 date and time with a zone, e.g. '2026-03-20T12:00:00Z', got {text!r}"
            ) from exc
        if moment.tzinfo is None:
            raise ValueError(f"text must carry a zone ('Z' for UTC or '+hh:mm'), got {text!r}")
        return cls(moment)

    def _julian_date_parts(self) -> tuple[float, float]:
        """The epoch's Julian date as sgp4's (whole-ish, fraction) pair [days]."""
        u = self.utc
        return jday(u.year, u.month, u.day, u.hour, u.minute, u.second + 1e-6 * u.microsecond)

    def julian_date(self, t: ArrayLike = 0.0) -> NDArray[np.float64]:
        """UTC Julian date [days] at ``t`` seconds after the epoch (``sgp4.functions.jday``).

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s].

        Returns
        -------
        ndarray, shape (...)
            Julian date [days]; float64 resolves it to about 40 microseconds.
        """
        t = as_float_array(t, "t")
        jd, fraction = self._julian_date_parts()
        return jd + (fraction + t / SECONDS_PER_DAY)

    def gmst(self, t: ArrayLike = 0.0) -> NDArray[np.float64]:
        """Greenwich mean sidereal time [rad] in ``[0, 2 pi)``, through ``sgp4.propagation.gstime``.

        Parameters
        ----------
        t : array_like, shape (...)
            Time since the epoch [s]; UT1 is taken equal to UTC.

        Returns
        -------
        ndarray, shape (...)
            The angle of the Earth-fixed x axis from the TEME x axis about z [rad].
        """
        return np.asarray(_gstime(self.julian_date(t)), dtype=np.float64)

    def describe(self) -> str:
        """The epoch as ISO 8601 UTC text, for reports.

        Returns
        -------
        str
        """
        return self.utc.isoformat().replace("+00:00", "Z")


def ecef_to_N(gmst: ArrayLike) -> NDArray[np.float64]:
    """Matrix turning Earth-fixed (ECEF) components into N (TEME) components: ``R_z(gmst)``.

    ``v_N = ecef_to_N(gmst) @ v_ECEF``; its transpose goes back. Polar motion
    is ignored (< 0.5 arcsec).

    Parameters
    ----------
    gmst : array_like, shape (...)
        Greenwich mean sidereal time [rad] (:meth:`Epoch.gmst`).

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    angle = as_float_array(gmst, "gmst")
    c, s = np.cos(angle), np.sin(angle)
    zero, one = np.zeros_like(angle), np.ones_like(angle)
    return np.stack(
        [np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1), np.stack([zero, zero, one], -1)],
        -2,
    )


def earth_fixed_positions(
    r_N: ArrayLike, epoch: Epoch, t: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], tuple[int, ...]]:
    """Positions in N at times ``t`` (broadcast together) in Earth-fixed axes, flattened for the field models.

    Parameters
    ----------
    r_N : array_like, shape (..., 3)
        Positions from the Earth's centre in N [m], non-zero.
    epoch : Epoch
        ``t = 0`` (anything with ``gmst(t)`` [rad]).
    t : array_like, shape broadcasting against ``r_N[..., 0]``
        Times since the epoch [s].

    Returns
    -------
    tuple
        ``(r_E (n, 3) [m], t (n,) [s], gmst (n,) [rad], shape)`` with ``shape`` the
        broadcast leading shape (``n`` its size).

    Raises
    ------
    ValueError
        If ``r_N`` is not (..., 3), holds a zero vector, or ``t`` does not broadcast against it.
    """
    r = check_vector(r_N, "r_N", 3)
    times = as_float_array(t, "t")
    try:
        shape = np.broadcast_shapes(r.shape[:-1], times.shape)
    except ValueError as exc:
        raise ValueError(
            f"t must broadcast against r_N's leading shape {r.shape[:-1]}, got shape {times.shape}"
        ) from exc
    r_flat = np.broadcast_to(r, (*shape, 3)).reshape(-1, 3)
    radius = np.linalg.norm(r_flat, axis=-1)
    if np.any(radius <= 0.0):
        raise ValueError(f"r_N must be away from the Earth's centre (|r_N| > 0), got {describe(r_flat[radius <= 0])}")
    times = np.broadcast_to(times, shape).reshape(-1)
    gmst = np.broadcast_to(np.asarray(epoch.gmst(times), dtype=float), times.shape)
    r_E = np.einsum("nji,nj->ni", ecef_to_N(gmst), r_flat)  # the transpose takes N to Earth-fixed
    return r_E, times, gmst, shape


def utc_naive(epoch: Any) -> datetime:
    """An epoch's UTC instant as a naive datetime (what ppigrf and pymsis compare dates against).

    Parameters
    ----------
    epoch : Epoch
        Anything with a timezone-aware ``utc`` datetime.

    Returns
    -------
    datetime.datetime
        The same instant in UTC, without a zone.

    Raises
    ------
    ValueError
        If ``epoch.utc`` is missing, not a datetime, or naive.
    """
    utc = getattr(epoch, "utc", None)
    if not isinstance(utc, datetime):
        raise ValueError(f"epoch must have a datetime attribute utc (an Epoch), got {epoch!r}")
    if utc.tzinfo is None:
        raise ValueError(f"epoch.utc must be timezone-aware (UTC), got the naive datetime {utc.isoformat()}")
    return utc.astimezone(UTC).replace(tzinfo=None)


#: An arbitrary default epoch (the March 2026 equinox day, noon UTC) for runs that do not give one.
DEFAULT_EPOCH = Epoch(datetime(2026, 3, 20, 12, 0, tzinfo=UTC))

"""Ground-target tracking: a body axis on the line of sight to a point on the Earth, a second axis constrained.

The target is given by geodetic latitude, longitude and height on the WGS-84
ellipsoid; ``pymap3d.geodetic2ecef`` turns it into Earth-fixed coordinates
(the geodesy is not written here). The Earth-fixed frame reaches N by the
rotation about z by GMST (:func:`attitude.environment.epoch.ecef_to_N`, the
frame convention of DESIGN.md), and a point fixed on the Earth moves in N
with

.. math::

    r_T' = \\omega_E \\times r_T,\\qquad r_T'' = \\omega_E \\times (\\omega_E \\times r_T)

(``omega_E = [0, 0, EARTH_ROTATION_RATE]``, the WGS-84 rate; the IAU-82 GMST
turns 1.2e-7 faster, a line-of-sight rate error below 1e-10 rad/s in low
orbit). The line of sight is ``r_T - r`` with the spacecraft's motion from
:mod:`controllers.guidance.directions`; the frame follows
:mod:`controllers.guidance.alignment`. :meth:`GroundTargetReference.elevation`
gives the target's view of the spacecraft above its local horizon (the
ellipsoid normal): positive when the target is visible. The reference does
not stop below the horizon (it then points through the Earth); a mode
manager switches on :meth:`GroundTargetReference.visible`. See docs/guidance.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pymap3d
from numpy.typing import ArrayLike, NDArray

from attitude.environment.epoch import ecef_to_N
from attitude.environment.orbit_environment import EARTH_ROTATION_RATE
from attitude.validation import as_float_array, scalar_angle
from controllers.guidance.alignment import SEPARATION_MIN_DEFAULT, VectorAlignmentReference, VectorTrack
from controllers.guidance.directions import check_orbit, direction_source, orbit_motion
from controllers.guidance.protocol import reference_times

__all__ = ["GroundTarget", "GroundTargetReference"]

_EARTH_RATE_N = np.array([0.0, 0.0, EARTH_ROTATION_RATE])


@dataclass(frozen=True)
class GroundTarget:
    """A point fixed on the Earth: geodetic latitude and longitude [rad], height above WGS-84 [m].

    Parameters
    ----------
    latitude : float
        Geodetic latitude [rad], in ``[-pi/2, pi/2]``.
    longitude : float
        East longitude [rad].
    altitude_m : float
        Height above the WGS-84 ellipsoid [m], above -1e5 m and below 1e8 m.

    Raises
    ------
    ValueError
        For a non-finite value, a latitude outside ``[-pi/2, pi/2]`` or an altitude out of range.
    """

    latitude: float
    longitude: float
    altitude_m: float = 0.0

    def __post_init__(self) -> None:
        lat = scalar_angle(self.latitude, "latitude")
        if not -0.5 * np.pi <= lat <= 0.5 * np.pi:
            raise ValueError(f"latitude must be a geodetic latitude in [-pi/2, pi/2] rad, got {lat!r}")
        alt = as_float_array(self.altitude_m, "altitude_m")
        if alt.ndim != 0 or not -1e5 < float(alt) < 1e8:
            raise ValueError(f"altitude_m must be a scalar height above WGS-84 in (-1e5, 1e8) m, got {alt!r}")
        object.__setattr__(self, "latitude", lat)
        object.__setattr__(self, "longitude", scalar_angle(self.longitude, "longitude"))
        object.__setattr__(self, "altitude_m", float(alt))

    @classmethod
    def from_degrees(cls, latitude_deg: float, longitude_deg: float, altitude_m: float = 0.0) -> GroundTarget:
        """The target from latitude and longitude in degrees.

        Parameters
        ----------
        latitude_deg : float
            Geodetic latitude [deg].
        longitude_deg : float
            East longitude [deg].
        altitude_m : float
            Height above the WGS-84 ellipsoid [m].

        Returns
        -------
        GroundTarget
        """
        lat = as_float_array(latitude_deg, "latitude_deg")
        lon = as_float_array(longitude_deg, "longitude_deg")
        return cls(float(np.radians(lat)), float(np.radians(lon)), altitude_m)

    @property
    def position_E(self) -> NDArray[np.float64]:
        """Earth-fixed position (3,) [m] (``pymap3d.geodetic2ecef``, WGS-84)."""
        x, y, z = pymap3d.geodetic2ecef(self.latitude, self.longitude, self.altitude_m, deg=False)
        return np.array([x, y, z], dtype=float)

    @property
    def up_E(self) -> NDArray[np.float64]:
        """Earth-fixed unit normal to the ellipsoid at the target (3,) (local vertical)."""
        cl = np.cos(self.latitude)
        return np.array([cl * np.cos(self.longitude), cl * np.sin(self.longitude), np.sin(self.latitude)])


class GroundTargetReference(VectorAlignmentReference):
    """Point ``primary_axis_B`` along the line of sight to a ground target (module docstring).

    Parameters
    ----------
    orbit : object
        The spacecraft's orbit (``position_N``, ``velocity_N``, ``mu`` and ``epoch``).
    target : GroundTarget
        The point tracked.
    primary_axis_B : array_like, shape (3,)
        The boresight in body axes (default body z).
    secondary_axis_B : array_like, shape (3,)
        Body axis turned towards ``secondary`` (default body y).
    secondary : str or array_like (3,)
        ``"orbit_normal"`` (default), ``"velocity"``, ``"nadir"``, ``"zenith"``
        or a fixed direction in N.
    separation_min : float
        Smallest accepted angle [rad] between the line of sight and the secondary direction (default 1 deg).

    Raises
    ------
    ValueError
        For a bad orbit, target, axes or ``secondary``; at sampling, for the
        line of sight within ``separation_min`` of the secondary direction.
    """

    def __init__(
        self,
        orbit: Any,
        target: GroundTarget,
        primary_axis_B: ArrayLike = (0.0, 0.0, 1.0),
        secondary_axis_B: ArrayLike = (0.0, 1.0, 0.0),
        *,
        secondary: Any = "orbit_normal",
        separation_min: float = SEPARATION_MIN_DEFAULT,
    ) -> None:
        self.orbit = check_orbit(orbit)
        if not isinstance(target, GroundTarget):
            raise ValueError(f"target must be a GroundTarget (latitude, longitude, altitude_m), got {target!r}")
        self.target = target
        self._position_E = target.position_E
        self._up_E = target.up_E
        super().__init__(
            primary_axis_B,
            self.line_of_sight,
            secondary_axis_B,
            direction_source(orbit, secondary),
            separation_min=separation_min,
        )

    def _earth_to_N(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        return ecef_to_N(self.orbit.epoch.gmst(t))

    def target_motion_N(self, t: ArrayLike) -> VectorTrack:
        """The target's position [m], velocity [m/s] and acceleration [m/s^2] in N, each (n, 3).

        Parameters
        ----------
        t : array_like, shape (n,)
            Times since the orbit's epoch [s].
        """
        t = reference_times(t)
        r = self._earth_to_N(t) @ self._position_E
        v = np.cross(_EARTH_RATE_N, r)
        return VectorTrack(r, v, np.cross(_EARTH_RATE_N, v))

    def line_of_sight(self, t: NDArray[np.float64]) -> VectorTrack:
        """Spacecraft-to-target vector [m] in N with its rate [m/s] and acceleration [m/s^2], each (n, 3).

        Parameters
        ----------
        t : ndarray, shape (n,)
            Times since the orbit's epoch [s].
        """
        r_t, v_t, a_t = self.target_motion_N(t)
        r, v, a, _ = orbit_motion(self.orbit, reference_times(t))
        return VectorTrack(r_t - r, v_t - v, a_t - a)

    def elevation(self, t: ArrayLike) -> NDArray[np.float64]:
        """Elevation of the spacecraft above the target's horizon [rad], shape (n,).

        Parameters
        ----------
        t : array_like, shape (n,)
            Times since the orbit's epoch [s].
        """
        t = reference_times(t)
        to_spacecraft = -self.line_of_sight(t).vector
        up = self._earth_to_N(t) @ self._up_E
        sine = np.sum(up * to_spacecraft, axis=-1) / np.linalg.norm(to_spacecraft, axis=-1)
        return np.arcsin(np.clip(sine, -1.0, 1.0))

    def visible(self, t: ArrayLike, elevation_min: float = 0.0) -> NDArray[np.bool_]:
        """Whether the spacecraft is above ``elevation_min`` as seen from the target, shape (n,).

        Parameters
        ----------
        t : array_like, shape (n,)
            Times since the orbit's epoch [s].
        elevation_min : float
            Mask angle [rad].
        """
        return self.elevation(t) > scalar_angle(elevation_min, "elevation_min")

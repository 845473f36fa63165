"""Sun pointing: a body axis to the Sun, a second body axis turned towards a secondary direction.

The primary direction is the spacecraft-Sun vector ``r_sun - r`` of the
almanac Sun (:func:`attitude.environment.sun.sun_motion_N`, which also gives
its exact rates) and the orbit (:mod:`controllers.guidance.directions`); the
spacecraft's own motion moves it by at most ``|v|/AU`` (5e-8 rad/s), the
Earth's by about 2e-7 rad/s (1 deg/day). The secondary direction defaults to
the orbit normal (e.g. solar arrays to the Sun with their rotation axis
across the orbit); it and the frame follow
:mod:`controllers.guidance.alignment`. The Sun near the secondary direction
(beta angle near 90 deg for the orbit normal) is refused, not flown through.
See docs/guidance.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.environment.sun import sun_motion_N
from controllers.guidance.alignment import SEPARATION_MIN_DEFAULT, VectorAlignmentReference, VectorTrack
from controllers.guidance.directions import check_orbit, direction_source, orbit_motion

__all__ = ["SunReference"]


class SunReference(VectorAlignmentReference):
    """Point ``primary_axis_B`` at the Sun, ``secondary_axis_B`` as close as possible to ``secondary``.

    Parameters
    ----------
    orbit : object
        The spacecraft's orbit (``position_N``, ``velocity_N``, ``mu``, ``epoch``).
    primary_axis_B : array_like, shape (3,)
        Body axis to the Sun (e.g. the solar-array normal).
    secondary_axis_B : array_like, shape (3,)
        Body axis turned towards ``secondary``.
    secondary : str or array_like (3,)
        ``"orbit_normal"`` (default), ``"velocity"``, ``"nadir"``,
        ``"zenith"`` or a fixed direction in N (e.g. ``[0, 0, 1]``, the pole).
    separation_min : float
        Smallest accepted angle [rad] between the Sun and the secondary direction (default 1 deg).

    Raises
    ------
    ValueError
        For a bad orbit, axes or ``secondary``; at sampling, for the Sun
        within ``separation_min`` of the secondary direction.
    """

    def __init__(
        self,
        orbit: Any,
        primary_axis_B: ArrayLike = (0.0, 0.0, 1.0),
        secondary_axis_B: ArrayLike = (0.0, 1.0, 0.0),
        *,
        secondary: Any = "orbit_normal",
        separation_min: float = SEPARATION_MIN_DEFAULT,
    ) -> None:
        self.orbit = check_orbit(orbit)
        super().__init__(
            primary_axis_B,
            self.sun_line_of_sight,
            secondary_axis_B,
            direction_source(orbit, secondary),
            separation_min=separation_min,
        )

    def sun_line_of_sight(self, t: NDArray[np.float64]) -> VectorTrack:
        """Spacecraft-to-Sun vector [m] in N with its rate [m/s] and acceleration [m/s^2], each (n, 3).

        Parameters
        ----------
        t : ndarray, shape (n,)
            Times since the orbit's epoch [s].
        """
        sun, sun_rate, sun_acceleration = sun_motion_N(self.orbit.epoch.julian_date(t))
        r, v, a, _ = orbit_motion(self.orbit, t)
        return VectorTrack(sun - r, sun_rate - v, sun_acceleration - a)

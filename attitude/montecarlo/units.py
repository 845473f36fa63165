"""Review units of the campaign's metrics, histories and parameters (SI inside, these on axes and in summaries)."""

from __future__ import annotations

import math

__all__ = ["DISPLAY_UNITS", "display_unit"]

_DEG = 180.0 / math.pi
#: Display scale and unit of the built-in metric, history and parameter names (SI inside, review units on
#: the axes), by name or by the prefix before the first "." (``keep_out_margin.<cone>``, ``inertia.xx``).
DISPLAY_UNITS: dict[str, tuple[float, str]] = {
    "settling_time": (1.0, "s"),
    "settling_after_slew": (1.0, "s"),
    "pointing_error_hold": (_DEG, "deg"),
    "final_pointing_error": (_DEG, "deg"),
    "error_angle": (_DEG, "deg"),
    "tracking_error": (_DEG, "deg"),
    "estimation_error": (_DEG * 3600.0, "arcsec"),
    "keep_out_margin": (_DEG, "deg"),
    "rate_peak": (_DEG, "deg/s"),
    "omega": (_DEG, "deg/s"),
    "initial_rate": (_DEG, "deg/s"),
    "wheel_speed_peak": (30.0 / math.pi, "rpm"),
    "wheel_speed": (30.0 / math.pi, "rpm"),
    "inertia": (1.0, "kg m^2"),
    "gyro_misalignment": (_DEG * 3600.0, "arcsec"),
    "star_tracker_misalignment": (_DEG * 3600.0, "arcsec"),
    "gyro_bias": (_DEG * 3600.0, "deg/h"),
}


def display_unit(name: str) -> tuple[float, str]:
    """Scale and unit label for plotting a metric, history or parameter (``(1, "")`` when unknown).

    Parameters
    ----------
    name : str
        Name of a metric, history or dispersed parameter (its suffix says the unit).
    """
    for key in (name, name.split(".")[0], name.split("[")[0]):
        if key in DISPLAY_UNITS:
            return DISPLAY_UNITS[key]
    return 1.0, ""

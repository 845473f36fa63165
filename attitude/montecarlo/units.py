"""Review units of the campaign's metrics, histories and parameters (SI inside, these on axes, in summaries and tables).

One table, :data:`DISPLAY_UNITS`, says how each built-in quantity is shown:
the summary's numbers, the figures' axes and the columns of ``results.csv``
(:func:`table_column`: the column ``final_pointing_error_deg`` holds the
final pointing error in degrees) all read it, so they cannot disagree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = [
    "DIMENSIONLESS",
    "DISPLAY_UNITS",
    "REVIEW_UNITS",
    "ColumnUnit",
    "display_unit",
    "quantity_of_column",
    "table_column",
]

_DEG = 180.0 / math.pi
#: Display scale and unit of the built-in metric, history and parameter names (SI inside, review units on
#: the axes), by name or by the prefix before the first "." (``keep_out_margin.<cone>``, ``inertia.xx``).
DISPLAY_UNITS: dict[str, tuple[float, str]] = {
    "settling_time": (1.0, "s"),
    "slew_time": (1.0, "s"),
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
    "disturbance_torque_peak": (1e6, "uN m"),  # the momentum budget's unit (attitude momentum)
    "residual_dipole": (1.0, "A m^2"),
    "centre_of_pressure_offset": (1.0, "m"),
}

#: Built-in quantities without a unit (a NEES, a relative scale, a quaternion's components): their table
#: columns keep their names and the schema says ``unit: "1"``, unlike a user's metric of unknown unit.
DIMENSIONLESS = frozenset({"nees", "drag_scale", "initial_attitude"})

#: Each review unit of :data:`DISPLAY_UNITS`: its SI unit (what the scale converts from) and its spelling at
#: the end of a table column's name (DESIGN.md naming rule: ``_deg``, ``_deg_per_s``, ``_kg_m2``).
REVIEW_UNITS: dict[str, tuple[str, str]] = {
    "s": ("s", "s"),
    "deg": ("rad", "deg"),
    "arcsec": ("rad", "arcsec"),
    "deg/s": ("rad/s", "deg_per_s"),
    "deg/h": ("rad/s", "deg_per_h"),
    "rpm": ("rad/s", "rpm"),
    "kg m^2": ("kg m^2", "kg_m2"),
    "A m^2": ("A m^2", "Am2"),
    "m": ("m", "m"),
    "uN m": ("N m", "uNm"),
}


def _known(name: str, names: Any) -> str | None:
    """The key of ``names`` that describes ``name``: itself, or its prefix before the first "." or "["."""
    for key in (name, name.split(".")[0], name.split("[")[0]):
        if key in names:
            return key
    return None


def display_unit(name: str) -> tuple[float, str]:
    """Scale and unit label for plotting a metric, history or parameter (``(1, "")`` when unknown).

    Parameters
    ----------
    name : str
        Name of a metric, history or dispersed parameter (its suffix says the unit).
    """
    key = _known(name, DISPLAY_UNITS)
    return DISPLAY_UNITS[key] if key is not None else (1.0, "")


@dataclass(frozen=True)
class ColumnUnit:
    """How one quantity (a metric or a dispersed parameter) is written in the campaign's table.

    Parameters
    ----------
    quantity : str
        Its name inside (``result.metrics``, ``result.parameters``, requirements), SI.
    column : str
        Its column in ``results.csv``: the quantity with its review unit appended
        (``final_pointing_error_deg``), or the quantity itself when it has no unit or an unknown one.
    unit : str or None
        The review unit of the column (``"deg"``), ``"1"`` for a dimensionless quantity, None when unknown.
    si_unit : str or None
        The SI unit the values are held in inside (``"rad"``), ``"1"`` dimensionless, None when unknown.
    scale : float
        Column value = ``scale`` * SI value (1 when the unit is unknown: the value as the scenario returned it).
    """

    quantity: str
    column: str
    unit: str | None
    si_unit: str | None
    scale: float

    def schema(self, role: str) -> dict[str, Any]:
        """The column's entry of the campaign's schema (``campaign.json`` ``"columns"``).

        Parameters
        ----------
        role : str
            ``"metric"`` or ``"parameter"``.
        """
        entry: dict[str, Any] = {
            "role": role,
            "quantity": self.quantity,
            "unit": self.unit,
            "si_unit": self.si_unit,
            "scale_from_si": self.scale,
        }
        if self.unit is None:
            entry["note"] = "unit unknown: written as the scenario returned it (SI by the scenario protocol)"
        return entry


def table_column(name: str) -> ColumnUnit:
    """The table column of a metric or dispersed parameter: its name with the unit, and the scale from SI.

    The review unit is :func:`display_unit`'s, the one the summary prints.

    Parameters
    ----------
    name : str
        The quantity's name inside (``"final_pointing_error"``, ``"inertia.xx"``, a user's metric).

    Returns
    -------
    ColumnUnit
        ``final_pointing_error`` -> column ``final_pointing_error_deg``, scale 180/pi; ``inertia.xx`` ->
        ``inertia.xx_kg_m2``, scale 1; ``nees`` -> ``nees``, unit ``"1"``; an unknown name -> itself, unit None.

    Examples
    --------
    >>> c = table_column("wheel_speed_peak")
    >>> c.column, c.unit, c.si_unit, round(c.scale, 6)
    ('wheel_speed_peak_rpm', 'rpm', 'rad/s', 9.549297)
    >>> table_column("my_metric").unit is None
    True
    """
    key = _known(name, DISPLAY_UNITS)
    if key is not None:
        scale, unit = DISPLAY_UNITS[key]
        si_unit, suffix = REVIEW_UNITS[unit]
        return ColumnUnit(name, f"{name}_{suffix}", unit, si_unit, scale)
    if _known(name, DIMENSIONLESS) is not None:
        return ColumnUnit(name, name, "1", "1", 1.0)
    return ColumnUnit(name, name, None, None, 1.0)


def quantity_of_column(column: str) -> str | None:
    """The built-in quantity whose table column ``column`` is (None when it is no such column).

    Parameters
    ----------
    column : str
        A column name, e.g. ``"settling_time_s"``.
    """
    for _, suffix in REVIEW_UNITS.values():
        if column.endswith("_" + suffix):
            quantity = column[: -len(suffix) - 1]
            if quantity and table_column(quantity).column == column:
                return quantity
    return None

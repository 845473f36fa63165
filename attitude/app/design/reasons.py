"""Why a requirement row failed, in one line: what the terminal and the report print under a FAIL.

Top floor (DESIGN.md), beside :mod:`attitude.app.design.run`. Each reason is
made from the numbers stored in the design's results (never recomputed), so
the line, the table and ``results.json`` cannot disagree. A row that could
not be judged (no figure) says what was missing: the slew that could not be
planned and the planner's own words, the campaign that could not be flown.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["failure_reason", "pd_input_disk_margins"]


def _g(value: Any, digits: int = 4) -> str:
    """A number for a sentence: 4 significant digits, thousands separated (callers word inf and NaN)."""
    if value is None:
        return "n/a"
    x = float(value)
    if not math.isfinite(x):
        return str(x)
    if abs(x) >= 1e4:
        return f"{x:,.0f}"
    return f"{x:.{digits}g}"


def _no_flight(results: Mapping[str, Any]) -> str:
    """Why nothing was flown: the slew study's own error (or that no plan and no eigenaxis slew exist)."""
    slews = results.get("slews") or {}
    error = slews.get("error")
    return f"nothing was flown: {error}" if error else "nothing was flown: the slew could not be planned"


def _cause(results: Mapping[str, Any]) -> str:
    """A likely cause of a flown row's failure, from the other sections: an unstable or mismatched loop, saturation."""
    findings = ((results.get("linear") or {}).get("findings")) or []
    unstable = [f["message"] for f in findings if f["id"].endswith("unstable")]
    if unstable:
        return f"; likely cause: {unstable[0]}"
    flight = results.get("closed_loop") or {}
    fraction = flight.get("torque_saturated_fraction")
    # More than 1 tick in 20 cut: more than the opening and closing torque steps of a slew that fits its wheels
    # (0 % on the built-in spacecraft, 40-100 % on the reviewed failures).
    if fraction is not None and fraction > 0.05:
        return (
            f"; the wheels cut the commanded torque on {100 * fraction:.3g} % of the ticks (command peak "
            f"{_g(flight['torque_command_peak_mNm'])} mN m, applied {_g(flight['torque_applied_peak_mNm'])} mN m)"
        )
    if findings:
        return f"; see also: {findings[0]['message']}"
    return ""


def _dwell(flight: Mapping[str, Any]) -> str:
    """The settling dwell as words ("30 s")."""
    dwell = flight.get("settling_dwell_s")
    return "settling" if dwell is None else f"{_g(dwell)} s"


def _slew_time(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    flight = results.get("closed_loop")
    plan = (results.get("slews") or {}).get("plan")
    if row["achieved"] is None:
        return _no_flight(results)
    if flight is None:  # judged on the plan alone (attitude slew)
        return f"the plan takes {_g(row['achieved'])} s, {_g(row['required'])} s allowed"
    planned = f"; the plan takes {_g(plan['duration_s'])} s" if plan else ""
    if math.isinf(float(row["achieved"])):
        return (
            f"the error to the target never stays within the pointing accuracy for the {_dwell(flight)} dwell "
            f"({_g(flight['pointing_error_end_deg'])} deg at the end){planned}{_cause(results)}"
        )
    return (
        f"the error to the target stays within the pointing accuracy only from {_g(row['achieved'])} s, "
        f"{_g(row['required'])} s allowed{planned}{_cause(results)}"
    )


def _settling(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    flight = results.get("closed_loop")
    if row["achieved"] is None or flight is None:
        return _no_flight(results)
    if not math.isfinite(float(row["achieved"])):
        return (
            f"the error to the target never stays within the accuracy for the {_dwell(flight)} dwell by the end "
            f"of the hold ({_g(flight['pointing_window_end_s'])} s; the slew ended at {_g(flight['slew_end_s'])} s, "
            f"{_g(row['required'])} s of settling allowed){_cause(results)}"
        )
    return (
        f"the error to the target stays within the accuracy only {_g(row['achieved'])} s after the slew ended at "
        f"{_g(flight['slew_end_s'])} s, {_g(row['required'])} s allowed{_cause(results)}"
    )


def _pointing(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    flight = results.get("closed_loop")
    if row["achieved"] is None or flight is None:
        return _no_flight(results)
    if not math.isfinite(float(row["achieved"])):
        return f"the error to the target is not a number in the hold (a diverged or broken run){_cause(results)}"
    at = flight.get("pointing_error_max_in_window_at_s")
    when = f" at {_g(at)} s" if at is not None else ""
    return (
        f"the error to the target reached {_g(row['achieved'])} deg{when} in the hold "
        f"({_g(flight['pointing_window_start_s'])} to {_g(flight['pointing_window_end_s'])} s), "
        f"{_g(row['required'])} deg allowed{_cause(results)}"
    )


def _rate(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    if row["achieved"] is None:
        return _no_flight(results)
    return f"the body rate peaked at {_g(row['achieved'])} deg/s, {_g(row['required'])} deg/s allowed{_cause(results)}"


def _keep_out(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    if row["achieved"] is None:
        return _no_flight(results)
    return f"the boresight came {_g(row['achieved'])} deg from the direction, inside the {_g(row['required'])} deg cone"


def _momentum(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    budget = ((results.get("orbit") or {}).get("momentum")) or {}
    case = budget.get("judged_case", "the budget")
    return (
        f"a wheel stores {_g(row['achieved'])} mN m s over the orbits ({case}), "
        f"{_g(row['required'])} mN m s allowed by the momentum margin"
    )


def _dispersed(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    d = results.get("dispersed") or {}
    if d.get("error"):
        return f"the campaign could not be flown: {d['error']}"
    failing = d.get("failing_runs") or []
    listed = ", ".join(f"run {f['run']} ({f['error'] or ', '.join(f['missed'])})" for f in failing)
    more = d.get("failures", 0) - len(failing)
    tail = f" and {more} more" if more > 0 else ""
    return f"{d.get('failures')} of {d.get('runs')} dispersed runs fail: {listed}{tail}; rerun: {d.get('command')}"


def pd_input_disk_margins(results: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The disk-margin rows ``requirements.disk_margin_min`` judges: the PD loops (with the file's modes and
    filters too) at the wheels' input, each axis and all at once, that have a figure.

    Parameters
    ----------
    results : mapping
        The design's JSON-ready results (section 2 under ``"linear"``).
    """
    rows = (results.get("linear") or {}).get("disk_margins", [])
    return [m for m in rows if m["controller"].startswith("PD") and m["break_point"] == "input" and "note" not in m]


def _disk_margin(row: Mapping[str, Any], results: Mapping[str, Any]) -> str:
    rows = pd_input_disk_margins(results)
    unstable = [m for m in rows if not m["stable"]]
    if unstable:
        m = unstable[0]
        return f"the closed loop of {m['controller']} on the {m['plant']} plant is unstable ({m['channel']})"
    if not rows:
        return "no disk margin could be computed"
    m = min(rows, key=lambda r: r["disk_margin"])
    return (
        f"{m['controller']} on the {m['plant']} plant, {m['channel']}: {_g(m['disk_margin'])} at "
        f"{_g(m['frequency_rad_per_s'])} rad/s, required >= {_g(row['required'])} (`attitude tune` finds gains "
        "that meet it, or says what binds)"
    )


_REASONS: dict[str, Callable[[Mapping[str, Any], Mapping[str, Any]], str]] = {
    "disk_margin": _disk_margin,
    "slew_time": _slew_time,
    "settling_time": _settling,
    "pointing_accuracy": _pointing,
    "slew_rate": _rate,
    "wheel_momentum_budget": _momentum,
    "dispersed": _dispersed,
}


def failure_reason(row: Mapping[str, Any], results: Mapping[str, Any]) -> str | None:
    """One line saying why ``row`` failed (None when it passed).

    Parameters
    ----------
    row : mapping
        A requirement row (``id``, ``required``, ``achieved``, ``pass``, ...).
    results : mapping
        The design's JSON-ready results the row was judged from.
    """
    if row["pass"]:
        return None
    rid = row["id"]
    if rid.startswith("keep_out_"):
        return _keep_out(row, results)
    reason = _REASONS.get(rid)
    if reason is not None:
        return reason(row, results)
    if row["achieved"] is None:
        findings = ((results.get("linear") or {}).get("findings")) or []
        unstable = [f["message"] for f in findings if f["id"].endswith("unstable")]
        if unstable and row["id"].endswith(("_gain_margin", "_phase_margin")):
            return f"no margin: {unstable[0]}"
        return "no figure could be computed"
    return f"{_g(row['achieved'])} {row['unit']}, required {row['comparison']} {_g(row['required'])} {row['unit']}"

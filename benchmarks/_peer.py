"""The compiled peer each speed figure is compared with: Basilisk, case by case, from a checked-in file.

``benchmarks/basilisk_reference.json`` holds Basilisk's figures measured on
a stated machine and date::

    {"machine": "...", "date": "...",
     "cases": {"torquefree": {"sim_s_per_cpu_s": {"median": ...}},
               "closed_nodelay": {"sim_s_per_cpu_s": {"median": ...}},
               "rw_no_earth": {"sim_s_per_cpu_s": {"median": ...}}}}

A figure is compared with the case that does the same work (:data:`PEER_CASES`):
a loop with wheels with Basilisk's wheel loop, never with its wheel-less one.
:func:`versus_basilisk` gives the keys a benchmark writes next to a figure; when
the file is absent (or lacks the case) the ratio is null and ``basilisk_note``
says why, so a missing reference never reads as a comparison.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

#: The checked-in reference (absent until it is measured).
REFERENCE_FILE = Path(__file__).resolve().with_name("basilisk_reference.json")

#: Basilisk's cases and the work each does per simulated second.
PEER_CASES = {
    "torquefree": "rigid body, no torque, RK4 (propagation alone)",
    "closed_nodelay": "rigid body under an MRP-feedback law, no wheels, no sensor delay",
    "rw_no_earth": "rigid body with reaction wheels under MRP feedback, no Earth (no gravity, no environment)",
}


def load_basilisk_reference(path: str | Path | None = None) -> dict[str, Any] | None:
    """The reference file's contents, or None when there is no file.

    Parameters
    ----------
    path : str or Path, optional
        The file (default :data:`REFERENCE_FILE`).

    Raises
    ------
    ValueError
        The file is there but not a JSON object with ``cases``, naming the file.
    """
    path = REFERENCE_FILE if path is None else Path(path)
    if not path.exists():
        return None
    try:
        reference = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: the Basilisk reference must be JSON: {exc}") from exc
    if not isinstance(reference, dict) or not isinstance(reference.get("cases"), dict):
        raise ValueError(f"{path}: the Basilisk reference must be an object with a 'cases' object, got {reference!r}")
    return reference


def versus_basilisk(
    sim_s_per_cpu_s: float, case: str, *, reference: dict[str, Any] | None = None, note: str = ""
) -> dict[str, Any]:
    """The keys written next to a speed figure: its Basilisk case, that case's figure and the ratio.

    Parameters
    ----------
    sim_s_per_cpu_s : float
        The figure: simulated seconds (spacecraft-seconds for a batch) per CPU second.
    case : str
        The Basilisk case doing the same work, a key of :data:`PEER_CASES`.
    reference : dict, optional
        :func:`load_basilisk_reference`'s result (default: read the checked-in file).
    note : str, optional
        How the work differs from the peer case's, when it does (said in ``basilisk_note``).

    Returns
    -------
    dict
        ``basilisk_case``, ``basilisk_sim_s_per_cpu_s`` (the case's median, or
        None), ``ratio_to_basilisk`` (figure / median, or None) and
        ``basilisk_note`` (the reference's machine and date, or why there is no
        ratio, and ``note``).
    """
    if case not in PEER_CASES:
        raise ValueError(f"case must be one of {sorted(PEER_CASES)}, got {case!r}")
    if reference is None:
        reference = load_basilisk_reference()
    median = None
    if reference is None:
        said = f"no ratio: benchmarks/{REFERENCE_FILE.name} is absent"
    else:
        try:
            median = float(reference["cases"][case]["sim_s_per_cpu_s"]["median"])
        except (KeyError, TypeError, ValueError):
            median = None
        if median is None or not math.isfinite(median) or median <= 0.0:
            median = None
            said = f"no ratio: {REFERENCE_FILE.name} has no positive cases.{case}.sim_s_per_cpu_s.median"
        else:
            said = f"Basilisk {case} ({PEER_CASES[case]}) on {reference.get('machine')}, {reference.get('date')}"
    return {
        "basilisk_case": case,
        "basilisk_sim_s_per_cpu_s": median,
        "ratio_to_basilisk": None if median is None else sim_s_per_cpu_s / median,
        "basilisk_note": said + (f"; {note}" if note else ""),
    }

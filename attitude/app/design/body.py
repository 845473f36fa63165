"""Section 1 of the design report: the body (principal axes, torque-free stability, gravity gradient).

Part of the top floor that :mod:`attitude.app.design.run` assembles (it imports only
``attitude`` modules, but serves ``attitude design`` and ``attitude physics``).

* Principal axes and moments of the whole spacecraft (wheels included, at rest).
* Torque-free spin about each principal axis, from the linearised Euler
  equations: a spin ``W`` about axis ``i`` (the others ``j``, ``k``) nutates
  at ``W sqrt((Ii-Ij)(Ii-Ik)/(Ij Ik))`` when that product is positive (minor
  and major axes) and diverges at ``W sqrt(-(Ii-Ij)(Ii-Ik)/(Ij Ik))`` about the
  middle axis; with energy dissipation only the major axis stays stable. The
  exact (elliptic) nutation period and the middle-axis flip period of a spin
  perturbed by :data:`PERTURBATION` come from :mod:`attitude.analytic`.
* Gravity-gradient stability (when the file has an ``[orbit]``) of the body
  as mounted (body x, y, z along roll, pitch, yaw, each with the principal
  moment of its best-aligned principal axis) and with the major axis on the
  orbit normal and the minor axis to nadir (the Lagrange orientation), plus
  the largest gravity-gradient torque ``3 n^2 (I3 - I1) / 2``.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude.analytic import flip_period, torque_free_motion
from attitude.app import assembly
from attitude.config import SpacecraftConfig
from attitude.environment.gravity_gradient import gravity_gradient_stability
from attitude.environment.orbit import CircularOrbit
from attitude.plain import plain_float as _f
from attitude.plain import plain_matrix as _mat
from attitude.plain import plain_vector as _vec
from attitude.plotting import plot_polhodes

__all__ = ["DEFAULT_SPIN_RATE_DEG_PER_S", "PERTURBATION", "body_analysis", "body_figures"]

#: Reference spin rate of the torque-free analysis [deg/s]: 10 deg/s, the usual upper bound of the
#: tip-off rate after separation that detumbling is sized for. Every rate of section 1 scales with it.
DEFAULT_SPIN_RATE_DEG_PER_S = 10.0
#: Relative off-axis perturbation of the spins whose exact nutation and flip periods are reported.
PERTURBATION = 0.01

_AXES = "xyz"


def _closest_body_axis(axis_B: np.ndarray) -> tuple[str, float]:
    i = int(np.argmax(np.abs(axis_B)))
    sign = "+" if axis_B[i] >= 0 else "-"
    return f"{sign}{_AXES[i]}", math.degrees(math.acos(min(1.0, abs(float(axis_B[i])))))


def _mounted_moments(axes_B: np.ndarray, moments: np.ndarray) -> np.ndarray:
    """Principal moments assigned to body x, y, z: the permutation of best-aligned axes."""
    best = max(itertools.permutations(range(3)), key=lambda p: sum(abs(axes_B[b, p[b]]) for b in range(3)))
    return moments[list(best)]


def _gg_entry(moments: np.ndarray, orbit: Any, label: str) -> dict[str, Any]:
    gg = gravity_gradient_stability(moments, orbit)
    entry = {
        "orientation": label,
        "roll_pitch_yaw_moments_kg_m2": _vec(moments),
        "region": gg.region,
        "pitch_stable": bool(gg.pitch_stable),
        "roll_yaw_stable": bool(gg.roll_yaw_stable),
        "stable": bool(gg.stable),
        "pitch_libration_period_s": None,
        "pitch_libration_period_minutes": None,
        "roll_yaw_periods_s": None,
        "roll_yaw_periods_minutes": None,
    }
    if gg.pitch_frequency:
        entry["pitch_libration_period_s"] = 2 * math.pi / gg.pitch_frequency
        entry["pitch_libration_period_minutes"] = entry["pitch_libration_period_s"] / 60.0
    if gg.roll_yaw_frequencies:
        entry["roll_yaw_periods_s"] = [2 * math.pi / w for w in gg.roll_yaw_frequencies]
        entry["roll_yaw_periods_minutes"] = [p / 60.0 for p in entry["roll_yaw_periods_s"]]
    return entry


def body_analysis(config: SpacecraftConfig, spin_rate_deg_per_s: float = DEFAULT_SPIN_RATE_DEG_PER_S) -> dict[str, Any]:
    """Section 1: principal axes, torque-free stability, nutation and flip, gravity gradient.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft (the whole body, wheels included and at rest).
    spin_rate_deg_per_s : float
        Reference spin rate [deg/s] (rates scale linearly with it).

    Returns
    -------
    dict
        JSON-ready figures (see the report's section 1).
    """
    if not (math.isfinite(spin_rate_deg_per_s) and spin_rate_deg_per_s > 0):
        raise ValueError(f"spin_rate_deg_per_s must be a positive number, got {spin_rate_deg_per_s!r}")
    body = assembly.rigid_body(config)
    pa = body.principal_axes()
    m = pa.moments
    # A principal axis is a line: show each with its largest component positive (q_PB keeps the frame).
    axes_B = pa.axes_B * np.sign(pa.axes_B[np.argmax(np.abs(pa.axes_B), axis=0), range(3)])
    spin = math.radians(spin_rate_deg_per_s)
    tol = 1e-9 * m[2]
    distinct = (m[1] - m[0] > tol) and (m[2] - m[1] > tol)
    names = ("minor", "intermediate", "major")
    axes = []
    for i in range(3):
        j, k = (n for n in range(3) if n != i)
        prod = (m[i] - m[j]) * (m[i] - m[k])
        closest, off = _closest_body_axis(axes_B[:, i])
        entry: dict[str, Any] = {
            "name": names[i],
            "moment_kg_m2": _f(m[i]),
            "axis_B": _vec(axes_B[:, i]),
            "closest_body_axis": closest,
            "angle_from_body_axis_deg": off,
            "torque_free": "stable",
            "with_energy_dissipation": "stable" if (i == 2 and m[2] - m[1] > tol) else "unstable",
            "nutation_frequency_rad_per_s": None,
            "nutation_period_s": None,
            "nutation_period_exact_s": None,
            "growth_rate_per_s": None,
            "e_folding_time_s": None,
        }
        scale = m[j] * m[k]
        if prod > tol * tol:
            w_n = spin * math.sqrt(prod / scale)
            entry["nutation_frequency_rad_per_s"] = w_n
            entry["nutation_period_s"] = 2 * math.pi / w_n
            if distinct:
                tilt = axes_B[:, i] + PERTURBATION * axes_B[:, j]
                motion = torque_free_motion(body, spin * tilt / np.linalg.norm(tilt))
                entry["nutation_period_exact_s"] = _f(motion.period)
        elif prod < -tol * tol:
            entry["torque_free"] = "unstable"
            growth = spin * math.sqrt(-prod / scale)
            entry["growth_rate_per_s"] = growth
            entry["e_folding_time_s"] = 1.0 / growth
        else:
            entry["torque_free"] = "neutral (axisymmetric pair)"
            entry["with_energy_dissipation"] = "neutral (axisymmetric pair)"
        axes.append(entry)
    out: dict[str, Any] = {
        "inertia_B_kg_m2": _mat(body.inertia),
        "principal_moments_kg_m2": _vec(m),
        "q_PB": _vec(pa.q_PB),
        "axisymmetric": not distinct,
        "spin_rate_deg_per_s": float(spin_rate_deg_per_s),
        "perturbation": PERTURBATION,
        "perturbation_percent": 100.0 * PERTURBATION,
        "axes": axes,
        "flip_period_s": None,
        "gravity_gradient": None,
    }
    if distinct:
        off_axis = (axes_B[:, 0] + axes_B[:, 2]) / math.sqrt(2.0)
        tilt = axes_B[:, 1] + PERTURBATION * off_axis
        out["flip_period_s"] = _f(flip_period(body, spin * tilt / np.linalg.norm(tilt)))
    orbit = assembly.orbit(config)
    if orbit is not None and not isinstance(orbit, CircularOrbit):
        # The linear gravity-gradient analysis is about a circular orbit: the one of the same mean motion
        # (for an eccentric orbit the libration is forced at the orbital rate, Wie sec. 6.4; this is its mean).
        orbit = CircularOrbit((orbit.mu / orbit.mean_motion**2) ** (1.0 / 3.0), mu=orbit.mu)
    if orbit is not None:
        n = orbit.mean_motion
        mounted = _mounted_moments(axes_B, m)
        lagrange = np.array([m[1], m[2], m[0]])  # roll intermediate, pitch major, yaw minor
        out["gravity_gradient"] = {
            "altitude_km": _f(orbit.altitude_m / 1000.0),
            "orbit_period_s": _f(orbit.period),
            "orbit_period_minutes": _f(orbit.period / 60.0),
            "mean_motion_rad_per_s": _f(n),
            "torque_peak_uNm": _f(1.5 * n * n * (m[2] - m[0]) * 1e6),
            "orientations": [
                _gg_entry(mounted, orbit, "as mounted (body x, y, z along roll, pitch, yaw)"),
                _gg_entry(lagrange, orbit, "major axis on the orbit normal, minor axis to nadir"),
            ],
        }
    return out


def body_figures(config: SpacecraftConfig, body: dict[str, Any]) -> dict[str, Figure]:
    """The polhode figure of section 1 (none for an axisymmetric body).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    body : dict
        The section-1 results (``results["body"]``).
    """
    if body["axisymmetric"]:
        return {}
    rate = math.radians(body["spin_rate_deg_per_s"])
    title = f"Torque-free polhodes at the energy of a {body['spin_rate_deg_per_s']:g} deg/s middle-axis spin"
    return {"body_polhodes": plot_polhodes(assembly.rigid_body(config), rate, rate_unit="deg/s", title=title)}

"""Section 2 of the design report: linear design (top floor: imports :mod:`controllers`).

* Quaternion PD from the file's ``control.bandwidth_rad_per_s`` and
  ``control.damping`` (:meth:`controllers.pd.QuaternionPD.from_bandwidth`,
  gyroscopic compensation on), its closed-loop poles on the body linearised
  at rest (:func:`controllers.analysis.attitude_closed_loop`) and its step
  responses.
* Discrete LQR at ``control.period_s`` with Bryson's rule from
  ``[control.lqr]`` (when the file has it), with its closed-loop poles as
  s-plane equivalents.
* Loop-at-a-time margins per axis (gain, phase, delay) of the continuous
  loops and of the sampled loops that fly (zero-order hold at
  ``control.period_s`` on every axis, :func:`controllers.analysis.loop_gain`),
  with Bode figures.
* Disk margins of the sampled loops (:func:`controllers.disk_margins.loop_disk_margins`): each axis alone and
  all three at once at the plant input (the wheels' gain and phase), all six measurements at once at the
  plant output (the star tracker's and gyro's), with the disk margin over frequency as a figure.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude.app import assembly
from attitude.config import SpacecraftConfig
from attitude.plain import plain_float as _f
from attitude.plain import plain_matrix as _mat
from attitude.plain import plain_vector as _vec
from controllers.analysis import (
    attitude_closed_loop,
    input_loop,
    loop_gain,
    margins,
    output_loop,
    plot_bode,
    plot_nichols,
    plot_step,
)
from controllers.diagnostics import mismatch_findings
from controllers.disk_margins import DiskMargins, loop_disk_margins, plot_disk_margins
from controllers.lqr import LQRController

__all__ = ["OUTPUT_NOTE", "controller_findings", "disk_margin_rows", "linear_design"]

_AXES = "xyz"


def _pole(p: complex) -> dict[str, float]:
    wn = abs(p)
    return {"real": _f(p.real), "imag": _f(p.imag), "wn_rad_per_s": _f(wn), "zeta": _f(-p.real / wn) if wn else 1.0}


def _poles(poles: Any) -> list[dict[str, float]]:
    """Poles sorted by frequency, one of each conjugate pair (the one with Im >= 0)."""
    p = np.asarray(poles, dtype=complex)
    p = p[p.imag >= -1e-12 * np.maximum(1.0, np.abs(p))]
    return [_pole(complex(v)) for v in sorted(p, key=lambda v: (abs(v), v.imag))]


def _margin_row(controller: str, loop_name: str, axis: str, loop: Any) -> dict[str, Any]:
    m = margins(loop)
    return {
        "controller": controller,
        "loop": loop_name,
        "axis": axis,
        "gain_margin_db": _f(m.gain_margin_db),
        "gain_margin_lower_db": _f(m.gain_margin_lower_db),
        "phase_margin_deg": _f(m.phase_margin_deg),
        "delay_margin_s": _f(m.delay_margin_s),
        "gain_crossover_rad_per_s": _f(m.gain_crossover),
        "phase_crossover_rad_per_s": _f(m.phase_crossover),
        "stable": bool(m.stable),
    }


def _disk_row(controller: str, break_point: str, channel: str, m: DiskMargins) -> dict[str, Any]:
    return {
        "controller": controller,
        "plant": "rigid",
        "break_point": break_point,
        "channel": channel,
        "disk_margin": _f(m.disk_margin),
        "gain_margin_db": _f(m.gain_margin_db),
        "phase_margin_deg": _f(m.phase_margin_deg),
        "frequency_rad_per_s": _f(m.frequency_rad_s),
        "converged": bool(m.converged),
        "stable": bool(m.closed_loop_stable),
    }


def disk_margin_rows(
    controller_name: str, plant: Any, controller: Any, plant_name: str = "rigid", output: bool = True
) -> list[dict[str, Any]]:
    """Disk margins of the sampled loop that flies: per axis and multiloop at the input, multiloop at the output.

    Parameters
    ----------
    controller_name : str
        The controller's name in the report ("PD", "LQR", "PD + filters").
    plant : RigidBody or control LTI
        The plant (:func:`controllers.analysis.loop_gain`).
    controller : object
        The controller (with its period: the sampled loop).
    plant_name : str
        The plant's name in the report ("rigid", "flexible (2 modes)").
    output : bool
        Whether to add the multiloop margin at the output (see :data:`OUTPUT_NOTE` for why the flexible and
        filtered loops leave it out).
    """
    at_input = loop_disk_margins(plant, controller)
    rows = [_disk_row(controller_name, "input", f"{a} alone", m) for a, m in zip(_AXES, at_input.per_axis)]
    results = [("input", at_input)]
    if output:
        results.append(("output", loop_disk_margins(plant, controller, break_point="output")))
    for point, result in results:
        if result.multiloop is None:
            rows.append({"controller": controller_name, "break_point": point, "channel": "all", "note": result.note})
        else:
            rows.append(_disk_row(controller_name, point, "all at once", result.multiloop))
    return [row | {"plant": plant_name} for row in rows]


#: Why the loops on the flexible plant or with filters have no multiloop margin at the output in the report.
OUTPUT_NOTE = (
    "The multiloop margin at the output is given for the rigid, unfiltered loops only: on the flexible plant "
    "slycot's structured-singular-value bound (ab13md) took 297 s at a single frequency of the six-channel loop, "
    "where the three axes' largest singular values nearly coincide (the rigid loop's coincide exactly and take "
    "milliseconds)."
)


def _variants(config: SpacecraftConfig, name: str, rigid: Any, controller: Any) -> list[tuple[str, str, Any, Any]]:
    """(controller name, plant name, plant, controller) of the loops to judge beyond the rigid design.

    With ``[[flexible_modes]]``: the law on the flexible plant; with ``[[control.filters]]``: the law with its
    filters (the controller that flies) on the rigid or flexible plant. Empty for a rigid, unfiltered file.
    """
    flexible = assembly.flexible_plant_model(config)
    filtered = assembly.command_filtered(config, controller)
    out = []
    if flexible is not None:
        modes = len(config.flexible_modes)
        plant_name = f"flexible ({modes} mode{'s' if modes > 1 else ''})"
        out.append((name, plant_name, flexible, controller))
    else:
        plant_name = "rigid"
    if filtered is not controller:
        out.append((f"{name} + filters", plant_name, flexible if flexible is not None else rigid, filtered))
    return out


def linear_design(config: SpacecraftConfig) -> tuple[dict[str, Any], dict[str, Figure]]:
    """Section 2: PD and LQR gains, closed-loop poles, margins per axis, Bode and step figures.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    """
    body = assembly.rigid_body(config)
    c = config.control
    period = c.period_s
    pd = assembly.quaternion_pd(config, body)
    closed = attitude_closed_loop(body, pd)
    loops = loop_gain(body, pd, sampled=False)
    sampled = loop_gain(body, pd)
    sampled_name = f"sampled ({1.0 / period:g} Hz, zero-order hold)"
    rows = [_margin_row("PD", "continuous", a, loop) for a, loop in zip(_AXES, loops)]
    rows += [_margin_row("PD", sampled_name, a, loop) for a, loop in zip(_AXES, sampled)]
    out: dict[str, Any] = {
        "period_s": period,
        "rate_Hz": 1.0 / period,
        "pd": {
            "bandwidth_rad_per_s": c.bandwidth_rad_per_s,
            "damping": c.damping,
            "K_Nm": _mat(pd.K),
            "C_Nms": _mat(pd.C),
            "gyroscopic_compensation": True,
            "poles": _poles(np.linalg.eigvals(closed.A)),
        },
        "lqr": None,
        "margins": rows,
        "disk_margins": disk_margin_rows("PD", body, pd),
    }
    pd_variants = _variants(config, "PD", body, pd)
    if pd_variants:
        out["disk_margin_note"] = OUTPUT_NOTE
    for name, plant_name, plant, controller in pd_variants:
        out["disk_margins"] += disk_margin_rows(name, plant, controller, plant_name, output=False)
        rows += [
            _margin_row(name, f"{sampled_name}, {plant_name}", a, lp)
            for a, lp in zip(_AXES, loop_gain(plant, controller))
        ]
    figures = {
        "pd_step": plot_step(closed),
        "pd_bode": plot_bode(loops, labels=[f"PD, {a} axis, continuous" for a in _AXES]),
        "pd_bode_sampled": plot_bode(sampled, labels=[f"PD, {a} axis, {1.0 / period:g} Hz ZOH" for a in _AXES]),
    }
    designed = assembly.lqr(config, body)
    if designed is not None:
        plant, lqr = designed
        lqr_loops = loop_gain(plant, lqr, sampled=False)
        lqr_sampled = loop_gain(plant, lqr)
        rows += [_margin_row("LQR", "continuous", a, loop) for a, loop in zip(_AXES, lqr_loops)]
        rows += [_margin_row("LQR", sampled_name, a, loop) for a, loop in zip(_AXES, lqr_sampled)]
        out["disk_margins"] += disk_margin_rows("LQR", plant, lqr)
        for name, plant_name, variant_plant, controller in _variants(config, "LQR", plant, LQRController(lqr)):
            out["disk_margins"] += disk_margin_rows(name, variant_plant, controller, plant_name, output=False)
        out["lqr"] = {
            "angle_max_deg": _vec(np.degrees(c.lqr.angle_max)),
            "rate_max_deg_per_s": _vec(np.degrees(c.lqr.rate_max)),
            "torque_max_Nm": _vec(c.lqr.torque_max),
            "K": _mat(lqr.K),
            "poles": _poles(lqr.s_poles),
            "slowest_decay_rate_per_s": _f(lqr.slowest_decay_rate),
        }
        figures["lqr_bode_sampled"] = plot_bode(
            lqr_sampled, labels=[f"LQR, {a} axis, {1.0 / period:g} Hz ZOH" for a in _AXES]
        )
    disk_loops = {"PD, at the input": input_loop(body, pd), "PD, at the output": output_loop(body, pd)}
    if designed is not None:
        disk_loops |= {"LQR, at the input": input_loop(plant, lqr), "LQR, at the output": output_loop(plant, lqr)}
    if pd_variants:  # the PD as it flies (modes, filters): the loop the verdict judges, at the input
        name, plant_name, plant_flown, flown = pd_variants[-1]
        disk_loops[f"{name}, {plant_name}, at the input"] = input_loop(plant_flown, flown)
    figures["disk_margins"] = plot_disk_margins(
        disk_loops, title=f"Multiloop disk margins of the sampled loops ({1.0 / period:g} Hz)"
    )
    nichols = [(f"PD, {a} axis, rigid", lp) for a, lp in zip(_AXES, sampled)]
    if pd_variants:
        name, plant_name, plant_flown, flown = pd_variants[-1]
        nichols += [(f"{name}, {a} axis, {plant_name}", lp) for a, lp in zip(_AXES, loop_gain(plant_flown, flown))]
    figures["pd_nichols"] = plot_nichols(
        [lp for _, lp in nichols],
        labels=[label for label, _ in nichols],
        disk_margin=(
            config.requirements.disk_margin_min
            if config.requirements.disk_margin_min is not None
            else min((_f(r["disk_margin"]) for r in out["disk_margins"] if r.get("stable")), default=None)
        ),
    )
    out["findings"] = controller_findings(config, body, pd, None if designed is None else designed[1])
    return out, figures


def controller_findings(
    config: SpacecraftConfig, body: Any = None, pd: Any = None, lqr: Any = None
) -> list[dict[str, Any]]:
    """The file's controllers that do not fit their sample rate or the requirements' bandwidth, in words.

    :func:`controllers.diagnostics.mismatch_findings` on the file's PD and LQR (built here when not given),
    JSON-ready; ``attitude design`` and ``attitude montecarlo`` print them.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    body : RigidBody, optional
        The file's body (built when None).
    pd : QuaternionPD, optional
        The file's PD (built when None).
    lqr : LQRDesign, optional
        The file's LQR (built when None and the file has ``[control.lqr]``).
    """
    body = assembly.rigid_body(config) if body is None else body
    pd = assembly.quaternion_pd(config, body) if pd is None else pd
    if lqr is None:
        designed = assembly.lqr(config, body)
        lqr = None if designed is None else designed[1]
    findings = mismatch_findings(
        body=body,
        pd=pd,
        lqr=lqr,
        settling_time=config.requirements.settling_time_s,
        damping=float(min(np.atleast_1d(config.control.damping))),  # per axis: the least damped axis's
    )
    return [{"id": f.id, "message": f.message, "figures": {k: _f(v) for k, v in f.figures.items()}} for f in findings]

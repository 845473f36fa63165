"""The content of the design report: the eight sections as a list of blocks, built from ``results`` only.

Every number in a block comes from the results dict of
:func:`attitude.app.design.run.run_design` (the same dict ``results.json`` holds),
formatted by :func:`fmt`; :mod:`attitude.app.report.writer` renders the blocks to
markdown and HTML. Nothing here computes a figure of merit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

__all__ = [
    "Block",
    "Figure",
    "Heading",
    "Paragraph",
    "Table",
    "build_blocks",
    "diagnostics_lines",
    "fmt",
    "requirement_rows",
]

SECTIONS = (
    ("body", "1. The body"),
    ("linear", "2. Linear design"),
    ("slews", "3. Slews"),
    ("closed_loop", "4. Closed loop"),
    ("estimation", "5. Estimation"),
    ("orbit", "6. Orbit: disturbances, momentum, detumbling"),
    ("determination", "7. Attitude determination from the Sun and the field"),
    ("requirements", "8. Requirements"),
)


@dataclass(frozen=True)
class Heading:
    """A heading of ``level`` 1-3 with an anchor.

    Parameters
    ----------
    level : int
        Heading level, 1 to 3 (1 for the title).
    text : str
        Heading text.
    anchor : str, optional
        HTML anchor (``id``) of the heading; empty for none.
    """

    level: int
    text: str
    anchor: str = ""


@dataclass(frozen=True)
class Paragraph:
    """A paragraph of plain text.

    Parameters
    ----------
    text : str
        The paragraph (Markdown inline markup allowed).
    """

    text: str


@dataclass(frozen=True)
class Table:
    """A table: header cells, rows of cells (strings), first column left-aligned, the others right.

    Parameters
    ----------
    header : tuple of str
        Column titles.
    rows : tuple of tuple of str
        Cells, row by row.
    caption : str, optional
        Caption above the table.
    """

    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    caption: str = ""


@dataclass(frozen=True)
class Figure:
    """A figure of the report: file stem (``figures/<name>.png``) and caption.

    Parameters
    ----------
    name : str
        File name without extension (``figures/<name>.png``).
    caption : str
        Caption under the figure.
    """

    name: str
    caption: str


Block = Heading | Paragraph | Table | Figure


def fmt(value: Any, digits: int = 4) -> str:
    """Format a number for the report: ``digits`` significant digits; None is "n/a"; inf is "inf".

    The one number format of the report (tests use it to find values of
    ``results.json`` in ``report.md``).

    Parameters
    ----------
    value : number, list of numbers or None
        The value to format (a list: each value, in brackets).
    digits : int, optional
        Significant digits.
    """
    if value is None:
        return "n/a"
    if isinstance(value, (list, tuple)):  # one value per axis
        return "[" + ", ".join(fmt(v, digits) for v in value) + "]"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    x = float(value)
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == 0.0:
        return "0"
    return f"{x:.{digits}g}"


def _vec(values: Any, digits: int = 4) -> str:
    return "[" + ", ".join(fmt(v, digits) for v in values) + "]"


def _t(header: list[str], rows: list[list[str]], caption: str = "") -> Table:
    return Table(tuple(header), tuple(tuple(r) for r in rows), caption)


def _figure(results: dict[str, Any], name: str) -> list[Block]:
    info = results.get("figures", {}).get(name)
    return [] if info is None else [Figure(name, info["caption"])]


def verdict_text(ok: bool) -> str:
    """The verdict cell: PASS or FAIL."""
    return "PASS" if ok else "FAIL"


# ---------------------------------------------------------------------------
# 1. The body


def _body(results: dict[str, Any]) -> list[Block]:
    b = results["body"]
    spin = fmt(b["spin_rate_deg_per_s"])
    pct = fmt(b["perturbation_percent"])
    out: list[Block] = [
        Paragraph(
            "The whole spacecraft, reaction wheels included and at rest. Inertia tensor about the centre of mass "
            "in body axes [kg m^2]: " + "; ".join(_vec(row) for row in b["inertia_B_kg_m2"]) + "."
        ),
        Paragraph(
            f"Torque-free spin about each principal axis at the reference rate of {spin} deg/s (every rate scales "
            "with it). Linear theory gives the nutation period of a stable axis and the e-folding time of the "
            f"unstable one; the exact period is that of the elliptic solution for a spin {pct} % off the axis."
        ),
    ]
    rows = []
    for a in b["axes"]:
        rows.append(
            [
                a["name"],
                fmt(a["moment_kg_m2"]),
                _vec(a["axis_B"], 3),
                f"{a['closest_body_axis']} ({fmt(a['angle_from_body_axis_deg'], 2)} deg)",
                a["torque_free"],
                a["with_energy_dissipation"],
                fmt(a["nutation_period_s"]),
                fmt(a["nutation_period_exact_s"]),
                fmt(a["e_folding_time_s"]),
            ]
        )
    out.append(
        _t(
            [
                "principal axis",
                "moment [kg m^2]",
                "direction (body axes)",
                "closest body axis",
                "torque-free spin",
                "with energy dissipation",
                "nutation period, linear [s]",
                "nutation period, exact [s]",
                "divergence e-folding time [s]",
            ],
            rows,
        )
    )
    if b["flip_period_s"] is not None:
        out.append(
            Paragraph(
                f"A {spin} deg/s spin about the intermediate axis, perturbed by {pct} %, flips over every "
                f"{fmt(b['flip_period_s'])} s (exact elliptic solution; the tennis-racket effect). With energy "
                "dissipation (flexible parts, fuel, dampers) only the major axis is a stable spin axis."
            )
        )
    else:
        out.append(Paragraph("The body is axisymmetric (two equal principal moments): there is no middle-axis flip."))
    gg = b["gravity_gradient"]
    if gg is None:
        out.append(Paragraph("No [orbit] table in the spacecraft file: gravity gradient not analysed."))
    else:
        out.append(
            Paragraph(
                f"Gravity gradient on the circular orbit at {fmt(gg['altitude_km'])} km (orbit period "
                f"{fmt(gg['orbit_period_minutes'])} min): the largest gravity-gradient torque on this body is "
                f"{fmt(gg['torque_peak_uNm'])} uN m (3 n^2 (I3 - I1) / 2, at 45 deg from the principal axes). "
                "Stability of the nadir-pointing attitude (linearised about the LVLH frame):"
            )
        )
        rows = []
        for o in gg["orientations"]:
            ry = o["roll_yaw_periods_s"]
            rows.append(
                [
                    o["orientation"],
                    _vec(o["roll_pitch_yaw_moments_kg_m2"]),
                    o["region"],
                    "stable" if o["pitch_stable"] else "unstable",
                    "stable" if o["roll_yaw_stable"] else "unstable",
                    fmt(o["pitch_libration_period_minutes"]),
                    "n/a" if ry is None else ", ".join(fmt(p) for p in o["roll_yaw_periods_minutes"]),
                ]
            )
        out.append(
            _t(
                [
                    "orientation",
                    "roll, pitch, yaw moments [kg m^2]",
                    "region",
                    "pitch",
                    "roll-yaw",
                    "pitch libration period [min]",
                    "roll-yaw periods [min]",
                ],
                rows,
            )
        )
    out += _figure(results, "body_polhodes")
    return out


# ---------------------------------------------------------------------------
# 2. Linear design


def _poles_table(poles: list[dict[str, Any]]) -> Table:
    rows = []
    for p in poles:
        im = p["imag"]
        pole = fmt(p["real"]) + (f" ± {fmt(im)}j" if abs(im) > 0 else "")
        rows.append([pole, fmt(p["wn_rad_per_s"]), fmt(p["zeta"])])
    return _t(["closed-loop pole [1/s]", "natural frequency [rad/s]", "damping"], rows)


def _linear(results: dict[str, Any]) -> list[Block]:
    lin = results["linear"]
    pd = lin["pd"]
    period = lin["period_s"]
    out: list[Block] = [
        Paragraph(
            f"Controller sample period {fmt(period)} s ({fmt(lin['rate_Hz'])} Hz). Quaternion-feedback PD from "
            f"the natural frequency {fmt(pd['bandwidth_rad_per_s'])} rad/s and damping {fmt(pd['damping'])}: "
            "K = 2 I wn^2 and C = 2 I zeta wn with the full inertia tensor (the factor 2 because the error "
            "quaternion's vector part is half the angle), plus gyroscopic compensation. "
            + (
                "Mismatch checks (bandwidth against the sample rate, the sampled loops' stability, LQR poles against "
                "the bandwidth the settling time needs): "
                + (" ".join(f["message"] + "." for f in lin.get("findings") or []) or "none found.")
            )
        ),
        _t(
            ["row", "K x [N m]", "K y [N m]", "K z [N m]", "C x [N m s]", "C y [N m s]", "C z [N m s]"],
            [[a] + [fmt(v) for v in k] + [fmt(v) for v in c] for a, k, c in zip("xyz", pd["K_Nm"], pd["C_Nms"])],
            "PD gains (torque = -K sgn(q_e0) q_ev - C omega_e)",
        ),
        _poles_table(pd["poles"]),
    ]
    lqr = lin["lqr"]
    if lqr is None:
        out.append(Paragraph("No [control.lqr] table in the spacecraft file: no LQR design."))
    else:
        out.append(
            Paragraph(
                f"Discrete LQR at {fmt(period)} s by Bryson's rule: largest acceptable attitude error "
                f"{_vec(lqr['angle_max_deg'])} deg, rate error {_vec(lqr['rate_max_deg_per_s'])} deg/s and torque "
                f"{_vec([1e3 * v for v in lqr['torque_max_Nm']])} mN m per axis. Closed-loop poles as s-plane "
                "equivalents; the "
                f"slowest decays at {fmt(lqr['slowest_decay_rate_per_s'])} 1/s."
            )
        )
        out.append(
            _t(
                ["row", "q_e1", "q_e2", "q_e3", "omega_1 [s]", "omega_2 [s]", "omega_3 [s]"],
                [[a] + [fmt(v) for v in row] for a, row in zip("xyz", lqr["K"])],
                "LQR gain K [N m per state unit]: torque = -K [q_ev, omega]",
            )
        )
        out.append(_poles_table(lqr["poles"]))
    out.append(
        Paragraph(
            "Margins per axis, loop broken at the plant input with the other axes closed: the continuous loops and "
            f"the sampled loops (zero-order hold at {fmt(period)} s). The delay margin is the extra computation "
            "delay each loop tolerates."
        )
    )

    def margin(m: dict, key: str) -> str:
        # Margins of an unstable closed loop are not margins (no stable gain interval to bound).
        return fmt(m[key]) if m["stable"] else "n/a"

    rows = [
        [
            m["controller"],
            m["loop"],
            m["axis"],
            margin(m, "gain_margin_db"),
            margin(m, "phase_margin_deg"),
            margin(m, "delay_margin_s"),
            margin(m, "gain_crossover_rad_per_s"),
            "stable" if m["stable"] else "UNSTABLE",
        ]
        for m in lin["margins"]
    ]
    out.append(
        _t(
            [
                "controller",
                "loop",
                "axis",
                "gain margin [dB]",
                "phase margin [deg]",
                "delay margin [s]",
                "crossover [rad/s]",
                "closed loop",
            ],
            rows,
        )
    )
    out += _disk_margins(lin.get("disk_margins") or [], period)
    if lin.get("disk_margin_note"):
        out.append(Paragraph(lin["disk_margin_note"]))
    for name in ("pd_step", "pd_bode", "pd_bode_sampled", "lqr_bode_sampled", "disk_margins", "pd_nichols"):
        out += _figure(results, name)
    out += _robust(lin.get("robust"), results)
    out += _tuning(lin.get("tuning"), results)
    return out


def _robust(robust: dict[str, Any] | None, results: dict[str, Any]) -> list[Block]:
    if robust is None:
        return [Paragraph("No [uncertainty] table in the spacecraft file: no worst-case search.")]
    out: list[Block] = [
        Paragraph(
            f"Worst case over the [uncertainty] set, {robust['controller']}: found by optimisation (corner local "
            "searches, then differential evolution) and compared with uniform samples of the same set; an unstable "
            "closed loop counts as no margin. The disk margin is that of the loop that flies (the file's modes on "
            "every plant, its filters on the command); the step is the linear reference loop's, without filters. "
            + " ".join(line if line.endswith(".") else line + "." for line in robust["summary"])
            + _robust_floor(robust)
        )
    ]
    for name in ("robust_disk_margin", "robust_overshoot_percent", "robust_settling_time_s"):
        out += _figure(results, name)
    return out


def _robust_floor(robust: dict[str, Any]) -> str:
    """A sentence when the worst disk margin over the set is below the requirement's floor (else nothing)."""
    floor, worst = robust.get("disk_margin_min"), robust.get("worst_disk_margin")
    if floor is None or worst is None or worst >= floor:
        return ""
    return (
        f" The worst disk margin over the set, {fmt(worst)}, is below requirements.disk_margin_min = {fmt(floor)}: "
        "the nominal design meets the floor, this spacecraft of the set would not."
    )


def _tuning(tuning: dict[str, Any] | None, results: dict[str, Any]) -> list[Block]:
    if tuning is None:
        return [Paragraph("No requirements.disk_margin_min in the spacecraft file: no tuning to the requirements.")]
    if "error" in tuning:
        return [Paragraph(f"Tuning to the requirements: {tuning['error']}")]
    text = (
        f"Tuned to the requirements (`attitude tune` writes the tuned file): a {fmt(tuning['step_angle_deg'])} deg "
        f"step settled within the pointing accuracy, the wheels' torque and momentum, the disk-margin floor; "
        f"{tuning['cost']} minimised. {tuning['message']}."
    )
    nonlinear = tuning.get("nonlinear")
    if nonlinear is not None:
        text += (
            f" On the nonlinear plant through the wheels the tuned step settles in {fmt(nonlinear['settling_time_s'])} "
            f"s ({'PASS' if nonlinear['passed'] else 'FAIL'})."
        )
    flexible = tuning.get("nonlinear_flexible")
    if flexible is not None:
        text += (
            f" On the {flexible['plant']}, with the file's filters, it settles in "
            f"{fmt(flexible['settling_time_s'])} s ({'PASS' if flexible['passed'] else 'FAIL'})."
        )
    flown = tuning.get("flown_disk_margin")
    if flown is not None:
        text += (
            f" The tuning judges the disk margin on the loops that fly, with the file's flexible modes and filters: "
            f"the tuned PD's smallest, per axis and multiloop, is {fmt(flown)}."
        )
    rows = [
        [r["metric"], fmt(r["before"]), fmt(r["after"]) if tuning["feasible"] else "n/a", r["required"] or ""]
        for r in tuning["table"]
    ]
    return [
        Paragraph(text),
        _t(["metric", "before (the file)", "after (tuned)", "required"], rows),
        *_figure(results, "tuning_tradeoff"),
    ]


def _disk_margins(rows: list[dict[str, Any]], period: float) -> list[Block]:
    if not rows:
        return []

    def cell(m: dict, key: str) -> str:
        if "note" in m:
            return "n/a"
        return fmt(m[key]) if m["stable"] else "n/a"

    def state(m: dict) -> str:
        if "note" in m:
            return m["note"]
        if not m["stable"]:
            return "UNSTABLE"
        return "stable" if m["converged"] else "stable, NOT converged"

    table = [
        [
            m["controller"],
            m.get("plant", "rigid"),
            m["break_point"],
            m["channel"],
            cell(m, "disk_margin"),
            cell(m, "gain_margin_db"),
            cell(m, "phase_margin_deg"),
            cell(m, "frequency_rad_per_s"),
            state(m),
        ]
        for m in rows
    ]
    return [
        Paragraph(
            f"Disk margins of the sampled loops ({fmt(period)} s, zero-order hold): every gain and phase change "
            "inside the disk keeps the loop stable, the gain and phase changing together (Seiler, Packard and "
            "Gahinet 2020). At the plant input each axis alone (the others closed) and all three at once (the "
            "wheels' torque scale and lag); at the plant output the six measurements (attitude and rate) at once "
            "(the star tracker's and gyro's). The closed loop's stability is checked first and the worst frequency "
            "refined. A multiloop margin below the per-axis ones is coupling that loop-at-a-time margins miss. "
            "With [[flexible_modes]] the loops are also judged on the flexible plant (hybrid coordinates), and with "
            "[[control.filters]] with the filters in series on the command (Tustin, pre-warped), as they fly."
        ),
        _t(
            [
                "controller",
                "plant",
                "broken at",
                "channels",
                "disk margin",
                "gain [+-dB]",
                "phase [+-deg]",
                "at [rad/s]",
                "closed loop",
            ],
            table,
        ),
    ]


# ---------------------------------------------------------------------------
# 3. Slews


def _slews(results: dict[str, Any]) -> list[Block]:
    s = results["slews"]
    plan, eig = s["plan"], s["eigenaxis"]
    cones = s["keep_out"]
    rate = s["plan_rate_max_deg_per_s"]
    text = (
        f"The required slew: {fmt(s['angle_deg'])} deg from q_BN = {_vec(s['q_start_BN'])} to "
        f"{_vec(s['q_target_BN'])}. Both are planned with {fmt(s['plan_torque_percent'])} % of the wheels' "
        f"torque (body envelope {_vec(s['torque_envelope_mNm'])} mN m per axis)"
    )
    if rate is not None:
        text += f" and {fmt(s['plan_rate_percent'])} % of the rate limit ({fmt(rate)} deg/s)"
    text += ", leaving the feedback authority on top of the feedforward."
    if s.get("momentum_rate_max_deg_per_s") is not None:
        text += (
            f" The wheels hold -I omega during the slew, so both are also rate-limited to keep the wheel momentum "
            f"within {fmt(100.0 * s['plan_momentum_fraction'])} % of its limit: "
            f"{fmt(s['planner_rate_max_deg_per_s'])} deg/s for the optimal plan (any direction) and "
            f"{fmt(s['eigenaxis_rate_max_deg_per_s'])} deg/s along the eigenaxis."
        )
    if cones and plan is None:
        text += (
            " The optimal plan could not be made (below), so no slew here is shown to keep out of "
            + ", ".join(f"'{c['name']}'" for c in cones)
            + "; the eigenaxis slew cannot avoid a cone."
        )
    elif cones:
        text += (
            " The optimal plan keeps out of "
            + ", ".join(f"'{c['name']}' (planned at {fmt(c['planned_half_angle_deg'])} deg)" for c in cones)
            + "; the eigenaxis slew cannot avoid a cone."
        )
    out: list[Block] = [Paragraph(text)]
    if s["error"]:
        out.append(Paragraph(f"Planning problem: {s['error']}"))
    names = [
        "quantity",
        "optimal plan" if plan is None else f"{plan['name']} (optimal plan)",
        "eigenaxis",
        "requirement",
    ]
    rows = []

    def row(label: str, key: str, required: str = "") -> list[str]:
        return [label] + [fmt(None if x is None else x[key]) for x in (plan, eig)] + [required]

    rows.append(row("duration [s]", "duration_s", f"<= {fmt(s['time_max_s'])}"))
    limit = s["rate_max_deg_per_s"]
    rows.append(row("peak body rate [deg/s]", "rate_peak_deg_per_s", "" if limit is None else f"<= {fmt(limit)}"))
    rows.append(row("peak torque [mN m]", "torque_peak_mNm"))
    rows.append(row("energy, integral of |torque|^2 [N^2 m^2 s]", "energy_N2m2s"))
    for c in cones:
        vals = [None if x is None else x["separation_min_deg"][c["name"]] for x in (plan, eig)]
        rows.append([f"smallest separation '{c['name']}' [deg]", *map(fmt, vals), f">= {fmt(c['half_angle_deg'])}"])
    out.append(_t(names, rows, "Side by side (the requirements are judged on the flown slew, section 4)"))
    if plan is not None:
        detail = (
            f"Planner: {s['nodes']} intervals, IPOPT status {plan['status']}, "
            f"{'switch times refined' if plan['refined'] else 'not refined'} (grid duration "
            f"{fmt(plan['grid_duration_s'])} s), {fmt(plan['solve_time_s'])} s in IPOPT; the open-loop "
            f"re-simulation of the plan ends {fmt(plan['open_loop_final_error_deg'])} deg from the target."
        )
        if s["speedup_percent"] is not None:
            if s["speedup_percent"] >= 0:
                detail += f" The plan is {fmt(s['speedup_percent'])} % faster than the eigenaxis slew."
            else:
                detail += (
                    f" The plan takes {fmt(s['slowdown_percent'])} % longer than the eigenaxis slew: the price of the "
                    "keep-out detour and of respecting the limits on every axis."
                )
        out.append(Paragraph(detail))
    out += _figure(results, "slew_plan") + _figure(results, "slew_comparison")
    return out


# ---------------------------------------------------------------------------
# 4. Closed loop


def _settling_text(f: dict[str, Any]) -> str:
    text = fmt(f["settling_time_after_slew_s"])
    if math.isinf(float(f["flown_slew_time_s"])):
        text += " (never stays within the accuracy)"
    elif float(f["flown_slew_time_s"]) <= f["slew_end_s"]:
        text += f" (the error to the target is within the accuracy from {fmt(f['flown_slew_time_s'])} s on)"
    return text


def _closed_loop(results: dict[str, Any]) -> list[Block]:
    f = results["closed_loop"]
    if f is None:
        return [Paragraph("Nothing to fly: neither the optimal plan nor the eigenaxis slew could be made.")]
    out: list[Block] = [
        Paragraph(
            f"The {f['reference']} flown on the nonlinear plant for {fmt(f['duration_s'])} s (tick "
            f"{fmt(f['tick_s'])} s): tracking control (plan torque as feedforward, quaternion PD feedback at "
            f"{fmt(f['tracking_wn_rad_per_s'])} rad/s and damping {fmt(f['tracking_damping'])}), reaction wheels "
            "with their torque and momentum limits, the gyro and the star tracker of the file, and the MEKF in the "
            f"loop from an initial knowledge error of {fmt(f.get('drawn_initial_knowledge_error_arcsec'))} arcsec "
            "(drawn from the filter's initial covariance; "
            f"{fmt(f['initial_knowledge_error_arcsec'])} arcsec after the first star-tracker update). The slew "
            f"ends at {fmt(f['slew_end_s'])} s. {f.get('judged_how', '')} The Monte Carlo campaigns and the "
            "dispersed check judge their runs the same way. "
            + (
                "Flown in empty inertial space (no [orbit] in the file)."
                if not f.get("environment")
                else "Flown in the orbit of section 6 from its epoch, with "
                + ", ".join(
                    f"{k.replace('_', ' ')} (peak {fmt(v)} uN m)"
                    for k, v in f.get("disturbance_torque_peak_uNm", {}).items()
                )
                + f": {f['environment']}."
            )
        )
    ]
    rows = [
        ["slew time, planned [s]", fmt(f.get("plan_slew_time_s"))],
        [
            "slew time, flown (error to the target within the accuracy from then on, to the hold) [s]",
            fmt(f.get("flown_slew_time_s")),
        ],
        ["settling time after the end of the slew (error to the target) [s]", _settling_text(f)],
        [
            "largest error to the target after the end of the slew [deg]",
            fmt(f.get("pointing_error_max_after_slew_deg")),
        ],
        ["largest error to the target over the hold [deg]", fmt(f["pointing_error_max_in_window_deg"])],
        ["largest error to the moving reference over the hold [deg]", fmt(f.get("tracking_error_max_in_window_deg"))],
        ["pointing error at the end [deg]", fmt(f["pointing_error_end_deg"])],
        ["pointing error at the end [arcsec]", fmt(f["pointing_error_end_arcsec"])],
        ["knowledge error after settling, RMS [arcsec]", fmt(f["knowledge_error_rms_in_window_arcsec"])],
        ["knowledge error after settling, largest [arcsec]", fmt(f["knowledge_error_max_in_window_arcsec"])],
        ["peak body rate [deg/s]", fmt(f["rate_peak_deg_per_s"])],
    ]
    for name, sep in f["separation_min_deg"].items():
        rows.append([f"smallest separation '{name}' [deg]", fmt(sep)])
    rows += [
        [
            "ticks on which the wheels cut the commanded torque [%]",
            fmt(100.0 * f.get("torque_saturated_fraction", 0.0)),
        ],
        [
            "peak commanded / applied body torque [mN m]",
            f"{fmt(f.get('torque_command_peak_mNm'))} / {fmt(f.get('torque_applied_peak_mNm'))}",
        ],
        ["peak wheel speed [rpm]", f"{fmt(f['wheel_speed_peak_rpm'])} (limit {fmt(f['wheel_speed_limit_rpm'])})"],
        [
            "peak wheel momentum [N m s]",
            f"{fmt(f['wheel_momentum_peak_Nms'])} (limit {fmt(f['wheel_momentum_limit_Nms'])})",
        ],
        ["peak motor torque [mN m]", f"{fmt(f['motor_torque_peak_mNm'])} (limit {fmt(f['motor_torque_limit_mNm'])})"],
        [
            "star-tracker updates (blinded samples)",
            f"{fmt(f['tracker_updates'])} ({fmt(f['tracker_blinded_samples'])})",
        ],
    ]
    out.append(_t(["closed-loop figure", "value"], rows))
    out += _figure(results, "pointing") + _figure(results, "closed_loop")
    return out


# ---------------------------------------------------------------------------
# 5. Estimation


def _mount_approach(sigma_arcsec: float) -> str:
    """How the star tracker's mounting error is treated (issue 16: the report says which approach was taken)."""
    if not sigma_arcsec:
        return "The file disperses no star-tracker mounting error: the filters see a perfect mount."
    return (
        f"The star tracker's mounting error ({fmt(sigma_arcsec)} arcsec per axis, 1 sigma, in the Monte Carlo "
        "table) is not estimated: with one attitude sensor it cannot be told from the attitude, so the MEKF "
        "converges to the tracker's frame. It is accounted for as a consider covariance: the Monte Carlo "
        "campaign (attitude montecarlo) judges each run's attitude NEES against the filter's covariance plus "
        "the mount's. The runs above fly a perfect mount."
    )


def _estimation(results: dict[str, Any]) -> list[Block]:
    e = results["estimation"]
    if e is None:
        return [Paragraph("No flown slew to serve as the truth: estimation not analysed.")]
    m, r = e["mekf"], e["rate_ekf"]
    out: list[Block] = [
        Paragraph(
            f"Both filters run over {e['truth']} ({e['steps']} gyro steps of {fmt(e['gyro_period_s'])} s; star "
            f"tracker every {e['tracker_every_steps']} steps, {e['tracker_blinded_steps']} steps blinded by the "
            "Sun). Each Monte Carlo run draws its own gyro noise (the file's angle random walk, its bias "
            "instability as a Gauss-Markov bias and its rate random walk; the filters model the bias as a random walk "
            "tuned by Gyro.filter_sigma_u), "
            "star-tracker noise and initial errors from the filters' initial covariance: "
            f"{fmt(e['attitude_sigma0_deg'])} deg attitude, {fmt(e['bias_sigma0_deg_per_h'])} deg/h bias and "
            f"{fmt(e['rate_sigma0_deg_per_s'])} deg/s rate (1 sigma per axis). A consistent filter keeps the "
            f"average NEES (6 degrees of freedom) inside its {fmt(e['confidence_percent'])} % chi-square band. The "
            f"rate EKF uses a torque uncertainty of {fmt(r['torque_noise_Nm_per_sqrt_Hz'])} N m/sqrt(Hz), the "
            "wheel tachometers and, as its known external torque, the flight's environment torques (peak "
            f"{fmt(r.get('external_torque_peak_uNm', 0.0))} uN m; a torque left out would be a rate error common "
            "to every run); a gyro alone separates rate and bias only through the gyroscopic dynamics, so its "
            "bias uncertainty stays large during a slow slew."
        ),
        Paragraph(_mount_approach(e.get("tracker_mount_sigma_arcsec", 0.0))),
    ]
    rows = []
    for f in (m, r):
        rows.append(
            [
                f["label"],
                fmt(f["runs"]),
                fmt(f["nees_mean"]),
                f"[{fmt(f['band_low'])}, {fmt(f['band_high'])}]",
                fmt(f["percent_inside"]),
            ]
        )
    out.append(_t(["filter", "runs", "average NEES, mean over time", "95 % band", "steps inside the band [%]"], rows))
    out.append(
        _t(
            ["filter", "error at the end, RMS over runs", "3-sigma at the end (largest axis)"],
            [
                [
                    "MEKF attitude [arcsec]",
                    fmt(m["attitude_error_rms_end_arcsec"]),
                    fmt(m["attitude_3sigma_end_arcsec"]),
                ],
                ["MEKF gyro bias [deg/h]", fmt(m["bias_error_rms_end_deg_per_h"]), fmt(m["bias_3sigma_end_deg_per_h"])],
                [
                    "rate EKF body rate [deg/h]",
                    fmt(r["rate_error_rms_end_deg_per_h"]),
                    fmt(r["rate_3sigma_end_deg_per_h"]),
                ],
                [
                    "rate EKF gyro bias [deg/h]",
                    fmt(r["bias_error_rms_end_deg_per_h"]),
                    fmt(r["bias_3sigma_end_deg_per_h"]),
                ],
            ],
        )
    )
    for name in ("mekf_errors", "mekf_nees", "rate_ekf_errors", "rate_ekf_nees"):
        out += _figure(results, name)
    return out


# ---------------------------------------------------------------------------
# 6. Orbit


def _orbit(results: dict[str, Any]) -> list[Block]:
    o = results.get("orbit")
    if o is None:
        return [
            Paragraph(
                "No [orbit] table in the spacecraft file: the spacecraft is flown in empty inertial space, with no "
                "disturbance torques, momentum budget or detumbling study."
            )
        ]
    b = o["momentum"]
    names = {
        "gravity_gradient": "gravity gradient",
        "aerodynamic": "aerodynamic",
        "solar_pressure": "solar radiation pressure",
        "magnetic": "residual dipole",
    }
    rows = [
        [names.get(k, k), fmt(v["peak_uNm"]), fmt(v["mean_uNm"]), _vec(v["orbit_average_body_uNm"])]
        for k, v in b["torques"].items()
    ]
    rows.append(["total", "", "", _vec(b["total_orbit_average_body_uNm"])])
    out: list[Block] = [
        Paragraph(
            f"Orbit: {b['orbit']}. Environment: {b['environment']}. Attitude: {b['pointing']}. The torques are "
            "evaluated on the nominal attitude; the orbit average in body axes is the part that accumulates in the "
            "wheels."
        ),
        _t(
            ["source", "peak [uN m]", "mean magnitude [uN m]", "orbit average, body [uN m]"],
            rows,
            "Disturbance torques over one orbit",
        ),
        *_figure(results, "orbit_torques"),
    ]
    free, unl = b["no_dumping"], b["unloading"]
    text = (
        f"Momentum budget over {fmt(b['orbits'])} orbits ({fmt(b['step_s'])} s steps; the budget of a perfect "
        "attitude control: the wheels carry whatever the external torques add to the spacecraft's momentum). "
        f"Without dumping the spacecraft's momentum grows by {fmt(free['secular_rate_magnitude_uNms_per_orbit'])} "
        f"uN m s per orbit ({_vec(free['secular_rate_inertial_uNms_per_orbit'])} in the inertial frame, "
        "least-squares slope: the body components across the orbit normal turn with a nadir-pointing body) and "
        f"the wheel momentum peaks at {fmt(free['peak_body_mNms'])} mN m s; the largest "
        f"wheel then stores {fmt(max(free['peak_per_wheel_mNms']))} mN m s of its "
        f"{fmt(min(free['capacity_per_wheel_mNms']))} mN m s."
    )
    if unl is None:
        text += " No magnetic unloading in the file ([magnetorquers] and [momentum] unloading_gain_per_s)."
    else:
        text += (
            f" With cross-product unloading (gain {fmt(unl['gain_per_s'])} 1/s, peak dipole "
            f"{fmt(unl['dipole_peak_Am2'])} A m^2) the momentum stays below {fmt(unl['peak_body_mNms'])} mN m s "
            f"({fmt(unl['last_orbit_peak_body_mNms'])} mN m s in the last orbit); the largest wheel stores "
            f"{fmt(max(unl['peak_per_wheel_mNms']))} mN m s."
        )
    text += (
        f" Judged case: {b['judged_case']}, against {fmt(b['wheel_momentum_margin'])} of each wheel's capacity: "
        + verdict_text(b["pass"])
        + "."
    )
    out += [Paragraph(text), *_figure(results, "orbit_momentum")]
    h = o.get("nadir_hold")
    if h is not None:
        unloading = (
            f" and cross-product unloading on the true field (peak dipole {fmt(h['dipole_peak_Am2'])} A m^2)"
            if h["unloading"]
            else " (no unloading in the file)"
        )
        out += [
            Paragraph(
                f"Nadir hold flown in closed loop for {fmt(h['orbits'])} orbit ({fmt(h['duration_s'])} s, "
                f"{h['engine']} engine): the [control] PD on the LVLH frame with the wheels, the four disturbance "
                f"torques{unloading}. Pointing error to the LVLH frame: largest {fmt(h['pointing_error_max_deg'])} "
                f"deg, RMS {fmt(h['pointing_error_rms_deg'])} deg; peak wheel speed "
                f"{fmt(h['wheel_speed_peak_rpm'])} rpm, peak motor torque {fmt(h['motor_torque_peak_mNm'])} mN m."
            ),
            *_figure(results, "orbit_nadir_hold"),
        ]
    d = o["detumble"]
    if d is None:
        out.append(Paragraph("No [detumble] table: detumbling not studied."))
        return out
    gain = f"{fmt(d['gain_Nms'])} N m s" + (" (automatic: 2 n (1 + sin i) J_min)" if d["gain_is_auto"] else "")
    if d["detumbled"]:
        outcome = (
            f"the rate stays below {fmt(d['rate_threshold_deg_per_s'])} deg/s from "
            f"{fmt(d['time_to_detumble_s'])} s ({fmt(d['time_to_detumble_orbits'])} orbits) on"
        )
    else:
        outcome = (
            f"NOT detumbled in the {fmt(d['duration_simulated_s'])} s simulated: the rate ends at "
            f"{fmt(d['final_rate_deg_per_s'])} deg/s, above the {fmt(d['rate_threshold_deg_per_s'])} deg/s threshold"
        )
    out += [
        Paragraph(
            f"Detumbling from the tip-off rate {_vec(d['tip_off_rate_deg_per_s'])} deg/s with the B-dot law on the "
            f"magnetometer's samples (gain {gain}; rods limited to {_vec(d['dipole_max_Am2'])} A m^2, saturated "
            f"{fmt(100 * d['dipole_saturated_fraction'], 3)} % of the time), flown with the environment on: "
            f"{outcome}. Total angular momentum {fmt(d['momentum_initial_mNms'])} -> "
            f"{fmt(d['momentum_final_mNms'])} mN m s."
        ),
        *_figure(results, "detumble"),
    ]
    return out


# ---------------------------------------------------------------------------
# 8. Requirements


# ---------------------------------------------------------------------------
# 7. Attitude determination


def _determination(results: dict[str, Any]) -> list[Block]:
    d = results.get("determination")
    if d is None:
        return [
            Paragraph(
                "No direction sensor ([magnetometer], [coarse_sun_sensors], [fine_sun_sensor]) with an [orbit] in "
                "the spacecraft file: determination from the Sun and the field not analysed."
            )
        ]
    sensors = ", ".join(d["sensor_labels"])
    if d["excluded_sensors"]:
        sensors += " (left out: " + "; ".join(d["excluded_sensors"]) + ")"
    systematic = d["systematic_errors"]
    models = (
        "Two sensor models: **noise**, each direction sensor's white noise alone (what QUEST and the MEKF model; "
        "their consistency is judged on it), and **file**, the sensors as the file describes them, with "
        + "; ".join(systematic)
        + ". Neither estimator estimates those errors, so with them their covariance is too small: the file rows "
        "show by how much. Left out of both: the on-board field model's error (the reference field here is the "
        "truth's) and the gyro's scale factor and misalignment."
        if systematic
        else "The file's direction sensors have white noise only: one sensor model."
    )
    out: list[Block] = [
        Paragraph(
            f"Sensors: {sensors}. Truth: one orbit of the nadir (LVLH) hold, {fmt(d['duration_s'])} s in steps of "
            f"{fmt(d['step_s'])} s ({fmt(100 * d['eclipse_fraction'])} % of it with less than half the Sun's disk), "
            f"{d['runs']} Monte Carlo runs per model, each with its own sensor noise"
            + (" (a first look: with so few runs the NEES checks below have little power)" if d["runs"] < 10 else "")
            + ". Every sensor is read once per "
            "step: the samples of a faster sensor in between are not used, so the figures are those of a "
            f"{fmt(1.0 / d['step_s'])} Hz determination. {models}"
        )
    ]
    found = d.get("sun_vector_fraction_of_sunlit") or {}
    if found:
        parts = [
            f"the {'coarse cells' if k == 'coarse_sun_sensors' else 'fine sensor'} at {fmt(100 * v)} %"
            for k, v in found.items()
        ]
        text = "Sun vector found at the steps with at least half the Sun's disk: " + ", ".join(parts) + "."
        if found.get("coarse_sun_sensors") == 0.0:
            text += (
                " The coarse cells never found the Sun: their lit rows never spanned three dimensions (cells "
                "narrower than a hemisphere pair up with no opposite cell, and a Sun in a plane of their normals "
                "lights at most two independent ones)."
            )
        out.append(Paragraph(text))
    st = d["static"]
    if st is None:
        out.append(
            Paragraph(
                "Static determination needs two directions, the Sun and the field: one of them is not flown, so "
                "only the MEKF below determines the attitude (with one direction, the rotation about it is observed "
                "only through the gyro)."
            )
        )
    else:
        rows = []
        for model, e in st.items():
            if not e["solutions"]:
                rows.append([model, fmt(100 * e["available_fraction"]), "no solution", "", "", "", "", ""])
                continue
            rows.append(
                [
                    model,
                    fmt(100 * e["available_fraction"]),
                    fmt(e["quest_error_rms_deg"]),
                    fmt(e["quest_error_p95_deg"]),
                    fmt(e["quest_error_max_deg"]),
                    fmt(e["triad_error_rms_deg"]),
                    fmt(e["quest_3sigma_median_deg"]),
                    f"{fmt(e['nees_mean'])} in [{fmt(e['nees_band_low'])}, {fmt(e['nees_band_high'])}]: {e['verdict']}",
                ]
            )
        out.append(
            Paragraph(
                "Static determination at each step with both a Sun direction (the fine sensor when in view, else the "
                "coarse cells' least squares) and the field: QUEST with its covariance (Shuster and Oh 1981), and "
                "TRIAD with the more accurate vector as primary; none where the Sun sensors find no Sun (umbra, and "
                "outside a fine sensor's view; the coarse cells may still find it in the penumbra). QUEST takes one "
                "sigma per vector: for the coarse cells the largest axis of their covariance (conservative where it "
                "is not isotropic), for a fine sensor its angle noise (conservative off its boresight, where an "
                "angle error turns the direction less). The NEES (3 "
                "degrees of freedom) is averaged over every solution of every run: independent samples, so its band "
                f"is that of the mean of that many chi-square values ({fmt(d['confidence_percent'])} %)."
            )
        )
        out.append(
            _t(
                [
                    "model",
                    "orbit with a solution [%]",
                    "QUEST error RMS [deg]",
                    "95th percentile [deg]",
                    "largest [deg]",
                    "TRIAD error RMS [deg]",
                    "QUEST 3-sigma, median [deg]",
                    "QUEST NEES, mean",
                ],
                rows,
            )
        )
        out += _figure(results, "determination_static")
    rows = []
    for model, e in d["mekf"].items():
        rows.append(
            [
                model,
                f"{fmt(e['nees_mean'])} ({fmt(100 * e['fraction_inside'])} % of steps in [{fmt(e['band_low'])}, "
                f"{fmt(e['band_high'])}]; attitude alone {fmt(100 * e['attitude_fraction_inside'])} %): "
                f"{e['verdict']}",
                f"{fmt(e['attitude_nees_mean'])} / {fmt(e['bias_nees_mean'])}",
                f"{fmt(e['error_rms_sunlit_deg'])} / {fmt(e['sigma_rms_sunlit_deg'])}",
                f"{fmt(e['error_rms_eclipse_deg'])} / {fmt(e['sigma_rms_eclipse_deg'])}",
                f"{fmt(e['error_max_sunlit_deg'])} / {fmt(e['error_max_eclipse_deg'])}",
            ]
        )
    out.append(
        Paragraph(
            "MEKF with the gyro's angle increments over each step and the direction sensors, no star tracker (a "
            f"spacecraft without one, or with it blinded), from a {fmt(d['attitude_sigma0_deg'])} deg start (1 sigma "
            "per axis, drawn from the filter's initial covariance, so the NEES holds from the first step; it is "
            "averaged over every step). The gyro draws the file's noise (angle random walk, the bias instability "
            "as a Gauss-Markov bias, rate random walk) in both models; the filter models the bias as a random walk "
            "tuned by Gyro.filter_sigma_u, a bound on the Gauss-Markov increments (docs/sensors.md), so its bias "
            "covariance, and in eclipse, where the gyro carries the attitude, its attitude covariance, can be "
            "conservative: the attitude and bias NEES (3 degrees of freedom each; the band of one step's average "
            f"[{fmt(d['mekf']['noise']['part_band_low'])}, {fmt(d['mekf']['noise']['part_band_high'])}]) say "
            "which. Errors and the filter's own sigma are taken after the first tenth of the orbit (the "
            "convergence); sigma is sqrt(trace P) of the attitude, the RMS of the error angle a consistent filter "
            "gives."
        )
    )
    out.append(
        _t(
            [
                "model",
                "average NEES (6 dof), mean",
                "attitude / bias NEES, mean",
                "sunlit: error RMS / sigma [deg]",
                "eclipse: error RMS / sigma [deg]",
                "largest error, sunlit / eclipse [deg]",
            ],
            rows,
        )
    )
    for name in ("determination_mekf", "determination_nees"):
        out += _figure(results, name)
    return out


def requirement_rows(rows: list[dict[str, Any]]) -> list[list[str]]:
    """Table rows (requirement, key, required, achieved, verdict) shared by the report and the terminal.

    Parameters
    ----------
    rows : list of dict
        The requirement rows of the results (``results["requirements"]``).
    """
    out = []
    for r in rows:
        unit = f" {r['unit']}" if r["unit"] else ""
        out.append(
            [
                r["requirement"],
                r["key"] or "(guideline)",
                f"{r['comparison']} {fmt(r['required'])}{unit}",
                fmt(r["achieved"]) + (unit if r["achieved"] is not None else ""),
                verdict_text(r["pass"]),
            ]
        )
    return out


def _dispersed(d: dict[str, Any] | None) -> list[Block]:
    """The dispersed check's paragraph."""
    if d is None:
        return [Paragraph("No [montecarlo] table: no dispersed check; the verdict is the nominal spacecraft's.")]
    if "error" in d:
        return [Paragraph(f"The dispersed check could not be flown, so it fails: {d['error']}")]
    text = (
        f"Dispersed check: {d['runs']} runs of the file's [montecarlo] dispersions (seed {d['seed']}), each flying "
        f"the planned slew in closed loop for {fmt(d['duration_s'])} s (the slew, the settling time and the hold) "
        "and judged by the same requirements, definitions and windows as the table above ("
        + ", ".join(f"{name}: {v['passed']}/{d['runs']} passed" for name, v in d["requirements"].items())
        + f"). {d['statement']}. A failing run fails the design. The same runs: `{d['command']}`."
    )
    if d["failing_runs"]:
        listed = "; ".join(
            f"run {f['run']} missed {', '.join(f['missed']) or 'nothing'}" + (f" ({f['error']})" if f["error"] else "")
            for f in d["failing_runs"]
        )
        text += f" First failing runs: {listed}."
    return [Paragraph(text)]


def diagnostics_lines(results: dict[str, Any]) -> list[str]:
    """Mismatch findings and the closed loop's saturation, one line each (shown whatever the verdict).

    Parameters
    ----------
    results : mapping
        The JSON-ready results of the design.
    """
    lines = [f"Mismatch: {f['message']}" for f in ((results.get("linear") or {}).get("findings") or [])]
    flight = results.get("closed_loop")
    if flight is not None and "torque_saturated_fraction" in flight:
        f = flight
        lines.append(
            f"Saturation (closed loop): the wheels cut the command on {100 * f['torque_saturated_fraction']:.3g} % "
            f"of the ticks; command peak {f['torque_command_peak_mNm']:.4g} mN m, applied "
            f"{f['torque_applied_peak_mNm']:.4g} mN m (ratio {f['torque_command_to_applied_peak_ratio']:.3g}); "
            f"wheel speed margin {f['wheel_speed_margin_percent']:.3g} % of the limit"
        )
    return lines


def _reasons(rows: list[dict[str, Any]]) -> list[Block]:
    """One line per failing row saying why (:func:`attitude.app.design.reasons.failure_reason`)."""
    lines = [f"{r['id']}: {r['reason']}" for r in rows if not r["pass"] and r.get("reason")]
    return [Paragraph("Why each failing requirement fails: " + " | ".join(lines) + ".")] if lines else []


def _requirements(results: dict[str, Any]) -> list[Block]:
    verdict = results["verdict"]
    header = ["requirement", "file key", "required", "achieved", "verdict"]
    n_fail = len(verdict["failed"])
    summary = (
        "All requirements pass."
        if verdict["pass"]
        else f"{n_fail} of {len(results['requirements'])} requirements FAIL: {', '.join(verdict['failed'])}."
    )
    return [
        Paragraph(
            "Each requirement of the spacecraft file against the achieved figure of the sections above (the same "
            "numbers, from results.json). 'Flown' figures come from the closed-loop run of section 4. "
            + ((results.get("closed_loop") or {}).get("judged_how") or "")
            + " "
            + summary
        ),
        _t(header, requirement_rows(results["requirements"]), "Requirements (they decide the exit code)"),
        *_reasons(results["requirements"]),
        *_dispersed(results.get("dispersed")),
        Paragraph(
            "Advisory design checks: classical guidelines and consistency checks that are not requirements of "
            "the file and do not change the verdict."
        ),
        _t(header, requirement_rows(results["checks"]), "Advisory checks"),
        *_reasons(results["checks"]),
        *[Paragraph(line + ".") for line in diagnostics_lines(results)],
    ]


# ---------------------------------------------------------------------------


def build_blocks(results: dict[str, Any]) -> list[Block]:
    """The whole report as blocks: title, summary, the eight sections and the notes.

    Parameters
    ----------
    results : dict
        The JSON-ready results of the design (``results.json``).
    """
    sc = results["spacecraft"]
    verdict = results["verdict"]
    out: list[Block] = [Heading(1, f"Attitude-control design report: {sc['name']}", "top")]
    intro = f"{sc['description']}. " if sc["description"] else ""
    out.append(
        Paragraph(
            f"{intro}Spacecraft file: {sc['source']} (resolved copy: spacecraft.toml). Verdict: "
            + ("all requirements PASS." if verdict["pass"] else f"requirements FAIL ({', '.join(verdict['failed'])}).")
        )
    )
    builders = {
        "body": _body,
        "linear": _linear,
        "slews": _slews,
        "closed_loop": _closed_loop,
        "estimation": _estimation,
        "orbit": _orbit,
        "determination": _determination,
        "requirements": _requirements,
    }
    for key, title in SECTIONS:
        out.append(Heading(2, title, key))
        out += builders[key](results)
    out.append(Heading(2, "Notes", "notes"))
    st = results["settings"]
    out.append(
        Paragraph(
            f"Settings: seed {st['seed']}, {st['planner_nodes']} planner intervals, {st['mekf_runs']} MEKF and "
            f"{st['rate_ekf_runs']} rate-EKF Monte Carlo runs" + (" (quick run)" if st["quick"] else "") + ". "
            "Wall time per step [s]: " + ", ".join(f"{k} {v:.2f}" for k, v in results["timing_s"].items()) + "."
        )
    )
    if results["warnings"]:
        out.append(Paragraph("Warnings raised during the design: " + " | ".join(results["warnings"])))
    if "provenance" in results:
        out.append(Paragraph(_provenance_text(results["provenance"])))
    return out


def _provenance_text(p: dict[str, Any]) -> str:
    """What the report was made with (attitude.results.provenance)."""
    digest = (p.get("input") or {}).get("sha256") or "none (not made from a file)"
    packages = ", ".join(f"{k} {v}" for k, v in p["packages"].items() if k != "attitude-toolkit")
    return (
        f"Made with attitude-toolkit {p['toolkit_version']} on {p['created_utc']} (Python {p['python']}, "
        f"{p['platform']}). Spacecraft file SHA-256: {digest}. Packages: {packages}."
    )

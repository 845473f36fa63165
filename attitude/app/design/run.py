"""The design computation behind ``attitude design``: a spacecraft file in, every figure of the report out.

Top floor (DESIGN.md): like :mod:`attitude.app.cli`, this module and its parts
(:mod:`attitude.app.design.body`, :mod:`attitude.app.design.linear`,
:mod:`attitude.app.design.slew`, :mod:`attitude.app.design.estimation`) tie the
toolkit together and import :mod:`controllers` and :mod:`estimation`; no
ground-floor module imports them. Writing the report (markdown, HTML, JSON,
PNG) is :mod:`attitude.app.report.writer`'s job; these modules only compute.

:func:`run_design` runs the nine steps of the report in order and returns a
:class:`DesignResult`: ``results``, a JSON-ready dict holding every number
the report shows (keys carry their units as in the spacecraft file: ``_s``,
``_deg``, ``_deg_per_s``, ``_mNm``, ``_arcsec`` ...), and ``figures``
(matplotlib Figures by file stem).

1. The body (:func:`attitude.app.design.body.body_analysis`).
2. Linear design (:func:`attitude.app.design.linear.linear_design`).
3. Slews (:func:`attitude.app.design.slew.plan_slews`).
4. Closed loop (:func:`attitude.app.design.slew.fly_slew`).
5. Estimation (:func:`attitude.app.design.estimation.estimation_study`).
6. Orbit, when the file has an ``[orbit]``: disturbance torques, momentum
   budget and unloading, detumbling (:mod:`attitude.app.design.orbit`).
7. Attitude determination from the Sun and the field, when the file has an
   ``[orbit]`` and a direction sensor (:mod:`attitude.app.design.determination`).
8. The dispersed check, when the file has a ``[montecarlo]`` table: a small
   vectorised campaign on its dispersions (:mod:`attitude.app.design.dispersed`);
   a failing run fails the design (a requirement row).
9. Requirements (:func:`requirement_verdicts`; :func:`plan_verdicts` judges a
   plan alone for ``attitude slew``): each requirement of the
   file against the achieved figure, judged from the numbers stored in
   ``results`` and nowhere else, so the report, ``results.json`` and the
   exit code cannot disagree. Advisory design checks (margin guidelines,
   wheel momentum, filter consistency) are listed apart and do not change
   the verdict.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude.app.design.body import DEFAULT_SPIN_RATE_DEG_PER_S, body_analysis, body_figures
from attitude.app.design.determination import determination_figures, determination_study
from attitude.app.design.dispersed import dispersed_check
from attitude.app.design.estimation import FRACTION_INSIDE_MIN, estimation_study
from attitude.app.design.linear import linear_design
from attitude.app.design.orbit import (
    detumble_figures,
    detumble_study,
    momentum_budget,
    momentum_figures,
    nadir_hold,
)
from attitude.app.design.reasons import failure_reason, pd_input_disk_margins
from attitude.app.design.robust import robust_study
from attitude.app.design.slew import check_periods, fly_slew, plan_slews, slew_figures
from attitude.app.design.tune import tuning_section
from attitude.config import SpacecraftConfig
from attitude.results import provenance

__all__ = [
    "GAIN_MARGIN_GUIDELINE_DB",
    "PHASE_MARGIN_GUIDELINE_DEG",
    "QUICK_BUDGET_ORBITS",
    "QUICK_DETUMBLE_ORBITS",
    "STEPS",
    "DesignOptions",
    "DesignResult",
    "orbit_study",
    "plan_verdicts",
    "requirement_verdicts",
    "run_design",
]

#: Steps of :func:`run_design` (the progress lines count them).
STEPS = 9

#: Classical margin guidelines of the advisory checks (not requirements of the file).
GAIN_MARGIN_GUIDELINE_DB = 6.0
PHASE_MARGIN_GUIDELINE_DEG = 30.0


@dataclass(frozen=True)
class DesignOptions:
    """How much work the design does.

    Attributes
    ----------
    quick : bool
        Fewer planner nodes and Monte Carlo runs (a first look, and the test
        suite); the verdict rules are the same.
    spin_rate_deg_per_s : float
        Reference spin rate of the torque-free analysis [deg/s].
    seed : int or None
        Master seed; None takes ``montecarlo.seed`` from the file, else 0.
    """

    quick: bool = False
    spin_rate_deg_per_s: float = DEFAULT_SPIN_RATE_DEG_PER_S
    seed: int | None = None

    @property
    def nodes(self) -> int:
        """Planner intervals."""
        return 30 if self.quick else 60

    @property
    def mekf_runs(self) -> int:
        """Monte Carlo runs of the MEKF consistency check (batched: cheap)."""
        return 8 if self.quick else 50

    @property
    def rate_ekf_runs(self) -> int:
        """Monte Carlo runs of the rate-EKF consistency check (one filterpy filter per run)."""
        return 4 if self.quick else 20

    @property
    def dispersed_runs(self) -> int:
        """Runs of the dispersed check (one vectorised batch: seconds)."""
        return 10 if self.quick else 50

    @property
    def determination_runs(self) -> int:
        """Monte Carlo runs of each sensor model of the determination study (batched)."""
        return 4 if self.quick else 16


@dataclass
class DesignResult:
    """What :func:`run_design` computed.

    Attributes
    ----------
    config : SpacecraftConfig
        The validated spacecraft.
    results : dict
        JSON-ready: every number the report shows (module docstring).
    figures : dict of str to Figure
        Figures by file stem; ``results["figures"]`` holds their section and caption.
    """

    config: SpacecraftConfig
    results: dict[str, Any]
    figures: dict[str, Figure] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """True when every requirement passes."""
        return bool(self.results["verdict"]["pass"])


Progress = Callable[[str], None]


# ---------------------------------------------------------------------------
# 9. Requirements


def _row(rid: str, text: str, key: str, required: Any, achieved: Any, unit: str, comparison: str) -> dict[str, Any]:
    if achieved is None:
        ok = False
    elif comparison == "<=":
        ok = bool(achieved <= required)
    else:
        ok = bool(achieved >= required)
    return {
        "id": rid,
        "requirement": text,
        "key": key,
        "required": required,
        "achieved": achieved,
        "unit": unit,
        "comparison": comparison,
        "pass": ok,
    }


def _slew_rows(
    config: SpacecraftConfig,
    angle_deg: float,
    figures: dict[str, Any] | None,
    source: str,
    time_label: str,
    slew_time_s: float | None,
) -> list[dict[str, Any]]:
    """The slew requirements (time, rate limit, keep-out cones) judged on ``figures`` of a plan or a flight.

    ``figures`` holds ``rate_peak_deg_per_s`` and ``separation_min_deg`` (None: not computed, so failed);
    ``source`` ("plan" or "flown") labels the rows.
    """
    req = config.requirements
    rows = [
        _row(
            "slew_time",
            f"slew time for {angle_deg:.1f} deg ({time_label})",
            "requirements.slew.time_max_s",
            req.slew.time_max_s,
            slew_time_s,
            "s",
            "<=",
        )
    ]
    if req.slew.rate_max_deg_per_s is not None:
        rows.append(
            _row(
                "slew_rate",
                f"largest body rate ({source})",
                "requirements.slew.rate_max_deg_per_s",
                req.slew.rate_max_deg_per_s,
                None if figures is None else figures["rate_peak_deg_per_s"],
                "deg/s",
                "<=",
            )
        )
    for i, cone in enumerate(req.keep_out):
        rows.append(
            _row(
                f"keep_out_{i}",
                f"keep-out '{cone.name}': smallest separation ({source})",
                f"requirements.keep_out[{i}].half_angle_deg",
                cone.half_angle_deg,
                None if figures is None else figures["separation_min_deg"][cone.name],
                "deg",
                ">=",
            )
        )
    return rows


#: Orbits of the momentum budget and of the detumbling study in a quick design.
QUICK_BUDGET_ORBITS = 3.0
QUICK_DETUMBLE_ORBITS = 2.0


def orbit_study(config: SpacecraftConfig, quick: bool = False) -> tuple[dict[str, Any] | None, dict[str, Figure]]:
    """Section 6: the momentum budget and the detumbling study (None without an ``[orbit]``).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    quick : bool
        Shorter spans (:data:`QUICK_BUDGET_ORBITS`, :data:`QUICK_DETUMBLE_ORBITS`).

    Returns
    -------
    tuple
        ``({"momentum": ..., "detumble": ...} or None, figures)``; the numpy
        histories the figures need are left out of the JSON-ready dict.
    """
    budget = momentum_budget(config, QUICK_BUDGET_ORBITS if quick else None)
    if budget is None:
        return None, {}
    figures = momentum_figures(budget)
    hold = nadir_hold(config)
    figures["orbit_nadir_hold"] = hold["_result"].plot()
    detumble = detumble_study(config, QUICK_DETUMBLE_ORBITS if quick else None)
    if detumble is not None:
        figures.update(detumble_figures(detumble))
    plain = {
        "momentum": {k: v for k, v in budget.items() if not k.startswith("_")},
        "nadir_hold": {k: v for k, v in hold.items() if not k.startswith("_")},
        "detumble": None if detumble is None else {k: v for k, v in detumble.items() if not k.startswith("_")},
    }
    return plain, figures


def requirement_verdicts(config: SpacecraftConfig, results: dict[str, Any]) -> dict[str, Any]:
    """Section 8 of the report: each requirement of the file against the achieved figure (from ``results`` only).

    A requirement passes when ``achieved <= required`` (or ``>=``, per row);
    a figure that could not be computed (``None``) fails. Returns
    ``{"requirements": [...], "checks": [...], "verdict": {...}}``; the
    ``checks`` are advisory design guidelines that do not change the verdict.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (its requirements).
    results : dict
        The JSON-ready results of sections 1 to 7 and of the dispersed check.
    """
    req = config.requirements
    slews = results["slews"]
    flight = results["closed_loop"]
    # The slew time is judged on the FLOWN slew: the first time after which the attitude error stays
    # within the pointing accuracy (the plan's duration is shown beside it, in sections 3 and 4).
    rows = _slew_rows(
        config,
        slews["angle_deg"],
        flight,
        "flown",
        "flown, error to the target",
        None if flight is None else flight["flown_slew_time_s"],
    )
    rows.append(
        _row(
            "settling_time",
            "settling time after the end of the planned slew (flown, error to the target)",
            "requirements.settling_time_s",
            req.settling_time_s,
            None if flight is None else flight["settling_time_after_slew_s"],
            "s",
            "<=",
        )
    )
    rows.append(
        _row(
            "pointing_accuracy",
            "largest error to the target over the hold (flown)",
            "requirements.pointing_accuracy_deg",
            req.pointing_accuracy_deg,
            None if flight is None else flight["pointing_error_max_in_window_deg"],
            "deg",
            "<=",
        )
    )
    if req.disk_margin_min is not None:
        at_input = pd_input_disk_margins(results)
        rows.append(
            _row(
                "disk_margin",
                "smallest disk margin of the sampled PD loops at the wheels' input, each axis and all at once "
                "(with the file's modes and filters)",
                "requirements.disk_margin_min",
                req.disk_margin_min,
                min(m["disk_margin"] for m in at_input) if at_input and all(m["stable"] for m in at_input) else None,
                "",
                ">=",
            )
        )
    checks = []
    sampled = [m for m in results["linear"]["margins"] if m["loop"] != "continuous"]
    for ctrl in sorted({m["controller"] for m in sampled}):
        ms = [m for m in sampled if m["controller"] == ctrl]
        checks.append(
            _row(
                f"{ctrl.lower().replace(' + ', '_')}_gain_margin",
                f"{ctrl} sampled loop: smallest gain margin (guideline)",
                "",
                GAIN_MARGIN_GUIDELINE_DB,
                min(m["gain_margin_db"] for m in ms) if all(m["stable"] for m in ms) else None,
                "dB",
                ">=",
            )
        )
        checks.append(
            _row(
                f"{ctrl.lower().replace(' + ', '_')}_phase_margin",
                f"{ctrl} sampled loop: smallest phase margin (guideline)",
                "",
                PHASE_MARGIN_GUIDELINE_DEG,
                min(m["phase_margin_deg"] for m in ms) if all(m["stable"] for m in ms) else None,
                "deg",
                ">=",
            )
        )
    if flight is not None:
        checks.append(
            _row(
                "wheel_momentum",
                "peak wheel momentum below the wheel limit",
                "wheels.momentum_max_Nms",
                flight["wheel_momentum_limit_Nms"],
                flight["wheel_momentum_peak_Nms"],
                "N m s",
                "<=",
            )
        )
    est = results.get("estimation")
    if est is not None:
        for name in ("mekf", "rate_ekf"):
            e = est[name]
            checks.append(
                _row(
                    f"{name}_nees",
                    f"{e['label']}: fraction of steps with the average NEES inside its 95 % band",
                    "",
                    est["fraction_inside_min"],
                    e["fraction_inside"],
                    "",
                    ">=",
                )
            )
    orbit = results.get("orbit")
    if orbit is not None:
        budget = orbit["momentum"]
        judged = budget["unloading"] if budget["unloading"] is not None else budget["no_dumping"]
        rows.append(
            _row(
                "wheel_momentum_budget",
                f"wheel momentum over {_orbits_text(budget['orbits'])} orbits in the environment "
                f"({budget['judged_case']}), largest wheel, within the margin of its capacity",
                "momentum.wheel_momentum_margin",
                min(judged["allowed_per_wheel_mNms"]),
                max(judged["peak_per_wheel_mNms"]),
                "mN m s",
                "<=",
            )
        )
        det = orbit["detumble"]
        if det is not None:
            checks.append(
                _row(
                    "detumble_time",
                    "detumbled (rate below the threshold for good) within the simulated span",
                    "detumble.duration_max_orbits",
                    det["duration_simulated_s"],
                    det["time_to_detumble_s"],
                    "s",
                    "<=",
                )
            )
    dispersed = results.get("dispersed")
    if dispersed is not None:
        rows.append(
            _row(
                "dispersed",
                f"dispersed check: runs failing a requirement ({dispersed.get('runs')} runs of [montecarlo])",
                "montecarlo",
                0,
                dispersed.get("failures"),
                "runs",
                "<=",
            )
        )
    det = results.get("determination")
    if det is not None:
        static = (det["static"] or {}).get("noise")
        if static is not None and static["solutions"]:
            checks.append(
                _row(
                    "quest_nees",
                    "QUEST covariance not over-confident: mean NEES at most the top of its band (noise model)",
                    "",
                    static["nees_band_high"],
                    static["nees_mean"],
                    "",
                    "<=",
                )
            )
        checks.append(
            _row(
                "determination_mekf_nees",
                "Direction-sensor MEKF not over-confident: fraction of steps with the average NEES at most the top "
                "of its band, whole state and attitude alone, the smaller (noise model)",
                "",
                FRACTION_INSIDE_MIN,
                det["mekf"]["noise"]["fraction_not_above_min"],
                "",
                ">=",
            )
        )
    for row in (*rows, *checks):
        row["reason"] = failure_reason(row, results)
    failed = [r["id"] for r in rows if not r["pass"]]
    return {"requirements": rows, "checks": checks, "verdict": {"pass": not failed, "failed": failed}}


def _orbits_text(value: float) -> str:
    """A count of orbits as text: whole numbers without a decimal point.

    Parameters
    ----------
    value : float
        The count.
    """
    return f"{value:g}"


def plan_verdicts(config: SpacecraftConfig, slews: dict[str, Any]) -> dict[str, Any]:
    """The slew requirements judged on a plan alone (``attitude slew``): time, plan rate, plan separation.

    ``slews`` is :attr:`attitude.app.design.slew.SlewStudy.summary`. Returns
    ``{"requirements": [...], "verdict": {...}}``.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (its requirements).
    slews : dict
        The slew study's summary.
    """
    plan = slews["plan"]
    duration = None if plan is None else plan["duration_s"]
    rows = _slew_rows(config, slews["angle_deg"], plan, "plan", "optimal plan", duration)
    for row in rows:
        row["reason"] = failure_reason(row, {"slews": slews, "closed_loop": None})
    failed = [r["id"] for r in rows if not r["pass"]]
    return {"requirements": rows, "verdict": {"pass": not failed, "failed": failed}}


# ---------------------------------------------------------------------------
# The whole design


def robust_linear_design(config: SpacecraftConfig) -> tuple[dict[str, Any], dict[str, Figure]]:
    """Section 2 with its robustness parts: the linear design, the worst case and the tuning.

    :func:`attitude.app.design.linear.linear_design`, then with ``[uncertainty]`` the worst case of the PD over
    the set (:func:`attitude.app.design.robust.robust_study`, under ``"robust"``) and with
    ``requirements.disk_margin_min`` the PD tuned to the requirements, before and after
    (:func:`attitude.app.design.tune.tuning_section` without its dispersed check: the design runs its own,
    under ``"tuning"``).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    """
    linear, figures = linear_design(config)
    robust, robust_figures = robust_study(config)
    linear["robust"] = robust if robust.get("uncertainty") is not None else None
    figures.update(robust_figures)
    linear["tuning"] = None
    if config.requirements.disk_margin_min is not None:
        linear["tuning"], tuning_figures = tuning_section(config)
        figures.update(tuning_figures)
    return linear, figures


def _caption_table() -> dict[str, tuple[str, str]]:
    return {
        "body_polhodes": (
            "body",
            "Torque-free polhodes: rates circle the minor and major axes, the middle axis is unstable (separatrix).",
        ),
        "pd_step": ("linear", "PD closed-loop step responses (linearised at rest)."),
        "pd_bode": ("linear", "PD loop gain broken at the plant input, per axis, continuous."),
        "pd_bode_sampled": ("linear", "PD loop gain of the sampled loop (zero-order hold at the controller rate)."),
        "lqr_bode_sampled": ("linear", "LQR loop gain of the sampled loop, per axis."),
        "disk_margins": (
            "linear",
            "Multiloop disk margin over frequency of the sampled loops, all channels perturbed at once, at the plant "
            "input (torques) and output (attitude and rate measurements); dots: the refined smallest margin.",
        ),
        "pd_nichols": (
            "linear",
            "Nichols chart of the sampled PD loops per axis (broken at the plant input, the other axes closed); "
            "with flexible modes or filters in the file, also the loops that fly; shaded: the region inside the "
            "required disk margin (requirements.disk_margin_min; without it, the smallest margin of the table).",
        ),
        "robust_disk_margin": (
            "linear",
            "Worst case over [uncertainty]: the multiloop disk margin of the sampled PD loop over uniform samples of "
            "the set, with the optimiser's worst, the samples' worst and the nominal marked.",
        ),
        "robust_overshoot_percent": (
            "linear",
            "Worst case over [uncertainty]: the step overshoot of the linear closed loop over uniform samples of the "
            "set, with the optimiser's worst, the samples' worst and the nominal marked.",
        ),
        "robust_settling_time_s": (
            "linear",
            "Worst case over [uncertainty]: the step settling time over uniform samples of the set.",
        ),
        "tuning_tradeoff": (
            "linear",
            "Tuning to the requirements: settling time against disk margin over the PD's bandwidth and damping, the "
            "Pareto front, the file's gains (before) and the tuned ones; shaded: failing a requirement.",
        ),
        "slew_plan": (
            "slews",
            "Optimal plan: torque [mN m], rates, attitude and keep-out separation; the planned limits (dashed or "
            "dotted: the cone widened by the planning margin, the planned rate and torque) beside the required ones "
            "(red).",
        ),
        "slew_comparison": ("slews", "Optimal plan and eigenaxis slew: body rate and keep-out separation."),
        "closed_loop": ("closed_loop", "Flown slew: attitude error, body rates, torques, wheel speeds."),
        "pointing": ("closed_loop", "Pointing error (truth) and knowledge error (MEKF) with the requirement."),
        "mekf_errors": (
            "estimation",
            "MEKF attitude and gyro-bias errors in body axes: run 1, the spread of all runs (+-3 RMS) and the "
            "filter's 3-sigma envelope.",
        ),
        "rate_ekf_errors": (
            "estimation",
            "Rate EKF rate and bias errors in body axes (run 1) with 3-sigma bounds; limits from the steady state.",
        ),
        "mekf_nees": ("estimation", "MEKF: average NEES over the Monte Carlo runs with its 95 % chi-square band."),
        "rate_ekf_nees": ("estimation", "Rate EKF: average NEES with its 95 % chi-square band."),
        "orbit_torques": ("orbit", "Disturbance torques per source over one orbit, nadir hold (log scale)."),
        "orbit_momentum": (
            "orbit",
            "Momentum of each wheel (minimum-norm distribution) over the budget, without dumping and with "
            "cross-product unloading; dashed: the allowed momentum per wheel (drawn when within the scale).",
        ),
        "detumble": ("orbit", "B-dot detumbling: body rates with the threshold, and the rods' dipole."),
        "determination_static": (
            "determination",
            "QUEST attitude error over one orbit (run 1) for both sensor models, with QUEST's 3-sigma (largest axis); "
            "below, the angle between the Sun and the field (small: the rotation about them is poorly observed).",
        ),
        "determination_mekf": (
            "determination",
            "MEKF on the gyro and the direction sensors (no star tracker): error angle of the first runs and the "
            "3-sigma of the largest axis.",
        ),
        "determination_nees": (
            "determination",
            "MEKF on the gyro and the direction sensors: average NEES (noise model) with its 95 % chi-square band.",
        ),
        "orbit_nadir_hold": (
            "orbit",
            "Nadir hold over one orbit in closed loop: error to the LVLH frame, rates, torques, wheel speeds, the "
            "disturbance torques per source and the unloading dipole.",
        ),
    }


def run_design(
    config: SpacecraftConfig,
    options: DesignOptions | None = None,
    progress: Progress | None = None,
    on_step: Callable[[int, str], None] | None = None,
) -> DesignResult:
    """Run the whole design (module docstring) and judge the requirements.

    Parameters
    ----------
    config : SpacecraftConfig
        A validated spacecraft.
    options : DesignOptions, optional
        Size of the computation (default: the full design).
    progress : callable, optional
        Called with a short message before and after each step
        (``"[3/9] slews: ... ..."``, ``"[3/9] slews: ...: done in 2.1 s"``).
    on_step : callable, optional
        ``on_step(number, label)``: called when step ``number`` (1 to
        :data:`STEPS`) starts, with its label (a progress bar over the steps).

    Raises
    ------
    ConfigError
        When the sample periods cannot share one simulation clock.
    """
    options = options or DesignOptions()
    say = progress or (lambda _msg: None)
    check_periods(config)
    seed = options.seed
    if seed is None:
        seed = 0 if config.montecarlo is None else config.montecarlo.seed
    seeds = np.random.SeedSequence(seed).spawn(3)
    timing: dict[str, float] = {}
    caught: list[str] = []
    figures: dict[str, Figure] = {}

    def step(number: int, name: str, label: str, fun: Callable[[], Any]) -> Any:
        if on_step is not None:
            on_step(number, label)
        say(f"[{number}/{STEPS}] {label} ...")
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            value = fun()
        for w in record:
            text = f"{name}: {w.category.__name__}: {w.message}"
            if text not in caught:
                caught.append(text)
        timing[name] = time.perf_counter() - start
        say(f"[{number}/{STEPS}] {label}: done in {timing[name]:.1f} s")
        return value

    results: dict[str, Any] = {
        "schema": "attitude-design-results/1",
        "spacecraft": {"name": config.name, "description": config.description, "source": config.source},
        "provenance": provenance(config.source or None, config.source_sha256 or None),  # versions, date, hash
        "settings": {
            "quick": options.quick,
            "seed": int(seed),
            "planner_nodes": options.nodes,
            "mekf_runs": options.mekf_runs,
            "rate_ekf_runs": options.rate_ekf_runs,
            "determination_runs": options.determination_runs,
            "dispersed_runs": options.dispersed_runs,
            "spin_rate_deg_per_s": options.spin_rate_deg_per_s,
        },
    }
    results["body"] = step(
        1, "body", "body: principal axes, stability", lambda: body_analysis(config, options.spin_rate_deg_per_s)
    )
    figures.update(body_figures(config, results["body"]))
    linear, figs = step(
        2, "linear", "linear design: PD, LQR, margins, worst case, tuning", lambda: robust_linear_design(config)
    )
    results["linear"] = linear
    figures.update(figs)
    study = step(
        3,
        "slews",
        f"slews: optimal plan ({options.nodes} nodes) and eigenaxis",
        lambda: plan_slews(config, nodes=options.nodes),
    )
    results["slews"] = study.summary
    figures.update(slew_figures(study))
    flight, figs, sim = step(
        4,
        "closed_loop",
        "closed loop: tracking, wheels, gyro, star tracker, MEKF",
        lambda: fly_slew(config, study, seeds[0]),
    )
    results["closed_loop"] = flight
    figures.update(figs)
    label = f"estimation: MEKF ({options.mekf_runs} runs) and rate EKF ({options.rate_ekf_runs} runs)"
    est, figs = step(
        5,
        "estimation",
        label,
        lambda: estimation_study(config, sim, options.mekf_runs, options.rate_ekf_runs, seeds[1]),
    )
    results["estimation"] = est
    figures.update(figs)
    if est is not None:
        est["fraction_inside_min"] = FRACTION_INSIDE_MIN
    orbit, figs = step(
        6,
        "orbit",
        "orbit: disturbance torques, momentum budget, detumbling",
        lambda: orbit_study(config, options.quick),
    )
    results["orbit"] = orbit
    figures.update(figs)
    determination, histories = step(
        7,
        "determination",
        f"determination: QUEST, TRIAD and MEKF from the Sun and the field ({options.determination_runs} runs)",
        lambda: determination_study(config, options.determination_runs, seeds[2]),
    )
    results["determination"] = determination
    if determination is not None:
        figures.update(determination_figures(determination, histories))
    plan = results["slews"].get("plan")
    results["dispersed"] = step(
        8,
        "dispersed",
        f"dispersed check: {options.dispersed_runs} runs of the [montecarlo] dispersions, vectorised",
        lambda: dispersed_check(
            config, options.dispersed_runs, None if plan is None else plan["duration_s"], options.nodes, study
        ),
    )
    verdicts = step(9, "requirements", "requirements", lambda: requirement_verdicts(config, results))
    results.update(verdicts)
    captions = _caption_table()
    results["figures"] = {
        name: {"section": captions[name][0], "caption": captions[name][1], "file": f"figures/{name}.png"}
        for name in figures
    }
    results["warnings"] = caught
    results["timing_s"] = timing
    return DesignResult(config=config, results=results, figures=figures)

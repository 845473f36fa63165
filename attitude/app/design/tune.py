"""`attitude tune`: the file's PD tuned to its requirements, confirmed, and written into a new file.

Top floor (DESIGN.md). The requirements come from the spacecraft file
(:func:`tuning_requirements`): the step is the largest attitude error the
feedback must correct (``--step-deg``; by default ``[control.lqr]
angle_max_deg``, the file's largest acceptable attitude error, since the
design flies the required slew as a plan with feedforward and the feedback
sees only the tracking error; without ``[control.lqr]`` the whole required
slew, as flown by the PD alone), settled within
``requirements.pointing_accuracy_deg`` in ``requirements.settling_time_s``,
with the wheels' body-torque and body-momentum envelopes
(:meth:`attitude.actuators.ReactionWheels.torque_envelope`, and the same rule
for the momentum) and ``requirements.disk_margin_min`` at ``control.period_s``.
:func:`controllers.tuning.tune_pd` finds the gains on the linear metrics; the
winner is then flown on the nonlinear plant through the wheels
(:func:`controllers.tuning.confirm_nonlinear`) and in the design's dispersed
check (:func:`attitude.app.design.dispersed.dispersed_check`: the planned slew
tracked with the new gains, with gyro, star tracker and MEKF, on the file's
``[montecarlo]`` dispersions). With ``--structure lqr`` the
``[control.lqr]`` Bryson bounds are tuned instead (:func:`controllers.tuning.tune_lqr`: the attitude bound
``angle_max_deg`` kept, the rate and torque bounds per axis), the LQR flown in the nonlinear step, and its
dispersed confirmation is that step flown on the file's ``[montecarlo]`` inertia dispersion (the design's
campaign flies the PD, which this structure leaves as it is). The new file is the input's text with
``control.bandwidth_rad_per_s`` and ``control.damping`` (or ``control.lqr.rate_max_deg_per_s`` and
``control.lqr.torque_max_Nm``) replaced
(:func:`attitude.config.writer.replace_values`): every other key and
comment kept, and a header line saying what changed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.app.design.dispersed import FAILING_RUNS_LISTED, dispersed_check
from attitude.config import ConfigError, SpacecraftConfig, default_config, default_config_text
from attitude.config.writer import replace_values
from controllers.disk_margins import loop_disk_margins
from controllers.lqr import LQRController
from controllers.tuning import (
    MarginLoop,
    PDMetrics,
    RequirementConflict,
    TuningRequirements,
    TuningResult,
    confirm_nonlinear,
    format_values,
    lqr_metrics,
    pd_metrics,
    tune_lqr,
    tune_pd,
)

__all__ = [
    "STRUCTURES",
    "TuneOutcome",
    "dispersed_step_check",
    "flown_disk_margin",
    "margin_loop",
    "step_source",
    "tune_config",
    "tuned_file_text",
    "tuning_requirements",
    "tuning_section",
]

#: Controller structures `attitude tune` can tune and write back: the ``[control]`` PD with one bandwidth and
#: damping, or one per body axis (``controllers.tuning.tune_pd(per_axis=True)``; the rate-limited eigenaxis PD,
#: which needs ``K = k J``, then refuses the file), and the ``[control.lqr]`` Bryson bounds (per axis).
STRUCTURES = ("pd", "pd_per_axis", "lqr")
#: The file key each tuning requirement comes from (named when requirements contradict themselves).
REQUIREMENT_KEYS = {
    "settling_time": "requirements.settling_time_s",
    "step_angle": "requirements.slew.angle_deg",
    "pointing_accuracy": "requirements.pointing_accuracy_deg",
    "torque_max": "wheels.torque_max_Nm",
    "momentum_max": "wheels.momentum_max_Nms",
    "disk_margin_min": "requirements.disk_margin_min",
}
#: Runs of the dispersed confirmation (the design's --quick count) and the planner's nodes for it.
DISPERSED_RUNS = 10
DISPERSED_NODES = 30


def step_source(config: SpacecraftConfig, step_deg: float | None = None) -> tuple[float, str]:
    """The step the tuned feedback must settle [rad] and where it comes from (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    step_deg : float, optional
        The step [deg], given (``attitude tune --step-deg``).

    Returns
    -------
    step_rad : float
        The step angle [rad].
    source : str
        The key or option it comes from.
    """
    if step_deg is not None:
        if not (math.isfinite(step_deg) and 0.0 < step_deg <= 180.0):
            raise ValueError(f"step_deg must be in (0, 180] deg, got {step_deg!r}")
        return math.radians(step_deg), "--step-deg"
    if config.control.lqr is not None:
        return float(np.max(config.control.lqr.angle_max)), "control.lqr.angle_max_deg"
    req = config.requirements
    return float(quat.error_angle(req.slew.q_start(), req.slew.q_target())), "requirements.slew.angle_deg"


def tuning_requirements(config: SpacecraftConfig, step_deg: float | None = None) -> TuningRequirements:
    """The tuning requirements of a spacecraft file (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    step_deg : float, optional
        The step the feedback must settle [deg] (default: :func:`step_source`).

    Raises
    ------
    ConfigError
        When the requirements contradict themselves, naming their keys.
    """
    req = config.requirements
    step, source = step_source(config, step_deg)
    wheels = assembly.reaction_wheels(config)
    try:
        return TuningRequirements(
            settling_time=req.settling_time_s,
            step_angle=step,
            pointing_accuracy=math.radians(req.pointing_accuracy_deg),
            torque_max=wheels.torque_envelope(),
            momentum_max=wheels.momentum_envelope(),
            disk_margin_min=req.disk_margin_min,
        )
    except RequirementConflict as exc:
        raise _config_error(exc, config, source) from exc


def _config_error(exc: RequirementConflict, config: SpacecraftConfig, step_key: str | None = None) -> ConfigError:
    keys = ", ".join(step_key if n == "step_angle" and step_key else REQUIREMENT_KEYS[n] for n in exc.names)
    return ConfigError(f"the requirements contradict themselves: {exc}", keys, config.source or "<config>")


@dataclass(frozen=True)
class TuneOutcome:
    """A tuning of a spacecraft file, its confirmations and the tuned file.

    Attributes
    ----------
    config : SpacecraftConfig
        The input file.
    tuned : SpacecraftConfig or None
        The file with the tuned gains (None when infeasible).
    result : TuningResult
        The tuning on the linear metrics.
    before : PDMetrics
        The input file's PD on the same metrics.
    nonlinear : dict or None
        :func:`controllers.tuning.confirm_nonlinear` of the winner (None when infeasible).
    dispersed : dict or None
        :func:`attitude.app.design.dispersed.dispersed_check` of the tuned file (None when infeasible, without
        ``[montecarlo]``, or not asked for).
    flown_disk_margin : float or None
        The tuned law's smallest disk margin at the wheels' input on the loops that fly, with the file's
        ``[[flexible_modes]]`` and ``[[control.filters]]``, per axis and multiloop (the design's verdict judges
        these; the search judged them too, by :func:`margin_loop`); None for a rigid, unfiltered file or when
        infeasible. NaN: a closed loop is unstable.
    nonlinear_flexible : dict or None
        :func:`controllers.tuning.confirm_nonlinear` of the winner on the file's flexible spacecraft (hybrid
        coordinates, the filters flown, the torque on the body: that simulation has no wheel model); None for
        a rigid file or when infeasible.
    """

    config: SpacecraftConfig
    tuned: SpacecraftConfig | None
    result: TuningResult
    before: PDMetrics
    nonlinear: dict[str, Any] | None
    dispersed: dict[str, Any] | None
    flown_disk_margin: float | None = None
    nonlinear_flexible: dict[str, Any] | None = None

    @property
    def passed(self) -> bool:
        """Feasible, confirmed on the nonlinear plant and (when flown) the dispersed campaign, and the disk margin
        floor met on the loops that fly (with the file's modes and filters)."""
        ok = self.result.feasible and self.nonlinear is not None and self.nonlinear["passed"]
        if self.nonlinear_flexible is not None:
            ok = ok and self.nonlinear_flexible["passed"]
        if self.dispersed is not None:
            ok = ok and "error" not in self.dispersed and self.dispersed["failures"] == 0
        floor = self.result.requirements.disk_margin_min
        if self.flown_disk_margin is not None and floor is not None:
            ok = ok and self.flown_disk_margin >= floor  # NaN (unstable) fails
        return bool(ok)

    def table(self) -> list[dict[str, Any]]:
        """Before and after, one row per metric, with the requirement."""
        req = self.result.requirements
        after = self.result.metrics
        if self.result.structure == "lqr":
            old = self.config.control.lqr
            new = self.tuned.control.lqr if self.tuned is not None else None
            gains = [
                (f"lqr.rate_max_deg_per_s ({a})", float(np.degrees(old.rate_max[k])), _bound(new, "rate_max", k, True))
                for k, a in enumerate("xyz")
            ] + [
                (f"lqr.torque_max_Nm ({a})", float(old.torque_max[k]), _bound(new, "torque_max", k, False))
                for k, a in enumerate("xyz")
            ]
            gain_rows = [(m, b, a, None) for m, b, a in gains]
        else:
            gain_rows = [
                *_axis_rows("bandwidth_rad_per_s", self.before.wn, after.wn),
                *_axis_rows("damping", self.before.zeta, after.zeta),
            ]
        rows = [
            *gain_rows,
            ("settling_time_s (linear)", self.before.settling_time, after.settling_time, f"<= {req.settling_time:g}"),
            (
                "peak_torque_Nm",
                float(np.max(self.before.peak_torque)),
                float(np.max(after.peak_torque)),
                f"<= {np.min(req.torque_max):.4g}",
            ),
            (
                "peak_momentum_Nms",
                float(np.max(self.before.peak_momentum)),
                float(np.max(after.peak_momentum)),
                None if req.momentum_max is None else f"<= {np.min(req.momentum_max):.4g}",
            ),
            (
                "disk_margin",
                self.before.disk_margin,
                after.disk_margin,
                None if req.disk_margin_min is None else f">= {req.disk_margin_min:g}",
            ),
        ]
        return [{"metric": m, "before": b, "after": a, "required": r} for m, b, a, r in rows]

    @property
    def structure(self) -> str:
        """The controller tuned (:data:`STRUCTURES`)."""
        return self.result.structure

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the verdict, the gains, the table, what binds and the confirmations."""
        return {
            "structure": self.result.structure,
            "feasible": self.result.feasible,
            "passed": self.passed,
            "cost": self.result.cost,
            "binding": list(self.result.binding),
            "message": self.result.message,
            "step_angle_deg": math.degrees(self.result.requirements.step_angle),
            "before": self.before.as_dict(),
            "after": self.result.metrics.as_dict(),
            "table": self.table(),
            "nonlinear": self.nonlinear,
            "nonlinear_flexible": self.nonlinear_flexible,
            "dispersed": self.dispersed,
            "flown_disk_margin": self.flown_disk_margin,
        }


def _axis_rows(name: str, before: Any, after: Any) -> list[tuple[str, float, float, None]]:
    """One table row of a gain, or one per axis when either side has a value per axis."""
    if np.ndim(before) == 0 and np.ndim(after) == 0:
        return [(name, float(before), float(after), None)]
    b, a = np.broadcast_to(before, (3,)), np.broadcast_to(after, (3,))
    return [(f"{name} ({axis})", float(b[k]), float(a[k]), None) for k, axis in enumerate("xyz")]


def _written(value: float, toward: str) -> float:
    """A tuned value to 6 significant digits, rounded ``"down"`` or ``"up"`` (the side the requirements allow)."""
    rounded = float(f"{value:.6g}")
    step = 10.0 ** (math.floor(math.log10(abs(value))) - 5)
    if toward == "down" and rounded > value:
        rounded = float(f"{rounded - step:.6g}")
    elif toward == "up" and rounded < value:
        rounded = float(f"{rounded + step:.6g}")
    return rounded


def _bound(bounds: Any, name: str, axis: int, degrees: bool) -> float:
    """One axis's Bryson bound of a ``[control.lqr]`` table (NaN without one), in the file's unit."""
    if bounds is None:
        return math.nan
    value = float(getattr(bounds, name)[axis])
    return math.degrees(value) if degrees else value


def tune_config(
    config: SpacecraftConfig,
    *,
    cost: str = "settling",
    structure: str = "pd",
    dispersed_runs: int = DISPERSED_RUNS,
    tradeoff_points: int = 10,
    step_deg: float | None = None,
) -> TuneOutcome:
    """Tune the file's controller to its requirements and confirm the winner (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    cost : str
        ``"settling"`` or ``"effort"`` (:func:`controllers.tuning.tune_pd`).
    structure : str
        The controller tuned: ``"pd"``, ``"pd_per_axis"`` or ``"lqr"`` (:data:`STRUCTURES`).
    dispersed_runs : int
        Runs of the dispersed confirmation (0: none).
    tradeoff_points : int
        Dampings of the trade-off sweep (0: none).
    step_deg : float, optional
        The step the feedback must settle [deg] (default: :func:`step_source`).

    Raises
    ------
    ConfigError
        When the requirements contradict themselves (the keys named), or ``"lqr"`` for a file without
        ``[control.lqr]``.
    ValueError
        For a structure other than :data:`STRUCTURES`.
    """
    if structure not in STRUCTURES:
        raise ValueError(f"structure must be one of {STRUCTURES}, got {structure!r}")
    if structure == "lqr" and config.control.lqr is None:
        raise ConfigError(
            "structure 'lqr' tunes the [control.lqr] Bryson bounds (rate and torque, with its angle_max_deg kept), "
            "but the file has no [control.lqr] table: add one with angle_max_deg, rate_max_deg_per_s and "
            "torque_max_Nm",
            "control.lqr",
            config.source or "<config>",
        )
    body = assembly.rigid_body(config)
    wheels = assembly.reaction_wheels(config)
    requirements = tuning_requirements(config, step_deg)
    period = config.control.period_s
    loop = margin_loop(config)
    try:
        if structure == "lqr":
            result = tune_lqr(
                body,
                requirements,
                period=period,
                angle_max=config.control.lqr.angle_max,
                cost=cost,
                loop=loop,
                tradeoff_points=tradeoff_points,
            )
        else:
            result = tune_pd(
                body,
                requirements,
                period=period,
                cost=cost,
                per_axis=structure == "pd_per_axis",
                loop=loop,
                tradeoff_points=tradeoff_points,
            )
    except RequirementConflict as exc:
        raise _config_error(exc, config, step_source(config, step_deg)[1]) from exc
    if structure == "lqr":
        before = lqr_metrics(body, requirements, assembly.lqr(config, body)[1], loop=loop)
    else:
        before = pd_metrics(
            body,
            requirements,
            wn=config.control.bandwidth_rad_per_s,
            zeta=config.control.damping,
            period=period,
            loop=loop,
        )
    if not result.feasible:
        return TuneOutcome(config, None, result, before, None, None)
    if structure == "lqr":
        bounds = result.lqr_bounds
        lqr_table = replace(
            config.control.lqr,
            rate_max_deg_per_s=tuple(float(v) for v in np.degrees(bounds["rate_max"])),
            torque_max_Nm=tuple(float(v) for v in bounds["torque_max"]),
        )
        control = replace(config.control, lqr=lqr_table)
    else:
        # Six digits in the file, the bandwidth rounded to the side the requirements allow: down when the fastest
        # loop was sought (the torque, momentum and margin limits bind above), up for the cheapest (the settling
        # time binds below). The tuned file and this configuration hold the same numbers.
        toward = "down" if cost == "settling" else "up"
        wn = [_written(v, toward) for v in np.atleast_1d(result.wn)]
        zeta = [_written(v, "nearest") for v in np.atleast_1d(result.zeta)]
        per_axis = structure == "pd_per_axis"
        control = replace(
            config.control,
            bandwidth_rad_per_s=tuple(wn) if per_axis else wn[0],
            damping=tuple(zeta) if per_axis else zeta[0],
        )
        gains_flown = {"wn": np.array(wn) if per_axis else wn[0], "zeta": np.array(zeta) if per_axis else zeta[0]}
    tuned = replace(config, control=control)
    axis = np.asarray(
        quat.to_rotation_vector(
            quat.error_quaternion(config.requirements.slew.q_start(), config.requirements.slew.q_target())
        )
    )
    gains: dict[str, Any] = {"lqr": result.lqr} if structure == "lqr" else gains_flown
    hold = config.requirements.hold_time_judged_s
    nonlinear = confirm_nonlinear(
        body,
        requirements,
        period=period,
        wheels=wheels,
        axis=axis,
        hold_time=hold,
        command_filter=loop.command_filter,
        **gains,
    )
    modes = assembly.flexible_modes(config)
    nonlinear_flexible = None
    if modes is not None:
        nonlinear_flexible = confirm_nonlinear(
            body,
            requirements,
            period=period,
            axis=axis,
            hold_time=hold,
            modes=modes,
            command_filter=loop.command_filter,
            **gains,
        )
    dispersed = None
    if dispersed_runs > 0 and config.montecarlo is not None:
        if structure == "lqr":
            dispersed = dispersed_step_check(tuned, requirements, dispersed_runs, axis)
        else:
            dispersed = dispersed_check(tuned, dispersed_runs, None, DISPERSED_NODES)
    controller = LQRController(result.lqr) if structure == "lqr" else None
    margin = flown_disk_margin(tuned, body, controller)
    return TuneOutcome(config, tuned, result, before, nonlinear, dispersed, margin, nonlinear_flexible)


def margin_loop(config: SpacecraftConfig) -> MarginLoop:
    """The loop whose disk margin the tuning judges: the file's flexible plant and command filters, as they fly.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (its ``[[flexible_modes]]`` and ``[[control.filters]]``).
    """
    filters = None
    if config.control.filters:

        def filters(law: Any) -> Any:
            return assembly.command_filtered(config, law)

    return MarginLoop(plant=assembly.flexible_plant_model(config), command_filter=filters)


def dispersed_step_check(
    config: SpacecraftConfig, requirements: TuningRequirements, runs: int, axis: Any
) -> dict[str, Any] | None:
    """The file's LQR, designed on the nominal body, flown in the tuning's step on dispersed bodies.

    The bodies are the file's ``[montecarlo]`` inertia dispersion, drawn as the campaign draws them
    (:func:`attitude.montecarlo.dispersions.draw_parameters`, ``montecarlo.seed``, runs ``0 .. runs - 1``);
    each is judged by :func:`controllers.tuning.confirm_nonlinear` through the wheels.

    Parameters
    ----------
    config : SpacecraftConfig
        The tuned file (its ``[control.lqr]``, ``[montecarlo]`` and wheels).
    requirements : TuningRequirements
        The step, the accuracy and the settling time.
    runs : int
        Dispersed bodies flown (>= 1).
    axis : array_like (3,)
        The step axis in body axes.

    Returns
    -------
    dict or None
        ``runs``, ``failures``, ``failing_runs`` (the first few), ``worst_settling_time_s``,
        ``worst_pointing_error_rad`` and a one-line ``statement``; None without an inertia dispersion.
    """
    mc = config.montecarlo
    if mc is None or mc.inertia is None:
        return None
    from attitude.montecarlo.dispersions import dispersions_from_config, draw_parameters
    from attitude.rigid_body import RigidBody

    nominal = assembly.rigid_body(config)
    wheels = assembly.reaction_wheels(config)
    design = assembly.lqr(config, nominal)[1]
    inertia = {"inertia": dispersions_from_config(mc, nominal.inertia, config.requirements.slew.q_start())["inertia"]}
    flown = []
    for run in range(int(runs)):
        body = RigidBody(draw_parameters(inertia, mc.seed, run)["inertia"])
        flown.append(
            confirm_nonlinear(
                body,
                requirements,
                lqr=design,
                period=config.control.period_s,
                wheels=wheels,
                axis=axis,
                hold_time=config.requirements.hold_time_judged_s,
            )
        )
    failing = [i for i, f in enumerate(flown) if not f["passed"]]
    worst_settling = max(f["settling_time_s"] for f in flown)
    worst_pointing = max(f["pointing_error_rad"] for f in flown)
    return {
        "runs": len(flown),
        "failures": len(failing),
        "failing_runs": failing[:FAILING_RUNS_LISTED],
        "worst_settling_time_s": worst_settling,
        "worst_pointing_error_rad": worst_pointing,
        "statement": (
            f"the tuned LQR's {math.degrees(requirements.step_angle):g} deg step on {len(flown)} dispersed bodies "
            f"(montecarlo.inertia): {len(failing)} failures; worst settling {worst_settling:.4g} s, worst pointing "
            f"{math.degrees(worst_pointing):.3g} deg"
        ),
    }


def flown_disk_margin(config: SpacecraftConfig, body: Any = None, controller: Any = None) -> float | None:
    """The file's PD's (or a controller's) smallest disk margin at the wheels' input with its modes and filters.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (its ``[control]`` PD, ``[[flexible_modes]]`` and ``[[control.filters]]``).
    body : RigidBody, optional
        The file's body (built when None).
    controller : object, optional
        The law judged (e.g. an :class:`controllers.lqr.LQRController`); default the file's PD.

    Returns
    -------
    float or None
        Per axis and multiloop, the sampled loop (NaN: a closed loop is unstable); None for a rigid file
        without filters, whose loop the tuning itself judged.
    """
    body = assembly.rigid_body(config) if body is None else body
    law = assembly.quaternion_pd(config, body) if controller is None else controller
    flown = assembly.command_filtered(config, law)
    flexible = assembly.flexible_plant_model(config)
    if flexible is None and flown is law:
        return None
    return float(loop_disk_margins(body if flexible is None else flexible, flown).smallest)


def _source_text(config: SpacecraftConfig) -> str:
    if config.source is None or config.source == default_config().source:
        return default_config_text()
    return Path(config.source).read_text(encoding="utf-8")


def tuned_file_text(outcome: TuneOutcome) -> str:
    """The input file's text with the tuned gains, its other keys and comments kept, and a header saying so.

    Parameters
    ----------
    outcome : TuneOutcome
        A feasible tuning.

    Raises
    ------
    ValueError
        For an infeasible tuning (there are no gains to write).
    """
    if outcome.tuned is None:
        raise ValueError("outcome must be feasible: an infeasible tuning has no gains to write")
    old, new = outcome.config.control, outcome.tuned.control
    if outcome.structure == "lqr":
        rate = [float(f"{v:.6g}") for v in new.lqr.rate_max_deg_per_s]
        torque = [float(f"{v:.6g}") for v in new.lqr.torque_max_Nm]
        text = replace_values(
            _source_text(outcome.config),
            {"control.lqr.rate_max_deg_per_s": rate, "control.lqr.torque_max_Nm": torque},
        )
        header = (
            f"# Tuned by `attitude tune --structure lqr` ({outcome.result.cost} minimised): "
            f"control.lqr.rate_max_deg_per_s {old.lqr.rate_max_deg_per_s} -> {rate}, control.lqr.torque_max_Nm "
            f"{old.lqr.torque_max_Nm} -> {torque} (angle_max_deg kept).\n"
            "# Bryson's bounds are weights, not limits: only their ratios set the gain (the torque bound is the\n"
            "# torque at an angle_max error; the wheels' limits are judged on the tuned loop itself).\n"
            "# The comments beside those keys describe the values before tuning.\n"
        )
        return header + text
    values = {"control.bandwidth_rad_per_s": new.bandwidth_rad_per_s, "control.damping": new.damping}
    text = replace_values(
        _source_text(outcome.config), {k: list(v) if isinstance(v, tuple) else v for k, v in values.items()}
    )
    structure = " --structure pd_per_axis" if outcome.structure == "pd_per_axis" else ""
    header = (
        f"# Tuned by `attitude tune{structure}` ({outcome.result.cost} minimised): control.bandwidth_rad_per_s "
        f"{format_values(old.bandwidth_rad_per_s, 6)} -> {format_values(new.bandwidth_rad_per_s, 6)}, "
        f"control.damping {format_values(old.damping, 6)} -> {format_values(new.damping, 6)}.\n"
        "# The comments beside those keys describe the values before tuning.\n"
    )
    return header + text


def tuning_section(config: SpacecraftConfig, dispersed_runs: int = 0) -> tuple[dict[str, Any], dict[str, Figure]]:
    """The design report's tuning section: before and after, what binds, the trade-off figure.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    dispersed_runs : int
        Runs of the dispersed confirmation (0: none; the design runs its own dispersed check).

    Returns
    -------
    tuple of (dict, dict of Figure)
        :meth:`TuneOutcome.summary` (``{"error": ...}`` when the requirements contradict themselves) and
        ``{"tuning_tradeoff": figure}``.
    """
    try:
        outcome = tune_config(config, dispersed_runs=dispersed_runs)
    except ConfigError as exc:
        return {"error": str(exc)}, {}
    return outcome.summary(), {"tuning_tradeoff": outcome.result.plot(outcome.before)}

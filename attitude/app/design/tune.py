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
``[montecarlo]`` dispersions). The new file is the input's text with
``control.bandwidth_rad_per_s`` and ``control.damping`` replaced
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
from attitude.app.design.dispersed import dispersed_check
from attitude.config import ConfigError, SpacecraftConfig, default_config, default_config_text
from attitude.config.writer import replace_values
from controllers.disk_margins import loop_disk_margins
from controllers.tuning import (
    PDMetrics,
    RequirementConflict,
    TuningRequirements,
    TuningResult,
    confirm_nonlinear,
    pd_metrics,
    tune_pd,
)

__all__ = [
    "STRUCTURES",
    "TuneOutcome",
    "flown_disk_margin",
    "step_source",
    "tune_config",
    "tuned_file_text",
    "tuning_requirements",
    "tuning_section",
]

#: Controller structures `attitude tune` can tune.
STRUCTURES = ("pd",)
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
        The tuned PD's smallest disk margin at the wheels' input on the loops that fly, with the file's
        ``[[flexible_modes]]`` and ``[[control.filters]]`` (the design's verdict judges these; the tuning itself
        works on the rigid, unfiltered loop); None for a rigid, unfiltered file or when infeasible. NaN: a
        closed loop is unstable.
    """

    config: SpacecraftConfig
    tuned: SpacecraftConfig | None
    result: TuningResult
    before: PDMetrics
    nonlinear: dict[str, Any] | None
    dispersed: dict[str, Any] | None
    flown_disk_margin: float | None = None

    @property
    def passed(self) -> bool:
        """Feasible, confirmed on the nonlinear plant and (when flown) the dispersed campaign, and the disk margin
        floor met on the loops that fly (with the file's modes and filters)."""
        ok = self.result.feasible and self.nonlinear is not None and self.nonlinear["passed"]
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
        rows = [
            ("bandwidth_rad_per_s", self.before.wn, after.wn, None),
            ("damping", self.before.zeta, after.zeta, None),
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

    def summary(self) -> dict[str, Any]:
        """JSON-ready: the verdict, the gains, the table, what binds and the confirmations."""
        return {
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
            "dispersed": self.dispersed,
            "flown_disk_margin": self.flown_disk_margin,
        }


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
        The controller tuned: ``"pd"`` (:data:`STRUCTURES`).
    dispersed_runs : int
        Runs of the dispersed confirmation (0: none).
    tradeoff_points : int
        Dampings of the trade-off sweep (0: none).
    step_deg : float, optional
        The step the feedback must settle [deg] (default: :func:`step_source`).

    Raises
    ------
    ConfigError
        When the requirements contradict themselves (the keys named).
    ValueError
        For a structure other than :data:`STRUCTURES`.
    """
    if structure not in STRUCTURES:
        raise ValueError(f"structure must be one of {STRUCTURES}, got {structure!r}")
    body = assembly.rigid_body(config)
    wheels = assembly.reaction_wheels(config)
    requirements = tuning_requirements(config, step_deg)
    period = config.control.period_s
    try:
        result = tune_pd(body, requirements, period=period, cost=cost, tradeoff_points=tradeoff_points)
    except RequirementConflict as exc:
        raise _config_error(exc, config, step_source(config, step_deg)[1]) from exc
    before = pd_metrics(
        body, requirements, wn=config.control.bandwidth_rad_per_s, zeta=config.control.damping, period=period
    )
    if not result.feasible:
        return TuneOutcome(config, None, result, before, None, None)
    control = replace(config.control, bandwidth_rad_per_s=float(result.wn), damping=float(result.zeta))
    tuned = replace(config, control=control)
    axis = np.asarray(
        quat.to_rotation_vector(
            quat.error_quaternion(config.requirements.slew.q_start(), config.requirements.slew.q_target())
        )
    )
    nonlinear = confirm_nonlinear(
        body,
        requirements,
        wn=result.wn,
        zeta=result.zeta,
        period=period,
        wheels=wheels,
        axis=axis,
        hold_time=config.requirements.hold_time_judged_s,
    )
    dispersed = None
    if dispersed_runs > 0 and config.montecarlo is not None:
        dispersed = dispersed_check(tuned, dispersed_runs, None, DISPERSED_NODES)
    return TuneOutcome(config, tuned, result, before, nonlinear, dispersed, flown_disk_margin(tuned, body))


def flown_disk_margin(config: SpacecraftConfig, body: Any = None) -> float | None:
    """The file's PD's smallest disk margin at the wheels' input with its modes and filters, or None without them.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (its ``[control]`` PD, ``[[flexible_modes]]`` and ``[[control.filters]]``).
    body : RigidBody, optional
        The file's body (built when None).

    Returns
    -------
    float or None
        Per axis and multiloop, the sampled loop (NaN: a closed loop is unstable); None for a rigid file
        without filters, whose loop the tuning itself judged.
    """
    body = assembly.rigid_body(config) if body is None else body
    pd = assembly.quaternion_pd(config, body)
    flown = assembly.command_filtered(config, pd)
    flexible = assembly.flexible_plant_model(config)
    if flexible is None and flown is pd:
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
    text = replace_values(
        _source_text(outcome.config),
        {"control.bandwidth_rad_per_s": new.bandwidth_rad_per_s, "control.damping": new.damping},
    )
    header = (
        f"# Tuned by `attitude tune` ({outcome.result.cost} minimised): control.bandwidth_rad_per_s "
        f"{old.bandwidth_rad_per_s:g} -> {new.bandwidth_rad_per_s:.6g}, control.damping {old.damping:g} -> "
        f"{new.damping:.6g}.\n# The comments beside those keys describe the values before tuning.\n"
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

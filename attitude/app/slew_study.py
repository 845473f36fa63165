"""The required slew of a spacecraft file, planned: minimum time around the keep-out cones, and the eigenaxis slew.

Top floor (DESIGN.md). One home for the plan that ``attitude design``
(section 3, :mod:`attitude.app.design.slew`), ``attitude slew`` and the
Monte Carlo scenarios (:mod:`attitude.app.scenarios`) fly: the required slew
planned minimum-time (or minimum-energy) with the keep-out cones and the
rate limit of the requirements (:func:`controllers.slew.planner.plan_slew`),
and the eigenaxis slew with the same torque and rate limits
(:func:`controllers.slew.reference.eigenaxis_slew`), which cannot avoid a
cone. It sits beside the design package rather than in it, so the design's
dispersed check can fly the scenarios without an import cycle.

Planning margins (:data:`PLAN_TORQUE_FRACTION`, :data:`PLAN_RATE_FRACTION`,
:data:`KEEP_OUT_MARGIN_DEG`) leave the feedback authority on top of the
feedforward, as a flight design would; the requirements are judged on the
flown slew, not on the plan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from attitude.app import assembly
from attitude.config import SpacecraftConfig
from attitude.plain import plain_float as _f
from attitude.plain import plain_vector as _vec
from controllers.slew.planner import plan_slew
from controllers.slew.problem import SlewPlanningError, momentum_rate_max
from controllers.slew.reference import axis_angle, eigenaxis_slew

__all__ = [
    "KEEP_OUT_MARGIN_DEG",
    "PLAN_MOMENTUM_FRACTION",
    "PLAN_RATE_FRACTION",
    "PLAN_STARTS",
    "PLAN_TORQUE_FRACTION",
    "SlewStudy",
    "plan_slews",
]

#: The slew is planned with this fraction of the wheels' torque, so the feedback keeps authority.
PLAN_TORQUE_FRACTION = 0.8
#: ... and this fraction of the rate limit, so tracking corrections stay under the limit. Sized by the
#: default file's Monte Carlo: with the inertia dispersed (5 % per moment, 1 sigma) the feedforward torque
#: of the nominal plan makes the tracked rate overshoot the plan's by up to 11 % (200 runs).
PLAN_RATE_FRACTION = 0.85
#: Perturbed starts of the planner, which keeps the best converged one: minimum-time slews around a
#: keep-out cone have local optima (controllers.slew.planner, "Guess and multi-start"), such as a loop around
#: the cone nearly three times longer than the optimum; a second start costs about a second here.
PLAN_STARTS = 2
#: ... and each keep-out cone widened by this much [deg] (less when the start or end attitude is closer).
KEEP_OUT_MARGIN_DEG = 0.5
#: ... and this fraction of the wheels' momentum capacity (controllers.slew.planner.momentum_rate_max): the
#: wheels hold -I omega during a rest-to-rest slew, plus what the feedback corrections add.
PLAN_MOMENTUM_FRACTION = 0.8


@dataclass
class SlewStudy:
    """The required slew planned two ways.

    Attributes
    ----------
    plan : SlewPlan or None
        The optimal plan (None when planning failed: see ``error``).
    eigenaxis : EigenaxisSlew or None
        The eigenaxis slew with the same torque and rate limits.
    cones : list of KeepOutConfig
        The keep-out requirements (half angles as required, unwidened).
    summary : dict
        JSON-ready figures of both.
    error : str or None
        Why the optimal plan is missing.
    hopeless : bool
        The eigenaxis slew takes more than :data:`HOPELESS_FACTOR` times the
        required time: planning and flight were skipped.
    """

    plan: Any
    eigenaxis: Any
    cones: list[Any]
    summary: dict[str, Any]
    error: str | None = None
    hopeless: bool = False

    @property
    def reference(self) -> Any:
        """What the closed loop flies: the plan, else the eigenaxis slew, else None (also when hopeless)."""
        if self.hopeless:
            return None
        return self.plan if self.plan is not None else self.eigenaxis


#: Eigenaxis slew time beyond this multiple of the required time: the slew is
#: reported as failed without optimal planning or flight (time-optimal plans
#: beat the eigenaxis slew by tens of percent, not by this factor).
HOPELESS_FACTOR = 10.0


def _trajectory_summary(name: str, t: Any, q: Any, omega: Any, torque: Any, cones: list[Any]) -> dict[str, Any]:
    sep = {c.name: _f(np.degrees(np.min(c.separation(q)))) for c in cones}
    return {
        "name": name,
        "duration_s": _f(t[-1] - t[0]),
        "rate_peak_deg_per_s": _f(np.degrees(np.max(np.linalg.norm(omega, axis=-1)))),
        "torque_peak_mNm": _f(1e3 * np.max(np.linalg.norm(torque, axis=-1))),
        "separation_min_deg": sep,
    }


def plan_slews(
    config: SpacecraftConfig,
    *,
    nodes: int = 60,
    objective: str = "time",
    duration_s: float | None = None,
    progress: bool | None = False,
) -> SlewStudy:
    """Section 3: the required slew, optimal (with cones and rate limit) and eigenaxis.

    Parameters
    ----------
    config : SpacecraftConfig
        Spacecraft and ``requirements.slew`` / ``requirements.keep_out``.
    nodes : int
        Planner intervals.
    objective : {"time", "energy"}
        Minimum time, or minimum ``integral |tau|^2 dt`` over ``duration_s``.
    duration_s : float, optional
        Slew time for "energy" [s] (default ``requirements.slew.time_max_s``).
    progress : bool or None
        A progress bar over the planner's :data:`PLAN_STARTS` starts on stderr
        (default False; None: when stderr is a terminal; ``progress`` of
        :func:`controllers.slew.planner.plan_slew`).
    """
    body = assembly.rigid_body(config)
    req = config.requirements
    slew = req.slew
    q0, qf = slew.q_start(), slew.q_target()
    plan_wheels = assembly.reaction_wheels(config, PLAN_TORQUE_FRACTION)
    rate_max = None if slew.rate_max_rad_per_s is None else PLAN_RATE_FRACTION * slew.rate_max_rad_per_s
    # Wheel momentum envelope: a rate limit that keeps the minimum-norm wheel momenta -A^+ I omega
    # inside PLAN_MOMENTUM_FRACTION of momentum_max on any path (the optimal plan), and the exact
    # momentum-limited rate along the eigenaxis for the eigenaxis slew.
    wheels = assembly.reaction_wheels(config)
    rate_h = PLAN_MOMENTUM_FRACTION * momentum_rate_max(body, wheels)
    rate_h_axis = PLAN_MOMENTUM_FRACTION * momentum_rate_max(body, wheels, axis_angle(q0, qf)[0])
    rate_plan = rate_h if rate_max is None else min(rate_max, rate_h)
    rate_eig = rate_h_axis if rate_max is None else min(rate_max, rate_h_axis)
    cones = list(req.keep_out)
    planned = []
    for c in cones:
        clearance = min(float(np.degrees(c.separation(q))) for q in (q0, qf)) - c.half_angle_deg
        margin = min(KEEP_OUT_MARGIN_DEG, max(0.0, 0.5 * clearance))
        planned.append(assembly.keep_out_cone(c, margin))
    summary: dict[str, Any] = {
        "angle_deg": _f(math.degrees(slew.angle_rad)),
        "q_start_BN": _vec(q0),
        "q_target_BN": _vec(qf),
        "objective": objective,
        "time_max_s": slew.time_max_s,
        "rate_max_deg_per_s": slew.rate_max_deg_per_s,
        "plan_torque_fraction": PLAN_TORQUE_FRACTION,
        "plan_torque_percent": 100.0 * PLAN_TORQUE_FRACTION,
        "plan_rate_fraction": PLAN_RATE_FRACTION,
        "plan_rate_percent": 100.0 * PLAN_RATE_FRACTION,
        "plan_rate_max_deg_per_s": None if rate_max is None else _f(math.degrees(rate_max)),
        "plan_momentum_fraction": PLAN_MOMENTUM_FRACTION,
        "momentum_rate_max_deg_per_s": _f(math.degrees(rate_h)),
        "momentum_rate_max_eigenaxis_deg_per_s": _f(math.degrees(rate_h_axis)),
        "planner_rate_max_deg_per_s": _f(math.degrees(rate_plan)),
        "eigenaxis_rate_max_deg_per_s": _f(math.degrees(rate_eig)),
        "torque_envelope_mNm": _vec(1e3 * plan_wheels.torque_envelope()),
        "keep_out": [
            {
                "name": c.name,
                "half_angle_deg": c.half_angle_deg,
                "planned_half_angle_deg": _f(math.degrees(p.half_angle)),
                "boresight_B": _vec(c.boresight_B),
                "direction_N": _vec(np.asarray(c.direction_N) / np.linalg.norm(c.direction_N)),
            }
            for c, p in zip(cones, planned)
        ],
        "nodes": nodes,
        "plan": None,
        "eigenaxis": None,
        "speedup_percent": None,
        "slowdown_percent": None,
        "error": None,
    }
    plan = eig = None
    error = None
    try:
        eig = eigenaxis_slew(body, q0, qf, torque_max=plan_wheels, rate_max=rate_eig, n_points=801)
    except ValueError as exc:
        error = f"eigenaxis: {exc}"
    # The eigenaxis time (closed form, instant) bounds what is achievable within a
    # small factor; far beyond the requirement, optimal planning and the flight
    # would only take a long time to confirm the failure.
    hopeless = eig is not None and objective == "time" and eig.duration > HOPELESS_FACTOR * slew.time_max_s
    if hopeless:
        error = (
            f"the eigenaxis slew takes {eig.duration:.4g} s, more than {HOPELESS_FACTOR:g} x the required "
            f"{slew.time_max_s:g} s: these wheels cannot make this slew in time (optimal planning and the flight "
            "were skipped)"
        )
    else:
        try:
            kwargs: dict[str, Any] = {
                "torque_max": plan_wheels,
                "rate_max": rate_plan,
                "keep_out": planned,
                "nodes": nodes,
            }
            if objective == "energy":
                kwargs["duration"] = slew.time_max_s if duration_s is None else duration_s
            plan = plan_slew(body, q0, qf, objective=objective, starts=PLAN_STARTS, progress=progress, **kwargs)
        except (SlewPlanningError, ValueError) as exc:
            error = (error + "; " if error else "") + f"{type(exc).__name__}: {exc}"
    if plan is not None:
        dense = plan.resample(min(0.05, plan.duration / 400.0))
        entry = _trajectory_summary(
            "minimum time" if objective == "time" else "minimum energy",
            dense.t,
            dense.q,
            dense.omega,
            plan.torque,
            cones,
        )
        entry["separation_min_deg"] = {
            c.name: _f(math.degrees(s)) for c, s in zip(cones, np.atleast_1d(plan.separation_min))
        }
        entry.update(
            {
                "refined": plan.refined_duration is not None,
                "grid_duration_s": _f(plan.grid_duration),
                "status": plan.status,
                "solve_time_s": _f(plan.solve_time),
                "wall_time_s": _f(plan.wall_time),
                "open_loop_final_error_deg": _f(plan.final_attitude_error_deg),
                "energy_N2m2s": _f(np.sum(np.sum(plan.torque[:-1] ** 2, axis=1) * np.diff(plan.t))),
            }
        )
        summary["plan"] = entry
    if eig is not None:
        entry = _trajectory_summary("eigenaxis", eig.t, eig.q, eig.omega, eig.torque, cones)
        entry["axis_B"] = _vec(eig.axis_B)
        power = np.sum(eig.torque**2, axis=1)
        entry["energy_N2m2s"] = _f(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(eig.t)))
        summary["eigenaxis"] = entry
    if plan is not None and eig is not None:
        summary["speedup_percent"] = _f(100.0 * (1.0 - plan.duration / eig.duration))
        summary["slowdown_percent"] = -summary["speedup_percent"]
    summary["error"] = error
    summary["hopeless"] = bool(hopeless)
    return SlewStudy(plan, eig, cones, summary, error, hopeless)

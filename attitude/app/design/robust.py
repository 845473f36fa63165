"""The robust study of the design: the worst case of the file's PD over its ``[uncertainty]`` set (top floor).

The quaternion PD of ``[control]`` (:func:`attitude.app.assembly.quaternion_pd`) on the whole spacecraft
(:func:`attitude.app.assembly.rigid_body`) with the file's wheels, over the set of ``[uncertainty]``
(:func:`attitude.app.assembly.uncertainty_set`):

* the smallest multiloop disk margin at the plant input of the sampled loop that flies
  (:func:`controllers.worst_case.worst_case_disk_margin`): with the file's ``[[flexible_modes]]`` on every
  plant of the set and its ``[[control.filters]]`` on the command, and
* the largest overshoot of the linear closed loop's reference steps
  (:func:`controllers.worst_case.worst_case_step`: with the modes, without the filters, whose linear
  reference loop it does not model),

each found by optimisation, with its worst plant, and compared with uniform samples of the same set.
"""

from __future__ import annotations

from typing import Any

from matplotlib.figure import Figure

from attitude.app import assembly
from attitude.config import SpacecraftConfig
from controllers.tuning import format_values
from controllers.worst_case import (
    DEFAULT_LOCAL_MAXFEV,
    DEFAULT_LOCAL_STARTS,
    DEFAULT_MAXITER,
    DEFAULT_POPSIZE,
    DEFAULT_SAMPLES,
    STEP_METRICS,
    worst_case_disk_margin,
    worst_case_step,
)

__all__ = ["robust_study"]


def robust_study(
    config: SpacecraftConfig,
    *,
    step_metric: str | None = "overshoot",
    samples: int = DEFAULT_SAMPLES,
    maxiter: int = DEFAULT_MAXITER,
    popsize: int = DEFAULT_POPSIZE,
    local_starts: int = DEFAULT_LOCAL_STARTS,
    local_maxfev: int = DEFAULT_LOCAL_MAXFEV,
    seed: int = 0,
) -> tuple[dict[str, Any], dict[str, Figure]]:
    """The worst disk margin (and step metric) of the file's PD over its ``[uncertainty]`` set.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file; without an ``[uncertainty]`` table the study is empty (``"uncertainty": None``).
    step_metric : {"overshoot", "settling_time"} or None
        The step metric whose worst case is also found (None: the disk margin alone).
    samples : int
        Uniform samples of the set (the Monte Carlo comparison).
    maxiter : int
        Generations of differential evolution.
    popsize : int
        Its population per parameter.
    local_starts : int
        Corners from which a local search starts.
    local_maxfev : int
        Evaluations of each local search at most.
    seed : int
        Seed of the samples and of differential evolution.

    Returns
    -------
    dict
        JSON-ready: ``uncertainty`` (the bounds, or None), ``controller``, ``disk_margin`` and ``step``
        (:meth:`controllers.worst_case.WorstCase.to_dict`), ``summary`` (lines).
    dict of str to Figure
        ``robust_disk_margin`` (and ``robust_<step quantity>``): the samples' histogram with the optimiser's
        worst, the sampled worst and the nominal marked.

    Raises
    ------
    ValueError
        For a ``step_metric`` not in :data:`controllers.worst_case.STEP_METRICS`.
    """
    if step_metric is not None and step_metric not in STEP_METRICS:
        raise ValueError(f"step_metric must be one of {tuple(STEP_METRICS)} or None, got {step_metric!r}")
    uncertainty = assembly.uncertainty_set(config)
    if uncertainty is None:
        return {"uncertainty": None, "summary": ["no [uncertainty] table: no worst-case search"]}, {}
    body = assembly.rigid_body(config)
    pd = assembly.quaternion_pd(config)
    wheels = assembly.reaction_wheels(config)
    budget = {
        "samples": samples,
        "maxiter": maxiter,
        "popsize": popsize,
        "local_starts": local_starts,
        "local_maxfev": local_maxfev,
        "seed": seed,
    }
    modes = assembly.flexible_modes(config)
    flown = assembly.command_filtered(config, pd)
    margin = worst_case_disk_margin(body, flown, uncertainty, wheels=wheels, modes=modes, **budget)
    c = config.control
    plant = "rigid" if modes is None else f"flexible ({modes.n_modes} mode{'s' if modes.n_modes > 1 else ''})"
    filters = f", with its {len(c.filters)} command filter(s)" if c.filters else ""
    out: dict[str, Any] = {
        "uncertainty": margin.to_dict()["uncertainty"],
        "controller": (
            f"quaternion PD, {format_values(c.bandwidth_rad_per_s)} rad/s, damping {format_values(c.damping)}, "
            f"sampled at {c.period_s:g} s"
            f"{filters}, on the {plant} spacecraft"
        ),
        "disk_margin_min": config.requirements.disk_margin_min,
        "worst_disk_margin": margin.worst,
        "disk_margin": margin.to_dict(),
        "step": None,
        "summary": margin.summary().splitlines(),
    }
    figures = {"robust_disk_margin": margin.plot()}
    if step_metric is not None:
        step = worst_case_step(body, pd, uncertainty, wheels=wheels, modes=modes, metric=step_metric, **budget)
        out["step"] = step.to_dict()
        out["summary"] += step.summary().splitlines()
        figures[f"robust_{step.quantity}"] = step.plot()
    return out, figures

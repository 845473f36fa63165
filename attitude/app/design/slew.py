"""Sections 3 and 4 of the design report: the required slew, planned and flown (top floor).

Imports :mod:`controllers` and :mod:`estimation` (the MEKF flies in the
loop), so it belongs to the top floor with :mod:`attitude.app.design.run`.

* Section 3 (:func:`plan_slews`, whose home is :mod:`attitude.app.slew_study`,
  shared with the Monte Carlo scenarios): the required slew planned
  minimum-time (or minimum-energy) with the keep-out cones and the rate limit
  of the requirements, and the eigenaxis slew with the same limits; here its
  figures (:func:`slew_figures`).
* Section 4 (:func:`fly_slew`): the plan flown with
  :class:`controllers.tracking.TrackingController` (feedback at the file's
  bandwidth and damping), the reaction wheels with their limits, the gyro
  and the star tracker, and the MEKF in the loop, from an initial knowledge
  error drawn from the filter's covariance. The run goes on for the
  required settling time after the slew, then for the hold
  (``requirements.hold_time_s``) over which the pointing accuracy is judged.

The requirements are judged on the flown slew, not on the plan, on the error
to the target attitude, with the definitions and windows the Monte Carlo
campaigns use (:mod:`attitude.simulation.slew_windows`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.app.slew_study import KEEP_OUT_MARGIN_DEG, PLAN_RATE_FRACTION, PLAN_TORQUE_FRACTION, SlewStudy, plan_slews
from attitude.config import ConfigError, SpacecraftConfig
from attitude.plain import plain_float as _f
from attitude.simulation.engine import SimulationResult, simulate

__all__ = [
    "CLOSED_LOOP_TICKS_MAX",
    "KEEP_OUT_MARGIN_DEG",
    "PLAN_RATE_FRACTION",
    "PLAN_TORQUE_FRACTION",
    "TICK_CPU_S",
    "SlewStudy",
    "check_periods",
    "fly_slew",
    "plan_slews",
    "slew_figures",
]


def slew_figures(study: SlewStudy) -> dict[str, Figure]:
    """The figures of section 3: the optimal plan and the side-by-side comparison.

    Parameters
    ----------
    study : SlewStudy
        The planned slew of section 3.
    """
    figures: dict[str, Figure] = {}
    if study.plan is not None:
        # The plan's limits carry the planning margins; the required ones are drawn beside them.
        rate = study.summary["rate_max_deg_per_s"]
        figures["slew_plan"] = study.plan.plot(
            keep_out_half_angle_required=[math.radians(c.half_angle_deg) for c in study.cones] or None,
            rate_max_required=None if rate is None else math.radians(rate),
            torque_envelope_available=1e-3 * np.asarray(study.summary["torque_envelope_mNm"]) / PLAN_TORQUE_FRACTION,
        )
    if study.plan is None and study.eigenaxis is None:
        return figures
    # Without a keep-out cone there is no separation to show: one panel (no empty legend).
    fig = Figure(figsize=(10, 6.5 if study.cones else 3.8), layout="constrained")
    ax_w, ax_s = fig.subplots(2, 1, sharex=True) if study.cones else (fig.subplots(), None)
    for name, traj, style in (("optimal plan", study.plan, "-"), ("eigenaxis", study.eigenaxis, "--")):
        if traj is None:
            continue
        if name == "optimal plan":
            traj = traj.resample(min(0.05, traj.duration / 400.0))
        ax_w.plot(traj.t, np.degrees(np.linalg.norm(traj.omega, axis=1)), style, label=name)
        for c in study.cones:
            ax_s.plot(traj.t, np.degrees(c.separation(traj.q)), style, label=f"{name}: {c.name}")
    rate = study.summary["plan_rate_max_deg_per_s"]
    if rate is not None:
        ax_w.axhline(rate / PLAN_RATE_FRACTION, color="tab:red", lw=0.8, ls=":", label="required rate limit")
    ax_w.set_ylabel("|body rate| [deg/s]")
    if ax_s is not None:
        lo, hi = ax_s.get_ylim()
        for c in study.cones:
            ax_s.axhline(c.half_angle_deg, color="tab:red", lw=0.8, ls=":", label=f"keep-out half-angle ({c.name})")
            ax_s.axhspan(min(lo, c.half_angle_deg) - 90.0, c.half_angle_deg, color="tab:red", alpha=0.08)
        ax_s.set_ylim(min(lo, min(c.half_angle_deg for c in study.cones) - 1.0), hi)
        ax_s.set_ylabel("boresight separation [deg]")
    (ax_w if ax_s is None else ax_s).set_xlabel("time from the start of the slew [s]")
    for ax in (ax_w, ax_s):
        if ax is not None:
            ax.grid(True, alpha=0.3)
            ax.legend(loc="best", fontsize=8)
    suffix = "" if study.cones else " (no keep-out cones in the requirements)"
    fig.suptitle("Optimal plan and eigenaxis slew side by side" + suffix)
    figures["slew_comparison"] = fig
    return figures


# ---------------------------------------------------------------------------
# 4. Closed loop


#: CPU time of one tick of the design's closed loop with gyro, star tracker, MEKF and the orbit environment
#: [s] (measured on the built-in spacecraft: 2.9 s for its 1,589 ticks).
TICK_CPU_S = 1.8e-3
#: Longest closed loop the design flies [ticks]: 2e5 ticks take about 6 minutes. A sample period a
#: thousand times too short (a units mistake) is refused instead of running for hours with no word.
CLOSED_LOOP_TICKS_MAX = 2e5


def check_periods(config: SpacecraftConfig) -> float:
    """The engine tick [s]; every period must be a whole multiple of the shortest one.

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (sensor, filter and controller periods [s]).

    Raises
    ------
    ConfigError
        Naming the first period that is not a multiple, or the shortest
        period when it makes the closed loop longer than
        :data:`CLOSED_LOOP_TICKS_MAX` ticks (a units mistake).
    """
    periods = {
        "control.period_s": config.control.period_s,
        "gyro.period_s": config.gyro_config.period_s,
        "star_tracker.period_s": config.star_tracker_config.period_s,
    }
    tick = min(periods.values())
    for key, p in periods.items():
        k = round(p / tick)
        if abs(p / tick - k) > 1e-9 * max(1.0, p / tick):
            raise ConfigError(
                f"must be a whole multiple of the shortest sample period ({tick:g} s) so that the closed-loop "
                f"simulation can run the controller, gyro and star tracker on one clock; got {p:g} s",
                key=key,
                file=config.source or "<config>",
            )
    # The closed loop of section 4 runs at most the required slew time plus settling plus the hold.
    req = config.requirements
    span = req.slew.time_max_s + req.settling_time_s + req.hold_time_judged_s
    ticks = span / tick
    if ticks > CLOSED_LOOP_TICKS_MAX:
        key = min(periods, key=periods.get)
        raise ConfigError(
            f"makes the closed loop of the design {ticks:.3g} ticks long ({span:g} s of slew, settling and hold "
            f"at {tick:g} s), more than {CLOSED_LOOP_TICKS_MAX:.0e} (about {ticks * TICK_CPU_S / 60.0:.0f} "
            f"minutes at {TICK_CPU_S * 1e6:.0f} us per tick): check the unit (seconds); got {tick:g} s",
            key=key,
            file=config.source or "<config>",
        )
    return tick


def fly_slew(
    config: SpacecraftConfig, study: SlewStudy, seed: Any
) -> tuple[dict[str, Any] | None, dict[str, Figure], SimulationResult | None]:
    """Section 4: the planned slew flown with tracking control, wheels, gyro, star tracker and MEKF.

    With an ``[orbit]`` in the file the slew is flown in it, from the orbit's
    epoch: the four disturbance torques act (their peaks per source are in
    the figures dict).

    Returns the figures dict (None when there is nothing to fly), the
    figures and the :class:`SimulationResult` (the truth of section 5).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    study : SlewStudy
        The planned slew of section 3.
    seed : int, numpy.random.SeedSequence or None
        Seed of the sensor noise.
    """
    ref = study.reference
    if ref is None:
        return None, {}, None
    tick = check_periods(config)
    req = config.requirements
    body = assembly.rigid_body(config)
    c = config.control
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    rng_init, rng_sim = (np.random.default_rng(s) for s in root.spawn(2))
    slew_end = float(ref.t[-1])
    windows = assembly.slew_windows(config, slew_end)
    duration = assembly.judged_duration(config, slew_end)
    reference = ref.resample(c.period_s) if hasattr(ref, "resample") else ref
    # The filters of [[control.filters]] fly on the command (the protocol path: no compiled law).
    controller = assembly.command_filtered(
        config, assembly.tracking_controller(config, reference, body, feedforward=ref)
    )
    # An integrating gyro (interval-mean samples): what the MEKF's propagation models.
    gyro, tracker = assembly.gyro(config, sampling="mean"), assembly.star_tracker(config)
    q0 = req.slew.q_start()
    sig_a0 = assembly.attitude_sigma0()
    sig_b0 = assembly.gyro_bias_sigma0(config)
    q_hat0 = quat.multiply(q0, quat.from_rotation_vector(rng_init.standard_normal(3) * sig_a0))
    mekf = assembly.mekf(
        gyro,
        tracker,
        q0=q_hat0,
        P0=assembly.mekf_initial_covariance(attitude_sigma_rad=sig_a0, bias_sigma_rad_per_s=sig_b0),
    )
    wheels = assembly.reaction_wheels(config)
    environment = assembly.orbit_environment(config)  # None without an [orbit]: empty inertial space
    r = simulate(
        body,
        q0,
        np.zeros(3),
        duration,
        controller=controller,
        wheels=wheels,
        sensors=[gyro, tracker],
        estimator=mekf,
        environment=environment,
        rng=rng_sim,
    )
    accuracy = req.pointing_accuracy_rad
    # Every row is judged on the error to the TARGET attitude (r.error_angle is the error to the moving
    # reference, the tracking error), over the windows the campaigns use.
    to_target = np.asarray(quat.error_angle(req.slew.q_target(), r.q))
    judged = windows.metrics(r.t, to_target)
    window = (r.t >= windows.hold_start_s - 1e-9) & (r.t <= windows.hold_end_s + 1e-9)
    err_deg = np.degrees(to_target)
    knowledge = np.degrees(quat.error_angle(r.estimate_q, r.q)) * 3600.0
    speed_limit_rpm = np.asarray(r.info.get("wheel_speed_limit_rpm", [np.inf]), dtype=float)
    updates = r.logs.get("estimator.updates")
    out = {
        "reference": "optimal plan" if study.plan is not None else "eigenaxis slew (the optimal plan failed)",
        "duration_s": _f(duration),
        "tick_s": _f(tick),
        "engine": r.info.get("engine"),
        "tracking_wn_rad_per_s": c.bandwidth_rad_per_s,
        "tracking_damping": c.damping,
        "drawn_initial_knowledge_error_arcsec": _f(math.degrees(float(quat.error_angle(q_hat0, q0))) * 3600.0),
        "initial_knowledge_error_arcsec": _f(knowledge[0]),
        "slew_end_s": slew_end,
        "plan_slew_time_s": slew_end,
        "flown_slew_time_s": _f(judged["slew_time"]),
        "pointing_error_max_after_slew_deg": _f(np.max(err_deg[r.t >= slew_end])),
        "settling_time_after_slew_s": _f(judged["settling_after_slew"]),
        "settling_dwell_s": _f(windows.dwell_s),
        "pointing_window_start_s": _f(windows.hold_start_s),
        "pointing_window_end_s": _f(windows.hold_end_s),
        "pointing_error_max_in_window_deg": _f(math.degrees(judged["pointing_error_hold"])),
        "pointing_error_max_in_window_at_s": _f(r.t[window][np.argmax(err_deg[window])]),
        "tracking_error_max_in_window_deg": _f(np.degrees(np.max(r.error_angle[window]))),
        "judged_how": windows.describe(),
        "pointing_error_end_deg": _f(err_deg[-1]),
        "pointing_error_end_arcsec": _f(err_deg[-1] * 3600.0),
        "knowledge_error_rms_in_window_arcsec": _f(np.sqrt(np.mean(knowledge[window] ** 2))),
        "knowledge_error_max_in_window_arcsec": _f(np.max(knowledge[window])),
        "rate_peak_deg_per_s": _f(np.degrees(np.max(np.linalg.norm(r.omega, axis=1)))),
        "wheel_speed_peak_rpm": _f(np.max(np.abs(r.wheel_speed)) * 30.0 / math.pi),
        "wheel_speed_limit_rpm": _f(np.min(speed_limit_rpm)),
        "wheel_momentum_peak_Nms": _f(np.max(np.abs(r.h_wheels))),
        "wheel_momentum_limit_Nms": _f(np.min(wheels.momentum_max)),
        "motor_torque_peak_mNm": _f(1e3 * np.max(np.abs(r.motor_torque))),
        **_saturation(r),
        "motor_torque_limit_mNm": _f(1e3 * np.min(wheels.torque_max)),
        "separation_min_deg": {k.name: _f(np.degrees(np.min(k.separation(r.q)))) for k in study.cones},
        "tracker_updates": None if updates is None else int(np.nanmax(updates)),
        "tracker_blinded_samples": _blinded_samples(tracker, r),
        "wall_time_s": _f(r.info.get("wall_time_s", 0.0)),
        "environment": None if environment is None else environment.describe(),
        "disturbance_torque_peak_uNm": {
            source: _f(1e6 * float(np.max(np.linalg.norm(tau, axis=-1))))
            for source, tau in r.disturbance_torques.items()
        },
    }
    return out, {"closed_loop": r.plot(), "pointing": _pointing_figure(r, out, accuracy, knowledge, to_target)}, r


def _saturation(r: SimulationResult) -> dict[str, Any]:
    """Commanded against applied torque: how often and how far the wheels cut the command.

    A tick is saturated when the applied body torque differs from the command by more than 1e-9 of the
    command's size (the allocation is exact to rounding otherwise).
    """
    command = np.linalg.norm(r.torque_command, axis=-1)
    gap = np.linalg.norm(r.torque_command - r.torque_applied, axis=-1)
    saturated = gap > 1e-9 * np.maximum(command, 1e-12)
    applied = np.linalg.norm(r.torque_applied, axis=-1)
    peak_ratio = float(np.max(command) / np.max(applied)) if np.max(applied) > 0.0 else math.inf
    speed = np.max(np.abs(r.wheel_speed)) if r.wheel_speed.size else 0.0
    limit = np.min(np.asarray(r.info.get("wheel_speed_limit_rpm", [np.inf]), dtype=float)) * math.pi / 30.0
    return {
        "torque_saturated_fraction": _f(float(np.mean(saturated))),
        "torque_command_peak_mNm": _f(1e3 * float(np.max(command))),
        "torque_applied_peak_mNm": _f(1e3 * float(np.max(applied))),
        "torque_command_to_applied_peak_ratio": _f(peak_ratio),
        "wheel_speed_margin_percent": _f(100.0 * (1.0 - speed / limit) if math.isfinite(limit) else math.nan),
    }


def _blinded_samples(tracker: Any, r: SimulationResult) -> int:
    """Star-tracker sample times at which the Sun blinded the tracker."""
    phase = r.t / tracker.period
    sampled = np.abs(phase - np.round(phase)) < 1e-6
    return int(sum(tracker.sun_blinded(t, q) for t, q in zip(r.t[sampled], r.q[sampled])))


def _pointing_figure(
    r: SimulationResult, flight: dict[str, Any], accuracy: float, knowledge: Any, to_target: Any
) -> Figure:
    """Error to the target (what every row judges), to the moving reference, and knowledge, with the windows."""
    fig = Figure(figsize=(10, 4.8), layout="constrained")
    ax = fig.subplots()
    target_deg = np.degrees(to_target)
    floor = 10.0 ** np.floor(np.log10(max(np.min(target_deg[r.t >= flight["slew_end_s"]]), 1e-6)))
    ax.semilogy(r.t, np.maximum(target_deg, floor), color="black", label="error to the target (judged)")
    ax.semilogy(
        r.t, np.maximum(np.degrees(r.error_angle), floor), color="0.55", lw=0.7, label="error to the moving reference"
    )
    ax.semilogy(r.t, np.maximum(knowledge / 3600.0, floor), color="tab:blue", lw=0.7, label="knowledge error (MEKF)")
    ax.axhline(math.degrees(accuracy), color="tab:red", ls="--", lw=1.0, label="required pointing accuracy")
    ax.axvspan(flight["slew_end_s"], flight["pointing_window_start_s"], color="tab:orange", alpha=0.10)
    ax.axvspan(flight["pointing_window_start_s"], flight["pointing_window_end_s"], color="tab:green", alpha=0.12)
    ax.set_ylim(floor, None)
    top = ax.get_ylim()[1]
    ax.text(flight["slew_end_s"], top, " settling allowed", va="top", fontsize=8)
    ax.text(flight["pointing_window_start_s"], top, " hold: pointing judged", va="top", fontsize=8)
    arrived = flight["flown_slew_time_s"]
    if math.isfinite(arrived):
        ax.axvline(arrived, color="black", ls=":", lw=1.0)
        ax.text(arrived, floor * 1.3, " settled", fontsize=8)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("angle [deg]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="center right", fontsize=8)
    settle = flight["settling_time_after_slew_s"]
    settled = f"settled {settle:.1f} s after the slew" if math.isfinite(settle) else "never settled within the accuracy"
    ax.set_title(
        f"Error to the target: {settled}; largest over the hold {flight['pointing_error_max_in_window_deg']:.3g} deg "
        f"(required {math.degrees(accuracy):.3g} deg)"
    )
    return fig

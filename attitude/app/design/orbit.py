"""The design report's orbit section: disturbance torques, the momentum budget, unloading and detumbling.

Part of the top floor (:mod:`attitude.app.design.run` assembles it; ``attitude
momentum`` runs the budget alone). It runs when the spacecraft file has an
``[orbit]``:

* **Disturbance torques over one orbit**, per source (gravity gradient,
  aerodynamic, solar radiation pressure, residual dipole), along the nominal
  nadir (LVLH) hold: peak, mean magnitude and the orbit-averaged vector in
  body axes (the part that accumulates).
* **Momentum budget** over ``[momentum] orbits`` orbits
  (:func:`attitude.environment.held_attitude_momentum`, the budget of a
  perfect attitude control): the wheel momentum without dumping (secular
  build-up rate from a least-squares fit) and, with ``[magnetorquers]`` and an
  unloading gain, under cross-product unloading; per-wheel momentum (minimum
  norm distribution) against ``wheel_momentum_margin`` of each wheel's
  capacity, as a requirement row.
* **Nadir hold in closed loop** over one orbit: the ``[control]`` PD on the
  LVLH frame with the wheels, the four disturbance torques and, with rods,
  cross-product unloading on the true field, flown by the compiled engine:
  how the pointing holds under the disturbances.
* **Detumbling** from the ``[detumble]`` tip-off rate with the B-dot law on the
  magnetometer's samples, flown by the engine with the environment on: time
  until the rate stays below the threshold.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from attitude.app import assembly
from attitude.config import SpacecraftConfig
from attitude.environment import DISTURBANCE_SOURCES, MomentumBuildUp, held_attitude_momentum
from attitude.plain import plain_float as _f
from attitude.plain import plain_vector as _vec
from attitude.progress import progress_bar
from attitude.simulation.engine import simulate

__all__ = [
    "BUDGET_STEP_S",
    "UNLOADING_STEP_FRACTION",
    "detumble_figures",
    "detumble_study",
    "momentum_budget",
    "momentum_figures",
    "nadir_hold",
]

#: Grid of the momentum budget [s]. The torques change on the scale of the orbit (about 5,700 s in LEO) and
#: the unloading law on 1/k (2,000 s in the default file): RK4 on a 10 s grid is exact to far below 1e-6.
BUDGET_STEP_S = 10.0

#: Largest ``k dt`` of the budget's RK4 under cross-product unloading of gain ``k`` [1/s] (see the step).
UNLOADING_STEP_FRACTION = 0.5

_UNITS_MICRO = 1e6
_UNITS_MILLI = 1e3


def _nadir_reference(orbit: Any, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The nadir (LVLH) hold: body axes on the LVLH axes, attitude and body rate at ``t``."""
    q = np.asarray(orbit.q_LN(t), dtype=float)
    w = np.asarray(orbit.omega_LN_L(t), dtype=float)
    return q, np.broadcast_to(w, (t.size, 3)).copy()


def _build_up_summary(build: MomentumBuildUp, wheels: Any, margin: float, period: float) -> dict[str, Any]:
    per_wheel = build.h_wheels_B @ wheels.allocation.T  # minimum-norm distribution A^+ of the wheels
    capacity = np.asarray(wheels.momentum_max, dtype=float) * np.ones(wheels.n_wheels)
    peak = np.max(np.abs(per_wheel), axis=0)
    return {
        "peak_body_mNms": _f(build.peak_B * _UNITS_MILLI),
        "final_body_mNms": _vec(build.h_wheels_B[-1] * _UNITS_MILLI),
        # Inertial frame: the body components of a nadir-pointing spacecraft turn with it.
        "secular_rate_inertial_uNms_per_orbit": _vec(build.secular_rate_N * period * _UNITS_MICRO),
        "secular_rate_magnitude_uNms_per_orbit": _f(
            float(np.linalg.norm(build.secular_rate_N)) * period * _UNITS_MICRO
        ),
        "peak_per_wheel_mNms": _vec(peak * _UNITS_MILLI),
        "capacity_per_wheel_mNms": _vec(capacity * _UNITS_MILLI),
        "allowed_per_wheel_mNms": _vec(margin * capacity * _UNITS_MILLI),
        "fraction_of_capacity_max": _f(float(np.max(peak / capacity))),
        "within_margin": bool(np.all(peak <= margin * capacity)),
    }


def momentum_budget(
    config: SpacecraftConfig, orbits: float | None = None, progress: bool | None = False
) -> dict[str, Any] | None:
    """Disturbance torques over one orbit and the wheel momentum over ``orbits`` (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (``[orbit]``, ``[environment]``, ``[surface]``,
        ``[wheels]``, and optionally ``[magnetorquers]`` and ``[momentum]``).
    orbits : float, optional
        Length of the budget [orbits]; default ``[momentum] orbits`` (20 without the table).
    progress : bool or None
        A progress bar on stderr over the unloading run, the long part
        (:func:`attitude.progress.progress_bar`; default False; None: when
        stderr is a terminal; erased when done).

    Returns
    -------
    dict or None
        JSON-ready results (units in the keys), plus the private key
        ``"_histories"`` (numpy arrays for the figures); None without an ``[orbit]``.
    """
    env = assembly.orbit_environment(config)
    if env is None:
        return None
    orbit = env.orbit
    body = assembly.rigid_body(config)
    wheels = assembly.reaction_wheels(config)
    settings = assembly.momentum_settings(config)
    margin = 1.0 if settings is None else settings.wheel_momentum_margin
    n_orbits = float(orbits if orbits is not None else (settings.orbits if settings is not None else 20))
    if not n_orbits > 0:
        raise ValueError(f"orbits must be positive, got {n_orbits!r}")
    period = float(orbit.period)

    # One orbit of torques along the nadir hold, at the track's own resolution.
    t1 = np.arange(0.0, period + env.sample_period, env.sample_period)
    q1, _ = _nadir_reference(orbit, t1)
    track1 = env.track(t1)
    torques = env.torques_B(body, q1, track1)
    per_source = {}
    for source in DISTURBANCE_SOURCES:
        if source not in torques:
            continue
        tau = torques[source]
        mag = np.linalg.norm(tau, axis=-1)
        per_source[source] = {
            "peak_uNm": _f(float(mag.max()) * _UNITS_MICRO),
            "mean_uNm": _f(float(mag.mean()) * _UNITS_MICRO),
            "orbit_average_body_uNm": _vec(tau.mean(axis=0) * _UNITS_MICRO),
        }
    total = sum(torques.values())

    # N orbits: no dumping, then unloading. The step resolves the unloading law's time constant 1/k too:
    # RK4 on dh/dt = -k h errs by (k dt)^5 / 120 per step, 2.6e-4 at k dt = 0.5 (stable up to 2.8).
    law = assembly.unloading_controller(config, use_truth_field=True)
    step = BUDGET_STEP_S if law is None else min(BUDGET_STEP_S, UNLOADING_STEP_FRACTION / law.gain)
    n_steps = max(2, math.ceil(n_orbits * period / step))
    t = np.arange(n_steps + 1) * step
    q, w = _nadir_reference(orbit, t)
    # The budget reads the track at half steps: sample it there, not at the file's finer period.
    env = dataclasses.replace(env, sample_period=max(env.sample_period, 0.5 * step))
    free = held_attitude_momentum(env, body, t, q, w)
    free_summary = _build_up_summary(free, wheels, margin, period)
    unloading = None
    unloaded = None
    if law is not None:
        target = list(law.target_momentum_B)

        def dipole_law(field_B: np.ndarray, h_B: np.ndarray) -> np.ndarray:
            return np.array([float(v) for v in law.dipole_components(list(field_B), list(h_B), target)])

        desc = f"unloading over {n_orbits:g} orbits"
        with progress_bar(n_steps, desc=desc, unit="step", enabled=progress, leave=False) as bar:
            unloaded = held_attitude_momentum(
                env, body, t, q, w, dipole_law=dipole_law, progress=lambda f: bar.update(round(n_steps * f) - bar.n)
            )
        unloading = _build_up_summary(unloaded, wheels, margin, period)
        unloading.update(
            {
                "gain_per_s": _f(law.gain),
                "dipole_peak_Am2": _f(float(np.max(np.abs(unloaded.dipole)))),
                "last_orbit_peak_body_mNms": _f(
                    float(np.max(np.linalg.norm(unloaded.h_wheels_B[t >= t[-1] - period], axis=-1))) * _UNITS_MILLI
                ),
            }
        )
    judged = unloading if unloading is not None else free_summary
    return {
        "orbit": orbit.describe() if hasattr(orbit, "describe") else type(orbit).__name__,
        "environment": env.describe(),
        "pointing": "nadir (LVLH) hold, body axes on the LVLH axes",
        "orbit_period_s": _f(period),
        "orbits": _f(n_orbits),
        "step_s": _f(step),
        "torques": per_source,
        "total_orbit_average_body_uNm": _vec(total.mean(axis=0) * _UNITS_MICRO),
        "no_dumping": free_summary,
        "unloading": unloading,
        "wheel_momentum_margin": _f(margin),
        "judged_case": "unloading" if unloading is not None else "no dumping",
        "pass": bool(judged["within_margin"]),
        "_histories": {
            "t1": t1,
            "torques": torques,
            "illumination": track1.illumination,
            "t": t,
            "free": free,
            "unloaded": unloaded,
            "period": period,
            "wheel_allocation": wheels.allocation,
        },
    }


def momentum_figures(budget: dict[str, Any]) -> dict[str, Figure]:
    """The torque figure (one orbit, per source) and the per-wheel momentum figure (N orbits).

    Parameters
    ----------
    budget : dict
        The result of :func:`momentum_budget` (with its ``"_histories"``).
    """
    h = budget["_histories"]
    period = h["period"]
    fig_t = Figure(figsize=(9, 4.5), layout="constrained")
    ax = fig_t.subplots()
    x1 = h["t1"] / period
    largest = max((float(np.max(np.linalg.norm(tau, axis=-1))) for tau in h["torques"].values()), default=0.0)
    for source, tau in h["torques"].items():
        magnitude = np.linalg.norm(tau, axis=-1) * 1e6
        # Below 1e-9 of the largest torque is rounding (e.g. gravity gradient on principal axes along LVLH).
        shown = np.where(magnitude > 1e-9 * largest * 1e6, magnitude, np.nan)
        if np.all(np.isnan(shown)):
            ax.plot([], [], label=f"{source.replace('_', ' ')} (zero to rounding)")
            continue
        ax.semilogy(x1, shown, label=source.replace("_", " "))
    shadow = h["illumination"] < 0.5
    if np.any(shadow):
        ax.fill_between(x1, 0, 1, where=shadow, color="0.85", transform=ax.get_xaxis_transform(), label="eclipse")
    ax.set_xlabel("time [orbits]")
    ax.set_ylabel("torque magnitude [uN m]")
    ax.set_title("Disturbance torques over one orbit, nadir hold (no solar pressure in eclipse)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower left", ncols=5, fontsize="small")

    cases = [("no dumping", h["free"])]
    if h["unloaded"] is not None:
        cases.append(("cross-product unloading", h["unloaded"]))
    fig_h = Figure(figsize=(9, 3.2 * len(cases) + 0.6), layout="constrained")
    axes = np.atleast_1d(fig_h.subplots(len(cases), 1, sharex=True))
    allowed = min(budget["no_dumping"]["allowed_per_wheel_mNms"])
    for ax, (label, build) in zip(axes, cases):
        per_wheel = build.h_wheels_B @ h["wheel_allocation"].T * 1e3
        for i in range(per_wheel.shape[1]):
            ax.plot(build.t / period, per_wheel[:, i], lw=1.0, label=f"wheel {i + 1}")
        peak = float(np.max(np.abs(per_wheel)))
        if peak > 0.2 * allowed:
            ax.axhline(allowed, color="r", ls="--", lw=1, label="allowed")
            ax.axhline(-allowed, color="r", ls="--", lw=1)
            title = f"Wheel momentum, {label}"
        else:
            title = f"Wheel momentum, {label} (allowed +-{allowed:.3g} mN m s: off this scale)"
        ax.set_ylabel("wheel momentum [mN m s]")
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", ncols=6, fontsize="small")
    axes[-1].set_xlabel("time [orbits]")
    return {"orbit_torques": fig_t, "orbit_momentum": fig_h}


def detumble_study(config: SpacecraftConfig, duration_max_orbits: float | None = None) -> dict[str, Any] | None:
    """Detumbling from the tip-off rate with B-dot on the magnetometer (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (``[orbit]``, ``[detumble]``, ``[magnetorquers]``, ``[magnetometer]``).
    duration_max_orbits : float, optional
        Simulated span [orbits] instead of the file's ``duration_max_orbits``
        (the quick design shortens it).

    Returns
    -------
    dict or None
        JSON-ready results plus ``"_result"`` (the simulation, for the figure);
        None without a ``[detumble]`` table.
    """
    body = assembly.rigid_body(config)
    settings = assembly.detumble_settings(config, body)
    if settings is None:
        return None
    env = assembly.orbit_environment(config)
    duration = settings.duration_max
    if duration_max_orbits is not None:
        duration = float(duration_max_orbits) * float(env.orbit.period)
    rods = assembly.magnetorquers(config)
    law = assembly.bdot_controller(config)
    sensor = assembly.magnetometer(config, period=settings.period)
    result = simulate(
        body,
        np.array([1.0, 0.0, 0.0, 0.0]),
        settings.tip_off_rate,
        duration,
        sensors=[sensor],
        environment=env,
        magnetorquers=rods,
        dipole_controller=law,
        dt=settings.period,
        rng=0,
    )
    rate = np.linalg.norm(result.omega, axis=-1)
    above = np.nonzero(rate >= settings.rate_threshold)[0]
    detumbled = above.size == 0 or above[-1] < rate.size - 1
    time_s = float(result.t[0] if above.size == 0 else result.t[min(above[-1] + 1, rate.size - 1)])
    period = float(env.orbit.period)
    momentum = np.linalg.norm(result.momentum_N, axis=-1)
    return {
        "tip_off_rate_deg_per_s": _vec(np.degrees(settings.tip_off_rate)),
        "rate_threshold_deg_per_s": _f(math.degrees(settings.rate_threshold)),
        "gain_Nms": _f(settings.gain),
        "gain_is_auto": settings.gain_is_auto,
        "dipole_max_Am2": _vec(np.asarray(rods.dipole_max_Am2, dtype=float)),
        "duration_simulated_s": _f(float(result.t[-1])),
        "detumbled": bool(detumbled),
        "time_to_detumble_s": _f(time_s) if detumbled else None,
        "time_to_detumble_orbits": _f(time_s / period) if detumbled else None,
        "final_rate_deg_per_s": _f(math.degrees(float(rate[-1]))),
        "momentum_initial_mNms": _f(float(momentum[0]) * _UNITS_MILLI),
        "momentum_final_mNms": _f(float(momentum[-1]) * _UNITS_MILLI),
        "dipole_saturated_fraction": _f(
            float(np.mean(np.any(np.abs(result.dipole) >= 0.999 * np.asarray(rods.dipole_max_Am2), axis=-1)))
        ),
        "_result": result,
        "_period": period,
    }


def detumble_figures(study: dict[str, Any]) -> dict[str, Figure]:
    """The detumbling figure: body rates, their magnitude with the threshold, and the rods' dipole.

    Parameters
    ----------
    study : dict
        The result of :func:`detumble_study` (with ``"_result"``).
    """
    r = study["_result"]
    period = study["_period"]
    x = r.t / period
    fig = Figure(figsize=(9, 6.5), layout="constrained")
    ax_w, ax_m = fig.subplots(2, 1, sharex=True)
    for i, name in enumerate("xyz"):
        ax_w.plot(x, np.degrees(r.omega[:, i]), lw=0.8, label=f"omega_{name}")
    ax_w.plot(x, np.degrees(np.linalg.norm(r.omega, axis=-1)), "k", lw=1.4, label="|omega|")
    ax_w.axhline(study["rate_threshold_deg_per_s"], color="r", ls="--", lw=1, label="threshold")
    if study["time_to_detumble_orbits"] is not None:
        ax_w.axvline(study["time_to_detumble_orbits"], color="g", ls=":", lw=1.2, label="detumbled")
    ax_w.set_ylabel("body rate [deg/s]")
    ax_w.set_title("B-dot detumbling from the tip-off rate (magnetometer samples, IGRF, rods' limits)")
    ax_w.grid(True, alpha=0.3)
    ax_w.legend(loc="upper right", ncols=3, fontsize="small")
    for i, name in enumerate("xyz"):
        ax_m.plot(x, r.dipole[:, i], lw=0.6, label=f"m_{name}")
    limit = max(study["dipole_max_Am2"])
    ax_m.axhline(limit, color="r", ls="--", lw=1, label="rod limit")
    ax_m.axhline(-limit, color="r", ls="--", lw=1)
    ax_m.set_xlabel("time [orbits]")
    ax_m.set_ylabel("dipole [A m^2]")
    ax_m.grid(True, alpha=0.3)
    ax_m.legend(loc="upper right", ncols=4, fontsize="small")
    return {"detumble": fig}


def nadir_hold(config: SpacecraftConfig, orbits: float = 1.0) -> dict[str, Any] | None:
    """The nadir hold flown in closed loop in the environment (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file.
    orbits : float
        Span of the run [orbits].

    Returns
    -------
    dict or None
        JSON-ready results plus ``"_result"`` (the simulation); None without an ``[orbit]``.
    """
    env = assembly.orbit_environment(config)
    if env is None:
        return None
    orbit = env.orbit
    body = assembly.rigid_body(config)
    wheels = assembly.reaction_wheels(config)
    controller = assembly.nadir_pointing(config, orbit, body)
    period = config.control.period_s
    rods = assembly.magnetorquers(config)
    law = assembly.unloading_controller(config, use_truth_field=True, period=period) if rods is not None else None
    duration = round(orbits * float(orbit.period) / period) * period
    result = simulate(
        body,
        np.asarray(orbit.q_LN(0.0), dtype=float),
        np.asarray(orbit.omega_LN_L(0.0), dtype=float).reshape(3),
        duration,
        controller=controller,
        wheels=wheels,
        environment=env,
        magnetorquers=rods if law is not None else None,
        dipole_controller=law,
    )
    error_deg = np.degrees(result.error_angle)
    speed_rpm = np.abs(result.wheel_speed) * 30.0 / math.pi
    return {
        "duration_s": _f(duration),
        "orbits": _f(orbits),
        "engine": result.info.get("engine"),
        "unloading": law is not None,
        "pointing_error_max_deg": _f(float(error_deg.max())),
        "pointing_error_rms_deg": _f(float(np.sqrt(np.mean(error_deg**2)))),
        "wheel_speed_peak_rpm": _f(float(speed_rpm.max())),
        "motor_torque_peak_mNm": _f(1e3 * float(np.max(np.abs(result.motor_torque)))),
        "dipole_peak_Am2": _f(float(np.max(np.abs(result.dipole)))) if law is not None else None,
        "_result": result,
    }

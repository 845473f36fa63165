"""The vectorised closed loop: many spacecraft advance together as one batched numpy state.

:func:`simulate_batch` runs ``N`` closed loops (dispersed inertias, initial
attitudes, rates and wheel momenta; one controller law and one wheel set)
with every state component an array of shape ``(N,)``. It evaluates the
*same* backend-neutral definitions as the single-run engine
(:mod:`attitude.simulation`): :meth:`ReactionWheels.state_derivative_components`
(which calls :meth:`RigidBody.omega_dot_components` of a batched hub body),
:meth:`ReactionWheels.allocate_components`, the controller's
``torque_components`` and :func:`attitude.integrators.rk4_step`; a test proves
it agrees with :func:`attitude.simulation.simulate` run by run. Only the
order of evaluation differs (numpy per component instead of casadi per
run), so results agree to rounding.

Controllers are those of the engine's compiled path: ``period``,
``compiled_inputs(t) -> (m, len(t))`` and ``torque_components(q, omega,
h_body, inputs)``; the inputs (reference samples) are shared by all runs,
so a controller with per-run state latched by ``prepare`` is refused.

Metrics are reduced on the fly (no full histories unless asked):
``settling_time`` (first time after which the error angle stays at or below
``pointing_threshold``, as :meth:`SimulationResult.settling_time`), the
final pointing error, the peak body rate and the peak wheel speed,
exactly as :func:`closed_loop_metrics` computes them from a single run.

Speed: each RK4 stage is a few hundred numpy operations on arrays of ``N``
doubles, so the cost per spacecraft falls with ``N`` until the arrays leave
the cache; batches are split into chunks of :data:`BATCH_CHUNK`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude._validation import as_float_array, check_positive
from attitude.actuators import ReactionWheels
from attitude.integrators import normalize_quaternion_components, quaternion_multiply_components, rk4_step
from attitude.rigid_body import RigidBody

__all__ = ["BATCH_CHUNK", "BatchResult", "closed_loop_metrics", "simulate_batch"]

#: Most spacecraft advanced together; larger batches are split (cache-sized component arrays).
BATCH_CHUNK = 4096


@dataclass
class BatchResult:
    """Outcome of :func:`simulate_batch` (``N`` runs).

    Attributes
    ----------
    t : ndarray (n,)
        Tick times [s] (metrics use every tick).
    metrics : dict of ndarray (N,)
        ``settling_time`` [s], ``final_pointing_error`` [rad], ``peak_rate``
        [rad/s], ``peak_wheel_speed`` [rad/s] (with wheels).
    q, omega, h_wheels : ndarray (N, 4), (N, 3), (N, n_wheels)
        Final state.
    diverged_at : ndarray (N,)
        Time [s] at which a run's state became non-finite (NaN if it did not).
    history_t : ndarray (k,)
        Times of the recorded histories [s] (every ``history_stride`` ticks).
    histories : dict of ndarray
        ``error_angle`` (N, k) [rad], ``omega`` (N, k, 3) [rad/s],
        ``wheel_speed`` (N, k, n_wheels) [rad/s]; empty without a stride.
    info : dict
        Tick, substeps, chunk size, wall time [s].
    """

    t: NDArray[np.float64]
    metrics: dict[str, NDArray[np.float64]]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    h_wheels: NDArray[np.float64]
    diverged_at: NDArray[np.float64]
    history_t: NDArray[np.float64]
    histories: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)


def closed_loop_metrics(result: Any, pointing_threshold: float) -> dict[str, float]:
    """The batch metrics of one :class:`attitude.simulation.SimulationResult`.

    Parameters
    ----------
    result : SimulationResult
    pointing_threshold : float
        Error angle [rad] that defines settling.
    """
    metrics = {
        "settling_time": float(result.settling_time(pointing_threshold)),
        "final_pointing_error": float(result.error_angle[-1]),
        "peak_rate": float(np.max(np.linalg.norm(result.omega, axis=-1))),
    }
    if result.wheel_speed.shape[-1]:
        metrics["peak_wheel_speed"] = float(np.max(np.abs(result.wheel_speed)))
    return metrics


def _batch(value: ArrayLike, name: str, width: int, n: int) -> NDArray[np.float64]:
    """``value`` as an ``(n, width)`` array: one row per run, or one row shared by all."""
    arr = as_float_array(value, name)
    if arr.shape == (width,):
        arr = np.broadcast_to(arr, (n, width))
    if arr.shape != (n, width):
        raise ValueError(f"{name} must have shape ({n}, {width}) or ({width},), got {arr.shape}")
    return np.ascontiguousarray(arr)


def simulate_batch(
    body: RigidBody,
    q0: ArrayLike,
    omega0: ArrayLike,
    duration: float,
    *,
    controller: Any,
    wheels: ReactionWheels | None = None,
    h_wheels0: ArrayLike | None = None,
    dt: float | None = None,
    substeps: int = 1,
    disturbance: ArrayLike | None = None,
    pointing_threshold: float = 0.0,
    history_stride: int | None = None,
) -> BatchResult:
    """Simulate ``N`` closed loops at once (module docstring).

    Parameters
    ----------
    body : RigidBody
        The whole spacecraft, wheels included [kg m^2]: a batch of ``N``
        inertias (``body.batch_shape == (N,)``) or one shared by all runs.
    q0 : array_like (N, 4)
        Initial attitudes ``q_BN``.
    omega0 : array_like (N, 3) or (3,)
        Initial body rates [rad/s].
    duration : float
        Simulated time [s], a whole number of ticks.
    controller : object
        ``period`` [s], ``compiled_inputs(t)`` and ``torque_components`` (module docstring).
    wheels : ReactionWheels, optional
        Shared by all runs; None applies the commanded torque directly.
    h_wheels0 : array_like (N, n) or (n,), optional
        Initial wheel momenta [N m s] (default 0).
    dt : float, optional
        Tick [s] (default the controller period, which must be a whole multiple of it).
    substeps : int
        RK4 steps per tick.
    disturbance : array_like (3,) or (N, 3), optional
        Constant external torque [N m] in body axes.
    pointing_threshold : float
        Error angle [rad] for ``settling_time``.
    history_stride : int, optional
        Record histories every ``history_stride`` ticks (None: none).

    Returns
    -------
    BatchResult
        Runs whose state became non-finite carry their divergence time in
        ``diverged_at`` (and NaN metrics); the others are unaffected.
    """
    if not isinstance(body, RigidBody) or len(body.batch_shape) > 1:
        raise ValueError("body must be a RigidBody with one inertia or a batch of shape (N,)")
    q0 = quat.as_unit_quaternion(q0, "q0")
    if q0.ndim != 2:
        raise ValueError(f"q0 must have shape (N, 4), got {q0.shape}")
    n = q0.shape[0]
    if body.batch_shape not in ((), (n,)):
        raise ValueError(f"body batch {body.batch_shape} must be () or ({n},) to match q0")
    omega0 = _batch(omega0, "omega0", 3, n)
    for name in ("torque_components", "compiled_inputs", "period"):
        if not hasattr(controller, name):
            raise ValueError(f"controller must have {name!r} (the compiled-path protocol of attitude.simulation)")
    if hasattr(controller, "prepare"):
        raise ValueError(
            "controller has per-run state (a prepare hook); simulate_batch shares one input table across runs"
        )
    if wheels is not None and not isinstance(wheels, ReactionWheels):
        raise ValueError(f"wheels must be a ReactionWheels or None, got {type(wheels).__name__}")
    n_w = 0 if wheels is None else wheels.n_wheels
    h0 = np.zeros((n, n_w)) if h_wheels0 is None else _batch(h_wheels0, "h_wheels0", n_w, n)
    duration = float(check_positive(duration, "duration"))
    period = float(check_positive(controller.period, "controller.period"))
    dt = period if dt is None else float(check_positive(dt, "dt"))
    every = round(period / dt)
    if every < 1 or abs(period / dt - every) > 1e-9 * max(1.0, period / dt):
        raise ValueError(f"controller.period = {period!r} s must be a whole multiple of dt = {dt!r} s")
    n_ticks = round(duration / dt)
    if n_ticks < 1 or abs(n_ticks * dt - duration) > 1e-9 * duration:
        raise ValueError(f"duration = {duration!r} s must be a whole number (>= 1) of ticks dt = {dt!r} s")
    if not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"substeps must be a positive integer, got {substeps!r}")
    tau_ext = None if disturbance is None else _batch(disturbance, "disturbance", 3, n)
    stride = history_stride
    if stride is not None and (not isinstance(stride, int) or stride < 1):
        raise ValueError(f"history_stride must be a positive integer or None, got {stride!r}")

    t = np.arange(n_ticks + 1) * dt
    inputs = np.atleast_2d(as_float_array(controller.compiled_inputs(t), "controller.compiled_inputs(t)"))
    if inputs.shape[-1] != t.size:
        raise ValueError(f"controller.compiled_inputs(t) must return shape (m, {t.size}), got {inputs.shape}")
    q_ref = np.asarray(controller.reference_samples(t)[0], float) if hasattr(controller, "reference_samples") else None
    plant = body if wheels is None else wheels.hub_body(body)

    start = time.perf_counter()
    metrics = {k: np.empty(n) for k in ("settling_time", "final_pointing_error", "peak_rate")}
    if wheels is not None:
        metrics["peak_wheel_speed"] = np.empty(n)
    final = np.empty((n, 7 + n_w))
    diverged = np.full(n, np.nan)
    history_t = t[::stride] if stride else np.zeros(0)
    histories: dict[str, NDArray[np.float64]] = {}
    if stride:
        k_rec = history_t.size
        histories = {"error_angle": np.empty((n, k_rec)), "omega": np.empty((n, k_rec, 3))}
        if wheels is not None:
            histories["wheel_speed"] = np.empty((n, k_rec, n_w))
    chunks = -(-n // BATCH_CHUNK)
    size = -(-n // chunks)
    for lo in range(0, n, size):
        sl = slice(lo, min(lo + size, n))
        chunk_plant = plant if not plant.batch_shape else RigidBody(plant.inertia[sl])
        x0 = np.concatenate([q0[sl], omega0[sl], h0[sl]], axis=1)
        _run_chunk(
            chunk_plant,
            wheels,
            controller,
            x0,
            None if tau_ext is None else tau_ext[sl],
            t,
            inputs,
            q_ref,
            dt,
            substeps,
            every,
            pointing_threshold,
            stride,
            sl,
            metrics,
            final,
            diverged,
            histories,
        )
    info = {"dt": dt, "substeps": substeps, "chunk": size, "wall_time_s": time.perf_counter() - start}
    return BatchResult(t, metrics, final[:, :4], final[:, 4:7], final[:, 7:], diverged, history_t, histories, info=info)


def _run_chunk(
    plant, wheels, controller, x0, tau_ext, t, inputs, q_ref, dt, substeps, every, threshold, stride, sl, metrics,
    final, diverged, histories,
) -> None:  # fmt: skip
    n_ticks = t.size - 1
    n = x0.shape[0]
    x = [np.ascontiguousarray(x0[:, i]) for i in range(x0.shape[1])]
    ext = None if tau_ext is None else [np.ascontiguousarray(tau_ext[:, i]) for i in range(3)]
    h_step = dt / substeps
    last_above = np.full(n, -1, dtype=np.int64)
    peak_rate = np.zeros(n)
    peak_speed = np.zeros(n)
    alive = np.ones(n, dtype=bool)
    diverged_chunk = np.full(n, np.nan)
    u: list = []
    rec = 0
    with np.errstate(all="ignore"):  # a diverging run turns NaN; it is reported, the others go on
        for k in range(n_ticks + 1):
            q, w, h = x[:4], x[4:7], x[7:]
            if k % every == 0:
                column = [float(v) for v in inputs[:, k]]
                tau = controller.torque_components(q, w, _body_momentum(wheels, x), column)
                u = tau if wheels is None else wheels.allocate_components(tau, h, w)
            rate = np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
            np.fmax(peak_rate, rate, out=peak_rate)
            speeds = [] if wheels is None else wheels.wheel_speed_components(h, w)
            for s in speeds:
                np.fmax(peak_speed, np.abs(s), out=peak_speed)
            if q_ref is not None:
                r = q_ref[k]
                e = quaternion_multiply_components([r[0], -r[1], -r[2], -r[3]], q)
                err = 2.0 * np.arctan2(np.sqrt(e[1] * e[1] + e[2] * e[2] + e[3] * e[3]), np.abs(e[0]))
            else:
                err = np.zeros(n)
            last_above[err > threshold] = k
            if stride and k % stride == 0:
                histories["error_angle"][sl, rec] = err
                histories["omega"][sl, rec] = np.stack(w, axis=-1)
                if speeds:
                    histories["wheel_speed"][sl, rec] = np.stack(speeds, axis=-1)
                rec += 1
            finite = np.isfinite(w[0] + w[1] + w[2])
            newly = alive & ~finite
            if np.any(newly):
                diverged_chunk[newly] = t[k]
                alive &= finite
            if k == n_ticks:
                break
            x = _hold_step(plant, wheels, x, u, ext, h_step, substeps)
    settle = np.where(last_above < 0, t[0], t[np.minimum(last_above + 1, n_ticks)])
    settle = np.where(last_above == n_ticks, np.inf, settle)
    metrics["settling_time"][sl] = settle
    metrics["final_pointing_error"][sl] = err
    metrics["peak_rate"][sl] = peak_rate
    if wheels is not None:
        metrics["peak_wheel_speed"][sl] = peak_speed
    for name in metrics:
        metrics[name][sl] = np.where(alive, metrics[name][sl], np.nan)
    final[sl] = np.stack(np.broadcast_arrays(*x), axis=-1)
    diverged[sl] = diverged_chunk


def _body_momentum(wheels: ReactionWheels | None, x: list) -> list:
    """Wheel momentum relative to the body ``A (J Omega)`` on components (as the single-run engine)."""
    if wheels is None:
        return [0.0 * x[4]] * 3
    speeds = wheels.wheel_speed_components(x[7:], x[4:7])
    return wheels._body_components([wheels.spin_inertia[i] * s for i, s in enumerate(speeds)], scale=1.0)


def _hold_step(plant, wheels, x, u, ext, h, substeps) -> list:
    if wheels is None:
        tau = u if ext is None else [a + b for a, b in zip(u, ext)]

        def derivative(_t, xc):
            return plant.state_derivative_components(xc, tau)

    else:

        def derivative(_t, xc):
            return wheels.state_derivative_components(plant, xc, u, ext)

    for _ in range(substeps):
        x = normalize_quaternion_components(rk4_step(derivative, 0.0, x, h))
    return x

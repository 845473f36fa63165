"""The vectorised closed loop: many spacecraft advance together.

:func:`simulate_batch` runs ``N`` closed loops (dispersed inertias, initial
attitudes, rates and wheel momenta; one controller law and one wheel set).
Each tick evaluates the *same* backend-neutral definitions as the single-run
engine (:mod:`attitude.simulation.engine`), gathered in
:mod:`attitude.simulation.kernel`: :meth:`ReactionWheels.state_derivative_components`
(which calls Euler's equations of the hub body),
:meth:`ReactionWheels.allocate_components`, the controller's
``torque_components`` and :func:`attitude.integrators.rk4_step`. A test
proves it agrees with :func:`attitude.simulation.engine.simulate` run by run. Two
back ends evaluate them:

* ``"compiled"``: the tick of one run generated as C, compiled once per
  machine (:mod:`attitude.simulation.codegen`) and mapped over the runs; many ticks per
  call. Several times faster than numpy (``make bench``: about 450k
  spacecraft-simulated seconds per CPU second for PD + four wheels).
* ``"numpy"``: every component an array of shape ``(N,)``; each RK4 stage a
  few hundred numpy operations, so the cost per spacecraft falls with ``N``
  until the arrays leave the cache (batches split in chunks of
  :data:`BATCH_CHUNK`). No compiler needed.

Only the order of evaluation differs from the single-run engine (C or numpy
per component instead of casadi's virtual machine per run), so results agree
to rounding. Each run's arithmetic is independent of the others, so a run
gives bit-identical results whatever batch it is in (for one back end).

Controllers are those of the engine's compiled path: ``period``,
``compiled_inputs(t) -> (m, len(t))`` and ``torque_components(q, omega,
h_body, inputs)``; the inputs (reference samples) are shared by all runs,
so a controller with per-run state latched by ``prepare`` is refused.

With an orbit environment (``environment=``, an
:class:`attitude.environment.OrbitEnvironment`) every run flies it from the
orbit's epoch: the environment's track (attitude-independent, shared by the
runs) joins the shared tick columns, each run's surface parameters
(``surface_parameters=``, dispersed drag scale, residual dipole and
centre-of-pressure offset) join its tick state, and each tick adds the
per-source disturbance torques of the run's attitude at the tick, held over
it, to the external torque (:func:`attitude.simulation.kernel.disturbance_torques`),
exactly as the single-run engine with ``environment=`` and
``surface_parameters=``. Their histories are kept per source with the other
histories.

Metrics are reduced on the fly (no full histories unless asked):
``settling_time`` (first time after which the error angle stays at or below
``pointing_threshold``, as :meth:`SimulationResult.settling_time`), the
final pointing error, the peak body rate and the peak wheel speed,
exactly as :func:`closed_loop_metrics` computes them from a single run.
"""

from __future__ import annotations

import pickle
import threading
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.environment.orbit_environment import SURFACE_PARAMETERS, OrbitEnvironment
from attitude.integrators import (
    ATTITUDE_ERROR_BUDGET_RAD,
    MAX_RULE_SUBSTEPS,
    StepSizeWarning,
    attitude_error_text,
    check_error_budget,
)
from attitude.progress import Throttle
from attitude.rigid_body import RigidBody, symmetric_entries
from attitude.simulation.build_cache import BuildCache
from attitude.simulation.codegen import CompilationError
from attitude.simulation.engine import settling_time_after, ticks_per_period, whole_ticks
from attitude.simulation.kernel import METRICS, CompiledTicks, command, disturbance_torques, environment_key, observe
from attitude.simulation.plant import PlantModel
from attitude.simulation.protocols import CompiledController
from attitude.simulation.step_rule import batch_broken, batch_needed_substeps, batch_substeps
from attitude.validation import as_float_array, check_positive

__all__ = [
    "BATCH_CHUNK",
    "PROGRESS_SEGMENTS",
    "BatchResult",
    "closed_loop_metrics",
    "environment_inputs",
    "simulate_batch",
]

#: Most spacecraft advanced together; larger batches are split (cache-sized component arrays).
BATCH_CHUNK = 4096
#: Compiled calls a batch's ticks are split into when a progress callback is given (one call otherwise).
PROGRESS_SEGMENTS = 100


@dataclass
class BatchResult:
    """Outcome of :func:`simulate_batch` (``N`` runs).

    Attributes
    ----------
    t : ndarray (n,)
        Tick times [s] (metrics use every tick).
    metrics : dict of ndarray (N,)
        ``settling_time`` [s], ``final_pointing_error`` [rad], ``rate_peak``
        [rad/s], ``wheel_speed_peak`` [rad/s] (with wheels).
    q, omega, h_wheels : ndarray (N, 4), (N, 3), (N, n_wheels)
        Final state.
    diverged_at : ndarray (N,)
        Time [s] at which a run's state became non-finite (NaN if it did not).
    history_t : ndarray (k,)
        Times of the recorded histories [s] (every ``history_stride`` ticks).
    histories : dict of ndarray
        ``error_angle`` (N, k) [rad], ``omega`` (N, k, 3) [rad/s],
        ``wheel_speed`` (N, k, n_wheels) [rad/s] and, with an environment,
        ``disturbance.<source>`` (N, k, 3) [N m] (each source's torque in body
        axes, held from each sample's time); empty without a stride.
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
    """The batch metrics of one :class:`attitude.simulation.engine.SimulationResult`.

    Parameters
    ----------
    result : SimulationResult
    pointing_threshold : float
        Error angle [rad] that defines settling.
    """
    metrics = {
        "settling_time": float(result.settling_time(pointing_threshold)),
        "final_pointing_error": float(result.error_angle[-1]),
        "rate_peak": float(np.max(np.linalg.norm(result.omega, axis=-1))),
    }
    if result.wheel_speed.shape[-1]:
        metrics["wheel_speed_peak"] = float(np.max(np.abs(result.wheel_speed)))
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
    controller: CompiledController,
    wheels: ReactionWheels | None = None,
    h_wheels0: ArrayLike | None = None,
    dt: float | None = None,
    substeps: int = 1,
    disturbance: ArrayLike | None = None,
    pointing_threshold: float = 0.0,
    history_stride: int | None = None,
    backend: str = "auto",
    environment: OrbitEnvironment | None = None,
    surface_parameters: ArrayLike | None = None,
    attitude_error_budget_rad: float = ATTITUDE_ERROR_BUDGET_RAD,
    progress: Callable[[float], None] | None = None,
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
    backend : {"auto", "compiled", "numpy"}
        "compiled": the tick compiled to C (:mod:`attitude.simulation.kernel`;
        raises :class:`attitude.simulation.codegen.CompilationError` without a C
        compiler); "numpy": numpy operations on arrays of runs; "auto"
        (default): compiled when a compiler works, else numpy
        (``info["backend"]`` and ``info["backend_note"]`` say which and why).
    environment : OrbitEnvironment, optional
        The orbit every run flies from its epoch (module docstring); None: empty space.
    surface_parameters : array_like (N, 7) or (7,), optional
        Per-run surface parameters (:meth:`OrbitEnvironment.surface_parameters`:
        drag scale, residual dipole [A m^2], centre-of-pressure offset [m]);
        default the environment's nominal ones. Only with ``environment``.
    attitude_error_budget_rad : float
        Accumulated attitude error [rad] the plant's RK4 may make in a run
        (docs/rk4_step_rule.md; ``inf`` turns the rule off). Checked before
        the run on every run's initial state (``substeps`` raised for the
        batch with a :class:`attitude.integrators.StepSizeWarning` where it is
        broken) and after it on every run's peak rate: the runs that may have
        broken it mid-run fly again, at the step count the largest of their
        peak rates needs (``info["step_rule_rerun_substeps"]``, with a
        warning), as the single-run compiled path does. A run still over the
        budget then (or needing more than
        :data:`attitude.integrators.MAX_RULE_SUBSTEPS` times ``substeps``) is
        reported as failed (NaN metrics, ``info["step_rule_broken"]``) with a
        warning; its final state is returned as run and is not within the
        budget: do not use it.
    progress : callable, optional
        ``progress(fraction)``: called with the fraction of the runs' ticks
        simulated (over all chunks), at most every
        :data:`attitude.progress.REFRESH_PERIOD_S` of wall time
        (:class:`attitude.progress.Throttle`), for a progress bar. The
        compiled back end then advances the ticks in
        :data:`PROGRESS_SEGMENTS` calls instead of one (same numbers).

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
    every = ticks_per_period(period, dt, "controller")
    n_ticks = whole_ticks(duration, dt)
    if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"substeps must be a positive integer, got {substeps!r}")
    tau_ext = None if disturbance is None else _batch(disturbance, "disturbance", 3, n)
    stride = history_stride
    if stride is not None and (isinstance(stride, bool) or not isinstance(stride, int) or stride < 1):
        raise ValueError(f"history_stride must be a positive integer or None, got {stride!r}")
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be callable as progress(fraction) or None, got {progress!r}")

    if backend not in ("auto", "compiled", "numpy"):
        raise ValueError(f"backend must be 'auto', 'compiled' or 'numpy', got {backend!r}")
    surface = environment_inputs(environment, surface_parameters, n)

    t = np.arange(n_ticks + 1) * dt
    inputs = np.atleast_2d(as_float_array(controller.compiled_inputs(t), "controller.compiled_inputs(t)"))
    if inputs.shape[-1] != t.size:
        raise ValueError(f"controller.compiled_inputs(t) must return shape (m, {t.size}), got {inputs.shape}")
    q_ref = np.asarray(controller.reference_samples(t)[0], float) if hasattr(controller, "reference_samples") else None
    plant = body if wheels is None else wheels.hub_body(body)
    budget = check_error_budget(attitude_error_budget_rad)
    substeps_asked = substeps
    substeps, refused = batch_substeps(PlantModel(plant, wheels), omega0, dt, n_ticks, substeps, budget)
    if n >= PILOT_MIN_RUNS and getattr(_RERUNS, "depth", 0) < RULE_RERUNS and not refused[0]:
        # A pilot: run 0 flown alone first (1/n of the work). The check above sees only the initial rates; a
        # slew from rest reaches its peak rate mid-run, and the batch would be flown twice (see the rerun).
        _RERUNS.depth = getattr(_RERUNS, "depth", 0) + 1
        _RERUNS.pilot = True  # its own verdict is not said: the batch flies run 0 again
        try:
            pilot = simulate_batch(
                body if not body.batch_shape else RigidBody(body.inertia[:1]),
                q0[:1],
                omega0[:1],
                duration,
                controller=controller,
                wheels=wheels,
                h_wheels0=h0[:1],
                dt=dt,
                substeps=substeps,
                disturbance=None if tau_ext is None else tau_ext[:1],
                pointing_threshold=pointing_threshold,
                backend=backend,
                environment=environment,
                surface_parameters=None if surface is None else surface[:1],
                attitude_error_budget_rad=budget,
            )
        finally:
            _RERUNS.depth -= 1
            _RERUNS.pilot = False
        peak = pilot.info["rate_peak_flown"]
        if np.all(np.isfinite(peak)):
            pilot_plant = plant if not plant.batch_shape else RigidBody(plant.inertia[:1])
            needed = batch_needed_substeps(PlantModel(pilot_plant, wheels), peak, dt, n_ticks, substeps, budget)
            if needed[0] <= MAX_RULE_SUBSTEPS * substeps_asked:
                substeps = max(substeps, int(needed[0]))
    rows = None if environment is None else environment.track(t).columns()
    loop = _Loop(PlantModel(plant, wheels), controller, t, inputs, q_ref, every, substeps, pointing_threshold, stride)
    loop.environment, loop.rows = environment, rows

    start = time.perf_counter()
    ticks, note = None, None
    if backend != "numpy":
        try:
            ticks = _compiled_ticks(wheels, controller, inputs.shape[0], q_ref is not None, substeps, environment)
        except CompilationError as exc:
            if backend == "compiled":
                raise
            note = f"numpy fallback: {exc}"
            warnings.warn(f"simulating the batch without a compiled kernel ({note})", RuntimeWarning, stacklevel=2)
    compile_s = time.perf_counter() - start
    metrics = {k: np.empty(n) for k in ("settling_time", "final_pointing_error", "rate_peak")}
    if wheels is not None:
        metrics["wheel_speed_peak"] = np.empty(n)
    final = np.empty((n, 7 + n_w))
    diverged = np.full(n, np.nan)
    history_t = t[::stride] if stride else np.zeros(0)
    histories: dict[str, NDArray[np.float64]] = {}
    if stride:
        k_rec = history_t.size
        histories = {"error_angle": np.empty((n, k_rec)), "omega": np.empty((n, k_rec, 3))}
        if wheels is not None:
            histories["wheel_speed"] = np.empty((n, k_rec, n_w))
        for source in () if environment is None else environment.sources:
            histories[f"disturbance.{source}"] = np.empty((n, k_rec, 3))
    x0 = np.concatenate([q0, omega0, h0], axis=1)
    ext = np.zeros((n, 3)) if tau_ext is None else tau_ext
    chunk = n if ticks is not None else BATCH_CHUNK
    chunks = -(-n // chunk)
    size = -(-n // chunks)
    # Ticks over every chunk: chunk c's tick k is step c * n_ticks + k of the whole batch.
    loop.report = None if progress is None else Throttle(progress, chunks * n_ticks)
    for c, lo in enumerate(range(0, n, size)):
        loop.first_step = c * n_ticks
        sl = slice(lo, min(lo + size, n))
        chunk_plant = plant if not plant.batch_shape else RigidBody(plant.inertia[sl])
        with np.errstate(all="ignore"):  # a diverging run turns NaN; it is reported, the others go on
            chunk_surface = None if surface is None else surface[sl]
            if ticks is None:
                ext_chunk = None if tau_ext is None else ext[sl]
                x, acc, err, recorded = loop.run_numpy(chunk_plant, x0[sl], ext_chunk, chunk_surface)
            else:
                x, acc, err, recorded = loop.run_compiled(ticks, chunk_plant, x0[sl], ext[sl], chunk_surface)
        _store(t, acc, err, sl, metrics, diverged)
        final[sl] = np.stack(np.broadcast_arrays(*x), axis=-1)
        for name, rows in recorded.items():
            histories[name][sl] = np.stack(rows, axis=1)
    rate_peak_flown = metrics["rate_peak"].copy()
    broken, bound = batch_broken(loop.model, metrics["rate_peak"], dt, n_ticks, substeps, budget)
    rerun_steps = None
    if np.any(broken) and getattr(_RERUNS, "depth", 0) < RULE_RERUNS:
        # As the single-run compiled path: runs whose peak rate broke the rule fly again, all of them at the
        # step count the largest of their peak rates needs (each run is a pure function of its inputs).
        needed = batch_needed_substeps(loop.model, metrics["rate_peak"], dt, n_ticks, substeps, budget)
        again = broken & (needed <= MAX_RULE_SUBSTEPS * substeps_asked)
        if np.any(again):
            rerun_steps = int(np.max(needed[again]))
            idx = np.flatnonzero(again)
            _RERUNS.depth = getattr(_RERUNS, "depth", 0) + 1
            try:
                sub = simulate_batch(
                    body if not body.batch_shape else RigidBody(body.inertia[idx]),
                    q0[idx],
                    omega0[idx],
                    duration,
                    controller=controller,
                    wheels=wheels,
                    h_wheels0=h0[idx],
                    dt=dt,
                    substeps=rerun_steps,
                    disturbance=None if tau_ext is None else tau_ext[idx],
                    pointing_threshold=pointing_threshold,
                    history_stride=history_stride,
                    backend=backend,
                    environment=environment,
                    surface_parameters=None if surface is None else surface[idx],
                    attitude_error_budget_rad=budget,
                )
            finally:
                _RERUNS.depth -= 1
            flown_peak = metrics["rate_peak"].copy()
            for name in metrics:
                metrics[name][idx] = sub.metrics[name]
            final[idx] = np.concatenate([sub.q, sub.omega, sub.h_wheels], axis=1)
            diverged[idx] = sub.diverged_at
            for name in histories:
                histories[name][idx] = sub.histories[name]
            broken[idx] = sub.info["step_rule_broken"]
            bound[idx] = sub.info["step_rule_error_bound_rad"]
            warnings.warn(
                f"{idx.size} run(s) of the batch broke the step-size rule mid-run (docs/rk4_step_rule.md; "
                f"peak body rate up to {float(np.max(flown_peak[idx])):.3g} rad/s at {substeps} RK4 "
                f"step(s) per tick of {dt:.3g} s): flown again at {rerun_steps} steps per tick",
                StepSizeWarning,
                stacklevel=2,
            )
    broken |= refused & np.isnan(diverged)
    if np.any(broken) and not getattr(_RERUNS, "pilot", False):
        peak = metrics["rate_peak"].copy()
        if rerun_steps is not None:  # a run still broken after its rerun: its peak as first flown
            peak = np.where(np.isnan(peak), flown_peak, peak)
        for name in metrics:
            metrics[name][broken] = np.nan
        first = int(np.argmax(broken))
        warnings.warn(
            f"{int(np.sum(broken))} run(s) of the batch may have broken the step-size rule mid-run "
            f"(docs/rk4_step_rule.md; run {first}: peak body rate {float(peak[first]):.3g} rad/s, "
            f"error bound {attitude_error_text(float(bound[first]))}, over the budget of {budget:.3g} rad): "
            "reported as failed "
            "(NaN metrics, info['step_rule_broken']); shorten dt or raise substeps",
            StepSizeWarning,
            stacklevel=2,
        )
    info = {
        "dt": dt,
        "substeps": substeps,
        "step_rule_broken": broken,
        "step_rule_rerun_substeps": rerun_steps,
        "rate_peak_flown": rate_peak_flown,
        "step_rule_error_bound_rad": bound,
        "chunk": size,
        "backend": "numpy" if ticks is None else "compiled",
        "backend_note": note,
        "compile_s": compile_s,
        "wall_time_s": time.perf_counter() - start,
    }
    if environment is not None:
        info["environment"] = environment.describe()
    return BatchResult(t, metrics, final[:, :4], final[:, 4:7], final[:, 7:], diverged, history_t, histories, info=info)


def environment_inputs(
    environment: OrbitEnvironment | None, surface_parameters: ArrayLike | None, n: int
) -> NDArray[np.float64] | None:
    """The per-run surface parameters ``(n, 7)`` of a batch in orbit, checked; None without an environment.

    Parameters
    ----------
    environment : OrbitEnvironment or None
        The environment flown.
    surface_parameters : array_like (n, 7) or (7,), optional
        Per-run surface parameters (:data:`attitude.environment.SURFACE_PARAMETERS`);
        default the environment's nominal ones.
    n : int
        Number of runs.

    Returns
    -------
    ndarray (n, 7) or None

    Raises
    ------
    ValueError
        For an environment that is not an OrbitEnvironment, surface
        parameters without an environment, of the wrong shape, or with a
        negative drag scale.
    """
    if environment is None:
        if surface_parameters is not None:
            raise ValueError(
                "surface_parameters need an environment: give environment=OrbitEnvironment(...) or leave "
                "surface_parameters out"
            )
        return None
    if not isinstance(environment, OrbitEnvironment):
        raise ValueError(f"environment must be an OrbitEnvironment or None, got {type(environment).__name__}")
    width = len(SURFACE_PARAMETERS)
    if surface_parameters is None:
        surface_parameters = environment.surface_parameters()
    surface = _batch(surface_parameters, f"surface_parameters {SURFACE_PARAMETERS}", width, n)
    negative = surface[:, 0] < 0.0
    if np.any(negative):
        raise ValueError(
            f"surface_parameters drag_scale (column 0) must be >= 0, got {float(surface[negative, 0][0])!r} "
            f"(run {int(np.argmax(negative))})"
        )
    return surface


#: Times a batch flies again the runs that broke the step-size rule (at the count their peak rates need).
RULE_RERUNS = 1
#: Runs from which a batch first flies run 0 alone, to set its step count from that run's peak rate.
PILOT_MIN_RUNS = 20
_RERUNS = threading.local()  # depth of the rerun in this thread

#: One CompiledTicks per loop structure, a few at a time (keep memory flat).
_TICKS_CACHE: BuildCache[CompiledTicks] = BuildCache(4)


def _compiled_ticks(
    wheels: Any, controller: Any, n_inputs: int, has_reference: bool, substeps: int, environment: Any = None
) -> CompiledTicks:
    """One :class:`CompiledTicks` per loop structure in a process (the library itself is cached on disk).

    The environment enters the key by what the kernel builds in
    (:func:`attitude.simulation.kernel.environment_key`: sources, plates,
    ``mu``), never by its track, which is an input. Thread-safe: a Dask
    worker may run several batches in threads at once.
    """
    key = pickle.dumps((wheels, controller, n_inputs, has_reference, substeps, environment_key(environment)))
    return _TICKS_CACHE.get(
        key, lambda: CompiledTicks(wheels, controller, n_inputs, has_reference, substeps, environment)
    )


def _store(t, acc, err, sl, metrics, diverged) -> None:
    """Final metrics of a chunk from its running metrics (as :meth:`SimulationResult.settling_time`)."""
    rate_peak, speed_peak, last_above, diverged_at = (np.broadcast_to(a, np.shape(err)) for a in acc)
    settle = settling_time_after(t, np.where(np.isfinite(last_above), last_above, -1))
    alive = ~np.isfinite(diverged_at)
    values = {"settling_time": settle, "final_pointing_error": err, "rate_peak": rate_peak}
    if "wheel_speed_peak" in metrics:
        values["wheel_speed_peak"] = speed_peak
    for name, value in values.items():
        metrics[name][sl] = np.where(alive, value, np.nan)
    diverged[sl] = np.where(alive, np.nan, diverged_at)


class _Loop:
    """The tick sequence of one :func:`simulate_batch` call, run by numpy or by the compiled kernel."""

    def __init__(self, model, controller, t, inputs, q_ref, every, substeps, threshold, stride) -> None:
        self.model, self.controller, self.t, self.inputs, self.q_ref = model, controller, t, inputs, q_ref
        self.every, self.substeps, self.threshold, self.stride = every, substeps, threshold, stride
        self.environment: OrbitEnvironment | None = None
        self.rows: NDArray[np.float64] | None = None  # (15, n_ticks + 1) track columns with an environment
        self.report: Throttle | None = None  # progress of the whole batch, in ticks over every chunk
        self.first_step = 0  # the batch's step count at this chunk's first tick

    def _disturbance(self, model, x, k, surface) -> tuple:
        """Per-source torques and their sum at tick ``k`` (numpy on arrays of runs)."""
        row = [float(v) for v in self.rows[:, k]]
        whole = model.body
        if model.wheels is not None:  # gravity gradient on the whole spacecraft, wheels included
            whole = RigidBody(model.body.inertia + model.wheels.spin_inertia_tensor())
        return disturbance_torques(self.environment, whole, x[:4], row, surface)

    def _start(self, n: int) -> list:
        return [np.zeros(n), np.zeros(n), np.full(n, -np.inf), np.full(n, np.inf)]

    def _observe(self, model, x, k, acc, recorded, surface=None, torques=None) -> tuple[list, Any]:
        q_ref = None if self.q_ref is None else [float(v) for v in self.q_ref[k]]
        acc, err, speeds = observe(model, x, q_ref, self.threshold, float(k), float(self.t[k]), acc)
        if self.stride and k % self.stride == 0:
            shape = np.shape(acc[0])
            recorded.setdefault("error_angle", []).append(np.broadcast_to(err, shape))
            recorded.setdefault("omega", []).append(np.stack(np.broadcast_arrays(*x[4:7]), axis=-1))
            if speeds:
                recorded.setdefault("wheel_speed", []).append(np.stack(np.broadcast_arrays(*speeds), axis=-1))
            if self.environment is not None:
                if torques is None:
                    torques, _ = self._disturbance(model, x, k, surface)
                for source, tau in torques.items():
                    rows = np.stack([np.broadcast_to(c, shape) for c in tau], axis=-1)
                    recorded.setdefault(f"disturbance.{source}", []).append(rows)
        return acc, err

    def run_numpy(self, plant: RigidBody, x0: NDArray, ext: NDArray | None, surface: NDArray | None = None) -> tuple:
        """Every tick as numpy operations on arrays of runs."""
        model = PlantModel(plant, self.model.wheels)
        n_ticks = self.t.size - 1
        dt = self.t[1] - self.t[0]
        x = [np.ascontiguousarray(x0[:, i]) for i in range(x0.shape[1])]
        ext_c = None if ext is None else [np.ascontiguousarray(ext[:, i]) for i in range(3)]
        surface_c = None if surface is None else [np.ascontiguousarray(surface[:, i]) for i in range(surface.shape[1])]
        acc, recorded, u = self._start(x0.shape[0]), {}, []
        for k in range(n_ticks + 1):
            if self.report is not None:
                self.report(self.first_step + k)
            if k % self.every == 0:
                u = command(model, self.controller, x, [float(v) for v in self.inputs[:, k]])
            tau_ext, torques = ext_c, None
            if self.environment is not None:
                torques, total = self._disturbance(model, x, k, surface_c)
                tau_ext = total if ext_c is None else [a + b for a, b in zip(ext_c, total)]
            acc, err = self._observe(model, x, k, acc, recorded, surface_c, torques)
            if k == n_ticks:
                break
            x = model.hold_step(x, u, tau_ext, dt, self.substeps)
        return x, acc, err, recorded

    def run_compiled(
        self, ticks: CompiledTicks, plant: RigidBody, x0: NDArray, ext: NDArray, surface: NDArray | None = None
    ) -> tuple:
        """Ticks in compiled calls; the last tick's metrics and the history samples by numpy."""
        n, n_ticks = x0.shape[0], self.t.size - 1
        inertia = np.broadcast_to(plant.inertia, (n, 3, 3))
        inverse = np.broadcast_to(plant.inertia_inv, (n, 3, 3))
        z = np.concatenate(
            [x0, np.zeros((n, ticks.n_u)), np.stack(self._start(n), axis=1), symmetric_entries(inertia),
             symmetric_entries(inverse), ext, *([] if surface is None else [surface])], axis=1,
        )  # fmt: skip
        surface_c = None if surface is None else [np.ascontiguousarray(surface[:, i]) for i in range(surface.shape[1])]
        k = np.arange(n_ticks)
        columns = [self.inputs[:, :-1]]
        if self.q_ref is not None:
            columns.append(self.q_ref[:-1].T)
        if self.rows is not None:
            columns.append(self.rows[:, :-1])
        columns.append(np.stack([k, self.t[:-1], (k % self.every == 0), np.diff(self.t), np.full(n_ticks, 0.0)]))
        columns = np.concatenate(columns, axis=0)
        columns[-1] = self.threshold
        stops = set(range(0, n_ticks, self.stride)) if self.stride else {0}
        if self.report is not None:  # calls short enough for the bar to move (the state carries over exactly)
            stops |= set(range(0, n_ticks, -(-n_ticks // PROGRESS_SEGMENTS)))
        bounds = sorted(stops)
        recorded: dict[str, list] = {}
        model = PlantModel(plant, self.model.wheels)
        for a, b in zip(bounds, [*bounds[1:], n_ticks]):
            if self.stride and a % self.stride == 0:
                self._observe(model, [z[:, i] for i in range(ticks.n_x)], a, self._start(n), recorded, surface_c)
            z = ticks.advance(z, columns[:, a:b])
            if self.report is not None:
                self.report(self.first_step + b)
        x = [np.ascontiguousarray(z[:, i]) for i in range(ticks.n_x)]
        off = ticks.n_x + ticks.n_u
        acc = [np.ascontiguousarray(z[:, off + i]) for i in range(len(METRICS))]
        acc, err = self._observe(model, x, n_ticks, acc, recorded, surface_c)
        return x, acc, err, recorded

"""The vectorised closed loop with sensors and an estimator in the loop.

:func:`simulate_batch_estimated` advances ``N`` runs together, one tick at a
time, in the order of the single-run engine's Python path
(:func:`attitude.simulation.engine.simulate` with sensors and an estimator):

1. the sensors sample the truth at their periods, the gyro first and then the
   star tracker, each run drawing from its own random stream
   (:class:`attitude.rng.NormalStreams`) exactly the numbers it would draw
   alone (:class:`attitude.sensors.GyroBatch`,
   :meth:`attitude.sensors.StarTracker.measure_batch`);
2. the estimator steps with the samples (``estimator.step(t, gyro, tracker,
   mask) -> (q_hat, omega_hat)``, e.g. :class:`estimation.mekf.MEKFBatch`);
3. ``observer(k, t, x, q_hat, omega_hat, updated)`` sees the tick (metrics
   are the caller's: this module does not know what a requirement is);
4. at controller samples, the control law's ``torque_components`` on the
   *estimate* (and the wheel momentum of the truth, as the engine), allocated
   to the wheels on the true wheel speeds, then held;
5. the plant's hold step: compiled to C (:class:`CompiledHold`) or numpy,
   with, in orbit (``environment=``), the disturbance torques of the true
   attitude at the tick held over it
   (:func:`attitude.simulation.kernel.disturbance_torques`, numpy on the
   arrays of runs) as the external torque, as the single-run engine.

So run ``r`` of a batch is the single-run engine's run with the same
generator, to rounding (the truth step is evaluated by C or numpy instead of
casadi's virtual machine; the filter by numpy instead of filterpy). A run
whose state turns non-finite is frozen at its last finite state, reported in
``diverged_at`` and should be discarded by the caller; the others go on.

The controller follows the engine's compiled-path protocol (``period``,
``compiled_inputs(t)``, ``torque_components``), with the reference samples
shared by all runs.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.environment.orbit_environment import OrbitEnvironment
from attitude.integrators import ATTITUDE_ERROR_BUDGET_RAD, StepSizeWarning, attitude_error_text, check_error_budget
from attitude.progress import Throttle
from attitude.rigid_body import RigidBody, symmetric_entries
from attitude.rng import NormalStreams
from attitude.sensors import GyroBatch, StarTracker
from attitude.simulation.batch import environment_inputs
from attitude.simulation.codegen import CompilationError
from attitude.simulation.engine import ticks_per_period, whole_ticks
from attitude.simulation.kernel import CompiledHold, command, disturbance_torques
from attitude.simulation.plant import PlantModel
from attitude.simulation.protocols import BatchEstimator, CompiledController
from attitude.simulation.step_rule import batch_broken, batch_substeps
from attitude.validation import as_float_array, check_positive

__all__ = ["simulate_batch_estimated"]

Observer = Callable[[int, float, NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], bool], None]


def simulate_batch_estimated(
    body: RigidBody,
    q0: ArrayLike,
    omega0: ArrayLike,
    duration: float,
    *,
    controller: CompiledController,
    wheels: Any,
    gyro: GyroBatch,
    tracker: StarTracker,
    estimator: BatchEstimator,
    streams: NormalStreams,
    tracker_mounting: ArrayLike | None = None,
    dt: float | None = None,
    substeps: int = 1,
    observer: Observer | None = None,
    backend: str = "auto",
    environment: OrbitEnvironment | None = None,
    surface_parameters: ArrayLike | None = None,
    attitude_error_budget_rad: float = ATTITUDE_ERROR_BUDGET_RAD,
    progress: Callable[[float], None] | None = None,
) -> dict[str, Any]:
    """Simulate ``N`` closed loops with a gyro, a star tracker and an estimator (module docstring).

    Parameters
    ----------
    body : RigidBody
        Whole-spacecraft inertias, a batch of shape ``(N,)`` [kg m^2].
    q0 : array_like (N, 4)
        True initial attitudes ``q_BN``.
    omega0 : array_like (N, 3)
        True initial body rates [rad/s].
    duration : float
        Simulated time [s], a whole number of ticks.
    controller : object
        Compiled-path control law acting on the estimate.
    wheels : ReactionWheels
        Shared by all runs.
    gyro : GyroBatch
        The runs' gyros (fresh: they start with a first sample).
    tracker : StarTracker
        The star tracker (shared model).
    estimator : object
        ``step(t, gyro (N, 3) or None, tracker (N, 4) or None, mask (N,) or None) -> (q (N, 4), omega (N, 3))``
        and ``period`` [s].
    streams : NormalStreams
        The runs' random streams.
    tracker_mounting : array_like (N, 4), optional
        Per-run tracker misalignment ``dq``: the tracker sees ``q_BN ⊗ dq``.
    dt : float, optional
        Tick [s] (default the gyro period).
    substeps : int
        RK4 steps per tick.
    observer : callable, optional
        ``observer(k, t_k, x (N, 7 + n_w), q_hat, omega_hat, updated)`` at every tick.
    backend : {"auto", "compiled", "numpy"}
        The truth step's evaluation (as :func:`attitude.simulation.batch.simulate_batch`).
    environment : OrbitEnvironment, optional
        The orbit every run flies from its epoch (module docstring); None: empty space.
    surface_parameters : array_like (N, 7) or (7,), optional
        Per-run surface parameters (:meth:`OrbitEnvironment.surface_parameters`);
        default the environment's nominal ones. Only with ``environment``.
    attitude_error_budget_rad : float
        Accumulated attitude error [rad] the plant's RK4 may make in a run,
        checked on every run's initial state before the run (``substeps``
        raised with a :class:`attitude.integrators.StepSizeWarning`;
        docs/rk4_step_rule.md) and after it on every run's peak body rate
        (a run that outgrew the rule mid-run is flagged in
        ``step_rule_broken``, with a warning); ``inf`` turns the rule off.
    progress : callable, optional
        ``progress(fraction)``: called with the fraction of the ticks
        simulated, at most every :data:`attitude.progress.REFRESH_PERIOD_S`
        of wall time (:class:`attitude.progress.Throttle`), for a progress bar.

    Returns
    -------
    dict
        ``x`` (N, 7 + n_w) final true states, ``diverged_at`` (N,) [s] (NaN
        for runs that stayed finite), ``step_rule_refused`` (N,) (runs too fast
        for the tick under the step-size rule: failed, to be discarded with the
        diverged ones), ``step_rule_broken`` (N,) and ``step_rule_error_bound_rad``
        (N,) [rad] (runs whose peak rate may have broken the rule mid-run: their
        attitude may be off by more than the budget; failed likewise),
        ``backend``, ``backend_note`` and
        ``wall_time_s``; with an environment, ``disturbance_torques``: the
        last tick's torque per source (N, 3) [N m], and
        ``disturbance_torque_peak``: each source's largest torque magnitude
        over the run (N,) [N m].
    """
    if not isinstance(body, RigidBody) or len(body.batch_shape) != 1:
        raise ValueError("body must be a RigidBody holding a batch of inertias of shape (N,)")
    n = body.batch_shape[0]
    q0 = quat.as_unit_quaternion(q0, "q0")
    omega0 = as_float_array(omega0, "omega0")
    if q0.shape != (n, 4) or omega0.shape != (n, 3):
        raise ValueError(f"q0 and omega0 must have shapes ({n}, 4) and ({n}, 3), got {q0.shape} and {omega0.shape}")
    if not isinstance(gyro, GyroBatch) or gyro.n_runs != n:
        raise ValueError(f"gyro must be a GyroBatch of {n} runs")
    if not isinstance(streams, NormalStreams) or streams.n_runs != n:
        raise ValueError(f"streams must be NormalStreams of {n} runs")
    if hasattr(controller, "prepare"):
        raise ValueError("controller has per-run state (a prepare hook); the batch shares one input table")
    if backend not in ("auto", "compiled", "numpy"):
        raise ValueError(f"backend must be 'auto', 'compiled' or 'numpy', got {backend!r}")
    if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"substeps must be a positive integer, got {substeps!r}")
    if progress is not None and not callable(progress):
        raise ValueError(f"progress must be callable as progress(fraction) or None, got {progress!r}")
    dt = gyro.period if dt is None else float(check_positive(dt, "dt"))
    every = {
        name: ticks_per_period(float(check_positive(part.period, f"{name}.period")), dt, name)
        for name, part in (("gyro", gyro), ("tracker", tracker), ("estimator", estimator), ("controller", controller))
    }
    n_ticks = whole_ticks(float(check_positive(duration, "duration")), dt)
    mounting = None if tracker_mounting is None else quat.as_unit_quaternion(tracker_mounting, "tracker_mounting")
    if mounting is not None and mounting.shape != (n, 4):
        raise ValueError(f"tracker_mounting must have shape ({n}, 4), got {mounting.shape}")

    surface = environment_inputs(environment, surface_parameters, n)

    t = np.arange(n_ticks + 1) * dt
    inputs = np.atleast_2d(as_float_array(controller.compiled_inputs(t), "controller.compiled_inputs(t)"))
    plant = wheels.hub_body(body)
    rows = None if environment is None else environment.track(t).columns()
    surface_c = None if surface is None else [np.ascontiguousarray(surface[:, i]) for i in range(surface.shape[1])]
    torques: dict[str, NDArray[np.float64]] = {}
    peaks = {} if environment is None else {s: np.zeros(n) for s in environment.sources}
    model = PlantModel(plant, wheels)
    budget = check_error_budget(attitude_error_budget_rad)
    substeps, refused = batch_substeps(model, omega0, dt, n_ticks, substeps, budget)
    hold, note = None, None
    if backend != "numpy":
        try:
            hold = CompiledHold(wheels, substeps)
        except CompilationError as exc:
            if backend == "compiled":
                raise
            note = f"numpy fallback: {exc}"
            warnings.warn(f"simulating the batch without a compiled kernel ({note})", RuntimeWarning, stacklevel=2)
    parameters = np.concatenate(
        [symmetric_entries(plant.inertia), symmetric_entries(plant.inertia_inv), np.zeros((n, 3))], axis=1
    )
    start = time.perf_counter()
    x = np.concatenate([q0, omega0, np.zeros((n, wheels.n_wheels))], axis=1)
    q_hat, w_hat = q0.copy(), omega0.copy()
    u = np.zeros((n, wheels.n_wheels))
    diverged_at = np.full(n, np.nan)
    rate_peak = np.linalg.norm(omega0, axis=1)  # each run's largest body rate [rad/s], for the rule after the run
    report = None if progress is None else Throttle(progress, n_ticks)
    for k in range(n_ticks + 1):
        if report is not None:
            report(k)
        tk = float(t[k])
        q_true = x[:, :4] / np.linalg.norm(x[:, :4], axis=1, keepdims=True)
        g = y = mask = None
        if k % every["gyro"] == 0:
            g = gyro.measure(tk, q_true, x[:, 4:7], streams)
        if k % every["tracker"] == 0:
            seen = q_true if mounting is None else quat.multiply(q_true, mounting)
            y, mask = tracker.measure_batch(tk, seen, streams)
        updated = k % every["estimator"] == 0
        if updated:
            q_hat, w_hat = estimator.step(tk, g, y, mask)
        if observer is not None:
            observer(k, tk, x, q_hat, w_hat, updated)
        if k % every["controller"] == 0:
            xc = [x[:, i] for i in range(x.shape[1])]
            estimate = [q_hat[:, i] for i in range(4)] + [w_hat[:, i] for i in range(3)]
            column = [float(v) for v in inputs[:, k]]
            u = np.stack(np.broadcast_arrays(*command(model, controller, xc, column, estimate)), axis=1)
        tau_ext = None
        if environment is not None:
            row = [float(v) for v in rows[:, k]]
            q_c = [np.ascontiguousarray(q_true[:, i]) for i in range(4)]
            comps, tau_ext = disturbance_torques(environment, body, q_c, row, surface_c)
            torques = {s: np.stack(np.broadcast_arrays(*comps[s], q_c[0]), axis=1)[:, :3] for s in comps}
            for s, tau in torques.items():
                np.fmax(peaks[s], np.linalg.norm(tau, axis=1), out=peaks[s])
            parameters[:, 12:15] = np.stack(np.broadcast_arrays(*tau_ext, q_c[0]), axis=1)[:, :3]
        if k == n_ticks:
            break
        with np.errstate(all="ignore"):
            if hold is not None:
                x_next = hold.step(x, u, parameters, dt)
            else:
                xn = model.hold_step([x[:, i] for i in range(x.shape[1])], list(u.T), tau_ext, dt, substeps)
                x_next = np.stack(np.broadcast_arrays(*xn), axis=1)
        bad = ~np.all(np.isfinite(x_next), axis=1)
        if np.any(bad):
            diverged_at[bad & np.isnan(diverged_at)] = t[k + 1]
            x_next[bad] = x[bad]  # frozen: the run is reported, the others go on
        x = x_next
        np.fmax(rate_peak, np.linalg.norm(x[:, 4:7], axis=1), out=rate_peak)
    rate_peak[~np.isnan(diverged_at)] = np.nan  # a diverged run is reported as such, not as a broken rule
    broken, bound = batch_broken(model, rate_peak, dt, n_ticks, substeps, budget)
    broken &= ~refused
    if np.any(broken):
        first = int(np.argmax(broken))
        warnings.warn(
            f"{int(np.sum(broken))} run(s) of the batch may have broken the step-size rule mid-run "
            f"(docs/rk4_step_rule.md; run {first}: peak body rate {float(rate_peak[first]):.3g} rad/s, "
            f"error bound {attitude_error_text(float(bound[first]))}, over the budget of {budget:.3g} rad): "
            "their attitude may be off by more "
            "than the budget (info step_rule_broken); shorten dt or raise substeps",
            StepSizeWarning,
            stacklevel=2,
        )
    out = {
        "x": x,
        "diverged_at": diverged_at,
        "step_rule_refused": refused,
        "step_rule_broken": broken,
        "step_rule_error_bound_rad": bound,
        "backend": "numpy" if hold is None else "compiled",
        "backend_note": note,
        "wall_time_s": time.perf_counter() - start,
    }
    if environment is not None:
        out.update(disturbance_torques=torques, disturbance_torque_peak=peaks)
    return out

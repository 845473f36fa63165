"""One tick of the vectorised closed loop: one definition, run by numpy or compiled to C.

A tick of :func:`attitude.simulation.batch.simulate_batch` at time
``t_k = k dt`` is

1. :func:`observe`: the metrics of the state ``x_k`` (peak body rate, peak
   wheel speed, the last tick whose error angle exceeded the pointing
   threshold, the first time the state went non-finite);
2. :func:`command`: at controller samples, the control law's torque on the
   true state, allocated to the wheels (held between samples);
3. the plant's hold step over ``dt`` (:class:`attitude.simulation.plant.PlantModel`,
   the single-run engine's).

These functions are written on components with :mod:`attitude.backend`, so
numpy evaluates them on arrays of runs and casadi on symbols.
:class:`CompiledTicks` builds the casadi tick for *one* run with the
inertia, its inverse and the external torque as inputs (a
:class:`attitude.rigid_body.ParametricBody`), folds it over 10 and 100
ticks, compiles the three to C (:mod:`attitude.simulation.codegen`) and maps the
compiled functions over the runs: one call advances every run by up to 100
ticks with no Python work in between.

Tick state per run, ``z = [x (7 + n_w), u (n_u), metrics (4), parameters (15),
surface (7, with an environment)]``;
``metrics = [rate_peak, wheel_speed_peak, last_above, diverged_at]``
(``diverged_at`` is +inf while the run is finite); ``parameters`` are the six
entries of the hub inertia and of its inverse
(:func:`attitude.rigid_body.symmetric_entries`) and the external torque;
``surface`` the run's surface parameters
(:data:`attitude.environment.SURFACE_PARAMETERS`).
Tick column (shared by all runs): ``c = [controller inputs (m), q_ref (4,
when the controller has a reference), track row (15, with an environment:
:data:`attitude.environment.TRACK_COLUMNS`), k, t_k, sample, dt, threshold]``.

With an orbit environment (:class:`attitude.environment.OrbitEnvironment`)
the tick adds its disturbance torques (:func:`disturbance_torques`, the
environment's backend-neutral ``torque_components`` on the hub body, the
tick's attitude and track row and the run's surface parameters) to the
external torque, evaluated at the tick and held over it, as the single-run
engine (:mod:`attitude.simulation.orbit_flight`).
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from attitude import backend as bk
from attitude import quaternion as quat
from attitude.environment.orbit_environment import SURFACE_PARAMETERS, TRACK_COLUMNS
from attitude.rigid_body import ParametricBody, split_components, symmetric_entries
from attitude.simulation.codegen import compile_functions
from attitude.simulation.plant import PlantModel
from attitude.simulation.protocols import CompiledController

__all__ = [
    "FOLDS",
    "METRICS",
    "CompiledHold",
    "CompiledTicks",
    "command",
    "disturbance_torques",
    "environment_key",
    "observe",
]

#: Order of the running metrics in the tick state.
METRICS = ("rate_peak", "wheel_speed_peak", "last_above", "diverged_at")
#: Ticks per compiled call (besides single ticks): long folds for speed, short ones to stop at history samples.
FOLDS = (100, 10)


def observe(model: PlantModel, x: list, q_ref: list | None, threshold: Any, k: Any, t_k: Any, acc: list) -> tuple:
    """Update the running metrics with the state ``x`` at tick ``k`` (module docstring).

    Parameters
    ----------
    model : PlantModel
        Plant (hub body and wheels).
    x : list
        State components ``[q (4), omega (3) [rad/s], h (n_w) [N m s]]``.
    q_ref : list of 4 or None
        Reference attitude at the tick (None: error angle 0).
    threshold : float or symbol
        Pointing threshold [rad] of the settling time.
    k, t_k : float or symbol
        Tick index and time [s].
    acc : list of 4
        Running metrics (:data:`METRICS`).

    Returns
    -------
    tuple
        New metrics (list of 4), the error angle [rad] and the wheel speeds
        (list of n_w) [rad/s] at the tick.
    """
    w = x[4:7]
    rate = bk.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    speeds = [] if model.wheels is None else model.wheels.wheel_speed_components(x[7:], w)
    speed_peak = acc[1]
    for s in speeds:
        speed_peak = bk.fmax(speed_peak, bk.fabs(s))
    if q_ref is None:
        err = 0.0 * rate
    else:
        err = quat.error_angle_components(q_ref, x[:4])
    last_above = bk.if_else(err > threshold, k + 0.0 * err, acc[2])
    diverged_at = bk.if_else(bk.is_finite(w[0] + w[1] + w[2]), acc[3], bk.fmin(acc[3], t_k))
    return [bk.fmax(acc[0], rate), speed_peak, last_above, diverged_at], err, speeds


def command(
    model: PlantModel, controller: CompiledController, x: list, inputs: list, estimate: list | None = None
) -> list:
    """Motor torques (or the body torque without wheels) of the control law.

    As the single-run engine: the law sees ``estimate`` (``[q (4), omega
    (3)]``, default the true state ``x``) and the wheel momentum of the true
    state; the allocation uses the true wheel speeds.

    Parameters
    ----------
    model : PlantModel
        The plant (body and wheels).
    controller : object
        A controller with ``torque_components``.
    x : list
        State components ``[q (4), omega (3), wheel momenta (n)]`` (numbers or casadi expressions).
    inputs : list
        The controller's compiled inputs at this tick.
    estimate : list, optional
        ``[q (4), omega (3)]`` seen by the law; default the true state.
    """
    seen = x if estimate is None else estimate
    tau = controller.torque_components(seen[:4], seen[4:7], model.body_momentum(x), inputs)
    return model.command(tau, x)[0]


def disturbance_torques(environment: Any, body: Any, q: list, row: Sequence[Any], surface: Sequence[Any]) -> tuple:
    """The environment's disturbance torques per source and their sum, on components (numpy or casadi).

    Parameters
    ----------
    environment : OrbitEnvironment
        The orbit environment (its ``sources``).
    body : RigidBody or ParametricBody
        The whole spacecraft, wheels included (gravity gradient acts on the
        wheels' spin inertia too), as the single-run engine.
    q : list of 4
        Attitude ``q_BN`` at the tick.
    row : sequence of 15
        The tick's track row (:data:`attitude.environment.TRACK_COLUMNS`).
    surface : sequence of 7
        The run's surface parameters (:data:`attitude.environment.SURFACE_PARAMETERS`).

    Returns
    -------
    tuple
        ``(torques, total)``: a dict of list of 3 per source [N m] (in the
        order of ``environment.sources``) and their sum (list of 3) [N m].
    """
    torques = environment.torque_components(body, q, row, surface)
    total: list = [0.0, 0.0, 0.0]
    for source in environment.sources:
        total = [a + b for a, b in zip(total, torques[source])]
    return torques, total


def environment_key(environment: Any) -> Any:
    """What of an environment is built into a compiled tick: sources, plates and ``mu``, not the track.

    The track rows and the surface parameters are inputs of the tick, so
    every orbit, field, atmosphere and epoch with the same sources, the same
    plates and the same gravitational parameter shares one kernel.

    Parameters
    ----------
    environment : OrbitEnvironment or None
        The environment flown (None: no environment).

    Returns
    -------
    tuple or None
        ``(sources, plates or None, mu)``; None without an environment.
    """
    if environment is None:
        return None
    surface = environment.surface
    plates = None
    if surface is not None:
        plates = tuple(
            np.asarray(getattr(surface, name), dtype=float).tobytes()
            for name in ("area_m2", "normal_B", "centre_of_pressure_B_m", "specular", "diffuse", "drag_coefficient")
        )
    return (tuple(environment.sources), plates, float(environment.orbit.mu))


class CompiledTicks:
    """The closed-loop tick for one run compiled to C, mapped over ``n_runs`` (module docstring).

    Parameters
    ----------
    wheels : ReactionWheels or None
        Shared by all runs.
    controller : object
        The compiled-path control law (``torque_components``).
    n_inputs : int
        Rows of ``controller.compiled_inputs``.
    has_reference : bool
        Whether tick columns carry ``q_ref`` (error angles).
    substeps : int
        RK4 steps per tick.
    environment : OrbitEnvironment, optional
        Flown by every run (module docstring); None: none.

    Raises
    ------
    attitude.simulation.codegen.CompilationError
        Without a working C compiler.
    """

    def __init__(
        self,
        wheels: Any,
        controller: CompiledController,
        n_inputs: int,
        has_reference: bool,
        substeps: int,
        environment: Any = None,
    ) -> None:
        n_row = 0 if environment is None else len(TRACK_COLUMNS)
        n_surface = 0 if environment is None else len(SURFACE_PARAMETERS)
        self.n_w = 0 if wheels is None else wheels.n_wheels
        self.n_x = 7 + self.n_w
        self.n_u = self.n_w if wheels is not None else 3
        self.n_z = self.n_x + self.n_u + len(METRICS) + 15 + n_surface
        self.n_c = n_inputs + (4 if has_reference else 0) + n_row + 5
        z = ca.SX.sym("z", self.n_z)
        c = ca.SX.sym("c", self.n_c)
        zs, cs = split_components(z, self.n_z), split_components(c, self.n_c)
        x = zs[: self.n_x]
        u_held = zs[self.n_x : self.n_x + self.n_u]
        acc = zs[self.n_x + self.n_u : self.n_x + self.n_u + len(METRICS)]
        p = zs[self.n_z - 15 - n_surface : self.n_z - n_surface]
        surface = zs[self.n_z - n_surface :]
        q_ref = cs[n_inputs : n_inputs + 4] if has_reference else None
        k, t_k, sample, dt, threshold = cs[self.n_c - 5 :]
        model = PlantModel(ParametricBody(p[:6], p[6:12]), wheels)
        acc_next, _, _ = observe(model, x, q_ref, threshold, k, t_k, acc)
        u_new = command(model, controller, x, cs[:n_inputs])
        u = [bk.if_else(sample > 0.5, a, b) for a, b in zip(u_new, u_held)]
        tau_ext = p[12:15]
        if environment is not None:
            row = cs[self.n_c - 5 - n_row : self.n_c - 5]
            whole = p[:6]
            if wheels is not None:  # the hub plus the wheels' spin inertia
                whole = [a + float(b) for a, b in zip(p[:6], symmetric_entries(wheels.spin_inertia_tensor()))]
            _, total = disturbance_torques(environment, ParametricBody(whole, p[6:12]), x[:4], row, surface)
            tau_ext = [a + b for a, b in zip(tau_ext, total)]
        x_next = model.hold_step(x, u, tau_ext, dt, substeps)
        tick = ca.Function("tick1", [z, c], [ca.vertcat(*x_next, *u, *acc_next, *p, *surface)])
        functions = [tick]
        for n in FOLDS:
            zm, cm = ca.MX.sym("z", self.n_z), ca.MX.sym("c", self.n_c, n)
            functions.append(ca.Function(f"tick{n}", [zm, cm], [tick.fold(n)(zm, cm)]))
        self._compiled = dict(zip([1, *FOLDS], compile_functions(functions)))
        self._mapped: dict[tuple[int, int], _Evaluator] = {}
        self._lock = threading.Lock()

    def advance(self, z: NDArray[np.float64], columns: NDArray[np.float64]) -> NDArray[np.float64]:
        """Advance every run by ``columns.shape[1]`` ticks.

        Parameters
        ----------
        z : ndarray (n_runs, n_z)
            Tick states, one row per run.
        columns : ndarray (n_c, n)
            Tick columns (shared by all runs), in order.

        Returns
        -------
        ndarray (n_runs, n_z)
        """
        n_runs = z.shape[0]
        done = 0
        while done < columns.shape[1]:
            left = columns.shape[1] - done
            fold = next((n for n in FOLDS if n <= left), 1)
            # Input 1 (the tick columns) is shared by the runs, not repeated.
            function = self._compiled[fold]
            evaluator = _mapped(
                self._mapped,
                self._lock,
                (fold, n_runs),
                lambda f=function, m=fold: f.map(f"runs{m}", "serial", n_runs, [1], []),
            )
            z = evaluator(z, columns[:, done : done + fold].T)
            done += fold
        return z


class _Evaluator:
    """Zero-copy evaluation of a compiled function on numpy arrays (``casadi.Function.buffer``).

    A casadi (rows, cols) matrix is stored column by column, which is a
    C-ordered numpy array of shape (cols, rows): runs are rows here. The
    buffer holds pointers to the arrays of the call in progress, so calls
    are serialised by a lock: two threads (a Dask worker with several
    threads) must not interleave their arguments.
    """

    def __init__(self, function: ca.Function) -> None:
        self._buffer, self._evaluate = function.buffer()
        self.n_out = function.size1_out(0)
        self._lock = threading.Lock()

    def __call__(self, *args: NDArray[np.float64]) -> NDArray[np.float64]:
        inputs = [np.ascontiguousarray(a, dtype=np.float64) for a in args]
        out = np.empty((inputs[0].shape[0], self.n_out))
        with self._lock:
            for i, a in enumerate(inputs):
                self._buffer.set_arg(i, memoryview(a))
            self._buffer.set_res(0, memoryview(out))
            self._evaluate()
        return out


def _mapped(cache: dict, lock: threading.Lock, key: Any, build: Any) -> _Evaluator:
    """The evaluator of ``key`` in ``cache``, built once under ``lock`` (thread-safe)."""
    with lock:
        if key not in cache:
            cache[key] = _Evaluator(build())
        return cache[key]


class CompiledHold:
    """The plant's hold step over one tick for one run, compiled to C and mapped over the runs.

    For loops whose commands come from outside the kernel (an estimator in
    the loop): ``x_next = hold(x, u, parameters, dt)`` with the parameters
    of the tick state (module docstring).

    Parameters
    ----------
    wheels : ReactionWheels or None
    substeps : int
        RK4 steps per tick.

    Raises
    ------
    attitude.simulation.codegen.CompilationError
        Without a working C compiler.
    """

    def __init__(self, wheels: Any, substeps: int) -> None:
        self.n_x = 7 + (0 if wheels is None else wheels.n_wheels)
        self.n_u = wheels.n_wheels if wheels is not None else 3
        z = ca.SX.sym("z", self.n_x + self.n_u + 15)
        dt = ca.SX.sym("dt")
        zs = split_components(z, self.n_x + self.n_u + 15)
        x, u, p = zs[: self.n_x], zs[self.n_x : self.n_x + self.n_u], zs[self.n_x + self.n_u :]
        model = PlantModel(ParametricBody(p[:6], p[6:12]), wheels)
        hold = ca.Function("hold1", [z, dt], [ca.vertcat(*model.hold_step(x, u, p[12:15], dt, substeps))])
        (self._compiled,) = compile_functions([hold])
        self._mapped: dict[int, _Evaluator] = {}
        self._lock = threading.Lock()

    def step(
        self, x: NDArray[np.float64], u: NDArray[np.float64], parameters: NDArray[np.float64], dt: float
    ) -> NDArray[np.float64]:
        """Next states (n_runs, n_x) of states (n_runs, n_x), commands (n_runs, n_u), parameters (n_runs, 15).

        Parameters
        ----------
        x : ndarray (n_runs, n_x)
            States of the runs.
        u : ndarray (n_runs, n_u)
            Commands held over the tick.
        parameters : ndarray (n_runs, 15)
            Per-run parameters of the tick state.
        dt : float
            Tick length [s].
        """
        n = x.shape[0]
        evaluator = _mapped(
            self._mapped, self._lock, n, lambda: self._compiled.map(f"hold_runs{n}", "serial", n, [1], [])
        )
        return evaluator(np.concatenate([x, u, parameters], axis=1), np.array([dt]))

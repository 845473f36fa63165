"""The plant's part of a tick of the protocol engine, compiled to C and called through ctypes.

:func:`attitude.simulation.simulate` flies a user's Python objects (controller,
sensors, estimator) tick by tick in Python. Everything else in a tick is the
plant's and needs no Python: allocating the command to the wheels (at
controller samples, held between them), the hold step over the tick
(:meth:`attitude.simulation.plant.PlantModel.hold_step`), the wheels'
momentum seen by the next estimate, and the step-size rule
(:class:`attitude.simulation.step_rule.TickRule`: its rates and its
projection over the ticks left, :func:`~attitude.simulation.step_rule.tick_rule_rates`
and :func:`~attitude.simulation.step_rule.tick_projection`). :class:`ProtocolTick`
builds that as one casadi function of the tick's inputs, generates it as C
with a small C entry point that reads and writes the run's preallocated
history arrays at tick ``k`` directly, and calls it through :mod:`ctypes`:
one call of about a microsecond per tick, where a casadi call from Python
costs some 50 (``docs/protocol_engine_speed.md`` has the figures).

The hub inertia and its inverse are inputs of the function, so one compiled
library serves every body with the same wheels (and step count); it is
compiled once per machine (:mod:`attitude.simulation.codegen`) and loaded once
per process.

The C entry point returns

* ``1``: the tick is done (state, motor torques, applied torque and wheel
  momentum written; the rule's running sums advanced);
* ``0``: the step-size rule asks for more than one hold step in this tick:
  the engine asks :class:`~attitude.simulation.step_rule.TickRule` (which
  warns) and sub-steps the plant itself;
* ``-1``: the command is not finite; ``-2``: the state after the tick is not
  finite (the engine names the error); ``-3``: the generated function failed.

Without a C compiler, the same casadi function runs in casadi's virtual
machine through :meth:`TickRunner.advance_reference` (the reference path: the
tests check the two give the same trajectory).
"""

from __future__ import annotations

import ctypes
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from attitude import backend as bk
from attitude.rigid_body import ParametricBody, RigidBody, split_components, symmetric_entries, symmetric_rows
from attitude.simulation.build_cache import BuildCache
from attitude.simulation.codegen import CompilationError, compile_library, entry_source
from attitude.simulation.plant import PlantModel
from attitude.simulation.step_rule import tick_advance, tick_projection, tick_rule_rates

__all__ = ["ProtocolTick", "TickRunner", "protocol_tick"]

#: Entries of the parameter input: tick index, ticks in the run, tick [s], attitude-error budget [rad],
#: then the six entries of the hub inertia and of its inverse (:func:`attitude.rigid_body.symmetric_entries`).
N_PARAMETERS = 4 + 12
#: Return codes of the C entry point (module docstring).
DONE, SUBSTEP, COMMAND_NOT_FINITE, STATE_NOT_FINITE, FAILED = 1, 0, -1, -2, -3

_C_ENTRY = """
#include <math.h>
/* One tick of the protocol engine at tick k on the run's history arrays (attitude.simulation.protocol_tick). */
CASADI_SYMBOL_EXPORT int protocol_tick_run(double **ctx, long long k, int sample) {
  double *x_all = ctx[0], *cmd_all = ctx[1], *u_all = ctx[2], *tapp_all = ctx[3], *hb_all = ctx[4];
  double *tau_ext = ctx[5], *rule = ctx[6], *par = ctx[7];
  const casadi_real *arg[SZ_ARG];
  casadi_real *res[SZ_RES];
  casadi_int iw[SZ_IW];
  casadi_real w[SZ_W];
  double rule_next[4], error = 0.0, flag = sample ? 1.0 : 0.0;
  long long i, prev = k > 0 ? k - 1 : 0;
  if (!sample) for (i = 0; i < 3; i++) cmd_all[k * 3 + i] = cmd_all[prev * 3 + i];
  for (i = 0; i < 3; i++) if (!(fabs(cmd_all[k * 3 + i]) < INFINITY)) return -1;
  par[0] = (double)k;
  arg[0] = x_all + k * NX; arg[1] = cmd_all + k * 3; arg[2] = u_all + prev * NU; arg[3] = tapp_all + prev * 3;
  arg[4] = &flag; arg[5] = tau_ext; arg[6] = rule; arg[7] = par;
  res[0] = x_all + (k + 1) * NX; res[1] = u_all + k * NU; res[2] = tapp_all + k * 3; res[3] = hb_all + (k + 1) * 3;
  res[4] = rule_next; res[5] = &error;
  if (protocol_tick(arg, res, iw, w, 0)) return -3; /* FAILED */
  if (k >= (long long)par[1]) return 1; /* the last tick: its commands only; the step lands in a scratch row */
  for (i = 0; i < NX; i++) if (!(fabs(x_all[(k + 1) * NX + i]) < INFINITY)) return -2;
  if (!(error <= par[3])) return 0;
  for (i = 0; i < 4; i++) rule[i] = rule_next[i];
  return 1;
}
"""


class ProtocolTick:
    """The plant's part of a protocol-engine tick for one wheel set and step count (module docstring).

    Parameters
    ----------
    model : PlantModel
        The plant; only its wheels and ``n_x`` are built in (the inertia is an input).
    substeps : int
        RK4 steps per hold step.
    """

    def __init__(self, model: PlantModel, substeps: int) -> None:
        wheels = model.wheels
        self.n_x = model.n_x
        self.n_u = model.n_w if wheels is not None else 3
        self.substeps = substeps
        x = ca.SX.sym("x", self.n_x)
        tau_cmd = ca.SX.sym("tau_cmd", 3)
        u_held = ca.SX.sym("u_held", self.n_u)
        tau_app_held = ca.SX.sym("tau_app_held", 3)
        sample = ca.SX.sym("sample")
        tau_ext = ca.SX.sym("tau_ext", 3)
        rule = ca.SX.sym("rule", 4)
        par = ca.SX.sym("par", N_PARAMETERS)
        xc = split_components(x, self.n_x)
        pc = split_components(par, N_PARAMETERS)
        k, n_ticks, dt = pc[0], pc[1], pc[2]
        body = ParametricBody(pc[4:10], pc[10:16])
        plant = PlantModel(body, wheels)
        u_new, tau_app_new = plant.command(split_components(tau_cmd, 3), xc)
        u = [bk.if_else(sample > 0.5, a, b) for a, b in zip(u_new, split_components(u_held, self.n_u))]
        tau_app = [bk.if_else(sample > 0.5, a, b) for a, b in zip(tau_app_new, split_components(tau_app_held, 3))]
        ext = split_components(tau_ext, 3)
        x_next = plant.hold_step(xc, u, ext, dt, substeps)
        h_body_next = plant.body_momentum(x_next)
        # The step-size rule on the state at the tick and the torque held over it (TickRule.calls).
        torque = [a + b for a, b in zip(tau_app, ext)]
        distribution = None if wheels is None else wheels.distribution.tolist()
        h = xc[7:] if wheels is not None else None
        inertia, inverse = symmetric_rows(pc[4:10]), symmetric_rows(pc[10:16])
        rate, turn, excess = tick_rule_rates(inertia, inverse, distribution, xc[4:7], h, torque)
        left = n_ticks - k
        state = split_components(rule, 4)
        angle, _, _, per_call, error = tick_projection(state, rate, turn, excess, left, dt, substeps)
        advanced = tick_advance(state, angle, turn, per_call, left, dt, angle / substeps)
        finite = bk.is_finite(rate + turn + excess)  # TickRule.calls: no count on non-finite rates
        rule_next = [bk.if_else(finite, a, b) for a, b in zip(advanced, state)]
        error = bk.if_else(finite, error, 0.0 * error)
        self.function = ca.Function(
            "protocol_tick",
            [x, tau_cmd, u_held, tau_app_held, sample, tau_ext, rule, par],
            [*(ca.vertcat(*v) for v in (x_next, u, tau_app, h_body_next, rule_next)), error],
        )
        self._library: ctypes.CDLL | None = None
        self._compile_error: str | None = None

    def entry_point(self) -> Any:
        """The C entry point ``protocol_tick_run(ctx, k, sample)`` (compiled and loaded once), or None.

        Returns
        -------
        ctypes function or None
            None when no C compiler works here (:attr:`compile_error` says why).
        """
        if self._library is None and self._compile_error is None:
            f = self.function
            source = entry_source(f, _C_ENTRY, NX=self.n_x, NU=self.n_u)
            try:
                self._library = ctypes.CDLL(str(compile_library([f], source)))
            except (CompilationError, OSError) as exc:
                self._compile_error = str(exc)
                return None
            entry = self._library.protocol_tick_run
            entry.argtypes = (ctypes.c_void_p, ctypes.c_longlong, ctypes.c_int)
            entry.restype = ctypes.c_int
        return None if self._library is None else self._library.protocol_tick_run

    @property
    def compile_error(self) -> str | None:
        """Why the C path is not available (None while it is, or before it was tried)."""
        return self._compile_error


class TickRunner:
    """One run's history arrays and the tick function over them.

    Parameters
    ----------
    tick : ProtocolTick
        The compiled tick of the plant.
    hub_body : RigidBody
        The hub body (its inertia [kg m^2] and inverse are the tick's inputs).
    x0 : ndarray (n_x,)
        Initial state.
    h_body0 : ndarray (3,)
        The wheels' momentum relative to the body at ``x0`` [N m s].
    n_ticks : int
        Ticks in the run.
    dt : float
        Tick [s].
    budget_rad : float
        The step-size rule's attitude-error budget [rad].
    compiled : bool
        Use the C entry point when it is available (False: the reference path).

    Attributes
    ----------
    x, torque_command, motor_torque, torque_applied, h_body : ndarray
        Histories at the ticks, ``(n_ticks + 1, ...)`` (a scratch row past the end).
    tau_ext : ndarray (3,)
        The external torque over the current tick [N m] (the engine writes it).
    rule : ndarray (4,)
        The step-size rule's running sums (:class:`~attitude.simulation.step_rule.TickRule`).
    advance : callable
        ``advance(k, sample) -> int``: the tick (module docstring's return codes).
    """

    def __init__(
        self,
        tick: ProtocolTick,
        hub_body: RigidBody,
        x0: NDArray[np.float64],
        h_body0: NDArray[np.float64],
        n_ticks: int,
        dt: float,
        budget_rad: float,
        *,
        compiled: bool = True,
    ) -> None:
        rows = n_ticks + 2  # a scratch row: the last tick's step goes there
        self.tick = tick
        self.x = np.zeros((rows, tick.n_x))
        self.x[0] = x0
        self.torque_command = np.zeros((rows, 3))
        self.motor_torque = np.zeros((rows, tick.n_u))
        self.torque_applied = np.zeros((rows, 3))
        self.h_body = np.zeros((rows, 3))
        self.h_body[0] = h_body0
        self.tau_ext = np.zeros(3)
        self.rule = np.zeros(4)
        self.parameters = np.concatenate(
            [
                [0.0, float(n_ticks), float(dt), float(budget_rad)],
                symmetric_entries(hub_body.inertia),
                symmetric_entries(hub_body.inertia_inv),
            ]
        )
        arrays = (
            self.x,
            self.torque_command,
            self.motor_torque,
            self.torque_applied,
            self.h_body,
            self.tau_ext,
            self.rule,
            self.parameters,
        )
        self._ctx = (ctypes.c_void_p * len(arrays))(*[a.ctypes.data for a in arrays])
        entry = tick.entry_point() if compiled else None
        self.compiled = entry is not None
        if entry is not None:
            ctx = ctypes.addressof(self._ctx)

            def advance(k: int, sample: int) -> int:
                return entry(ctx, k, sample)

            self.advance = advance
        else:
            self.advance = self.advance_reference

    def advance_reference(self, k: int, sample: int) -> int:
        """The C entry point's tick evaluated by casadi's virtual machine (the reference path).

        Parameters
        ----------
        k : int
            Tick index.
        sample : int
            1 at controller samples (the command in row ``k`` is new), else 0 (held).

        Returns
        -------
        int
            The module docstring's return codes.
        """
        prev = max(k - 1, 0)
        if not sample:
            self.torque_command[k] = self.torque_command[prev]
        if not np.all(np.isfinite(self.torque_command[k])):
            return COMMAND_NOT_FINITE
        self.parameters[0] = float(k)
        out = self.tick.function(
            self.x[k],
            self.torque_command[k],
            self.motor_torque[prev],
            self.torque_applied[prev],
            float(sample),
            self.tau_ext,
            self.rule,
            self.parameters,
        )
        x_next, u, tau_app, h_body, rule_next, error = (np.array(v, dtype=float).ravel() for v in out)
        self.x[k + 1], self.motor_torque[k], self.torque_applied[k], self.h_body[k + 1] = x_next, u, tau_app, h_body
        if k >= int(self.parameters[1]):
            return DONE
        if not np.all(np.isfinite(x_next)):
            return STATE_NOT_FINITE
        if not float(error[0]) <= self.parameters[3]:
            return SUBSTEP
        self.rule[:] = rule_next
        return DONE


#: Ticks built per process, by wheel set and step count (a few: each holds a loaded library).
_TICKS: BuildCache[ProtocolTick] = BuildCache(16)


def protocol_tick(model: PlantModel, substeps: int) -> ProtocolTick:
    """The :class:`ProtocolTick` of a plant's wheels and a step count, built once per process.

    Parameters
    ----------
    model : PlantModel
        The plant (its wheels are the key; the inertia is an input).
    substeps : int
        RK4 steps per hold step.

    Returns
    -------
    ProtocolTick
    """
    return _TICKS.get((substeps, model.wheels_key()), lambda: ProtocolTick(model, substeps))

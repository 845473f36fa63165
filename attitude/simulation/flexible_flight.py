"""A controller flown on a spacecraft with flexible appendages: :func:`simulate_flexible`.

The plant is :class:`attitude.flexible.FlexibleBody` (the hybrid-coordinate
equations; the linear model of :func:`attitude.linearize.flexible_plant` is
their Jacobian). A controller meeting
:class:`attitude.simulation.protocols.Controller` sees the true attitude and
body rate (an :class:`~attitude.simulation.protocols.Estimate`; it does not
see the modal coordinates, as a gyro and star tracker on the hub would not
apart from the rate the modes induce) and its torque is held over its period
(zero-order hold), like the main engine (:func:`attitude.simulation.simulate`)
does. The torque acts directly on the body: **no wheels, sensors or
estimator** in this version (fly those on the rigid body with the main
engine).

Integration: classical RK4 (:func:`attitude.integrators.rk4_step`, the
quaternion renormalised after each step) on the one definition of the
equations, compiled once per run with casadi. The step is at most
:data:`MODE_STEP_MAX_RAD` divided by the fastest unconstrained frequency
(about 63 steps per period of the fastest mode): RK4's error on an undamped
oscillator is ``(w h)^5 / 120`` rad of phase and ``(w h)^6 / 144`` of
relative amplitude per step, so 1e-7 rad and 7e-9 per step, a 1e-5 drift over
a hundred periods. The tick is sub-stepped to keep it, and the result says
how (``info``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.flexible import FlexibleBody, FlexibleModes
from attitude.integrators import normalize_quaternion_components, rk4_step
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody
from attitude.simulation.engine import ticks_per_period, whole_ticks
from attitude.simulation.protocols import Controller, Disturbance, Estimate
from attitude.validation import check_positive, check_vector

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = ["MODE_STEP_MAX_RAD", "FlexibleSimulationResult", "simulate_flexible"]

#: Largest RK4 step times the fastest unconstrained modal frequency [rad] (module docstring: ~63 steps per
#: period of the fastest mode, a phase error of 1e-7 rad and an amplitude error of 7e-9 per step).
MODE_STEP_MAX_RAD = 0.1


@dataclass
class FlexibleSimulationResult(ResultIO):
    """Time histories of :func:`simulate_flexible` (one row per tick).

    Attributes
    ----------
    t : ndarray (m,)
        Sample times [s].
    q : ndarray (m, 4)
        Attitude ``q_BN``.
    omega : ndarray (m, 3)
        Body rate [rad/s].
    eta, eta_dot : ndarray (m, n)
        Modal coordinates [sqrt(kg) m] and their rates [sqrt(kg) m/s].
    torque : ndarray (m, 3)
        Body torque held from each row's time [N m]: the controller's command
        plus the disturbance (the last row repeats the one before).
    energy : ndarray (m,)
        Mechanical energy ``T + V`` [J] (:meth:`FlexibleBody.energy`).
    momentum_N : ndarray (m, 3)
        Angular momentum in inertial components [N m s].
    info : dict
        ``tick_s`` (the tick), ``step_s`` (the RK4 step) and ``substeps`` (RK4
        steps per tick).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    eta: NDArray[np.float64]
    eta_dot: NDArray[np.float64]
    torque: NDArray[np.float64]
    energy: NDArray[np.float64]
    momentum_N: NDArray[np.float64]
    info: dict[str, Any] = field(default_factory=dict)

    def plot(self) -> matplotlib.figure.Figure:
        """Attitude, body rates, modal coordinates and torque against time (``plot_flexible_flight``)."""
        from attitude.plotting import plot_flexible_flight

        return plot_flexible_flight(self)


def _tick_function(flexible: FlexibleBody, substeps: int, step: float) -> ca.Function:
    """``tick(x, tau) -> x_next``: ``substeps`` RK4 steps of ``step`` [s], torque held, quaternion renormalised."""
    x = ca.SX.sym("x", flexible.n_states)
    tau = ca.SX.sym("tau", 3)
    torque = [tau[i] for i in range(3)]

    def derivative(t: Any, xs: list[Any]) -> list[Any]:
        return flexible.state_derivative_components(xs, torque)

    xs = [x[i] for i in range(flexible.n_states)]
    for _ in range(substeps):
        xs = normalize_quaternion_components(rk4_step(derivative, 0.0, xs, step))
    return ca.Function("flexible_tick", [x, tau], [ca.vertcat(*xs)])


def _disturbance(disturbance: Disturbance) -> Callable[[float, NDArray, NDArray], NDArray]:
    if disturbance is None:
        return lambda t, q, w: np.zeros(3)
    if callable(disturbance):
        return lambda t, q, w: check_vector(disturbance(t, q, w), "disturbance(t, q, omega)", 3)
    constant = check_vector(disturbance, "disturbance", 3)
    if constant.shape != (3,):
        raise ValueError(f"disturbance must be a torque of shape (3,) [N m] or a callable, got shape {constant.shape}")
    return lambda t, q, w: constant


def simulate_flexible(
    body: RigidBody,
    modes: FlexibleModes,
    q0: ArrayLike,
    omega0: ArrayLike,
    duration: float,
    *,
    controller: Controller | None = None,
    dt: float | None = None,
    disturbance: Disturbance = None,
    eta0: ArrayLike | None = None,
    eta_dot0: ArrayLike | None = None,
) -> FlexibleSimulationResult:
    """Fly a controller (or nothing) on a spacecraft with flexible appendages, from ``t = 0`` to ``duration``.

    Parameters
    ----------
    body : RigidBody
        The whole spacecraft, appendages included and undeformed [kg m^2].
    modes : FlexibleModes
        The constrained modes of the appendages.
    q0 : array_like (4,)
        Initial attitude ``q_BN``.
    omega0 : array_like (3,)
        Initial body rate [rad/s].
    duration : float
        Simulated time [s], a whole number of ticks.
    controller : object, optional
        Meets :class:`attitude.simulation.protocols.Controller` (``period``,
        ``torque(t, estimate)``); it sees the true ``q`` and ``omega`` and its
        torque [N m] is held over its period. None: no control torque.
    dt : float, optional
        The tick [s]: the controller's period by default (which must then be a
        whole multiple of it); required without a controller.
    disturbance : None, array_like (3,) or callable
        External body torque [N m]: constant, or ``torque(t, q, omega)``
        evaluated at each tick and held over it.
    eta0, eta_dot0 : array_like (n,), optional
        Initial modal coordinates [sqrt(kg) m] and rates [sqrt(kg) m/s] (zero).

    Returns
    -------
    FlexibleSimulationResult
        One row per tick, the initial state first.

    Raises
    ------
    ValueError
        Bad arguments (named), a controller period that is not a whole
        multiple of ``dt``, a duration that is not a whole number of ticks,
        ``I - L^T L`` not positive definite, or a non-finite state (the run
        diverged).
    """
    flexible = FlexibleBody(body, modes)
    x = flexible.initial_state(q0, omega0, eta0, eta_dot0)
    duration = float(check_positive(duration, "duration"))
    if controller is not None:
        if not hasattr(controller, "torque"):
            raise ValueError(f"controller must have a torque(t, estimate) method, got {type(controller).__name__}")
        period = float(check_positive(getattr(controller, "period", np.nan), "controller.period"))
        tick = period if dt is None else float(check_positive(dt, "dt"))
        every = ticks_per_period(period, tick, "controller")
    elif dt is None:
        raise ValueError("dt (the tick, s) is required without a controller")
    else:
        tick, every = float(check_positive(dt, "dt")), 1
    n_ticks = whole_ticks(duration, tick)
    substeps = max(1, math.ceil(tick * float(np.max(flexible.unconstrained_frequencies())) / MODE_STEP_MAX_RAD))
    step_fn = _tick_function(flexible, substeps, tick / substeps)
    external = _disturbance(disturbance)

    states = np.empty((n_ticks + 1, flexible.n_states))
    torques = np.zeros((n_ticks + 1, 3))
    states[0] = x
    command = np.zeros(3)
    if controller is not None and hasattr(controller, "prepare"):
        # As the main engine does: a controller with state (filters, integrators) starts each run at rest.
        controller.prepare(0.0, x[:4].copy(), x[4:7].copy())
    for k in range(n_ticks):
        t = k * tick
        q, w = x[:4], x[4:7]
        if controller is not None and k % every == 0:
            estimate = Estimate(t=t, q=q.copy(), omega=w.copy())
            command = check_vector(controller.torque(t, estimate), "controller.torque(t, estimate)", 3)
        torques[k] = command + external(t, q.copy(), w.copy())
        x = np.asarray(step_fn(x, torques[k]).full(), dtype=float).reshape(-1)
        if not np.all(np.isfinite(x)):
            raise ValueError(f"the simulation diverged: a non-finite state at t = {t + tick:.6g} s")
        states[k + 1] = x
    torques[-1] = torques[-2]
    n = flexible.n_modes
    return FlexibleSimulationResult(
        t=tick * np.arange(n_ticks + 1),
        q=states[:, :4],
        omega=states[:, 4:7],
        eta=states[:, 7 : 7 + n],
        eta_dot=states[:, 7 + n :],
        torque=torques,
        energy=flexible.energy(states),
        momentum_N=flexible.inertial_angular_momentum(states),
        info={"tick_s": tick, "step_s": tick / substeps, "substeps": substeps},
    )

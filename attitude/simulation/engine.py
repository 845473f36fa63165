"""The closed-loop engine: plant + wheels + sensors + estimator + controller.

``simulate(...)`` integrates the continuous plant between discrete samples.
Commands are held (zero-order hold) over each sample interval ``dt``, the
engine's tick; every component runs at a period that is a whole multiple of
``dt``. Components are plain objects meeting small protocols, so a user's own
controller or filter drops in; this module never imports ``controllers`` or
``estimation``.

Protocols
---------
Controllers, sensors, estimators and disturbances meet the protocols of
:mod:`attitude.simulation.protocols` (:class:`Controller`, :class:`Sensor`,
:class:`Estimator`, :data:`Disturbance`); sensors see a :class:`Truth`,
controllers an :class:`Estimate`: copies of the record, so a law may change or
keep them (one truth per tick is read by every sensor and the disturbance in
turn; the controller's estimate is its own). The plant's part of each tick (allocation, hold step, the step-size
rule) is one call of generated C (:mod:`attitude.simulation.protocol_tick`):
what remains in Python is the user's objects and a few microseconds.

Compiled path
-------------
With no sensors or estimator (the controller sees the truth), a controller
that offers ``compiled_inputs(t) -> (m, N)`` and
``torque_components(q, omega, h_body, inputs) -> [3]`` (backend-neutral, see
:mod:`attitude.backend`) runs with the plant and the wheels entirely in one
casadi ``mapaccum`` (folded over :data:`FOLD_TICKS` ticks per call): no
Python work per sample. It evaluates the same definitions as the Python path,
and a test proves the two agree. A built-in law (``compiled_law_cacheable``)
keeps its closed loop per process by content (docs/protocol_engine_speed.md).
"""

from __future__ import annotations

import dataclasses
import pickle
import time
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import Magnetorquers, ReactionWheels
from attitude.environment.orbit_environment import OrbitEnvironment
from attitude.integrators import (
    ATTITUDE_ERROR_BUDGET_RAD,
    MAX_RULE_SUBSTEPS,
    StepSizeWarning,
    attitude_error_text,
    check_error_budget,
    rule_formula,
    warn_outside_calibration,
)
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody, split_components
from attitude.rng import as_generator
from attitude.simulation.build_cache import BuildCache
from attitude.simulation.orbit_flight import OrbitFlight
from attitude.simulation.plant import PlantModel
from attitude.simulation.protocol_tick import (
    COMMAND_NOT_FINITE,
    DONE,
    STATE_NOT_FINITE,
    SUBSTEP,
    TickRunner,
    protocol_tick,
)
from attitude.simulation.protocols import (
    Controller,
    DipoleController,
    Disturbance,
    Estimate,
    Estimator,
    Sensor,
    Truth,
    VectorMeasurement,
)
from attitude.simulation.step_rule import TickRule, history_substeps
from attitude.validation import as_float_array, check_positive, check_vector

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = [
    "SimulationDivergedError",
    "SimulationResult",
    "settling_time_after",
    "simulate",
]


@dataclass
class SimulationResult(ResultIO):
    """Time histories of a closed-loop simulation (one row per tick).

    Attributes
    ----------
    t : ndarray (n,)
        Sample times [s].
    q, omega : ndarray (n, 4), (n, 3)
        True attitude ``q_BN`` and body rate [rad/s].
    h_wheels, wheel_speed : ndarray (n, n_wheels)
        Wheel spin-axis momenta [N m s] and speeds relative to the body [rad/s].
    torque_command : ndarray (n, 3)
        Body torque commanded by the controller, held from each row's time [N m].
    torque_applied : ndarray (n, 3)
        Body torque the actuators deliver after saturation [N m] (``-A u``;
        without wheels, the command itself).
    motor_torque : ndarray (n, n_wheels)
        Wheel motor torques [N m].
    momentum_N : ndarray (n, 3)
        Total inertial angular momentum (body plus wheels) [N m s].
    error_angle : ndarray (n,)
        Angle between the true attitude and the controller's reference [rad]
        (NaN-free; zeros if the controller has no reference).
    estimate_q, estimate_omega : ndarray (n, 4), (n, 3)
        The controller's view (truth when there is no estimator).
    logs : dict of ndarray
        Whatever the components logged (keys ``controller.*``, ``estimator.*``,
        ``sensor.<name>``, ``dipole_controller.*``), one row per tick, NaN where
        a component did not sample. A sensor returning a
        :class:`~attitude.simulation.protocols.VectorMeasurement` logs its unit
        ``vector_B`` under ``sensor.<name>`` and its ``reference_N`` under
        ``sensor.<name>.reference_N``.
    info : dict
        Engine details: tick, engine ("compiled" or "python"), wall time [s].
    disturbance_torques : dict of ndarray (n, 3)
        With an orbit environment: each source's torque in body axes [N m]
        (keys of :data:`attitude.environment.DISTURBANCE_SOURCES`), held from
        each row's time; empty without one.
    field_B : ndarray (n, 3)
        Geomagnetic field at the spacecraft in body axes [T] (empty without an environment).
    illumination : ndarray (n,)
        Fraction of the Sun seen (1 full sun, 0 umbra; empty without an environment).
    dipole_command : ndarray (n, 3)
        Dipole commanded by the magnetic law in body axes [A m^2] (empty without magnetorquers).
    dipole : ndarray (n, 3)
        Dipole the magnetorquers deliver after saturation and quantisation [A m^2].
    torque_magnetorquer : ndarray (n, 3)
        Torque of the magnetorquers ``m x B`` [N m], held from each row's time.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    h_wheels: NDArray[np.float64]
    wheel_speed: NDArray[np.float64]
    torque_command: NDArray[np.float64]
    torque_applied: NDArray[np.float64]
    motor_torque: NDArray[np.float64]
    momentum_N: NDArray[np.float64]
    error_angle: NDArray[np.float64]
    estimate_q: NDArray[np.float64]
    estimate_omega: NDArray[np.float64]
    logs: dict[str, Any] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    disturbance_torques: dict[str, Any] = field(default_factory=dict)
    field_B: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    illumination: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    dipole_command: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    dipole: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))
    torque_magnetorquer: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def external_torque(self) -> NDArray[np.float64]:
        """Body torque from outside the wheels at each row [N m], (n, 3): the environment sources and magnetorquers.

        The sum of :attr:`disturbance_torques` and :attr:`torque_magnetorquer`,
        held from each row's time like them (zeros in empty space without
        magnetorquers). A ``disturbance`` handed to :func:`simulate` is not
        recorded, so it is not included.
        """
        torque = np.zeros_like(self.omega)
        for source in self.disturbance_torques.values():
            torque = torque + source
        if self.torque_magnetorquer.size:
            torque = torque + self.torque_magnetorquer
        return torque

    def settling_time(self, threshold_rad: float) -> float:
        """First time [s] after which the error angle stays below ``threshold_rad`` (inf if never).

        Parameters
        ----------
        threshold_rad : float
            Error-angle threshold [rad].
        """
        threshold = float(check_positive(threshold_rad, "threshold_rad"))
        above = np.nonzero(self.error_angle > threshold)[0]
        return float(settling_time_after(self.t, above[-1] if above.size else -1))

    def plot(self) -> matplotlib.figure.Figure:
        """The standard review figure: error, rates, torques, wheel speeds."""
        from attitude.plotting import plot_simulation

        return plot_simulation(self)


# ---------------------------------------------------------------------------


def settling_time_after(t: ArrayLike, last_outside: ArrayLike) -> NDArray[np.float64]:
    """The settling time from the last sample outside the threshold: the one definition.

    Parameters
    ----------
    t : array_like (n,)
        Sample times [s].
    last_outside : int or array_like of int
        Index of the last sample whose error exceeded the threshold (-1: none).

    Returns
    -------
    ndarray
        ``t[0]`` when no sample was outside, ``inf`` when the last one was,
        else the time of the sample after the last one outside [s].
    """
    t = np.asarray(t, dtype=float)
    last = np.asarray(last_outside, dtype=np.int64)
    settle = np.where(last < 0, t[0], t[np.minimum(last + 1, t.size - 1)])
    return np.where(last == t.size - 1, np.inf, settle)


def _period(obj: Any, name: str) -> float:
    period = getattr(obj, "period", None)
    if period is None:
        raise ValueError(f"{name} must have a 'period' attribute (its sample time in s)")
    return float(check_positive(period, f"{name}.period"))


def ticks_per_period(period: float, dt: float, name: str) -> int:
    """Ticks of ``dt`` [s] in a component's ``period`` [s], which must be a whole multiple of it (to 1e-9).

    ``name`` is the component, named in the error (``"{name}.period"``).
    """
    ratio = period / dt
    k = round(ratio)
    if k < 1 or abs(ratio - k) > 1e-9 * max(1.0, ratio):
        raise ValueError(f"{name}.period = {period!r} s must be a whole multiple of the tick dt = {dt!r} s")
    return int(k)


def whole_ticks(duration: float, dt: float) -> int:
    """Ticks of ``dt`` [s] in ``duration`` [s], which must be a whole number (>= 1) of them (to 1e-9)."""
    n = round(duration / dt)
    if n < 1 or abs(n * dt - duration) > 1e-9 * duration:
        raise ValueError(f"duration = {duration!r} s must be a whole number (>= 1) of ticks dt = {dt!r} s")
    return n


def simulate(
    body: RigidBody,
    q0: ArrayLike,
    omega0: ArrayLike,
    duration: float,
    *,
    controller: Controller | None = None,
    wheels: ReactionWheels | None = None,
    h_wheels0: ArrayLike | None = None,
    sensors: tuple[Sensor, ...] | list[Sensor] = (),
    estimator: Estimator | None = None,
    disturbance: Disturbance = None,
    environment: OrbitEnvironment | None = None,
    surface_parameters: ArrayLike | None = None,
    magnetorquers: Magnetorquers | None = None,
    dipole_controller: DipoleController | None = None,
    dt: float | None = None,
    substeps: int = 1,
    rng: Any = None,
    engine: str = "auto",
    attitude_error_budget_rad: float = ATTITUDE_ERROR_BUDGET_RAD,
) -> SimulationResult:
    """Simulate the closed loop from ``t = 0`` to ``duration``.

    Parameters
    ----------
    body : RigidBody
        The whole spacecraft, wheels included [kg m^2]. With wheels, the
        plant uses the hub inertia (:meth:`ReactionWheels.hub_body`).
    q0 : array_like (4,)
        Initial attitude ``q_BN``.
    omega0 : array_like (3,)
        Initial body rate [rad/s].
    duration : float
        Simulated time [s]; the run ends at the first tick at or after it.
    controller : object, optional
        See the module docstring. None: no control torque.
    wheels : ReactionWheels, optional
        Actuators. None: the commanded torque acts directly on the body.
    h_wheels0 : array_like (n,), optional
        Initial wheel momenta [N m s] (default zero).
    sensors : sequence of objects
        See the module docstring.
    estimator : object, optional
        See the module docstring. None: the controller sees the truth.
    disturbance : None, array_like (3,) or callable
        External torque [N m] (module docstring), added to the environment's.
    environment : OrbitEnvironment, optional
        Fly the spacecraft in its orbit: gravity-gradient, aerodynamic, solar
        pressure and residual-dipole torques (per source in
        ``disturbance_torques``), and the field and Sun handed to the sensors
        (:class:`attitude.simulation.orbit_flight.OrbitFlight`). ``t = 0`` is the
        orbit's epoch.
    surface_parameters : array_like (7,), optional
        This run's surface parameters (drag scale, residual dipole,
        centre-of-pressure offset: :meth:`OrbitEnvironment.surface_parameters`);
        default the surface model's own.
    magnetorquers : Magnetorquers, optional
        Torque rods; their torque ``m x B`` acts with the wheels'.
    dipole_controller : object, optional
        The magnetic law commanding the rods
        (:class:`attitude.simulation.protocols.DipoleController`: B-dot
        detumbling, momentum unloading), running beside ``controller``.
    dt : float, optional
        The tick [s]: the shortest component period by default.
    substeps : int
        RK4 steps per tick (each renormalised).
    rng : Generator, int or None
        Random source handed to the sensors.
    engine : {"auto", "python", "compiled"}
        "auto" uses the compiled path when possible (module docstring).
    attitude_error_budget_rad : float
        Accumulated attitude error [rad] the plant's RK4 may make over the run
        (default :data:`attitude.integrators.ATTITUDE_ERROR_BUDGET_RAD`). The
        step-size rule (docs/rk4_step_rule.md) is checked at every tick on the
        rate reached (the compiled path: before the run and on its history,
        running again if needed); where it is broken the plant is sub-stepped
        with the commands held, with one :class:`attitude.integrators.StepSizeWarning`
        per run, and a second one saying "NOT within the budget" at the end
        of a run whose predicted error still exceeds it (a rate that kept
        growing). ``inf`` turns the rule off. A disturbance that changes
        strongly within one tick is outside the rule (docs/rk4_step_rule.md).

    Returns
    -------
    SimulationResult
        ``info["step_rule"]`` holds the predicted error [rad], the budget and
        the most RK4 steps taken in one tick.

    Raises
    ------
    ValueError
        For invalid arguments, or a tick so long for the rates that the rule
        needs more than :data:`attitude.integrators.MAX_RULE_SUBSTEPS` times
        ``substeps`` RK4 steps per tick.

    Warns
    -----
    StepSizeWarning
        When the step-size rule sub-stepped the plant.
    """
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError("body must be a single RigidBody")
    q0 = quat.as_unit_quaternion(q0, "q0")
    omega0 = check_vector(omega0, "omega0", 3)
    if q0.shape != (4,) or omega0.shape != (3,):
        raise ValueError(f"q0 must have shape (4,) and omega0 shape (3,), got {q0.shape} and {omega0.shape}")
    duration = float(check_positive(duration, "duration"))
    if isinstance(substeps, bool) or not isinstance(substeps, int) or substeps < 1:
        raise ValueError(f"substeps must be a positive integer, got {substeps!r}")
    budget = check_error_budget(attitude_error_budget_rad)
    if engine not in ("auto", "python", "compiled"):
        raise ValueError(f"engine must be 'auto', 'python' or 'compiled', got {engine!r}")
    if wheels is not None and not isinstance(wheels, ReactionWheels):
        raise ValueError(f"wheels must be a ReactionWheels or None, got {type(wheels).__name__}")
    n_w = 0 if wheels is None else wheels.n_wheels
    if h_wheels0 is None:
        h_wheels0 = np.zeros(n_w)
    h_wheels0 = as_float_array(h_wheels0, "h_wheels0").reshape(-1)
    if h_wheels0.size != n_w:
        raise ValueError(f"h_wheels0 must have one momentum per wheel ({n_w}), got {h_wheels0.size}")
    if disturbance is not None and not callable(disturbance):
        disturbance = check_vector(disturbance, "disturbance", 3)
        if disturbance.shape != (3,):
            raise ValueError(
                f"disturbance must be a constant torque of shape (3,) or a callable, got shape {disturbance.shape}"
            )
    names = []
    for s in sensors:
        if not hasattr(s, "measure") or not hasattr(s, "name"):
            raise ValueError(f"sensor {s!r} must have 'name', 'period' and 'measure(t, truth, rng)'")
        if s.name in names:
            raise ValueError(
                f"sensors must have distinct names; {s.name!r} appears twice (their samples would collide)"
            )
        names.append(s.name)
    if controller is not None and not hasattr(controller, "torque"):
        raise ValueError("controller must have a 'torque(t, estimate)' method")
    if estimator is not None and not hasattr(estimator, "update"):
        raise ValueError("estimator must have an 'update(t, measurements)' method")

    periods = {}
    if controller is not None:
        periods["controller"] = _period(controller, "controller")
    if dipole_controller is not None:
        periods["dipole_controller"] = _period(dipole_controller, "dipole_controller")
    if estimator is not None:
        periods["estimator"] = _period(estimator, "estimator")
    for s in sensors:
        periods[f"sensor {s.name}"] = _period(s, f"sensor {s.name}")
    if dt is None:
        dt = min(periods.values()) if periods else 0.1
    dt = float(check_positive(dt, "dt"))
    every = {name: ticks_per_period(p, dt, name) for name, p in periods.items()}
    # Whole ticks: the run ends at the first tick at or after `duration`
    # (the 1e-9 slack keeps 600 s / 0.1 s at 6000 ticks despite rounding).
    n_ticks = max(1, int(np.ceil(duration / dt - 1e-9)))

    try:
        plant = body if wheels is None else wheels.hub_body(body)
    except ValueError as exc:
        raise ValueError(
            "wheels spin_inertia is too large for body: the hub inertia I - sum J a a^T (the spacecraft without "
            f"the wheels' spin-axis inertia) must be a valid inertia: {exc}"
        ) from exc
    model = PlantModel(plant, wheels)
    warn_outside_calibration(plant, budget, "simulate")
    # The gravity gradient acts on the whole mass distribution: the rotors are axisymmetric about
    # their spin axes, so their full inertia (spin part included) takes the gradient; the hub
    # body (I - sum J a a^T) is only the plant's dynamic inertia.
    flight = OrbitFlight(
        environment,
        body,
        np.arange(n_ticks + 1) * dt,
        surface_parameters=surface_parameters,
        magnetorquers=magnetorquers,
        dipole_controller=dipole_controller,
    )
    compiled_ok = (
        controller is not None
        and not sensors
        and estimator is None
        and hasattr(controller, "torque_components")
        and hasattr(controller, "compiled_inputs")
        and (disturbance is None or not callable(disturbance))
        and every.get("controller") == 1
        and (
            dipole_controller is None
            or (
                hasattr(dipole_controller, "dipole_components")
                and hasattr(dipole_controller, "compiled_inputs")
                and getattr(dipole_controller, "use_truth_field", False)
                and every.get("dipole_controller") == 1
            )
        )
    )
    if engine == "compiled" and not compiled_ok:
        raise ValueError(
            "engine='compiled' needs a controller with torque_components/compiled_inputs at period dt, "
            "no sensors or estimator, a constant (or no) disturbance, and a dipole_controller (if any) with "
            "dipole_components at period dt"
        )
    use_compiled = compiled_ok and engine != "python"
    for s in sensors:
        if hasattr(s, "reset"):
            s.reset()  # a sensor carries state (e.g. gyro bias) from run to run otherwise
    if dipole_controller is not None and hasattr(dipole_controller, "reset"):
        dipole_controller.reset()  # a B-dot law keeps its last field sample otherwise
    if controller is not None and hasattr(controller, "prepare"):
        controller.prepare(0.0, q0, omega0)
    start = time.perf_counter()
    args = (model, flight, controller, sensors, estimator, disturbance, q0, omega0, h_wheels0, dt, n_ticks)
    if use_compiled:
        result = _run_compiled_rule(args, substeps, every, rng, budget)
    else:
        rule = TickRule(model, dt, n_ticks, substeps, budget)
        result = _run_python(*args, substeps, every, rng, rule=rule)
        result.info["step_rule"] = rule.info()
    _warn_over_budget(result.info["step_rule"])
    if wheels is not None:
        result.info["wheel_speed_limit_rpm"] = (
            wheels.momentum_max / wheels.spin_inertia * 60.0 / (2.0 * np.pi)
        ).tolist()
    result.info.update(
        {"dt": dt, "substeps": substeps, "engine": "compiled" if use_compiled else "python"},
        wall_time_s=time.perf_counter() - start,
    )
    return result


def _finish(model, t, x, tau_cmd, tau_app, u, err, est_q, est_w, logs, orbit=None) -> SimulationResult:
    q, omega, h = x[:, :4], x[:, 4:7], x[:, 7:]
    speed = model.wheels.wheel_speed(h, omega) if model.wheels is not None else np.zeros((t.size, 0))
    motor = u if model.wheels is not None else np.zeros((t.size, 0))
    result = SimulationResult(
        t=t,
        q=q,
        omega=omega,
        h_wheels=h,
        wheel_speed=speed,
        torque_command=tau_cmd,
        torque_applied=tau_app,
        motor_torque=motor,
        momentum_N=model.momentum_N(q, omega, h),
        error_angle=err,
        estimate_q=est_q,
        estimate_omega=est_w,
        logs=logs,
        info={},
    )
    if orbit is not None:
        for name, value in orbit.items():
            setattr(result, name, value)
    return result


def _orbit_histories(flight: OrbitFlight, torques, field_B, illumination, m_cmd, m_B, tau_m) -> dict | None:
    """The result fields of a run in orbit (None without an environment)."""
    if not flight.active:
        return None
    fields = {
        "disturbance_torques": {s: torques[:, i, :] for i, s in enumerate(flight.sources)},
        "field_B": field_B,
        "illumination": illumination,
    }
    if flight.magnetorquers is not None:
        fields.update(dipole_command=m_cmd, dipole=m_B, torque_magnetorquer=tau_m)
    return fields


#: Ticks per casadi call of the compiled path.
FOLD_TICKS = 600

#: Most runs of the compiled path under the step-size rule (the first, and repeats when the rates reached
#: ask for more steps than the initial rates did).
RULE_PASSES = 3


def _run_compiled_rule(args: tuple, substeps: int, every: dict, rng: Any, budget: float) -> SimulationResult:
    """The compiled path under the step-size rule: checked on the initial state, then on each run's history.

    The compiled loop is a pure function of its inputs, so a run that broke
    the rule is run again with one step count per tick for the whole run.
    """
    model, disturbance, dt, n_ticks = args[0], args[5], args[9], args[10]
    x0 = np.concatenate([args[6], args[7], args[8]])
    steps, error = history_substeps(model, x0, dt, n_ticks, substeps, budget, disturbance)
    _check_rule_steps(steps, substeps)
    for _ in range(RULE_PASSES):
        result = _run_compiled(*args, steps, every, rng)
        x = np.concatenate([result.q, result.omega, result.h_wheels], axis=1)
        torque = _body_torque_history(result, disturbance)
        needed, error = history_substeps(model, x, dt, n_ticks, steps, budget, torque)
        if needed <= steps:
            break
        if needed > MAX_RULE_SUBSTEPS * substeps:
            warnings.warn(
                f"simulate breaks the step-size rule (docs/rk4_step_rule.md) at the rates reached (body rate up to "
                f"{float(np.max(np.linalg.norm(result.omega, axis=1))):.3g} rad/s): meeting it needs {needed} RK4 "
                f"steps per tick, more than {MAX_RULE_SUBSTEPS * substeps}; the attitude is NOT within the "
                f"budget of {budget:.3g} rad (predicted error {attitude_error_text(error)})",
                StepSizeWarning,
                stacklevel=3,
            )
            break
        steps = needed
    if steps > substeps:
        warnings.warn(
            f"simulate breaks the step-size rule {rule_formula()} <= {budget:.3g} rad "
            f"(docs/rk4_step_rule.md): {substeps} RK4 step(s) per tick of {dt:.3g} s predicts an accumulated "
            f"attitude error above the budget at the rates reached (body rate up to "
            f"{float(np.max(np.linalg.norm(result.omega, axis=1))):.3g} rad/s); the plant is sub-stepped to {steps} "
            "RK4 steps per tick with the commands held (substeps sets the steps per tick, "
            "attitude_error_budget_rad the budget)",
            StepSizeWarning,
            stacklevel=3,
        )
    result.info["step_rule"] = {
        "predicted_error_rad": error,
        "budget_rad": budget,
        "substeps_added": steps > substeps,
        "most_substeps_per_tick": steps,
    }
    return result


def _body_torque_history(result: SimulationResult, disturbance: Any) -> NDArray[np.float64]:
    """Body torque at the ticks [N m]: the actuators', a constant disturbance, the environment and magnetorquers."""
    torque = result.torque_applied + result.external_torque
    if disturbance is not None:
        torque += np.asarray(disturbance, dtype=float)
    return torque


def _check_rule_steps(steps: int, substeps: int) -> None:
    if steps > MAX_RULE_SUBSTEPS * substeps:
        raise ValueError(
            f"simulate breaks the step-size rule (docs/rk4_step_rule.md): meeting it needs {steps} RK4 steps per "
            f"tick, more than {MAX_RULE_SUBSTEPS} x substeps = {MAX_RULE_SUBSTEPS * substeps}: shorten dt or raise "
            "substeps"
        )


#: Closed loops of the compiled path kept per process, by content (:func:`_closed_loop_key`).
_LOOPS: BuildCache[_ClosedLoop] = BuildCache(8)


class _ClosedLoop:
    """The compiled path's tick as a casadi function, its command output and its folds over many ticks."""

    def __init__(self, model, flight, controller, disturbance, dt, substeps, m, n_row, n_law) -> None:
        law = flight.dipole_controller
        x = ca.SX.sym("x", model.n_x)
        p = ca.SX.sym("p", m + n_row + n_law)
        xc = split_components(x, model.n_x)
        pc = split_components(p, m + n_row + n_law)
        h_body = model.body_momentum(xc)
        tau_cmd = controller.torque_components(xc[:4], xc[4:7], h_body, pc[:m])
        u_sym, tau_app_sym = model.compiled_command()(ca.vertcat(*tau_cmd), x)
        u, tau_app = split_components(u_sym, model.n_u), split_components(tau_app_sym, 3)
        tau_ext = [0.0, 0.0, 0.0] if disturbance is None else [float(v) for v in disturbance]
        extra: list = []
        if flight.active:
            row = pc[m : m + n_row]
            field_B, _ = flight.environment.body_vectors_components(xc[:4], row)
            m_cmd = m_B = None
            if law is not None:
                m_cmd = law.dipole_components(field_B, h_body, pc[m + n_row :])
                m_B = flight.magnetorquers.dipole_components(flight.magnetorquers.command_components(m_cmd))
            torques, field_B, _, tau_m = flight.compiled_pieces(xc[:4], row, m_B)
            for i in range(flight.n_sources):
                tau_ext = [a + b for a, b in zip(tau_ext, torques[3 * i : 3 * i + 3])]
            tau_ext = [a + b for a, b in zip(tau_ext, tau_m)]
            zero = [0.0 * field_B[0]] * 3
            extra = [*torques, *field_B, *(m_cmd or zero), *(m_B or zero), *tau_m]
        commands = ca.vertcat(*tau_cmd, *tau_app, *u, *extra)
        x_next = model.step_expression(x, u_sym, ca.vertcat(*tau_ext), dt, substeps)
        self.function = ca.Function("closed_loop", [x, p], [x_next, commands])
        self.commands = ca.Function("command", [x, p], [commands])
        self.n_u = len(u)
        self._folds: dict[int, ca.Function] = {}

    def fold(self, ticks: int) -> ca.Function:
        """The tick folded over ``ticks`` ticks (``mapaccum``), built once."""
        if ticks not in self._folds:
            self._folds[ticks] = self.function.mapaccum(ticks)
        return self._folds[ticks]


def _closed_loop_key(model, flight, controller, disturbance, dt, substeps, m, n_row, n_law) -> tuple | None:
    """What the compiled path's closed loop is built from, or None where it is not cached.

    Only a controller whose class declares ``compiled_law_cacheable = True`` is cached: its law must depend on
    nothing but its pickled state (the built-in laws), so that its class object and its pickle are the key (the
    same gains rebuilt by a new script reuse the loop; a changed gain, or a class redefined in a notebook, does
    not). A user's law may read globals or drop fields from its pickle: it is built every run. A run in orbit is
    not cached (its tick holds the environment's models), nor a controller that cannot be pickled.
    """
    plant = model.identity(substeps)
    if flight.active or plant is None or not getattr(type(controller), "compiled_law_cacheable", False):
        return None
    try:
        law = pickle.dumps(controller)
    except Exception:  # e.g. a reference given as a lambda
        return None
    ext = None if disturbance is None else np.asarray(disturbance, dtype=float).tobytes()
    return (type(controller), law, plant, ext, float(dt), m, n_row, n_law)


def _run_compiled(
    model, flight, controller, sensors, estimator, disturbance, q0, omega0, h0, dt, n_ticks, substeps, every, rng
):
    t = np.arange(n_ticks + 1) * dt
    inputs = np.atleast_2d(as_float_array(controller.compiled_inputs(t), "controller.compiled_inputs(t)"))
    if inputs.shape[-1] != n_ticks + 1:
        raise ValueError(f"controller.compiled_inputs(t) must return shape (m, {n_ticks + 1}), got {inputs.shape}")
    m = inputs.shape[0]
    n_row = flight.rows.shape[1] if flight.active else 0
    law = flight.dipole_controller
    law_inputs = np.zeros((0, n_ticks + 1))
    if law is not None:
        law_inputs = np.atleast_2d(
            as_float_array(law.compiled_inputs(t), "dipole_controller.compiled_inputs(t)")
        ).reshape(-1, n_ticks + 1)
    n_law = law_inputs.shape[0]
    key = _closed_loop_key(model, flight, controller, disturbance, dt, substeps, m, n_row, n_law)

    def build() -> _ClosedLoop:
        return _ClosedLoop(model, flight, controller, disturbance, dt, substeps, m, n_row, n_law)

    loop = build() if key is None else _LOOPS.get(key, build)
    closed_loop, commands_fn, n_u = loop.function, loop.commands, loop.n_u
    columns = inputs if not flight.active else np.concatenate([inputs, flight.rows.T, law_inputs], axis=0)
    x_start = np.concatenate([q0, omega0, h0])
    x_all = np.empty((n_ticks + 1, model.n_x))
    x_all[0] = x_start
    out = np.empty((n_ticks, closed_loop.size1_out(1)))
    for start in range(0, n_ticks, FOLD_TICKS):
        ticks = min(FOLD_TICKS, n_ticks - start)
        x_fold, out_fold = loop.fold(ticks)(x_all[start], columns[:, start : start + ticks])
        x_all[start + 1 : start + ticks + 1] = x_fold.full().T
        out[start : start + ticks] = out_fold.full().T
    finite = np.all(np.isfinite(x_all), axis=1)
    if not np.all(finite):
        k = int(np.argmin(finite))
        _diverged(t[k], x_all[k - 1])
    # The command at the final time, as the Python path computes it.
    last = commands_fn(x_all[-1], columns[:, -1]).full().T
    out = np.concatenate([out, last], axis=0)
    tau_c, tau_a, uu = out[:, :3], out[:, 3:6], out[:, 6 : 6 + n_u]
    orbit = None
    if flight.active:
        o = 6 + n_u
        ns = flight.n_sources
        torques = out[:, o : o + 3 * ns].reshape(-1, ns, 3)
        o += 3 * ns
        field_B, m_cmd, m_B, tau_m = (out[:, o + 3 * i : o + 3 * i + 3] for i in range(4))
        orbit = _orbit_histories(flight, torques, field_B, flight.track.illumination, m_cmd, m_B, tau_m)
    err = _error_angles(controller, t, x_all[:, :4])
    return _finish(model, t, x_all, tau_c, tau_a, uu, err, x_all[:, :4].copy(), x_all[:, 4:7].copy(), {}, orbit)


class SimulationDivergedError(FloatingPointError):
    """The closed loop blew up (an unstable loop, or a tick too long for the rates)."""


def _diverged(t: float, x_before: NDArray) -> None:
    rate = float(np.linalg.norm(x_before[4:7])) if np.all(np.isfinite(x_before[4:7])) else float("inf")
    raise SimulationDivergedError(
        f"the closed-loop state became non-finite at t = {float(t):.6g} s (body rate {rate:.3g} rad/s one tick "
        "before): check the controller gains and sample time, the torque limits, or use more substeps"
    )


def _error_angles(controller: Any, t: NDArray, q: NDArray) -> NDArray:
    if controller is None or not hasattr(controller, "reference"):
        return np.zeros(t.size)
    if hasattr(controller, "reference_samples"):
        q_ref = np.asarray(controller.reference_samples(t)[0], dtype=float)
    else:
        q_ref = np.stack([np.asarray(controller.reference(tk)[0], dtype=float) for tk in t])
    # An all-NaN row: no reference at that time (a mode sequence's detumbling), and no error to log. Any other
    # non-finite row is a broken reference, refused as before.
    has = np.all(np.isfinite(q_ref), axis=-1)
    broken = ~has & ~np.all(np.isnan(q_ref), axis=-1)
    if np.any(broken):
        k = int(np.argmax(broken))
        raise ValueError(
            f"controller reference q_ref must be finite, or all NaN where there is none; got {q_ref[k]} at "
            f"t = {float(t[k]):.6g} s"
        )
    angles = np.full(t.size, np.nan)
    if np.any(has):
        angles[has] = quat.error_angle(q_ref[has], quat.normalize(q[has]))
    return angles


def _run_python(
    model,
    flight,
    controller,
    sensors,
    estimator,
    disturbance,
    q0,
    omega0,
    h0,
    dt,
    n_ticks,
    substeps,
    every,
    rng,
    rule,
):
    """The protocol path: the user's objects in Python, the plant's part of each tick compiled.

    The plant's part (allocation, hold step, the wheels' momentum for the next
    estimate, the step-size rule's projection) is one call per tick
    (:mod:`attitude.simulation.protocol_tick`); ticks that the rule sub-steps
    go through ``rule`` (:class:`TickRule`, which warns) and the casadi hold step.
    """
    gen = as_generator(rng)
    t = np.arange(n_ticks + 1) * dt
    tick = protocol_tick(model, substeps)
    x0 = np.concatenate([q0, omega0, h0])
    h_body0 = np.array([float(v) for v in model.body_momentum(list(x0))])
    runner = TickRunner(tick, model.body, x0, h_body0, n_ticks, dt, rule.budget)
    advance = runner.advance
    x_all = runner.x
    tau_c_all = runner.torque_command
    est_q = np.empty((n_ticks + 1, 4)) if estimator is not None else None
    est_w = np.empty((n_ticks + 1, 3)) if estimator is not None else None
    logs: dict[str, list] = {}
    estimate = Estimate(0.0, q0.copy(), omega0.copy(), h0.copy())
    const_dist = None
    if disturbance is not None and not callable(disturbance):
        const_dist = check_vector(disturbance, "disturbance", 3)
        runner.tau_ext[:] = const_dist
    if flight.active:
        down_N = -flight.track.position_N / np.linalg.norm(flight.track.position_N, axis=-1, keepdims=True)
        env_torques = np.zeros((n_ticks + 1, flight.n_sources, 3))
        field_all = np.zeros((n_ticks + 1, 3))
        m_cmd_all = np.zeros((n_ticks + 1, 3))
        m_B_all = np.zeros((n_ticks + 1, 3))
        tau_m_all = np.zeros((n_ticks + 1, 3))
        m_cmd = np.zeros(3)
        m_B = np.zeros(3)
    law = flight.dipole_controller
    every_controller = every.get("controller", 0)
    controller_logs = controller is not None and hasattr(controller, "log")
    needs_truth = bool(sensors) or estimator is not None or flight.active or callable(disturbance)

    def record(prefix: str, k: int, values: dict) -> None:
        for key, value in values.items():
            name = f"{prefix}.{key}"
            series = logs.get(name)
            if series is None:  # allocated once per series, not per call
                series = logs[name] = [None] * (n_ticks + 1)
            arr = np.asarray(value, dtype=float)
            series[k] = arr.reshape(1) if arr.ndim == 0 else arr

    truth = None
    for k in range(n_ticks + 1):
        tk = k * dt
        # What the user's objects are handed: copies of the record (a controller or sensor may change its arrays
        # in place, or keep them, without touching the run). The truth is one per tick, read by every sensor and
        # the disturbance in turn; the controller's estimate is its own.
        x = x_all[k].copy()
        h_body = runner.h_body[k].copy()
        if needs_truth:
            q_unit = x[:4] / np.linalg.norm(x[:4])
            if flight.active:
                torques_k, field_B, sun_B = flight.at_tick(k, q_unit)
                env_torques[k], field_all[k] = torques_k, field_B
                nadir_B = np.array(quat.rotate_inverse_components(q_unit.tolist(), down_N[k].tolist()))
                illumination = float(flight.track.illumination[k])
                truth = Truth(tk, q_unit, x[4:7], x[7:], field_B, sun_B, illumination, nadir_B)
            else:
                truth = Truth(tk, q_unit, x[4:7], x[7:])
        if sensors or estimator is not None:
            prev = tau_c_all[k - 1] if k > 0 else tau_c_all[0]
            measurements: dict[str, Any] = {"torque_command": prev.copy(), "wheel_momentum": truth.h_wheels}
            samples: dict[str, Any] = {}
            for s in sensors:
                sample = None
                if k % every[f"sensor {s.name}"] == 0:
                    sample = s.measure(tk, truth, gen)
                    if isinstance(sample, VectorMeasurement):
                        # Logged as numbers: the measured direction and its reference.
                        record("sensor", k, {s.name: sample.vector_B, f"{s.name}.reference_N": sample.reference_N})
                    elif sample is not None:
                        record("sensor", k, {s.name: sample})
                measurements[s.name] = sample
                samples[s.name] = sample
        elif law is not None:
            samples = {}
        if estimator is not None:
            if k % every["estimator"] == 0:
                estimate = estimator.update(tk, measurements)
                if not isinstance(estimate, Estimate):
                    raise ValueError(
                        f"estimator.update(t, measurements) must return an attitude.simulation.Estimate, "
                        f"got {type(estimate).__name__} at t = {tk:.6g} s"
                    )
                if hasattr(estimator, "log"):
                    record("estimator", k, estimator.log())
            if type(estimate) is Estimate:
                estimate = Estimate(estimate.t, estimate.q, estimate.omega, x[7:], h_body, estimate.covariance)
            else:  # a subclass keeps its own fields
                estimate = dataclasses.replace(estimate, h_wheels=x[7:], h_body=h_body)
            est_q[k] = estimate.q
            est_w[k] = estimate.omega
        elif truth is None:
            # The engine renormalises the quaternion at every RK4 step: x[:4] is the unit attitude.
            estimate = Estimate(tk, x[:4], x[4:7], x[7:], h_body)
        else:  # the controller's own arrays, apart from the truth the sensors and the disturbance read
            estimate = Estimate(tk, x[:4].copy(), x[4:7].copy(), x[7:].copy(), h_body)
        sample_now = 0
        if controller is not None and k % every_controller == 0:
            tau = controller.torque(tk, estimate)
            if type(tau) is not np.ndarray or tau.shape != (3,) or tau.dtype != np.float64:
                tau = check_vector(tau, "controller.torque(t, estimate)", 3).reshape(3)
            tau_c_all[k] = tau
            sample_now = 1
            if controller_logs:
                record("controller", k, controller.log())
        if law is not None and k % every["dipole_controller"] == 0:
            m_cmd = flight.dipole_command(tk, samples, h_body, field_B)
            m_B = flight.delivered_dipole(m_cmd)
            if hasattr(law, "log"):
                record("dipole_controller", k, law.log())
        if k < n_ticks:
            if callable(disturbance):
                runner.tau_ext[:] = check_vector(disturbance(tk, truth.q, truth.omega), "disturbance(t, q, omega)", 3)
            if flight.active:
                tau_ext = env_torques[k].sum(axis=0) + (0.0 if const_dist is None else const_dist)
                if callable(disturbance):
                    tau_ext = tau_ext + runner.tau_ext
                if flight.magnetorquers is not None:
                    tau_m = flight.magnetorquer_torque(m_B, field_B)
                    m_cmd_all[k], m_B_all[k], tau_m_all[k] = m_cmd, m_B, tau_m
                    tau_ext = tau_ext + tau_m
                runner.tau_ext[:] = tau_ext
        done = advance(k, sample_now)
        if done == DONE:
            continue
        if done == COMMAND_NOT_FINITE:
            check_vector(tau_c_all[k], "controller.torque(t, estimate)", 3)  # names the non-finite command
        if done == STATE_NOT_FINITE:
            _diverged(t[k + 1], x)
        if done != SUBSTEP:
            raise RuntimeError(f"the protocol tick failed at t = {tk:.6g} s (code {done})")
        # The rule asks for more than one hold step this tick: TickRule chooses the count (and warns).
        rule.turned, rule.swept, rule.varied, rule.largest = runner.rule.tolist()
        u, tau_ext = runner.motor_torque[k], runner.tau_ext.copy()
        calls = rule.calls(k, x[4:7], x[7:], runner.torque_applied[k] + tau_ext)
        runner.rule[:] = (rule.turned, rule.swept, rule.varied, rule.largest)
        if calls > 1:  # the commands held over the tick, the plant in shorter steps
            step = model.compiled_step(substeps)
            x_next = np.array(x)
            for _ in range(calls):
                x_next = np.array(step(x_next, u, tau_ext, dt / calls)).ravel()
            x_all[k + 1] = x_next
            runner.h_body[k + 1] = [float(v) for v in model.body_momentum(list(x_next))]
        if not np.all(np.isfinite(x_all[k + 1])):
            _diverged(t[k + 1], x)

    rule.turned, rule.swept, rule.varied, rule.largest = runner.rule.tolist()
    rows = slice(0, n_ticks + 1)
    x_all = x_all[rows].copy()
    orbit = None
    if flight.active:
        if flight.magnetorquers is not None:  # the last row, as the other commands: what would be held from t_end
            m_cmd_all[-1], m_B_all[-1], tau_m_all[-1] = m_cmd, m_B, flight.magnetorquer_torque(m_B, field_all[-1])
        orbit = _orbit_histories(
            flight, env_torques, field_all, flight.track.illumination.copy(), m_cmd_all, m_B_all, tau_m_all
        )
    err = _error_angles(controller, t, x_all[:, :4])
    packed = {}
    for key, series in logs.items():
        width = max(v.size for v in series if v is not None)
        arr = np.full((n_ticks + 1, width), np.nan)
        for i, v in enumerate(series):
            if v is not None:
                arr[i, : v.size] = v
        packed[key] = arr
    for s in sensors:  # a sensor that never sampled (e.g. blinded) still gets its column
        packed.setdefault(f"sensor.{s.name}", np.full((n_ticks + 1, 0), np.nan))
    u_all = runner.motor_torque[rows].copy() if model.wheels is not None else np.zeros((n_ticks + 1, 0))
    if est_q is None:
        est_q, est_w = x_all[:, :4].copy(), x_all[:, 4:7].copy()
    result = _finish(
        model,
        t,
        x_all,
        tau_c_all[rows].copy(),
        runner.torque_applied[rows].copy(),
        u_all,
        err,
        est_q,
        est_w,
        packed,
        orbit,
    )
    available = "C" if runner.compiled else f"casadi (the C tick is not available: {tick.compile_error})"
    result.info["protocol_tick"] = available
    return result


def _warn_over_budget(step_rule: dict[str, Any]) -> None:
    """Warn when the rates actually flown predict an attitude error over the budget (the run's own figure)."""
    error, budget = step_rule["predicted_error_rad"], step_rule["budget_rad"]
    if np.isfinite(error) and error > budget:
        warnings.warn(
            f"simulate: the result is NOT within the attitude-error budget: the rates flown predict "
            f"{attitude_error_text(error, 4)} against {budget:.4g} rad (docs/rk4_step_rule.md; the figure is a "
            "bound and may overstate); pass a shorter dt or more substeps, or a larger attitude_error_budget_rad",
            StepSizeWarning,
            stacklevel=3,
        )

"""The fixed-step rule (docs/rk4_step_rule.md) applied to the closed loop's plant, tick by tick.

The plant is RK4 over each tick with the commands held
(:meth:`attitude.simulation.plant.PlantModel.hold_step`). :class:`TickRule`
checks :func:`attitude.integrators.predicted_attitude_error` at every tick
on the rate reached, projecting it over the ticks left, and asks for more
steps per tick when the accumulated attitude error would exceed the budget.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from attitude import backend as bk
from attitude.integrators import (
    MAX_RULE_SUBSTEPS,
    VARYING_RATE_WEIGHT,
    StepSizeWarning,
    attitude_error_text,
    fifth_derivative_excess,
    predicted_attitude_error,
    rule_formula,
    rule_rates,
    substeps_for_budget,
)
from attitude.simulation.plant import PlantModel

__all__ = [
    "TickRule",
    "batch_broken",
    "batch_needed_substeps",
    "batch_substeps",
    "history_substeps",
    "tick_advance",
    "tick_projection",
    "tick_rule_rates",
]


def _rule_rates(
    model: PlantModel, omega: NDArray[np.float64], h: NDArray[np.float64], torque: Any = None
) -> tuple[Any, Any, Any]:
    """:func:`attitude.integrators.rule_rates` of the plant (wheel momentum and the applied body torque [N m])."""
    h_b = None if model.wheels is None else h @ model.wheels.distribution.T
    return rule_rates(model.body, omega, h_b, torque)


class TickRule:
    """Steps per tick that keep the plant's accumulated attitude error within a budget.

    Parameters
    ----------
    model : PlantModel
        The plant (hub body and wheels).
    dt : float
        Tick [s].
    n_ticks : int
        Ticks in the run.
    substeps : int
        RK4 steps per tick asked for.
    budget_rad : float
        Accumulated attitude-error budget [rad].
    """

    def __init__(self, model: PlantModel, dt: float, n_ticks: int, substeps: int, budget_rad: float) -> None:
        self.model, self.dt, self.n_ticks, self.substeps, self.budget = model, dt, n_ticks, substeps, budget_rad
        self.turned = 0.0  # Theta so far [rad]
        self.swept = 0.0  # Phi so far [rad]
        self.varied = 0.0  # sum of c Xi h h_s^4 so far [rad] (the varying-rate term)
        self.largest = 0.0  # largest rotation per RK4 step so far [rad]
        self.warned = False
        self.over = False
        # Plain floats: the check runs every tick of the Python engine and must cost next to nothing.
        self._inertia = model.body.inertia.tolist()
        self._inverse = model.body.inertia_inv.tolist()
        self._distribution = None if model.wheels is None else model.wheels.distribution.tolist()
        self.most_calls = 1

    def calls(self, k: int, omega: NDArray[np.float64], h: NDArray[np.float64], torque: Any = None) -> int:
        """Hold steps (of ``substeps`` RK4 steps each, over ``dt / calls``) for tick ``k`` at rate ``omega``.

        Parameters
        ----------
        k : int
            Tick index.
        omega : ndarray (3,)
            Body rate at the tick [rad/s].
        h : ndarray (n,)
            Wheel momenta at the tick [N m s].
        torque : array_like (3,), optional
            Body torque applied over the tick [N m] (control and disturbance): its
            component across ``omega`` turns the rate vector (docs/rk4_step_rule.md).

        Returns
        -------
        int
            1 where the rule holds.

        Raises
        ------
        ValueError
            If meeting the rule at the first tick needs more than
            :data:`attitude.integrators.MAX_RULE_SUBSTEPS` calls (later, a warning: see the comment).
        """
        try:
            rate, turn, excess = self._rule_rates(omega, h, torque)
        except OverflowError:  # float arithmetic raises where numpy returns inf: a blowing-up loop
            rate = turn = excess = math.inf
        if not (math.isfinite(rate) and math.isfinite(turn) and math.isfinite(excess)):
            return 1  # the engine reports the divergence
        left = self.n_ticks - k
        state = (self.turned, self.swept, self.varied, self.largest)
        angle, turned, swept, per_call, error_one_call = tick_projection(
            state, rate, turn, excess, left, self.dt, self.substeps
        )

        def error_at(calls: int, past_theta: float, past_varied: float) -> float:
            theta_k = max(past_theta, angle / (calls * self.substeps))
            return _error(turned, swept, theta_k, past_varied + per_call / calls**4)

        calls = 1
        theta = angle / self.substeps
        if error_one_call > self.budget:
            theta_s = (1920.0 * self.budget / ((1.0 + 2.0 * swept) * turned)) ** 0.25
            calls = max(1, math.ceil(theta / theta_s))
            # The smallest count (in 12 % rises) that meets the budget. Where the steps already taken, projected
            # over the ticks left, exceed it on their own, no count can: then the smallest that meets it on the
            # steps still to come, and the end of the run says the result is NOT within the budget.
            past = (self.largest, self.varied)
            if _error(turned, swept, self.largest, self.varied) > self.budget:
                past = (0.0, 0.0)
            while error_at(calls, *past) > self.budget and calls <= MAX_RULE_SUBSTEPS:
                calls += max(1, calls // 8)
            if calls > MAX_RULE_SUBSTEPS:
                message = (
                    f"{self._rule(rate, k, turned, swept)}; meeting it needs {calls * self.substeps} RK4 steps per "
                    f"tick, more than {MAX_RULE_SUBSTEPS * self.substeps}"
                )
                if k == 0:
                    raise ValueError(f"{message}: shorten dt or raise substeps")
                # Rates grown this far mid-run are an unstable loop more often than a fast spin: the run goes on
                # at the steps asked, warned, and the engine names a divergence if it comes.
                calls = 1
                if not self.over:
                    self.over = True
                    warnings.warn(
                        f"{message}; the run goes on without sub-stepping and its attitude is NOT within the budget",
                        StepSizeWarning,
                        stacklevel=4,
                    )
            if calls > 1 and not self.warned:
                self.warned = True
                warnings.warn(
                    f"{self._rule(rate, k, turned, swept)}; the plant is sub-stepped to {calls * self.substeps} "
                    "RK4 steps per tick with the commands held (substeps sets the steps per tick, "
                    "attitude_error_budget_rad the budget)",
                    StepSizeWarning,
                    stacklevel=4,
                )
        self.turned, self.swept, self.varied, self.largest = tick_advance(
            state, angle, turn, per_call / calls**4, left, self.dt, theta / calls
        )
        self.most_calls = max(self.most_calls, calls)
        return calls

    def _rule_rates(
        self, omega: NDArray[np.float64], h: NDArray[np.float64], torque: Any
    ) -> tuple[float, float, float]:
        """:func:`_rule_rates` of one state on floats (:func:`tick_rule_rates`)."""
        w = [float(v) for v in omega]
        hs = None if self._distribution is None else [float(v) for v in h]
        tau = None if torque is None else [float(v) for v in torque]
        return tick_rule_rates(self._inertia, self._inverse, self._distribution, w, hs, tau, sqrt=math.sqrt)

    def _rule(self, rate: float, k: int, turned: float, swept: float) -> str:
        error = _error(turned, swept, max(self.largest, rate * self.dt / self.substeps), self.varied)
        return (
            f"simulate breaks the step-size rule {rule_formula()} <= {self.budget:.3g} rad "
            f"(docs/rk4_step_rule.md) at t = {k * self.dt:.6g} s: body rate {rate:.3g} rad/s with "
            f"{self.substeps} RK4 step(s) per tick of {self.dt:.3g} s "
            f"(|omega| h = {rate * self.dt / self.substeps:.3g} rad per step) predicts an accumulated attitude "
            f"error of {attitude_error_text(error)}"
        )

    def info(self) -> dict[str, Any]:
        """The run's ``info["step_rule"]``: predicted error [rad], budget [rad], most calls per tick."""
        return {
            "predicted_error_rad": _error(self.turned, self.swept, self.largest, self.varied),
            "budget_rad": self.budget,
            "substeps_added": self.most_calls > 1,
            "most_substeps_per_tick": self.most_calls * self.substeps,
        }


def tick_rule_rates(
    inertia: Sequence[Sequence[Any]],
    inverse: Sequence[Sequence[Any]],
    distribution: Sequence[Sequence[Any]] | None,
    omega: Sequence[Any],
    h: Sequence[Any] | None,
    torque: Sequence[Any] | None,
    *,
    sqrt: Callable[[Any], Any] = bk.sqrt,
) -> tuple[Any, Any, Any]:
    """:func:`attitude.integrators.rule_rates` of one tick on components: floats or casadi symbols.

    The one definition :class:`TickRule` evaluates on floats and the compiled
    tick of the protocol engine (:mod:`attitude.simulation.protocol_tick`) on
    symbols.

    Parameters
    ----------
    inertia, inverse : 3 x 3 nested sequences
        Hub inertia [kg m^2] and its inverse [1/(kg m^2)] (numbers or symbols).
    distribution : 3 x n nested sequence or None
        Wheel spin axes as columns (None without wheels).
    omega : sequence of 3
        Body rate [rad/s].
    h : sequence of n or None
        Wheel momenta [N m s] (None without wheels).
    torque : sequence of 3 or None
        Body torque applied over the tick [N m]; None: torque-free.
    sqrt : callable
        Square root of the backend (``math.sqrt`` on floats is the fast one).

    Returns
    -------
    rate, turn, excess
        ``|omega|`` [rad/s], the gyroscopic turn rate [rad/s] and the
        fifth-derivative excess [rad^5/s^5].
    """
    w = list(omega)
    m = [sum(a * b for a, b in zip(row, w)) for row in inertia]
    if distribution is not None and h is not None:
        m = [mi + sum(a * b for a, b in zip(row, h)) for mi, row in zip(m, distribution)]
    c = [w[1] * m[2] - w[2] * m[1], w[2] * m[0] - w[0] * m[2], w[0] * m[1] - w[1] * m[0]]
    accel = sqrt(sum(sum(a * b for a, b in zip(row, c)) ** 2 for row in inverse))
    rate = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    if bk.is_symbolic(rate):
        turn = bk.if_else(rate > 0.0, accel / rate, 0.0 * rate)
    else:
        turn = accel / rate if rate > 0.0 else 0.0
    # The applied torque enters the varying-rate term through |omega'| = |I^-1 (tau - w x m)|, not Phi.
    acceleration = accel
    if torque is not None:
        net = [v - ci for v, ci in zip(torque, c)]
        acceleration = sqrt(sum(sum(a * b for a, b in zip(row, net)) ** 2 for row in inverse))
    # Jacobian of Euler's equations, I^-1 ([m]x - [w]x I), for its Frobenius norm.
    skew_m = [[0.0, -m[2], m[1]], [m[2], 0.0, -m[0]], [-m[1], m[0], 0.0]]
    skew_w = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
    inner = [[skew_m[i][j] - sum(skew_w[i][n] * inertia[n][j] for n in range(3)) for j in range(3)] for i in range(3)]
    growth = sqrt(sum(sum(inverse[i][n] * inner[n][j] for n in range(3)) ** 2 for i in range(3) for j in range(3)))
    return rate, turn, fifth_derivative_excess(rate, acceleration, growth)


def tick_projection(
    state: Sequence[Any], rate: Any, turn: Any, excess: Any, left: Any, dt: Any, substeps: int
) -> tuple[Any, Any, Any, Any, Any]:
    """The rule's projection over the ticks left at one RK4 hold step per tick, on floats or symbols.

    Parameters
    ----------
    state : sequence of 4
        :class:`TickRule`'s running sums ``(turned, swept, varied, largest)`` [rad].
    rate, turn, excess
        :func:`tick_rule_rates` of the tick.
    left : int or symbol
        Ticks left in the run, this one included (>= 1).
    dt : float or symbol
        Tick [s].
    substeps : int
        RK4 steps per hold step.

    Returns
    -------
    tuple
        ``(angle, turned, swept, per_call, error)``: the tick's rotation
        ``|omega| dt`` [rad], the projected ``Theta`` and ``Phi`` [rad], the
        varying-rate term of the ticks left at one call [rad] and the predicted
        error [rad] of the run if every tick left takes one call.
    """
    turned, swept, varied, largest = state
    angle = rate * dt
    turned_left, swept_left = turned + angle * left, swept + turn * dt * left
    per_call = VARYING_RATE_WEIGHT * excess * dt * (dt / substeps) ** 4 * left
    theta = angle / substeps
    largest_now = bk.fmax(largest, theta) if bk.is_symbolic(theta) else max(largest, theta)
    return angle, turned_left, swept_left, per_call, _error(turned_left, swept_left, largest_now, varied + per_call)


def tick_advance(state: Sequence[Any], angle: Any, turn: Any, per_call: Any, left: Any, dt: Any, theta: Any) -> list:
    """:class:`TickRule`'s running sums after a tick of one call (hold step) per tick, on floats or symbols.

    Parameters
    ----------
    state : sequence of 4
        ``(turned, swept, varied, largest)`` before the tick [rad].
    angle, turn, per_call
        From :func:`tick_projection`.
    left : int or symbol
        Ticks left, this one included.
    dt : float or symbol
        Tick [s].
    theta : float or symbol
        The tick's rotation per RK4 step [rad].

    Returns
    -------
    list of 4
        The sums after the tick.
    """
    turned, swept, varied, largest = state
    largest_next = bk.fmax(largest, theta) if bk.is_symbolic(theta) else max(largest, theta)
    return [turned + angle, swept + turn * dt, varied + per_call / left, largest_next]


def _error(turned: float, swept: float, theta: float, varied: float = 0.0) -> float:
    """``[(1 + 2 Phi) Theta theta^4 + varied] / 1920`` [rad]: :func:`attitude.integrators.predicted_attitude_error`
    on floats, ``varied`` being its weighted varying-rate sum ``c sum Xi h h_s^4``.

    Written out because the Python engine evaluates it every tick; ``tests/attitude/simulation/test_step_rule.py``
    checks the two agree.
    """
    return ((1.0 + 2.0 * swept) * turned * theta**4 + varied) / 1920.0


def history_substeps(
    model: PlantModel,
    x: NDArray[np.float64],
    dt: float,
    n_ticks: int,
    substeps: int,
    budget_rad: float,
    torque: Any = None,
) -> tuple[int, float]:
    """RK4 steps per tick (one count for the whole run) that a state history asks for, and its predicted error.

    Parameters
    ----------
    model : PlantModel
        The plant.
    x : ndarray (n_ticks + 1, 7 + n_w) or (7 + n_w,)
        States at the ticks (or the initial state alone, held over ``n_ticks``).
    dt : float
        Tick [s].
    n_ticks : int
        Ticks in the run.
    substeps : int
        RK4 steps per tick of that history.
    budget_rad : float
        Accumulated attitude-error budget [rad].
    torque : array_like (n_ticks + 1, 3) or (3,), optional
        Body torque applied at the ticks [N m] (control and disturbance), for the turn rate.

    Returns
    -------
    tuple
        ``(steps per tick >= substeps, predicted error [rad] at substeps)``.
    """
    rates = [np.atleast_1d(value) for value in _rule_rates(model, x[..., 4:7], x[..., 7:], torque)]
    if rates[0].size > 1:
        rate, turn, excess = (np.maximum(value[:-1], value[1:]) for value in rates)
    else:
        rate, turn, excess = (np.full(n_ticks, value[0]) for value in rates)
    error = float(predicted_attitude_error(rate, dt, turn, substeps=substeps, method="rk4", excess_rad5_s5=excess))
    if not math.isfinite(error) or error <= budget_rad:
        return substeps, error
    # One count for the whole run: the most any tick needs under the integrators' one allocation.
    needed = substeps_for_budget(
        rate, dt, turn, substeps=substeps, budget_rad=budget_rad, method="rk4", excess_rad5_s5=excess
    )
    return int(np.max(needed)), error


def _batch_turn_bound(model: PlantModel, rate: NDArray[np.float64]) -> NDArray[np.float64]:
    """Largest gyroscopic turn rate at body rate ``rate`` [rad/s]: ``(I_max / I_min) |omega| + |A| |h|_max / I_min``.

    The batch bounds carry the ``Phi`` term only: on this worst case (the wheels' momentum at its limit across
    the rate) the varying-rate majorant flags every wheeled run, so it is evaluated where the states flown
    are known, in ``propagate`` and ``simulate`` (docs/rk4_step_rule.md).
    """
    moments = np.linalg.eigvalsh(model.body.inertia)
    nu = moments[..., -1] / moments[..., 0] * rate
    if model.wheels is not None:  # the wheels at their momentum limits
        h_max = np.linalg.norm(model.wheels.distribution, 2) * np.linalg.norm(model.wheels.momentum_max)
        nu = nu + h_max / moments[..., 0]
    return nu


def batch_substeps(
    model: PlantModel,
    omega0: NDArray[np.float64],
    dt: float,
    n_ticks: int,
    substeps: int,
    budget_rad: float,
) -> tuple[int, NDArray[np.bool_]]:
    """RK4 steps per tick for a vectorised batch, chosen before the run from every run's initial rate.

    The batch cannot sub-step one run mid-run, so the check is a bound: the
    rate is the larger of ``|omega0|`` and the torque-free energy bound
    ``sqrt(omega . I omega / I_min)``, held over the run, and the turn rate
    its largest (:func:`batch_broken` then flags the runs that went faster).
    A run that would need more than :data:`attitude.integrators.MAX_RULE_SUBSTEPS`
    times ``substeps`` is left out of the count and returned as refused: one
    wild dispersion must not slow or stop the others.

    Parameters
    ----------
    model : PlantModel
        The plant (hub body single or batched, wheels).
    omega0 : ndarray (N, 3)
        Initial body rates [rad/s].
    dt : float
        Tick [s].
    n_ticks : int
        Ticks in the run.
    substeps : int
        RK4 steps per tick asked for.
    budget_rad : float
        Accumulated attitude-error budget [rad].

    Returns
    -------
    tuple
        ``(steps per tick >= substeps, refused (N,) bool)``; a
        :class:`attitude.integrators.StepSizeWarning` when steps were added
        or runs refused.
    """
    i_min = np.linalg.eigvalsh(model.body.inertia)[..., 0]
    energy = np.einsum("...i,...ij,...j->...", omega0, model.body.inertia, omega0)
    rate = np.maximum(np.linalg.norm(omega0, axis=-1), np.sqrt(energy / i_min))
    needed = batch_needed_substeps(model, rate, dt, n_ticks, substeps, budget_rad)
    refused = needed > MAX_RULE_SUBSTEPS * substeps
    steps = int(max(substeps, np.max(needed[~refused], initial=substeps)))
    if steps == substeps and not np.any(refused):
        return substeps, refused
    worst = int(np.argmax(np.where(refused, -np.inf, rate)))
    message = (
        f"the batch breaks the step-size rule {rule_formula()} <= {budget_rad:.3g} rad "
        f"(docs/rk4_step_rule.md) with {substeps} RK4 step(s) per tick of {dt:.3g} s"
    )
    if steps > substeps:
        message += (
            f": body rate up to {float(rate[worst]):.3g} rad/s (run {worst}); every run is sub-stepped to {steps}"
        )
    if np.any(refused):
        message += (
            f"; {int(np.sum(refused))} run(s) (first: run {int(np.argmax(refused))}) would need more than "
            f"{MAX_RULE_SUBSTEPS * substeps} RK4 steps per tick and are reported as failed (shorten dt)"
        )
    warnings.warn(message, StepSizeWarning, stacklevel=3)
    return steps, refused


def batch_needed_substeps(
    model: PlantModel, rate: NDArray[np.float64], dt: float, n_ticks: int, substeps: int, budget_rad: float
) -> NDArray[np.float64]:
    """RK4 steps per tick each run of a batch needs at a body rate held over the run (the batch bound).

    Parameters
    ----------
    model : PlantModel
        The plant.
    rate : ndarray (N,)
        Each run's body rate [rad/s] (the largest assumed or reached).
    dt : float
        Tick [s].
    n_ticks : int
        Ticks in the run.
    substeps : int
        RK4 steps per tick asked for (returned where they meet the budget).
    budget_rad : float
        Accumulated attitude-error budget [rad].

    Returns
    -------
    ndarray (N,)
        Steps per tick (whole numbers as floats; NaN where the rate is not finite).
    """
    nu = _batch_turn_bound(model, rate)
    duration = n_ticks * dt
    error = predicted_attitude_error(rate[:, None], duration, nu[:, None], substeps=n_ticks * substeps)
    with np.errstate(divide="ignore", invalid="ignore"):
        theta_s = (1920.0 * budget_rad / ((1.0 + 2.0 * nu * duration) * rate * duration)) ** 0.25
        return np.where(error > budget_rad, np.ceil(rate * dt / theta_s), substeps)


def batch_broken(
    model: PlantModel, rate_peak: NDArray[np.float64], dt: float, n_ticks: int, substeps: int, budget_rad: float
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Runs of a batch whose peak rate may have broken the rule mid-run, and their error bound [rad].

    The bound of :func:`batch_substeps` at each run's peak rate: a run that
    stayed below the rate assumed before the run is never flagged.

    Parameters
    ----------
    model : PlantModel
        The plant.
    rate_peak : ndarray (N,)
        Each run's largest body rate [rad/s] (NaN for a diverged run: not flagged).
    dt : float
        Tick [s].
    n_ticks : int
        Ticks in the run.
    substeps : int
        RK4 steps per tick flown.
    budget_rad : float
        Accumulated attitude-error budget [rad].

    Returns
    -------
    tuple
        ``(broken (N,) bool, bound (N,) [rad])``.
    """
    nu = _batch_turn_bound(model, rate_peak)
    bound = predicted_attitude_error(rate_peak[:, None], n_ticks * dt, nu[:, None], substeps=n_ticks * substeps)
    return np.isfinite(bound) & (bound > budget_rad), bound

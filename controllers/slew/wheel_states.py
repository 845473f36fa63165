"""Slews planned on the wheels themselves: motor torques as controls, wheel momenta as states (casadi + IPOPT).

Part of :mod:`controllers.slew.planner`: ``plan_slew(..., torque_max=wheels,
wheel_states=True)`` lands here after its common checks. The plan's state is
the simulation engine's, ``x = [q, omega, h]`` with ``h`` the absolute
spin-axis momentum of each wheel; its controls are the motor torques ``u``
(``|u_i| <= torque_max_i``), whose reaction on the body is ``-A u``
(:class:`attitude.actuators.ReactionWheels`). The dynamics are the hold step of
:class:`attitude.simulation.plant.PlantModel` (the hub body with the wheels'
gyroscopic coupling ``omega x (I_s omega + A h)`` and their friction), so the
plan obeys the equations the engine flies. Each wheel's momentum relative to
the body, ``J_i Omega_i = h_i - J_i a_i . omega``, stays within
``momentum_max_i`` (the wheel-speed limit) at every checkpoint; the body-rate
limit is a separate, optional requirement.

The body torques the wheels can make form the zonotope ``{-A u : |u_i| <=
torque_max_i}`` (:func:`wheel_torque_rows`); the minimum-norm allocation
envelope of ``plan_slew(torque_max=wheels)`` is a subset of it that ignores
the null space, and a per-axis box inside it (:func:`wheel_torque_box`) is
smaller still. Out of scope: magnetorquer-assisted slews (magnetic torque
during the slew) and momentum-biased slews (a commanded non-zero wheel
momentum bias held as a requirement); refinement, keep-out cones, warm
starts and smoothing are not available with wheel states (refused).
Pontryagin's conditions are checked on the motor torques, from the NLP's
multipliers as for the rigid plans (:func:`wheel_pontryagin_check`). See
docs/slew_planning.md, Reaction-wheel polytope and wheel momentum.
"""

from __future__ import annotations

import itertools
import time
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import linprog

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.rigid_body import RigidBody
from attitude.simulation.plant import PlantModel
from attitude.validation import as_float_array
from controllers.slew.checks import CHECK_SAMPLES
from controllers.slew.guess import StartSpec, base_guess, family_guess, perturbed
from controllers.slew.keep_out import KeepOutCone
from controllers.slew.multistart import start_report
from controllers.slew.optimality import (
    HAMILTONIAN_TOLERANCE,
    NOT_CHECKED_JUNCTIONS,
    SWITCHING_TOLERANCE,
    SWITCHING_ZERO_FRACTION,
    costate_physical,
    interval_costates,
    intervals_to_check,
    pontryagin_conditions,
)
from controllers.slew.plan import SlewPlan, cone_arrays
from controllers.slew.problem import INFEASIBLE, InfeasibleSlewError, Problem, SlewPlanningError
from controllers.slew.transcription import IntervalFunction, Solution, Transcription, ipopt_setup, objective_terms

__all__ = [
    "HAMILTONIAN_WHEEL_FACTOR",
    "TORQUE_BOUND_TOLERANCE",
    "check_wheel_state_options",
    "plan_with_wheel_states",
    "scaled_wheels",
    "verify_wheels",
    "wheel_interval_function",
    "wheel_pontryagin_check",
    "wheel_torque_box",
    "wheel_torque_rows",
]


#: Largest accepted relative excess of an optimiser's motor torque over its
#: ``torque_max`` before it is clipped. IPOPT keeps each variable within its
#: bound relaxed by ``bound_relax_factor`` (1e-8) times ``max(1, |bound|)`` on
#: the nondimensional torques: ``1e-8 / bound`` relative for a bound below 1
#: (measured 1.8e-8 to 2.3e-8 on eighteen pyramid slews); 1e-6 allows bounds
#: down to 0.01 of the torque unit. A torque further out is a wrong answer,
#: not IPOPT's tolerance.
TORQUE_BOUND_TOLERANCE = 1e-6

#: A wheel-state plan (a uniform-grid answer: no refinement) is flagged when
#: ``max |H|`` exceeds ``HAMILTONIAN_WHEEL_FACTOR / n`` (no path constraint
#: active; with one, ``H`` is reported, not judged, as for the rigid plans).
#: Measured ``n max |H|`` over the pyramid slews of docs/slew_planning.md on
#: 20 to 120 nodes: at most 0.52 without friction (the rigid plans: 1.95), up
#: to 5.2 with viscous and Coulomb friction (``H`` constant on each arc, offset
#: between arcs, the offsets shrinking as O(1/n)); 10 leaves a factor 2.
HAMILTONIAN_WHEEL_FACTOR = 10.0


def wheel_torque_rows(wheels: ReactionWheels) -> NDArray[np.float64]:
    """The body torques the wheels can make, ``{-A u : |u_i| <= torque_max_i}``, as ``|rows @ tau| <= 1``.

    The set is a zonotope; in three dimensions each facet is parallel to two
    non-parallel wheel axes, so its normals are the cross products
    ``n = a_i x a_j`` and its half-width along ``n`` is the support
    ``sum_k |n . a_k| torque_max_k``. The rows are the normals over their
    half-widths, one per pair (parallel pairs skipped).

    Parameters
    ----------
    wheels : ReactionWheels
        The wheel set (axes and ``torque_max`` [N m]).

    Returns
    -------
    ndarray, shape (m, 3)
        Rows [1/(N m)] of the set ``|rows @ tau| <= 1``.
    """
    if not isinstance(wheels, ReactionWheels):
        raise ValueError(f"wheels must be a ReactionWheels, got {type(wheels).__name__}")
    axes = wheels.axes_B
    rows = []
    for i, j in itertools.combinations(range(wheels.n_wheels), 2):
        normal = np.cross(axes[i], axes[j])
        size = float(np.linalg.norm(normal))
        if size < 1e-9:
            continue
        normal /= size
        rows.append(normal / float(np.sum(np.abs(axes @ normal) * wheels.torque_max)))
    return np.array(rows)


def wheel_torque_box(wheels: ReactionWheels) -> NDArray[np.float64]:
    """The largest per-axis torque box inside the wheels' torque zonotope [N m] (3,).

    The box keeps the proportions of the zonotope's per-axis reach
    ``sum_i |A_ki| torque_max_i`` and is scaled until a corner touches a
    facet: every torque in it is available in every direction at once, which
    is what a per-axis ``torque_max`` promises.

    Parameters
    ----------
    wheels : ReactionWheels
        The wheel set.
    """
    rows = wheel_torque_rows(wheels)
    reach = np.abs(wheels.distribution) @ wheels.torque_max
    return reach / float(np.max(np.abs(rows) @ reach))


def scaled_wheels(wheels: ReactionWheels, j_s: float, t_s: float) -> ReactionWheels:
    """The wheel set in the planner's units: inertia ``j_s``, time ``t_s`` (torque ``j_s / t_s^2``).

    Parameters
    ----------
    wheels : ReactionWheels
        The wheel set [SI].
    j_s : float
        Inertia scale [kg m^2].
    t_s : float
        Time scale [s].
    """
    tau_s = j_s / t_s**2
    return ReactionWheels(
        wheels.axes_B,
        spin_inertia=wheels.spin_inertia / j_s,
        torque_max=wheels.torque_max / tau_s,
        momentum_max=wheels.momentum_max * t_s / j_s,
        viscous_friction=wheels.viscous_friction * t_s / j_s,
        coulomb_friction=wheels.coulomb_friction / tau_s,
        coulomb_smoothing_speed=wheels.coulomb_smoothing_speed * t_s,
    )


def wheel_interval_function(prob: Problem, wheels_s: ReactionWheels) -> IntervalFunction:
    """One multiple-shooting interval of the hub and its wheels, with rate-limit and wheel-speed rows.

    The step is :meth:`PlantModel.compiled_step` of the nondimensional hub
    body and wheels (one RK4 step per sub-step); the rows hold
    ``|omega|^2 <= rate_max^2`` (when set) and ``|J_i Omega_i| <=
    momentum_max_i`` at every sub-step boundary.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem (its ``body_s`` is the whole spacecraft).
    wheels_s : ReactionWheels
        The wheel set in the problem's units (:func:`scaled_wheels`).
    """
    n_w = wheels_s.n_wheels
    step = PlantModel(wheels_s.hub_body(prob.body_s), wheels_s).compiled_step(1)
    x = ca.SX.sym("x", 7 + n_w)
    u = ca.SX.sym("u", n_w)
    h = ca.SX.sym("h")
    x_next = ca.SX.sym("x_next", 7 + n_w)
    states = [x]
    for _ in range(prob.substeps):
        states.append(step(states[-1], u, ca.SX.zeros(3), h / prob.substeps))
    g = []
    for p in [*states[1:-1], x_next]:
        if prob.rate_max_scaled is not None:
            g.append(ca.sumsqr(p[4:7]) - prob.rate_max_scaled**2)
        omega = [p[4 + k] for k in range(3)]
        speed = wheels_s.wheel_speed_components([p[7 + i] for i in range(n_w)], omega)
        for i in range(n_w):
            relative = wheels_s.spin_inertia[i] * speed[i] / wheels_s.momentum_max[i]
            g += [relative - 1.0, -relative - 1.0]
    fun = ca.Function(
        "wheel_slew_interval", [x, u, h, x_next], [states[-1] - x_next, ca.vertcat(*g), ca.SX(0, 1), ca.SX(0, 1)]
    )
    return IntervalFunction(fun, (), ())


def check_wheel_state_options(
    torque_max: Any,
    keep_out: Sequence[KeepOutCone] | KeepOutCone,
    refine: bool | None,
    initial_guess: Any,
    smoothing: float,
    workers: Any,
) -> None:
    """Refuse, naming the argument, what the wheel-state planner does not do (module docstring).

    Parameters
    ----------
    torque_max : ReactionWheels
        Must be a wheel set.
    keep_out : sequence of KeepOutCone
        Must be empty.
    refine : bool or None
        Must not be True.
    initial_guess : SlewPlan or None
        Must be None.
    smoothing : float
        Must be 0.
    workers : int or None
        Must be 1.
    """
    if not isinstance(torque_max, ReactionWheels):
        raise ValueError(
            f"wheel_states=True needs torque_max to be a ReactionWheels (the wheels are the plan's actuators), "
            f"got {type(torque_max).__name__}"
        )
    cones = (keep_out,) if isinstance(keep_out, KeepOutCone) else tuple(keep_out)
    refused = {
        "keep_out": (bool(cones), f"{len(cones)} cone(s)"),
        "refine": (refine is True, "True"),
        "initial_guess": (initial_guess is not None, "a SlewPlan"),
        "smoothing": (smoothing != 0, repr(smoothing)),
        "workers": (workers != 1, repr(workers)),
    }
    for name, (bad, value) in refused.items():
        if bad:
            raise ValueError(
                f"{name} is not available with wheel_states=True (docs/slew_planning.md, Reaction-wheel polytope "
                f"and wheel momentum), got {value}"
            )


def _initial_wheel_momentum(wheels: ReactionWheels, h_wheels0: ArrayLike | None, omega0: NDArray) -> NDArray:
    """``h_wheels0`` checked: one finite momentum per wheel, within the speed limit at ``omega0``."""
    n_w = wheels.n_wheels
    h0 = np.zeros(n_w) if h_wheels0 is None else as_float_array(h_wheels0, "h_wheels0")
    if h0.shape != (n_w,):
        raise ValueError(f"h_wheels0 must hold one momentum per wheel ({n_w}) in N m s, got shape {h0.shape}")
    relative = wheels.spin_inertia * wheels.wheel_speed(h0, omega0)
    for i in range(n_w):
        if abs(relative[i]) > wheels.momentum_max[i]:
            raise ValueError(
                f"h_wheels0[{i}] must keep wheel {i} within its speed limit: its momentum relative to the body "
                f"J Omega = h - J a . omega0 = {relative[i]:.6g} N m s exceeds momentum_max[{i}] = "
                f"{wheels.momentum_max[i]:.6g} N m s"
            )
    return h0


def _check_final_momentum(prob: Problem, wheels: ReactionWheels, h0: NDArray) -> None:
    """InfeasibleSlewError when the conserved angular momentum cannot sit in the wheels at ``qf``, ``omegaf``.

    The total ``H_N = C_NB (I_s omega + A h)`` is constant, so at the end
    ``A h_f = C_BN(q_f) H_N - I_s omega_f`` with every ``|h_f,i - J_i a_i . omega_f|
    <= momentum_max_i``: a linear feasibility problem (scipy's ``linprog``).
    """
    hub = wheels.hub_body(prob.body).inertia
    total_N = quat.rotate(prob.q0, hub @ prob.omega0 + wheels.distribution @ h0)
    needed_B = quat.rotate(quat.conjugate(prob.qf), total_N) - hub @ prob.omegaf
    center = wheels.spin_inertia * (wheels.axes_B @ prob.omegaf)
    bounds = list(zip(center - wheels.momentum_max, center + wheels.momentum_max))
    lp = linprog(np.zeros(wheels.n_wheels), A_eq=wheels.distribution, b_eq=needed_B, bounds=bounds, method="highs")
    if lp.status == 2:
        cause = (
            f"the total angular momentum {np.round(total_N, 6).tolist()} N m s (inertial, conserved) leaves "
            f"{np.round(needed_B, 6).tolist()} N m s (body axes) for the wheels at qf and omegaf, which no wheel "
            f"momenta within momentum_max {wheels.momentum_max.tolist()} N m s can hold: change h_wheels0, omegaf or qf"
        )
        raise InfeasibleSlewError(f"slew infeasible: {cause}", status="wheel_momentum", cause=cause)


def _wheel_guess(
    prob: Problem, wheels_s: ReactionWheels, h0_s: NDArray, X: NDArray, U: NDArray
) -> tuple[NDArray, NDArray]:
    """A rigid-body guess (7, n+1), (3, n) as wheel states (7 + n_w, n+1) and motor torques (n_w, n).

    Motor torques: the minimum-norm ``u = -A^+ tau``, scaled into the torque
    limits. Wheel momenta: what the conserved total momentum leaves for them,
    ``h = N h0 + A^+ (C_BN H_N - I_s omega)`` (``N`` the null-space projector).
    """
    u = -wheels_s.allocation @ U
    u = u / np.maximum(np.max(np.abs(u) / wheels_s.torque_max[:, None], axis=0), 1.0)
    hub = wheels_s.hub_body(prob.body_s).inertia
    total_N = quat.rotate(X[:4, 0], hub @ X[4:7, 0] + wheels_s.distribution @ h0_s)
    in_body = quat.rotate(quat.conjugate(quat.normalize(X[:4].T)), total_N)
    h = wheels_s.null_projector @ h0_s + (in_body - X[4:7].T @ hub.T) @ wheels_s.allocation.T
    return np.vstack([X, h.T]), u


def _solve(
    prob: Problem,
    wheels_s: ReactionWheels,
    x0: NDArray,
    n: int,
    objective: str,
    duration_s: float | None,
    guesses: list[tuple[NDArray, NDArray, float]],
    max_iter: int,
    options: Mapping[str, Any],
) -> list[Solution]:
    """The wheel-state NLP on ``n`` uniform intervals, solved from each guess (nondimensional answers)."""
    n_w = wheels_s.n_wheels
    tr = Transcription(prob, n, options, state_size=7 + n_w)
    opti = tr.opti
    U = opti.variable(n_w, n)
    T, H, cost = objective_terms(opti, U, n, objective, duration_s, guesses)
    opti.minimize(cost)
    tr.constrain(U, H, interval=wheel_interval_function(prob, wheels_s), x0=x0)
    for i in range(n_w):
        opti.subject_to(opti.bounded(-wheels_s.torque_max[i], U[i, :], wheels_s.torque_max[i]))
    ipopt_setup(tr, max_iter)
    values = {"X": tr.X, "U": U, "cost": cost}
    if T is not None:
        values["T"] = T
    results = []
    for X0, U0, T0 in guesses:
        init = [(tr.X, X0), (U, U0)] + ([(T, T0)] if T is not None else [])
        status, iters, elapsed, val = tr.solve(init, values)
        t_total = float(val["T"][0]) if T is not None else duration_s
        results.append(
            Solution(
                status=status,
                iterations=iters,
                solve_time=elapsed,
                X=val["X"].reshape(7 + n_w, n + 1),
                U=val["U"].reshape(n_w, n),
                H=np.full(n, t_total / n),
                objective=float(val["cost"][0]),
                costate=val["costate"],
                path_multiplier=val["path_multiplier"],
                path_row_multiplier=val["path_row_multiplier"],
            )
        )
    return results


def _plant_functions(body: RigidBody, wheels: ReactionWheels) -> ca.Function:
    """``(x, u) -> (f, df/du)`` of the hub and its wheels (:meth:`PlantModel.derivative`); ``body`` with its wheels."""
    plant = PlantModel(wheels.hub_body(body), wheels)
    n_w = wheels.n_wheels
    xs, us = ca.SX.sym("x", 7 + n_w), ca.SX.sym("u", n_w)
    f = ca.vertcat(*plant.derivative([xs[i] for i in range(7 + n_w)], [us[i] for i in range(n_w)], None))
    return ca.Function("wheel_plant", [xs, us], [f, ca.jacobian(f, us)])


def wheel_pontryagin_check(
    body: RigidBody,
    wheels: ReactionWheels,
    q: ArrayLike,
    omega: ArrayLike,
    wheel_momentum: ArrayLike,
    wheel_torque: ArrayLike,
    costate: ArrayLike,
    checked: ArrayLike | None = None,
    hamiltonian_tolerance: float = HAMILTONIAN_TOLERANCE,
    costate_start: ArrayLike | None = None,
    costate_end: ArrayLike | None = None,
    path_active: ArrayLike | None = None,
    path_length_term: ArrayLike | None = None,
    hamiltonian_decides: bool = True,
) -> dict[str, Any]:
    """Pontryagin's conditions of a minimum-time wheel-state plan, on its motor torques.

    With ``x = [q, omega, h]``, ``x_dot = f(x, u)`` the engine's plant
    (:meth:`PlantModel.derivative`) and the box ``|u_i| <= torque_max_i``:
    ``H = 1 + lambda . f`` is zero, and ``u_i = -torque_max_i sign(sigma_i)``
    wherever the switching function ``sigma = (df/du)^T lambda`` is away from
    zero (casadi's exact Jacobian of ``f``), judged by
    :func:`controllers.slew.optimality.pontryagin_conditions` at both ends of each interval.

    Parameters
    ----------
    body : RigidBody
        The whole spacecraft, wheels included [kg m^2].
    wheels : ReactionWheels
        The wheel set whose ``torque_max`` is the control box.
    q : array_like
        Node attitudes ``q_BN`` (n + 1, 4).
    omega : array_like
        Node body rates [rad/s] (n + 1, 3).
    wheel_momentum : array_like
        Node absolute wheel momenta [N m s] (n + 1, n_wheels).
    wheel_torque : array_like
        Motor torques held over each interval [N m] (n, n_wheels) or (n + 1, n_wheels) (the last row ignored).
    costate : array_like
        Node costates (n + 1, 7 + n_wheels): ``lambda_q`` [s], ``lambda_omega`` [s^2], ``lambda_h`` [1/(N m)]
        (:func:`controllers.slew.optimality.costate_physical`).
    checked : array_like of bool (n,), optional
        Intervals to check (default all).
    hamiltonian_tolerance : float
        Largest accepted ``max |H|``.
    costate_start, costate_end : array_like (n, 7 + n_wheels), optional
        Costates just after the start and just before the end of each interval
        (:func:`controllers.slew.optimality.interval_costates`); default the node costates.
    path_active : array_like of bool (n,), optional
        Intervals where a path constraint (wheel-speed or rate limit) is active: the switching function not checked.
    path_length_term : array_like (n,), optional
        ``mu_k^T dg_k/dh_k`` of each interval, added to its ``H``; default zero.
    hamiltonian_decides : bool
        ``max |H|`` above its tolerance fails the plan (default); False reports it only.

    Returns
    -------
    dict
        As :func:`controllers.slew.optimality.pontryagin_conditions` (the switching check per wheel).
    """
    x = np.concatenate(
        [np.asarray(q, dtype=float), np.asarray(omega, dtype=float), np.asarray(wheel_momentum, dtype=float)], axis=1
    )
    n = x.shape[0] - 1
    u = np.asarray(wheel_torque, dtype=float)[:n]
    lam = np.asarray(costate, dtype=float)
    lam_start = lam[:-1] if costate_start is None else np.asarray(costate_start, dtype=float)
    lam_end = lam[1:] if costate_end is None else np.asarray(costate_end, dtype=float)
    term = np.zeros(n) if path_length_term is None else np.asarray(path_length_term, dtype=float)
    plant = _plant_functions(body, wheels).map(n)
    ends = []
    for states, costates in ((x[:-1], lam_start), (x[1:], lam_end)):
        f, jac = plant(states.T, u.T)
        f = np.asarray(f, dtype=float).T  # (n, 7 + n_w)
        # The map stacks the (7 + n_w, n_w) Jacobians side by side: column j n_w + i is node j, wheel i.
        jac = np.asarray(jac, dtype=float).reshape(7 + wheels.n_wheels, n, wheels.n_wheels)
        ends.append((1.0 + np.sum(costates * f, axis=1) + term, np.einsum("nr,rnw->nw", costates, jac)))
    return pontryagin_conditions(
        ends[0][0],
        ends[1][0],
        ends[0][1],
        ends[1][1],
        u,
        control_box=wheels.torque_max,
        checked=checked,
        hamiltonian_tolerance=hamiltonian_tolerance,
        path_active=path_active,
        hamiltonian_decides=hamiltonian_decides,
    )


def verify_wheels(
    prob: Problem,
    wheels: ReactionWheels,
    h0: NDArray,
    t: NDArray,
    wheel_torque: NDArray,
    tolerance: float,
) -> dict[str, Any]:
    """Check the optimiser's motor torques against their bounds, then re-simulate them (scipy DOP853).

    The torques as the optimiser returned them must lie within
    ``torque_max (1 + TORQUE_BOUND_TOLERANCE)`` (:data:`TORQUE_BOUND_TOLERANCE`:
    IPOPT's bound relaxation); the re-simulation then flies them clipped to
    ``torque_max`` (what the plan stores and a wheel can do). The derivative is
    :meth:`PlantModel.derivative` of the hub and its wheels (the engine's
    equations), integrated by scipy's adaptive DOP853 at rtol 1e-10,
    independently of the NLP's RK4 grid; the limits are checked at
    :data:`controllers.slew.checks.CHECK_SAMPLES` points per interval.

    Parameters
    ----------
    prob : Problem
        The validated problem (``body`` is the whole spacecraft).
    wheels : ReactionWheels
        The wheel set [SI].
    h0 : ndarray
        Initial wheel momenta [N m s] (n_wheels,).
    t : ndarray
        Node times [s] (N + 1,).
    wheel_torque : ndarray
        Motor torques held over each interval [N m] (N, n_wheels), as the optimiser returned them (not clipped).
    tolerance : float
        Largest accepted final attitude error [rad] (rate: ``tolerance / T_s``
        [rad/s]); the rate, torque and wheel-momentum limits are accepted up
        to a relative excess of ``tolerance``.

    Returns
    -------
    dict
        Final errors, peaks, the largest ratio of an optimiser torque to its
        ``torque_max`` (before clipping) and of a wheel momentum to its
        ``momentum_max``, and the largest drift of the total inertial angular momentum
        [N m s].
    """
    hub = wheels.hub_body(prob.body)
    derivative = _plant_functions(prob.body, wheels)
    raw = np.asarray(wheel_torque, dtype=float)
    flown = np.clip(raw, -wheels.torque_max, wheels.torque_max)
    x = np.concatenate([prob.q0, prob.omega0, h0])
    samples = [x[None, :]]
    frac = np.arange(1, CHECK_SAMPLES + 1) / CHECK_SAMPLES
    nfev = 0
    for k in range(t.size - 1):
        u = flown[k]
        sol = solve_ivp(
            lambda _t, y, u=u: np.asarray(derivative(y, u)[0]).ravel(),
            (t[k], t[k + 1]),
            x,
            method="DOP853",
            t_eval=t[k] + frac * (t[k + 1] - t[k]),
            rtol=1e-10,
            atol=1e-12,
        )
        nfev += sol.nfev
        samples.append(sol.y.T)
        x = sol.y[:, -1]
    traj = np.vstack(samples)
    q = quat.normalize(traj[:, :4])
    omega, h = traj[:, 4:7], traj[:, 7:]
    total_N = quat.rotate(q, omega @ hub.inertia.T + h @ wheels.distribution.T)
    relative = wheels.spin_inertia * wheels.wheel_speed(h, omega)
    check = {
        "final_attitude_error": float(quat.error_angle(prob.qf, q[-1])),
        "final_rate_error": float(np.linalg.norm(omega[-1] - prob.omegaf)),
        "rate_peak": float(np.max(np.linalg.norm(omega, axis=1))),
        "torque_ratio_max": float(np.max(np.abs(raw) / wheels.torque_max)),
        "momentum_ratio_max": float(np.max(np.abs(relative) / wheels.momentum_max)),
        "angular_momentum_drift": float(np.max(np.linalg.norm(total_N - total_N[0], axis=1))),
        "final_wheel_momentum": traj[-1, 7:].tolist(),
        "nfev": int(nfev),
    }
    rate_tol = tolerance / prob.t_s
    problems = []
    if check["final_attitude_error"] > tolerance:
        problems.append(f"final attitude error {check['final_attitude_error']:.3g} rad > {tolerance:.3g}")
    if check["final_rate_error"] > rate_tol:
        problems.append(f"final rate error {check['final_rate_error']:.3g} rad/s > {rate_tol:.3g}")
    if prob.rate_max is not None and check["rate_peak"] > prob.rate_max * (1 + tolerance):
        problems.append(f"largest rate {check['rate_peak']:.6g} rad/s > rate_max {prob.rate_max:.6g}")
    if check["torque_ratio_max"] > 1.0 + TORQUE_BOUND_TOLERANCE:
        problems.append(
            f"an optimiser's wheel torque is {check['torque_ratio_max']:.9g} times its torque_max (accepted up to "
            f"1 + {TORQUE_BOUND_TOLERANCE:.0e}, IPOPT's bound relaxation)"
        )
    if check["momentum_ratio_max"] > 1.0 + tolerance:
        problems.append(f"a wheel momentum is {check['momentum_ratio_max']:.6g} times its momentum_max")
    if problems:
        raise SlewPlanningError(
            f"the wheel plan failed its re-simulation: {'; '.join(problems)}; increase substeps or nodes",
            status="verification_failed",
            cause="transcription error of the RK4 grid too large for this slew",
            details=check,
        )
    return check


def _check_wheel_solution(
    prob: Problem,
    wheels: ReactionWheels,
    wheels_s: ReactionWheels,
    sol: Solution,
    objective: str,
    wheel_torque: NDArray,
) -> dict[str, Any]:
    """:func:`wheel_pontryagin_check` of the NLP's answer, its multipliers as costates (as the rigid plans')."""
    if objective != "time" or sol.costate is None:
        return {"passes": None, "note": "not checked: the Pontryagin check is for minimum-time plans"}
    active, checked = intervals_to_check(sol)
    if not np.any(checked):
        return dict(NOT_CHECKED_JUNCTIONS)
    n = sol.U.shape[1]
    start, end, term = interval_costates(prob, sol, wheel_interval_function(prob, wheels_s))
    h_s = prob.j_s / prob.t_s
    out = wheel_pontryagin_check(
        prob.body,
        wheels,
        sol.X[:4].T,
        sol.X[4:7].T / prob.t_s,
        sol.X[7:].T * h_s,
        wheel_torque,
        costate_physical(prob, sol.costate),
        checked=checked,
        hamiltonian_tolerance=HAMILTONIAN_WHEEL_FACTOR / n,
        costate_start=costate_physical(prob, np.hstack([start, end[:, -1:]]))[:-1],
        costate_end=costate_physical(prob, np.hstack([start[:, :1], end]))[1:],
        path_active=active,
        path_length_term=term,
        hamiltonian_decides=not np.any(active),
    )
    out["tolerances"] = {
        "hamiltonian": out["hamiltonian_tolerance"],
        "switching_disagreement": SWITCHING_TOLERANCE,
        "switching_zero_fraction": SWITCHING_ZERO_FRACTION,
    }
    return out


def _raise_failure(results: list[Solution], max_iter: int) -> None:
    """No start converged: InfeasibleSlewError or SlewPlanningError with the statuses."""
    statuses = [r.status for r in results]
    details = {"statuses": statuses, "iterations": [r.iterations for r in results]}
    names = ", ".join(sorted(set(statuses)))
    if any(s in INFEASIBLE for s in statuses):
        cause = (
            "the wheel torque and momentum limits (and the rate limit, if set) admit no such slew: the momentum the "
            "wheels must take up at this slew's rates may exceed momentum_max, or the duration is shorter than the "
            "minimum time"
        )
        raise InfeasibleSlewError(
            f"slew infeasible (IPOPT: {names}): {cause}", status=statuses[0], cause=cause, details=details
        )
    cause = f"IPOPT stopped without converging (max_iter={max_iter}): raise max_iter or nodes, or add starts"
    raise SlewPlanningError(
        f"wheel slew planning failed (IPOPT: {names} on {len(statuses)} start(s)): {cause}",
        status=statuses[0],
        cause=cause,
        details=details,
    )


def plan_with_wheel_states(
    prob: Problem,
    wheels: ReactionWheels,
    h_wheels0: ArrayLike | None,
    objective: str,
    duration_s: float | None,
    n: int,
    specs: Sequence[StartSpec],
    perturbation: float,
    gen: np.random.Generator,
    max_iter: int,
    options: Mapping[str, Any],
    verify_tolerance: float,
    wall_start: float,
) -> SlewPlan:
    """The wheel-state plan of a problem checked and scaled by :func:`controllers.slew.plan_slew`.

    Parameters
    ----------
    prob : Problem
        The validated problem, scaled to the slew (``body`` the whole spacecraft).
    wheels : ReactionWheels
        The wheel set [SI].
    h_wheels0 : array_like or None
        Initial absolute wheel momenta [N m s] (n_wheels,); None for zero.
    objective : str
        ``"time"`` or ``"energy"`` (``integral |u|^2 dt`` over the motor torques).
    duration_s : float or None
        Fixed duration in units of ``T_s`` (energy); None for minimum time.
    n : int
        Intervals of the uniform grid.
    specs : sequence of (str, int)
        The starts (:func:`controllers.slew.guess.expand_starts`).
    perturbation : float
        Guess perturbation size.
    gen : numpy.random.Generator
        Source of the perturbations.
    max_iter : int
        IPOPT iteration limit.
    options : mapping
        IPOPT options of the caller.
    verify_tolerance : float
        Tolerance of the re-simulation (:func:`verify_wheels`).
    wall_start : float
        ``time.perf_counter()`` at the start of the planning call [s].
    """
    h0 = _initial_wheel_momentum(wheels, h_wheels0, prob.omega0)
    _check_final_momentum(prob, wheels, h0)
    wheels_s = scaled_wheels(wheels, prob.j_s, prob.t_s)
    h_s = prob.j_s / prob.t_s
    x0 = np.concatenate([prob.x0, h0 / h_s])
    X, U, T = base_guess(prob, n, duration_s)
    first = perturbed(prob, X, U, perturbation, gen)
    seed = int(gen.integers(2**63))
    rigid = [
        (*first, T) if s[0] == "eigenaxis" else family_guess(prob, n, s, perturbation, seed, duration_s) for s in specs
    ]
    guesses = [(*_wheel_guess(prob, wheels_s, h0 / h_s, Xg, Ug), Tg) for Xg, Ug, Tg in rigid]
    used = list(specs)
    results = _solve(prob, wheels_s, x0, n, objective, duration_s, guesses, max_iter, options)
    if not any(r.converged for r in results) and perturbation > 0:
        # The unperturbed eigenaxis path as one more start (as plan_slew's fallback).
        results += _solve(
            prob,
            wheels_s,
            x0,
            n,
            objective,
            duration_s,
            [(*_wheel_guess(prob, wheels_s, h0 / h_s, X, U), T)],
            max_iter,
            options,
        )
        used.append(("eigenaxis_fallback", 0))
    good = [r for r in results if r.converged]
    if not good:
        _raise_failure(results, max_iter)
    best = min(good, key=lambda r: r.objective)
    starts_info, multi = start_report(results, used, prob.t_s, [{}] * len(results))
    multi["solved"] = "in this process"
    t = np.concatenate([[0.0], np.cumsum(best.H)]) * prob.t_s
    raw = best.U.T * prob.tau_s
    check = verify_wheels(prob, wheels, h0, t, raw, verify_tolerance)
    # Within IPOPT's bound relaxation (checked above): put on their bounds, as the re-simulation flew them.
    wheel_torque = np.clip(raw, -wheels.torque_max, wheels.torque_max)
    pontryagin = _check_wheel_solution(prob, wheels, wheels_s, best, objective, wheel_torque)
    notes = []
    if pontryagin.get("passes") is False:
        notes.append(
            f"the wheel plan fails Pontryagin's necessary conditions (residual {pontryagin['residual']:.3g} > 1: "
            f"max |H| {pontryagin['hamiltonian_residual']:.3g}, switching disagreement "
            f"{pontryagin['switching_disagreement']}): not a time-optimal extremal "
            "(docs/slew_planning.md, Optimality evidence)"
        )
    for note in notes:
        warnings.warn(note, RuntimeWarning, stacklevel=3)
    wheel_torque = np.vstack([wheel_torque, wheel_torque[-1:]])
    body_torque = wheels.body_torque(wheel_torque)
    energy = float(np.sum(np.sum(wheel_torque[:-1] ** 2, axis=1) * np.diff(t)))
    duration = float(t[-1])
    rows = wheel_torque_rows(wheels)
    bore, direc, half = cone_arrays(())
    info = {
        "scaling": {"inertia_kg_m2": prob.j_s, "torque_n_m": prob.tau_s, "time_s": prob.t_s},
        "nodes": n,
        "substeps": prob.substeps,
        "perturbation": perturbation,
        "torque_set": f"{wheels.n_wheels} reaction wheels: torque polytope, wheel momenta as states",
        "keep_out_names": [],
        "starts": starts_info,
        "multi_start": multi,
        "best_start": int(results.index(best)),
        "pontryagin": pontryagin,
        "refinement": {"requested": False, "status": "not available with wheel states"},
        "grid_status": best.status,
        "grid_iterations": best.iterations,
        "energy_n2m2s": energy,
        "h_wheels0_nms": h0.tolist(),
        "verification": check,
        "notes": ["wheel states: the uniform-grid answer (no switch-time refinement)"],
        "warnings": notes,
    }
    return SlewPlan(
        t=t,
        q=best.X[:4].T.copy(),
        omega=best.X[4:7].T / prob.t_s,
        torque=body_torque,
        duration=duration,
        objective=objective,
        objective_value=duration if objective == "time" else energy,
        status=best.status,
        iterations=best.iterations,
        wall_time=time.perf_counter() - wall_start,
        solve_time=sum(r.solve_time for r in results),
        grid_duration=duration,
        refined_duration=None,
        switch_times=np.zeros(0),
        final_attitude_error=check["final_attitude_error"],
        final_rate_error=check["final_rate_error"],
        separation_min=np.zeros(0),
        rate_peak=check["rate_peak"],
        q_target=prob.qf.copy(),
        omega_target=prob.omegaf.copy(),
        inertia=prob.body.inertia,
        torque_envelope=np.abs(wheels.distribution) @ wheels.torque_max,
        torque_rows=rows,
        rate_max=prob.rate_max,
        keep_out_boresight_B=bore,
        keep_out_direction_N=direc,
        keep_out_half_angle=half,
        eigenaxis_duration=None,
        info=info,
        costate=None if best.costate is None else costate_physical(prob, best.costate),
        pontryagin_residual=pontryagin.get("residual"),
        optimality_flagged=pontryagin.get("passes") is False,
        wheel_torque=wheel_torque,
        wheel_momentum=best.X[7:].T * h_s,
        wheel_set={
            "axes_B": wheels.axes_B.copy(),
            "spin_inertia": wheels.spin_inertia.copy(),
            "torque_max": wheels.torque_max.copy(),
            "momentum_max": wheels.momentum_max.copy(),
            "viscous_friction": wheels.viscous_friction.copy(),
            "coulomb_friction": wheels.coulomb_friction.copy(),
            "coulomb_smoothing_speed": wheels.coulomb_smoothing_speed,
        },
    )

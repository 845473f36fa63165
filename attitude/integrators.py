"""Integration steps for the attitude equations of motion.

Three integrators serve three purposes:

* :func:`rk4_step`: classical fixed-step Runge-Kutta 4 on the state
  components, followed by renormalisation of the quaternion. Written on lists
  of components with ``+ - *`` only, so the same step evaluates on batched
  numpy arrays and on casadi symbols (:func:`casadi_rk4_step` compiles it,
  and ``Function.mapaccum`` runs a whole trajectory in C: the fast path for a
  single spacecraft).
* :func:`rkmk4_step`: a Runge-Kutta-Munthe-Kaas step of order 4 on the Lie
  group SU(2) x R^3. The attitude moves only by multiplication with the
  quaternion exponential of an increment, so ``|q| = 1`` is kept to rounding
  error with no renormalisation. Written on components with the functions
  of :mod:`attitude.backend` as RK4 is, so the same step runs on batched
  numpy arrays and compiled in casadi (:func:`casadi_rkmk4_step`).
* the adaptive reference, scipy ``solve_ivp`` with DOP853, lives in
  :mod:`attitude.propagate`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from attitude.backend import cross
from attitude.quaternion import exp_rotation_vector_components
from attitude.quaternion import multiply_components as quaternion_multiply_components
from attitude.rigid_body import Components, RigidBody, skew, split_components

__all__ = [
    "ATTITUDE_ERROR_BUDGET_RAD",
    "MAX_RULE_SUBSTEPS",
    "RULE_INERTIA_RATIO_MAX",
    "VARYING_RATE_WEIGHT",
    "StepSizeWarning",
    "attitude_error_text",
    "casadi_rk4_step",
    "casadi_rkmk4_step",
    "check_error_budget",
    "fifth_derivative_excess",
    "gyroscopic_turn_rate",
    "normalize_quaternion_components",
    "predicted_attitude_error",
    "rate_variation_excess",
    "rk4_step",
    "rkmk4_step",
    "rule_formula",
    "rule_rates",
    "substeps_for_budget",
    "warn_outside_calibration",
]

Derivative = Callable[[Any, Components], Components]


def rk4_step(derivative: Derivative, t: Any, x: Components, dt: Any) -> Components:
    """One classical Runge-Kutta 4 step on a list of state components.

    Parameters
    ----------
    derivative : callable
        ``derivative(t, x) -> x_dot`` on lists of components.
    t : float or array
        Time at the start of the step [s].
    x : list
        State components (numpy arrays of a common batch shape, or casadi
        scalars).
    dt : float
        Step size [s].

    Returns
    -------
    list
        The state components after the step (not renormalised).
    """
    half = 0.5 * dt
    k1 = derivative(t, x)
    k2 = derivative(t + half, [a + half * k for a, k in zip(x, k1)])
    k3 = derivative(t + half, [a + half * k for a, k in zip(x, k2)])
    k4 = derivative(t + dt, [a + dt * k for a, k in zip(x, k3)])
    sixth = dt / 6.0
    return [a + sixth * (p + 2.0 * (q + r) + s) for a, p, q, r, s in zip(x, k1, k2, k3, k4)]


def normalize_quaternion_components(x: Components) -> Components:
    """Divide the first four components (the quaternion) by their norm.

    Parameters
    ----------
    x : list of numpy arrays or casadi scalars
        State components whose first four are a non-zero quaternion
        ``[w, x, y, z]``; the rest (e.g. body rate [rad/s]) pass through.

    Returns
    -------
    list
        A new list: the unit quaternion followed by ``x[4:]`` unchanged.
    """
    inv = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]) ** -0.5
    return [x[0] * inv, x[1] * inv, x[2] * inv, x[3] * inv, *x[4:]]


def _dexpinv(theta: Components, omega: Components) -> Components:
    """Rotation-vector rate for body rate ``omega`` at increment ``theta`` (to order 4).

    With ``q(t) = q0 ⊗ exp(theta(t)/2)`` and ``q_dot = q ⊗ [0, omega] / 2``,
    ``theta_dot = dexp^{-1}_{-theta}(omega) = omega + theta x omega / 2
    + theta x (theta x omega) / 12 + O(|theta|^4)``; the truncation keeps RKMK
    of order 4 because ``theta = O(dt)``.
    """
    c1 = cross(theta, omega)
    c2 = cross(theta, c1)
    return [w + 0.5 * a + b / 12.0 for w, a, b in zip(omega, c1, c2)]


def rkmk4_step(
    body: RigidBody,
    torque: Callable[[Any, Components, Components], Components | None],
    t: Any,
    q: Components,
    omega: Components,
    dt: Any,
) -> tuple[Components, Components]:
    """One Runge-Kutta-Munthe-Kaas step of order 4 on components (numpy arrays or casadi scalars).

    The attitude is advanced as ``q ⊗ exp(theta/2)`` where the rotation
    vector ``theta`` is integrated in the Lie algebra with the classical RK4
    tableau, so ``|q|`` is preserved to rounding error without renormalising.
    Only ``+ - * /`` and :mod:`attitude.backend` functions: the one definition
    of the step for the batched numpy path and the compiled one
    (:func:`casadi_rkmk4_step`).

    Parameters
    ----------
    body : RigidBody
        The plant (Euler's equations).
    torque : callable
        ``torque(t, q, omega) -> tau`` on component lists [N m] (None for torque-free).
    t : float or casadi scalar
        Time at the start of the step [s].
    q, omega : list of numpy arrays or casadi scalars
        Attitude quaternion ``q_BN`` (4) and body rate ``omega_BN_B`` (3)
        [rad/s] components.
    dt : float or casadi scalar
        Step size [s].

    Returns
    -------
    q, omega : lists
        Quaternion (4) and body rate (3) [rad/s] components after the step, same backend as ``q``.
    """
    zero = [0.0 * omega[0]] * 3
    stages = ((0.0, None, 0.0), (0.5, 0, 0.5), (0.5, 1, 0.5), (1.0, 2, 1.0))
    ks: list[Components] = []
    ls: list[Components] = []
    for c, prev, a in stages:
        if prev is None:
            theta, w_stage, q_stage = zero, omega, q
        else:
            theta = [a * dt * k for k in ks[prev]]
            w_stage = [w + a * dt * lv for w, lv in zip(omega, ls[prev])]
            q_stage = quaternion_multiply_components(q, exp_rotation_vector_components(theta))
        tau = torque(t + c * dt, q_stage, w_stage)
        ks.append(_dexpinv(theta, w_stage))
        ls.append(body.omega_dot_components(w_stage, tau))
    # The weights combined as rk4_step combines them. Not as sum(b_i * l_i): casadi folds a constant times a
    # constant-scaled node (b_i * (c * y) -> (b_i c) * y, as Euler's equations of a diagonal inertia give),
    # which rounds differently from numpy; here no constant multiplies such a node on either backend.
    sixth = dt / 6.0
    theta = [sixth * (a + 2.0 * (b + c) + d) for a, b, c, d in zip(*ks)]
    omega_new = [w + sixth * (a + 2.0 * (b + c) + d) for w, a, b, c, d in zip(omega, *ls)]
    q_new = quaternion_multiply_components(q, exp_rotation_vector_components(theta))
    return q_new, omega_new


def casadi_rk4_step(body: RigidBody, substeps: int = 1) -> ca.Function:
    """RK4 step with quaternion renormalisation as a casadi ``SX`` Function.

    ``step(x[7], tau[3], dt) -> x_next[7]`` advances ``[q, omega]`` by ``dt``
    [s] under a torque ``tau`` [N m] held constant over the step, built from
    the one definition :meth:`RigidBody.state_derivative_components`.
    ``step.mapaccum(n)`` runs ``n`` steps in compiled code.

    Parameters
    ----------
    body : RigidBody
        A single (not batched) body.
    substeps : int
        Equal RK4 sub-steps taken inside one call (each renormalised).

    Returns
    -------
    casadi.Function
        ``step(x[7], tau[3], dt) -> x_next[7]`` with
        ``x = [q_BN (4), omega_BN_B (3) [rad/s]]``, ``tau`` [N m] and ``dt`` [s].

    Raises
    ------
    ValueError
        If ``body`` is a batch of inertias.
    """
    return _casadi_step(body, "rk4", substeps)


def casadi_rkmk4_step(body: RigidBody, substeps: int = 1) -> ca.Function:
    """The RKMK4 step (:func:`rkmk4_step`, no renormalisation) as a casadi ``SX`` Function.

    ``step(x[7], tau[3], dt) -> x_next[7]`` advances ``[q, omega]`` by ``dt``
    [s] under a torque ``tau`` [N m] held constant over the step: the same
    arithmetic as the numpy evaluation of :func:`rkmk4_step`, so
    ``step.mapaccum(n)`` runs a geometric trajectory in compiled code.

    Parameters
    ----------
    body : RigidBody
        A single (not batched) body.
    substeps : int
        Equal RKMK4 sub-steps taken inside one call.

    Returns
    -------
    casadi.Function
        ``step(x[7], tau[3], dt) -> x_next[7]`` with
        ``x = [q_BN (4), omega_BN_B (3) [rad/s]]``, ``tau`` [N m] and ``dt`` [s].

    Raises
    ------
    ValueError
        If ``body`` is a batch of inertias.
    """
    return _casadi_step(body, "geometric", substeps)


def _casadi_step(body: RigidBody, method: str, substeps: int) -> ca.Function:
    """``step(x[7], tau[3], dt) -> x_next[7]``: RK4 (renormalised) or RKMK4, ``substeps`` steps of ``dt / substeps``."""
    name = {"rk4": "rk4_step", "geometric": "rkmk4_step"}[method]
    if body.batch_shape:
        raise ValueError(f"casadi_{name} needs a single body, not a batch of inertias")
    x = ca.SX.sym("x", 7)
    tau = ca.SX.sym("tau", 3)
    dt = ca.SX.sym("dt")
    tau_c = split_components(tau, 3)
    h = dt / substeps

    def derivative(_t: Any, xc: Components) -> Components:
        return body.state_derivative_components(xc, tau_c)

    xc = split_components(x, 7)
    for _ in range(substeps):
        if method == "rk4":
            xc = normalize_quaternion_components(rk4_step(derivative, 0.0, xc, h))
        else:
            q, w = rkmk4_step(body, lambda _t, _q, _w: tau_c, 0.0, xc[:4], xc[4:], h)
            xc = [*q, *w]
    return ca.Function(name, [x, tau, dt], [ca.vertcat(*xc)], ["x", "tau", "dt"], ["x_next"])


# -- The step-size rule of the fixed-step methods (docs/rk4_step_rule.md) -----

#: Default accumulated attitude-error budget of a fixed-step run [rad] (0.2 arcsec): a tenth of
#: the finest star tracker's noise, so the truth model's integration error never shows in an estimate.
ATTITUDE_ERROR_BUDGET_RAD = 1e-6
#: Largest ratio of principal moments the rule is calibrated for (docs/rk4_step_rule.md); beyond it the
#: fixed-step paths warn that the predicted error is not a checked bound (a review measured the geometric
#: method up to 1.075 times its prediction at ratio 30).
RULE_INERTIA_RATIO_MAX = 20.0
#: Most sub-steps the rule may put in one step before it refuses (a step that long is a mistyped max_step or dt).
MAX_RULE_SUBSTEPS = 1000
#: Per-method weight of the kinematic term: RK4's 4th-order truncation of ``exp(i theta / 2)``
#: (1); RKMK4 moves the attitude by an exact exponential, so a constant rate costs it nothing (0).
_KINEMATIC_WEIGHT = {"rk4": 1.0, "geometric": 0.0}
#: Weight of the gyroscopic term, twice the largest ratio (0.86) measured against DOP853 at rtol 1e-13
#: on 60 random bodies (flat plates and near-principal spins included; docs/rk4_step_rule.md).
_GYROSCOPIC_WEIGHT = 2.0
#: Weight of the varying-rate term (:func:`rate_variation_excess`): twice the largest ratio (0.77) that
#: 1170 runs needed against DOP853 at rtol 1e-13 (prolate, oblate and triaxial bodies of inertia ratio up to
#: 20, near-principal and general tumbles, torques, 1 to 500 steps; docs/rk4_step_rule.md).
VARYING_RATE_WEIGHT = 1.5


def rule_formula(method: str = "rk4") -> str:
    """The step-size rule as the warnings and errors print it (docs/rk4_step_rule.md).

    Parameters
    ----------
    method : {"rk4", "geometric"}
        The fixed-step method (RKMK4 has no kinematic term).

    Returns
    -------
    str
    """
    kinematic = "1 + " if _KINEMATIC_WEIGHT[method] else ""
    return f"E = [({kinematic}2 Phi) Theta theta^4 + {VARYING_RATE_WEIGHT:g} sum Xi h h_s^4] / 1920"


class StepSizeWarning(UserWarning):
    """A fixed-step run broke the step-size rule and was sub-stepped (or could not be): see docs/rk4_step_rule.md."""


def gyroscopic_turn_rate(body: RigidBody, omega: Any, h: Any = None) -> Any:
    """Bound on the rate at which the gyroscopic term turns the body rate vector in the body [rad/s].

    ``|I^-1 (omega x (I omega + h))| / |omega|``, torque-free on purpose: an
    applied torque enters the rule through :func:`rate_variation_excess`
    (docs/rk4_step_rule.md). Zero for a constant rate (a principal-axis
    spin, a sphere, rest).

    Parameters
    ----------
    body : RigidBody
        The (hub) body, single or batched like ``omega``.
    omega : array_like (..., 3)
        Body rate [rad/s].
    h : array_like (..., 3), optional
        Internal (wheel) angular momentum in body components [N m s].

    Returns
    -------
    ndarray (...)
        Turn rate [rad/s] (0 where ``omega`` is 0).
    """

    omega = np.asarray(omega, dtype=float)
    rate = np.linalg.norm(omega, axis=-1)
    accel = np.linalg.norm(body.omega_dot(omega, None, h), axis=-1)
    safe = np.where(rate > 0.0, rate, 1.0)
    return np.where(rate > 0.0, accel / safe, 0.0)


def rate_variation_excess(body: RigidBody, omega: Any, h: Any = None, torque: Any = None) -> Any:
    """How much a varying body rate adds to a fixed step's local attitude error [rad^5/s^5].

    ``Xi = 32 b_5 - |omega|^5``, where ``b_5`` bounds ``|q^(5)|`` for
    ``q' = q ⊗ omega / 2`` when the rate's derivatives grow as
    ``|omega^(j)| <= |omega'| mu^(j-1)``: ``|omega'|`` is the body's angular
    acceleration from Euler's equations (gyroscopic terms and the applied
    torque) and ``mu`` the Frobenius norm of the Jacobian of Euler's equations,
    ``I^-1 ([I omega + h]x - [omega]x I)``, which bounds how fast each
    further derivative of the linearised rate grows. For a constant rate
    ``b_5 = (|omega| / 2)^5``, the constant-spin term of the rule, and
    ``Xi = 0``. A step of length ``h_s`` then adds about
    ``Xi h_s^5 / 1920`` rad to the kinematic term ``|omega|^5 h_s^5 / 1920``
    (docs/rk4_step_rule.md): the nutation of a prolate body spun about its
    minor axis, faster than the turn of its rate, is what this term sees.

    Parameters
    ----------
    body : RigidBody
        The (hub) body, single or batched like ``omega``.
    omega : array_like (..., 3)
        Body rate [rad/s].
    h : array_like (..., 3), optional
        Internal (wheel) angular momentum in body components [N m s].
    torque : array_like (..., 3), optional
        Applied torque in body components [N m]; None for torque-free.

    Returns
    -------
    ndarray (...)
        ``Xi`` [rad^5/s^5], 0 for a constant rate.
    """
    omega = np.asarray(omega, dtype=float)
    rate = np.linalg.norm(omega, axis=-1)
    momentum = np.matmul(body.inertia, omega[..., None])[..., 0]
    if h is not None:
        momentum = momentum + np.asarray(h, dtype=float)
    jacobian = np.matmul(body.inertia_inv, skew(momentum) - np.matmul(skew(omega), body.inertia))
    acceleration = np.linalg.norm(body.omega_dot(omega, torque, h), axis=-1)
    return fifth_derivative_excess(rate, acceleration, np.linalg.norm(jacobian, axis=(-2, -1)))


def rule_rates(body: RigidBody, omega: Any, h: Any = None, torque: Any = None) -> tuple[Any, Any, Any]:
    """The three state rates the step-size rule reads: ``|omega|``, :func:`gyroscopic_turn_rate` (torque-free:
    ``Phi`` measures the gyroscopic turn, the applied torque enters through the acceleration) and
    :func:`rate_variation_excess` (the one place they are evaluated together).

    Parameters
    ----------
    body : RigidBody
        The (hub) body, single or batched like ``omega``.
    omega : array_like (..., 3)
        Body rate [rad/s].
    h : array_like (..., 3), optional
        Internal (wheel) angular momentum in body components [N m s].
    torque : array_like (..., 3), optional
        Applied torque in body components [N m]; None for torque-free.

    Returns
    -------
    rate, turn, excess : ndarray (...)
        [rad/s], [rad/s], [rad^5/s^5].
    """
    omega = np.asarray(omega, dtype=float)
    return (
        np.linalg.norm(omega, axis=-1),
        gyroscopic_turn_rate(body, omega, h),
        rate_variation_excess(body, omega, h, torque),
    )


def fifth_derivative_excess(rate_rad_s: Any, acceleration_rad_s2: Any, growth_rate_rad_s: Any) -> Any:
    """``Xi = 32 b_5 - |omega|^5`` of :func:`rate_variation_excess` [rad^5/s^5].

    ``b_{n+1} = (1/2) sum_j C(n, j) b_{n-j} w_j`` with ``b_0 = 1``,
    ``w_0 = |omega|`` and ``w_j = |omega'| mu^(j-1)`` (Leibniz's rule on
    ``q' = q ⊗ omega / 2`` with every product bounded by its norms). Works
    on floats and on arrays alike (the simulate engine evaluates it every tick).

    Parameters
    ----------
    rate_rad_s : float or array_like
        ``|omega|`` [rad/s].
    acceleration_rad_s2 : float or array_like
        ``|omega'|`` [rad/s^2].
    growth_rate_rad_s : float or array_like
        ``mu`` [rad/s].

    Returns
    -------
    float or ndarray
        ``Xi`` [rad^5/s^5] (>= 0).
    """
    w0, w1, mu = rate_rad_s, acceleration_rad_s2, growth_rate_rad_s
    w2, w3, w4 = w1 * mu, w1 * mu * mu, w1 * mu * mu * mu
    b1 = 0.5 * w0
    b2 = 0.5 * (b1 * w0 + w1)
    b3 = 0.5 * (b2 * w0 + 2.0 * b1 * w1 + w2)
    b4 = 0.5 * (b3 * w0 + 3.0 * b2 * w1 + 3.0 * b1 * w2 + w3)
    b5 = 0.5 * (b4 * w0 + 4.0 * b3 * w1 + 6.0 * b2 * w2 + 4.0 * b1 * w3 + w4)
    excess = 32.0 * b5 - w0**5
    if isinstance(excess, ca.SX | ca.MX):  # the compiled protocol tick (NaN stays NaN on numbers)
        return ca.fmax(excess, 0.0)
    return np.maximum(excess, 0.0)


def predicted_attitude_error(
    rate_rad_s: Any,
    step_s: Any,
    turn_rate_rad_s: Any = 0.0,
    *,
    substeps: Any = 1,
    method: str = "rk4",
    excess_rad5_s5: Any = 0.0,
) -> Any:
    """Predicted accumulated attitude error of a fixed-step run [rad] (docs/rk4_step_rule.md).

    ``E = [(k + 2 Phi) Theta theta^4 + c sum_i Xi_i h_i (h_i / s_i)^4] / 1920``
    with ``Theta = sum |omega| h`` the angle turned, ``Phi = sum nu h`` the
    angle the rate vector turns in the body (:func:`gyroscopic_turn_rate`),
    ``theta`` the largest rotation per (sub-)step, ``k = 1`` for RK4 and 0
    for RKMK4, and ``Xi`` the varying-rate term (:func:`rate_variation_excess`)
    over intervals of ``h_i`` split into ``s_i`` steps. For a constant rate
    the RK4 term is the exact leading error of the renormalised step,
    ``theta^5 / 1920`` rad per step.

    Parameters
    ----------
    rate_rad_s : array_like (..., n)
        ``|omega|`` over each of ``n`` intervals [rad/s] (leading axes: a batch).
    step_s : float or array_like (n,)
        Interval lengths [s].
    turn_rate_rad_s : float or array_like (..., n)
        Gyroscopic turn rate over each interval [rad/s].
    substeps : int or array_like of int (n,)
        Equal steps per interval.
    method : {"rk4", "geometric"}
        The fixed-step method.
    excess_rad5_s5 : float or array_like (..., n)
        Varying-rate term ``Xi`` over each interval [rad^5/s^5].

    Returns
    -------
    ndarray (...)
        Predicted error [rad] of each run of the batch.
    """
    angle = np.asarray(rate_rad_s, dtype=float) * np.asarray(step_s, dtype=float)
    phi = np.sum(np.broadcast_to(np.asarray(turn_rate_rad_s, dtype=float) * step_s, angle.shape), axis=-1)
    theta = np.max(angle / np.asarray(substeps, dtype=float), axis=-1, initial=0.0)
    weight = _KINEMATIC_WEIGHT[method] + _GYROSCOPIC_WEIGHT * phi
    step = np.broadcast_to(np.asarray(step_s, dtype=float), angle.shape[-1:])
    local = np.broadcast_to(np.asarray(excess_rad5_s5, dtype=float), angle.shape) * step * (step / substeps) ** 4
    return (weight * np.sum(angle, axis=-1) * theta**4 + VARYING_RATE_WEIGHT * np.sum(local, axis=-1)) / 1920.0


def attitude_error_text(error_rad: float, digits: int = 3) -> str:
    """A predicted or bounded attitude error as the messages print it: in rad, or above pi, that the attitude is lost.

    The angle between two attitudes is at most pi rad, so a prediction beyond
    it (:func:`predicted_attitude_error` grows without limit with the step)
    says only that the fixed-step attitude may be anywhere, not by how much.

    Parameters
    ----------
    error_rad : float
        The predicted or bounded error [rad].
    digits : int, optional
        Significant digits of a printed number.

    Returns
    -------
    str
        ``"1.2e-05 rad"``, or ``"more than pi rad (the attitude is lost)"``.

    Examples
    --------
    >>> attitude_error_text(1.234e-5)
    '1.23e-05 rad'
    >>> attitude_error_text(370.0)
    'more than pi rad (the attitude is lost)'
    """
    if error_rad > np.pi:
        return "more than pi rad (the attitude is lost)"
    return f"{error_rad:.{digits}g} rad"


def substeps_for_budget(
    rate_rad_s: Any,
    step_s: Any,
    turn_rate_rad_s: Any = 0.0,
    *,
    substeps: Any = 1,
    budget_rad: float = ATTITUDE_ERROR_BUDGET_RAD,
    method: str = "rk4",
    excess_rad5_s5: Any = 0.0,
) -> NDArray[np.int64]:
    """Steps per interval that keep :func:`predicted_attitude_error` within ``budget_rad``.

    Where the rule is broken the budget is split between its two terms in
    proportion to their size at the steps asked, ``B_1 + B_2 = B``, and each
    term gets a uniform angle per step (the allocation that minimises the
    step count of one term): ``|omega_i| h_s <= theta_1 = (1920 B_1 / ((k +
    2 Phi) Theta))^(1/4)`` and ``(c Xi_i)^(1/5) h_s <= theta_2 = (1920 B_2 /
    sum_i (c Xi_i)^(1/5) h_i)^(1/4)``; each interval takes the steps the
    stricter asks for, which bounds the terms by ``B_1`` and ``B_2``
    (``Phi``, ``Theta`` and ``Xi`` do not depend on the step). Where the rule
    holds, ``substeps`` is returned unchanged.

    Parameters
    ----------
    rate_rad_s : array_like (..., n)
        ``|omega|`` over each interval [rad/s] (leading axes: a batch; the worst run sets the count).
    step_s : float or array_like (n,)
        Interval lengths [s].
    turn_rate_rad_s : float or array_like (..., n)
        Gyroscopic turn rate over each interval [rad/s] (:func:`gyroscopic_turn_rate`).
    substeps : int or array_like of int (n,)
        The steps per interval asked for (never lowered).
    budget_rad : float
        Accumulated attitude-error budget [rad].
    method : {"rk4", "geometric"}
        The fixed-step method.
    excess_rad5_s5 : float or array_like (..., n)
        Varying-rate term over each interval [rad^5/s^5] (:func:`rate_variation_excess`).

    Returns
    -------
    ndarray of int64 (n,)
        Steps per interval.
    """
    rate = np.asarray(rate_rad_s, dtype=float)
    rate = rate.reshape(-1, rate.shape[-1]) if rate.ndim else rate.reshape(1, 1)
    step = np.broadcast_to(np.asarray(step_s, dtype=float), rate.shape[-1:])
    asked = np.broadcast_to(np.asarray(substeps, dtype=np.int64), rate.shape[-1:])
    turn = np.broadcast_to(np.asarray(turn_rate_rad_s, dtype=float), np.shape(rate_rad_s)).reshape(rate.shape)
    excess = np.broadcast_to(np.asarray(excess_rad5_s5, dtype=float), np.shape(rate_rad_s)).reshape(rate.shape)
    error = predicted_attitude_error(rate, step, turn, substeps=asked, method=method, excess_rad5_s5=excess)
    if np.max(error) <= budget_rad:
        return asked.copy()
    # The budget split between the two terms in proportion to their size at the steps asked; each term then
    # gets its own uniform angle per step: theta_1 for |omega| h_s, theta_2 for (c Xi)^(1/5) h_s.
    kinematic = predicted_attitude_error(rate, step, turn, substeps=asked, method=method)
    share = np.where(error > 0.0, kinematic / np.where(error > 0.0, error, 1.0), 1.0)
    varying = (VARYING_RATE_WEIGHT * excess) ** 0.2  # [rad/s]
    weight = (_KINEMATIC_WEIGHT[method] + _GYROSCOPIC_WEIGHT * np.sum(turn * step, axis=-1)) * np.sum(
        rate * step, axis=-1
    )
    swept_varying = np.sum(varying * step, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        # A term that is zero for every run constrains nothing (its angle is infinite).
        theta_1 = np.min(np.where(weight > 0.0, (1920.0 * share * budget_rad / weight) ** 0.25, np.inf))
        theta_2 = np.min(
            np.where(swept_varying > 0.0, (1920.0 * (1.0 - share) * budget_rad / swept_varying) ** 0.25, np.inf)
        )
        angle_1, angle_2 = np.max(rate * step, axis=0), np.max(varying * step, axis=0)
        needed = np.maximum(
            np.where(angle_1 > 0.0, angle_1 / theta_1, 0.0), np.where(angle_2 > 0.0, angle_2 / theta_2, 0.0)
        )
    return np.maximum(asked, np.ceil(needed)).astype(np.int64)


def warn_outside_calibration(body: RigidBody, budget_rad: float, who: str) -> None:
    """A :class:`StepSizeWarning` when ``body``'s principal moments span more than :data:`RULE_INERTIA_RATIO_MAX`.

    Parameters
    ----------
    body : RigidBody
        The (hub) body, single or batched (the most elongated body counts).
    budget_rad : float
        The run's budget [rad]; ``inf`` (the rule off) warns nothing.
    who : str
        The caller, named in the warning.
    """
    if not np.isfinite(budget_rad):
        return
    moments = np.linalg.eigvalsh(body.inertia)
    ratio = float(np.max(moments[..., -1] / moments[..., 0]))
    if ratio > RULE_INERTIA_RATIO_MAX:
        warnings.warn(
            f"{who}: the body's principal moments span a ratio of {ratio:.3g}, beyond the {RULE_INERTIA_RATIO_MAX:g} "
            "the step-size rule is calibrated for (docs/rk4_step_rule.md): its predicted attitude error is an "
            "estimate, not a checked bound (measured up to 1.075 times it at ratio 30); pass a smaller "
            "attitude_error_budget_rad for margin or use method='adaptive'",
            StepSizeWarning,
            stacklevel=3,
        )


def check_error_budget(value: Any, name: str = "attitude_error_budget_rad") -> float:
    """An accumulated attitude-error budget [rad]: positive, ``inf`` turning the step-size rule off.

    Parameters
    ----------
    value : float
        The budget [rad].
    name : str
        The argument, named in the error.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        If ``value`` is not a number greater than 0 (NaN included).
    """
    try:
        budget = float(value)
    except (TypeError, ValueError):
        budget = float("nan")
    if not budget > 0.0:
        raise ValueError(f"{name} must be a number > 0 rad (inf turns the step-size rule off), got {value!r}")
    return budget

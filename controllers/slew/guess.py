"""Initial guesses of the slew planner: the eigenaxis profile, smooth perturbations, a previous plan.

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq

from attitude import quaternion as quat
from controllers.slew.plan import SlewPlan, states_between
from controllers.slew.problem import Problem
from controllers.slew.reference import axis_angle, eigenaxis_profile

__all__ = ["COAST_MARGIN", "base_guess", "eigenaxis_start", "guess_from_plan", "perturbed", "project"]


#: The grid version of an eigenaxis start coasts this fraction below the rate
#: limit, so that the start lies strictly inside the limit (the RK4 sub-steps of
#: a coast exactly at the limit may cross it by rounding, and IPOPT then starts
#: in restoration).
COAST_MARGIN = 1e-3


def _smooth_noise(rng: np.random.Generator, s: NDArray, dims: int, modes: int = 3) -> NDArray[np.float64]:
    """Smooth random functions of ``s`` in [0, 1] vanishing at both ends, O(1) amplitude, shape (len(s), dims)."""
    coef = rng.normal(size=(modes, dims)) / np.arange(1, modes + 1)[:, None]
    basis = np.sin(np.pi * np.outer(s, np.arange(1, modes + 1)))
    return basis @ coef


def _profile(prob: Problem, axis: NDArray, angle: float, rate_max: float | None) -> dict | None:
    """The eigenaxis profile of the nondimensional problem with a rate cap (None if the torque set cannot make it)."""
    try:
        return eigenaxis_profile(prob.body_s.inertia, prob.rows_s, axis, angle, rate_max, 401)
    except ValueError:
        return None


def _stretched_eigenaxis(prob: Problem, axis: NDArray, angle: float, duration_s: float) -> dict | None:
    """The eigenaxis bang-coast-bang that takes exactly ``duration_s`` (units of T_s): the peak rate lowered.

    None when no eigenaxis slew takes that long within the limits (the
    duration is below the eigenaxis minimum time, or the torque set cannot
    make the eigenaxis slew). The duration falls from infinity to the minimum
    time as the peak rate rises from 0 to its unconstrained value, and a
    peak of ``angle / duration_s`` takes at least ``duration_s`` (the rate
    never exceeds the peak), which brackets the root.
    """
    if angle <= 0:
        return None
    inertia_s = prob.body_s.inertia
    try:
        fastest = eigenaxis_profile(inertia_s, prob.rows_s, axis, angle, prob.rate_max_scaled, 2, timing_only=True)
    except ValueError:
        return None
    if fastest["duration"] > duration_s:
        return None

    def excess(w: float) -> float:
        return eigenaxis_profile(inertia_s, prob.rows_s, axis, angle, w, 2, timing_only=True)["duration"] - duration_s

    low, high = angle / duration_s, fastest["rate_peak"]
    peak = high if excess(high) >= 0 else brentq(excess, min(low, high), high, xtol=1e-14 * high, rtol=1e-12)
    return _profile(prob, axis, angle, peak)


def _guess_on_grid(
    prob: Problem, n: int, axis: NDArray, duration_s: float, theta: NDArray, rate: NDArray
) -> tuple[NDArray, NDArray, float]:
    """States (7, n+1) and torques (3, n) of a rotation ``theta`` about ``axis`` at ``rate`` (on the nodes)."""
    s = np.linspace(0.0, 1.0, n + 1)
    q = quat.multiply(prob.q0, quat.from_axis_angle(axis, theta))
    w = rate[:, None] * axis[None, :]
    w = w + np.outer(1 - s, prob.omega0 * prob.t_s) + np.outer(s, prob.omegaf * prob.t_s)
    dw = np.diff(w, axis=0) / (duration_s / n)
    wm = 0.5 * (w[1:] + w[:-1])
    # Inverse dynamics from the one definition: tau = I (w_dot - w_dot_torque_free(w)).
    u = (dw - prob.body_s.omega_dot(wm)) @ prob.body_s.inertia.T
    return np.vstack([q.T, w.T]), u.T, duration_s


def _sampled(prob: Problem, n: int, axis: NDArray, duration_s: float, prof: dict) -> tuple[NDArray, NDArray, float]:
    """The guess of an eigenaxis profile ``prof`` (nondimensional) lasting ``duration_s``."""
    t = np.linspace(0.0, 1.0, n + 1) * duration_s
    theta = np.interp(t, prof["t"], prof["angle"])
    rate = np.interp(t, prof["t"], prof["rate"])
    return _guess_on_grid(prob, n, axis, duration_s, theta, rate)


def base_guess(prob: Problem, n: int, duration_s: float | None) -> tuple[NDArray, NDArray, float]:
    """Eigenaxis-based guess (nondimensional): states (7, n+1), torques (3, n), duration.

    Minimum time: the eigenaxis slew. Fixed duration: the minimum-energy cubic
    angle profile about the eigenaxis, unless its peak rate breaks the rate
    limit; then the eigenaxis bang-coast-bang stretched to the duration.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    n : int
        Number of intervals.
    duration_s : float or None
        Fixed duration in units of ``T_s``; None for the eigenaxis time.
    """
    axis, angle = axis_angle(prob.q0, prob.qf)
    if duration_s is None:
        eig = _profile(prob, axis, angle, prob.rate_max_scaled)
        if eig is not None and eig["duration"] > 0:
            extra = (np.linalg.norm(prob.omega0) + np.linalg.norm(prob.omegaf)) * prob.t_s
            if extra == 0:
                return _sampled(prob, n, axis, eig["duration"], eig)
            duration_s = eig["duration"] + extra
        else:
            extra = (np.linalg.norm(prob.omega0) + np.linalg.norm(prob.omegaf)) * prob.t_s
            duration_s = 2.0 * math.sqrt(max(angle, 0.1)) + extra
    elif prob.rate_max_scaled is not None and 1.5 * angle / duration_s > prob.rate_max_scaled:
        stretched = _stretched_eigenaxis(prob, axis, angle, duration_s)
        if stretched is not None:
            return _sampled(prob, n, axis, duration_s, stretched)
    # Cubic angle profile: the minimum-energy rest-to-rest double integrator.
    s = np.linspace(0.0, 1.0, n + 1)
    theta = angle * (3 * s**2 - 2 * s**3)
    rate = angle * (6 * s - 6 * s**2) / duration_s
    return _guess_on_grid(prob, n, axis, duration_s, theta, rate)


def eigenaxis_start(prob: Problem, n: int, duration_s: float | None) -> tuple[NDArray, NDArray, float] | None:
    """The eigenaxis slew as a start, unperturbed: a feasible path for the solver to fall back on.

    Minimum time: the eigenaxis slew itself. Fixed duration: the eigenaxis
    bang-coast-bang stretched to the duration (:func:`_stretched_eigenaxis`).
    None when there is none: boundary rates (the eigenaxis slew is rest to
    rest), a duration below the eigenaxis minimum time, or a torque set that
    cannot make the eigenaxis slew.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    n : int
        Number of intervals.
    duration_s : float or None
        Fixed duration in units of ``T_s``; None for minimum time.
    """
    if np.any(prob.omega0) or np.any(prob.omegaf):
        return None
    axis, angle = axis_angle(prob.q0, prob.qf)
    if duration_s is None:
        prof = _profile(prob, axis, angle, prob.rate_max_scaled)
        if prof is None or not prof["duration"] > 0:
            return None
        duration_s = prof["duration"]
        w = prof["rate_peak"]
        t_dec = duration_s - prof["t_acc"] - prof["coast"]
        if prof["coast"] > 0 and max(prof["t_acc"], t_dec) * n < duration_s * (n - 1):
            # Accelerations shorter than an interval (a tight rate limit): no torque held over an interval
            # reaches the profile's nodes. Its grid version accelerates over the first interval and
            # decelerates over the last, just below the rate limit in between (a start inside the limit):
            # angle = w (T - h), h = T / n.
            w *= 1.0 - COAST_MARGIN
            duration_s = angle / w * n / (n - 1)
            h = duration_s / n
            rate = np.full(n + 1, w)
            rate[0] = rate[-1] = 0.0
            theta = np.concatenate([[0.0], 0.5 * w * h + w * h * np.arange(n - 1), [angle]])
            X, U, T = _guess_on_grid(prob, n, axis, duration_s, theta, rate)
            return X, project(prob, U), T
    else:
        prof = _stretched_eigenaxis(prob, axis, angle, duration_s)
        if prof is None:
            return None
    X, U, T = _sampled(prob, n, axis, duration_s, prof)
    return X, project(prob, U), T


def perturbed(
    prob: Problem, X: NDArray, U: NDArray, amplitude: float, rng: np.random.Generator
) -> tuple[NDArray, NDArray]:
    """Perturb a guess smoothly: torque noise and an attitude bump, both vanishing at the ends.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    X : ndarray
        Guessed states (7, n + 1), nondimensional.
    U : ndarray
        Guessed torques (3, n), units of ``tau_s``.
    amplitude : float
        Size of the perturbation [-]: torque noise in units of the largest
        torque bound (at most ``J_s / T_s^2``), attitude bump in units of pi/4 rad.
    rng : numpy.random.Generator
        Source of the perturbation.
    """
    n = U.shape[1]
    if amplitude == 0:
        return X.copy(), project(prob, U)
    s_nodes = np.linspace(0.0, 1.0, n + 1)
    s_mid = (np.arange(n) + 0.5) / n
    # In units of the largest torque, but at most J_s / T_s^2 (one radian in T_s^2 / 2): a slew stretched past
    # SLEW_SPAN_MAX torque times needs far less than its torque limit.
    U = U + amplitude * _smooth_noise(rng, s_mid, 3).T * min(float(np.max(prob.u_bounds())), 1.0)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    bump = amplitude * (math.pi / 4) * np.sin(np.pi * s_nodes)
    q = quat.multiply(X[:4].T, quat.from_axis_angle(axis, bump))
    X = X.copy()
    X[:4] = q.T
    return X, project(prob, U)


def project(prob: Problem, U: NDArray) -> NDArray[np.float64]:
    """Scale each torque column into the torque set (direction kept).

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    U : ndarray
        Torques (3, n), units of ``tau_s``.
    """
    ratio = np.max(np.abs(prob.rows_s @ U), axis=0)
    return U / np.maximum(ratio, 1.0)


def guess_from_plan(prob: Problem, plan: SlewPlan, n: int) -> tuple[NDArray, NDArray, float]:
    """A previous plan on ``n`` uniform intervals (nondimensional): states (7, n+1), torques (3, n), duration.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    plan : SlewPlan
        A previous plan of the same slew.
    n : int
        Number of intervals.
    """
    t = np.linspace(0.0, plan.duration, n + 1)
    x = states_between(prob.body, plan.t, plan.q, plan.omega, plan.torque, t)
    mid = 0.5 * (t[1:] + t[:-1])
    k = np.clip(np.searchsorted(plan.t, mid, side="right") - 1, 0, plan.t.size - 2)
    X = np.vstack([x[:, :4].T, (x[:, 4:] * prob.t_s).T])
    return X, plan.torque[k].T / prob.tau_s, plan.duration / prob.t_s

"""Initial guesses of the slew planner: the eigenaxis profile, smooth perturbations, a previous plan.

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from attitude import quaternion as quat
from controllers.slew.plan import SlewPlan, states_between
from controllers.slew.problem import Problem
from controllers.slew.reference import axis_angle, eigenaxis_profile

__all__ = ["base_guess", "guess_from_plan", "perturbed", "project"]


def _smooth_noise(rng: np.random.Generator, s: NDArray, dims: int, modes: int = 3) -> NDArray[np.float64]:
    """Smooth random functions of ``s`` in [0, 1] vanishing at both ends, O(1) amplitude, shape (len(s), dims)."""
    coef = rng.normal(size=(modes, dims)) / np.arange(1, modes + 1)[:, None]
    basis = np.sin(np.pi * np.outer(s, np.arange(1, modes + 1)))
    return basis @ coef


def base_guess(prob: Problem, n: int, duration_s: float | None) -> tuple[NDArray, NDArray, float]:
    """Eigenaxis-based guess (nondimensional): states (7, n+1), torques (3, n), duration.

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
    inertia_s = prob.body_s.inertia
    eig = None
    try:
        eig = eigenaxis_profile(inertia_s, prob.rows_s, axis, angle, prob.rate_max_scaled, 401)
    except ValueError:
        eig = None
    if duration_s is None:
        base = eig["duration"] if eig is not None and eig["duration"] > 0 else 2.0 * math.sqrt(max(angle, 0.1))
        extra = (np.linalg.norm(prob.omega0) + np.linalg.norm(prob.omegaf)) * prob.t_s
        duration_s = base + extra
    s = np.linspace(0.0, 1.0, n + 1)
    t = s * duration_s
    if eig is not None and duration_s == eig["duration"] and eig["duration"] > 0:
        theta = np.interp(t, eig["t"], eig["angle"])
        rate = np.interp(t, eig["t"], eig["rate"])
    else:
        # Cubic angle profile: the minimum-energy rest-to-rest double integrator.
        theta = angle * (3 * s**2 - 2 * s**3)
        rate = angle * (6 * s - 6 * s**2) / duration_s
    q = quat.multiply(prob.q0, quat.from_axis_angle(axis, theta))
    w = rate[:, None] * axis[None, :]
    w = w + np.outer(1 - s, prob.omega0 * prob.t_s) + np.outer(s, prob.omegaf * prob.t_s)
    dw = np.diff(w, axis=0) / (duration_s / n)
    wm = 0.5 * (w[1:] + w[:-1])
    # Inverse dynamics from the one definition: tau = I (w_dot - w_dot_torque_free(w)).
    u = (dw - prob.body_s.omega_dot(wm)) @ inertia_s.T
    return np.vstack([q.T, w.T]), u.T, duration_s


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
        torque bound, attitude bump in units of pi/4 rad.
    rng : numpy.random.Generator
        Source of the perturbation.
    """
    n = U.shape[1]
    if amplitude == 0:
        return X.copy(), project(prob, U)
    s_nodes = np.linspace(0.0, 1.0, n + 1)
    s_mid = (np.arange(n) + 0.5) / n
    U = U + amplitude * _smooth_noise(rng, s_mid, 3).T * np.max(prob.u_bounds())
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

"""Initial guesses of the slew planner: the eigenaxis profile, smooth perturbations, a previous plan, start families.

Part of :mod:`controllers.slew.planner` (import the public names from there).

The start families of a multi-start search (docs/slew_planning.md, Guess and
multi-start), each a deterministic function of the problem, the grid, the
perturbation size and one seed, so that a larger start set repeats every
start of a smaller one exactly:

* ``"eigenaxis"``: the eigenaxis slew the short way, perturbed (the single
  start of the planner);
* ``"eigenaxis_long"``: the eigenaxis slew the long way round (``2 pi - phi``
  about ``-axis``), perturbed;
* ``"energy"``: the minimum-energy slew over :data:`ENERGY_START_STRETCH`
  eigenaxis times, solved first (a homotopy start: a smooth path that already
  uses every axis's torque);
* ``"principal"``: three starts, the eigenaxis path with an attitude detour
  of :data:`PRINCIPAL_DETOUR` rad about each principal axis of the body
  (``sin^2`` in time: the boundary rates are kept), lightly perturbed;
* ``"random"``: the eigenaxis slew with a larger seeded perturbation; repeat
  the name for more of them.
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

__all__ = [
    "COAST_MARGIN",
    "ENERGY_START_STRETCH",
    "MULTI_START",
    "PRINCIPAL_DETOUR",
    "START_FAMILIES",
    "StartSpec",
    "base_guess",
    "eigenaxis_start",
    "expand_starts",
    "family_guess",
    "guess_from_plan",
    "perturbed",
    "project",
]

#: The start families (module docstring), in their order in a start set.
START_FAMILIES = ("eigenaxis", "eigenaxis_long", "energy", "principal", "random")

#: The start set of a multi-start search: every family, two random starts
#: (eight minimum-time solves and one minimum-energy solve).
MULTI_START = ("eigenaxis", "eigenaxis_long", "energy", "principal", "random", "random")

#: The ``"energy"`` family solves the minimum-energy slew over this many
#: eigenaxis times (the eigenaxis slew is feasible over any longer duration,
#: so the energy problem has a solution; 5 % keeps the torque short of a
#: bang-bang profile, which is the smooth start the family is for).
ENERGY_START_STRETCH = 1.05

#: Detour [rad] of the ``"principal"`` family about each principal axis, at mid-slew.
PRINCIPAL_DETOUR = math.pi / 4

#: Perturbation of the ``"principal"`` starts, as a fraction of ``perturbation``
#: (the detour already leaves the eigenaxis; a little noise breaks symmetries).
PRINCIPAL_NOISE = 0.5

#: Seed stream of each family (the second word of its ``numpy`` seed).
_FAMILY_CODE = {"eigenaxis_long": 2, "energy": 3, "principal": 4, "random": 1}

#: Number of starts one name stands for.
_FAMILY_SIZE = {"principal": 3}

#: One start: its family and its index in the family.
StartSpec = tuple[str, int]


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


def base_guess(
    prob: Problem, n: int, duration_s: float | None, *, long_way: bool = False
) -> tuple[NDArray, NDArray, float]:
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
    long_way : bool
        Turn the long way round, ``2 pi - phi`` about ``-axis``.
    """
    axis, angle = axis_angle(prob.q0, prob.qf)
    if long_way:
        axis, angle = -axis, 2.0 * math.pi - angle
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


def expand_starts(starts: object) -> list[StartSpec]:
    """The starts of a ``starts`` argument: a count, a family name or a sequence of family names.

    A count ``k`` is the eigenaxis start and ``k - 1`` random ones (the
    planner's historical multi-start); ``"principal"`` stands for three
    starts (one per principal axis) and each ``"random"`` for one more random
    start. A start's guess depends on its family and its index in the family
    only (:func:`family_guess`), so a larger start set repeats a smaller one.

    Parameters
    ----------
    starts : int, str or sequence of str
        The start set (names from :data:`START_FAMILIES`).

    Raises
    ------
    ValueError
        Naming ``starts``: an empty set, a count below 1, an unknown name, or
        a family other than ``"random"`` named twice.
    """
    if isinstance(starts, (int, np.integer)) and not isinstance(starts, bool):
        if starts < 1:
            raise ValueError(f"starts must be a count >= 1 or family names from {START_FAMILIES}, got {starts!r}")
        return [("eigenaxis", 0)] + [("random", i) for i in range(int(starts) - 1)]
    names = (starts,) if isinstance(starts, str) else starts
    try:
        names = list(names)  # type: ignore[call-overload]
    except TypeError:
        raise ValueError(f"starts must be a count >= 1 or family names from {START_FAMILIES}, got {starts!r}") from None
    if not names:
        raise ValueError(f"starts must name at least one start (a count >= 1 or names from {START_FAMILIES}), got []")
    specs: list[StartSpec] = []
    for name in names:
        if name not in START_FAMILIES:
            raise ValueError(f"starts: unknown start family {name!r}; the families are {START_FAMILIES}")
        if name != "random" and any(f == name for f, _ in specs):
            raise ValueError(f"starts names {name!r} twice; repeat only 'random' (one more random start each)")
        if name == "random":
            specs.append((name, sum(f == "random" for f, _ in specs)))
        else:
            specs += [(name, i) for i in range(_FAMILY_SIZE.get(name, 1))]
    return specs


def family_guess(
    prob: Problem,
    n: int,
    spec: StartSpec,
    perturbation: float,
    seed: int,
    duration_s: float | None = None,
    energy: tuple[NDArray, NDArray] | None = None,
) -> tuple[NDArray, NDArray, float]:
    """The minimum-time start of one family member (module docstring), nondimensional.

    Parameters
    ----------
    prob : Problem
        The validated, nondimensional problem.
    n : int
        Number of intervals.
    spec : (str, int)
        Family and index in the family (:func:`expand_starts`); not ``"eigenaxis"``,
        whose start the planner draws from its own generator.
    perturbation : float
        The planner's ``perturbation``.
    seed : int
        Seed of the starts (one per planning call).
    duration_s : float, optional
        Fixed duration in units of ``T_s`` (minimum energy); None for minimum time.
    energy : (ndarray, ndarray), optional
        States (7, n + 1) and torques (3, n) of the minimum-energy answer, the
        ``"energy"`` start of a minimum-time plan; without it that start is the
        guess of the minimum-energy problem (the cubic about the eigenaxis).
    """
    family, index = spec
    rng = np.random.default_rng([seed, _FAMILY_CODE[family], index])
    X, U, T = base_guess(prob, n, duration_s, long_way=family == "eigenaxis_long")
    if family == "energy":
        if energy is not None:
            return energy[0].copy(), project(prob, energy[1]), T * ENERGY_START_STRETCH
        stretched = T if duration_s is not None else T * ENERGY_START_STRETCH
        X, U, _ = base_guess(prob, n, stretched)
        return X, project(prob, U), stretched
    if family == "random":
        X, U = perturbed(prob, X, U, perturbation * (1.0 + 0.5 * (index + 1)), rng)
        return X, U, T
    if family == "principal":
        axis_p = prob.body_s.principal_axes().axes_B[:, index]
        s = np.linspace(0.0, 1.0, n + 1)
        q = quat.multiply(X[:4].T, quat.from_axis_angle(axis_p, PRINCIPAL_DETOUR * np.sin(np.pi * s) ** 2))
        X, U = _from_attitudes(prob, q, T)
        X, U = perturbed(prob, X, U, PRINCIPAL_NOISE * perturbation, rng)
        return X, U, T
    X, U = perturbed(prob, X, U, perturbation, rng)
    return X, U, T


def _from_attitudes(prob: Problem, q: NDArray, duration_s: float) -> tuple[NDArray, NDArray]:
    """States and torques of a path of node attitudes (n + 1, 4) over ``duration_s``: rates and inverse dynamics.

    The rates solve ``q_dot = G(q) omega`` (least squares; ``G`` the
    kinematics of the one definition, read off its state derivative) with
    ``q_dot`` by second-order finite differences; the end rates are the
    boundary rates.
    """
    n = q.shape[0] - 1
    t = np.linspace(0.0, duration_s, n + 1)
    q_dot = np.gradient(q, t, axis=0, edge_order=2)
    body = prob.body_s
    G = np.stack(
        [body.state_derivative(np.concatenate([q, np.tile(e, (n + 1, 1))], axis=1))[:, :4] for e in np.eye(3)],
        axis=-1,
    )
    w = np.einsum("kij,kj->ki", np.linalg.pinv(G), q_dot)
    w[0], w[-1] = prob.omega0 * prob.t_s, prob.omegaf * prob.t_s
    dw = np.diff(w, axis=0) / (duration_s / n)
    wm = 0.5 * (w[1:] + w[:-1])
    u = (dw - body.omega_dot(wm)) @ body.inertia.T
    return np.vstack([q.T, w.T]), project(prob, u.T)

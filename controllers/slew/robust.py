"""Robust ("unscented") slews: one open-loop torque plan optimised over sigma points of the inertia uncertainty.

:func:`plan_robust_slew` plans one torque profile over a fixed duration (the time bound) that flies the
nominal spacecraft exactly to the target and keeps the terminal error of the dispersed spacecraft small:
the sigma points of the principal moments' uncertainty (the unscented transform) are flown as copies of
the plant driven by the same open-loop torque, and the weighted mean of their terminal errors
(``objective="expected"``) or the largest (``"worst"``, epigraph form) is minimised. This is the unscented
optimal control of Ross, Proulx and Karpenko (2014) on the multiple-shooting transcription of
:mod:`controllers.slew.transcription`.
:func:`controllers.slew.robust_comparison.compare_robust_slew` flies the robust plan and a nominal
plan over a Monte Carlo sample of the same uncertainty, open loop and tracked
(:class:`controllers.tracking.TrackingController`), and reports the spread of the terminal errors.

See docs/slew_planning.md ("Robust (unscented) slews") for the formulation, the distribution assumed, the
sigma-point variant and its weights, and the references.
"""

from __future__ import annotations

import math
import textwrap
import time
import warnings
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.propagate import propagate
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody
from attitude.validation import as_float_array, positive_scalar
from controllers.slew.checks import verify
from controllers.slew.planner import plan_slew
from controllers.slew.problem import (
    CONVERGED,
    InfeasibleSlewError,
    Problem,
    SlewPlanningError,
    check_count,
    validate,
)
from controllers.slew.transcription import (
    Transcription,
    check_ipopt_options,
    interval_function,
    ipopt_setup,
    sigint_guard,
)
from controllers.tracking import ReferenceTrajectory
from controllers.worst_case import UncertaintySet, perturbed_plant

if TYPE_CHECKING:
    import matplotlib.figure


__all__ = [
    "ENERGY_WEIGHT",
    "ROBUST_OBJECTIVES",
    "MomentUncertainty",
    "RobustSlewPlan",
    "dispersed_bodies",
    "moment_uncertainty",
    "plan_robust_slew",
    "unscented_sigma_points",
]

#: The objectives of :func:`plan_robust_slew`: the sigma-weighted mean of the terminal errors, or the largest.
ROBUST_OBJECTIVES = ("expected", "worst")

#: Default weight of the energy [rad^2]: the cost counts the nominal plan's energy as a terminal error of
#: 0.1 deg (squared), so a robust plan doubles the energy only where that buys more than 0.1 deg (rms over
#: the sigma points), and as the uncertainty vanishes the plan becomes the minimum-energy one
#: (docs/slew_planning.md, Robust (unscented) slews).
ENERGY_WEIGHT = math.radians(0.1) ** 2


# ---------------------------------------------------------------------------
# The uncertainty and its sigma points


def unscented_sigma_points(
    mean: ArrayLike, covariance: ArrayLike, *, kappa: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The symmetric ``2 n + 1`` sigma points and weights of Julier and Uhlmann's unscented transform.

    ``chi_0 = m``, ``chi_k = m + S_k`` and ``chi_{n+k} = m - S_k`` with ``S_k`` the rows of a square root
    ``S^T S = (n + kappa) P``; weights ``w_0 = kappa / (n + kappa)`` and ``w_k = 1 / (2 (n + kappa))``
    (filterpy's ``JulierSigmaPoints``; the square root is the upper Cholesky factor, or for a singular
    ``P`` the symmetric one from its eigen-decomposition). The weighted points reproduce the mean and the
    covariance exactly (``sum w chi = m``, ``sum w (chi - m)(chi - m)^T = P``); ``kappa >= 0`` keeps every
    weight non-negative, so a weighted cost stays a mean.

    Parameters
    ----------
    mean : array_like (n,)
        Mean of the distribution.
    covariance : array_like (n, n)
        Its covariance, symmetric positive semi-definite.
    kappa : float
        Spread parameter, >= 0 (0: the points at ``sqrt(n)`` standard deviations; with ``n = 3`` that is
        Julier and Uhlmann's ``kappa = 3 - n`` for a Gaussian).

    Returns
    -------
    points : ndarray (2 n + 1, n)
        The sigma points: the mean, the ``n`` points ``m + S_k``, then the ``n`` points ``m - S_k``.
    weights : ndarray (2 n + 1,)
        Their weights (sum 1).

    Raises
    ------
    ValueError
        For a covariance that is not symmetric positive semi-definite or of the wrong shape, or a negative
        ``kappa``.
    """
    from filterpy.kalman import JulierSigmaPoints
    from scipy.linalg import LinAlgError, cholesky

    m = np.atleast_1d(as_float_array(mean, "mean")).astype(float)
    p = as_float_array(covariance, "covariance")
    n = m.size
    if m.ndim != 1 or p.shape != (n, n):
        raise ValueError(f"mean must be (n,) and covariance (n, n); got shapes {m.shape} and {p.shape}")
    if not np.allclose(p, p.T, rtol=0.0, atol=1e-12 * max(1.0, float(np.max(np.abs(p))))):
        raise ValueError(f"covariance must be symmetric, got {p.tolist()}")
    kappa = positive_scalar(kappa, "kappa", allow_zero=True)
    eig = np.linalg.eigvalsh(p)
    if eig[0] < -1e-12 * max(1.0, float(eig[-1])):
        raise ValueError(f"covariance must be positive semi-definite, got eigenvalues {eig.tolist()}")

    def square_root(a: NDArray[np.float64]) -> NDArray[np.float64]:
        """``S`` with ``S^T S = a``: Cholesky, or the eigen-decomposition's root where ``a`` is singular."""
        try:
            return cholesky(a)
        except LinAlgError:
            vals, vecs = np.linalg.eigh(0.5 * (a + a.T))
            return np.sqrt(np.clip(vals, 0.0, None))[:, None] * vecs.T

    julier = JulierSigmaPoints(n, kappa=kappa, sqrt_method=square_root)
    return np.asarray(julier.sigma_points(m, p), dtype=float), np.asarray(julier.Wm, dtype=float)


@dataclass(frozen=True)
class MomentUncertainty:
    """The relative changes of the principal moments ``I1 <= I2 <= I3``: independent, zero mean.

    Parameters
    ----------
    distribution : str
        ``"uniform"`` (each change uniform in ``[-bound, bound]``, from an :class:`UncertaintySet`) or
        ``"normal"`` (each change normal with standard deviation ``sigma``).
    sigma : ndarray (3,)
        Standard deviation of each relative change [-] (``bound / sqrt(3)`` for the uniform one).
    bound : ndarray (3,)
        Half-width of the uniform interval [-] (``inf`` for the normal one).
    """

    distribution: str
    sigma: NDArray[np.float64]
    bound: NDArray[np.float64]

    def words(self) -> str:
        """The distribution in words, e.g. ``"principal moments uniform within +-10 %"``."""
        if self.distribution == "uniform":
            return (
                "principal moments uniform within +-"
                + ", ".join(f"{100 * b:.3g}" for b in np.unique(self.bound))
                + " %"
            )
        return "principal moments normal, sigma " + ", ".join(f"{100 * s:.3g}" for s in self.sigma) + " %"

    @property
    def empty(self) -> bool:
        """Whether the moments are known exactly."""
        return not np.any(self.sigma)

    def sample(self, rng: np.random.Generator, count: int) -> NDArray[np.float64]:
        """``count`` draws of the three relative changes (count, 3).

        Parameters
        ----------
        rng : numpy.random.Generator
            The random source.
        count : int
            Number of draws.
        """
        if self.distribution == "uniform":
            return rng.uniform(-self.bound, self.bound, size=(count, 3))
        return rng.standard_normal((count, 3)) * self.sigma


def moment_uncertainty(inertia_uncertainty: UncertaintySet | ArrayLike) -> MomentUncertainty:
    """The distribution of the principal moments' relative changes that a robust slew disperses.

    Parameters
    ----------
    inertia_uncertainty : UncertaintySet or array_like
        An :class:`UncertaintySet` (the ``[uncertainty]`` table of a spacecraft file): each moment uniform
        within ``+-inertia_percent``; its other bounds (principal-axis rotation, wheel misalignment, extra
        delay) must be zero, since the robust plan disperses the moments only (docs/slew_planning.md). Or
        the standard deviation of each moment's relative change [-] (a scalar or 3 values, >= 0, e.g. 0.05
        for 5 %): independent normal changes.

    Returns
    -------
    MomentUncertainty

    Raises
    ------
    ValueError
        Naming ``inertia_uncertainty`` and the rule broken: a negative or non-finite deviation, a wrong
        shape, or a set with a non-zero bound other than the moments'.
    """
    if isinstance(inertia_uncertainty, UncertaintySet):
        others = {
            "axis_rotation_deg": inertia_uncertainty.axis_rotation_deg,
            "wheel_misalignment_deg": inertia_uncertainty.wheel_misalignment_deg,
            "extra_delay_s": inertia_uncertainty.extra_delay_s,
        }
        extra = {k: v for k, v in others.items() if v}
        if extra:
            raise ValueError(
                f"inertia_uncertainty: the robust slew disperses the principal moments only; the set's other "
                f"bounds must be 0, got {extra} (pass dataclasses.replace(set, "
                + ", ".join(f"{k}=0.0" for k in extra)
                + "))"
            )
        p = inertia_uncertainty.inertia_percent / 100.0
        bound = np.full(3, p)
        return MomentUncertainty("uniform", bound / math.sqrt(3.0), bound)
    arr = as_float_array(inertia_uncertainty, "inertia_uncertainty")
    if arr.shape not in ((), (1,), (3,)):
        raise ValueError(
            f"inertia_uncertainty must be an UncertaintySet or the relative standard deviation of the principal "
            f"moments (a scalar or 3 values), got shape {arr.shape}"
        )
    if np.any(arr < 0):
        raise ValueError(
            f"inertia_uncertainty (relative standard deviation of the principal moments) must be >= 0, "
            f"got {arr.tolist()}"
        )
    sigma = np.broadcast_to(arr, (3,)).astype(float).copy()
    return MomentUncertainty("normal", sigma, np.full(3, math.inf))


def dispersed_bodies(body: RigidBody, changes: NDArray[np.float64]) -> list[RigidBody]:
    """The bodies with the principal moments scaled by ``1 + change`` (rows of ``changes``), axes unchanged.

    Built by :func:`controllers.worst_case.perturbed_plant` (the one formula of a perturbed inertia) on a set
    just wide enough to hold every change.

    Parameters
    ----------
    body : RigidBody
        The nominal spacecraft [kg m^2].
    changes : ndarray (N, 3)
        Relative changes of the principal moments ``I1 <= I2 <= I3`` [-], each above -1.
    """
    widest = float(np.max(np.abs(changes))) if changes.size else 0.0
    if widest >= 1.0:
        raise ValueError(
            f"inertia_uncertainty leaves a principal moment non-positive: a relative change of {widest:.3g} "
            "(the sigma points or samples must stay above -100 %)"
        )
    span = UncertaintySet(inertia_percent=100.0 * widest * (1.0 + 1e-12)) if widest else UncertaintySet()
    bodies = []
    for change in changes:
        try:
            bodies.append(perturbed_plant(body, span, change if widest else np.zeros(0)).body)
        except ValueError as exc:
            raise ValueError(
                f"inertia_uncertainty: the moment changes {np.round(100 * change, 4).tolist()} % give no "
                f"physical body: {exc}"
            ) from exc
    return bodies


def _sigma_set(body: RigidBody, spread: MomentUncertainty) -> tuple[NDArray, NDArray, list[RigidBody]]:
    """Sigma points of the moment changes (7, 3), their weights (7,) and bodies (kappa = 0, docs)."""
    points, weights = unscented_sigma_points(np.zeros(3), np.diag(spread.sigma**2), kappa=0.0)
    return points, weights, dispersed_bodies(body, points)


# ---------------------------------------------------------------------------
# The plan


@dataclass
class RobustSlewPlan(ResultIO):
    """A robust (unscented) slew: the nominal trajectory of the shared torque, and the sigma points' errors.

    ``torque[k]`` is held over ``[t[k], t[k+1])`` and the last row repeats the last interval's, as in a
    :class:`controllers.slew.SlewPlan`: a :class:`controllers.tracking.TrackingController` flies either, but
    the robust plan is meant for open-loop flight (tracked, it does worse than the nominal plan:
    :func:`plan_robust_slew`).

    Attributes
    ----------
    t : ndarray (n + 1,)
        Node times [s], uniform from 0 to ``duration``.
    q : ndarray (n + 1, 4)
        Attitude ``q_BN`` of the nominal body under the plan.
    omega : ndarray (n + 1, 3)
        Body rate of the nominal body [rad/s].
    torque : ndarray (n + 1, 3)
        The open-loop body torque [N m].
    duration : float
        The fixed duration (the time bound) [s].
    objective : str
        ``"expected"`` or ``"worst"``.
    objective_value : float
        The sigma-weighted mean (or the largest) terminal error of the sigma points on re-simulation [rad^2].
    nominal_objective_value : float
        The same for the nominal (minimum-energy) plan over the same duration [rad^2].
    energy : float
        ``integral |tau|^2 dt`` [N^2 m^2 s].
    nominal_energy : float
        The same for the nominal plan [N^2 m^2 s].
    sigma_moment_change : ndarray (7, 3)
        The sigma points: relative changes of the principal moments ``I1 <= I2 <= I3`` [-].
    sigma_weights : ndarray (7,)
        Their unscented weights.
    sigma_inertia : ndarray (7, 3, 3)
        Their inertias [kg m^2].
    sigma_attitude_error : ndarray (7,)
        Terminal attitude error angle of each sigma point under this plan (open loop, re-simulated) [rad].
    sigma_rate_error : ndarray (7,)
        Terminal ``|omega - omegaf|`` of each sigma point [rad/s].
    nominal_sigma_attitude_error, nominal_sigma_rate_error : ndarray (7,)
        The same under the nominal plan.
    nominal_q, nominal_omega, nominal_torque : ndarray (n + 1, 4), (n + 1, 3), (n + 1, 3)
        The nominal plan on the same grid (:func:`plan_slew`'s minimum-energy slew over ``duration``):
        attitude, rate [rad/s] and torque [N m], for the comparison (:meth:`nominal_reference`).
    rate_error_time : float
        Weight of the rate error in the terminal error [s] (docs/slew_planning.md).
    final_attitude_error : float
        Terminal attitude error of the nominal body on re-simulation (adaptive) [rad].
    final_rate_error : float
        Terminal rate error of the nominal body on re-simulation [rad/s].
    q_target, omega_target : ndarray
        The requested final attitude and rate [rad/s].
    q_start, omega_start : ndarray
        The initial attitude and rate [rad/s].
    inertia : ndarray (3, 3)
        The nominal inertia [kg m^2].
    torque_envelope : ndarray (3,)
        Largest torque per body axis of the torque set [N m].
    status : str
        IPOPT's return status.
    iterations : int
        IPOPT iterations.
    solve_time : float
        Wall time inside the robust IPOPT solve [s].
    wall_time : float
        Wall time of the whole call (nominal plans, robust solve, re-simulations) [s].
    info : dict
        Scaling, grid, distribution, weights, the nominal plan's minimum time.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    torque: NDArray[np.float64]
    duration: float
    objective: str
    objective_value: float
    nominal_objective_value: float
    energy: float
    nominal_energy: float
    sigma_moment_change: NDArray[np.float64]
    sigma_weights: NDArray[np.float64]
    sigma_inertia: NDArray[np.float64]
    sigma_attitude_error: NDArray[np.float64]
    sigma_rate_error: NDArray[np.float64]
    nominal_sigma_attitude_error: NDArray[np.float64]
    nominal_sigma_rate_error: NDArray[np.float64]
    nominal_q: NDArray[np.float64]
    nominal_omega: NDArray[np.float64]
    nominal_torque: NDArray[np.float64]
    rate_error_time: float
    final_attitude_error: float
    final_rate_error: float
    q_target: NDArray[np.float64]
    omega_target: NDArray[np.float64]
    q_start: NDArray[np.float64]
    omega_start: NDArray[np.float64]
    inertia: NDArray[np.float64]
    torque_envelope: NDArray[np.float64]
    status: str
    iterations: int
    solve_time: float
    wall_time: float
    info: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> str:
        """One line: duration, sigma-point terminal error against the nominal plan's; for open-loop flight."""
        return (
            f"robust ({self.objective}) slew {self.duration:.5g} s: sigma-point terminal error "
            f"{math.degrees(math.sqrt(self.objective_value)):.4g} deg (nominal plan "
            f"{math.degrees(math.sqrt(self.nominal_objective_value)):.4g} deg), energy "
            f"{self.energy:.4g} N^2 m^2 s (nominal {self.nominal_energy:.4g}); for open-loop flight: tracked by "
            "feedback it does worse than the nominal plan (docs/slew_planning.md)"
        )

    def sigma_terminal_error(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Each sigma point's terminal error ``sqrt(4 sin^2(angle / 2) + (rate_error_time rate)^2)`` [rad].

        Returns
        -------
        (ndarray (7,), ndarray (7,))
            Under this plan, and under the nominal plan.
        """

        def combined(angle: NDArray, rate: NDArray) -> NDArray[np.float64]:
            return np.sqrt(4.0 * np.sin(angle / 2.0) ** 2 + (self.rate_error_time * rate) ** 2)

        return (
            combined(self.sigma_attitude_error, self.sigma_rate_error),
            combined(self.nominal_sigma_attitude_error, self.nominal_sigma_rate_error),
        )

    def plot(self) -> matplotlib.figure.Figure:
        """The robust and the nominal torque over time [mN m], and each sigma point's terminal errors."""
        from matplotlib.figure import Figure

        from attitude.plotting import AXIS_COLORS

        fig = Figure(figsize=(12, 7.5), layout="constrained")
        grid = fig.add_gridspec(2, 2)
        ax_t = fig.add_subplot(grid[0, :])
        for i, name in enumerate("xyz"):
            ax_t.step(
                self.t, 1e3 * self.torque[:, i], where="post", color=AXIS_COLORS[i], label=rf"robust $\tau_{name}$"
            )
            ax_t.step(
                self.t,
                1e3 * self.nominal_torque[:, i],
                where="post",
                color=AXIS_COLORS[i],
                ls="--",
                lw=1.0,
                label=rf"nominal $\tau_{name}$",
            )
        for bound in self.torque_envelope:
            ax_t.axhline(1e3 * bound, color="gray", ls=":", lw=0.8)
            ax_t.axhline(-1e3 * bound, color="gray", ls=":", lw=0.8)
        ax_t.set_xlabel("time [s]")
        ax_t.set_ylabel("torque [mN m]")
        ax_t.set_title("torque: robust plan (solid), nominal minimum-energy plan (dashed), torque box (dotted)")
        top = 1e3 * float(np.max(self.torque_envelope))
        ax_t.set_ylim(-1.1 * top, 1.5 * top)  # room for the legend above the box
        ax_t.legend(ncols=6, fontsize="small", loc="upper center")
        ax_t.grid(True, alpha=0.3)
        labels = [
            ", ".join(f"I{i + 1} {100 * c:+.3g} %" for i, c in enumerate(point) if c) or "nominal"
            for point in self.sigma_moment_change
        ]
        x = np.arange(len(labels))
        for ax, (robust, nominal, unit, title) in zip(
            (fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[1, 1])),
            (
                (
                    np.degrees(self.sigma_attitude_error),
                    np.degrees(self.nominal_sigma_attitude_error),
                    "deg",
                    "attitude",
                ),
                (np.degrees(self.sigma_rate_error), np.degrees(self.nominal_sigma_rate_error), "deg/s", "rate"),
            ),
        ):
            ax.bar(x - 0.2, robust, width=0.4, color="tab:blue", label="robust plan")
            ax.bar(x + 0.2, nominal, width=0.4, color="tab:orange", label="nominal plan")
            ax.set_xticks(x, labels, rotation=30, fontsize="small")
            ax.set_ylabel(f"terminal {title} error [{unit}]")
            ax.set_title(f"sigma points' terminal {title} error (open loop)")
            ax.legend(fontsize="small")
            ax.grid(True, axis="y", alpha=0.3)
        fig.suptitle(textwrap.fill(self.summary(), 150), fontsize="medium")  # the summary runs past one line
        return fig

    def nominal_reference(self) -> ReferenceTrajectory:
        """The nominal plan as a :class:`controllers.tracking.ReferenceTrajectory` (to fly or track it)."""
        return ReferenceTrajectory(t=self.t, q=self.nominal_q, omega=self.nominal_omega, torque=self.nominal_torque)


def _terminal_error(q_err_vec: Any, rate_err: Any, rate_weight: float) -> Any:
    """``4 |vec(qf* q)|^2 + (rate_weight |omega - omegaf|)^2`` [rad^2] on casadi expressions."""
    return 4.0 * ca.sumsqr(q_err_vec) + rate_weight**2 * ca.sumsqr(rate_err)


def _sigma_errors(
    prob: Problem, bodies: list[RigidBody], t: NDArray, torque: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Terminal attitude error angles [rad] and rate errors [rad/s] of ``bodies`` under the held ``torque``."""
    batch = RigidBody(np.stack([b.inertia for b in bodies]))
    count = len(bodies)
    traj = propagate(
        batch,
        np.broadcast_to(prob.q0, (count, 4)),
        np.broadcast_to(prob.omega0, (count, 3)),
        t,
        np.vstack([torque, torque[-1:]])[:, None, :],
        method="adaptive",
        rtol=1e-10,
        atol=1e-12,
    )
    q_end = quat.normalize(traj.q[:, -1])
    return (
        np.asarray(quat.error_angle(prob.qf, q_end), dtype=float),
        np.linalg.norm(traj.omega[:, -1] - prob.omegaf, axis=-1),
    )


def _mean_or_worst(objective: str, weights: NDArray, attitude: NDArray, rate: NDArray, rate_weight: float) -> float:
    """The plan's objective on re-simulated errors: ``4 sin^2(angle / 2) + (t_w rate)^2`` weighted or worst."""
    e = 4.0 * np.sin(attitude / 2.0) ** 2 + (rate_weight * rate) ** 2
    return float(weights @ e) if objective == "expected" else float(np.max(e))


def plan_robust_slew(
    body: RigidBody,
    q0: ArrayLike,
    qf: ArrayLike,
    *,
    torque_max: ArrayLike | ReactionWheels,
    duration: float,
    inertia_uncertainty: UncertaintySet | ArrayLike,
    objective: str = "expected",
    omega0: ArrayLike = 0.0,
    omegaf: ArrayLike = 0.0,
    rate_error_time: float | None = None,
    energy_weight: float = ENERGY_WEIGHT,
    nodes: int = 30,
    substeps: int = 2,
    max_iter: int = 1000,
    ipopt_options: dict[str, Any] | None = None,
    verify_tolerance: float = 1e-4,
) -> RobustSlewPlan:
    """Plan one open-loop slew over a fixed duration that holds up on the dispersed spacecraft (docs/slew_planning.md).

    The torque profile (held over ``nodes`` intervals, inside the torque set) must fly the nominal body from
    ``(q0, omega0)`` to ``(qf, omegaf)`` in ``duration``; among such profiles it minimises the terminal
    error of the sigma points of the moments' uncertainty (each flown by the same torque from the same
    start), ``e = 4 |vec(qf* q(T))|^2 + (rate_error_time |omega(T) - omegaf|)^2`` [rad^2] (``4 sin^2``
    of half the error angle: the squared angle for small errors), their unscented mean
    (``"expected"``) or their largest (``"worst"``), plus ``energy_weight`` times the energy relative to
    the nominal plan's. Sigma points equal to the nominal body are the nominal body (its error is zero by
    the end conditions), so with no uncertainty the problem is the minimum-energy slew. The warm start is
    the nominal plan, :func:`plan_slew`'s minimum-energy slew over the same duration, with each sigma
    body's states those of its own flight under that torque.

    The plan is meant for open-loop flight (no attitude and rate feedback, Ross et al.'s case). Tracked by
    feedback it does worse than the nominal plan: the feedback pulls each dispersed body onto the nominal
    trajectory and undoes the deviations the robust plan relies on (docs/slew_planning.md, Robust
    (unscented) slews, Measured: 0.15 against 0.09 deg median attitude error tracked at twice the minimum
    time, 0.066 against 0.005 deg/s in rate). Track the nominal plan instead.

    Parameters
    ----------
    body : RigidBody
        The nominal spacecraft (a single body) [kg m^2].
    q0, qf : array_like (4,)
        Initial and final attitude ``q_BN``.
    torque_max : float, array_like (3,) or ReactionWheels
        Per-axis torque bound [N m], or a wheel set whose allocation envelope limits the body torque.
    duration : float
        The time bound: the slew's fixed duration [s], at least the nominal minimum time.
    inertia_uncertainty : UncertaintySet or array_like
        The moments' uncertainty (:func:`moment_uncertainty`): a set (uniform within
        ``+-inertia_percent``) or per-moment relative standard deviations (normal).
    objective : {"expected", "worst"}
        The unscented mean of the sigma points' terminal error, or the largest.
    omega0, omegaf : float or array_like (3,)
        Initial and final body rate [rad/s] (default rest).
    rate_error_time : float, optional
        Weight of the rate error [s]: a rate error counts as the attitude it drifts in this time (default
        ``duration``).
    energy_weight : float
        Weight of the energy [rad^2], >= 0: the nominal plan's energy costs as much as a terminal error of
        ``sqrt(energy_weight)`` rad (default :data:`ENERGY_WEIGHT`, 0.1 deg).
    nodes : int
        Intervals of the uniform grid (>= 4).
    substeps : int
        RK4 steps per interval.
    max_iter : int
        IPOPT iteration limit of the robust solve (the nominal plans keep :func:`plan_slew`'s).
    ipopt_options : dict, optional
        Extra IPOPT options of every solve (override :data:`controllers.slew.IPOPT_DEFAULTS`).
    verify_tolerance : float
        Largest accepted terminal attitude error of the nominal body's re-simulation [rad] (rate:
        ``verify_tolerance / T_s``), as :func:`plan_slew`.

    Returns
    -------
    RobustSlewPlan

    Raises
    ------
    ValueError
        Bad input (named): a negative uncertainty, an unknown objective, a bad duration or weight.
    InfeasibleSlewError
        ``duration`` below the nominal minimum time (named, with both times).
    SlewPlanningError
        IPOPT did not converge, or the nominal body misses the target on re-simulation: no plan is
        returned.

    Warns
    -----
    RuntimeWarning
        The robust plan's sigma-point error exceeds the nominal plan's (a worse local optimum; also in
        ``plan.info["warnings"]``).
    """
    with sigint_guard("robust slew planning interrupted (Ctrl-C)"):
        wall_start = time.perf_counter()
        prob = validate(body, q0, qf, omega0, omegaf, torque_max, None, (), substeps)
        if objective not in ROBUST_OBJECTIVES:
            raise ValueError(f"objective must be one of {ROBUST_OBJECTIVES}, got {objective!r}")
        duration = positive_scalar(duration, "duration")
        spread = moment_uncertainty(inertia_uncertainty)
        rate_error_time = duration if rate_error_time is None else positive_scalar(rate_error_time, "rate_error_time")
        energy_weight = positive_scalar(energy_weight, "energy_weight", allow_zero=True)
        n = check_count(nodes, "nodes", 4)
        max_iter = check_count(max_iter, "max_iter", 1)
        verify_tolerance = positive_scalar(verify_tolerance, "verify_tolerance")
        options = check_ipopt_options(ipopt_options)
        points, weights, bodies = _sigma_set(prob.body, spread)

        fastest = plan_slew(
            body, q0, qf, omega0=omega0, omegaf=omegaf, torque_max=torque_max, nodes=n, substeps=substeps
        )
        if duration < fastest.duration:
            raise InfeasibleSlewError(
                f"duration must be at least the nominal minimum time {fastest.duration:.6g} s (the time bound "
                f"cannot be met faster), got {duration!r} s",
                status="duration_below_minimum_time",
                cause="duration below the minimum time",
                details={"minimum_time_s": fastest.duration},
            )
        nominal = plan_slew(
            body,
            q0,
            qf,
            omega0=omega0,
            omegaf=omegaf,
            torque_max=torque_max,
            objective="energy",
            duration=duration,
            nodes=n,
            substeps=substeps,
            ipopt_options=options,
        )
        prob = prob.scaled_to(duration)
        t_s, tau_s = prob.t_s, prob.tau_s
        h = duration / n / t_s
        t = np.linspace(0.0, duration, n + 1)
        nominal_torque = nominal.torque[:-1]
        nominal_att, nominal_rate = _sigma_errors(prob, bodies, nominal.t, nominal_torque)
        nominal_value = _mean_or_worst(objective, weights, nominal_att, nominal_rate, rate_error_time)
        nominal_energy_s = float(np.sum(nominal_torque**2) * h) / tau_s**2
        # A constant factor on the whole cost: the optimum is the same, IPOPT sees a cost near one.
        cost_scale = max(nominal_value, energy_weight) or 1.0

        # The nominal body: plan_slew's transcription (dynamics, both ends, torque set).
        tr = Transcription(prob, n, options)
        opti = tr.opti
        U = opti.variable(3, n)
        H = ca.DM.ones(1, n) * h
        tr.constrain(U, H)
        tr.torque_set(U)
        # Each sigma body: its own states from the same start under the same torque, its end free.
        x0 = ca.DM(prob.x0)
        w_f = prob.qf
        omega_f_s = prob.omegaf * t_s
        rate_weight_s = rate_error_time / t_s
        errors, guesses = [], []
        x_guess = nominal.q, nominal.omega * t_s
        for point, b in zip(points, bodies):
            if not np.any(point):
                errors.append(0.0)  # the nominal body, whose end state is fixed: no copy
                continue
            sub = replace(prob, body=b, body_s=RigidBody(b.inertia / prob.j_s))
            free = opti.variable(7, n)
            X = ca.horzcat(x0, free)
            defect = interval_function(sub).fun.map(n)(X[:, :-1], U, H, X[:, 1:])[0]
            opti.subject_to(ca.vec(defect) == 0)
            qe = quat.multiply_components([w_f[0], -w_f[1], -w_f[2], -w_f[3]], [X[i, -1] for i in range(4)])
            errors.append(_terminal_error(ca.vertcat(*qe[1:]), X[4:, -1] - omega_f_s, rate_weight_s))
            guesses.append((free, _flight(sub, prob.x0, nominal_torque.T / tau_s, h)[:, 1:]))
        energy_s = ca.sum2(ca.sum1(U * U) * H)
        if objective == "expected":
            robust_cost = sum(float(w) * e for w, e in zip(weights, errors))
            extra_guess = []
        else:
            bound = opti.variable()
            for e in errors:
                if not isinstance(e, float):
                    opti.subject_to(e <= bound)
            opti.subject_to(bound >= 0.0)
            robust_cost = bound
            extra_guess = [(bound, nominal_value)]
        opti.minimize((robust_cost + energy_weight * energy_s / max(nominal_energy_s, 1e-300)) / cost_scale)
        ipopt_setup(tr, max_iter)
        nominal_x = np.concatenate([x_guess[0], x_guess[1]], axis=1).T
        initial = [(tr.X, nominal_x), (U, nominal_torque.T / tau_s), *guesses, *extra_guess]
        status, iterations, solve_time, values = tr.solve(initial, {"U": U, "X": tr.X})
        if status not in CONVERGED:
            raise SlewPlanningError(
                f"robust slew: IPOPT did not converge ({status} after {iterations} iterations); no plan returned",
                status=status,
                cause="the robust problem did not converge (raise max_iter, or nodes)",
                details={"iterations": iterations},
            )
        torque = values["U"].reshape(3, n).T * tau_s
        ratio = prob.torque_set.ratio(torque)
        torque = torque / np.maximum(ratio, 1.0)[:, None]
        check = verify(prob, t, np.vstack([torque, torque[-1:]]), verify_tolerance)
        sigma_att, sigma_rate = _sigma_errors(prob, bodies, t, torque)
        X = values["X"].reshape(7, n + 1)
        value = _mean_or_worst(objective, weights, sigma_att, sigma_rate, rate_error_time)
        notes = []
        # Warm-started on the nominal plan, whose cost it can only lower: a higher error is a worse local optimum.
        if value > nominal_value * (1.0 + 1e-6) + 1e-15:
            notes.append(
                f"the robust plan's sigma-point terminal error {value:.4g} rad^2 exceeds the nominal plan's "
                f"{nominal_value:.4g} rad^2: IPOPT ended in a worse local optimum (try other nodes)"
            )
        for note in notes:
            warnings.warn(note, RuntimeWarning, stacklevel=2)
        energy = float(np.sum(torque**2) * duration / n)
        return RobustSlewPlan(
            t=t,
            q=X[:4].T.copy(),
            omega=X[4:].T / t_s,
            torque=np.vstack([torque, torque[-1:]]),
            duration=duration,
            objective=objective,
            objective_value=value,
            nominal_objective_value=nominal_value,
            energy=energy,
            nominal_energy=float(nominal.objective_value),
            sigma_moment_change=points,
            sigma_weights=weights,
            sigma_inertia=np.stack([b.inertia for b in bodies]),
            sigma_attitude_error=sigma_att,
            sigma_rate_error=sigma_rate,
            nominal_sigma_attitude_error=nominal_att,
            nominal_sigma_rate_error=nominal_rate,
            nominal_q=nominal.q.copy(),
            nominal_omega=nominal.omega.copy(),
            nominal_torque=nominal.torque.copy(),
            rate_error_time=rate_error_time,
            final_attitude_error=float(check["final_attitude_error"]),
            final_rate_error=float(check["final_rate_error"]),
            q_target=prob.qf.copy(),
            omega_target=prob.omegaf.copy(),
            q_start=prob.q0.copy(),
            omega_start=prob.omega0.copy(),
            inertia=prob.body.inertia,
            torque_envelope=prob.torque_set.envelope.copy(),
            status=status,
            iterations=iterations,
            solve_time=solve_time,
            wall_time=time.perf_counter() - wall_start,
            info={
                "scaling": {"inertia_kg_m2": prob.j_s, "torque_n_m": tau_s, "time_s": t_s},
                "nodes": n,
                "substeps": prob.substeps,
                "distribution": spread.distribution,
                "moment_sigma": spread.sigma.tolist(),
                "unscented_kappa": 0.0,
                "energy_weight": energy_weight,
                "minimum_time_s": fastest.duration,
                "torque_set": prob.torque_set.label,
                "nominal_plan_status": nominal.status,
                "warnings": notes,
            },
        )


def _flight(prob: Problem, x0: NDArray, U: NDArray, h: float) -> NDArray[np.float64]:
    """Nondimensional states (7, n + 1) of ``prob``'s body flown from ``x0`` under ``U`` (3, n) (the NLP's steps)."""
    step = interval_function(replace(prob, cones=(), rate_max=None)).fun
    states = [np.asarray(x0, dtype=float)]
    for k in range(U.shape[1]):
        # The defect with x_next = 0 is the step's end state itself.
        end = step(states[-1], U[:, k], h, np.zeros(7))[0]
        states.append(np.asarray(end, dtype=float).ravel())
    return np.array(states).T

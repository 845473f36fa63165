"""The slew plan: result dataclass, resampling and its figure.

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.integrators import casadi_rk4_step
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody
from attitude.simulation.plant import PlantModel
from attitude.validation import check_positive, check_vector, positive_scalar
from controllers.slew.keep_out import KeepOutCone
from controllers.slew.optimality import summary_words

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = [
    "STATUS_WORDS",
    "SlewPlan",
    "cone_arrays",
    "plan_title",
    "plot_plan",
    "plot_wheel_plan",
    "states_between",
]

#: IPOPT statuses in words for figure titles.
STATUS_WORDS = {"Solve_Succeeded": "converged", "Solved_To_Acceptable_Level": "converged (acceptable level)"}


def cone_arrays(cones: Sequence[KeepOutCone]) -> tuple[NDArray, NDArray, NDArray]:
    """Boresights (m, 3), directions (m, 3) and half angles (m,) [rad] of the cones, for storage.

    Parameters
    ----------
    cones : sequence of KeepOutCone
        The keep-out cones.
    """
    if not cones:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    return (
        np.array([c.boresight_B for c in cones]),
        np.array([c.direction_N for c in cones]),
        np.array([c.half_angle for c in cones]),
    )


@dataclass
class SlewPlan(ResultIO):
    """An optimal slew: states and torque on the plan grid, and how it was obtained.

    ``torque[k]`` is held over ``[t[k], t[k+1])`` (zero-order hold, as
    :func:`attitude.propagate.propagate` applies a torque array); the last
    row repeats the final interval's torque so that all arrays share ``t``.

    Attributes
    ----------
    t : ndarray (n,)
        Time [s], from 0 to ``duration``; uniform on the node grid,
        piecewise uniform (one block per phase) after refinement.
    q : ndarray (n, 4)
        Attitude ``q_BN`` (the final one is ``qf`` or ``-qf``).
    omega : ndarray (n, 3)
        Body rate ``omega_BN_B`` [rad/s].
    torque : ndarray (n, 3)
        Body torque [N m].
    duration : float
        Duration of this trajectory [s] (the refined one when refined).
    objective : str
        ``"time"`` or ``"energy"``.
    objective_value : float
        Duration [s] or ``integral |tau|^2 dt`` [N^2 m^2 s] of this trajectory.
    status : str
        IPOPT return status of the solve that produced this trajectory.
    iterations : int
        IPOPT iterations of that solve.
    wall_time : float
        Wall time of the whole planning call [s] (all starts, refinement
        and verification).
    solve_time : float
        Wall time inside IPOPT solves [s], all starts and refinement.
    grid_duration : float
        Duration [s] of the best solution on the uniform node grid.
    refined_duration : float or None
        Duration [s] after the multi-phase refinement (None if not
        refined). Grid-converged (exact up to the RK4 error) only for a pure
        bang-bang answer, every phase a vertex of the torque set
        (``info["refinement"]["grid_converged"]``); with rate-limited coasts,
        partly saturated or keep-out boundary arcs it is the best answer on
        the refined grid, whose phase ends move freely but whose unsaturated
        torque is still piecewise constant.
    switch_times : ndarray (p,)
        Phase boundaries [s] found by the refinement (empty if not refined).
    final_attitude_error : float
        Angle [rad] between the target and the open-loop re-simulated final attitude.
    final_rate_error : float
        ``|omega_sim(t_f) - omegaf|`` [rad/s] of the re-simulation.
    separation_min : ndarray (m,)
        Smallest keep-out separation [rad] per cone along the re-simulation.
    rate_peak : float
        Largest ``|omega|`` [rad/s] along the re-simulation.
    q_target, omega_target : ndarray
        The requested final attitude and rate [rad/s].
    inertia : ndarray (3, 3)
        Inertia of the planned body [kg m^2].
    torque_envelope : ndarray (3,)
        Largest torque per body axis of the torque set [N m].
    torque_rows : ndarray (m, 3)
        The torque set ``|torque_rows @ tau| <= 1`` [1/(N m)].
    rate_max : float or None
        Body-rate limit [rad/s].
    keep_out_boresight_B, keep_out_direction_N, keep_out_half_angle : ndarray
        The keep-out cones (unit vectors; half angles [rad]).
    eigenaxis_duration : float or None
        Duration [s] of the eigenaxis reference slew (rest to rest only);
        ``info["eigenaxis_enters_keep_out"]`` says whether that slew enters a
        keep-out cone (it cannot steer around one).
    info : dict
        Scaling, grid, per-start results (``"starts"``: family, status,
        duration, whether it reached the best), the multi-start summary
        (``"multi_start"``), the Pontryagin check (``"pontryagin"``),
        refinement details, verification, and ``"warnings"``: the planner's
        warnings in words (e.g. a plan slower than a feasible eigenaxis slew),
        also issued with :func:`warnings.warn`.
    costate : ndarray (n, 7) or None
        Costate estimates at the nodes from the NLP's multipliers:
        ``lambda_q`` [s] and ``lambda_omega`` [s^2] (with wheel states (n, 7 +
        n_wheels), then ``lambda_h`` [1/(N m)]), normalised so that
        ``H = 1 + lambda . x_dot`` (docs/slew_planning.md, Optimality
        evidence); None after :meth:`resample`.
    pontryagin_residual : float or None
        Pontryagin's necessary conditions as one normalised number:
        ``max(max |H| / its tolerance, switching disagreement / its
        tolerance)`` over the parts judged (``info["pontryagin"]`` holds
        ``hamiltonian_residual``, ``switching_disagreement`` and their
        tolerances). Small for a time-optimal extremal; above 1 the plan
        is flagged. None when not checked (minimum energy, or a path
        constraint active everywhere).
    optimality_flagged : bool
        The plan fails Pontryagin's necessary conditions beyond their
        tolerances (``info["pontryagin"]``): not a time-optimal extremal.
    wheel_torque : ndarray (n, n_wheels) or None
        Motor torque per wheel [N m], held like ``torque`` (plans with the
        wheel momenta as states, :mod:`controllers.slew.wheel_states`; then
        ``torque`` is the motor reaction ``-A u`` on the body and ``inertia``
        the whole spacecraft's, wheels included). None otherwise.
    wheel_momentum : ndarray (n, n_wheels) or None
        Absolute spin-axis momentum per wheel ``h`` [N m s] (the simulation
        engine's wheel state); :attr:`wheel_relative_momentum` is the part the
        speed limit bounds.
    wheel_set : dict or None
        The wheel set as the keyword arguments of
        :class:`attitude.actuators.ReactionWheels` (``axes_B``,
        ``spin_inertia``, ``torque_max``, ``momentum_max``, the friction);
        :meth:`wheels` rebuilds it.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    torque: NDArray[np.float64]
    duration: float
    objective: str
    objective_value: float
    status: str
    iterations: int
    wall_time: float
    solve_time: float
    grid_duration: float
    refined_duration: float | None
    switch_times: NDArray[np.float64]
    final_attitude_error: float
    final_rate_error: float
    separation_min: NDArray[np.float64]
    rate_peak: float
    q_target: NDArray[np.float64]
    omega_target: NDArray[np.float64]
    inertia: NDArray[np.float64]
    torque_envelope: NDArray[np.float64]
    torque_rows: NDArray[np.float64]
    rate_max: float | None
    keep_out_boresight_B: NDArray[np.float64]
    keep_out_direction_N: NDArray[np.float64]
    keep_out_half_angle: NDArray[np.float64]
    eigenaxis_duration: float | None
    info: dict[str, Any] = field(default_factory=dict)
    costate: NDArray[np.float64] | None = None
    pontryagin_residual: float | None = None
    optimality_flagged: bool = False
    wheel_torque: NDArray[np.float64] | None = None
    wheel_momentum: NDArray[np.float64] | None = None
    wheel_set: dict[str, Any] | None = None

    def wheels(self) -> ReactionWheels | None:
        """The planned wheel set (:attr:`wheel_set`), None for a plan without wheel states."""
        return None if self.wheel_set is None else ReactionWheels(**self.wheel_set)

    @property
    def wheel_relative_momentum(self) -> NDArray[np.float64] | None:
        """Wheel momentum relative to the body ``J Omega = h - J a . omega`` [N m s] (n, n_wheels); None without wheels.

        This is what ``momentum_max`` (the wheel-speed limit) bounds.
        """
        wheels = self.wheels()
        if wheels is None or self.wheel_momentum is None:
            return None
        return wheels.spin_inertia * wheels.wheel_speed(self.wheel_momentum, self.omega)

    def summary(self) -> str:
        """One line: objective, duration, starts that reached the best, and the Pontryagin check."""
        parts = [f"{self.objective}-optimal slew {self.duration:.6g} s ({STATUS_WORDS.get(self.status, self.status)})"]
        multi = self.info.get("multi_start")
        if multi and multi.get("starts", 0) > 1:
            parts.append(f"{multi['reached_best']} of {multi['starts']} starts reached the best")
        words = summary_words(self.info.get("pontryagin"))
        if words:
            parts.append(words)
        return "; ".join(parts)

    @property
    def final_attitude_error_deg(self) -> float:
        """:attr:`final_attitude_error` in degrees."""
        return math.degrees(self.final_attitude_error)

    @property
    def warnings(self) -> list[str]:
        """The planner's warnings (``info["warnings"]``), empty for a clean plan."""
        return list(self.info.get("warnings", []))

    @property
    def keep_out(self) -> tuple[KeepOutCone, ...]:
        """The keep-out cones as :class:`KeepOutCone` objects."""
        names = list(self.info.get("keep_out_names", [])) + [""] * self.keep_out_half_angle.size
        return tuple(
            KeepOutCone(b, s, float(a), str(name))
            for b, s, a, name in zip(
                self.keep_out_boresight_B, self.keep_out_direction_N, self.keep_out_half_angle, names
            )
        )

    def separation(self) -> NDArray[np.float64]:
        """Keep-out separation [rad] at the plan's times, shape (n, m)."""
        if not self.keep_out_half_angle.size:
            return np.zeros((self.t.size, 0))
        return np.stack([c.separation(self.q) for c in self.keep_out], axis=-1)

    def resample(self, dt: float) -> SlewPlan:
        """The plan on a uniform grid of step ``dt`` [s] (plus the final time).

        States between nodes are integrated from the preceding node with the
        plan's torque (RK4, 8 sub-steps over at most one interval: exact to
        ~1e-12 for these step sizes), so they lie on the planned trajectory
        rather than on an interpolation. ``torque`` holds the plan's torque
        at each new time; fed back as a zero-order hold on the new grid it
        differs from the plan on new intervals that straddle a plan node.

        Parameters
        ----------
        dt : float
            Step of the new grid [s], > 0.
        """
        dt = float(check_positive(dt, "dt"))
        t_new = np.arange(0.0, self.duration, dt)
        if self.duration - t_new[-1] > 1e-9 * self.duration:
            t_new = np.append(t_new, self.duration)
        else:
            t_new[-1] = self.duration
        k = np.clip(np.searchsorted(self.t, t_new, side="right") - 1, 0, self.t.size - 2)
        info = dict(self.info)
        info["resampled_dt_s"] = dt
        wheels = self.wheels()
        if wheels is None or self.wheel_momentum is None or self.wheel_torque is None:
            x = states_between(RigidBody(self.inertia), self.t, self.q, self.omega, self.torque, t_new)
            return replace(
                self, t=t_new, q=x[:, :4], omega=x[:, 4:], torque=self.torque[k].copy(), info=info, costate=None
            )
        x = states_between(
            RigidBody(self.inertia), self.t, self.q, self.omega, self.wheel_torque, t_new, self.wheel_momentum, wheels
        )
        return replace(
            self,
            t=t_new,
            q=x[:, :4],
            omega=x[:, 4:7],
            torque=self.torque[k].copy(),
            wheel_torque=self.wheel_torque[k].copy(),
            wheel_momentum=x[:, 7:],
            info=info,
            costate=None,
        )

    def plot_wheels(self) -> matplotlib.figure.Figure:
        """Wheel torques and momenta against their limits (:func:`plot_wheel_plan`; plans with wheel states)."""
        return plot_wheel_plan(self)

    def plot(
        self,
        *,
        keep_out_half_angle_required: ArrayLike | None = None,
        rate_max_required: float | None = None,
        torque_envelope_available: ArrayLike | None = None,
    ) -> matplotlib.figure.Figure:
        """Torque and rate profiles, attitude path and keep-out separation over time (:func:`plot_plan`).

        Parameters
        ----------
        keep_out_half_angle_required : array_like (m,), optional
            The cones' half angles as required [rad], one per cone in the
            plan's order, when the plan kept a margin (planned at wider
            cones): both are drawn and labelled.
        rate_max_required : float, optional
            The required rate limit [rad/s] when the plan used a smaller one.
        torque_envelope_available : array_like (3,), optional
            The actuators' full torque per body axis [N m] when the plan used
            a fraction of it.
        """
        return plot_plan(
            self,
            keep_out_half_angle_required=keep_out_half_angle_required,
            rate_max_required=rate_max_required,
            torque_envelope_available=torque_envelope_available,
        )


def plot_wheel_plan(plan: SlewPlan) -> matplotlib.figure.Figure:
    """Motor torque and momentum relative to the body per wheel against their limits (:meth:`SlewPlan.plot_wheels`).

    Torques in mN m and momenta in mN m s, each wheel in its own colour with
    its limits dashed; a limit the plan reaches is where the wheel binds.

    Parameters
    ----------
    plan : SlewPlan
        A plan with the wheel momenta as states (:attr:`SlewPlan.wheel_set`).
    """
    from matplotlib.figure import Figure

    wheels = plan.wheels()
    if wheels is None or plan.wheel_torque is None:
        raise ValueError("plan must hold wheel states (plan_slew(..., wheel_states=True)); this plan has none")
    fine = plan.resample(plan.duration / 400.0) if plan.t.size < 400 else plan
    relative = fine.wheel_relative_momentum
    fig = Figure(figsize=(11, 4.8), layout="constrained")
    ax = fig.subplots(1, 2, sharex=True)
    for i in range(wheels.n_wheels):
        # Wider lines under narrower ones: wheels that a symmetric slew drives alike stay visible.
        style = {"color": f"C{i}", "lw": 1.2 + 1.2 * (wheels.n_wheels - 1 - i), "alpha": 0.85}
        ax[0].step(plan.t, 1e3 * plan.wheel_torque[:, i], where="post", label=f"wheel {i + 1}", **style)
        ax[1].plot(fine.t, 1e3 * relative[:, i], label=f"wheel {i + 1}", **style)
    for a, limit in ((ax[0], wheels.torque_max), (ax[1], wheels.momentum_max)):
        for value in np.unique(limit):
            for sign in (1.0, -1.0):
                a.axhline(sign * 1e3 * value, color="black", ls="--", lw=0.9)
        a.plot([], [], color="black", ls="--", lw=0.9, label="limit")
    ax[0].set_ylabel("motor torque [mN m]")
    ax[0].set_title("wheel motor torque and torque_max")
    ax[1].set_ylabel(r"momentum relative to the body $J\,\Omega$ [mN m s]")
    ax[1].set_title("wheel momentum and momentum_max (the speed limit)")
    for a in ax:
        a.grid(True, alpha=0.3)
        a.margins(x=0)
        a.set_xlabel("time [s]")
        a.legend(loc="best", fontsize="small")
    fig.suptitle(plan_title(plan))
    return fig


def states_between(
    body: RigidBody,
    t: NDArray,
    q: NDArray,
    omega: NDArray,
    torque: NDArray,
    t_new: NDArray,
    wheel_momentum: NDArray | None = None,
    wheels: ReactionWheels | None = None,
) -> NDArray[np.float64]:
    """States at ``t_new`` integrated from the preceding node of ``t`` under the ZOH torque (RK4, 8 sub-steps).

    With ``wheels`` the state is ``[q, omega, h]`` and ``torque`` the motor
    torques: the hold step of :class:`attitude.simulation.plant.PlantModel`
    (the hub body and its wheels, as the simulation engine flies them).

    Parameters
    ----------
    body : RigidBody
        The spacecraft.
    t : ndarray
        Node times of the plan [s], shape (N + 1,).
    q : ndarray
        Node attitudes ``q_BN``, shape (N + 1, 4).
    omega : ndarray
        Node body rates [rad/s], shape (N + 1, 3).
    torque : ndarray
        Body torque held over each interval [N m], shape (N, 3); with
        ``wheels``, the motor torque per wheel (N, n_wheels).
    t_new : ndarray
        Times at which to return the states [s].
    wheel_momentum : ndarray, optional
        Node wheel momenta ``h`` [N m s], shape (N + 1, n_wheels) (with ``wheels``).
    wheels : ReactionWheels, optional
        The wheel set; ``body`` is then the whole spacecraft, wheels included.
    """
    k = np.clip(np.searchsorted(t, t_new, side="right") - 1, 0, t.size - 2)
    dt = t_new - t[k]
    if wheels is None or wheel_momentum is None:
        x0 = np.concatenate([q[k], omega[k]], axis=1)
        step = casadi_rk4_step(body, substeps=8).map(t_new.size)
        out = np.asarray(step(x0.T, torque[k].T, dt[None, :])).T
    else:
        x0 = np.concatenate([q[k], omega[k], wheel_momentum[k]], axis=1)
        hold = PlantModel(wheels.hub_body(body), wheels).compiled_step(8).map(t_new.size)
        out = np.asarray(hold(x0.T, torque[k].T, np.zeros((3, t_new.size)), dt[None, :])).T
    exact = dt == 0
    out[exact] = x0[exact]
    return out


def plot_plan(
    plan: SlewPlan,
    *,
    keep_out_half_angle_required: ArrayLike | None = None,
    rate_max_required: float | None = None,
    torque_envelope_available: ArrayLike | None = None,
) -> matplotlib.figure.Figure:
    """Torque, rate, attitude and keep-out panels of a plan (:meth:`SlewPlan.plot`).

    Torques are drawn in mN m, the unit of the design report's tables. The
    limits the planner used are drawn dashed or dotted and labelled
    "planned"; where the caller gives the required limits (a plan made
    with margins: wider cones, a fraction of the rate limit or of the
    wheels' torque), those are drawn too, in red, and the keep-out panel
    shades the forbidden side of each required cone.

    Parameters
    ----------
    plan : SlewPlan
        The plan.
    keep_out_half_angle_required : array_like (m,), optional
        The cones' half angles as required [rad], one per cone of the plan,
        in its order.
    rate_max_required : float, optional
        The required rate limit [rad/s].
    torque_envelope_available : array_like (3,), optional
        The actuators' full torque per body axis [N m].
    """
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from attitude.plotting import AXIS_COLORS

    cones = plan.keep_out
    required = None
    if keep_out_half_angle_required is not None:
        required = np.atleast_1d(check_positive(keep_out_half_angle_required, "keep_out_half_angle_required"))
        if required.shape != (len(cones),):
            raise ValueError(
                f"keep_out_half_angle_required must give one half angle per cone of the plan ({len(cones)}), "
                f"got shape {required.shape}"
            )
    rate_required = None if rate_max_required is None else positive_scalar(rate_max_required, "rate_max_required")
    available = None
    if torque_envelope_available is not None:
        available = check_positive(
            check_vector(torque_envelope_available, "torque_envelope_available", 3), "torque_envelope_available"
        )

    fine = plan.resample(plan.duration / 400.0) if plan.t.size < 400 else plan
    fig = Figure(figsize=(11, 7.5), layout="constrained")
    ax = fig.subplots(2, 2, sharex=True)
    for i, name in enumerate("xyz"):
        ax[0, 0].step(plan.t, 1e3 * plan.torque[:, i], where="post", color=AXIS_COLORS[i], label=rf"$\tau_{name}$")
        for sign in (1.0, -1.0):
            ax[0, 0].axhline(sign * 1e3 * plan.torque_envelope[i], color=AXIS_COLORS[i], ls=":", lw=0.9)
            if available is not None:
                ax[0, 0].axhline(sign * 1e3 * available[i], color="tab:red", ls="-.", lw=0.8)
        ax[0, 1].plot(fine.t, np.degrees(fine.omega[:, i]), color=AXIS_COLORS[i], label=rf"$\omega_{name}$")
    limits = [Line2D([], [], color="0.3", ls=":", lw=0.9, label="planned limit (per axis)")]
    if available is not None:
        limits.append(Line2D([], [], color="tab:red", ls="-.", lw=0.8, label="wheels' limit (per axis)"))
    handles = ax[0, 0].get_legend_handles_labels()[0] + limits
    top = 1e3 * float(
        np.max(plan.torque_envelope if available is None else np.maximum(available, plan.torque_envelope))
    )
    ax[0, 0].set_ylim(-1.1 * top, 1.7 * top)  # headroom for the legend above the limits
    ax[0, 0].legend(handles=handles, loc="upper center", fontsize="small", ncols=2)
    ax[0, 0].set_ylabel("torque [mN m]")
    ax[0, 0].set_title("torque")
    ax[0, 1].plot(fine.t, np.degrees(np.linalg.norm(fine.omega, axis=1)), color="black", label=r"$|\omega|$")
    if plan.rate_max is not None:
        ax[0, 1].axhline(math.degrees(plan.rate_max), color="black", ls="--", lw=0.8, label="planned rate limit")
    if rate_required is not None:
        ax[0, 1].axhline(math.degrees(rate_required), color="tab:red", ls="-.", lw=0.8, label="required rate limit")
    ax[0, 1].set_ylabel("body rate [deg/s]")
    ax[0, 1].set_title("body rate")
    for i, name in enumerate("wxyz"):
        ax[1, 0].plot(fine.t, fine.q[:, i], color=("black", *AXIS_COLORS)[i], label=f"$q_{name}$")
    to_go = np.degrees(quat.error_angle(plan.q_target, quat.normalize(fine.q)))
    twin = ax[1, 0].twinx()
    twin.plot(fine.t, to_go, color="0.5", ls="--", label="angle to go")
    twin.set_ylabel("angle to go [deg]")
    ax[1, 0].set_ylabel(r"attitude $q_{BN}$")
    ax[1, 0].set_title("attitude path (grey dashed: angle to go, right axis)")
    sep = fine.separation()
    if sep.shape[1]:
        for j, cone in enumerate(cones):
            name = cone.name or f"cone {j}"
            line = ax[1, 1].plot(fine.t, np.degrees(sep[:, j]), label=f"{name}: separation")[0]
            planned_deg = math.degrees(cone.half_angle)
            required_deg = None if required is None else math.degrees(float(required[j]))
            label = (
                f"{name}: half angle {planned_deg:.4g} deg"
                if required_deg is None
                else f"{name}: planned at {planned_deg:.4g} deg (margin {planned_deg - required_deg:.3g} deg)"
            )
            ax[1, 1].axhline(planned_deg, color=line.get_color(), ls="--", lw=0.9, label=label)
            if required_deg is None:
                continue
            ax[1, 1].axhline(
                required_deg, color="tab:red", ls="-", lw=1.2, label=f"{name}: keep-out limit {required_deg:.4g} deg"
            )
            ax[1, 1].axhspan(0.0, required_deg, color="tab:red", alpha=0.08)
        if required is not None:
            # The limit in view with a little of the forbidden side, whatever the shading's span.
            lowest = min(float(np.degrees(np.min(sep))), float(np.degrees(np.min(required))))
            top = max(float(np.degrees(np.max(sep))), max(math.degrees(c.half_angle) for c in cones))
            pad = 0.1 * max(top - lowest, 0.5)
            ax[1, 1].set_ylim(lowest - pad, top + pad)
        ax[1, 1].set_title("keep-out separation (boresight to direction)")
    else:
        ax[1, 1].text(0.5, 0.5, "no keep-out cones", transform=ax[1, 1].transAxes, ha="center", va="center")
        ax[1, 1].set_title("keep-out separation")
    ax[1, 1].set_ylabel("separation [deg]")
    for a in ax.ravel():
        a.grid(True, alpha=0.3)
        a.margins(x=0)
        if a is not ax[0, 0] and a.get_legend_handles_labels()[0]:
            a.legend(loc="best", fontsize="small")
    for a in ax[1]:
        a.set_xlabel("time [s]")
    fig.suptitle(plan_title(plan))
    return fig


def plan_title(plan: SlewPlan) -> str:
    """Two lines: objective, duration and solver outcome in words; grid and eigenaxis comparison.

    Parameters
    ----------
    plan : SlewPlan
        The plan.
    """
    words = STATUS_WORDS.get(plan.status, f"solver status {plan.status}")
    if plan.warnings:
        words += f", {len(plan.warnings)} warning(s) in info['warnings']"
    head = f"{plan.objective}-optimal slew: {plan.duration:.5g} s ({words})"
    nodes = plan.info.get("nodes")
    grid = f"the {nodes}-node grid" if nodes else "the grid"
    parts = []
    if plan.refined_duration is not None:
        parts.append(f"refined from {plan.grid_duration:.5g} s on {grid}")
    words = summary_words(plan.info.get("pontryagin"))
    if words:
        parts.append(words)
    if plan.eigenaxis_duration is not None:
        eig = f"eigenaxis slew {plan.eigenaxis_duration:.5g} s"
        if plan.info.get("eigenaxis_enters_keep_out"):
            eig += " (enters the keep-out cone)"
        parts.append(eig)
    return head if not parts else f"{head}\n{'; '.join(parts)}"

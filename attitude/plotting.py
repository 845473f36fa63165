"""Matplotlib figures for review. Every function returns its Figure.

Figures are built with the object-oriented API (``matplotlib.figure.Figure``)
so they work under any backend, including headless CI, and never touch the
pyplot global state.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from attitude.rigid_body import RigidBody


# What the figures read of the results, as protocols rather than imports: the results draw
# themselves with these functions, and the two modules must not import each other.


class TrajectoryData(Protocol):
    """What :func:`plot_trajectory` reads (:class:`attitude.propagate.Trajectory` meets it)."""

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    inertia: NDArray[np.float64]
    method: str


class SimulationData(Protocol):
    """What :func:`plot_simulation` reads (:class:`attitude.simulation.SimulationResult` meets it)."""

    t: NDArray[np.float64]
    omega: NDArray[np.float64]
    error_angle: NDArray[np.float64]
    torque_applied: NDArray[np.float64]
    torque_command: NDArray[np.float64]
    wheel_speed: NDArray[np.float64]
    info: dict[str, Any]


__all__ = [
    "AXIS_COLORS",
    "LOG_AXIS_DECADES_BELOW",
    "RATE_UNITS",
    "TIME_UNITS",
    "SimulationData",
    "TrajectoryData",
    "log_axis_floor",
    "plot_flexible_flight",
    "plot_flip",
    "plot_mode_timeline",
    "plot_polhodes",
    "plot_rates_comparison",
    "plot_simulation",
    "plot_trajectory",
]

#: One colour per body axis, used consistently across figures.
AXIS_COLORS = ("tab:blue", "tab:orange", "tab:green")
_QUAT_COLORS = ("black", *AXIS_COLORS)


def plot_trajectory(traj: TrajectoryData, index: tuple[int, ...] | int = ()) -> Figure:
    """Body rates, attitude quaternion and invariant drift of a trajectory.

    Parameters
    ----------
    traj : Trajectory
        Result of :func:`attitude.propagate.propagate`.
    index : int or tuple of int
        Which body of a batch to show (ignored for a single body).

    Returns
    -------
    matplotlib.figure.Figure
    """
    index = (index,) if isinstance(index, int) else tuple(index)
    q = traj.q[index] if traj.q.ndim > 2 else traj.q
    omega = traj.omega[index] if traj.omega.ndim > 2 else traj.omega
    inertia = traj.inertia[index] if traj.inertia.ndim > 2 else traj.inertia
    t = traj.t
    h_b = omega @ inertia.T
    energy = 0.5 * np.sum(omega * h_b, axis=-1)
    qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
    # |H| is frame independent; use it and the kinetic energy as drift measures.
    h_mag = np.linalg.norm(h_b, axis=-1)

    fig = Figure(figsize=(9, 8), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    for i, name in enumerate(("x", "y", "z")):
        axes[0].plot(t, np.degrees(omega[:, i]), color=AXIS_COLORS[i], label=rf"$\omega_{name}$")
    axes[0].set_ylabel("body rate [deg/s]")
    axes[0].legend(loc="upper right", ncols=3)
    for i, name in enumerate(("w", "x", "y", "z")):
        axes[1].plot(t, qn[:, i], color=_QUAT_COLORS[i], label=f"$q_{name}$")
    axes[1].set_ylabel(r"attitude $q_{BN}$")
    axes[1].legend(loc="upper right", ncols=4)
    e_rel = (energy - energy[0]) / energy[0] if energy[0] > 0 else energy - energy[0]
    h_rel = (h_mag - h_mag[0]) / h_mag[0] if h_mag[0] > 0 else h_mag - h_mag[0]
    axes[2].plot(t, e_rel, label="kinetic energy (relative)")
    axes[2].plot(t, h_rel, label="|H| (relative)")
    axes[2].plot(t, np.linalg.norm(q, axis=-1) - 1.0, label="|q| - 1")
    axes[2].set_ylabel("drift")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper left")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"Attitude propagation ({traj.method})")
    return fig


# ---------------------------------------------------------------------------
# Torque-free motion: simulation against closed form, polhodes, the flip
# ---------------------------------------------------------------------------

#: Display units of time: name -> seconds per unit.
TIME_UNITS = {"s": 1.0, "min": 60.0, "h": 3600.0, "day": 86400.0}

#: Display units of angular rate: name -> factor from rad/s.
RATE_UNITS = {
    "rad/s": 1.0,
    "mrad/s": 1e3,
    "deg/s": 180.0 / np.pi,
    "deg/h": 3600.0 * 180.0 / np.pi,
    "rpm": 60.0 / (2.0 * np.pi),
    "arcsec/day": 86400.0 * 3600.0 * 180.0 / np.pi,
}


_TIME_LABELS = {"day": "days"}


def _time_unit(unit: str) -> float:
    if unit not in TIME_UNITS:
        raise ValueError(f"time_unit must be one of {tuple(TIME_UNITS)}, got {unit!r}")
    return TIME_UNITS[unit]


def _time_label(unit: str) -> str:
    return f"time [{_TIME_LABELS.get(unit, unit)}]"


def _rate_unit(unit: str | tuple[str, float]) -> tuple[str, float]:
    """``(label, factor from rad/s)`` for a named unit or a ``(label, factor)`` pair."""
    if isinstance(unit, tuple):
        if len(unit) != 2 or not np.isfinite(unit[1]) or unit[1] <= 0:
            raise ValueError(f"rate_unit must be a name or a (label, positive factor) pair, got {unit!r}")
        return str(unit[0]), float(unit[1])
    if unit not in RATE_UNITS:
        raise ValueError(f"rate_unit must be one of {tuple(RATE_UNITS)} or a (label, factor) pair, got {unit!r}")
    return unit, RATE_UNITS[unit]


def _component_labels(labels: Sequence[str] | None, n: int, frame: str = "xyz") -> list[str]:
    if labels is None:
        names = frame if n <= len(frame) else [str(i + 1) for i in range(n)]
        return [rf"$\omega_{{{names[i]}}}$" for i in range(n)]
    if len(labels) != n:
        raise ValueError(f"labels must name the {n} rate components, got {len(labels)} labels")
    return list(labels)


def _marker_step(n: int, per_panel: int = 30) -> int:
    return max(1, n // per_panel)


def plot_rates_comparison(
    t: ArrayLike,
    omega_sim: ArrayLike,
    omega_exact: ArrayLike,
    title: str,
    *,
    panel_titles: Sequence[str] | None = None,
    labels: Sequence[str] | None = None,
    time_unit: str = "s",
    rate_unit: str | tuple[str, float] = "deg/s",
    sim_label: str = "simulation",
    exact_label: str = "closed form",
) -> Figure:
    """Simulated body rates against a closed-form solution, with the error.

    One column per case: the rate components on top (simulation as lines,
    closed form as open markers of the same colour) and the absolute
    difference below on a log scale (where it is exactly zero the curve has
    a gap, and a note says so).

    Parameters
    ----------
    t : array_like, shape (n,)
        Time [s].
    omega_sim, omega_exact : array_like, shape (n, c) or (p, n, c)
        Simulated and closed-form rate components [rad/s]; a leading
        dimension ``p`` draws ``p`` cases side by side (the batch layout of
        :class:`attitude.propagate.Trajectory`).
    title : str
        Figure title.
    panel_titles : sequence of str, optional
        One title per case.
    labels : sequence of str, optional
        Names of the ``c`` components (default ``omega_x``, ``omega_y``,
        ``omega_z``).
    time_unit : {"s", "min", "h", "day"}
        Unit of the time axis.
    rate_unit : str or (str, float)
        A name in :data:`RATE_UNITS` or a ``(label, factor from rad/s)`` pair.
    sim_label, exact_label : str
        Legend names of the two sources.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(t, dtype=float)
    sim = np.asarray(omega_sim, dtype=float)
    exact = np.asarray(omega_exact, dtype=float)
    if sim.shape != exact.shape:
        raise ValueError(f"omega_sim and omega_exact must have the same shape, got {sim.shape} and {exact.shape}")
    if sim.ndim == 2:
        sim, exact = sim[None], exact[None]
    if sim.ndim != 3 or sim.shape[1] != t.size:
        raise ValueError(f"omega_sim must have shape (len(t)={t.size}, c) or (p, len(t), c), got {sim.shape}")
    n_cases, _, n_comp = sim.shape
    if panel_titles is not None and len(panel_titles) != n_cases:
        raise ValueError(f"panel_titles must have {n_cases} entries, got {len(panel_titles)}")
    names = _component_labels(labels, n_comp)
    ts = t / _time_unit(time_unit)
    unit_label, factor = _rate_unit(rate_unit)
    step = _marker_step(t.size)

    width = max(9.5, 4.2 * n_cases + 1.8)
    fig = Figure(figsize=(width, 6.6), layout="constrained")
    axes = fig.subplots(2, n_cases, sharex="col", squeeze=False, height_ratios=(2, 1))
    for j in range(n_cases):
        ax_w, ax_e = axes[0, j], axes[1, j]
        for i in range(n_comp):
            color = AXIS_COLORS[i % len(AXIS_COLORS)]
            ax_w.plot(ts, sim[j, :, i] * factor, color=color, lw=1.6)
            ax_w.plot(ts[::step], exact[j, ::step, i] * factor, "o", color=color, mfc="none", ms=5, mew=1.1, alpha=0.9)
            err = np.abs(sim[j, :, i] - exact[j, :, i]) * factor
            ax_e.plot(ts, np.where(err > 0, err, np.nan), color=color, lw=1.2)
        err_all = np.abs(sim[j] - exact[j])
        if not np.any(err_all > 0):
            ax_e.text(0.5, 0.5, "identical: error exactly 0", transform=ax_e.transAxes, ha="center", va="center")
            ax_e.set_yticks([])
        else:
            ax_e.set_yscale("log")
            if np.any(err_all == 0):
                ax_e.text(0.01, 0.03, "gaps: error exactly 0", transform=ax_e.transAxes, fontsize="small")
        if panel_titles is not None:
            ax_w.set_title(panel_titles[j])
        ax_e.set_xlabel(_time_label(time_unit))
        for ax in (ax_w, ax_e):
            ax.grid(True, alpha=0.3)
            ax.margins(x=0)
    axes[0, 0].set_ylabel(f"rate [{unit_label}]")
    axes[1, 0].set_ylabel(f"|{sim_label} - {exact_label}|\n[{unit_label}]")
    handles = [Line2D([], [], color=AXIS_COLORS[i % len(AXIS_COLORS)], lw=2, label=names[i]) for i in range(n_comp)]
    handles += [
        Line2D([], [], color="0.3", lw=1.6, label=sim_label),
        Line2D([], [], color="0.3", ls="none", marker="o", mfc="none", label=exact_label),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), frameon=False)
    fig.suptitle(textwrap.fill(title, width=int(10 * width)), fontsize="large")
    return fig


def _polhode_energy_ellipsoid(moments: NDArray[np.float64], energy: float, n: int = 40) -> tuple[NDArray, ...]:
    u = np.linspace(0.0, 2.0 * np.pi, 2 * n)
    v = np.linspace(0.0, np.pi, n)
    semi = np.sqrt(2.0 * energy / moments)
    x = semi[0] * np.outer(np.cos(u), np.sin(v))
    y = semi[1] * np.outer(np.sin(u), np.sin(v))
    z = semi[2] * np.outer(np.ones_like(u), np.cos(v))
    return x, y, z


def _separatrix(moments: NDArray[np.float64], energy: float, n: int = 400) -> list[NDArray[np.float64]]:
    """The two separatrix ellipses ``H^2 = 2 T I2`` on the energy ellipsoid, principal components."""
    i1, i2, i3 = moments
    # The separatrix lies in the planes sqrt(I1 (I2-I1)) w1 = +-sqrt(I3 (I3-I2)) w3 through the middle axis.
    c = np.sqrt(i1 * (i2 - i1) / (i3 * (i3 - i2)))
    th = np.linspace(0.0, 2.0 * np.pi, n)
    w1 = np.sqrt(2.0 * energy / (i1 + i3 * c * c)) * np.cos(th)
    w2 = np.sqrt(2.0 * energy / i2) * np.sin(th)
    return [np.stack([w1, w2, sign * c * w1], axis=-1) for sign in (1.0, -1.0)]


def plot_polhodes(
    body: RigidBody | ArrayLike,
    rate: float = 1.0,
    *,
    n_curves: int = 4,
    near_middle: float = 0.03,
    overlays: Mapping[str, ArrayLike] | None = None,
    rate_unit: str | tuple[str, float] = "rad/s",
    title: str | None = None,
) -> Figure:
    """Polhodes on the kinetic-energy ellipsoid in principal rate space.

    Torque-free, the body rate ``omega`` (principal components) stays on the
    energy ellipsoid ``I1 w1^2 + I2 w2^2 + I3 w3^2 = 2T`` and on the momentum
    ellipsoid ``|I omega|^2 = H^2``; their intersection is the polhode. With
    ``D = H^2 / (2T)`` in ``(I1, I3)``: ``D < I2`` gives closed loops around
    the minor axis, ``D > I2`` loops around the major axis, and ``D = I2``
    the separatrix, two ellipses crossing at the (unstable) middle axis.

    The polhodes are drawn from the exact elliptic solution
    (:func:`attitude.analytic.torque_free_motion`) over one period, for
    ``n_curves`` values of ``D`` spread over each family, plus one curve on
    each side of the separatrix (``D = I2 -+ near_middle`` of the gap to the
    outer moment), the separatrix itself (in closed form: its planes through
    the middle axis) and the mirror image ``-omega`` of each curve.

    Parameters
    ----------
    body : RigidBody or array_like
        The body (or its inertia [kg m^2]); three distinct principal moments.
    rate : float
        Sets the energy: ``T = I2 rate^2 / 2``, the energy of a spin of
        ``rate`` [rad/s] about the middle axis.
    n_curves : int
        Polhodes per stable family.
    near_middle : float
        Fractional distance of the two near-separatrix polhodes, in ``(0, 1)``.
    overlays : mapping of str to array_like (n, 3), optional
        Rate histories in principal components [rad/s] (for example
        simulations) drawn as dots. Each is scaled by ``sqrt(T / T_own)`` to the
        plotted energy: Euler's equations are homogeneous in ``omega``, so a
        scaled polhode is a polhode (the motion is only slower or faster).
    rate_unit : str or (str, float)
        Display unit of the rate axes (:data:`RATE_UNITS` name or pair).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Two 3-D views of the same picture: oblique, and looking down the
        middle axis (where the separatrix appears as an X).
    """
    from attitude.analytic import torque_free_motion
    from attitude.rigid_body import RigidBody

    body = body if isinstance(body, RigidBody) else RigidBody(body)
    moments = body.principal_axes().moments
    i1, i2, i3 = (float(x) for x in moments)
    if not (i1 < i2 < i3) or min(i2 - i1, i3 - i2) <= 1e-9 * i3:
        raise ValueError(f"body must have three distinct principal moments, got {moments} kg m^2")
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive rate [rad/s], got {rate!r}")
    if not 0.0 < near_middle < 1.0:
        raise ValueError(f"near_middle must be in (0, 1), got {near_middle!r}")
    unit_label, factor = _rate_unit(rate_unit)
    energy = 0.5 * i2 * rate**2
    diagonal = RigidBody(moments)

    def polhode(d: float) -> NDArray[np.float64]:
        # The point of the polhode with w2 = 0 (every polhode crosses w2 = 0), then one period of the exact motion.
        w1 = np.sqrt(2.0 * energy * (i3 - d) / (i1 * (i3 - i1)))
        w3 = np.sqrt(2.0 * energy * (d - i1) / (i3 * (i3 - i1)))
        motion = torque_free_motion(diagonal, [w1, 0.0, w3])
        return motion.omega_principal(np.linspace(0.0, motion.period, 800))

    fractions = np.linspace(0.15, 0.8, n_curves)
    families = [
        ("around the minor axis (stable)", "tab:blue", [i1 + f * (i2 - i1) for f in fractions]),
        ("around the major axis (stable)", "tab:green", [i3 - f * (i3 - i2) for f in fractions]),
        (
            "near the middle axis",
            "tab:orange",
            [i2 - near_middle * (i2 - i1), i2 + near_middle * (i3 - i2)],
        ),
    ]
    curves = [(label, color, [polhode(d) for d in ds]) for label, color, ds in families]
    separatrix = _separatrix(moments, energy)
    scaled_overlays = []
    for name, values in (overlays or {}).items():
        w = np.asarray(values, dtype=float)
        if w.ndim != 2 or w.shape[-1] != 3:
            raise ValueError(f"overlays[{name!r}] must have shape (n, 3), got {w.shape}")
        own = 0.5 * float(np.sum(moments * w[0] ** 2))
        scaled_overlays.append((name, w * np.sqrt(energy / own)))

    fig = Figure(figsize=(13, 6.2), layout="constrained")
    semi = np.sqrt(2.0 * energy / moments) * factor
    surface = [s * factor for s in _polhode_energy_ellipsoid(moments, energy)]
    overlay_colors = ("tab:purple", "black", "tab:brown", "tab:pink")
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax2 = fig.add_subplot(1, 2, 2)
    # The 3-D view draws all three components, the projection along the middle axis drops omega_2 (the picture is
    # symmetric under omega_2 -> -omega_2, so nothing is hidden by the projection).
    views = ((ax3, [0, 1, 2]), (ax2, [0, 2]))
    ax3.plot_surface(*surface, color="0.85", alpha=0.18, linewidth=0, shade=False)
    ax3.plot_wireframe(*surface, rstride=4, cstride=4, color="0.6", linewidth=0.3, alpha=0.5)
    th = np.linspace(0.0, 2.0 * np.pi, 200)
    ax2.fill(semi[0] * np.cos(th), semi[2] * np.sin(th), color="0.93", zorder=0)
    ax2.plot(semi[0] * np.cos(th), semi[2] * np.sin(th), color="0.5", lw=0.8, label="outline of the energy ellipsoid")
    for ax, comps in views:
        for label, color, ws in curves:
            for n, w in enumerate(ws):
                for sign in (1.0, -1.0):
                    name = label if n == 0 and sign > 0 and ax is ax3 else None
                    ax.plot(*(sign * w[:, comps] * factor).T, color=color, lw=1.3, label=name)
        for n, w in enumerate(separatrix):
            name = r"separatrix ($H^2 = 2 T I_2$)" if n == 0 and ax is ax3 else None
            ax.plot(*(w[:, comps] * factor).T, color="tab:red", lw=2.2, label=name)
        for n, (name, w) in enumerate(scaled_overlays):
            every = max(1, w.shape[0] // 400)
            ax.plot(
                *(w[::every, comps] * factor).T,
                ".",
                color=overlay_colors[n % 4],
                ms=4,
                label=name if ax is ax3 else None,
                zorder=5,
            )
        for i in range(3):  # the six principal-axis spins: minor and major stable, middle unstable
            point = np.zeros(3)
            point[i] = semi[i]
            ax.plot(
                *np.stack([point, -point])[:, comps].T,
                "X" if i == 1 else "o",
                color="black",
                ms=8,
                mfc="white" if i == 1 else "black",
                zorder=6,
            )
    ax3.view_init(elev=22, azim=-58)
    ax3.set_box_aspect(tuple(semi), zoom=0.95)
    ax3.set_xlabel(rf"$\omega_1$ (minor) [{unit_label}]")
    ax3.set_ylabel(rf"$\omega_2$ (middle) [{unit_label}]")
    ax3.set_zlabel(rf"$\omega_3$ (major) [{unit_label}]")
    ax3.set_title("3-D view")
    ax2.set_aspect("equal")
    ax2.grid(True, alpha=0.3)
    ax2.set_xlabel(rf"$\omega_1$ (minor) [{unit_label}]")
    ax2.set_ylabel(rf"$\omega_3$ (major) [{unit_label}]")
    ax2.set_title(r"seen along the middle axis $\omega_2$: the separatrix is an X")
    handles = ax3.get_legend_handles_labels()[0] + ax2.get_legend_handles_labels()[0]
    handles += [
        Line2D([], [], ls="none", marker="o", color="black", label="stable spin axes (minor, major)"),
        Line2D([], [], ls="none", marker="X", color="black", mfc="white", label="unstable spin axis (middle)"),
    ]
    fig.legend(handles=handles, loc="outside lower center", ncols=3, frameon=False)
    fig.suptitle(
        title or (f"Polhodes on the kinetic-energy ellipsoid, principal moments {i1:.3g}, {i2:.3g}, {i3:.3g} kg m$^2$"),
        fontsize="large",
    )
    return fig


def plot_flip(
    t: ArrayLike,
    omega: ArrayLike,
    growth_rate: float,
    *,
    flip_period: float | None = None,
    flip_times: ArrayLike | None = None,
    omega_exact: ArrayLike | None = None,
    middle: int = 1,
    linear_limit: float = 0.05,
    labels: Sequence[str] | None = None,
    time_unit: str = "s",
    rate_unit: str | tuple[str, float] = "deg/s",
    title: str | None = None,
) -> Figure:
    """The middle-axis (tennis-racket, Dzhanibekov) flip.

    Top: the rate components over time, with the predicted flips (sign
    reversals of the middle-axis rate) marked. Bottom: the transverse rate
    ``sqrt(|omega|^2 - omega_middle^2)`` on a log scale up to the first flip,
    against ``exp(k t)`` with the predicted growth rate ``k``. The reference
    line has the predicted slope; only its height is fitted (least squares on
    the logarithm over the linear window: after ``4 / k``, when the decaying
    mode ``exp(-k t)`` has died out, and while the transverse rate is below
    ``linear_limit`` times the spin), so its slope is a test, not a fit.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time [s].
    omega : array_like, shape (n, 3)
        Rates in principal components [rad/s].
    growth_rate : float
        Predicted growth rate ``k`` [1/s]
        (:func:`attitude.analytic.intermediate_axis_growth_rate`).
    flip_period : float, optional
        Predicted time between flips [s], quoted in the legend.
    flip_times : array_like, optional
        Predicted flip instants [s], drawn as vertical lines.
    omega_exact : array_like, shape (n, 3), optional
        Closed-form rates [rad/s], drawn as open markers.
    middle : int
        Index of the middle-axis component.
    linear_limit : float
        Upper end of the linear window, as a fraction of ``|omega|``.
    labels : sequence of str, optional
        Names of the components (default ``omega_1..3``).
    time_unit : {"s", "min", "h", "day"}
        Unit of the time axis.
    rate_unit : str or (str, float)
        Unit of the rate axes.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(t, dtype=float)
    w = np.asarray(omega, dtype=float)
    if w.shape != (t.size, 3):
        raise ValueError(f"omega must have shape (len(t)={t.size}, 3), got {w.shape}")
    if middle not in (0, 1, 2):
        raise ValueError(f"middle must be 0, 1 or 2, got {middle!r}")
    if not (np.isfinite(growth_rate) and growth_rate > 0):
        raise ValueError(f"growth_rate must be a positive rate [1/s], got {growth_rate!r}")
    names = _component_labels(labels, 3, frame="123")
    scale_t = _time_unit(time_unit)
    ts = t / scale_t
    unit_label, factor = _rate_unit(rate_unit)

    fig = Figure(figsize=(11, 7.5), layout="constrained")
    ax_w, ax_g = fig.subplots(2, 1, height_ratios=(1.3, 1))
    for i in range(3):
        ax_w.plot(ts, w[:, i] * factor, color=AXIS_COLORS[i], lw=1.5, label=f"{names[i]} simulation")
    if omega_exact is not None:
        we = np.asarray(omega_exact, dtype=float)
        if we.shape != w.shape:
            raise ValueError(f"omega_exact must have the shape of omega {w.shape}, got {we.shape}")
        step = _marker_step(t.size, 120)
        for i in range(3):
            ax_w.plot(ts[::step], we[::step, i] * factor, "o", color=AXIS_COLORS[i], mfc="none", ms=4, mew=0.9)
        ax_w.plot([], [], "o", color="0.3", mfc="none", label="closed form (elliptic)")
    flips = np.array([]) if flip_times is None else np.asarray(flip_times, dtype=float)
    for n, tf in enumerate(flips):
        label = None
        if n == 0:
            every = "" if flip_period is None else f" (every {flip_period / scale_t:.4g} {time_unit})"
            label = "predicted flip" + every
        ax_w.axvline(tf / scale_t, color="tab:red", ls="--", lw=1.0, label=label)
    ax_w.axhline(0.0, color="0.5", lw=0.6)
    ax_w.set_ylabel(f"principal rate [{unit_label}]")
    ax_w.set_xlabel(_time_label(time_unit))
    ax_w.set_title("rates: the middle-axis rate reverses sign again and again")
    ax_w.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)

    spin = np.linalg.norm(w, axis=-1)
    transverse = np.sqrt(np.maximum(spin**2 - w[:, middle] ** 2, 0.0))
    end = flips[0] if flips.size and flips[0] > t[0] else t[-1]
    early = t <= end
    linear = early & (t >= t[0] + 4.0 / growth_rate) & (transverse < linear_limit * spin) & (transverse > 0)
    ax_g.semilogy(ts[early], transverse[early] * factor, color="tab:purple", lw=1.8, label="simulation")
    if np.count_nonzero(linear) >= 2:
        offset = np.mean(np.log(transverse[linear]) - growth_rate * t[linear])
        ref = np.exp(offset + growth_rate * t[early])
        ax_g.semilogy(
            ts[early], ref * factor, "k--", lw=1.2, label=rf"$\propto e^{{kt}}$, predicted $k$ = {growth_rate:.4g} 1/s"
        )
        t_lin = t[linear]
        ax_g.axvspan(t_lin[0] / scale_t, t_lin[-1] / scale_t, color="0.9", zorder=0, label="linear window")
        ax_g.set_ylim(transverse[early][transverse[early] > 0].min() * factor / 3, spin.max() * factor * 3)
    ax_g.set_ylabel(f"transverse rate [{unit_label}]")
    ax_g.set_xlabel(_time_label(time_unit))
    ax_g.set_title("early growth of the transverse rate (log scale) up to the first flip")
    ax_g.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    for ax in (ax_w, ax_g):
        ax.grid(True, alpha=0.3)
        ax.margins(x=0)
    fig.suptitle(textwrap.fill(title or "Middle-axis instability (tennis-racket effect)", 120), fontsize="large")
    return fig


#: Decades drawn below the small end of the data on a log axis (:func:`log_axis_floor`).
LOG_AXIS_DECADES_BELOW = 1


def log_axis_floor(values: ArrayLike, percentile: float = 1.0) -> float | None:
    """Lower limit of a log axis chosen from the data (None when no value is positive).

    The power of ten one decade (:data:`LOG_AXIS_DECADES_BELOW`) below the
    decade holding the ``percentile`` of the positive values: a few
    isolated tiny values (an exact start, a zero crossing) do not stretch
    the axis over empty decades, and the small end of the data stays in
    view.

    Parameters
    ----------
    values : array_like
        The data of the axis (zeros, negatives and NaN ignored).
    percentile : float
        Percentile of the positive values that sets the floor [%], in [0, 100].

    Examples
    --------
    >>> log_axis_floor([0.0, 3e-3, 0.02, 0.05], percentile=0.0)
    0.0001
    """
    if not 0.0 <= percentile <= 100.0:
        raise ValueError(f"percentile must lie in [0, 100], got {percentile!r}")
    v = np.asarray(values, dtype=float).ravel()
    positive = v[np.isfinite(v) & (v > 0.0)]
    if positive.size == 0:
        return None
    small = float(np.percentile(positive, percentile))
    return float(10.0 ** (math.floor(math.log10(small)) - LOG_AXIS_DECADES_BELOW))


def plot_simulation(result: SimulationData) -> Figure:
    """The standard review figure of a closed-loop run.

    Panels: attitude error to the controller's reference [deg] on a log
    scale (its lower limit from the data: :func:`log_axis_floor`), body
    rates [deg/s], commanded (wide, pale) and applied (thin) body torques
    [mN m], wheel speeds [rpm] with their limits when wheels are present,
    and in orbit the disturbance torques per source [uN m] and the
    magnetorquers' commanded and delivered dipole [A m^2].

    Parameters
    ----------
    result : SimulationResult
        Output of :func:`attitude.simulation.engine.simulate`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = result.t
    has_wheels = result.wheel_speed.shape[-1] > 0
    disturbances = getattr(result, "disturbance_torques", {}) or {}
    dipole = getattr(result, "dipole", np.zeros((0, 3)))
    has_rods = dipole.shape[0] == t.size
    n_panels = 3 + has_wheels + bool(disturbances) + has_rods
    fig = Figure(figsize=(10, 2.4 * n_panels + 0.8), layout="constrained")
    axes = fig.subplots(n_panels, 1, sharex=True)
    err_deg = np.degrees(result.error_angle)
    floor = log_axis_floor(err_deg)
    if floor is None:  # no positive error to draw on a log scale
        axes[0].plot(t, err_deg, color="black")
        axes[0].set_title("error angle to the reference (shortest way)", fontsize=10)
    else:
        axes[0].semilogy(t, np.where(err_deg > 0.0, err_deg, np.nan), color="black")
        axes[0].set_ylim(bottom=floor)
        below = int(np.sum(err_deg < floor))
        note = f"; {below} sample(s) below {floor:.0e} deg not shown" if below else ""
        axes[0].set_title(f"error angle to the reference (shortest way{note})", fontsize=10)
    axes[0].set_ylabel("attitude error [deg]")
    for i, name in enumerate("xyz"):
        axes[1].plot(t, np.degrees(result.omega[:, i]), color=AXIS_COLORS[i], label=rf"$\omega_{name}$")
    axes[1].plot(t, np.degrees(np.linalg.norm(result.omega, axis=1)), color="black", lw=1.0, label=r"$|\omega|$")
    axes[1].set_ylabel("body rate [deg/s]")
    axes[1].legend(loc="upper right", ncols=4)
    # Where they agree the commanded torque is a pale band around the applied line; a limit shows as the
    # band leaving the line.
    command_mNm, applied_mNm = 1e3 * result.torque_command, 1e3 * result.torque_applied
    for i, name in enumerate("xyz"):
        axes[2].plot(
            t,
            command_mNm[:, i],
            color=AXIS_COLORS[i],
            lw=4.0,
            alpha=0.3,
            solid_capstyle="butt",
            label=rf"commanded $\tau_{name}$",
        )
        axes[2].plot(t, applied_mNm[:, i], color=AXIS_COLORS[i], lw=1.0, label=rf"applied $\tau_{name}$")
    gap = float(np.max(np.abs(command_mNm - applied_mNm))) if t.size else 0.0
    if gap <= 1e-9 * (float(np.max(np.abs(command_mNm))) if t.size else 0.0):
        agreement = "equal to rounding (no limit reached)"
    else:
        agreement = f"largest difference {gap:.3g} mN m"
    axes[2].set_title(f"body torque: commanded (wide, pale) and applied (thin); {agreement}", fontsize=10)
    axes[2].set_ylabel("body torque [mN m]")
    axes[2].legend(loc="upper right", ncols=3, fontsize=8)
    if has_wheels:
        rpm = result.wheel_speed * 60.0 / (2.0 * np.pi)
        for i in range(rpm.shape[1]):
            axes[3].plot(t, rpm[:, i], label=f"wheel {i + 1}")
        limits = result.info.get("wheel_speed_limit_rpm")
        if limits is not None:
            peak = float(np.max(np.abs(rpm))) if rpm.size else 0.0
            if peak >= 0.1 * float(np.min(limits)):
                for lim in np.atleast_1d(limits):
                    axes[3].axhline(lim, color="red", ls="--", lw=0.8)
                    axes[3].axhline(-lim, color="red", ls="--", lw=0.8)
            else:  # the limits would flatten the speeds into a line at zero
                axes[3].set_title(
                    f"wheel speeds (limit +-{float(np.min(limits)):.4g} rpm, off this scale)", fontsize=10
                )
        axes[3].set_ylabel("wheel speed [rpm]")
        axes[3].legend(loc="upper right", ncols=4, fontsize=8)
    k = 3 + has_wheels
    if disturbances:
        largest = max(float(np.max(np.linalg.norm(tau, axis=-1))) for tau in disturbances.values())
        for source, tau in disturbances.items():
            magnitude = 1e6 * np.linalg.norm(tau, axis=-1)
            # Below 1e-9 of the largest torque is rounding (gravity gradient on principal axes along LVLH).
            shown = np.where(magnitude > 1e-9 * 1e6 * largest, magnitude, np.nan)
            axes[k].semilogy(t, shown, label=source.replace("_", " "))
        if has_rods:
            rods = 1e6 * np.linalg.norm(result.torque_magnetorquer, axis=-1)
            axes[k].semilogy(t, np.where(rods > 0.0, rods, np.nan), color="black", lw=0.8, label="magnetorquers")
        axes[k].set_ylabel("external torque [uN m]")
        axes[k].set_title(
            "external torques: disturbances per source and the magnetorquers' control torque (magnitude; none "
            "drawn where zero)",
            fontsize=10,
        )
        axes[k].legend(loc="upper right", ncols=5, fontsize=8)
        k += 1
    if has_rods:
        for i, name in enumerate("xyz"):  # drawn as the torques: commanded wide and pale under delivered
            axes[k].plot(
                t,
                result.dipole_command[:, i],
                color=AXIS_COLORS[i],
                lw=4.0,
                alpha=0.3,
                solid_capstyle="butt",
                label=f"$m_{name}$ commanded",
            )
            axes[k].plot(t, dipole[:, i], color=AXIS_COLORS[i], lw=1.0, label=f"$m_{name}$ delivered")
        axes[k].set_ylabel("magnetic dipole [A m$^2$]")
        axes[k].legend(loc="upper right", ncols=3, fontsize=8)
    axes[-1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(
        f"Closed-loop simulation ({result.info.get('engine', '?')} engine, dt = {result.info.get('dt', '?')} s)"
    )
    return fig


def plot_mode_timeline(
    t: ArrayLike,
    mode_index: ArrayLike,
    mode_names: Sequence[str],
    omega: ArrayLike,
    error_angle: ArrayLike,
    switch_times: Sequence[float] = (),
) -> Figure:
    """A mode sequence flown: the active mode over time, the body rate and the pointing error.

    Parameters
    ----------
    t : array_like (n,)
        Times [s].
    mode_index : array_like of int (n,)
        Index into ``mode_names`` of the mode active at each time.
    mode_names : sequence of str
        The modes, in the order flown.
    omega : array_like (n, 3)
        Body rate [rad/s].
    error_angle : array_like (n,)
        Attitude error to the active mode's reference [rad] (NaN where it has none).
    switch_times : sequence of float
        Times of the switches [s], drawn on every panel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    t = np.asarray(t, dtype=float)
    index = np.asarray(mode_index, dtype=int)
    fig = Figure(figsize=(10, 7.5), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True, height_ratios=[1.0, 2.0, 2.0])
    colors = [f"C{i}" for i in range(len(mode_names))]
    # One band per stretch of a mode, from its first sample to the next mode's first (no gap at a switch).
    edges = np.flatnonzero(np.diff(index)) + 1
    starts, stops = np.concatenate([[0], edges]), np.concatenate([edges, [t.size - 1]])
    labelled: set[int] = set()
    for a, b in zip(starts, stops):
        i = int(index[a])
        label = None if i in labelled else mode_names[i]
        labelled.add(i)
        axes[0].axvspan(t[a], t[b], color=colors[i], alpha=0.85, label=label, lw=0)
    axes[0].set_yticks([])
    axes[0].set_ylim(0, 1)
    axes[0].set_ylabel("mode")
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize="small")
    rate_deg = np.degrees(np.linalg.norm(np.asarray(omega, dtype=float), axis=-1))
    axes[1].semilogy(t, np.maximum(rate_deg, 1e-6), color="k", lw=1)
    axes[1].set_ylabel("body rate |omega| [deg/s]")
    err_deg = np.degrees(np.asarray(error_angle, dtype=float))
    for i in range(len(mode_names)):
        seg = index == i
        if np.any(seg & np.isfinite(err_deg)):
            axes[2].semilogy(t[seg], np.maximum(err_deg[seg], 1e-6), color=colors[i], lw=1)
    axes[2].set_ylabel("error to the mode's reference [deg]")
    axes[2].set_xlabel("time [s]")
    for ax in axes:
        for ts in switch_times:
            ax.axvline(ts, color="0.4", ls="--", lw=0.8)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("Mode sequence: modes, body rate and pointing error (dashed: switches)")
    return fig


def plot_flexible_flight(result: Any) -> Figure:
    """The review figure of a flight with flexible appendages (``simulate_flexible``).

    Panels: the attitude as a rotation vector from N [deg], body rates
    [deg/s], the modal coordinates [sqrt(kg) m] and the body torque [mN m],
    each against time [s].

    Parameters
    ----------
    result : FlexibleSimulationResult
        Arrays ``t``, ``q``, ``omega``, ``eta``, ``torque``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from attitude.quaternion import to_rotation_vector

    fig = Figure(figsize=(8.0, 8.0), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True)
    t = result.t
    panels = (
        (np.degrees(to_rotation_vector(result.q)), "attitude [deg]\n(rotation vector)", "xyz"),
        (np.degrees(result.omega), "body rate [deg/s]", "xyz"),
        (result.eta, "modal coordinate\n[sqrt(kg) m]", [f"mode {k + 1}" for k in range(result.eta.shape[1])]),
        (1e3 * result.torque, "body torque [mN m]", "xyz"),
    )
    for ax, (values, label, names) in zip(axes, panels):
        for k, name in enumerate(names):
            color = AXIS_COLORS[k] if k < len(AXIS_COLORS) else None
            ax.plot(t, values[:, k], color=color, lw=1.0, label=name)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=8, ncol=len(names))
    axes[-1].set_xlabel("time [s]")
    fig.suptitle("Flight with flexible appendages", fontsize=11)
    return fig

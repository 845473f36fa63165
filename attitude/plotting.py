"""Matplotlib figures for review. Every function returns its Figure.

Figures are built with the object-oriented API (``matplotlib.figure.Figure``)
so they work under any backend, including headless CI, and never touch the
pyplot global state.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

if TYPE_CHECKING:
    from attitude.propagate import Trajectory

__all__ = ["AXIS_COLORS", "plot_trajectory"]

#: One colour per body axis, used consistently across figures.
AXIS_COLORS = ("tab:blue", "tab:orange", "tab:green")
_QUAT_COLORS = ("black", *AXIS_COLORS)


def plot_trajectory(traj: Trajectory, index: tuple[int, ...] | int = ()) -> Figure:
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

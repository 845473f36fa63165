"""The eigenaxis reference slew: time-optimal rotation about the fixed eigenaxis (rest to rest).

Part of :mod:`controllers.slew.planner` (import the public names from there).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody
from attitude.validation import check_positive
from controllers.slew.problem import TorqueSet, check_count

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = ["PUBLISHED_BILIMORIA_WIE", "EigenaxisSlew", "axis_angle", "eigenaxis_profile", "eigenaxis_slew"]

#: Bilimoria and Wie (1993), rest-to-rest 180 deg about a body axis, unit
#: inertia, ``|u_i| <= 1``: eigenaxis and time-optimal durations [s].
PUBLISHED_BILIMORIA_WIE = {"eigenaxis": 2.0 * math.sqrt(math.pi), "time_optimal": 3.2431}


@dataclass
class EigenaxisSlew(ResultIO):
    """The time-optimal rotation about the fixed eigenaxis (rest to rest).

    The body turns about the eigenaxis ``e`` (the same in B and N) with
    ``omega = w(t) e``; the torque ``tau = alpha I e + w^2 (e x I e)`` must
    stay in the torque set, which fixes the largest acceleration and
    deceleration at each rate (the gyroscopic part vanishes about a
    principal axis). The profile is bang-bang, or bang-coast-bang when the
    rate limit is reached.

    Attributes
    ----------
    t : ndarray (n,)
        Time [s].
    q : ndarray (n, 4)
        Attitude ``q_BN``.
    omega : ndarray (n, 3)
        Body rate [rad/s].
    torque : ndarray (n, 3)
        Body torque [N m] (sampled, continuous within each arc).
    angle : ndarray (n,)
        Rotation angle about the eigenaxis [rad].
    duration : float
        Slew time [s].
    axis_B : ndarray (3,)
        Eigenaxis (unit, body components).
    total_angle : float
        Eigenaxis rotation angle [rad], in ``[0, pi]``.
    rate_peak : float
        Largest rate [rad/s].
    accel_duration : float
        End of the acceleration arc [s] (the first switch).
    coast_duration : float
        Time spent at the rate limit [s].
    inertia : ndarray (3, 3)
        Inertia [kg m^2].
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    torque: NDArray[np.float64]
    angle: NDArray[np.float64]
    duration: float
    axis_B: NDArray[np.float64]
    total_angle: float
    rate_peak: float
    accel_duration: float
    coast_duration: float
    inertia: NDArray[np.float64]

    def plot(self) -> matplotlib.figure.Figure:
        """Torque [mN m], rate and angle profiles."""
        from matplotlib.figure import Figure

        from attitude.plotting import AXIS_COLORS

        fig = Figure(figsize=(9, 7), layout="constrained")
        axes = fig.subplots(3, 1, sharex=True)
        for i, name in enumerate("xyz"):
            axes[0].plot(self.t, 1e3 * self.torque[:, i], color=AXIS_COLORS[i], label=rf"$\tau_{name}$")
            axes[1].plot(self.t, np.degrees(self.omega[:, i]), color=AXIS_COLORS[i], label=rf"$\omega_{name}$")
        axes[0].set_ylabel("torque [mN m]")
        axes[1].set_ylabel("body rate [deg/s]")
        axes[2].plot(self.t, np.degrees(self.angle), color="black")
        axes[2].set_ylabel("eigenaxis angle [deg]")
        axes[2].set_xlabel("time [s]")
        for ax in axes[:2]:
            ax.legend(loc="upper right", ncols=3)
        for ax in axes:
            ax.grid(True, alpha=0.3)
        fig.suptitle(
            f"eigenaxis slew: {math.degrees(self.total_angle):.2f} deg in {self.duration:.4g} s "
            f"(peak {math.degrees(self.rate_peak):.3g} deg/s, coast {self.coast_duration:.4g} s)"
        )
        return fig


def axis_angle(q0: NDArray, qf: NDArray) -> tuple[NDArray[np.float64], float]:
    """Body-fixed eigenaxis and angle in [0, pi] taking q0 to qf (``qf = q0 ⊗ exp(e phi / 2)``).

    Parameters
    ----------
    q0 : ndarray
        Initial attitude ``q_BN`` (4,).
    qf : ndarray
        Final attitude ``q_BN`` (4,).
    """
    rel = quat.multiply(quat.conjugate(q0), qf)
    if rel[0] < 0:
        rel = -rel
    s = float(np.linalg.norm(rel[1:]))
    angle = 2.0 * math.atan2(s, float(rel[0]))
    axis = rel[1:] / s if s > 0 else np.array([1.0, 0.0, 0.0])
    return axis, angle


def eigenaxis_profile(
    inertia: NDArray,
    rows: NDArray,
    axis: NDArray,
    angle: float,
    rate_max: float | None,
    n_points: int,
    *,
    timing_only: bool = False,
) -> dict[str, Any]:
    """Bang(-coast)-bang profile along ``axis`` with gyroscopic-aware acceleration limits.

    Parameters
    ----------
    inertia : ndarray
        Inertia tensor [kg m^2], (3, 3).
    rows : ndarray
        Rows of the torque set ``|rows @ tau| <= 1`` [1/(N m)].
    axis : ndarray
        Unit eigenaxis in body components (3,).
    angle : float
        Slew angle [rad].
    rate_max : float or None
        Body-rate limit [rad/s]; None for no limit.
    n_points : int
        Number of samples of the profile.
    timing_only : bool, optional
        Return only the scalars (``duration``, ``rate_peak``, ``coast``,
        ``t_acc``), without sampling the profile.
    """
    ie = inertia @ axis
    g0 = np.cross(axis, ie)
    c = rows @ ie
    d = rows @ g0
    # With z = w^2 each row |c_j alpha + d_j z| <= 1 bounds the acceleration:
    # accel(z) = min_j (A_j - B_j z), decel(z) = min_j (A_j + B_j z) with
    # A_j = 1/|c_j| and B_j = d_j/c_j; a row with c_j = 0 only requires |d_j| z <= 1.
    on = np.abs(c) > 1e-12 * np.max(np.abs(c))
    a_coef = 1.0 / np.abs(c[on])
    b_coef = d[on] / c[on]
    caps = [a / abs(b) for a, b in zip(a_coef, b_coef) if b != 0]
    caps += [1.0 / abs(dj) for dj in d[~on] if dj != 0]
    z_cap = min(caps, default=math.inf)
    w_cap = math.sqrt(z_cap)

    def accel(w: float) -> float:
        return float(np.min(a_coef - b_coef * (w * w)))

    def decel(w: float) -> float:
        return float(np.min(a_coef + b_coef * (w * w)))

    def integrals(sign: float, w: float) -> tuple[float, float]:
        """Exact ``(integral s / alpha(s) ds, integral 1 / alpha(s) ds)`` over ``[0, w]``.

        ``alpha(s) = min_j (A_j - sign B_j s^2)``; on each piece between
        kinks one row is active and both integrands have closed forms.
        """
        if w <= 0:
            return 0.0, 0.0
        bs = sign * b_coef
        cuts = {0.0, w}
        for i in range(a_coef.size):
            for j in range(i + 1, a_coef.size):
                if bs[i] != bs[j]:
                    z = (a_coef[i] - a_coef[j]) / (bs[i] - bs[j])
                    if 0.0 < z < w * w:
                        cuts.add(math.sqrt(z))
        cuts = sorted(cuts)
        dist = dur = 0.0
        for s0, s1 in itertools.pairwise(cuts):
            zm = (0.5 * (s0 + s1)) ** 2
            k = int(np.argmin(a_coef - bs * zm))
            a, b = float(a_coef[k]), float(bs[k])
            if b == 0.0:
                dist += (s1 * s1 - s0 * s0) / (2.0 * a)
                dur += (s1 - s0) / a
                continue
            dist += -math.log1p(-b * (s1 * s1 - s0 * s0) / (a - b * s0 * s0)) / (2.0 * b)
            r = math.sqrt(abs(b) / a)
            if b > 0:
                dur += (math.atanh(r * s1) - math.atanh(r * s0)) / math.sqrt(a * b)
            else:
                dur += (math.atan(r * s1) - math.atan(r * s0)) / math.sqrt(-a * b)
        return dist, dur

    def dist(fun: Any, w: float) -> float:
        return integrals(1.0 if fun is accel else -1.0, w)[0]

    def duration_of(fun: Any, w: float) -> float:
        return integrals(1.0 if fun is accel else -1.0, w)[1]

    def both(w: float) -> float:
        return dist(accel, w) + dist(decel, w)

    coast = 0.0
    rate_limited = rate_max is not None and rate_max < w_cap
    if angle <= 0:
        w_peak = 0.0
    elif rate_limited and both(rate_max) <= angle:
        w_peak = rate_max  # bang-coast-bang
        coast = (angle - both(rate_max)) / rate_max
    else:
        if rate_limited:
            top = rate_max
        elif math.isfinite(w_cap):
            # Capacity runs out at w_cap (acceleration or deceleration -> 0): the peak must stay below.
            top = w_cap * (1.0 - 1e-9)
            if both(top) < angle:
                raise ValueError(
                    f"eigenaxis slew infeasible: the gyroscopic torque uses up the torque limits at "
                    f"{w_cap:.6g} rad/s before the slew angle is covered"
                )
        else:
            top = 1.0
            while both(top) < angle:
                top *= 2.0
        w_peak = brentq(lambda w: both(w) - angle, 0.0, top, xtol=1e-15, rtol=1e-14)
    t_acc = duration_of(accel, w_peak)
    t_dec = duration_of(decel, w_peak)
    total = t_acc + coast + t_dec
    if timing_only:
        return {"duration": total, "rate_peak": w_peak, "coast": coast, "t_acc": t_acc}

    # Sample the profile: integrate the arcs with dense output.
    t = np.linspace(0.0, total, n_points) if total > 0 else np.zeros(1)
    theta = np.zeros_like(t)
    w = np.zeros_like(t)
    alpha = np.zeros_like(t)
    opts = {"method": "DOP853", "rtol": 1e-12, "atol": 1e-14, "dense_output": True}
    if t_acc > 0:
        acc = solve_ivp(lambda _s, y: [y[1], accel(y[1])], (0.0, t_acc), [0.0, 0.0], **opts)
        m = t <= t_acc
        y = acc.sol(t[m])
        theta[m], w[m] = y[0], y[1]
        alpha[m] = [accel(v) for v in y[1]]
    th_acc = dist(accel, w_peak)
    m = (t > t_acc) & (t <= t_acc + coast)
    theta[m] = th_acc + w_peak * (t[m] - t_acc)
    w[m] = w_peak
    if t_dec > 0:
        dec = solve_ivp(lambda _s, y: [y[1], -decel(max(y[1], 0.0))], (0.0, t_dec), [0.0, w_peak], **opts)
        m = t > t_acc + coast
        y = dec.sol(t[m] - t_acc - coast)
        theta[m], w[m] = th_acc + w_peak * coast + y[0], np.maximum(y[1], 0.0)
        alpha[m] = [-decel(v) for v in w[m]]
    torque = alpha[:, None] * ie[None, :] + (w * w)[:, None] * g0[None, :]
    return {
        "t": t,
        "angle": theta,
        "rate": w,
        "torque": torque,
        "duration": total,
        "rate_peak": w_peak,
        "coast": coast,
        "t_acc": t_acc,
    }


def eigenaxis_slew(
    body: RigidBody,
    q0: ArrayLike,
    qf: ArrayLike,
    *,
    torque_max: ArrayLike | ReactionWheels,
    rate_max: float | None = None,
    n_points: int = 201,
) -> EigenaxisSlew:
    """Time-optimal rest-to-rest rotation about the fixed eigenaxis, for comparison.

    Parameters
    ----------
    body : RigidBody
        The spacecraft (a single body).
    q0, qf : array_like (4,)
        Initial and final attitude ``q_BN`` (unit norm); the shorter way
        (angle <= pi) is taken.
    torque_max : float, array_like (3,) or ReactionWheels
        Per-axis torque limits [N m], or a wheel set (module docstring).
    rate_max : float, optional
        Body-rate limit [rad/s] (bang-coast-bang when reached).
    n_points : int
        Samples of the profile.

    Returns
    -------
    EigenaxisSlew
        For unit inertia, ``|u_i| <= 1`` and 180 degrees about a body axis the
        duration is ``2 sqrt(pi)`` = 3.5449 s (Bilimoria and Wie, 1993).

    Raises
    ------
    ValueError
        For bad attitudes or limits, or when the gyroscopic torque of the
        eigenaxis rotation exceeds the torque set before the angle is covered.
    """
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single RigidBody, got {body!r}")
    q0 = quat.as_unit_quaternion(q0, "q0")
    qf = quat.as_unit_quaternion(qf, "qf")
    if q0.shape != (4,) or qf.shape != (4,):
        raise ValueError(f"q0 and qf must have shape (4,), got {q0.shape} and {qf.shape}")
    tset = TorqueSet.make(torque_max)
    if rate_max is not None:
        rate_max = float(check_positive(rate_max, "rate_max"))
    n_points = check_count(n_points, "n_points", 2)
    axis, angle = axis_angle(q0, qf)
    prof = eigenaxis_profile(body.inertia, tset.rows, axis, angle, rate_max, n_points)
    q = quat.multiply(q0, quat.from_axis_angle(axis, prof["angle"]))
    return EigenaxisSlew(
        t=prof["t"],
        q=q,
        omega=prof["rate"][:, None] * axis[None, :],
        torque=prof["torque"],
        angle=prof["angle"],
        duration=float(prof["duration"]),
        axis_B=axis,
        total_angle=float(angle),
        rate_peak=float(prof["rate_peak"]),
        accel_duration=float(prof["t_acc"]),
        coast_duration=float(prof["coast"]),
        inertia=body.inertia,
    )

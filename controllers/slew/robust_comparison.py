"""The Monte Carlo comparison of a robust slew with the nominal plan, flown open loop and tracked.

:func:`compare_robust_slew` flies a :class:`controllers.slew.robust.RobustSlewPlan` and the nominal
minimum-energy plan of the same slew over a sample of the same inertia uncertainty, open loop and tracked
(:class:`controllers.tracking.TrackingController`), and reports the spread of the terminal errors
(docs/slew_planning.md, "Robust (unscented) slews").
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.propagate import propagate
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody
from attitude.rng import as_generator
from attitude.simulation.batch import simulate_batch
from attitude.validation import as_float_array, positive_scalar
from controllers.slew.problem import (
    check_count,
)
from controllers.tracking import ReferenceTrajectory, TrackingController
from controllers.worst_case import UncertaintySet

if TYPE_CHECKING:
    import matplotlib.figure


from controllers.slew.robust import RobustSlewPlan, dispersed_bodies, moment_uncertainty

__all__ = ["COMPARISON_CASES", "RobustSlewComparison", "compare_robust_slew"]


# ---------------------------------------------------------------------------
# The Monte Carlo comparison

#: The four flights of :func:`compare_robust_slew`, in the order of its tables and figure.
COMPARISON_CASES = ("robust_open_loop", "nominal_open_loop", "robust_tracked", "nominal_tracked")


@dataclass
class RobustSlewComparison(ResultIO):
    """Terminal errors of the robust and the nominal plan flown over a Monte Carlo sample of the inertia.

    Attributes
    ----------
    moment_change : ndarray (N, 3)
        The sampled relative changes of the principal moments ``I1 <= I2 <= I3`` [-].
    attitude_error : dict of str to ndarray (N,)
        Terminal attitude error angle [rad] per case (:data:`COMPARISON_CASES`).
    rate_error : dict of str to ndarray (N,)
        Terminal ``|omega - omegaf|`` [rad/s] per case.
    terminal_error : dict of str to ndarray (N,)
        The plan's terminal error ``sqrt(4 sin^2(angle / 2) + (rate_error_time rate)^2)`` per case [rad]:
        the square root of what the robust plan minimises at its sigma points (docs/slew_planning.md).
    rate_error_time : float
        The plan's weight of the rate error [s].
    duration : float
        The plans' duration [s]: the open-loop flights end there.
    tracked_duration : float
        End of the tracked flights [s]: ``duration`` rounded up to a whole number of controller periods.
    info : dict
        Samples, seed, distribution, tracking gains and period, wall time.
    """

    moment_change: NDArray[np.float64]
    attitude_error: dict[str, NDArray[np.float64]]
    rate_error: dict[str, NDArray[np.float64]]
    terminal_error: dict[str, NDArray[np.float64]]
    rate_error_time: float
    duration: float
    tracked_duration: float
    info: dict[str, Any] = field(default_factory=dict)

    def spread(self) -> dict[str, dict[str, float]]:
        """Median, 95th percentile and largest terminal errors per case, in degrees and deg/s.

        Returns
        -------
        dict
            ``case -> {"<kind>_median_<unit>", "<kind>_p95_<unit>", "<kind>_max_<unit>"}`` for the kinds
            ``attitude`` and ``terminal`` (deg) and ``rate`` (deg_per_s).
        """
        out = {}
        for case in COMPARISON_CASES:
            row = {}
            for kind, values, unit in (
                ("attitude", self.attitude_error[case], "deg"),
                ("rate", self.rate_error[case], "deg_per_s"),
                ("terminal", self.terminal_error[case], "deg"),
            ):
                v = np.degrees(values)
                row[f"{kind}_median_{unit}"] = float(np.median(v))
                row[f"{kind}_p95_{unit}"] = float(np.percentile(v, 95))
                row[f"{kind}_max_{unit}"] = float(np.max(v))
            out[case] = row
        return out

    def summary(self) -> str:
        """One line: the 95th percentiles of the terminal attitude and rate errors, robust against nominal."""
        s = self.spread()
        parts = []
        for flight in ("open_loop", "tracked"):
            r, n = s[f"robust_{flight}"], s[f"nominal_{flight}"]
            parts.append(
                f"{flight.replace('_', ' ')}: robust {r['attitude_p95_deg']:.3g} deg, "
                f"{r['rate_p95_deg_per_s']:.3g} deg/s vs nominal {n['attitude_p95_deg']:.3g} deg, "
                f"{n['rate_p95_deg_per_s']:.3g} deg/s"
            )
        return f"95th percentile of the terminal errors over {self.moment_change.shape[0]} samples: " + "; ".join(parts)

    def plot(self) -> matplotlib.figure.Figure:
        """Empirical CDFs of the terminal errors, robust against nominal plan, open loop (top) and tracked (bottom)."""
        from matplotlib.figure import Figure
        from matplotlib.ticker import NullFormatter

        fig = Figure(figsize=(14, 7.5), layout="constrained")
        axes = fig.subplots(2, 3)
        colors = {"robust": "tab:blue", "nominal": "tab:orange"}
        spread = self.spread()
        kinds = (
            ("attitude", self.attitude_error, "deg", "deg", "attitude error"),
            ("rate", self.rate_error, "deg_per_s", "deg/s", "rate error"),
            ("terminal", self.terminal_error, "deg", "deg", f"terminal error (rate x {self.rate_error_time:.3g} s)"),
        )
        for row, flight in enumerate(("open_loop", "tracked")):
            how = "open loop" if flight == "open_loop" else "tracked (feedforward + PD)"
            for col, (kind, errors, key_unit, unit, title) in enumerate(kinds):
                ax = axes[row, col]
                for plan in ("robust", "nominal"):
                    case = f"{plan}_{flight}"
                    values = np.sort(np.degrees(errors[case]))
                    frac = np.arange(1, values.size + 1) / values.size
                    p95 = spread[case][f"{kind}_p95_{key_unit}"]
                    ax.step(
                        values, frac, where="post", color=colors[plan], label=f"{plan} plan (95 %: {p95:.3g} {unit})"
                    )
                    ax.axvline(p95, color=colors[plan], ls=":", lw=0.9)
                ax.set_xscale("log")
                ax.xaxis.set_minor_formatter(NullFormatter())
                ax.axhline(0.95, color="gray", ls="--", lw=0.7)
                ax.set_ylim(0.0, 1.02)
                ax.set_xlabel(f"{title} [{unit}]")
                ax.set_ylabel("fraction of samples")
                ax.set_title(f"{title}, {how}", fontsize="medium")
                ax.grid(True, which="both", alpha=0.3)
                ax.legend(loc="upper left", fontsize="small")
        fig.suptitle(
            f"Robust (unscented) vs nominal slew plan, {self.duration:.4g} s, over {self.moment_change.shape[0]} "
            f"dispersed inertias ({self.info.get('distribution_words', '')})"
        )
        return fig


def compare_robust_slew(
    plan: RobustSlewPlan,
    *,
    inertia_uncertainty: UncertaintySet | ArrayLike,
    wn: ArrayLike,
    zeta: ArrayLike,
    period: float,
    samples: int = 200,
    rng: object = 0,
) -> RobustSlewComparison:
    """Fly the robust plan and its nominal plan over a Monte Carlo sample of the inertia, open loop and tracked.

    Each sample draws the relative changes of the principal moments from the same distribution the plan
    was made for (:func:`moment_uncertainty`; seeded). Open loop: the plan's torque held over its intervals
    (:func:`attitude.propagate.propagate`, RK4 under its error budget). Tracked: the plan's attitude, rate
    and torque followed by a :class:`controllers.tracking.TrackingController` (feedforward plus quaternion
    PD designed on the nominal body), flown by :func:`attitude.simulation.batch.simulate_batch`.

    Parameters
    ----------
    plan : RobustSlewPlan
        The robust plan (it carries its nominal plan).
    inertia_uncertainty : UncertaintySet or array_like
        The moments' uncertainty to sample (:func:`moment_uncertainty`).
    wn : float or array_like (3,)
        Tracking feedback natural frequency [rad/s].
    zeta : float or array_like (3,)
        Tracking feedback damping ratio.
    period : float
        Tracking controller period [s]; the tracked flights end at the first tick at or after the plan's end.
    samples : int
        Monte Carlo samples (>= 2).
    rng : numpy.random.Generator, int or None
        Source of the samples (default seed 0).

    Returns
    -------
    RobustSlewComparison

    Raises
    ------
    ValueError
        Bad input (named), or a sample that gives no physical body (a normal spread wide enough to break
        ``I3 <= I1 + I2`` or to reach -100 %: use a narrower spread or the uniform set).
    """
    if not isinstance(plan, RobustSlewPlan):
        raise ValueError(f"plan must be a RobustSlewPlan, got {type(plan).__name__}")
    wall_start = time.perf_counter()
    spread = moment_uncertainty(inertia_uncertainty)
    samples = check_count(samples, "samples", 2)
    period = positive_scalar(period, "period")
    gen = as_generator(rng)
    body = RigidBody(plan.inertia)
    changes = spread.sample(gen, samples)
    batch = RigidBody(np.stack([b.inertia for b in dispersed_bodies(body, changes)]))
    q0 = np.broadcast_to(plan.q_start, (samples, 4))
    omega0 = np.broadcast_to(plan.omega_start, (samples, 3))
    ticks = math.ceil(plan.duration / period - 1e-9)
    tracked_duration = ticks * period
    attitude, rate = {}, {}
    references = {"robust": ReferenceTrajectory.from_plan(plan), "nominal": plan.nominal_reference()}
    for name, ref in references.items():
        flown = propagate(batch, q0, omega0, ref.t, ref.torque[:, None, :], method="adaptive", rtol=1e-9, atol=1e-12)
        q_end = quat.normalize(flown.q[:, -1])
        attitude[f"{name}_open_loop"] = np.asarray(quat.error_angle(plan.q_target, q_end), dtype=float)
        rate[f"{name}_open_loop"] = np.linalg.norm(flown.omega[:, -1] - plan.omega_target, axis=-1)
        controller = TrackingController(ref, body, wn=wn, zeta=zeta, period=period)
        result = simulate_batch(batch, q0, omega0, tracked_duration, controller=controller, backend="numpy")
        attitude[f"{name}_tracked"] = np.asarray(quat.error_angle(plan.q_target, result.q), dtype=float)
        rate[f"{name}_tracked"] = np.linalg.norm(result.omega - plan.omega_target, axis=-1)
    t_w = plan.rate_error_time
    return RobustSlewComparison(
        moment_change=changes,
        attitude_error={k: attitude[k] for k in COMPARISON_CASES},
        rate_error={k: rate[k] for k in COMPARISON_CASES},
        terminal_error={
            k: np.sqrt(4.0 * np.sin(attitude[k] / 2.0) ** 2 + (t_w * rate[k]) ** 2) for k in COMPARISON_CASES
        },
        rate_error_time=t_w,
        duration=plan.duration,
        tracked_duration=tracked_duration,
        info={
            "samples": samples,
            "seed": rng if isinstance(rng, (int, type(None))) else repr(rng),
            "distribution": spread.distribution,
            "moment_sigma_percent": [round(100.0 * s, 6) for s in spread.sigma],
            "distribution_words": spread.words(),
            "wn_rad_per_s": np.broadcast_to(as_float_array(wn, "wn"), (3,)).tolist(),
            "zeta": np.broadcast_to(as_float_array(zeta, "zeta"), (3,)).tolist(),
            "period_s": period,
            "wall_time_s": time.perf_counter() - wall_start,
        },
    )

"""Mismatch diagnostics: a controller that does not fit its sample rate or its requirements.

:func:`mismatch_findings` is the one home of these checks; the design report
and the command line call it and print each :class:`Finding`'s message, one
line with the reason in words and the figures behind it.

Controller bandwidth against the sample rate
    A continuous design (``wn`` of the closed-loop poles) is only predictive
    below about a tenth of the sample rate ``omega_s = 2 pi / T``
    (:data:`SAMPLE_RATE_FRACTION`, the limit
    :meth:`controllers.pd.QuaternionPD.from_bandwidth` warns at; sample-rate
    selection in Franklin, Powell and Workman, *Digital Control of Dynamic
    Systems*, 3rd ed., ch. 11, asks for more still).
    Above it the hold's half-period delay erodes the designed damping; far
    above it the sampled loop is unstable. The sampled loop is judged
    exactly (:func:`controllers.analysis.closed_loop_poles`, zero-order hold
    on every axis): for the PD on a double integrator, stable exactly while
    ``wn T < min(4 zeta, 1 / zeta)`` (Jury's test on its second-order
    characteristic polynomial; 1.43 at ``zeta = 0.7``).

LQR weights from a different scale of spacecraft
    Bryson's-rule weights (``[control.lqr]``) copied from another
    spacecraft put the LQR poles far from where this one needs them. The
    requirements imply a bandwidth: a 2 % settling time ``t_s`` at damping
    ``zeta`` needs ``wn ~ 4 / (zeta t_s)`` (the envelope ``exp(-zeta wn t)``
    falls to 2 % at ``ln 50 = 3.9`` time constants; N. S. Nise, *Control
    Systems Engineering*, 6th ed., sec. 4.6, ``T_s = 4 / (zeta wn)``). A
    slowest LQR pole :data:`SCALE_MISMATCH_FACTOR` times below that, or a
    fastest one above a tenth of the sample rate, is flagged. Below by a
    factor ``F``, that mode alone settles in at least ``4 / wn = F zeta
    t_s`` (its own damping is at most 1): twice the requirement and more at
    ``F = 3``, ``zeta = 0.7``, so no retuning of the damping saves it. The
    bandwidth of Bryson's-rule weights scales like ``sqrt(torque / (J
    angle))``: the CubeSat's weights on a 1000 kg-class body (inertia a
    thousand times larger) come out about 30 times slower.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from attitude.rigid_body import RigidBody
from attitude.validation import check_positive
from controllers.analysis import closed_loop_poles, controller_period
from controllers.lqr import LQRController, LQRDesign

__all__ = [
    "SAMPLE_RATE_FRACTION",
    "SCALE_MISMATCH_FACTOR",
    "SETTLING_TIME_CONSTANTS",
    "Finding",
    "mismatch_findings",
    "required_bandwidth",
]

#: A closed-loop natural frequency above this fraction of the sample rate
#: ``2 pi / T`` is flagged (module docstring).
SAMPLE_RATE_FRACTION = 0.1

#: An LQR pole this many times slower than the bandwidth the requirements
#: imply is flagged as weights from a different scale of spacecraft: that
#: mode alone needs at least ``3 zeta`` times the required settling time
#: (module docstring), so it is not a tuning detail.
SCALE_MISMATCH_FACTOR = 3.0

#: Time constants ``1 / (zeta wn)`` to a 2 % settling: ``ln 50 = 3.91``,
#: rounded to the textbook's 4.
SETTLING_TIME_CONSTANTS = 4.0


@dataclass(frozen=True)
class Finding:
    """One mismatch, for a report row or a terminal line.

    Attributes
    ----------
    id : str
        Stable identifier (``"pd_bandwidth_above_sample_rate"``,
        ``"pd_sampled_loop_unstable"``, ``"lqr_bandwidth_below_requirement"``,
        ``"lqr_bandwidth_above_sample_rate"``, ``"lqr_sampled_loop_unstable"``).
    message : str
        One line saying what is wrong and why, with the figures.
    figures : dict of str to float
        The numbers behind the message, unit-suffixed names
        (``wn_rad_per_s``, ``sample_rate_rad_per_s``, ``period_s``, ...).
    """

    id: str
    message: str
    figures: dict[str, float] = field(default_factory=dict)


def required_bandwidth(*, settling_time: float, damping: float) -> float:
    """Natural frequency a 2 % settling time needs: ``wn = 4 / (zeta t_s)`` [rad/s].

    Parameters
    ----------
    settling_time : float
        Required 2 % settling time ``t_s`` [s].
    damping : float
        Damping ratio ``zeta`` of the design [-] (> 0).

    Returns
    -------
    float
        ``SETTLING_TIME_CONSTANTS / (damping * settling_time)`` [rad/s].

    Examples
    --------
    >>> round(required_bandwidth(settling_time=60.0, damping=0.7), 4)
    0.0952
    """
    t_s = float(check_positive(settling_time, "settling_time"))
    zeta = float(check_positive(damping, "damping"))
    return SETTLING_TIME_CONSTANTS / (zeta * t_s)


def _sample_rate_findings(plant: Any, controller: Any, name: str, period: float, delay: float) -> list[Finding]:
    """Bandwidth above a tenth of the sample rate; the sampled loop unstable (with the reason)."""
    prefix = name.lower()
    sample_rate = 2.0 * math.pi / period
    limit = SAMPLE_RATE_FRACTION * sample_rate
    wn = float(np.max(np.abs(closed_loop_poles(plant, controller, sampled=False)), initial=0.0))
    radius = float(np.max(np.abs(closed_loop_poles(plant, controller, sampled=True, computation_delay=delay))))
    figures = {
        "wn_rad_per_s": wn,
        "sample_rate_rad_per_s": sample_rate,
        "limit_rad_per_s": limit,
        "period_s": period,
        "pole_radius_max": radius,
    }
    above = f"wn {wn:.3g} rad/s above a tenth of the {sample_rate:.3g} rad/s sample rate (T = {period:g} s)"
    if radius >= 1.0:
        reason = above if wn > limit else f"a closed-loop pole at |z| = {radius:.3g}, outside the unit circle"
        if delay:
            reason += f", with a computation delay of {delay:g} s"
        return [Finding(f"{prefix}_sampled_loop_unstable", f"sampled {name} loop unstable: {reason}", figures)]
    if wn > limit:
        return [
            Finding(
                f"{prefix}_bandwidth_above_sample_rate",
                f"{name} bandwidth: {above}; sampling and delay erode the designed damping",
                figures,
            )
        ]
    return []


def _lqr_design(lqr: Any) -> tuple[LQRDesign, float | None]:
    if isinstance(lqr, LQRController):
        return lqr.design, lqr.period
    if isinstance(lqr, LQRDesign):
        return lqr, lqr.period
    raise ValueError(f"lqr must be an LQRDesign or an LQRController, got {type(lqr).__name__}")


def _lqr_findings(lqr: Any, settling_time: float | None, damping: float | None, delay: float) -> list[Finding]:
    design, period = _lqr_design(lqr)
    wn = np.abs(design.s_poles)
    wn_slow, wn_fast = float(np.min(wn)), float(np.max(wn))
    out = []
    if settling_time is not None and damping is not None:
        wn_req = required_bandwidth(settling_time=settling_time, damping=damping)
        if wn_slow < wn_req / SCALE_MISMATCH_FACTOR:
            out.append(
                Finding(
                    "lqr_bandwidth_below_requirement",
                    f"LQR weights from a different scale of spacecraft? its slowest closed-loop pole, wn "
                    f"{wn_slow:.3g} rad/s, is more than {SCALE_MISMATCH_FACTOR:g} times below the {wn_req:.3g} rad/s "
                    f"the {settling_time:g} s settling time needs (4 / (zeta t_s), zeta = {damping:g})",
                    {
                        "wn_slowest_rad_per_s": wn_slow,
                        "wn_fastest_rad_per_s": wn_fast,
                        "wn_required_rad_per_s": wn_req,
                        "settling_time_s": float(settling_time),
                        "damping": float(damping),
                    },
                )
            )
    if period is None:
        return out
    sample_rate = 2.0 * math.pi / period
    if wn_fast > SAMPLE_RATE_FRACTION * sample_rate:
        out.append(
            Finding(
                "lqr_bandwidth_above_sample_rate",
                f"LQR weights from a different scale of spacecraft? its fastest closed-loop pole, wn {wn_fast:.3g} "
                f"rad/s, is above a tenth of the {sample_rate:.3g} rad/s sample rate (T = {period:g} s)",
                {
                    "wn_slowest_rad_per_s": wn_slow,
                    "wn_fastest_rad_per_s": wn_fast,
                    "sample_rate_rad_per_s": sample_rate,
                    "limit_rad_per_s": SAMPLE_RATE_FRACTION * sample_rate,
                    "period_s": period,
                },
            )
        )
    if design.period is None and isinstance(lqr, LQRController):
        # A continuous design flown at a period: its sampled loop is not stable by construction.
        unstable = _sample_rate_findings(design.plant, lqr, "LQR", period, delay)
        out += [f for f in unstable if f.id == "lqr_sampled_loop_unstable"]
    return out


def mismatch_findings(
    *,
    body: RigidBody | None = None,
    pd: Any = None,
    lqr: LQRDesign | LQRController | None = None,
    settling_time: float | None = None,
    damping: float | None = None,
    computation_delay: float = 0.0,
) -> list[Finding]:
    """Mismatches between the controllers, their sample rate and the requirements (module docstring).

    Parameters
    ----------
    body : RigidBody, optional
        The spacecraft the PD flies on (inertia [kg m^2]); required with ``pd``.
    pd : object with ``K``, ``C`` and ``period``, optional
        The PD (:class:`~controllers.pd.QuaternionPD`,
        :class:`~controllers.pd.RateLimitedPD`): its closed-loop natural
        frequency on ``body`` against a tenth of the sample rate, and its
        sampled loop's stability.
    lqr : LQRDesign or LQRController, optional
        The LQR: its closed-loop poles (``s_poles``) against the bandwidth
        the requirements imply and a tenth of the sample rate.
    settling_time : float, optional
        Required 2 % settling time [s]; with ``damping``, sets the required
        bandwidth (:func:`required_bandwidth`).
    damping : float, optional
        Damping ratio the requirement's bandwidth is read at [-] (the
        design's, e.g. ``[control] damping``).
    computation_delay : float
        Delay [s] from sampling to applying the command in the sampled loops
        (>= 0; the simulation engine has none).

    Returns
    -------
    list of Finding
        Empty when nothing is out of place.

    Raises
    ------
    ValueError
        ``pd`` without ``body`` or without a period; ``lqr`` of the wrong
        type; only one of ``settling_time`` and ``damping``; a bad number.
    """
    delay = float(check_positive(computation_delay, "computation_delay", allow_zero=True))
    if (settling_time is None) != (damping is None):
        raise ValueError(
            "settling_time and damping must be given together (the required bandwidth is 4 / (damping * "
            f"settling_time)), got settling_time = {settling_time!r}, damping = {damping!r}"
        )
    findings: list[Finding] = []
    if pd is not None:
        if not isinstance(body, RigidBody):
            raise ValueError(f"body must be the RigidBody the PD flies on, got {body!r}")
        period = controller_period(pd)
        if period is None:
            raise ValueError(f"pd must have a period (its sample time in s), got {type(pd).__name__}")
        findings += _sample_rate_findings(body, pd, "PD", period, delay)
    if lqr is not None:
        findings += _lqr_findings(lqr, settling_time, damping, delay)
    return findings

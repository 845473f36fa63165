"""Tuning a quaternion PD to a set of requirements: the fastest (or cheapest) gains that meet them all.

The structure is :meth:`controllers.pd.QuaternionPD.from_bandwidth` with one
natural frequency ``wn`` and one damping ``zeta`` for the three axes (the
spacecraft file's ``control.bandwidth_rad_per_s`` and ``control.damping``).
A candidate is judged on linear metrics of the body linearised at rest
(:func:`controllers.analysis.attitude_closed_loop`), for a step of the
attitude reference of ``step_angle`` about each body axis:

* **settling time**: when the error enters for good the band
  ``pointing_accuracy / step_angle`` of the step (:func:`control.step_info`
  on the response; the design's settling requirement, "within the pointing
  accuracy", on this step), at most ``settling_time``;
* **peak torque** ``|J theta''|`` of the step about axis ``k``, at most the
  wheels' body-torque envelope ``torque_max[k]``
  (:meth:`attitude.actuators.ReactionWheels.torque_envelope`); for a PD the
  peak is at ``t = 0``, ``J wn^2 step_angle`` (a bound on the quaternion
  law's ``2 J wn^2 sin(step_angle / 2)``);
* **peak momentum** ``|J omega|`` of the step (what the wheels must absorb from
  rest), at most ``momentum_max[k]``;
* **disk margin** of the loop broken at the plant input, sampled at the
  control period with its zero-order hold (:mod:`controllers.disk_margins`),
  at least ``disk_margin_min``. With one ``wn`` and ``zeta`` for all axes
  ``K = 2 J wn^2`` and ``C = 2 J zeta wn``, so the loop ``G_c P`` is
  ``(wn^2 + 2 zeta wn s) / s^2`` times the identity, whatever ``J`` (products
  of inertia included): every axis has the same margin and the multiloop
  margin equals it; the search evaluates one axis, the winner is checked on
  all of them and the multiloop (:func:`controllers.disk_margins.loop_disk_margins`).
  Continuous, the margin is ``2 zeta / sqrt(1 + zeta^2)`` whatever ``wn``
  (below 2 for every loop: a floor of 2 or more is refused); sampling lowers
  it as ``wn T`` grows. For ``skew = 0`` a disk margin ``alpha`` guarantees
  the gain factors ``[(2 - alpha) / (2 + alpha), (2 + alpha) / (2 - alpha)]``
  and the phase ``+-2 atan(alpha / 2)`` (Seiler, Packard and Gahinet 2020).

Search. In time ``wn t`` the continuous closed loop is the same for every
``wn``: the settling time scales as ``1 / wn``, the peak momentum as ``wn``
and the peak torque as ``wn^2``. For each damping, the largest ``wn`` the
torque, the momentum, the sample rate (``wn`` at most a tenth of it, where
:meth:`~controllers.pd.QuaternionPD.from_bandwidth` stops trusting the
continuous design) and the disk-margin floor allow (the last by
:func:`scipy.optimize.brentq`: the sampled margin falls as ``wn`` grows) gives
the fastest PD at that damping; with ``cost="effort"`` the smallest ``wn``
meeting the settling time gives the cheapest. The best damping is found on a
grid refined around its best point (the settling time jumps where an
overshoot leaves the band, so a derivative-based search would stall there),
then the winner's metrics are computed again directly. When no gains meet
every requirement the result is infeasible and names the requirements that
bind: those active at the fastest PD within all the others.

:func:`confirm_nonlinear` flies the winner on the nonlinear plant with the
wheels (:func:`attitude.simulation.engine.simulate`) and judges the settling
and the pointing with :class:`attitude.simulation.slew_windows.SlewWindows`.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import control
import numpy as np
import scipy.optimize
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from attitude.rigid_body import RigidBody
from attitude.validation import positive_per_axis, positive_scalar
from controllers.analysis import attitude_closed_loop, loop_gain
from controllers.disk_margins import disk_margins, loop_disk_margins
from controllers.pd import QuaternionPD

__all__ = [
    "COSTS",
    "DAMPING_BOUNDS",
    "PDMetrics",
    "RequirementConflict",
    "TuningRequirements",
    "TuningResult",
    "confirm_nonlinear",
    "minimum_step_time",
    "pd_metrics",
    "tune_pd",
]

#: What a tuning minimises: the settling time of the step, or its peak torque (the control effort).
COSTS = ("settling", "effort")
#: Dampings searched [-]: below 0.2 the step rings for tens of periods; above 4 the slow pole is 16 times below wn.
DAMPING_BOUNDS = (0.2, 4.0)
#: Dampings of the first grid and of each refinement around the best one.
DAMPING_GRID_POINTS = 17
REFINE_POINTS = 7
#: The refinement stops when the bracket of the best damping is this narrow [-] (the damping is then known to
#: 3e-4 relative near 0.8: the settling time moves by less than the search's time resolution).
DAMPING_TOLERANCE = 5e-4
#: The bracket of the damping of an infeasible set's diagnosis (the fastest PD within the other requirements) [-].
DIAGNOSIS_TOLERANCE = 5e-2
#: Samples of a step response: its settling time is resolved to its span / TIME_POINTS (about 5e-4 of the settling).
TIME_POINTS = 8000
#: Samples of the search's one-axis step responses (settling resolved to about 1e-3 of itself; the winner's
#: metrics are computed again with TIME_POINTS).
SEARCH_TIME_POINTS = 4000
#: The largest wn searched, as a fraction of the sample rate 2 pi / period (QuaternionPD.from_bandwidth's limit).
SAMPLE_RATE_FRACTION = 0.1
#: Relative tolerance of the wn at which the disk margin meets its floor (brentq's rtol); the wn kept is below the
#: root by twice this, on the side where the margin is above the floor (it falls as wn grows).
WN_RTOL = 1e-4
#: Relative tolerance of the disk margins of the search (the winner's are computed at the default, 1e-6).
SEARCH_MARGIN_RTOL = 1e-4
#: A linear metric within this fraction of its limit counts as binding (active) at the winner.
ACTIVE_FRACTION = 1e-3

_AXES = "xyz"


class RequirementConflict(ValueError):
    """Requirements that contradict themselves: no controller of any structure can meet them.

    Parameters
    ----------
    message : str
        What contradicts what, with the values.
    names : tuple of str
        The :class:`TuningRequirements` fields in conflict (``"settling_time"``, ``"torque_max"`` ...).
    """

    def __init__(self, message: str, names: tuple[str, ...]) -> None:
        super().__init__(message)
        self.names = tuple(names)


@dataclass(frozen=True)
class TuningRequirements:
    """What a tuned controller must meet (module docstring for how each is judged).

    Parameters
    ----------
    settling_time : float
        Largest settling time of the step into the band ``pointing_accuracy / step_angle`` [s].
    step_angle : float
        The step of the attitude reference [rad], in ``(0, pi]`` (e.g. the required slew's angle).
    pointing_accuracy : float
        The error the step must settle within [rad], below ``step_angle``.
    torque_max : float or array_like (3,)
        Largest body torque about each body axis [N m] (the wheels' envelope).
    momentum_max : float or array_like (3,), optional
        Largest body momentum the wheels may absorb about each body axis [N m s]; None: not judged.
    disk_margin_min : float, optional
        Smallest disk margin ``alpha`` of the loop at the plant input [-], in ``(0, 2)``; None: not judged.
    """

    settling_time: float
    step_angle: float
    pointing_accuracy: float
    torque_max: Any
    momentum_max: Any = None
    disk_margin_min: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "settling_time", positive_scalar(self.settling_time, "settling_time"))
        step = positive_scalar(self.step_angle, "step_angle")
        if step > math.pi:
            raise ValueError(f"step_angle must be in (0, pi] rad, got {step!r}")
        object.__setattr__(self, "step_angle", step)
        accuracy = positive_scalar(self.pointing_accuracy, "pointing_accuracy")
        if accuracy >= step:
            raise RequirementConflict(
                f"pointing_accuracy = {accuracy:.6g} rad is not below step_angle = {step:.6g} rad: a step that starts "
                "within the accuracy has nothing to settle",
                ("pointing_accuracy", "step_angle"),
            )
        object.__setattr__(self, "pointing_accuracy", accuracy)
        object.__setattr__(self, "torque_max", positive_per_axis(self.torque_max, "torque_max"))
        if self.momentum_max is not None:
            object.__setattr__(self, "momentum_max", positive_per_axis(self.momentum_max, "momentum_max"))
        if self.disk_margin_min is not None:
            alpha = float(self.disk_margin_min)
            if not (math.isfinite(alpha) and alpha > 0.0):
                raise ValueError(f"disk_margin_min must be a finite number > 0, got {self.disk_margin_min!r}")
            if alpha >= 2.0:
                raise RequirementConflict(
                    f"disk_margin_min = {alpha:.6g} is not below 2: a disk margin of 2 would tolerate a gain of "
                    "zero and infinite gain at once, which no loop has (for a PD, 2 zeta / sqrt(1 + zeta^2) < 2)",
                    ("disk_margin_min",),
                )
            object.__setattr__(self, "disk_margin_min", alpha)

    @property
    def settling_band(self) -> float:
        """The settling band as a fraction of the step [-]: ``pointing_accuracy / step_angle``."""
        return self.pointing_accuracy / self.step_angle


def minimum_step_time(body: RigidBody, requirements: TuningRequirements) -> NDArray[np.float64]:
    """The shortest time any controller needs for the step about each body axis [s] (rest to rest).

    Bang-bang at ``torque_max[k]`` about axis ``k`` with the moment ``J_kk``,
    ``2 sqrt((step_angle - pointing_accuracy) J_kk / torque_max[k])``; when the peak rate of that manoeuvre
    needs more momentum than ``momentum_max[k]``, it coasts at ``momentum_max[k] / J_kk`` (Wie, *Space Vehicle
    Dynamics and Control*, 2nd ed., sec. 7.3: the rest-to-rest time-optimal manoeuvre of one axis).

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    requirements : TuningRequirements
        The step, the accuracy, the torque and momentum limits.
    """
    inertia = np.diag(body.inertia)
    angle = requirements.step_angle - requirements.pointing_accuracy
    accel = requirements.torque_max / inertia
    times = 2.0 * np.sqrt(angle / accel)
    if requirements.momentum_max is not None:
        rate_max = requirements.momentum_max / inertia
        coasting = np.sqrt(angle * accel) > rate_max
        times = np.where(coasting, angle / rate_max + rate_max / accel, times)
    return times


@dataclass(frozen=True)
class PDMetrics:
    """The linear metrics of a PD candidate for the step of the requirements (module docstring).

    Attributes
    ----------
    wn : float
        Natural frequency [rad/s].
    zeta : float
        Damping ratio [-].
    settling_time : float
        The largest over the three step axes [s] (inf when it does not settle within the simulated span).
    peak_torque : ndarray (3,)
        Peak body-torque magnitude of the step about each body axis [N m].
    peak_momentum : ndarray (3,)
        Peak body-momentum magnitude of the step about each body axis [N m s].
    disk_margin : float
        Smallest disk margin at the plant input [-] (NaN when the closed loop is unstable).
    sampled : bool
        Whether the disk margin is that of the sampled loop.
    """

    wn: float
    zeta: float
    settling_time: float
    peak_torque: NDArray[np.float64]
    peak_momentum: NDArray[np.float64]
    disk_margin: float
    sampled: bool

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready, with units in the names."""
        return {
            "bandwidth_rad_per_s": self.wn,
            "damping": self.zeta,
            "settling_time_s": self.settling_time,
            "peak_torque_Nm": self.peak_torque.tolist(),
            "peak_momentum_Nms": self.peak_momentum.tolist(),
            "disk_margin": self.disk_margin,
            "disk_margin_sampled": self.sampled,
        }


def _step_system(body: RigidBody, pd: QuaternionPD) -> control.StateSpace:
    """The linear closed loop with outputs ``[theta (3), omega (3), tau (3)]`` for the reference ``theta_ref``."""
    closed = attitude_closed_loop(body, pd)
    half_k = 0.5 * np.asarray(pd.K, dtype=float)
    c_rate = np.asarray(pd.C, dtype=float)
    # tau = J omega' = K/2 (theta_ref - theta) - C omega
    c_out = np.vstack([np.asarray(closed.A)[:3], np.asarray(closed.A)[3:] * 0.0, np.hstack([-half_k, -c_rate])])
    c_out[:3] = np.hstack([np.eye(3), np.zeros((3, 3))])
    c_out[3:6] = np.hstack([np.zeros((3, 3)), np.eye(3)])
    d_out = np.vstack([np.zeros((6, 3)), half_k])
    return control.ss(closed.A, closed.B, c_out, d_out)


def _time_grid(system: control.StateSpace, wn: float, band: float, points: int) -> NDArray[np.float64]:
    """Times covering a step's settling into ``band``: 1.5 times the time to the band plus three time constants."""
    decay = float(np.min(-np.real(np.linalg.eigvals(np.asarray(system.A)))))
    # The error decays like (wn t)^m exp(-decay t) (m = 1 for the double pole of zeta = 1).
    span = 1.5 * (math.log(1.0 / band) + 3.0 + math.log1p(wn / decay)) / decay
    return np.linspace(0.0, span, points)


def _settling(y: NDArray[np.float64], t: NDArray[np.float64], band: float) -> float:
    """The step's settling time into ``band`` of the final value 1 (:func:`control.step_info`); inf if never."""
    if abs(y[-1] - 1.0) > band:
        return math.inf
    return float(control.step_info(y, t, final_output=1.0, SettlingTimeThreshold=band)["SettlingTime"])


def _step_metrics(
    body: RigidBody, wn: float, zeta: float, requirements: TuningRequirements
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """Settling time [s], peak torque [N m] (3,) and peak momentum [N m s] (3,) of the continuous linear loop."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the sample-rate warning: this loop is continuous
        pd = QuaternionPD.from_bandwidth(body, wn=wn, zeta=zeta, period=1.0)
    system = _step_system(body, pd)
    band = requirements.settling_band
    t = _time_grid(system, wn, band, TIME_POINTS)
    response = control.step_response(system, t)
    y = np.asarray(response.outputs) * requirements.step_angle  # (outputs 9, inputs 3, time)
    settling = 0.0
    inertia = body.inertia
    peak_torque = np.zeros(3)
    peak_momentum = np.zeros(3)
    for k in range(3):
        settling = max(settling, _settling(y[k, k] / requirements.step_angle, t, band))
        peak_torque[k] = float(np.max(np.linalg.norm(y[6:9, k], axis=0)))
        peak_momentum[k] = float(np.max(np.linalg.norm(inertia @ y[3:6, k], axis=0)))
    return settling, peak_torque, peak_momentum


def _search_margin(body: RigidBody, wn: float, zeta: float, period: float | None) -> float:
    """The disk margin of one axis's loop (every axis's, module docstring); NaN when the closed loop is unstable."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pd = QuaternionPD.from_bandwidth(body, wn=wn, zeta=zeta, period=period or 1.0)
    loop = loop_gain(body, pd, sampled=period is not None)[0]
    return float(disk_margins(loop, rtol=SEARCH_MARGIN_RTOL).disk_margin)


def pd_metrics(
    body: RigidBody, requirements: TuningRequirements, *, wn: float, zeta: float, period: float | None
) -> PDMetrics:
    """The linear metrics of the PD at ``wn`` and ``zeta`` for the requirements' step (module docstring).

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    requirements : TuningRequirements
        The step and its band.
    wn : float
        Natural frequency [rad/s].
    zeta : float
        Damping ratio [-].
    period : float or None
        Control period [s] of the sampled loop whose disk margin is judged; None: the continuous loop.
    """
    wn = positive_scalar(wn, "wn")
    zeta = positive_scalar(zeta, "zeta")
    settling, torque, momentum = _step_metrics(body, wn, zeta, requirements)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pd = QuaternionPD.from_bandwidth(body, wn=wn, zeta=zeta, period=period or 1.0)
    margins = loop_disk_margins(body, pd, sampled=period is not None)
    return PDMetrics(wn, zeta, settling, torque, momentum, margins.smallest, period is not None)


@dataclass(frozen=True)
class _AtDamping:
    """The best wn at one damping and what limits it."""

    zeta: float
    wn: float  # NaN when none is feasible
    cost: float  # inf when none is feasible
    limits: dict[str, float] = field(default_factory=dict)  # the wn each requirement allows at most [rad/s]
    wn_needed: float = 0.0  # the smallest wn meeting the settling time [rad/s]
    alpha_low: float = math.nan  # the disk margin as wn -> 0 (the continuous loop's)


class _Search:
    """The per-damping reduction of the module docstring, with its evaluations cached."""

    def __init__(
        self,
        body: RigidBody,
        requirements: TuningRequirements,
        period: float | None,
        cost: str,
        zeta_grid: NDArray[np.float64],
    ) -> None:
        self.body = body
        self.zeta_grid = zeta_grid
        self.req = requirements
        self.period = period
        self.cost = cost
        self.cache: dict[float, _AtDamping] = {}
        self.wn_cap = math.inf if period is None else SAMPLE_RATE_FRACTION * 2.0 * math.pi / period

    def unit(self, zeta: float) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        """The step metrics at wn = 1 rad/s (they scale as 1/wn, wn^2, wn), from one axis's loop.

        Every axis obeys ``theta'' + 2 zeta wn theta' + wn^2 theta = wn^2 theta_ref`` (``J^-1 K / 2 = wn^2 I``,
        ``J^-1 C = 2 zeta wn I``), so the step about axis ``k`` has the torque ``J e_k theta''`` and the
        momentum ``J e_k theta'``: one second-order step gives all three axes.
        """
        system = control.ss(
            [[0.0, 1.0], [-1.0, -2.0 * zeta]],
            [[0.0], [1.0]],
            [[1.0, 0.0], [0.0, 1.0], [-1.0, -2.0 * zeta]],
            [[0.0], [0.0], [1.0]],
        )
        t = _time_grid(system, 1.0, self.req.settling_band, SEARCH_TIME_POINTS)
        y = np.asarray(control.step_response(system, t).outputs)[:, 0]  # (3, time): theta, theta', theta''
        settling = _settling(y[0], t, self.req.settling_band)
        lever = np.linalg.norm(self.body.inertia, axis=0) * self.req.step_angle  # |J e_k| step_angle
        return settling, lever * float(np.max(np.abs(y[2]))), lever * float(np.max(np.abs(y[1])))

    def at(self, zeta: float) -> _AtDamping:
        zeta = float(zeta)
        if zeta in self.cache:
            return self.cache[zeta]
        req = self.req
        settling_1, torque_1, momentum_1 = self.unit(zeta)
        limits = {"torque_max": float(np.min(np.sqrt(req.torque_max / torque_1)))}
        if req.momentum_max is not None:
            limits["momentum_max"] = float(np.min(req.momentum_max / momentum_1))
        if math.isfinite(self.wn_cap):
            limits["sample_rate"] = self.wn_cap
        wn_high = min(limits.values())
        wn_needed = settling_1 / req.settling_time
        alpha_low = math.nan
        if req.disk_margin_min is not None:
            floor = req.disk_margin_min

            def excess(wn: float) -> float:
                alpha = _search_margin(self.body, wn, zeta, self.period)
                return (alpha if math.isfinite(alpha) else 0.0) - floor

            if excess(wn_high) < 0.0:
                low = wn_high * 1e-4
                alpha_low = excess(low) + floor
                if alpha_low < floor:
                    limits["disk_margin_min"] = 0.0
                else:
                    root = scipy.optimize.brentq(excess, low, wn_high, rtol=WN_RTOL)
                    limits["disk_margin_min"] = root * (1.0 - 2.0 * WN_RTOL)
        wn_max = min(limits.values())
        if self.cost == "settling":
            wn = wn_max
            ok = wn_max > 0.0 and wn_needed <= wn_max * (1.0 + 1e-12)
            value = settling_1 / wn_max if ok else math.inf
        else:
            wn = wn_needed
            ok = wn_needed <= wn_max * (1.0 + 1e-12)
            value = float(np.max(torque_1)) * wn_needed**2 if ok else math.inf
        out = _AtDamping(zeta, wn if ok else math.nan, value, limits, wn_needed, alpha_low)
        self.cache[zeta] = out
        return out

    def fastest_within_others(self, zeta: float) -> float:
        """The settling time of the fastest PD at ``zeta`` within every requirement but the settling time [s]."""
        point = self.at(zeta)
        wn_max = min(point.limits.values())
        return math.inf if wn_max <= 0.0 else point.wn_needed * self.req.settling_time / wn_max

    def best(self, score: Any, tolerance: float = DAMPING_TOLERANCE) -> float:
        """The damping minimising ``score(zeta)`` on the grid, refined around its best point."""
        grid = self.zeta_grid
        while True:
            values = np.array([score(z) for z in grid])
            i = int(np.argmin(values))
            low, high = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
            if high - low <= tolerance or not np.isfinite(values[i]):
                return float(grid[i])
            grid = np.linspace(low, high, REFINE_POINTS)


@dataclass(frozen=True)
class TuningResult:
    """A tuned PD, or why none meets the requirements.

    Attributes
    ----------
    feasible : bool
        Whether the returned gains meet every requirement on the linear metrics.
    wn : float
        The natural frequency [rad/s] (of the fastest PD within the other requirements when infeasible).
    zeta : float
        The damping ratio [-] (likewise).
    metrics : PDMetrics
        The linear metrics of those gains, computed directly (not by scaling).
    cost : str
        What was minimised (:data:`COSTS`).
    binding : tuple of str
        The requirements active at the result (:data:`ACTIVE_FRACTION` of their limit), or, when infeasible,
        the ones that keep the settling time (or the disk margin) out of reach.
    message : str
        One paragraph: what binds and by how much.
    requirements : TuningRequirements
        What was asked.
    period : float or None
        The control period [s] (None: continuous).
    tradeoff : dict of ndarray
        Every damping and frequency of the trade-off sweep: ``zeta``, ``wn`` [rad/s], ``settling_time`` [s],
        ``disk_margin`` [-], and ``pareto`` (bool): no other candidate within torque and momentum settles
        faster with a larger margin.
    """

    feasible: bool
    wn: float
    zeta: float
    metrics: PDMetrics
    cost: str
    binding: tuple[str, ...]
    message: str
    requirements: TuningRequirements
    period: float | None
    tradeoff: dict[str, NDArray[Any]]

    def summary(self) -> str:
        """One line: the gains and the verdict."""
        verdict = "meets every requirement" if self.feasible else "INFEASIBLE"
        return (
            f"PD wn = {self.wn:.4g} rad/s, zeta = {self.zeta:.4g}: settling {self.metrics.settling_time:.4g} s, "
            f"disk margin {self.metrics.disk_margin:.4g}; {verdict} (binding: {', '.join(self.binding) or 'none'})"
        )

    def plot(self, before: PDMetrics | None = None) -> Figure:
        """The trade-off of settling time against disk margin, the requirement lines and the chosen point.

        Parameters
        ----------
        before : PDMetrics, optional
            The gains before tuning, marked for comparison.

        Returns
        -------
        matplotlib.figure.Figure
        """
        return plot_tradeoff(self, before)


def _tradeoff(search: _Search, zetas: NDArray[np.float64]) -> dict[str, NDArray[Any]]:
    """Candidates at each damping, from the actuator limit down to a fifth of it, and their Pareto front."""
    rows = []
    for zeta in zetas:
        point = search.at(float(zeta))
        wn_actuator = min(v for k, v in point.limits.items() if k != "disk_margin_min")
        settling_1 = point.wn_needed * search.req.settling_time
        for fraction in np.geomspace(1.0, 0.2, 5):
            wn = wn_actuator * fraction
            rows.append((zeta, wn, settling_1 / wn, _search_margin(search.body, wn, float(zeta), search.period)))
    table = np.array(rows)
    settling, alpha = table[:, 2], np.nan_to_num(table[:, 3], nan=0.0)
    pareto = np.array(
        [not np.any((settling < s) & (alpha >= a) | (settling <= s) & (alpha > a)) for s, a in zip(settling, alpha)]
    )
    return {
        "zeta": table[:, 0],
        "wn": table[:, 1],
        "settling_time": settling,
        "disk_margin": table[:, 3],
        "pareto": pareto,
    }


def _describe_limit(name: str, req: TuningRequirements, period: float | None) -> str:
    if name == "torque_max":
        return f"torque_max = {np.min(req.torque_max):.4g} N m (the step's peak torque, J wn^2 step_angle)"
    if name == "momentum_max":
        return f"momentum_max = {np.min(req.momentum_max):.4g} N m s (the step's peak momentum)"
    if name == "sample_rate":
        return f"wn at most a tenth of the sample rate 2 pi / {period:g} s"
    return f"disk_margin_min = {req.disk_margin_min:g}" + (
        f" at the {1.0 / period:g} Hz sample rate" if period is not None else ""
    )


def tune_pd(
    body: RigidBody,
    requirements: TuningRequirements,
    *,
    period: float | None,
    cost: str = "settling",
    damping_bounds: tuple[float, float] = DAMPING_BOUNDS,
    damping_points: int = DAMPING_GRID_POINTS,
    tradeoff_points: int = 10,
) -> TuningResult:
    """The PD (one ``wn`` and ``zeta`` for all axes) that meets the requirements at the least cost.

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    requirements : TuningRequirements
        What the PD must meet.
    period : float or None
        Control period [s]: the disk margin is that of the sampled loop, and ``wn`` stays below a tenth of the
        sample rate; None: the continuous loop, no such limit.
    cost : str
        ``"settling"`` (the shortest settling time) or ``"effort"`` (the smallest peak torque that still
        settles in time).
    damping_bounds : tuple of float
        The dampings searched [-] (:data:`DAMPING_BOUNDS`).
    damping_points : int
        Dampings of the first grid (at least 3), geometrically spaced; the best is refined.
    tradeoff_points : int
        Dampings of the trade-off sweep (five frequencies each); 0: none.

    Returns
    -------
    TuningResult

    Raises
    ------
    RequirementConflict
        When the settling time is shorter than the fastest rest-to-rest step the torque (and momentum)
        limits allow (:func:`minimum_step_time`): no controller meets it.
    ValueError
        For a bad argument.
    """
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single RigidBody, got {body!r}")
    if not isinstance(requirements, TuningRequirements):
        raise ValueError(f"requirements must be TuningRequirements, got {type(requirements).__name__}")
    if cost not in COSTS:
        raise ValueError(f"cost must be one of {COSTS}, got {cost!r}")
    if period is not None:
        period = positive_scalar(period, "period")
    tradeoff_points = int(tradeoff_points)
    if tradeoff_points < 0:
        raise ValueError(f"tradeoff_points must be >= 0, got {tradeoff_points}")
    fastest = minimum_step_time(body, requirements)
    if requirements.settling_time < float(np.max(fastest)):
        k = int(np.argmax(fastest))
        # The momentum limit binds only when the bang-bang step would spin past it (it coasts).
        inertia_k = float(np.diag(body.inertia)[k])
        peak_rate = math.sqrt(
            (requirements.step_angle - requirements.pointing_accuracy) * requirements.torque_max[k] / inertia_k
        )
        coasts = requirements.momentum_max is not None and peak_rate > requirements.momentum_max[k] / inertia_k
        names = ("settling_time", "torque_max") + (("momentum_max",) if coasts else ())
        raise RequirementConflict(
            f"settling_time = {requirements.settling_time:.6g} s is shorter than the fastest possible step of "
            f"{requirements.step_angle:.6g} rad about body {_AXES[k]}: {fastest[k]:.6g} s rest to rest at "
            f"torque_max = {requirements.torque_max[k]:.6g} N m"
            + (" coasting at momentum_max" if coasts else "")
            + " (bang-bang; no controller is faster)",
            names,
        )

    low, high = (float(v) for v in damping_bounds)
    if not (0.0 < low < high and math.isfinite(high)):
        raise ValueError(f"damping_bounds must be 0 < low < high, finite, got {damping_bounds!r}")
    damping_points = int(damping_points)
    if damping_points < 3:
        raise ValueError(f"damping_points must be at least 3, got {damping_points}")
    search = _Search(body, requirements, period, cost, np.geomspace(low, high, damping_points))
    zeta = search.best(lambda z: search.at(z).cost)
    point = search.at(zeta)
    feasible = math.isfinite(point.cost)
    if feasible:
        wn = point.wn
        metrics = pd_metrics(body, requirements, wn=wn, zeta=zeta, period=period)
        binding = _active(metrics, requirements, point, cost)
        message = f"wn = {wn:.6g} rad/s, zeta = {zeta:.6g} ({cost} minimised); binding: " + (
            ", ".join(_describe_limit(n, requirements, period) if n != "settling_time" else n for n in binding)
            or "none"
        )
    else:
        # The fastest PD within everything but the settling time shows what holds it back (a diagnosis: the
        # damping to DIAGNOSIS_TOLERANCE).
        zeta = search.best(search.fastest_within_others, tolerance=DIAGNOSIS_TOLERANCE)
        point = search.at(zeta)
        wn_max = min(point.limits.values())
        if wn_max <= 0.0:
            margins = [search.at(float(z)).alpha_low for z in search.zeta_grid]
            best_alpha = float(np.nanmax(margins))
            wn = point.wn_needed
            binding = ("disk_margin_min",)
            message = (
                f"disk_margin_min = {requirements.disk_margin_min:g} is out of reach: the largest disk margin of a "
                f"PD with zeta in [{low:g}, {high:g}] is {best_alpha:.4g} (continuous, 2 zeta / sqrt(1 + zeta^2)"
                + ("; sampling only lowers it)" if period is not None else ")")
            )
        else:
            wn = wn_max
            limiting = sorted(
                (n for n, v in point.limits.items() if v <= wn_max * (1.0 + ACTIVE_FRACTION)),
                key=lambda n: point.limits[n],
            )
            binding = ("settling_time", *limiting)
            message = (
                f"settling_time = {requirements.settling_time:g} s needs wn >= {point.wn_needed:.4g} rad/s at the "
                f"best damping zeta = {zeta:.4g}, but "
                + " and ".join(_describe_limit(n, requirements, period) for n in limiting)
                + f" allow at most wn = {wn_max:.4g} rad/s: the fastest PD within them settles in "
                f"{search.fastest_within_others(zeta):.4g} s"
            )
        metrics = pd_metrics(body, requirements, wn=wn, zeta=zeta, period=period)
    # The sweep holds the result's damping too, so its front passes through the chosen point when the actuators bind.
    sweep = np.union1d(np.geomspace(low, high, tradeoff_points), [zeta]) if tradeoff_points else None
    tradeoff = _tradeoff(search, sweep) if sweep is not None else {}
    return TuningResult(feasible, wn, zeta, metrics, cost, binding, message, requirements, period, tradeoff)


def _active(metrics: PDMetrics, req: TuningRequirements, point: _AtDamping, cost: str) -> tuple[str, ...]:
    """The requirements within ACTIVE_FRACTION of their limit at the winner."""
    near = 1.0 - ACTIVE_FRACTION
    active = []
    if metrics.settling_time >= near * req.settling_time:
        active.append("settling_time")
    if np.any(metrics.peak_torque >= near * req.torque_max):
        active.append("torque_max")
    if req.momentum_max is not None and np.any(metrics.peak_momentum >= near * req.momentum_max):
        active.append("momentum_max")
    if req.disk_margin_min is not None and metrics.disk_margin <= req.disk_margin_min / near:
        active.append("disk_margin_min")
    if "sample_rate" in point.limits and metrics.wn >= near * point.limits["sample_rate"]:
        active.append("sample_rate")
    return tuple(active)


def plot_tradeoff(result: TuningResult, before: PDMetrics | None = None) -> Figure:
    """Settling time against disk margin: the sweep, its Pareto front, the requirements and the chosen PD.

    Parameters
    ----------
    result : TuningResult
        A tuning with its trade-off sweep.
    before : PDMetrics, optional
        The gains before tuning, marked for comparison.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.figure import Figure as _Figure

    req = result.requirements
    fig = _Figure(figsize=(7.5, 5.0), layout="constrained")
    ax = fig.add_subplot()
    t = result.tradeoff
    if t:
        alpha = np.nan_to_num(t["disk_margin"], nan=0.0)
        ax.scatter(alpha, t["settling_time"], s=10, color="0.65", label="candidates within torque and momentum (sweep)")
        front = t["pareto"]
        order = np.argsort(alpha[front])
        ax.plot(alpha[front][order], t["settling_time"][front][order], "-o", ms=3, color="C0", label="Pareto front")
    ax.axhline(req.settling_time, color="C3", ls="--", lw=1.2, label=f"settling_time = {req.settling_time:g} s")
    x_low, x_high = ax.get_xlim()
    y_high = ax.get_ylim()[1]
    y_high = max(y_high, 1.2 * req.settling_time)
    ax.axhspan(req.settling_time, 1e3 * y_high, color="C3", alpha=0.08, lw=0)
    if req.disk_margin_min is not None:
        ax.axvline(req.disk_margin_min, color="C1", ls="--", lw=1.2, label=f"disk_margin_min = {req.disk_margin_min:g}")
        ax.axvspan(min(x_low, req.disk_margin_min), req.disk_margin_min, color="C1", alpha=0.08, lw=0)
        x_low = min(x_low, req.disk_margin_min - 0.05)
    m = result.metrics
    if before is not None:
        over = np.max(before.peak_torque / req.torque_max)
        note = f", peak torque {over:.2g} x the limit" if over > 1.0 + ACTIVE_FRACTION else ""
        ax.plot(
            before.disk_margin,
            before.settling_time,
            "s",
            ms=9,
            mfc="none",
            mec="k",
            mew=1.5,
            label=f"before: wn {before.wn:.3g} rad/s, zeta {before.zeta:.3g}{note}",
        )
        y_high = max(y_high, 1.1 * before.settling_time) if math.isfinite(before.settling_time) else y_high
    ax.plot(
        m.disk_margin,
        m.settling_time,
        "*",
        ms=16,
        color="C2",
        mec="k",
        label=f"{'tuned' if result.feasible else 'closest (infeasible)'}: wn {m.wn:.3g} rad/s, zeta {m.zeta:.3g}",
    )
    ax.set_xlim(x_low, x_high)
    ax.set_yscale("log")
    ax.set_ylim(0.3 * min(m.settling_time, req.settling_time), min(y_high, 20.0 * req.settling_time))
    ax.set_xlabel("disk margin alpha at the plant input [-]" + (" (sampled loop)" if result.period else ""))
    ax.set_ylabel(f"settling time into {100 * req.settling_band:.3g} % of the step [s]")
    ax.set_title("PD tuning: settling time vs disk margin (shaded: fails a requirement)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return fig


def confirm_nonlinear(
    body: RigidBody,
    requirements: TuningRequirements,
    *,
    wn: float,
    zeta: float,
    period: float,
    wheels: Any = None,
    axis: ArrayLike = (1.0, 0.0, 0.0),
    hold_time: float | None = None,
) -> dict[str, Any]:
    """Fly the PD's step on the nonlinear plant and judge its settling time and pointing.

    :meth:`QuaternionPD.from_bandwidth` with gyroscopic compensation, the truth fed back, from rest at the
    identity to ``step_angle`` about ``axis``, through the wheels (their torque and momentum limits) when given.
    Judged with :class:`attitude.simulation.slew_windows.SlewWindows` (the slew ends at ``t = 0``: the step
    is the whole manoeuvre): ``settling_time`` is the time the error enters the pointing accuracy for good,
    ``pointing_error`` the largest error over the hold that follows the required settling time.

    Parameters
    ----------
    body : RigidBody
        The spacecraft (wheels included) [kg m^2].
    requirements : TuningRequirements
        The step, the accuracy and the settling time.
    wn : float
        Natural frequency [rad/s].
    zeta : float
        Damping ratio [-].
    period : float
        Control period [s].
    wheels : ReactionWheels, optional
        The actuators; None: the commanded torque acts on the body.
    axis : array_like (3,)
        Step axis in body axes (normalised).
    hold_time : float, optional
        The hold judged after the settling time [s]; default ``max(30 s, settling_time)``.

    Returns
    -------
    dict
        ``settling_time_s``, ``pointing_error_rad``, ``peak_torque_Nm``, ``passed`` (both within the
        requirements) and the flown ``duration_s``.
    """
    from attitude import quaternion as quat
    from attitude.simulation.engine import simulate
    from attitude.simulation.slew_windows import SlewWindows

    period = positive_scalar(period, "period")
    axis = np.asarray(axis, dtype=float)
    if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) == 0.0:
        raise ValueError(f"axis must be a non-zero finite 3-vector, got {axis!r}")
    axis = axis / np.linalg.norm(axis)
    hold = max(30.0, requirements.settling_time) if hold_time is None else positive_scalar(hold_time, "hold_time")
    windows = SlewWindows(0.0, requirements.settling_time, hold, requirements.pointing_accuracy)
    target = quat.from_rotation_vector(axis * requirements.step_angle)
    pd = QuaternionPD.from_bandwidth(body, wn=wn, zeta=zeta, period=period, gyroscopic=True, q_ref=target)
    run = simulate(body, quat.identity(), np.zeros(3), windows.hold_end_s, controller=pd, wheels=wheels)
    judged = windows.metrics(run.t, quat.error_angle(target, run.q))
    settling = float(judged["slew_time"])
    pointing = float(judged["pointing_error_hold"])
    return {
        "settling_time_s": settling,
        "pointing_error_rad": pointing,
        "peak_torque_Nm": float(np.max(np.linalg.norm(run.torque_applied, axis=-1))),
        "duration_s": float(run.t[-1]),
        "passed": bool(settling <= requirements.settling_time and pointing <= requirements.pointing_accuracy),
    }

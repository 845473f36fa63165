"""Tuning a quaternion PD or an LQR to a set of requirements: the fastest (or cheapest) gains that meet them all.

The structures (:data:`STRUCTURES`): :meth:`controllers.pd.QuaternionPD.from_bandwidth` with one
natural frequency ``wn`` and one damping ``zeta`` for the three axes (the
spacecraft file's ``control.bandwidth_rad_per_s`` and ``control.damping``), the same PD with one pair per
axis, and the LQR's Bryson bounds per axis (see Per axis and LQR below).
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

Per axis. ``tune_pd(per_axis=True)`` gives each body axis its own ``wn_k`` and ``zeta_k``:
``K = 2 J diag(wn^2)`` and ``C = 2 J diag(zeta wn)`` keep ``J^-1 K / 2`` and ``J^-1 C`` diagonal, so the linear
axes stay uncoupled even with products of inertia, and each axis is searched alone with its own torque and
momentum limits (the step about axis ``k`` loads ``|J e_k|``). The disk-margin root depends on ``zeta`` and
``wn T`` only, so the three searches share it. The winner's margins are then computed on the 3-axis loop, where
the axes' different gains and the products of inertia can lower the multiloop margin below any one axis's: a
winner below the floor there is infeasible, and says so.

LQR. The LQR (:func:`controllers.lqr.design_lqr`, Bryson's rule) on the rigid body at rest is, per principal axis,
a PD on the double integrator ``q' = omega / 2``, ``J omega' = tau``: the Riccati equation gives
``k_q = c / sin(a / 2)`` and ``k_omega = sqrt(J k_q + c^2 / b^2)`` for the bounds ``a`` (angle), ``b`` (rate) and
``c`` (torque), so ``wn^2 = c / (2 J sin(a / 2))`` and ``zeta^2 = 1/2 + c^2 / (4 J^2 wn^2 b^2)`` (Bryson and Ho,
*Applied Optimal Control*, 1975, sec. 5.2; the ``zeta >= 1 / sqrt(2)`` of every LQR on a double integrator).
:func:`tune_lqr` therefore runs the per-axis search on dampings above ``1 / sqrt(2)``, maps each axis's
``(wn, zeta)`` to Bryson bounds with the file's attitude bound ``a`` kept (:func:`lqr_bounds`), designs the LQR
at the control period, and judges that design itself (:func:`lqr_metrics`: its gain's step on the linear
loop, its sampled loop's disk margins). The discrete design is not exactly its continuous equivalent, so one
scale on the three ``wn`` is then bisected to the fastest (or cheapest) sampled design within every requirement.

Modes and filters. With a :class:`MarginLoop` (the flexible plant of :func:`attitude.linearize.flexible_plant`
and the command filters as they fly) the disk margin is judged on that loop instead, each axis's loop alone
in the search (the axes differ now, so per-axis searches no longer share the margin's root) and per axis and
multiloop at the winner. The step metrics stay those of the rigid body: the modes are well above the
bandwidth or they would bind the margin first. A mode can make the margin non-monotonic in ``wn`` (a
collocated mode phase-stabilised at one bandwidth, not at another); the root search then finds one crossing,
and the winner's own margins, computed afterwards on every loop, are what the result is judged on.

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
from dataclasses import dataclass, field, replace
from typing import Any

import control
import numpy as np
import scipy.optimize
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from attitude.linearize import linearize
from attitude.rigid_body import RigidBody
from attitude.validation import positive_per_axis, positive_scalar
from controllers.analysis import attitude_closed_loop, loop_gain
from controllers.disk_margins import disk_margins, loop_disk_margins
from controllers.lqr import LQRController, LQRDesign, bryson_weights, design_lqr
from controllers.pd import QuaternionPD

__all__ = [
    "COSTS",
    "DAMPING_BOUNDS",
    "LQR_DAMPING_BOUNDS",
    "STRUCTURES",
    "MarginLoop",
    "PDMetrics",
    "RequirementConflict",
    "TuningRequirements",
    "TuningResult",
    "confirm_nonlinear",
    "format_values",
    "lqr_bounds",
    "lqr_metrics",
    "minimum_step_time",
    "pd_metrics",
    "tune_lqr",
    "tune_pd",
]

#: The controller structures tuned: one PD for all axes (:func:`tune_pd`), a PD per axis
#: (``tune_pd(per_axis=True)``) and the LQR's Bryson bounds per axis (:func:`tune_lqr`).
STRUCTURES = ("pd", "pd_per_axis", "lqr")
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


def format_values(value: ArrayLike, digits: int = 4) -> str:
    """A scalar as ``1.234``, three per-axis values as ``[1.234, 0.5, 2]`` (``digits`` significant digits).

    Parameters
    ----------
    value : float or array_like (3,)
        One value or one per body axis.
    digits : int
        Significant digits.
    """
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        return f"{float(arr):.{digits}g}"
    return "[" + ", ".join(f"{v:.{digits}g}" for v in arr.ravel()) + "]"


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
    wn : float or ndarray (3,)
        Natural frequency, one or per body axis [rad/s] (for an LQR, the equivalent of :func:`lqr_bounds`).
    zeta : float or ndarray (3,)
        Damping ratio, one or per body axis [-] (likewise).
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

    wn: float | NDArray[np.float64]
    zeta: float | NDArray[np.float64]
    settling_time: float
    peak_torque: NDArray[np.float64]
    peak_momentum: NDArray[np.float64]
    disk_margin: float
    sampled: bool

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready, with units in the names."""
        return {
            "bandwidth_rad_per_s": np.asarray(self.wn).tolist(),
            "damping": np.asarray(self.zeta).tolist(),
            "settling_time_s": self.settling_time,
            "peak_torque_Nm": self.peak_torque.tolist(),
            "peak_momentum_Nms": self.peak_momentum.tolist(),
            "disk_margin": self.disk_margin,
            "disk_margin_sampled": self.sampled,
        }


def _step_system(body: RigidBody, gains: Any) -> control.StateSpace:
    """The linear closed loop with outputs ``[theta (3), omega (3), tau (3)]`` for the reference ``theta_ref``.

    ``gains`` has ``K`` (on the error-quaternion vector part) and ``C`` (on the rate) [N m, N m s], (3, 3): a
    :class:`~controllers.pd.QuaternionPD`, or an LQR's ``[K_q, K_omega]`` (:func:`lqr_metrics`).
    """
    closed = attitude_closed_loop(body, gains)
    half_k = 0.5 * np.asarray(gains.K, dtype=float)
    c_rate = np.asarray(gains.C, dtype=float)
    # tau = J omega' = K/2 (theta_ref - theta) - C omega
    c_out = np.vstack(
        [
            np.hstack([np.eye(3), np.zeros((3, 3))]),
            np.hstack([np.zeros((3, 3)), np.eye(3)]),
            np.hstack([-half_k, -c_rate]),
        ]
    )
    d_out = np.vstack([np.zeros((6, 3)), half_k])
    return control.ss(closed.A, closed.B, c_out, d_out)


def _time_grid(system: control.StateSpace, band: float, points: int, wn: float | None = None) -> NDArray[np.float64]:
    """Times covering a step's settling into ``band``: 1.5 times the time to the band plus three time constants.

    ``wn`` [rad/s] is the loop's natural frequency (default: the largest pole magnitude).
    """
    poles = np.linalg.eigvals(np.asarray(system.A))
    decay = float(np.min(-np.real(poles)))
    wn = float(np.max(np.abs(poles))) if wn is None else wn
    # The error decays like (wn t)^m exp(-decay t) (m = 1 for the double pole of zeta = 1).
    span = 1.5 * (math.log(1.0 / band) + 3.0 + math.log1p(wn / decay)) / decay
    return np.linspace(0.0, span, points)


def _settling(y: NDArray[np.float64], t: NDArray[np.float64], band: float) -> float:
    """The step's settling time into ``band`` of the final value 1 (:func:`control.step_info`); inf if never."""
    if abs(y[-1] - 1.0) > band:
        return math.inf
    return float(control.step_info(y, t, final_output=1.0, SettlingTimeThreshold=band)["SettlingTime"])


def _step_metrics(
    body: RigidBody, gains: Any, requirements: TuningRequirements, wn: float | None = None
) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """Settling time [s], peak torque [N m] (3,) and peak momentum [N m s] (3,) of the continuous linear loop.

    ``wn`` [rad/s]: the loop's largest natural frequency when known (:func:`_time_grid`).
    """
    system = _step_system(body, gains)
    band = requirements.settling_band
    t = _time_grid(system, band, TIME_POINTS, wn)
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


def _pd(body: RigidBody, wn: ArrayLike, zeta: ArrayLike, period: float | None) -> QuaternionPD:
    """The PD at ``wn`` and ``zeta`` (scalars or per axis), its sample-rate warning silenced (the search caps wn)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return QuaternionPD.from_bandwidth(body, wn=wn, zeta=zeta, period=period or 1.0)


@dataclass(frozen=True)
class MarginLoop:
    """The loop whose disk margin a tuning judges: the plant and the filters that fly (module docstring, Modes).

    Parameters
    ----------
    plant : control LTI, optional
        The plant of the loop (e.g. :func:`attitude.linearize.flexible_plant`, with the outputs of the rigid
        plant); None: the rigid body at rest.
    command_filter : callable, optional
        ``command_filter(law)`` returns the law as flown (e.g. wrapped in
        :class:`controllers.filters.FilteredController`); None: no filters.
    """

    plant: Any = None
    command_filter: Any = None

    @property
    def rigid(self) -> bool:
        """True for the rigid, unfiltered loop (the default)."""
        return self.plant is None and self.command_filter is None

    @property
    def label(self) -> str:
        """The loop in words ("" for the rigid, unfiltered loop)."""
        parts = (["flexible plant"] if self.plant is not None else []) + (
            ["command filters"] if self.command_filter is not None else []
        )
        return "with the " + " and the ".join(parts) if parts else ""

    def flown(self, law: Any) -> Any:
        """The law as flown (filtered when there are filters).

        Parameters
        ----------
        law : object
            A controller (PD, LQR).
        """
        return law if self.command_filter is None else self.command_filter(law)

    def margins(self, body: RigidBody, law: Any, sampled: bool) -> Any:
        """:func:`controllers.disk_margins.loop_disk_margins` of the law on this loop (per axis and multiloop).

        Parameters
        ----------
        body : RigidBody
            The rigid body (the plant when ``plant`` is None) [kg m^2].
        law : object
            The controller, before filtering.
        sampled : bool
            Whether the loop is sampled at the law's period.
        """
        return loop_disk_margins(body if self.plant is None else self.plant, self.flown(law), sampled=sampled)


def _search_margin(
    body: RigidBody,
    wn: float,
    zeta: float,
    period: float | None,
    loop: MarginLoop | None = None,
    axes: list[int] | None = None,
) -> float:
    """The smallest disk margin of the axes' loops (each alone); NaN when the closed loop is unstable.

    On the rigid, unfiltered loop every axis's loop is the same (module docstring): one is evaluated.
    """
    loop = loop or MarginLoop()
    pd = _pd(body, wn, zeta, period)
    loops = loop_gain(body if loop.plant is None else loop.plant, loop.flown(pd), sampled=period is not None)
    axes = [0] if loop.rigid or axes is None else axes
    margins = [float(disk_margins(loops[k], rtol=SEARCH_MARGIN_RTOL).disk_margin) for k in axes]
    return math.nan if any(math.isnan(m) for m in margins) else min(margins)


def _per_axis_or_scalar(value: ArrayLike, name: str) -> float | NDArray[np.float64]:
    """A positive scalar, or three positive values per body axis (kept as given: one value stays one value)."""
    if np.ndim(value) == 0:
        return positive_scalar(value, name)
    return positive_per_axis(value, name)


def pd_metrics(
    body: RigidBody,
    requirements: TuningRequirements,
    *,
    wn: ArrayLike,
    zeta: ArrayLike,
    period: float | None,
    loop: MarginLoop | None = None,
) -> PDMetrics:
    """The linear metrics of the PD at ``wn`` and ``zeta`` for the requirements' step (module docstring).

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    requirements : TuningRequirements
        The step and its band.
    wn : float or array_like (3,)
        Natural frequency, one or per body axis [rad/s].
    zeta : float or array_like (3,)
        Damping ratio, one or per body axis [-].
    period : float or None
        Control period [s] of the sampled loop whose disk margin is judged; None: the continuous loop.
    loop : MarginLoop, optional
        The plant and filters of the loop whose disk margin is judged (default: the rigid body, unfiltered).
    """
    wn = _per_axis_or_scalar(wn, "wn")
    zeta = _per_axis_or_scalar(zeta, "zeta")
    pd = _pd(body, wn, zeta, period)
    settling, torque, momentum = _step_metrics(body, pd, requirements, float(np.max(wn)))
    margins = (loop or MarginLoop()).margins(body, pd, sampled=period is not None)
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
        axes: tuple[int, ...] = (0, 1, 2),
        margin_roots: dict[tuple[Any, ...], tuple[float, float]] | None = None,
        loop: MarginLoop | None = None,
    ) -> None:
        self.body = body
        self.zeta_grid = zeta_grid
        self.axes = list(axes)  # the step axes this search judges (one for a per-axis tuning)
        self.margin_roots = {} if margin_roots is None else margin_roots  # shared by per-axis searches
        self.loop = loop or MarginLoop()
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
        t = _time_grid(system, self.req.settling_band, SEARCH_TIME_POINTS, wn=1.0)
        y = np.asarray(control.step_response(system, t).outputs)[:, 0]  # (3, time): theta, theta', theta''
        settling = _settling(y[0], t, self.req.settling_band)
        lever = np.linalg.norm(self.body.inertia, axis=0)[self.axes] * self.req.step_angle  # |J e_k| step_angle
        return settling, lever * float(np.max(np.abs(y[2]))), lever * float(np.max(np.abs(y[1])))

    def at(self, zeta: float) -> _AtDamping:
        zeta = float(zeta)
        if zeta in self.cache:
            return self.cache[zeta]
        req = self.req
        settling_1, torque_1, momentum_1 = self.unit(zeta)
        limits = {"torque_max": float(np.min(np.sqrt(req.torque_max[self.axes] / torque_1)))}
        if req.momentum_max is not None:
            limits["momentum_max"] = float(np.min(req.momentum_max[self.axes] / momentum_1))
        if math.isfinite(self.wn_cap):
            limits["sample_rate"] = self.wn_cap
        wn_high = min(limits.values())
        wn_needed = settling_1 / req.settling_time
        alpha_low = math.nan
        if req.disk_margin_min is not None:
            root, alpha_low = self.margin_root(zeta, wn_high)
            if root < wn_high:
                limits["disk_margin_min"] = root
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

    def margin_root(self, zeta: float, wn_high: float) -> tuple[float, float]:
        """The largest wn whose disk margin meets the floor (inf: all up to the top) and the margin as wn -> 0.

        The sampled loop's margin depends on ``zeta`` and ``wn T`` only, not on the axis (module docstring), so
        the root is found below the sample-rate cap once per damping and shared by the per-axis searches
        (``margin_roots``); the continuous loop's is found below ``wn_high``.
        """
        top = self.wn_cap if math.isfinite(self.wn_cap) else wn_high
        # With modes or filters each axis's loop differs: the root is the axes' own.
        key = (zeta, top) if self.loop.rigid else (zeta, top, tuple(self.axes))
        if key not in self.margin_roots:
            floor = self.req.disk_margin_min

            def excess(wn: float) -> float:
                alpha = _search_margin(self.body, wn, zeta, self.period, self.loop, self.axes)
                return (alpha if math.isfinite(alpha) else 0.0) - floor

            answer = (math.inf, math.nan)
            if excess(top) < 0.0:
                low = top * 1e-4
                alpha_low = excess(low) + floor
                if alpha_low < floor:
                    answer = (0.0, alpha_low)
                else:
                    root = scipy.optimize.brentq(excess, low, top, rtol=WN_RTOL)
                    answer = (root * (1.0 - 2.0 * WN_RTOL), alpha_low)
            self.margin_roots[key] = answer
        return self.margin_roots[key]

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
    """A tuned PD or LQR, or why none meets the requirements.

    Attributes
    ----------
    feasible : bool
        Whether the returned gains meet every requirement on the linear metrics.
    wn : float or ndarray (3,)
        The natural frequency, one or per body axis [rad/s] (of the fastest PD within the other requirements
        when infeasible; for an LQR, the per-axis equivalent its Bryson bounds were set from).
    zeta : float or ndarray (3,)
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
        faster with a larger margin (of the slowest axis for a per-axis tuning).
    structure : str
        The controller tuned (:data:`STRUCTURES`).
    lqr_bounds : dict of ndarray or None
        For an LQR: its Bryson bounds ``angle_max`` [rad], ``rate_max`` [rad/s], ``torque_max`` [N m] per axis
        (:func:`lqr_bounds`); None otherwise.
    lqr : LQRDesign or None
        For an LQR: the design at ``period`` on the linearised body (:func:`controllers.lqr.design_lqr`).
    loop_label : str
        The loop whose disk margin was judged, in words ("" for the rigid, unfiltered loop; :class:`MarginLoop`).
    """

    feasible: bool
    wn: float | NDArray[np.float64]
    zeta: float | NDArray[np.float64]
    metrics: PDMetrics
    cost: str
    binding: tuple[str, ...]
    message: str
    requirements: TuningRequirements
    period: float | None
    tradeoff: dict[str, NDArray[Any]]
    structure: str = "pd"
    lqr_bounds: dict[str, NDArray[np.float64]] | None = None
    lqr: Any = None
    loop_label: str = ""

    def summary(self) -> str:
        """One line: the gains and the verdict."""
        verdict = "meets every requirement" if self.feasible else "INFEASIBLE"
        name = {"pd": "PD", "pd_per_axis": "PD per axis", "lqr": "LQR (equivalent)"}[self.structure]
        return (
            f"{name} wn = {format_values(self.wn)} rad/s, zeta = {format_values(self.zeta)}: settling "
            f"{self.metrics.settling_time:.4g} s, disk margin {self.metrics.disk_margin:.4g}; {verdict} "
            f"(binding: {', '.join(self.binding) or 'none'})"
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
            alpha = _search_margin(search.body, wn, float(zeta), search.period, search.loop, search.axes)
            rows.append((zeta, wn, settling_1 / wn, alpha))
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


def _describe_limit(name: str, req: TuningRequirements, period: float | None, axes: list[int] | None = None) -> str:
    axes = [0, 1, 2] if axes is None else axes
    if name == "torque_max":
        return f"torque_max = {np.min(req.torque_max[axes]):.4g} N m (the step's peak torque, J wn^2 step_angle)"
    if name == "momentum_max":
        return f"momentum_max = {np.min(req.momentum_max[axes]):.4g} N m s (the step's peak momentum)"
    if name == "sample_rate":
        return f"wn at most a tenth of the sample rate 2 pi / {period:g} s"
    return f"disk_margin_min = {req.disk_margin_min:g}" + (
        f" at the {1.0 / period:g} Hz sample rate" if period is not None else ""
    )


def _check_inputs(
    body: Any, requirements: Any, cost: str, period: Any, tradeoff_points: Any, damping_bounds: Any, damping_points: Any
) -> tuple[float | None, int, float, float, int]:
    """The common checks of :func:`tune_pd` and :func:`tune_lqr`: the period, the counts and the damping bounds."""
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
    low, high = (float(v) for v in damping_bounds)
    if not (0.0 < low <= high and math.isfinite(high)):
        raise ValueError(
            f"damping_bounds must be 0 < low <= high, finite (low = high: that damping), got {damping_bounds!r}"
        )
    damping_points = int(damping_points)
    if damping_points < 3:
        raise ValueError(f"damping_points must be at least 3, got {damping_points}")
    return period, tradeoff_points, low, high, damping_points


def _check_not_contradictory(body: RigidBody, requirements: TuningRequirements) -> None:
    """Raise :class:`RequirementConflict` when the settling time is below the bang-bang step time."""
    fastest = minimum_step_time(body, requirements)
    if requirements.settling_time >= float(np.max(fastest)):
        return
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


@dataclass(frozen=True)
class _Tuned:
    """The search's answer for a set of step axes: one wn and zeta, or the closest PD when infeasible."""

    feasible: bool
    wn: float
    zeta: float
    point: _AtDamping
    binding: tuple[str, ...]  # filled for an infeasible answer; a feasible one's comes from its metrics
    message: str  # likewise
    search: _Search


def _tune_axes(search: _Search, low: float, high: float) -> _Tuned:
    """The best damping and frequency of one search, or the diagnosis of why none meets the requirements."""
    req, period = search.req, search.period
    zeta = search.best(lambda z: search.at(z).cost)
    point = search.at(zeta)
    if math.isfinite(point.cost):
        return _Tuned(True, point.wn, zeta, point, (), "", search)
    # The fastest PD within everything but the settling time shows what holds it back (a diagnosis: the
    # damping to DIAGNOSIS_TOLERANCE).
    zeta = search.best(search.fastest_within_others, tolerance=DIAGNOSIS_TOLERANCE)
    point = search.at(zeta)
    wn_max = min(point.limits.values())
    if wn_max <= 0.0:
        margins = [search.at(float(z)).alpha_low for z in search.zeta_grid]
        best_alpha = float(np.nanmax(margins))
        message = (
            f"disk_margin_min = {req.disk_margin_min:g} is out of reach: the largest disk margin of a "
            f"PD with zeta in [{low:g}, {high:g}] is {best_alpha:.4g} (continuous, 2 zeta / sqrt(1 + zeta^2)"
            + ("; sampling only lowers it)" if period is not None else ")")
        )
        return _Tuned(False, point.wn_needed, zeta, point, ("disk_margin_min",), message, search)
    limiting = sorted(
        (n for n, v in point.limits.items() if v <= wn_max * (1.0 + ACTIVE_FRACTION)),
        key=lambda n: point.limits[n],
    )
    message = (
        f"settling_time = {req.settling_time:g} s needs wn >= {point.wn_needed:.4g} rad/s at the "
        f"best damping zeta = {zeta:.4g}, but "
        + " and ".join(_describe_limit(n, req, period, search.axes) for n in limiting)
        + f" allow at most wn = {wn_max:.4g} rad/s: the fastest PD within them settles in "
        f"{search.fastest_within_others(zeta):.4g} s"
    )
    return _Tuned(False, wn_max, zeta, point, ("settling_time", *limiting), message, search)


#: The winner's disk margin, computed afresh (to 1e-6), may sit this far below the floor the search met with
#: margins to SEARCH_MARGIN_RTOL and the root kept 2 WN_RTOL below the crossing; further below, the search
#: was misled (a margin not monotonic in wn, the axes coupled) and the winner fails.
MARGIN_SLACK = 1e-3


def _margin_missed(metrics: PDMetrics, req: TuningRequirements) -> str:
    """ "" when the winner's own disk margin meets the floor (within MARGIN_SLACK), else what it misses by."""
    floor = req.disk_margin_min
    if floor is None or metrics.disk_margin >= floor * (1.0 - MARGIN_SLACK):
        return ""
    return (
        f"; but the winner's own smallest disk margin (per axis and multiloop) {metrics.disk_margin:.4g} is below "
        f"disk_margin_min = {floor:g}: infeasible"
    )


def _point_active(tuned: _Tuned) -> tuple[str, ...]:
    """The requirements within ACTIVE_FRACTION of binding at a feasible search answer (from its scaled metrics)."""
    point, wn = tuned.point, tuned.wn
    active = [n for n, v in point.limits.items() if v <= wn * (1.0 + ACTIVE_FRACTION)]
    if point.wn_needed >= wn * (1.0 - ACTIVE_FRACTION):
        active.insert(0, "settling_time")
    return tuple(active)


def _sweep(search: _Search, low: float, high: float, zeta: float, points: int) -> dict[str, NDArray[Any]]:
    # The sweep holds the result's damping too, so its front passes through the chosen point when the actuators bind.
    return _tradeoff(search, np.union1d(np.geomspace(low, high, points), [zeta])) if points else {}


def tune_pd(
    body: RigidBody,
    requirements: TuningRequirements,
    *,
    period: float | None,
    cost: str = "settling",
    per_axis: bool = False,
    loop: MarginLoop | None = None,
    damping_bounds: tuple[float, float] = DAMPING_BOUNDS,
    damping_points: int = DAMPING_GRID_POINTS,
    tradeoff_points: int = 10,
) -> TuningResult:
    """The PD (one ``wn`` and ``zeta`` for all axes, or one per axis) that meets the requirements at the least cost.

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
    per_axis : bool
        One ``wn`` and ``zeta`` per body axis (module docstring, Per axis): each axis as fast (or cheap) as its
        own torque and momentum allow, where one pair for all is held back by the weakest axis.
    loop : MarginLoop, optional
        The plant (flexible modes) and filters of the loop whose disk margin is judged, in the search and at
        the winner (module docstring, Modes and filters); default the rigid body, unfiltered.
    damping_bounds : tuple of float
        The dampings searched [-] (:data:`DAMPING_BOUNDS`); equal bounds fix the damping (only ``wn`` is tuned).
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
    period, tradeoff_points, low, high, damping_points = _check_inputs(
        body, requirements, cost, period, tradeoff_points, damping_bounds, damping_points
    )
    _check_not_contradictory(body, requirements)
    grid = np.geomspace(low, high, damping_points)
    loop = loop or MarginLoop()
    if per_axis:
        roots: dict[tuple[Any, ...], tuple[float, float]] = {}
        tuned = [
            _tune_axes(_Search(body, requirements, period, cost, grid, (k,), roots, loop), low, high) for k in range(3)
        ]
        return _combine_axes(body, requirements, period, cost, "pd_per_axis", tuned, low, high, tradeoff_points, loop)
    one = _tune_axes(_Search(body, requirements, period, cost, grid, loop=loop), low, high)
    metrics = pd_metrics(body, requirements, wn=one.wn, zeta=one.zeta, period=period, loop=loop)
    feasible = one.feasible
    if feasible:
        binding = _active(metrics, requirements, one.point, cost)
        message = f"wn = {one.wn:.6g} rad/s, zeta = {one.zeta:.6g} ({cost} minimised); binding: " + (
            ", ".join(_describe_limit(n, requirements, period) if n != "settling_time" else n for n in binding)
            or "none"
        )
        missed = _margin_missed(metrics, requirements)
        if missed:
            feasible, binding, message = False, (*binding, "disk_margin_min (winner)"), message + missed
    else:
        binding, message = one.binding, one.message
    tradeoff = _sweep(one.search, low, high, one.zeta, tradeoff_points)
    return TuningResult(
        feasible,
        one.wn,
        one.zeta,
        metrics,
        cost,
        binding,
        message,
        requirements,
        period,
        tradeoff,
        loop_label=loop.label,
    )


def _combine_axes(
    body: RigidBody,
    requirements: TuningRequirements,
    period: float | None,
    cost: str,
    structure: str,
    tuned: list[_Tuned],
    low: float,
    high: float,
    tradeoff_points: int,
    loop: MarginLoop,
) -> TuningResult:
    """One per-axis PD from three one-axis searches, its metrics computed on the coupled 3-axis loop."""
    wn = np.array([t.wn for t in tuned])
    zeta = np.array([t.zeta for t in tuned])
    metrics = pd_metrics(body, requirements, wn=wn, zeta=zeta, period=period, loop=loop)
    feasible = all(t.feasible for t in tuned)
    binding: list[str] = []
    parts = []
    for axis, t in zip(_AXES, tuned):
        names = _point_active(t) if t.feasible else t.binding
        binding += [f"{n} ({axis})" for n in names]
        parts.append(
            f"{axis}: wn = {t.wn:.6g} rad/s, zeta = {t.zeta:.6g}, binding " + (", ".join(names) or "none")
            if t.feasible
            else f"{axis}: {t.message}"
        )
    message = f"per axis ({cost} minimised): " + "; ".join(parts)
    missed = _margin_missed(metrics, requirements) if feasible else ""
    if missed:
        # Each axis met the floor alone; products of inertia (and modes) couple the axes of the 3-axis loop.
        feasible = False
        binding.append("disk_margin_min (3-axis loop)")
        message += missed + " (the products of inertia or the modes couple the axes)"
    # The trade-off of the slowest axis (the one that sets the settling time), or the first that fails.
    order = [t for t in tuned if not t.feasible] or sorted(tuned, key=lambda t: -t.point.wn_needed / t.wn)
    slowest = order[0]
    tradeoff = _sweep(slowest.search, low, high, slowest.zeta, tradeoff_points)
    return TuningResult(
        feasible,
        wn,
        zeta,
        metrics,
        cost,
        tuple(binding),
        message,
        requirements,
        period,
        tradeoff,
        structure,
        loop_label=loop.label,
    )


#: Dampings an LQR reaches on the rigid body at rest (module docstring, LQR): ``zeta >= 1 / sqrt(2)``, equal
#: only without a rate weight; the lower bound keeps the rate bound finite (``4 zeta^2 - 2 >= 0.016``).
LQR_DAMPING_BOUNDS = (0.71, 4.0)
#: The scales of the equivalent wn searched for the sampled LQR (its zero-order hold is not in the equivalent) ...
LQR_SCALE_RANGE = (0.5, 1.5)
#: ... by this many bisections (the scale to 1/128 of its bracket: under 0.4 % of wn, 0.8 % of the torque).
LQR_SCALE_BISECTIONS = 7


@dataclass(frozen=True)
class _StateGains:
    """``K`` on the error-quaternion vector part and ``C`` on the rate [N m, N m s] of a state feedback."""

    K: NDArray[np.float64]
    C: NDArray[np.float64]


def lqr_bounds(body: RigidBody, wn: ArrayLike, zeta: ArrayLike, angle_max: ArrayLike) -> dict[str, NDArray[np.float64]]:
    """Bryson bounds whose LQR on the body at rest places each axis at ``wn`` and ``zeta`` (module docstring, LQR).

    With the attitude bound ``angle_max`` kept, the torque bound is ``2 J wn^2 sin(angle_max / 2)`` (the PD's
    torque at that error) and the rate bound ``torque / (J wn sqrt(4 zeta^2 - 2))``, ``J`` the axis's moment.

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2] (its diagonal moments; exact for principal body axes).
    wn : float or array_like (3,)
        Natural frequency per axis [rad/s].
    zeta : float or array_like (3,)
        Damping ratio per axis [-], above ``1 / sqrt(2)`` (an LQR on a double integrator cannot go below).
    angle_max : float or array_like (3,)
        Bryson's attitude bound per axis [rad], in ``(0, pi]`` (kept as given).

    Returns
    -------
    dict of ndarray (3,)
        ``angle_max`` [rad], ``rate_max`` [rad/s], ``torque_max`` [N m]: the arguments of
        :func:`controllers.lqr.bryson_weights`.
    """
    wn = positive_per_axis(wn, "wn", "rad/s")
    zeta = positive_per_axis(zeta, "zeta")
    angle = positive_per_axis(angle_max, "angle_max", "rad")
    if np.any(angle > math.pi):
        raise ValueError(f"angle_max must not exceed pi rad, got {angle.tolist()}")
    if np.any(zeta <= 1.0 / math.sqrt(2.0)):
        raise ValueError(
            f"zeta must be above 1/sqrt(2) = 0.7071 for an LQR on the rigid body (zeta^2 = 1/2 + a rate weight "
            f"term), got {zeta.tolist()}"
        )
    inertia = np.diag(body.inertia)
    torque = 2.0 * inertia * wn**2 * np.sin(0.5 * angle)
    rate = torque / (inertia * wn * np.sqrt(4.0 * zeta**2 - 2.0))
    return {"angle_max": angle, "rate_max": rate, "torque_max": torque}


def lqr_metrics(
    body: RigidBody,
    requirements: TuningRequirements,
    design: LQRDesign,
    *,
    wn: ArrayLike = math.nan,
    zeta: ArrayLike = math.nan,
    loop: MarginLoop | None = None,
) -> PDMetrics:
    """The linear metrics of an LQR for the requirements' step: its gain on the body at rest, its sampled loop.

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    requirements : TuningRequirements
        The step and its band.
    design : LQRDesign
        The LQR on :func:`attitude.linearize.linearize` of the body (states ``[q_ev, omega]``).
    wn : float or array_like (3,)
        The equivalent natural frequency recorded in the metrics [rad/s] (not used to compute them).
    zeta : float or array_like (3,)
        The equivalent damping recorded in the metrics [-] (likewise).
    loop : MarginLoop, optional
        The plant and filters of the loop whose disk margin is judged (default: the linearised rigid body).
    """
    if not isinstance(design, LQRDesign) or np.shape(design.K) != (3, 6):
        raise ValueError(f"design must be an LQRDesign of the 6-state attitude model, got {design!r}")
    gain = np.asarray(design.K, dtype=float)
    settling, torque, momentum = _step_metrics(body, _StateGains(gain[:, :3], gain[:, 3:]), requirements)
    loop = loop or MarginLoop()
    plant = linearize(body) if loop.plant is None else loop.plant
    flown = design if loop.command_filter is None else loop.flown(LQRController(design))
    margins = loop_disk_margins(plant, flown, sampled=design.period is not None)
    return PDMetrics(wn, zeta, settling, torque, momentum, margins.smallest, design.period is not None)


def _misses(metrics: PDMetrics, req: TuningRequirements) -> list[str]:
    """The requirements the metrics miss (a relative 1e-9 for the rounding of a limit met exactly)."""
    slack = 1.0 + 1e-9
    missed = []
    if not metrics.settling_time <= req.settling_time * slack:
        missed.append("settling_time")
    if np.any(metrics.peak_torque > req.torque_max * slack):
        missed.append("torque_max")
    if req.momentum_max is not None and np.any(metrics.peak_momentum > req.momentum_max * slack):
        missed.append("momentum_max")
    if req.disk_margin_min is not None and not metrics.disk_margin * slack >= req.disk_margin_min:
        missed.append("disk_margin_min")
    return missed


def tune_lqr(
    body: RigidBody,
    requirements: TuningRequirements,
    *,
    period: float | None,
    angle_max: ArrayLike,
    cost: str = "settling",
    loop: MarginLoop | None = None,
    damping_bounds: tuple[float, float] = LQR_DAMPING_BOUNDS,
    damping_points: int = DAMPING_GRID_POINTS,
    tradeoff_points: int = 10,
) -> TuningResult:
    """The LQR weights (Bryson bounds per axis) that meet the requirements at the least cost (module docstring, LQR).

    Parameters
    ----------
    body : RigidBody
        The spacecraft [kg m^2].
    requirements : TuningRequirements
        What the LQR must meet.
    period : float or None
        Control period [s]: the design is discrete at it (:func:`controllers.lqr.design_lqr`) and its disk
        margin that of the sampled loop; None: continuous.
    angle_max : float or array_like (3,)
        Bryson's attitude bound per axis [rad], kept; the rate and torque bounds are tuned.
    cost : str
        ``"settling"`` or ``"effort"`` (:func:`tune_pd`).
    loop : MarginLoop, optional
        The plant and filters of the loop whose disk margin is judged (:func:`tune_pd`).
    damping_bounds : tuple of float
        The equivalent dampings searched [-], above ``1 / sqrt(2)`` (:data:`LQR_DAMPING_BOUNDS`).
    damping_points : int
        Dampings of the first grid (at least 3).
    tradeoff_points : int
        Dampings of the trade-off sweep of the equivalent PD (five frequencies each); 0: none.

    Returns
    -------
    TuningResult
        With ``structure = "lqr"``, ``lqr_bounds``, ``lqr`` and the metrics of that design.

    Raises
    ------
    RequirementConflict
        As :func:`tune_pd`.
    ValueError
        For a bad argument (a damping bound at or below ``1 / sqrt(2)`` among them).
    """
    period, tradeoff_points, low, high, damping_points = _check_inputs(
        body, requirements, cost, period, tradeoff_points, damping_bounds, damping_points
    )
    if low <= 1.0 / math.sqrt(2.0):
        raise ValueError(f"damping_bounds must lie above 1/sqrt(2) = 0.7071 for an LQR, got {damping_bounds!r}")
    angle = positive_per_axis(angle_max, "angle_max", "rad")
    _check_not_contradictory(body, requirements)
    grid = np.geomspace(low, high, damping_points)
    loop = loop or MarginLoop()
    roots: dict[tuple[Any, ...], tuple[float, float]] = {}
    tuned = [
        _tune_axes(_Search(body, requirements, period, cost, grid, (k,), roots, loop), low, high) for k in range(3)
    ]
    equivalent = _combine_axes(body, requirements, period, cost, "lqr", tuned, low, high, tradeoff_points, loop)
    plant = linearize(body)
    wn0, zeta = np.asarray(equivalent.wn, dtype=float), np.asarray(equivalent.zeta, dtype=float)
    cap = math.inf if period is None else SAMPLE_RATE_FRACTION * 2.0 * math.pi / period

    def evaluate(scale: float) -> tuple[dict[str, NDArray[np.float64]], LQRDesign, PDMetrics, list[str]]:
        bounds = lqr_bounds(body, wn0 * scale, zeta, angle)
        q_weight, r_weight = bryson_weights(**bounds)
        design = design_lqr(plant, Q=q_weight, R=r_weight, period=period)
        metrics = lqr_metrics(body, requirements, design, wn=wn0 * scale, zeta=zeta, loop=loop)
        return bounds, design, metrics, _misses(metrics, requirements)

    # The sampled LQR is not exactly its continuous equivalent: one scale on the three wn, the largest (settling)
    # or smallest (effort) whose design meets every requirement, by bisection within LQR_SCALE_RANGE.
    at_one = evaluate(1.0)
    scale = 1.0
    if equivalent.feasible:
        low, high = LQR_SCALE_RANGE[0], min(LQR_SCALE_RANGE[1], cap / float(np.max(wn0)))
        anchor = 1.0 if not at_one[3] else None
        if anchor is None:  # a passing scale on the side the misses point to (faster when only settling misses)
            side = np.geomspace(1.0, high if at_one[3] == ["settling_time"] else low, 5)[1:]
            anchor = next((float(v) for v in side if not evaluate(float(v))[3]), None)
        if anchor is not None:
            end = high if cost == "settling" else low
            good, bad = (end, end) if not evaluate(end)[3] else (anchor, end)
            for _ in range(LQR_SCALE_BISECTIONS if good != bad else 0):
                middle = 0.5 * (good + bad)
                good, bad = (middle, bad) if not evaluate(middle)[3] else (good, middle)
            scale = good
    bounds, design, metrics, missed = evaluate(scale) if scale != 1.0 else at_one
    feasible = equivalent.feasible and not missed
    message = equivalent.message
    binding = equivalent.binding
    if scale != 1.0:
        aim = "fastest" if cost == "settling" else "cheapest"
        message += f"; every wn scaled by {scale:.4g} for the {aim} sampled LQR within the requirements"
    if equivalent.feasible and missed:
        binding = (*binding, *(f"{m} (sampled LQR)" for m in missed))
        message += f"; the sampled LQR misses {', '.join(missed)} at every scale in {LQR_SCALE_RANGE}: infeasible"
    return replace(
        equivalent,
        feasible=feasible,
        wn=wn0 * scale,
        metrics=metrics,
        binding=tuple(binding),
        message="LQR " + message,
        lqr_bounds=bounds,
        lqr=design,
    )


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
            label=f"before: {_gains_label(result, before)}{note}",
        )
        y_high = max(y_high, 1.1 * before.settling_time) if math.isfinite(before.settling_time) else y_high
    ax.plot(
        m.disk_margin,
        m.settling_time,
        "*",
        ms=16,
        color="C2",
        mec="k",
        label=f"{'tuned' if result.feasible else 'closest (infeasible)'}: {_gains_label(result, m)}",
    )
    ax.set_xlim(x_low, x_high)
    ax.set_yscale("log")
    ax.set_ylim(0.3 * min(m.settling_time, req.settling_time), min(y_high, 20.0 * req.settling_time))
    loop = "sampled loop" if result.period else "continuous loop"
    if result.loop_label:
        loop += f", {result.loop_label}"
    ax.set_xlabel(f"disk margin alpha at the plant input [-] ({loop})")
    ax.set_ylabel(f"settling time into {100 * req.settling_band:.3g} % of the step [s]")
    title = {
        "pd": "PD tuning",
        "pd_per_axis": "PD per axis tuning\n(sweep: the slowest axis)",
        "lqr": "LQR tuning\n(sweep: the slowest axis's PD equivalent; the star: the sampled LQR)",
    }[result.structure]
    ax.set_title(
        title.replace("\n", ": settling time vs disk margin (shaded: fails a requirement)\n", 1)
        if "\n" in title
        else f"{title}: settling time vs disk margin (shaded: fails a requirement)",
        fontsize=10,
    )
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    return fig


def _gains_label(result: TuningResult, metrics: PDMetrics) -> str:
    """The gains of a point of the trade-off figure, in words."""
    if result.structure == "lqr":
        if np.all(np.isnan(np.asarray(metrics.wn, dtype=float))):
            return "the file's LQR bounds"
        return f"LQR, equivalent wn {format_values(metrics.wn, 3)} rad/s, zeta {format_values(metrics.zeta, 3)}"
    return f"wn {format_values(metrics.wn, 3)} rad/s, zeta {format_values(metrics.zeta, 3)}"


def confirm_nonlinear(
    body: RigidBody,
    requirements: TuningRequirements,
    *,
    wn: ArrayLike | None = None,
    zeta: ArrayLike | None = None,
    period: float,
    lqr: LQRDesign | None = None,
    wheels: Any = None,
    axis: ArrayLike = (1.0, 0.0, 0.0),
    hold_time: float | None = None,
    modes: Any = None,
    command_filter: Any = None,
) -> dict[str, Any]:
    """Fly the PD's (or the LQR's) step on the nonlinear plant and judge its settling time and pointing.

    :meth:`QuaternionPD.from_bandwidth` with gyroscopic compensation (or :class:`controllers.lqr.LQRController`
    of ``lqr``), the truth fed back, from rest at the identity to ``step_angle`` about ``axis``, through the
    wheels (their torque and momentum limits) when given.
    Judged with :class:`attitude.simulation.slew_windows.SlewWindows` (the slew ends at ``t = 0``: the step
    is the whole manoeuvre): ``settling_time`` is the time the error enters the pointing accuracy for good,
    ``pointing_error`` the largest error over the hold that follows the required settling time.

    Parameters
    ----------
    body : RigidBody
        The spacecraft (wheels included) [kg m^2].
    requirements : TuningRequirements
        The step, the accuracy and the settling time.
    wn : float or array_like (3,), optional
        Natural frequency, one or per axis [rad/s] (the PD; not with ``lqr``).
    zeta : float or array_like (3,), optional
        Damping ratio, one or per axis [-] (likewise).
    period : float
        Control period [s].
    lqr : LQRDesign, optional
        Fly this LQR (at its period, which must equal ``period``) instead of a PD.
    wheels : ReactionWheels, optional
        The actuators; None: the commanded torque acts on the body.
    axis : array_like (3,)
        Step axis in body axes (normalised).
    hold_time : float, optional
        The hold judged after the settling time [s]; default ``max(30 s, settling_time)``.
    modes : FlexibleModes, optional
        Fly the body with these appendage modes (:func:`attitude.simulation.flexible_flight.simulate_flexible`,
        hybrid coordinates, the modes at rest at the start) instead of the rigid body; its torque acts on the
        body directly (that simulation has no wheel model, so ``wheels`` must then be None).
    command_filter : callable, optional
        ``command_filter(law)`` returns the law as flown (the file's command filters); None: unfiltered.

    Returns
    -------
    dict
        ``settling_time_s``, ``pointing_error_rad``, ``peak_torque_Nm``, ``passed`` (both within the
        requirements), the flown ``duration_s`` and ``plant`` (what was flown, in words).
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
    if (lqr is None) == (wn is None or zeta is None):
        raise ValueError("give either wn and zeta (a PD) or lqr (an LQRDesign), not both or neither")
    if lqr is None:
        controller: Any = QuaternionPD.from_bandwidth(
            body, wn=wn, zeta=zeta, period=period, gyroscopic=True, q_ref=target
        )
    else:
        controller = LQRController(lqr, q_ref=target, period=period)
    if command_filter is not None:
        controller = command_filter(controller)
    if modes is not None:
        if wheels is not None:
            raise ValueError("wheels must be None with modes: the flexible simulation has no wheel model")
        from attitude.simulation.flexible_flight import simulate_flexible

        run = simulate_flexible(body, modes, quat.identity(), np.zeros(3), windows.hold_end_s, controller=controller)
        count = f"{modes.n_modes} mode" + ("s" if modes.n_modes > 1 else "")
        plant, torque = f"flexible ({count}), torque on the body", run.torque
    else:
        run = simulate(body, quat.identity(), np.zeros(3), windows.hold_end_s, controller=controller, wheels=wheels)
        plant = "rigid, through the wheels" if wheels is not None else "rigid, torque on the body"
        torque = run.torque_applied
    judged = windows.metrics(run.t, quat.error_angle(target, run.q))
    settling = float(judged["slew_time"])
    pointing = float(judged["pointing_error_hold"])
    return {
        "settling_time_s": settling,
        "pointing_error_rad": pointing,
        "peak_torque_Nm": float(np.max(np.linalg.norm(torque, axis=-1))),
        "duration_s": float(run.t[-1]),
        "passed": bool(settling <= requirements.settling_time and pointing <= requirements.pointing_accuracy),
        "plant": plant,
    }

"""The worst case of an attitude loop over an uncertainty set, found by optimisation and checked by sampling.

An :class:`UncertaintySet` bounds what is not known about the spacecraft:

* each principal moment of inertia within ``+-inertia_percent`` of its value;
* the principal axes turned by a rotation vector of norm at most ``axis_rotation_deg``;
* each wheel's spin axis tilted by at most ``wheel_misalignment_deg``: the controller allocates its
  command with the nominal axes (``u = -A^+ tau_cmd``, :class:`attitude.actuators.ReactionWheels`), the
  wheels push along the true ones, so the body receives ``A_true A^+ tau_cmd`` (a torque map near the
  identity at the plant input);
* an extra delay in ``[0, extra_delay_s]`` between the controller's sample and the torque.

:func:`worst_case_disk_margin` finds the smallest multiloop disk margin at the plant input
(:func:`controllers.disk_margins.disk_margins` on :func:`controllers.analysis.input_loop`, the sampled loop
that flies for a controller with a period, the extra delay as its computation delay) over the set;
:func:`worst_case_step` the largest overshoot or settling time of the linear closed loop. An unstable
closed loop counts as disk margin 0 (an infinite overshoot) and is reported unstable, never as a margin.

Both share one search (:func:`_search`), which never trusts one method alone:

1. the nominal plant and the corners of the box of the scalar uncertainties (the moments and the delay;
   the rotations at zero) are evaluated, and the best ``local_starts`` of them start bounded local searches
   over every parameter (:func:`scipy.optimize.minimize`, L-BFGS-B with finite differences of
   :data:`LOCAL_STEP` of each range, on the unit box);
2. :func:`scipy.optimize.differential_evolution` searches the whole box globally (``maxiter``,
   ``popsize``), and its best point is polished by the same local search;
3. ``samples`` points drawn uniformly over the same set (:func:`attitude.rng.as_generator`) give the Monte
   Carlo answer. The optimiser's worst must be at least as bad as the sampled worst: when it is not, a
   warning says the optimiser missed (raise the budget).

A rotation vector and a wheel's tilt are points of a ball (a disk): the optimisers search the enclosing
box and a point outside the ball is pulled radially onto its surface, so every point searched is in the
set; the samples are uniform over the balls themselves. The ``[uncertainty]`` table of a spacecraft file
describes the set (``attitude.app.assembly.uncertainty_set``); it is sampled uniformly here, unlike the
normal dispersions of ``[montecarlo]``.

Speed: a multiloop disk margin of the 3-axis sampled loop takes about 0.1 s on its default grid (400
frequencies, each a structured singular value bound by slycot). The search evaluates on a grid of
:data:`SEARCH_GRID_POINTS` frequencies over :data:`SEARCH_GRID_DECADES` decades each side of the nominal
worst frequency (refined, and extended where the minimum sits at an end, by ``disk_margins``: about 100
frequencies where the full grid takes 160 to 520);
the two answers reported (the optimiser's and the sampled worst) are evaluated again on the full grid, and
a warning says when the search grid had missed that plant's smallest margin.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import control
import numpy as np
import scipy.optimize
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.linearize import flexible_plant
from attitude.rigid_body import RigidBody
from attitude.rng import as_generator
from attitude.validation import as_float_array
from controllers.analysis import (
    closed_loop_poles,
    controller_period,
    delayed_loop,
    input_loop,
    rigid_body_at_rest,
    sampled_loop,
)
from controllers.disk_margins import DiskMargins, disk_margins

__all__ = [
    "DEFAULT_LOCAL_MAXFEV",
    "DEFAULT_LOCAL_STARTS",
    "DEFAULT_MAXITER",
    "DEFAULT_POPSIZE",
    "DEFAULT_SAMPLES",
    "LOCAL_STEP",
    "SEARCH_GRID_DECADES",
    "SEARCH_GRID_POINTS",
    "SEARCH_RTOL",
    "STEP_METRICS",
    "PerturbedPlant",
    "UncertaintySet",
    "WorstCase",
    "perturbed_plant",
    "worst_case_disk_margin",
    "worst_case_step",
]

#: The search's default budget. Differential evolution evaluates about ``(maxiter + 1) popsize k`` plants
#: for ``k`` parameters (15 for the default spacecraft with every uncertainty: 3 moments, 3 rotations, 2
#: tilts per wheel of a pyramid, 1 delay), each local search at most ``local_maxfev`` (about three
#: finite-difference gradients in 15 parameters: the local searches from the corners find most of the worst
#: case, measured; the global stage guards against a worst case away from them). About 360 plants in all on
#: the default spacecraft (benchmarks/bench_robust.py gives the time).
DEFAULT_MAXITER = 2
DEFAULT_POPSIZE = 2
DEFAULT_LOCAL_STARTS = 2
DEFAULT_LOCAL_MAXFEV = 50
#: Monte Carlo samples of the set, uniform (the comparison the optimiser must beat).
DEFAULT_SAMPLES = 64
#: The search's frequency grid: points, and decades each side of the nominal loop's worst frequency; and the
#: refinement's stopping tolerance there. It compares successive refinements, so one refinement (60 points
#: about 1 % apart) passes it: measured on the default spacecraft's perturbed loops, the search's margins agree
#: with the full grid's to 2e-6 relative, at 100 frequencies instead of 160 to 520.
SEARCH_GRID_POINTS = 40
SEARCH_GRID_DECADES = 1.0
SEARCH_RTOL = 1e-2
#: Finite-difference step of the local searches, as a fraction of each parameter's range: far above the
#: margins' 1e-6 refinement noise, small beside the range.
LOCAL_STEP = 1e-3
#: Relative disagreement between a plant's margin on the search grid and on the full grid beyond which a
#: warning says the search grid missed its smallest margin (both are refined to 1e-6 relative).
GRID_AGREEMENT = 1e-3
#: The step metrics :func:`worst_case_step` maximises: name -> (result quantity, unit).
STEP_METRICS = {"overshoot": ("overshoot_percent", "%"), "settling_time": ("settling_time_s", "s")}
#: What an unstable closed loop costs a minimised step objective (its metric is reported as infinite): any
#: finite number larger than a stable loop's overshoot [%] or settling time [s] ranks it worst.
_UNSTABLE_STEP = 1e12

_AXES = "xyz"


# ---------------------------------------------------------------------------
# The set


@dataclass(frozen=True)
class UncertaintySet:
    """What is not known about the spacecraft, as bounds (module docstring).

    Parameters
    ----------
    inertia_percent : float
        Each principal moment within ``+-`` this percentage of its value [%], in ``[0, 100)``.
    axis_rotation_deg : float
        The principal axes turned by a rotation vector of norm at most this [deg], in ``[0, 180]``.
    wheel_misalignment_deg : float
        Each wheel's spin axis tilted by at most this [deg], in ``[0, 90)``.
    extra_delay_s : float
        Extra delay from the sample to the torque, anywhere in ``[0, extra_delay_s]`` [s] (>= 0).

    Raises
    ------
    ValueError
        For a bound that is not a finite number in its range (named, with the rule and the value).
    """

    inertia_percent: float = 0.0
    axis_rotation_deg: float = 0.0
    wheel_misalignment_deg: float = 0.0
    extra_delay_s: float = 0.0

    def __post_init__(self) -> None:
        rules = {
            "inertia_percent": (100.0, False, "below 100 % (the moments must stay positive)"),
            "axis_rotation_deg": (180.0, True, "at most 180 deg"),
            "wheel_misalignment_deg": (90.0, False, "below 90 deg (a wheel tilted 90 deg gives no torque on its axis)"),
            "extra_delay_s": (math.inf, False, "finite"),
        }
        for name, (high, closed, rule) in rules.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ValueError(f"{name} must be a finite number, got {value!r}")
            if value < 0:
                raise ValueError(f"{name} must be non-negative (>= 0), got {value!r}")
            if value > high or (value == high and not closed):
                raise ValueError(f"{name} must be {rule}, got {value!r}")
            object.__setattr__(self, name, float(value))

    @property
    def empty(self) -> bool:
        """Whether every bound is zero (the set holds the nominal plant alone)."""
        return not (self.inertia_percent or self.axis_rotation_deg or self.wheel_misalignment_deg or self.extra_delay_s)

    def parameter_names(self, n_wheels: int = 0) -> tuple[str, ...]:
        """Names of the parameter vector's entries, SI (the bounds of :meth:`bounds`, in order).

        ``inertia_1..3``: relative change of the principal moments ``I1 <= I2 <= I3`` [-];
        ``axis_rotation_x..z``: rotation vector of the principal axes, body components [rad];
        ``wheel_<i>_tilt_a``, ``_b``: tilt of wheel ``i``'s axis along two directions normal to it [rad];
        ``extra_delay``: [s]. A bound of zero leaves its entries out.

        Parameters
        ----------
        n_wheels : int
            Wheels whose misalignment is counted (0: none, the wheel bound ignored).
        """
        return tuple(name for name, _, _ in self._layout(n_wheels))

    def bounds(self, n_wheels: int = 0) -> NDArray[np.float64]:
        """Lower and upper bound of each parameter (:meth:`parameter_names`), SI, shape ``(k, 2)``.

        Parameters
        ----------
        n_wheels : int
            Wheels whose misalignment is counted.
        """
        layout = self._layout(n_wheels)
        return np.array([[lo, hi] for _, lo, hi in layout], dtype=float).reshape(len(layout), 2)

    def check_body(self, body: RigidBody) -> None:
        """Refuse a set whose corners leave no physical body (a moment above the sum of the other two).

        The principal moments at every corner of ``+-inertia_percent`` are checked by
        :class:`~attitude.rigid_body.RigidBody` (the home of the rule); the rotation does not change them.

        Parameters
        ----------
        body : RigidBody
            The nominal body.

        Raises
        ------
        ValueError
            Naming ``inertia_percent``, the corner and the moments.
        """
        moments = _single_body(body).principal_axes().moments
        p = self.inertia_percent / 100.0
        for signs in itertools.product((-1.0, 1.0), repeat=3):
            corner = moments * (1.0 + p * np.array(signs))
            try:
                RigidBody(corner)
            except ValueError as exc:
                raise ValueError(
                    f"inertia_percent = {self.inertia_percent:g} leaves no physical body at the corner "
                    f"{[f'{s * self.inertia_percent:+g} %' for s in signs]} of the principal moments "
                    f"{moments.tolist()} kg m^2: {exc}"
                ) from exc

    def summary(self) -> str:
        """One line: the bounds."""
        return (
            f"moments +-{self.inertia_percent:g} %, principal axes turned up to {self.axis_rotation_deg:g} deg, "
            f"wheel axes tilted up to {self.wheel_misalignment_deg:g} deg, extra delay up to {self.extra_delay_s:g} s"
        )

    def _layout(self, n_wheels: int) -> list[tuple[str, float, float]]:
        if isinstance(n_wheels, bool) or not isinstance(n_wheels, (int, np.integer)) or n_wheels < 0:
            raise ValueError(f"n_wheels must be a non-negative integer, got {n_wheels!r}")
        out: list[tuple[str, float, float]] = []
        p = self.inertia_percent / 100.0
        if p:
            out += [(f"inertia_{i}", -p, p) for i in (1, 2, 3)]
        a = math.radians(self.axis_rotation_deg)
        if a:
            out += [(f"axis_rotation_{c}", -a, a) for c in _AXES]
        tilt = math.radians(self.wheel_misalignment_deg)
        if tilt:
            for i in range(int(n_wheels)):
                out += [(f"wheel_{i}_tilt_a", -tilt, tilt), (f"wheel_{i}_tilt_b", -tilt, tilt)]
        if self.extra_delay_s:
            out.append(("extra_delay", 0.0, self.extra_delay_s))
        return out


def _single_body(body: Any) -> RigidBody:
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single RigidBody, got {body!r}")
    return body


def _clip_to_ball(v: NDArray[np.float64], radius: float) -> NDArray[np.float64]:
    """``v`` pulled radially onto the ball of ``radius`` when outside it."""
    norm = float(np.linalg.norm(v))
    return v * (radius / norm) if norm > radius else v


def _normal_basis(axis: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit vectors normal to ``axis`` and to each other (the tilt directions a and b)."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e_a = np.cross(axis, helper)
    e_a /= np.linalg.norm(e_a)
    return e_a, np.cross(axis, e_a)


# ---------------------------------------------------------------------------
# One plant of the set


@dataclass(frozen=True)
class PerturbedPlant:
    """One spacecraft of an uncertainty set: its body, the torque the wheels really give, its extra delay.

    Attributes
    ----------
    body : RigidBody
        The perturbed inertia [kg m^2].
    moment_change : ndarray (3,)
        Relative change of the principal moments ``I1 <= I2 <= I3`` of the nominal body [-].
    axis_rotation : ndarray (3,)
        Rotation vector turning the nominal principal axes, body components [rad].
    wheel_axes_B : ndarray (n, 3) or None
        The tilted spin axes (None: no wheels given).
    torque_map : ndarray (3, 3)
        Body torque per commanded torque, ``A_true A_nominal^+`` (the identity without misalignment) [-].
    extra_delay_s : float
        Extra delay [s].
    parameters : ndarray (k,)
        The parameter vector it was made from (:meth:`UncertaintySet.parameter_names`), SI.
    modes : FlexibleModes or None
        The appendages' constrained modes (None: a rigid spacecraft); the same on every plant of the set.
    """

    body: RigidBody
    moment_change: NDArray[np.float64]
    axis_rotation: NDArray[np.float64]
    wheel_axes_B: NDArray[np.float64] | None
    torque_map: NDArray[np.float64]
    extra_delay_s: float
    parameters: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    modes: Any = None

    def system(self) -> control.StateSpace:
        """The linearised plant at rest: commanded torque in, ``[q_v, omega]`` out (continuous).

        :func:`controllers.analysis.rigid_body_at_rest` of :attr:`body` (or, with :attr:`modes`,
        :func:`attitude.linearize.flexible_plant` of it: the appendages' modes on the perturbed body) with
        :attr:`torque_map` at its input; the delay is not in it (the loops add it).
        """
        plant = rigid_body_at_rest(self.body) if self.modes is None else flexible_plant(self.body, self.modes)
        return control.ss(plant.A, plant.B @ self.torque_map, plant.C, plant.D)

    def to_dict(self) -> dict[str, Any]:
        """The plant in review units, JSON-ready (the worst plant of a report)."""
        principal = self.body.principal_axes()
        out: dict[str, Any] = {
            "inertia_kg_m2": np.asarray(self.body.inertia).tolist(),
            "principal_moments_kg_m2": principal.moments.tolist(),
            "moment_change_percent": (100.0 * self.moment_change).tolist(),
            "axis_rotation_deg": np.degrees(self.axis_rotation).tolist(),
            "axis_rotation_angle_deg": float(np.degrees(np.linalg.norm(self.axis_rotation))),
            "extra_delay_s": self.extra_delay_s,
        }
        if self.wheel_axes_B is not None:
            out["wheel_axes_B"] = self.wheel_axes_B.tolist()
            out["torque_map"] = self.torque_map.tolist()
        return out

    def summary(self) -> str:
        """One line: the moments' changes, the axes' turn, the largest wheel tilt, the delay."""
        text = (
            "moments " + ", ".join(f"{100 * c:+.3g} %" for c in self.moment_change)
            + f"; axes turned {np.degrees(np.linalg.norm(self.axis_rotation)):.3g} deg"
        )  # fmt: skip
        if self.wheel_axes_B is not None:
            text += f"; torque map off identity by {np.linalg.norm(self.torque_map - np.eye(3), 2):.3g}"
        return text + f"; extra delay {self.extra_delay_s:.4g} s"


def perturbed_plant(
    body: RigidBody,
    uncertainty: UncertaintySet,
    parameters: ArrayLike,
    *,
    wheels: ReactionWheels | None = None,
    modes: Any = None,
) -> PerturbedPlant:
    """The plant of ``uncertainty`` at a parameter vector.

    ``J = R V diag(I (1 + dI)) V^T R^T`` with ``V`` the nominal principal axes (columns), ``I`` the
    principal moments, ``dI`` the relative changes and ``R`` the rotation of ``axis_rotation``; wheel ``i``'s
    axis tilted by its tilt vector ``t = t_a e_a + t_b e_b`` (normal to it): ``cos|t| a + sin|t| t/|t|``.
    A rotation vector or tilt beyond its bound is pulled radially onto it (module docstring).

    Parameters
    ----------
    body : RigidBody
        The nominal body.
    uncertainty : UncertaintySet
        The set.
    parameters : array_like (k,)
        In the order of ``uncertainty.parameter_names(n_wheels)``, SI.
    wheels : ReactionWheels, optional
        The nominal wheels (needed for the misalignment; without them it is not counted).
    modes : FlexibleModes, optional
        The appendages' modes, kept on the perturbed body (:attr:`PerturbedPlant.modes`).

    Returns
    -------
    PerturbedPlant

    Raises
    ------
    ValueError
        For a parameter vector of the wrong length or outside the bounds, or a body that is not physical.
    """
    body = _single_body(body)
    if not isinstance(uncertainty, UncertaintySet):
        raise ValueError(f"uncertainty must be an UncertaintySet, got {uncertainty!r}")
    if wheels is not None and not isinstance(wheels, ReactionWheels):
        raise ValueError(f"wheels must be ReactionWheels or None, got {wheels!r}")
    n_wheels = 0 if wheels is None else wheels.n_wheels
    names = uncertainty.parameter_names(n_wheels)
    bounds = uncertainty.bounds(n_wheels)
    x = np.atleast_1d(as_float_array(parameters, "parameters")).astype(float)
    if x.shape != (len(names),):
        raise ValueError(
            f"parameters must hold {len(names)} values ({', '.join(names) or 'none'}), got shape {x.shape}"
        )
    slack = 1e-12 * np.maximum(1.0, np.abs(bounds).max(axis=1))
    outside = (x < bounds[:, 0] - slack) | (x > bounds[:, 1] + slack)
    if np.any(outside):
        i = int(np.argmax(outside))
        raise ValueError(f"parameters[{i}] ({names[i]}) must be in [{bounds[i, 0]:g}, {bounds[i, 1]:g}], got {x[i]!r}")
    values = dict(zip(names, np.clip(x, bounds[:, 0], bounds[:, 1])))
    change = np.array([values.get(f"inertia_{i}", 0.0) for i in (1, 2, 3)])
    rotation = _clip_to_ball(
        np.array([values.get(f"axis_rotation_{c}", 0.0) for c in _AXES]), math.radians(uncertainty.axis_rotation_deg)
    )
    principal = body.principal_axes()
    axes = principal.axes_B @ np.diag(principal.moments * (1.0 + change)) @ principal.axes_B.T
    turn = quat.to_dcm(quat.from_rotation_vector(rotation)).T if np.any(rotation) else np.eye(3)
    # to_dcm gives C_BN (N components to B); its transpose rotates a vector by the rotation vector.
    inertia = turn @ axes @ turn.T
    torque_map = np.eye(3)
    wheel_axes = None
    if wheels is not None:
        limit = math.radians(uncertainty.wheel_misalignment_deg)
        wheel_axes = wheels.axes_B.copy()
        for i, a in enumerate(wheels.axes_B):
            tilt = _clip_to_ball(
                np.array([values.get(f"wheel_{i}_tilt_a", 0.0), values.get(f"wheel_{i}_tilt_b", 0.0)]), limit
            )
            angle = float(np.linalg.norm(tilt))
            if angle > 0.0:
                e_a, e_b = _normal_basis(a)
                wheel_axes[i] = math.cos(angle) * a + math.sin(angle) * (tilt[0] * e_a + tilt[1] * e_b) / angle
        torque_map = wheel_axes.T @ wheels.allocation
    return PerturbedPlant(
        body=RigidBody(0.5 * (inertia + inertia.T)),
        moment_change=change,
        axis_rotation=rotation,
        wheel_axes_B=wheel_axes,
        torque_map=torque_map,
        extra_delay_s=float(values.get("extra_delay", 0.0)),
        parameters=x,
        modes=modes,
    )


# ---------------------------------------------------------------------------
# The loops of one plant


def _loop_plant(
    plant: PerturbedPlant, controller: Any, sampled: bool | None, computation_delay: float
) -> tuple[Any, bool, float]:
    """The plant a loop function takes, whether the loop is sampled, and the delay it takes as its own.

    A sampled loop takes the whole delay (nominal plus extra) as its computation delay (exact, modified
    z-transform); a continuous one gets it as a Pade approximant on every input (:func:`delayed_loop`).
    """
    period = controller_period(controller)
    is_sampled = period is not None if sampled is None else bool(sampled)
    delay = computation_delay + plant.extra_delay_s
    system = plant.system()
    if is_sampled or delay == 0.0:
        return system, is_sampled, delay
    pade = control.ss(delayed_loop(control.tf([1.0], [1.0]), delay=delay))
    return control.series(control.append(*(pade for _ in range(system.ninputs))), system), False, 0.0


def _margin_of(
    plant: PerturbedPlant, controller: Any, sampled: bool | None, computation_delay: float, omega: Any
) -> DiskMargins:
    """The multiloop disk margin at the plant input: on the search grid (``omega``), or the full one (None)."""
    system, is_sampled, delay = _loop_plant(plant, controller, sampled, computation_delay)
    loop = input_loop(system, controller, sampled=is_sampled, computation_delay=delay)
    return disk_margins(loop, omega=omega) if omega is None else disk_margins(loop, omega=omega, rtol=SEARCH_RTOL)


def _step_metric(
    plant: PerturbedPlant,
    controller: Any,
    sampled: bool | None,
    computation_delay: float,
    metric: str,
    duration: float,
) -> float:
    """The largest overshoot [%] or 2 % settling time [s] over the axes' steps; inf when unstable."""
    system, is_sampled, delay = _loop_plant(plant, controller, sampled, computation_delay)
    poles = closed_loop_poles(system, controller, sampled=is_sampled, computation_delay=delay)
    stable = np.all(np.abs(poles) < 1.0) if is_sampled else np.all(poles.real < 0.0)
    if not stable:
        return math.inf
    closed, times = _reference_loop(system, controller, is_sampled, delay, duration)
    worst = 0.0
    final = np.atleast_2d(control.dcgain(closed))  # the steady state, not the response's last sample
    for j in range(3):
        response = control.step_response(closed, times, input_indices=[j], output_indices=[j])
        y, y_final = np.ravel(response.outputs), float(final[j, j])
        if abs(y[-1] - y_final) > 0.02 * abs(y_final):
            # Still outside the 2 % band at the end of the response: its settling time is only known to be longer
            # (and python-control's step_info fails on a response that has not yet risen).
            warnings.warn(
                f"a plant of the set has not settled within duration_s = {duration:.6g} s (axis {j}): its "
                f"{metric.replace('_', ' ')}, and so the worst one, is a lower bound; give a longer duration_s",
                RuntimeWarning,
                stacklevel=2,
            )
            value = duration if metric == "settling_time" else max(0.0, 100.0 * (y.max() - y_final) / y_final)
        else:
            info = control.step_info(y, response.time, yfinal=y_final, SettlingTimeThreshold=0.02)
            value = float(info["Overshoot" if metric == "overshoot" else "SettlingTime"])
        worst = max(worst, value)
    return worst


def _reference_loop(
    system: Any, controller: Any, is_sampled: bool, delay: float, duration: float
) -> tuple[control.StateSpace, NDArray[np.float64]]:
    """Reference angle to attitude angle, per axis: ``tau = -K (q_v - theta_ref / 2) - C omega`` closed.

    The reference enters at the controller's output as ``K theta_ref / 2`` and ``theta = 2 q_v``, so the loop
    from ``theta_ref`` to ``theta`` is ``[feedback(P, [K C])]_qv K`` (as
    :func:`controllers.analysis.attitude_closed_loop`, with the plant's torque map, hold and delay).
    """
    if not (hasattr(controller, "K") and hasattr(controller, "C")):
        raise ValueError(f"controller must have gain matrices K and C (3, 3) for a step response, got {controller!r}")
    K = np.asarray(controller.K, dtype=float)
    gain = np.hstack([K, np.asarray(controller.C, dtype=float)])
    if is_sampled:
        period = float(controller_period(controller))
        plant = sampled_loop(system, period=period, computation_delay=delay)
        closed = control.feedback(plant, control.ss([], [], [], gain, period))
        times = np.arange(0.0, duration + 0.5 * period, period)
    else:
        closed = control.feedback(system, control.ss([], [], [], gain))
        times = np.linspace(0.0, duration, 1001)
    qv = control.ss(closed.A, closed.B @ K, closed.C[:3], closed.D[:3] @ K, closed.dt)
    return qv, times


# ---------------------------------------------------------------------------
# The search (one driver for every quantity)


class _BudgetSpent(Exception):
    """A local search has used its evaluations."""


@dataclass
class _Search:
    best_x: NDArray[np.float64]
    best_f: float
    nominal_f: float
    sample_x: NDArray[np.float64]
    sample_f: NDArray[np.float64]
    evaluations: int


def _search(
    objective: Callable[[NDArray[np.float64]], float],
    bounds: NDArray[np.float64],
    names: tuple[str, ...],
    sample: Callable[[np.random.Generator, int], NDArray[np.float64]],
    *,
    samples: int,
    maxiter: int,
    popsize: int,
    local_starts: int,
    local_maxfev: int,
    rng: np.random.Generator,
) -> _Search:
    """Minimise ``objective`` over the box ``bounds``: corners and local searches, differential evolution and
    its polish (module docstring); and the same objective at ``samples`` uniform points of the set."""
    # The optimisers work on the unit box (one finite-difference step fits every parameter); every plant
    # evaluated counts, whichever stage asked for it.
    low, width = bounds[:, 0], bounds[:, 1] - bounds[:, 0]
    seen: dict[bytes, float] = {}
    k = len(names)
    best: list[Any] = [np.zeros(k), math.inf]

    def f(x: NDArray[np.float64]) -> float:
        x = np.clip(np.asarray(x, dtype=float), bounds[:, 0], bounds[:, 1])
        key = x.tobytes()
        if key not in seen:
            seen[key] = float(objective(x))
            if seen[key] < best[1]:
                best[:] = [x, seen[key]]
        return seen[key]

    def f_unit(u: NDArray[np.float64]) -> float:
        return f(low + np.clip(u, 0.0, 1.0) * width)

    def local(x0: NDArray[np.float64]) -> None:
        # L-BFGS-B's own maxfun leaves out its finite-difference evaluations: the budget is kept here.
        calls = [0]

        def counted(u: NDArray[np.float64]) -> float:
            calls[0] += 1
            if calls[0] > local_maxfev:
                raise _BudgetSpent
            return f_unit(u)

        try:
            scipy.optimize.minimize(
                counted, (x0 - low) / width, method="L-BFGS-B", bounds=[(0.0, 1.0)] * k, options={"eps": LOCAL_STEP}
            )
        except _BudgetSpent:
            pass  # every point it evaluated is already in ``best``

    nominal_f = f(np.zeros(k))
    if k:
        # Corners of the scalar uncertainties (moments, delay), the rotations and tilts at zero.
        scalar = [i for i, n in enumerate(names) if n.startswith("inertia_") or n == "extra_delay"]
        starts = [np.zeros(k)]
        for choice in itertools.product((0, 1), repeat=len(scalar)):
            x = np.zeros(k)
            x[scalar] = bounds[scalar, list(choice)]
            starts.append(x)
        starts.sort(key=f)
        for x0 in starts[:local_starts]:
            local(x0)
        scipy.optimize.differential_evolution(
            f_unit, [(0.0, 1.0)] * k, maxiter=maxiter, popsize=popsize, polish=False, seed=rng, init="latinhypercube"
        )
        local(best[0])
    points = sample(rng, samples)
    values = np.array([f(x) for x in points]) if k else np.full(samples, nominal_f)
    return _Search(best[0], best[1], nominal_f, points, values, len(seen))


def _uniform_sampler(
    uncertainty: UncertaintySet, names: tuple[str, ...], bounds: NDArray[np.float64]
) -> Callable[[np.random.Generator, int], NDArray[np.float64]]:
    """Uniform points of the set: boxes for the moments and the delay, balls for the rotation and each tilt."""
    groups: list[tuple[list[int], float]] = []
    rotation = [i for i, n in enumerate(names) if n.startswith("axis_rotation_")]
    if rotation:
        groups.append((rotation, math.radians(uncertainty.axis_rotation_deg)))
    wheels = sorted({n.split("_tilt_")[0] for n in names if "_tilt_" in n})
    for wheel in wheels:
        groups.append(([names.index(f"{wheel}_tilt_a"), names.index(f"{wheel}_tilt_b")], 0.0))
    tilt = math.radians(uncertainty.wheel_misalignment_deg)

    def sample(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
        x = rng.uniform(bounds[:, 0], bounds[:, 1], size=(n, len(names)))
        for indices, radius in groups:
            radius = radius or tilt
            d = len(indices)
            direction = rng.standard_normal((n, d))
            direction /= np.linalg.norm(direction, axis=1, keepdims=True)
            x[:, indices] = direction * (radius * rng.uniform(size=(n, 1)) ** (1.0 / d))
        return x

    return sample


def _budget_record(budget: tuple[int, int, int, int, int], seed: Any) -> dict[str, Any]:
    """The budget as the result records it (a generator given as the seed is named, not stored)."""
    names = ("samples", "maxiter", "popsize", "local_starts", "local_maxfev")
    return {**dict(zip(names, budget)), "seed": seed if isinstance(seed, (int, type(None))) else repr(seed)}


def _check_budget(samples: int, maxiter: int, popsize: int, local_starts: int, local_maxfev: int) -> None:
    for name, value, low in (
        ("samples", samples, 1),
        ("maxiter", maxiter, 1),
        ("popsize", popsize, 1),
        ("local_starts", local_starts, 0),
        ("local_maxfev", local_maxfev, 1),
    ):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")


# ---------------------------------------------------------------------------
# Results


@dataclass(frozen=True)
class WorstCase:
    """The worst case of one quantity over an uncertainty set, and what sampling the set found.

    Attributes
    ----------
    quantity : str
        ``"disk_margin"`` [-] (worse is lower), ``"overshoot_percent"`` [%] or ``"settling_time_s"`` [s]
        (worse is higher).
    worst : float
        The optimiser's worst value (0 margin, infinite step metric, when its closed loop is unstable).
    worst_unstable : bool
        Whether the worst plant's closed loop is unstable.
    worst_plant : PerturbedPlant
        The worst plant found.
    nominal : float
        The value of the nominal plant.
    sampled_worst : float
        The worst value over ``samples`` uniform samples of the same set (the Monte Carlo answer).
    sampled_worst_plant : PerturbedPlant
        The sample that gave it.
    sampled_values : ndarray (samples,)
        Every sample's value (on the search's frequency grid for a margin).
    evaluations : int
        Plants evaluated (search and samples).
    seconds : float
        Wall-clock time of the whole search [s].
    uncertainty : UncertaintySet
        The set.
    budget : dict
        ``samples``, ``maxiter``, ``popsize``, ``local_starts``, ``local_maxfev``, ``seed``.
    notes : tuple of str
        Warnings raised (the optimiser missed, a grid missed a minimum), also in the summary.
    """

    quantity: str
    worst: float
    worst_unstable: bool
    worst_plant: PerturbedPlant
    nominal: float
    sampled_worst: float
    sampled_worst_plant: PerturbedPlant
    sampled_values: NDArray[np.float64]
    evaluations: int
    seconds: float
    uncertainty: UncertaintySet
    budget: dict[str, Any]
    notes: tuple[str, ...] = ()

    @property
    def lower_is_worse(self) -> bool:
        """Whether a smaller value is worse (a margin) or a larger one (a step metric)."""
        return self.quantity == "disk_margin"

    @property
    def optimiser_at_least_as_bad(self) -> bool:
        """Whether the optimiser's worst is at least as bad as the sampled worst (it should be)."""
        if self.lower_is_worse:
            return self.worst <= self.sampled_worst
        return self.worst >= self.sampled_worst

    def summary(self) -> str:
        """Two lines: the worst (unstable said as such) against the nominal and the samples; the worst plant."""
        unit = {"disk_margin": "", "overshoot_percent": " %", "settling_time_s": " s"}[self.quantity]
        worst = "UNSTABLE closed loop" if self.worst_unstable else f"{self.worst:.4g}{unit}"
        sampled_unstable = self.sampled_worst <= 0.0 if self.lower_is_worse else not math.isfinite(self.sampled_worst)
        sampled = "UNSTABLE" if sampled_unstable else f"{self.sampled_worst:.4g}{unit}"
        relation = "<=" if self.lower_is_worse else ">="
        verdict = "" if self.optimiser_at_least_as_bad else " (the optimiser MISSED: raise the budget)"
        lines = [
            f"worst {self.quantity.replace('_', ' ')} over the set: {worst} (nominal {self.nominal:.4g}{unit}; "
            f"{self.budget['samples']} uniform samples: {sampled}, optimiser {relation} "
            f"samples: {self.optimiser_at_least_as_bad}{verdict}); {self.evaluations} plants in {self.seconds:.3g} s",
            f"worst plant: {self.worst_plant.summary()}",
        ]
        return "\n".join(lines + [f"note: {n}" for n in self.notes])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready figures: the worst and where, the nominal, the sampled worst, the budget."""

        def number(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {
            "quantity": self.quantity,
            "worst": number(self.worst),
            "worst_unstable": self.worst_unstable,
            "worst_plant": self.worst_plant.to_dict(),
            "nominal": number(self.nominal),
            "sampled_worst": number(self.sampled_worst),
            "sampled_worst_plant": self.sampled_worst_plant.to_dict(),
            "optimiser_at_least_as_bad_as_samples": self.optimiser_at_least_as_bad,
            "samples_unstable": int(np.sum(self._unstable_samples())),
            "evaluations": self.evaluations,
            "seconds": self.seconds,
            "uncertainty": {
                "inertia_percent": self.uncertainty.inertia_percent,
                "axis_rotation_deg": self.uncertainty.axis_rotation_deg,
                "wheel_misalignment_deg": self.uncertainty.wheel_misalignment_deg,
                "extra_delay_s": self.uncertainty.extra_delay_s,
                "sampling": "uniform over the set",
            },
            "budget": dict(self.budget),
            "notes": list(self.notes),
        }

    def _unstable_samples(self) -> NDArray[np.bool_]:
        values = self.sampled_values
        return values <= 0.0 if self.lower_is_worse else ~np.isfinite(values)

    def plot(self) -> Figure:
        """Histogram of the sampled values with the optimiser's worst, the sampled worst and the nominal marked."""
        fig = Figure(figsize=(7.5, 4.2), layout="constrained")
        ax = fig.subplots()
        unstable = self._unstable_samples()
        stable = self.sampled_values[~unstable]
        unit = {"disk_margin": "[-]", "overshoot_percent": "[%]", "settling_time_s": "[s]"}[self.quantity]
        label = {"disk_margin": "multiloop disk margin at the plant input", "overshoot_percent": "largest overshoot",
                 "settling_time_s": "longest 2 % settling time"}[self.quantity]  # fmt: skip
        if stable.size:
            ax.hist(stable, bins=min(30, max(5, stable.size // 4)), color="0.75", edgecolor="0.5",
                    label=f"{stable.size} uniform samples of the set")  # fmt: skip
        marks = [
            (self.nominal, "k", "--", f"nominal {self.nominal:.4g}"),
            (
                self.sampled_worst,
                "tab:orange",
                ":",
                "sampled worst: UNSTABLE (0)"
                if self.lower_is_worse and self.sampled_worst <= 0.0
                else f"sampled worst {self.sampled_worst:.4g}",
            ),
        ]
        if not self.worst_unstable:
            marks.append((self.worst, "tab:red", "-", f"optimiser's worst {self.worst:.4g}"))
        for value, color, style, text in marks:
            if math.isfinite(value):
                ax.axvline(value, color=color, ls=style, lw=2.0, label=text)
        notes = []
        if unstable.any():
            notes.append(f"{int(unstable.sum())} samples UNSTABLE (not in the histogram)")
        if self.worst_unstable:
            notes.append("optimiser's worst: UNSTABLE closed loop")
        if notes:
            ax.text(0.02, 0.97, "\n".join(notes), transform=ax.transAxes, va="top", ha="left", color="tab:red",
                    bbox={"boxstyle": "round", "facecolor": "white", "edgecolor": "tab:red"})  # fmt: skip
        ax.set_xlabel(f"{label} {unit}")
        ax.set_ylabel("samples")
        ax.legend(loc="best", fontsize=8)
        ax.grid(True, alpha=0.3)
        ax.set_title(f"Worst case over the set\n{self.uncertainty.summary()}", fontsize=9)
        return fig


def _prepare(
    body: RigidBody,
    controller: Any,
    uncertainty: UncertaintySet,
    wheels: ReactionWheels | None,
    computation_delay: float,
    budget: tuple[int, int, int, int, int],
) -> tuple[tuple[str, ...], NDArray[np.float64]]:
    _single_body(body)
    if not isinstance(uncertainty, UncertaintySet):
        raise ValueError(f"uncertainty must be an UncertaintySet, got {uncertainty!r}")
    if wheels is not None and not isinstance(wheels, ReactionWheels):
        raise ValueError(f"wheels must be ReactionWheels or None, got {wheels!r}")
    if uncertainty.wheel_misalignment_deg and wheels is None:
        raise ValueError(
            f"wheel_misalignment_deg = {uncertainty.wheel_misalignment_deg:g} needs the wheels (wheels=): "
            "the misalignment acts through their allocation"
        )
    if not (
        isinstance(computation_delay, (int, float)) and math.isfinite(computation_delay) and computation_delay >= 0
    ):
        raise ValueError(f"computation_delay must be a finite number >= 0 [s], got {computation_delay!r}")
    _check_budget(*budget)
    uncertainty.check_body(body)
    n_wheels = 0 if wheels is None else wheels.n_wheels
    return uncertainty.parameter_names(n_wheels), uncertainty.bounds(n_wheels)


def _run(
    quantity: str,
    evaluate: Callable[[PerturbedPlant], tuple[float, bool]],
    final: Callable[[PerturbedPlant], tuple[float, bool]],
    lower_is_worse: bool,
    body: RigidBody,
    uncertainty: UncertaintySet,
    wheels: ReactionWheels | None,
    names: tuple[str, ...],
    bounds: NDArray[np.float64],
    budget: dict[str, Any],
    seed: Any,
    started: float,
    notes: list[str],
    modes: Any = None,
) -> WorstCase:
    """The shared driver: ``evaluate`` (value, unstable) of a plant during the search, ``final`` for the two
    answers; the search minimises the value (negated when higher is worse)."""
    sign = 1.0 if lower_is_worse else -1.0

    def plant(x: NDArray[np.float64]) -> PerturbedPlant:
        return perturbed_plant(body, uncertainty, x, wheels=wheels, modes=modes)

    def objective(x: NDArray[np.float64]) -> float:
        value, unstable = evaluate(plant(x))
        if unstable:
            return 0.0 if lower_is_worse else -_UNSTABLE_STEP
        return sign * value

    rng = as_generator(seed)
    search = _search(
        objective,
        bounds,
        names,
        _uniform_sampler(uncertainty, names, bounds),
        samples=budget["samples"],
        maxiter=budget["maxiter"],
        popsize=budget["popsize"],
        local_starts=budget["local_starts"],
        local_maxfev=budget["local_maxfev"],
        rng=rng,
    )
    worst_plant = plant(search.best_x)
    sampled_index = int(np.argmin(search.sample_f))
    sampled_plant = plant(search.sample_x[sampled_index])
    worst, worst_unstable = final(worst_plant)
    sampled_worst, _ = final(sampled_plant)
    nominal, _ = final(plant(np.zeros(len(names))))
    values = sign * search.sample_f
    if lower_is_worse:
        values = np.maximum(values, 0.0)
    else:
        values = np.where(search.sample_f <= -_UNSTABLE_STEP, math.inf, values)
    result = WorstCase(
        quantity=quantity,
        worst=worst,
        worst_unstable=worst_unstable,
        worst_plant=worst_plant,
        nominal=nominal,
        sampled_worst=sampled_worst,
        sampled_worst_plant=sampled_plant,
        sampled_values=values,
        evaluations=search.evaluations,
        seconds=time.perf_counter() - started,
        uncertainty=uncertainty,
        budget=budget,
        notes=tuple(notes),
    )
    if not result.optimiser_at_least_as_bad:
        message = (
            f"the optimiser missed: its worst {quantity} {worst:.6g} is less bad than the sampled worst "
            f"{sampled_worst:.6g}; raise the budget (maxiter, popsize, local_starts)"
        )
        warnings.warn(message, RuntimeWarning, stacklevel=3)
        result = dataclasses.replace(result, notes=(*result.notes, message))
    return result


def worst_case_disk_margin(
    body: RigidBody,
    controller: Any,
    uncertainty: UncertaintySet,
    *,
    wheels: ReactionWheels | None = None,
    modes: Any = None,
    sampled: bool | None = None,
    computation_delay: float = 0.0,
    samples: int = DEFAULT_SAMPLES,
    maxiter: int = DEFAULT_MAXITER,
    popsize: int = DEFAULT_POPSIZE,
    local_starts: int = DEFAULT_LOCAL_STARTS,
    local_maxfev: int = DEFAULT_LOCAL_MAXFEV,
    seed: Any = 0,
) -> WorstCase:
    """The smallest multiloop disk margin at the plant input over an uncertainty set, by optimisation.

    Parameters
    ----------
    body : RigidBody
        The nominal body [kg m^2].
    controller : object
        As :func:`controllers.analysis.input_loop` (a :class:`~controllers.pd.QuaternionPD`, an LQR design,
        a gain or an LTI controller); its period makes the loop sampled.
    uncertainty : UncertaintySet
        The set.
    wheels : ReactionWheels, optional
        The nominal wheels (required for a wheel misalignment).
    modes : FlexibleModes, optional
        The appendages' modes: every plant of the set is the flexible one (:attr:`PerturbedPlant.modes`).
    sampled : bool, optional
        As :func:`controllers.analysis.loop_gain` (None: sampled when the controller has a period).
    computation_delay : float
        The nominal delay from the sample to the torque [s]; the set's extra delay adds to it. A continuous
        loop takes the delay as a Pade approximant (:func:`controllers.analysis.delayed_loop`).
    samples : int
        Uniform samples of the set for the Monte Carlo comparison.
    maxiter : int
        Generations of differential evolution.
    popsize : int
        Population of differential evolution per parameter (scipy's ``popsize``).
    local_starts : int
        Corners (or the nominal) from which a local search starts.
    local_maxfev : int
        Evaluations of each local search at most.
    seed : int, numpy Generator or None
        The random source of the samples and of differential evolution (:func:`attitude.rng.as_generator`).

    Returns
    -------
    WorstCase
        ``quantity = "disk_margin"``; an unstable worst plant has ``worst = 0`` and ``worst_unstable``.

    Raises
    ------
    ValueError
        For a bad body, controller, set (a corner without a physical body), wheels or budget.
    ImportError
        Without slycot (multiloop margins need the ``robust`` extra).
    """
    started = time.perf_counter()
    budget = (samples, maxiter, popsize, local_starts, local_maxfev)
    names, bounds = _prepare(body, controller, uncertainty, wheels, computation_delay, budget)
    nominal = perturbed_plant(body, uncertainty, np.zeros(len(names)), wheels=wheels, modes=modes)
    first = _margin_of(nominal, controller, sampled, computation_delay, None)
    grid = None
    if first.closed_loop_stable:
        top = math.pi / float(controller_period(controller)) * (1.0 - 1e-6) if first.sampled else math.inf
        high = min(first.frequency_rad_s * 10.0**SEARCH_GRID_DECADES, top)
        low = min(first.frequency_rad_s * 10.0**-SEARCH_GRID_DECADES, 0.5 * high)
        grid = np.logspace(math.log10(low), math.log10(high), SEARCH_GRID_POINTS)
    notes: list[str] = []

    def evaluate(omega: Any) -> Callable[[PerturbedPlant], tuple[float, bool]]:
        def margin(plant: PerturbedPlant) -> tuple[float, bool]:
            result = _margin_of(plant, controller, sampled, computation_delay, omega)
            return (result.disk_margin, False) if result.closed_loop_stable else (0.0, True)

        return margin

    on_grid, on_full = evaluate(grid), evaluate(None)

    def final(plant: PerturbedPlant) -> tuple[float, bool]:
        value, unstable = on_full(plant)
        searched, _ = on_grid(plant)
        if not unstable and abs(searched - value) > GRID_AGREEMENT * value:
            message = (
                f"the search grid gave a margin of {searched:.6g} where the full grid gives {value:.6g} for the "
                f"plant {plant.summary()}: its smallest margin lies outside the search grid"
            )
            warnings.warn(message, RuntimeWarning, stacklevel=4)
            notes.append(message)
        return value, unstable

    keys = _budget_record(budget, seed)
    return _run(
        "disk_margin", on_grid, final, True, body, uncertainty, wheels, names, bounds, keys, seed, started, notes, modes
    )


def worst_case_step(
    body: RigidBody,
    controller: Any,
    uncertainty: UncertaintySet,
    *,
    metric: str = "overshoot",
    wheels: ReactionWheels | None = None,
    modes: Any = None,
    sampled: bool | None = None,
    computation_delay: float = 0.0,
    duration_s: float | None = None,
    samples: int = DEFAULT_SAMPLES,
    maxiter: int = DEFAULT_MAXITER,
    popsize: int = DEFAULT_POPSIZE,
    local_starts: int = DEFAULT_LOCAL_STARTS,
    local_maxfev: int = DEFAULT_LOCAL_MAXFEV,
    seed: Any = 0,
) -> WorstCase:
    """The largest overshoot or settling time of the linear closed loop over an uncertainty set.

    A unit step on each axis's reference angle (``tau = -K (q_v - theta_ref / 2) - C omega``, the closed loop
    of :func:`controllers.analysis.attitude_closed_loop` with the plant's torque map, hold and delay); the
    worst over the three axes of the overshoot [%] or the 2 % settling time [s] (:func:`control.step_info`).

    Parameters
    ----------
    body : RigidBody
        The nominal body [kg m^2].
    controller : object with ``K`` and ``C`` (3, 3)
        A PD controller (:class:`~controllers.pd.QuaternionPD`); its period makes the loop sampled.
    uncertainty : UncertaintySet
        The set.
    metric : {"overshoot", "settling_time"}
        What is maximised (:data:`STEP_METRICS`).
    wheels : ReactionWheels, optional
        The nominal wheels (required for a wheel misalignment).
    modes : FlexibleModes, optional
        The appendages' modes: every plant of the set is the flexible one (:attr:`PerturbedPlant.modes`).
    sampled : bool, optional
        As :func:`controllers.analysis.loop_gain`.
    computation_delay : float
        The nominal delay [s]; the set's extra delay adds to it.
    duration_s : float, optional
        Length of the step responses [s] (default ten times the nominal closed loop's slowest time constant;
        a response still outside the 2 % band at its end warns: its figure is then a lower bound).
    samples : int
        Uniform samples of the set for the Monte Carlo comparison.
    maxiter : int
        Generations of differential evolution.
    popsize : int
        Population of differential evolution per parameter.
    local_starts : int
        Corners (or the nominal) from which a local search starts.
    local_maxfev : int
        Evaluations of each local search at most.
    seed : int, numpy Generator or None
        The random source (:func:`attitude.rng.as_generator`).

    Returns
    -------
    WorstCase
        ``quantity`` ``"overshoot_percent"`` or ``"settling_time_s"``; an unstable worst plant has an
        infinite value and ``worst_unstable``.

    Raises
    ------
    ValueError
        For a bad metric, duration, body, controller, set, wheels or budget.
    """
    started = time.perf_counter()
    if metric not in STEP_METRICS:
        raise ValueError(f"metric must be one of {tuple(STEP_METRICS)}, got {metric!r}")
    budget = (samples, maxiter, popsize, local_starts, local_maxfev)
    names, bounds = _prepare(body, controller, uncertainty, wheels, computation_delay, budget)
    if not (hasattr(controller, "K") and hasattr(controller, "C")):
        raise ValueError(f"controller must have gain matrices K and C (3, 3) for a step response, got {controller!r}")
    nominal = perturbed_plant(body, uncertainty, np.zeros(len(names)), wheels=wheels, modes=modes)
    if duration_s is None:
        system, is_sampled, delay = _loop_plant(nominal, controller, sampled, computation_delay)
        poles = closed_loop_poles(system, controller, sampled=is_sampled, computation_delay=delay)
        if is_sampled:
            poles = np.log(poles[np.abs(poles) > 0].astype(complex)) / float(controller_period(controller))
        rates = -poles.real[poles.real < 0]
        if rates.size == 0:
            raise ValueError("the nominal closed loop is not stable: give duration_s for its step response")
        duration_s = 10.0 / float(np.min(rates))
    if not (isinstance(duration_s, (int, float)) and math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s must be a positive finite number [s], got {duration_s!r}")
    duration = float(duration_s)

    def evaluate(plant: PerturbedPlant) -> tuple[float, bool]:
        value = _step_metric(plant, controller, sampled, computation_delay, metric, duration)
        return value, not math.isfinite(value)

    keys = {**_budget_record(budget, seed), "duration_s": duration}
    quantity = STEP_METRICS[metric][0]
    return _run(
        quantity, evaluate, evaluate, False, body, uncertainty, wheels, names, bounds, keys, seed, started, [], modes
    )

"""Built-in Monte Carlo scenarios (top floor: ties ``attitude`` to ``controllers`` and ``estimation``).

Like :mod:`attitude.app.cli`, this module may import the controllers and the
estimators; :mod:`attitude.montecarlo.campaign` never does (a scenario is any callable
``scenario(params, rng)``).

:class:`ClosedLoopScenario`
    The spacecraft file's closed loop: dispersed plant, reaction wheels, a
    gyro and a star tracker (with dispersed misalignments) feeding an MEKF,
    and a controller designed on the *nominal* inertia. By default
    (``guidance="plan"``) it flies the design's guidance: the required slew
    planned once, on the nominal spacecraft, by
    :func:`attitude.app.slew_study.plan_slews` (minimum time around the
    keep-out cones, within the rate limit and the wheels' torque and
    momentum), tracked by :class:`controllers.tracking.TrackingController`
    with the plan's torque as feedforward, as ``attitude design`` flies it.
    ``guidance="eigenaxis"`` is the earlier scenario: a Wie-Lu rate-limited
    quaternion PD straight to the target (an eigenaxis slew, which cannot
    avoid a keep-out cone). With ``run_batch`` (``vectorized=True``) all
    runs advance together: truth, sensors, MEKF and control law as batched
    states (:mod:`attitude.simulation.batch_estimated`).
:class:`PDWheelsScenario`
    PD + wheels with the controller seeing the truth: runs per run in the
    engine's compiled path and, with ``run_batch``, all runs at once in
    :func:`attitude.simulation.batch.simulate_batch`.
:func:`run_campaign_from_config`
    What ``attitude montecarlo FILE`` calls: the campaign of the file's
    ``[montecarlo]`` table (:func:`campaign_from_config`), written with its
    figures to an output directory.
:func:`replay_from_config`
    What ``attitude montecarlo FILE --replay RUN`` calls: one run of that
    campaign flown again alone, with its history at every tick.

In orbit (``environment=True``, ``attitude montecarlo --environment``) both
scenarios fly the file's ``[orbit]``, ``[environment]`` and ``[surface]``
(:func:`attitude.app.assembly.orbit_environment`): every run starts at the
orbit's epoch, and the disturbance torques of its sources act on it, with
each run's surface parameters drawn from the ``drag_scale``,
``residual_dipole`` and ``centre_of_pressure_offset`` dispersions
(:func:`surface_parameters`; the file's values where not dispersed). The
guidance is unchanged: the runs start from the file's start attitude and
slew to its target, both inertial (``q_BN`` in the orbit environment's frame
N), and are judged on the same pointing metrics; the keep-out cone ``"sun"``
stays the file's fixed ``environment.sun_direction_N`` (the scene of the slew
design), not the ephemeris Sun the solar pressure uses. The closed-loop
scenario adds ``disturbance_torque_peak.<source>`` [N m] (largest torque
magnitude of each source over the run) to its metrics.

Metrics (SI), all judged against the TARGET attitude of the slew (not the
moving reference a tracking controller follows), at every tick, over the
requirements' windows (:mod:`attitude.simulation.slew_windows`):
``slew_time`` [s] (the design report's "flown slew time": the start of the
first stretch within the pointing accuracy that lasts the settling dwell,
from the start of the run; inf if none), ``settling_after_slew`` [s],
``pointing_error_hold`` [rad] (largest error over the hold),
``final_pointing_error``
[rad] (true error angle to the target at the end), ``rate_peak`` [rad/s],
``wheel_speed_peak`` [rad/s] (relative to the body), ``nees`` (mean
attitude NEES of the MEKF over the run, 3 degrees of freedom: about 3 for a
consistent filter, judged against the filter's covariance plus the tracker
mount's where the run disperses it; see :class:`ClosedLoopScenario`) and
``keep_out_margin.<cone>`` [rad] (smallest angle between boresight and
direction minus the cone's half-angle over the whole run; negative: the
cone was entered). For :class:`PDWheelsScenario` and
``guidance="eigenaxis"`` the controller's reference *is* the target, so
these are the definitions those scenarios always had.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.app.slew_study import SlewStudy, plan_slews
from attitude.config import SpacecraftConfig, load_config
from attitude.config.schema import SURFACE_DISPERSIONS
from attitude.environment.orbit_environment import OrbitEnvironment
from attitude.integrators import attitude_error_text
from attitude.montecarlo.campaign import Campaign, run_campaign, usable_cpus
from attitude.montecarlo.dispersions import dispersions_from_config
from attitude.montecarlo.executors import RunOutput
from attitude.montecarlo.results import CampaignResult, Requirement, RunReplay
from attitude.results import provenance
from attitude.rigid_body import RigidBody
from attitude.rng import NormalStreams
from attitude.sensors import Gyro, GyroBatch
from attitude.simulation.batch import closed_loop_metrics, simulate_batch
from attitude.simulation.batch_estimated import simulate_batch_estimated
from attitude.simulation.engine import simulate
from attitude.simulation.protocols import Truth
from attitude.simulation.slew_windows import SlewWindows, SlewWindowsTracker
from attitude.validation import finite_floats
from controllers.slew.problem import SlewPlanningError
from controllers.tracking import ReferenceTrajectory, TrackingController
from estimation.consistency import band_verdict, chi2_band, nees
from estimation.mekf import MEKF, MEKFBatch

__all__ = [
    "GUIDANCES",
    "PLAN_NODES",
    "ClosedLoopScenario",
    "PDWheelsScenario",
    "ScenarioError",
    "campaign_from_config",
    "replay_from_config",
    "requirements_from_config",
    "run_campaign_from_config",
    "surface_parameters",
]

#: What :class:`ClosedLoopScenario` can fly: the planned slew (default) or the eigenaxis rate-limited PD.
GUIDANCES = ("plan", "eigenaxis")
#: Planner intervals of ``guidance="plan"``: the design report's (``attitude design``; 30 with ``--quick``).
#: Planning takes about 2 s for the default spacecraft (1 s with 30), once per campaign, in the parent process.
PLAN_NODES = 60


class ScenarioError(ValueError):
    """A scenario argument that cannot be used (the message names it, the rule and the value)."""


def requirements_from_config(config: SpacecraftConfig, *, keep_out: bool = True) -> tuple[Requirement, ...]:
    """The file's ``[requirements]`` as Monte Carlo pass/fail rules on the metrics (module docstring).

    Built by :func:`attitude.app.assembly.monte_carlo_requirements`.

    The design's rows on the same windows (:mod:`attitude.simulation.slew_windows`):
    ``slew_time``: settling time (the flown slew time) <= ``slew.time_max_s``;
    ``settling``: settling after the end of the planned slew <= ``settling_time_s``;
    ``pointing``: largest error to the target over the hold <= the pointing
    accuracy; ``rate``: peak rate <= the slew rate limit (when given);
    ``keep_out.<name>``: margin >= 0 for each keep-out
    cone. ``keep_out=False`` leaves the cones out, for a guidance that does
    not plan around them (``ClosedLoopScenario(guidance="eigenaxis")``).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft file (its ``[requirements]``).
    keep_out : bool, optional
        Include a rule per keep-out cone.
    """
    return assembly.monte_carlo_requirements(config, keep_out=keep_out)


def surface_parameters(environment: OrbitEnvironment | None, params: Mapping[str, Any]) -> np.ndarray | None:
    """One run's surface parameters from its dispersed values; None without an environment.

    Parameters
    ----------
    environment : OrbitEnvironment or None
        The environment flown (its surface's dipole where ``residual_dipole`` is not dispersed).
    params : mapping
        The run's dispersed parameters: ``drag_scale`` (factor, default 1),
        ``residual_dipole`` (3,) [A m^2] (default the file's),
        ``centre_of_pressure_offset`` (3,) [m] (default 0).

    Returns
    -------
    ndarray (7,) or None
        :meth:`OrbitEnvironment.surface_parameters`.
    """
    if environment is None:
        return None
    return environment.surface_parameters(
        drag_scale=params.get("drag_scale", 1.0),
        residual_dipole_Am2=params.get("residual_dipole"),
        centre_of_pressure_offset_B_m=params.get("centre_of_pressure_offset", np.zeros(3)),
    )


def _scenario_environment(config: SpacecraftConfig, environment: bool) -> OrbitEnvironment | None:
    """The file's orbit environment when a scenario flies it (ScenarioError without an [orbit])."""
    if not environment:
        return None
    built = assembly.orbit_environment(config)
    if built is None:
        raise ScenarioError(
            "environment=True flies the spacecraft file's [orbit], [environment] and [surface], but the file has "
            "no [orbit] table; add one, or leave the environment off"
        )
    return built


def _history(result: Any, stride: int | None, extra: Mapping[str, np.ndarray] | None = None) -> dict | None:
    if not stride:
        return None
    h = {
        "t": result.t[::stride],
        "error_angle": result.error_angle[::stride],
        "omega": result.omega[::stride],
        "wheel_speed": result.wheel_speed[::stride],
    }
    for k, v in (extra or {}).items():
        h[k] = v[::stride]
    return h


class _MisalignedTracker:
    """A star tracker mounted with a small rotation ``theta`` [rad]: it reports ``q_BN ⊗ exp(theta/2)``.

    The product is formed on Python floats for an attitude given as a float64 array (the same
    operations as :func:`attitude.quaternion.multiply`, so the same numbers, at a tenth of the cost).
    """

    def __init__(self, tracker: Any, theta: np.ndarray) -> None:
        self.tracker = tracker
        self.name = tracker.name
        self.period = tracker.period
        self._dq = quat.from_rotation_vector(np.asarray(theta, dtype=float))
        self._dq_floats = self._dq.tolist()

    def measure(self, t: float, truth: Truth, rng: Any) -> Any:
        q = finite_floats(truth.q, 4)
        seen_q = (
            quat.multiply(truth.q, self._dq) if q is None else np.array(quat.multiply_components(q, self._dq_floats))
        )
        return self.tracker.measure(t, Truth(truth.t, seen_q, truth.omega, truth.h_wheels), rng)


class _RecordingEstimator:
    """Passes an estimator through and keeps its attitude estimates and covariances (for the NEES)."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.period = inner.period
        self.t: list[float] = []
        self.q: list[np.ndarray] = []
        self.P: list[np.ndarray] = []

    def update(self, t: float, measurements: Any) -> Any:
        estimate = self.inner.update(t, measurements)
        self.t.append(t)
        self.q.append(estimate.q)
        self.P.append(estimate.covariance[:3, :3])
        return estimate

    def log(self) -> dict[str, Any]:
        return self.inner.log()


class _TabulatedTracking:
    """A :class:`TrackingController` whose reference is sampled once per run, vectorised, on the control ticks.

    The same law and the same reference values (``compiled_inputs``, the
    vectorised form of what ``torque`` samples per tick), looked up instead
    of slerped per tick: bit-identical runs (tests/attitude/app/test_scenarios.py), and a
    600 s run of the default file took 3.8 s instead of 6.8 s when it was
    introduced. The table and the estimate are read as Python floats: the law
    costs a third of what it costs on numpy scalars, with the same numbers. A
    time off the table falls back to the controller itself.
    """

    def __init__(self, inner: TrackingController, duration: float) -> None:
        self.inner = inner
        self.period = inner.period
        n = math.floor(duration / self.period + 1e-9) + 1
        self._t = np.arange(n) * self.period
        self._inputs = np.asarray(inner.compiled_inputs(self._t), dtype=float).T  # (n, 10)
        # Python floats for the per-tick law (numpy scalars cost several times more per operation).
        self._t_floats = self._t.tolist()
        self._input_floats = self._inputs.tolist()

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        return self.inner.reference(t)

    def reference_samples(self, t: Any) -> tuple[np.ndarray, np.ndarray]:
        return self.inner.reference_samples(t)

    def torque(self, t: float, estimate: Any) -> np.ndarray:
        k = round(t / self.period)
        if not (0 <= k < len(self._t_floats) and abs(self._t_floats[k] - t) <= 1e-9 * self.period):
            return self.inner.torque(t, estimate)
        h_body = getattr(estimate, "h_body", None)
        h_body = [0.0] * 3 if h_body is None else np.asarray(h_body, float).tolist()
        q, omega = np.asarray(estimate.q, float).tolist(), np.asarray(estimate.omega, float).tolist()
        out = self.inner.torque_components(q, omega, h_body, self._input_floats[k])
        return np.array([float(v) for v in out])


class ClosedLoopScenario:
    """The spacecraft file's closed loop with an MEKF in the loop (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft (nominal values; the campaign's dispersions perturb them).
    duration : float, optional
        Simulated time [s]; it must reach the end of the requirements' hold
        (:attr:`windows`: the planned slew, or the allowed slew time with
        ``guidance="eigenaxis"``, plus the settling time and the hold), else
        ScenarioError names each part. Default: exactly that
        (:func:`attitude.app.assembly.judged_duration`).
    history_stride : int, optional
        Keep time histories every this many ticks (None: metrics only).
        Histories: ``error_angle`` (true error to the target) [rad],
        ``tracking_error`` (true error to the controller's reference) [rad],
        ``omega`` [rad/s], ``wheel_speed`` [rad/s], ``estimation_error``
        (MEKF attitude error at its updates, NaN between them) [rad].
    rate_margin : float
        ``guidance="eigenaxis"`` only: the controller's slew-rate limit is
        ``rate_margin`` times the requirement's (default 0.9): the Wie-Lu
        bound holds for the design inertia and the true rate, so a dispersed
        inertia and a noisy rate estimate overshoot a limit set exactly at
        the requirement (by about 0.5 % for the default spacecraft). The
        plan has its own margins (:data:`attitude.app.slew_study.PLAN_RATE_FRACTION`).
    guidance : {"plan", "eigenaxis"}
        ``"plan"`` (default): the design's optimal slew, planned once here
        on the nominal spacecraft (:func:`attitude.app.slew_study.plan_slews`,
        ``nodes`` intervals) and flown by
        :class:`controllers.tracking.TrackingController` (feedback at the
        file's bandwidth and damping, designed on the nominal inertia; the
        plan's torque as feedforward), exactly as ``attitude design`` flies
        it. When planning fails there is no fallback: SlewPlanningError says
        why (a campaign silently flying another guidance would sign off the
        wrong thing; pass ``guidance="eigenaxis"`` to fly that one on
        purpose). ``"eigenaxis"``: the Wie-Lu rate-limited quaternion PD
        straight to the target (no planning; cannot avoid a keep-out cone).
    nodes : int
        Planner intervals for ``guidance="plan"`` (default :data:`PLAN_NODES`,
        the design report's).
    study : SlewStudy, optional
        A study already made by :func:`attitude.app.slew_study.plan_slews` for
        this ``config`` (e.g. the design report's) to fly instead of planning
        again; its start and target must be the file's.
    consider_misalignment : bool
        Add the per-axis variance of the file's ``star_tracker_misalignment``
        dispersion to the tracker measurement covariance the MEKF uses
        (default False; see Notes).
    environment : bool
        Fly the file's orbit environment (module docstring; default False:
        empty inertial space, as before). Needs an ``[orbit]`` table.
    plan_progress : bool or None
        A progress bar over the planner's starts while the slew is planned
        here (``progress`` of :func:`controllers.slew.planner.plan_slew`;
        default False; None: when stderr is a terminal). Not part of the
        scenario: it is not kept.

    Notes
    -----
    The plan is computed in the parent process when the scenario is built;
    the scenario keeps only numpy copies of it
    (:class:`controllers.tracking.ReferenceTrajectory`: the plan resampled
    at the control period, and the plan's own torque steps for the
    feedforward), so it pickles small and workers (local processes or Dask)
    never plan. Attributes: ``slew_end`` (planned slew duration [s], None
    for the eigenaxis guidance), ``plan_separation_min`` (the plan's own
    smallest boresight separation per cone [rad]), ``plan_summary`` (the
    study's JSON-ready summary).

    The MEKF models neither misalignment: it takes the star tracker's
    attitude for the body's and the gyro triad for the body axes. A tracker
    misalignment ``theta`` is a constant offset of every measurement, which
    the filter cannot observe, so its estimate converges to the tracker's
    frame: the true attitude error keeps about ``|theta|`` while the
    filter's covariance shrinks to the tracker-noise level, and the attitude
    NEES grows like ``|theta|^2 / P``. A gyro misalignment adds a rate error
    ``theta x omega`` during the slew only, which the 5 Hz tracker updates
    correct. Measured on the default spacecraft file with the tracker
    misalignment dispersed at 30 arcsec per axis, an uncalibrated mount
    (8 runs, seed 12345, 600 s, planned guidance; each case keeps the other
    dispersions' draws): mean NEES 44.8 with both misalignment dispersions
    (30 arcsec tracker, 100 arcsec gyro, 1 sigma per axis), 44.9 with the
    tracker's alone, 3.00 with the gyro's alone and 3.00 with neither (3 is
    consistent). The NEES is a diagnostic, not a requirement: the pointing
    requirements are judged on the truth, where the tracker misalignment
    shows as a pointing offset (with it, 3 of those 8 runs were still
    leaving the 0.05 deg accuracy now and then long after arriving, last at
    about 238, 410 and 579 s, so their settling time failed; without it,
    none did; over 200 runs, 64 with it). The file now disperses a
    calibrated mount (10 arcsec per axis): over 200 runs, mean NEES 8.1
    and 12 settling failures, from the same pointing noise on a smaller
    offset.

    The ``nees`` metric therefore judges a run that disperses the tracker
    mount against the attitude error covariance, the filter's ``P`` plus the
    mount's ``sigma_theta^2 I`` (:func:`attitude.app.assembly.tracker_misalignment_covariance`):
    the true error is the filter's error plus the mount's rotation,
    independent of each other, and one attitude sensor cannot observe the
    latter (the Schmidt consider covariance of an unestimated bias). The
    filter itself is unchanged. The default file's 200-run vectorised
    campaign (seed 12345, 600 s) has a mean NEES of 2.90, inside the
    two-sided 95 % chi-square band of the mean of 200 values, [2.67, 3.35]
    (it was 8.07 against the filter's ``P`` alone).

    ``consider_misalignment=True`` is another remedy, in the filter rather
    than in the judgement: the tracker covariance
    the MEKF uses becomes ``R + sigma_theta^2 I``, so the filter no longer
    trusts the tracker beyond the mounting knowledge. Measured on the same
    8 runs: mean NEES 9.2 (from 44.8), keep-out margins and peak rates
    unchanged within 0.01 deg and 0.001 deg/s, final pointing errors up to
    0.0022 deg larger, and one more run leaving the accuracy long after
    arriving (4 instead of 3). It only reduces the inconsistency: a constant offset
    is not white noise, so averaging many measurements still shrinks ``P``
    below ``sigma_theta^2``; estimating the misalignment (augmented states)
    is the complete remedy and is not done here.

    Dispersion names it reads (all optional): ``inertia`` (3, 3) [kg m^2],
    ``initial_attitude`` (4,), ``initial_rate`` (3,) [rad/s],
    ``gyro_misalignment`` and ``star_tracker_misalignment`` (3,) [rad],
    ``gyro_bias`` (3,) [rad/s] (added to the file's turn-on bias; the MEKF's
    initial bias uncertainty grows to cover it) and, in orbit,
    ``drag_scale``, ``residual_dipole`` (3,) [A m^2] and
    ``centre_of_pressure_offset`` (3,) [m] (:func:`surface_parameters`).

    Raises
    ------
    ScenarioError
        (a ValueError) naming the argument: an unknown ``guidance``, a
        ``duration`` shorter than the planned slew plus the settling time, a
        ``rate_margin`` outside (0, 1], a ``study`` of another slew,
        ``environment=True`` for a file without an ``[orbit]``.
    SlewPlanningError
        ``guidance="plan"`` and the slew could not be planned.
    """

    def __init__(
        self,
        config: SpacecraftConfig,
        duration: float | None = None,
        history_stride: int | None = None,
        rate_margin: float = 0.9,
        *,
        guidance: str = "plan",
        nodes: int = PLAN_NODES,
        study: SlewStudy | None = None,
        consider_misalignment: bool = False,
        environment: bool = False,
        plan_progress: bool | None = False,
    ) -> None:
        if guidance not in GUIDANCES:
            raise ScenarioError(f"guidance must be one of {', '.join(map(repr, GUIDANCES))}, got {guidance!r}")
        if not 0.0 < rate_margin <= 1.0:
            raise ScenarioError(f"rate_margin must be in (0, 1], got {rate_margin!r}")
        if duration is not None:
            duration = float(duration)
            if not (math.isfinite(duration) and duration > 0.0):
                raise ScenarioError(f"duration must be a positive number of seconds, got {duration!r}")
        self.guidance = guidance
        self.rate_margin = float(rate_margin)
        self.config = config
        self.history_stride = history_stride
        self.nodes = int(nodes)
        self.consider_misalignment = bool(consider_misalignment)
        self.environment = bool(environment)
        self._environment = _scenario_environment(config, self.environment)
        self._nominal = assembly.rigid_body(config)
        self._wheels = assembly.reaction_wheels(config)
        self._tracker = assembly.star_tracker(config)
        req = config.requirements
        slew = req.slew
        self._q_start = slew.q_start()
        self._q_target = slew.q_target()
        mc = config.montecarlo
        dispersion = None if mc is None else mc.initial_attitude
        if dispersion is not None and dispersion.distribution == "uniform_so3" and guidance == "plan":
            raise ScenarioError(
                "guidance='plan' flies a slew planned from the file's start attitude, which an initial attitude "
                "uniform on SO(3) ([montecarlo] initial_attitude) does not start from; disperse the initial "
                "attitude about the start (normal or uniform), or fly guidance='eigenaxis'"
            )
        self._attitude_sigma = assembly.attitude_sigma0(dispersion)
        self._bias_sigma = assembly.gyro_bias_sigma0(config)
        self._tracker_covariance = assembly.mekf_tracker_covariance(config, self._tracker, self.consider_misalignment)
        # A run that disperses the tracker mount judges its NEES against the attitude error covariance: the
        # filter's plus the mount's, which one attitude sensor cannot observe (Notes).
        self._mount_covariance = assembly.tracker_misalignment_covariance(config)
        self._reference: ReferenceTrajectory | None = None
        self._feedforward: ReferenceTrajectory | None = None
        self.slew_end: float | None = None
        #: The planned slew (None with guidance="eigenaxis").
        self.study: SlewStudy | None = None
        self.plan_separation_min: dict[str, float] = {}
        self.plan_summary: dict[str, Any] | None = None
        if guidance == "plan":
            self._plan(study, plan_progress)
        #: When the requirements are judged: the planned slew's end, or the allowed slew time (eigenaxis).
        self.windows = assembly.slew_windows(config, self.slew_end)
        if duration is None:
            duration = assembly.judged_duration(config, self.slew_end)
        try:
            self.windows.check_covers(duration)
        except ValueError as exc:
            raise ScenarioError(str(exc)) from None
        self.duration = duration

    def _plan(self, study: SlewStudy | None, progress: bool | None = False) -> None:
        """Plan (or take) the slew on the nominal spacecraft and keep numpy copies of it."""
        if study is None:
            study = plan_slews(self.config, nodes=self.nodes, progress=progress)
        self.study = study
        plan = study.plan
        if plan is None:
            raise SlewPlanningError(
                f"guidance='plan': the required slew of {self.config.name!r} could not be planned "
                f"({study.error}); fix the slew, the limits or the keep-out cones, or pass guidance='eigenaxis' "
                "to fly the eigenaxis slew instead",
                status="no_plan",
                cause=str(study.error),
            )
        for name, mine, theirs in (("start", self._q_start, plan.q[0]), ("target", self._q_target, plan.q_target)):
            if float(quat.error_angle(mine, theirs)) > 1e-9:
                raise ScenarioError(f"study must plan this config's slew: its {name} attitude differs from the file's")
        c = self.config.control
        self._reference = ReferenceTrajectory.from_plan(plan.resample(c.period_s))
        self._feedforward = ReferenceTrajectory.from_plan(plan)
        self.slew_end = float(plan.duration)
        separations = np.atleast_1d(plan.separation_min)
        self.plan_separation_min = {cone.name: float(s) for cone, s in zip(study.cones, separations)}
        self.plan_summary = study.summary

    def __getstate__(self) -> dict[str, Any]:
        # Only numpy copies of the plan travel to the workers, not the planner's objects (the study).
        state = dict(self.__dict__)
        state["study"] = None
        return state

    @property
    def fingerprint(self) -> str:
        return (
            f"ClosedLoopScenario({self.config!r}, duration={self.duration!r}, stride={self.history_stride!r}, "
            f"rate_margin={self.rate_margin!r}, guidance={self.guidance!r}, nodes={self.nodes!r}, "
            f"slew_end={self.slew_end!r}, consider_misalignment={self.consider_misalignment!r}"
            + (", environment=True)" if self.environment else ")")
        )

    def controller(self) -> Any:
        """The control law, designed on the nominal inertia (a new one per run)."""
        if self._reference is not None:
            return assembly.tracking_controller(self.config, self._reference, self._nominal, self._feedforward)
        return assembly.eigenaxis_controller(self.config, self._nominal, self._q_target, self.rate_margin)

    def gyro(self, misalignment: np.ndarray | None, bias: np.ndarray | None = None) -> Gyro:
        """The file's gyro with an extra misalignment rotation vector [rad] and turn-on bias [rad/s].

        Parameters
        ----------
        misalignment : ndarray (3,) or None
            Extra misalignment rotation vector [rad]; None for none.
        bias : ndarray (3,), optional
            Extra turn-on bias [rad/s], added to the file's constant bias; None for none.
        """
        # Interval-mean samples (an integrating gyro): what the MEKF models.
        return assembly.gyro(self.config, "mean", misalignment_rad=misalignment, bias_rad_per_s=bias)

    def estimator(self, gyro: Gyro) -> MEKF:
        """The MEKF matched to the (nominal) sensors, started at the nominal start attitude.

        Parameters
        ----------
        gyro : Gyro
            The run's gyro (its noise figures set the filter).
        """
        return assembly.mekf(
            gyro,
            self._tracker,
            q0=self._q_start,
            P0=assembly.mekf_initial_covariance(
                attitude_sigma_rad=self._attitude_sigma, bias_sigma_rad_per_s=self._bias_sigma
            ),
            tracker_covariance=self._tracker_covariance,
        )

    def _mount_for(self, params: Mapping[str, Any]) -> np.ndarray:
        """The mount covariance a run's NEES adds [rad^2] (3, 3): the dispersion's where the run disperses it."""
        return self._mount_covariance if "star_tracker_misalignment" in params else np.zeros((3, 3))

    def __call__(self, params: Mapping[str, Any], rng: np.random.Generator) -> RunOutput:
        body = RigidBody(params["inertia"]) if "inertia" in params else self._nominal
        q0 = params.get("initial_attitude", self._q_start)
        omega0 = params.get("initial_rate", np.zeros(3))
        gyro = self.gyro(params.get("gyro_misalignment"), params.get("gyro_bias"))
        tracker = self._tracker
        if "star_tracker_misalignment" in params:
            tracker = _MisalignedTracker(tracker, params["star_tracker_misalignment"])
        estimator = _RecordingEstimator(self.estimator(gyro))
        controller = self.controller()
        if isinstance(controller, TrackingController):
            controller = _TabulatedTracking(controller, self.duration)
        result = simulate(
            body,
            q0,
            omega0,
            self.duration,
            controller=controller,
            wheels=self._wheels,
            sensors=[gyro, tracker],
            estimator=estimator,
            rng=rng,
            environment=self._environment,
            surface_parameters=surface_parameters(self._environment, params),
        )
        metrics = closed_loop_metrics(result, self.windows.accuracy_rad)
        # Judged against the target attitude, not the moving reference, over the requirement's windows
        # (module docstring): the design's definitions.
        to_target = np.asarray(quat.error_angle(self._q_target, result.q))
        metrics.pop("settling_time")  # the engine's, on the moving reference: not a requirement's figure
        metrics.update(self.windows.metrics(result.t, to_target))
        metrics["final_pointing_error"] = float(to_target[-1])
        q_hat = np.array(estimator.q)
        k = np.searchsorted(result.t, np.array(estimator.t))
        errors = quat.to_rotation_vector(quat.multiply(quat.conjugate(q_hat), quat.normalize(result.q[k])))
        metrics["nees"] = float(np.mean(nees(errors, np.array(estimator.P) + self._mount_for(params))))
        for cone in self.config.requirements.keep_out:
            separation = cone.separation(result.q)
            metrics[f"keep_out_margin.{cone.name}"] = float(np.min(separation) - cone.half_angle_rad)
        for source, tau in result.disturbance_torques.items():
            metrics[f"disturbance_torque_peak.{source}"] = float(np.max(np.linalg.norm(tau, axis=-1)))
        est_error = np.full(result.t.size, np.nan)
        est_error[k] = np.linalg.norm(errors, axis=-1)
        extra = {"error_angle": to_target, "tracking_error": result.error_angle, "estimation_error": est_error}
        return RunOutput(metrics, _history(result, self.history_stride, extra))

    def run_batch(
        self,
        params_list: Sequence[Mapping[str, Any]],
        rngs: Sequence[Any],
        progress: Callable[[float], None] | None = None,
    ) -> list[RunOutput]:
        """All runs at once (``run_campaign(..., vectorized=True)``): the same runs as :meth:`__call__`.

        The truth, the sensors, the MEKF and the control law advance as
        batched states (:func:`attitude.simulation.batch_estimated.simulate_batch_estimated`):
        run ``r`` draws from ``rngs[r]`` exactly the numbers it draws alone,
        so its metrics equal :meth:`__call__`'s to rounding. The eigenaxis
        guidance (a rate-limited PD that latches its limits per run) is run
        run by run.

        Parameters
        ----------
        params_list : sequence of mapping
            The dispersed parameters of each run.
        rngs : sequence of numpy.random.Generator
            The generator of each run.
        progress : callable, optional
            ``progress(fraction)`` of the batch simulated, for the campaign's progress bar.
        """
        if self._reference is None:
            outputs = []
            for i, (p, r) in enumerate(zip(params_list, rngs)):
                outputs.append(self(p, r))
                if progress is not None:
                    progress((i + 1) / len(params_list))
            return outputs
        n = len(params_list)
        body = RigidBody(_stacked(params_list, "inertia", self._nominal.inertia))
        q0 = _stacked(params_list, "initial_attitude", self._q_start)
        omega0 = _stacked(params_list, "initial_rate", np.zeros(3))
        gyros = [self.gyro(p.get("gyro_misalignment"), p.get("gyro_bias")) for p in params_list]
        theta = _stacked(params_list, "star_tracker_misalignment", np.zeros(3))
        mekf = MEKFBatch(self.estimator(gyros[0]), n)
        recorder = _BatchRecorder(self, n, mekf)
        recorder.mount_covariance = np.stack([self._mount_for(p) for p in params_list])
        surface = None
        if self._environment is not None:
            surface = np.stack([surface_parameters(self._environment, p) for p in params_list])
        out = simulate_batch_estimated(
            body,
            q0,
            omega0,
            self.duration,
            controller=self.controller(),
            wheels=self._wheels,
            gyro=GyroBatch(gyros),
            tracker=self._tracker,
            estimator=mekf,
            streams=NormalStreams(list(rngs)),
            tracker_mounting=quat.from_rotation_vector(theta),
            observer=recorder,
            environment=self._environment,
            surface_parameters=surface,
            progress=progress,
        )
        return recorder.outputs(
            out["diverged_at"],
            out.get("disturbance_torque_peak", {}),
            out.get("step_rule_refused"),
            out.get("step_rule_broken"),
            out.get("step_rule_error_bound_rad"),
        )


#: A run the step-size rule fails (docs/rk4_step_rule.md): its attitude may be off by more than the budget.
_STEP_RULE_ERROR = (
    "the plant's RK4 broke the step-size rule (docs/rk4_step_rule.md): attitude error bound {bound} "
    "over the budget; shorten the tick or raise substeps"
)


def nees_consistency(result: CampaignResult, confidence: float = 0.95) -> str | None:
    """The campaign's mean attitude NEES against its chi-square band, in one line (None without a ``nees`` metric).

    Each run's ``nees`` is a time average over the run (3 degrees of
    freedom, the tracker mount counted where it is dispersed:
    :class:`ClosedLoopScenario`); a consistent filter's campaign mean lies in
    the two-sided band of the mean of ``n`` chi-square(3) values (Bar-Shalom,
    Li and Kirubarajan, *Estimation with Applications to Tracking and
    Navigation*, 2001, sec. 5.4), which is wide for time averages.

    Parameters
    ----------
    result : CampaignResult
        A finished campaign.
    confidence : float, optional
        Probability of the band, in (0, 1).

    Returns
    -------
    str or None
    """
    if "nees" not in result.metrics:
        return None
    values = np.asarray(result.metrics["nees"], dtype=float)[np.asarray(result.status) == "ok"]
    values = values[np.isfinite(values)]
    if values.size == 0:
        return None
    low, high = chi2_band(3, values.size, confidence)
    mean = float(np.mean(values))
    verdict = band_verdict(mean, low, high)
    return (
        f"  attitude NEES: mean {mean:.3g} over {values.size} runs, {verdict} (a consistent MEKF's mean lies in "
        f"[{low:.3g}, {high:.3g}] at {100 * confidence:g} %, 3 degrees of freedom; the tracker mount's dispersion "
        "is counted as a consider covariance)"
    )


def _stacked(params_list: Sequence[Mapping[str, Any]], name: str, default: Any) -> np.ndarray:
    """One dispersed parameter of every run, stacked (``default`` where a run does not disperse it)."""
    return np.stack([np.asarray(p.get(name, default), dtype=float) for p in params_list])


class _BatchRecorder:
    """The metrics and histories of :meth:`ClosedLoopScenario.__call__`, reduced tick by tick for a batch."""

    def __init__(self, scenario: ClosedLoopScenario, n: int, mekf: Any) -> None:
        self.scenario, self.mekf = scenario, mekf
        req = scenario.config.requirements
        self.windows = SlewWindowsTracker(scenario.windows, n)
        self.cones = list(req.keep_out)
        self.controller = scenario.controller()
        self.stride = scenario.history_stride
        self.wheels = scenario._wheels
        self.rate_peak = np.zeros(n)
        self.speed_peak = np.zeros(n)
        self.nees_sum = np.zeros(n)
        self.mount_covariance = np.zeros((n, 3, 3))  # [rad^2], set by the scenario for runs dispersing the mount
        self.nees_count = 0
        self.separation_min = {c.name: np.full(n, np.inf) for c in self.cones}
        self.t: list[float] = []
        self.final_error = np.zeros(n)
        self.n_ticks = -1
        self.history: dict[str, list] = {}

    def __call__(self, k: int, t: float, x: np.ndarray, q_hat: np.ndarray, w_hat: np.ndarray, updated: bool) -> None:
        q = quat.normalize(x[:, :4])
        to_target = np.asarray(quat.error_angle(self.scenario._q_target, q))
        self.windows.update(t, to_target)
        self.final_error = to_target
        self.n_ticks = k
        np.fmax(self.rate_peak, np.linalg.norm(x[:, 4:7], axis=1), out=self.rate_peak)
        speeds = self.wheels.wheel_speed(x[:, 7:], x[:, 4:7])
        np.fmax(self.speed_peak, np.max(np.abs(speeds), axis=1), out=self.speed_peak)
        for cone in self.cones:
            np.fmin(self.separation_min[cone.name], cone.separation(q), out=self.separation_min[cone.name])
        est_error = np.full(x.shape[0], np.nan)
        if updated:
            errors = quat.to_rotation_vector(quat.multiply(quat.conjugate(q_hat), q))
            self.nees_sum += nees(errors, self.mekf.P[:, :3, :3] + self.mount_covariance)
            self.nees_count += 1
            est_error = np.linalg.norm(errors, axis=-1)
        self.t.append(t)
        if self.stride and k % self.stride == 0:
            q_ref = self.controller.reference(t)[0]
            rows = {
                "t": np.full(x.shape[0], t),
                "error_angle": to_target,
                "tracking_error": np.asarray(quat.error_angle(q_ref, q)),
                "omega": x[:, 4:7].copy(),
                "wheel_speed": speeds,
                "estimation_error": est_error,
            }
            for name, value in rows.items():
                self.history.setdefault(name, []).append(value)

    def outputs(
        self,
        diverged_at: np.ndarray,
        torque_peaks: Mapping[str, np.ndarray],
        refused: np.ndarray | None = None,
        broken: np.ndarray | None = None,
        bound: np.ndarray | None = None,
    ) -> list[RunOutput]:
        windowed = self.windows.metrics()
        history = {name: np.stack(rows, axis=1) for name, rows in self.history.items()}
        outputs = []
        for r in range(self.final_error.size):
            if math.isfinite(diverged_at[r]):
                outputs.append(RunOutput(error=f"the closed loop diverged at t = {diverged_at[r]:.6g} s"))
                continue
            if refused is not None and refused[r]:
                outputs.append(
                    RunOutput(
                        error="the run's initial rate is too fast for the tick under the step-size rule "
                        "(docs/rk4_step_rule.md: more than 1000 sub-steps per tick); shorten the tick"
                    )
                )
                continue
            if broken is not None and broken[r]:
                outputs.append(RunOutput(error=_STEP_RULE_ERROR.format(bound=attitude_error_text(float(bound[r])))))
                continue
            metrics = {
                **{name: float(values[r]) for name, values in windowed.items()},
                "final_pointing_error": float(self.final_error[r]),
                "rate_peak": float(self.rate_peak[r]),
                "wheel_speed_peak": float(self.speed_peak[r]),
                "nees": float(self.nees_sum[r] / self.nees_count),
            }
            for cone in self.cones:
                metrics[f"keep_out_margin.{cone.name}"] = float(self.separation_min[cone.name][r] - cone.half_angle_rad)
            for source, peak in torque_peaks.items():
                metrics[f"disturbance_torque_peak.{source}"] = float(peak[r])
            run_history = None
            if self.stride:
                run_history = {name: values[r] for name, values in history.items()}
                run_history["t"] = history["t"][0]
            outputs.append(RunOutput(metrics, run_history))
        return outputs


def _per_axis_value(value: Any) -> float | tuple[float, ...]:
    """A scalar as a float, three per-axis values as a tuple of floats."""
    return float(value) if np.ndim(value) == 0 else tuple(float(v) for v in np.ravel(value))


class PDWheelsScenario:
    """Quaternion PD + reaction wheels, the controller seeing the truth; vectorisable.

    Parameters
    ----------
    inertia : array_like (3, 3) or RigidBody
        Nominal whole-spacecraft inertia [kg m^2] (the controller's design model).
    wheels : ReactionWheels
    q_start, q_target : array_like (4,)
        Nominal start and target attitudes ``q_BN``.
    bandwidth : float or array_like (3,)
        PD natural frequency, one or per body axis [rad/s].
    damping : float or array_like (3,)
        PD damping ratio, one or per body axis.
    period : float
        Control period and tick [s].
    duration : float
        Simulated time [s].
    pointing_threshold : float
        Error angle [rad] for the settling time.
    history_stride : int, optional
        Keep time histories every this many ticks.
    environment : OrbitEnvironment, optional
        The orbit the runs fly (module docstring); None: empty inertial space.

    Dispersion names it reads (all optional): ``inertia`` (3, 3),
    ``initial_attitude`` (4,), ``initial_rate`` (3,) [rad/s] and, in orbit,
    ``drag_scale``, ``residual_dipole`` (3,) [A m^2] and
    ``centre_of_pressure_offset`` (3,) [m] (:func:`surface_parameters`).
    """

    def __init__(
        self,
        inertia: Any,
        wheels: Any,
        q_start: Any,
        q_target: Any,
        *,
        bandwidth: Any,
        damping: Any,
        period: float,
        duration: float = 600.0,
        pointing_threshold: float = math.radians(0.05),
        history_stride: int | None = None,
        environment: OrbitEnvironment | None = None,
    ) -> None:
        if environment is not None and not isinstance(environment, OrbitEnvironment):
            raise ScenarioError(f"environment must be an OrbitEnvironment or None, got {type(environment).__name__}")
        self.environment = environment
        self.nominal = inertia if isinstance(inertia, RigidBody) else RigidBody(inertia)
        self.wheels = wheels
        self.q_start = quat.as_unit_quaternion(q_start, "q_start")
        self.q_target = quat.as_unit_quaternion(q_target, "q_target")
        # One value for all axes, or one per axis (kept as given: a tuple of three).
        self.bandwidth, self.damping = (_per_axis_value(v) for v in (bandwidth, damping))
        self.period = float(period)
        self.duration = float(duration)
        self.pointing_threshold = float(pointing_threshold)
        self.history_stride = history_stride
        self.controller = assembly.pd_from_bandwidth(
            self.nominal,
            bandwidth_rad_per_s=self.bandwidth,
            damping=self.damping,
            period_s=self.period,
            q_ref=self.q_target,
        )

    @classmethod
    def from_config(cls, config: SpacecraftConfig, *, environment: bool = False, **kwargs: Any) -> PDWheelsScenario:
        """The file's spacecraft, wheels, control bandwidth and slew (pointing threshold: its accuracy).

        Parameters
        ----------
        config : SpacecraftConfig
            The spacecraft file.
        environment : bool
            Fly the file's orbit environment (needs an ``[orbit]``; default False).
        **kwargs
            Other fields of the scenario.
        """
        c = config.control
        kwargs.setdefault("pointing_threshold", config.requirements.pointing_accuracy_rad)
        kwargs.setdefault("environment", _scenario_environment(config, environment))
        return cls(
            assembly.rigid_body(config),
            assembly.reaction_wheels(config),
            config.requirements.slew.q_start(),
            config.requirements.slew.q_target(),
            bandwidth=c.bandwidth_rad_per_s,
            damping=c.damping,
            period=c.period_s,
            **kwargs,
        )

    @property
    def fingerprint(self) -> str:
        return (
            f"PDWheelsScenario({self.nominal.inertia.tolist()}, {self.wheels!r}, {self.q_start.tolist()}, "
            f"{self.q_target.tolist()}, {self.bandwidth!r}, {self.damping!r}, {self.period!r}, {self.duration!r}, "
            f"{self.pointing_threshold!r}, {self.history_stride!r}"
            + (")" if self.environment is None else f", {self.environment.describe()!r})")
        )

    def initial_state(self, params: Mapping[str, Any]) -> tuple[Any, Any, Any]:
        """A run's inertia, start attitude and start rate: the dispersed values, else the nominal ones.

        Parameters
        ----------
        params : mapping
            The run's dispersed parameters (``inertia`` [kg m^2], ``initial_attitude``, ``initial_rate`` [rad/s]).

        Returns
        -------
        tuple
            ``(inertia (3, 3), q0 (4,), omega0 (3,))``.
        """
        inertia = params.get("inertia", self.nominal.inertia)
        return inertia, params.get("initial_attitude", self.q_start), params.get("initial_rate", np.zeros(3))

    def __call__(self, params: Mapping[str, Any], rng: np.random.Generator) -> RunOutput:
        inertia, q0, omega0 = self.initial_state(params)
        result = simulate(
            RigidBody(inertia),
            q0,
            omega0,
            self.duration,
            controller=self.controller,
            wheels=self.wheels,
            environment=self.environment,
            surface_parameters=surface_parameters(self.environment, params),
        )
        return RunOutput(closed_loop_metrics(result, self.pointing_threshold), _history(result, self.history_stride))

    def run_batch(
        self,
        params_list: Sequence[Mapping[str, Any]],
        rngs: Sequence[Any],
        progress: Callable[[float], None] | None = None,
    ) -> list[RunOutput]:
        """All runs at once (``run_campaign(..., vectorized=True)``): the same runs as :meth:`__call__`.

        Parameters
        ----------
        params_list : sequence of mapping
            The dispersed parameters of each run.
        rngs : sequence of numpy.random.Generator
            The generator of each run.
        progress : callable, optional
            ``progress(fraction)`` of the batch simulated, for the campaign's progress bar.
        """
        initial = [self.initial_state(p) for p in params_list]
        result = simulate_batch(
            RigidBody(np.stack([np.asarray(i[0], dtype=float) for i in initial])),
            np.stack([np.asarray(i[1], dtype=float) for i in initial]),
            np.stack([np.asarray(i[2], dtype=float) for i in initial]),
            self.duration,
            controller=self.controller,
            wheels=self.wheels,
            pointing_threshold=self.pointing_threshold,
            history_stride=self.history_stride,
            environment=self.environment,
            surface_parameters=(
                None
                if self.environment is None
                else np.stack([surface_parameters(self.environment, p) for p in params_list])
            ),
            progress=progress,
        )
        outputs = []
        for i in range(len(params_list)):
            if math.isfinite(result.diverged_at[i]):
                outputs.append(RunOutput(error=f"the closed loop diverged at t = {result.diverged_at[i]:.6g} s"))
                continue
            if result.info["step_rule_broken"][i]:
                bound = float(result.info["step_rule_error_bound_rad"][i])
                outputs.append(RunOutput(error=_STEP_RULE_ERROR.format(bound=attitude_error_text(bound))))
                continue
            history = None
            if self.history_stride:
                history = {"t": result.history_t, **{k: v[i] for k, v in result.histories.items()}}
            outputs.append(RunOutput({k: float(v[i]) for k, v in result.metrics.items()}, history))
        return outputs


def campaign_from_config(
    config: SpacecraftConfig | str | Path,
    runs: int | None = None,
    *,
    seed: int | None = None,
    duration: float | None = None,
    history_stride: int | None = 10,
    keep_out: bool = True,
    guidance: str = "plan",
    nodes: int = PLAN_NODES,
    consider_misalignment: bool = False,
    environment: bool = False,
    study: SlewStudy | None = None,
    plan_progress: bool | None = False,
) -> Campaign:
    """The campaign of a spacecraft file, not yet run: what :func:`run_campaign_from_config` runs.

    The scenario (:class:`ClosedLoopScenario`, its slew planned here), the
    file's dispersions, the run count, the seed and the requirements.

    Parameters
    ----------
    config : SpacecraftConfig or path
        The spacecraft (its ``[montecarlo]`` table gives the runs, the seed
        and the dispersions; without one, nothing is dispersed).
    runs : int, optional
        Overrides ``montecarlo.runs``.
    seed : int, optional
        Overrides ``montecarlo.seed`` (None and no table: drawn and recorded).
    duration : float, optional
        Simulated time per run [s] (:func:`run_campaign_from_config`; default: to the end of the hold).
    history_stride : int, optional
        Keep time histories every this many ticks (1: every tick; None: none).
    keep_out : bool
        Count the keep-out cones as requirements.
    guidance : {"plan", "eigenaxis"}
        What the closed loop flies (:class:`ClosedLoopScenario`).
    nodes : int
        Planner intervals of the planned guidance.
    consider_misalignment : bool
        Inflate the MEKF's tracker covariance by the tracker-misalignment dispersion.
    environment : bool
        Fly the file's orbit environment with the surface dispersions (:func:`run_campaign_from_config`).
    study : SlewStudy, optional
        The slew already planned for this file and ``nodes`` (:attr:`ClosedLoopScenario.study`); None plans it.
    plan_progress : bool or None
        A bar over the planner's starts (:class:`ClosedLoopScenario`; None: when stderr is a terminal).
    """
    if not isinstance(config, SpacecraftConfig):
        config = load_config(config)
    mc = config.montecarlo
    dispersions = {}
    if mc is not None:
        if not environment:
            declared = [name for name in SURFACE_DISPERSIONS if getattr(mc, name) is not None]
            if declared:
                raise ScenarioError(
                    f"montecarlo.{declared[0]} disperses the surface flown along the orbit, but the campaign does not "
                    "fly the environment: pass environment=True (attitude montecarlo --environment) or remove "
                    f"the key{'s' if len(declared) > 1 else ''} {', '.join('montecarlo.' + n for n in declared)}"
                )
        nominal = assembly.rigid_body(config).inertia
        surface = assembly.surface(config)
        dispersions = dispersions_from_config(
            mc,
            nominal,
            config.requirements.slew.q_start(),
            residual_dipole_Am2=np.zeros(3) if surface is None else surface.residual_dipole_Am2,
        )
    n = runs if runs is not None else (mc.runs if mc is not None else None)
    if n is None:
        raise ValueError("runs must be given when the spacecraft file has no [montecarlo] table")
    scenario = ClosedLoopScenario(
        config,
        duration=duration,
        history_stride=history_stride,
        guidance=guidance,
        nodes=nodes,
        consider_misalignment=consider_misalignment,
        environment=environment,
        study=study,
        plan_progress=plan_progress,
    )
    return Campaign(
        scenario,
        dispersions,
        runs=n,
        seed=seed if seed is not None else (mc.seed if mc is not None else None),
        requirements=requirements_from_config(config, keep_out=keep_out),
        input_file=(config.source, config.source_sha256) if config.source else None,
    )


def replay_from_config(
    config: SpacecraftConfig | str | Path,
    run: int,
    runs: int | None = None,
    *,
    vectorized: bool = False,
    seed: int | None = None,
    duration: float | None = None,
    keep_out: bool = True,
    guidance: str = "plan",
    nodes: int = PLAN_NODES,
    consider_misalignment: bool = False,
    environment: bool = False,
    study: SlewStudy | None = None,
) -> RunReplay:
    """One run of a file's campaign flown again, alone, with its history at every tick (``--replay``).

    The campaign is :func:`campaign_from_config`'s with the same arguments
    (give those the campaign was run with), so the run has the same
    parameters and the same generator: with ``vectorized`` as the campaign's,
    its metrics are that run's row bit for bit, except that a vectorised batch
    takes one RK4 sub-step count for all its runs from their initial rates
    (:func:`attitude.simulation.step_rule.batch_substeps`): when a fast
    run made its batch sub-step, a replayed run of that batch agrees to about
    1e-12 relative instead. On the other path they agree to rounding (README,
    "Monte Carlo campaigns").

    Parameters
    ----------
    config : SpacecraftConfig or path
        The spacecraft file.
    run : int
        The run's index, ``0 <= run < runs``.
    runs : int, optional
        The campaign's run count (default ``montecarlo.runs``): the run must be one of them.
    vectorized : bool
        Fly it as a vectorised campaign did (``run_batch`` on a batch of one).
    seed : int, optional
        The campaign's master seed (default ``montecarlo.seed``).
    duration : float
        Simulated time [s], the campaign's.
    keep_out : bool
        Count the keep-out cones as requirements, as the campaign did.
    guidance : {"plan", "eigenaxis"}
        What the closed loop flies, as in the campaign.
    nodes : int
        Planner intervals of the planned guidance, as in the campaign.
    consider_misalignment : bool
        As in the campaign (:class:`ClosedLoopScenario`).
    environment : bool
        As in the campaign: fly the file's orbit environment.
    study : SlewStudy, optional
        The campaign's planned slew (:attr:`ClosedLoopScenario.study`); None plans it again.

    Returns
    -------
    RunReplay
        With ``info["wheel_speed_limit"]``, each wheel's speed at its largest momentum [rad/s], and
        ``info["windows"]``, the requirements' windows [s] (end of the slew, start and end of the hold), for
        the figures.
    """
    if not isinstance(config, SpacecraftConfig):
        config = load_config(config)
    campaign = campaign_from_config(
        config,
        runs,
        seed=seed,
        duration=duration,
        history_stride=1,
        keep_out=keep_out,
        guidance=guidance,
        nodes=nodes,
        consider_misalignment=consider_misalignment,
        environment=environment,
        study=study,
    )
    replay = campaign.replay(run, vectorized=vectorized)
    wheels = assembly.reaction_wheels(config)
    replay.info["wheel_speed_limit"] = (np.asarray(wheels.momentum_max) / np.asarray(wheels.spin_inertia)).tolist()
    replay.info["windows"] = _windows_info(campaign.scenario.windows)
    replay.info["provenance"] = provenance(config.source, config.source_sha256)
    return replay


def _windows_info(windows: SlewWindows) -> dict[str, float]:
    """The requirements' windows for the figures [s]: end of the slew, start and end of the hold."""
    return {"slew_end_s": windows.slew_end_s, "hold_start_s": windows.hold_start_s, "hold_end_s": windows.hold_end_s}


#: Failing runs flown again at every tick for the envelope figures of :func:`run_campaign_from_config`.
FAILING_RUNS_REPLAYED = 3


def run_campaign_from_config(
    config: SpacecraftConfig | str | Path,
    runs: int | None = None,
    workers: int | None = None,
    scheduler: Any = None,
    out_dir: str | Path | None = None,
    *,
    seed: int | None = None,
    duration: float | None = None,
    history_stride: int | None = 10,
    progress: bool | None = None,
    figures: bool = True,
    keep_out: bool = True,
    guidance: str = "plan",
    nodes: int = PLAN_NODES,
    consider_misalignment: bool = False,
    vectorized: bool = False,
    resume: bool = True,
    environment: bool = False,
    study: SlewStudy | None = None,
) -> CampaignResult:
    """The campaign of a spacecraft file: what ``attitude montecarlo FILE`` runs.

    Parameters
    ----------
    config : SpacecraftConfig or path
        The spacecraft (its ``[montecarlo]`` table gives the runs, the seed
        and the dispersions; without one, nothing is dispersed).
    runs : int, optional
        Overrides ``montecarlo.runs``.
    workers : int, optional
        Local worker processes (default: all cores).
    scheduler : str or dask.distributed.Client, optional
        A Dask scheduler address ``tcp://HOST:PORT`` (or client) instead of local processes.
    out_dir : path, optional
        Where the table, statistics, histories, checkpoint and figures go.
    seed : int, optional
        Overrides ``montecarlo.seed`` (None and no table: drawn and recorded).
    duration : float, optional
        Simulated time per run [s], at least to the end of the requirements'
        hold (ScenarioError otherwise). Default: exactly that
        (:func:`attitude.app.assembly.judged_duration`: the planned slew, the
        settling time and the hold, as the design flies it).
    history_stride : int, optional
        Keep time histories every this many ticks (default 10: 1 s at 10 Hz).
    progress : bool, optional
        Progress bars on stderr: the planner's starts and the campaign's runs
        (:func:`attitude.montecarlo.campaign.run_campaign`; default: when
        stderr is a terminal; False: none).
    figures : bool
        Save ``figures/*.png`` into ``out_dir``.
    keep_out : bool
        Count the keep-out cones as requirements (default). The planned
        guidance steers around them; ``guidance="eigenaxis"`` cannot, and the
        default file's eigenaxis path enters its Sun cone on purpose, so
        judge that guidance with ``keep_out=False``.
    guidance : {"plan", "eigenaxis"}
        What the closed loop flies (:class:`ClosedLoopScenario`): the
        design's planned slew, tracked (default; planned once, here), or the
        eigenaxis rate-limited PD.
    nodes : int
        Planner intervals of the planned guidance (default :data:`PLAN_NODES`).
    consider_misalignment : bool
        Inflate the MEKF's tracker covariance by the tracker-misalignment
        dispersion (:class:`ClosedLoopScenario` Notes).
    vectorized : bool
        Advance the runs together in batches (:meth:`ClosedLoopScenario.run_batch`;
        each run's metrics equal the per-run path's to rounding), about
        four batches per worker (at least 100 runs a batch).
    resume : bool
        Resume the campaign checkpointed in ``out_dir`` (default); False starts afresh.
    environment : bool
        Fly the file's orbit environment with the surface dispersions of
        ``[montecarlo]`` (module docstring; ``attitude montecarlo
        --environment``). Default False: empty space, and a file that
        disperses the surface is refused (ScenarioError naming the key)
        rather than drawing values nobody flies.
    study : SlewStudy, optional
        The slew already planned for this file and ``nodes`` (the design's); None plans it.
    """
    if not isinstance(config, SpacecraftConfig):
        config = load_config(config)
    campaign = campaign_from_config(
        config,
        runs,
        seed=seed,
        duration=duration,
        history_stride=history_stride,
        keep_out=keep_out,
        guidance=guidance,
        nodes=nodes,
        consider_misalignment=consider_misalignment,
        environment=environment,
        plan_progress=progress,
        study=study,
    )
    n = campaign.runs
    runs_per_task = None
    if vectorized:
        # Several batches per worker (every core busy; a progress bar and checkpoints that move), but
        # not below 100 runs a batch, where the per-batch set-up would cost more than the runs.
        workers = workers or usable_cpus()
        runs_per_task = min(1000, max(math.ceil(n / (4 * workers)), min(n, 100)))
    result = run_campaign(
        campaign,
        workers=workers,
        scheduler=scheduler,
        out_dir=out_dir,
        progress=progress,
        vectorized=vectorized,
        runs_per_task=runs_per_task,
        resume=resume,
    )
    if out_dir is not None and figures:
        from attitude.montecarlo.plots import save_figures

        wheels = assembly.reaction_wheels(config)
        speed_limit = {"wheel speed limit": wheels.momentum_max / wheels.spin_inertia}  # [rad/s], per wheel
        # The failing runs' excursions at every tick (the table's histories are thinned): flown again alone.
        failing = np.flatnonzero((np.asarray(result.status) == "ok") & ~np.asarray(result.passed))
        overlays = {}
        if history_stride not in (None, 1):
            for run in failing[:FAILING_RUNS_REPLAYED]:
                replay = replay_from_config(
                    config,
                    int(run),
                    runs,
                    vectorized=vectorized,
                    seed=campaign.seed,  # the campaign's (drawn when neither the file nor the caller gave one)
                    duration=duration,
                    keep_out=keep_out,
                    guidance=guidance,
                    nodes=nodes,
                    consider_misalignment=consider_misalignment,
                    environment=environment,
                    study=campaign.scenario.study,
                )
                overlays[int(run)] = replay.history
        windows = _windows_info(campaign.scenario.windows)
        save_figures(
            result, Path(out_dir) / "figures", lines={"wheel_speed": speed_limit}, overlays=overlays, windows=windows
        )
    return result

"""Built-in Monte Carlo scenarios (top floor: ties ``attitude`` to ``controllers`` and ``estimation``).

Like :mod:`attitude.cli`, this module may import the controllers and the
estimators; :mod:`attitude.montecarlo` never does (a scenario is any callable
``scenario(params, rng)``).

:class:`ClosedLoopScenario`
    The spacecraft file's closed loop: dispersed plant, reaction wheels, a
    gyro and a star tracker (with dispersed misalignments) feeding an MEKF,
    and a quaternion PD (Wie-Lu rate-limited when the slew has a rate limit)
    designed on the *nominal* inertia, slewing from the start to the target
    attitude. Not vectorisable (the MEKF runs per sample in Python).
:class:`PDWheelsScenario`
    PD + wheels with the controller seeing the truth: runs per run in the
    engine's compiled path and, with ``run_batch``, all runs at once in
    :func:`attitude.montecarlo_batch.simulate_batch`.
:func:`run_campaign_from_config`
    What ``attitude montecarlo FILE`` calls: the campaign of the file's
    ``[montecarlo]`` table, written with its figures to an output directory.

Metrics (SI): ``settling_time`` [s] (first time after which the true error
angle stays within the pointing accuracy; inf if it never does),
``final_pointing_error`` [rad], ``peak_rate`` [rad/s],
``peak_wheel_speed`` [rad/s] (relative to the body), ``nees`` (mean
attitude NEES of the MEKF over the run, 3 degrees of freedom: about 3 for a
consistent filter) and ``keep_out_margin.<cone>`` [rad] (smallest angle
between boresight and direction minus the cone's half-angle over the run;
negative: the cone was entered).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from attitude import quaternion as quat
from attitude.config import SpacecraftConfig, load_config
from attitude.montecarlo import Campaign, CampaignResult, Requirement, RunOutput, run_campaign
from attitude.montecarlo_batch import closed_loop_metrics, simulate_batch
from attitude.montecarlo_dispersions import dispersions_from_config
from attitude.rigid_body import RigidBody
from attitude.sensors import Gyro
from attitude.simulation import Truth, simulate
from controllers.pd import QuaternionPD, RateLimitedPD
from estimation.consistency import nees
from estimation.mekf import MEKF, initial_covariance

__all__ = [
    "ClosedLoopScenario",
    "PDWheelsScenario",
    "requirements_from_config",
    "run_campaign_from_config",
]

#: Initial gyro-bias uncertainty of the MEKF [rad/s] (10 deg/h, above the MEMS preset's 8 deg/h in-run stability).
BIAS_SIGMA = math.radians(10.0) / 3600.0
#: Initial attitude uncertainty of the MEKF when the attitude is not dispersed [rad].
ATTITUDE_SIGMA = math.radians(1.0)


def requirements_from_config(config: SpacecraftConfig, *, keep_out: bool = True) -> tuple[Requirement, ...]:
    """The file's ``[requirements]`` as Monte Carlo pass/fail rules.

    ``pointing``: final pointing error <= pointing accuracy; ``settling``:
    settling time <= slew max time + settling time; ``rate``: peak rate <=
    the slew rate limit (when given); ``keep_out.<name>``: margin >= 0 for
    each keep-out cone (``keep_out=False`` leaves them out, e.g. for a
    controller that does not plan around them).
    """
    req = config.requirements
    out = [
        Requirement("final_pointing_error", max=req.pointing_accuracy_rad, name="pointing"),
        Requirement("settling_time", max=req.slew.max_time_s + req.settling_time_s, name="settling"),
    ]
    if req.slew.rate_max_rad_per_s is not None:
        out.append(Requirement("peak_rate", max=req.slew.rate_max_rad_per_s, name="rate"))
    if keep_out:
        for cone in req.keep_out:
            out.append(Requirement(f"keep_out_margin.{cone.name}", min=0.0, name=f"keep_out.{cone.name}"))
    return tuple(out)


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
    """A star tracker mounted with a small rotation ``theta`` [rad]: it reports ``q_BN ⊗ exp(theta/2)``."""

    def __init__(self, tracker: Any, theta: np.ndarray) -> None:
        self.tracker = tracker
        self.name = tracker.name
        self.period = tracker.period
        self._dq = quat.from_rotation_vector(np.asarray(theta, dtype=float))

    def measure(self, t: float, truth: Truth, rng: Any) -> Any:
        seen = Truth(truth.t, quat.multiply(truth.q, self._dq), truth.omega, truth.h_wheels)
        return self.tracker.measure(t, seen, rng)


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


class ClosedLoopScenario:
    """The spacecraft file's closed loop with an MEKF in the loop (module docstring).

    Parameters
    ----------
    config : SpacecraftConfig
        The spacecraft (nominal values; the campaign's dispersions perturb them).
    duration : float
        Simulated time [s] (default 600).
    history_stride : int, optional
        Keep time histories every this many ticks (None: metrics only).
    rate_margin : float
        The controller's slew-rate limit is ``rate_margin`` times the
        requirement's (default 0.9): the Wie-Lu bound holds for the design
        inertia and the true rate, so a dispersed inertia and a noisy rate
        estimate overshoot a limit set exactly at the requirement (by about
        0.5 % for the default spacecraft).

    Dispersion names it reads (all optional): ``inertia`` (3, 3) [kg m^2],
    ``initial_attitude`` (4,), ``initial_rate`` (3,) [rad/s],
    ``gyro_misalignment`` and ``star_tracker_misalignment`` (3,) [rad].
    """

    def __init__(
        self,
        config: SpacecraftConfig,
        duration: float = 600.0,
        history_stride: int | None = None,
        rate_margin: float = 0.9,
    ) -> None:
        if not 0.0 < rate_margin <= 1.0:
            raise ValueError(f"rate_margin must be in (0, 1], got {rate_margin!r}")
        self.rate_margin = float(rate_margin)
        self.config = config
        self.duration = float(duration)
        self.history_stride = history_stride
        self._nominal = config.body()
        self._wheels = config.wheels()
        self._tracker = config.star_tracker()
        slew = config.requirements.slew
        self._q_start = slew.q_start()
        self._q_target = slew.q_target()
        mc = config.montecarlo
        spread = None if mc is None or mc.initial_attitude is None else mc.initial_attitude.scale_si
        self._attitude_sigma = spread if spread else ATTITUDE_SIGMA
        if mc is not None and mc.initial_attitude is not None and mc.initial_attitude.distribution == "uniform_so3":
            self._attitude_sigma = math.pi  # unknown attitude: the tracker's first update must decide it
        if mc is not None and mc.initial_attitude is not None and mc.initial_attitude.distribution == "uniform":
            self._attitude_sigma = spread / math.sqrt(3.0)  # standard deviation of U(-h, h)

    @property
    def fingerprint(self) -> str:
        return (
            f"ClosedLoopScenario({self.config!r}, duration={self.duration!r}, stride={self.history_stride!r}, "
            f"rate_margin={self.rate_margin!r})"
        )

    def controller(self) -> Any:
        """The control law, designed on the nominal inertia."""
        c = self.config.control
        rate_max = self.config.requirements.slew.rate_max_rad_per_s
        if rate_max is not None:
            return RateLimitedPD.from_bandwidth(
                self._nominal,
                c.bandwidth_rad_per_s,
                c.damping,
                self.rate_margin * rate_max,
                c.period_s,
                q_ref=self._q_target,
            )
        return QuaternionPD.from_bandwidth(
            self._nominal, c.bandwidth_rad_per_s, c.damping, c.period_s, q_ref=self._q_target, gyroscopic=True
        )

    def gyro(self, misalignment: np.ndarray | None) -> Gyro:
        """The file's gyro with an extra misalignment rotation vector [rad]."""
        g = self.config.gyro_config
        figures = g.figures()
        if misalignment is not None:
            figures["misalignment_rad"] = np.asarray(figures.get("misalignment_rad", np.zeros(3))) + misalignment
        # Interval-mean samples (an integrating gyro): what the MEKF models.
        if g.preset is not None:
            return Gyro.preset(g.preset, period=g.period_s, sampling="mean", **figures)
        arw = figures.pop("arw_deg_per_sqrt_h")
        return Gyro.from_datasheet(arw, period=g.period_s, sampling="mean", **figures)

    def __call__(self, params: Mapping[str, Any], rng: np.random.Generator) -> RunOutput:
        body = RigidBody(params["inertia"]) if "inertia" in params else self._nominal
        q0 = params.get("initial_attitude", self._q_start)
        omega0 = params.get("initial_rate", np.zeros(3))
        gyro = self.gyro(params.get("gyro_misalignment"))
        tracker = self._tracker
        if "star_tracker_misalignment" in params:
            tracker = _MisalignedTracker(tracker, params["star_tracker_misalignment"])
        mekf = MEKF.from_sensors(
            gyro, self._tracker, q0=self._q_start, P0=initial_covariance(self._attitude_sigma, BIAS_SIGMA)
        )
        estimator = _RecordingEstimator(mekf)
        result = simulate(
            body,
            q0,
            omega0,
            self.duration,
            controller=self.controller(),
            wheels=self._wheels,
            sensors=[gyro, tracker],
            estimator=estimator,
            rng=rng,
        )
        metrics = closed_loop_metrics(result, self.config.requirements.pointing_accuracy_rad)
        q_hat = np.array(estimator.q)
        k = np.searchsorted(result.t, np.array(estimator.t))
        errors = quat.to_rotation_vector(quat.multiply(quat.conjugate(q_hat), quat.normalize(result.q[k])))
        metrics["nees"] = float(np.mean(nees(errors, np.array(estimator.P))))
        for cone in self.config.requirements.keep_out:
            separation = cone.separation(result.q)
            metrics[f"keep_out_margin.{cone.name}"] = float(np.min(separation) - cone.half_angle_rad)
        est_error = np.full(result.t.size, np.nan)
        est_error[k] = np.linalg.norm(errors, axis=-1)
        return RunOutput(metrics, _history(result, self.history_stride, {"estimation_error": est_error}))


class PDWheelsScenario:
    """Quaternion PD + reaction wheels, the controller seeing the truth; vectorisable.

    Parameters
    ----------
    inertia : array_like (3, 3) or RigidBody
        Nominal whole-spacecraft inertia [kg m^2] (the controller's design model).
    wheels : ReactionWheels
    q_start, q_target : array_like (4,)
        Nominal start and target attitudes ``q_BN``.
    bandwidth : float
        PD natural frequency [rad/s].
    damping : float
        PD damping ratio.
    period : float
        Control period and tick [s].
    duration : float
        Simulated time [s].
    pointing_threshold : float
        Error angle [rad] for the settling time.
    history_stride : int, optional
        Keep time histories every this many ticks.

    Dispersion names it reads (all optional): ``inertia`` (3, 3),
    ``initial_attitude`` (4,), ``initial_rate`` (3,) [rad/s].
    """

    def __init__(
        self,
        inertia: Any,
        wheels: Any,
        q_start: Any,
        q_target: Any,
        *,
        bandwidth: float,
        damping: float,
        period: float,
        duration: float = 600.0,
        pointing_threshold: float = math.radians(0.05),
        history_stride: int | None = None,
    ) -> None:
        self.nominal = inertia if isinstance(inertia, RigidBody) else RigidBody(inertia)
        self.wheels = wheels
        self.q_start = quat.as_unit_quaternion(q_start, "q_start")
        self.q_target = quat.as_unit_quaternion(q_target, "q_target")
        self.bandwidth, self.damping, self.period = float(bandwidth), float(damping), float(period)
        self.duration = float(duration)
        self.pointing_threshold = float(pointing_threshold)
        self.history_stride = history_stride
        self.controller = QuaternionPD.from_bandwidth(
            self.nominal, self.bandwidth, self.damping, self.period, q_ref=self.q_target, gyroscopic=True
        )

    @classmethod
    def from_config(cls, config: SpacecraftConfig, **kwargs: Any) -> PDWheelsScenario:
        """The file's spacecraft, wheels, control bandwidth and slew (pointing threshold: its accuracy)."""
        c = config.control
        kwargs.setdefault("pointing_threshold", config.requirements.pointing_accuracy_rad)
        return cls(
            config.body(),
            config.wheels(),
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
            f"{self.pointing_threshold!r}, {self.history_stride!r})"
        )

    def _initial(self, params: Mapping[str, Any]) -> tuple[Any, Any, Any]:
        inertia = params.get("inertia", self.nominal.inertia)
        return inertia, params.get("initial_attitude", self.q_start), params.get("initial_rate", np.zeros(3))

    def __call__(self, params: Mapping[str, Any], rng: np.random.Generator) -> RunOutput:
        inertia, q0, omega0 = self._initial(params)
        result = simulate(RigidBody(inertia), q0, omega0, self.duration, controller=self.controller, wheels=self.wheels)
        return RunOutput(closed_loop_metrics(result, self.pointing_threshold), _history(result, self.history_stride))

    def run_batch(self, params_list: Sequence[Mapping[str, Any]], rngs: Sequence[Any]) -> list[RunOutput]:
        initial = [self._initial(p) for p in params_list]
        result = simulate_batch(
            RigidBody(np.stack([np.asarray(i[0], dtype=float) for i in initial])),
            np.stack([np.asarray(i[1], dtype=float) for i in initial]),
            np.stack([np.asarray(i[2], dtype=float) for i in initial]),
            self.duration,
            controller=self.controller,
            wheels=self.wheels,
            pointing_threshold=self.pointing_threshold,
            history_stride=self.history_stride,
        )
        outputs = []
        for i in range(len(params_list)):
            if math.isfinite(result.diverged_at[i]):
                outputs.append(RunOutput(error=f"the closed loop diverged at t = {result.diverged_at[i]:.6g} s"))
                continue
            history = None
            if self.history_stride:
                history = {"t": result.history_t, **{k: v[i] for k, v in result.histories.items()}}
            outputs.append(RunOutput({k: float(v[i]) for k, v in result.metrics.items()}, history))
        return outputs


def run_campaign_from_config(
    config: SpacecraftConfig | str | Path,
    runs: int | None = None,
    workers: int | None = None,
    scheduler: Any = None,
    out_dir: str | Path | None = None,
    *,
    seed: int | None = None,
    duration: float = 600.0,
    history_stride: int | None = 10,
    progress: bool | None = None,
    figures: bool = True,
    keep_out: bool = True,
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
    duration : float
        Simulated time per run [s].
    history_stride : int, optional
        Keep time histories every this many ticks (default 10: 1 s at 10 Hz).
    progress : bool, optional
        Progress bar on stderr (default: when stderr is a terminal).
    figures : bool
        Save ``figures/*.png`` into ``out_dir``.
    keep_out : bool
        Count the keep-out cones as requirements (the built-in scenario flies
        an eigenaxis slew, which does not avoid them: the default file's
        slew enters its Sun cone on purpose, for the slew planner to fix).
    """
    if not isinstance(config, SpacecraftConfig):
        config = load_config(config)
    mc = config.montecarlo
    dispersions = {}
    if mc is not None:
        dispersions = dispersions_from_config(mc, config.body().inertia, config.requirements.slew.q_start())
    n = runs if runs is not None else (mc.runs if mc is not None else None)
    if n is None:
        raise ValueError("runs must be given when the spacecraft file has no [montecarlo] table")
    campaign = Campaign(
        ClosedLoopScenario(config, duration=duration, history_stride=history_stride),
        dispersions,
        runs=n,
        seed=seed if seed is not None else (mc.seed if mc is not None else None),
        requirements=requirements_from_config(config, keep_out=keep_out),
    )
    result = run_campaign(campaign, workers=workers, scheduler=scheduler, out_dir=out_dir, progress=progress)
    if out_dir is not None and figures:
        from attitude.montecarlo_plots import save_figures

        save_figures(result, Path(out_dir) / "figures")
    return result

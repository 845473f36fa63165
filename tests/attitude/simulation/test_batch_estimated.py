"""The vectorised closed loop with a gyro, a star tracker and an MEKF (attitude.simulation.batch_estimated).

There is no external reference here: the tests check agreement between independent implementations.

* Batch vs single run: run ``r`` of :func:`attitude.simulation.batch_estimated.simulate_batch_estimated`
  (truth step in C or numpy, :class:`attitude.sensors.GyroBatch` and
  :class:`attitude.rng.NormalStreams`, the numpy :class:`estimation.mekf.MEKFBatch`) against the
  single-run engine's Python path (:func:`attitude.simulation.engine.simulate` with the gyro, the
  star tracker and the filterpy-based :class:`estimation.mekf.MEKF`) driven by the same generator:
  the same random numbers and equations, so truth and estimate agree to rounding.
* Back ends: the compiled and numpy truth steps agree to rounding.
* Bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.config import default_config
from attitude.rigid_body import RigidBody
from attitude.rng import NormalStreams
from attitude.sensors import GyroBatch
from attitude.simulation.batch_estimated import simulate_batch_estimated
from attitude.simulation.engine import simulate
from controllers.pd import QuaternionPD
from estimation.mekf import MEKF, MEKFBatch, initial_covariance

CONFIG = default_config()
BODY = assembly.rigid_body(CONFIG)
WHEELS = assembly.reaction_wheels(CONFIG)
Q_START = CONFIG.requirements.slew.q_start()
CONTROLLER = QuaternionPD.from_bandwidth(
    BODY,
    wn=0.3,
    zeta=0.8,
    period=0.1,
    q_ref=quat.multiply(Q_START, quat.from_rotation_vector([0.0, 0.0, 0.2])),
    gyroscopic=True,
)
P0 = initial_covariance(attitude_sigma=math.radians(0.5), bias_sigma=math.radians(10.0) / 3600.0)
N_RUNS = 4
DURATION = 40.0


def _setup(seed: int = 11):
    rng = np.random.default_rng(seed)
    moments = BODY.principal_axes().moments * (1.0 + 0.05 * rng.standard_normal((N_RUNS, 3)))
    axes = BODY.principal_axes().axes_B
    inertia = np.einsum("ij,nj,kj->nik", axes, moments, axes)
    q0 = quat.multiply(Q_START, quat.from_rotation_vector(0.005 * rng.standard_normal((N_RUNS, 3))))
    omega0 = 5e-4 * rng.standard_normal((N_RUNS, 3))
    mounting = quat.from_rotation_vector(1e-4 * rng.standard_normal((N_RUNS, 3)))
    seeds = np.random.SeedSequence(seed).spawn(N_RUNS)
    return inertia, q0, omega0, mounting, seeds


def _run_batch(inertia, q0, omega0, seeds, duration, **kwargs):
    """The batch with fresh sensors, filter and streams (gyros and filters are stateful)."""
    tracker = assembly.star_tracker(CONFIG)
    gyros = [assembly.gyro(CONFIG, sampling="mean") for _ in range(len(seeds))]
    mekf = MEKF.from_sensors(gyros[0], tracker, q0=Q_START, P0=P0)
    return simulate_batch_estimated(
        RigidBody(inertia),
        q0,
        omega0,
        duration,
        controller=CONTROLLER,
        wheels=WHEELS,
        gyro=GyroBatch(gyros),
        tracker=tracker,
        estimator=MEKFBatch(mekf, len(seeds)),
        streams=NormalStreams([np.random.default_rng(s) for s in seeds]),
        **kwargs,
    )


class _Mounted:
    """The tracker seen through a mounting rotation (what the batch's ``tracker_mounting`` models)."""

    def __init__(self, tracker, dq):
        self.tracker, self.name, self.period, self.dq = tracker, tracker.name, tracker.period, dq

    def measure(self, t, truth, rng):
        from attitude.simulation.protocols import Truth

        return self.tracker.measure(t, Truth(truth.t, quat.multiply(truth.q, self.dq), truth.omega, None), rng)


@pytest.fixture(scope="module")
def batch_and_singles():
    inertia, q0, omega0, mounting, seeds = _setup()
    tracker = assembly.star_tracker(CONFIG)
    seen = {"q_hat": [], "updated": 0}

    def observer(k, t, x, q_hat, w_hat, updated):
        seen["q_hat"].append(q_hat.copy())
        seen["updated"] += int(updated)

    out = _run_batch(inertia, q0, omega0, seeds, DURATION, tracker_mounting=mounting, observer=observer)
    singles = []
    for r in range(N_RUNS):
        gyro = assembly.gyro(CONFIG, sampling="mean")
        singles.append(
            simulate(
                RigidBody(inertia[r]),
                q0[r],
                omega0[r],
                DURATION,
                controller=CONTROLLER,
                wheels=WHEELS,
                sensors=[gyro, _Mounted(tracker, mounting[r])],
                estimator=MEKF.from_sensors(gyro, tracker, q0=Q_START, P0=P0),
                rng=np.random.default_rng(seeds[r]),
                engine="python",
            )
        )
    return out, np.array(seen["q_hat"]), seen["updated"], singles


def test_each_run_of_the_batch_is_the_single_run_engine_with_its_generator(batch_and_singles):
    out, q_hat, updated, singles = batch_and_singles
    assert updated == round(DURATION / 0.1) + 1
    assert np.all(np.isnan(out["diverged_at"]))
    for r, single in enumerate(singles):
        # Same numbers drawn, same equations: the truth step by C/numpy instead of casadi's virtual
        # machine and the filter by numpy instead of filterpy differ in rounding only, and the loop
        # is stable, so the differences stay at the 1e-12 level over 400 ticks.
        np.testing.assert_allclose(out["x"][r, :7], np.concatenate([single.q[-1], single.omega[-1]]), atol=1e-11)
        np.testing.assert_allclose(out["x"][r, 7:], single.h_wheels[-1], rtol=1e-9, atol=1e-13)
        errors = quat.error_angle(q_hat[:, r], single.estimate_q)
        assert np.max(errors) < 1e-10


def test_compiled_and_numpy_truth_steps_agree():
    inertia, q0, omega0, _, seeds = _setup(5)
    finals = {}
    for backend in ("compiled", "numpy"):
        out = _run_batch(inertia, q0, omega0, seeds, 10.0, backend=backend)
        assert out["backend"] == backend
        finals[backend] = out["x"]
    # Rounding only (C vs numpy evaluation of the same component expressions).
    np.testing.assert_allclose(finals["compiled"], finals["numpy"], rtol=1e-9, atol=1e-13)


def test_bad_arguments_are_named():
    inertia, q0, omega0, _, seeds = _setup()
    with pytest.raises(ValueError, match="whole number"):
        _run_batch(inertia, q0, omega0, seeds, 1.05)
    with pytest.raises(ValueError, match="batch of inertias"):
        _run_batch(BODY.inertia, q0, omega0, seeds, 1.0)
    with pytest.raises(ValueError, match="backend"):
        _run_batch(inertia, q0, omega0, seeds, 1.0, backend="gpu")
    with pytest.raises(ValueError, match="tracker_mounting"):
        _run_batch(inertia, q0, omega0, seeds, 1.0, tracker_mounting=np.ones((2, 4)))
    with pytest.raises(ValueError, match="progress must be callable"):
        _run_batch(inertia, q0, omega0, seeds, 1.0, progress="bar")


def test_progress_reports_each_tick_and_changes_no_number(monkeypatch):
    """With every report let through (no wait between reports), the callback sees ``k / n_ticks`` at each
    tick ``k``; the final states are the same bits as without it."""
    import attitude.progress

    monkeypatch.setattr(attitude.progress, "REFRESH_PERIOD_S", 0.0)
    inertia, q0, omega0, _, seeds = _setup(5)
    reference = _run_batch(inertia, q0, omega0, seeds, 10.0)
    fractions: list[float] = []
    reported = _run_batch(inertia, q0, omega0, seeds, 10.0, progress=fractions.append)
    np.testing.assert_array_equal(reported["x"], reference["x"])
    n_ticks = 100  # 10 s at the gyro's 0.1 s
    assert fractions == [k / n_ticks for k in range(n_ticks + 1)]


def test_a_run_that_outgrew_the_step_rule_mid_run_is_flagged():
    """The step-size rule after the run (docs/rk4_step_rule.md): a run whose peak rate breaks it is flagged.

    The slew raises each run's rate well above its initial rate, which is all the check before the run
    sees. The budget is set between the two predictions: below the bound at the run's peak rate, above the
    one at its initial rate (both from :mod:`attitude.simulation.step_rule`), so the check before the run
    passes and only the check after it can catch the run. Before, the batch never looked after the run.
    """
    from attitude.simulation.plant import PlantModel
    from attitude.simulation.step_rule import batch_broken

    inertia, q0, omega0, _, seeds = _setup()
    peaks = np.linalg.norm(omega0, axis=1)

    def record_peak(k, tk, x, q_hat, w_hat, updated):
        np.fmax(peaks, np.linalg.norm(x[:, 4:7], axis=1), out=peaks)

    n_ticks = round(DURATION / 0.1)
    _run_batch(inertia, q0, omega0, seeds, DURATION, observer=record_peak, attitude_error_budget_rad=np.inf)
    model = PlantModel(WHEELS.hub_body(RigidBody(inertia)), WHEELS)
    _, bound_peak = batch_broken(model, peaks, 0.1, n_ticks, 1, np.inf)
    _, bound_start = batch_broken(model, np.linalg.norm(omega0, axis=1), 0.1, n_ticks, 1, np.inf)
    budget = float(np.sqrt(np.min(bound_peak) * np.max(bound_start) * 1e4))  # a decade or two inside the gap
    assert np.max(bound_start) * 10 < budget < np.min(bound_peak) / 10  # the premise: a wide gap
    with pytest.warns(Warning) as caught:
        out = _run_batch(inertia, q0, omega0, seeds, DURATION, attitude_error_budget_rad=budget)
    assert out["step_rule_broken"].all() and not out["step_rule_refused"].any()
    assert np.allclose(out["step_rule_error_bound_rad"], bound_peak)
    assert any("broken the step-size rule mid-run" in str(w.message) for w in caught)

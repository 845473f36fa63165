"""The vectorised closed loops in orbit: the environment's disturbance torques in the batch kernels.

No external reference: agreement between independent code paths of the same definitions
(:meth:`attitude.environment.OrbitEnvironment.torque_components`, evaluated by casadi's virtual
machine in the single-run engine, by generated C in the compiled tick, by numpy on arrays of runs).

* :func:`attitude.simulation.batch.simulate_batch` with ``environment=`` and per-run
  ``surface_parameters=`` against :func:`attitude.simulation.engine.simulate` with the same
  environment and parameters, run by run, both back ends: final state, metrics and the per-source
  torque histories (``disturbance.<source>``) to rounding; the environment changes the runs by
  far more than that (the test is not vacuous).
* :func:`attitude.simulation.batch_estimated.simulate_batch_estimated` in orbit against the
  single-run engine's Python path with the same sensors, filter and generator.
* The compiled-kernel cache: keyed by the environment's structure (sources, plates, ``mu``),
  never by the track (another orbit and field reuse the kernel, and still agree with the
  single-run engine in that orbit).
* Bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from attitude import quaternion as quat
from attitude.app import assembly
from attitude.config import default_config
from attitude.environment import CircularOrbit, OrbitEnvironment, TiltedDipole
from attitude.rigid_body import RigidBody
from attitude.rng import NormalStreams
from attitude.sensors import GyroBatch
from attitude.simulation import batch as mb
from attitude.simulation.batch import closed_loop_metrics, simulate_batch
from attitude.simulation.batch_estimated import simulate_batch_estimated
from attitude.simulation.build_cache import BuildCache
from attitude.simulation.engine import simulate
from attitude.simulation.kernel import environment_key
from controllers.pd import QuaternionPD
from estimation.mekf import MEKF, MEKFBatch, initial_covariance

CONFIG = default_config()
BODY = assembly.rigid_body(CONFIG)
WHEELS = assembly.reaction_wheels(CONFIG)
Q_START = CONFIG.requirements.slew.q_start()
Q_TARGET = CONFIG.requirements.slew.q_target()
THRESHOLD = CONFIG.requirements.pointing_accuracy_rad
ENVIRONMENT = assembly.orbit_environment(CONFIG)  # 500 km SSO, IGRF, exponential atmosphere, all four torques
# 5 Hz control on a 10 Hz tick (the engine's Python path), and at the tick (its compiled path).
CONTROLLERS = {
    "python": QuaternionPD.from_bandwidth(BODY, wn=0.3, zeta=0.8, period=0.2, q_ref=Q_TARGET, gyroscopic=True),
    "compiled": QuaternionPD.from_bandwidth(BODY, wn=0.3, zeta=0.8, period=0.1, q_ref=Q_TARGET, gyroscopic=True),
}
N_RUNS = 4
DURATION = 30.0
STRIDE = 7


def _runs(n: int = N_RUNS, seed: int = 3):
    """Dispersed inertias, starts and surfaces: dipoles of about 1 A m^2 so the magnetic torque (3e-5 N m) shows."""
    rng = np.random.default_rng(seed)
    moments = BODY.principal_axes().moments * (1.0 + 0.05 * rng.standard_normal((n, 3)))
    axes = BODY.principal_axes().axes_B
    inertia = np.einsum("ij,nj,kj->nik", axes, moments, axes)
    q0 = quat.multiply(Q_START, quat.from_rotation_vector(0.01 * rng.standard_normal((n, 3))))
    omega0 = 1e-3 * rng.standard_normal((n, 3))
    surface = np.array(
        [
            ENVIRONMENT.surface_parameters(
                drag_scale=1.0 + 0.3 * rng.standard_normal(),
                residual_dipole_Am2=rng.standard_normal(3),
                centre_of_pressure_offset_B_m=0.05 * rng.standard_normal(3),
            )
            for _ in range(n)
        ]
    )
    return inertia, q0, omega0, surface


@pytest.fixture(scope="module")
def singles():
    """The single-run engine in orbit, each run with its own surface parameters (both engine paths)."""
    inertia, q0, omega0, surface = _runs()
    out = {}
    for path, controller in CONTROLLERS.items():
        out[path] = [
            simulate(
                RigidBody(inertia[i]),
                q0[i],
                omega0[i],
                DURATION,
                controller=controller,
                wheels=WHEELS,
                dt=0.1,
                substeps=2,
                environment=ENVIRONMENT,
                surface_parameters=surface[i],
            )
            for i in range(N_RUNS)
        ]
        assert {s.info["engine"] for s in out[path]} == {path}
    return out


@pytest.mark.parametrize("path", ["python", "compiled"])
@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_batch_in_orbit_agrees_with_the_single_run_engine_run_by_run(backend, path, singles):
    inertia, q0, omega0, surface = _runs()
    result = simulate_batch(
        RigidBody(inertia),
        q0,
        omega0,
        DURATION,
        controller=CONTROLLERS[path],
        wheels=WHEELS,
        dt=0.1,
        substeps=2,
        pointing_threshold=THRESHOLD,
        history_stride=STRIDE,
        backend=backend,
        environment=ENVIRONMENT,
        surface_parameters=surface,
    )
    assert result.info["backend"] == backend
    assert set(result.histories) == {"error_angle", "omega", "wheel_speed"} | {
        f"disturbance.{s}" for s in ENVIRONMENT.sources
    }
    for i, single in enumerate(singles[path]):
        # The same component arithmetic by C or numpy instead of casadi's virtual machine, summed in
        # another order: rounding only (measured: q 3e-16, omega 1.5e-16 rad/s, h 5e-17 N m s, torques
        # 1.4e-15 of their size over 300 ticks).
        np.testing.assert_allclose(result.q[i], single.q[-1], atol=1e-13)
        np.testing.assert_allclose(result.omega[i], single.omega[-1], atol=1e-14)
        np.testing.assert_allclose(result.h_wheels[i], single.h_wheels[-1], rtol=1e-10, atol=1e-15)
        for name, value in closed_loop_metrics(single, THRESHOLD).items():
            np.testing.assert_allclose(result.metrics[name][i], value, rtol=1e-9, atol=1e-15, err_msg=name)
        for source, tau in single.disturbance_torques.items():
            recorded = result.histories[f"disturbance.{source}"][i]
            np.testing.assert_allclose(recorded, tau[::STRIDE], rtol=0, atol=1e-12 * np.abs(tau).max(), err_msg=source)
    np.testing.assert_array_equal(result.history_t, np.arange(0, 301, STRIDE) * 0.1)


def test_the_environment_changes_the_runs_far_beyond_rounding(singles):
    """Without the environment the final rates differ by 1e-7 to 1e-6 rad/s: 1e7 times the agreement above."""
    inertia, q0, omega0, _ = _runs()
    empty = simulate_batch(
        RigidBody(inertia), q0, omega0, DURATION, controller=CONTROLLERS["python"], wheels=WHEELS, dt=0.1, substeps=2
    )
    in_orbit = np.array([s.omega[-1] for s in singles["python"]])
    assert np.min(np.max(np.abs(empty.omega - in_orbit), axis=1)) > 1e-7
    magnetic = np.array([np.abs(s.disturbance_torques["magnetic"]).max() for s in singles["python"]])
    assert np.all(magnetic > 1e-5)  # N m: about 1 A m^2 across 20-50 uT


def test_batch_with_an_estimator_in_orbit_is_the_single_run_engine_with_its_generator():
    n, duration = 3, 20.0
    inertia, q0, omega0, surface = _runs(n, seed=5)
    controller = QuaternionPD.from_bandwidth(
        BODY, wn=0.3, zeta=0.8, period=0.1, q_ref=quat.multiply(Q_START, quat.from_rotation_vector([0, 0, 0.2]))
    )
    p0 = initial_covariance(attitude_sigma=math.radians(0.5), bias_sigma=math.radians(10.0) / 3600.0)
    seeds = np.random.SeedSequence(7).spawn(n)
    tracker = assembly.star_tracker(CONFIG)
    finals = {}
    for backend in ("compiled", "numpy"):
        gyros = [assembly.gyro(CONFIG, sampling="mean") for _ in range(n)]
        out = simulate_batch_estimated(
            RigidBody(inertia),
            q0,
            omega0,
            duration,
            controller=controller,
            wheels=WHEELS,
            gyro=GyroBatch(gyros),
            tracker=tracker,
            estimator=MEKFBatch(MEKF.from_sensors(gyros[0], tracker, q0=Q_START, P0=p0), n),
            streams=NormalStreams([np.random.default_rng(s) for s in seeds]),
            backend=backend,
            environment=ENVIRONMENT,
            surface_parameters=surface,
        )
        assert out["backend"] == backend
        finals[backend] = out
    for r in range(n):
        gyro = assembly.gyro(CONFIG, sampling="mean")
        single = simulate(
            RigidBody(inertia[r]),
            q0[r],
            omega0[r],
            duration,
            controller=controller,
            wheels=WHEELS,
            sensors=[gyro, tracker],
            estimator=MEKF.from_sensors(gyro, tracker, q0=Q_START, P0=p0),
            rng=np.random.default_rng(seeds[r]),
            engine="python",
            environment=ENVIRONMENT,
            surface_parameters=surface[r],
        )
        for out in finals.values():
            # Same draws and equations; truth by C/numpy, filter by numpy vs filterpy: rounding
            # (measured 3.5e-17 on the state, 8e-21 N m on the torques).
            np.testing.assert_allclose(out["x"][r, :7], np.concatenate([single.q[-1], single.omega[-1]]), atol=1e-12)
            np.testing.assert_allclose(out["x"][r, 7:], single.h_wheels[-1], rtol=1e-9, atol=1e-14)
            for source, tau in single.disturbance_torques.items():
                size = np.abs(tau).max()
                np.testing.assert_allclose(out["disturbance_torques"][source][r], tau[-1], atol=1e-12 * size)
                peak = np.max(np.linalg.norm(tau, axis=1))
                np.testing.assert_allclose(out["disturbance_torque_peak"][source][r], peak, rtol=1e-12)


def _fake_ticks(monkeypatch):
    """Count the kernels built (no compiler needed: the cache is what is tested here)."""
    built = []

    class Fake:
        def __init__(self, *args):
            built.append(args)

    monkeypatch.setattr(mb, "_TICKS_CACHE", BuildCache(4))
    monkeypatch.setattr(mb, "CompiledTicks", Fake)
    return built


def test_the_kernel_cache_keys_on_the_environment_structure_not_its_track(monkeypatch):
    built = _fake_ticks(monkeypatch)
    other_orbit = dataclasses.replace(
        ENVIRONMENT,
        orbit=CircularOrbit.from_altitude(700e3, inclination=math.radians(51.6), epoch=ENVIRONMENT.epoch),
        magnetic_field=TiltedDipole(ENVIRONMENT.epoch),
        eclipse="cylindrical",
    )
    gravity_only = dataclasses.replace(ENVIRONMENT, sources=("gravity_gradient",))
    no_surface = OrbitEnvironment(ENVIRONMENT.orbit, surface=None, sources=("gravity_gradient",))
    args = (WHEELS, CONTROLLERS["compiled"], 1, True, 2)
    first = mb._compiled_ticks(*args, ENVIRONMENT)
    assert mb._compiled_ticks(*args, other_orbit) is first  # another track, the same kernel
    assert environment_key(other_orbit) == environment_key(ENVIRONMENT)
    kernels = {id(mb._compiled_ticks(*args, e)) for e in (None, gravity_only, no_surface)}
    assert len(kernels) == 3 and id(first) not in kernels
    assert len(built) == 4
    assert environment_key(gravity_only)[0] == ("gravity_gradient",)
    assert environment_key(no_surface)[1] is None and environment_key(gravity_only)[1] is not None


def test_a_cached_kernel_flies_another_orbit_as_the_single_run_engine():
    """The track is an input of the compiled tick: a kernel built for one orbit flies another one exactly."""
    other = dataclasses.replace(
        ENVIRONMENT,
        orbit=CircularOrbit.from_altitude(400e3, inclination=math.radians(51.6), epoch=ENVIRONMENT.epoch),
        magnetic_field=TiltedDipole(ENVIRONMENT.epoch),
    )
    inertia, q0, omega0, surface = _runs(2, seed=9)
    common = dict(controller=CONTROLLERS["compiled"], wheels=WHEELS, dt=0.1, substeps=2, backend="compiled")
    batch = {
        name: simulate_batch(
            RigidBody(inertia), q0, omega0, 10.0, environment=env, surface_parameters=surface[0], **common
        )
        for name, env in (("nominal", ENVIRONMENT), ("other", other))
    }
    assert not np.allclose(batch["nominal"].omega, batch["other"].omega, rtol=0, atol=1e-9)
    for i in range(2):
        single = simulate(
            RigidBody(inertia[i]),
            q0[i],
            omega0[i],
            10.0,
            controller=CONTROLLERS["compiled"],
            wheels=WHEELS,
            dt=0.1,
            substeps=2,
            environment=other,
            surface_parameters=surface[0],
        )
        np.testing.assert_allclose(batch["other"].omega[i], single.omega[-1], atol=1e-14)


def test_bad_environment_arguments_name_the_argument_the_rule_and_the_value():
    inertia, q0, omega0, surface = _runs(2)
    common = dict(controller=CONTROLLERS["compiled"], wheels=WHEELS, backend="numpy")
    with pytest.raises(ValueError, match=r"surface_parameters need an environment"):
        simulate_batch(RigidBody(inertia), q0, omega0, 1.0, surface_parameters=surface, **common)
    with pytest.raises(ValueError, match=r"environment must be an OrbitEnvironment or None, got str"):
        simulate_batch(RigidBody(inertia), q0, omega0, 1.0, environment="leo", **common)
    with pytest.raises(ValueError, match=r"surface_parameters .*must have shape \(2, 7\) or \(7,\), got \(2, 3\)"):
        simulate_batch(
            RigidBody(inertia), q0, omega0, 1.0, environment=ENVIRONMENT, surface_parameters=surface[:, :3], **common
        )
    bad = surface.copy()
    bad[1, 0] = -0.5
    with pytest.raises(ValueError, match=r"drag_scale \(column 0\) must be >= 0, got -0.5 \(run 1\)"):
        simulate_batch(RigidBody(inertia), q0, omega0, 1.0, environment=ENVIRONMENT, surface_parameters=bad, **common)


@pytest.mark.parametrize("backend", ["compiled", "numpy"])
def test_gravity_gradient_acts_on_the_wheels_spin_inertia_too(backend):
    """Orthogonal wheels of unequal spin inertia (sum J a a^T not isotropic): the batch's gravity gradient
    is the single-run engine's, on the whole spacecraft, and differs from the hub body's.

    Gravity gradient ``3 mu / r^5 r x (I r)`` (Wie, *Space Vehicle Dynamics and Control*, sec. 6.4) with
    ``I`` the whole spacecraft: the rotors spin about their axes but their mass distribution still feels
    the gradient. A pyramid at the magic angle hides the difference (its sum J a a^T is a multiple of 1,
    which adds no torque), so these wheels are deliberately unequal.
    """
    from attitude.actuators import ReactionWheels

    wheels = ReactionWheels.orthogonal(spin_inertia=[0.01, 0.05, 0.3], torque_max=0.05, momentum_max=1.0)
    body = RigidBody(np.diag([8.0, 10.0, 4.0]))
    env = OrbitEnvironment(CircularOrbit.from_altitude(500e3), sources=("gravity_gradient",), atmosphere=None)
    q0 = quat.from_rotation_vector(np.array([[0.3, -0.2, 0.5], [0.1, 0.4, -0.3]]))
    pd = QuaternionPD.from_bandwidth(body, wn=0.3, zeta=0.8, period=0.1, q_ref=q0[0], gyroscopic=True)
    common = dict(controller=pd, wheels=wheels, dt=0.1, environment=env)
    batch = simulate_batch(body, q0, np.zeros(3), 20.0, history_stride=1, backend=backend, **common)
    for i in range(2):
        single = simulate(body, q0[i], np.zeros(3), 20.0, **common)
        tau = single.disturbance_torques["gravity_gradient"]
        # Rounding only, as the test above.
        np.testing.assert_allclose(
            batch.histories["disturbance.gravity_gradient"][i], tau, atol=1e-12 * np.abs(tau).max()
        )
        np.testing.assert_allclose(batch.q[i], single.q[-1], atol=1e-13)
        # The hub body's torque differs at the percent level: the check above can tell them apart.
        hub = env.torques_B(wheels.hub_body(body), single.q, env.track(single.t))["gravity_gradient"]
        assert np.max(np.abs(hub - tau)) > 1e-3 * np.abs(tau).max()

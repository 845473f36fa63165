"""The built-in Monte Carlo scenarios in orbit (attitude.app.scenarios with ``environment=True``).

No external reference: agreement between code paths of the same definitions.

* :class:`ClosedLoopScenario` in orbit: the vectorised path (:meth:`run_batch`, the batch kernels
  with the environment) gives each run's metrics as the per-run path (the single-run engine in
  orbit) to rounding, with the surface parameters drawn from the file's dispersions; the
  environment changes the runs (not vacuous); the guidance still starts at the file's start
  attitude and is judged against its target.
* :class:`PDWheelsScenario` in orbit: the compiled batch kernel against the single-run engine.
* Switching the environment on changes the fingerprint (a checkpoint is not resumed across it),
  off leaves it as before; clear errors for a file without an orbit and for surface dispersions
  in a campaign that does not fly the environment.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from attitude.app import assembly
from attitude.app.scenarios import (
    ClosedLoopScenario,
    PDWheelsScenario,
    ScenarioError,
    run_campaign_from_config,
    surface_parameters,
)
from attitude.config import default_config
from attitude.config.model import Dispersion as DispersionConfig
from attitude.environment import DISTURBANCE_SOURCES
from attitude.montecarlo.dispersions import dispersions_from_config, draw_parameters

BASE = default_config()
# A short settling requirement so a planned run is short (the planned slew takes 39 s).
CONFIG = dataclasses.replace(
    BASE,
    requirements=dataclasses.replace(BASE.requirements, settling_time_s=5.0, hold_time_s=1.0),
    montecarlo=dataclasses.replace(
        BASE.montecarlo,
        drag_scale=DispersionConfig("normal", 20.0, "percent"),
        residual_dipole=DispersionConfig("normal", 0.5, "Am2"),  # large, so the magnetic torque shows
        centre_of_pressure_offset=DispersionConfig("uniform", 0.02, "m"),
    ),
)
N_RUNS = 2


def _params(n: int = N_RUNS):
    dispersions = dispersions_from_config(
        CONFIG.montecarlo,
        assembly.rigid_body(CONFIG).inertia,
        CONFIG.requirements.slew.q_start(),
        residual_dipole_Am2=assembly.surface(CONFIG).residual_dipole_Am2,
    )
    return [draw_parameters(dispersions, 12345, i) for i in range(n)]


@pytest.fixture(scope="module")
def scenarios():
    in_orbit = ClosedLoopScenario(CONFIG, duration=45.0, nodes=30, environment=True)
    empty = ClosedLoopScenario(CONFIG, duration=45.0, nodes=30, study=None)
    return in_orbit, empty


def test_closed_loop_in_orbit_batch_agrees_with_the_per_run_path(scenarios):
    in_orbit, empty = scenarios
    params = _params()
    batch = in_orbit.run_batch(params, [np.random.default_rng(i) for i in range(N_RUNS)])
    for i, p in enumerate(params):
        single = in_orbit(p, np.random.default_rng(i))
        assert batch[i].error is None and set(single.metrics) == set(batch[i].metrics)
        for source in DISTURBANCE_SOURCES:
            assert single.metrics[f"disturbance_torque_peak.{source}"] > 0.0
        for name, value in single.metrics.items():
            # Same draws and equations; C/numpy vs casadi and numpy vs filterpy: rounding (measured
            # <= 4e-13 relative on the NEES, 1e-15 rad on the pointing error, 1e-22 N m on the torques).
            np.testing.assert_allclose(batch[i].metrics[name], value, rtol=1e-9, atol=1e-15, err_msg=name)
        # The environment changes the run: without it the final pointing error differs.
        alone = empty(p, np.random.default_rng(i))
        assert "disturbance_torque_peak.magnetic" not in alone.metrics
        assert abs(alone.metrics["final_pointing_error"] - single.metrics["final_pointing_error"]) > 1e-9
    # The scenario's guidance is the file's: from its start attitude to its target (inertial).
    assert in_orbit.slew_end == empty.slew_end
    np.testing.assert_array_equal(in_orbit._q_start, CONFIG.requirements.slew.q_start())


def test_pd_wheels_in_orbit_batch_agrees_with_the_per_run_path():
    scenario = PDWheelsScenario.from_config(CONFIG, duration=10.0, environment=True)
    params = _params(3)
    batch = scenario.run_batch(params, [None] * 3)
    for i, p in enumerate(params):
        single = scenario(p, None)
        for name, value in single.metrics.items():
            np.testing.assert_allclose(batch[i].metrics[name], value, rtol=1e-9, atol=1e-15, err_msg=name)
    sp = surface_parameters(scenario.environment, params[0])
    assert sp[0] == params[0]["drag_scale"]
    np.testing.assert_array_equal(sp[1:4], params[0]["residual_dipole"])
    np.testing.assert_array_equal(sp[4:7], params[0]["centre_of_pressure_offset"])
    nominal = surface_parameters(scenario.environment, {})
    np.testing.assert_array_equal(nominal, scenario.environment.surface_parameters())


def test_the_environment_enters_the_fingerprint_only_when_on(scenarios):
    in_orbit, empty = scenarios
    assert in_orbit.fingerprint.endswith(", environment=True)")
    assert empty.fingerprint.endswith("consider_misalignment=False)")  # as before the environment existed
    assert PDWheelsScenario.from_config(BASE).fingerprint.endswith(", None)")  # as before
    assert "torques: gravity gradient, aerodynamic" in PDWheelsScenario.from_config(BASE, environment=True).fingerprint


def test_environment_errors_name_the_key_and_the_remedy():
    no_orbit = dataclasses.replace(BASE, orbit_config=None)
    with pytest.raises(ScenarioError, match=r"environment=True .* the file has no \[orbit\] table"):
        ClosedLoopScenario(no_orbit, guidance="eigenaxis", environment=True)
    with pytest.raises(ScenarioError, match=r"no \[orbit\] table"):
        PDWheelsScenario.from_config(no_orbit, environment=True)
    with pytest.raises(ScenarioError, match=r"environment must be an OrbitEnvironment or None, got str"):
        PDWheelsScenario(
            assembly.rigid_body(BASE).inertia,
            assembly.reaction_wheels(BASE),
            [1.0, 0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 0.0],
            bandwidth=0.1,
            damping=0.7,
            period=0.1,
            environment="leo",
        )
    with pytest.raises(
        ScenarioError,
        match=r"montecarlo\.drag_scale disperses the surface .* pass environment=True \(attitude montecarlo "
        r"--environment\) or remove the keys montecarlo\.drag_scale, montecarlo\.residual_dipole",
    ):
        run_campaign_from_config(CONFIG, runs=1)

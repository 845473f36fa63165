"""The assembly: one place turns a spacecraft file into objects, and the design and the scenarios share it.

There is no external reference here; the tests check against the file and the toolkit's own rules:
the design (:mod:`attitude.app.design.slew`) and the Monte Carlo scenario
(:class:`attitude.app.scenarios.ClosedLoopScenario`) start the MEKF with identical covariances
(agreement between the two callers); the built objects carry the numbers written in the default
file, with datasheet units converted to SI by hand (deg/sqrt(h) to rad/s^0.5, as in
:mod:`attitude.sensors`); the initial attitude and gyro-bias sigma rules of
:mod:`attitude.app.assembly`; and a source scan (``ast``) proving no other module builds objects
from file data (DESIGN.md: one place).
"""

from __future__ import annotations

import ast
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import attitude
from attitude.actuators import ReactionWheels
from attitude.app import assembly
from attitude.app.design import slew as design_slew
from attitude.app.design.slew import fly_slew, plan_slews
from attitude.app.scenarios import ClosedLoopScenario
from attitude.config import default_config, default_config_text, parse_config
from attitude.rigid_body import RigidBody
from attitude.sensors import Gyro, StarTracker

CONFIG = default_config()
#: The default file without the Monte Carlo dispersion of the start attitude: the scenario's filter
#: then starts with the same attitude knowledge as the design's.
UNDISPERSED = dataclasses.replace(CONFIG, montecarlo=dataclasses.replace(CONFIG.montecarlo, initial_attitude=None))


class _Captured(Exception):
    """Stops the design's flight once its MEKF covariance is known."""


@pytest.fixture(scope="module")
def study():
    return plan_slews(CONFIG, nodes=30)


def _design_mekf_p0(config, study, monkeypatch):
    """The P0 the design's closed-loop flight (report section 4) gives its MEKF."""
    seen = {}

    def capture(gyro, tracker, q0, P0, tracker_covariance=None):
        seen["P0"] = np.array(P0)
        raise _Captured

    monkeypatch.setattr(assembly, "mekf", capture)
    with pytest.raises(_Captured):
        fly_slew(config, study, seed=1)
    monkeypatch.undo()
    return seen["P0"]


def test_the_design_and_the_scenario_start_the_mekf_with_the_same_attitude_knowledge(study, monkeypatch):
    design_p0 = _design_mekf_p0(UNDISPERSED, study, monkeypatch)
    sc = ClosedLoopScenario(UNDISPERSED, study=study)
    scenario_p0 = sc.estimator(sc.gyro(None)).P
    sigma = math.radians(assembly.ATTITUDE_SIGMA0_DEG)
    np.testing.assert_array_equal(design_p0[:3, :3], sigma**2 * np.eye(3))
    np.testing.assert_array_equal(np.asarray(scenario_p0)[:3, :3], design_p0[:3, :3])
    assert np.count_nonzero(design_p0 - np.diag(np.diag(design_p0))) == 0
    # A dispersed start attitude is the filter's initial error: the scenario takes its sigma (0.02 deg here).
    dispersed = ClosedLoopScenario(CONFIG, study=study).estimator(sc.gyro(None)).P
    assert math.sqrt(dispersed[0, 0]) == pytest.approx(math.radians(0.02), rel=1e-12)


def test_the_design_and_the_scenario_start_the_mekf_with_the_same_bias_knowledge(study, monkeypatch):
    design_p0 = _design_mekf_p0(UNDISPERSED, study, monkeypatch)
    sc = ClosedLoopScenario(UNDISPERSED, study=study)
    np.testing.assert_allclose(np.asarray(sc.estimator(sc.gyro(None)).P)[3:, 3:], design_p0[3:, 3:], rtol=1e-12)


def test_the_assembled_objects_carry_the_files_numbers():
    body, hub, wheels = assembly.rigid_body(CONFIG), assembly.hub_body(CONFIG), assembly.reaction_wheels(CONFIG)
    assert isinstance(body, RigidBody) and isinstance(hub, RigidBody) and isinstance(wheels, ReactionWheels)
    np.testing.assert_array_equal(body.inertia, np.array(CONFIG.inertia.tensor_kg_m2))
    assert wheels.n_wheels == 4  # layout = "pyramid"
    np.testing.assert_array_equal(wheels.torque_max, np.full(4, 0.007))
    np.testing.assert_array_equal(wheels.momentum_max, np.full(4, 0.050))
    # The hub is the body less each rotor's spin inertia about its axis: I - sum J a a^T.
    a = np.asarray(wheels.axes_B)
    a = a if a.shape[0] == 3 else a.T  # one column per wheel
    np.testing.assert_allclose(hub.inertia, body.inertia - 8.0e-5 * a @ a.T, rtol=0, atol=1e-15)
    scaled = assembly.reaction_wheels(CONFIG, 0.8)
    np.testing.assert_allclose(scaled.torque_max, np.full(4, 0.8 * 0.007), rtol=1e-15)
    tracker = assembly.star_tracker(CONFIG)
    assert isinstance(tracker, StarTracker) and tracker.period == 0.2
    assert tracker.sun_exclusion == pytest.approx(math.radians(35.0), rel=1e-15)
    assert assembly.orbit(CONFIG).altitude_m == pytest.approx(500e3, rel=1e-12)
    pd = assembly.quaternion_pd(CONFIG)
    # from_bandwidth: K = 2 wn^2 I, C = 2 zeta wn I (wn = 0.4 rad/s, zeta = 0.7 in the file).
    np.testing.assert_allclose(pd.K, 2.0 * 0.4**2 * body.inertia, rtol=1e-12)
    np.testing.assert_allclose(pd.C, 2.0 * 0.7 * 0.4 * body.inertia, rtol=1e-12)
    assert assembly.lqr(CONFIG) is not None
    assert assembly.lqr(dataclasses.replace(CONFIG, control=dataclasses.replace(CONFIG.control, lqr=None))) is None


def test_the_gyro_arw_is_converted_to_si_as_by_hand():
    # ARW [deg/sqrt(h)] -> sigma_v [rad/sqrt(s)]: deg -> rad is pi/180 and sqrt(h) = sqrt(3600 s) = 60 sqrt(s)
    # (IEEE Std 952-1997, Annex C: the angle random walk N in deg/sqrt(h) is N/60 deg/sqrt(s)).
    text = default_config_text().replace('preset = "mems"', "arw_deg_per_sqrt_h = 0.15", 1)
    config = parse_config(text)
    assert config.gyro_config.preset is None and config.gyro_config.arw_deg_per_sqrt_h == 0.15
    gyro = assembly.gyro(config)
    assert isinstance(gyro, Gyro) and gyro.period == 0.1 and gyro.sampling == "instantaneous"
    by_hand = 0.15 * 3.141592653589793 / 180.0 / 60.0  # = 4.3633e-5 rad/sqrt(s)
    assert gyro.sigma_v == pytest.approx(by_hand, rel=1e-12)
    assert by_hand == pytest.approx(4.3633e-5, rel=1e-4)
    assert assembly.gyro(config, sampling="mean").sampling == "mean"
    # A dispersed misalignment and turn-on bias add to the file's.
    bias = np.radians([1.0, -2.0, 3.0]) / 3600.0
    np.testing.assert_allclose(assembly.gyro(config, bias_rad_per_s=bias).initial_bias, bias, rtol=1e-12)


def test_the_initial_attitude_sigma_rule():
    from attitude.config import Dispersion

    assert assembly.attitude_sigma0() == math.radians(assembly.ATTITUDE_SIGMA0_DEG)
    assert assembly.attitude_sigma0(Dispersion("normal", 0.5, "deg")) == pytest.approx(math.radians(0.5))
    uniform = assembly.attitude_sigma0(Dispersion("uniform", 0.5, "deg"))
    assert uniform == pytest.approx(math.radians(0.5) / math.sqrt(3.0))
    assert assembly.attitude_sigma0(Dispersion("uniform_so3", None, "deg")) == math.pi
    assert assembly.attitude_sigma0(Dispersion("normal", 0.0, "deg")) == math.radians(assembly.ATTITUDE_SIGMA0_DEG)


def test_the_initial_gyro_bias_sigma_is_the_largest_of_floor_instability_constant_bias_and_dispersion():
    from attitude.config import Dispersion

    deg_per_h = math.radians(1.0) / 3600.0  # [rad/s]
    # The default file: the MEMS preset (8 deg/h instability), no constant bias, no dispersion: the floor.
    assert assembly.gyro_bias_sigma0(CONFIG) == pytest.approx(assembly.BIAS_SIGMA0_FLOOR_DEG_PER_H * deg_per_h)
    text = default_config_text().replace('preset = "mems"', "arw_deg_per_sqrt_h = 0.15", 1)
    unstable = parse_config(
        text.replace("[gyro]\n", "[gyro]\nbias_instability_deg_per_h = 20.0\nbias_instability_time_s = 300.0\n", 1)
    )
    assert assembly.gyro_bias_sigma0(unstable) == pytest.approx(20.0 * deg_per_h)
    biased = parse_config(text.replace("[gyro]\n", "[gyro]\nbias_deg_per_h = [1.0, -15.0, 2.0]\n", 1))
    assert assembly.gyro_bias_sigma0(biased) == pytest.approx(15.0 * deg_per_h)
    wide = dataclasses.replace(CONFIG.montecarlo, gyro_bias=Dispersion("uniform", 60.0, "deg_per_h"))
    dispersed = dataclasses.replace(CONFIG, montecarlo=wide)
    assert assembly.gyro_bias_sigma0(dispersed) == pytest.approx(60.0 / math.sqrt(3.0) * deg_per_h)  # U(-h, h)


# ---------------------------------------------------------------------------
# No second construction site

#: Constructors and factories that turn file data into objects: only the assembly (and, for one table at
#: a time, attitude.config.build, which the reader also uses to validate) may call them.
FACTORY_METHODS = {"from_bandwidth", "from_datasheet", "from_sensors", "from_gyro", "from_altitude", "from_degrees"}
FACTORY_CALLS = {"MEKF", "RateEKF", "initial_covariance", "TrackingController", "design_lqr", "bryson_weights"}
PRESET_CLASSES = {"Gyro", "StarTracker", "ReactionWheels"}
#: The build methods the config dataclasses used to have.
OLD_BUILD_METHODS = {"body", "hub_body", "wheels", "star_tracker", "orbit", "build", "figures"}
ALLOWED = {"app/assembly.py", "config/build.py"}


def construction_sites(source: str, name: str = "<source>") -> list[str]:
    """Calls in ``source`` that build a toolkit object from file data, as ``"name:line: call"``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        what = None
        if isinstance(f, ast.Name) and f.id in FACTORY_CALLS | {"ReactionWheels"}:
            what = f.id
        elif isinstance(f, ast.Attribute):
            owner = f.value.id if isinstance(f.value, ast.Name) else getattr(f.value, "attr", "")
            if f.attr in FACTORY_METHODS or f.attr in FACTORY_CALLS:
                what = f"{owner}.{f.attr}"
            elif owner in PRESET_CLASSES and f.attr in {"preset", "pyramid", "orthogonal"}:
                what = f"{owner}.{f.attr}"
            elif f.attr in OLD_BUILD_METHODS and ("config" in owner.lower() or owner.endswith("_config")):
                what = f"{owner}.{f.attr}"
            elif f.attr == "gyro" and "config" in owner.lower():
                what = f"{owner}.gyro"
        if what is not None:
            found.append(f"{name}:{node.lineno}: {what}()")
    return found


def _package_sites() -> list[str]:
    root = Path(attitude.__file__).parent
    sites = []
    for path in sorted((root / "app").rglob("*.py")) + sorted((root / "config").rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel not in ALLOWED:
            sites += construction_sites(path.read_text(encoding="utf-8"), rel)
    return sites


def test_no_module_but_the_assembly_builds_objects_from_the_file():
    assert _package_sites() == []


def test_the_construction_check_finds_a_second_site():
    sites = construction_sites(
        "gyro = Gyro.from_datasheet(config.gyro_config.arw_deg_per_sqrt_h, period=0.1)\n"
        "pd = QuaternionPD.from_bandwidth(body, c.bandwidth_rad_per_s, c.damping, c.period_s)\n"
        "f = MEKF.from_sensors(gyro, tracker, q0=q0, P0=initial_covariance(0.1, 0.2))\n"
        "w = ReactionWheels.pyramid(j, t, h)\n"
        "b = config.body()\n"
        "g = self.config.gyro(sampling='mean')\n"
    )
    assert len(sites) == 7, sites
    # The design's modules call the assembly instead (what the check is for).
    assert "assembly" in Path(design_slew.__file__).read_text(encoding="utf-8")

"""The assembly of the orbit-environment tables: the objects carry the file's numbers, converted by hand.

References: the B-dot gain ``k = 2 n (1 + sin i) J_min`` of Avanzini and Giulietti (J. Guidance, Control,
and Dynamics 35(4), 2012), evaluated here by hand from the mean motion ``n = sqrt(mu / a^3)`` (Kepler's
third law) and the smallest principal moment of the file's tensor (``numpy.linalg.eigvalsh``); unit
conversions (1 nT = 1e-9 T, deg -> rad) by hand; the surface plate count and order from the file's box
(six faces) and panels (front then back, :meth:`SurfaceModel.with_panels`).
"""

from __future__ import annotations

import copy
import math
import tomllib

import numpy as np
import pytest

from attitude.actuators import Magnetorquers
from attitude.app import assembly
from attitude.config import config_from_dict, default_config, default_config_text
from attitude.environment.orbit import MU_EARTH, R_EARTH, CircularOrbit
from attitude.environment.orbit_environment import DISTURBANCE_SOURCES, OrbitEnvironment
from attitude.environment.surface import SurfaceModel
from attitude.sensors import Magnetometer
from controllers.magnetic import BDotController, CrossProductUnloading

CONFIG = default_config()
DATA = tomllib.loads(default_config_text())


def _without(*tables):
    data = copy.deepcopy(DATA)
    for t in tables:
        data.pop(t)
    if "environment" not in data:
        data["requirements"].pop("keep_out")  # "sun" needs the Sun direction
    return config_from_dict(data)


def test_orbit_and_environment_of_the_default_file():
    orbit = assembly.orbit(CONFIG)
    assert isinstance(orbit, CircularOrbit)
    assert orbit.epoch.utc.isoformat() == "2026-03-20T12:00:00+00:00"
    env = assembly.orbit_environment(CONFIG)
    assert isinstance(env, OrbitEnvironment)
    assert env.sources == DISTURBANCE_SOURCES and env.eclipse == "conical" and env.sample_period == 1.0
    assert env.surface == assembly.surface(CONFIG)
    # The orbit passed in is the one flown.
    assert assembly.orbit_environment(CONFIG, orbit).orbit is orbit


def test_without_a_surface_only_gravity_gradient_is_flown_and_without_an_orbit_nothing():
    env = assembly.orbit_environment(_without("surface"))
    assert env.sources == ("gravity_gradient",) and env.surface is None
    bare = _without(
        "orbit", "environment", "surface", "magnetorquers", "magnetometer", "coarse_sun_sensors", "detumble", "momentum"
    )
    assert assembly.orbit(bare) is None and assembly.orbit_environment(bare) is None
    for build in (assembly.surface, assembly.magnetorquers, assembly.magnetometer, assembly.coarse_sun_sensors):
        assert build(bare) is None
    assert assembly.detumble_settings(bare) is None and assembly.momentum_settings(bare) is None
    assert assembly.bdot_controller(bare) is None and assembly.unloading_controller(bare) is None


def test_surface_is_the_box_then_the_panels():
    surface = assembly.surface(CONFIG)
    assert isinstance(surface, SurfaceModel) and surface.n_plates == 6 + 2 * 2
    a, b, c = 0.2263, 0.2263, 0.366
    np.testing.assert_allclose(surface.area_m2[:6], [b * c, b * c, a * c, a * c, a * b, a * b], rtol=1e-15)
    np.testing.assert_allclose(surface.area_m2[6:], 0.0828)
    # Box face +x at half the edge plus the offset; panel fronts along +x, backs along -x.
    np.testing.assert_allclose(surface.centre_of_pressure_B_m[0], [a / 2 + 0.005, -0.003, 0.015], rtol=1e-15)
    np.testing.assert_array_equal(surface.normal_B[6:8], [[1, 0, 0], [1, 0, 0]])
    np.testing.assert_array_equal(surface.normal_B[8:10], [[-1, 0, 0], [-1, 0, 0]])
    np.testing.assert_array_equal(surface.diffuse[8:], [0.3, 0.3])
    np.testing.assert_array_equal(surface.residual_dipole_Am2, [0.005, 0.005, -0.01])


def test_rods_and_magnetometer_in_si():
    rods = assembly.magnetorquers(CONFIG)
    assert isinstance(rods, Magnetorquers) and rods.n_rods == 3
    np.testing.assert_array_equal(rods.dipole_max_Am2, [0.2, 0.2, 0.2])
    sensor = assembly.magnetometer(CONFIG)
    assert isinstance(sensor, Magnetometer) and sensor.period == 0.1
    assert sensor.sigma == pytest.approx(20.0e-9, rel=1e-15)  # 20 nT
    np.testing.assert_allclose(sensor.bias, np.array([200.0, -150.0, 100.0]) * 1e-9, rtol=1e-15)
    # A small rotation phi gives M = -[phi x] (first order): M[0, 1] = phi_z, M[1, 0] = -phi_z.
    phi_z = math.radians(0.2)
    assert sensor.misalignment[0, 1] == pytest.approx(phi_z, rel=1e-12)
    assert sensor.misalignment[1, 0] == pytest.approx(-phi_z, rel=1e-12)


def test_detumble_auto_gain_by_hand():
    settings = assembly.detumble_settings(CONFIG)
    n = math.sqrt(MU_EARTH / (R_EARTH + 500e3) ** 3)
    j_min = float(np.min(np.linalg.eigvalsh(np.array(CONFIG.inertia.tensor_kg_m2))))
    by_hand = 2.0 * n * (1.0 + math.sin(math.radians(97.4))) * j_min
    assert settings.gain_is_auto and settings.gain == pytest.approx(by_hand, rel=1e-12)
    assert settings.gain == pytest.approx(9.3e-4, rel=0.01)  # the default file's comment
    np.testing.assert_allclose(settings.tip_off_rate, np.radians([4.0, -3.0, 5.0]), rtol=1e-15)
    assert settings.rate_threshold == pytest.approx(math.radians(0.5), rel=1e-15)
    assert settings.duration_max == pytest.approx(3.0 * 2.0 * math.pi / n, rel=1e-12)
    law = assembly.bdot_controller(CONFIG)
    assert isinstance(law, BDotController) and law.gain == settings.gain and law.period == 1.0
    assert law.law == "unit" and law.magnetorquers is not None


def test_a_numeric_gain_is_taken_as_written():
    data = copy.deepcopy(DATA)
    data["detumble"]["gain_Nms"] = 0.002
    settings = assembly.detumble_settings(config_from_dict(data))
    assert settings.gain == 0.002 and not settings.gain_is_auto


def test_momentum_settings_and_unloading_law():
    settings = assembly.momentum_settings(CONFIG)
    n = math.sqrt(MU_EARTH / (R_EARTH + 500e3) ** 3)
    assert settings.unloading_gain == 5e-4 and settings.orbits == 20 and settings.wheel_momentum_margin == 0.5
    assert settings.duration == pytest.approx(20 * 2.0 * math.pi / n, rel=1e-12)
    law = assembly.unloading_controller(CONFIG)
    assert isinstance(law, CrossProductUnloading) and law.gain == 5e-4 and law.period == 1.0
    np.testing.assert_array_equal(law.target_momentum_B, np.zeros(3))
    data = copy.deepcopy(DATA)
    del data["momentum"]["unloading_gain_per_s"]
    assert assembly.unloading_controller(config_from_dict(data)) is None

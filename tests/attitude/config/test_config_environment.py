"""The orbit-environment tables of the spacecraft file: [orbit] kinds, [environment] models, [surface],
[magnetorquers], [magnetometer], [detumble], [momentum].

What each group checks against:

* Round trips: ``parse_config(config_to_toml(c)) == c`` for the default file and for variants using
  every optional form (Kepler by altitudes and by elements, a TLE, NRLMSIS, plates and panels).
* Backward compatibility: a circular ``[orbit]`` without ``kind`` or ``epoch_utc`` reads as the same
  orbit as before, at the toolkit's default epoch.
* Validation, one snippet per rule: a :class:`attitude.config.ConfigError` naming the key, the rule
  and, where the key has one, the unit (DESIGN.md: errors name the argument, the rule and the value).
* The Keplerian sizes from perigee and apogee altitudes by hand: ``a = R + (h_p + h_a) / 2``,
  ``e = (r_a - r_p) / (r_a + r_p)`` (Vallado, *Fundamentals of Astrodynamics and Applications*,
  4th ed., eqs. 2-62/2-63 region: ``r_p = a (1 - e)``, ``r_a = a (1 + e)``).
* The TLE checksum by hand (modulo 10 of the digits, '-' counting 1: the NORAD format,
  CelesTrak "NORAD Two-Line Element Set Format").
"""

from __future__ import annotations

import copy
import dataclasses
import re
import tomllib

import numpy as np
import pytest

from attitude.app import assembly
from attitude.config import (
    ConfigError,
    config_from_dict,
    config_to_toml,
    default_config,
    default_config_text,
    parse_config,
)
from attitude.config.model import DEFAULT_EPOCH_UTC
from attitude.environment.epoch import DEFAULT_EPOCH
from attitude.environment.orbit import R_EARTH

DEFAULT_TEXT = default_config_text()
DEFAULT_DATA = tomllib.loads(DEFAULT_TEXT)

#: Vallado et al. 2006 ("Revisiting Spacetrack Report #3", AIAA 2006-6753) verification satellite 00005,
#: as in the sgp4 package's SGP4-VER.TLE.
TLE_1 = "1 00005U 58002B   00179.78495062  .00000023  00000-0  28098-4 0  4753"
TLE_2 = "2 00005  34.2682 348.7242 1859667 331.7664  19.3264 10.82419157413667"


def _load(data, file="test.toml"):
    return config_from_dict(data, file)


def _with(**tables):
    data = copy.deepcopy(DEFAULT_DATA)
    for name, value in tables.items():
        if value is None:
            data.pop(name, None)
        else:
            data[name] = value
    return data


def _round_trip(config):
    assert parse_config(config_to_toml(config), "again.toml") == config


# ---------------------------------------------------------------------------
# The default file and round trips


def test_default_file_has_every_new_table_and_round_trips():
    config = default_config()
    assert config.orbit_config.kind == "circular" and config.orbit_config.epoch_utc == "2026-03-20T12:00:00Z"
    assert config.surface is not None and len(config.surface.panels) == 2
    assert config.magnetorquers_config.dipole_max_Am2 == 0.2
    assert config.magnetometer_config.noise_nT == 20.0
    assert config.detumble.gain_Nms == "auto" and config.momentum.orbits == 20
    _round_trip(config)


def test_sun_sensor_tables_read_in_their_units_build_and_round_trip():
    data = _with()
    data["coarse_sun_sensors"] = {
        "period_s": 0.2,
        "noise_percent": 2.0,
        "normals_B": [[1, 0, 1], [0, 1, 1], [-1, 0, 1], [0, -1, 1]],
        "fov_half_angle_deg": 80.0,
        "albedo_percent": 10.0,
    }
    data["fine_sun_sensor"] = {
        "period_s": 0.5,
        "accuracy_deg": 0.3,
        "accuracy_sigma_level": 3,
        "fov_half_angle_deg": 60.0,
        "boresight_B": [0, 1, 0],
        "bias_deg": [0.01, -0.02],
    }
    config = _load(data)
    _round_trip(config)
    coarse = assembly.coarse_sun_sensors(config)
    assert coarse.n_cells == 4 and coarse.period == 0.2
    np.testing.assert_allclose(coarse.normals_B[0], [np.sqrt(0.5), 0.0, np.sqrt(0.5)], rtol=1e-15)
    assert coarse.noise == pytest.approx(0.02) and coarse.albedo_fraction == pytest.approx(0.10)
    assert coarse.fov_half_angle == pytest.approx(np.radians(80.0))
    fine = assembly.fine_sun_sensor(config)
    assert fine.sigma == pytest.approx(np.radians(0.1))  # 0.3 deg at 3 sigma
    np.testing.assert_allclose(fine.C_BS[:, 2], [0.0, 1.0, 0.0])
    np.testing.assert_allclose(fine.bias, np.radians([0.01, -0.02]))
    # The white-noise-only sensors of the determination study drop exactly the systematic errors.
    plain = assembly.direction_sensors(config, white_noise_only=True)
    assert plain["coarse_sun_sensors"].albedo_fraction == 0.0 and plain["coarse_sun_sensors"].noise == coarse.noise
    assert not np.any(plain["fine_sun_sensor"].bias) and plain["fine_sun_sensor"].sigma == fine.sigma
    mag = plain["magnetometer"]
    assert not np.any(mag.bias) and not np.any(mag.misalignment) and mag.sigma == assembly.magnetometer(config).sigma


def test_a_circular_orbit_file_of_before_reads_as_before():
    data = _with()
    data["orbit"] = {"altitude_km": 500.0, "inclination_deg": 97.4}
    for table in ("surface", "magnetorquers", "magnetometer", "detumble", "momentum"):
        data.pop(table)
    data["environment"] = {"sun_direction_N": [0.42, -0.45, 0.78]}
    config = _load(data)
    orbit = config.orbit_config
    assert (orbit.kind, orbit.altitude_km, orbit.inclination_deg, orbit.raan_deg) == ("circular", 500.0, 97.4, 0.0)
    assert orbit.epoch_utc == DEFAULT_EPOCH_UTC
    assert DEFAULT_EPOCH_UTC == DEFAULT_EPOCH.utc.strftime("%Y-%m-%dT%H:%M:%SZ")
    assert config.environment.sources is None and config.surface is None
    _round_trip(config)


@pytest.mark.parametrize(
    "value, expected",
    [
        ("2026-01-02T03:04:05Z", "2026-01-02T03:04:05Z"),
        ("2026-01-02T05:04:05.25+02:00", "2026-01-02T03:04:05.250000Z"),
    ],
)
def test_epoch_is_stored_in_utc(value, expected):
    data = _with()
    data["orbit"]["epoch_utc"] = value
    config = _load(data)
    assert config.orbit_config.epoch_utc == expected
    _round_trip(config)


def test_a_toml_datetime_epoch_is_accepted():
    text = DEFAULT_TEXT.replace('epoch_utc = "2026-03-20T12:00:00Z"', "epoch_utc = 2026-03-20T13:00:00+01:00", 1)
    assert parse_config(text).orbit_config.epoch_utc == "2026-03-20T12:00:00Z"


def test_kepler_by_altitudes_and_by_elements_round_trip():
    data = _with()
    data["orbit"] = {
        "kind": "kepler",
        "perigee_altitude_km": 400.0,
        "apogee_altitude_km": 1200.0,
        "inclination_deg": 51.6,
        "raan_deg": 30.0,
        "argument_of_perigee_deg": 90.0,
        "mean_anomaly_deg": 10.0,
        "epoch_utc": "2025-06-01T00:00:00Z",
    }
    config = _load(data)
    _round_trip(config)
    assert config.orbit_config.argument_of_latitude_deg is None
    data["orbit"] = {"kind": "kepler", "semi_major_axis_km": 7000.0, "eccentricity": 0.01}
    config = _load(data)
    assert config.orbit_config.argument_of_perigee_deg == 0.0 and config.orbit_config.mean_anomaly_deg == 0.0
    _round_trip(config)


def test_tle_round_trips_without_epoch_and_angles():
    data = _with()
    data["orbit"] = {"kind": "tle", "tle_line1": TLE_1, "tle_line2": TLE_2}
    config = _load(data)
    assert config.orbit_config.epoch_utc is None and config.orbit_config.inclination_deg is None
    assert config.orbit_config.tle_line1 == TLE_1
    _round_trip(config)


def test_environment_variants_round_trip():
    data = _with()
    data["environment"].update(
        magnetic_field="dipole",
        atmosphere="nrlmsis",
        f107_sfu=70.0,
        eclipse="cylindrical",
        sources=["gravity_gradient", "magnetic"],
        sample_period_s=2.0,
    )
    config = _load(data)
    env = config.environment
    # The NRLMSIS space weather left out is resolved to the model's defaults (written back explicitly).
    assert (env.f107_sfu, env.f107_average_sfu, env.ap) == (70.0, 150.0, 4.0)
    assert env.sources == ("gravity_gradient", "magnetic")
    _round_trip(config)


def test_surface_plates_panels_and_rod_variants_round_trip():
    data = _with()
    data["surface"] = {
        "plate": [
            {"area_m2": 0.1, "normal_B": [0, 0, 2], "centre_of_pressure_B_m": [0, 0, 0.2], "specular": 0.3},
            {"area_m2": 0.1, "normal_B": [0, 0, -1], "centre_of_pressure_B_m": [0, 0, -0.2], "drag_coefficient": 2.0},
        ],
        "panel": [{"area_m2": 0.05, "normal_B": [1, 0, 0], "centre_of_pressure_B_m": [0, 0.3, 0], "diffuse": 0.2}],
        "residual_dipole_Am2": [0.01, 0, 0],
    }
    data["magnetorquers"] = {
        "dipole_max_Am2": [0.1, 0.2, 0.3, 0.4],
        "quantum_Am2": 0.001,
        "axes_B": [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]],
        "saturation": "clip",
    }
    data["detumble"]["gain_Nms"] = 0.002
    data["detumble"]["tip_off_rate_deg_per_s"] = 3.0
    config = _load(data)
    panel = config.surface.panels[0]
    # A panel's back takes its front's optics unless the file says otherwise.
    assert (panel.back_specular, panel.back_diffuse) == (panel.specular, panel.diffuse) == (0.0, 0.2)
    assert config.surface.box_specular is None and config.magnetorquers_config.count == 4
    _round_trip(config)


def test_writer_comments_every_new_key_and_notes_the_default_sources():
    text = config_to_toml(default_config())
    block = text[text.index("[orbit]") : text.index("[requirements]")]
    for line in block.splitlines():
        if re.match(r"^[A-Za-z_0-9]+ = ", line):
            assert "  # " in line, line
    assert "# sources left out: ['gravity_gradient', 'aerodynamic', 'solar_pressure', 'magnetic']" in block


# ---------------------------------------------------------------------------
# Validation: one snippet per rule (key, rule, unit)


def _kepler(**keys):
    return {"kind": "kepler", **keys}


BAD = [
    # (id, {table: replacement or edit}, key, fragments of the message)
    (
        "unknown kind",
        {"orbit": {"kind": "elliptic", "altitude_km": 500}},
        "orbit.kind",
        ["unknown orbit kind 'elliptic'"],
    ),
    (
        "kepler key on a circular orbit",
        {"orbit": {"altitude_km": 500, "eccentricity": 0.1}},
        "orbit.eccentricity",
        ["applies to kind = 'kepler'", "set kind = 'kepler'"],
    ),
    (
        "eccentricity 1.2",
        {"orbit": _kepler(semi_major_axis_km=8000, eccentricity=1.2)},
        "orbit.eccentricity",
        ["must be in [0, 1) for a closed orbit, got 1.2"],
    ),
    (
        "negative eccentricity",
        {"orbit": _kepler(semi_major_axis_km=8000, eccentricity=-0.1)},
        "orbit.eccentricity",
        ["[0, 1)"],
    ),
    (
        "perigee below the surface (elements)",
        {"orbit": _kepler(semi_major_axis_km=7000, eccentricity=0.1)},
        "orbit.semi_major_axis_km",
        ["perigee above the Earth's surface", "eccentricity = 0.1", "km altitude"],
    ),
    (
        "perigee below the surface (altitudes)",
        {"orbit": _kepler(perigee_altitude_km=-10, apogee_altitude_km=500)},
        "orbit.perigee_altitude_km",
        ["above the Earth's surface (> 0 km", "got -10"],
    ),
    (
        "apogee below perigee",
        {"orbit": _kepler(perigee_altitude_km=600, apogee_altitude_km=500)},
        "orbit.apogee_altitude_km",
        ["at least perigee_altitude_km = 600 km"],
    ),
    (
        "two kepler shapes",
        {"orbit": _kepler(perigee_altitude_km=600, apogee_altitude_km=700, eccentricity=0.1)},
        "orbit.semi_major_axis_km",
        ["not both"],
    ),
    ("no kepler shape", {"orbit": _kepler(inclination_deg=10)}, "orbit.perigee_altitude_km", ["missing required key"]),
    (
        "only the perigee",
        {"orbit": _kepler(perigee_altitude_km=600)},
        "orbit.apogee_altitude_km",
        ["missing required key", "[km]"],
    ),
    (
        "circular below the surface",
        {"orbit": {"altitude_km": -5}},
        "orbit.altitude_km",
        ["strictly positive (> 0) [km]", "got -5"],
    ),
    (
        "naive epoch",
        {"orbit": {"altitude_km": 500, "epoch_utc": "2026-03-20T12:00:00"}},
        "orbit.epoch_utc",
        ["time zone"],
    ),
    ("garbage epoch", {"orbit": {"altitude_km": 500, "epoch_utc": "yesterday"}}, "orbit.epoch_utc", ["ISO 8601"]),
    ("numeric epoch", {"orbit": {"altitude_km": 500, "epoch_utc": 2026}}, "orbit.epoch_utc", ["ISO 8601"]),
    (
        "epoch on a TLE",
        {"orbit": {"kind": "tle", "tle_line1": TLE_1, "tle_line2": TLE_2, "epoch_utc": "2026-03-20T12:00:00Z"}},
        "orbit.epoch_utc",
        ["applies to kind = 'circular' or 'kepler'"],
    ),
    ("TLE missing line 2", {"orbit": {"kind": "tle", "tle_line1": TLE_1}}, "orbit.tle_line2", ["missing required key"]),
    (
        "TLE lines swapped",
        {"orbit": {"kind": "tle", "tle_line1": TLE_2, "tle_line2": TLE_1}},
        "orbit.tle_line1",
        ["must be line 1 of a TLE"],
    ),
    (
        "TLE truncated",
        {"orbit": {"kind": "tle", "tle_line1": TLE_1, "tle_line2": TLE_2[:60]}},
        "orbit.tle_line2",
        ["69 characters", "got 60"],
    ),
    (
        "TLE checksum",
        {"orbit": {"kind": "tle", "tle_line1": TLE_1, "tle_line2": TLE_2.replace("34.2682", "34.2692")}},
        "orbit.tle_line2",
        ["checksum fails: the last digit is 7 but the line sums to 8"],
    ),
    (
        "TLE not a string",
        {"orbit": {"kind": "tle", "tle_line1": 1, "tle_line2": TLE_2}},
        "orbit.tle_line1",
        ["expected a string"],
    ),
    # [environment]
    ("unknown field model", {"environment.magnetic_field": "wmm"}, "environment.magnetic_field", ["Valid: 'igrf'"]),
    ("unknown atmosphere", {"environment.atmosphere": "jacchia"}, "environment.atmosphere", ["Valid:"]),
    ("unknown eclipse", {"environment.eclipse": "umbra"}, "environment.eclipse", ["Valid: 'conical'"]),
    (
        "space weather without nrlmsis",
        {"environment.f107_sfu": 120.0},
        "environment.f107_sfu",
        ["only with atmosphere = 'nrlmsis'"],
    ),
    (
        "negative F10.7",
        {"environment.atmosphere": "nrlmsis", "environment.f107_sfu": -1.0},
        "environment.f107_sfu",
        ["strictly positive (> 0) [sfu]"],
    ),
    ("unknown source", {"environment.sources": ["drag"]}, "environment.sources[0]", ["unknown disturbance source"]),
    (
        "repeated source",
        {"environment.sources": ["magnetic", "magnetic"]},
        "environment.sources[1]",
        ["repeats 'magnetic'"],
    ),
    (
        "surface source without a surface",
        {"environment.sources": ["aerodynamic"], "surface": None},
        "environment.sources",
        ["needs a [surface] table"],
    ),
    (
        "magnetic torque without a field",
        {
            "environment.sources": ["magnetic"],
            "environment.magnetic_field": "none",
            "magnetometer": None,
            "magnetorquers": None,
            "detumble": None,
            "momentum": None,
        },
        "environment.sources",
        ["'magnetic' needs a field model"],
    ),
    (
        "drag without an atmosphere",
        {"environment.sources": ["aerodynamic"], "environment.atmosphere": "none"},
        "environment.sources",
        ["'aerodynamic' needs an atmosphere"],
    ),
    ("zero sample period", {"environment.sample_period_s": 0.0}, "environment.sample_period_s", ["(> 0) [s]"]),
    (
        "models without an orbit",
        {
            "orbit": None,
            "detumble": None,
            "momentum": None,
            "magnetometer": None,
            "magnetorquers": None,
            "coarse_sun_sensors": None,
        },
        "environment.magnetic_field",
        ["needs an [orbit] table"],
    ),
    # [surface]
    (
        "zero plate normal",
        {"surface": {"plate": [{"area_m2": 0.1, "normal_B": [0, 0, 0], "centre_of_pressure_B_m": [0, 0, 0]}]}},
        "surface.plate[0].normal_B",
        ["non-zero"],
    ),
    (
        "negative plate area",
        {"surface": {"plate": [{"area_m2": -0.1, "normal_B": [0, 0, 1], "centre_of_pressure_B_m": [0, 0, 0]}]}},
        "surface.plate[0].area_m2",
        ["strictly positive (> 0) [m^2]"],
    ),
    (
        "optics above 1",
        {
            "surface": {
                "plate": [
                    {
                        "area_m2": 0.1,
                        "normal_B": [0, 0, 1],
                        "centre_of_pressure_B_m": [0, 0, 0],
                        "specular": 0.6,
                        "diffuse": 0.5,
                    }
                ]
            }
        },
        "surface.plate[0].diffuse",
        ["specular + diffuse must be at most 1", "0.6 + 0.5"],
    ),
    ("specular out of range", {"surface.box_specular": 1.5}, "surface.box_specular", ["in [0, 1]"]),
    ("negative drag coefficient", {"surface.box_drag_coefficient": -2.2}, "surface.box_drag_coefficient", [">= 0"]),
    ("zero box edge", {"surface.box_m": [0.2, 0.0, 0.3]}, "surface.box_m[1]", ["(> 0) [m]"]),
    (
        "box keys without a box",
        {
            "surface": {
                "box_specular": 0.1,
                "plate": [{"area_m2": 1, "normal_B": [1, 0, 0], "centre_of_pressure_B_m": [0, 0, 0]}],
            }
        },
        "surface.box_specular",
        ["only with box_m"],
    ),
    ("empty surface", {"surface": {"residual_dipole_Am2": [0, 0, 0.1]}}, "surface.box_m", ["box_m = [x, y, z] [m]"]),
    ("dipole of 2 values", {"surface.residual_dipole_Am2": [0.1, 0.2]}, "surface.residual_dipole_Am2", ["list of 3"]),
    # [magnetorquers], [magnetometer]
    (
        "negative dipole limit",
        {"magnetorquers.dipole_max_Am2": -0.2},
        "magnetorquers.dipole_max_Am2",
        ["strictly positive (> 0) [A m^2]", "got -0.2"],
    ),
    (
        "dipole limit per rod of the wrong length",
        {"magnetorquers.dipole_max_Am2": [0.2, 0.2]},
        "magnetorquers.dipole_max_Am2",
        ["one per rod"],
    ),
    ("dipole with units", {"magnetorquers.dipole_max_Am2": "0.2 A m^2"}, "magnetorquers.dipole_max_Am2", ["A m^2"]),
    ("zero quantum", {"magnetorquers.quantum_Am2": 0.0}, "magnetorquers.quantum_Am2", ["(> 0) [A m^2]"]),
    ("unknown saturation", {"magnetorquers.saturation": "cut"}, "magnetorquers.saturation", ["Valid: 'scale'"]),
    (
        "zero rod axis",
        {"magnetorquers.axes_B": [[1, 0, 0], [0, 0, 0], [0, 0, 1]]},
        "magnetorquers.axes_B[1]",
        ["non-zero"],
    ),
    ("negative noise", {"magnetometer.noise_nT": -1.0}, "magnetometer.noise_nT", ["non-negative (>= 0) [nT]"]),
    ("zero magnetometer period", {"magnetometer.period_s": 0}, "magnetometer.period_s", ["(> 0) [s]"]),
    (
        "large misalignment",
        {"magnetometer.misalignment_deg": [20.0, 0, 0]},
        "magnetometer.misalignment_deg",
        ["a small rotation, |phi| <= 10 deg"],
    ),
    ("missing noise", {"magnetometer": {"period_s": 0.1}}, "magnetometer.noise_nT", ["missing required key", "[nT]"]),
    (
        "magnetometer without a field",
        {"environment.magnetic_field": "none", "environment.sources": ["gravity_gradient"]},
        "magnetorquers",
        ["needs a magnetic field: environment.magnetic_field is 'none'"],
    ),
    (
        "perigee below the Karman line",
        {"orbit.altitude_km": 50.0},
        "orbit.altitude_km",
        ["at least 100 km up", "50 km"],
    ),
    (
        "epoch beyond the IGRF coefficients",
        {"orbit.epoch_utc": "2040-03-20T12:00:00Z"},
        "orbit.epoch_utc",
        ["outside the geomagnetic field model", "span 1900-01-01 to 2030-01-01", "2040-03-20"],
    ),
    (
        "track sampled too coarsely",
        {"environment.sample_period_s": 4000.0},
        "environment",
        ["sample_period must be at most 1/100 of the orbit period", "4000"],
    ),
    # [detumble], [momentum]
    ("unknown gain word", {"detumble.gain_Nms": "fast"}, "detumble.gain_Nms", ["expected a number"]),
    ("negative gain", {"detumble.gain_Nms": -1e-3}, "detumble.gain_Nms", ["strictly positive (> 0) [N m s]"]),
    (
        "tip-off below the threshold",
        {"detumble.tip_off_rate_deg_per_s": 0.1},
        "detumble.tip_off_rate_deg_per_s",
        ["faster than rate_threshold_deg_per_s = 0.5 deg/s"],
    ),
    ("zero threshold", {"detumble.rate_threshold_deg_per_s": 0.0}, "detumble.rate_threshold_deg_per_s", ["[deg/s]"]),
    ("detumble without rods", {"magnetorquers": None}, "detumble", ["needs a [magnetorquers] table"]),
    ("detumble without a magnetometer", {"magnetometer": None}, "detumble", ["needs a [magnetometer] table"]),
    ("negative unloading gain", {"momentum.unloading_gain_per_s": -1e-3}, "momentum.unloading_gain_per_s", ["[1/s]"]),
    (
        "unloading gain over the sample rate",
        {"momentum.unloading_gain_per_s": 2.0},
        "momentum.unloading_gain_per_s",
        ["below 1 / period_s = 1 1/s"],
    ),
    ("zero orbits", {"momentum.orbits": 0}, "momentum.orbits", ["an integer in [1, 1000]"]),
    ("margin above 1", {"momentum.wheel_momentum_margin": 1.5}, "momentum.wheel_momentum_margin", ["in (0, 1]"]),
    (
        "unloading without rods",
        {"magnetorquers": None, "detumble": None},
        "momentum.unloading_gain_per_s",
        ["needs a [magnetorquers] table"],
    ),
    (
        "momentum without an orbit",
        {
            "orbit": None,
            "environment": None,
            "detumble": None,
            "magnetometer": None,
            "magnetorquers": None,
            "coarse_sun_sensors": None,
        },
        "momentum",
        ["needs an [orbit] table"],
    ),
    # [coarse_sun_sensors], [fine_sun_sensor]
    (
        "negative cell noise",
        {"coarse_sun_sensors.noise_percent": -1.0},
        "coarse_sun_sensors.noise_percent",
        ["strictly positive (> 0) [% of full scale]", "got -1.0"],
    ),
    (
        "cells wider than a hemisphere",
        {"coarse_sun_sensors.fov_half_angle_deg": 95.0},
        "coarse_sun_sensors.fov_half_angle_deg",
        ["in (0, 90] deg", "got 95.0"],
    ),
    (
        "two cells",
        {"coarse_sun_sensors.normals_B": [[1, 0, 0], [0, 1, 0]]},
        "coarse_sun_sensors.normals_B",
        ["at least 3 cell normals"],
    ),
    (
        "cell normals in a plane",
        {"coarse_sun_sensors.normals_B": [[1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]]},
        "coarse_sun_sensors.normals_B",
        ["normals spanning three dimensions"],
    ),
    (
        "zero cell normal",
        {"coarse_sun_sensors.normals_B": [[1, 0, 0], [0, 0, 0], [0, 0, 1]]},
        "coarse_sun_sensors.normals_B[1]",
        ["non-zero"],
    ),
    (
        "fine accuracy without its sigma level",
        {"fine_sun_sensor": {"period_s": 0.1, "accuracy_deg": 0.1, "fov_half_angle_deg": 60.0}},
        "fine_sun_sensor.accuracy_sigma_level",
        ["missing required key", "how many sigma accuracy_deg is"],
    ),
    (
        "fine sensor field of view of a hemisphere",
        {
            "fine_sun_sensor": {
                "period_s": 0.1,
                "accuracy_deg": 0.1,
                "accuracy_sigma_level": 3,
                "fov_half_angle_deg": 90.0,
            }
        },
        "fine_sun_sensor.fov_half_angle_deg",
        ["in (0, 90) deg", "got 90.0"],
    ),
    (
        "sun sensors without an orbit",
        {"orbit": None, "environment": None, "detumble": None, "magnetometer": None, "magnetorquers": None},
        "coarse_sun_sensors",
        ["needs an [orbit] table", "the Sun's direction and the eclipses come from the orbit"],
    ),
]


def _apply(edits):
    data = copy.deepcopy(DEFAULT_DATA)
    for path, value in edits.items():
        if "." in path:
            table, key = path.split(".")
            data[table][key] = value
        elif value is None:
            data.pop(path, None)
        else:
            data[path] = value
    if "environment" not in data:
        data.setdefault("requirements", {}).pop("keep_out", None)  # "sun" needs the Sun direction
        data["star_tracker"]["sun_exclusion_deg"] = 35.0
    return data


@pytest.mark.parametrize("edits, key, fragments", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_value_names_key_rule_and_unit(edits, key, fragments):
    with pytest.raises(ConfigError) as info:
        _load(_apply(edits), "bad.toml")
    err = info.value
    assert err.key == key, str(err)
    assert str(err).startswith(f"bad.toml: {key}: ")
    for fragment in fragments:
        assert fragment in str(err), (fragment, str(err))


def test_kepler_sizes_from_altitudes_by_hand():
    from attitude.config import build

    data = _with()
    data["orbit"] = _kepler(perigee_altitude_km=400.0, apogee_altitude_km=1200.0)
    orbit = build.kepler_orbit(_load(data).orbit_config)
    r_p, r_a = R_EARTH + 400e3, R_EARTH + 1200e3
    assert orbit.semi_major_axis_m == pytest.approx((r_p + r_a) / 2, rel=1e-15)
    assert orbit.eccentricity == pytest.approx((r_a - r_p) / (r_a + r_p), rel=1e-14)
    # r_p = a (1 - e): the perigee altitude comes back (rounding of two float operations).
    assert orbit.semi_major_axis_m * (1 - orbit.eccentricity) - R_EARTH == pytest.approx(400e3, rel=1e-12)


def test_tle_checksum_by_hand():
    from attitude.config.reader import _tle_checksum

    # Line 1 of 00005: digits sum 1+5+8+2+2+... (counted here independently) with the one '-' counting 1.
    digits = sum(int(c) for c in TLE_1[:68] if c.isdigit()) + TLE_1[:68].count("-")
    assert _tle_checksum(TLE_1) == digits % 10 == int(TLE_1[68])
    assert _tle_checksum(TLE_2) == int(TLE_2[68])


# ---------------------------------------------------------------------------
# [montecarlo] surface dispersions (flown with the orbit environment)

_SURFACE_DISPERSIONS = {
    "drag_scale": {"distribution": "normal", "sigma_percent": 10.0},
    "residual_dipole": {"distribution": "uniform", "half_width_Am2": 0.004},
    "centre_of_pressure_offset": {"distribution": "normal", "sigma_m": 0.005},
}


def _with_surface_dispersions(**tables):
    data = _with(**tables)
    data["montecarlo"].update(copy.deepcopy(_SURFACE_DISPERSIONS))
    return data


def test_surface_dispersions_read_in_their_units_and_round_trip():
    config = _load(_with_surface_dispersions())
    mc = config.montecarlo
    assert (mc.drag_scale.distribution, mc.drag_scale.scale, mc.drag_scale.unit) == ("normal", 10.0, "percent")
    assert mc.drag_scale.scale_si == pytest.approx(0.10)
    assert (mc.residual_dipole.distribution, mc.residual_dipole.scale_si) == ("uniform", 0.004)  # A m^2
    assert mc.centre_of_pressure_offset.scale_si == 0.005  # m
    assert parse_config(config_to_toml(config)) == config
    # Left out (the default file): None, and the file writes none of them.
    assert default_config().montecarlo.drag_scale is None
    assert "drag_scale" not in config_to_toml(default_config())


@pytest.mark.parametrize(
    ("change", "key", "rule"),
    [
        (("drag_scale", {"distribution": "normal", "sigma_percent": 100.0}), "montecarlo.drag_scale.sigma_percent",
         r"must be below 100 percent \(the drag coefficients must stay positive\), got 100.0"),
        (("residual_dipole", {"distribution": "normal", "sigma_Am2": -1.0}), "montecarlo.residual_dipole.sigma_Am2",
         r"must be non-negative \(>= 0\) \[A m\^2\], got -1.0"),
        (("centre_of_pressure_offset", {"distribution": "normal", "half_width_m": 0.01}),
         "montecarlo.centre_of_pressure_offset.half_width_m", r"only with distribution = 'uniform'"),
        (("drag_scale", {"distribution": "uniform_so3"}), "montecarlo.drag_scale.distribution", r"uniform_so3"),
    ],
)  # fmt: skip
def test_surface_dispersions_refuse_bad_values_naming_the_key(change, key, rule):
    data = _with_surface_dispersions()
    data["montecarlo"][change[0]] = change[1]
    with pytest.raises(ConfigError, match=rf"{re.escape(key)}: .*{rule}"):
        _load(data)


@pytest.mark.parametrize(("missing", "table"), [("surface", "a [surface] table"), ("orbit", "an [orbit] table")])
def test_surface_dispersions_need_an_orbit_and_a_surface(missing, table):
    data = _with_surface_dispersions(**{missing: None})
    if missing == "orbit":  # the tables and models that need an orbit go with it
        for name in ("magnetorquers", "magnetometer", "coarse_sun_sensors", "detumble", "momentum"):
            data.pop(name)
        data["environment"] = {"sun_direction_N": data["environment"]["sun_direction_N"]}
    data["environment"].pop("sources", None)
    with pytest.raises(
        ConfigError, match=rf"montecarlo\.drag_scale: needs {re.escape(table)} \(it disperses the surface"
    ):
        _load(data)


def test_surface_dispersions_leave_the_rest_of_the_file_as_it_was():
    """Reading the new keys must not disturb the other fields (the spacecraft name, the tables)."""
    with_them = _load(_with_surface_dispersions())
    plain = default_config()
    assert with_them.name == plain.name
    assert dataclasses.replace(with_them, montecarlo=plain.montecarlo, source=plain.source) == plain

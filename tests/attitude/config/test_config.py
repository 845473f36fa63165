"""The spacecraft file: the built-in default, round trips, and one test per validation rule.

What each group checks against:

* The built-in default: the objects :mod:`attitude.app.assembly` builds from it against the values
  written in the packaged ``default_spacecraft.toml`` and its comments; the comment arithmetic of
  ``[wheels]`` re-derived from the built objects with the single-axis rest-to-rest slew times of a
  rigid body (bang-bang ``2 sqrt(theta I / tau)`` and rate-limited ``theta / w + w I / tau``, by
  hand: elementary kinematics of constant acceleration); the Sun cone against the eigenaxis path
  sampled by :func:`attitude.quaternion.slerp` (the file's "comes within 25 deg of the Sun").
* The file itself: parsed by the standard library's :mod:`tomllib` (TOML 1.0) as the independent
  reader; every key commented (``attitude init`` is a commented starting point) and listed in the
  schema (``CONFIG_KEYS``).
* Round trips: ``parse_config(config_to_toml(c)) == c`` for the resolved default, a variant using
  every optional form, and whatever loads from random edits (hypothesis); the slew target ``q_start ⊗ q(axis_B, angle)``
  keeps the body axis fixed in inertial space (:func:`attitude.quaternion.rotate`).
* Validation, one snippet per rule: a :class:`attitude.config.ConfigError` whose message names the
  file, the key, the rule and the value (DESIGN.md), TOML syntax errors with the line and column
  :mod:`tomllib` reports, and random garbage in numeric keys (hypothesis) raising only
  ``ConfigError`` or building every object.
"""

from __future__ import annotations

import copy
import datetime
import math
import pickle
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import attitude
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.app import assembly
from attitude.config import (
    CONFIG_KEYS,
    ConfigError,
    SpacecraftConfig,
    config_from_dict,
    config_to_toml,
    default_config,
    default_config_text,
    load_config,
    parse_config,
)
from attitude.config.reader import CONFIG_SIZE_MAX_BYTES
from attitude.config.schema import RENAMED_KEYS, children
from attitude.environment.orbit import CircularOrbit
from attitude.rigid_body import RigidBody
from attitude.sensors import ARCSEC, Gyro, StarTracker

PACKAGED = Path(attitude.__file__).parent / "data" / "default_spacecraft.toml"
DEFAULT_TEXT = PACKAGED.read_text(encoding="utf-8")
DEFAULT_DATA = tomllib.loads(DEFAULT_TEXT)


# ---------------------------------------------------------------------------
# The built-in default


def test_default_loads_and_builds_every_object():
    config = default_config()
    assert isinstance(config, SpacecraftConfig)
    body, wheels, gyro, tracker, orbit = (
        assembly.rigid_body(config),
        assembly.reaction_wheels(config),
        assembly.gyro(config),
        assembly.star_tracker(config),
        assembly.orbit(config),
    )
    assert isinstance(body, RigidBody)
    np.testing.assert_allclose(body.inertia, np.array(config.inertia.tensor_kg_m2))
    assert isinstance(wheels, ReactionWheels) and wheels.n_wheels == 4
    assert isinstance(gyro, Gyro) and gyro.period == 0.1
    assert isinstance(tracker, StarTracker) and tracker.period == 0.2
    # The Sun blinds the tracker with the file's 35 deg, not the preset's 45 deg.
    assert tracker.sun_exclusion == pytest.approx(math.radians(35.0), rel=1e-15)
    assert isinstance(orbit, CircularOrbit)
    assert orbit.altitude_m == pytest.approx(500e3, rel=1e-12)
    assert isinstance(assembly.hub_body(config), RigidBody)
    assert config.control.lqr is not None and config.montecarlo is not None
    assert config.montecarlo.inertia.scale_si == pytest.approx(0.05)
    assert config.montecarlo.gyro_misalignment.scale_si == pytest.approx(100.0 * ARCSEC)


def test_default_slew_is_feasible_as_its_comments_say():
    """The arithmetic left in the default file's [wheels] comment, from the built objects."""
    config = default_config()
    wheels, inertia = assembly.reaction_wheels(config), config.inertia.tensor
    slew = config.requirements.slew
    theta = slew.angle_rad
    assert theta == pytest.approx(math.radians(60.0), rel=1e-12)
    tau = wheels.torque_envelope()[0]  # the slew is about body x
    h_env = 1.0 / np.max(np.abs(wheels.allocation[:, 0]) / wheels.momentum_max)
    i_x = inertia[0, 0]
    assert tau == pytest.approx(0.0162, abs=5e-5)  # "2.31 x 0.007 = 0.0162 N m"
    t_bang_bang = 2.0 * math.sqrt(theta * i_x / tau)
    assert t_bang_bang == pytest.approx(10.1, abs=0.05)
    assert i_x * math.sqrt(theta * tau / i_x) < h_env  # no momentum saturation
    w = slew.rate_max_rad_per_s
    t_rate_limited = theta / w + w / (tau / i_x)
    assert t_rate_limited == pytest.approx(30.8, abs=0.05)
    assert t_rate_limited < slew.time_max_s
    # A rate-limited slew uses less than the wheels' momentum.
    assert i_x * w < h_env


def test_default_sun_keep_out_matters_for_the_slew():
    """The eigenaxis path enters the cone; the start and target attitudes are outside it."""
    config = default_config()
    slew, (cone,) = config.requirements.slew, config.requirements.keep_out
    assert cone.follows_sun and cone.direction_N == config.environment.sun_direction_N
    path = quat.slerp(slew.q_start(), slew.q_target(), np.linspace(0.0, 1.0, 201))
    separation = np.degrees(cone.separation(path))
    assert separation.min() == pytest.approx(25.0, abs=0.1)  # "comes within 25 deg of the Sun"
    assert separation[0] == pytest.approx(38.3, abs=0.05) and separation[-1] == pytest.approx(38.3, abs=0.05)
    assert separation.min() < cone.half_angle_deg < min(separation[0], separation[-1])
    # The tracker sees stars at both ends (same Sun and exclusion as the cone).
    tracker = assembly.star_tracker(config)
    assert not tracker.sun_blinded(0.0, slew.q_start())
    assert not tracker.sun_blinded(0.0, slew.q_target())
    assert tracker.sun_blinded(0.0, path[100])


def test_init_text_is_the_packaged_file_and_loads(tmp_path):
    text = default_config_text()
    assert text == DEFAULT_TEXT
    target = tmp_path / "spacecraft.toml"
    target.write_text(text, encoding="utf-8")
    assert load_config(target) == default_config()
    assert load_config(target).source == str(target)


def test_default_file_comments_every_key():
    """`attitude init` must be a commented starting point: each key line carries a comment.

    A multi-line value (the inertia tensor) is explained by the comment just above it.
    """
    lines = DEFAULT_TEXT.splitlines()
    for i, line in enumerate(lines):
        if not re.match(r"^[A-Za-z_]+ = ", line):
            continue
        explained_above = line.endswith("[") and lines[i - 1].startswith("#")
        assert "#" in line or explained_above, f"key without a comment in the default file: {line!r}"


def test_every_default_key_is_documented_in_the_schema():
    def paths(data, prefix=""):
        for key, value in data.items():
            path = f"{prefix}.{key}" if prefix else key
            yield path
            if isinstance(value, dict):
                yield from paths(value, path)
            elif isinstance(value, list) and value and isinstance(value[0], dict):
                for entry in value:
                    yield from paths(entry, f"{path}[]")

    for path in paths(DEFAULT_DATA):
        assert path in CONFIG_KEYS, path


# ---------------------------------------------------------------------------
# Round trips


def test_resolved_default_round_trips(tmp_path):
    config = default_config()
    text = config_to_toml(config)
    assert parse_config(text, "resolved.toml") == config
    target = tmp_path / "resolved.toml"
    target.write_text(text, encoding="utf-8")
    assert load_config(target) == config
    assert config_to_toml(load_config(target)).splitlines()[2:] == text.splitlines()[2:]  # only the source differs


VARIANT = """
name = "variant \\"quoted\\" \\\\ name"
description = "multi\\nline"

[inertia]
moments_kg_m2 = [12.0, 10, 8.5]

[wheels]
layout = "custom"
axes_B = [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]
spin_inertia_kg_m2 = [0.01, 0.01, 0.01, 0.012]
torque_max_Nm = 0.1
momentum_max_Nms = [1.0, 1.0, 1.0, 1.5]
coulomb_friction_Nm = 1e-4
null_space_gain_per_s = 0.05
bias_momentum_Nms = [0.1, 0.1, 0.1, -0.1]

[gyro]
period_s = 0.05
arw_deg_per_sqrt_h = 0.15
rrw_deg_per_h_per_sqrt_h = 0.3
bias_deg_per_h = [1.0, -2.0, 0.5]
scale_factor_ppm = 200
misalignment_arcsec = [20, -10, 5]
saturation_deg_per_s = inf

[star_tracker]
period_s = 0.25
cross_boresight_arcsec = 3.0
roll_arcsec = 20.0
boresight_B = [0, -1, 1]

[control]
period_s = 0.2
bandwidth_rad_per_s = 0.1
damping = 1.0

[requirements]
pointing_accuracy_deg = 0.01
settling_time_s = 100

[requirements.slew]
target_q_BN = [0.7071, 0.0, 0.7071, 0.0]
time_max_s = 300

[[requirements.keep_out]]
boresight_B = [0, 0, 1]
direction_N = [1, 0, 0]
half_angle_deg = 20

[[requirements.keep_out]]
name = "earth"
boresight_B = [0, -1, 1]
direction_N = [0, 0, -1]
half_angle_deg = 70

[montecarlo]
runs = 3
seed = 0
initial_attitude = { distribution = "uniform_so3" }
initial_rate = { distribution = "uniform", half_width_deg_per_s = 0.2 }
"""


def test_variant_round_trips_and_builds():
    config = parse_config(VARIANT, "variant.toml")
    assert assembly.orbit(config) is None and config.environment.sun_direction_N is None
    assert assembly.reaction_wheels(config).n_wheels == 4
    assert assembly.star_tracker(config).sun_exclusion is None  # no Sun in the scene
    assert np.isinf(assembly.gyro(config).saturation)
    assert config.requirements.keep_out[0].name == "keep_out_0"
    assert config.requirements.slew.angle_rad == pytest.approx(math.pi / 2, abs=1e-4)
    assert config.montecarlo.initial_attitude.scale_si is None
    assert parse_config(config_to_toml(config), "again.toml") == config


def test_wheel_torque_saturation_is_read_built_and_written_back():
    """``wheels.torque_saturation``: 'scale' when left out (the results of before), 'clip' kept by a round trip."""
    assert default_config().wheels_config.torque_saturation == "scale"
    assert assembly.reaction_wheels(default_config()).torque_saturation == "scale"
    text = DEFAULT_TEXT.replace(
        "\nmomentum_max_Nms = 0.050", '\ntorque_saturation = "clip"\nmomentum_max_Nms = 0.050', 1
    )
    config = parse_config(text, "clip.toml")
    assert config.wheels_config.torque_saturation == "clip"
    assert assembly.reaction_wheels(config).torque_saturation == "clip"
    written = config_to_toml(config)
    assert re.search(r'^torque_saturation = "clip"  # ', written, re.M)
    again = parse_config(written, "again.toml")
    assert again == config and again.wheels_config.torque_saturation == "clip"


def test_slew_axis_angle_is_a_body_rotation():
    """``q_target = q_start ⊗ q(axis_B, angle)``: the body axis stays fixed in inertial space."""
    data = copy.deepcopy(DEFAULT_DATA)
    q0 = quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), 0.7)
    data["requirements"]["slew"]["start_q_BN"] = [float(v) for v in q0]
    data["requirements"]["slew"]["axis_B"] = [0.0, 0.0, 2.0]
    slew = config_from_dict(data).requirements.slew
    np.testing.assert_allclose(quat.rotate(slew.q_target(), [0, 0, 1.0]), quat.rotate(q0, [0, 0, 1.0]), atol=1e-15)
    assert slew.angle_rad == pytest.approx(math.radians(60.0), rel=1e-12)


# ---------------------------------------------------------------------------
# Validation: one bad snippet per rule


def _replace(old: str, new: str):
    def edit(text: str) -> str:
        assert old in text, f"test snippet not found in the default file: {old!r}"
        return text.replace(old, new, 1)

    return edit


def _replace_re(pattern: str, new: str):
    def edit(text: str) -> str:
        out, n = re.subn(pattern, new, text, count=1, flags=re.M | re.S)
        assert n == 1, pattern
        return out

    return edit


def _drop_line(start: str):
    def edit(text: str) -> str:
        lines = text.splitlines(keepends=True)
        kept = [line for line in lines if not line.startswith(start)]
        assert len(kept) == len(lines) - 1, f"expected one line starting with {start!r}"
        return "".join(kept)

    return edit


def _drop_table(header: str):
    def edit(text: str) -> str:
        pattern = re.compile(rf"^{re.escape(header)}\n.*?(?=^\[)", re.M | re.S)
        out, n = pattern.subn("", text, count=1)
        assert n == 1, header
        return out

    return edit


BAD = [
    # (id, edit of the default file, key, fragment of the message)
    (
        "unknown key",
        _replace("\ntorque_max_Nm = 0.007", "\ntorque_max = 0.007"),
        "wheels.torque_max",
        "unknown key; did you mean 'torque_max_Nm'?",
    ),
    (
        "unknown key with a unit suffix",
        _replace("altitude_km = 500.0", "altitude_m = 500e3"),
        "orbit.altitude_m",
        "did you mean 'altitude_km'?",
    ),
    ("unknown table", _replace("[star_tracker]", "[startracker]"), "startracker", "did you mean 'star_tracker'?"),
    (
        "unknown key, no close match",
        _replace('name = "Default', 'zzz = 1\nname = "Default'),
        "zzz",
        "unknown key. Keys of the top level: name, description",
    ),
    ("missing required", _drop_line("momentum_max_Nms"), "wheels.momentum_max_Nms", "missing required key"),
    ("missing table", _drop_table("[gyro]"), "gyro", "missing required table: add a [gyro] table"),
    (
        "missing inertia",
        _replace_re(r"^tensor_kg_m2 = \[.*?^\]\n", ""),
        "inertia.moments_kg_m2",
        "moments_kg_m2 = [Ixx, Iyy, Izz]",
    ),
    (
        "missing slew angle",
        _drop_line("angle_deg = 60.0"),
        "requirements.slew.angle_deg",
        "missing required key (slew angle about axis_B",
    ),
    ("wrong type: string", _replace('layout = "pyramid"', "layout = 4"), "wheels.layout", "expected a string"),
    ("wrong type: boolean", _replace("damping = 0.7", "damping = true"), "control.damping", "got the boolean true"),
    ("wrong type: table", _replace("seed = 12345", "seed = 1.5"), "montecarlo.seed", "expected an integer"),
    (
        "wrong length",
        _replace("\ntorque_max_Nm = 0.007", "\ntorque_max_Nm = [0.007, 0.007]"),
        "wheels.torque_max_Nm",
        "list of 4 (one per wheel), got 2",
    ),
    (
        "wrong vector length",
        _replace("axis_B = [1.0, 0.0, 0.0]", "axis_B = [1.0, 0.0]"),
        "requirements.slew.axis_B",
        "expected a list of 3 numbers, got 2",
    ),
    (
        "units in a string",
        _replace("\ntorque_max_Nm = 0.007", '\ntorque_max_Nm = "0.007 Nm"'),
        "wheels.torque_max_Nm",
        "units given where a number is expected: got '0.007 Nm'; write 0.007 (the unit is fixed by the key name",
    ),
    (
        "other units in a string",
        _replace("\ntorque_max_Nm = 0.007", '\ntorque_max_Nm = "7 mNm"'),
        "wheels.torque_max_Nm",
        "write a bare number in N m (the unit is fixed by the key name; convert from 'mNm' first)",
    ),
    (
        "units in a tensor entry",
        _replace("[0.390, 0.004, -0.003]", '["0.39 kg m^2", 0.004, -0.003]'),
        "inertia.tensor_kg_m2[0][0]",
        "units given where a number is expected: got '0.39 kg m^2'; write 0.39",
    ),
    (
        "units in degrees",
        _replace("angle_deg = 60.0", 'angle_deg = "60 degrees"'),
        "requirements.slew.angle_deg",
        "write 60 (the unit is fixed by the key name: deg)",
    ),
    (
        "units on a dimensionless key",
        _replace("damping = 0.7", 'damping = "0.7 deg"'),
        "control.damping",
        "write 0.7 (this key takes no unit)",
    ),
    (
        "a date where a number is expected",
        _replace("time_max_s = 120.0", "time_max_s = 2024-06-01"),
        "requirements.slew.time_max_s",
        "expected a number, got the date/time 2024-06-01",
    ),
    ("quoted number", _replace("period_s = 0.1 ", 'period_s = "0.1" '), "gyro.period_s", "write 0.1 without quotes"),
    (
        "triangle inequality",
        _replace("[-0.003, 0.002, 0.210]", "[-0.003, 0.002, 0.810]"),
        "inertia.tensor_kg_m2",
        "physically realisable",
    ),
    (
        "asymmetric tensor",
        _replace("[0.004, 0.360, 0.002]", "[0.005, 0.360, 0.002]"),
        "inertia.tensor_kg_m2",
        "symmetric",
    ),
    (
        "not positive definite",
        _replace("[0.390, 0.004, -0.003]", "[-0.390, 0.004, -0.003]"),
        "inertia.tensor_kg_m2",
        "positive definite",
    ),
    ("negative limit", _replace("\ntorque_max_Nm = 0.007", "\ntorque_max_Nm = -0.007"), "wheels.torque_max_Nm", "> 0"),
    (
        "negative per-wheel limit",
        _replace("momentum_max_Nms = 0.050", "momentum_max_Nms = [0.05, 0.05, -0.05, 0.05]"),
        "wheels.momentum_max_Nms[2]",
        "strictly positive",
    ),
    ("infinite limit", _replace("\ntorque_max_Nm = 0.007", "\ntorque_max_Nm = inf"), "wheels.torque_max_Nm", "finite"),
    ("nan", _replace("damping = 0.7", "damping = nan"), "control.damping", "got nan"),
    (
        "wheels heavier than the body",
        _replace("spin_inertia_kg_m2 = 8.0e-5", "spin_inertia_kg_m2 = 0.5"),
        "wheels.spin_inertia_kg_m2",
        "the wheels' spin inertia leaves no physical body",
    ),
    (
        "unknown gyro preset",
        _replace('preset = "mems"', 'preset = "mem"'),
        "gyro.preset",
        "unknown gyro preset 'mem'; did you mean 'mems'? Valid: 'mems', 'tactical', 'navigation'",
    ),
    (
        "unknown star tracker preset",
        _replace('preset = "typical"', 'preset = "nst"'),
        "star_tracker.preset",
        "unknown star tracker preset 'nst'. Valid: 'typical'",
    ),
    (
        "unknown layout",
        _replace('layout = "pyramid"', 'layout = "pyramidal"'),
        "wheels.layout",
        "did you mean 'pyramid'?",
    ),
    (
        "unknown wheel torque saturation",
        _replace("\nmomentum_max_Nms = 0.050", '\ntorque_saturation = "clamp"\nmomentum_max_Nms = 0.050'),
        "wheels.torque_saturation",
        "unknown saturation mode 'clamp'; did you mean 'clip'? Valid: 'scale', 'clip'",
    ),
    (
        "wheel torque saturation not a string",
        _replace("\nmomentum_max_Nms = 0.050", "\ntorque_saturation = 1\nmomentum_max_Nms = 0.050"),
        "wheels.torque_saturation",
        "expected a string (one of 'scale', 'clip'), got the integer 1",
    ),
    (
        "rank-deficient wheel axes",
        _replace_re(
            r'^layout = "pyramid"[^\n]*\ncount = 4[^\n]*',
            'layout = "custom"\naxes_B = [[1, 0, 0], [0, 1, 0], [1, 1, 0]]',
        ),
        "wheels.axes_B",
        "rank 3",
    ),
    (
        "zero wheel axis",
        _replace_re(
            r'^layout = "pyramid"[^\n]*\ncount = 4[^\n]*',
            'layout = "custom"\naxes_B = [[1, 0, 0], [0, 1, 0], [0, 0, 0]]',
        ),
        "wheels.axes_B[2]",
        "non-zero",
    ),
    ("pyramid count", _replace("count = 4 ", "count = 5 "), "wheels.count", "must be 4 for layout = 'pyramid'"),
    (
        "axes with a named layout",
        _replace("count = 4 ", "axes_B = [[1, 0, 0]]\ncount = 4 "),
        "wheels.axes_B",
        "only for layout = 'custom'",
    ),
    ("zero period", _replace("period_s = 0.1 ", "period_s = 0 "), "gyro.period_s", "strictly positive"),
    (
        "bandwidth above Nyquist",
        _replace("bandwidth_rad_per_s = 0.4", "bandwidth_rad_per_s = 40.0"),
        "control.bandwidth_rad_per_s",
        "Nyquist",
    ),
    (
        "one axis's bandwidth above Nyquist",
        _replace("bandwidth_rad_per_s = 0.4", "bandwidth_rad_per_s = [0.4, 40.0, 0.4]"),
        "control.bandwidth_rad_per_s[1]",
        "Nyquist",
    ),
    (
        "a damping per axis of the wrong length",
        _replace("damping = 0.7 ", "damping = [0.7, 0.7] "),
        "control.damping",
        "3",
    ),
    (
        # 0.664 x 1 deg/h at the preset's 100 s is below the ARW line 0.34 x 60 / sqrt(100) = 2 deg/h.
        "bias instability floor under the ARW line",
        _replace(
            'preset = "mems"', 'preset = "mems"\nrrw_deg_per_h_per_sqrt_h = 1.0\nbias_instability_deg_per_h = 1.0'
        ),
        "gyro",
        "within sqrt",
    ),
    (
        "gyro without preset or ARW",
        _replace('preset = "mems"', "saturation_deg_per_s = 100.0"),
        "gyro.arw_deg_per_sqrt_h",
        "or a preset ('mems'",
    ),
    (
        "sun exclusion out of range",
        _replace("sun_exclusion_deg = 35.0", "sun_exclusion_deg = 190.0"),
        "star_tracker.sun_exclusion_deg",
        "in (0, 180) deg",
    ),
    (
        "keep-out half-angle",
        _replace("half_angle_deg = 35.0", "half_angle_deg = -5"),
        "requirements.keep_out[0].half_angle_deg",
        "in (0, 180) deg",
    ),
    (
        "keep-out unknown key",
        _replace("half_angle_deg = 35.0", "half_angle = 35.0"),
        "requirements.keep_out[0].half_angle",
        "did you mean 'half_angle_deg'?",
    ),
    ("sun without a Sun", _drop_table("[environment]"), "requirements.keep_out[0].direction_N", "sun_direction_N"),
    (
        "two slew targets",
        _replace("time_max_s = 120.0", "time_max_s = 120.0\ntarget_q_BN = [1, 0, 0, 0]"),
        "requirements.slew.angle_deg",
        "not both",
    ),
    (
        "slew angle out of range",
        _replace("angle_deg = 60.0", "angle_deg = 270.0"),
        "requirements.slew.angle_deg",
        "in (0, 180] deg",
    ),
    ("inclination", _replace("inclination_deg = 97.4", "inclination_deg = 200"), "orbit.inclination_deg", "[0, 180]"),
    (
        "unknown distribution",
        _replace('inertia = { distribution = "normal"', 'inertia = { distribution = "gauss"'),
        "montecarlo.inertia.distribution",
        "Valid: 'normal', 'uniform'",
    ),
    (
        "dispersion scale key",
        _replace("sigma_percent = 5.0", "half_width_percent = 5.0"),
        "montecarlo.inertia.half_width_percent",
        "only with distribution = 'uniform'",
    ),
    (
        "renamed LQR key",
        _replace("\nangle_max_deg = 1.0", "\nmax_angle_deg = 1.0"),
        "control.lqr.max_angle_deg",
        "control.lqr.max_angle_deg was renamed angle_max_deg (names read quantity, qualifier, unit",
    ),
    (
        "renamed slew key",
        _replace("\ntime_max_s = 120.0", "\nmax_time_s = 120.0"),
        "requirements.slew.max_time_s",
        "requirements.slew.max_time_s was renamed time_max_s (names read quantity, qualifier, unit",
    ),
    ("negative seed", _replace("seed = 12345", "seed = -1"), "montecarlo.seed", "non-negative integer"),
    ("zero runs", _replace("runs = 20", "runs = 0"), "montecarlo.runs", "positive integer"),
]


@pytest.mark.parametrize(("edit", "key", "fragment"), [case[1:] for case in BAD], ids=[case[0] for case in BAD])
def test_bad_file_names_key_and_file(tmp_path, edit, key, fragment):
    path = tmp_path / "bad_spacecraft.toml"
    path.write_text(edit(DEFAULT_TEXT), encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    err = info.value
    assert isinstance(err, ValueError)
    assert err.key == key
    assert err.file == str(path)
    assert str(err).startswith(f"{path}: {key}: ")
    assert fragment in str(err)


@pytest.mark.parametrize(("old", "new"), list(RENAMED_KEYS.items()))
def test_renamed_key_names_the_new_key_and_the_rule(old, new):
    table, _, key = old.rpartition(".")
    assert new in children(table) and key not in children(table)
    data = tomllib.loads(DEFAULT_TEXT)
    section = data
    for part in table.split("."):
        section = section[part]
    section[key] = section.pop(new)
    with pytest.raises(ConfigError) as info:
        config_from_dict(data)
    assert info.value.key == old
    assert f"{old} was renamed {new} (names read quantity, qualifier, unit" in str(info.value)
    assert "unknown key" not in str(info.value)


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        ("[inertia]\nmoments_kg_m2 = [1, 2, 3\n[wheels]\n", 3, 1),  # unclosed array
        ('name = "x"\nname = "y"\n', 2, 11),  # duplicate key
        ("[control]\nperiod_s = 0.1 s\n", 2, 16),  # a unit after a number: a TOML syntax error
    ],
)
def test_toml_syntax_error_names_file_line_and_column(tmp_path, text, line, column):
    path = tmp_path / "broken.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    err = info.value
    assert err.key is None and err.file == str(path)
    assert (err.line, err.column) == (line, column)
    assert str(err).startswith(f"{path}: line {line}, column {column}: TOML syntax error: ")


def test_syntax_error_at_end_of_document():
    with pytest.raises(ConfigError, match=r"^x\.toml: at the end of the file: TOML syntax error: Invalid value"):
        parse_config("a = ", "x.toml")


def test_unreadable_and_non_utf8_files(tmp_path):
    with pytest.raises(ConfigError, match="cannot read the file") as info:
        load_config(tmp_path / "missing.toml")
    assert info.value.file == str(tmp_path / "missing.toml")
    latin = tmp_path / "latin.toml"
    latin.write_bytes('name = "caf\xe9"\n'.encode("latin-1"))
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_config(latin)


def test_deep_nesting_and_endless_files_are_clear_errors(tmp_path):
    """Issue 13, item 9: deeply nested TOML raised RecursionError, and /dev/zero filled the memory."""
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="nested too deeply") as info:
        load_config(deep)
    assert info.value.file == str(deep)
    big = tmp_path / "big.toml"
    with big.open("wb") as handle:  # sparse: the size without the disk use
        handle.truncate(CONFIG_SIZE_MAX_BYTES + 1)
    with pytest.raises(ConfigError, match="larger than 16 MiB: not a spacecraft file"):
        load_config(big)


def test_config_error_pickles():
    err = ConfigError("must be > 0", key="wheels.torque_max_Nm", file="sc.toml")
    back = pickle.loads(pickle.dumps(err))
    assert (back.key, back.file, str(back)) == (err.key, err.file, str(err))
    assert str(err) == "sc.toml: wheels.torque_max_Nm: must be > 0"


# ---------------------------------------------------------------------------
# Garbage in numeric keys: ConfigError or a configuration that builds


def _numeric_paths(data, prefix=()):
    for key, value in data.items():
        path = (*prefix, key)
        if isinstance(value, dict):
            yield from _numeric_paths(value, path)
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for i, entry in enumerate(value):
                yield from _numeric_paths(entry, (*path, i))
        elif isinstance(value, (int, float, list)) and not isinstance(value, bool):
            yield path


NUMERIC_PATHS = sorted(_numeric_paths(DEFAULT_DATA), key=str)
TABLE_PATHS = [(k,) for k, v in DEFAULT_DATA.items() if isinstance(v, dict)]

_finite_or_not = st.floats(allow_nan=True, allow_infinity=True)
GARBAGE = st.one_of(
    _finite_or_not,
    st.floats(min_value=-1e3, max_value=1e3),
    st.sampled_from([0.0, -0.0, 1e-320, 1e308, -1e308, 2**63, -(2**63), 10**400]),
    st.integers(),
    st.booleans(),
    st.text(max_size=8),
    st.sampled_from(["10 kg m^2", "0.05 Nm", "5 deg", "1e3", "", "nan", "inf", "sun"]),
    st.lists(_finite_or_not, max_size=5),
    st.lists(st.lists(st.floats(min_value=-2, max_value=2), min_size=3, max_size=3), max_size=4),
    st.dictionaries(st.text(max_size=4), st.integers(), max_size=2),
    st.datetimes(min_value=datetime.datetime(2000, 1, 1)),
)


def _set(data, path, value):
    target = data
    for step in path[:-1]:
        if not isinstance(target, (dict, list)) or (isinstance(target, list) and not isinstance(step, int)):
            return  # an earlier edit replaced the parent table by garbage
        try:
            target = target[step]
        except (KeyError, IndexError):
            return
    if isinstance(target, dict) or (isinstance(target, list) and isinstance(path[-1], int) and path[-1] < len(target)):
        target[path[-1]] = value


def _top_table(key: str) -> str:
    return re.split(r"[.\[]", key)[0]


@given(
    edits=st.lists(st.tuples(st.sampled_from(NUMERIC_PATHS + TABLE_PATHS), GARBAGE), min_size=1, max_size=3),
)
def test_garbage_values_raise_only_config_errors(edits):
    data = copy.deepcopy(DEFAULT_DATA)
    for path, value in edits:
        _set(data, path, value)
    try:
        config = config_from_dict(data, "garbage.toml")
    except ConfigError as err:
        assert err.file == "garbage.toml" and err.key is not None
        assert str(err).startswith(f"garbage.toml: {err.key}: ")
        touched = {path[0] for path, _ in edits}
        # Inertia and Sun changes are checked against the wheels, tracker and keep-out cones.
        allowed = touched | ({"wheels"} if "inertia" in touched else set())
        allowed |= {"star_tracker", "requirements"} if "environment" in touched else set()
        assert _top_table(err.key) in allowed, (err.key, touched)
        return
    # Whatever loads builds every object and round-trips.
    (
        assembly.rigid_body(config),
        assembly.reaction_wheels(config),
        assembly.hub_body(config),
        assembly.gyro(config),
        assembly.star_tracker(config),
        assembly.orbit(config),
    )
    assert parse_config(config_to_toml(config), "again.toml") == config


@pytest.mark.parametrize("key", ["start_q_BN", "target_q_BN"])
def test_a_non_unit_quaternion_is_rejected_with_its_key(key, tmp_path):
    text = default_config_text()
    lines = [
        ln
        for ln in text.splitlines()
        if not ln.strip().startswith(("angle_deg", "axis_B", "start_q_BN", "target_q_BN"))
    ]
    i = lines.index("[requirements.slew]")
    lines.insert(i + 1, f"{key} = [1.0, 1.0, 0.0, 0.0]")
    if key == "start_q_BN":
        lines.insert(i + 1, "target_q_BN = [0.7071, 0.0, 0.7071, 0.0]")  # 4 digits as typed: accepted
    path = tmp_path / "bad.toml"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ConfigError, match="must be a unit quaternion") as info:
        load_config(path)
    assert info.value.key == f"requirements.slew.{key}"
    assert str(path) in str(info.value)


def test_montecarlo_disperses_principal_axes_and_gyro_bias():
    from attitude.montecarlo.dispersions import InertiaDispersion, Normal, dispersions_from_config

    data = copy.deepcopy(DEFAULT_DATA)
    data["montecarlo"]["inertia"]["axis_sigma_deg"] = 1.5
    data["montecarlo"]["gyro_bias"] = {"distribution": "normal", "sigma_deg_per_h": 20.0}
    config = config_from_dict(data, "mc.toml")
    mc = config.montecarlo
    assert mc.inertia.axis_sigma_deg == 1.5
    assert mc.gyro_bias.scale_si == pytest.approx(math.radians(20.0) / 3600.0)
    assert parse_config(config_to_toml(config), "again.toml") == config
    dispersions = dispersions_from_config(mc, assembly.rigid_body(config).inertia, config.requirements.slew.q_start())
    assert isinstance(dispersions["inertia"], InertiaDispersion)
    assert dispersions["inertia"].axis_sigma == pytest.approx(math.radians(1.5))
    assert isinstance(dispersions["gyro_bias"], Normal)
    np.testing.assert_allclose(dispersions["gyro_bias"].sigma, math.radians(20.0) / 3600.0)
    for value, rule in ((-1.0, "non-negative"), (45.0, "at most 30 deg")):
        data["montecarlo"]["inertia"]["axis_sigma_deg"] = value
        with pytest.raises(ConfigError, match=rf"montecarlo\.inertia\.axis_sigma_deg: .*{rule}"):
            config_from_dict(data, "mc.toml")
    data["montecarlo"]["inertia"]["axis_sigma_deg"] = 1.0
    data["montecarlo"]["initial_rate"]["axis_sigma_deg"] = 1.0  # only the inertia has axes
    with pytest.raises(ConfigError, match=r"montecarlo\.initial_rate\.axis_sigma_deg: unknown key"):
        config_from_dict(data, "mc.toml")


def test_a_pd_per_axis_reads_and_builds_and_the_rate_limited_pd_refuses_it():
    """[control] bandwidth and damping per axis: read as three values, the PD built with K = 2 J diag(wn^2) and
    C = 2 J diag(zeta wn) (QuaternionPD.from_bandwidth's formula, evaluated here with numpy); the rate-limited
    eigenaxis PD, which needs one bandwidth (K = k J), refuses the file naming the key."""
    text = default_config_text().replace("bandwidth_rad_per_s = 0.4", "bandwidth_rad_per_s = [0.4, 0.5, 0.6]", 1)
    text = text.replace("damping = 0.7 ", "damping = [0.7, 0.8, 0.9] ", 1)
    config = parse_config(text)
    assert config.control.per_axis and config.control.bandwidth_rad_per_s == (0.4, 0.5, 0.6)
    pd = assembly.quaternion_pd(config)
    inertia = assembly.rigid_body(config).inertia
    wn, zeta = np.array([0.4, 0.5, 0.6]), np.array([0.7, 0.8, 0.9])
    np.testing.assert_allclose(pd.K, 2.0 * inertia @ np.diag(wn**2), rtol=1e-14)
    np.testing.assert_allclose(pd.C, 2.0 * inertia @ np.diag(zeta * wn), rtol=1e-14)
    with pytest.raises(ConfigError, match=r"control\.bandwidth_rad_per_s"):
        assembly.rate_limited_pd(config, rate_max_rad_per_s=0.05)

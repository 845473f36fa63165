"""The ``[[flexible_modes]]`` tables of a spacecraft file: reading, building, writing back, and each rule.

What each test checks against:

* the default file's commented example, uncommented: the modes built are the
  numbers written (frequency ``2 pi f``), and the linear model of the
  assembly has the unconstrained frequencies of the one-mode-per-axis formula
  ``W / sqrt(1 - l^2 / I_axis)`` (docs/flexible_modes.md) about the axes the
  modes couple to; left commented, the default file is rigid as before;
* the round trip ``parse_config(config_to_toml(c)) == c``;
* one snippet per rule: a :class:`ConfigError` naming the file, the key, the
  rule and the value (negative damping is the issue's own example).
"""

from __future__ import annotations

import re

import control
import numpy as np
import pytest

from attitude.app import assembly
from attitude.config import ConfigError, config_to_toml, default_config, default_config_text, parse_config
from attitude.flexible import FlexibleModes

DEFAULT_TEXT = default_config_text()


def _uncommented_example() -> str:
    """The default file with its commented ``[[flexible_modes]]`` example switched on."""
    start = DEFAULT_TEXT.index("# [[flexible_modes]]")
    end = DEFAULT_TEXT.index("[requirements]")
    block = DEFAULT_TEXT[start:end]
    on = re.sub(
        r"^# (\[\[flexible_modes\]\]$|frequency_Hz = |damping = |participation_B_sqrt_kg_m = )",
        r"\1",
        block,
        flags=re.M,
    )
    return DEFAULT_TEXT[:start] + on + DEFAULT_TEXT[end:]


def _with_modes(entries: str) -> str:
    return DEFAULT_TEXT.replace("[requirements]\n", entries + "\n[requirements]\n", 1)


def test_the_default_file_stays_rigid():
    """The example is commented out: no modes, no flexible plant."""
    config = default_config()
    assert config.flexible_modes == ()
    assert assembly.flexible_modes(config) is None
    assert assembly.flexible_plant_model(config) is None


def test_the_default_example_builds_the_modes_it_writes():
    """Uncommented, the example gives the two modes as written; the plant's undamped poles are the
    unconstrained frequencies ``W / sqrt(1 - l^2 / I)`` (one mode per principal axis: the default body's
    products of inertia are 1 % of its moments, so the formula holds to ~1e-4 relative; 1e-3 is checked)."""
    config = parse_config(_uncommented_example(), "flexible.toml")
    modes = assembly.flexible_modes(config)
    assert isinstance(modes, FlexibleModes)
    np.testing.assert_allclose(modes.frequency, 2.0 * np.pi * np.array([2.0, 3.0]), rtol=1e-15)
    np.testing.assert_array_equal(modes.damping, [0.005, 0.005])
    np.testing.assert_array_equal(modes.participation, [[0.0, 0.0, 0.14], [0.0, 0.07, 0.0]])
    body = assembly.rigid_body(config)
    inertia = body.inertia
    expected = [
        2.0 * np.pi * 2.0 / np.sqrt(1.0 - 0.14**2 / inertia[2, 2]),
        2.0 * np.pi * 3.0 / np.sqrt(1.0 - 0.07**2 / inertia[1, 1]),
    ]
    poles = control.poles(assembly.flexible_plant_model(config))
    oscillating = np.sort(np.abs(poles[np.abs(poles) > 1.0]))[::2]  # one of each conjugate pair
    np.testing.assert_allclose(oscillating, expected, rtol=1e-3)
    assert parse_config(config_to_toml(config), "again.toml") == config


def test_modes_round_trip_through_the_resolved_file():
    """``parse_config(config_to_toml(c)) == c`` with three modes, the written file naming the table."""
    text = _with_modes(
        "[[flexible_modes]]\nfrequency_Hz = 0.8\ndamping = 0.0\nparticipation_B_sqrt_kg_m = [0.1, -0.05, 0.02]\n"
        "[[flexible_modes]]\nfrequency_Hz = 1.7\ndamping = 0.01\nparticipation_B_sqrt_kg_m = [0, 0.2, 0]\n"
        "[[flexible_modes]]\nfrequency_Hz = 12\ndamping = 0.02\nparticipation_B_sqrt_kg_m = [0, 0, 0]\n"
    )
    config = parse_config(text, "modes.toml")
    written = config_to_toml(config)
    assert len(re.findall(r"^\[\[flexible_modes\]\]", written, flags=re.M)) == 3
    assert parse_config(written, "again.toml") == config
    assert config.flexible_modes[2].frequency_Hz == 12.0


MODE = "[[flexible_modes]]\nfrequency_Hz = {f}\ndamping = {z}\nparticipation_B_sqrt_kg_m = {p}\n"

BAD = [
    ("negative damping", MODE.format(f=2.0, z=-0.01, p="[0, 0, 0.1]"), "flexible_modes[0].damping", "in [0, 1)"),
    ("damping of one", MODE.format(f=2.0, z=1.0, p="[0, 0, 0.1]"), "flexible_modes[0].damping", "got 1.0"),
    ("zero frequency", MODE.format(f=0.0, z=0.01, p="[0, 0, 0.1]"), "flexible_modes[0].frequency_Hz", "> 0"),
    (
        "negative frequency in the second mode",
        MODE.format(f=2.0, z=0.01, p="[0, 0, 0.1]") + MODE.format(f=-3.0, z=0.01, p="[0, 0.1, 0]"),
        "flexible_modes[1].frequency_Hz",
        "strictly positive",
    ),
    (
        "frequency with a unit",
        MODE.format(f='"2 Hz"', z=0.01, p="[0, 0, 0.1]"),
        "flexible_modes[0].frequency_Hz",
        "the unit is fixed by the key name",
    ),
    (
        "participation of two entries",
        MODE.format(f=2.0, z=0.01, p="[0, 0.1]"),
        "flexible_modes[0].participation_B_sqrt_kg_m",
        "expected a list of 3 numbers",
    ),
    (
        "more inertia in the modes than the spacecraft has",
        MODE.format(f=2.0, z=0.01, p="[0, 0, 0.5]"),  # 0.25 kg m^2 > I_zz = 0.21 kg m^2
        "flexible_modes[].participation_B_sqrt_kg_m",
        "I - L^T L positive definite",
    ),
    (
        "missing damping",
        "[[flexible_modes]]\nfrequency_Hz = 2.0\nparticipation_B_sqrt_kg_m = [0, 0, 0.1]\n",
        "flexible_modes[0].damping",
        "missing required key",
    ),
    (
        "unknown key",
        MODE.format(f=2.0, z=0.01, p="[0, 0, 0.1]") + "frequency_rad_per_s = 3.0\n",
        "flexible_modes[0].frequency_rad_per_s",
        "unknown key",
    ),
    ("not an array of tables", "flexible_modes = 3\n", "flexible_modes", "expected an array of tables"),
]


@pytest.mark.parametrize(("entries", "key", "fragment"), [case[1:] for case in BAD], ids=[case[0] for case in BAD])
def test_bad_modes_name_the_key_and_the_rule(entries, key, fragment):
    """Each bad entry raises ConfigError on its key, naming the file, with the rule or the value."""
    text = _with_modes(entries) if entries.startswith("[[") else entries + DEFAULT_TEXT
    with pytest.raises(ConfigError) as info:
        parse_config(text, "bad.toml")
    assert info.value.key == key
    assert str(info.value).startswith(f"bad.toml: {key}: ")
    assert fragment in str(info.value)

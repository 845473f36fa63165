"""The ``[uncertainty]`` table: read, validated (each rule named with its key), written back, assembled.

Checked against: the file's own values (round trip through config_to_toml, equality of the dataclasses),
the triangle inequality of the principal moments at every corner of the +-inertia_percent box (the default
spacecraft's moments 0.210, 0.360, 0.391 kg m^2: 0.391 (1 + p) <= 0.570 (1 - p) holds up to p = 18.6 %).
"""

import pytest

from attitude.app import assembly
from attitude.config import ConfigError, config_to_toml, default_config_text, parse_config

TABLE = """
[uncertainty]
inertia_percent = 10.0
axis_rotation_deg = 5.0
wheel_misalignment_deg = 1.0
extra_delay_s = 0.1
"""


def _with(table: str):
    return parse_config(default_config_text() + table, "test.toml")


def test_the_table_is_read_written_back_and_assembled():
    config = _with(TABLE)
    u = config.uncertainty
    assert (u.inertia_percent, u.axis_rotation_deg, u.wheel_misalignment_deg, u.extra_delay_s) == (10.0, 5.0, 1.0, 0.1)
    assert parse_config(config_to_toml(config)) == config
    built = assembly.uncertainty_set(config)
    assert built.inertia_percent == 10.0 and built.extra_delay_s == 0.1
    assert "[uncertainty]" in config_to_toml(config)


def test_left_out_the_table_is_none_and_a_left_out_key_is_zero():
    assert parse_config(default_config_text()).uncertainty is None
    assert assembly.uncertainty_set(parse_config(default_config_text())) is None
    assert _with("\n[uncertainty]\nextra_delay_s = 0.05\n").uncertainty.inertia_percent == 0.0


@pytest.mark.parametrize(
    ("table", "key", "match"),
    [
        ("inertia_percent = -1.0", "uncertainty.inertia_percent", "non-negative"),
        ("inertia_percent = 100.0", "uncertainty.inertia_percent", "below 100"),
        ("inertia_percent = 20.0", "uncertainty.inertia_percent", "no physical body at the corner"),
        ("axis_rotation_deg = 181.0", "uncertainty.axis_rotation_deg", "at most 180"),
        ("wheel_misalignment_deg = 90.0", "uncertainty.wheel_misalignment_deg", "below 90"),
        ('extra_delay_s = "0.1 s"', "uncertainty.extra_delay_s", "units given"),
        ("extra_delay = 0.1", "uncertainty.extra_delay", "unknown key"),
    ],
)
def test_bad_values_are_refused_with_the_key_named(table, key, match):
    with pytest.raises(ConfigError, match=match) as info:
        _with(f"\n[uncertainty]\n{table}\n")
    assert info.value.key == key

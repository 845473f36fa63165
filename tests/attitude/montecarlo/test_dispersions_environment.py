"""The surface dispersions of a campaign in orbit (attitude.montecarlo.dispersions).

Checked against the distributions they claim, with sampling tolerances from the sample sizes
(standard errors: ``sigma / sqrt(n)`` for a mean, ``sigma / sqrt(2 n)`` for a standard deviation;
bounds at 5 standard errors, so a correct sampler fails about once in 3 million), and the
per-run streams of :func:`attitude.montecarlo.dispersions.draw_parameters` (adding the surface
dispersions does not change the values drawn for the others).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from attitude.app import assembly
from attitude.config import default_config
from attitude.config.model import Dispersion as DispersionConfig
from attitude.montecarlo.dispersions import Normal, RelativeScale, Uniform, dispersions_from_config, draw_parameters

CONFIG = default_config()
N = 4000


def _campaign_dispersions(**entries):
    mc = dataclasses.replace(CONFIG.montecarlo, **entries)
    return dispersions_from_config(
        mc,
        assembly.rigid_body(CONFIG).inertia,
        CONFIG.requirements.slew.q_start(),
        residual_dipole_Am2=assembly.surface(CONFIG).residual_dipole_Am2,
    )


def test_the_file_s_surface_dispersions_draw_what_they_declare():
    dispersions = _campaign_dispersions(
        drag_scale=DispersionConfig("normal", 10.0, "percent"),
        residual_dipole=DispersionConfig("normal", 0.005, "Am2"),
        centre_of_pressure_offset=DispersionConfig("uniform", 0.01, "m"),
    )
    assert isinstance(dispersions["drag_scale"], RelativeScale)
    assert isinstance(dispersions["residual_dipole"], Normal)
    assert isinstance(dispersions["centre_of_pressure_offset"], Uniform)
    runs = [draw_parameters(dispersions, 2024, i) for i in range(N)]
    drag = np.array([r["drag_scale"] for r in runs])
    dipole = np.array([r["residual_dipole"] for r in runs])
    offset = np.array([r["centre_of_pressure_offset"] for r in runs])
    se = 1.0 / np.sqrt(N)
    # drag scale ~ N(1, 0.1): measured mean 1.0005, std 0.1011
    assert abs(drag.mean() - 1.0) < 5 * 0.1 * se
    assert abs(drag.std(ddof=1) - 0.1) < 5 * 0.1 * se / np.sqrt(2)
    # residual dipole ~ N(file's [0.005, 0.005, -0.01], 0.005) per axis [A m^2]
    nominal = assembly.surface(CONFIG).residual_dipole_Am2
    assert np.all(np.abs(dipole.mean(axis=0) - nominal) < 5 * 0.005 * se)
    assert np.all(np.abs(dipole.std(axis=0, ddof=1) - 0.005) < 5 * 0.005 * se / np.sqrt(2))
    assert abs(np.corrcoef(dipole.T)[0, 1]) < 5 * se  # axes independent
    # offset ~ U(-1 cm, 1 cm) per axis: inside the bounds, std h / sqrt(3)
    assert np.all(np.abs(offset) <= 0.01)
    assert np.all(np.abs(offset.std(axis=0, ddof=1) - 0.01 / np.sqrt(3)) < 5 * 0.01 * se)
    # The other dispersions draw the same values with or without the surface ones (own streams).
    plain = _campaign_dispersions()
    for i in (0, 17):
        with_surface, without = draw_parameters(dispersions, 2024, i), draw_parameters(plain, 2024, i)
        for name, value in without.items():
            np.testing.assert_array_equal(with_surface[name], value)
    columns = [c for name, d in dispersions.items() for c in d.columns(name)]
    assert "drag_scale" in columns and "residual_dipole.z" in columns and "centre_of_pressure_offset.x" in columns


def test_relative_scale_is_truncated_at_zero_and_refuses_impossible_settings():
    rng = np.random.default_rng(1)
    wide = RelativeScale(sigma=1.0)  # 16 % of the normal draws fall below -1: redrawn
    values = np.array([wide.sample(rng) for _ in range(N)])
    assert values.min() >= 0.0
    uniform = RelativeScale(half_width=0.2)
    values = np.array([uniform.sample(rng) for _ in range(N)])
    assert 0.8 <= values.min() and values.max() <= 1.2
    assert abs(values.mean() - 1.0) < 5 * 0.2 / np.sqrt(3) / np.sqrt(N)
    with pytest.raises(ValueError, match=r"half_width must be at most 1 \(the factor must stay >= 0\), got 1.5"):
        RelativeScale(half_width=1.5)
    with pytest.raises(ValueError, match=r"give exactly one of sigma \(normal\) or half_width"):
        RelativeScale()
    with pytest.raises(ValueError, match=r"sigma"):
        RelativeScale(sigma=-0.1)
    assert repr(RelativeScale(sigma=0.1)) == "RelativeScale(normal, relative=0.1)"

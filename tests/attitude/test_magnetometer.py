"""Magnetometer: deterministic errors exactly, noise statistics against chi-square bounds, batch path, errors."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from attitude.rng import NormalStreams
from attitude.sensors import Magnetometer
from attitude.simulation.protocols import Sensor, Truth

FIELD_B = np.array([2.1e-5, -0.7e-5, -3.4e-5])  # [T], a LEO-sized field


def _truth(field_B=FIELD_B):
    return Truth(0.0, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(0), magnetic_field_B=field_B)


def test_meets_the_sensor_protocol():
    assert isinstance(Magnetometer(1e-7, period=1.0), Sensor)


def test_bias_and_small_rotation_misalignment_are_exact_without_noise():
    phi = np.array([1e-3, -2e-3, 0.5e-3])  # [rad]
    bias = np.array([50e-9, -20e-9, 10e-9])  # [T]
    sensor = Magnetometer(0.0, period=1.0, bias_T=bias, misalignment=phi)
    # Model: y = (I - [phi x]) B + b, i.e. B - phi x B + b (first-order rotation of the triad, as the gyro).
    expected = FIELD_B - np.cross(phi, FIELD_B) + bias
    # Three products and sums of numbers near 3e-5 T: a few ulps (1e-20 T) of rounding.
    np.testing.assert_allclose(sensor.measure(0.0, _truth(), 1), expected, rtol=0, atol=1e-19)


def test_matrix_misalignment_and_scale_factor_from_the_datasheet():
    m = np.array([[0.0, 1e-3, -2e-3], [3e-3, 0.0, 1e-3], [-1e-3, 2e-3, 0.0]])
    sensor = Magnetometer.from_datasheet(
        noise_nT=0.0, period=0.5, bias_nT=[10.0, 0.0, -5.0], scale_factor_ppm=[100.0, -200.0, 0.0], misalignment_rad=m
    )
    transfer = np.eye(3) + np.diag([100e-6, -200e-6, 0.0]) + m
    expected = transfer @ FIELD_B + np.array([10e-9, 0.0, -5e-9])
    np.testing.assert_allclose(sensor.measure(0.0, _truth(), 1), expected, rtol=0, atol=1e-19)


def test_noise_standard_deviation_lies_inside_the_chi_square_bounds():
    sigma = 150e-9  # [T]
    sensor = Magnetometer(sigma, period=1.0)
    rng = np.random.default_rng(11)
    n = 4000
    samples = np.array([sensor.measure(0.0, _truth(), rng) for _ in range(n)]) - FIELD_B
    # (n - 1) s^2 / sigma^2 ~ chi2(n - 1) for Gaussian noise: a two-sided 99.9 % interval per axis
    # (three axes: about 0.3 % false alarms over the test, with this fixed seed none).
    lo, hi = stats.chi2.ppf([0.0005, 0.9995], n - 1)
    scaled = (n - 1) * samples.var(axis=0, ddof=1) / sigma**2
    assert np.all((lo < scaled) & (scaled < hi)), (lo, scaled, hi)
    # Zero mean: |mean| < 4 sigma / sqrt(n) (a 6e-5 two-sided probability per axis).
    assert np.all(np.abs(samples.mean(axis=0)) < 4 * sigma / np.sqrt(n))


def test_quantisation_rounds_each_axis_to_the_nearest_level():
    sensor = Magnetometer.from_datasheet(noise_nT=0.0, period=1.0, quantization_nT=13.0)
    out = sensor.measure(0.0, _truth(), 0)
    np.testing.assert_allclose(out, 13e-9 * np.round(FIELD_B / 13e-9), rtol=1e-12)


def test_batch_is_the_sequence_of_single_samples():
    sensor = Magnetometer(100e-9, period=1.0, bias_T=[1e-8, 0, 0])
    fields = np.random.default_rng(2).normal(scale=3e-5, size=(5, 3))
    seeds = [np.random.default_rng(s) for s in range(5)]
    single = np.array([sensor.measure(0.0, _truth(f), np.random.default_rng(s)) for s, f in enumerate(fields)])
    batch = sensor.measure_batch(0.0, fields, NormalStreams(seeds, block=7))
    np.testing.assert_array_equal(batch, single)


def test_no_field_in_the_truth_asks_for_an_environment():
    truth = Truth(0.0, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(0))
    with pytest.raises(ValueError, match=r"magnetic_field_B.*got None: fly it with an environment"):
        Magnetometer(1e-7, period=1.0).measure(0.0, truth, 0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"sigma_T": -1e-9, "period": 1.0}, "sigma_T must be non-negative, got -1e-09"),
        ({"sigma_T": 1e-9, "period": 0.0}, "period must be strictly positive, got 0"),
        ({"sigma_T": 1e-9, "period": 1.0, "bias_T": [1.0, 2.0]}, "bias_T must be a scalar or have shape"),
        ({"sigma_T": 1e-9, "period": 1.0, "misalignment": np.eye(3)}, "zero diagonal"),
        ({"sigma_T": 1e-9, "period": 1.0, "scale_factor": -1.0}, "scale_factor must be > -1"),
    ],
)
def test_bad_input_names_the_argument_the_rule_and_the_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Magnetometer(**kwargs)

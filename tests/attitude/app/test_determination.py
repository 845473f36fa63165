"""The design's determination section (attitude.app.design.determination) on the default spacecraft and variants.

What each test checks against:

- the truth is the nadir hold: the spacecraft-to-Earth direction stays on the
  body yaw axis (LVLH ``o3``, Wie 2008 sec. 3.5; Hughes 1986 ch. 8), and the
  field and Sun in body axes are the environment's rotated by scipy's
  ``Rotation`` (independent of attitude.quaternion);
- the eclipse: the fraction of the orbit in shadow against the cylindrical
  shadow of a circular orbit, ``arccos(sqrt(h^2 + 2 R h) / ((R + h) cos beta)) / pi``
  (Wertz and Larson, *Space Mission Analysis and Design*, 3rd ed., 1999,
  sec. 5.1, the eclipse fraction), with the Sun's elevation ``beta`` above
  the orbit plane;
- the static determination of the noise model: the QUEST NEES (3 dof)
  averaged over every solution inside the chi-square band of that mean
  (Shuster and Oh 1981: the QUEST covariance; band from ``scipy.stats.chi2``);
  none in eclipse;
- the MEKF of the noise model consistent by the section's rule, and the
  file model's systematic errors (a 269 nT magnetometer bias, a 0.62 deg
  misalignment) caught: NEES far above the band for both estimators;
- files with one kind of direction, a fine Sun sensor, or none.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from attitude.app import assembly
from attitude.app.design import determination
from attitude.app.design.estimation import FRACTION_INSIDE_MIN
from attitude.config import default_config, default_config_text, parse_config
from attitude.environment.orbit import R_EARTH

RUNS = 4


@functools.cache
def default_study():
    return determination.determination_study(default_config(), RUNS, 3)


def test_the_truth_is_the_nadir_hold_and_its_vectors_are_the_environments():
    config = default_config()
    truth = determination._truth(config)
    np.testing.assert_allclose(truth["nadir_B"], np.broadcast_to([0.0, 0.0, 1.0], truth["nadir_B"].shape), atol=1e-12)
    c_bn = Rotation.from_quat(truth["q"], scalar_first=True).inv()
    # [T]: rounding of two rotation codes on a 5e-5 T field, 1e-13 of it.
    np.testing.assert_allclose(truth["field_B"], c_bn.apply(truth["field_N"]), rtol=0, atol=5e-18)
    np.testing.assert_allclose(truth["sun_B"], c_bn.apply(truth["sun_N"]), rtol=0, atol=1e-14)
    assert truth["step"] == determination.STEP_S


def test_the_eclipse_is_the_cylindrical_shadow_of_the_orbit():
    config = default_config()
    truth = determination._truth(config)
    track = assembly.orbit_environment(config).track(truth["t"])
    r = track.position_N
    normal = np.cross(r[0], r[100])
    normal /= np.linalg.norm(normal)
    beta = np.arcsin(truth["sun_N"] @ normal)
    h = float(np.mean(np.linalg.norm(r, axis=-1))) - R_EARTH
    fraction = np.mean(np.arccos(np.sqrt(h * h + 2 * R_EARTH * h) / ((R_EARTH + h) * np.cos(beta))) / np.pi)
    out, _ = default_study()
    # The study counts steps of 1 s with less than half the Sun's disk; the cylinder's edge is the middle of
    # the penumbra (the Sun's parallax across the Earth, 4e-5 rad, moves it by a fraction of a second):
    # one step at each of the two edges.
    assert out["eclipse_fraction"] == pytest.approx(fraction, abs=2.0 / truth["t"].size)


def test_static_determination_is_consistent_with_its_covariance_and_absent_in_eclipse():
    out, histories = default_study()
    static = out["static"]["noise"]
    # The cube's opposite cells find the Sun whenever a cell is lit: at every step with at least half the
    # Sun's disk, into the penumbra, never in umbra.
    available = histories["static_noise"]["available"]
    light = histories["illumination"]
    assert np.all(available[:, light >= 0.5])
    assert not np.any(available[:, light == 0.0])
    assert np.mean(light >= 0.5) <= static["available_fraction"] <= np.mean(light > 0.0)
    k = static["solutions"]
    # QUEST takes the cells' largest axis as their sigma: conservative when a pair's lit cell (variance
    # sigma^2) and a dark pair's difference (2 sigma^2) share a solution; never above the band.
    high = stats.chi2.ppf(0.975, 3 * k) / k
    assert static["nees_mean"] <= high and static["verdict"] in ("consistent", "conservative")
    # TRIAD with the magnetometer (the more accurate direction) as primary is near QUEST for two vectors.
    assert static["triad_error_rms_deg"] == pytest.approx(static["quest_error_rms_deg"], rel=0.05)


def test_the_filter_is_not_over_confident_on_the_noise_and_the_files_systematic_errors_are_exposed():
    out, _ = default_study()
    assert out["systematic_errors"] == ["magnetometer bias 269 nT", "magnetometer misalignment 0.62 deg"]
    noise, file_ = out["mekf"]["noise"], out["mekf"]["file"]
    # The default gyro's bias instability is a Gauss-Markov bias the filter bounds by a random walk: the
    # filter may be conservative (its consistency proper is the next test's, on a gyro it models exactly).
    assert noise["fraction_not_above"] >= FRACTION_INSIDE_MIN and noise["verdict"] in ("consistent", "conservative")
    # Eclipse: the magnetometer alone, the rotation about the field only through the gyro: far larger.
    assert noise["sigma_rms_eclipse_deg"] > 3 * noise["sigma_rms_sunlit_deg"]
    # A 269 nT bias on a 20-50 uT field is 0.3-0.8 deg, ten times the field's 20 nT noise: over-confident.
    assert file_["verdict"] == "over-confident" and file_["nees_mean"] > 10 * file_["band_high"]
    assert out["static"]["file"]["verdict"] == "over-confident"


def _gyro_modelled_exactly(text):
    """The default file with a gyro of angle and rate random walk only: the MEKF's own gyro model."""
    return text.replace(
        'preset = "mems"                # gyro grade; the figures below override it',
        "arw_deg_per_sqrt_h = 0.34\nrrw_deg_per_h_per_sqrt_h = 2.0",
    )


@pytest.mark.slow
def test_on_a_gyro_it_models_exactly_the_sun_and_field_filter_is_consistent():
    config = parse_config(_gyro_modelled_exactly(default_config_text()))
    assert (
        assembly.gyro(config).sigma_b == 0.0 and assembly.gyro(config).filter_sigma_u == assembly.gyro(config).sigma_u
    )
    runs = 16
    out, _ = determination.determination_study(config, runs, 5)
    noise = out["mekf"]["noise"]
    # The section's rule (80 % of the steps inside the 95 % band of the 16-run average; the steps are
    # correlated, so the rule of the MEKF tests, test_filter_vectors.MIN_FRACTION = 0.85 at 99 %, in kind).
    assert noise["fraction_inside"] >= FRACTION_INSIDE_MIN and noise["verdict"] == "consistent"
    # Attitude and bias apart, each a 3-dof mean over runs and time: inside the band of one step's 16-run mean
    # (a time average has at most the variance of one step's).
    low, high = stats.chi2.ppf([0.005, 0.995], 3 * runs) / runs
    assert low <= noise["attitude_nees_mean"] <= high and low <= noise["bias_nees_mean"] <= high


def test_albedo_does_not_fake_a_sun_in_eclipse():
    # A review found the cube's nadir cell, lit by a constant-brightness Earth in umbra, giving a "Sun".
    text = default_config_text().replace("# albedo_percent = 0.0", "albedo_percent = 20.0")
    out, histories = determination.determination_study(parse_config(text), 2, 1)
    assert out["systematic_errors"][-1] == "Earth albedo on the coarse cells, 20 % of full scale"
    umbra = histories["illumination"] == 0.0
    assert umbra.sum() > 1500
    for model in ("noise", "file"):
        assert not np.any(histories[f"static_{model}"]["available"][:, umbra])


def test_the_figures_are_drawn():
    out, histories = default_study()
    figures = determination.determination_figures(out, histories)
    assert set(figures) == {"determination_static", "determination_mekf", "determination_nees"}


def _variant(drop=(), extra=""):
    text = default_config_text()
    for table in drop:
        start = text.index(f"[{table}]")
        end = text.index("\n[", start + 1)
        text = text[:start] + text[end + 1 :]
    return parse_config(text + extra)


def test_one_direction_gives_no_static_solution_and_a_filter_and_none_gives_no_section():
    only_field = _variant(drop=("coarse_sun_sensors",))
    out, _ = determination.determination_study(only_field, 2, 0)
    assert out["static"] is None and out["sensors"] == ["magnetometer"]
    assert out["mekf"]["noise"]["runs"] == 2
    none = _variant(drop=("coarse_sun_sensors", "magnetometer", "detumble"))
    assert determination.determination_study(none, 2, 0) == (None, {})


def test_a_fine_sun_sensor_is_used_when_the_sun_is_in_its_view():
    # Boresight along the LVLH x axis (along-track): its 60 deg cone sees the Sun on part of the sunlit orbit.
    fine = (
        "\n[fine_sun_sensor]\nperiod_s = 1.0\naccuracy_deg = 0.05\naccuracy_sigma_level = 1\n"
        "fov_half_angle_deg = 60.0\nboresight_B = [1.0, 0.0, 0.0]\n"
    )
    config = _variant(drop=("coarse_sun_sensors",), extra=fine)
    out, _ = determination.determination_study(config, 2, 0)
    st = out["static"]["noise"]
    assert 0.0 < st["available_fraction"] < 1.0 - out["eclipse_fraction"]  # only with the Sun in view
    # The sensor's noise is on its two angles; off the boresight an angle error turns the direction by less
    # (by cos alpha across alpha), so the angle sigma taken as the direction's makes QUEST conservative:
    # the NEES at most the top of its band (and below it here: the Sun is up to 60 deg off the boresight).
    high = stats.chi2.ppf(0.975, 3 * st["solutions"]) / st["solutions"]
    assert st["nees_mean"] <= high and st["verdict"] in ("consistent", "conservative")
    # Against 0.05 deg of noise on the Sun and 20 nT on the field, QUEST is well under the coarse cells' degree.
    assert st["quest_error_rms_deg"] < 0.5


def test_a_noise_free_magnetometer_is_left_out_not_a_crash():
    # A new user's trial: noise_nT = 0 (accepted by the file) crashed the design with infinite weights.
    text = default_config_text().replace("noise_nT = 20.0", "noise_nT = 0.0")
    out, _ = determination.determination_study(parse_config(text), 2, 0)
    assert out["sensors"] == ["coarse_sun_sensors"] and out["static"] is None
    assert out["excluded_sensors"] == ["magnetometer (noise_nT = 0: a noise-free direction cannot be weighted)"]
    # Its bias and misalignment are not the flown sensors' errors: one (noise) model.
    assert out["systematic_errors"] == [] and set(out["mekf"]) == {"noise"}


class _Batch:
    """A stand-in for run_mekf's result: the errors and covariances the verdict reads."""

    def __init__(self, errors, P):
        self._errors, self.P = errors, P
        self.q = np.zeros((*errors.shape[:2], 4))

    def errors(self, q_true, bias_true):
        return self._errors


def test_the_verdict_takes_the_attitude_alone_as_well_as_the_whole_state():
    # Unit covariance, errors drawn with an attitude variance of 1.6 and a bias variance of 0.5: the whole
    # state's mean NEES is 3 x 1.6 + 3 x 0.5 = 6.3, inside its 6-dof band, the attitude's 4.8, above its
    # 3-dof band (16 runs: chi2.ppf(0.975, 48) / 16 = 4.2). The 6-dof rule alone called this consistent.
    runs, n = 16, 2000
    rng = np.random.default_rng(0)
    scale = np.sqrt([1.6] * 3 + [0.5] * 3)
    errors = rng.standard_normal((runs, n, 6)) * scale
    truth = {"t": np.arange(n, dtype=float), "illumination": np.ones(n), "q": np.zeros((n, 4))}
    out, _ = determination._mekf_summary(
        _Batch(errors, np.broadcast_to(np.eye(6), (runs, n, 6, 6))), slice(None), truth, np.zeros((runs, n, 3))
    )
    assert out["fraction_inside"] >= FRACTION_INSIDE_MIN  # the whole state passes ...
    assert out["attitude_fraction_not_above"] < FRACTION_INSIDE_MIN  # ... the attitude does not
    assert out["verdict"] == "over-confident" and out["fraction_not_above_min"] < FRACTION_INSIDE_MIN

"""Sun sensors: geometry against scipy frames, cosine law, least-squares Sun vector, FOV, eclipse, noise, errors.

What each test checks against:

* Cosine law of a flat detector (Markley and Crassidis, *Fundamentals of Spacecraft Attitude
  Determination and Control*, 2014, sec. 4.4; Wertz, *Spacecraft Attitude Determination and
  Control*, 1978, sec. 6.1): a cell whose normal is rotated by scipy ``Rotation`` and a Sun placed
  at a chosen angle from it reads ``I_fs cos(angle)`` exactly.
* Least-squares Sun vector: exact (rounding) without noise with >= 3 independent lit cells; its
  scatter under noise matches the first-order covariance ``sigma^2 (I - s s^T)(N^T N)^-1(I - s s^T)``
  within the sampling error of the Monte Carlo (variance of a sample trace ``2 tr(P^2) / (M - 1)``).
* Fine sensor: the angles of a Sun placed at chosen ``(alpha, beta)`` in a sensor frame built by
  scipy ``Rotation`` are returned exactly; the noise sample variance lies inside chi-square bounds.
* Field of view and eclipse: edges on either side, penumbra scales the currents linearly, umbra
  gives no Sun estimate and no fine sample.
* Engine: an inertially fixed body in a 500 km orbit entering the Earth's shadow records both
  sensors; the readings before the shadow match the almanac Sun of the environment track, those in
  umbra are flagged (fine: NaN rows; coarse: no valid estimate).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from attitude import RigidBody
from attitude.environment.orbit import CircularOrbit
from attitude.environment.orbit_environment import OrbitEnvironment
from attitude.simulation.engine import simulate
from attitude.simulation.protocols import Sensor, Truth
from attitude.sun_sensors import CUBE_NORMALS_B, CoarseSunSensors, FineSunSensor

ROTATION = Rotation.from_euler("zyx", [35.0, -20.0, 50.0], degrees=True)  # a generic sensor mounting


def _truth(sun_B, illumination=1.0, nadir_B=None):
    s = np.asarray(sun_B, dtype=float)
    return Truth(
        0.0,
        np.array([1.0, 0.0, 0.0, 0.0]),
        np.zeros(3),
        np.zeros(0),
        sun_B=s / np.linalg.norm(s),
        illumination=illumination,
        nadir_B=None if nadir_B is None else np.asarray(nadir_B, dtype=float),
    )


def _tilted(normal, angle, axis_hint=(0.3, -0.5, 0.8)):
    """``normal`` turned by ``angle`` about an axis perpendicular to it (scipy Rotation)."""
    axis = np.cross(normal, axis_hint)
    axis /= np.linalg.norm(axis)
    return Rotation.from_rotvec(angle * axis).apply(normal)


# -- protocol ------------------------------------------------------------------------------------


def test_both_meet_the_sensor_protocol():
    assert isinstance(CoarseSunSensors.cube(period=1.0), Sensor)
    assert isinstance(FineSunSensor(1e-3, period=1.0, fov_half_angle_rad=1.0), Sensor)


# -- coarse sun sensors --------------------------------------------------------------------------


@pytest.mark.parametrize("angle_deg", [0.0, 10.0, 45.0, 80.0, 89.0])
def test_cosine_law_is_exact_without_noise(angle_deg):
    normal = ROTATION.apply([0.0, 0.0, 1.0])
    sensor = CoarseSunSensors(normal[None, :], period=1.0, fov_half_angle_rad=np.pi / 2, full_scale_A=2e-3)
    sun = _tilted(normal, np.radians(angle_deg))
    # I = I_fs cos(theta) (cosine law); a dot product of unit vectors rounds to a few ulps.
    np.testing.assert_allclose(
        sensor.measure(0.0, _truth(sun), 1), [2e-3 * np.cos(np.radians(angle_deg))], rtol=0, atol=1e-17
    )


def test_field_of_view_edges_and_back_side():
    normal = ROTATION.apply([1.0, 0.0, 0.0])
    sensor = CoarseSunSensors.from_datasheet(normal[None, :], period=1.0, fov_half_angle_deg=60.0, full_scale_mA=1.0)
    inside = sensor.measure(0.0, _truth(_tilted(normal, np.radians(59.9))), 1)
    outside = sensor.measure(0.0, _truth(_tilted(normal, np.radians(60.1))), 1)
    behind = sensor.measure(0.0, _truth(-normal), 1)
    np.testing.assert_allclose(inside, [1e-3 * np.cos(np.radians(59.9))], rtol=1e-12)
    assert outside[0] == 0.0 and behind[0] == 0.0


def test_penumbra_scales_and_umbra_darkens_the_currents():
    sensor = CoarseSunSensors.cube(period=1.0)
    sun = np.array([0.4, -0.5, 0.77])
    full = sensor.measure(0.0, _truth(sun, 1.0), 1)
    # I is linear in the illumination lambda (the fraction of the disk seen).
    np.testing.assert_allclose(sensor.measure(0.0, _truth(sun, 0.37), 1), 0.37 * full, rtol=1e-15, atol=0)
    assert np.all(sensor.measure(0.0, _truth(sun, 0.0), 1) == 0.0)
    est = sensor.sun_vector(sensor.measure(0.0, _truth(sun, 0.0), 1))
    assert not est.valid and est.n_lit == 0 and np.all(est.sun_B == 0.0)
    # Penumbra leaves the direction unchanged (the estimate is normalised).
    np.testing.assert_allclose(
        sensor.sun_vector(sensor.measure(0.0, _truth(sun, 0.2), 1)).sun_B, sun / np.linalg.norm(sun), atol=1e-15
    )


@pytest.mark.parametrize(
    "make",
    [
        lambda: CoarseSunSensors.cube(period=1.0),
        lambda: CoarseSunSensors.pyramid(period=1.0, tilt_rad=np.radians(50.0), axis_B=ROTATION.apply([0, 0, 1])),
        lambda: CoarseSunSensors(
            ROTATION.apply(np.vstack([np.eye(3), -np.eye(3)])), period=1.0, fov_half_angle_rad=np.radians(80.0)
        ),
    ],
)
def test_least_squares_sun_vector_is_exact_without_noise(make):
    sensor = make()
    rng = np.random.default_rng(4)
    checked = 0
    for sun in rng.standard_normal((200, 3)):
        sun /= np.linalg.norm(sun)
        est = sensor.sun_vector(sensor.measure(0.0, _truth(sun), 1))
        if not est.valid:
            continue
        checked += 1
        # Exact model: pinv(N_lit) I_lit = s; lstsq of a well-conditioned 3-column system: ~1e-15.
        np.testing.assert_allclose(est.sun_B, sun, atol=1e-13)
    assert checked > 20  # the test looked at valid estimates


def test_fewer_than_three_independent_lit_cells_give_no_estimate_unless_in_opposite_pairs():
    # A cube of hemispherical cells: opposite faces measure each component by their difference, lit or
    # dark (max(0, c) - max(0, -c) = c), so two lit faces (the Sun in the x-y plane) or one suffice.
    sensor = CoarseSunSensors.cube(period=1.0)
    for sun in ([1.0, 1.0, 0.0], [0.0, 0.0, -1.0]):
        est = sensor.sun_vector(sensor.measure(0.0, _truth(sun), 1))
        assert est.valid and est.n_lit == np.count_nonzero(sun)
        np.testing.assert_allclose(est.sun_B, np.array(sun) / np.linalg.norm(sun), atol=1e-15)
    # Narrower cells have no such identity: two lit faces of a 80 deg cube are rank 2, refused.
    narrow = CoarseSunSensors.cube(period=1.0, fov_half_angle_rad=np.radians(80.0))
    est = narrow.sun_vector(narrow.measure(0.0, _truth([1.0, 1.0, 0.0]), 1))
    assert not est.valid and est.n_lit == 2
    # Four lit cells but all normals in one plane (rank 2): refused as well.
    ring = CoarseSunSensors(
        [[1, 0, 0], [0, 1, 0], [np.sqrt(0.5), np.sqrt(0.5), 0], [0.8, 0.6, 0]], period=1.0, fov_half_angle_rad=1.5
    )
    est = ring.sun_vector(ring.measure(0.0, _truth([0.6, 0.6, 0.3]), 1))
    assert not est.valid and est.n_lit == 4


@pytest.mark.parametrize("noise", [1e-3, 4e-3])
def test_least_squares_scatter_matches_the_first_order_covariance(noise):
    sensor = CoarseSunSensors.pyramid(period=1.0, tilt_rad=np.radians(45.0), n_cells=6, noise_fraction=noise)
    sun = np.array([0.2, -0.1, 1.0])
    sun /= np.linalg.norm(sun)
    rng = np.random.default_rng(11)
    m = 4000
    est = [sensor.sun_vector(sensor.measure(0.0, _truth(sun), rng)) for _ in range(m)]
    assert all(e.valid and e.n_lit == 6 for e in est)
    errors = np.array([e.sun_B for e in est]) - sun
    predicted = sensor.sun_vector(sensor.ideal_currents(sun)).covariance_B  # at the true direction
    sample_trace = float(np.trace(errors.T @ errors) / m)  # mean around the truth (bias is O(sigma^2))
    # Sampling std of the trace of a Gaussian sample covariance: sqrt(2 tr(P^2) / M); 5 sigma bound.
    # The second-order bias (relative ~ sigma^2 / |x|^2 ~ 2e-5 at most here) is far below it.
    bound = 5.0 * np.sqrt(2.0 * np.trace(predicted @ predicted) / m)
    assert abs(sample_trace - np.trace(predicted)) < bound
    # The error is perpendicular to s to first order: the covariance has the estimate in its null
    # space (rounding: a few ulps of the entries, ~1e-16 of the trace).
    np.testing.assert_allclose(predicted @ sun, 0.0, atol=1e-14 * np.trace(predicted))
    # Scaling: the predicted angle error is proportional to the noise (sigma^2 in the trace).
    quiet = CoarseSunSensors.pyramid(period=1.0, tilt_rad=np.radians(45.0), n_cells=6, noise_fraction=1e-3)
    ratio = np.trace(predicted) / np.trace(quiet.sun_vector(quiet.ideal_currents(sun)).covariance_B)
    np.testing.assert_allclose(ratio, (noise / 1e-3) ** 2, rtol=1e-12)


def test_noise_standard_deviation_within_chi_square_bounds():
    sigma = 0.01
    sensor = CoarseSunSensors.from_datasheet(
        np.eye(3), period=1.0, fov_half_angle_deg=90.0, full_scale_mA=1.5, noise_percent=100 * sigma
    )
    rng = np.random.default_rng(3)
    m = 3000
    samples = np.array([sensor.measure(0.0, _truth([1.0, 2.0, 2.0]), rng) for _ in range(m)])
    ideal = sensor.ideal_currents([1.0, 2.0, 2.0])
    residual = samples - ideal
    for k in range(3):
        # (M sum r^2 / sigma^2) ~ chi2(M) with the known mean: a 99.9 % two-sided interval per cell.
        ss = np.sum(residual[:, k] ** 2) / (sigma * 1.5e-3) ** 2
        assert stats.chi2.ppf(0.0005, m) < ss < stats.chi2.ppf(0.9995, m)


def test_albedo_adds_a_cosine_weighted_fraction_when_the_earth_is_in_view():
    sensor = CoarseSunSensors.cube(period=1.0, albedo_fraction=0.3, full_scale_A=1.0)
    sun = np.array([0.0, 0.0, 1.0])
    nadir = np.array([0.6, 0.0, -0.8])  # +x sees the Earth at cos = 0.6, -z at 0.8
    # The sub-satellite point sees the Sun at a zenith angle of cos = -nadir . sun = 0.8 (Lambert).
    expected = np.zeros(6)
    expected[4] = 1.0  # +z: the Sun
    expected[0] += 0.3 * 0.8 * 0.6
    expected[5] += 0.3 * 0.8 * 0.8
    np.testing.assert_allclose(sensor.ideal_currents(sun, 1.0, nadir), expected, atol=1e-15)


def test_albedo_is_dark_over_the_night_side_so_eclipse_gives_no_sun():
    # A review found a constant-brightness Earth lighting the nadir cell in umbra: the cube then "found" a
    # Sun at nadir. Below the spacecraft it is night when the Sun is behind the Earth (-nadir . sun <= 0).
    sensor = CoarseSunSensors.cube(period=1.0, albedo_fraction=0.3, noise_fraction=1e-3)
    sun, nadir = np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0])  # the Sun behind the Earth
    np.testing.assert_array_equal(sensor.ideal_currents(sun, 0.0, nadir), np.zeros(6))
    est = sensor.sun_vector(sensor.measure(0.0, _truth(sun, 0.0, nadir), 2))
    assert not est.valid and est.n_lit == 0


def test_without_an_orbit_the_sensors_say_there_is_no_sun():
    truth = Truth(0.0, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(0))
    with pytest.raises(ValueError, match=r"truth.sun_B .* environment"):
        CoarseSunSensors.cube(period=1.0).measure(0.0, truth, 1)
    with pytest.raises(ValueError, match=r"truth.sun_B .* environment"):
        FineSunSensor(1e-3, period=1.0, fov_half_angle_rad=1.0).measure(0.0, truth, 1)


# -- fine sun sensor -----------------------------------------------------------------------------


@pytest.mark.parametrize("alpha_deg, beta_deg", [(0.0, 0.0), (20.0, -35.0), (-40.0, 5.0)])
def test_fine_angles_in_a_scipy_built_frame_are_exact_without_noise(alpha_deg, beta_deg):
    sensor = FineSunSensor(
        0.0,
        period=1.0,
        fov_half_angle_rad=np.radians(60.0),
        boresight_B=ROTATION.apply([0.0, 0.0, 1.0]),
        x_axis_B=ROTATION.apply([1.0, 0.0, 0.0]),
    )
    a, b = np.radians(alpha_deg), np.radians(beta_deg)
    # Two-axis sensor: tan(alpha) = s_x / s_z, tan(beta) = s_y / s_z in the sensor frame.
    s_S = np.array([np.tan(a), np.tan(b), 1.0])
    s_B = ROTATION.apply(s_S / np.linalg.norm(s_S))
    out = sensor.sample(0.0, _truth(s_B), 1)
    np.testing.assert_allclose([out.alpha, out.beta], [a, b], atol=1e-14)
    np.testing.assert_allclose(out.sun_B, s_B, atol=1e-14)
    np.testing.assert_allclose(sensor.measure(0.0, _truth(s_B), 1), s_B, atol=1e-14)


def test_fine_field_of_view_edge_and_eclipse_threshold():
    sensor = FineSunSensor.from_datasheet(
        accuracy_deg=0.0, accuracy_sigma_level=1, period=1.0, fov_half_angle_deg=30.0, illumination_min=0.8
    )
    z = np.array([0.0, 0.0, 1.0])
    assert sensor.measure(0.0, _truth(_tilted(z, np.radians(29.9))), 1) is not None
    assert sensor.measure(0.0, _truth(_tilted(z, np.radians(30.1))), 1) is None
    assert sensor.measure(0.0, _truth(-z), 1) is None
    assert sensor.measure(0.0, _truth(z, 0.81), 1) is not None
    assert sensor.measure(0.0, _truth(z, 0.79), 1) is None
    assert sensor.measure(0.0, _truth(z, 0.0), 1) is None


def test_fine_noise_from_a_three_sigma_datasheet_within_chi_square_bounds():
    sensor = FineSunSensor.from_datasheet(
        accuracy_deg=0.3, accuracy_sigma_level=3, period=1.0, fov_half_angle_deg=60.0, bias_deg=[0.05, -0.02]
    )
    sigma = np.radians(0.1)  # 0.3 deg at 3 sigma
    rng = np.random.default_rng(8)
    m = 3000
    samples = np.array([sensor.sample(0.0, _truth([0.0, 0.0, 1.0]), rng)[:2] for _ in range(m)])
    residual = samples - np.radians([0.05, -0.02])  # Sun on the boresight: true angles 0
    for k in range(2):
        ss = np.sum(residual[:, k] ** 2) / sigma**2  # ~ chi2(M) (known mean); 99.9 % interval
        assert stats.chi2.ppf(0.0005, m) < ss < stats.chi2.ppf(0.9995, m)


# -- bad input -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "build, match",
    [
        (lambda: FineSunSensor(1e-3, period=1.0, fov_half_angle_rad=None), r"fov_half_angle_rad is required"),
        (lambda: FineSunSensor(1e-3, period=1.0, fov_half_angle_rad=0.0), r"fov_half_angle_rad must be strictly"),
        (
            lambda: FineSunSensor(1e-3, period=1.0, fov_half_angle_rad=np.pi / 2),
            r"fov_half_angle_rad must be in \(0, pi/2 rad\) .* 1.57",
        ),
        (
            lambda: FineSunSensor.from_datasheet(
                accuracy_deg=0.1, accuracy_sigma_level=3, period=1.0, fov_half_angle_deg=95.0
            ),
            r"fov_half_angle_deg must be in \(0, 90 deg\) .* got 95.0 deg",
        ),
        (
            lambda: FineSunSensor.from_datasheet(
                accuracy_deg=0.1, accuracy_sigma_level=0, period=1.0, fov_half_angle_deg=60.0
            ),
            r"accuracy_sigma_level must be strictly",
        ),
        (lambda: FineSunSensor(-1e-3, period=1.0, fov_half_angle_rad=1.0), r"sigma_rad must be non-negative"),
        (
            lambda: FineSunSensor(1e-3, period=1.0, fov_half_angle_rad=1.0, x_axis_B=[0, 0, 2]),
            r"x_axis_B must not be along boresight_B",
        ),
        (
            lambda: FineSunSensor(1e-3, period=1.0, fov_half_angle_rad=1.0, illumination_min=1.5),
            r"illumination_min must be in \(0, 1\], got 1.5",
        ),
        (lambda: CoarseSunSensors.cube(period=1.0, fov_half_angle_rad=None), r"fov_half_angle_rad is required"),
        (lambda: CoarseSunSensors.cube(period=1.0, fov_half_angle_rad=-0.1), r"fov_half_angle_rad must be strictly"),
        (
            lambda: CoarseSunSensors.cube(period=1.0, fov_half_angle_rad=2.0),
            r"fov_half_angle_rad must be in \(0, pi/2 rad\] .* got 2.0 rad",
        ),
        (lambda: CoarseSunSensors(np.zeros((0, 3)), period=1.0, fov_half_angle_rad=1.0), r"normals_B must have shape"),
        (lambda: CoarseSunSensors([[1, 0, 0], [0, 0, 0]], period=1.0, fov_half_angle_rad=1.0), r"normals_B .* zero"),
        (lambda: CoarseSunSensors.cube(period=1.0, noise_fraction=-0.1), r"noise_fraction must be non-negative"),
        (lambda: CoarseSunSensors.cube(period=1.0, scale_factor=[0.1, -1.0, 0, 0, 0, 0]), r"scale_factor must be > -1"),
        (lambda: CoarseSunSensors.cube(period=0.0), r"period must be strictly positive"),
        (lambda: CoarseSunSensors.pyramid(period=1.0, tilt_rad=1.0, n_cells=2), r"n_cells must be an integer >= 3"),
    ],
)
def test_bad_input_is_refused_with_a_clear_message(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def test_bad_truth_and_currents_are_refused():
    sensor = CoarseSunSensors.cube(period=1.0)
    with pytest.raises(ValueError, match=r"truth.illumination must be in \[0, 1\], got 1.2"):
        sensor.measure(0.0, _truth([0, 0, 1], 1.2), 1)
    with pytest.raises(ValueError, match=r"currents_A"):
        sensor.sun_vector(np.zeros(5))


# -- flown by the engine -------------------------------------------------------------------------

# Sun-synchronous 500 km; with raan = 0 at the default epoch the umbra spans argument of latitude
# 1.96 ... 4.33 rad: starting at 1.90 rad the run enters the shadow after about 60 s.
ORBIT = CircularOrbit.from_altitude(500e3, inclination=np.radians(97.4), argument_of_latitude=1.90)
ENV = OrbitEnvironment(ORBIT, sources=(), magnetic_field=None, atmosphere=None, sample_period=1.0)


def test_an_orbit_flight_records_both_sensors_and_flags_the_eclipse():
    sun_N0 = ENV.track(np.array([0.0])).sun_N[0]
    # A cube turned by a generic rotation: the Sun lights three faces throughout.
    cube_B = ROTATION.apply(np.vstack([np.eye(3), -np.eye(3)]))
    css = CoarseSunSensors(cube_B, period=1.0, fov_half_angle_rad=np.pi / 2, noise_fraction=1e-3, name="css")
    fss = FineSunSensor(np.radians(0.05), period=1.0, fov_half_angle_rad=np.radians(60.0), boresight_B=sun_N0)
    # No torque sources and no rate: the body stays at q_BN = identity, so sun_B = sun_N.
    run = simulate(
        RigidBody(np.diag([1.0, 2.0, 3.0])),
        [1.0, 0.0, 0.0, 0.0],
        np.zeros(3),
        200.0,
        sensors=[css, fss],
        environment=ENV,
        rng=5,
    )
    sun_N = ENV.track(run.t).sun_N
    fine = run.logs["sensor.fine_sun_sensor"]
    coarse = run.logs["sensor.css"]
    sampled = np.isclose(run.t % 1.0, 0.0)
    lit = sampled & (run.illumination >= 0.9)
    dark = sampled & (run.illumination == 0.0)
    assert lit.sum() > 20 and dark.sum() > 20  # the run has both
    # Lit: the fine sample is the almanac Sun within 6 sigma of the per-axis noise (0.05 deg, two axes).
    angle = np.arccos(np.clip(np.sum(fine[lit] * sun_N[lit], axis=1), -1, 1))
    assert np.all(angle < 6 * np.sqrt(2) * np.radians(0.05))
    assert np.all(np.isnan(fine[dark]))  # umbra: no sample, NaN rows
    assert coarse.shape[1] == 6 and np.all(np.isfinite(coarse[sampled]))
    estimates = [css.sun_vector(row) for row in coarse[lit]]
    lit_valid = [e for e, s in zip(estimates, sun_N[lit], strict=True) if e.valid]
    assert len(lit_valid) == lit.sum()  # this Sun direction lights three faces
    errs = [np.arccos(min(1.0, e.sun_B @ s)) for e, s in zip(estimates, sun_N[lit], strict=True)]
    # 1e-3 of full scale gives about 1e-3 rad per axis: 6 sigma.
    assert max(errs) < 6e-3
    assert not any(css.sun_vector(row).valid for row in coarse[dark])


def test_the_engine_hands_the_cells_the_nadir_so_albedo_reaches_a_flight():
    # A new user's trial: albedo_fraction changed nothing in simulate, because the engine's Truth carried no
    # nadir. It now carries the spacecraft-to-Earth-centre direction in body axes: -r/|r| rotated by q_BN*
    # (checked here against scipy's Rotation), and a flown cube of cells with albedo reads the ideal currents
    # of ideal_currents(sun_B, illumination, nadir_B) plus its noise.
    orbit = CircularOrbit.from_altitude(500e3, inclination=np.radians(97.4))
    environment = OrbitEnvironment(orbit, sources=())
    seen = []

    class Recorder:
        name, period = "recorder", 10.0

        def measure(self, t, truth, rng=None):
            seen.append((t, truth.q, truth.nadir_B, truth.sun_B, truth.illumination))
            return np.zeros(1)

    q0 = np.array([0.8, 0.2, -0.4, 0.4]) / np.linalg.norm([0.8, 0.2, -0.4, 0.4])
    cells = CoarseSunSensors.cube(period=10.0, albedo_fraction=0.3, full_scale_A=1.0, name="css")
    run = simulate(RigidBody([1.0, 1.2, 0.9]), q0, np.zeros(3), 60.0, sensors=[Recorder(), cells],
                   environment=environment)  # fmt: skip
    track = environment.track(np.array([s[0] for s in seen]))
    for (_t, q, nadir_B, _sun, _illumination), r_N in zip(seen, track.position_N):
        expected = Rotation.from_quat([q[1], q[2], q[3], q[0]]).inv().apply(-r_N / np.linalg.norm(r_N))
        np.testing.assert_allclose(nadir_B, expected, atol=1e-12)
    flown = run.logs["sensor.css"][np.isfinite(run.logs["sensor.css"][:, 0])]
    ideal = np.array([cells.ideal_currents(s[3], s[4], s[2]) for s in seen])
    np.testing.assert_allclose(flown, ideal, atol=1e-15)  # no noise: the currents are the ideal ones, albedo in
    assert np.any(ideal != np.array([cells.ideal_currents(s[3], s[4]) for s in seen]))  # the Earth is in view


def test_batch_sun_vectors_are_the_least_squares_of_the_lit_cells():
    # Against numpy's lstsq on each sample's lit cells (an independent solver of the same problem), over
    # random Sun directions, illuminations (eclipse included) and noise; invalid samples where fewer than
    # three independent cells are lit.
    rng = np.random.default_rng(7)
    cells = CoarseSunSensors.cube(period=0.1, fov_half_angle_rad=np.radians(70.0), noise_fraction=0.01)
    sun = rng.standard_normal((400, 3))
    sun /= np.linalg.norm(sun, axis=-1, keepdims=True)
    light = rng.choice([0.0, 0.5, 1.0], size=400)
    currents = cells.ideal_currents(sun, light) + 0.01 * cells.full_scale * rng.standard_normal((400, 6))
    sun_B, valid, n_lit, cov = cells.sun_vectors(currents.reshape(20, 20, 6))
    sun_B, valid, n_lit, cov = sun_B.reshape(400, 3), valid.ravel(), n_lit.ravel(), cov.reshape(400, 3, 3)
    assert 50 < valid.sum() < 400  # both kinds occur (70 deg cells leave gaps; eclipse rows are dark)
    for k in range(400):
        y = currents[k] / cells.full_scale
        lit = y > cells.lit_threshold
        assert n_lit[k] == lit.sum()
        independent = lit.sum() >= 3 and np.linalg.svd(cells.normals_B[lit], compute_uv=False)[-1] >= 1e-6
        assert valid[k] == independent
        if independent:
            x, *_ = np.linalg.lstsq(cells.normals_B[lit], y[lit], rcond=None)
            # Rounding of two solvers of a system with condition number <= 3 (the cube's normals).
            np.testing.assert_allclose(sun_B[k], x / np.linalg.norm(x), atol=1e-14)
            s_hat = x / np.linalg.norm(x)
            perp = np.eye(3) - np.outer(s_hat, s_hat)
            n_lit_cells = cells.normals_B[lit]
            expected = 0.01**2 * perp @ np.linalg.inv(n_lit_cells.T @ n_lit_cells) @ perp / (x @ x)
            np.testing.assert_allclose(cov[k], expected, rtol=1e-10, atol=1e-20)
        else:
            assert not np.any(sun_B[k]) and not np.any(cov[k])


def test_fine_sensor_batch_samples_are_the_single_samples():
    rng = np.random.default_rng(3)
    sensor = FineSunSensor(1e-3, period=0.1, fov_half_angle_rad=np.radians(60.0), boresight_B=[0, 1, 1], bias_rad=1e-4)
    sun = rng.standard_normal((300, 3))
    light = rng.choice([0.0, 0.95, 1.0], size=300)
    # Sample k draws its two normals from a generator seeded k; the batch gets the same numbers.
    normals = np.array([np.random.default_rng(k).standard_normal(2) for k in range(300)])
    batch = sensor.sample_batch(sun, light, normals)
    seen = 0
    for k in range(300):
        one = sensor.sample(0.0, _truth(sun[k] / np.linalg.norm(sun[k]), light[k]), np.random.default_rng(k))
        if one is None:
            assert np.all(np.isnan(batch[k]))
        else:
            seen += 1
            np.testing.assert_allclose(batch[k], one.sun_B, atol=1e-15)
    assert 30 < seen < 300


def test_the_pair_estimate_of_a_cube_scatters_as_its_first_order_covariance():
    # Two faces lit (the Sun 20 deg off +z towards +x): the y component comes from the dark pair alone.
    sensor = CoarseSunSensors.cube(period=1.0, noise_fraction=2e-3)
    sun = np.array([np.sin(np.radians(20.0)), 0.0, np.cos(np.radians(20.0))])
    rng = np.random.default_rng(5)
    m = 4000
    currents = sensor.ideal_currents(sun) + 2e-3 * sensor.full_scale * rng.standard_normal((m, 6))
    sun_B, valid, n_lit, _ = sensor.sun_vectors(currents)
    assert np.all(valid) and np.all(n_lit == 2)  # +z and +x lit
    errors = sun_B - sun
    predicted = sensor.sun_vector(sensor.ideal_currents(sun)).covariance_B
    # +x and +z lit alone (weight 1), the dark y pair by its difference (weight 1/2): M = diag(1, 1/2, 1).
    perp = np.eye(3) - np.outer(sun, sun)
    np.testing.assert_allclose(predicted, 2e-3**2 * perp @ np.diag([1.0, 2.0, 1.0]) @ perp, atol=1e-18)
    sample_trace = float(np.trace(errors.T @ errors) / m)
    # Sampling std of the trace, sqrt(2 tr(P^2) / M); 5 sigma (second-order bias ~ sigma^2 = 4e-6 relative).
    assert abs(sample_trace - np.trace(predicted)) < 5 * np.sqrt(2 * np.trace(predicted @ predicted) / m)


def test_the_pair_rule_is_the_weighted_least_squares_of_its_rows():
    # Independent formulation: the rule's rows written out one by one and solved by numpy's lstsq with
    # square-root weights, against sun_vectors' normal equations; random Sun directions, penumbra, noise.
    rng = np.random.default_rng(12)
    sigma = 5e-3
    cells = CoarseSunSensors(ROTATION.apply(CUBE_NORMALS_B.copy()), period=1.0, fov_half_angle_rad=np.pi / 2,
                             noise_fraction=sigma)  # fmt: skip
    sun = rng.standard_normal((300, 3))
    sun /= np.linalg.norm(sun, axis=-1, keepdims=True)
    light = rng.uniform(0.3, 1.0, 300)
    currents = cells.ideal_currents(sun, light) + sigma * cells.full_scale * rng.standard_normal((300, 6))
    sun_B, valid, _, cov = cells.sun_vectors(currents)
    assert np.all(valid)
    n = cells.normals_B
    for k in range(300):
        y = currents[k] / cells.full_scale
        lit = y > cells.lit_threshold
        rows, values, weights = [], [], []
        for i, j in ((0, 1), (2, 3), (4, 5)):  # the cube's opposite faces
            if lit[i] != lit[j]:
                one = i if lit[i] else j
                rows.append(n[one]), values.append(y[one]), weights.append(1.0)
            else:
                rows.append(n[i]), values.append(y[i] - y[j]), weights.append(0.5)
        a = np.array(rows) * np.sqrt(weights)[:, None]
        x, *_ = np.linalg.lstsq(a, np.array(values) * np.sqrt(weights), rcond=None)
        s_hat = x / np.linalg.norm(x)
        np.testing.assert_allclose(sun_B[k], s_hat, atol=1e-13)  # rounding of two solvers, condition <= 2
        perp = np.eye(3) - np.outer(s_hat, s_hat)
        expected = sigma**2 * perp @ np.linalg.inv(a.T @ a) @ perp / (x @ x)
        np.testing.assert_allclose(cov[k], expected, rtol=1e-9, atol=1e-22)

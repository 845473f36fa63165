"""Tests of the Keplerian orbit, Kepler's equation and the LVLH frame of a state (attitude.environment.orbit).

Checked against: Vallado, *Fundamentals of Astrodynamics and Applications*,
4th ed. (2013), Example 2-1 (Kepler's equation, M = 235.4 deg, e = 0.4 ->
E = 220.512074767522 deg) and Example 2-5 (the state r, v whose elements are
p = 11067.790 km, a = 36127.343 km, e = 0.832853, i = 87.870 deg,
RAAN = 227.898 deg, omega = 53.38 deg, nu = 92.335 deg); the two-body
conservation laws (specific energy -mu/2a, vis-viva, Vallado eq. 1-31, and the
angular momentum vector); the period; and CircularOrbit for e = 0.
"""

from __future__ import annotations

import numpy as np
import pytest

from attitude import quaternion as quat
from attitude.environment.epoch import DEFAULT_EPOCH, Epoch
from attitude.environment.orbit import (
    MU_EARTH,
    R_EARTH,
    CircularOrbit,
    KeplerOrbit,
    Orbit,
    lvlh_attitude,
    solve_kepler,
)

EPS = np.finfo(float).eps
MOLNIYA = KeplerOrbit.from_altitudes(500e3, 39_700e3, inclination=np.radians(63.4), raan=1.0, argument_of_perigee=4.0)
T = np.linspace(0.0, 2.0 * MOLNIYA.period, 401)


def test_kepler_equation_vallado_example_2_1():
    # Vallado Example 2-1: E = 220.512074767522 deg (published to 1e-12 deg);
    # Newton converges to machine precision, so 1e-11 deg is the published rounding.
    assert np.degrees(solve_kepler(np.radians(235.4), 0.4)) == pytest.approx(220.512074767522, abs=1e-11)


@pytest.mark.parametrize("e", [0.0, 0.1, 0.5, 0.9, 0.99, 0.999999])
def test_kepler_equation_residual_is_machine_precision(e):
    m = np.linspace(-20.0, 20.0, 2001)
    big_e = solve_kepler(m, e)
    # Residual of M = E - e sin E: a few ulps of |M| <= 20 rad (the float
    # evaluation of the residual itself rounds at 20 * eps).
    assert np.max(np.abs(big_e - e * np.sin(big_e) - m)) < 8 * 20 * EPS


def test_vallado_example_2_5_state_from_elements():
    a, e = 36127.343e3, 0.832853
    nu = np.radians(92.335)
    big_e = 2.0 * np.arctan(np.sqrt((1 - e) / (1 + e)) * np.tan(nu / 2))  # Vallado Algorithm 5 (nu -> E)
    orbit = KeplerOrbit(
        a, e, np.radians(87.870), np.radians(227.898), np.radians(53.38), big_e - e * np.sin(big_e),
        central_body_radius_m=0.0,  # the example's perigee (6030 km) is inside the Earth
    )  # fmt: skip
    r_km = orbit.position_N(0.0) / 1e3
    v_km_s = orbit.velocity_N(0.0) / 1e3
    # Published elements are rounded: omega to 0.01 deg, the others to 0.001 deg;
    # 0.0065 deg of rotation at |r| = 9490 km is 1.1 km, at |v| = 7.64 km/s 0.9 m/s.
    np.testing.assert_allclose(r_km, [6524.834, 6862.875, 6448.296], atol=1.2)
    np.testing.assert_allclose(v_km_s, [4.901327, 5.533756, -1.976341], atol=1.0e-3)
    # Semi-latus rectum p = h^2 / mu = 11067.790 km (rounded to 1 m; 1e-7 relative
    # from e rounded to 1e-6: dp/p = 2 e de / (1 - e^2) = 5e-6).
    p = np.sum(np.cross(orbit.position_N(0.0), orbit.velocity_N(0.0)) ** 2) / MU_EARTH
    assert p / 1e3 == pytest.approx(11067.790, rel=5e-6)


def test_energy_and_angular_momentum_are_conserved():
    r, v = MOLNIYA.position_N(T), MOLNIYA.velocity_N(T)
    a, e = MOLNIYA.semi_major_axis_m, MOLNIYA.eccentricity
    energy = 0.5 * np.sum(v * v, -1) - MU_EARTH / np.linalg.norm(r, axis=-1)
    # Vis-viva (Vallado eq. 1-31): the specific energy is -mu / 2a. Terms of
    # size mu/r_p = 6e7 m^2/s^2 cancel to 4e6: rounding 1e-16 * 6e7 / 4e6 = 2e-15
    # relative, and E solved to an ulp; 1e-12 leaves room for both.
    np.testing.assert_allclose(energy, -MU_EARTH / (2 * a), rtol=1e-12)
    h = np.cross(r, v)
    h_expected = np.sqrt(MU_EARTH * a * (1 - e * e))
    np.testing.assert_allclose(np.linalg.norm(h, axis=-1), h_expected, rtol=1e-12)  # rounding only
    np.testing.assert_allclose(h / h_expected, np.broadcast_to(h[0] / h_expected, h.shape), atol=1e-12)
    # Perigee and apogee radii a (1 -+ e) reached (the samples include t = 0 at perigee, M = 0).
    radius = np.linalg.norm(r, axis=-1)
    assert radius[0] == pytest.approx(R_EARTH + 500e3, rel=1e-14)
    assert radius[100] == pytest.approx(R_EARTH + 39_700e3, rel=1e-14)  # t = period / 2: apogee


def test_motion_repeats_after_one_period():
    # Exactly periodic; the mean anomaly 2 pi apart loses ~ulp(4 pi) per revolution: 1e-6 m.
    np.testing.assert_allclose(MOLNIYA.position_N(T + MOLNIYA.period), MOLNIYA.position_N(T), atol=1e-6)


def test_zero_eccentricity_reproduces_circular_orbit():
    epoch = Epoch.from_iso("2030-01-01T00:00:00Z")
    circular = CircularOrbit.from_altitude(550e3, inclination=1.7, raan=-0.4, argument_of_latitude=2.2, epoch=epoch)
    kepler = KeplerOrbit(circular.radius_m, 0.0, 1.7, -0.4, 0.0, 2.2, epoch=epoch)
    t = np.linspace(0.0, 3 * circular.period, 50)
    # Same formulae with E = M: rounding only (ulp of 7e6 m is 1e-9 m; of 7.6 km/s, 1e-12 m/s).
    np.testing.assert_allclose(kepler.position_N(t), circular.position_N(t), rtol=0, atol=1e-7)
    np.testing.assert_allclose(kepler.velocity_N(t), circular.velocity_N(t), rtol=0, atol=1e-10)
    assert kepler.mean_motion == circular.mean_motion and kepler.period == circular.period
    # Two constructions of L (rotation sequence vs r, v): same frame to rounding.
    assert np.max(quat.error_angle(circular.q_LN(t), kepler.q_LN(t))) < 1e-7
    np.testing.assert_allclose(kepler.omega_LN_L(t), circular.omega_LN_L(t), rtol=1e-13)
    assert kepler.epoch == epoch and circular.epoch == epoch


def test_lvlh_axes_point_to_nadir_and_the_negative_orbit_normal():
    r, v = MOLNIYA.position_N(T), MOLNIYA.velocity_N(T)
    q = lvlh_attitude(r, v)
    o2 = quat.rotate(q, [0.0, 1.0, 0.0])
    o3 = quat.rotate(q, [0.0, 0.0, 1.0])
    h = np.cross(r, v)
    # Definition of L (Wie; Hughes); rounding only.
    np.testing.assert_allclose(o3, -r / np.linalg.norm(r, axis=-1, keepdims=True), atol=1e-14)
    np.testing.assert_allclose(o2, -h / np.linalg.norm(h, axis=-1, keepdims=True), atol=1e-14)
    np.testing.assert_array_equal(MOLNIYA.q_LN(T), q)


def test_omega_LN_L_is_the_rate_of_q_LN():
    # Central difference of q_LN over +-h: L turns about the fixed o2 axis, so the
    # mean rate over 2h differs from omega(t) by h^2 nu'''/6 (< 1e-10 rad/s at
    # h = 0.5 s near perigee) plus quaternion rounding (1e-16 / 1 s).
    t = np.linspace(0.0, MOLNIYA.period, 25)
    h = 0.5
    dq = quat.multiply(quat.conjugate(MOLNIYA.q_LN(t - h)), MOLNIYA.q_LN(t + h))
    rate = quat.to_rotation_vector(dq) / (2 * h)
    np.testing.assert_allclose(rate, MOLNIYA.omega_LN_L(t), rtol=0, atol=1e-9)
    # [0, -|r x v| / |r|^2, 0] at perigee: -v_p / r_p.
    v_p = np.linalg.norm(MOLNIYA.velocity_N(0.0))
    assert MOLNIYA.omega_LN_L(0.0)[1] == pytest.approx(-v_p / (R_EARTH + 500e3), rel=1e-14)


def test_meets_the_orbit_protocol_and_describes_itself():
    assert isinstance(MOLNIYA, Orbit)
    assert isinstance(CircularOrbit(7e6), Orbit)
    assert MOLNIYA.epoch == DEFAULT_EPOCH
    assert "perigee 500.0 km" in MOLNIYA.describe() and "apogee 39700.0 km" in MOLNIYA.describe()
    assert MOLNIYA.position_N(np.zeros((2, 3))).shape == (2, 3, 3)
    assert MOLNIYA.q_LN(np.zeros((2, 3))).shape == (2, 3, 4)


def test_circular_omega_LN_L_stays_a_constant_vector():
    orbit = CircularOrbit(7e6)
    np.testing.assert_array_equal(orbit.omega_LN_L, [0.0, -orbit.mean_motion, 0.0])
    np.testing.assert_array_equal(orbit.omega_LN_L(np.zeros(4)), np.tile([0.0, -orbit.mean_motion, 0.0], (4, 1)))
    assert type(orbit.omega_LN_L * 2.0) is np.ndarray


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"semi_major_axis_m": 8e6, "eccentricity": 1.2},
            r"eccentricity must be in \[0, 1\) for a closed orbit, got 1.2",
        ),
        ({"semi_major_axis_m": 8e6, "eccentricity": -0.1}, r"eccentricity must be in \[0, 1\).*-0.1"),
        (
            {"semi_major_axis_m": 8e6, "eccentricity": 0.3},
            r"semi_major_axis_m and eccentricity.*perigee altitude -778137",
        ),
        ({"semi_major_axis_m": -8e6}, "semi_major_axis_m"),
        ({"semi_major_axis_m": 8e6, "inclination": 4.0}, r"inclination must be in \[0, pi\]"),
        ({"semi_major_axis_m": 8e6, "epoch": "2026"}, "epoch must be an attitude.environment.epoch.Epoch"),
    ],
)
def test_bad_orbits_are_refused_naming_the_argument(kwargs, message):
    with pytest.raises(ValueError, match=message):
        KeplerOrbit(**kwargs)


def test_from_altitudes_refuses_an_apogee_below_the_perigee():
    with pytest.raises(ValueError, match="apogee_altitude_m must be >= perigee_altitude_m"):
        KeplerOrbit.from_altitudes(800e3, 500e3)

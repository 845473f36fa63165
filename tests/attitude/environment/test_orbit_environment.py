"""The flown orbit environment (:class:`attitude.environment.OrbitEnvironment`) checked piece by piece.

* The track: its linear interpolation between samples against the models evaluated directly at the
  ticks (exact at the samples, within the chord bound between them).
* The magnetic torque in the tilted-dipole limit against a hand computation: the dipole field
  ``B = mu0/4pi (3 (m.r_hat) r_hat - m) / r^3`` (Wertz 1978, appendix H) with the Earth-fixed moment
  rotated to N by ERFA's Greenwich mean sidereal time (``erfa.gmst82``, independent of sgp4's), then
  into body axes by scipy's rotation, and ``tau = m_res x B`` (Wertz sec. 17.3).
* The per-run surface parameters: the drag scale multiplies the aerodynamic torque exactly, and a
  common centre-of-pressure offset ``d`` adds exactly ``d x F`` (the moment of the total force).
"""

from __future__ import annotations

import erfa
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude import quaternion as quat
from attitude.environment import (
    CircularOrbit,
    OrbitEnvironment,
    SurfaceModel,
    TiltedDipole,
    aerodynamic_force,
    solar_pressure_force,
)
from attitude.environment.magnetic_field import MU0_OVER_4PI
from attitude.rigid_body import RigidBody

ORBIT = CircularOrbit.from_altitude(500e3, inclination=np.radians(97.4), raan=0.3)
BODY = RigidBody([[0.39, 0.004, -0.003], [0.004, 0.36, 0.002], [-0.003, 0.002, 0.21]])
SURFACE = SurfaceModel.box([0.23, 0.24, 0.34], specular=0.1, diffuse=0.4, residual_dipole_Am2=[0.02, -0.01, 0.03])


def test_track_is_exact_at_its_samples_and_within_the_chord_bound_between_them():
    coarse = OrbitEnvironment(ORBIT, surface=SURFACE, sample_period=20.0)
    fine = OrbitEnvironment(ORBIT, surface=SURFACE, sample_period=1.0)
    t = np.arange(0.0, 600.0, 1.0)
    a, b = coarse.track(t), fine.track(t)
    at_samples = t % 20.0 == 0.0
    # At the samples both are the models themselves: equal to rounding.
    np.testing.assert_allclose(a.position_N[at_samples], b.position_N[at_samples], rtol=1e-14)
    np.testing.assert_allclose(a.field_N[at_samples], b.field_N[at_samples], rtol=1e-12)
    # Between them, linear interpolation over h = 20 s errs by at most h^2/8 max|f''| per component
    # (the interpolation error theorem). For the position |r''| = r n^2 (a chord of the circle: 0.4 km);
    # for the field, |B''| is taken from the models evaluated every second (central differences).
    h = 20.0
    assert np.max(np.abs(a.position_N - b.position_N)) <= h**2 / 8 * ORBIT.radius_m * ORBIT.mean_motion**2 * 1.001
    field_second = np.abs(b.field_N[2:] - 2.0 * b.field_N[1:-1] + b.field_N[:-2])  # 1 s steps
    bound = h**2 / 8 * field_second.max(axis=0) * 1.05  # 5 %: the second difference is itself sampled
    assert np.all(np.abs(a.field_N - b.field_N).max(axis=0) <= bound)


def test_magnetic_torque_in_the_tilted_dipole_limit_matches_a_hand_computation():
    dipole_model = TiltedDipole(ORBIT.epoch)
    env = OrbitEnvironment(ORBIT, surface=SURFACE, magnetic_field=dipole_model, atmosphere=None, sources=("magnetic",))
    t = np.arange(0.0, 3000.0, 250.0)
    track = env.track(t)
    q = quat.from_rotation_vector(np.outer(np.linspace(0.0, 1.0, t.size), [0.3, -1.1, 0.7]))
    torque = env.torques_B(BODY, q, track)["magnetic"]

    # By hand: ERFA's GMST (IAU 1982, as SGP4's TEME uses) at the UTC Julian date (UT1 = UTC).
    jd = 2451545.0 + (ORBIT.epoch.utc.timestamp() - 946728000.0) / 86400.0 + t / 86400.0
    gmst = erfa.gmst82(np.floor(jd), jd - np.floor(jd))
    r_N = ORBIT.position_N(t)
    m_E = dipole_model.dipole_moment_Am2
    for k in range(t.size):
        c, s = np.cos(gmst[k]), np.sin(gmst[k])
        m_N = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ m_E
        r = np.linalg.norm(r_N[k])
        r_hat = r_N[k] / r
        b_N = MU0_OVER_4PI * (3.0 * (m_N @ r_hat) * r_hat - m_N) / r**3
        b_B = Rotation.from_quat(q[k], scalar_first=True).inv().apply(b_N)
        expected = np.cross(SURFACE.residual_dipole_Am2, b_B)
        # ERFA's and sgp4's GMST agree to 1e-8 rad (test_epoch); the torque follows to that relative size.
        np.testing.assert_allclose(torque[k], expected, rtol=0, atol=1e-7 * np.linalg.norm(expected))


def test_surface_parameters_scale_drag_and_move_every_centre_of_pressure():
    env = OrbitEnvironment(ORBIT, surface=SURFACE, sources=("aerodynamic", "solar_pressure"))
    t = np.arange(0.0, 2000.0, 100.0)
    track = env.track(t)
    q = quat.from_rotation_vector(np.outer(np.linspace(0.0, 1.0, t.size), [0.5, 0.2, -0.9]))
    nominal = env.torques_B(BODY, q, track)
    offset = np.array([0.01, -0.02, 0.03])
    moved = env.torques_B(BODY, q, track, env.surface_parameters(drag_scale=1.7, centre_of_pressure_offset_B_m=offset))
    # The forces by the independent numpy front functions, in body axes.
    v_B = quat.rotate_inverse(q, track.velocity_relative_N)
    s_B = quat.rotate_inverse(q, track.sun_N)
    f_aero = aerodynamic_force(SURFACE, v_B, track.density_kg_m3)
    f_srp = solar_pressure_force(SURFACE, s_B, track.solar_pressure_Pa)
    # r x F is linear in r and in the drag coefficient: exact to rounding.
    np.testing.assert_allclose(
        moved["aerodynamic"], 1.7 * (nominal["aerodynamic"] + np.cross(offset, f_aero)), rtol=1e-12, atol=1e-22
    )
    np.testing.assert_allclose(
        moved["solar_pressure"], nominal["solar_pressure"] + np.cross(offset, f_srp), rtol=1e-12, atol=1e-22
    )


def test_bad_surface_parameters_and_models_name_the_argument():
    env = OrbitEnvironment(ORBIT, surface=SURFACE)
    with pytest.raises(ValueError, match="drag_scale"):
        env.surface_parameters(drag_scale=-1.0)
    with pytest.raises(ValueError, match="sample_period must be at most 1/100 of the orbit period"):
        OrbitEnvironment(ORBIT, surface=SURFACE, sample_period=4000.0)
    with pytest.raises(ValueError, match="'magnetic' needs a magnetic_field"):
        OrbitEnvironment(ORBIT, surface=SURFACE, magnetic_field=None)

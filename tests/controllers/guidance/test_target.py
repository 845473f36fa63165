"""Ground-target tracking against an independent geometry: ERFA's geodesy and GMST, pymap3d's elevation.

At several epochs over a day the boresight of the reference (body z rotated by ``q_RN``) is compared
with the line of sight built without the module: the target's Earth-fixed position from
``erfa.gd2gc`` (IAU SOFA, WGS-84) instead of pymap3d, turned into N by ``erfa.gmst82`` (the IAU-82
GMST, SOFA's implementation, instead of sgp4's) and differenced with the orbit's position. The
visibility flag is compared with ``pymap3d.ecef2aer``'s elevation of the spacecraft seen from the
target, the spacecraft taken to Earth-fixed axes by ERFA's GMST.
"""

from __future__ import annotations

import erfa
import numpy as np
import pymap3d
import pytest

from attitude import quaternion as quat
from attitude.environment import CircularOrbit, KeplerOrbit
from controllers.guidance import GroundTarget, GroundTargetReference

CIRCULAR = CircularOrbit.from_altitude(550e3, inclination=np.radians(97.6), raan=0.4, argument_of_latitude=1.0)
ELLIPTIC = KeplerOrbit.from_altitudes(400e3, 4000e3, inclination=1.0, raan=0.3, argument_of_perigee=0.7)
MUNICH = GroundTarget.from_degrees(48.14, 11.58, 520.0)
EPOCHS = np.linspace(0.0, 86400.0, 97)


def _independent(orbit, target, t):
    jd = orbit.epoch.julian_date(t)
    gmst = np.array([erfa.gmst82(j, 0.0) for j in jd])
    r_E = erfa.gd2gc(1, target.longitude, target.latitude, target.altitude_m)  # 1 = WGS-84
    c, s = np.cos(gmst), np.sin(gmst)
    r_T = np.stack([c * r_E[0] - s * r_E[1], s * r_E[0] + c * r_E[1], np.full_like(c, r_E[2])], axis=-1)
    r = orbit.position_N(t)
    los = r_T - r
    r_sc_E = np.stack([c * r[:, 0] + s * r[:, 1], -s * r[:, 0] + c * r[:, 1], r[:, 2]], axis=-1)
    _, elevation, _ = pymap3d.ecef2aer(
        r_sc_E[:, 0], r_sc_E[:, 1], r_sc_E[:, 2], target.latitude, target.longitude, target.altitude_m, deg=False
    )
    return los / np.linalg.norm(los, axis=-1, keepdims=True), np.asarray(elevation)


@pytest.mark.parametrize("orbit", [CIRCULAR, ELLIPTIC], ids=["circular", "elliptic"])
def test_boresight_on_the_independent_line_of_sight_at_many_epochs(orbit):
    ref = GroundTargetReference(orbit, MUNICH, [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], secondary="velocity")
    los, elevation = _independent(orbit, MUNICH, EPOCHS)
    q, _, _ = ref.samples(EPOCHS)
    angle = np.arccos(np.clip(np.sum(quat.rotate(q, [0.0, 0.0, 1.0]) * los, axis=-1), -1.0, 1.0))
    # sgp4's and SOFA's IAU-82 GMST agree to ~1e-12 rad (the same expression) and pymap3d's and SOFA's
    # geodetic conversions to well under a millimetre: 6.4e6 m x 1e-12 / 400 km and 1 mm / 400 km
    # bound the angle by ~3e-9 rad. arccos near 1 resolves angles to ~2e-8 rad (sqrt of 2 eps).
    assert np.max(angle) < 5e-8
    # Visibility: the mode's elevation against pymap3d's az/el of the same geometry (~1e-9 rad apart).
    np.testing.assert_allclose(ref.elevation(EPOCHS), elevation, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(ref.visible(EPOCHS), elevation > 0.0)
    assert 0 < np.count_nonzero(ref.visible(EPOCHS)) < EPOCHS.size  # both cases occur


def test_target_moves_with_the_earth():
    ref = GroundTargetReference(CIRCULAR, MUNICH)
    r, v, a = ref.target_motion_N(np.array([0.0, 3600.0]))
    # A point on the Earth turns about the pole at the Earth's rate (WGS-84, 7.292115e-5 rad/s):
    # speed omega_E times its distance from the axis, centripetal acceleration omega_E^2 times it.
    rho = np.hypot(r[:, 0], r[:, 1])
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 7.292115e-5 * rho, rtol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(a, axis=1), 7.292115e-5**2 * rho, rtol=1e-14)
    assert abs(np.linalg.norm(r[0]) - np.linalg.norm(r[1])) < 1e-6


@pytest.mark.parametrize(
    ("args", "match"),
    [((np.radians(91.0), 0.0), "latitude must be a geodetic latitude"), ((0.0, 0.0, -2e5), "altitude_m")],
)
def test_bad_target_is_refused_by_name(args, match):
    with pytest.raises(ValueError, match=match):
        GroundTarget(*args)


def test_bad_target_argument_is_refused_by_name():
    with pytest.raises(ValueError, match="target must be a GroundTarget"):
        GroundTargetReference(CIRCULAR, (0.8, 0.2, 0.0))
    with pytest.raises(ValueError, match="secondary must be one of"):
        GroundTargetReference(CIRCULAR, MUNICH, secondary="sun")
    with pytest.raises(ValueError, match=r"orbit must have position_N"):
        GroundTargetReference(object(), MUNICH)

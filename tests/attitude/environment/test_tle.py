"""Tests of TLEOrbit (attitude.environment.orbit): SGP4 through the sgp4 package.

Checked against the verification case of Vallado, Crawford, Hujsak and
Kelso, "Revisiting Spacetrack Report #3", AIAA 2006-6753, as shipped in the
sgp4 package (2.27) file ``sgp4/tcppver.out``: satellite 00005 (TLE from
``sgp4/SGP4-VER.TLE``) at 0 and 360 minutes, TEME position [km] and velocity
[km/s]. The tolerance 2e-7 (km, km/s) is the one sgp4's own ``tests.py`` uses
against that file (``error = 2e-7``). Satellite 28872 of the same file decays
before 60 minutes (sgp4 error 6).
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import numpy as np
import pytest

from attitude import quaternion as quat
from attitude.environment.orbit import Orbit, TLEOrbit

LINE1 = "1 00005U 58002B   00179.78495062  .00000023  00000-0  28098-4 0  4753"
LINE2 = "2 00005  34.2682 348.7242 1859667 331.7664  19.3264 10.82419157413667"
DECAYING = (
    "1 28872U 05037B   05333.02012661  .25992681  00000-0  24476-3 0  1534",
    "2 28872  96.4736 157.9986 0303955 244.0492 110.6523 16.46015938 10708",
)

#: sgp4/tcppver.out, satellite 5: minutes, r [km], v [km/s].
TCPPVER_00005 = {
    0.0: ([7022.46529266, -1400.08296755, 0.03995155], [1.893841015, 6.405893759, 4.534807250]),
    360.0: ([-7154.03120202, -3783.17682504, -3536.19412294], [4.741887409, -4.151817765, -2.093935425]),
}
SGP4_TEST_TOLERANCE = 2e-7  # sgp4 tests.py, on km and km/s


def test_00005_against_the_published_verification_output():
    orbit = TLEOrbit(LINE1, LINE2)
    minutes = np.array(sorted(TCPPVER_00005))
    r = orbit.position_N(60.0 * minutes)
    v = orbit.velocity_N(60.0 * minutes)
    for k, m in enumerate(minutes):
        r_km, v_km_s = TCPPVER_00005[m]
        np.testing.assert_allclose(r[k] / 1e3, r_km, rtol=0, atol=SGP4_TEST_TOLERANCE)
        np.testing.assert_allclose(v[k] / 1e3, v_km_s, rtol=0, atol=SGP4_TEST_TOLERANCE)


def test_epoch_and_mean_motion_come_from_the_tle():
    orbit = TLEOrbit(LINE1, LINE2)
    # Epoch field 00179.78495062: day 179.78495062 of 2000 (day 1 = 1 January).
    expected = datetime(2000, 1, 1, tzinfo=UTC) + timedelta(days=178.78495062)
    # sgp4 rounds the epoch to the microsecond; the TLE gives it to 1e-8 day (0.9 ms).
    assert abs((orbit.epoch.utc - expected).total_seconds()) <= 1e-6
    # Mean motion field 10.82419157 rev/day, exact to the float conversion.
    assert orbit.mean_motion == pytest.approx(10.82419157 * 2 * np.pi / 86400.0, rel=1e-12)
    assert orbit.period == pytest.approx(86400.0 / 10.82419157, rel=1e-12)
    assert "00005" in orbit.describe() and "2000-06-27T18:50:19" in orbit.describe()


def test_lvlh_frame_and_rate_of_the_sgp4_state():
    orbit = TLEOrbit(LINE1, LINE2)
    t = np.linspace(0.0, orbit.period, 9).reshape(3, 3)
    r, v = orbit.position_N(t), orbit.velocity_N(t)
    q = orbit.q_LN(t)
    assert q.shape == (3, 3, 4) and orbit.omega_LN_L(t).shape == (3, 3, 3)
    # o3 to nadir (definition of L); rounding only.
    np.testing.assert_allclose(quat.rotate(q, [0, 0, 1.0]), -r / np.linalg.norm(r, axis=-1, keepdims=True), atol=1e-14)
    rate = np.linalg.norm(np.cross(r, v), axis=-1) / np.sum(r * r, axis=-1)
    np.testing.assert_allclose(orbit.omega_LN_L(t)[..., 1], -rate, rtol=1e-14)
    assert isinstance(orbit, Orbit)


def test_decayed_satellite_raises_naming_the_time_and_sgp4s_message():
    orbit = TLEOrbit(*DECAYING)
    orbit.position_N(600.0)  # still flying at 10 minutes
    with pytest.raises(
        ValueError, match=r"t = 3600.0 s after the TLE epoch: sgp4 error 6: mrt is less than 1.0.*decayed"
    ):
        orbit.position_N([600.0, 3600.0])


@pytest.mark.parametrize(
    ("line1", "line2", "message"),
    [
        ("1 garbage", LINE2, "line1 does not parse as a TLE line: TLE format error"),
        (LINE1, LINE2[:40], "line2 does not parse as a TLE line: TLE format error"),
        (
            LINE1[:-1] + "5",
            LINE2,
            "line1 fails its TLE checksum: TLE line gives its checksum as 5 but in fact tallies to 3",
        ),
        (LINE2, LINE1, "line1 must be the first TLE line, starting with '1 '"),
        (LINE1, None, "line2 must be a str"),
    ],
)
def test_lines_that_do_not_parse_are_refused_naming_the_line(line1, line2, message):
    with pytest.raises(ValueError, match=message):
        TLEOrbit(line1, line2)

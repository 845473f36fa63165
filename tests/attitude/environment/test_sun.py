"""Tests of the low-precision solar ephemeris (attitude.environment.sun).

Checked against:
- ERFA (pyerfa): the geocentric Sun is minus the Earth's heliocentric position
  of ``erfa.epv00`` (in the ICRS axes), made apparent by the annual aberration
  of the Earth's barycentric velocity with ``erfa.ab`` (20 arcsec, which the
  Almanac's mean longitude includes, so it is applied to ERFA rather than
  left in the error budget), and rotated to the mean equator and equinox of
  date with ``erfa.pmat06`` (IAU 2006 precession with frame bias). The
  Almanac's figure is 0.01 deg from 1950 to 2050: that is the tolerance, on
  400 dates spread over the century. Measured: 0.0091 deg at worst.
- The instants of the 2024 equinoxes and solstices published by the US Naval
  Observatory ("Earth's Seasons and Apsides", to the minute, UTC): right
  ascension 0/90/180/270 deg; declination 0 at the equinoxes and +-obliquity
  (``erfa.obl06``, IAU 2006) at the solstices.
"""

from __future__ import annotations

import erfa
import numpy as np
import pytest

from attitude.environment.epoch import Epoch
from attitude.environment.sun import AU_M, SUN_RADIUS_M, sun_direction_N, sun_position_N

#: The Astronomical Almanac's stated accuracy of the low-precision formulae (1950-2050).
ALMANAC_ACCURACY_DEG = 0.01
#: TT - UTC: 32.184 s + leap seconds (37 s since 2017); 69.184 s, used for every
#: date: the 40 s range of the offset over the century moves the Sun 0.0005 deg.
TT_MINUS_UTC_S = 69.184
JD_1950, JD_2050 = 2433282.5, 2469807.5


def erfa_apparent_sun(jd_utc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ERFA's apparent Sun direction on the mean equator and equinox of date, and its distance [AU]."""
    directions, distances = [], []
    c_au_per_day = erfa.CMPS * 86400.0 / erfa.DAU
    for jd in jd_utc:
        tt2 = jd - 2400000.5 + TT_MINUS_UTC_S / 86400.0  # TDB ~ TT to 1.7 ms
        heliocentric, barycentric = erfa.epv00(2400000.5, tt2)
        sun = -heliocentric[0]
        velocity_c = barycentric[1] / c_au_per_day
        apparent = erfa.ab(
            sun / np.linalg.norm(sun), velocity_c, np.linalg.norm(sun), np.sqrt(1 - velocity_c @ velocity_c)
        )
        directions.append(erfa.pmat06(2400000.5, tt2) @ apparent)
        distances.append(np.linalg.norm(sun))
    return np.array(directions), np.array(distances)


def test_direction_within_the_almanac_accuracy_of_erfa_1950_to_2050():
    jd = np.linspace(JD_1950, JD_2050, 400) + 0.37  # spread over times of day too
    expected, _ = erfa_apparent_sun(jd)
    angle = np.degrees(np.arccos(np.clip(np.sum(sun_direction_N(jd) * expected, -1), -1.0, 1.0)))
    assert np.max(angle) < ALMANAC_ACCURACY_DEG


def test_distance_against_erfa():
    jd = np.linspace(JD_1950, JD_2050, 400)
    _, expected_au = erfa_apparent_sun(jd)
    distance_au = np.linalg.norm(sun_position_N(jd), axis=-1) / AU_M
    # The two-term series leaves out the Earth's 4,700 km swing about the
    # Earth-Moon barycentre (3.1e-5 AU) and the planetary perturbations (a few
    # 1e-5 AU): 1e-4 AU, 2e-4 relative in the solar pressure. Measured 8.4e-5 AU.
    np.testing.assert_allclose(distance_au, expected_au, rtol=0, atol=1e-4)


# USNO, Earth's Seasons and Apsides, 2024 (UTC, to the minute).
SEASONS_2024 = [
    ("2024-03-20T03:06:00Z", 0.0, 0),
    ("2024-06-20T20:51:00Z", 90.0, +1),
    ("2024-09-22T12:44:00Z", 180.0, 0),
    ("2024-12-21T09:21:00Z", 270.0, -1),
]


@pytest.mark.parametrize(("iso", "right_ascension_deg", "solstice_sign"), SEASONS_2024)
def test_equinoxes_and_solstices_of_2024(iso, right_ascension_deg, solstice_sign):
    jd = Epoch.from_iso(iso).julian_date()
    s = sun_direction_N(jd)
    ra = np.degrees(np.arctan2(s[1], s[0])) % 360.0
    dec = np.degrees(np.arcsin(s[2]))
    # The almanac's 0.01 deg, plus the 30 s rounding of the published minute
    # (the Sun moves 0.0003 deg of longitude in 30 s).
    tolerance = ALMANAC_ACCURACY_DEG + 0.0003
    assert abs((ra - right_ascension_deg + 180.0) % 360.0 - 180.0) < tolerance
    obliquity = np.degrees(erfa.obl06(jd + TT_MINUS_UTC_S / 86400.0, 0.0))  # mean obliquity, IAU 2006
    assert dec == pytest.approx(solstice_sign * obliquity, abs=tolerance)


def test_shapes_units_and_constants():
    jd = 2451545.0 + np.arange(12.0).reshape(3, 4) * 30.0
    assert sun_position_N(jd).shape == (3, 4, 3)
    np.testing.assert_allclose(np.linalg.norm(sun_direction_N(jd), axis=-1), 1.0, rtol=1e-15)
    # The distance stays within perihelion and aphelion, 1 -+ e with e = 0.0167.
    distance_au = np.linalg.norm(sun_position_N(jd), axis=-1) / AU_M
    assert np.all((distance_au > 0.9832) & (distance_au < 1.0168))
    assert AU_M == 149_597_870_700.0 and SUN_RADIUS_M == 6.957e8
    with pytest.raises(ValueError, match="julian_date must be finite"):
        sun_position_N(np.inf)

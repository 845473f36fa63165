"""Tests of attitude.environment.epoch: UTC epochs, Julian dates, GMST and the ECEF -> N rotation.

Checked against ERFA (pyerfa, the IAU SOFA library): Julian dates against
``erfa.dtf2d`` and GMST against ``erfa.gmst82`` (the IAU 1982 expression, the
one SGP4's ``gstime`` implements); J2000.0 against its definition
(2000-01-01 12:00 TT is JD 2451545.0).
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone

import erfa
import numpy as np
import pytest

from attitude.environment.epoch import DEFAULT_EPOCH, Epoch, ecef_to_N

DATES = ["1957-10-04T19:28:34Z", "2000-01-01T12:00:00Z", "2024-06-20T20:51:00Z", "2049-12-31T23:59:59.5Z"]

#: float64 resolves a Julian date near 2.45e6 days to 4.7e-10 days (40 us);
#: two ulps of the sum of sgp4's two-part date.
JD_TOLERANCE_DAYS = 1e-9


def test_j2000_julian_date_by_definition():
    # JD 2451545.0 is 2000-01-01 12:00 (Meeus, Astronomical Algorithms, ch. 7).
    assert Epoch.from_iso("2000-01-01T12:00:00Z").julian_date() == pytest.approx(2451545.0, abs=JD_TOLERANCE_DAYS)


# ERFA flags 1957 (before UTC) and 2049 (beyond its leap-second table) as a
# "dubious year": that concerns leap seconds, not the calendar-to-JD conversion.
@pytest.mark.filterwarnings("ignore::erfa.ErfaWarning")
@pytest.mark.parametrize("iso", DATES)
def test_julian_date_matches_erfa(iso):
    epoch = Epoch.from_iso(iso)
    u = epoch.utc
    jd1, jd2 = erfa.dtf2d("UTC", u.year, u.month, u.day, u.hour, u.minute, u.second + 1e-6 * u.microsecond)
    t = np.array([0.0, 3600.0, 86400.0 * 10])
    # Whole days later are the same UTC time of day (no leap second inside these spans).
    expected = jd1 + jd2 + t / 86400.0
    np.testing.assert_allclose(epoch.julian_date(t), expected, rtol=0, atol=JD_TOLERANCE_DAYS)


@pytest.mark.parametrize("iso", DATES)
def test_gmst_matches_erfa_gmst82(iso):
    epoch = Epoch.from_iso(iso)
    t = np.linspace(0.0, 6000.0, 7).reshape(7, 1) * np.ones((1, 2))
    jd = epoch.julian_date(t)
    expected = np.vectorize(lambda d: erfa.gmst82(d, 0.0))(jd)
    # Same IAU-82 polynomial; the difference is the 40 us float64 resolution of
    # the date times Earth's rotation rate (7.3e-5 rad/s): 3e-9 rad, bound 1e-8.
    diff = np.angle(np.exp(1j * (epoch.gmst(t) - expected)))
    assert np.max(np.abs(diff)) < 1e-8
    assert epoch.gmst(t).shape == (7, 2)


def test_non_utc_time_is_converted_to_the_same_instant():
    paris = Epoch(datetime(2026, 3, 20, 14, 0, tzinfo=timezone(timedelta(hours=2))))
    assert paris.utc == datetime(2026, 3, 20, 12, 0, tzinfo=UTC)
    assert paris.utc.utcoffset() == timedelta(0)
    assert paris == DEFAULT_EPOCH
    assert Epoch.from_iso("2026-03-20T12:00:00Z") == DEFAULT_EPOCH
    assert DEFAULT_EPOCH.describe() == "2026-03-20T12:00:00Z"


def test_bad_epochs_are_refused_with_the_argument_named():
    with pytest.raises(ValueError, match=r"utc must be timezone-aware.*2026-03-20T12:00:00"):
        Epoch(datetime(2026, 3, 20, 12, 0))
    with pytest.raises(ValueError, match="utc must be a timezone-aware datetime"):
        Epoch("2026-03-20")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"text must be an ISO 8601.*'yesterday'"):
        Epoch.from_iso("yesterday")
    with pytest.raises(ValueError, match=r"text must carry a zone.*'2026-03-20T12:00:00'"):
        Epoch.from_iso("2026-03-20T12:00:00")
    with pytest.raises(ValueError, match="t must be finite"):
        DEFAULT_EPOCH.julian_date(np.nan)


def test_ecef_to_N_turns_the_greenwich_meridian_by_gmst():
    gmst = np.array([[0.0, 0.3], [2.0, 5.9]])
    m = ecef_to_N(gmst)
    assert m.shape == (2, 2, 3, 3)
    # Definition: the ECEF x axis (Greenwich meridian, equator) lies at right
    # ascension GMST in N; z is shared. Rounding only: 1e-15.
    np.testing.assert_allclose(m @ [1.0, 0.0, 0.0], np.stack([np.cos(gmst), np.sin(gmst), 0 * gmst], -1), atol=1e-15)
    np.testing.assert_allclose(m @ [0.0, 0.0, 1.0], np.broadcast_to([0.0, 0.0, 1.0], (2, 2, 3)), atol=1e-15)
    np.testing.assert_allclose(m @ np.swapaxes(m, -1, -2), np.broadcast_to(np.eye(3), (2, 2, 3, 3)), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(m), 1.0, atol=1e-15)

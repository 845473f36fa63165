"""The geomagnetic field in N: IGRF through ppigrf and the tilted dipole.

What each test checks against:

* IGRF at five points on 2020-01-01, 5 km above the WGS-84 ellipsoid, against the NOAA NCEI
  geomagnetic calculator (model "IGRF2020", calculator version 0.5.1.11), as stored in ppigrf's own
  test data (github.com/klaundal/ppigrf, ``test/data/2020-01-01/b_e.csv``, ``b_n.csv``, ``b_z.csv``,
  commit 4dc503d): the whole chain geodetic -> Earth-fixed -> N -> field -> Earth-fixed -> local
  east/north/down, at two sidereal angles.
* The N-frame rotation: an Earth-fixed point seen at two times has the same field magnitude and its
  field turned by exactly the GMST difference; the magnitude equals ppigrf's ``igrf_gc`` at the
  same geocentric point (frame-invariant); at the north pole the radial component is ppigrf's and
  the horizontal component turns with the Earth.
* Lowes-Mauersberger spectrum (Lowes, J. Geophys. Res. 71, 2179, 1966; Lowes, Geophys. J. R.
  Astron. Soc. 36, 717, 1974): the mean square of the field of degree n over a sphere of radius r is
  ``(n + 1) (a / r)^(2n + 4) sum_m (g_nm^2 + h_nm^2)``, degrees orthogonal. Integrated exactly
  (Gauss-Legendre in cos(theta) times a uniform grid in longitude) for the full IGRF, the tilted
  dipole and their difference at r = a and 4 a: the non-dipole part falls as r^-(n+2).
* The tilted dipole against IGRF at ``max_degree=1`` (same three coefficients: rounding only), its
  field 1e-7 |m| / r^3 on the magnetic equator and twice that on its axis (Wertz 1978, app. H), about
  3e-5 T at the surface, and its tilt (about 9-10 deg in the 2020s).
* Secular variation ignored by the one-day date grid: below 0.25 nT (module docstring).
* Bad input: errors name the argument, the rule and the value.

Package A's ``Epoch`` is stood in for by ``_Epoch`` (``utc`` and ``gmst(t)`` through
``sgp4.propagation.gstime``, the functions ``Epoch`` is specified to use).
"""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np
import pytest
from ppigrf import ppigrf
from sgp4.api import jday
from sgp4.propagation import gstime

from attitude.environment.magnetic_field import IGRF, TiltedDipole

A_REF = 6371.2e3  # IGRF reference radius [m] (IGRF-14 file header, ppigrf.ppigrf.RE)
WGS84_A = 6378137.0
WGS84_E2 = 0.00669437999014


class _Epoch:
    """Stand-in for attitude.environment.epoch.Epoch (package A): ``utc`` and ``gmst(t)``."""

    def __init__(self, utc: datetime) -> None:
        self.utc = utc

    def gmst(self, t):
        u = self.utc
        jd, fr = jday(u.year, u.month, u.day, u.hour, u.minute, u.second + 1e-6 * u.microsecond)
        return np.vectorize(gstime, otypes=[float])(jd + (fr + np.asarray(t, dtype=float) / 86400.0))


def _r3(angle):
    """R3(angle): N components -> Earth-fixed components when angle is the GMST."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def _geodetic_to_earth_fixed(lat_deg, lon_deg, h_m):
    """Textbook WGS-84 geodetic -> Earth-fixed (prime-vertical radius N = a / sqrt(1 - e^2 sin^2 lat))."""
    lat, lon = np.radians(lat_deg), np.radians(lon_deg)
    n = WGS84_A / np.sqrt(1 - WGS84_E2 * np.sin(lat) ** 2)
    return np.array(
        [
            (n + h_m) * np.cos(lat) * np.cos(lon),
            (n + h_m) * np.cos(lat) * np.sin(lon),
            (n * (1 - WGS84_E2) + h_m) * np.sin(lat),
        ]
    )


# NOAA NCEI calculator, IGRF2020, 2020.0, 5 km above WGS-84: (lat, lon, east, north, down) [deg, nT].
NCEI_2020 = [
    (80.0, 0.0, -151.6, 6560.4, 54497.7),
    (60.0, 10.0, 920.3, 15063.0, 48911.3),
    (10.0, -70.0, -5080.0, 26693.7, 18140.5),
    (0.0, 0.0, -2238.6, 27469.7, -15947.4),
    (-45.0, 120.0, -1684.0, 14218.9, -62223.8),
]


@pytest.mark.parametrize(
    ("coefficient_file", "tolerance_nT"),
    [
        # The NCEI values are IGRF-13's 2020 model, ppigrf ships that file: ppigrf's own evaluation
        # differs from the calculator by up to 1.05 nT at these points (measured; ppigrf's test
        # allows 1 nT + 1 %), the calculator prints 0.1 nT. A frame error of 0.005 deg would add
        # 5 nT on 60,000 nT.
        (ppigrf.shc_fn_igrf13, 1.5),
        # IGRF-14 (the default) replaced the provisional 2020 model by the definitive DGRF 2020:
        # up to 3.9 nT apart at these points (ppigrf with both files), plus the 1.05 nT above.
        (None, 5.0),
    ],
)
def test_igrf_matches_noaa_calculator(coefficient_file, tolerance_nT):
    epoch = _Epoch(datetime(2020, 1, 1, tzinfo=UTC))
    model = IGRF(coefficient_file=coefficient_file)
    for t in (0.0, 6 * 3600.0):  # GMST 100 deg and 190 deg; both round to the 2020-01-01 coefficients
        gmst = float(epoch.gmst(t))
        for lat, lon, east, north, down in NCEI_2020:
            r_E = _geodetic_to_earth_fixed(lat, lon, 5e3)
            b_E = _r3(gmst) @ model.field_N(_r3(gmst).T @ r_E, epoch, t)
            la, lo = np.radians(lat), np.radians(lon)
            e_hat = np.array([-np.sin(lo), np.cos(lo), 0.0])
            n_hat = np.array([-np.sin(la) * np.cos(lo), -np.sin(la) * np.sin(lo), np.cos(la)])
            u_hat = np.array([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)])
            got = 1e9 * np.array([b_E @ e_hat, b_E @ n_hat, -(b_E @ u_hat)])
            np.testing.assert_allclose(got, [east, north, down], rtol=0, atol=tolerance_nT, err_msg=f"{lat}, {lon}")


def test_rotation_to_N_is_the_earth_rotation():
    epoch = _Epoch(datetime(2026, 3, 20, 12, tzinfo=UTC))
    model = IGRF()
    rng = np.random.default_rng(11)
    r_E = rng.normal(size=(6, 3))
    r_E *= 6778e3 / np.linalg.norm(r_E, axis=-1, keepdims=True)
    t1, t2 = 0.0, 3 * 3600.0  # same one-day coefficient date
    g1, g2 = float(epoch.gmst(t1)), float(epoch.gmst(t2))
    b1 = model.field_N(r_E @ _r3(g1), epoch, t1)  # rows: R3(g)^T r_E
    b2 = model.field_N(r_E @ _r3(g2), epoch, t2)
    # Rounding only: the same ppigrf evaluation, rotated by double-precision matrices.
    np.testing.assert_allclose(np.linalg.norm(b1, axis=-1), np.linalg.norm(b2, axis=-1), rtol=1e-12)
    np.testing.assert_allclose(b2, b1 @ _r3(g2 - g1), rtol=0, atol=1e-12 * 6e-5)
    # Frame-invariant magnitude against ppigrf called directly in geocentric coordinates.
    radius = np.linalg.norm(r_E, axis=-1)
    theta = np.degrees(np.arccos(r_E[:, 2] / radius))
    phi = np.degrees(np.arctan2(r_E[:, 1], r_E[:, 0]))
    b_r, b_t, b_p = ppigrf.igrf_gc(radius / 1e3, theta, phi, datetime(2026, 3, 20, 12))
    np.testing.assert_allclose(1e9 * np.linalg.norm(b1, axis=-1), np.sqrt(b_r**2 + b_t**2 + b_p**2)[0], rtol=1e-12)


def test_field_at_the_north_pole():
    epoch = _Epoch(datetime(2026, 3, 20, 12, tzinfo=UTC))
    model = IGRF()
    r_N = np.array([0.0, 0.0, 7000e3])
    b = model.field_N(np.stack([r_N, r_N]), epoch, [0.0, 3600.0])
    assert np.all(np.isfinite(b))
    # Limit of ppigrf's spherical components at colatitude 1e-6 deg (the field is smooth there;
    # 1e-6 deg moves the point 0.1 m, a 1e-8 relative change): B . z = B_r, horizontal |B| the same.
    b_r, b_t, b_p = (float(c[0]) for c in ppigrf.igrf_gc(7000.0, 1e-6, 0.0, datetime(2026, 3, 20, 12)))
    np.testing.assert_allclose(1e9 * b[:, 2], b_r, rtol=1e-7)
    np.testing.assert_allclose(1e9 * np.linalg.norm(b[:, :2], axis=-1), np.hypot(b_t, b_p), rtol=1e-6)
    assert b_r < 0  # the field points down into the northern hemisphere
    # The horizontal field is fixed to the Earth: in N it turns by the sidereal angle in one hour.
    turned = np.arctan2(b[1, 1], b[1, 0]) - np.arctan2(b[0, 1], b[0, 0])
    expected = float(epoch.gmst(3600.0) - epoch.gmst(0.0))
    assert abs(np.angle(np.exp(1j * (turned - expected)))) < 1e-9  # rounding of atan2 on 1e-6 T components


def _gauss_coefficients_2025():
    """(n, sum_m g^2 + h^2) [nT^2] of the 2025 IGRF-14 model, read through ppigrf."""
    g, h = ppigrf.read_shc()
    row_g, row_h = g.loc[datetime(2025, 1, 1)], h.loc[datetime(2025, 1, 1)]
    power = {}
    for (n, m), value in row_g.items():
        power[n] = power.get(n, 0.0) + value**2 + float(row_h[(n, m)]) ** 2
    return power


def _sphere_mean_square(field, radius):
    """Exact mean of |B|^2 over a sphere for fields of degree <= 14 (|B|^2 of degree <= 28)."""
    x, w = np.polynomial.legendre.leggauss(20)  # exact for polynomials of degree <= 39 in cos(theta)
    lon = np.linspace(0.0, 2 * np.pi, 40, endpoint=False)  # exact for longitude frequencies < 40
    ct, ln = np.meshgrid(x, lon, indexing="ij")
    st = np.sqrt(1 - ct**2)
    r = radius * np.stack((st * np.cos(ln), st * np.sin(ln), ct), axis=-1)
    b2 = np.sum(field(r) ** 2, axis=-1)
    return float(np.sum(w[:, None] * b2) / (2.0 * lon.size))


def test_lowes_spectrum_igrf_dipole_and_rest():
    epoch = _Epoch(datetime(2025, 1, 1, tzinfo=UTC))  # a tabulated model: no interpolation
    power = _gauss_coefficients_2025()
    igrf, dipole = IGRF(), TiltedDipole(epoch)
    share = {}
    for ratio in (1.0, 4.0):
        spectrum = {n: (n + 1) * ratio ** -(2 * n + 4) * p * 1e-18 for n, p in power.items()}  # T^2
        full = _sphere_mean_square(lambda r: igrf.field_N(r, epoch, 0.0), ratio * A_REF)
        dip = _sphere_mean_square(lambda r: dipole.field_N(r, epoch, 0.0), ratio * A_REF)
        rest = _sphere_mean_square(lambda r: igrf.field_N(r, epoch, 0.0) - dipole.field_N(r, epoch, 0.0), ratio * A_REF)
        # The quadrature is exact for these band-limited fields: rounding only (800 points).
        np.testing.assert_allclose(full, sum(spectrum.values()), rtol=1e-10)
        np.testing.assert_allclose(dip, spectrum[1], rtol=1e-10)
        np.testing.assert_allclose(rest, sum(v for n, v in spectrum.items() if n >= 2), rtol=1e-10)
        share[ratio] = rest / dip
    # Relative to the dipole, degree n loses (a / r)^(2n - 2) in mean square: at least 16 at 4 a.
    assert share[4.0] < share[1.0] / 16


def test_tilted_dipole_is_igrf_degree_one():
    epoch = _Epoch(datetime(2026, 3, 20, 12, tzinfo=UTC))  # between tabulated years: interpolated
    rng = np.random.default_rng(3)
    r = rng.normal(size=(50, 3)) * 7e6
    t = rng.uniform(0.0, 5700.0, size=50)
    # Same three coefficients, same linear interpolation in time, different arithmetic: rounding only.
    np.testing.assert_allclose(
        TiltedDipole(epoch).field_N(r, epoch, t),
        IGRF(max_degree=1, date_resolution=1e9).field_N(r, epoch, t),
        rtol=0,
        atol=1e-13 * 6e-5,
    )


def test_dipole_magnitudes_and_tilt():
    epoch = _Epoch(datetime(2025, 1, 1, tzinfo=UTC))
    g, h = ppigrf.read_shc()
    g10, g11, h11 = (
        float(x)
        for x in (
            g.loc[datetime(2025, 1, 1), (1, 0)],
            g.loc[datetime(2025, 1, 1), (1, 1)],
            h.loc[datetime(2025, 1, 1), (1, 1)],
        )
    )
    b0 = 1e-9 * np.sqrt(g10**2 + g11**2 + h11**2)  # equatorial surface field of the dipole [T]
    dipole = TiltedDipole(epoch)
    m = dipole.dipole_moment_Am2
    np.testing.assert_allclose(np.linalg.norm(m), 1e7 * b0 * A_REF**3, rtol=1e-14)  # |m| = 4 pi a^3 B0 / mu0
    assert 7.5e22 < np.linalg.norm(m) < 8.0e22  # Earth's dipole moment, 7.7e22 A m^2 in the 2020s
    # Tilt: angle of the north geomagnetic pole (-m) from the spin axis, about 9.2 deg in 2025.
    np.testing.assert_allclose(dipole.tilt_rad, np.arccos(-g10 / np.sqrt(g10**2 + g11**2 + h11**2)), rtol=1e-14)
    assert np.radians(9.0) < dipole.tilt_rad < np.radians(10.0)
    gmst = float(epoch.gmst(0.0))
    equator_E = np.cross(m, [0.0, 0.0, 1.0])
    equator_E *= A_REF / np.linalg.norm(equator_E)
    axis_E = -m / np.linalg.norm(m) * A_REF
    b_equator = dipole.field_N(_r3(gmst).T @ equator_E, epoch, 0.0)
    b_axis = dipole.field_N(_r3(gmst).T @ axis_E, epoch, 0.0)
    # Wertz app. H: |B| = B0 on the magnetic equator, 2 B0 on the axis; rounding only.
    np.testing.assert_allclose(np.linalg.norm(b_equator), b0, rtol=1e-13)
    np.testing.assert_allclose(np.linalg.norm(b_axis), 2 * b0, rtol=1e-13)
    assert 2.9e-5 < np.linalg.norm(b_equator) < 3.1e-5  # the textbook "about 3e-5 T at the equator"
    # On the equator the field is antiparallel to m (pointing north); on the axis parallel to it.
    m_N = _r3(gmst).T @ m
    np.testing.assert_allclose(b_equator / np.linalg.norm(b_equator), -m_N / np.linalg.norm(m_N), atol=1e-13)


def test_one_day_date_grid_ignores_under_a_quarter_nanotesla():
    epoch = _Epoch(datetime(2026, 3, 20, 12, tzinfo=UTC))
    r = np.array([[6778e3, 0.0, 0.0], [0.0, 4e6, 5.5e6], [-3e6, -3e6, -5e6]])
    t = 43199.0  # half a day: the default grid uses the epoch's coefficients
    coarse = IGRF().field_N(r, epoch, t)
    exact = IGRF(date_resolution=1.0).field_N(r, epoch, t)
    # IGRF-14 secular variation, at most ~150 nT/yr at the surface: 0.2 nT in half a day.
    assert 0.0 < np.max(np.linalg.norm(coarse - exact, axis=-1)) < 0.25e-9


def test_shapes_and_describe():
    epoch = _Epoch(datetime(2026, 3, 20, 12, tzinfo=UTC))
    r = np.full((2, 3, 3), 7e6)
    for model in (IGRF(max_degree=4), TiltedDipole(epoch)):
        b = model.field_N(r, epoch, np.array([0.0, 10.0, 20.0]))
        assert b.shape == (2, 3, 3)
        np.testing.assert_allclose(b[0], b[1], rtol=1e-14)  # same points, batch rounding only
        assert model.field_N(r[0, 0], epoch, 0.0).shape == (3,)
    assert "degree 4" in IGRF(max_degree=4).describe()
    assert "tilt 9." in TiltedDipole(epoch).describe()


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"max_degree": 0}, ["max_degree", "[1, 13]", "0"]),
        ({"max_degree": 14}, ["max_degree", "[1, 13]", "14"]),
        ({"max_degree": 2.5}, ["max_degree", "integer", "2.5"]),
        ({"date_resolution": -1.0}, ["date_resolution", "positive", "-1"]),
    ],
)
def test_bad_model_arguments(kwargs, words):
    with pytest.raises(ValueError) as info:
        IGRF(**kwargs)
    assert all(word in str(info.value) for word in words)


def test_bad_field_arguments():
    epoch = _Epoch(datetime(2026, 3, 20, 12, tzinfo=UTC))
    with pytest.raises(ValueError, match=r"r_N must have shape \(\.\.\., 3\), got shape \(2,\)"):
        IGRF().field_N([7e6, 0.0], epoch, 0.0)
    with pytest.raises(ValueError, match=r"r_N must be away from the Earth's centre"):
        TiltedDipole(epoch).field_N([0.0, 0.0, 0.0], epoch, 0.0)
    with pytest.raises(ValueError, match=r"t must broadcast against r_N's leading shape \(2,\), got shape \(3,\)"):
        IGRF().field_N(np.full((2, 3), 7e6), epoch, [0.0, 1.0, 2.0])
    late = _Epoch(datetime(2031, 6, 1, tzinfo=UTC))
    with pytest.raises(
        ValueError, match=r"epoch.utc \+ t must fall inside .* 1900-01-01 to 2030-01-01, got 2031-06-01"
    ):
        IGRF().field_N([7e6, 0.0, 0.0], late, 0.0)
    with pytest.raises(ValueError, match=r"epoch.utc must fall inside"):
        TiltedDipole(late)
    with pytest.raises(ValueError, match=r"epoch.utc must be timezone-aware"):
        TiltedDipole(_Epoch(datetime(2026, 1, 1)))

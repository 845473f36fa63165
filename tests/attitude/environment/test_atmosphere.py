"""Air density: the exponential model of Vallado's Table 8-4 and NRLMSIS through pymsis.

What each test checks against:

* The table: Vallado, *Fundamentals of Astrodynamics and Applications*, 4th ed., 2013, Table 8-4,
  as copied in SatelliteToolboxAtmosphericModels.jl (JuliaSpace, ``src/exponential/constants.jl``,
  citing the same table; the two copies agree row by row). At each base altitude the model returns
  the tabulated density exactly; inside a band the density falls by exactly ``exp(-dh / H)``.
* Vallado Example 8-4 (4th ed., p. 567, as quoted in the Julia package's ``test/exponential.jl``):
  rho(747.2119 km) = 2.1219854e-14 kg/m^3.
* The band edges: each band's exponential carried to the next base altitude lands on that row to
  the rounding of the table's four significant figures, except at 25 km (0.14 %, measured).
* The altitude is above the WGS-84 ellipsoid (NIMA TR8350.2, a = 6378.137 km, e^2 = 0.00669437999014):
  the same density at the same height above the equator and the pole, whatever the sidereal angle.
* NRLMSIS against pymsis's own reference value (pymsis 0.13, ``pymsis/tests/test_msis.py``,
  ``expected_output``, MSIS 2.1): 2010-01-01 12:00 UTC, 0 deg N 0 deg E, 200 km, F10.7 = F10.7a = 150,
  Ap = 3: 2.466441e-10 kg/m^3; and within a factor of 3 of the exponential table at 400 km for mean
  solar activity (the table is a mean-activity fit).
* Bad input: errors name the argument, the rule and the value; no pymsis -> an ImportError saying
  how to install it.

Package A's ``Epoch`` is stood in for by ``_Epoch`` (``utc`` and ``gmst(t)`` through
``sgp4.propagation.gstime``).
"""

from __future__ import annotations

import itertools
import sys
from datetime import UTC, datetime

import numpy as np
import pytest
from sgp4.api import jday
from sgp4.propagation import gstime

from attitude.environment.atmosphere import NRLMSIS, ExponentialAtmosphere, geodetic_coordinates

WGS84_A = 6378137.0
WGS84_B = WGS84_A * np.sqrt(1 - 0.00669437999014)

# Vallado (2013) Table 8-4 as in SatelliteToolboxAtmosphericModels.jl: h0 [km], rho0 [kg/m^3], H [km].
TABLE = [
    (0, 1.225, 7.249), (25, 3.899e-2, 6.349), (30, 1.774e-2, 6.682), (40, 3.972e-3, 7.554),
    (50, 1.057e-3, 8.382), (60, 3.206e-4, 7.714), (70, 8.770e-5, 6.549), (80, 1.905e-5, 5.799),
    (90, 3.396e-6, 5.382), (100, 5.297e-7, 5.877), (110, 9.661e-8, 7.263), (120, 2.438e-8, 9.473),
    (130, 8.484e-9, 12.636), (140, 3.845e-9, 16.149), (150, 2.070e-9, 22.523), (180, 5.464e-10, 29.740),
    (200, 2.789e-10, 37.105), (250, 7.248e-11, 45.546), (300, 2.418e-11, 53.628), (350, 9.518e-12, 53.298),
    (400, 3.725e-12, 58.515), (450, 1.585e-12, 60.828), (500, 6.967e-13, 63.822), (600, 1.454e-13, 71.835),
    (700, 3.614e-14, 88.667), (800, 1.170e-14, 124.64), (900, 5.245e-15, 181.05), (1000, 3.019e-15, 268.00),
]  # fmt: skip


class _Epoch:
    """Stand-in for attitude.environment.epoch.Epoch (package A): ``utc`` and ``gmst(t)``."""

    def __init__(self, utc: datetime) -> None:
        self.utc = utc

    def gmst(self, t):
        u = self.utc
        jd, fr = jday(u.year, u.month, u.day, u.hour, u.minute, u.second + 1e-6 * u.microsecond)
        return np.vectorize(gstime, otypes=[float])(jd + (fr + np.asarray(t, dtype=float) / 86400.0))


EPOCH = _Epoch(datetime(2026, 3, 20, 12, tzinfo=UTC))


def _inertial(r_E, gmst):
    """R3(gmst)^T r_E: Earth-fixed -> N."""
    c, s = np.cos(gmst), np.sin(gmst)
    return np.array([c * r_E[0] - s * r_E[1], s * r_E[0] + c * r_E[1], r_E[2]])


def test_table_altitudes_give_the_table_densities():
    model = ExponentialAtmosphere()
    h0 = np.array([row[0] for row in TABLE]) * 1e3
    rho0 = np.array([row[1] for row in TABLE])
    np.testing.assert_allclose(model.density_at_altitude(h0), rho0, rtol=1e-15)  # exp(0) = 1: exact


def test_vallado_example_8_4():
    # Published to 8 significant figures.
    np.testing.assert_allclose(ExponentialAtmosphere().density_at_altitude(747211.9), 2.1219854e-14, rtol=1e-7)


def test_ratio_inside_a_band_is_the_scale_height():
    model = ExponentialAtmosphere()
    for (h0, _, scale), (h1, _, _) in itertools.pairwise(TABLE):
        dh = 0.5 * (h1 - h0)
        ratio = model.density_at_altitude(1e3 * (h0 + dh)) / model.density_at_altitude(1e3 * h0)
        np.testing.assert_allclose(ratio, np.exp(-dh / scale), rtol=1e-13)  # one exp, rounding only
    # Above 1000 km the last band goes on (module docstring).
    np.testing.assert_allclose(model.density_at_altitude(1.1e6), 3.019e-15 * np.exp(-100 / 268.0), rtol=1e-14)


def test_band_edges_are_continuous_to_the_table_rounding():
    model = ExponentialAtmosphere()
    for (h0, rho0, scale), (h1, rho1, _) in itertools.pairwise(TABLE):
        below = model.density_at_altitude(1e3 * h1 - 1e-6)
        jump = abs(below / rho1 - 1.0)
        if h1 == 25:
            # Measured 0.136 %: the 0-25 km band (sea level 1.225, H = 7.249 km) is not fitted to 25 km.
            assert 1.3e-3 < jump < 1.4e-3
            continue

        # Four significant figures: half a unit of the last digit of rho0, rho1 and H.
        def half_unit(x):
            return 0.5 * 10.0 ** (np.floor(np.log10(x)) - 3)

        bound = half_unit(rho0) / rho0 + half_unit(rho1) / rho1 + (h1 - h0) / scale * half_unit(scale) / scale
        assert jump < bound, (h1, jump, bound)


def test_altitude_is_above_the_wgs84_ellipsoid():
    model = ExponentialAtmosphere()
    h = 425e3  # mid-band: at a base altitude a rounding below it would pick the band underneath
    expected = 3.725e-12 * np.exp(-25.0 / 58.515)
    lon = np.radians(37.0)
    equator_E = np.array([(WGS84_A + h) * np.cos(lon), (WGS84_A + h) * np.sin(lon), 0.0])
    pole_E = np.array([0.0, 0.0, -(WGS84_B + h)])
    for t in (0.0, 5000.0):
        gmst = float(EPOCH.gmst(t))
        rho = model.density(np.stack([_inertial(equator_E, gmst), _inertial(pole_E, gmst)]), EPOCH, t)
        # geoc2geod is good to well under 1 mm: 1e-3 m / 58.5 km scale height = 2e-8 in density.
        np.testing.assert_allclose(rho, expected, rtol=1e-7)
    lat, lon_out, alt = geodetic_coordinates(np.stack([equator_E, pole_E]))
    np.testing.assert_allclose(lat, [0.0, -np.pi / 2], atol=1e-12)
    np.testing.assert_allclose(lon_out[0], lon, atol=1e-15)
    np.testing.assert_allclose(alt, h, atol=1e-3)  # geoc2geod series: sub-millimetre


def test_shapes():
    model = ExponentialAtmosphere()
    r = np.zeros((2, 3, 3))
    r[..., 0] = WGS84_A + np.array([300e3, 400e3, 500e3])
    rho = model.density(r, EPOCH, np.array([0.0, 0.0, 0.0]))
    assert rho.shape == (2, 3)
    assert model.density(r[0, 0], EPOCH, 0.0).shape == ()
    assert "Table 8-4" in model.describe()


def test_nrlmsis_matches_pymsis_reference_value():
    epoch = _Epoch(datetime(2010, 1, 1, 12, tzinfo=UTC))
    gmst = float(epoch.gmst(0.0))
    r_N = _inertial(np.array([WGS84_A + 200e3, 0.0, 0.0]), gmst)  # 0 N, 0 E, 200 km
    rho = NRLMSIS(f107_sfu=150.0, f107_average_sfu=150.0, ap=3.0).density(r_N, epoch, 0.0)
    # pymsis's own tolerance for this value (float32 output); the position round trip is sub-mm.
    np.testing.assert_allclose(rho, 2.466441e-10, rtol=1e-5)


def test_nrlmsis_and_the_table_agree_within_their_spread_at_400_km():
    msis = NRLMSIS()  # F10.7 = 150: mean solar activity
    t = np.linspace(0.0, 86400.0, 24, endpoint=False)
    lon = np.radians(15.0 * np.arange(24))
    r_E = np.stack([(WGS84_A + 400e3) * np.cos(lon), (WGS84_A + 400e3) * np.sin(lon), 0.0 * lon], axis=-1)
    gmst = EPOCH.gmst(t)
    r_N = np.stack([_inertial(r, g) for r, g in zip(r_E, gmst, strict=True)])
    rho = msis.density(r_N, EPOCH, t)
    # The table is a single mean; the day-night bulge spreads MSIS by about 2x around it.
    assert np.all((rho > 3.725e-12 / 3) & (rho < 3 * 3.725e-12)), rho
    assert "NRLMSIS 2.1" in msis.describe()


def test_bad_input():
    model = ExponentialAtmosphere()
    with pytest.raises(ValueError, match=r"r_N must be above the WGS-84 ellipsoid \(altitude >= 0 m\), got"):
        model.density([WGS84_A - 10e3, 0.0, 0.0], EPOCH, 0.0)
    with pytest.raises(ValueError, match=r"altitude must be >= 0 m .* got \[-5\.\]"):
        model.density_at_altitude(-5.0)
    with pytest.raises(ValueError, match=r"r_N must have shape \(\.\.\., 3\)"):
        model.density([7e6, 0.0], EPOCH, 0.0)
    with pytest.raises(ValueError, match=r"f107_sfu .*positive.*-1"):
        NRLMSIS(f107_sfu=-1.0)
    with pytest.raises(ValueError, match=r"ap must be in \[0, 400\] .* got 500"):
        NRLMSIS(ap=500.0)


def test_nrlmsis_without_pymsis_says_how_to_install_it(monkeypatch):
    monkeypatch.setitem(sys.modules, "pymsis", None)  # import pymsis now raises ImportError
    with pytest.raises(ImportError, match=r"pip install attitude-toolkit\[msis\]"):
        NRLMSIS().density([7e6, 0.0, 0.0], EPOCH, 0.0)

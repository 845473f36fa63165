"""Tests of the Earth's shadow at the spacecraft (attitude.environment.sun.illumination_fraction).

Checked against geometry done here, independently of the module:
- cylindrical shadow on a circular orbit: with the Sun at beta above the orbit
  plane, the spacecraft at angle phi from the anti-Sun point is in shadow when
  ``cos(beta) cos(phi) > sqrt(1 - (R_E/r)^2)`` (from ``r.s < 0`` and
  ``|r - (r.s)s| < R_E``), so the shadow arc has half-angle
  ``arccos(sqrt(1 - (R_E/r)^2) / cos(beta))`` (Wertz, *Spacecraft Attitude
  Determination and Control*, 1978, sec. 3.5; Vallado 4th ed. sec. 5.3): entry
  and exit times found by bisection match it;
- conical shadow (Montenbruck and Gill, *Satellite Orbits*, 2000, sec. 3.4.2):
  with beta = 0 the umbra spans the angles below ``b - a`` and full sun starts at
  ``b + a`` (a, b the apparent radii of the Sun and the Earth), so the umbra is
  shorter than the cylindrical shadow and each penumbra lasts ``2a / n``: the
  Sun's angular diameter crossed at the orbital rate;
- the occulted fraction against a direct count of grid points of the solar disk
  hidden by the Earth's disk.
"""

from __future__ import annotations

import numpy as np
import pytest

from attitude.environment.orbit import R_EARTH, CircularOrbit
from attitude.environment.sun import AU_M, SUN_RADIUS_M, illumination_fraction

ORBIT = CircularOrbit.from_altitude(500e3)  # equatorial: u = n t from the x axis
N = ORBIT.mean_motion
BISECTION_TOLERANCE_S = 1e-6


def sun_at_beta(beta: float) -> np.ndarray:
    """Sun 1 AU away at beta above the orbit plane, on the side of u = 0."""
    return AU_M * np.array([np.cos(beta), 0.0, np.sin(beta)])


def edge(predicate, t_inside: float, t_outside: float) -> float:
    """Time where ``predicate`` switches, by bisection to 1 us."""
    while abs(t_outside - t_inside) > BISECTION_TOLERANCE_S:
        mid = 0.5 * (t_inside + t_outside)
        if predicate(mid):
            t_inside = mid
        else:
            t_outside = mid
    return 0.5 * (t_inside + t_outside)


def fraction_at(t: float, sun: np.ndarray, model: str) -> float:
    return float(illumination_fraction(ORBIT.position_N(t), sun, model))


@pytest.mark.parametrize("beta_deg", [0.0, 30.0, 60.0])
def test_cylindrical_entry_and_exit_match_the_beta_angle_geometry(beta_deg):
    beta = np.radians(beta_deg)
    sun = sun_at_beta(beta)
    half = np.arccos(np.sqrt(1 - (R_EARTH / ORBIT.radius_m) ** 2) / np.cos(beta))
    middle = np.pi / N  # anti-Sun point
    in_shadow = lambda t: fraction_at(t, sun, "cylindrical") == 0.0  # noqa: E731
    entry = edge(in_shadow, middle, 0.0)
    exit_ = edge(in_shadow, middle, 2 * middle)
    # Bisection to 1 us; the geometry is exact (the orbit's angle is n t to rounding).
    assert entry == pytest.approx((np.pi - half) / N, abs=2 * BISECTION_TOLERANCE_S)
    assert exit_ == pytest.approx((np.pi + half) / N, abs=2 * BISECTION_TOLERANCE_S)


def test_no_eclipse_above_the_critical_beta_angle():
    beta_critical = np.arccos(np.sqrt(1 - (R_EARTH / ORBIT.radius_m) ** 2))  # 68.0 deg at 500 km
    t = np.linspace(0.0, ORBIT.period, 2001)
    r = ORBIT.position_N(t)
    for model in ("cylindrical", "conical"):
        assert np.all(illumination_fraction(r, sun_at_beta(beta_critical + np.radians(1.0)), model) == 1.0)
        assert np.any(illumination_fraction(r, sun_at_beta(beta_critical - np.radians(1.0)), model) < 1.0)


def test_conical_umbra_and_penumbra_at_zero_beta():
    sun = sun_at_beta(0.0)
    middle = np.pi / N
    a = np.arcsin(SUN_RADIUS_M / AU_M)  # 0.2665 deg
    b = np.arcsin(R_EARTH / ORBIT.radius_m)
    umbra_exit = edge(lambda t: fraction_at(t, sun, "conical") == 0.0, middle, 2 * middle)
    sun_full = edge(lambda t: fraction_at(t, sun, "conical") < 1.0, middle, 2 * middle)
    cylinder_exit = edge(lambda t: fraction_at(t, sun, "cylindrical") == 0.0, middle, 2 * middle)
    # Edges at angles b - a and b + a from the anti-Sun point, seen from the
    # spacecraft: the Sun's direction from it differs from the geocentric one by
    # the parallax r sin(phi) / AU = R_E / AU (4.3e-5 rad, 0.04 s) at the edge
    # (sin(phi) = sin(b) = R_E / r), which delays both edges. Left out: second
    # order in r / AU and a's change with distance (5e-5 of a = 2e-7 rad, 2e-4 s);
    # tolerance 1e-3 s.
    parallax = R_EARTH / AU_M
    assert umbra_exit - middle == pytest.approx((b - a + parallax) / N, abs=1e-3)
    assert sun_full - middle == pytest.approx((b + a + parallax) / N, abs=1e-3)
    assert umbra_exit < cylinder_exit < sun_full
    # Each penumbra lasts the Sun's angular diameter crossed at the orbital rate (8.4 s here).
    assert sun_full - umbra_exit == pytest.approx(2 * a / N, abs=1e-3)
    # Through the penumbra the fraction rises monotonically from 0 to 1.
    t = np.linspace(umbra_exit, sun_full, 200)
    f = illumination_fraction(ORBIT.position_N(t), sun, "conical")
    assert np.all(np.diff(f) >= 0.0) and f[0] < 1e-3 and f[-1] > 1 - 1e-3


def test_penumbra_fraction_matches_a_count_of_the_hidden_solar_disk():
    sun = sun_at_beta(0.0)
    a = np.arcsin(SUN_RADIUS_M / AU_M)
    b = np.arcsin(R_EARTH / ORBIT.radius_m)
    k = np.arange(-300, 301) / 300.0
    x, y = np.meshgrid(k, k)
    for offset in (-0.6, 0.0, 0.5):  # Earth's limb across the solar disk, in units of a
        phi = b + offset * a  # angle of the spacecraft from the anti-Sun point
        r = ORBIT.radius_m * np.array([-np.cos(phi), np.sin(phi), 0.0])
        to_sun = (sun - r) / np.linalg.norm(sun - r)
        e1 = np.cross(to_sun, [0.0, 0.0, 1.0])
        e2 = np.cross(to_sun, e1)
        rays = to_sun + np.tan(a) * (x[..., None] * e1 + y[..., None] * e2)
        rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
        in_disk = np.arccos(np.clip(rays @ to_sun, -1, 1)) < a
        hidden = np.arccos(np.clip(rays @ (-r / np.linalg.norm(r)), -1, 1)) < b
        counted = 1.0 - np.sum(in_disk & hidden) / np.sum(in_disk)
        # 601 x 601 grid over the disk: the boundary cells (about 4 / 600 of the
        # area) set the count's error; tolerance 0.005.
        assert float(illumination_fraction(r, sun)) == pytest.approx(counted, abs=0.005)


def test_bad_arguments_are_refused():
    with pytest.raises(ValueError, match="model must be one of"):
        illumination_fraction([7e6, 0, 0], sun_at_beta(0.0), model="cone")
    with pytest.raises(ValueError, match="r_N must be outside the Earth"):
        illumination_fraction([6e6, 0, 0], sun_at_beta(0.0))
    with pytest.raises(ValueError, match=r"sun_N must have shape \(..., 3\)"):
        illumination_fraction([7e6, 0, 0], [1.0, 2.0])

"""Disturbance torques on flat plates: solar radiation pressure, free-molecular drag, magnetic dipole.

What each group checks against (derivations in docs/environment_torques.md):

* Solar radiation pressure on one plate at a known incidence, against hand computations of the
  per-plate force ``F = -P A cos(th) [(1 - specular) s + 2 (specular cos(th) + diffuse / 3) n]``
  (Montenbruck and Gill, *Satellite Orbits*, 2000, sec. 3.4.1, absorbed and specular parts; Wertz,
  *Spacecraft Attitude Determination and Control*, 1978, sec. 17.2, with the diffuse part; the
  formula of Basilisk's ``facetSRPDynamicEffector.cpp``), one surface type at a time, and
  independently from the momentum balance of the photons (incoming minus outgoing momentum flux;
  the Lambertian 2/3 by quadrature over the hemisphere).
* Drag on one plate at a known angle of attack, against the hand computation of
  ``F = -1/2 rho Cd A |v|^2 cos(alpha) v_hat`` (Vallado, *Fundamentals of Astrodynamics and
  Applications*, 4th ed., sec. 8.6.2; Wertz 1978 sec. 17.2; Basilisk ``facetDragDynamicEffector.cpp``)
  and, for ``Cd = 2``, against the free-molecular momentum flux (every molecule hitting the plate
  loses its velocity: Wertz 1978 sec. 17.2, complete accommodation).
* Signs and frames: a plate with its centre of pressure on the centre of mass gives a force but
  zero torque; a cuboid symmetric about the centre of mass gives zero torque for any direction;
  offsetting every centre of pressure by ``d`` gives exactly ``d x F_total``; a centre of pressure
  behind the centre of mass weathervanes into the flow; plates facing away get no force.
* Backends: the casadi SX evaluation of the same component functions equals the numpy one.
* Magnetic torque ``m x B`` against a hand cross product.
* Bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import quad

from attitude.environment.surface import SurfaceModel
from attitude.environment.torques import (
    SOLAR_PRESSURE_1AU_PA,
    aerodynamic_force,
    aerodynamic_force_components,
    aerodynamic_torque,
    aerodynamic_torque_components,
    magnetic_torque,
    magnetic_torque_components,
    solar_pressure_force,
    solar_pressure_force_components,
    solar_pressure_torque,
    solar_pressure_torque_components,
)

# Hand computations below are a handful of products of exact-ish decimals: they agree with the code to a
# few ulp of the result. 1e-14 relative leaves room for the different order of the same operations.
RTOL = 1e-14

P = 4.56e-6  # [Pa] about the solar pressure at 1 AU
AREA = 2.0  # [m^2]
ARM = np.array([0.5, 0.0, 0.0])  # [m] centre of pressure of the test plate, off the centre of mass along x
TH = np.radians(60.0)  # incidence: cos = 1/2, sin = sqrt(3)/2
SUN = np.array([np.sin(TH), 0.0, np.cos(TH)])  # unit vector to the Sun in the x-z plane, 60 deg from +z


def plate(specular=0.0, diffuse=0.0, arm=ARM, normal=(0.0, 0.0, 1.0), area=AREA, cd=2.2):
    return SurfaceModel([area], [normal], [arm], specular=specular, diffuse=diffuse, drag_coefficient=cd)


# ---------------------------------------------------------------------------
# Solar radiation pressure on one plate (hand computations, cos(th) = 1/2, sin(th) = sqrt(3)/2)
# ---------------------------------------------------------------------------


def test_srp_solar_constant():
    # Kopp and Lean 2011: 1361 W/m^2; over c = 299,792,458 m/s: 4.5398e-6 Pa (5 digits by hand).
    assert SOLAR_PRESSURE_1AU_PA == pytest.approx(4.5398e-6, rel=1e-4)  # 5 significant digits quoted


def test_srp_absorbing_plate_by_hand():
    # Absorber (M&G 2000 sec. 3.4.1): F = -P A cos(th) s: the projected area A cos = 1 m^2 absorbs the
    # momentum flux P along s. F = -P [sqrt(3)/2, 0, 1/2]; tau = r x F = [0, -0.5 F_z, 0] = [0, P/4, 0].
    f = solar_pressure_force(plate(), SUN, P)
    t = solar_pressure_torque(plate(), SUN, P)
    np.testing.assert_allclose(f, [-P * np.sqrt(3.0) / 2.0, 0.0, -P / 2.0], rtol=RTOL, atol=0)
    np.testing.assert_allclose(t, [0.0, P / 4.0, 0.0], rtol=RTOL, atol=1e-30)


def test_srp_specular_plate_by_hand():
    # Mirror (M&G 2000 sec. 3.4.1): F = -2 P A cos^2(th) n = -2 P 2 (1/4) n = -P n; tau = [0, 0.5 P, 0].
    f = solar_pressure_force(plate(specular=1.0), SUN, P)
    t = solar_pressure_torque(plate(specular=1.0), SUN, P)
    np.testing.assert_allclose(f, [0.0, 0.0, -P], rtol=RTOL, atol=1e-30)
    np.testing.assert_allclose(t, [0.0, P / 2.0, 0.0], rtol=RTOL, atol=1e-30)


def test_srp_diffuse_plate_by_hand():
    # Lambertian (Wertz 1978 sec. 17.2): F = -P A cos(th) [s + 2/3 n] = -P [sqrt(3)/2, 0, 1/2 + 2/3];
    # tau = [0, 0.5 P (1/2 + 2/3), 0] = [0, 7 P / 12, 0].
    f = solar_pressure_force(plate(diffuse=1.0), SUN, P)
    t = solar_pressure_torque(plate(diffuse=1.0), SUN, P)
    np.testing.assert_allclose(f, [-P * np.sqrt(3.0) / 2.0, 0.0, -P * 7.0 / 6.0], rtol=RTOL, atol=0)
    np.testing.assert_allclose(t, [0.0, 7.0 * P / 12.0, 0.0], rtol=RTOL, atol=1e-30)


def test_srp_mixed_plate_is_the_weighted_sum():
    # The force is linear in (absorbed, specular, diffuse): a 0.2 / 0.5 / 0.3 plate is the weighted sum of
    # the three pure cases above (hand values), so the mix is checked without re-deriving the formula.
    absorbing = np.array([-P * np.sqrt(3.0) / 2.0, 0.0, -P / 2.0])
    mirror = np.array([0.0, 0.0, -P])
    lambert = np.array([-P * np.sqrt(3.0) / 2.0, 0.0, -P * 7.0 / 6.0])
    expected = 0.2 * absorbing + 0.5 * mirror + 0.3 * lambert
    np.testing.assert_allclose(solar_pressure_force(plate(0.5, 0.3), SUN, P), expected, rtol=RTOL, atol=1e-30)


def _reflect(d, n):
    return d - 2.0 * np.dot(d, n) * n


def test_srp_momentum_balance_of_the_photons():
    # Independent of the formula: the plate intercepts the momentum flux P A cos(th) travelling along -s.
    # Force = (momentum in) - (momentum out). Absorbed: nothing out. Specular: out along the mirror image
    # of -s. Lambertian: out along n with mean cosine int cos^2 dOmega / int cos dOmega (quadrature: 2/3).
    n = np.array([0.0, 0.0, 1.0])
    flux = P * AREA * np.cos(TH)
    photons_in = -SUN
    mean_cos, _ = quad(lambda u: u * u * 2.0 * np.pi, 0.0, 1.0)  # int cos^2 dOmega over the hemisphere
    norm, _ = quad(lambda u: u * 2.0 * np.pi, 0.0, 1.0)  # int cos dOmega
    lambert_out = (mean_cos / norm) * n
    cases = {
        (0.0, 0.0): flux * photons_in,
        (1.0, 0.0): flux * (photons_in - _reflect(photons_in, n)),
        (0.0, 1.0): flux * (photons_in - lambert_out),
    }
    for (spec, diff), expected in cases.items():
        # quad's 1e-14-level error on 2/3 is the only difference: 1e-12 relative covers it.
        np.testing.assert_allclose(solar_pressure_force(plate(spec, diff), SUN, P), expected, rtol=1e-12, atol=1e-24)


def test_srp_matches_basilisk_facet_srp_formula():
    # Peer: Basilisk facetSRPDynamicEffector.cpp, for a facet with projected area A cos > 0:
    #   F = -P A cos * ((1 - specular) sHat + 2 (diffuse / 3 + specular cos) nHat),  tau = r_CopB x F
    # written out here for a tilted plate, arbitrary arm and mixed optics (same arithmetic, other code).
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    r = np.array([0.3, -0.7, 1.1])
    s = np.array([2.0, 1.0, 2.0]) / 3.0  # cos = (2 + 2 + 4) / 9 = 8/9
    spec, diff = 0.35, 0.4
    cos = 8.0 / 9.0
    f = -P * AREA * cos * ((1.0 - spec) * s + 2.0 * (diff / 3.0 + spec * cos) * n)
    surf = plate(spec, diff, arm=r, normal=n)
    np.testing.assert_allclose(solar_pressure_force(surf, s, P), f, rtol=RTOL)
    np.testing.assert_allclose(solar_pressure_torque(surf, s, P), np.cross(r, f), rtol=1e-13)  # cancellation


# ---------------------------------------------------------------------------
# Drag on one plate at a known angle of attack
# ---------------------------------------------------------------------------

RHO = 3.0e-12  # [kg/m^3] order of the density at 450 km
SPEED = 7600.0  # [m/s]
ALPHA = np.radians(30.0)  # angle between the flow and the plate normal: cos = sqrt(3)/2, sin = 1/2


def test_drag_plate_at_angle_of_attack_by_hand():
    # Plate normal +x, area 1.5 m^2, Cd 2.2, centre of pressure [0, 0, 0.4] m; the spacecraft moves along
    # v = V [cos a, sin a, 0]. Vallado 4th ed. sec. 8.6.2 / Basilisk facetDrag:
    # |F| = 1/2 rho Cd A V^2 cos(a), along -v_hat. tau = r x F = [-0.4 F_y, 0.4 F_x, 0].
    surf = plate(normal=(1.0, 0.0, 0.0), arm=(0.0, 0.0, 0.4), area=1.5, cd=2.2)
    v = SPEED * np.array([np.cos(ALPHA), np.sin(ALPHA), 0.0])
    magnitude = 0.5 * RHO * 2.2 * 1.5 * SPEED**2 * np.sqrt(3.0) / 2.0
    f_expected = -magnitude * np.array([np.sqrt(3.0) / 2.0, 0.5, 0.0])
    np.testing.assert_allclose(aerodynamic_force(surf, v, RHO), f_expected, rtol=RTOL)
    np.testing.assert_allclose(
        aerodynamic_torque(surf, v, RHO), [-0.4 * f_expected[1], 0.4 * f_expected[0], 0.0], rtol=RTOL, atol=1e-30
    )


def test_drag_cd2_is_the_free_molecular_momentum_flux():
    # Wertz 1978 sec. 17.2 (complete accommodation, negligible re-emission speed): the mass flux through the
    # projected area, rho |v| A cos(a), loses all of its velocity v: F = -rho |v| A cos(a) v, i.e. Cd = 2.
    surf = plate(normal=(0.0, 1.0, 0.0), arm=(0.0, 0.0, 0.0), area=0.8, cd=2.0)
    v = SPEED * np.array([0.0, np.cos(ALPHA), np.sin(ALPHA)])
    mass_flux = RHO * SPEED * 0.8 * np.cos(ALPHA)
    np.testing.assert_allclose(aerodynamic_force(surf, v, RHO), -mass_flux * v, rtol=RTOL)


def test_drag_weathervanes_a_centre_of_pressure_behind_the_centre_of_mass():
    # A box flying along +x with its centre of pressure 0.2 m behind the centre of mass (offset -x): with the
    # flow 10 deg off the nose, turned about +z, the torque turns the nose (+x) into the velocity: tau_z > 0.
    # This checks the sign conventions (v = spacecraft velocity relative to the air, torque = r x F).
    box = SurfaceModel.box([1.0, 1.0, 1.0], centre_of_pressure_offset_B_m=[-0.2, 0.0, 0.0])
    beta = np.radians(10.0)
    v = SPEED * np.array([np.cos(beta), np.sin(beta), 0.0])
    tau = aerodynamic_torque(box, v, RHO)
    assert tau[2] > 0.0
    # and the other way round for the mirror-image flow
    assert aerodynamic_torque(box, v * [1.0, -1.0, 1.0], RHO)[2] < 0.0


# ---------------------------------------------------------------------------
# Signs and frames: centre of pressure on the centre of mass, symmetric box, offsets, facing away
# ---------------------------------------------------------------------------


def random_directions(count, seed=11):
    d = np.random.default_rng(seed).normal(size=(count, 3))
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_centre_of_pressure_on_centre_of_mass_gives_force_but_no_torque():
    surf = plate(specular=0.3, diffuse=0.4, arm=(0.0, 0.0, 0.0))
    assert np.linalg.norm(solar_pressure_force(surf, SUN, P)) > 0.5 * P  # the plate is loaded...
    np.testing.assert_array_equal(solar_pressure_torque(surf, SUN, P), [0.0, 0.0, 0.0])  # ...with no arm
    v = SPEED * np.array([0.1, 0.2, 0.97])
    assert np.linalg.norm(aerodynamic_force(surf, v, RHO)) > 0.0
    np.testing.assert_array_equal(aerodynamic_torque(surf, v, RHO), [0.0, 0.0, 0.0])


def test_symmetric_box_gives_zero_torque_in_any_direction():
    # Exact zero, by hand: face i has r_i = (L_i / 2) n_i, so its normal force has no moment, and its force
    # along the light/flow has the arm A_i c_i r_i = (A_i L_i / 2) c_i n_i = (V / 2) (n_i . s) n_i (V the
    # box volume, the same for every face). Exactly one face per axis is lit, so sum_i (n_i . s) n_i = s,
    # parallel to s: (V / 2) s x s = 0 (same optics and Cd on every face assumed).
    # Rounding: each face moment is ~|F| L; the sum cancels to ~1e-16 |F| L per term: 1e-14 |F| L bounds it.
    box = SurfaceModel.box([1.0, 2.0, 3.0], specular=0.3, diffuse=0.25)
    dirs = random_directions(200)
    length = 3.0
    t_srp = solar_pressure_torque(box, dirs, P)
    f_srp = np.linalg.norm(solar_pressure_force(box, dirs, P), axis=-1, keepdims=True)
    assert np.all(np.abs(t_srp) <= 1e-14 * f_srp * length)
    t_aero = aerodynamic_torque(box, SPEED * dirs, RHO)
    f_aero = np.linalg.norm(aerodynamic_force(box, SPEED * dirs, RHO), axis=-1, keepdims=True)
    assert np.all(np.abs(t_aero) <= 1e-14 * f_aero * length)


def test_offset_box_torque_is_offset_cross_total_force():
    # Shifting every centre of pressure by d adds d x F_total: sum (r_i + d) x F_i = 0 + d x sum F_i.
    d = np.array([0.03, -0.05, 0.12])
    box = SurfaceModel.box([1.0, 2.0, 3.0], specular=0.3, diffuse=0.25, centre_of_pressure_offset_B_m=d)
    dirs = random_directions(50, seed=3)
    f = solar_pressure_force(box, dirs, P)
    scale = np.linalg.norm(f, axis=-1, keepdims=True) * 3.0  # cancellation of ~|F| L moments, as above
    assert np.all(np.abs(solar_pressure_torque(box, dirs, P) - np.cross(d, f)) <= 1e-14 * scale)
    f = aerodynamic_force(box, SPEED * dirs, RHO)
    scale = np.linalg.norm(f, axis=-1, keepdims=True) * 3.0
    assert np.all(np.abs(aerodynamic_torque(box, SPEED * dirs, RHO) - np.cross(d, f)) <= 1e-14 * scale)


@pytest.mark.parametrize("direction", [[0.0, 0.0, -1.0], [0.6, 0.0, -0.8], [1.0, 0.0, 0.0]])
def test_plate_facing_away_or_edge_on_gets_no_force(direction):
    # n = +z; a Sun or a flow from behind (n . s < 0) or edge-on (n . s = 0): max(0, cos) = 0 exactly.
    surf = plate(specular=0.5, diffuse=0.5)
    d = np.array(direction)
    np.testing.assert_array_equal(solar_pressure_force(surf, d, P), [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(solar_pressure_torque(surf, d, P), [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(aerodynamic_force(surf, SPEED * d, RHO), [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(aerodynamic_torque(surf, SPEED * d, RHO), [0.0, 0.0, 0.0])


def test_eclipse_and_vacuum_give_zero():
    box = SurfaceModel.box([1.0, 1.0, 1.0], centre_of_pressure_offset_B_m=[0.1, 0.0, 0.0])
    np.testing.assert_array_equal(solar_pressure_torque(box, SUN, 0.0), [0.0, 0.0, 0.0])  # umbra
    np.testing.assert_array_equal(aerodynamic_torque(box, SPEED * SUN, 0.0), [0.0, 0.0, 0.0])


def test_batches_broadcast():
    box = SurfaceModel.box([1.0, 2.0, 3.0], centre_of_pressure_offset_B_m=[0.1, 0.0, 0.0])
    dirs = random_directions(12).reshape(3, 4, 3)
    pressure = np.linspace(0.0, P, 4)  # a batch of pressures along the last batch axis
    t = solar_pressure_torque(box, dirs, pressure)
    assert t.shape == (3, 4, 3)
    np.testing.assert_allclose(t[1, 2], solar_pressure_torque(box, dirs[1, 2], pressure[2]), rtol=1e-15)
    assert aerodynamic_torque(box, SPEED * dirs, RHO).shape == (3, 4, 3)


# ---------------------------------------------------------------------------
# numpy vs casadi
# ---------------------------------------------------------------------------


def test_numpy_and_casadi_evaluations_agree():
    # Same component functions on SX symbols, compiled into a casadi Function; casadi may reorder the sums,
    # so agreement is to rounding: 1e-13 of the largest per-plate term (|F| L) rather than bit-exact.
    surf = SurfaceModel.box(
        [0.3, 0.4, 0.5], specular=0.2, diffuse=0.3, centre_of_pressure_offset_B_m=[0.02, -0.01, 0.03]
    ).with_panels(1.2, [0.0, 0.0, 1.0], [0.0, 0.9, 0.0], specular=0.05, diffuse=0.1)
    x = ca.SX.sym("x", 3)
    scalar = ca.SX.sym("p")
    xs = [x[i] for i in range(3)]
    f = ca.Function(
        "env",
        [x, scalar],
        [
            ca.vertcat(*aerodynamic_torque_components(surf, xs, scalar)),
            ca.vertcat(*aerodynamic_force_components(surf, xs, scalar)),
            ca.vertcat(*solar_pressure_torque_components(surf, xs, scalar)),
            ca.vertcat(*solar_pressure_force_components(surf, xs, scalar)),
            ca.vertcat(*magnetic_torque_components(xs, [scalar, 2.0 * scalar, -scalar])),
        ],
    )
    for d in random_directions(40, seed=5):
        tau_a, f_a, tau_s, f_s, tau_m = (np.array(o.full()).ravel() for o in f(SPEED * d, RHO))
        scale = np.linalg.norm(aerodynamic_force(surf, SPEED * d, RHO)) * 1.0
        np.testing.assert_allclose(tau_a, aerodynamic_torque(surf, SPEED * d, RHO), rtol=0, atol=1e-13 * scale)
        np.testing.assert_allclose(f_a, aerodynamic_force(surf, SPEED * d, RHO), rtol=0, atol=1e-13 * scale)
        tau_a_check = [float(c) for c in aerodynamic_torque_components(surf, list(SPEED * d), RHO)]
        np.testing.assert_allclose(tau_a, tau_a_check, rtol=0, atol=1e-13 * scale)
        tau_s, f_s = (np.array(o.full()).ravel() for o in f(d, P)[2:4])
        scale = np.linalg.norm(solar_pressure_force(surf, d, P)) * 1.0
        np.testing.assert_allclose(tau_s, solar_pressure_torque(surf, d, P), rtol=0, atol=1e-13 * scale)
        np.testing.assert_allclose(f_s, solar_pressure_force(surf, d, P), rtol=0, atol=1e-13 * scale)
        np.testing.assert_allclose(tau_m, np.cross(SPEED * d, [RHO, 2 * RHO, -RHO]), rtol=1e-14, atol=0)


# ---------------------------------------------------------------------------
# Magnetic dipole
# ---------------------------------------------------------------------------


def test_magnetic_torque_by_hand():
    # m = [0, 0, 0.1] A m^2, B = [2e-5, 0, 3e-5] T: m x B = [0*3e-5 - 0.1*0, 0.1*2e-5 - 0*3e-5, 0 - 0] = [0, 2e-6, 0].
    np.testing.assert_allclose(magnetic_torque([0.0, 0.0, 0.1], [2e-5, 0.0, 3e-5]), [0.0, 2e-6, 0.0], rtol=RTOL)
    fields = np.array([[2e-5, 0.0, 3e-5], [0.0, -1e-5, 0.0]])
    # m x B for B = [0, -1e-5, 0]: [0*0 - 0.1*(-1e-5), 0, 0] = [1e-6, 0, 0]
    np.testing.assert_allclose(magnetic_torque([0.0, 0.0, 0.1], fields), [[0, 2e-6, 0], [1e-6, 0, 0]], rtol=RTOL)
    surf = SurfaceModel.box([1.0, 1.0, 1.0], residual_dipole_Am2=[0.0, 0.0, 0.1])
    comps = magnetic_torque_components(list(surf.residual_dipole_Am2), [fields[:, k] for k in range(3)])
    np.testing.assert_allclose(np.stack(comps, axis=-1), [[0, 2e-6, 0], [1e-6, 0, 0]], rtol=RTOL)


# ---------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda s: aerodynamic_torque(s, [7600.0, 0.0, 0.0], -1e-12), ["density_kg_m3", "non-negative", "-1e-12"]),
        (lambda s: aerodynamic_force(s, [7600.0, 0.0], 1e-12), ["v_rel_B", "(..., 3)"]),
        (lambda s: solar_pressure_torque(s, [0.0, 0.0, 0.0], P), ["sun_B", "non-zero"]),
        (lambda s: solar_pressure_force(s, SUN, -P), ["pressure_Pa", "non-negative"]),
        (lambda s: solar_pressure_torque("plates", SUN, P), ["surface", "SurfaceModel", "str"]),
        (lambda s: aerodynamic_torque_components(s, [1.0, 2.0], 1e-12), ["v_rel_B", "3 components", "2"]),
        (lambda s: magnetic_torque([0.0, 0.0, np.inf], [1e-5, 0.0, 0.0]), ["dipole_B", "finite"]),
        (lambda s: magnetic_torque_components([0.0, 0.0, 1.0], [1e-5, 0.0]), ["field_B", "3 components"]),
    ],
)
def test_bad_input_names_argument_rule_and_value(call, words):
    with pytest.raises(ValueError) as info:
        call(plate())
    for word in words:
        assert word in str(info.value), (word, str(info.value))

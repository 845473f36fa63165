"""Cross-checks of :mod:`attitude.quaternion` against ``scipy.spatial.transform``.

Convention under test (DESIGN.md): ``q = [w, x, y, z]`` scalar first, Hamilton
product; ``q_BN`` rotates body vectors into N, ``v_N = q ⊗ v_B ⊗ q*``, which is
``Rotation.from_quat(q, scalar_first=True).apply(v_B)``; ``C_BN = as_matrix().T``.

Every check runs twice: vectorised on a batch of ``N`` random rotations drawn
with a fixed seed, and as a hypothesis property on single quaternions built
from arbitrary 4-vectors (normalised, norm kept away from zero). ``q`` and
``-q`` are the same attitude, so quaternions coming from two libraries are
compared up to sign unless a sign convention is part of the contract.

Tolerances: the quantities compared are O(1) (unit quaternions, DCM entries,
angles <= a few pi); float64 rounding over a few dozen operations is ~1e-15,
so ``TOL = 1e-12`` leaves a factor ~1000 of headroom while any convention
error (a sign, a transpose, a product order) shows up as an O(1) difference.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import stats
from scipy.spatial.transform import Rotation, Slerp

from attitude import quaternion as Q

SEED = 20240531
N = 5000
EPS = np.finfo(np.float64).eps

# Rounding of O(1) values over a few dozen flops is ~1e-15; see the module docstring.
TOL = 1e-12

_rng = np.random.default_rng(SEED)
P = Q.random(N, rng=SEED)
P2 = Q.random(N, rng=SEED + 1)
V = _rng.normal(size=(N, 3))  # body vectors, |v| of order 1
SCALES = 10.0 ** _rng.uniform(-3.0, 3.0, N)  # magnitudes for non-unit quaternions
# Rotations within 1e-3 rad of 180 degrees (|w| < 5e-4): where a naive trace-based
# DCM -> quaternion conversion loses precision and the sign of w is nearly ambiguous.
_near_pi_axes = _rng.normal(size=(200, 3))
NEAR_PI = Q.from_axis_angle(_near_pi_axes, np.pi - _rng.uniform(0.0, 1e-3, 200))


# ------------------------------------------------------------------- helpers


def rot(q) -> Rotation:
    """scipy Rotation of scalar-first quaternion(s), flattened to a 1-D batch."""
    return Rotation.from_quat(np.reshape(q, (-1, 4)), scalar_first=True)


def squat(r: Rotation) -> np.ndarray:
    """Scalar-first quaternions of a scipy Rotation (as a 1-D batch), with scipy's own sign."""
    return np.reshape(r.as_quat(scalar_first=True, canonical=False), (-1, 4))


def pure(v) -> np.ndarray:
    """Pure quaternion ``[0, v]``."""
    v = np.asarray(v, dtype=float)
    return np.concatenate([np.zeros((*v.shape[:-1], 1)), v], axis=-1)


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def assert_same_attitude(a, b, atol: float = TOL) -> None:
    """``a`` equals ``b`` or ``-b`` (same rotation), row by row."""
    a = np.reshape(a, (-1, 4))
    b = np.reshape(b, (-1, 4))
    d = np.minimum(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
    worst = int(np.argmax(d))
    assert d[worst] <= atol, f"row {worst}: {a[worst]} vs {b[worst]} differ by {d[worst]:.3g} > {atol:g} (up to sign)"


def assert_close(a, b, atol: float = TOL) -> None:
    np.testing.assert_allclose(a, b, rtol=0.0, atol=atol)


# ---------------------------------------------------------------- strategies

_component = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
# Norm > 1e-3 keeps normalisation well conditioned (relative error ~eps) while
# hypothesis still tries zeros, signed zeros, subnormals and +-1 in components.
nonzero_quats = arrays(np.float64, 4, elements=_component).filter(lambda a: np.linalg.norm(a) > 1e-3)
unit_quats = nonzero_quats.map(lambda a: a / np.linalg.norm(a))
# General non-zero quaternions, |q| from ~1e-6 to ~2e3.
general_quats = st.tuples(nonzero_quats, st.floats(1e-3, 1e3)).map(lambda t: t[0] * t[1])
vectors = arrays(np.float64, 3, elements=st.floats(-100.0, 100.0, allow_nan=False, allow_infinity=False))
# Rotation vectors up to |phi| ~ 17 rad: several turns, beyond the principal range.
rotvecs = arrays(np.float64, 3, elements=st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False))
axes = arrays(np.float64, 3, elements=_component).filter(lambda a: np.linalg.norm(a) > 1e-3)
angles = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)
fractions = st.floats(0.0, 1.0, allow_nan=False)


# ------------------------------------------------------------- multiply


def test_multiply_matches_scipy_composition_batch():
    got = Q.multiply(P, P2)
    # scipy's r1 * r2 applies r2 first, then r1: the same as p ⊗ q for q_CN = q_BN ⊗ q_CB.
    assert_same_attitude(got, squat(rot(P) * rot(P2)))
    # Composition meaning, independently of scipy: rotate by q, then by p.
    assert_close(Q.rotate(got, V), Q.rotate(P, Q.rotate(P2, V)))
    # The product is not commutative: the test above would notice a swapped order.
    assert np.max(np.linalg.norm(got - Q.multiply(P2, P), axis=-1)) > 0.1


def test_multiply_is_bilinear_for_non_unit_quaternions_batch():
    a = SCALES[:, None] * P
    b = SCALES[::-1, None] * P2
    got = Q.multiply(a, b)
    want = (SCALES * SCALES[::-1])[:, None] * Q.multiply(P, P2)
    # Each output entry is a sum of 4 products: relative rounding ~4 eps of the scale.
    np.testing.assert_allclose(got, want, rtol=0.0, atol=0.0 + TOL * np.max(SCALES * SCALES[::-1]))
    np.testing.assert_allclose(Q.norm(got), Q.norm(a) * Q.norm(b), rtol=TOL)


@given(unit_quats, unit_quats, st.floats(1e-3, 1e3), st.floats(1e-3, 1e3))
def test_multiply_matches_scipy_composition_property(p, q, a, b):
    got = Q.multiply(p, q)
    assert_same_attitude(got, squat(rot(p) * rot(q)))
    # Non-unit operands: |p ⊗ q| = |p||q| and the product scales bilinearly (relative rounding ~eps).
    np.testing.assert_allclose(Q.multiply(a * p, b * q), a * b * got, rtol=0.0, atol=TOL * a * b)


# ---------------------------------------------------- conjugate / inverse


def test_conjugate_and_inverse_batch():
    assert_same_attitude(Q.conjugate(P), squat(rot(P).inv()))
    assert_close(Q.multiply(P, Q.conjugate(P)), Q.identity((N,)))
    g = SCALES[:, None] * P
    inv = Q.inverse(g)
    # q ⊗ q^-1 = q^-1 ⊗ q = 1 with relative rounding ~eps for any |q|.
    assert_close(Q.multiply(g, inv), Q.identity((N,)))
    assert_close(Q.multiply(inv, g), Q.identity((N,)))
    # For a unit quaternion the inverse is the conjugate.
    assert_close(Q.inverse(P), Q.conjugate(P))


@given(general_quats)
def test_conjugate_and_inverse_property(q):
    u = q / np.linalg.norm(q)
    assert_same_attitude(Q.conjugate(u), squat(rot(u).inv()))
    assert_close(Q.multiply(q, Q.inverse(q)), [1.0, 0.0, 0.0, 0.0])
    assert_close(Q.multiply(Q.inverse(q), q), [1.0, 0.0, 0.0, 0.0])


# ---------------------------------------------------- rotate / rotate_inverse


def test_rotate_matches_scipy_apply_batch():
    r = rot(P)
    assert_close(Q.rotate(P, V), r.apply(V))
    assert_close(Q.rotate_inverse(P, V), r.inv().apply(V))
    assert_close(Q.rotate_inverse(P, Q.rotate(P, V)), V)
    # Same as the quaternion sandwich q ⊗ [0, v] ⊗ q*, written out with multiply.
    assert_close(pure(Q.rotate(P, V)), Q.multiply(Q.multiply(P, pure(V)), Q.conjugate(P)))


@given(unit_quats, vectors)
def test_rotate_matches_scipy_apply_property(q, v):
    # Errors scale with |v| (up to ~173 here).
    atol = TOL * (1.0 + np.linalg.norm(v))
    r = rot(q)
    assert_close(Q.rotate(q, v), r.apply(v)[0], atol)
    assert_close(Q.rotate_inverse(q, v), r.inv().apply(v)[0], atol)
    # q and -q are the same attitude, so they rotate identically.
    assert_close(Q.rotate(-q, v), Q.rotate(q, v), atol)


# ---------------------------------------------------------------- DCM


def test_dcm_matches_scipy_batch():
    q = np.concatenate([P, NEAR_PI])
    c = Q.to_dcm(q)
    assert c.shape == (len(q), 3, 3)
    assert_close(c, np.swapaxes(rot(q).as_matrix(), -1, -2))
    # C_BN maps inertial components to body components.
    assert_close(np.einsum("nij,nj->ni", c[:N], V), Q.rotate_inverse(P, V))
    back = Q.from_dcm(c)
    assert np.all(back[:, 0] >= 0.0)
    assert_same_attitude(back, q)
    assert_same_attitude(back, squat(Rotation.from_matrix(np.swapaxes(c, -1, -2))))
    # from_dcm returns the shortest() representative, so the round trip is exact up to rounding.
    assert_close(back[:N], Q.shortest(P))


@given(unit_quats)
def test_dcm_matches_scipy_property(q):
    c = Q.to_dcm(q)
    assert_close(c, rot(q).as_matrix()[0].T)
    assert_same_attitude(Q.from_dcm(c), q)
    assert_same_attitude(Q.from_dcm(c), squat(Rotation.from_matrix(c.T)))


def test_from_dcm_accepts_a_dcm_rounded_to_eight_digits():
    c = np.round(Q.to_dcm(P[:100]), 8)
    # Rounding to 8 digits moves entries by <= 5e-9: orthonormal within the 1e-6 tolerance,
    # and the attitude within ~1e-8 of the original.
    assert_same_attitude(Q.from_dcm(c), P[:100], atol=1e-7)


# ---------------------------------------------------------- rotation vector


def test_rotation_vector_matches_scipy_batch():
    q = np.concatenate([P, NEAR_PI])
    phi = Q.to_rotation_vector(q)
    assert_close(phi, rot(q).as_rotvec())
    assert np.all(np.linalg.norm(phi, axis=-1) <= np.pi + 4 * EPS)
    # Any rotation vector, including several turns (|phi| up to ~17 rad).
    phis = _rng.uniform(-10.0, 10.0, (N, 3))
    assert_same_attitude(Q.from_rotation_vector(phis), squat(Rotation.from_rotvec(phis)))
    # Round trip inside the principal range |phi| < pi.
    small = phis / np.linalg.norm(phis, axis=-1, keepdims=True) * _rng.uniform(0.0, 3.1, (N, 1))
    assert_close(Q.to_rotation_vector(Q.from_rotation_vector(small)), small)


@given(unit_quats, rotvecs)
def test_rotation_vector_matches_scipy_property(q, phi):
    got = Q.to_rotation_vector(q)
    want = rot(q).as_rotvec()[0]
    if abs(q[0]) > 1e-9:
        assert_close(got, want)
    else:  # 180 degrees: phi and -phi are both valid.
        assert min(np.linalg.norm(got - want), np.linalg.norm(got + want)) <= TOL
    assert_same_attitude(Q.from_rotation_vector(got), q)
    assert_same_attitude(Q.from_rotation_vector(phi), squat(Rotation.from_rotvec(phi)))


# -------------------------------------------------------------- axis/angle


def test_axis_angle_matches_scipy_batch():
    axis, angle = Q.to_axis_angle(P)
    r = rot(P)
    assert_close(np.linalg.norm(axis, axis=-1), 1.0)
    # angle is a norm of 2 log(q): it may exceed pi by a rounding or two.
    assert np.all((angle >= 0.0) & (angle <= np.pi + 4 * EPS))
    assert_close(angle, r.magnitude())
    assert_close(axis * angle[:, None], r.as_rotvec())
    # from_axis_angle normalises the axis (any length) and takes any angle.
    ax = _rng.normal(size=(N, 3)) * SCALES[:, None]
    ang = _rng.uniform(-10.0, 10.0, N)
    assert_same_attitude(Q.from_axis_angle(ax, ang), squat(Rotation.from_rotvec(unit(ax) * ang[:, None])))


def test_axis_angle_of_identity_is_zero_about_x():
    axis, angle = Q.to_axis_angle(Q.identity())
    assert angle == 0.0
    np.testing.assert_array_equal(axis, [1.0, 0.0, 0.0])


@given(unit_quats, axes, angles)
def test_axis_angle_matches_scipy_property(q, ax, ang):
    axis, angle = Q.to_axis_angle(q)
    assert 0.0 <= angle <= np.pi + 4 * EPS  # a norm: pi plus a rounding or two at 180 degrees
    assert_close(np.linalg.norm(axis), 1.0)
    assert_close(angle, rot(q).magnitude()[0])
    assert_same_attitude(Q.from_axis_angle(axis, angle), q)
    assert_same_attitude(Q.from_axis_angle(ax, ang), squat(Rotation.from_rotvec(unit(ax) * ang)))


# ---------------------------------------------------------------- MRP


def _check_mrp(q, sigma):
    r = rot(q)
    sigma2 = np.reshape(sigma, (-1, 3))
    s_norm = np.linalg.norm(sigma2, axis=-1)
    assert np.all(s_norm <= 1.0 + 4 * EPS), "to_mrp must return the short set |sigma| <= 1"
    assert_same_attitude(Q.from_mrp(sigma), q)
    assert_same_attitude(Q.from_mrp(sigma), squat(Rotation.from_mrp(sigma2)))
    assert np.all(np.reshape(Q.from_mrp(sigma), (-1, 4))[:, 0] >= 0.0)
    nonzero = s_norm > 1e-6  # the shadow of sigma = 0 is at infinity
    if np.any(nonzero):
        shadow = Q.mrp_shadow(sigma2[nonzero])
        assert np.all(np.linalg.norm(shadow, axis=-1) >= 1.0 - 4 * EPS)
        # Both sets describe the same attitude, here and in scipy.
        assert_same_attitude(Q.from_mrp(shadow), np.reshape(q, (-1, 4))[nonzero])
        assert_same_attitude(Q.from_mrp(shadow), squat(r[nonzero]))
        assert_same_attitude(squat(Rotation.from_mrp(shadow)), np.reshape(q, (-1, 4))[nonzero])
        # Converting back picks the short set again (|sigma| may be exactly 1 at 180 degrees).
        back = Q.to_mrp(Q.from_mrp(shadow))
        on_sphere = np.abs(s_norm[nonzero] - 1.0) < 1e-9
        d = np.minimum(
            np.linalg.norm(back - sigma2[nonzero], axis=-1),
            np.where(on_sphere, np.linalg.norm(back + sigma2[nonzero], axis=-1), np.inf),
        )
        assert np.max(d) <= TOL


def test_mrp_matches_scipy_batch():
    q = np.concatenate([P, NEAR_PI])
    sigma = Q.to_mrp(q)
    assert_close(sigma, rot(q).as_mrp())
    _check_mrp(q, sigma)
    # q and -q give the same (short) MRP.
    assert_close(Q.to_mrp(-q), sigma)
    # from_mrp of arbitrary MRPs, long ones included, against scipy.
    s = _rng.normal(size=(N, 3)) * SCALES[:, None] ** 0.3  # |sigma| from ~0.1 to ~10
    assert_same_attitude(Q.from_mrp(s), squat(Rotation.from_mrp(s)))


@given(unit_quats, rotvecs)
def test_mrp_matches_scipy_property(q, s):
    sigma = Q.to_mrp(q)
    want = rot(q).as_mrp()[0]
    if abs(q[0]) > 1e-9:
        assert_close(sigma, want)
    else:  # 180 degrees: sigma and -sigma (|sigma| = 1) are both short sets.
        assert min(np.linalg.norm(sigma - want), np.linalg.norm(sigma + want)) <= TOL
    _check_mrp(q, sigma)
    assert_same_attitude(Q.from_mrp(s), squat(Rotation.from_mrp(s)))


# ----------------------------------------------------------- exp / log


def test_exp_log_identities_batch():
    g = SCALES[:, None] * P  # general non-zero quaternions, |q| in [1e-3, 1e3]
    # exp(ln|q|) has relative error ~|ln|q|| eps <= 7 eps; the rest is O(eps) relative.
    np.testing.assert_allclose(Q.exp(Q.log(g)), g, rtol=0.0, atol=0.0 + TOL * np.max(SCALES))
    rel = np.linalg.norm(Q.exp(Q.log(g)) - g, axis=-1) / SCALES
    assert np.max(rel) <= TOL
    # The log of a unit quaternion is pure: ln|q| = ln(1 +- few eps) ~ few eps.
    lq = Q.log(P)
    assert np.max(np.abs(lq[:, 0])) <= 8 * EPS
    assert np.all(np.linalg.norm(lq[:, 1:], axis=-1) <= np.pi + 4 * EPS)
    # exp([0, phi/2]) is the rotation by phi, with scipy's sign: [cos(|phi|/2), sin(|phi|/2) phi/|phi|].
    phis = _rng.uniform(-10.0, 10.0, (N, 3))
    assert_close(Q.exp(pure(phis / 2)), squat(Rotation.from_rotvec(phis)))
    assert_close(Q.exp(pure(phis / 2)), Q.from_rotation_vector(phis))
    # log is the inverse of exp on the principal branch |v| < pi.
    p = np.concatenate([_rng.uniform(-3.0, 3.0, (N, 1)), unit(phis) * _rng.uniform(0.0, 3.1, (N, 1))], axis=-1)
    assert_close(Q.log(Q.exp(p)), p)
    # Powers: exp(2 log q) = q ⊗ q.
    assert_close(Q.exp(2.0 * lq), Q.multiply(P, P))


@given(general_quats)
def test_exp_of_log_is_identity_property(q):
    qn = np.linalg.norm(q)
    assert np.linalg.norm(Q.exp(Q.log(q)) - q) <= TOL * qn
    u = q / qn
    lu = Q.log(u)
    assert abs(lu[0]) <= 8 * EPS
    # The vector part of log(u) is half the rotation vector, taken the way u points.
    assert_same_attitude(squat(Rotation.from_rotvec(2.0 * lu[1:])), u)


@given(rotvecs)
def test_exp_of_pure_is_rotation_vector_property(phi):
    assert_close(Q.exp(pure(phi / 2)), squat(Rotation.from_rotvec(phi))[0])
    assert_close(Q.exp(pure(phi / 2)), Q.from_rotation_vector(phi))


@pytest.mark.parametrize(
    "q",
    [
        [-1.0, 0.0, 0.0, 0.0],
        [-2.5, 0.0, 0.0, 0.0],
        [-1.0, 1e-7, 0.0, 0.0],
        [-1.0, 3e-6, -4e-6, 1e-9],
        [-3.0, 0.0, 1e-160, 0.0],
        [-1.0, 1e-160, 1e-160, 0.0],
    ],
)
def test_exp_of_log_near_minus_identity(q):
    """q close to -|q| (w < 0, tiny vector part) is 360 degrees away from +|q|: log must say so."""
    q = np.asarray(q)
    assert np.linalg.norm(Q.exp(Q.log(q)) - q) <= TOL * np.linalg.norm(q)
    # The vector part is ~pi long (half of a ~2 pi rotation vector).
    assert abs(np.linalg.norm(Q.log(q)[1:]) - np.pi) < 1e-5


@pytest.mark.parametrize("half_angle", [1e-12, 1e-9, 3e-6, 9.9e-6, 2e-5, 1e-3])
def test_log_keeps_full_precision_for_small_rotations(half_angle):
    axis = unit([0.3, -0.5, 0.8])
    q = np.concatenate([[np.cos(half_angle)], np.sin(half_angle) * axis])
    # The exact log is [0, half_angle * axis]: only a few roundings (cos, sin, atan2) apart.
    np.testing.assert_allclose(Q.log(q)[1:], half_angle * axis, rtol=16 * EPS, atol=0.0)


@pytest.mark.parametrize("half_angle", [1e-12, 1e-9, 3e-6, 9.9e-6, 2e-5, 1e-3])
def test_exp_keeps_full_precision_for_small_rotations(half_angle):
    axis = unit([0.3, -0.5, 0.8])
    # exp([0, a u]) = [cos a, sin a u]; the small-angle series must be as good as sin(a)/a (a few roundings).
    np.testing.assert_allclose(
        Q.exp(pure(half_angle * axis)),
        np.concatenate([[np.cos(half_angle)], np.sin(half_angle) * axis]),
        rtol=16 * EPS,
        atol=0.0,
    )


# -------------------------------------------------------------- slerp


def test_slerp_matches_scipy_batch():
    f = _rng.uniform(0.0, 1.0, N - 1)
    got = Q.slerp(P[:-1], P[1:], f)
    # scipy Slerp interpolates between consecutive key rotations: key i at time i.
    want = squat(Slerp(np.arange(N), rot(P))(np.arange(N - 1) + f))
    # The shortest way is ambiguous when the keys are ~180 degrees apart (w of the delta ~ 0).
    w_delta = np.abs(np.sum(P[:-1] * P[1:], axis=-1))
    ok = w_delta > 1e-9
    assert np.count_nonzero(~ok) < 3
    assert_same_attitude(got[ok], want[ok])
    # Constant rate along the shortest way: the angle travelled is f times the full angle (<= pi).
    full = Q.error_angle(P[:-1], P[1:])
    assert_close(Q.error_angle(P[:-1], got), f * full)
    assert_close(Q.error_angle(got, P[1:]), (1.0 - f) * full)


def test_slerp_end_points():
    assert_close(Q.slerp(P, P2, 0.0), P)
    assert_same_attitude(Q.slerp(P, P2, 1.0), P2)
    # From q to -q (same attitude) the shortest way goes nowhere.
    assert_same_attitude(Q.slerp(P, -P, 0.5), P)


@given(unit_quats, unit_quats, fractions)
def test_slerp_matches_scipy_property(q0, q1, f):
    assume(abs(np.dot(q0, q1)) > 1e-6)  # not ~180 degrees apart (two shortest ways)
    got = Q.slerp(q0, q1, f)
    want = squat(Slerp([0.0, 1.0], rot(np.stack([q0, q1])))([f]))
    assert_same_attitude(got, want)


# --------------------------------------------------- attitude error


def test_error_quaternion_and_angle_batch():
    e = Q.error_quaternion(P, P2)
    r_err = rot(P).inv() * rot(P2)
    assert_same_attitude(e, squat(r_err))
    assert np.all(e[:, 0] >= 0.0)
    assert_same_attitude(Q.multiply(P, e), P2)
    ang = Q.error_angle(P, P2)
    assert np.all((ang >= 0.0) & (ang <= np.pi))
    assert_close(ang, r_err.magnitude())
    assert_close(ang, 2.0 * np.arctan2(np.linalg.norm(e[:, 1:], axis=-1), e[:, 0]))
    # -q is the same attitude as q: zero error, and the error quaternion is the identity.
    assert_close(Q.error_angle(P, -P), 0.0)
    assert_close(Q.error_quaternion(P, -P), Q.identity((N,)))


@given(unit_quats, unit_quats)
def test_error_quaternion_and_angle_property(q_ref, q):
    r_err = rot(q_ref).inv() * rot(q)
    e = Q.error_quaternion(q_ref, q)
    assert e[0] >= 0.0
    assert_same_attitude(e, squat(r_err))
    assert_close(Q.error_angle(q_ref, q), r_err.magnitude()[0])


def test_error_angle_359_degrees_is_1_degree():
    axes_ = unit(_rng.normal(size=(N, 3)))
    q = Q.multiply(P, Q.from_axis_angle(axes_, np.deg2rad(359.0)))
    assert_close(Q.error_angle(P, q), np.deg2rad(1.0))
    e = Q.error_quaternion(P, q)
    assert np.all(e[:, 0] > 0.0)
    # The short way round: -1 degree about the axis.
    assert_close(Q.to_rotation_vector(e), -np.deg2rad(1.0) * axes_)


def test_error_angle_keeps_precision_for_tiny_errors():
    tiny = 1e-9  # rad
    axes_ = unit(_rng.normal(size=(N, 3)))
    dq = np.concatenate([np.full((N, 1), np.cos(tiny / 2)), np.sin(tiny / 2) * axes_], axis=-1)
    # From the identity the error is exactly the 1e-9 rad built in (a few roundings of sin/atan2).
    np.testing.assert_allclose(Q.error_angle(Q.identity((N,)), dq), tiny, rtol=1e-14)
    # arccos would lose it: cos(5e-10) rounds to 1, so 2 arccos|w| is 0 (or 2e-8 after one ulp).
    assert np.all(np.abs(2.0 * np.arccos(np.minimum(np.abs(dq[:, 0]), 1.0)) - tiny) > 0.5 * tiny)
    # From a random reference the product q_ref* ⊗ q has absolute rounding ~1e-16 per entry,
    # i.e. ~1e-7 relative of a 5e-10 vector part; scipy sees the same rounding.
    q = Q.multiply(P, dq)
    ang = Q.error_angle(P, q)
    np.testing.assert_allclose(ang, tiny, rtol=1e-5)
    assert_close(ang, (rot(P).inv() * rot(q)).magnitude(), atol=1e-15)


# ---------------------------------------------------------- derivative


def test_derivative_matches_central_difference():
    omega = _rng.normal(size=(N, 3))  # rad/s, |omega| up to ~4.5

    def q_at(t):
        # Exact solution of q_dot = 0.5 q ⊗ [0, omega] for constant body rate omega.
        return Q.multiply(P, Q.exp(pure(omega * t / 2)))

    h = 1e-5  # s
    fd = (q_at(h) - q_at(-h)) / (2 * h)
    err = np.linalg.norm(fd - Q.derivative(P, omega), axis=-1)
    # Central difference: truncation h^2/6 |q'''| with |q'''| = |omega/2|^3 (each time derivative
    # multiplies by [0, omega/2]), plus rounding ~4 eps / h of the O(1) entries differenced;
    # the 2x factor covers the higher-order terms. A wrong product order (omega ⊗ q, an
    # inertial-frame rate) or a missing 1/2 would be off by O(|omega|).
    bound = h**2 / 48 * np.linalg.norm(omega, axis=-1) ** 3 + 4 * EPS / h
    assert np.all(err <= 2 * bound), f"max err/bound {np.max(err / bound):.3g}"
    # Norm preservation: q . q_dot = 0 for a unit q.
    assert_close(np.sum(P * Q.derivative(P, omega), axis=-1), 0.0)


@given(unit_quats, vectors)
def test_derivative_property(q, omega):
    qd = Q.derivative(q, omega)
    assert_close(qd, 0.5 * Q.multiply(q, pure(omega)), atol=TOL * (1 + np.linalg.norm(omega)))
    # Rotating body vectors: d/dt (q v q*) = q (omega x v) q*, i.e. the rate is expressed in B.
    v = np.array([0.3, -1.2, 0.7])
    dq_dt_v = Q.multiply(Q.multiply(qd, pure(v)), Q.conjugate(q)) + Q.multiply(Q.multiply(q, pure(v)), Q.conjugate(qd))
    assert_close(dq_dt_v[1:], Q.rotate(q, np.cross(omega, v)), atol=TOL * (1 + np.linalg.norm(omega)))


# --------------------------------------------------------------- random


def _angles(q):
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))


def _haar_angle_cdf(theta):
    # Density (1 - cos theta) / pi on [0, pi].
    return (theta - np.sin(theta)) / np.pi


def test_random_is_uniform_on_so3():
    q = Q.random(20000, rng=SEED)
    assert_close(np.linalg.norm(q, axis=-1), 1.0)
    # Rotation angle distributed as (1 - cos theta)/pi. Fixed seed: the p-value is deterministic.
    assert stats.kstest(_angles(q), _haar_angle_cdf).pvalue > 1e-3
    # The same test rejects a plausible mistake (normalising a uniform 4-cube sample), so it has power.
    cube = unit(np.random.default_rng(SEED).uniform(-1.0, 1.0, (20000, 4)))
    assert stats.kstest(_angles(cube), _haar_angle_cdf).pvalue < 1e-10
    # Rotation axes are isotropic: each axis component is uniform on [-1, 1].
    axis, _ = Q.to_axis_angle(q)
    for k in range(3):
        assert stats.kstest(axis[:, k], stats.uniform(-1.0, 2.0).cdf).pvalue > 1e-3
    # Haar measure: E[C] = 0 with Var(C_ij) = 1/3 per entry, Var(trace C) = 1. Within 5 standard errors.
    c = Q.to_dcm(q)
    assert np.all(np.abs(c.mean(axis=0)) < 5 * np.sqrt(1 / 3 / len(q)))
    assert abs(np.trace(c, axis1=-2, axis2=-1).mean()) < 5 / np.sqrt(len(q))


def test_random_seed_and_shape():
    np.testing.assert_array_equal(Q.random((3, 4), rng=7), Q.random((3, 4), rng=7))
    gen = np.random.default_rng(7)
    np.testing.assert_array_equal(Q.random((3, 4), rng=gen).shape, (3, 4, 4))
    assert Q.random(5, rng=1).shape == (5, 4)
    assert Q.random(rng=1).shape == (4,)
    assert not np.array_equal(Q.random(5, rng=1), Q.random(5, rng=2))


# ----------------------------------------------------- batch behaviour

# Arguments with two leading batch dimensions that broadcast: (3, 1, ...) against (1, 4, ...).
_b = np.random.default_rng(SEED + 7)
QA = Q.random((3, 1), rng=_b)
QB = Q.random((1, 4), rng=_b)
QAB = Q.random((3, 4), rng=_b)
VB = _b.normal(size=(1, 4, 3))
GA = QA * _b.uniform(0.5, 2.0, (3, 1, 1))  # non-unit
GAB = QAB * _b.uniform(0.5, 2.0, (3, 4, 1))  # non-unit
VAB = _b.normal(size=(3, 4, 3))
FRAC = _b.uniform(0.0, 1.0, (3, 4))
ANG_B = _b.uniform(-4.0, 4.0, (1, 4))
AX_A = _b.normal(size=(3, 1, 3))
SIG_AB = _b.normal(size=(3, 4, 3))


def _to_axis_angle_stacked(q):
    axis, angle = Q.to_axis_angle(q)
    return np.concatenate([axis, angle[..., None]], axis=-1)


BATCH_CASES = {
    "multiply": (Q.multiply, (GA, QB)),
    "conjugate": (Q.conjugate, (GAB,)),
    "inverse": (Q.inverse, (GAB,)),
    "norm": (Q.norm, (GAB,)),
    "normalize": (Q.normalize, (GAB,)),
    "shortest": (Q.shortest, (-QAB,)),
    "as_unit_quaternion": (Q.as_unit_quaternion, (QAB,)),
    "rotate": (Q.rotate, (QA, VB)),
    "rotate_inverse": (Q.rotate_inverse, (QA, VB)),
    "exp": (Q.exp, (GAB,)),
    "log": (Q.log, (GAB,)),
    "slerp": (Q.slerp, (QA, QB, FRAC)),
    "error_quaternion": (Q.error_quaternion, (QA, QB)),
    "error_angle": (Q.error_angle, (QA, QB)),
    "derivative": (Q.derivative, (QA, VB)),
    "to_dcm": (Q.to_dcm, (QAB,)),
    "from_dcm": (Q.from_dcm, (Q.to_dcm(QAB),)),
    "to_axis_angle": (_to_axis_angle_stacked, (QAB,)),
    "from_axis_angle": (Q.from_axis_angle, (AX_A, ANG_B)),
    "to_rotation_vector": (Q.to_rotation_vector, (QAB,)),
    "from_rotation_vector": (Q.from_rotation_vector, (VAB,)),
    "to_mrp": (Q.to_mrp, (QAB,)),
    "from_mrp": (Q.from_mrp, (SIG_AB,)),
    "mrp_shadow": (Q.mrp_shadow, (SIG_AB,)),
}


def _element(arr, i, j):
    """Element (i, j) of a broadcast batch argument (size-1 batch axes repeat)."""
    arr = np.asarray(arr)
    return arr[min(i, arr.shape[0] - 1), min(j, arr.shape[1] - 1)]


@pytest.mark.parametrize("name", list(BATCH_CASES))
def test_batch_broadcasts_and_matches_loop(name):
    func, args = BATCH_CASES[name]
    out = func(*args)
    single = func(*[_element(a, 0, 0) for a in args])
    assert out.shape == (3, 4, *np.shape(single))
    for i in range(3):
        for j in range(4):
            # Same elementwise arithmetic batched or not; only reductions (norms, matmul/det in the
            # from_dcm check) may be ordered differently, which moves results by an ulp or so.
            np.testing.assert_allclose(out[i, j], func(*[_element(a, i, j) for a in args]), rtol=4 * EPS, atol=4 * EPS)


@pytest.mark.parametrize("name", list(BATCH_CASES))
def test_inputs_are_never_mutated(name):
    func, args = BATCH_CASES[name]
    originals = [np.array(a, copy=True) for a in args]
    frozen = []
    for a in args:
        a = np.array(a, copy=True)
        a.flags.writeable = False  # an in-place write would raise
        frozen.append(a)
    out = func(*frozen)
    for a, orig in zip(frozen, originals, strict=True):
        np.testing.assert_array_equal(a, orig)
        assert not np.shares_memory(out, a), "the result must not be a view of an input"


def test_identity_shape():
    np.testing.assert_array_equal(Q.identity(), [1.0, 0.0, 0.0, 0.0])
    ident = Q.identity((3, 4))
    assert ident.shape == (3, 4, 4)
    assert_same_attitude(Q.multiply(ident, QAB), QAB, atol=0.0)


# ------------------------------------------------------------ bad input

_U = np.array([0.5, 0.5, 0.5, 0.5])  # a valid unit quaternion
_NAN_Q = np.array([1.0, np.nan, 0.0, 0.0])
_INF_Q = np.array([np.inf, 0.0, 0.0, 0.0])
_ZERO_Q = np.zeros(4)
_NON_UNIT = np.array([1.0, 0.1, 0.0, 0.0])  # |q| = 1.005
_C = Q.to_dcm(_U)

_FINITE = "must be finite"
_SHAPE4 = re.escape("must have shape (..., 4)")
_SHAPE3 = re.escape("must have shape (..., 3)")
_UNIT = "must be a unit quaternion"

BAD_INPUT_CASES = [
    # NaN / inf, in every argument
    ("multiply p nan", lambda: Q.multiply(_NAN_Q, _U), "^p " + _FINITE),
    ("multiply q inf", lambda: Q.multiply(_U, _INF_Q), "^q " + _FINITE),
    ("rotate q nan", lambda: Q.rotate(_NAN_Q, [1.0, 0.0, 0.0]), "^q " + _FINITE),
    ("rotate v inf", lambda: Q.rotate(_U, [1.0, np.inf, 0.0]), "^v " + _FINITE),
    ("rotate_inverse v nan", lambda: Q.rotate_inverse(_U, [np.nan, 0.0, 0.0]), "^v " + _FINITE),
    ("to_dcm nan", lambda: Q.to_dcm(_NAN_Q), "^q " + _FINITE),
    ("from_dcm nan", lambda: Q.from_dcm(np.where(np.eye(3) > 0, np.nan, _C)), "^dcm " + _FINITE),
    ("exp inf", lambda: Q.exp(_INF_Q), "^q " + _FINITE),
    ("log nan", lambda: Q.log(_NAN_Q), "^q " + _FINITE),
    ("from_rotation_vector inf", lambda: Q.from_rotation_vector([0.0, 0.0, np.inf]), "^rotvec " + _FINITE),
    ("from_axis_angle angle nan", lambda: Q.from_axis_angle([0.0, 0.0, 1.0], np.nan), "^angle " + _FINITE),
    ("from_axis_angle axis inf", lambda: Q.from_axis_angle([0.0, np.inf, 1.0], 1.0), "^axis " + _FINITE),
    ("from_mrp nan", lambda: Q.from_mrp([np.nan, 0.0, 0.0]), "^sigma " + _FINITE),
    ("mrp_shadow inf", lambda: Q.mrp_shadow([np.inf, 0.0, 0.0]), "^sigma " + _FINITE),
    ("slerp fraction nan", lambda: Q.slerp(_U, _U, np.nan), "^fraction " + _FINITE),
    ("slerp q1 nan", lambda: Q.slerp(_U, _NAN_Q, 0.5), "^q1 " + _FINITE),
    ("error_angle q_ref inf", lambda: Q.error_angle(_INF_Q, _U), "^q_ref " + _FINITE),
    ("derivative omega nan", lambda: Q.derivative(_U, [0.0, np.nan, 0.0]), "^omega " + _FINITE),
    ("derivative q inf", lambda: Q.derivative(_INF_Q, [0.0, 0.0, 0.0]), "^q " + _FINITE),
    # wrong shape
    ("multiply p shape", lambda: Q.multiply([1.0, 0.0, 0.0], _U), "^p " + _SHAPE4),
    ("conjugate shape", lambda: Q.conjugate(np.ones((2, 5))), "^q " + _SHAPE4),
    ("to_dcm scalar", lambda: Q.to_dcm(1.0), "^q " + _SHAPE4),
    ("rotate v shape", lambda: Q.rotate(_U, [1.0, 0.0, 0.0, 0.0]), "^v " + _SHAPE3),
    ("from_dcm 3x2", lambda: Q.from_dcm(np.ones((3, 2))), "^dcm " + re.escape("must have shape (..., 3, 3)")),
    ("from_dcm flat", lambda: Q.from_dcm(np.eye(3).ravel()), "^dcm " + re.escape("must have shape (..., 3, 3)")),
    ("from_rotation_vector shape", lambda: Q.from_rotation_vector([1.0, 2.0]), "^rotvec " + _SHAPE3),
    ("from_axis_angle axis shape", lambda: Q.from_axis_angle([1.0, 2.0], 1.0), "^axis " + _SHAPE3),
    ("from_mrp shape", lambda: Q.from_mrp(np.zeros(4)), "^sigma " + _SHAPE3),
    ("derivative omega shape", lambda: Q.derivative(_U, np.zeros(4)), "^omega " + _SHAPE3),
    ("error_quaternion q_ref shape", lambda: Q.error_quaternion(np.zeros(3), _U), "^q_ref " + _SHAPE4),
    ("non-numeric", lambda: Q.to_mrp(["a", "b", "c", "d"]), "^q must be numeric"),
    # zero-norm quaternion
    ("normalize zero", lambda: Q.normalize(_ZERO_Q), "^q must be non-zero"),
    ("inverse zero", lambda: Q.inverse(np.stack([_U, _ZERO_Q])), "^q must be non-zero"),
    ("log zero", lambda: Q.log(_ZERO_Q), "^q must be non-zero"),
    ("rotate zero", lambda: Q.rotate(_ZERO_Q, [1.0, 0.0, 0.0]), "^q " + _UNIT + ".*zero quaternion"),
    ("to_dcm zero", lambda: Q.to_dcm(_ZERO_Q), "^q " + _UNIT + ".*zero quaternion"),
    ("slerp q0 zero", lambda: Q.slerp(_ZERO_Q, _U, 0.5), "^q0 " + _UNIT + ".*zero quaternion"),
    # non-unit attitude quaternion
    ("rotate non-unit", lambda: Q.rotate(_NON_UNIT, [1.0, 0.0, 0.0]), "^q " + _UNIT),
    ("rotate_inverse non-unit", lambda: Q.rotate_inverse(2 * _U, [1.0, 0.0, 0.0]), "^q " + _UNIT),
    ("to_dcm non-unit", lambda: Q.to_dcm(np.stack([_U, _NON_UNIT])), "^q " + _UNIT),
    ("to_mrp non-unit", lambda: Q.to_mrp(_NON_UNIT), "^q " + _UNIT),
    ("to_rotation_vector non-unit", lambda: Q.to_rotation_vector(_NON_UNIT), "^q " + _UNIT),
    ("to_axis_angle non-unit", lambda: Q.to_axis_angle(_NON_UNIT), "^q " + _UNIT),
    ("slerp q1 non-unit", lambda: Q.slerp(_U, _NON_UNIT, 0.5), "^q1 " + _UNIT),
    ("error_quaternion q_ref non-unit", lambda: Q.error_quaternion(_NON_UNIT, _U), "^q_ref " + _UNIT),
    ("error_angle q non-unit", lambda: Q.error_angle(_U, _NON_UNIT), "^q " + _UNIT),
    ("as_unit_quaternion name", lambda: Q.as_unit_quaternion(_NON_UNIT, "q_BN"), "^q_BN " + _UNIT),
    # DCM that is not a rotation
    ("from_dcm scaled", lambda: Q.from_dcm(1.01 * _C), "^dcm must be orthonormal"),
    ("from_dcm sheared", lambda: Q.from_dcm(_C + 1e-4 * np.triu(np.ones((3, 3)))), "^dcm must be orthonormal"),
    ("from_dcm batch one bad", lambda: Q.from_dcm(np.stack([_C, 2 * _C])), "^dcm must be orthonormal"),
    ("from_dcm reflection", lambda: Q.from_dcm(-_C), "^dcm must be a proper rotation"),
    ("from_dcm mirror", lambda: Q.from_dcm(np.diag([1.0, 1.0, -1.0])), "^dcm must be a proper rotation"),
    # zero axis / zero MRP shadow
    ("from_axis_angle zero axis", lambda: Q.from_axis_angle([0.0, 0.0, 0.0], 1.0), "^axis must be a non-zero"),
    ("from_axis_angle zero in batch", lambda: Q.from_axis_angle([[1.0, 0, 0], [0, 0, 0]], 1.0), "^axis must be"),
    ("mrp_shadow zero", lambda: Q.mrp_shadow([0.0, 0.0, 0.0]), "^sigma must be non-zero"),
    # random source
    ("random negative seed", lambda: Q.random(3, rng=-1), "^rng "),
    ("random bad rng", lambda: Q.random(3, rng="seed"), "^rng "),
]


@pytest.mark.parametrize(("label", "call", "match"), BAD_INPUT_CASES, ids=[c[0] for c in BAD_INPUT_CASES])
def test_bad_input_raises_value_error_naming_the_argument(label, call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_unit_norm_tolerance_boundary():
    # Within UNIT_NORM_TOLERANCE (1e-6) a quaternion is accepted and normalised exactly.
    q = _U * (1.0 + 0.5 * Q.UNIT_NORM_TOLERANCE)
    assert_close(np.linalg.norm(Q.as_unit_quaternion(q)), 1.0, atol=2 * EPS)
    assert_close(Q.to_dcm(q), Q.to_dcm(_U), atol=4 * EPS)
    with pytest.raises(ValueError, match="^q " + _UNIT):
        Q.to_dcm(_U * (1.0 + 2.0 * Q.UNIT_NORM_TOLERANCE))


class TestExtremeMagnitudes:
    """Norms are computed with scaling, so huge or tiny inputs keep their meaning."""

    def test_huge_and_tiny_quaternions_normalise(self):
        np.testing.assert_array_equal(Q.normalize([1e200, 0.0, 0.0, 0.0]), [1.0, 0.0, 0.0, 0.0])
        np.testing.assert_array_equal(Q.normalize([1e-170, 0.0, 0.0, 0.0]), [1.0, 0.0, 0.0, 0.0])
        np.testing.assert_allclose(Q.inverse([2e200, 0.0, 0.0, 0.0]), [0.5e-200, 0.0, 0.0, 0.0], rtol=1e-15)

    def test_huge_axis_and_mrp_give_unit_quaternions(self):
        q = Q.from_axis_angle([1e200, 0.0, 0.0], 0.5)
        np.testing.assert_allclose(q, [np.cos(0.25), np.sin(0.25), 0.0, 0.0], atol=1e-15)
        # |sigma| -> infinity is a full turn: the identity attitude.
        np.testing.assert_allclose(Q.from_mrp([1e160, 0.0, 0.0]), [1.0, 0.0, 0.0, 0.0], atol=1e-15)

    def test_tiny_rotation_axis_is_unit(self):
        axis, angle = Q.to_axis_angle([1.0, 4.76e-162, 4.76e-162, 4.76e-162])
        np.testing.assert_allclose(axis, np.full(3, 1 / np.sqrt(3)), rtol=1e-15)
        assert angle == pytest.approx(2 * np.sqrt(3) * 4.76e-162, rel=1e-14)

    def test_overflowing_exponential_is_named(self):
        with pytest.raises(ValueError, match="q scalar part must be at most"):
            Q.exp([1000.0, 0.0, 0.0, 0.0])


class TestFloatsMirrorTheArrayFunctions:
    """One quaternion in Python floats (the sensors' per-tick path) rounds exactly as the array functions.

    The reference is the array function itself on the same numbers: a sensor sample formed either way
    must be the same bit for bit, which is what makes a batch of runs equal to one run at a time
    (tests/attitude/test_sensors_batch.py), so the comparison is exact (``assert_array_equal``).
    """

    @staticmethod
    def _cases() -> np.ndarray:
        """Random rotations, their negatives (w < 0), near pi, tiny and zero rotations, scaled within tolerance."""
        tiny = Q.from_rotation_vector(_rng.normal(size=(200, 3)) * 10.0 ** _rng.uniform(-12, -3, (200, 1)))
        off_unit = P[:200] * (1.0 + _rng.uniform(-0.9, 0.9, (200, 1)) * Q.UNIT_NORM_TOLERANCE)
        special = np.array([[1.0, 0.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, -1.0]])
        return np.concatenate([P[:1000], -P2[:500], NEAR_PI, tiny, off_unit, special])

    def test_unit_floats(self):
        for q in self._cases():
            np.testing.assert_array_equal(Q.unit_floats(q.tolist()), Q.as_unit_quaternion(q))

    def test_unit_floats_refuses_what_the_array_function_refuses(self):
        # Beyond the tolerance the array function raises; the floats give None (the caller then raises).
        q = (P[0] * (1.0 + 2.0 * Q.UNIT_NORM_TOLERANCE)).tolist()
        assert Q.unit_floats(q) is None
        with pytest.raises(ValueError, match=_UNIT):
            Q.as_unit_quaternion(q)
        assert Q.unit_floats([0.0, 0.0, 0.0, 0.0]) is None

    def test_rotation_vector_floats(self):
        for q in self._cases():
            np.testing.assert_array_equal(Q.rotation_vector_floats(q.tolist()), Q.to_rotation_vector(q))
        assert Q.rotation_vector_floats((2.0 * P[0]).tolist()) is None

    def test_from_rotation_vector_floats(self):
        # Across the series threshold (half-angle 1e-4), zero, and several turns.
        sizes = 10.0 ** _rng.uniform(-12.0, 1.2, (2000, 1))
        rotvecs = np.concatenate([_rng.normal(size=(2000, 3)) * sizes, np.zeros((1, 3)), [[2e-4, 0.0, 0.0]]])
        for phi in rotvecs:
            np.testing.assert_array_equal(Q.from_rotation_vector_floats(phi.tolist()), Q.from_rotation_vector(phi))

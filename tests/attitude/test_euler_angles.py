"""Tests of attitude.euler_angles against scipy Rotation, finite differences,
published formulas and a quaternion integration.

References: ``scipy.spatial.transform.Rotation`` (DCM, quaternion and angles for every sequence,
intrinsic upper-case letters); central finite differences of the rotation for the kinematic
matrix; the textbook 3-2-1 and 3-1-3 kinematic differential equations (Schaub and Junkins,
*Analytical Mechanics of Space Systems*, ch. 3), typed in independently; the Euler-angle
kinematics integrated and compared with the quaternion kinematics ``q' = q ⊗ [0, omega] / 2`` of
:mod:`attitude.quaternion`; gimbal lock where ``det W`` vanishes; bad input named with the
argument, the rule and the value (DESIGN.md)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from attitude import euler_angles as ea
from attitude import quaternion as quat

SEQUENCES = ea.SEQUENCES
LETTERS = str.maketrans("123", "XYZ")


def scipy_seq(sequence: str) -> str:
    """Upper-case letters: scipy's intrinsic form of a digit sequence."""
    return sequence.translate(LETTERS)


def scipy_euler(rotation: Rotation, sequence: str) -> np.ndarray:
    """scipy's intrinsic Euler angles, without its gimbal-lock warning (the ``suppress_warnings``
    keyword is newer than the scipy>=1.14 this project supports)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected")
        return rotation.as_euler(scipy_seq(sequence))


def wrapped(angle):
    """Angle difference mapped into (-pi, pi] (so pi and -pi compare equal)."""
    return np.pi - np.mod(np.pi - np.asarray(angle), 2.0 * np.pi)


def random_angles(rng, n, sequence, min_distance=0.0):
    """Random angles with t1, t3 in [-pi, pi) and t2 over its canonical range, at least
    ``min_distance`` (in |cos t2| or |sin t2|) from gimbal lock."""
    t = rng.uniform(-np.pi, np.pi, (n, 3))
    edge = np.arccos(min_distance) if min_distance > 0 else np.pi / 2
    if ea.is_tait_bryan(sequence):
        t[:, 1] = rng.uniform(-edge, edge, n)
    else:
        t[:, 1] = rng.uniform(np.pi / 2 - edge, np.pi / 2 + edge, n)
    return t


def test_sequence_lists():
    assert len(set(SEQUENCES)) == 12
    assert all(ea.is_tait_bryan(s) for s in ea.TAIT_BRYAN_SEQUENCES)
    assert not any(ea.is_tait_bryan(s) for s in ea.PROPER_SEQUENCES)


# --------------------------------------------------------------------------
# Cross-checks against scipy (an independent implementation)
# --------------------------------------------------------------------------


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_to_dcm_and_quaternion_match_scipy(sequence):
    rng = np.random.default_rng(1)
    t = rng.uniform(-2 * np.pi, 2 * np.pi, (5000, 3))  # any angles, not only the canonical ranges
    rot = Rotation.from_euler(scipy_seq(sequence), t)
    # Entries are sums of products of three sines/cosines (|terms| <= 1); two evaluation
    # orders differ by a few ulp (observed <= 7e-16). 1e-13 leaves a 100-fold margin.
    np.testing.assert_allclose(ea.to_dcm(t, sequence), np.swapaxes(rot.as_matrix(), -1, -2), rtol=0, atol=1e-13)
    q = ea.to_quaternion(t, sequence)
    q_scipy = rot.as_quat(scalar_first=True)
    sign = np.sign(np.sum(q * q_scipy, axis=-1, keepdims=True))  # q and -q are the same attitude
    np.testing.assert_allclose(q, sign * q_scipy, rtol=0, atol=1e-13)  # same argument as the DCM
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, rtol=0, atol=1e-14)  # product of unit quaternions


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_angles_match_scipy_away_from_gimbal_lock(sequence):
    rng = np.random.default_rng(2)
    q = quat.random(5000, rng)  # uniform on SO(3)
    rot = Rotation.from_quat(q, scalar_first=True)
    expected = scipy_euler(rot, sequence)
    far = ea.distance_to_gimbal_lock(expected, sequence) > 1e-3
    assert far.sum() > 4900  # the comparison covers almost all samples
    for angles in (ea.from_quaternion(q, sequence), ea.from_dcm(np.swapaxes(rot.as_matrix(), -1, -2), sequence)):
        # t1 and t3 are conditioned like 1/distance: a few ulp of input error becomes
        # ~1e-16 / 1e-3 = 1e-13 rad at worst here (observed 2e-15); 1e-11 is 100 times that.
        np.testing.assert_allclose(wrapped(angles - expected)[far], 0.0, rtol=0, atol=1e-11)


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_round_trip_reproduces_rotation_everywhere_including_gimbal_lock(sequence):
    rng = np.random.default_rng(3)
    t = rng.uniform(-2 * np.pi, 2 * np.pi, (5000, 3))
    singular = [np.pi / 2, -np.pi / 2] if ea.is_tait_bryan(sequence) else [0.0, np.pi]
    # A quarter of the samples at or within 1e-16..1e-4 rad of a singular middle angle.
    offsets = np.concatenate([[0.0], 10.0 ** -np.arange(4.0, 17.0)])
    near = rng.choice(len(t), 1250, replace=False)
    t[near, 1] = rng.choice(singular, 1250) + rng.choice([-1, 1], 1250) * rng.choice(offsets, 1250)
    dcm = ea.to_dcm(t, sequence)
    q = ea.to_quaternion(t, sequence)
    from_d = ea.from_dcm(dcm, sequence)
    from_q = ea.from_quaternion(q, sequence)
    # The round trip is exact up to rounding (~1e-15) except inside the lock snap window, where
    # setting t3 = 0 moves the rotation by at most 2 * LOCK_SNAP_ANGLE = 2e-13; 1e-12 covers both.
    np.testing.assert_allclose(ea.to_dcm(from_d, sequence), dcm, rtol=0, atol=1e-12)
    np.testing.assert_array_less(quat.error_angle(q, ea.to_quaternion(from_q, sequence)), 1e-12)
    for angles in (from_d, from_q):
        assert np.all((angles[:, [0, 2]] > -np.pi) & (angles[:, [0, 2]] <= np.pi))
        lo, hi = (-np.pi / 2, np.pi / 2) if ea.is_tait_bryan(sequence) else (0.0, np.pi)
        assert np.all((angles[:, 1] >= lo) & (angles[:, 1] <= hi))
    # Away from the singularity, angles inside the canonical ranges come back themselves.
    t = random_angles(rng, 5000, sequence, min_distance=1e-2)
    # Conditioning of t1, t3 is 1/distance <= 100: ~1e-14 rad; 1e-12 leaves a 100-fold margin.
    np.testing.assert_allclose(
        wrapped(ea.from_quaternion(ea.to_quaternion(t, sequence), sequence) - t), 0.0, rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(wrapped(ea.from_dcm(ea.to_dcm(t, sequence), sequence) - t), 0.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_exact_gimbal_lock_gives_third_angle_zero(sequence):
    rng = np.random.default_rng(4)
    t = rng.uniform(-np.pi, np.pi, (200, 3))
    for middle in [np.pi / 2, -np.pi / 2] if ea.is_tait_bryan(sequence) else [0.0, np.pi]:
        t[:, 1] = middle
        for angles in (
            ea.from_dcm(ea.to_dcm(t, sequence), sequence),
            ea.from_quaternion(ea.to_quaternion(t, sequence), sequence),
        ):
            assert np.all(angles[:, 2] == 0.0)
            # The middle angle is recovered to rounding (observed 4e-16).
            np.testing.assert_allclose(angles[:, 1], middle, rtol=0, atol=1e-14)
            # Rotation reproduced to rounding: the snap is exact at exact lock.
            np.testing.assert_allclose(ea.to_dcm(angles, sequence), ea.to_dcm(t, sequence), rtol=0, atol=1e-13)
            # At lock only t1 + t3 (or t1 - t3) is defined and t1 carries it; scipy makes the same
            # choice (t3 = 0, with a warning), so t1 must agree. At lock t1 is 2 atan2 of O(1)
            # quaternion components in both libraries (~1e-15 rad); 1e-12 is a wide margin.
            expected = scipy_euler(Rotation.from_matrix(np.swapaxes(ea.to_dcm(t, sequence), -1, -2)), sequence)
            np.testing.assert_allclose(wrapped(angles[:, 0] - expected[:, 0]), 0.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_half_turns_give_plus_pi(sequence):
    # A half turn about the first (or, for Tait-Bryan, the third) axis sits on the range boundary:
    # the documented range (-pi, pi] requires +pi, for q and -q, from a quaternion or a matrix.
    a, _, c = (int(ch) - 1 for ch in sequence)
    for axis, position in ((a, 0), (c, 2 if a != c else 0)):
        expected = np.zeros(3)
        expected[position] = np.pi
        for sign in (1.0, -1.0):
            q = np.zeros(4)
            q[1 + axis] = sign
            np.testing.assert_array_equal(ea.from_quaternion(q, sequence), expected)
            np.testing.assert_array_equal(ea.from_dcm(quat.to_dcm(q), sequence), expected)


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_small_angles_keep_absolute_accuracy(sequence):
    rng = np.random.default_rng(10)
    t = rng.uniform(-1e-9, 1e-9, (1000, 3))  # e.g. attitude errors of a fine-pointing controller
    if not ea.is_tait_bryan(sequence):
        t[:, 1] += 1.0  # a proper sequence is singular at t2 = 0
    # Absolute accuracy is what the atan2 formulas give: the Tait-Bryan middle angle is computed as
    # (an angle near pi/2) - pi/2, so its error is ~ulp(pi/2) = 2.2e-16; 1e-15 allows 4 ulp.
    for angles in (
        ea.from_quaternion(ea.to_quaternion(t, sequence), sequence),
        ea.from_dcm(ea.to_dcm(t, sequence), sequence),
    ):
        np.testing.assert_allclose(angles, t, rtol=0, atol=1e-15)
    # A pure rotation about the first axis returns its angle exactly, however small (wrapping into
    # (-pi, pi] must not round it to a multiple of ulp(pi), as a modulo would).
    q = np.array([1.0, 0.0, 0.0, 0.0])
    q[int(sequence[0])] = 0.5e-20
    np.testing.assert_array_equal(ea.from_quaternion(q, sequence), [1e-20, 0.0, 0.0])


@given(
    t=st.tuples(*[st.floats(-10.0, 10.0, allow_nan=False)] * 3),
    sequence=st.sampled_from(SEQUENCES),
)
def test_property_agrees_with_scipy(t, sequence):
    t = np.array(t)
    rot = Rotation.from_euler(scipy_seq(sequence), t)
    dcm = ea.to_dcm(t, sequence)
    np.testing.assert_allclose(dcm, rot.as_matrix().T, rtol=0, atol=1e-13)  # see test_to_dcm_and_quaternion...
    angles = ea.from_dcm(dcm, sequence)
    np.testing.assert_allclose(ea.to_dcm(angles, sequence), dcm, rtol=0, atol=1e-12)  # see the round-trip test
    expected = scipy_euler(rot, sequence)
    if ea.distance_to_gimbal_lock(expected, sequence) > 1e-3:
        np.testing.assert_allclose(wrapped(angles - expected), 0.0, rtol=0, atol=1e-11)  # see the scipy angle test


def test_letters_are_intrinsic_synonyms():
    t = np.array([0.3, -0.7, 2.1])
    for digits in SEQUENCES:
        letters = scipy_seq(digits)
        np.testing.assert_array_equal(ea.to_dcm(t, letters), ea.to_dcm(t, digits))
        np.testing.assert_array_equal(
            ea.from_dcm(ea.to_dcm(t, digits), letters), ea.from_dcm(ea.to_dcm(t, digits), digits)
        )
    # "321" is yaw-pitch-roll: yaw alone turns the body x axis towards inertial +y.
    x_body_in_n = ea.to_dcm([0.5, 0.0, 0.0], "321").T @ [1.0, 0.0, 0.0]
    np.testing.assert_allclose(x_body_in_n, [np.cos(0.5), np.sin(0.5), 0.0], rtol=0, atol=1e-15)


# --------------------------------------------------------------------------
# Kinematics
# --------------------------------------------------------------------------


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_kinematic_matrix_matches_finite_differences_of_the_rotation(sequence):
    rng = np.random.default_rng(5)
    t = random_angles(rng, 500, sequence, min_distance=0.25)
    omega = rng.uniform(-1.0, 1.0, (500, 3))  # rad/s
    q = ea.to_quaternion(t, sequence)

    def central(h):
        # Constant body rate: q(t + h) = q ⊗ exp(omega h / 2) exactly.
        plus = ea.from_quaternion(quat.multiply(q, quat.from_rotation_vector(omega * h)), sequence)
        minus = ea.from_quaternion(quat.multiply(q, quat.from_rotation_vector(-omega * h)), sequence)
        return wrapped(plus - minus) / (2.0 * h)

    h = 1e-4
    # Richardson extrapolation of the central difference: truncation O(h^4) ~ 1e-16 times derivatives
    # of order (|omega| / distance)^5 <= 1e4, so ~1e-12; round-off ~ 1e-15 rad / h = 1e-11 (observed
    # 1.6e-11 at most). 1e-9 is 100 times that, while any wrong entry in B gives errors of order 0.1.
    rates_fd = (4.0 * central(h) - central(2.0 * h)) / 3.0
    np.testing.assert_allclose(ea.angle_rates(t, omega, sequence), rates_fd, rtol=0, atol=1e-9)


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_body_rate_matrix_inverts_kinematic_matrix(sequence):
    rng = np.random.default_rng(6)
    t = random_angles(rng, 1000, sequence, min_distance=1e-3)
    b = ea.kinematic_matrix(t, sequence)
    w = ea.body_rate_matrix(t, sequence)
    # |B| <= ~2/distance = 2e3, so products carry rounding ~1e-16 * 2e3; 1e-11 is a 50-fold margin.
    np.testing.assert_allclose(b @ w, np.broadcast_to(np.eye(3), b.shape), rtol=0, atol=1e-11)
    np.testing.assert_allclose(w @ b, np.broadcast_to(np.eye(3), b.shape), rtol=0, atol=1e-11)
    omega = rng.normal(size=(1000, 3))
    np.testing.assert_allclose(ea.body_rates(t, ea.angle_rates(t, omega, sequence), sequence), omega, atol=1e-11)
    # det W = +-cos t2 (Tait-Bryan) or -sin t2 (proper): its magnitude is the distance to lock.
    np.testing.assert_allclose(np.abs(np.linalg.det(w)), ea.distance_to_gimbal_lock(t, sequence), rtol=0, atol=1e-14)


def test_kinematic_matrix_matches_published_formulas():
    # The textbook 3-2-1 and 3-1-3 kinematic differential equations (e.g. Schaub & Junkins,
    # Analytical Mechanics of Space Systems, chapter 3), typed in independently of the module.
    rng = np.random.default_rng(7)
    for _ in range(50):
        t1, t2, t3 = rng.uniform(-1.4, 1.4, 3)
        c2, s2, c3, s3 = np.cos(t2), np.sin(t2), np.cos(t3), np.sin(t3)
        b321 = np.array([[0, s3, c3], [0, c3 * c2, -s3 * c2], [c2, s3 * s2, c3 * s2]]) / c2
        t2p = t2 + 1.6  # keep the 3-1-3 middle angle away from 0
        c2p, s2p = np.cos(t2p), np.sin(t2p)
        b313 = np.array([[s3, c3, 0], [c3 * s2p, -s3 * s2p, 0], [-s3 * c2p, -c3 * c2p, s2p]]) / s2p
        # Entries are at most 1/cos(1.4) ~ 6 (3-2-1) or 1/sin(0.2) ~ 5 (3-1-3); 1e-13 allows ~20 ulp
        # of such values for the different evaluation orders.
        np.testing.assert_allclose(ea.kinematic_matrix([t1, t2, t3], "321"), b321, rtol=0, atol=1e-13)
        np.testing.assert_allclose(ea.kinematic_matrix([t1, t2p, t3], "313"), b313, rtol=0, atol=1e-13)


def omega_profile(t):
    """Smooth body rate [rad/s]: oscillations (every component changes sign) plus a drift."""
    oscillation = 0.1 * np.array([np.sin(0.7 * t + 0.2), np.cos(0.45 * t), 0.8 * np.sin(0.3 * t + 1.0)])
    return oscillation + np.array([0.02, -0.015, 0.01])


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_integrated_euler_kinematics_match_quaternion_kinematics(sequence):
    t0 = np.array([0.4, 0.25, -0.9]) if ea.is_tait_bryan(sequence) else np.array([0.4, 1.3, -0.9])
    t_eval = np.linspace(0.0, 20.0, 41)  # s
    options = {"method": "DOP853", "rtol": 1e-11, "atol": 1e-12, "t_eval": t_eval}
    euler = solve_ivp(lambda t, x: ea.angle_rates(x, omega_profile(t), sequence), (0.0, 20.0), t0, **options)
    quaternion = solve_ivp(
        lambda t, x: quat.derivative(x, omega_profile(t)),
        (0.0, 20.0),
        ea.to_quaternion(t0, sequence),
        **options,
    )
    assert euler.success and quaternion.success
    angles = euler.y.T
    # The premise: the attitude moves a lot (0.76 rad) and stays well away from gimbal lock (observed >= 0.59).
    assert quat.error_angle(quaternion.y.T[0], quaternion.y.T).max() > 0.5
    assert ea.distance_to_gimbal_lock(angles, sequence).min() > 0.5
    error = quat.error_angle(quaternion.y.T, ea.to_quaternion(angles, sequence))
    # Both integrations hold a local relative error of 1e-11 per step over a few hundred steps on
    # O(1) states with a well-conditioned B (distance > 0.5): global errors ~1e-10 rad (observed
    # ~1e-11). 1e-8 is a 100-fold margin; a wrong kinematic matrix gives errors ~0.1 rad.
    assert error.max() < 1e-8


# --------------------------------------------------------------------------
# Gimbal lock
# --------------------------------------------------------------------------


@pytest.mark.parametrize("sequence", SEQUENCES)
def test_gimbal_lock_raises_in_the_kinematics(sequence):
    tait_bryan = ea.is_tait_bryan(sequence)
    for middle in [np.pi / 2, -np.pi / 2] if tait_bryan else [0.0, np.pi]:
        angles = np.array([0.3, middle, -0.2])
        rule = "cos" if tait_bryan else "sin"
        with pytest.raises(ea.GimbalLockError, match=rf"sequence '{sequence}'.*middle angle.*\|{rule}\(t2\)\|"):
            ea.kinematic_matrix(angles, sequence)
        with pytest.raises(ValueError, match="gimbal lock"):  # it is a ValueError
            ea.angle_rates(angles, [0.1, 0.0, 0.0], sequence)
        # The inverse map is still defined there (it just loses rank).
        w = ea.body_rate_matrix(angles, sequence)
        assert np.all(np.isfinite(w)) and np.linalg.matrix_rank(w) == 2
        # The tolerance is on |cos t2| or |sin t2|, which is ~|offset| next to the singularity.
        step = 1.0 if middle <= 0 else -1.0  # towards the inside of the canonical range
        for offset, raises in [(0.5e-6, True), (2e-6, False)]:
            near = np.array([0.3, middle + step * offset, -0.2])
            assert np.isclose(ea.distance_to_gimbal_lock(near, sequence), offset, rtol=1e-6)
            if raises:
                with pytest.raises(ea.GimbalLockError) as info:
                    ea.kinematic_matrix(near, sequence)
                assert info.value.sequence == sequence and info.value.middle_angle == near[1]
            else:
                assert np.all(np.isfinite(ea.kinematic_matrix(near, sequence)))
        # A user tolerance moves the boundary.
        near = np.array([0.3, middle + step * 0.01, -0.2])
        ea.kinematic_matrix(near, sequence)
        with pytest.raises(ea.GimbalLockError):
            ea.kinematic_matrix(near, sequence, tolerance=0.05)


def test_gimbal_lock_error_names_the_first_bad_item_of_a_batch():
    angles = np.zeros((2, 3, 3))
    angles[1, 2, 1] = np.pi / 2
    with pytest.raises(ea.GimbalLockError, match=r"angles\[1, 2, 1\] = 1.5707963"):
        ea.kinematic_matrix(angles, "321")


def test_distance_to_gimbal_lock_values():
    t = np.array([[0.1, 0.3, 0.2], [0.0, -1.2, 0.0]])
    np.testing.assert_array_equal(ea.distance_to_gimbal_lock(t, "321"), np.abs(np.cos(t[:, 1])))
    np.testing.assert_array_equal(ea.distance_to_gimbal_lock(t, "313"), np.abs(np.sin(t[:, 1])))


# --------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------


BAD_SEQUENCES = ["113", "122", "12", "1234", "", "124", "abc", "zyx", "xyz", "Z Y", "XXY", 321, None, ("3", "2", "1")]


@pytest.mark.parametrize("bad", BAD_SEQUENCES)
def test_bad_sequences_raise(bad):
    for call in (
        lambda: ea.to_dcm([0.1, 0.2, 0.3], bad),
        lambda: ea.to_quaternion([0.1, 0.2, 0.3], bad),
        lambda: ea.from_dcm(np.eye(3), bad),
        lambda: ea.from_quaternion([1.0, 0.0, 0.0, 0.0], bad),
        lambda: ea.kinematic_matrix([0.1, 0.2, 0.3], bad),
        lambda: ea.body_rate_matrix([0.1, 0.2, 0.3], bad),
        lambda: ea.distance_to_gimbal_lock([0.1, 0.2, 0.3], bad),
    ):
        with pytest.raises(ValueError, match=r"sequence must be .*321") as info:
            call()
        assert not isinstance(info.value, ea.GimbalLockError)


def test_lower_case_letters_explain_the_extrinsic_trap():
    with pytest.raises(ValueError, match=r"extrinsic.*'ZYX'"):
        ea.to_dcm([0.1, 0.2, 0.3], "zyx")


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: ea.to_dcm([0.1, np.nan, 0.3], "321"), "angles"),
        (lambda: ea.to_quaternion([0.1, np.inf, 0.3], "321"), "angles"),
        (lambda: ea.to_dcm([0.1, 0.2], "321"), "angles"),
        (lambda: ea.to_dcm(np.zeros((4, 2)), "321"), "angles"),
        (lambda: ea.to_dcm(0.3, "321"), "angles"),
        (lambda: ea.kinematic_matrix([[0.1, 0.2]], "313"), "angles"),
        (lambda: ea.distance_to_gimbal_lock([0.1, np.nan, 0.3], "313"), "angles"),
        (lambda: ea.body_rate_matrix(np.ones(4), "313"), "angles"),
        (lambda: ea.angle_rates([0.1, 0.2, 0.3], [0.0, np.nan, 0.0], "321"), "omega"),
        (lambda: ea.angle_rates([0.1, 0.2, 0.3], [0.0, 0.0], "321"), "omega"),
        (lambda: ea.body_rates([0.1, 0.2, 0.3], [np.inf, 0.0, 0.0], "321"), "rates"),
        (lambda: ea.from_dcm(np.eye(4), "321"), "dcm"),
        (lambda: ea.from_dcm(np.full((3, 3), np.nan), "321"), "dcm"),
        (lambda: ea.from_dcm(2.0 * np.eye(3), "321"), "dcm"),
        (lambda: ea.from_dcm(-np.eye(3), "321"), "dcm"),
        (lambda: ea.from_quaternion([1.0, 0.0, 0.0], "321"), "q"),
        (lambda: ea.from_quaternion([2.0, 0.0, 0.0, 0.0], "321"), "q"),
        (lambda: ea.from_quaternion([np.nan, 0.0, 0.0, 0.0], "321"), "q"),
        (lambda: ea.kinematic_matrix([0.1, 0.2, 0.3], "321", tolerance=-1.0), "tolerance"),
        (lambda: ea.kinematic_matrix([0.1, 0.2, 0.3], "321", tolerance=np.nan), "tolerance"),
        (lambda: ea.kinematic_matrix([0.1, 0.2, 0.3], "321", tolerance=[1e-6, 1e-6]), "tolerance"),
    ],
)
def test_bad_values_raise_naming_the_argument(call, name):
    with pytest.raises(ValueError, match=rf"^{name} must") as info:
        call()
    assert not isinstance(info.value, ea.GimbalLockError)


# --------------------------------------------------------------------------
# Batches and purity
# --------------------------------------------------------------------------


@pytest.mark.parametrize("sequence", ["321", "132", "313", "212"])
def test_batches_match_the_loop_and_inputs_are_untouched(sequence):
    rng = np.random.default_rng(8)
    t = random_angles(rng, 20, sequence, min_distance=0.1).reshape(4, 5, 3)
    omega = rng.normal(size=(4, 5, 3))
    q = quat.random((4, 5), rng)
    dcm = quat.to_dcm(q)
    for arr in (t, omega, q, dcm):
        arr.flags.writeable = False  # any in-place write would raise
    batched = {
        "to_dcm": ea.to_dcm(t, sequence),
        "to_quaternion": ea.to_quaternion(t, sequence),
        "from_dcm": ea.from_dcm(dcm, sequence),
        "from_quaternion": ea.from_quaternion(q, sequence),
        "kinematic_matrix": ea.kinematic_matrix(t, sequence),
        "body_rate_matrix": ea.body_rate_matrix(t, sequence),
        "angle_rates": ea.angle_rates(t, omega, sequence),
        "body_rates": ea.body_rates(t, omega, sequence),
        "distance": ea.distance_to_gimbal_lock(t, sequence),
    }
    expected_shapes = {
        "to_dcm": (4, 5, 3, 3),
        "to_quaternion": (4, 5, 4),
        "kinematic_matrix": (4, 5, 3, 3),
        "body_rate_matrix": (4, 5, 3, 3),
        "distance": (4, 5),
    }
    for key, value in batched.items():
        assert value.shape == expected_shapes.get(key, (4, 5, 3)), key
    for i in range(4):
        for j in range(5):
            single = {
                "to_dcm": ea.to_dcm(t[i, j], sequence),
                "to_quaternion": ea.to_quaternion(t[i, j], sequence),
                "from_dcm": ea.from_dcm(dcm[i, j], sequence),
                "from_quaternion": ea.from_quaternion(q[i, j], sequence),
                "kinematic_matrix": ea.kinematic_matrix(t[i, j], sequence),
                "body_rate_matrix": ea.body_rate_matrix(t[i, j], sequence),
                "angle_rates": ea.angle_rates(t[i, j], omega[i, j], sequence),
                "body_rates": ea.body_rates(t[i, j], omega[i, j], sequence),
                "distance": ea.distance_to_gimbal_lock(t[i, j], sequence),
            }
            for key, value in single.items():
                # Same arithmetic item by item; only BLAS-vs-loop summation order may differ (1 ulp).
                np.testing.assert_allclose(batched[key][i, j], value, rtol=0, atol=1e-14, err_msg=key)


def test_broadcasting_of_rates_against_angles():
    t = np.random.default_rng(9).uniform(-1.0, 1.0, (4, 5, 3))
    omega = np.array([0.1, -0.2, 0.3])
    np.testing.assert_array_equal(
        ea.angle_rates(t, omega, "321"), ea.angle_rates(t, np.broadcast_to(omega, t.shape), "321")
    )
    np.testing.assert_array_equal(
        ea.body_rates(t, omega, "321"), ea.body_rates(t, np.broadcast_to(omega, t.shape), "321")
    )

"""Euler angles: all 12 sequences, conversions, kinematics and gimbal lock.

Convention
----------
A sequence is a string of three axis digits, ``"abc"`` (1 = x, 2 = y, 3 = z),
with no two consecutive axes equal: the six Tait-Bryan sequences ``"123"``,
``"132"``, ``"213"``, ``"231"``, ``"312"``, ``"321"`` and the six proper
(classical) Euler sequences ``"121"``, ``"131"``, ``"212"``, ``"232"``,
``"313"``, ``"323"``. Upper-case letters (``"ZYX"`` for ``"321"``) are
accepted as a synonym. Lower-case letters are **rejected**: in scipy they
mean extrinsic rotations, which this module does not use.

The rotations are *intrinsic* (the aerospace convention): angles
``(t1, t2, t3)`` [rad] of sequence ``"abc"`` take the inertial frame N to the
body frame B by a rotation ``t1`` about axis ``a``, then ``t2`` about the
*new* axis ``b``, then ``t3`` about the newest axis ``c``. Hence

.. math::

    C_{BN} = M_c(t_3)\\, M_b(t_2)\\, M_a(t_1), \\qquad
    q_{BN} = q_a(t_1) \\otimes q_b(t_2) \\otimes q_c(t_3),

with ``M_i(t)`` the frame (passive) rotation matrix about axis ``i``, e.g.
``M_1(t) = [[1, 0, 0], [0, cos t, sin t], [0, -sin t, cos t]]``, and
``q_i(t) = [cos(t/2), sin(t/2) e_i]``. This is exactly
``scipy.spatial.transform.Rotation.from_euler("ZYX", angles)`` (upper-case
letters: intrinsic), whose ``as_matrix()`` is ``C_BN.T``. ``"321"`` is
yaw-pitch-roll (``t1`` yaw about z, ``t2`` pitch about y', ``t3`` roll
about x'').

Angle ranges returned by :func:`from_dcm` and :func:`from_quaternion`: the
first and third angles lie in ``(-pi, pi]``; the middle angle lies in
``[-pi/2, pi/2]`` for Tait-Bryan sequences and in ``[0, pi]`` for proper
sequences. Inputs to the other functions may be any finite angles.

Gimbal lock
-----------
The sequence is singular where the first and third axes line up:
``cos(t2) = 0`` for Tait-Bryan and ``sin(t2) = 0`` for proper sequences
(:func:`distance_to_gimbal_lock` returns ``|cos t2|`` or ``|sin t2|``). There
only ``t1 + t3`` or ``t1 - t3`` is defined. :func:`from_dcm` and
:func:`from_quaternion` then return the set with ``t3 = 0`` (whenever the
middle angle is within :data:`LOCK_SNAP_ANGLE` of the singular value), which
reproduces the rotation; they never raise. The angle rates, however, are
unbounded there: :func:`kinematic_matrix` and :func:`angle_rates` raise
:class:`GimbalLockError` when the distance is below a tolerance
(:data:`GIMBAL_LOCK_TOLERANCE` by default). The inverse map
(:func:`body_rate_matrix`, :func:`body_rates`) is always defined (it only
loses rank at gimbal lock) and never raises.

The conversion from a rotation to angles is the quaternion method of
Bernardes and Viollet (2022, PLoS ONE 17(11) e0276302): two ``atan2`` of
quaternion components, well conditioned everywhere, with no ``arcsin``.
Every function accepts leading batch dimensions (``(..., 3)`` angles,
``(..., 4)`` quaternions, ``(..., 3, 3)`` matrices) and never mutates its
inputs.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.validation import as_float_array, check_vector

__all__ = [
    "GIMBAL_LOCK_TOLERANCE",
    "LOCK_SNAP_ANGLE",
    "PROPER_SEQUENCES",
    "SEQUENCES",
    "TAIT_BRYAN_SEQUENCES",
    "GimbalLockError",
    "angle_rates",
    "body_rate_matrix",
    "body_rates",
    "distance_to_gimbal_lock",
    "from_dcm",
    "from_quaternion",
    "is_tait_bryan",
    "kinematic_matrix",
    "to_dcm",
    "to_quaternion",
]

TAIT_BRYAN_SEQUENCES: tuple[str, ...] = ("123", "132", "213", "231", "312", "321")
PROPER_SEQUENCES: tuple[str, ...] = ("121", "131", "212", "232", "313", "323")
SEQUENCES: tuple[str, ...] = TAIT_BRYAN_SEQUENCES + PROPER_SEQUENCES

#: Default smallest accepted ``|cos t2|`` (Tait-Bryan) or ``|sin t2|`` (proper)
#: in the kinematics. The angle rates grow like ``|omega| / distance``, so 1e-6
#: allows rates up to a million times the body rate before refusing; closer to
#: the singularity the rates (and any integration of them) are meaningless.
GIMBAL_LOCK_TOLERANCE = 1e-6

#: Distance [rad] of the middle angle from its singular value below which
#: :func:`from_quaternion` and :func:`from_dcm` report ``t3 = 0``. Exactly
#: singular inputs land within ~5e-16 rad of the singular value after rounding,
#: so 1e-13 catches them with a 200-fold margin; the snap changes the
#: represented rotation by at most about ``2 * LOCK_SNAP_ANGLE`` rad. Farther
#: from the singularity, t1 and t3 are computed normally: each is then accurate
#: only to about 1e-16 / distance, but the set reproduces the rotation to
#: rounding.
LOCK_SNAP_ANGLE = 1e-13

_LETTERS = {"X": "1", "Y": "2", "Z": "3"}


class GimbalLockError(ValueError):
    """Euler-angle rates requested at (or too near) gimbal lock.

    Parameters
    ----------
    message : str
        The error message.
    sequence : str
        The Euler sequence (digits).
    middle_angle : float
        The offending middle angle ``t2`` [rad] (the first one in a batch).

    Attributes
    ----------
    sequence : str
        The Euler sequence (digits).
    middle_angle : float
        The offending middle angle ``t2`` [rad] (the first one in a batch).
    """

    def __init__(self, message: str, sequence: str, middle_angle: float) -> None:
        super().__init__(message)
        self.sequence = sequence
        self.middle_angle = middle_angle


def _parse_sequence(sequence: object) -> tuple[str, tuple[int, int, int]]:
    """Return the digit form and 0-based axes of a validated sequence."""
    if not isinstance(sequence, str):
        raise ValueError(
            f"sequence must be a string such as '321' or 'ZYX', got {sequence!r} of type {type(sequence).__name__}"
        )
    digits = "".join(_LETTERS.get(ch, ch) for ch in sequence)
    if digits not in SEQUENCES:
        hint = ""
        if sequence != sequence.upper() and sequence.upper().translate(str.maketrans(_LETTERS)) in SEQUENCES:
            hint = (
                f" (lower-case letters mean extrinsic rotations in scipy; this module's sequences are intrinsic: "
                f"write {sequence.upper()!r})"
            )
        raise ValueError(
            f"sequence must be one of {', '.join(SEQUENCES)} (or the same in upper-case letters X/Y/Z), "
            f"with no two consecutive axes equal; got {sequence!r}{hint}"
        )
    a, b, c = (int(ch) - 1 for ch in digits)
    return digits, (a, b, c)


def is_tait_bryan(sequence: str) -> bool:
    """True for a Tait-Bryan sequence (three different axes), False for a proper one.

    Parameters
    ----------
    sequence : str
        Axis sequence of three digits, e.g. ``"321"`` or ``"313"``.
    """
    _, (a, _, c) = _parse_sequence(sequence)
    return a != c


def _parity(i: int, j: int, k: int) -> int:
    """+1 if ``e_i x e_j = e_k`` (cyclic order), -1 otherwise (``i, j, k`` distinct)."""
    return 1 if (j - i) % 3 == 1 else -1


def _frame_rotation(axis: int, angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Passive rotation matrices ``M_axis(angle)``, shape ``angle.shape + (3, 3)``."""
    j, k = (axis + 1) % 3, (axis + 2) % 3
    c, s = np.cos(angle), np.sin(angle)
    m = np.zeros((*np.shape(angle), 3, 3))
    m[..., axis, axis] = 1.0
    m[..., j, j] = c
    m[..., k, k] = c
    m[..., j, k] = s
    m[..., k, j] = -s
    return m


def _wrap(angle: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wrap angles [rad] from ``[-2 pi, 2 pi]`` into ``(-pi, pi]``, leaving values inside untouched.

    (A modulo of ``pi - angle`` would round small angles to multiples of ulp(pi) ~ 4e-16.)
    """
    return np.where(angle > np.pi, angle - 2.0 * np.pi, np.where(angle <= -np.pi, angle + 2.0 * np.pi, angle))


def to_dcm(angles: ArrayLike, sequence: str) -> NDArray[np.float64]:
    """Direction cosine matrix ``C_BN = M_c(t3) M_b(t2) M_a(t1)`` of Euler angles.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles ``(t1, t2, t3)`` [rad], any finite values.
    sequence : str
        Axis sequence, e.g. ``"321"`` (see the module docstring).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``C_BN``, mapping inertial components to body components
        (``Rotation.from_euler(sequence_letters, angles).as_matrix().T``).
    """
    _, (a, b, c) = _parse_sequence(sequence)
    t = check_vector(angles, "angles", 3)
    return _frame_rotation(c, t[..., 2]) @ _frame_rotation(b, t[..., 1]) @ _frame_rotation(a, t[..., 0])


def to_quaternion(angles: ArrayLike, sequence: str) -> NDArray[np.float64]:
    """Attitude quaternion ``q_BN = q_a(t1) ⊗ q_b(t2) ⊗ q_c(t3)`` of Euler angles.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles ``(t1, t2, t3)`` [rad], any finite values.
    sequence : str
        Axis sequence, e.g. ``"321"``.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion ``[w, x, y, z]`` (scalar first, not sign-normalised).
    """
    _, axes = _parse_sequence(sequence)
    t = check_vector(angles, "angles", 3)
    out = None
    for n, axis in enumerate(axes):
        half = 0.5 * t[..., n]
        elementary = np.zeros((*half.shape, 4))
        elementary[..., 0] = np.cos(half)
        elementary[..., 1 + axis] = np.sin(half)
        out = elementary if out is None else quat.multiply(out, elementary)
    return out


def from_quaternion(q: ArrayLike, sequence: str) -> NDArray[np.float64]:
    """Euler angles of an attitude quaternion ``q_BN``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Unit quaternion(s) ``[w, x, y, z]`` (``q`` and ``-q`` give the same angles).
    sequence : str
        Axis sequence, e.g. ``"321"``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(t1, t2, t3)`` [rad]: ``t1, t3`` in ``(-pi, pi]``; ``t2`` in
        ``[-pi/2, pi/2]`` (Tait-Bryan) or ``[0, pi]`` (proper). At gimbal lock
        (``t2`` within :data:`LOCK_SNAP_ANGLE` of the singular value) ``t3 = 0``
        and ``t1`` carries the whole rotation about the aligned axes.
        Accuracy is absolute, about 1e-15 rad for ``t2`` and 1e-16 rad /
        :func:`distance_to_gimbal_lock` for ``t1`` and ``t3`` (so tiny angles
        carry no relative precision beyond that).

    Raises
    ------
    ValueError
        If ``q`` is not a finite unit quaternion of shape ``(..., 4)`` or the
        sequence is unknown. Gimbal lock is not an error here.
    """
    _, (a, b, c) = _parse_sequence(sequence)
    q = quat.as_unit_quaternion(q, "q")
    tait_bryan = a != c
    d = c if tait_bryan else 3 - a - b  # the axis completing (a, b, d)
    eps = _parity(a, b, d)
    w, x = q[..., 0], q[..., 1:]
    if tait_bryan:
        # q ⊗ q_b(pi/2) is the proper sequence a-b-a with middle angle t2 + pi/2
        # and third angle -eps * t3 (the factor 1/sqrt(2) cancels in every atan2).
        w, xa, xb, xd = w - x[..., b], x[..., a] - eps * x[..., d], x[..., b] + w, x[..., d] + eps * x[..., a]
    else:
        xa, xb, xd = x[..., a], x[..., b], x[..., d]
    # Proper a-b-a: w = c2 cos(s), x_a = c2 sin(s), x_b = s2 cos(h), eps x_d = s2 sin(h) with
    # c2, s2 = cos(t2/2), sin(t2/2), s = (t1 + t3)/2 and h = (t1 - t3)/2.
    half_sum = np.arctan2(xa, w)
    half_diff = np.arctan2(eps * xd, xb)
    middle = 2.0 * np.arctan2(np.hypot(xb, xd), np.hypot(w, xa))  # in [0, pi]
    near_zero = middle <= LOCK_SNAP_ANGLE
    near_pi = middle >= np.pi - LOCK_SNAP_ANGLE
    locked = near_zero | near_pi
    t1 = np.where(near_zero, 2.0 * half_sum, np.where(near_pi, 2.0 * half_diff, half_sum + half_diff))
    t3 = np.where(locked, 0.0, half_sum - half_diff)
    if tait_bryan:
        middle = middle - 0.5 * np.pi
        t3 = -eps * t3
    return np.stack([_wrap(t1), middle, _wrap(t3) + 0.0], axis=-1)  # + 0.0 turns -0.0 into 0.0


def from_dcm(dcm: ArrayLike, sequence: str) -> NDArray[np.float64]:
    """Euler angles of a direction cosine matrix ``C_BN``.

    The matrix is converted to a quaternion (Shepperd's method, see
    :func:`attitude.quaternion.from_dcm`) and then to angles with
    :func:`from_quaternion`; both steps are well conditioned everywhere.

    Parameters
    ----------
    dcm : array_like, shape (..., 3, 3)
        Proper orthonormal matrix ``C_BN`` (N components to B components).
    sequence : str
        Axis sequence, e.g. ``"321"``.

    Returns
    -------
    ndarray, shape (..., 3)
        ``(t1, t2, t3)`` [rad] in the ranges of :func:`from_quaternion`, with
        ``t3 = 0`` at gimbal lock.

    Raises
    ------
    ValueError
        If ``dcm`` has the wrong shape, is not finite, orthonormal and proper,
        or the sequence is unknown.
    """
    _parse_sequence(sequence)
    return from_quaternion(quat.from_dcm(dcm), sequence)


def distance_to_gimbal_lock(angles: ArrayLike, sequence: str) -> NDArray[np.float64]:
    """Distance from gimbal lock: ``|cos t2|`` (Tait-Bryan) or ``|sin t2|`` (proper).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles [rad].
    sequence : str
        Axis sequence.

    Returns
    -------
    ndarray, shape (...)
        Value in ``[0, 1]``: 1 farthest from and 0 exactly at the singularity.
        The Euler-angle rates scale like ``|omega| / distance``.
    """
    _, (a, _, c) = _parse_sequence(sequence)
    t2 = check_vector(angles, "angles", 3)[..., 1]
    return np.abs(np.cos(t2) if a != c else np.sin(t2))


def body_rate_matrix(angles: ArrayLike, sequence: str) -> NDArray[np.float64]:
    """Matrix ``W`` with ``omega_BN_B = W @ angle_rates``; defined for all angles.

    The columns are the three rotation axes in body components:
    ``W = [M_c(t3) M_b(t2) e_a, M_c(t3) e_b, e_c]``. Its determinant is
    ``+-cos t2`` (Tait-Bryan) or ``-sin t2`` (proper), so ``W`` loses rank at
    gimbal lock but never has unbounded entries.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles [rad].
    sequence : str
        Axis sequence.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``W`` [dimensionless]: maps angle rates [rad/s] to body rates [rad/s].
    """
    _, (a, b, c) = _parse_sequence(sequence)
    t = check_vector(angles, "angles", 3)
    eye = np.eye(3)
    m3 = _frame_rotation(c, t[..., 2])
    u1 = (m3 @ _frame_rotation(b, t[..., 1]))[..., a]  # M_c M_b e_a: column a of the product
    u2 = m3[..., b]
    u3 = np.broadcast_to(eye[c], u2.shape)
    return np.stack([u1, u2, u3], axis=-1)


def _check_tolerance(tolerance: float) -> float:
    tol = as_float_array(tolerance, "tolerance", allow_nonfinite=True)
    if tol.ndim != 0 or not np.isfinite(tol) or not 0.0 < tol < 1.0:
        raise ValueError(f"tolerance must be a finite scalar in (0, 1), got {tolerance!r}")
    return float(tol)


def kinematic_matrix(
    angles: ArrayLike, sequence: str, *, tolerance: float = GIMBAL_LOCK_TOLERANCE
) -> NDArray[np.float64]:
    """Matrix ``B`` of the Euler-angle kinematics: ``angle_rates = B @ omega_BN_B``.

    ``B`` is the inverse of :func:`body_rate_matrix`, computed from the cross
    products of its columns divided by its determinant (``+-cos t2`` or
    ``-sin t2``).

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles [rad].
    sequence : str
        Axis sequence.
    tolerance : float, optional
        Smallest accepted :func:`distance_to_gimbal_lock`, in ``(0, 1)``
        (default :data:`GIMBAL_LOCK_TOLERANCE`).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``B`` [dimensionless]: maps body rates [rad/s] to angle rates [rad/s].
        Its entries are of order ``1 / distance``.

    Raises
    ------
    GimbalLockError
        If any set has ``|cos t2|`` (Tait-Bryan) or ``|sin t2|`` (proper) below
        ``tolerance``.
    """
    digits, (a, _, c) = _parse_sequence(sequence)
    tol = _check_tolerance(tolerance)
    t = check_vector(angles, "angles", 3)
    distance = distance_to_gimbal_lock(t, digits)
    bad = distance < tol
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if bad.ndim else ()
        t2 = float(t[index][1])
        where = ", ".join(str(i) for i in (*index, 1))
        kind, rule = ("Tait-Bryan", "|cos(t2)|") if a != c else ("proper", "|sin(t2)|")
        raise GimbalLockError(
            f"sequence {digits!r} is at gimbal lock: middle angle angles[{where}] = {t2!r} rad gives "
            f"{rule} = {float(distance[index]):.3g} < tolerance {tol:g}; the Euler-angle rates of a {kind} sequence "
            f"need {rule} >= tolerance (use quaternions, or another sequence, near this attitude)",
            digits,
            t2,
        )
    w = body_rate_matrix(t, digits)
    u1, u2, u3 = w[..., 0], w[..., 1], w[..., 2]
    det = np.sum(u1 * np.cross(u2, u3), axis=-1)
    rows = np.stack([np.cross(u2, u3), np.cross(u3, u1), np.cross(u1, u2)], axis=-2)
    return rows / det[..., None, None]


def angle_rates(
    angles: ArrayLike, omega: ArrayLike, sequence: str, *, tolerance: float = GIMBAL_LOCK_TOLERANCE
) -> NDArray[np.float64]:
    """Euler-angle rates ``B(angles) @ omega`` [rad/s].

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles [rad].
    omega : array_like, shape (..., 3)
        Angular velocity of B relative to N in body components [rad/s];
        broadcast against ``angles``.
    sequence : str
        Axis sequence.
    tolerance : float, optional
        See :func:`kinematic_matrix`.

    Raises
    ------
    GimbalLockError
        Near gimbal lock (see :func:`kinematic_matrix`).
    """
    omega = check_vector(omega, "omega", 3)
    return (kinematic_matrix(angles, sequence, tolerance=tolerance) @ omega[..., None])[..., 0]


def body_rates(angles: ArrayLike, rates: ArrayLike, sequence: str) -> NDArray[np.float64]:
    """Body angular velocity ``omega_BN_B = W(angles) @ rates`` [rad/s]; never raises at gimbal lock.

    Parameters
    ----------
    angles : array_like, shape (..., 3)
        Euler angles [rad].
    rates : array_like, shape (..., 3)
        Euler-angle rates [rad/s]; broadcast against ``angles``.
    sequence : str
        Axis sequence.
    """
    rates = check_vector(rates, "rates", 3)
    return (body_rate_matrix(angles, sequence) @ rates[..., None])[..., 0]

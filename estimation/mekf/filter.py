"""Multiplicative extended Kalman filter (MEKF) for attitude and gyro bias.

The filter of Markley and Crassidis (*Fundamentals of Spacecraft Attitude
Determination and Control*, 2014, ch. 6) and Crassidis and Junkins
(*Optimal Estimation of Dynamic Systems*, 2nd ed., sec. 7.2): the reference
quaternion ``q_hat`` (``q_BN``) and gyro bias ``b_hat`` [rad/s] live outside
the Kalman state, whose six components are the error ``[delta_theta [rad],
delta_b [rad/s]]``; gyro samples propagate it, star-tracker samples update
it behind an innovation gate, and each update is followed by a reset.
Vector measurements (:class:`attitude.simulation.protocols.VectorMeasurement`:
a Sun sensor, a magnetometer with its field model) update it the same way,
one at a time, with ``H = [[b_hat x] 0]`` projected on the plane
perpendicular to the predicted vector ``b_hat = A(q_hat) r_N`` (2 degrees of
freedom), so the filter runs on any subset of tracker and vectors.

The batch (:mod:`estimation.mekf.batch`), the runner over recorded
histories (:mod:`estimation.mekf.runner`) and the steady state
(:mod:`estimation.mekf.steady_state`) live beside this module.

See docs/mekf.md for the derivation (propagation, update, gate, gyro
sampling, batches, the steady-state formula and its references).
"""

from __future__ import annotations

import copy
import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from filterpy.kalman import KalmanFilter
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.rigid_body import skew
from attitude.sensors import Gyro, StarTracker, farrenkopf_process_noise
from attitude.simulation.protocols import Estimate, VectorMeasurement
from attitude.validation import as_float_array, check_covariance, check_positive, finite_floats, positive_scalar
from estimation.consistency import GATE_PROBABILITY, NIS_CAP, NisHealth, gate_threshold, nis_health

__all__ = [
    "MEASUREMENT_MATRIX",
    "MEKF",
    "attitude_residual",
    "compose_rotation_vector",
    "error_transition",
    "initial_covariance",
    "process_noise",
    "transition_matrix",
    "vector_update_model",
]

_I3 = np.eye(3)
#: Tracker measurement matrix ``H = [I 0]`` of the error state ``[delta_theta, delta_b]``.
MEASUREMENT_MATRIX = np.hstack([_I3, np.zeros((3, 3))])
MEASUREMENT_MATRIX.flags.writeable = False
_RESETS = ("first_order", "second_order")
#: Steps whose process noise a filter keeps (the engine's ticks differ by a handful of distinct floats).
_Q_CACHE_SIZE = 64
#: Accepted deviation of a tracker quaternion's norm from 1 (that of attitude.quaternion).
_UNIT_TOL = quat.UNIT_NORM_TOLERANCE
_COUNT_KEYS = (
    "steps",
    "updates",
    "tracker_missing",
    "tracker_nan",
    "tracker_gated",
    "gyro_missing",
    "gyro_nan",
    "gyro_rejected",
    "vector_updates",
    "vector_nan",
    "vector_gated",
)


# ---------------------------------------------------------------------------
# Small batch-aware helpers (no validation: internal hot path; tested against attitude.quaternion)


def _cols(x: NDArray[np.float64]) -> list:
    return [x[..., i] for i in range(x.shape[-1])]


def _stack(parts: list) -> NDArray[np.float64]:
    return np.stack(np.broadcast_arrays(*parts), axis=-1)


def _qmul(p: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``p ⊗ q`` (..., 4) by the one definition in :mod:`attitude.quaternion` (no checks)."""
    return _stack(quat.multiply_components(_cols(p), _cols(q)))


def _conj(q: NDArray[np.float64]) -> NDArray[np.float64]:
    return _stack(quat.conjugate_components(_cols(q)))


def _exp_rotvec(phi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit quaternion of the rotation vector ``phi`` [rad] (..., 3)."""
    return _stack(quat.exp_rotation_vector_components(_cols(phi)))


def _log_rotvec(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation vector [rad] of the unit quaternion ``q`` on the shortest way (``|phi| <= pi``)."""
    sign = np.where(q[..., :1] < 0.0, -1.0, 1.0)
    return 2.0 * _stack(quat.log_vector_components(_cols(sign * q)))


def _normalize(q: NDArray[np.float64]) -> NDArray[np.float64]:
    return q / np.sqrt(np.sum(q * q, axis=-1, keepdims=True))


def _compose_floats(q: list[float], phi: list[float]) -> list[float]:
    """``normalise(q ⊗ exp(phi / 2))`` for one quaternion (4) and rotation vector (3) of Python floats."""
    dq = quat.exp_rotation_vector_components(phi)  # Python floats: the math module's sin and cos
    w, x, y, z = quat.multiply_components(q, dq)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return [w / n, x / n, y / n, z / n]


def _compose_one(q: NDArray[np.float64], phi: NDArray[np.float64]) -> NDArray[np.float64]:
    """``normalise(q ⊗ exp(phi / 2))`` for one quaternion (4,) and rotation vector (3,)."""
    return np.array(_compose_floats([float(c) for c in q], [float(phi[0]), float(phi[1]), float(phi[2])]))


def _residual_floats(q_ref: list[float], q: list[float]) -> list[float]:
    """:func:`attitude_residual` of one pair of unit quaternions of Python floats [rad] (the per-step path)."""
    w, x, y, z = quat.multiply_components(quat.conjugate_components(q_ref), q)
    if w < 0.0:  # the shortest way
        w, x, y, z = -w, -x, -y, -z
    vn = math.hypot(x, y, z)
    if vn == 0.0:
        return [0.0, 0.0, 0.0]  # w > 0 here (unit q): no rotation
    scale = 2.0 * math.atan2(vn, w) / vn
    return [scale * x, scale * y, scale * z]


def _inverse_3x3_array(s: NDArray[np.float64]) -> NDArray[np.float64]:
    """:func:`_inverse_3x3` of a (3, 3) array (filterpy's ``inv`` for the tracker update)."""
    return np.array(_inverse_3x3(s.tolist()))


def _inverse_3x3(s: list[list[float]]) -> list[list[float]]:
    """Inverse of a symmetric positive-definite 3 x 3 matrix of Python floats, by its cofactors.

    For the innovation covariance ``P_att + R`` (``R`` positive definite, so ``S`` is
    well conditioned): the cofactor formula rounds to a few ulps of ``numpy.linalg.inv``'s
    LU solution there (tests/estimation/mekf/test_filter.py).
    """
    (a, b, c), (d, e, f), (g, h, i) = s
    c00, c01, c02 = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * c00 + b * c01 + c * c02
    return [
        [c00 / det, (c * h - b * i) / det, (b * f - c * e) / det],
        [c01 / det, (a * i - c * g) / det, (c * d - a * f) / det],
        [c02 / det, (b * g - a * h) / det, (a * e - b * d) / det],
    ]


def compose_rotation_vector(q: NDArray[np.float64], phi: NDArray[np.float64]) -> NDArray[np.float64]:
    """``normalise(q ⊗ exp(phi / 2))`` for quaternions (..., 4) and rotation vectors [rad] (..., 3).

    The propagation and reset step of the filter on a runs axis (no checks: hot path).

    Parameters
    ----------
    q : ndarray (..., 4)
        Attitudes ``q_BN``, unit norm.
    phi : ndarray (..., 3)
        Rotation vectors in body axes [rad].

    Returns
    -------
    ndarray (..., 4)
        The composed, renormalised attitudes.
    """
    return _normalize(_qmul(q, _exp_rotvec(phi)))


def attitude_residual(q_ref: NDArray[np.float64], q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``rotvec(q_ref* ⊗ q)`` [rad] (..., 3) on the shortest way: the MEKF attitude residual / error (no checks).

    Parameters
    ----------
    q_ref : ndarray (..., 4)
        Reference (estimated) attitudes ``q_BN``, unit norm.
    q : ndarray (..., 4)
        Measured or true attitudes ``q_BN``, unit norm.

    Returns
    -------
    ndarray (..., 3)
        Rotation vectors [rad] in body axes, ``|phi| <= pi``.
    """
    return _log_rotvec(_qmul(_conj(q_ref), q))


def transition_matrix(omega: ArrayLike, dt: ArrayLike) -> NDArray[np.float64]:
    """Error-state transition ``Phi = expm([[-[w x], -I], [0, 0]] dt)`` in closed form, shape (..., 6, 6).

    Parameters
    ----------
    omega : array_like (..., 3)
        Estimated body rate ``w = omega_meas - b_hat`` [rad/s], constant over the step.
    dt : float or array_like (...)
        Step [s] (>= 0).

    Returns
    -------
    ndarray (..., 6, 6)
        ``[[Phi11, Phi12], [0, I]]`` with ``Phi11 = exp(-[w x] dt)`` (the
        transpose of the rotation over the step) and ``Phi12 = -int_0^dt
        exp(-[w x] s) ds`` (module docstring).
    """
    w = as_float_array(omega, "omega")
    if w.ndim == 0 or w.shape[-1] != 3:
        raise ValueError(f"omega must have shape (..., 3), got shape {w.shape}")
    h = check_positive(dt, "dt", allow_zero=True)
    return error_transition(w, h)


def error_transition(w: NDArray[np.float64], dt: Any) -> NDArray[np.float64]:
    """:func:`transition_matrix` without the argument checks (the batch hot path).

    Parameters
    ----------
    w : ndarray (..., 3)
        Estimated body rate ``omega_meas - b_hat`` [rad/s], constant over the step.
    dt : float or ndarray (...)
        Step [s].

    Returns
    -------
    ndarray (..., 6, 6)
        The error-state transition matrix.
    """
    dt = np.asarray(dt, dtype=np.float64)
    wn = np.sqrt(np.sum(w * w, axis=-1))
    a = wn * dt
    small = a < 1e-2
    sa = np.where(small, 1.0, a)
    # Coefficients in units of dt: sin(a)/a, (1 - cos a)/a^2, (a - sin a)/a^3. Series below a = 1e-2
    # (first dropped terms a^6/5040, a^6/40320, a^6/362880 < 2e-16 relative there); (1 - cos a)
    # as 2 sin^2(a/2) has no cancellation.
    c1 = np.where(small, 1.0 - a**2 / 6.0 + a**4 / 120.0, np.sin(sa) / sa)
    c2 = np.where(small, 0.5 - a**2 / 24.0 + a**4 / 720.0, 2.0 * np.sin(0.5 * sa) ** 2 / sa**2)
    c3 = np.where(small, 1.0 / 6.0 - a**2 / 120.0 + a**4 / 5040.0, (sa - np.sin(sa)) / sa**3)
    k = skew(w * dt[..., None])  # [w x] dt
    k2 = k @ k
    d = dt[..., None, None]
    phi11 = _I3 - c1[..., None, None] * k + c2[..., None, None] * k2
    phi12 = d * (-_I3 + c2[..., None, None] * k - c3[..., None, None] * k2)
    out = np.zeros((*np.broadcast_shapes(w.shape[:-1], dt.shape), 6, 6))
    out[..., :3, :3] = phi11
    out[..., :3, 3:] = phi12
    out[..., 3:, 3:] = _I3
    return out


def _transition_one(w: Any, dt: float) -> NDArray[np.float64]:
    """:func:`error_transition` for one rate (3) and a scalar step, in Python floats (the per-step path).

    With ``k = w dt = (x, y, z)``, ``[k x]^2 = k k^T - |k|^2 I`` written out, so
    ``Phi11 = I - c1 [k x] + c2 [k x]^2`` and ``Phi12 = dt (-I + c2 [k x] - c3 [k x]^2)``
    take a few dozen multiplications instead of numpy's small-matrix calls.
    """
    x, y, z = float(w[0]) * dt, float(w[1]) * dt, float(w[2]) * dt
    xx, yy, zz = x * x, y * y, z * z
    a = math.sqrt(xx + yy + zz)
    if a < 1e-2:
        a2 = a * a
        c1 = 1.0 - a2 / 6.0 + a2 * a2 / 120.0
        c2 = 0.5 - a2 / 24.0 + a2 * a2 / 720.0
        c3 = 1.0 / 6.0 - a2 / 120.0 + a2 * a2 / 5040.0
    else:
        c1 = math.sin(a) / a
        c2 = 2.0 * math.sin(0.5 * a) ** 2 / (a * a)
        c3 = (a - math.sin(a)) / a**3
    xy, xz, yz = x * y, x * z, y * z
    return np.array(
        [
            [1.0 - c2 * (yy + zz), c1 * z + c2 * xy, c2 * xz - c1 * y,
             dt * (c3 * (yy + zz) - 1.0), -dt * (c2 * z + c3 * xy), dt * (c2 * y - c3 * xz)],
            [c2 * xy - c1 * z, 1.0 - c2 * (xx + zz), c1 * x + c2 * yz,
             dt * (c2 * z - c3 * xy), dt * (c3 * (xx + zz) - 1.0), -dt * (c2 * x + c3 * yz)],
            [c1 * y + c2 * xz, c2 * yz - c1 * x, 1.0 - c2 * (xx + yy),
             -dt * (c2 * y + c3 * xz), dt * (c2 * x - c3 * yz), dt * (c3 * (xx + yy) - 1.0)],
            [0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        ]
    )  # fmt: skip


def process_noise(*, sigma_v: float, sigma_u: float, dt: float) -> NDArray[np.float64]:
    """Discrete process noise (6, 6) of ``[delta_theta, delta_b]`` over ``dt`` [s].

    The formula of :meth:`attitude.sensors.Gyro.process_noise` (Crassidis and
    Junkins, sec. 7.2.1) for ``sigma_v`` [rad/s^0.5] and ``sigma_u``
    [rad/s^1.5]: ``[[(sv^2 dt + su^2 dt^3/3) I, -(su^2 dt^2/2) I],
    [-(su^2 dt^2/2) I, su^2 dt I]]``.

    Parameters
    ----------
    sigma_v : float
        Angle random walk [rad/s^0.5].
    sigma_u : float
        Rate random walk [rad/s^1.5].
    dt : float
        Propagation interval [s].
    """
    sv = float(check_positive(sigma_v, "sigma_v", allow_zero=True))
    su = float(check_positive(sigma_u, "sigma_u", allow_zero=True))
    h = float(check_positive(dt, "dt", allow_zero=True))
    # The one definition of the Farrenkopf discrete process noise lives with the gyro model.
    return farrenkopf_process_noise(sv * sv, su * su, h)


def initial_covariance(*, attitude_sigma: float, bias_sigma: float) -> NDArray[np.float64]:
    """Diagonal initial covariance (6, 6) from per-axis standard deviations.

    Parameters
    ----------
    attitude_sigma : float
        Initial attitude error per axis [rad] (> 0).
    bias_sigma : float
        Initial gyro bias error per axis [rad/s] (> 0).
    """
    a = positive_scalar(attitude_sigma, "attitude_sigma")
    b = positive_scalar(bias_sigma, "bias_sigma")
    return np.diag([a**2] * 3 + [b**2] * 3)


def _vector_basis(q_hat: list[float], m: VectorMeasurement) -> tuple[list[float], list[float], list[float], float]:
    """Residual ``[z0, z1]``, basis rows ``t1``, ``t2`` and ``b . b_hat`` of one vector sample, in Python floats.

    The attitude Jacobian is ``h = [-t2; t1]`` (the hot path of the filter reads the floats).
    """
    # b_hat = C_BN(q_hat) r_N, by the one rotation of attitude.quaternion (on Python floats).
    p0, p1, p2 = quat.rotate_inverse_components(q_hat, m.reference_N.tolist())
    # t1 = b_hat x e / |.|, e the axis least aligned with b_hat (|b_hat x e| >= sqrt(2/3): no cancellation);
    # t2 = b_hat x t1, so (t1, t2, b_hat) is right-handed and orthonormal.
    a0, a1, a2 = abs(p0), abs(p1), abs(p2)
    if a0 <= a1 and a0 <= a2:
        u0, u1, u2 = 0.0, p2, -p1
    elif a1 <= a2:
        u0, u1, u2 = -p2, 0.0, p0
    else:
        u0, u1, u2 = p1, -p0, 0.0
    n = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
    u0, u1, u2 = u0 / n, u1 / n, u2 / n
    v0, v1, v2 = p1 * u2 - p2 * u1, p2 * u0 - p0 * u2, p0 * u1 - p1 * u0
    b0, b1, b2 = m.vector_B.tolist()
    # z = T (b - b_hat) = T b, since T b_hat = 0; T [b_hat x] has the rows t1 x b_hat = -t2 and t2 x b_hat = t1.
    z = [u0 * b0 + u1 * b1 + u2 * b2, v0 * b0 + v1 * b1 + v2 * b2]
    return z, [u0, u1, u2], [v0, v1, v2], p0 * b0 + p1 * b1 + p2 * b2


def _vector_noise(m: VectorMeasurement, t1: list[float], t2: list[float]) -> NDArray[np.float64]:
    """The noise ``R = T R3 T^T`` (2, 2) of the residual, ``T = [t1; t2]``."""
    if m.covariance is None:
        s2 = m.sigma * m.sigma  # T sigma^2 (I - b b^T) T^T = sigma^2 I, exactly, with b the predicted vector
        return np.array([[s2, 0.0], [0.0, s2]])
    tt = np.array([t1, t2])
    return tt @ m.covariance @ tt.T


def _vector_model(
    q_hat: NDArray[np.float64], m: VectorMeasurement
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]:
    """Residual (2,), attitude Jacobian (2, 3), noise (2, 2) and ``b . b_hat`` of one vector sample."""
    z, t1, t2, cosine = _vector_basis(q_hat.tolist(), m)
    return np.array(z), np.array([[-c for c in t2], t1]), _vector_noise(m, t1, t2), cosine


def vector_update_model(
    q_hat: ArrayLike, measurement: VectorMeasurement
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The MEKF's linearised model of one vector measurement at the attitude estimate ``q_hat``.

    With ``b_hat = A(q_hat) r_N`` the predicted unit vector and ``T`` (2, 3)
    an orthonormal basis of the plane perpendicular to it, the residual is
    ``z = T (b - b_hat) = T b``, the Jacobian of ``b`` with respect to the
    error state is ``[[b_hat x] 0]`` (Markley and Crassidis 2014, sec. 6.2;
    Crassidis and Junkins, sec. 7.2), projected ``H = T [[b_hat x] 0]``, and
    the noise ``R = T R3 T^T`` (``sigma^2 I`` for the QUEST model). See
    docs/mekf.md, "Vector measurements".

    Parameters
    ----------
    q_hat : array_like (4,)
        Attitude estimate ``q_BN`` (unit norm).
    measurement : VectorMeasurement
        The sample.

    Returns
    -------
    z : ndarray (2,)
        Residual [rad].
    H : ndarray (2, 6)
        Measurement matrix of ``[delta_theta, delta_b]``.
    R : ndarray (2, 2)
        Noise covariance of ``z`` [rad^2].
    """
    q = quat.as_unit_quaternion(q_hat, "q_hat")
    if q.shape != (4,):
        raise ValueError(f"q_hat must have shape (4,), got shape {q.shape}")
    m = _as_vector_measurement(measurement, "measurement")
    if not m.valid:
        raise ValueError(f"measurement.vector_B must be finite, got {m.vector_B.tolist()!r}")
    z, h, r, _ = _vector_model(q, m)
    return z, np.hstack([h, np.zeros((2, 3))]), r


# ---------------------------------------------------------------------------
# Validation


def _as_vector_measurement(sample: Any, name: str) -> VectorMeasurement:
    if isinstance(sample, VectorMeasurement):
        return sample
    if isinstance(sample, Mapping):
        unknown = set(sample) - {"vector_B", "reference_N", "sigma", "covariance"}
        if unknown or "vector_B" not in sample or "reference_N" not in sample:
            raise ValueError(
                f"vector measurement {name!r} must have the keys vector_B, reference_N and one of sigma and "
                f"covariance, got keys {sorted(sample)}"
            )
        try:
            return VectorMeasurement(**sample)
        except ValueError as err:
            raise ValueError(f"vector measurement {name!r}: {err}") from None
    raise ValueError(
        f"vector measurement {name!r} must be an attitude.simulation.protocols.VectorMeasurement, a mapping with "
        f"its fields, or None; got {type(sample).__name__}"
    )


def _check_name(value: Any, name: str) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"{name} must be a non-empty string, got {value!r}")
    return value


# ---------------------------------------------------------------------------
# The filter


class MEKF:
    """Multiplicative EKF: attitude ``q_BN`` and gyro bias from a gyro, a star tracker and vector sensors.

    See the module docstring for the equations. The object is also an
    estimator for :func:`attitude.simulation.engine.simulate`: :attr:`period` (the
    gyro period) and :meth:`update` ``(t, measurements) -> Estimate``; the
    controller then sees ``q_hat`` and ``omega_hat = omega_meas - b_hat``.

    Handling of imperfect input (documented behaviour, all counted in
    :attr:`counts` and :meth:`log`):

    - a missing tracker sample (None, e.g. Sun blinding, or a slower tracker
      than the gyro): propagate only;
    - a tracker sample with any NaN: skipped (no update), counted as
      ``tracker_nan``; it never reaches the state;
    - a tracker sample whose NIS exceeds the innovation gate: rejected (no
      update), counted as ``tracker_gated``, its NIS kept in the history
      (module docstring);
    - a missing (None) or NaN gyro sample: the last valid gyro sample is held
      over the interval (zero rate before the first one); NaN samples are
      counted as ``gyro_nan``, samples with a component above
      ``gyro_rate_max`` as ``gyro_rejected``. The held rate's error is not in
      ``Q``: a long gyro outage makes the filter over-confident, which the
      counts and the NIS reveal;
    - vector samples (:class:`attitude.simulation.protocols.VectorMeasurement`
      or a mapping of its fields, read under ``vector_names``): each applied
      in turn after the tracker, with its own reset and gate (2 degrees of
      freedom); None: absent; a non-finite ``vector_B``: skipped, counted as
      ``vector_nan``; above the gate, or more than 90 deg from its prediction
      (where the projected residual cannot tell a reversed vector from a good
      one): rejected, counted as ``vector_gated``.
      Any subset of tracker and vectors may be present at a step (a tracker
      blinded or in eclipse, a Sun sensor in eclipse);
    - a time that goes backwards raises ValueError (a repeated time
      propagates nothing and may still update);
    - a finite tracker quaternion whose norm differs from 1 by more than
      1e-6, or samples of the wrong shape, raise ValueError (input
      corruption the filter cannot interpret). Every check runs before the
      state changes.

    Parameters
    ----------
    sigma_v : float
        Gyro angle-random-walk density [rad/s^0.5] (> 0).
    sigma_u : float
        Gyro rate-random-walk density [rad/s^1.5] (> 0; a constant bias is
        modelled with a small value: with zero the bias covariance collapses
        and the filter stops learning the bias).
    tracker_covariance : array_like (3, 3)
        Covariance of the tracker's error rotation vector in body axes
        [rad^2] (:attr:`attitude.sensors.StarTracker.covariance_B`);
        symmetric positive definite.
    period : float
        Gyro (and propagation) period [s] (> 0): the estimator period for the engine.
    q0 : array_like (4,)
        Initial attitude estimate ``q_BN`` (unit norm).
    P0 : array_like (6, 6)
        Initial error covariance [rad^2, rad^2/s, rad^2/s^2], symmetric
        positive definite (see :func:`initial_covariance`).
    bias0 : array_like (3,) or float
        Initial gyro bias estimate [rad/s].
    t0 : float, optional
        Time [s] of ``q0`` and ``P0``; default: the first :meth:`update`'s time
        (no propagation on that call).
    covariance_reset : {"first_order", "second_order"}
        Covariance reset Jacobian after each update (module docstring).
    gyro_name, tracker_name : str
        Keys of the gyro and tracker samples in the measurements (the
        sensors' ``name``).
    vector_names : sequence of str, optional
        Keys of the vector samples in the measurements (e.g.
        ``("sun_sensor", "magnetometer")``), applied in this order.
    gate_probability : float or None
        Probability of the innovation gate, in (0, 1) (module docstring);
        default ``1 - 1e-9``; None disables the gate.
    gyro_rate_max : float, optional
        Largest plausible gyro component [rad/s] (> 0); default
        ``pi / period``. Larger samples are rejected like NaN ones.

    Raises
    ------
    ValueError
        For non-positive or non-finite noise figures or period, a covariance
        that is not symmetric positive definite, a non-unit ``q0``, an
        unknown reset option, empty names or invalid gate settings.
    """

    def __init__(
        self,
        *,
        sigma_v: float,
        sigma_u: float,
        tracker_covariance: ArrayLike,
        period: float,
        q0: ArrayLike,
        P0: ArrayLike,
        bias0: ArrayLike = 0.0,
        t0: float | None = None,
        covariance_reset: str = "first_order",
        gyro_name: str = "gyro",
        tracker_name: str = "star_tracker",
        gate_probability: float | None = GATE_PROBABILITY,
        gyro_rate_max: float | None = None,
        vector_names: Sequence[str] = (),
    ) -> None:
        self.sigma_v = positive_scalar(sigma_v, "sigma_v")
        su = as_float_array(sigma_u, "sigma_u")
        if su.ndim != 0 or su <= 0:
            raise ValueError(
                f"sigma_u must be strictly positive [rad/s^1.5] (for a constant bias use a small value: with 0 the "
                f"bias covariance collapses and the filter stops learning the bias), got {su.tolist()!r}"
            )
        self.sigma_u = float(su)
        self.tracker_covariance = check_covariance(tracker_covariance, "tracker_covariance", 3)
        self.tracker_covariance.flags.writeable = False
        self.period = positive_scalar(period, "period")
        q = quat.as_unit_quaternion(q0, "q0")
        if q.shape != (4,):
            raise ValueError(f"q0 must have shape (4,), got shape {q.shape}")
        b = as_float_array(bias0, "bias0")
        if b.ndim > 1 or (b.ndim == 1 and b.size != 3):
            raise ValueError(f"bias0 must be a scalar or have shape (3,), got shape {b.shape}")
        p0 = check_covariance(P0, "P0", 6)
        if covariance_reset not in _RESETS:
            raise ValueError(f"covariance_reset must be one of {_RESETS}, got {covariance_reset!r}")
        self.covariance_reset = covariance_reset
        self.gyro_name = _check_name(gyro_name, "gyro_name")
        self.tracker_name = _check_name(tracker_name, "tracker_name")
        if isinstance(vector_names, str):
            raise ValueError(f"vector_names must be a sequence of names, not one string, got {vector_names!r}")
        self._names_checked = False  # update() warns once about vector names no sensor provides
        self.vector_names = tuple(_check_name(v, "vector_names[]") for v in vector_names)
        taken = {self.gyro_name, self.tracker_name}
        if len(set(self.vector_names)) != len(self.vector_names) or taken & set(self.vector_names):
            raise ValueError(
                f"vector_names must be distinct and differ from gyro_name and tracker_name, got {self.vector_names!r}"
            )
        if t0 is not None:
            t0 = float(as_float_array(t0, "t0"))
        if gate_probability is None:
            self.gate_probability = None
            #: The NIS gate ``chi2.ppf(gate_probability, 3)`` (inf when disabled).
            self.gate_threshold = math.inf
            self.vector_gate_threshold = math.inf
        else:
            gp = as_float_array(gate_probability, "gate_probability")
            if gp.ndim != 0 or not 0.0 < float(gp) < 1.0:
                raise ValueError(f"gate_probability must be a scalar in (0, 1) or None, got {gp.tolist()!r}")
            self.gate_probability = float(gp)
            self.gate_threshold = gate_threshold(self.gate_probability, 3)
            #: The vector-sample gate ``chi2.ppf(gate_probability, 2)`` (the residual's 2 components).
            self.vector_gate_threshold = gate_threshold(self.gate_probability, 2)
        #: Largest accepted gyro component [rad/s].
        self.gyro_rate_max = (
            math.pi / self.period if gyro_rate_max is None else positive_scalar(gyro_rate_max, "gyro_rate_max")
        )

        self._q = q.copy()
        self._b = np.array(np.broadcast_to(b, (3,)), dtype=np.float64)
        kf = KalmanFilter(dim_x=6, dim_z=3)
        kf.x = np.zeros(6)  # 1-D: filterpy keeps x's shape and reshapes z to (3,)
        kf.P = p0.copy()
        kf.H = MEASUREMENT_MATRIX.copy()
        kf.R = self.tracker_covariance.copy()
        kf.inv = _inverse_3x3_array  # S is 3 x 3: its cofactors cost less than numpy.linalg.inv's call
        self._kf = kf
        self._q_cache: dict[float, NDArray[np.float64]] = {}
        self._t: float | None = t0
        self._last_gyro: NDArray[np.float64] | None = None
        self._last_nis = np.nan
        self._last_vector_nis: dict[str, float] = {}
        self._last_gated = False
        self._last_innovation = np.full(3, np.nan)
        self._last_S = np.full((3, 3), np.nan)
        self._nis_t: list[float] = []
        self._nis: list[float] = []
        self._counts = dict.fromkeys(_COUNT_KEYS, 0)
        self._vnis_t: list[float] = []
        self._vnis_name: list[str] = []
        self._vnis: list[float] = []

    @classmethod
    def from_sensors(
        cls,
        gyro: Gyro,
        tracker: StarTracker,
        *,
        q0: ArrayLike,
        P0: ArrayLike,
        bias0: ArrayLike = 0.0,
        sampling_check: str = "warn",
        **kwargs: Any,
    ) -> MEKF:
        """A filter matched to a gyro and a tracker: their noise figures, period and names.

        ``sigma_v``, ``sigma_u`` (:attr:`attitude.sensors.Gyro.filter_sigma_u`:
        the rate random walk plus the random walk that bounds a Gauss-Markov
        bias), ``period`` and ``gyro_name`` come from
        ``gyro``, ``tracker_covariance`` (:attr:`StarTracker.covariance_B`)
        and ``tracker_name`` from ``tracker``; other keywords go to the
        constructor. A gyro with ``sigma_u = 0`` (constant bias) is refused
        (see the class); build the filter with a small ``sigma_u`` instead.

        The propagation takes a gyro sample as the mean rate over the
        interval, so ``gyro.sampling`` must be ``"mean"``; on a mismatch
        ``sampling_check`` ``"warn"`` (default) emits a
        :class:`attitude.sensors.GyroSamplingWarning`, ``"raise"`` raises
        ValueError and ``"ignore"`` accepts it (for samples that are not
        this gyro's own, e.g. interval-mean rates generated separately).
        Another object with ``sigma_v``, ``sigma_u``, ``period`` and ``name``
        is accepted unchecked, as before.

        Parameters
        ----------
        gyro : Gyro
            The gyro (``sampling="mean"``, ``sigma_u > 0``).
        tracker : StarTracker
            The star tracker.
        q0 : array_like (4,)
            Initial attitude estimate ``q_BN`` (unit norm).
        P0 : array_like (6, 6)
            Initial error covariance [rad^2, rad^2/s, rad^2/s^2].
        bias0 : array_like (3,) or float, optional
            Initial gyro bias estimate [rad/s].
        sampling_check : {"warn", "raise", "ignore"}, optional
            What a gyro that does not sample interval means does.
        **kwargs
            Other keywords of the constructor.
        """
        if isinstance(gyro, Gyro):
            gyro.check_sampling("mean", consumer="MEKF.from_sensors", action=sampling_check)
        elif not all(hasattr(gyro, a) for a in ("sigma_v", "sigma_u", "period", "name")):
            raise ValueError(f"gyro must be an attitude.sensors.Gyro (or have its noise figures), got {gyro!r}")
        return cls(
            sigma_v=gyro.sigma_v,
            # A Gauss-Markov bias (the bias instability) enters as its bounding random walk.
            sigma_u=gyro.filter_sigma_u if isinstance(gyro, Gyro) else gyro.sigma_u,
            tracker_covariance=tracker.covariance_B,
            period=gyro.period,
            q0=q0,
            P0=P0,
            bias0=bias0,
            gyro_name=gyro.name,
            tracker_name=tracker.name,
            **kwargs,
        )

    def __repr__(self) -> str:
        return (
            f"MEKF(sigma_v={self.sigma_v:.4g} rad/s^0.5, sigma_u={self.sigma_u:.4g} rad/s^1.5, "
            f"period={self.period:g} s, t={self._t!r}, updates={self._counts['updates']})"
        )

    # -- state ----------------------------------------------------------------------

    @property
    def q(self) -> NDArray[np.float64]:
        """Attitude estimate ``q_BN`` (4,) (a copy)."""
        return self._q.copy()

    @property
    def bias(self) -> NDArray[np.float64]:
        """Gyro bias estimate [rad/s] (3,) (a copy)."""
        return self._b.copy()

    @property
    def P(self) -> NDArray[np.float64]:
        """Error covariance (6, 6) of ``[delta_theta, delta_b]`` (a copy)."""
        return self._kf.P.copy()

    @property
    def t(self) -> float | None:
        """Time [s] of the estimate (None before the first update without ``t0``)."""
        return self._t

    @property
    def omega(self) -> NDArray[np.float64]:
        """Rate estimate ``omega_meas - b_hat`` [rad/s] from the last valid gyro sample (zeros before one)."""
        if self._last_gyro is None:
            return np.zeros(3)
        return self._last_gyro - self._b

    @property
    def counts(self) -> dict[str, int]:
        """Steps, updates, missing/NaN/gated tracker samples, missing/NaN/rejected gyro samples."""
        return dict(self._counts)

    @property
    def held_gyro(self) -> NDArray[np.float64] | None:
        """The last valid gyro sample [rad/s] (3,), held over missing ones (a copy; None before the first)."""
        return None if self._last_gyro is None else self._last_gyro.copy()

    @property
    def last_innovation(self) -> NDArray[np.float64]:
        """Innovation [rad] (3,) of the tracker sample tested at the last step, applied or gated (NaN: none)."""
        return self._last_innovation.copy()

    @property
    def last_innovation_covariance(self) -> NDArray[np.float64]:
        """Innovation covariance ``S`` [rad^2] (3, 3) of that sample (NaN: none)."""
        return self._last_S.copy()

    @property
    def last_nis(self) -> float:
        """NIS of that sample (NaN: none)."""
        return float(self._last_nis)

    def with_state(self, q: ArrayLike, bias: ArrayLike) -> MEKF:
        """An independent copy started from another attitude and bias estimate (covariance and settings kept).

        Parameters
        ----------
        q : array_like (4,)
            Attitude estimate ``q_BN``, unit norm (used as given).
        bias : array_like (3,)
            Gyro bias estimate [rad/s].

        Returns
        -------
        MEKF
            The copy; this filter is not modified.
        """
        q = np.array(q, dtype=np.float64)
        bias = np.array(bias, dtype=np.float64)
        if q.shape != (4,) or bias.shape != (3,):
            raise ValueError(f"q must have shape (4,) and bias (3,), got {q.shape} and {bias.shape}")
        other = self.copy()
        other._q, other._b = q, bias
        return other

    @property
    def nis_history(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Times [s] and NIS values of every tracker sample tested so far (applied or gated)."""
        return np.array(self._nis_t), np.array(self._nis)

    @property
    def vector_nis_history(self) -> tuple[NDArray[np.float64], tuple[str, ...], NDArray[np.float64]]:
        """Times [s], sensor names and NIS values (2 dof) of every vector sample tested (applied or gated)."""
        return np.array(self._vnis_t), tuple(self._vnis_name), np.array(self._vnis)

    @property
    def last_vector_nis(self) -> dict[str, float]:
        """NIS (2 dof, capped) of each vector sample the last step tested, applied or gated, by sensor name."""
        return dict(self._last_vector_nis)

    def copy(self) -> MEKF:
        """An independent copy (state, covariance, counters and history)."""
        return copy.deepcopy(self)

    def estimate(self) -> Estimate:
        """The current :class:`attitude.simulation.engine.Estimate` (``covariance`` = P)."""
        t = 0.0 if self._t is None else self._t
        return Estimate(t, self._q.copy(), self.omega, covariance=self._kf.P.copy())

    # -- the filter -------------------------------------------------------------------

    def update(self, t: float, measurements: Mapping[str, Any]) -> Estimate:
        """One estimator step for :func:`attitude.simulation.engine.simulate`.

        Parameters
        ----------
        t : float
            Time [s]; must not go backwards.
        measurements : mapping
            Sensor name -> newest sample or None. Reads ``gyro_name``
            ((3,) [rad/s]), ``tracker_name`` ((4,) quaternion ``q_BN``) and
            each of ``vector_names`` (:class:`VectorMeasurement`); other keys
            are ignored.

        Returns
        -------
        attitude.simulation.engine.Estimate
            ``q_hat``, ``omega_hat = omega_meas - b_hat`` and ``covariance = P``.
        """
        if not self._names_checked:
            self._names_checked = True
            missing = [name for name in self.vector_names if name not in measurements]
            if missing:
                warnings.warn(
                    f"vector_names {missing} name no sensor of this run (its sensors: "
                    f"{sorted(k for k in measurements if k not in ('torque_command', 'wheel_momentum'))}): those "
                    "directions are never used; check the names",
                    UserWarning,
                    stacklevel=2,
                )
        vectors = {name: measurements.get(name) for name in self.vector_names} if self.vector_names else None
        return self.step(t, measurements.get(self.gyro_name), measurements.get(self.tracker_name), vectors)

    def step(
        self,
        t: float,
        gyro: ArrayLike | None = None,
        tracker: ArrayLike | None = None,
        vectors: Mapping[str, Any] | Sequence[Any] | None = None,
    ) -> Estimate:
        """Propagate to ``t`` with the gyro sample, then update with the tracker and vector samples.

        Parameters
        ----------
        t : float
            Time [s] of both samples; not before the previous step.
        gyro : array_like (3,), optional
            Gyro sample at ``t`` [rad/s]: the mean rate since the previous
            step (class docstring for None and NaN).
        tracker : array_like (4,), optional
            Star tracker attitude ``q_BN`` at ``t`` (None: no sample; NaN:
            skipped; above the innovation gate: rejected and counted).
        vectors : mapping or sequence, optional
            Vector samples at ``t``: name -> :class:`VectorMeasurement` (or a
            mapping of its fields, or None), or a sequence of them (named
            ``vector[i]`` in the history); applied in order after the tracker.

        Returns
        -------
        attitude.simulation.engine.Estimate

        Raises
        ------
        ValueError
            If ``t`` is not finite or goes backwards, or a sample has the
            wrong shape or (tracker) a finite non-unit norm, or a vector
            sample is malformed (:class:`VectorMeasurement`).
        """
        t = float(t) if isinstance(t, float) and math.isfinite(t) else float(as_float_array(t, "t"))
        if self._t is not None and t < self._t:
            raise ValueError(f"t must not go backwards: t = {t!r} s < previous time {self._t!r} s")
        rate = self._accept_gyro(gyro)
        q_meas = self._accept_tracker(tracker)
        vector_samples = self._accept_vectors(vectors)

        if self._t is not None and t > self._t:
            held = rate if rate is not None else self._last_gyro
            self._propagate(np.zeros(3) if held is None else held, t - self._t)
        self._t = t
        if rate is not None:
            self._last_gyro = rate
        self._last_nis = np.nan
        self._last_gated = False
        self._last_vector_nis = {}
        if q_meas is not None:
            self._correct(q_meas, t)
        for name, m in vector_samples:
            self._correct_vector(m, name, t)
        self._counts["steps"] += 1
        return self.estimate()

    def _accept_gyro(self, gyro: ArrayLike | None) -> NDArray[np.float64] | None:
        if gyro is None:
            self._counts["gyro_missing"] += 1
            return None
        g = finite_floats(gyro, 3)
        if g is None:
            arr = as_float_array(gyro, "gyro sample", allow_nonfinite=True)
            if arr.shape != (3,):
                raise ValueError(f"gyro sample must have shape (3,) [rad/s], got shape {arr.shape}")
            if not np.all(np.isfinite(arr)):
                self._counts["gyro_nan"] += 1
                return None
            g = arr.tolist()
        if max(abs(g[0]), abs(g[1]), abs(g[2])) > self.gyro_rate_max:
            self._counts["gyro_rejected"] += 1
            return None
        return np.array(g)

    def _accept_tracker(self, tracker: ArrayLike | None) -> list[float] | None:
        """The tracker sample as a normalised quaternion of Python floats (None: no sample or NaN)."""
        if tracker is None:
            self._counts["tracker_missing"] += 1
            return None
        y = finite_floats(tracker, 4)
        if y is None:
            arr = as_float_array(tracker, "tracker sample", allow_nonfinite=True)
            if arr.shape != (4,):
                raise ValueError(f"tracker sample must have shape (4,) (quaternion q_BN), got shape {arr.shape}")
            if not np.all(np.isfinite(arr)):
                self._counts["tracker_nan"] += 1
                return None
            y = arr.tolist()
        w, x, yy, z = y
        n = math.sqrt(w * w + x * x + yy * yy + z * z)
        if abs(n - 1.0) > _UNIT_TOL:
            raise ValueError(
                f"tracker sample must be a unit quaternion (| |q| - 1 | <= {_UNIT_TOL:g}); found |q| = {n!r}"
            )
        return [w / n, x / n, yy / n, z / n]

    def _accept_vectors(self, vectors: Mapping[str, Any] | Sequence[Any] | None) -> list:
        if vectors is None:
            return []
        if isinstance(vectors, Mapping):
            items = list(vectors.items())
        elif isinstance(vectors, (str, np.ndarray)) or not isinstance(vectors, Sequence):
            raise ValueError(
                "vectors must be a mapping name -> VectorMeasurement or a sequence of VectorMeasurement, got "
                f"{type(vectors).__name__}"
            )
        else:
            items = [(f"vector[{i}]", v) for i, v in enumerate(vectors)]
        out = []
        for name, sample in items:
            if sample is None:
                continue
            m = sample if type(sample) is VectorMeasurement else _as_vector_measurement(sample, name)
            if not m.valid:
                self._counts["vector_nan"] += 1
                continue
            out.append((name, m))
        return out

    def _propagate(self, rate: NDArray[np.float64], dt: float) -> None:
        # In Python floats (numpy's per-call cost dominates 3- and 4-vectors); filterpy forms F P F^T + Q.
        r0, r1, r2 = rate.tolist()
        b0, b1, b2 = self._b.tolist()
        w = [r0 - b0, r1 - b1, r2 - b2]
        self._q = np.array(_compose_floats(self._q.tolist(), [w[0] * dt, w[1] * dt, w[2] * dt]))
        kf = self._kf
        kf.F = _transition_one(w, dt)
        kf.Q = self._process_noise(dt)
        kf.predict()

    def _process_noise(self, dt: float) -> NDArray[np.float64]:
        """:func:`attitude.sensors.farrenkopf_process_noise` over ``dt`` [s], cached by step.

        The engine's ticks ``k dt`` differ by a handful of distinct floats (14
        over 6000 ticks of 0.1 s). filterpy reads ``Q`` without writing it, so
        the cached array is shared.
        """
        q = self._q_cache.get(dt)
        if q is None:
            if len(self._q_cache) >= _Q_CACHE_SIZE:
                self._q_cache.clear()
            q = self._q_cache[dt] = farrenkopf_process_noise(self.sigma_v**2, self.sigma_u**2, dt)
            q.flags.writeable = False
        return q

    def _correct(self, q_meas: list[float], t: float) -> None:
        kf = self._kf
        z_floats = _residual_floats(self._q.tolist(), q_meas)
        z = np.array(z_floats)
        # The gate, before anything is applied (the S filterpy's update forms: H P H^T + R, with H = [I 0]).
        s = kf.P[:3, :3] + kf.R
        si = _inverse_3x3(s.tolist())
        z0, z1, z2 = z_floats
        nis_gate = sum(zi * (r[0] * z0 + r[1] * z1 + r[2] * z2) for zi, r in zip(z_floats, si))
        if not nis_gate <= self.gate_threshold:
            nis_gate = nis_gate if nis_gate <= NIS_CAP else NIS_CAP
            self._last_nis, self._last_gated = nis_gate, True
            self._last_innovation, self._last_S = z, s
            self._nis_t.append(t)
            self._nis.append(nis_gate)
            self._counts["tracker_gated"] += 1
            return
        kf.update(z)  # its S is this S (H P H^T with H = [I 0] is exact), inverted by _inverse_3x3_array
        self._last_innovation, self._last_S = z, s
        self._reset(kf.x[:3].tolist(), kf.x[3:].tolist(), kf.P)
        self._last_nis = nis_gate
        self._nis_t.append(t)
        self._nis.append(nis_gate)
        self._counts["updates"] += 1

    def _reset(self, dtheta: list[float], db: list[float], p: NDArray[np.float64]) -> None:
        """Move the estimated error into ``q_hat`` and ``b_hat``, reset the covariance and zero ``x``."""
        kf = self._kf
        self._q = np.array(_compose_floats(self._q.tolist(), dtheta))
        b0, b1, b2 = self._b.tolist()
        self._b = np.array([b0 + db[0], b1 + db[1], b2 + db[2]])
        if self.covariance_reset == "second_order":
            g = np.eye(6)
            g[:3, :3] -= 0.5 * skew(dtheta)
            p = g @ p @ g.T
        kf.P = 0.5 * (p + p.T)
        kf.x = np.zeros(6)

    def _correct_vector(self, m: VectorMeasurement, name: str, t: float) -> None:
        (z0, z1), t1, t2, cosine = _vector_basis(self._q.tolist(), m)
        p = self._kf.P
        # P H^T (6, 2) with H = [h 0], h = [-t2; t1]; the 2 x 2 algebra in Python floats.
        pht = p[:, :3] @ np.array([[-t2[0], t1[0]], [-t2[1], t1[1]], [-t2[2], t1[2]]])
        rows = pht.tolist()
        (r00, r01), (r10, r11) = (
            ((m.sigma * m.sigma, 0.0), (0.0, m.sigma * m.sigma))
            if m.covariance is None
            else _vector_noise(m, t1, t2).tolist()
        )
        (a0, b0), (a1, b1), (a2, b2) = rows[0], rows[1], rows[2]
        s00 = -(t2[0] * a0 + t2[1] * a1 + t2[2] * a2) + r00
        s01 = -(t2[0] * b0 + t2[1] * b1 + t2[2] * b2) + r01
        s10 = t1[0] * a0 + t1[1] * a1 + t1[2] * a2 + r10
        s11 = t1[0] * b0 + t1[1] * b1 + t1[2] * b2 + r11
        # 2 x 2 inverse in closed form (S is symmetric positive definite: R is).
        det = s00 * s11 - s01 * s10
        si = ((s11 / det, -s01 / det), (-s10 / det, s00 / det))
        c0 = si[0][0] * z0 + si[0][1] * z1
        c1 = si[1][0] * z0 + si[1][1] * z1
        nis_value = z0 * c0 + z1 * c1
        if cosine <= 0.0:
            # More than 90 deg from the prediction: the projected residual of a reversed vector is as small
            # as that of a good one (T b = -T b_hat = 0), so the linear model cannot judge it; rejected.
            nis_value = NIS_CAP
        self._vnis_t.append(t)
        self._vnis_name.append(name)
        self._last_vector_nis[name] = nis_value if nis_value <= NIS_CAP else NIS_CAP
        if cosine <= 0.0 or not nis_value <= self.vector_gate_threshold:
            self._vnis.append(nis_value if nis_value <= NIS_CAP else NIS_CAP)
            self._counts["vector_gated"] += 1
            return
        self._vnis.append(nis_value)
        dx = [a * c0 + b * c1 for a, b in rows]  # K z, K = P H^T S^-1
        # P - K S K^T = P - (P H^T) S^-1 (P H^T)^T: with the optimal gain the same as the Joseph form filterpy
        # uses for the tracker, at a fraction of the cost; symmetrised in the reset.
        self._reset(dx[:3], dx[3:], p - (pht @ np.array(si)) @ pht.T)
        self._counts["vector_updates"] += 1

    # -- reporting --------------------------------------------------------------------

    def log(self) -> dict[str, Any]:
        """Values the engine logs at each estimator step.

        ``bias`` (3,) [rad/s], ``P_diag`` (6,), ``nis`` (NaN without a
        tracker sample at this step; the rejected value for a gated one),
        ``gated`` (0/1 this step) and the running counts (``updates``,
        ``tracker_nan``, ``tracker_gated``, ``gyro_nan``, ``gyro_rejected``,
        ``tracker_missing``, ``gyro_missing``, ``vector_updates``,
        ``vector_nan``, ``vector_gated``).
        """
        out: dict[str, Any] = {
            "bias": self._b.copy(),
            "P_diag": np.diag(self._kf.P).copy(),
            "nis": self._last_nis,
            "gated": float(self._last_gated),
        }
        for key in (
            "updates",
            "tracker_nan",
            "tracker_gated",
            "gyro_nan",
            "gyro_rejected",
            "tracker_missing",
            "gyro_missing",
            "vector_updates",
            "vector_nan",
            "vector_gated",
        ):
            out[key] = float(self._counts[key])
        return out

    def nis_health(self, window: int = 50, confidence: float = 0.999) -> NisHealth:
        """Moving-window NIS check of the tracker samples so far, gated ones included (3 dof).

        See :func:`estimation.consistency.nis_health`.

        Parameters
        ----------
        window : int, optional
            Number of samples per window.
        confidence : float, optional
            Two-sided confidence of each window's chi-square band, in (0, 1).
        """
        t, values = self.nis_history
        return nis_health(values, 3, window, confidence, t=t)

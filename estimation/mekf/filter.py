"""Multiplicative extended Kalman filter (MEKF) for attitude and gyro bias.

The filter of Markley and Crassidis (*Fundamentals of Spacecraft Attitude
Determination and Control*, 2014, ch. 6) and Crassidis and Junkins
(*Optimal Estimation of Dynamic Systems*, 2nd ed., sec. 7.2): the reference
quaternion ``q_hat`` (``q_BN``) and gyro bias ``b_hat`` [rad/s] live outside
the Kalman state, whose six components are the error ``[delta_theta [rad],
delta_b [rad/s]]``; gyro samples propagate it, star-tracker samples update
it behind an innovation gate, and each update is followed by a reset.

See docs/mekf.md for the derivation (propagation, update, gate, gyro
sampling, batches, the steady-state formula and its references).
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from filterpy.kalman import KalmanFilter
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from attitude import quaternion as quat
from attitude.results import ResultIO
from attitude.sensors import ARCSEC, Gyro, StarTracker, farrenkopf_process_noise
from attitude.simulation.engine import Estimate
from attitude.validation import as_float_array, check_covariance, check_positive, positive_scalar, scalar_time
from estimation.consistency import NisHealth, nees, nis_health, plot_errors_with_bounds

__all__ = [
    "GATE_PROBABILITY",
    "MEKF",
    "MEKFBatch",
    "MEKFResult",
    "initial_covariance",
    "process_noise",
    "run_mekf",
    "steady_state_attitude_sigma",
    "steady_state_covariance",
    "transition_matrix",
]

_I3 = np.eye(3)
_H = np.hstack([_I3, np.zeros((3, 3))])
_EYE6 = np.eye(6)
_RESETS = ("first_order", "second_order")
#: Accepted deviation of a tracker quaternion's norm from 1 (that of attitude.quaternion).
_UNIT_TOL = quat.UNIT_NORM_TOLERANCE
_DEG_PER_H = np.pi / 180.0 / 3600.0  # [rad/s] in one deg/h
#: Default probability of the innovation gate (module docstring): chi-square(3) gate at NIS 44.8.
GATE_PROBABILITY = 1.0 - 1e-9
#: NIS recorded for a rejected sample whose NIS is not finite in float64.
_NIS_CAP = 1e300
_COUNT_KEYS = (
    "steps",
    "updates",
    "tracker_missing",
    "tracker_nan",
    "tracker_gated",
    "gyro_missing",
    "gyro_nan",
    "gyro_rejected",
)
#: Per-run counts kept by :class:`MEKFBatch`.
_BATCH_COUNT_KEYS = ("steps", "updates", "tracker_nan", "tracker_gated", "gyro_nan", "gyro_rejected")


# ---------------------------------------------------------------------------
# Small batch-aware helpers (no validation: internal hot path; tested against attitude.quaternion)


def _skew(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``[v x]`` of shape (..., 3, 3)."""
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2)


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


def _compose_one(q: NDArray[np.float64], phi: NDArray[np.float64]) -> NDArray[np.float64]:
    """``normalise(q ⊗ exp(phi / 2))`` for one quaternion (4,) and rotation vector (3,)."""
    dq = quat.exp_rotation_vector_components([float(phi[0]), float(phi[1]), float(phi[2])])
    w, x, y, z = quat.multiply_components([float(c) for c in q], [float(c) for c in dq])
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return np.array([w / n, x / n, y / n, z / n])


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
        exp(-[w x] s) ds`` (docs/mekf.md).
    """
    w = as_float_array(omega, "omega")
    if w.ndim == 0 or w.shape[-1] != 3:
        raise ValueError(f"omega must have shape (..., 3), got shape {w.shape}")
    h = check_positive(dt, "dt", allow_zero=True)
    return _transition(w, h)


def _transition(w: NDArray[np.float64], dt: Any) -> NDArray[np.float64]:
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
    k = _skew(w * dt[..., None])  # [w x] dt
    k2 = k @ k
    d = dt[..., None, None]
    phi11 = _I3 - c1[..., None, None] * k + c2[..., None, None] * k2
    phi12 = d * (-_I3 + c2[..., None, None] * k - c3[..., None, None] * k2)
    out = np.zeros((*np.broadcast_shapes(w.shape[:-1], dt.shape), 6, 6))
    out[..., :3, :3] = phi11
    out[..., :3, 3:] = phi12
    out[..., 3:, 3:] = _I3
    return out


def _transition_one(w: NDArray[np.float64], dt: float) -> NDArray[np.float64]:
    """:func:`_transition` for one rate (3,) and a scalar step, with Python scalars (the per-step path)."""
    wx, wy, wz = float(w[0]) * dt, float(w[1]) * dt, float(w[2]) * dt
    a = math.sqrt(wx * wx + wy * wy + wz * wz)
    if a < 1e-2:
        a2 = a * a
        c1 = 1.0 - a2 / 6.0 + a2 * a2 / 120.0
        c2 = 0.5 - a2 / 24.0 + a2 * a2 / 720.0
        c3 = 1.0 / 6.0 - a2 / 120.0 + a2 * a2 / 5040.0
    else:
        c1 = math.sin(a) / a
        c2 = 2.0 * math.sin(0.5 * a) ** 2 / (a * a)
        c3 = (a - math.sin(a)) / a**3
    k = np.array([[0.0, -wz, wy], [wz, 0.0, -wx], [-wy, wx, 0.0]])
    k2 = k @ k
    out = np.zeros((6, 6))
    out[:3, :3] = _I3 - c1 * k + c2 * k2
    out[:3, 3:] = dt * (-_I3 + c2 * k - c3 * k2)
    out[3:, 3:] = _I3
    return out


def process_noise(sigma_v: float, sigma_u: float, dt: float) -> NDArray[np.float64]:
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
    return _process_noise(sv * sv, su * su, h)


# The one definition of the Farrenkopf discrete process noise lives with the gyro model.
_process_noise = farrenkopf_process_noise


def initial_covariance(attitude_sigma: float, bias_sigma: float) -> NDArray[np.float64]:
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


# ---------------------------------------------------------------------------
# Validation


def _check_name(value: Any, name: str) -> str:
    if not isinstance(value, str) or not value:
        raise ValueError(f"{name} must be a non-empty string, got {value!r}")
    return value


# ---------------------------------------------------------------------------
# The filter


class MEKF:
    """Multiplicative EKF: attitude ``q_BN`` and gyro bias from a gyro and a star tracker.

    See docs/mekf.md for the equations. The object is also an
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
      (docs/mekf.md);
    - a missing (None) or NaN gyro sample: the last valid gyro sample is held
      over the interval (zero rate before the first one); NaN samples are
      counted as ``gyro_nan``, samples with a component above
      ``max_gyro_rate`` as ``gyro_rejected``. The held rate's error is not in
      ``Q``: a long gyro outage makes the filter over-confident, which the
      counts and the NIS reveal;
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
        Covariance reset Jacobian after each update (docs/mekf.md).
    gyro_name, tracker_name : str
        Keys of the gyro and tracker samples in the measurements (the
        sensors' ``name``).
    gate_probability : float or None
        Probability of the innovation gate, in (0, 1) (docs/mekf.md);
        default ``1 - 1e-9``; None disables the gate.
    max_gyro_rate : float, optional
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
        sigma_v: float,
        sigma_u: float,
        tracker_covariance: ArrayLike,
        *,
        period: float,
        q0: ArrayLike,
        P0: ArrayLike,
        bias0: ArrayLike = 0.0,
        t0: float | None = None,
        covariance_reset: str = "first_order",
        gyro_name: str = "gyro",
        tracker_name: str = "star_tracker",
        gate_probability: float | None = GATE_PROBABILITY,
        max_gyro_rate: float | None = None,
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
        if t0 is not None:
            t0 = float(as_float_array(t0, "t0"))
        if gate_probability is None:
            self.gate_probability = None
            #: The NIS gate ``chi2.ppf(gate_probability, 3)`` (inf when disabled).
            self.gate_threshold = math.inf
        else:
            gp = as_float_array(gate_probability, "gate_probability")
            if gp.ndim != 0 or not 0.0 < float(gp) < 1.0:
                raise ValueError(f"gate_probability must be a scalar in (0, 1) or None, got {gp.tolist()!r}")
            self.gate_probability = float(gp)
            self.gate_threshold = float(stats.chi2.ppf(self.gate_probability, 3))
        #: Largest accepted gyro component [rad/s].
        self.max_gyro_rate = (
            math.pi / self.period if max_gyro_rate is None else positive_scalar(max_gyro_rate, "max_gyro_rate")
        )

        self._q = q.copy()
        self._b = np.array(np.broadcast_to(b, (3,)), dtype=np.float64)
        kf = KalmanFilter(dim_x=6, dim_z=3)
        kf.x = np.zeros(6)  # 1-D: filterpy keeps x's shape and reshapes z to (3,)
        kf.P = p0.copy()
        kf.H = _H.copy()
        kf.R = self.tracker_covariance.copy()
        self._kf = kf
        self._t: float | None = t0
        self._last_gyro: NDArray[np.float64] | None = None
        self._last_nis = np.nan
        self._last_gated = False
        self._last_innovation = np.full(3, np.nan)
        self._last_S = np.full((3, 3), np.nan)
        self._nis_t: list[float] = []
        self._nis: list[float] = []
        self._counts = dict.fromkeys(_COUNT_KEYS, 0)

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

        ``sigma_v``, ``sigma_u``, ``period`` and ``gyro_name`` come from
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
            gyro.sigma_v,
            gyro.sigma_u,
            tracker.covariance_B,
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
    def nis_history(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Times [s] and NIS values of every tracker sample tested so far (applied or gated)."""
        return np.array(self._nis_t), np.array(self._nis)

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
            ((3,) [rad/s]) and ``tracker_name`` ((4,) quaternion ``q_BN``);
            other keys are ignored.

        Returns
        -------
        attitude.simulation.engine.Estimate
            ``q_hat``, ``omega_hat = omega_meas - b_hat`` and ``covariance = P``.
        """
        return self.step(t, measurements.get(self.gyro_name), measurements.get(self.tracker_name))

    def step(self, t: float, gyro: ArrayLike | None = None, tracker: ArrayLike | None = None) -> Estimate:
        """Propagate to ``t`` with the gyro sample, then update with the tracker sample.

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

        Returns
        -------
        attitude.simulation.engine.Estimate

        Raises
        ------
        ValueError
            If ``t`` is not finite or goes backwards, or a sample has the
            wrong shape or (tracker) a finite non-unit norm.
        """
        t = float(as_float_array(t, "t"))
        if self._t is not None and t < self._t:
            raise ValueError(f"t must not go backwards: t = {t!r} s < previous time {self._t!r} s")
        rate = self._accept_gyro(gyro)
        q_meas = self._accept_tracker(tracker)

        if self._t is not None and t > self._t:
            held = rate if rate is not None else self._last_gyro
            self._propagate(np.zeros(3) if held is None else held, t - self._t)
        self._t = t
        if rate is not None:
            self._last_gyro = rate
        self._last_nis = np.nan
        self._last_gated = False
        if q_meas is not None:
            self._correct(q_meas, t)
        self._counts["steps"] += 1
        return self.estimate()

    def _accept_gyro(self, gyro: ArrayLike | None) -> NDArray[np.float64] | None:
        if gyro is None:
            self._counts["gyro_missing"] += 1
            return None
        g = as_float_array(gyro, "gyro sample", allow_nonfinite=True)
        if g.shape != (3,):
            raise ValueError(f"gyro sample must have shape (3,) [rad/s], got shape {g.shape}")
        if not np.all(np.isfinite(g)):
            self._counts["gyro_nan"] += 1
            return None
        if np.abs(g).max() > self.max_gyro_rate:
            self._counts["gyro_rejected"] += 1
            return None
        return g.copy()

    def _accept_tracker(self, tracker: ArrayLike | None) -> NDArray[np.float64] | None:
        if tracker is None:
            self._counts["tracker_missing"] += 1
            return None
        y = as_float_array(tracker, "tracker sample", allow_nonfinite=True)
        if y.shape != (4,):
            raise ValueError(f"tracker sample must have shape (4,) (quaternion q_BN), got shape {y.shape}")
        if not np.all(np.isfinite(y)):
            self._counts["tracker_nan"] += 1
            return None
        n = float(np.sqrt(y @ y))
        if abs(n - 1.0) > _UNIT_TOL:
            raise ValueError(
                f"tracker sample must be a unit quaternion (| |q| - 1 | <= {_UNIT_TOL:g}); found |q| = {n!r}"
            )
        return y / n

    def _propagate(self, rate: NDArray[np.float64], dt: float) -> None:
        w = rate - self._b
        self._q = _compose_one(self._q, w * dt)
        kf = self._kf
        kf.F = _transition_one(w, dt)
        kf.Q = _process_noise(self.sigma_v**2, self.sigma_u**2, dt)
        kf.predict()

    def _correct(self, q_meas: NDArray[np.float64], t: float) -> None:
        kf = self._kf
        z = _log_rotvec(_qmul(_conj(self._q), q_meas))
        # The gate, before anything is applied (the S filterpy's update would form: H P H^T + R).
        s = kf.P[:3, :3] + kf.R
        nis_gate = float(z @ np.linalg.inv(s) @ z)
        if not nis_gate <= self.gate_threshold:
            nis_gate = nis_gate if nis_gate <= _NIS_CAP else _NIS_CAP
            self._last_nis, self._last_gated = nis_gate, True
            self._last_innovation, self._last_S = z, s
            self._nis_t.append(t)
            self._nis.append(nis_gate)
            self._counts["tracker_gated"] += 1
            return
        kf.update(z)
        nis_value = float(kf.y @ kf.SI @ kf.y)
        self._last_innovation, self._last_S = np.array(kf.y, dtype=np.float64), np.array(kf.S, dtype=np.float64)
        dtheta, db = kf.x[:3].copy(), kf.x[3:].copy()
        self._q = _compose_one(self._q, dtheta)
        self._b = self._b + db
        p = kf.P
        if self.covariance_reset == "second_order":
            g = np.eye(6)
            g[:3, :3] -= 0.5 * _skew(dtheta)
            p = g @ p @ g.T
        kf.P = 0.5 * (p + p.T)
        kf.x = np.zeros(6)
        self._last_nis = nis_value
        self._nis_t.append(t)
        self._nis.append(nis_value)
        self._counts["updates"] += 1

    # -- reporting --------------------------------------------------------------------

    def log(self) -> dict[str, Any]:
        """Values the engine logs at each estimator step.

        ``bias`` (3,) [rad/s], ``P_diag`` (6,), ``nis`` (NaN without a
        tracker sample at this step; the rejected value for a gated one),
        ``gated`` (0/1 this step) and the running counts (``updates``,
        ``tracker_nan``, ``tracker_gated``, ``gyro_nan``, ``gyro_rejected``,
        ``tracker_missing``, ``gyro_missing``).
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


# ---------------------------------------------------------------------------
# Batch runs


class MEKFBatch:
    """N MEKFs advancing together, one step at a time: the batched state of a vectorised Monte Carlo loop.

    The filter of :class:`MEKF` (same equations, innovation gate,
    covariance reset option, handling of NaN and implausible gyro samples
    with the last valid rate held, NaN tracker samples skipped) for ``N``
    runs stacked along a leading axis, each step one numpy operation for all
    runs. Stepped from outside (a closed loop calls :meth:`step` each
    estimator tick with the runs' gyro and tracker samples);
    :func:`run_mekf` (``vectorized=True``) runs its recorded histories
    through the same :meth:`step` code, so there is one definition of the
    batch equations. No filterpy: it runs one filter at a time.

    The filter passed in is not modified: the batch starts from its state
    and settings (time, covariance, held gyro rate, attitude and bias unless
    ``q0``/``bias0`` replace them), like :func:`run_mekf`.

    Parameters
    ----------
    mekf : MEKF
        Settings (noise figures, tracker covariance, gate, reset option,
        ``max_gyro_rate``) and initial state.
    n_runs : int
        Number of runs N (>= 1).
    q0 : array_like (4,) or (N, 4), optional
        Initial attitude estimates ``q_BN`` (unit norm) replacing the filter's.
    bias0 : float or array_like (3,) or (N, 3), optional
        Initial gyro bias estimates [rad/s] replacing the filter's.

    Attributes
    ----------
    n_runs : int
        N.
    innovation : ndarray (N, 3)
        Tracker residuals [rad] of the last step (NaN where no sample was tested).
    innovation_covariance : ndarray (N, 3, 3)
        Their covariances ``S`` [rad^2] (NaN where no sample was tested).
    nis : ndarray (N,)
        NIS of the last step's tracker samples, applied or gated (NaN without one).
    updated, gated : ndarray (N,) of bool
        The last step applied a tracker sample / the gate rejected one.
    tracker_nan, gyro_nan, gyro_rejected : ndarray (N,) of bool
        The last step skipped a NaN tracker sample / a NaN gyro sample /
        rejected a gyro sample above ``max_gyro_rate``.

    Raises
    ------
    ValueError
        If ``mekf`` is not an :class:`MEKF`, ``n_runs`` is not a positive
        integer, or ``q0``/``bias0`` have a wrong shape or value.
    """

    def __init__(self, mekf: MEKF, n_runs: int, q0: ArrayLike | None = None, bias0: ArrayLike | None = None) -> None:
        if not isinstance(mekf, MEKF):
            raise ValueError(f"mekf must be an MEKF, got {type(mekf).__name__}")
        if not isinstance(n_runs, (int, np.integer)) or isinstance(n_runs, bool) or n_runs < 1:
            raise ValueError(f"n_runs must be a positive integer, got {n_runs!r}")
        runs = int(n_runs)
        if q0 is not None and np.shape(q0) not in ((4,), (runs, 4)):
            raise ValueError(f"q0 must have shape (4,) or ({runs}, 4), got {np.shape(q0)}")
        if bias0 is not None and np.shape(bias0) not in ((), (3,), (runs, 3)):
            raise ValueError(f"bias0 must be a scalar or have shape (3,) or ({runs}, 3), got {np.shape(bias0)}")
        qs = mekf.q if q0 is None else quat.as_unit_quaternion(q0, "q0")
        bs = mekf.bias if bias0 is None else as_float_array(bias0, "bias0")
        self._init(mekf, np.broadcast_to(qs, (runs, 4)), np.broadcast_to(bs, (runs, 3)))

    @classmethod
    def _unchecked(cls, mekf: MEKF, qs: NDArray[np.float64], bs: NDArray[np.float64]) -> MEKFBatch:
        """A batch from validated (N, 4) attitudes and (N, 3) biases, used as given (no renormalisation)."""
        self = cls.__new__(cls)
        self._init(mekf, qs, bs)
        return self

    def _init(self, mekf: MEKF, qs: NDArray[np.float64], bs: NDArray[np.float64]) -> None:
        runs = int(qs.shape[0])
        self.n_runs = runs
        self._q = np.array(qs, dtype=np.float64)
        self._b = np.array(bs, dtype=np.float64)
        self._P = np.broadcast_to(mekf._kf.P, (runs, 6, 6)).copy()
        self._R = mekf.tracker_covariance
        held = mekf._last_gyro
        self._last = np.zeros((runs, 3)) if held is None else np.broadcast_to(held, (runs, 3)).copy()
        self._t: float | None = mekf.t
        self._sv2 = mekf.sigma_v**2
        self._su2 = mekf.sigma_u**2
        self._gate = mekf.gate_threshold
        self._second = mekf.covariance_reset == "second_order"
        #: Settings copied from the filter.
        self.covariance_reset = mekf.covariance_reset
        self.gate_threshold = mekf.gate_threshold
        self.max_gyro_rate = mekf.max_gyro_rate
        #: Step period [s] (the filter's; what a closed loop steps it at).
        self.period = mekf.period
        self._counts = {k: np.zeros(runs, dtype=np.int64) for k in _BATCH_COUNT_KEYS}
        self._clear_step_outputs()

    def __repr__(self) -> str:
        return f"MEKFBatch(n_runs={self.n_runs}, t={self._t!r}, covariance_reset={self.covariance_reset!r})"

    # -- state ----------------------------------------------------------------------

    @property
    def q(self) -> NDArray[np.float64]:
        """Attitude estimates ``q_BN`` (N, 4) (a copy)."""
        return self._q.copy()

    @property
    def bias(self) -> NDArray[np.float64]:
        """Gyro bias estimates (N, 3) [rad/s] (a copy)."""
        return self._b.copy()

    @property
    def P(self) -> NDArray[np.float64]:
        """Error covariances (N, 6, 6) of ``[delta_theta, delta_b]`` (a copy)."""
        return self._P.copy()

    @property
    def t(self) -> float | None:
        """Time [s] of the estimates (None before the first step if the filter had no time)."""
        return self._t

    @property
    def omega(self) -> NDArray[np.float64]:
        """Rate estimates ``omega_meas - b_hat`` (N, 3) [rad/s] from the held gyro rate (zeros before one)."""
        return self._last - self._b

    @property
    def counts(self) -> dict[str, NDArray[np.int64]]:
        """Per-run counts (N,) so far: steps, updates, tracker_nan, tracker_gated, gyro_nan, gyro_rejected."""
        return {k: v.copy() for k, v in self._counts.items()}

    # -- the filter -------------------------------------------------------------------

    def step(
        self,
        t: float,
        gyro: ArrayLike | None,
        tracker: ArrayLike | None = None,
        mask: ArrayLike | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Propagate every run to ``t`` with its gyro sample, then update with its tracker sample.

        Run ``r`` follows :meth:`MEKF.step` of ``(t, gyro[r], tracker[r]
        if mask[r] else None)``.

        Parameters
        ----------
        t : float
            Time [s] of the samples (shared); not before the previous step
            (a repeated time propagates nothing and may still update).
        gyro : array_like (N, 3) or None
            Gyro samples [rad/s], the mean rate since the previous step. A
            row with a non-finite entry (NaN) or a component above
            ``max_gyro_rate`` is skipped and counted (``gyro_nan``,
            ``gyro_rejected``) and the run's last valid rate is held (zero
            before one); None: no sample in any run (held rates).
        tracker : array_like (N, 4), optional
            Tracker quaternions ``q_BN``; rows outside ``mask`` are ignored.
            A masked row with a non-finite entry is skipped and counted
            (``tracker_nan``); finite masked rows must have unit norm (to
            1e-6, as :meth:`MEKF.step`). Samples above the innovation gate are
            rejected and counted (``gated``).
        mask : array_like (N,) of bool, optional
            Runs whose tracker sampled (default: the rows of ``tracker``
            that are not all NaN).

        Returns
        -------
        q : ndarray (N, 4)
            Attitude estimates ``q_BN`` after the step.
        omega : ndarray (N, 3)
            Rate estimates ``omega_meas - b_hat`` [rad/s].

        Raises
        ------
        ValueError
            If ``t`` is not a finite scalar or goes backwards, an array has
            the wrong shape (or dtype for ``mask``), ``mask`` comes without
            ``tracker``, or a sampled finite tracker row is not unit norm.
            Every check runs before the state changes.
        """
        n = self.n_runs
        tk = scalar_time(t)
        if self._t is not None and tk < self._t:
            raise ValueError(f"t must not go backwards: t = {tk!r} s < previous time {self._t!r} s")
        g = None
        if gyro is not None:
            g = as_float_array(gyro, "gyro", allow_nonfinite=True)
            if g.shape != (n, 3):
                raise ValueError(f"gyro must have shape ({n}, 3) (one rate sample per run), got shape {g.shape}")
        y = None
        m = None
        if tracker is not None:
            y = as_float_array(tracker, "tracker", allow_nonfinite=True)
            if y.shape != (n, 4):
                raise ValueError(f"tracker must have shape ({n}, 4) (one quaternion per run), got shape {y.shape}")
            if mask is None:
                m = ~np.all(np.isnan(y), axis=-1)
            else:
                m = np.asarray(mask)
                if m.dtype != np.bool_ or m.shape != (n,):
                    raise ValueError(
                        f"mask must be a boolean array of shape ({n},), got dtype {m.dtype} and shape {m.shape}"
                    )
            finite_rows = np.all(np.isfinite(y), axis=-1)
            norms = np.sqrt(np.sum(np.where(finite_rows[:, None], y, 0.0) ** 2, axis=-1))
            bad = m & finite_rows & (np.abs(norms - 1.0) > _UNIT_TOL)
            if np.any(bad):
                r = int(np.argmax(bad))
                raise ValueError(
                    f"tracker must hold unit quaternions (| |q| - 1 | <= {_UNIT_TOL:g}) in sampled rows; found "
                    f"|q| = {norms[r]!r} in row {r}"
                )
        elif mask is not None:
            raise ValueError("mask was given without tracker samples (pass tracker (N, 4) with it)")
        self._step(tk, g, y, m)
        return self._q.copy(), self._last - self._b

    def _clear_step_outputs(self) -> None:
        n = self.n_runs
        self.innovation = np.full((n, 3), np.nan)
        self.innovation_covariance = np.full((n, 3, 3), np.nan)
        self.nis = np.full(n, np.nan)
        self.updated = np.zeros(n, dtype=bool)
        self.gated = np.zeros(n, dtype=bool)
        self.tracker_nan = np.zeros(n, dtype=bool)
        self.gyro_nan = np.zeros(n, dtype=bool)
        self.gyro_rejected = np.zeros(n, dtype=bool)

    def _step(
        self,
        tk: float,
        g: NDArray[np.float64] | None,
        y: NDArray[np.float64] | None,
        mask: NDArray[np.bool_] | None,
    ) -> None:
        """The batch equations for one step (no checks: :meth:`step` and :func:`run_mekf` validate)."""
        self._clear_step_outputs()
        q, b, P, R = self._q, self._b, self._P, self._R
        # Gyro: NaN rows and rows above max_gyro_rate are skipped, the last valid rate is held.
        if g is None:
            rate = self._last
        else:
            finite = np.all(np.isfinite(g), axis=-1)
            largest = np.max(np.abs(np.where(finite[:, None], g, 0.0)), axis=-1)
            rejected = finite & (largest > self.max_gyro_rate)
            self.gyro_nan = ~finite
            self.gyro_rejected = rejected
            rate = np.where((finite & ~rejected)[:, None], g, self._last)
        t_prev = self._t
        if t_prev is not None and tk > t_prev:
            dt = tk - t_prev
            w = rate - b
            q = _normalize(_qmul(q, _exp_rotvec(w * dt)))
            phi = _transition(w, dt)
            P = phi @ P @ np.swapaxes(phi, -1, -2) + _process_noise(self._sv2, self._su2, dt)
        self._t = tk
        self._last = rate
        # Tracker: NaN samples are skipped; the others are gated on their NIS, then applied.
        if y is not None:
            y_ok = np.all(np.isfinite(y), axis=-1)
            self.tracker_nan = mask & ~y_ok
            tested = np.nonzero(mask & y_ok)[0]
        else:
            tested = np.zeros(0, dtype=np.intp)
        if tested.size:
            qm = y[tested] / np.sqrt(np.sum(y[tested] ** 2, axis=-1, keepdims=True))
            z_all = _log_rotvec(_qmul(_conj(q[tested]), qm))
            S_all = P[tested, :3, :3] + R
            SI_all = np.linalg.inv(S_all)
            nis_all = np.einsum("ri,rij,rj->r", z_all, SI_all, z_all)
            self.innovation[tested] = z_all
            self.innovation_covariance[tested] = S_all
            self.nis[tested] = np.where(nis_all <= _NIS_CAP, nis_all, _NIS_CAP)
            accept = nis_all <= self._gate  # the innovation gate (NaN is rejected too)
            self.gated[tested[~accept]] = True
            sel, z, SI = tested[accept], z_all[accept], SI_all[accept]
        else:
            sel = tested
        if sel.size:
            Ps = P[sel]
            pht = Ps[:, :, :3]
            K = pht @ SI
            x = (K @ z[..., None])[..., 0]
            ikh = _EYE6 - K @ _H
            Pn = ikh @ Ps @ np.swapaxes(ikh, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
            dtheta = x[:, :3]
            q[sel] = _normalize(_qmul(q[sel], _exp_rotvec(dtheta)))
            b[sel] = b[sel] + x[:, 3:]
            if self._second:
                gm = np.broadcast_to(_EYE6, Pn.shape).copy()
                gm[:, :3, :3] -= 0.5 * _skew(dtheta)
                Pn = gm @ Pn @ np.swapaxes(gm, -1, -2)
            P[sel] = 0.5 * (Pn + np.swapaxes(Pn, -1, -2))
            self.updated[sel] = True
        self._q, self._b, self._P = q, b, P
        c = self._counts
        c["steps"] += 1
        c["updates"] += self.updated
        c["tracker_nan"] += self.tracker_nan
        c["tracker_gated"] += self.gated
        c["gyro_nan"] += self.gyro_nan
        c["gyro_rejected"] += self.gyro_rejected


@dataclass
class MEKFResult(ResultIO):
    """Histories of one MEKF run, or of many runs at once (leading runs axis).

    Shapes below are for one run; a batch adds a leading ``n_runs`` axis to
    every field except ``t``.

    Attributes
    ----------
    t : ndarray (n,)
        Step times [s].
    q : ndarray (n, 4)
        Attitude estimates ``q_BN`` after each step.
    bias : ndarray (n, 3)
        Gyro bias estimates [rad/s].
    omega : ndarray (n, 3)
        Rate estimates ``omega_meas - b_hat`` [rad/s] (last valid gyro sample held).
    P : ndarray (n, 6, 6)
        Error covariances of ``[delta_theta, delta_b]`` after each step.
    innovation : ndarray (n, 3)
        Tracker residuals ``rotvec(q_hat_prior* ⊗ q_meas)`` [rad] (NaN
        without a tracker sample; present for a gated one).
    innovation_covariance : ndarray (n, 3, 3)
        Their covariances ``S = H P_prior H^T + R`` [rad^2] (NaN without a sample).
    nis : ndarray (n,)
        Normalised innovation squared of each tracker sample, applied or
        gated (NaN without one).
    updated : ndarray (n,) of bool
        A tracker update happened at the step (see :attr:`gated` for the
        samples the innovation gate rejected).
    tracker_nan, gyro_nan : ndarray (n,) of bool
        A NaN tracker (gyro) sample was skipped at the step.
    info : dict
        Counts (per run for a batch), settings and wall time [s].
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    bias: NDArray[np.float64]
    omega: NDArray[np.float64]
    P: NDArray[np.float64]
    innovation: NDArray[np.float64]
    innovation_covariance: NDArray[np.float64]
    nis: NDArray[np.float64]
    updated: NDArray[np.bool_]
    tracker_nan: NDArray[np.bool_]
    gyro_nan: NDArray[np.bool_]
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def n_runs(self) -> int | None:
        """Number of runs of a batch result (None for a single run)."""
        return None if self.q.ndim == 2 else int(self.q.shape[0])

    @property
    def gated(self) -> NDArray[np.bool_]:
        """Steps (..., n) whose tracker sample the innovation gate rejected (a NIS but no update)."""
        return ~np.isnan(self.nis) & ~self.updated

    @property
    def sigma(self) -> NDArray[np.float64]:
        """Standard deviations ``sqrt(diag P)`` (..., n, 6) [rad, rad/s]."""
        return np.sqrt(np.diagonal(self.P, axis1=-2, axis2=-1))

    def errors(self, q_true: ArrayLike, bias_true: ArrayLike) -> NDArray[np.float64]:
        """Estimation errors (..., n, 6): ``[rotvec(q_hat* ⊗ q_true), b_true - b_hat]`` [rad, rad/s].

        The attitude part is the MEKF error ``delta_theta`` (``q_true = q_hat ⊗
        exp(delta_theta / 2)``), in body axes.

        Parameters
        ----------
        q_true : array_like (..., n, 4)
            True attitudes (broadcast against the runs axis).
        bias_true : array_like (..., n, 3)
            True gyro biases at the step times [rad/s].
        """
        qt = quat.as_unit_quaternion(q_true, "q_true")
        bt = as_float_array(bias_true, "bias_true")
        n = self.t.size
        if qt.shape[-2:] != (n, 4) or bt.shape[-2:] != (n, 3):
            raise ValueError(
                f"q_true must have shape (..., {n}, 4) and bias_true (..., {n}, 3), got {qt.shape} and {bt.shape}"
            )
        dtheta = _log_rotvec(_qmul(_conj(self.q), qt))
        return np.concatenate([dtheta, np.broadcast_to(bt, self.bias.shape) - self.bias], axis=-1)

    def nees(self, q_true: ArrayLike, bias_true: ArrayLike) -> NDArray[np.float64]:
        """NEES (..., n) of the 6-component error (chi-square, 6 dof, for a consistent filter).

        Parameters
        ----------
        q_true : array_like (..., n, 4)
            True attitudes ``q_BN`` (broadcast against the runs axis).
        bias_true : array_like (..., n, 3)
            True gyro biases at the step times [rad/s].
        """
        return nees(self.errors(q_true, bias_true), self.P)

    def nis_health(self, window: int = 50, confidence: float = 0.999, run: int = 0) -> NisHealth:
        """Moving-window NIS check (:func:`estimation.consistency.nis_health`) of one run.

        Parameters
        ----------
        window : int, optional
            Number of samples per window.
        confidence : float, optional
            Two-sided confidence of each window's chi-square band, in (0, 1).
        run : int, optional
            The run of a batch to check.
        """
        values = self.nis if self.nis.ndim == 1 else self.nis[run]
        return nis_health(values, 3, window, confidence, t=self.t)

    def plot(self, q_true: ArrayLike | None = None, bias_true: ArrayLike | None = None, run: int = 0) -> Figure:
        """Errors with +-3 sigma bounds (with the truth), else tracker residuals with +-3 sqrt(S).

        Attitude in arcsec, bias in deg/h. With the truth, every run of a
        batch is drawn; without it, the residuals of run ``run``.

        Parameters
        ----------
        q_true : array_like (..., n, 4), optional
            True attitudes ``q_BN``.
        bias_true : array_like (..., n, 3), optional
            True gyro biases [rad/s].
        run : int, optional
            The run of a batch whose residuals are drawn (without the truth).
        """
        if (q_true is None) != (bias_true is None):
            raise ValueError("q_true and bias_true must be given together (or neither)")
        labels = ["δθ1", "δθ2", "δθ3"]
        if q_true is not None:
            err = self.errors(q_true, bias_true)
            return plot_errors_with_bounds(
                self.t,
                err,
                self.sigma,
                labels=[*labels, "δb1", "δb2", "δb3"],
                units=["arcsec"] * 3 + ["deg/h"] * 3,
                scale=[1.0 / ARCSEC] * 3 + [1.0 / _DEG_PER_H] * 3,
                title=r"MEKF errors with $\pm 3\sigma$ bounds",
            )
        pick = (lambda a: a) if self.q.ndim == 2 else (lambda a: a[run])
        mask = pick(self.updated)
        if not np.any(mask):
            raise ValueError("no tracker update to plot (and no truth given)")
        s = np.sqrt(np.diagonal(pick(self.innovation_covariance)[mask], axis1=-2, axis2=-1))
        return plot_errors_with_bounds(
            self.t[mask],
            pick(self.innovation)[mask],
            s,
            labels=["residual 1", "residual 2", "residual 3"],
            units="arcsec",
            scale=1.0 / ARCSEC,
            title=r"MEKF tracker residuals with $\pm 3\sqrt{S}$ bounds",
        )


def run_mekf(
    mekf: MEKF,
    t: ArrayLike,
    gyro_meas: ArrayLike,
    tracker_meas: ArrayLike,
    *,
    tracker_mask: ArrayLike | None = None,
    q0: ArrayLike | None = None,
    bias0: ArrayLike | None = None,
    vectorized: bool | None = None,
) -> MEKFResult:
    """Run the MEKF over recorded samples: one run, or many runs at once.

    The filter passed in is not modified: a copy runs from its current state
    (if it has no time yet, it starts at ``t[0]`` with no propagation).

    Parameters
    ----------
    mekf : MEKF
        Filter settings and initial state.
    t : array_like (n,)
        Step times [s], non-decreasing (shared by all runs).
    gyro_meas : array_like (n, 3) or (n_runs, n, 3)
        Gyro samples [rad/s]; ``gyro_meas[..., k, :]`` is the mean rate over
        ``(t[k-1], t[k]]`` (row 0 only sets the first rate estimate). Rows
        with NaN, or with a component above the filter's ``max_gyro_rate``,
        are skipped, counted, and the last valid sample is held.
    tracker_meas : array_like (n, 4) or (n_runs, n, 4)
        Tracker quaternions ``q_BN``; all-NaN rows mean "no sample". Samples
        above the innovation gate are rejected and counted (``info["gated"]``,
        :attr:`MEKFResult.gated`).
    tracker_mask : array_like (n,) or (n_runs, n) of bool, optional
        True where the tracker sampled; a NaN anywhere in such a row is a
        skipped (counted) NaN sample. Default: the rows that are not all NaN.
    q0 : array_like (4,) or (n_runs, 4), optional
        Initial attitude estimate(s) replacing the filter's.
    bias0 : float or array_like (3,) or (n_runs, 3), optional
        Initial bias estimate(s) [rad/s] replacing the filter's.
    vectorized : bool, optional
        True: the numpy path over a runs axis; False: :class:`MEKF` steps
        (filterpy) run by run. Default: vectorised for a batch, steps for one run.

    Returns
    -------
    MEKFResult

    Raises
    ------
    ValueError
        For a time grid that goes backwards or is not finite, inconsistent
        shapes, a finite non-unit tracker quaternion, or invalid ``q0``/``bias0``.
    """
    if not isinstance(mekf, MEKF):
        raise ValueError(f"mekf must be an MEKF, got {type(mekf).__name__}")
    tt = as_float_array(t, "t")
    if tt.ndim != 1 or tt.size < 1:
        raise ValueError(f"t must be a 1-D array of step times, got shape {tt.shape}")
    steps = np.diff(tt)
    if np.any(steps < 0):
        i = int(np.argmax(steps < 0))
        raise ValueError(f"t must not go backwards; t[{i + 1}]={tt[i + 1]!r} < t[{i}]={tt[i]!r}")
    if mekf.t is not None and tt[0] < mekf.t:
        raise ValueError(f"t[0] = {tt[0]!r} s is before the filter's time {mekf.t!r} s")
    n = tt.size
    g = as_float_array(gyro_meas, "gyro_meas", allow_nonfinite=True)
    y = as_float_array(tracker_meas, "tracker_meas", allow_nonfinite=True)
    batch = g.ndim == 3
    if g.shape[-2:] != (n, 3) or g.ndim not in (2, 3):
        raise ValueError(f"gyro_meas must have shape ({n}, 3) or (n_runs, {n}, 3), got {g.shape}")
    if y.shape[-2:] != (n, 4) or y.ndim != g.ndim or (batch and y.shape[0] != g.shape[0]):
        raise ValueError(f"tracker_meas must have shape {(*g.shape[:-1], 4)} to match gyro_meas, got {y.shape}")
    if np.any(np.isinf(g)) or np.any(np.isinf(y)):
        raise ValueError("gyro_meas and tracker_meas must not hold inf (NaN marks a skipped sample)")
    if tracker_mask is None:
        mask = ~np.all(np.isnan(y), axis=-1)
    else:
        mask = np.asarray(tracker_mask)
        if mask.dtype != np.bool_ or mask.shape not in ((n,), y.shape[:-1]):
            raise ValueError(
                f"tracker_mask must be a boolean array of shape ({n},) or {y.shape[:-1]}, "
                f"got dtype {mask.dtype} and shape {mask.shape}"
            )
        mask = np.broadcast_to(mask, y.shape[:-1])
    finite_rows = np.all(np.isfinite(y), axis=-1)
    norms = np.sqrt(np.sum(np.where(finite_rows[..., None], y, 0.0) ** 2, axis=-1))
    bad = mask & finite_rows & (np.abs(norms - 1.0) > _UNIT_TOL)
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"tracker_meas must hold unit quaternions (| |q| - 1 | <= {_UNIT_TOL:g}); found |q| = "
            f"{norms[idx]!r} at index {idx}"
        )

    runs = g.shape[0] if batch else 1
    if q0 is not None and np.shape(q0) not in ((4,), (runs, 4)):
        raise ValueError(f"q0 must have shape (4,) or ({runs}, 4), got {np.shape(q0)}")
    if bias0 is not None and np.shape(bias0) not in ((), (3,), (runs, 3)):
        raise ValueError(f"bias0 must be a scalar or have shape (3,) or ({runs}, 3), got {np.shape(bias0)}")
    qs = np.broadcast_to(mekf.q if q0 is None else quat.as_unit_quaternion(q0, "q0"), (runs, 4))
    bs = np.broadcast_to(mekf.bias if bias0 is None else as_float_array(bias0, "bias0"), (runs, 3))
    g3 = g if batch else g[None]
    y3 = y if batch else y[None]
    m3 = mask if batch else mask[None]
    vec = batch if vectorized is None else bool(vectorized)
    start = time.perf_counter()
    if vec:
        out = _run_vectorized(mekf, tt, g3, y3, m3, qs, bs)
    else:
        out = _run_steps(mekf, tt, g3, y3, m3, qs, bs)
    wall = time.perf_counter() - start
    if not batch:
        out = {k: v[0] for k, v in out.items()}
    gyro_rejected = out.pop("gyro_rejected")
    counts = {
        "updates": np.sum(out["updated"], axis=-1),
        "tracker_nan": np.sum(out["tracker_nan"], axis=-1),
        "gyro_nan": np.sum(out["gyro_nan"], axis=-1),
        "gated": np.sum(~np.isnan(out["nis"]) & ~out["updated"], axis=-1),
        "gyro_rejected": np.sum(gyro_rejected, axis=-1),
    }
    info: dict[str, Any] = {k: v.tolist() for k, v in counts.items()}
    info.update(
        {
            "n_steps": n,
            "n_runs": runs if batch else None,
            "path": "vectorized" if vec else "filterpy steps",
            "covariance_reset": mekf.covariance_reset,
            "sigma_v": mekf.sigma_v,
            "sigma_u": mekf.sigma_u,
            "gate_probability": mekf.gate_probability,
            "gate_threshold": None if mekf.gate_probability is None else mekf.gate_threshold,
            "max_gyro_rate": mekf.max_gyro_rate,
            "wall_time_s": wall,
            "filter_steps_per_s": runs * n / wall if wall > 0 else float("inf"),
        }
    )
    return MEKFResult(t=tt.copy(), info=info, **out)


def _empty_histories(runs: int, n: int) -> dict[str, NDArray]:
    return {
        "q": np.empty((runs, n, 4)),
        "bias": np.empty((runs, n, 3)),
        "omega": np.empty((runs, n, 3)),
        "P": np.empty((runs, n, 6, 6)),
        "innovation": np.full((runs, n, 3), np.nan),
        "innovation_covariance": np.full((runs, n, 3, 3), np.nan),
        "nis": np.full((runs, n), np.nan),
        "updated": np.zeros((runs, n), dtype=bool),
        "tracker_nan": np.zeros((runs, n), dtype=bool),
        "gyro_nan": np.zeros((runs, n), dtype=bool),
        "gyro_rejected": np.zeros((runs, n), dtype=bool),
    }


def _run_steps(mekf, t, g, y, mask, qs, bs) -> dict[str, NDArray]:
    """One :class:`MEKF` (filterpy) per run, stepped in Python."""
    runs, n = g.shape[:2]
    out = _empty_histories(runs, n)
    for r in range(runs):
        f = mekf.copy()
        f._q = qs[r].copy()
        f._b = np.array(bs[r], dtype=np.float64)
        for k in range(n):
            gk = g[r, k]
            out["gyro_nan"][r, k] = not np.all(np.isfinite(gk))
            tracker = y[r, k] if mask[r, k] else None
            if tracker is not None and not np.all(np.isfinite(tracker)):
                out["tracker_nan"][r, k] = True
            before = (f._counts["updates"], f._counts["tracker_gated"], f._counts["gyro_rejected"])
            est = f.step(float(t[k]), gk, tracker)
            out["q"][r, k] = est.q
            out["bias"][r, k] = f._b
            out["omega"][r, k] = est.omega
            out["P"][r, k] = f._kf.P
            out["gyro_rejected"][r, k] = f._counts["gyro_rejected"] > before[2]
            applied = f._counts["updates"] > before[0]
            if applied or f._counts["tracker_gated"] > before[1]:
                out["updated"][r, k] = applied
                out["innovation"][r, k] = f._last_innovation
                out["innovation_covariance"][r, k] = f._last_S
                out["nis"][r, k] = f._last_nis
    return out


def _run_vectorized(mekf, t, g, y, mask, qs, bs) -> dict[str, NDArray]:
    """:meth:`MEKFBatch.step` over the recorded histories (the one definition of the batch equations)."""
    runs, n = g.shape[:2]
    out = _empty_histories(runs, n)
    batch = MEKFBatch._unchecked(mekf, qs, bs)
    for k in range(n):
        batch._step(float(t[k]), g[:, k], y[:, k], mask[:, k])
        out["q"][:, k] = batch._q
        out["bias"][:, k] = batch._b
        out["omega"][:, k] = batch._last - batch._b
        out["P"][:, k] = batch._P
        out["innovation"][:, k] = batch.innovation
        out["innovation_covariance"][:, k] = batch.innovation_covariance
        out["nis"][:, k] = batch.nis
        out["updated"][:, k] = batch.updated
        out["tracker_nan"][:, k] = batch.tracker_nan
        out["gyro_nan"][:, k] = batch.gyro_nan
        out["gyro_rejected"][:, k] = batch.gyro_rejected
    return out


# ---------------------------------------------------------------------------
# Closed-form steady state


def steady_state_covariance(
    sigma_v: float, sigma_u: float, sigma_n: float, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Steady-state covariances (2, 2) of the single-axis attitude/bias filter, in closed form.

    The per-axis model of the MEKF at zero rate: state ``[theta, b]``,
    ``Phi = [[1, -dt], [0, 1]]``, ``Q`` of :func:`process_noise` (per axis),
    an attitude measurement of variance ``r = sigma_n**2`` every ``dt``. With
    an isotropic tracker and a zero (or slow) rate the three axes decouple
    into this problem; ``dt`` is the *update* interval (the gyro may run
    faster: the sampled Farrenkopf model composes exactly, so propagating
    in gyro steps gives the same covariance at the update times).

    Derivation (spectral factorisation of the innovations; the result is
    the same steady state that Farrenkopf (1978) and Markley and Reynolds
    (2000) derive, Markley and Crassidis 2014, ch. 6, written in our own
    notation). Let ``S_v = sigma_v**2 dt / r`` and ``S_u = sigma_u**2 dt**3 / r``.
    The second difference of the measurements is an MA(2) process whose
    autocovariances are, in units of ``r``, ``c0 = 2 S_v + 2 S_u / 3 + 6``,
    ``c1 = -S_v + S_u / 6 - 4``, ``c2 = 1``. Its minimum-phase factor
    ``(1 - l1 z)(1 - l2 z)`` (``|l_i| < 1``) has
    ``l_i + 1/l_i - 2 = u_i`` with ``u_1, u_2`` the roots of
    ``u**2 - (S_v - S_u / 6) u + S_u = 0``, and the innovation variance of
    the steady-state filter is ``S = r / (l1 l2)``. Writing
    ``A = sqrt(1 + S_v/4 + S_u/48)`` and
    ``B = sqrt(S_v + S_u/3 + 2 sqrt(S_u) A)`` (both real even when the
    ``u_i`` are complex),

    .. math::

        \\sqrt{l_1 l_2} = A - B/2 + \\sqrt{S_u}/4 .

    Then, with ``q12 = -sigma_u**2 dt**2 / 2`` and ``q22 = sigma_u**2 dt``:

    - pre-update: ``p11 = S - r``, ``p12 = -sqrt(q22 S)``,
      ``p22 = q22 + (q12 - p12 p11 / S) / dt``;
    - post-update: ``p11+ = r (1 - l1 l2)``, ``p12+ = p12 r / S``,
      ``p22+ = p22 - p12**2 / S``.

    (From ``P- = Phi P+ Phi^T + Q`` and ``P+ = P- - P- H^T H P- / S``: the
    bias row gives ``p12**2 = q22 S``, the cross term gives ``p22``.)
    ``1 - l1 l2`` is formed without cancellation for small ``S_v``, ``S_u``.

    Parameters
    ----------
    sigma_v : float
        Angle-random-walk density [rad/s^0.5] (> 0).
    sigma_u : float
        Rate-random-walk density [rad/s^1.5] (> 0).
    sigma_n : float
        Attitude-measurement noise standard deviation per axis [rad] (> 0).
    dt : float
        Measurement interval [s] (> 0).

    Returns
    -------
    P_pre, P_post : ndarray (2, 2)
        Before and after an update, ``[[rad^2, rad^2/s], [rad^2/s, rad^2/s^2]]``.
    """
    sv = positive_scalar(sigma_v, "sigma_v")
    su = positive_scalar(sigma_u, "sigma_u")
    sn = positive_scalar(sigma_n, "sigma_n")
    h = positive_scalar(dt, "dt")
    r = sn**2
    s_v = sv**2 * h / r
    s_u = su**2 * h**3 / r
    root_su = np.sqrt(s_u)
    a = np.sqrt(1.0 + s_v / 4.0 + s_u / 48.0)
    b = np.sqrt(s_v + s_u / 3.0 + 2.0 * root_su * a)
    sqrt_l = a - 0.5 * b + 0.25 * root_su
    # 1 - sqrt(l) = B/2 - sqrt(S_u)/4 - (A - 1), with A - 1 = (S_v/4 + S_u/48) / (A + 1): no cancellation.
    one_minus_sqrt_l = 0.5 * b - 0.25 * root_su - (s_v / 4.0 + s_u / 48.0) / (a + 1.0)
    one_minus_l = one_minus_sqrt_l * (1.0 + sqrt_l)
    lam = sqrt_l**2
    innov = r / lam
    q12 = -(su**2) * h**2 / 2.0
    q22 = su**2 * h
    p11 = r * one_minus_l / lam
    p12 = -np.sqrt(q22 * innov)
    p22 = q22 + (q12 - p12 * p11 / innov) / h
    pre = np.array([[p11, p12], [p12, p22]])
    post = np.array([[r * one_minus_l, p12 * r / innov], [p12 * r / innov, p22 - p12**2 / innov]])
    return pre, post


def steady_state_attitude_sigma(
    sigma_v: float, sigma_u: float, sigma_n: float, dt: float, *, when: str = "post"
) -> float:
    """Closed-form steady-state attitude error standard deviation per axis [rad].

    ``sqrt(p11)`` of :func:`steady_state_covariance` (see there for the
    formula and its derivation): ``sigma_n sqrt(1 - l1 l2)`` just after an
    update (``when="post"``) or ``sigma_n sqrt(1/(l1 l2) - 1)`` just before
    one (``when="pre"``).

    Parameters
    ----------
    sigma_v : float
        Angle-random-walk density [rad/s^0.5] (> 0).
    sigma_u : float
        Rate-random-walk density [rad/s^1.5] (> 0).
    sigma_n : float
        Attitude-measurement noise per axis [rad] (> 0).
    dt : float
        Measurement interval [s] (> 0).
    when : {"post", "pre"}
        After or before an update.
    """
    if when not in ("post", "pre"):
        raise ValueError(f"when must be 'post' or 'pre', got {when!r}")
    pre, post = steady_state_covariance(sigma_v, sigma_u, sigma_n, dt)
    return float(np.sqrt((post if when == "post" else pre)[0, 0]))

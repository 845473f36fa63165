"""Rate EKF: body rate and gyro bias from a gyro and Euler's equations (filterpy).

The state is ``[omega_BN_B (3) [rad/s], beta (3) [rad/s]]`` (body rate and
gyro bias), or the rate alone when the bias is known. The mean is
propagated with RK4 on Euler's equations (:mod:`attitude.rigid_body`), the
covariance with the exact discrete transition and Van Loan's process noise;
gyro samples update it with the Farrenkopf-correlated noise model, behind an
innovation gate, with NIS health checks (:class:`RateEKF`, filterpy).

See docs/rate_ekf.md for the derivation (models, measurement correlation,
gate, observability, torque inputs, health thresholds, filterpy notes).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray
from scipy import stats

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.integrators import rk4_step
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody, split_components
from attitude.sensors import Gyro
from attitude.simulation.protocols import Estimate
from attitude.validation import (
    as_float_array,
    check_covariance,
    check_positive,
    describe,
    positive_scalar,
    scalar_time,
)
from estimation.consistency import (
    GATE_PROBABILITY,
    NIS_CAP,
    chi2_band,
    gate_threshold,
    nees,
    nis_health,
    plot_errors_with_bounds,
)

__all__ = ["NOISE_MODELS", "RateEKF", "RateEKFResult", "StepReport", "run_rate_ekf"]

#: Gyro measurement-noise treatments (see the module docstring).
NOISE_MODELS = ("farrenkopf", "uncorrelated")

_DIM_Z = 3


# ---------------------------------------------------------------------------
# Helpers


# Truncation tolerance of the Taylor series in :func:`_van_loan`, relative to each block's size.
_SERIES_TOL = 1e-17
# Largest 1-norm of the scaled block matrix before the series (scaling and squaring).
_SERIES_NORM = 0.25


def _van_loan(a: NDArray[np.float64], g: NDArray[np.float64], dt: float) -> tuple[NDArray, NDArray]:
    """``(Phi, Q)`` of ``x' = a x + g u`` (``u`` unit white noise) over ``dt`` [s] by Van Loan's method.

    The same quantity as :func:`filterpy.common.van_loan_discretization`
    ``(a, g, dt)``: ``E = expm([[-a, g g^T], [0, a^T]] dt)``, ``Phi = E22^T``,
    ``Q = Phi E12``. The exponential is evaluated with numpy matrix products
    only (scaling and squaring, then a Taylor series whose truncation error is
    bounded below 1e-17 of each block): scipy's ``expm`` calls multi-threaded
    BLAS, which on a loaded 2-core machine made each call up to a hundred
    times slower. ``Q`` is linear in ``g g^T``, so the noise block is scaled to
    the size of the dynamics block first (relative accuracy for tiny noise).
    """
    n = a.shape[0]
    a_dt = a * dt
    w_dt = (g @ g.T) * dt
    norm_a = float(np.abs(a_dt).sum(axis=0).max())
    norm_w = float(np.abs(w_dt).sum(axis=0).max())
    scale = max(norm_a, 1e-3) / norm_w if norm_w > 0 else 1.0
    m = np.zeros((2 * n, 2 * n))
    m[:n, :n] = -a_dt
    m[:n, n:] = w_dt * scale
    m[n:, n:] = a_dt.T
    theta = float(np.abs(m).sum(axis=0).max())
    squarings = max(0, math.ceil(math.log2(theta / _SERIES_NORM))) if theta > _SERIES_NORM else 0
    m /= 2.0**squarings
    theta /= 2.0**squarings
    # Order: the remainder theta^(k+1)/(k+1)! e^theta, relative to a block of size ~theta.
    order, bound = 1, theta / 2.0 * math.exp(theta)
    while bound > _SERIES_TOL:
        order += 1
        bound *= theta / (order + 1)
    eye = np.eye(2 * n)
    e = eye + m / order  # Horner: I + m (I + m/2 (I + ... (I + m/order)))
    for k in range(order - 1, 0, -1):
        e = eye + (m @ e) / k
    for _ in range(squarings):
        e = e @ e
    phi = e[n:, n:].T
    return phi, (phi @ e[:n, n:]) / scale


def _vector3(value: Any, name: str) -> NDArray[np.float64]:
    arr = as_float_array(value, name)
    if arr.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got shape {arr.shape}")
    return arr


@dataclass(frozen=True)
class _StepInput:
    """Inputs of one prediction substep: known torque, internal momentum at its start and rate, length."""

    torque: tuple[float, float, float]
    h0: tuple[float, float, float]
    hdot: tuple[float, float, float]
    dt: float


@dataclass(frozen=True)
class StepReport:
    """What one :meth:`RateEKF.step` did.

    Attributes
    ----------
    t : float
        Time of the step [s].
    updated : bool
        A gyro sample was used.
    nan_skipped : bool
        A gyro sample was present but non-finite, and skipped.
    innovation : ndarray (3,)
        ``z - h(x_prior)`` [rad/s] (NaN without a sample; present for a
        gated one).
    innovation_covariance : ndarray (3, 3)
        Its covariance ``S`` [rad^2/s^2] (NaN without a sample).
    nis : float
        ``nu^T S^-1 nu`` (NaN without a sample; for a gated sample the value
        that was rejected, capped at 1e300).
    nis_exceeds : bool
        The NIS is above the per-step chi-square threshold.
    health_flag : bool
        A run of exceedances or an out-of-band NIS window is in progress.
    gated : bool
        A finite sample was rejected by the innovation gate (not applied).
    """

    t: float
    updated: bool
    nan_skipped: bool
    innovation: NDArray[np.float64]
    innovation_covariance: NDArray[np.float64]
    nis: float
    nis_exceeds: bool
    health_flag: bool
    gated: bool = False


class _Breakdown(Exception):
    """The state or covariance would become non-finite (turned into a ValueError by :meth:`RateEKF.step`)."""


# ---------------------------------------------------------------------------
# The filter


class _FilterpyEKF(ExtendedKalmanFilter):
    """filterpy's EKF with the nonlinear mean propagation plugged in (``predict_x``)."""

    def __init__(self, dim_x: int, plant: RigidBody) -> None:
        super().__init__(dim_x=dim_x, dim_z=_DIM_Z)
        self.plant = plant

    def predict_x(self, u: Any = 0) -> None:
        """RK4 on Euler's equations (:meth:`RigidBody.omega_dot_components`) over one substep; bias constant.

        ``u`` is the substep input (known torque, internal momentum and its
        rate, length); filterpy's default ``F x`` would be wrong for this
        model, so anything else is refused.
        """
        if not isinstance(u, _StepInput):
            raise ValueError(f"predict needs a step input (torque, momentum, dt), got {u!r}; use RateEKF.step(t, ...)")
        body = self.plant
        tau = list(u.torque)
        h0, hd = u.h0, u.hdot
        has_h = any(h0) or any(hd)

        def derivative(s: float, w: list) -> list:
            h = [h0[i] + s * hd[i] for i in range(3)] if has_h else None
            return body.omega_dot_components(w, tau, h)

        w = [float(v) for v in self.x[:3]]
        w_next = rk4_step(derivative, 0.0, w, u.dt)
        self.x = np.concatenate([np.array(w_next, dtype=np.float64), self.x[3:]])

    def predict_update(self, *args: Any, **kwargs: Any) -> None:
        """Disabled: filterpy's ``predict_update`` ignores ``predict_x`` and evaluates ``H`` at the old state."""
        raise NotImplementedError(
            "predict_update is disabled: filterpy 2.0.0 propagates F x there (ignoring the nonlinear "
            "predict_x) and evaluates H at the old state; use RateEKF.step()"
        )


class RateEKF:
    """Extended Kalman filter of body rate and gyro bias, built on filterpy's ``ExtendedKalmanFilter``.

    See docs/rate_ekf.md for the models. Drive it with :meth:`step`, the
    engine protocol :meth:`update`, or :func:`run_rate_ekf` for a recorded
    run. The filterpy object is :attr:`kf` (its ``predict_x`` is the
    nonlinear propagation; its ``predict_update`` is disabled); :attr:`x`,
    :attr:`P` and the other arrays are its 1-D state and covariance.

    Parameters
    ----------
    body : RigidBody
        The whole spacecraft (wheels included) [kg m^2]; a single body.
    sigma_v : float
        Gyro angle-random-walk density [rad/s^0.5] (> 0).
    sigma_u : float
        Gyro rate-random-walk density [rad/s^1.5] (>= 0; 0: a constant bias).
    gyro_period : float
        The gyro's sample interval ``dt_g`` [s] (> 0), the averaging time of
        each sample (sets ``R``).
    torque_noise : float or array_like (3,)
        Torque-uncertainty density [N m / sqrt(Hz)] per body axis (>= 0;
        0 trusts the model and the torque exactly). See docs/rate_ekf.md.
    P0 : array_like (n, n) or (n,)
        Initial covariance of ``[omega, beta]`` (``n = 6``) or of ``omega``
        (``n = 3`` when ``estimate_bias`` is False) [rad^2/s^2], or its
        diagonal; symmetric positive definite.
    x0 : array_like (n,), optional
        Initial estimate [rad/s] (default zero).
    wheels : ReactionWheels, optional
        Reaction wheels: hub inertia, internal momentum and reaction torque
        from the wheel momenta (docs/rate_ekf.md).
    h_wheels0 : array_like (n_wheels,), optional
        Wheel momenta at ``t0`` [N m s] (default: taken from the first step
        that provides them).
    estimate_bias : bool
        False: a rate-only filter with the bias known (``known_bias``); then
        ``sigma_u`` must be 0.
    known_bias : float or array_like (3,)
        The known bias [rad/s] when ``estimate_bias`` is False.
    noise_model : {"farrenkopf", "uncorrelated"}
        Treatment of the correlation between the gyro noise and the bias
        random walk (docs/rate_ekf.md).
    t0 : float
        Time of ``x0`` [s].
    period : float, optional
        Estimator period for :func:`attitude.simulation.engine.simulate` [s]
        (default ``gyro_period``).
    max_step : float, optional
        Longest prediction substep [s] (default ``gyro_period``).
    q0 : array_like (4,), optional
        Initial attitude ``q_BN`` for the open-loop attitude of :meth:`update`
        (default identity).
    gyro_name : str
        Key of the gyro sample in the engine's measurements.
    attitude_name : str, optional
        Key of an attitude sensor (e.g. ``"star_tracker"``) whose samples
        reset the reported attitude.
    nis_confidence : float
        Per-step chi-square confidence of the NIS test, in (0, 1).
    nis_run_length : int
        Consecutive exceedances that raise the health flag (>= 1).
    nis_window : int
        Updates per window of the moving-mean NIS test (>= 1).
    health_confidence : float
        Two-sided confidence of the window band, in (0, 1) (see the module
        docstring for the false-alarm rates).
    gate_probability : float or None
        Probability of the innovation gate, in (0, 1): a sample whose NIS
        exceeds ``chi2.ppf(gate_probability, 3)`` is rejected (module
        docstring). Default ``1 - 1e-9``; None disables the gate.

    Raises
    ------
    ValueError
        For a non-positive ``sigma_v`` or ``gyro_period``, negative
        ``sigma_u`` or ``torque_noise``, a ``P0`` that is not symmetric
        positive definite, a non-finite ``x0``, mismatched shapes, an
        unknown ``noise_model``, ``sigma_u > 0`` with ``estimate_bias``
        False, or invalid health or gate settings.

    Attributes
    ----------
    kf : filterpy.kalman.ExtendedKalmanFilter
        The underlying filter (1-D ``x`` and ``z``).
    t : float
        Time of the current estimate [s].
    period : float
        Estimator period for the engine [s].
    q : ndarray (4,)
        The open-loop attitude reported to the engine.
    n_updates, n_nan_skipped, n_wheel_nan_skipped, n_attitude_nan_skipped, n_nis_exceeds : int
        Counters of gyro updates, skipped non-finite gyro samples, wheel
        momenta and attitude samples, and per-step NIS exceedances.
    n_gated : int
        Gyro samples rejected by the innovation gate.
    gate_threshold : float
        The NIS gate ``chi2.ppf(gate_probability, 3)`` (inf when disabled).
    """

    def __init__(
        self,
        body: RigidBody,
        *,
        sigma_v: float,
        sigma_u: float,
        gyro_period: float,
        torque_noise: ArrayLike,
        P0: ArrayLike,
        x0: ArrayLike | None = None,
        wheels: ReactionWheels | None = None,
        h_wheels0: ArrayLike | None = None,
        estimate_bias: bool = True,
        known_bias: ArrayLike = 0.0,
        noise_model: str = "farrenkopf",
        t0: float = 0.0,
        period: float | None = None,
        max_step: float | None = None,
        q0: ArrayLike | None = None,
        gyro_name: str = "gyro",
        attitude_name: str | None = None,
        nis_confidence: float = 0.99,
        nis_run_length: int = 3,
        nis_window: int = 50,
        health_confidence: float = 0.99999,
        gate_probability: float | None = GATE_PROBABILITY,
    ) -> None:
        if not isinstance(body, RigidBody) or body.batch_shape:
            raise ValueError(f"body must be a single RigidBody, got {body!r}")
        if wheels is not None and not isinstance(wheels, ReactionWheels):
            raise ValueError(f"wheels must be a ReactionWheels or None, got {wheels!r}")
        self.sigma_v = positive_scalar(sigma_v, "sigma_v")
        self.sigma_u = positive_scalar(sigma_u, "sigma_u", allow_zero=True)
        self.gyro_period = positive_scalar(gyro_period, "gyro_period")
        tn = check_positive(torque_noise, "torque_noise", allow_zero=True)
        if tn.ndim > 1 or (tn.ndim == 1 and tn.size != 3):
            raise ValueError(f"torque_noise must be a scalar or have shape (3,) [N m / sqrt(Hz)], got {tn.shape}")
        self.torque_noise = np.broadcast_to(tn, (3,)).astype(np.float64)
        if noise_model not in NOISE_MODELS:
            raise ValueError(f"noise_model must be one of {NOISE_MODELS}, got {noise_model!r}")
        self.noise_model = noise_model
        if not isinstance(estimate_bias, bool):
            raise ValueError(f"estimate_bias must be a bool, got {estimate_bias!r}")
        self.estimate_bias = estimate_bias
        if not estimate_bias and self.sigma_u > 0:
            raise ValueError(
                "sigma_u must be 0 when estimate_bias is False (a drifting bias must be estimated), "
                f"got sigma_u = {self.sigma_u!r} rad/s^1.5"
            )
        kb = as_float_array(known_bias, "known_bias")
        if kb.ndim > 1 or (kb.ndim == 1 and kb.size != 3):
            raise ValueError(f"known_bias must be a scalar or have shape (3,) [rad/s], got shape {kb.shape}")
        self.known_bias = np.broadcast_to(kb, (3,)).astype(np.float64)
        n = 6 if estimate_bias else 3

        # Plant: the hub body with wheels (the wheels' spin inertia is carried by h).
        self.body = body
        self.wheels = wheels
        self.plant = body if wheels is None else wheels.hub_body(body)
        self._n_wheels = 0 if wheels is None else wheels.n_wheels
        self._h_wheels: NDArray[np.float64] | None = None
        if h_wheels0 is not None:
            if wheels is None:
                raise ValueError("h_wheels0 needs wheels")
            self._h_wheels = self._wheel_vector(h_wheels0, "h_wheels0", allow_nonfinite=False)
        self._jacobian_coefficients()
        # Noise input of the rate block: omega_dot += I^-1 diag(torque_noise) u, u unit white [rad/s^1.5].
        self._g_rate = self.plant.inertia_inv * self.torque_noise[None, :]

        # The filterpy filter, with 1-D x and z (see the filterpy notes in the module docstring).
        x = np.zeros(n) if x0 is None else as_float_array(x0, "x0")
        if x.shape != (n,):
            raise ValueError(f"x0 must have shape ({n},) [rad/s], got shape {x.shape}")
        kf = _FilterpyEKF(n, self.plant)
        kf.x = x.astype(np.float64).copy()
        kf.P = check_covariance(P0, "P0", n, variances=True)
        #: The initial covariance (a copy) [rad^2/s^2].
        self.P0 = kf.P.copy()
        kf.x_prior, kf.P_prior = kf.x.copy(), kf.P.copy()
        kf.x_post, kf.P_post = kf.x.copy(), kf.P.copy()
        kf.R = self.measurement_variance() * np.eye(_DIM_Z)
        kf.y = np.zeros(_DIM_Z)
        kf.z = np.full(_DIM_Z, np.nan)
        kf.K = np.zeros((n, _DIM_Z))
        self.kf = kf
        self._H = np.hstack([np.eye(3), np.eye(3)]) if estimate_bias else np.eye(3)
        self.t = scalar_time(t0, "t0")
        self._t_start = self.t
        self._t_last_update: float | None = None

        self.period = self.gyro_period if period is None else positive_scalar(period, "period")
        self.max_step = self.gyro_period if max_step is None else positive_scalar(max_step, "max_step")
        self.q = quat.identity() if q0 is None else quat.as_unit_quaternion(q0, "q0").copy()
        if self.q.shape != (4,):
            raise ValueError(f"q0 must have shape (4,), got {self.q.shape}")
        for name, value in (("gyro_name", gyro_name), ("attitude_name", attitude_name)):
            if value is not None and (not isinstance(value, str) or not value):
                raise ValueError(f"{name} must be a non-empty string, got {value!r}")
        self.gyro_name = gyro_name
        self.attitude_name = attitude_name

        # Health.
        self.nis_confidence = _open_unit(nis_confidence, "nis_confidence")
        self.health_confidence = _open_unit(health_confidence, "health_confidence")
        self.nis_run_length = _count(nis_run_length, "nis_run_length")
        self.nis_window = _count(nis_window, "nis_window")
        #: Per-step NIS threshold ``chi2.ppf(nis_confidence, 3)``.
        self.nis_threshold = float(stats.chi2.ppf(self.nis_confidence, _DIM_Z))
        #: Band of the mean NIS of a window (``chi2_band(3, nis_window, health_confidence)``).
        self.nis_window_band = chi2_band(_DIM_Z, self.nis_window, self.health_confidence)
        if gate_probability is None:
            self.gate_probability = None
            self.gate_threshold = math.inf
        else:
            self.gate_probability = _open_unit(gate_probability, "gate_probability")
            self.gate_threshold = gate_threshold(self.gate_probability, _DIM_Z)
        self._recent_nis: deque[float] = deque(maxlen=self.nis_window)
        self._run = 0
        self.n_updates = 0
        self.n_gated = 0
        self._largest_applied_nis: tuple[float | None, float] = (None, -math.inf)  # (time [s], NIS)
        self.n_nan_skipped = 0
        self.n_wheel_nan_skipped = 0
        self.n_nis_exceeds = 0
        self.n_attitude_nan_skipped = 0
        self._last: StepReport | None = None

    def __repr__(self) -> str:
        return (
            f"RateEKF(t={self.t:g} s, states={self.dim_x}, sigma_v={self.sigma_v:.4g} rad/s^0.5, "
            f"sigma_u={self.sigma_u:.4g} rad/s^1.5, gyro_period={self.gyro_period:g} s, "
            f"noise_model={self.noise_model!r})"
        )

    # -- construction --------------------------------------------------------------

    @classmethod
    def from_gyro(cls, body: RigidBody, gyro: Gyro, *, sampling_check: str = "warn", **kwargs: Any) -> RateEKF:
        """A filter for a :class:`attitude.sensors.Gyro`: its ``sigma_v``, ``filter_sigma_u``, ``period`` and name.

        ``gyro.sigma_v`` must be > 0. The filter models a sample as the rate
        at the sample time, so ``gyro.sampling`` must be
        ``"instantaneous"`` (docs/rate_ekf.md); ``sampling_check`` says what
        a mismatch does: ``"warn"`` (default, a
        :class:`attitude.sensors.GyroSamplingWarning`), ``"raise"``
        (ValueError) or ``"ignore"`` (for samples that are not this gyro's
        own, e.g. generated separately). Other keywords as for the class
        (``torque_noise`` and ``P0`` are required).

        Parameters
        ----------
        body : RigidBody
            The spacecraft (inertia [kg m^2]).
        gyro : Gyro
            The gyro (``sampling="instantaneous"``, ``sigma_v > 0``).
        sampling_check : {"warn", "raise", "ignore"}, optional
            What a gyro that does not sample instantaneously does.
        **kwargs
            Other keywords of the constructor (``torque_noise`` and ``P0`` required).
        """
        if not isinstance(gyro, Gyro):
            raise ValueError(f"gyro must be an attitude.sensors.Gyro, got {gyro!r}")
        gyro.check_sampling("instantaneous", consumer="RateEKF.from_gyro", action=sampling_check)
        kwargs.setdefault("gyro_name", gyro.name)
        # A Gauss-Markov bias (the bias instability) enters as its bounding random walk (Gyro.filter_sigma_u).
        return cls(body, sigma_v=gyro.sigma_v, sigma_u=gyro.filter_sigma_u, gyro_period=gyro.period, **kwargs)

    def _jacobian_coefficients(self) -> None:
        """Exact ``A(omega, h) = A0 + sum_i c_i [omega, h]_i`` from casadi's Jacobian of the one definition."""
        w = ca.SX.sym("omega", 3)
        h = ca.SX.sym("h", 3)
        tau = ca.SX.sym("tau", 3)
        wdot = ca.vertcat(
            *self.plant.omega_dot_components(split_components(w, 3), split_components(tau, 3), split_components(h, 3))
        )
        a = ca.jacobian(wdot, w)
        wh = ca.vertcat(w, h)
        coeff = ca.jacobian(ca.vec(a), wh)  # (9, 6): constant when A is affine in (omega, h)
        if ca.jacobian(coeff, ca.vertcat(wh, tau)).nnz() != 0 or ca.jacobian(ca.vec(a), tau).nnz() != 0:
            raise RuntimeError("Euler's equations are expected to have a Jacobian affine in (omega, h)")
        a0, c = ca.Function("rate_jacobian", [wh], [a, coeff])(np.zeros(6))
        self._a0 = np.array(a0)
        self._a_coeff = np.array(c)  # casadi's vec is column-major: vec(A) = A.ravel(order="F")

    def jacobian(self, omega: ArrayLike, h_body: ArrayLike | None = None) -> NDArray[np.float64]:
        """Continuous Jacobian ``d omega_dot / d omega`` (3, 3) [1/s] at ``omega`` [rad/s] and ``h_body`` [N m s].

        ``h_body`` is the internal (wheel) momentum in body components.

        Parameters
        ----------
        omega : array_like (3,)
            Body rate [rad/s].
        h_body : array_like (3,), optional
            Internal (wheel) momentum in body components [N m s]; default zero.
        """
        wh = np.concatenate([_vector3(omega, "omega"), np.zeros(3) if h_body is None else _vector3(h_body, "h_body")])
        return self._a0 + (self._a_coeff @ wh).reshape((3, 3), order="F")

    def measurement_variance(self) -> float:
        """Per-axis ``R = sigma_v**2 / dt_g + sigma_u**2 dt_g / 3`` [rad^2/s^2] (docs/rate_ekf.md)."""
        return self.sigma_v**2 / self.gyro_period + self.sigma_u**2 * self.gyro_period / 3.0

    # -- state --------------------------------------------------------------------

    @property
    def dim_x(self) -> int:
        """Number of states (6 with bias, 3 without)."""
        return int(self.kf.dim_x)

    @property
    def x(self) -> NDArray[np.float64]:
        """State estimate ``[omega, beta]`` (or ``omega``) [rad/s] (a copy)."""
        return self.kf.x.copy()

    @property
    def P(self) -> NDArray[np.float64]:
        """Error covariance [rad^2/s^2] (a copy)."""
        return self.kf.P.copy()

    @property
    def omega(self) -> NDArray[np.float64]:
        """Estimated body rate ``omega_BN_B`` [rad/s] (a copy)."""
        return self.kf.x[:3].copy()

    @property
    def bias(self) -> NDArray[np.float64]:
        """Estimated (or known) gyro bias [rad/s] (a copy)."""
        return self.kf.x[3:6].copy() if self.estimate_bias else self.known_bias.copy()

    @property
    def sigma(self) -> NDArray[np.float64]:
        """Standard deviations (square roots of the diagonal of ``P``) [rad/s]."""
        return np.sqrt(np.diag(self.kf.P))

    @property
    def health_flag(self) -> bool:
        """True while a run of NIS exceedances or an out-of-band NIS window is in progress."""
        return self._last.health_flag if self._last is not None else False

    # -- prediction -------------------------------------------------------------------

    def _transition(self, inp: _StepInput) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``F`` and ``Q`` of one substep, linearised at the current estimate (Van Loan)."""
        wh = np.concatenate([self.kf.x[:3], inp.h0])
        a = self._a0 + (self._a_coeff @ wh).reshape((3, 3), order="F")
        if not np.all(np.isfinite(a)):
            raise _Breakdown("the Jacobian of Euler's equations at the estimate is not finite")
        phi, q_rate = _van_loan(a, self._g_rate, inp.dt)
        n = self.dim_x
        f = np.eye(n)
        f[:3, :3] = phi
        q = np.zeros((n, n))
        q[:3, :3] = 0.5 * (q_rate + q_rate.T)
        if self.estimate_bias:
            q[3:, 3:] = self.sigma_u**2 * inp.dt * np.eye(3)
        return f, q

    def _propagate(self, dt: float, torque: NDArray, h0: NDArray, hdot: NDArray) -> None:
        n_sub = max(1, math.ceil(dt / self.max_step - 1e-9))
        h = dt / n_sub
        tau = (float(torque[0]), float(torque[1]), float(torque[2]))
        hd = (float(hdot[0]), float(hdot[1]), float(hdot[2]))
        kf = self.kf
        for i in range(n_sub):
            start = h0 + (i * h) * hdot
            inp = _StepInput(tau, (float(start[0]), float(start[1]), float(start[2])), hd, h)
            kf.F, kf.Q = self._transition(inp)  # filterpy's predict uses F and Q as they stand
            kf.predict(u=inp)
            kf.P = 0.5 * (kf.P + kf.P.T)
            if not (np.all(np.isfinite(kf.x)) and np.all(np.isfinite(kf.P))):
                raise _Breakdown("the prediction (Euler's equations from the current estimate) overflowed")

    # -- update -----------------------------------------------------------------------

    def _hx(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return x[:3] + x[3:6] if self.estimate_bias else x[:3] + self.known_bias

    def _update(self, z: NDArray[np.float64], t: float) -> tuple[float, NDArray, NDArray, bool]:
        """Gate, then (if accepted) update; returns ``(nis, innovation, S, accepted)``."""
        kf = self.kf
        h = self._H
        r = kf.R
        if self.noise_model == "farrenkopf" and self.estimate_bias and self.sigma_u > 0:
            since = t - (self._t_start if self._t_last_update is None else self._t_last_update)
            m_scalar = -0.5 * self.sigma_u**2 * min(self.gyro_period, since)
            if m_scalar != 0.0:
                # Equivalent decorrelated measurement: H' = H + L, R' = R - L M with L = M^T P^-1.
                m = np.zeros((6, 3))
                m[3:, :] = m_scalar * np.eye(3)
                try:
                    ell = np.linalg.solve(kf.P, m).T  # P is symmetric: (P^-1 M)^T = M^T P^-1
                except np.linalg.LinAlgError as exc:
                    raise _Breakdown("the prior covariance is singular") from exc
                h = h + ell
                r = r - ell @ m
                r = 0.5 * (r + r.T)
        h_eff = h
        # The gate, on the prior innovation (the same S as filterpy's, before anything is applied).
        nu = z - self._hx(kf.x)
        s = h_eff @ kf.P @ h_eff.T + r
        if not np.all(np.isfinite(s)):
            raise _Breakdown("the innovation covariance is not finite")
        try:
            nis_gate = float(nu @ np.linalg.solve(s, nu))
        except np.linalg.LinAlgError as exc:
            raise _Breakdown("the innovation covariance is singular") from exc
        if nis_gate < 0:
            raise _Breakdown(f"the innovation covariance is not positive definite (NIS {nis_gate:.3g})")
        if not nis_gate <= self.gate_threshold:  # also rejects an infinite or NaN NIS
            return (nis_gate if nis_gate <= NIS_CAP else NIS_CAP), nu, s, False
        kf.update(z, HJacobian=lambda _x: h_eff, Hx=self._hx, R=r)
        kf.P = 0.5 * (kf.P + kf.P.T)
        if not (np.all(np.isfinite(kf.x)) and np.all(np.isfinite(kf.P))):
            raise _Breakdown(f"the update with the gyro sample {z.tolist()} rad/s (NIS {nis_gate:.3g}) overflowed")
        nu = np.array(kf.y, dtype=np.float64)
        s = np.array(kf.S, dtype=np.float64)
        nis_value = float(nu @ kf.SI @ nu)  # filterpy keeps S^-1
        return nis_value, nu, s, True

    # -- public stepping ----------------------------------------------------------------

    def _wheel_vector(self, value: Any, name: str, *, allow_nonfinite: bool) -> NDArray[np.float64]:
        arr = as_float_array(value, name, allow_nonfinite=allow_nonfinite).reshape(-1)
        if arr.size != self._n_wheels:
            raise ValueError(f"{name} must hold one momentum per wheel ({self._n_wheels}) [N m s], got {arr.size}")
        return arr.copy()

    def step(
        self,
        t: float,
        gyro: ArrayLike | None = None,
        *,
        torque: ArrayLike | None = None,
        wheel_momentum: ArrayLike | None = None,
        external_torque: ArrayLike | None = None,
    ) -> StepReport:
        """Predict to ``t`` and update with a gyro sample taken at ``t``.

        Parameters
        ----------
        t : float
            Time [s] (not before the filter's time).
        gyro : array_like (3,) or None
            Gyro sample [rad/s]; None: no sample (predict only). A
            non-finite sample is skipped and counted; a sample whose NIS is
            above the gate is rejected and counted (docs/rate_ekf.md).
        torque : array_like (3,), optional
            Known actuator torque on the body held over the interval ending
            at ``t`` [N m] (the engine's ``"torque_command"``; default zero).
            With wheels and their momenta known at both ends of the interval
            it is replaced by the wheels' reaction torque from the momenta
            (docs/rate_ekf.md); it is the fallback when they are not.
        wheel_momentum : array_like (n_wheels,), optional
            Wheel spin-axis momenta at ``t`` [N m s] (ignored without wheels;
            non-finite: treated as missing and counted).
        external_torque : array_like (3,), optional
            Known torque from outside the wheels (environment torques from a
            model, magnetorquers) held over the interval ending at ``t``
            [N m], body axes; added to the actuator torque in every case,
            with or without wheels (default zero). An external torque left
            out here must be covered by ``torque_noise``.

        Returns
        -------
        StepReport

        Raises
        ------
        ValueError
            If ``t`` is not finite or earlier than the filter's time, the
            torque or the external torque is not a finite (3,) vector, a
            sample has the wrong shape, or the covariance loses positive
            definiteness; or on a numerical
            breakdown (the state or covariance would become non-finite: the
            message names the time and cause, and the filter is left as it
            was before the step).
        """
        t = scalar_time(t, "t")
        if t < self.t:
            raise ValueError(f"t must not go backwards: t = {t!r} s is before the filter time {self.t!r} s")
        dt = t - self.t
        tau = np.zeros(3) if torque is None else _vector3(torque, "torque")
        tau_ext = np.zeros(3) if external_torque is None else _vector3(external_torque, "external_torque")
        # Validate every input before the state changes.
        z = None
        nan_skipped = False
        if gyro is not None:
            z = as_float_array(gyro, "gyro", allow_nonfinite=True)
            if z.shape != (3,):
                raise ValueError(f"gyro must have shape (3,) [rad/s], got shape {z.shape}")
            if not np.all(np.isfinite(z)):
                nan_skipped = True
                z = None
        hw = None
        if self.wheels is not None and wheel_momentum is not None:
            hw = self._wheel_vector(wheel_momentum, "wheel_momentum", allow_nonfinite=True)
        # filterpy re-assigns (never mutates) its arrays, so references are a snapshot for a breakdown.
        kf = self.kf
        saved = (
            {k: getattr(kf, k) for k in ("x", "P", "x_prior", "P_prior", "x_post", "P_post", "F", "Q")},
            self.t,
            self._h_wheels,
            self.n_wheel_nan_skipped,
        )
        try:
            with np.errstate(over="ignore", invalid="ignore"):  # overflow is caught by the finiteness checks
                return self._step(t, dt, tau, tau_ext, z, nan_skipped, hw)
        except _Breakdown as exc:
            for key, value in saved[0].items():
                setattr(kf, key, value)
            self.t, self._h_wheels, self.n_wheel_nan_skipped = saved[1:]
            w = float(np.abs(kf.x[:3]).max())
            t_upd, nis_upd = self._largest_applied_nis
            last = (
                "no sample applied yet"
                if t_upd is None
                else f"the largest NIS applied so far was {nis_upd:.3g}, at t = {t_upd!r} s"
            )
            gate = (
                "The innovation gate is disabled (gate_probability=None), so a corrupt sample (e.g. a huge rate) is "
                "applied as is: enable the gate to reject it."
                if self.gate_probability is None
                else "Check the inputs (torques, wheel momenta) and the initial covariance."
            )
            raise ValueError(
                f"numerical breakdown of the rate EKF at t = {t!r} s: {exc}; the estimate before the step was "
                f"max |omega_i| = {w:.6g} rad/s ({last}). The filter is left as it was before this step. {gate}"
            ) from None

    def _step(
        self,
        t: float,
        dt: float,
        tau: NDArray[np.float64],
        tau_ext: NDArray[np.float64],
        z: NDArray[np.float64] | None,
        nan_skipped: bool,
        hw: NDArray[np.float64] | None,
    ) -> StepReport:
        """The state-changing part of :meth:`step` (inputs validated; may raise :class:`_Breakdown`)."""
        h0 = hdot = np.zeros(3)
        if self.wheels is not None:
            h_new = None
            if hw is not None:
                if np.all(np.isfinite(hw)):
                    h_new = hw
                else:
                    self.n_wheel_nan_skipped += 1
            a = self.wheels.distribution
            if h_new is not None and self._h_wheels is not None and dt > 0:
                h0 = a @ self._h_wheels
                hdot = a @ (h_new - self._h_wheels) / dt
                tau = -hdot  # exact mean reaction torque over the interval
            else:
                known = self._h_wheels if self._h_wheels is not None else h_new
                h0 = np.zeros(3) if known is None else a @ known
            if h_new is not None:
                self._h_wheels = h_new
        if dt > 0:
            self._propagate(dt, tau + tau_ext, h0, hdot)
        self.t = t

        nu = np.full(3, np.nan)
        s = np.full((3, 3), np.nan)
        nis_value = float("nan")
        exceeds = False
        accepted = False
        if z is not None:
            nis_value, nu, s, accepted = self._update(z, t)
            exceeds = nis_value > self.nis_threshold
        # Nothing below can fail: the counters change only once the step has succeeded.
        if nan_skipped:
            self.n_nan_skipped += 1
        if z is not None:
            if accepted:
                self._t_last_update = t
                self.n_updates += 1
                if nis_value > self._largest_applied_nis[1]:
                    self._largest_applied_nis = (t, nis_value)
            else:
                self.n_gated += 1
            self.n_nis_exceeds += int(exceeds)
            self._run = self._run + 1 if exceeds else 0
            self._recent_nis.append(nis_value)
        if not accepted:
            self.kf.x_post, self.kf.P_post = self.kf.x.copy(), self.kf.P.copy()
        window_bad = False
        if len(self._recent_nis) == self.nis_window:
            mean = sum(self._recent_nis) / self.nis_window
            window_bad = not (self.nis_window_band[0] <= mean <= self.nis_window_band[1])
        report = StepReport(
            t=t,
            updated=accepted,
            nan_skipped=nan_skipped,
            innovation=nu,
            innovation_covariance=s,
            nis=nis_value,
            nis_exceeds=exceeds,
            health_flag=self._run >= self.nis_run_length or window_bad,
            gated=z is not None and not accepted,
        )
        self._last = report
        return report

    # -- engine protocol ----------------------------------------------------------------

    def update(self, t: float, measurements: dict[str, Any]) -> Estimate:
        """Engine protocol: one filter cycle at ``t`` [s] from the engine's ``measurements``; returns an Estimate.

        ``measurements`` maps sensor names to their newest sample (None: no
        sample) plus ``"torque_command"`` and ``"wheel_momentum"`` (see
        :mod:`attitude.simulation.engine`). The gyro is read under ``gyro_name``,
        an attitude sample under ``attitude_name``. The returned
        :class:`attitude.simulation.engine.Estimate` carries the filtered rate,
        the open-loop attitude (docs/rate_ekf.md) and the covariance of
        ``[omega, beta]``. A non-finite attitude sample is skipped and
        counted (:attr:`n_attitude_nan_skipped`).

        Parameters
        ----------
        t : float
            Time [s].
        measurements : dict
            Sensor name to newest sample (None: no sample), plus
            ``"torque_command"`` [N m] and ``"wheel_momentum"`` [N m s].

        Raises
        ------
        ValueError
            As :meth:`step`; also for a ``measurements`` that is not a
            mapping or an attitude sample that is not (4,).
        """
        if not isinstance(measurements, dict):
            raise ValueError(f"measurements must be a dict of sensor samples, got {type(measurements).__name__}")
        t_prev = self.t
        w_prev = self.kf.x[:3].copy()
        report = self.step(
            t,
            measurements.get(self.gyro_name),
            torque=measurements.get("torque_command"),
            wheel_momentum=measurements.get("wheel_momentum") if self.wheels is not None else None,
        )
        dt = report.t - t_prev
        if dt > 0:
            w_mean = 0.5 * (w_prev + self.kf.x[:3])
            self.q = quat.normalize(quat.multiply(self.q, quat.from_rotation_vector(w_mean * dt)))
        if self.attitude_name is not None:
            sample = measurements.get(self.attitude_name)
            if sample is not None:
                q_meas = as_float_array(sample, self.attitude_name, allow_nonfinite=True)
                if q_meas.shape != (4,):
                    raise ValueError(f"{self.attitude_name} sample must have shape (4,), got {q_meas.shape}")
                if np.all(np.isfinite(q_meas)):
                    self.q = quat.normalize(q_meas)
                else:
                    self.n_attitude_nan_skipped += 1
        return Estimate(report.t, self.q.copy(), self.kf.x[:3].copy(), covariance=self.kf.P.copy())

    def log(self) -> dict[str, Any]:
        """Values the engine logs at each estimator sample (``estimator.<key>``).

        ``bias`` (3) [rad/s], ``sigma`` (n) [rad/s], ``covariance`` (n*n,
        row-major) [rad^2/s^2], ``nis`` (NaN without a sample; the rejected
        value for a gated one), ``nis_exceeds``, ``health_flag``, ``updated``,
        ``nan_skipped``, ``gated`` (0/1 this step) and the running counts
        ``n_nan_skipped`` and ``n_gated``.
        """
        r = self._last
        return {
            "bias": self.bias,
            "sigma": self.sigma,
            "covariance": self.kf.P.ravel().copy(),
            "nis": float("nan") if r is None else r.nis,
            "nis_exceeds": float(r is not None and r.nis_exceeds),
            "health_flag": float(r is not None and r.health_flag),
            "updated": float(r is not None and r.updated),
            "nan_skipped": float(r is not None and r.nan_skipped),
            "n_nan_skipped": float(self.n_nan_skipped),
            "gated": float(r is not None and r.gated),
            "n_gated": float(self.n_gated),
        }


def _open_unit(value: Any, name: str) -> float:
    arr = as_float_array(value, name)
    if arr.ndim != 0 or not 0.0 < float(arr) < 1.0:
        raise ValueError(f"{name} must be a scalar in (0, 1), got {describe(arr)}")
    return float(arr)


def _count(value: Any, name: str) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


# ---------------------------------------------------------------------------
# Batch runs and their result


@dataclass
class RateEKFResult(ResultIO):
    """History of a :func:`run_rate_ekf` run (one row per sample time).

    Attributes
    ----------
    t : ndarray (n,)
        Times [s].
    omega, bias : ndarray (n, 3)
        Estimated rate and bias [rad/s] after each step (the known bias for
        a rate-only filter).
    covariance : ndarray (n, d, d)
        Error covariance of ``[omega, beta]`` (``d = 6``) or ``omega``
        (``d = 3``) [rad^2/s^2].
    innovation : ndarray (n, 3)
        Innovations [rad/s] (NaN rows without a sample; present for a gated one).
    innovation_covariance : ndarray (n, 3, 3)
        Their covariances [rad^2/s^2] (NaN without a sample).
    nis : ndarray (n,)
        NIS of each sample, applied or gated (NaN without one).
    nis_exceeds : ndarray (n,) of bool
        NIS above the per-step chi-square threshold.
    nis_flagged : ndarray (n,) of bool
        Steps in a run of at least ``nis_run_length`` exceedances or in an
        out-of-band NIS window (:func:`estimation.consistency.nis_health`).
    updated, nan_skipped : ndarray (n,) of bool
        A gyro sample was used / was non-finite and skipped. A sample
        rejected by the innovation gate is in neither (see :attr:`gated`).
    omega_true, bias_true : ndarray (n, 3) or None
        The truth, when known (simulation), for errors and NEES.
    info : dict
        Counts, thresholds, flagged intervals (indices and times), settings.
    """

    t: NDArray[np.float64]
    omega: NDArray[np.float64]
    bias: NDArray[np.float64]
    covariance: NDArray[np.float64]
    innovation: NDArray[np.float64]
    innovation_covariance: NDArray[np.float64]
    nis: NDArray[np.float64]
    nis_exceeds: NDArray[np.bool_]
    nis_flagged: NDArray[np.bool_]
    updated: NDArray[np.bool_]
    nan_skipped: NDArray[np.bool_]
    omega_true: NDArray[np.float64] | None = None
    bias_true: NDArray[np.float64] | None = None
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def healthy(self) -> bool:
        """True when no step was flagged."""
        return not bool(np.any(self.nis_flagged))

    @property
    def gated(self) -> NDArray[np.bool_]:
        """Steps (n,) whose gyro sample was rejected by the innovation gate (a NIS but no update)."""
        return ~np.isnan(self.nis) & ~self.updated

    @property
    def sigma(self) -> NDArray[np.float64]:
        """Standard deviations (n, d) [rad/s] from the covariance diagonals."""
        return np.sqrt(np.diagonal(self.covariance, axis1=-2, axis2=-1))

    def errors(self) -> NDArray[np.float64]:
        """Estimation errors ``truth - estimate`` (n, d) [rad/s]: rate, then bias when estimated.

        Raises
        ------
        ValueError
            Without the truth.
        """
        if self.omega_true is None:
            raise ValueError("errors need omega_true (and bias_true when the bias is estimated)")
        d = self.covariance.shape[-1]
        if d == 3:
            return self.omega_true - self.omega
        if self.bias_true is None:
            raise ValueError("errors of a bias-estimating filter need bias_true")
        return np.concatenate([self.omega_true - self.omega, self.bias_true - self.bias], axis=-1)

    def nees(self) -> NDArray[np.float64]:
        """NEES of every step (n,): chi-square with ``d`` degrees of freedom for a consistent filter."""
        return nees(self.errors(), self.covariance)

    def plot(self, kind: str | None = None) -> Figure:
        """``"errors"``: errors with +-3 sigma (needs the truth); ``"nis"``: NIS with its thresholds.

        Default: errors when the truth is known, NIS otherwise.

        Parameters
        ----------
        kind : {"errors", "nis"}, optional
            What to draw; default errors when the truth is known, NIS otherwise.
        """
        if kind is None:
            kind = "errors" if self.omega_true is not None else "nis"
        if kind == "errors":
            d = self.covariance.shape[-1]
            labels = [f"rate error {a} (body)" for a in "xyz"] + [f"bias error {a} (body)" for a in "xyz"]
            labels = labels[:d]
            return plot_errors_with_bounds(
                self.t,
                self.errors(),
                self.sigma,
                labels,
                "deg/h",
                scale=180.0 / np.pi * 3600.0,
                title=r"rate EKF errors with $\pm 3\sigma$ bounds",
            )
        if kind != "nis":
            raise ValueError(f"kind must be 'errors', 'nis' or None, got {kind!r}")
        fig = Figure(figsize=(9, 4), layout="constrained")
        ax = fig.subplots()
        ok = self.updated & ~np.isnan(self.nis)
        gated = self.gated
        ax.semilogy(self.t[ok], self.nis[ok], ".", ms=2, color="tab:blue", label="NIS")
        if np.any(gated):
            ax.semilogy(self.t[gated], self.nis[gated], "x", ms=6, color="tab:red", label="rejected by the gate")
        ax.axhline(self.info["nis_threshold"], color="tab:red", ls="--", lw=1, label="per-step threshold")
        if self.info.get("gate_threshold") is not None:
            ax.axhline(self.info["gate_threshold"], color="tab:purple", ls="-.", lw=1, label="innovation gate")
        ax.axhline(_DIM_Z, color="k", ls=":", lw=1, label="expected value 3")
        for start, stop in self.info.get("nis_interval_times", []):
            ax.axvspan(start, stop, color="tab:red", alpha=0.2)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("NIS")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right")
        state = "healthy" if self.healthy else f"{len(self.info.get('nis_intervals', []))} flagged stretch(es)"
        ax.set_title(
            f"rate EKF innovation health: {state}, {self.info.get('n_nan_skipped', 0)} NaN samples skipped, "
            f"{self.info.get('n_gated', 0)} gated"
        )
        return fig


def _runs(mask: NDArray[np.bool_], length: int) -> NDArray[np.bool_]:
    """Entries of ``mask`` in a run of at least ``length`` consecutive True values."""
    out = np.zeros(mask.size, dtype=bool)
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    for a, b in zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]):
        if b - a >= length:
            out[a:b] = True
    return out


def run_rate_ekf(
    ekf: RateEKF,
    t: ArrayLike,
    gyro: ArrayLike,
    *,
    torque: ArrayLike | None = None,
    wheel_momentum: ArrayLike | None = None,
    external_torque: ArrayLike | None = None,
    gyro_available: ArrayLike | None = None,
    omega_true: ArrayLike | None = None,
    bias_true: ArrayLike | None = None,
) -> RateEKFResult:
    """Run a filter over a recorded (or simulated) history.

    Parameters
    ----------
    ekf : RateEKF
        The filter, at a time not after ``t[0]`` (it is advanced in place).
    t : array_like (n,)
        Step times [s], non-decreasing (a filter step at each; the first may
        equal the filter's time).
    gyro : array_like (n, 3)
        Gyro samples [rad/s]. Rows with NaN/inf are skipped and counted;
        samples above the filter's innovation gate are rejected and counted
        (``info["n_gated"]``, :attr:`RateEKFResult.gated`).
    torque : array_like (n, 3), optional
        Known body torque held over the interval *ending* at ``t[k]`` [N m]
        (what the engine hands an estimator as ``"torque_command"``; a
        ``SimulationResult.torque_command`` row is held *from* its time, so
        shift it by one row). Default zero. With wheels and known momenta it
        is replaced by the wheels' reaction torque (:meth:`RateEKF.step`).
    wheel_momentum : array_like (n, n_wheels), optional
        Wheel momenta at each time [N m s] (filters with wheels).
    external_torque : array_like (n, 3), optional
        Known torque from outside the wheels (environment, magnetorquers)
        held over the interval ending at ``t[k]`` [N m], body axes; always
        added (:meth:`RateEKF.step`). A ``SimulationResult.external_torque``
        row is held from its time: shift it by one row. Default zero.
    gyro_available : array_like (n,) of bool, optional
        False where the gyro did not sample (multi-rate; not counted as
        NaN). Default: all samples present.
    omega_true, bias_true : array_like (n, 3), optional
        Truth at each time [rad/s], stored for errors, NEES and plots.

    Returns
    -------
    RateEKFResult

    Raises
    ------
    ValueError
        For mismatched shapes, times that go backwards (also relative to
        the filter's time), non-finite torques or times, or a numerical
        breakdown of the filter (:meth:`RateEKF.step`).
    """
    if not isinstance(ekf, RateEKF):
        raise ValueError(f"ekf must be a RateEKF, got {ekf!r}")
    times = as_float_array(t, "t")
    if times.ndim != 1 or times.size < 1:
        raise ValueError(f"t must be a 1-D array of times [s], got shape {times.shape}")
    n = times.size
    if np.any(np.diff(times) < 0):
        i = int(np.argmax(np.diff(times) < 0))
        raise ValueError(f"t must not go backwards; t[{i + 1}] = {times[i + 1]!r} < t[{i}] = {times[i]!r}")
    z = as_float_array(gyro, "gyro", allow_nonfinite=True)
    if z.shape != (n, 3):
        raise ValueError(f"gyro must have shape ({n}, 3), got {z.shape}")
    tau = np.zeros((n, 3)) if torque is None else as_float_array(torque, "torque")
    if tau.shape != (n, 3):
        raise ValueError(f"torque must have shape ({n}, 3), got {tau.shape}")
    tau_ext = None if external_torque is None else as_float_array(external_torque, "external_torque")
    if tau_ext is not None and tau_ext.shape != (n, 3):
        raise ValueError(f"external_torque must have shape ({n}, 3) [N m], got {tau_ext.shape}")
    hw = None
    if wheel_momentum is not None:
        hw = as_float_array(wheel_momentum, "wheel_momentum", allow_nonfinite=True)
        if hw.ndim != 2 or hw.shape[0] != n:
            raise ValueError(f"wheel_momentum must have shape ({n}, n_wheels), got {hw.shape}")
    avail = np.ones(n, dtype=bool) if gyro_available is None else np.asarray(gyro_available)
    if avail.shape != (n,) or avail.dtype != bool:
        raise ValueError(f"gyro_available must be a boolean array of shape ({n},), got {avail.dtype} {avail.shape}")
    truth = {}
    for name, value in (("omega_true", omega_true), ("bias_true", bias_true)):
        if value is not None:
            arr = as_float_array(value, name)
            if arr.shape != (n, 3):
                raise ValueError(f"{name} must have shape ({n}, 3), got {arr.shape}")
            truth[name] = arr
    d = ekf.dim_x
    out_w = np.empty((n, 3))
    out_b = np.empty((n, 3))
    out_p = np.empty((n, d, d))
    out_nu = np.full((n, 3), np.nan)
    out_s = np.full((n, 3, 3), np.nan)
    out_nis = np.full(n, np.nan)
    exceeds = np.zeros(n, dtype=bool)
    updated = np.zeros(n, dtype=bool)
    skipped = np.zeros(n, dtype=bool)
    gated = np.zeros(n, dtype=bool)
    live_flag = np.zeros(n, dtype=bool)
    for k in range(n):
        report = ekf.step(
            times[k],
            z[k] if avail[k] else None,
            torque=tau[k],
            wheel_momentum=None if hw is None else hw[k],
            external_torque=None if tau_ext is None else tau_ext[k],
        )
        out_w[k] = ekf.x[:3]
        out_b[k] = ekf.bias
        out_p[k] = ekf.P
        out_nu[k], out_s[k], out_nis[k] = report.innovation, report.innovation_covariance, report.nis
        exceeds[k], updated[k], skipped[k] = report.nis_exceeds, report.updated, report.nan_skipped
        gated[k] = report.gated
        live_flag[k] = report.health_flag
    has_nis = updated | gated  # gated samples still count in the health checks
    flagged = _runs(exceeds[has_nis], ekf.nis_run_length)
    flagged_all = np.zeros(n, dtype=bool)
    flagged_all[np.nonzero(has_nis)[0]] = flagged
    window_checked = int(has_nis.sum()) >= ekf.nis_window
    if window_checked:
        health = nis_health(out_nis, _DIM_Z, ekf.nis_window, ekf.health_confidence, t=times)
        flagged_all |= health.flagged
    intervals: list[list[int]] = []
    edges = np.diff(np.concatenate([[0], flagged_all.astype(np.int8), [0]]))
    for a, b in zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]):
        intervals.append([int(a), int(b)])
    info = {
        "n_steps": n,
        "n_updates": int(updated.sum()),
        "n_nan_skipped": int(skipped.sum()),
        "n_gated": int(gated.sum()),
        "gate_probability": ekf.gate_probability,
        "gate_threshold": None if ekf.gate_probability is None else ekf.gate_threshold,
        "n_nis_exceeds": int(exceeds.sum()),
        "nis_threshold": ekf.nis_threshold,
        "nis_confidence": ekf.nis_confidence,
        "nis_run_length": ekf.nis_run_length,
        "nis_window": ekf.nis_window,
        "nis_window_band": list(ekf.nis_window_band),
        "nis_window_checked": window_checked,
        "nis_intervals": intervals,
        "nis_interval_times": [[float(times[a]), float(times[b - 1])] for a, b in intervals],
        "live_flag_steps": int(live_flag.sum()),
        "healthy": not intervals,
        "noise_model": ekf.noise_model,
        "estimate_bias": ekf.estimate_bias,
    }
    return RateEKFResult(
        t=times.copy(),
        omega=out_w,
        bias=out_b,
        covariance=out_p,
        innovation=out_nu,
        innovation_covariance=out_s,
        nis=out_nis,
        nis_exceeds=exceeds,
        nis_flagged=flagged_all,
        updated=updated,
        nan_skipped=skipped,
        omega_true=truth.get("omega_true"),
        bias_true=truth.get("bias_true"),
        info=info,
    )

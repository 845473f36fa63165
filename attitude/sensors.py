"""Attitude sensors: a rate-integrating gyro (Farrenkopf model), a star tracker and a magnetometer.

Both meet the sensor protocol of :mod:`attitude.simulation.engine`: a ``name``, a
``period`` [s] and ``measure(t, truth, rng)`` returning an array, or None when
the sensor has nothing to report. Everything inside is SI (rad, rad/s, s);
datasheet units (deg/sqrt(h), deg/h, deg/h/sqrt(h), ppm, arcsec) appear only
in the ``from_datasheet`` constructors and the converters below, whose
argument names carry the unit.

See docs/sensors.md for the models (Farrenkopf gyro and its discrete
sampling, deterministic errors, star-tracker noise, batches of runs).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.rigid_body import skew
from attitude.rng import NormalStreams, as_generator
from attitude.validation import (
    as_float_array,
    check_direction,
    check_positive,
    check_vector,
    describe,
    finite_floats,
    positive_scalar,
    scalar_time,
)

__all__ = [
    "ARCSEC",
    "BIAS_INSTABILITY_FLOOR_FACTOR",
    "BIAS_INSTABILITY_MODELS",
    "GAUSS_MARKOV_PEAK_FACTOR",
    "GAUSS_MARKOV_PEAK_RATIO",
    "GYRO_PRESETS",
    "GYRO_SAMPLING",
    "SAMPLING_CHECKS",
    "STAR_TRACKER_PRESETS",
    "Gyro",
    "GyroBatch",
    "GyroSamplingWarning",
    "Magnetometer",
    "StarTracker",
    "arw_from_sigma_v",
    "arw_to_sigma_v",
    "bias_instability_to_gauss_markov",
    "bias_instability_to_sigma_u",
    "deg_per_h_to_rad_per_s",
    "gauss_markov_allan_variance",
    "gauss_markov_equivalent_sigma_u",
    "rrw_from_sigma_u",
    "rrw_to_sigma_u",
]

#: One arcsecond [rad].
ARCSEC = np.pi / (180.0 * 3600.0)

_DEG = np.pi / 180.0
_NANOTESLA = 1e-9  # [T]
_HOUR = 3600.0  # [s]
_SQRT_HOUR = 60.0  # sqrt(3600 s) [s^0.5]

#: Ratio of the flicker (bias-instability) floor of the Allan deviation to the
#: bias-instability coefficient B: ``sqrt(2 ln 2 / pi) = 0.6643`` (IEEE Std
#: 952-1997, Annex C: the flicker floor of the Allan variance is
#: ``2 ln(2) B^2 / pi``).
BIAS_INSTABILITY_FLOOR_FACTOR = float(np.sqrt(2.0 * np.log(2.0) / np.pi))


# ---------------------------------------------------------------------------
# Datasheet converters


def arw_to_sigma_v(arw_deg_per_sqrt_h: float) -> float:
    """Angle random walk [deg/sqrt(h)] to the ARW density ``sigma_v`` [rad/s^0.5].

    ``sigma_v = ARW * (pi / 180) / 60``, because ``sqrt(1 h) = 60 sqrt(s)``.
    Example: 0.15 deg/sqrt(h) = 4.363e-5 rad/s^0.5. (A noise density quoted
    in deg/s/sqrt(Hz) is ARW/60 in these units: multiply it by 60 to get
    deg/sqrt(h).)

    Parameters
    ----------
    arw_deg_per_sqrt_h : float
        Angle random walk [deg/sqrt(h)].
    """
    return float(check_positive(arw_deg_per_sqrt_h, "arw_deg_per_sqrt_h", allow_zero=True)) * _DEG / _SQRT_HOUR


def arw_from_sigma_v(sigma_v: float) -> float:
    """Inverse of :func:`arw_to_sigma_v`: ``sigma_v`` [rad/s^0.5] to ARW [deg/sqrt(h)].

    Parameters
    ----------
    sigma_v : float
        ARW density [rad/s^0.5].
    """
    return float(check_positive(sigma_v, "sigma_v", allow_zero=True)) * _SQRT_HOUR / _DEG


def rrw_to_sigma_u(rrw_deg_per_h_per_sqrt_h: float) -> float:
    """Rate random walk [deg/h/sqrt(h)] to the RRW density ``sigma_u`` [rad/s^1.5].

    ``sigma_u = RRW * (pi / 180) / 3600 / 60`` (deg -> rad, per hour -> per
    second, per sqrt(h) -> per sqrt(s)). Example: 1 deg/h/sqrt(h) =
    8.080e-8 rad/s^1.5.

    Parameters
    ----------
    rrw_deg_per_h_per_sqrt_h : float
        Rate random walk [deg/h/sqrt(h)].
    """
    value = float(check_positive(rrw_deg_per_h_per_sqrt_h, "rrw_deg_per_h_per_sqrt_h", allow_zero=True))
    return value * _DEG / _HOUR / _SQRT_HOUR


def rrw_from_sigma_u(sigma_u: float) -> float:
    """Inverse of :func:`rrw_to_sigma_u`: ``sigma_u`` [rad/s^1.5] to RRW [deg/h/sqrt(h)].

    Parameters
    ----------
    sigma_u : float
        RRW density [rad/s^1.5].
    """
    return float(check_positive(sigma_u, "sigma_u", allow_zero=True)) * _HOUR * _SQRT_HOUR / _DEG


def deg_per_h_to_rad_per_s(value_deg_per_h: ArrayLike) -> NDArray[np.float64]:
    """A rate or bias [deg/h] in rad/s: ``* (pi / 180) / 3600``.

    Parameters
    ----------
    value_deg_per_h : array_like
        A rate or bias [deg/h].
    """
    return as_float_array(value_deg_per_h, "value_deg_per_h") * _DEG / _HOUR


def bias_instability_to_sigma_u(bias_instability_deg_per_h: float, correlation_time_s: float) -> float:
    """An *approximate* rate random walk ``sigma_u`` [rad/s^1.5] from a bias instability.

    The Farrenkopf model has no flicker (1/f) noise, which is what a
    datasheet's bias instability ``B`` describes. This returns the rate
    random walk whose Allan deviation line ``sigma_u sqrt(tau / 3)`` reaches
    the flicker floor ``0.664 B`` (:data:`BIAS_INSTABILITY_FLOOR_FACTOR`,
    IEEE Std 952-1997 Annex C) at ``tau = correlation_time_s``:

    ``sigma_u = 0.664 B sqrt(3 / tau_c) = B sqrt(6 ln 2 / (pi tau_c))``

    with ``B`` in rad/s. It is an approximation in both directions: below
    ``tau_c`` the random walk has less instability than the real sensor,
    above it the random walk keeps growing while the real bias wanders near
    its floor, so long runs (>> ``tau_c``) over-state the bias drift. Take
    ``tau_c`` from the sensor's Allan-deviation plot (the averaging time at
    its minimum); prefer a measured or published RRW when there is one.

    Parameters
    ----------
    bias_instability_deg_per_h : float
        Bias instability ``B`` [deg/h] (the Allan floor divided by 0.664, as
        IEEE 952 defines it; most datasheets quote it so).
    correlation_time_s : float
        Averaging time ``tau_c`` [s] at which the Allan deviation reaches its floor.
    """
    b = float(check_positive(bias_instability_deg_per_h, "bias_instability_deg_per_h")) * _DEG / _HOUR
    tau = float(check_positive(correlation_time_s, "bias_instability_time_s"))
    return BIAS_INSTABILITY_FLOOR_FACTOR * b * np.sqrt(3.0 / tau)


# ---------------------------------------------------------------------------
# First-order Gauss-Markov bias (the bias instability)

#: ``tau / T`` at which the Allan deviation of a first-order Gauss-Markov process peaks
#: (the root of ``d ln f / d ln u = 0`` for :func:`gauss_markov_allan_variance`; verified by a
#: bounded search in tests/attitude/test_sensors.py).
GAUSS_MARKOV_PEAK_RATIO = 1.8926
#: Peak Allan deviation of a first-order Gauss-Markov process over its stationary standard
#: deviation ``sigma_b`` (``0.6174 sigma_b = 0.4366 q sqrt(T)`` with ``q = sigma_b sqrt(2 / T)``
#: its driving density; the "0.437" of IEEE Std 952-1997 Annex C is the second form).
GAUSS_MARKOV_PEAK_FACTOR = 0.6174

#: Coefficients of ``H(u) = u - 2 (1 - e^-u) + (1 - e^-2u) / 2 = sum_k c_k u^k`` (k = 3..10), used for u < 0.1
#: where the closed form cancels (``H' = (1 - e^-u)^2``, integrated term by term).
_H_SERIES = (1 / 3, -1 / 4, 7 / 60, -1 / 24, 31 / 2520, -1 / 320, 127 / 181440, -17 / 120960)


def _gm_h(u: NDArray[np.float64]) -> NDArray[np.float64]:
    """``H(u) = integral_0^u (1 - e^-s)^2 ds`` for ``u >= 0``, accurate to rounding for every ``u``."""
    u = np.asarray(u, dtype=np.float64)
    one_minus = -np.expm1(-u)
    closed = u - 2.0 * one_minus + 0.5 * (-np.expm1(-2.0 * u))
    series = np.zeros_like(u)
    for c in reversed(_H_SERIES):
        series = (series + c) * u
    series = series * u * u
    return np.where(u < 0.1, series, closed)


def gauss_markov_allan_variance(tau: ArrayLike, sigma_b: float, correlation_time: float) -> NDArray[np.float64]:
    """Allan variance [rad^2/s^2] of a first-order Gauss-Markov rate of stationary deviation ``sigma_b``.

    For ``db/dt = -b / T + w`` (``w`` white, density ``q = sigma_b sqrt(2 / T)``), with
    ``u = tau / T``:

    ``sigma^2(tau) = (q T)^2 / tau [1 - T / (2 tau) (3 - 4 e^-u + e^-2u)] = 2 sigma_b^2 H(u) / u^2``,

    ``H(u) = u - 2 (1 - e^-u) + (1 - e^-2u) / 2`` (IEEE Std 952-1997, Annex C, the
    exponentially correlated noise; El-Sheimy, Hou and Niu, "Analysis and modeling of inertial
    sensors using Allan variance", IEEE Trans. Instrum. Meas. 57(1), 2008, eq. 18). It rises as
    a rate random walk of density ``q`` (``q^2 tau / 3``) for ``tau << T``, peaks at ``tau =``
    :data:`GAUSS_MARKOV_PEAK_RATIO` ``T`` with ``sigma =`` :data:`GAUSS_MARKOV_PEAK_FACTOR`
    ``sigma_b``, and falls as white noise (``2 sigma_b^2 T / tau``) for ``tau >> T``.

    Parameters
    ----------
    tau : array_like
        Averaging times [s] (> 0).
    sigma_b : float
        Stationary standard deviation of the process [rad/s] (>= 0).
    correlation_time : float
        Correlation time ``T`` [s] (> 0).

    Returns
    -------
    ndarray
        Allan variance at each ``tau`` [rad^2/s^2].
    """
    t = check_positive(tau, "tau")
    s = positive_scalar(sigma_b, "sigma_b", allow_zero=True)
    big_t = positive_scalar(correlation_time, "correlation_time")
    u = t / big_t
    return 2.0 * s**2 * _gm_h(u) / u**2


def _gm_log_slope(u: float) -> float:
    """``d ln(sigma^2) / d ln(tau)`` of the Gauss-Markov Allan variance at ``u = tau / T``: ``u b^2 / H - 2``."""
    b = -np.expm1(-u)
    return float(u * b * b / _gm_h(np.array(u)) - 2.0)


def bias_instability_to_gauss_markov(
    bias_instability_deg_per_h: float,
    bias_instability_time_s: float,
    *,
    arw_deg_per_sqrt_h: float = 0.0,
    rrw_deg_per_h_per_sqrt_h: float = 0.0,
) -> tuple[float, float]:
    """The Gauss-Markov bias ``(sigma_b [rad/s], T [s])`` that puts the gyro's Allan floor where its datasheet does.

    A datasheet's bias instability ``B`` is read on the measured Allan-deviation curve: its
    minimum is ``0.664 B`` (:data:`BIAS_INSTABILITY_FLOOR_FACTOR`, IEEE Std 952-1997 Annex C)
    at the averaging time ``tau_B``. That curve holds every noise, so the Gauss-Markov term is
    solved for the *whole* model (ARW ``N``, the Gauss-Markov term ``GM``, RRW ``K``)

    ``sigma^2(tau) = N^2 / tau + GM(tau; sigma_b, T) + K^2 tau / 3``

    to have its minimum at ``tau_B`` with the value ``(0.664 B)^2``: two equations (value, zero
    slope) for two unknowns. With ``R = (0.664 B)^2 - N^2 / tau_B - K^2 tau_B / 3`` and
    ``S = N^2 / tau_B - K^2 tau_B / 3``, the log-slope of ``GM`` at ``tau_B`` must be
    ``rho = S / R``; it falls monotonically from 1 (``tau << T``) to -1 (``tau >> T``), which
    fixes ``u = tau_B / T`` (a bracketed root), then ``sigma_b^2 = R / (2 H(u) / u^2)``. When the
    ARW and RRW lines are far below the floor, ``rho -> 0``: ``T = tau_B / 1.89`` and
    ``sigma_b = 0.664 B / 0.617``, the peak of the Gauss-Markov curve on the floor.

    A solution needs the floor at least ``sqrt(2)`` above both lines at ``tau_B``
    (``(0.664 B)^2 > 2 N^2 / tau_B`` and ``> 2 K^2 tau_B / 3``; otherwise the curve cannot
    have a minimum there, whatever the bias does): a ValueError names the violated bound.

    Parameters
    ----------
    bias_instability_deg_per_h : float
        Bias instability ``B`` [deg/h] (> 0; the Allan floor divided by 0.664).
    bias_instability_time_s : float
        Averaging time ``tau_B`` [s] at the Allan floor (> 0).
    arw_deg_per_sqrt_h : float, optional
        Angle random walk [deg/sqrt(h)] (>= 0).
    rrw_deg_per_h_per_sqrt_h : float, optional
        Rate random walk [deg/h/sqrt(h)] (>= 0), modelled as its own random walk.

    Returns
    -------
    sigma_b : float
        Stationary standard deviation of the Gauss-Markov bias [rad/s].
    correlation_time : float
        Its correlation time ``T`` [s].

    Raises
    ------
    ValueError
        For a non-positive ``B`` or ``tau_B``, negative noise figures, or a floor too close to
        the ARW or RRW line (see above).
    """
    from scipy.optimize import brentq  # the root of one scalar equation, once per gyro

    floor = float(check_positive(bias_instability_deg_per_h, "bias_instability_deg_per_h"))
    floor *= BIAS_INSTABILITY_FLOOR_FACTOR * _DEG / _HOUR
    tau_b = float(check_positive(bias_instability_time_s, "bias_instability_time_s"))
    n2 = arw_to_sigma_v(arw_deg_per_sqrt_h) ** 2 / tau_b
    k2 = rrw_to_sigma_u(rrw_deg_per_h_per_sqrt_h) ** 2 * tau_b / 3.0
    for line, what in ((n2, "angle random walk N^2 / tau_B"), (k2, "rate random walk K^2 tau_B / 3")):
        if not floor**2 > 2.0 * line:
            raise ValueError(
                f"bias_instability_deg_per_h = {bias_instability_deg_per_h!r} at bias_instability_time_s = "
                f"{bias_instability_time_s!r} s puts the Allan floor (0.664 B)^2 = {floor**2:.4g} rad^2/s^2 within "
                f"sqrt(2) of the {what} = {line:.4g} rad^2/s^2: no Allan curve of these noises has its minimum "
                "there; check the datasheet figures (a longer averaging time or a larger B)"
            )
    rho = (n2 - k2) / (floor**2 - n2 - k2)
    lo, hi = 1e-6, 1e6
    u = brentq(lambda x: _gm_log_slope(x) - rho, lo, hi, xtol=1e-14, rtol=1e-13)
    correlation_time = tau_b / u
    sigma_b = float(np.sqrt((floor**2 - n2 - k2) / (2.0 * float(_gm_h(np.array(u))) / u**2)))
    return sigma_b, float(correlation_time)


def gauss_markov_equivalent_sigma_u(sigma_b: float, correlation_time: float, horizon_s: float | None = None) -> float:
    """The random-walk density ``sigma_u`` [rad/s^1.5] a filter uses for a Gauss-Markov bias.

    A filter that models the bias as a random walk (``estimation.mekf``, ``estimation.rate_ekf``)
    sees a Gauss-Markov bias through its tuning. Over a horizon ``D`` the Gauss-Markov bias
    moves by ``Var[b(t + D) - b(t)] = 2 sigma_b^2 (1 - e^(-D/T))``, a random walk by
    ``sigma_u^2 D``. Without a horizon this returns ``sigma_b sqrt(2 / T)`` (the driving density
    ``q``), which matches the short-term growth and bounds it at *every* horizon (``1 - e^-x <= x``):
    the filter never under-states how far the bias can move, at the price of some conservatism
    over horizons beyond ``T``. With a horizon (e.g. the filter's bias time constant) the random
    walk matches the increment at ``D`` exactly, and bounds every shorter one from below only.

    Parameters
    ----------
    sigma_b : float
        Stationary standard deviation of the Gauss-Markov bias [rad/s] (>= 0).
    correlation_time : float
        Its correlation time ``T`` [s] (> 0).
    horizon_s : float, optional
        Horizon ``D`` [s] (> 0) at which to match the bias increment; None: the bound for every horizon.

    Returns
    -------
    float
        ``sigma_u`` [rad/s^1.5].
    """
    s = positive_scalar(sigma_b, "sigma_b", allow_zero=True)
    big_t = positive_scalar(correlation_time, "correlation_time")
    if horizon_s is None:
        return float(s * np.sqrt(2.0 / big_t))
    d = positive_scalar(horizon_s, "horizon_s")
    return float(s * np.sqrt(2.0 * -np.expm1(-d / big_t) / d))


def _gm_step_coefficients(
    h: float, sigma_b: float, correlation_time: float
) -> tuple[float, float, float, float, float]:
    """Exact sampling of a Gauss-Markov state over ``h`` [s]: ``(phi, s, a, c, d)``.

    ``x_{k+1} = phi x_k + s N1`` and the interval mean ``m_k = a x_k + c N1 + d N2`` (the
    conditional Gaussian of the state and its mean over the interval; docs/sensors.md). ``h = 0``
    is a first sample: ``x = m = sigma_b N1`` drawn from the stationary distribution.
    """
    if h == 0.0:
        return 0.0, sigma_b, 0.0, sigma_b, 0.0
    x = h / correlation_time
    b1 = -np.expm1(-x)
    b2 = -np.expm1(-2.0 * x)
    big_h = float(_gm_h(np.array(x)))
    s = sigma_b * np.sqrt(b2)
    c = sigma_b * b1 * b1 / (x * np.sqrt(b2))
    d = sigma_b / x * np.sqrt(max(2.0 * big_h - b1**4 / b2, 0.0))
    return float(np.exp(-x)), float(s), float(b1 / x), float(c), float(d)


# ---------------------------------------------------------------------------
# Validation helpers


def _per_axis(value: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = as_float_array(value, name)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size != 3):
        raise ValueError(f"{name} must be a scalar or have shape (3,), got shape {arr.shape}")
    out = np.array(np.broadcast_to(arr, (3,)), dtype=np.float64)
    out.flags.writeable = False
    return out


def _misalignment_matrix(value: ArrayLike) -> NDArray[np.float64]:
    arr = as_float_array(value, "misalignment")
    if arr.shape == (3,):
        return -skew(arr)
    if arr.shape == (3, 3):
        if np.any(np.diag(arr) != 0.0):
            raise ValueError(
                "misalignment as a (3, 3) matrix must have a zero diagonal (the diagonal is the "
                f"scale_factor), got diagonal {describe(np.diag(arr))}"
            )
        return arr.copy()
    raise ValueError(
        f"misalignment must be a small rotation vector (3,) [rad] or a (3, 3) matrix with zero diagonal, "
        f"got shape {arr.shape}"
    )


# ---------------------------------------------------------------------------
# Gyro


def _apply_transfer(transfer: NDArray[np.float64], omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """``T omega`` for ``T`` (3, 3) or (..., 3, 3) and ``omega`` (..., 3).

    Explicit products (no BLAS, whose summation order and FMA use depend on
    the shapes) so that a batch and a single sample round identically.
    """
    return (
        omega[..., 0:1] * transfer[..., :, 0]
        + omega[..., 1:2] * transfer[..., :, 1]
        + omega[..., 2:3] * transfer[..., :, 2]
    )


def _check_after(t: float, t_last: float | None, who: str) -> None:
    """Raise ValueError unless ``t`` [s] comes after the previous sample time ``t_last``."""
    if t_last is not None and not t > t_last:
        raise ValueError(
            f"t must come after the previous sample of {who}: t = {t!r} s <= {t_last!r} s "
            "(call reset() before reusing the gyro in a new run)"
        )


def farrenkopf_process_noise(sigma_v2: float, sigma_u2: float, dt: float) -> NDArray[np.float64]:
    """Discrete process noise (6, 6) of ``[attitude error, bias error]`` over ``dt`` (Farrenkopf model).

    ``Q = [[(sv2 dt + su2 dt^3 / 3) I, -(su2 dt^2 / 2) I], [-(su2 dt^2 / 2) I, su2 dt I]]``
    (Crassidis and Junkins, 2nd ed., sec. 7.2.1): the one definition used by
    :meth:`Gyro.process_noise` and :mod:`estimation.mekf.filter`. No argument checks
    (callers validate).

    Parameters
    ----------
    sigma_v2 : float
        Squared angle-random-walk density [rad^2/s].
    sigma_u2 : float
        Squared rate-random-walk density [rad^2/s^3].
    dt : float
        Step [s].

    Returns
    -------
    ndarray (6, 6)
        ``Q`` [rad^2, rad^2/s, rad^2/s^2 blocks].
    """
    a = sigma_v2 * dt + sigma_u2 * dt**3 / 3.0
    c = -sigma_u2 * dt**2 / 2.0
    b = sigma_u2 * dt
    # Filled by index (a filter calls this every step; np.block costs 20x more).
    q = np.zeros((6, 6))
    q[_DIAG_A, _DIAG_A] = a
    q[_DIAG_A, _DIAG_B] = c
    q[_DIAG_B, _DIAG_A] = c
    q[_DIAG_B, _DIAG_B] = b
    return q


_DIAG_A = np.arange(3)
_DIAG_B = np.arange(3, 6)


#: Sample intervals whose Gauss-Markov coefficients a gyro keeps (:meth:`Gyro._gm_coefficients`).
_GM_CACHE_SIZE = 64

#: Gyro sampling models (see :class:`Gyro`).
GYRO_SAMPLING = ("instantaneous", "mean")
#: Models of a datasheet's bias instability (see :meth:`Gyro.from_datasheet`).
BIAS_INSTABILITY_MODELS = ("gauss_markov", "random_walk")
#: What :meth:`Gyro.check_sampling` does on a mismatch.
SAMPLING_CHECKS = ("raise", "warn", "ignore")


class GyroSamplingWarning(UserWarning):
    """A filter was built for a gyro whose ``sampling`` is not the one its model assumes."""


class Gyro:
    """A three-axis rate gyro: Farrenkopf noise, bias, scale factor, misalignment, quantisation, saturation.

    The model and its exact discrete-time sampling are described in
    docs/sensors.md. The object is a sensor for
    :func:`attitude.simulation.engine.simulate`; it carries state (the current bias
    and the time of the previous sample), so call :meth:`reset` (or build a
    new gyro) before reusing it in another run. :meth:`sample_errors` and
    :meth:`measure_history` are pure vectorised paths that share the same
    code and random-number layout.

    Parameters
    ----------
    sigma_v : float
        Angle-random-walk density [rad/s^0.5] (>= 0; 0 only for tests of the
        deterministic errors).
    sigma_u : float
        Rate-random-walk density driving the bias [rad/s^1.5] (>= 0; 0 gives
        a constant bias).
    period : float
        Sample period [s] (> 0); the engine samples at multiples of its tick.
    sigma_b : float
        Stationary standard deviation [rad/s] of a first-order Gauss-Markov
        bias term, the bias instability (>= 0; 0: none, and the gyro draws
        exactly the numbers of a Farrenkopf gyro). See
        :func:`bias_instability_to_gauss_markov`.
    correlation_time : float
        Correlation time ``T`` [s] of the Gauss-Markov term (> 0; used only
        with ``sigma_b > 0``).
    bias : array_like (3,) or float
        Bias at the first sample [rad/s] (the constant part of the bias; a
        Monte Carlo draws it from the turn-on bias repeatability).
    scale_factor : array_like (3,) or float
        Scale-factor errors (dimensionless, e.g. 1e-3 = 1000 ppm), each > -1.
    misalignment : array_like (3,) or (3, 3)
        Small rotation vector [rad] of the gyro triad from the body axes, or
        the matrix ``M`` (zero diagonal) of cross-axis sensitivities.
    quantization : float
        Output resolution [rad/s per LSB] (0: none).
    saturation : float
        Largest reported rate magnitude per axis [rad/s] (inf: none).
    name : str
        Sensor name (key in the estimator's measurements and the logs).
    sampling : {"instantaneous", "mean"}
        What the true part of a sample is: the body rate at the sample time
        (a rate gyro read at that instant), or the mean rate over the
        interval since the previous sample, ``rotvec(q_prev* ⊗ q) / dt`` (a
        rate-integrating gyro's angle increment, as fibre-optic and
        ring-laser gyros deliver). :class:`estimation.rate_ekf.RateEKF`
        models the first, :class:`estimation.mekf.filter.MEKF` the second (its
        propagation holds each sample as the mean rate over the interval);
        ``RateEKF.from_gyro`` and ``MEKF.from_sensors`` check the match.
        The first sample of a run reports the instantaneous rate.

    Raises
    ------
    ValueError
        For an unknown ``sampling``, negative or non-finite noise figures, a period <= 0, a
        saturation <= 0 or NaN, a scale factor <= -1, a misalignment of the
        wrong shape or with a non-zero diagonal.
    """

    def __init__(
        self,
        sigma_v: float,
        sigma_u: float = 0.0,
        *,
        period: float,
        sigma_b: float = 0.0,
        correlation_time: float = np.inf,
        bias: ArrayLike = 0.0,
        scale_factor: ArrayLike = 0.0,
        misalignment: ArrayLike = (0.0, 0.0, 0.0),
        quantization: float = 0.0,
        saturation: float = np.inf,
        name: str = "gyro",
        sampling: str = "instantaneous",
    ) -> None:
        if sampling not in GYRO_SAMPLING:
            raise ValueError(f"sampling must be one of {GYRO_SAMPLING}, got {sampling!r}")
        self.sampling = sampling
        self.sigma_v = positive_scalar(sigma_v, "sigma_v", allow_zero=True)
        self.sigma_u = positive_scalar(sigma_u, "sigma_u", allow_zero=True)
        self.period = positive_scalar(period, "period")
        self.sigma_b = positive_scalar(sigma_b, "sigma_b", allow_zero=True)
        time_b = as_float_array(correlation_time, "correlation_time", allow_nonfinite=True)
        if time_b.ndim != 0 or np.isnan(time_b) or time_b <= 0 or (self.sigma_b > 0 and not np.isfinite(time_b)):
            raise ValueError(
                "correlation_time must be a positive scalar [s] (finite when sigma_b > 0), "
                f"got {describe(time_b)} with sigma_b = {self.sigma_b!r}"
            )
        self.correlation_time = float(time_b)
        #: Rows of standard normals per sample: [N_u, N_v], plus the Gauss-Markov pair [N_b1, N_b2].
        self._normal_rows = 4 if self.sigma_b > 0 else 2
        self._gm_cache: dict[float, tuple[float, float, float, float, float]] = {}
        self.initial_bias = _per_axis(bias, "bias")
        self.scale_factor = _per_axis(scale_factor, "scale_factor")
        if np.any(self.scale_factor <= -1.0):
            raise ValueError(f"scale_factor must be > -1 on every axis (a positive gain), got {self.scale_factor}")
        self.misalignment = _misalignment_matrix(misalignment)
        self.misalignment.flags.writeable = False
        self.quantization = positive_scalar(quantization, "quantization", allow_zero=True)
        sat = as_float_array(saturation, "saturation", allow_nonfinite=True)
        if sat.ndim != 0 or np.isnan(sat) or sat <= 0:
            raise ValueError(f"saturation must be a positive scalar rate [rad/s] or inf, got {describe(sat)}")
        self.saturation = float(sat)
        if not isinstance(name, str) or not name:
            raise ValueError(f"name must be a non-empty string, got {name!r}")
        self.name = name
        transfer = np.eye(3) + np.diag(self.scale_factor) + self.misalignment
        transfer.flags.writeable = False
        #: ``I + S + M``: maps the true body rate to the noise-free gyro output.
        self.transfer_matrix = transfer
        self.reset()

    def __repr__(self) -> str:
        return (
            f"Gyro(name={self.name!r}, sigma_v={self.sigma_v:.4g} rad/s^0.5 "
            f"({arw_from_sigma_v(self.sigma_v):.4g} deg/sqrt(h)), sigma_u={self.sigma_u:.4g} rad/s^1.5, "
            + (f"sigma_b={self.sigma_b:.4g} rad/s, T={self.correlation_time:.4g} s, " if self.sigma_b else "")
            + f"period={self.period:g} s)"
        )

    # -- construction from datasheets -------------------------------------------------

    @classmethod
    def from_datasheet(
        cls,
        *,
        arw_deg_per_sqrt_h: float,
        period: float,
        rrw_deg_per_h_per_sqrt_h: float | None = None,
        bias_instability_deg_per_h: float | None = None,
        bias_instability_time_s: float | None = None,
        bias_deg_per_h: ArrayLike = 0.0,
        scale_factor_ppm: ArrayLike = 0.0,
        misalignment_rad: ArrayLike = (0.0, 0.0, 0.0),
        quantization_deg_per_s: float = 0.0,
        saturation_deg_per_s: float = np.inf,
        name: str = "gyro",
        sampling: str = "instantaneous",
        bias_instability_model: str = "gauss_markov",
    ) -> Gyro:
        """Build a gyro from datasheet figures.

        Conversions (see the module-level converters):

        - ``sigma_v [rad/s^0.5] = ARW [deg/sqrt(h)] * (pi/180) / 60``
          (:func:`arw_to_sigma_v`);
        - ``sigma_u [rad/s^1.5] = RRW [deg/h/sqrt(h)] * (pi/180) / 3600 / 60``
          (:func:`rrw_to_sigma_u`);
        - a bias instability ``B`` [deg/h] at the averaging time
          ``bias_instability_time_s``: a first-order Gauss-Markov bias
          (``sigma_b``, ``correlation_time``) solved by
          :func:`bias_instability_to_gauss_markov` so that the Allan deviation
          of the whole model (ARW, this term and the RRW, if given, as its own
          random walk) has its minimum ``0.664 B`` at that averaging time;
          with ``bias_instability_model="random_walk"``, the former rate-random-walk
          approximation :func:`bias_instability_to_sigma_u` instead (the
          filters' own bias model, for consistency tests of a matched filter;
          its Allan floor sits 10 to 15 % low and too early);
        - biases ``[deg/h] * (pi/180) / 3600``; scale factor ``ppm * 1e-6``;
          rates ``[deg/s] * pi/180``.

        Parameters
        ----------
        arw_deg_per_sqrt_h : float
            Angle random walk [deg/sqrt(h)] (> 0).
        period : float
            Sample period [s].
        rrw_deg_per_h_per_sqrt_h : float, optional
            Rate random walk [deg/h/sqrt(h)].
        bias_instability_deg_per_h : float, optional
            Bias instability [deg/h].
        bias_instability_time_s : float, optional
            Averaging time [s] at which the Allan deviation reaches the
            bias-instability floor; required with ``bias_instability_deg_per_h``.
        bias_deg_per_h : float or array_like (3,)
            Constant bias [deg/h].
        scale_factor_ppm : float or array_like (3,)
            Scale-factor error [ppm].
        misalignment_rad : array_like (3,) or (3, 3)
            See the class parameters [rad].
        quantization_deg_per_s : float
            Output resolution [deg/s per LSB] (0: none).
        saturation_deg_per_s : float
            Measurement range [deg/s] (inf: none).
        name : str
            Sensor name.
        sampling : {"instantaneous", "mean"}
            Instantaneous rate or interval-mean rate samples (see :class:`Gyro`).
        bias_instability_model : {"gauss_markov", "random_walk"}
            How the bias instability is modelled (see above).

        Raises
        ------
        ValueError
            If the bias instability comes without its averaging time, its
            floor is too close to the ARW or RRW line for a minimum there
            (:func:`bias_instability_to_gauss_markov`), both an RRW and a bias
            instability are given with ``bias_instability_model="random_walk"``
            (one bias-driving noise), or for any invalid figure.
        """
        positive_scalar(arw_deg_per_sqrt_h, "arw_deg_per_sqrt_h")
        if bias_instability_model not in BIAS_INSTABILITY_MODELS:
            raise ValueError(
                f"bias_instability_model must be one of {BIAS_INSTABILITY_MODELS}, got {bias_instability_model!r}"
            )
        random_walk = bias_instability_model == "random_walk"
        if random_walk and rrw_deg_per_h_per_sqrt_h is not None and bias_instability_deg_per_h is not None:
            raise ValueError(
                "give rrw_deg_per_h_per_sqrt_h or bias_instability_deg_per_h, not both, with "
                "bias_instability_model='random_walk' (one bias-driving noise; the default 'gauss_markov' takes both) "
                f"(got RRW = {rrw_deg_per_h_per_sqrt_h!r}, B = {bias_instability_deg_per_h!r})"
            )
        sigma_u = 0.0 if rrw_deg_per_h_per_sqrt_h is None else rrw_to_sigma_u(rrw_deg_per_h_per_sqrt_h)
        sigma_b, correlation_time = 0.0, np.inf
        if bias_instability_deg_per_h is not None:
            if bias_instability_time_s is None:
                raise ValueError(
                    "bias_instability_time_s (the averaging time [s] at the Allan-deviation floor) is required "
                    f"with bias_instability_deg_per_h = {bias_instability_deg_per_h!r}"
                )
            if random_walk:
                sigma_u = bias_instability_to_sigma_u(bias_instability_deg_per_h, bias_instability_time_s)
            else:
                sigma_b, correlation_time = bias_instability_to_gauss_markov(
                    bias_instability_deg_per_h,
                    bias_instability_time_s,
                    arw_deg_per_sqrt_h=arw_deg_per_sqrt_h,
                    rrw_deg_per_h_per_sqrt_h=0.0 if rrw_deg_per_h_per_sqrt_h is None else rrw_deg_per_h_per_sqrt_h,
                )
        saturation = as_float_array(saturation_deg_per_s, "saturation_deg_per_s", allow_nonfinite=True)
        if saturation.ndim != 0 or np.isnan(saturation) or saturation <= 0:
            raise ValueError(f"saturation_deg_per_s must be a positive scalar or inf, got {describe(saturation)}")
        return cls(
            arw_to_sigma_v(arw_deg_per_sqrt_h),
            sigma_u,
            period=period,
            sigma_b=sigma_b,
            correlation_time=correlation_time,
            bias=deg_per_h_to_rad_per_s(bias_deg_per_h),
            scale_factor=as_float_array(scale_factor_ppm, "scale_factor_ppm") * 1e-6,
            misalignment=misalignment_rad,
            quantization=positive_scalar(quantization_deg_per_s, "quantization_deg_per_s", allow_zero=True) * _DEG,
            saturation=float(saturation) * _DEG,
            name=name,
            sampling=sampling,
        )

    @classmethod
    def preset(cls, grade: str, *, period: float = 0.1, **overrides: Any) -> Gyro:
        """A gyro of a typical grade: ``"mems"``, ``"tactical"`` or ``"navigation"``.

        The figures, and where they come from, are in :data:`GYRO_PRESETS`
        (one entry per grade, keyword arguments of :meth:`from_datasheet`).

        - ``"mems"``: Analog Devices ADIS16470 MEMS IMU (datasheet rev. C):
          ARW 0.34 deg/sqrt(h), in-run bias stability 8 deg/h, range
          +-2000 deg/s. No RRW is published; the bias instability is a
          Gauss-Markov bias with its Allan floor at an *assumed* 100 s
          (typical of this class, not a datasheet figure). The 32-bit
          output LSB (~1.5e-6 deg/s) is far below the noise and is not modelled.
        - ``"tactical"``: Northrop Grumman LN-200 class fibre-optic gyro IMU
          (LN-200/LN-200S datasheets): ARW 0.07 deg/sqrt(h), bias 1 deg/h
          (1 sigma; the datasheet quotes bias repeatability, used here as the
          instability floor, a conservative reading), range +-1000 deg/s;
          Allan minimum *assumed* at 300 s.
        - ``"navigation"``: Honeywell HG9900 ring-laser-gyro IMU (brochure
          N61-1638-000-000): ARW 0.002 deg/sqrt(h), bias stability
          0.0035 deg/h; Allan minimum *assumed* at 3 h (10800 s: with this
          ARW no curve can have its minimum 0.664 B before 5300 s); range not modelled.
          Crassidis and Junkins' MEKF example (``sigma_v = sqrt(10) 1e-7``
          rad/s^0.5 = 0.0011 deg/sqrt(h)) is of the same class.

        Check the current datasheet revision before relying on a figure.

        Parameters
        ----------
        grade : {"mems", "tactical", "navigation"}
            Preset name.
        period : float
            Sample period [s].
        **overrides
            Any keyword of :meth:`from_datasheet` (e.g. ``bias_deg_per_h`` for
            a drawn turn-on bias, ``name``).
        """
        if grade not in GYRO_PRESETS:
            raise ValueError(f"grade must be one of {tuple(GYRO_PRESETS)}, got {grade!r}")
        kwargs = dict(GYRO_PRESETS[grade]["figures"])
        if "rrw_deg_per_h_per_sqrt_h" in overrides and overrides.get("bias_instability_model") == "random_walk":
            kwargs.pop("bias_instability_deg_per_h", None)
            kwargs.pop("bias_instability_time_s", None)
        kwargs.update(overrides)
        return cls.from_datasheet(period=period, **kwargs)

    # -- discrete noise figures for estimators ---------------------------------------

    def _dt(self, dt: float | None) -> float:
        return self.period if dt is None else positive_scalar(dt, "dt")

    @property
    def filter_sigma_u(self) -> float:
        """Rate-random-walk density [rad/s^1.5] of the bias for a filter that models it as a random walk.

        ``sqrt(sigma_u**2 + q**2)`` with ``q = sigma_b sqrt(2 / T)``
        (:func:`gauss_markov_equivalent_sigma_u` without a horizon): the
        random walk that bounds the Gauss-Markov bias increment at every
        horizon. ``sigma_u`` itself without a Gauss-Markov term. The MEKF,
        the rate EKF and the figures below (:meth:`rate_noise_variance`,
        :meth:`bias_step_variance`, :meth:`process_noise`) use it.
        """
        if self.sigma_b == 0.0:
            return self.sigma_u
        q = gauss_markov_equivalent_sigma_u(self.sigma_b, self.correlation_time)
        return float(np.hypot(self.sigma_u, q))

    def allan_variance(self, tau: ArrayLike) -> NDArray[np.float64]:
        """Allan variance [rad^2/s^2] of the model's rate noise at averaging times ``tau`` [s], per axis.

        ``sigma_v**2 / tau + GM(tau) + sigma_u**2 tau / 3`` with ``GM`` the
        Gauss-Markov term (:func:`gauss_markov_allan_variance`); the sampled
        output of a stationary gyro has exactly this Allan variance at every
        ``tau`` that is a multiple of the sample interval (docs/sensors.md).
        Quantisation and saturation are not included.

        Parameters
        ----------
        tau : array_like
            Averaging times [s] (> 0).
        """
        t = check_positive(tau, "tau")
        avar = self.sigma_v**2 / t + self.sigma_u**2 * t / 3.0
        if self.sigma_b > 0:
            avar = avar + gauss_markov_allan_variance(t, self.sigma_b, self.correlation_time)
        return avar

    def rate_noise_variance(self, dt: float | None = None) -> float:
        """Variance [rad^2/s^2] of the white part of one rate sample, per axis.

        ``sigma_v**2 / dt + sigma_u**2 dt / 12`` (the term ``N_v`` of
        docs/sensors.md; ``sigma_u`` is :attr:`filter_sigma_u`), for a sample averaged over ``dt`` [s] (default
        :attr:`period`). A filter whose state holds the bias at the sample
        time (``omega_meas = omega + beta_{k+1} + e``) sees the error
        ``e = -(beta_{k+1} - beta_k)/2 + noise`` of variance
        ``sigma_v**2/dt + sigma_u**2 dt/3``, correlated with the bias step
        (covariance ``-sigma_u**2 dt / 2``).

        Parameters
        ----------
        dt : float, optional
            Sample interval [s]; default :attr:`period`.
        """
        dt = self._dt(dt)
        return self.sigma_v**2 / dt + self.filter_sigma_u**2 * dt / 12.0

    def bias_step_variance(self, dt: float | None = None) -> float:
        """Variance [rad^2/s^2] of the bias increment over ``dt`` [s], per axis: ``filter_sigma_u**2 dt``.

        Parameters
        ----------
        dt : float, optional
            Interval [s]; default :attr:`period`.
        """
        return self.filter_sigma_u**2 * self._dt(dt)

    def process_noise(self, dt: float | None = None) -> NDArray[np.float64]:
        """Discrete process noise (6, 6) of the attitude-error / bias-error state over ``dt`` [s].

        For the MEKF state ``x = [dtheta, dbeta]`` with ``dtheta`` [rad] the
        attitude error (``q_true = q_est ⊗ dq(dtheta)``) after propagating
        with ``omega_meas - beta_est`` and ``dbeta = beta - beta_est`` [rad/s]:

        ``Q = [[(sigma_v**2 dt + sigma_u**2 dt**3 / 3) I, -(sigma_u**2 dt**2 / 2) I],
        [-(sigma_u**2 dt**2 / 2) I, sigma_u**2 dt I]]``

        (Crassidis and Junkins, 2nd ed., sec. 7.2.1; exact for the sampled
        model at zero rate, to first order in ``|omega| dt`` otherwise), with
        ``sigma_u`` :attr:`filter_sigma_u`.

        Parameters
        ----------
        dt : float, optional
            Propagation interval [s]; default :attr:`period`.
        """
        return farrenkopf_process_noise(self.sigma_v**2, self.filter_sigma_u**2, self._dt(dt))

    def check_sampling(self, expected: str, *, consumer: str, action: str = "raise") -> bool:
        """Check that :attr:`sampling` is ``expected`` (what a filter's measurement model assumes).

        Parameters
        ----------
        expected : {"instantaneous", "mean"}
            The sampling the consumer models.
        consumer : str
            Who asks (named in the message), e.g. ``"RateEKF.from_gyro"``.
        action : {"raise", "warn", "ignore"}
            On a mismatch: raise ValueError, emit a :class:`GyroSamplingWarning`,
            or do nothing.

        Returns
        -------
        bool
            True when the sampling matches.

        Raises
        ------
        ValueError
            On a mismatch with ``action="raise"``, or for an unknown
            ``expected`` or ``action``.
        """
        if expected not in GYRO_SAMPLING:
            raise ValueError(f"expected must be one of {GYRO_SAMPLING}, got {expected!r}")
        if action not in SAMPLING_CHECKS:
            raise ValueError(f"sampling_check must be one of {SAMPLING_CHECKS}, got {action!r}")
        if self.sampling == expected:
            return True
        meaning = {
            "instantaneous": "the rate at the sample time",
            "mean": "the mean rate over the interval since the previous sample (an angle increment / dt)",
        }
        message = (
            f"gyro.sampling must be {expected!r} for {consumer}, got {self.sampling!r} (gyro {self.name!r}): "
            f"its measurement model takes a sample as {meaning[expected]}, while this gyro reports "
            f"{meaning[self.sampling]}; they differ by about dt/2 times the angular acceleration, which the filter "
            f"does not model. Build the gyro with sampling={expected!r}, or pass sampling_check='ignore' if the "
            "samples you feed are not this gyro's own"
        )
        if action == "raise":
            raise ValueError(message)
        if action == "warn":
            warnings.warn(message, GyroSamplingWarning, stacklevel=3)
        return False

    # -- sampling -------------------------------------------------------------------

    @property
    def bias(self) -> NDArray[np.float64]:
        """The bias [rad/s] at the time of the latest :meth:`measure` sample (a copy).

        The random-walk part plus the Gauss-Markov state, if any.
        """
        if self.sigma_b == 0.0:
            return self._bias.copy()
        return self._bias + self._markov

    def reset(self) -> None:
        """Forget the sample history: the bias returns to its initial value, the next sample is a first one.

        The Gauss-Markov state is drawn afresh from its stationary distribution at the first sample.
        """
        self._bias = np.array(self.initial_bias, dtype=np.float64)
        self._markov = np.zeros(3)
        self._t_last: float | None = None
        self._q_last: NDArray[np.float64] | None = None

    def _gm_coefficients(self, h: float) -> tuple[float, float, float, float, float]:
        """:func:`_gm_step_coefficients` for this gyro, cached by interval.

        The engine's ticks ``k dt`` differ by a handful of distinct floats
        (14 over 6000 ticks of 0.1 s), so a small cache keeps them all.
        """
        coefficients = self._gm_cache.get(h)
        if coefficients is None:
            if len(self._gm_cache) >= _GM_CACHE_SIZE:
                self._gm_cache.clear()
            coefficients = self._gm_cache[h] = _gm_step_coefficients(h, self.sigma_b, self.correlation_time)
        return coefficients

    def _markov_errors(
        self, markov0: NDArray[np.float64], dt_bias: NDArray[np.float64], normals: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exact Gauss-Markov states (..., n + 1, 3) and interval means (..., n, 3) over the steps ``dt_bias`` (n,).

        ``normals`` (..., n, 2, 3) holds ``N_b1`` and ``N_b2`` of each step. The
        recursion ``x_{k+1} = phi x_k + s N_b1`` runs through
        ``scipy.signal.lfilter`` when every step has the same ``phi``, else
        step by step; both compute ``round(round(phi x) + e)``, so a batch, a
        history and one-at-a-time calls agree bit for bit.
        """
        coeffs = np.array([self._gm_coefficients(float(h)) for h in dt_bias])
        phi, s, a, c, d = (coeffs[:, i, None] for i in range(5))
        n1, n2 = normals[..., 0, :], normals[..., 1, :]
        drive = s * n1
        n = dt_bias.size
        states = np.empty((*drive.shape[:-2], n + 1, 3))
        states[..., 0, :] = markov0
        if n > 1 and np.all(phi == phi[0]):
            from scipy.signal import lfilter

            zi = (phi[0] * markov0)[..., None, :]
            states[..., 1:, :] = lfilter([1.0], [1.0, -float(phi[0, 0])], drive, axis=-2, zi=zi)[0]
        else:
            for k in range(n):
                states[..., k + 1, :] = phi[k] * states[..., k, :] + drive[..., k, :]
        means = a * states[..., :-1, :] + c * n1 + d * n2
        return states, means

    def _errors(
        self,
        bias0: NDArray[np.float64],
        dt_bias: NDArray[np.float64],
        dt_noise: NDArray[np.float64],
        normals: NDArray[np.float64],
        markov0: NDArray[np.float64] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
        """Farrenkopf (and Gauss-Markov) errors of ``n`` consecutive samples (the one code path).

        ``normals`` (..., n, 2, 3) holds ``N_u`` and ``N_v`` of each step (a
        leading runs axis is allowed, with ``bias0`` (..., 3)), and (..., n, 4, 3)
        ``N_b1``, ``N_b2`` after them with a Gauss-Markov term, whose state
        before the first step is ``markov0`` (..., 3);
        ``dt_bias`` (n,) the bias propagation interval (0 for a first sample,
        which draws the Gauss-Markov state from its stationary distribution)
        and ``dt_noise`` (n,) the averaging interval. Returns the rate errors
        (..., n, 3), the random-walk biases (..., n + 1, 3) starting with ``bias0``
        and the Gauss-Markov states (..., n + 1, 3) (None without the term).
        Sequential sums (``cumsum`` along the steps)
        make a batch bit-identical to one-at-a-time calls.
        """
        steps = (self.sigma_u * np.sqrt(dt_bias))[:, None] * normals[..., 0, :]
        start = np.broadcast_to(bias0[..., None, :], (*steps.shape[:-2], 1, 3))
        biases = np.cumsum(np.concatenate([start, steps], axis=-2), axis=-2)
        white = np.sqrt(self.sigma_v**2 / dt_noise + self.sigma_u**2 * dt_noise / 12.0)
        errors = 0.5 * (biases[..., :-1, :] + biases[..., 1:, :]) + white[:, None] * normals[..., 1, :]
        if self.sigma_b == 0.0:
            return errors, biases, None
        start_markov = np.zeros(bias0.shape) if markov0 is None else markov0
        states, means = self._markov_errors(start_markov, dt_bias, normals[..., 2:, :])
        return errors + means, biases, states

    def ideal_output(self, omega_BN_B: ArrayLike) -> NDArray[np.float64]:
        """Noise-free, unquantised output ``(I + S + M) omega`` [rad/s], shape (..., 3).

        Parameters
        ----------
        omega_BN_B : array_like (..., 3)
            True body rate [rad/s].
        """
        omega = check_vector(omega_BN_B, "omega_BN_B", 3)
        return _apply_transfer(self.transfer_matrix, omega)

    def _output(
        self, omega: NDArray[np.float64], errors: NDArray[np.float64], transfer: NDArray[np.float64] | None = None
    ) -> NDArray[np.float64]:
        """``clip(quantise(T omega + errors))`` with ``T`` this gyro's transfer matrix or ``transfer`` (..., 3, 3)."""
        raw = _apply_transfer(self.transfer_matrix if transfer is None else transfer, omega) + errors
        if self.quantization > 0:
            raw = np.round(raw / self.quantization) * self.quantization
        if np.isfinite(self.saturation):
            raw = np.clip(raw, -self.saturation, self.saturation)
        return raw

    def _sample(
        self,
        t: float,
        omega: NDArray[np.float64],
        q: NDArray[np.float64] | None,
        bias: NDArray[np.float64],
        t_last: float | None,
        q_last: NDArray[np.float64] | None,
        normals: NDArray[np.float64],
        transfer: NDArray[np.float64] | None = None,
        markov: NDArray[np.float64] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None]:
        """One sample of one gyro, or of N runs at once (a leading runs axis): the one code path.

        :meth:`measure` calls it with ``omega`` (3,), ``q`` (4,), ``bias``
        (3,), ``normals`` (1, rows, 3), ``markov`` (3,); :class:`GyroBatch` with (N, 3), (N, 4),
        (N, 3), (N, 1, rows, 3), (N, 3) and its per-run ``transfer`` (N, 3, 3). Every
        operation is elementwise along the runs axis (explicit products, no
        BLAS), so run ``r`` of a batch rounds exactly as the single call. No
        checks (the callers validate, ``t > t_last`` included). Returns the
        output, the random-walk bias and the Gauss-Markov state at ``t``.
        """
        if self.sampling == "mean" and q_last is not None:
            # The interval-mean rate: the rotation vector of the attitude increment over the interval.
            increment = quat.multiply(quat.conjugate(q_last), q)
            omega = quat.to_rotation_vector(increment) / (t - t_last)
        if t_last is None:
            dt_bias, dt_noise = 0.0, self.period
        else:
            dt_bias = dt_noise = t - t_last
        errors, biases, states = self._errors(bias, np.array([dt_bias]), np.array([dt_noise]), normals, markov)
        markov_t = None if states is None else states[..., -1, :]
        return self._output(omega, errors[..., 0, :], transfer), biases[..., -1, :], markov_t

    def _sample_floats(
        self, t: float, omega: list[float], q: list[float] | None, normals: list[list[float]]
    ) -> NDArray[np.float64]:
        """:meth:`_sample` of one gyro in Python floats, the same operations in the same order; updates the bias.

        ``omega`` (3) the true rate, ``q`` (4) the normalised attitude (None
        unless ``sampling="mean"``), ``normals`` the rows ``[N_u, N_v]`` (and
        ``[N_b1, N_b2]``) of 3. A sample is bit-identical to :meth:`_sample`'s
        (tests/attitude/test_sensors.py), hence to :class:`GyroBatch`'s.
        """
        t_last = self._t_last
        if q is not None and self._q_last is not None:
            increment = quat.multiply_components(quat.conjugate_components(self._q_last.tolist()), q)
            rotvec = quat.rotation_vector_floats(increment)
            if rotvec is None:  # not unit: the array function raises its error
                rotvec = quat.to_rotation_vector(np.array(increment)).tolist()
            dt = t - t_last
            omega = [c / dt for c in rotvec]
        if t_last is None:
            dt_bias, dt_noise = 0.0, self.period
        else:
            dt_bias = dt_noise = t - t_last
        n_u, n_v = normals[0], normals[1]
        step = self.sigma_u * math.sqrt(dt_bias)
        bias0 = self._bias.tolist()
        bias1 = [b + step * n for b, n in zip(bias0, n_u)]
        white = math.sqrt(self.sigma_v**2 / dt_noise + self.sigma_u**2 * dt_noise / 12.0)
        errors = [0.5 * (b0 + b1) + white * n for b0, b1, n in zip(bias0, bias1, n_v)]
        if self.sigma_b != 0.0:
            phi, s, a, c, d = self._gm_coefficients(dt_bias)
            markov0 = self._markov.tolist()
            n_b1, n_b2 = normals[2], normals[3]
            self._markov = np.array([phi * m + s * n1 for m, n1 in zip(markov0, n_b1)])
            errors = [e + (a * m + c * n1 + d * n2) for e, m, n1, n2 in zip(errors, markov0, n_b1, n_b2)]
        self._bias = np.array(bias1)
        o0, o1, o2 = omega
        raw = [o0 * r0 + o1 * r1 + o2 * r2 + e for (r0, r1, r2), e in zip(self.transfer_matrix.tolist(), errors)]
        if self.quantization > 0:
            lsb = self.quantization
            raw = [round(v / lsb) * lsb for v in raw]
        if math.isfinite(self.saturation):
            top = self.saturation
            raw = [min(max(v, -top), top) for v in raw]
        return np.array(raw)

    def measure(self, t: float, truth: Any, rng: Any = None) -> NDArray[np.float64]:
        """One rate sample [rad/s] at time ``t`` [s] (the engine's sensor protocol).

        Propagates the bias exactly over the time since the previous sample
        (a first sample, after construction or :meth:`reset`, starts from the
        initial bias with no propagation and the white noise of one nominal
        period), then applies the model of docs/sensors.md.

        Parameters
        ----------
        t : float
            Sample time [s]; must increase from call to call.
        truth : attitude.simulation.engine.Truth
            Anything with ``omega`` (3,) [rad/s], the true body rate.
        rng : Generator, int or None
            Random source. Pass one Generator for a sequence of samples (an
            integer seed here would restart the stream at every call).

        Raises
        ------
        ValueError
            If ``t`` does not come after the previous sample (call
            :meth:`reset` before a new run) or ``truth.omega`` is invalid.
        """
        gen = as_generator(rng)
        t = float(t) if isinstance(t, float) and math.isfinite(t) else float(as_float_array(t, "t"))
        omega_floats = finite_floats(truth.omega, 3)
        q_floats = None
        if self.sampling == "mean" and omega_floats is not None:
            q_in = finite_floats(truth.q, 4)
            q_floats = None if q_in is None else quat.unit_floats(q_in)
        if omega_floats is not None and (q_floats is not None or self.sampling != "mean"):
            # One sample in Python floats: the operations of _sample in the same order (bit for bit).
            _check_after(t, self._t_last, f"gyro {self.name!r}")
            normals = gen.standard_normal((self._normal_rows, 3)).tolist()
            out = self._sample_floats(t, omega_floats, q_floats, normals)
            self._t_last = t
            self._q_last = None if q_floats is None else np.array(q_floats)
            return out
        omega = check_vector(truth.omega, "truth.omega", 3)
        q = quat.as_unit_quaternion(truth.q, "truth.q") if self.sampling == "mean" else None
        _check_after(t, self._t_last, f"gyro {self.name!r}")
        normals = gen.standard_normal((1, self._normal_rows, 3))
        out, self._bias, markov = self._sample(
            t, omega, q, self._bias, self._t_last, self._q_last, normals, markov=self._markov
        )
        if markov is not None:
            self._markov = markov
        self._t_last = t
        self._q_last = q
        return out

    def sample_errors(
        self,
        n_steps: int,
        rng: Any = None,
        *,
        dt: float | None = None,
        bias0: ArrayLike | None = None,
        n_runs: int | None = None,
        markov0: ArrayLike | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Rate errors of ``n_steps`` consecutive samples of a running gyro, vectorised.

        Every step propagates the bias (unlike the first :meth:`measure` of a
        run). Does not touch the gyro's state. With a Gauss-Markov term and no
        ``markov0``, its state before the first step is drawn from the
        stationary distribution (3 normals per run, drawn before the steps'):
        the output is a stationary sequence.

        Parameters
        ----------
        n_steps : int
            Number of samples (>= 1).
        rng : Generator, int or None
            Random source.
        dt : float, optional
            Sample interval [s] (default :attr:`period`).
        bias0 : array_like (3,) or (n_runs, 3), optional
            Bias before the first step [rad/s] (default the initial bias); one
            per run with ``n_runs``.
        n_runs : int, optional
            Number of independent runs drawn at once (a leading runs axis on
            the outputs). Run ``r`` is bit-identical to the ``r``-th of
            ``n_runs`` consecutive single-run calls with the same Generator
            (and that run's ``bias0``): the normals are drawn in the same order.
        markov0 : array_like (3,) or (n_runs, 3), optional
            Gauss-Markov state before the first step [rad/s] (only with
            ``sigma_b > 0``); default a stationary draw.

        Returns
        -------
        errors : ndarray (n_steps, 3) or (n_runs, n_steps, 3)
            ``omega_meas - omega`` of each sample before scale factor,
            misalignment, quantisation and saturation [rad/s].
        biases : ndarray (n_steps + 1, 3) or (n_runs, n_steps + 1, 3)
            Bias (random walk plus Gauss-Markov state) at the start and at
            each sample time [rad/s].
        """
        if not isinstance(n_steps, (int, np.integer)) or isinstance(n_steps, bool) or n_steps < 1:
            raise ValueError(f"n_steps must be a positive integer, got {n_steps!r}")
        if n_runs is not None and (not isinstance(n_runs, (int, np.integer)) or isinstance(n_runs, bool) or n_runs < 1):
            raise ValueError(f"n_runs must be a positive integer or None, got {n_runs!r}")
        dt = self._dt(dt)
        if bias0 is None:
            b0 = np.array(self.initial_bias, dtype=np.float64)
        elif n_runs is None:
            b0 = np.array(_per_axis(bias0, "bias0"), dtype=np.float64)
        else:
            b0 = as_float_array(bias0, "bias0")
            if b0.shape not in ((), (3,), (int(n_runs), 3)):
                raise ValueError(f"bias0 must be a scalar or have shape (3,) or ({n_runs}, 3), got shape {b0.shape}")
            b0 = np.array(np.broadcast_to(b0, (int(n_runs), 3)), dtype=np.float64)
        lead = () if n_runs is None else (int(n_runs),)
        gen = as_generator(rng)
        dts = np.full(int(n_steps), dt)
        if self.sigma_b == 0.0:
            if markov0 is not None:
                raise ValueError(f"markov0 needs a Gauss-Markov term (sigma_b > 0); gyro {self.name!r} has none")
            errors, biases, _ = self._errors(b0, dts, dts, gen.standard_normal((*lead, int(n_steps), 2, 3)))
            return errors, biases
        if markov0 is None:
            block = gen.standard_normal((*lead, 3 + int(n_steps) * 12))
            m0 = self.sigma_b * block[..., :3]
            normals = block[..., 3:].reshape(*lead, int(n_steps), 4, 3)
        else:
            m0 = as_float_array(markov0, "markov0")
            if m0.shape not in ((), (3,), (*lead, 3)):
                raise ValueError(f"markov0 must be a scalar or have shape (3,) or {(*lead, 3)}, got shape {m0.shape}")
            m0 = np.array(np.broadcast_to(m0, (*lead, 3)), dtype=np.float64)
            normals = gen.standard_normal((*lead, int(n_steps), 4, 3))
        errors, biases, states = self._errors(b0, dts, dts, normals, m0)
        return errors, biases + states

    def measure_history(
        self, t: ArrayLike, omega_BN_B: ArrayLike, rng: Any = None, *, q_BN: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Samples [rad/s] of a whole true-rate history at once (a fresh run).

        Bit-identical to calling :meth:`measure` at each ``t[k]`` on a freshly
        reset gyro with the same Generator (and, for ``sampling="mean"``, the
        attitudes ``q_BN[k]``); does not touch the gyro's state.

        With ``sampling="mean"`` the true part of sample ``k >= 1`` is the
        mean rate over ``(t[k-1], t[k]]``, ``rotvec(q_BN[k-1]* ⊗ q_BN[k]) /
        (t[k] - t[k-1])``, as :meth:`measure` computes it, so the attitude
        history is required; the first sample is the instantaneous rate
        ``omega_BN_B[0]``.

        Parameters
        ----------
        t : array_like (n,)
            Strictly increasing sample times [s].
        omega_BN_B : array_like (n, 3)
            True body rates at those times [rad/s].
        rng : Generator, int or None
            Random source.
        q_BN : array_like (n, 4), optional
            True attitudes at those times (unit quaternions). Required for
            ``sampling="mean"``; checked and otherwise unused for
            ``sampling="instantaneous"``.

        Raises
        ------
        ValueError
            For non-increasing times, mismatched shapes, non-finite input, a
            non-unit ``q_BN``, or ``sampling="mean"`` without ``q_BN`` (the
            interval-mean rate cannot be formed from the rates at the sample
            times).
        """
        t = as_float_array(t, "t")
        if t.ndim != 1 or t.size < 1:
            raise ValueError(f"t must be a 1-D array of sample times, got shape {t.shape}")
        if np.any(np.diff(t) <= 0):
            raise ValueError("t must be strictly increasing")
        omega = check_vector(omega_BN_B, "omega_BN_B", 3)
        if omega.shape != (t.size, 3):
            raise ValueError(f"omega_BN_B must have shape ({t.size}, 3), got {omega.shape}")
        q = None
        if q_BN is not None:
            q = quat.as_unit_quaternion(q_BN, "q_BN")
            if q.shape != (t.size, 4):
                raise ValueError(f"q_BN must have shape ({t.size}, 4), got {q.shape}")
        steps = np.diff(t)
        if self.sampling == "mean":
            if q is None:
                raise ValueError(
                    f"q_BN is required: gyro {self.name!r} has sampling='mean', whose samples are the mean rate "
                    "rotvec(q[k-1]* ⊗ q[k]) / dt over each interval (what measure() reports), not the rate at the "
                    "sample time; pass the attitude history q_BN (n, 4), or use a gyro with sampling='instantaneous'"
                )
            omega = omega.copy()
            if t.size > 1:
                increment = quat.multiply(quat.conjugate(q[:-1]), q[1:])
                omega[1:] = quat.to_rotation_vector(increment) / steps[:, None]
        dt_bias = np.concatenate([[0.0], steps])
        dt_noise = np.concatenate([[self.period], steps])
        normals = as_generator(rng).standard_normal((t.size, self._normal_rows, 3))
        errors, _, _ = self._errors(np.array(self.initial_bias, dtype=np.float64), dt_bias, dt_noise, normals)
        return self._output(omega, errors)


#: Settings the gyros of a :class:`GyroBatch` must share (everything but the transfer matrix and the initial bias).
_GYRO_BATCH_SHARED = (
    "sigma_v",
    "sigma_u",
    "sigma_b",
    "correlation_time",
    "period",
    "sampling",
    "quantization",
    "saturation",
)


class GyroBatch:
    """N gyros sampled together: run ``r`` reproduces ``gyros[r].measure`` bit for bit.

    The batch sampler of a vectorised Monte Carlo campaign: N runs advance
    one tick at a time with their states stacked along a leading runs axis.
    The gyros may differ in their transfer matrix ``I + S + M`` (dispersed
    scale factor and misalignment) and in their initial bias (a dispersed
    turn-on bias); everything else (``sigma_v``, ``sigma_u``, ``sigma_b``,
    ``correlation_time``, ``period``, ``sampling``, ``quantization``,
    ``saturation``) must be the same. The
    batch keeps its own state (per-run bias (N, 3), the previous sample
    time, the previous attitudes (N, 4) for ``sampling="mean"``), starting
    as freshly reset gyros; the :class:`Gyro` objects are not touched.

    :meth:`measure` runs the same code as :meth:`Gyro.measure` (its
    ``_sample``: the interval-mean rate from the attitude increment, the
    first-sample rule, the exact Farrenkopf errors, quantisation and
    saturation) with a leading runs axis; every operation is elementwise
    along that axis, so when ``normals[r]`` are the numbers
    ``gen_r.standard_normal((1, rows, 3))`` would have drawn (``rows`` 2, or
    4 with a Gauss-Markov term), run ``r`` gets
    exactly the sample ``gyros[r].measure(t, truth_r, gen_r)`` returns.

    Parameters
    ----------
    gyros : sequence of Gyro
        One gyro per run (at least one), sharing the settings listed above.

    Raises
    ------
    ValueError
        If ``gyros`` is empty, holds something that is not a :class:`Gyro`,
        or two gyros differ in a shared setting (the message names it).
    """

    def __init__(self, gyros: Sequence[Gyro]) -> None:
        gs = list(gyros)
        if not gs:
            raise ValueError("gyros must hold at least one Gyro, got an empty sequence")
        for i, g in enumerate(gs):
            if not isinstance(g, Gyro):
                raise ValueError(f"gyros must hold attitude.sensors.Gyro objects; gyros[{i}] is {type(g).__name__}")
        first = gs[0]
        for name in _GYRO_BATCH_SHARED:
            for i, g in enumerate(gs[1:], start=1):
                if getattr(g, name) != getattr(first, name):
                    raise ValueError(
                        f"gyros must share {name} (only the transfer matrix and the initial bias may differ per run); "
                        f"gyros[0].{name} = {getattr(first, name)!r} but gyros[{i}].{name} = {getattr(g, name)!r}"
                    )
        # The shared settings and the one code path (Gyro._sample) come from the first gyro.
        self._model = first
        self.name = first.name
        transfer = np.stack([g.transfer_matrix for g in gs])
        transfer.flags.writeable = False
        #: Per-run ``I + S + M`` (N, 3, 3).
        self.transfer_matrix = transfer
        initial = np.stack([g.initial_bias for g in gs])
        initial.flags.writeable = False
        #: Per-run initial bias (N, 3) [rad/s].
        self.initial_bias = initial
        self.reset()

    def __repr__(self) -> str:
        return f"GyroBatch(n_runs={self.n_runs}, model={self._model!r})"

    @property
    def n_runs(self) -> int:
        """Number of runs."""
        return int(self.transfer_matrix.shape[0])

    @property
    def period(self) -> float:
        """Sample period [s] (shared)."""
        return self._model.period

    @property
    def sampling(self) -> str:
        """``"instantaneous"`` or ``"mean"`` (shared; see :class:`Gyro`)."""
        return self._model.sampling

    @property
    def sigma_v(self) -> float:
        """Angle-random-walk density [rad/s^0.5] (shared)."""
        return self._model.sigma_v

    @property
    def sigma_u(self) -> float:
        """Rate-random-walk density [rad/s^1.5] (shared)."""
        return self._model.sigma_u

    @property
    def bias(self) -> NDArray[np.float64]:
        """Per-run bias (N, 3) [rad/s] at the latest sample (a copy; random walk plus Gauss-Markov state)."""
        if self._model.sigma_b == 0.0:
            return self._bias.copy()
        return self._bias + self._markov

    @property
    def t_last(self) -> float | None:
        """Time [s] of the latest sample (None before the first)."""
        return self._t_last

    def reset(self) -> None:
        """Back to the initial biases; the next sample is a first one (as :meth:`Gyro.reset`)."""
        self._bias = np.array(self.initial_bias, dtype=np.float64)
        self._markov = np.zeros(self.initial_bias.shape)
        self._t_last: float | None = None
        self._q_last: NDArray[np.float64] | None = None

    def measure(
        self, t: float, q: ArrayLike | None, omega: ArrayLike, normals: ArrayLike | NormalStreams
    ) -> NDArray[np.float64]:
        """One rate sample [rad/s] per run at time ``t`` [s].

        Parameters
        ----------
        t : float
            Sample time [s] (shared); must come after the previous sample.
        q : array_like (N, 4) or None
            True attitudes ``q_BN`` (unit norm; normalised here as
            :meth:`Gyro.measure` does). Required for ``sampling="mean"``;
            ignored (may be None) for ``"instantaneous"``.
        omega : array_like (N, 3)
            True body rates [rad/s] (the sample of ``"instantaneous"``, and
            the first sample of ``"mean"``).
        normals : array_like (N, rows, 3) or NormalStreams
            Standard normals of each run, ``[N_u, N_v]`` (``rows = 2``), then
            ``[N_b1, N_b2]`` with a Gauss-Markov term (``rows = 4``), in the
            order of ``gen.standard_normal((1, rows, 3))``; or the runs'
            :class:`attitude.rng.NormalStreams`, from which ``3 rows`` numbers
            per run are drawn.

        Returns
        -------
        ndarray (N, 3)
            Samples [rad/s].

        Raises
        ------
        ValueError
            If ``t`` is not finite or does not come after the previous
            sample, or an array has the wrong shape, holds NaN/inf, or ``q``
            is not unit norm (nothing changes then).
        """
        n = self.n_runs
        t = scalar_time(t)
        w = check_vector(omega, "omega", 3)
        if w.shape != (n, 3):
            raise ValueError(f"omega must have shape ({n}, 3) (one true rate per run), got shape {w.shape}")
        qn = None
        if self.sampling == "mean":
            if q is None:
                raise ValueError(
                    "q is required: the gyros have sampling='mean', whose samples are formed from the attitude "
                    "increment since the previous sample"
                )
            qn = quat.as_unit_quaternion(q, "q")
            if qn.shape != (n, 4):
                raise ValueError(f"q must have shape ({n}, 4) (one attitude per run), got shape {qn.shape}")
        _check_after(t, self._t_last, "this GyroBatch")
        rows = self._model._normal_rows
        if isinstance(normals, NormalStreams):
            if normals.n_runs != n:
                raise ValueError(f"normals must have {n} streams (one per run), got {normals.n_runs}")
            nrm = normals.draw(None, 3 * rows).reshape(n, 1, rows, 3)
        else:
            nrm = as_float_array(normals, "normals")
            if nrm.shape != (n, rows, 3):
                what = "[N_u, N_v]" if rows == 2 else "[N_u, N_v, N_b1, N_b2]"
                raise ValueError(f"normals must have shape ({n}, {rows}, 3) ({what} per run), got shape {nrm.shape}")
            nrm = nrm[:, None]
        out, self._bias, markov = self._model._sample(
            t, w, qn, self._bias, self._t_last, self._q_last, nrm, self.transfer_matrix, self._markov
        )
        if markov is not None:
            self._markov = markov
        self._t_last = t
        self._q_last = qn
        return out


#: Datasheet figures of the gyro presets (keywords of :meth:`Gyro.from_datasheet`) and their sources.
GYRO_PRESETS: dict[str, dict[str, Any]] = {
    "mems": {
        "figures": {
            "arw_deg_per_sqrt_h": 0.34,
            "bias_instability_deg_per_h": 8.0,
            "bias_instability_time_s": 100.0,
            "saturation_deg_per_s": 2000.0,
        },
        "source": "Analog Devices ADIS16470 datasheet (rev. C): ARW 0.34 deg/sqrt(h), in-run bias stability "
        "8 deg/h, +-2000 deg/s; Allan-minimum time 100 s assumed",
    },
    "tactical": {
        "figures": {
            "arw_deg_per_sqrt_h": 0.07,
            "bias_instability_deg_per_h": 1.0,
            "bias_instability_time_s": 300.0,
            "saturation_deg_per_s": 1000.0,
        },
        "source": "Northrop Grumman LN-200/LN-200S FOG IMU datasheets: ARW 0.07 deg/sqrt(h), bias 1 deg/h "
        "(1 sigma), +-1000 deg/s; Allan-minimum time 300 s assumed",
    },
    "navigation": {
        "figures": {
            "arw_deg_per_sqrt_h": 0.002,
            "bias_instability_deg_per_h": 0.0035,
            "bias_instability_time_s": 10800.0,
        },
        "source": "Honeywell HG9900 RLG IMU brochure (N61-1638-000-000): ARW 0.002 deg/sqrt(h), bias 0.0035 deg/h; "
        "Allan-minimum time 3 h assumed (the earliest a minimum 0.664 B can sit with this ARW is 5300 s)",
    },
}


# ---------------------------------------------------------------------------
# Star tracker


def _sensor_frame(boresight: NDArray[np.float64]) -> NDArray[np.float64]:
    """``C_BS`` whose columns are the sensor axes in body components, the third being the boresight."""
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(boresight)))] = 1.0
    x = np.cross(helper, boresight)
    x /= np.linalg.norm(x)
    y = np.cross(boresight, x)
    return np.column_stack([x, y, boresight])


class StarTracker:
    """A star tracker: noisy attitude quaternions, larger noise about the boresight, Sun blinding.

    See docs/sensors.md for the model. Stateless: ``measure`` depends
    only on its arguments.

    Parameters
    ----------
    sigma_cross_rad : float
        Standard deviation of the error about each cross-boresight axis [rad] (> 0).
    sigma_roll_rad : float
        Standard deviation of the error about the boresight (roll) [rad] (> 0).
    period : float
        Sample period [s] (> 0).
    boresight_B : array_like (3,)
        Boresight direction in body components (normalised here; non-zero).
    sun_direction_N : array_like (3,) or callable, optional
        Direction to the Sun in inertial components (normalised), or a
        function ``t -> (3,)`` of time [s]. None: the Sun is ignored.
    sun_exclusion_rad : float, optional
        Half-angle of the Sun-exclusion cone about the boresight [rad], in
        ``(0, pi)``; required with, and only with, ``sun_direction_N``.
    name : str
        Sensor name.
    """

    def __init__(
        self,
        sigma_cross_rad: float,
        sigma_roll_rad: float,
        *,
        period: float,
        boresight_B: ArrayLike = (0.0, 0.0, 1.0),
        sun_direction_N: ArrayLike | Callable[[float], ArrayLike] | None = None,
        sun_exclusion_rad: float | None = None,
        name: str = "star_tracker",
    ) -> None:
        self.sigma_cross = positive_scalar(sigma_cross_rad, "sigma_cross_rad")
        self.sigma_roll = positive_scalar(sigma_roll_rad, "sigma_roll_rad")
        self.period = positive_scalar(period, "period")
        self.boresight_B = check_direction(boresight_B, "boresight_B")
        self.boresight_B.flags.writeable = False
        #: Sensor axes in body components (columns); the third is the boresight.
        self.C_BS = _sensor_frame(self.boresight_B)
        self.C_BS.flags.writeable = False
        if (sun_direction_N is None) != (sun_exclusion_rad is None):
            raise ValueError(
                "sun_direction_N and sun_exclusion_rad must be given together (or neither), got "
                f"sun_direction_N={'None' if sun_direction_N is None else 'set'} and "
                f"sun_exclusion_rad={sun_exclusion_rad!r}"
            )
        self.sun_exclusion: float | None = None
        self.sun_direction_N: NDArray[np.float64] | Callable[[float], ArrayLike] | None = None
        if sun_direction_N is not None:
            half = positive_scalar(sun_exclusion_rad, "sun_exclusion_rad")
            if half >= np.pi:
                raise ValueError(f"sun_exclusion_rad must be in (0, pi) [rad], got {half!r}")
            self.sun_exclusion = half
            self.sun_direction_N = (
                sun_direction_N if callable(sun_direction_N) else check_direction(sun_direction_N, "sun_direction_N")
            )
        if not isinstance(name, str) or not name:
            raise ValueError(f"name must be a non-empty string, got {name!r}")
        self.name = name

    def __repr__(self) -> str:
        return (
            f"StarTracker(name={self.name!r}, sigma_cross={self.sigma_cross / ARCSEC:.3g} arcsec, "
            f"sigma_roll={self.sigma_roll / ARCSEC:.3g} arcsec, period={self.period:g} s)"
        )

    @classmethod
    def from_datasheet(
        cls,
        *,
        cross_boresight_arcsec: float,
        roll_arcsec: float,
        period: float,
        boresight_B: ArrayLike = (0.0, 0.0, 1.0),
        sun_direction_N: ArrayLike | Callable[[float], ArrayLike] | None = None,
        sun_exclusion_deg: float | None = None,
        name: str = "star_tracker",
    ) -> StarTracker:
        """Build a tracker from 1-sigma noise figures [arcsec] and a Sun-exclusion half-angle [deg].

        ``1 arcsec = pi / 648000 rad`` (:data:`ARCSEC`). Datasheets quote
        either 1 sigma or 3 sigma: divide a 3-sigma figure by 3 first.

        Parameters
        ----------
        cross_boresight_arcsec : float
            1-sigma noise about each cross-boresight axis [arcsec].
        roll_arcsec : float
            1-sigma noise about the boresight (roll) [arcsec].
        period : float
            Sample period [s].
        boresight_B : array_like (3,), optional
            Boresight direction in body axes (normalised).
        sun_direction_N : array_like (3,) or callable, optional
            Sun direction in N, or ``f(t) -> (3,)`` for a moving Sun; None for no Sun exclusion.
        sun_exclusion_deg : float, optional
            Sun-exclusion half-angle about the boresight [deg].
        name : str, optional
            Sensor name (the key of its samples in the engine's measurements).
        """
        cross = positive_scalar(cross_boresight_arcsec, "cross_boresight_arcsec")
        roll = positive_scalar(roll_arcsec, "roll_arcsec")
        exclusion = None
        if sun_exclusion_deg is not None:
            exclusion = positive_scalar(sun_exclusion_deg, "sun_exclusion_deg") * _DEG
        return cls(
            cross * ARCSEC,
            roll * ARCSEC,
            period=period,
            boresight_B=boresight_B,
            sun_direction_N=sun_direction_N,
            sun_exclusion_rad=exclusion,
            name=name,
        )

    @classmethod
    def preset(
        cls,
        kind: str = "typical",
        *,
        period: float | None = None,
        sun_direction_N: ArrayLike | Callable[[float], ArrayLike] | None = None,
        **overrides: Any,
    ) -> StarTracker:
        """A typical commercial small-satellite star tracker.

        ``"typical"``: 6 arcsec cross-boresight and 40 arcsec about the
        boresight (1 sigma), 5 Hz: the figures Blue Canyon Technologies
        publishes for its Nano Star Tracker (NST) and XACT units; Sinclair
        ST-16 and Arcsec Sagitta class trackers are similar (a few arcsec
        cross-boresight, 5 to 10 times more in roll, 2 to 10 Hz). With a Sun
        direction, a 45 deg Sun-exclusion half-angle (an *assumed* typical
        small-baffle value; larger trackers with long baffles reach about
        30 deg, e.g. the Terma HE-5AS on CryoSat). See :data:`STAR_TRACKER_PRESETS`.

        Parameters
        ----------
        kind : {"typical"}
            Preset name.
        period : float, optional
            Sample period [s] (default that of the preset, 0.2 s).
        sun_direction_N : array_like (3,) or callable, optional
            Enables Sun exclusion (see the class).
        **overrides
            Keywords of :meth:`from_datasheet`.
        """
        if kind not in STAR_TRACKER_PRESETS:
            raise ValueError(f"kind must be one of {tuple(STAR_TRACKER_PRESETS)}, got {kind!r}")
        figures = dict(STAR_TRACKER_PRESETS[kind]["figures"])
        exclusion = figures.pop("sun_exclusion_deg")
        if period is not None:
            figures["period"] = period
        if sun_direction_N is not None:
            figures["sun_direction_N"] = sun_direction_N
            figures["sun_exclusion_deg"] = exclusion
        figures.update(overrides)
        return cls.from_datasheet(**figures)

    @property
    def covariance_B(self) -> NDArray[np.float64]:
        """Covariance (3, 3) [rad^2] of the error rotation vector of ``q_BN* ⊗ q_meas`` in body axes.

        ``C_BS diag(s_c^2, s_c^2, s_r^2) C_BS^T = s_c^2 I + (s_r^2 - s_c^2) b b^T``.
        """
        b = self.boresight_B
        return self.sigma_cross**2 * np.eye(3) + (self.sigma_roll**2 - self.sigma_cross**2) * np.outer(b, b)

    def sun_direction_at(self, t: float) -> NDArray[np.float64] | None:
        """Unit Sun direction in N at ``t`` [s] (None without Sun exclusion).

        Parameters
        ----------
        t : float
            Time [s].
        """
        if self.sun_direction_N is None:
            return None
        if callable(self.sun_direction_N):
            return check_direction(self.sun_direction_N(t), "sun_direction_N(t)")
        return self.sun_direction_N

    def sun_blinded(self, t: float, q_BN: ArrayLike) -> bool | NDArray[np.bool_]:
        """True when the Sun is strictly inside the exclusion cone about the boresight.

        The test is ``angle(boresight, sun) < sun_exclusion``, with the Sun
        direction taken into body axes by ``q_BN`` and the angle
        ``atan2(|s x b|, s . b)`` formed with explicit products (a batch
        decides exactly as one attitude at a time).

        Parameters
        ----------
        t : float
            Time [s] (for a time-varying Sun direction).
        q_BN : array_like (4,) or (..., 4)
            Attitude(s) (unit norm).

        Returns
        -------
        bool or ndarray (...) of bool
            A bool for one attitude, an array for a batch.
        """
        q = quat.as_unit_quaternion(q_BN, "q_BN")
        blinded = self._blinded(t, q)
        return bool(blinded) if q.ndim == 1 else blinded

    def _blinded(self, t: float, q: NDArray[np.float64]) -> NDArray[np.bool_]:
        """:meth:`sun_blinded` for normalised attitudes ``q`` (..., 4) (the one code path)."""
        sun_N = self.sun_direction_at(t)
        if sun_N is None:
            return np.zeros(q.shape[:-1], dtype=bool)
        sun_B = quat.rotate_inverse(q, sun_N)
        s0, s1, s2 = sun_B[..., 0], sun_B[..., 1], sun_B[..., 2]
        b0, b1, b2 = (float(c) for c in self.boresight_B)
        cos_part = s0 * b0 + s1 * b1 + s2 * b2
        c0, c1, c2 = s1 * b2 - s2 * b1, s2 * b0 - s0 * b2, s0 * b1 - s1 * b0
        sin_part = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        return np.asarray(np.arctan2(sin_part, cos_part) < self.sun_exclusion)

    def _noisy(self, q: NDArray[np.float64], normals: NDArray[np.float64]) -> NDArray[np.float64]:
        """``q ⊗ exp(C_BS diag(s_c, s_c, s_r) normals / 2)`` for normalised ``q`` (..., 4) (the one code path)."""
        scale = np.array([self.sigma_cross, self.sigma_cross, self.sigma_roll])
        dtheta_S = normals * scale
        c = self.C_BS
        # Explicit products (no BLAS) so a batch and a single sample round identically.
        dtheta_B = dtheta_S[..., 0:1] * c[:, 0] + dtheta_S[..., 1:2] * c[:, 1] + dtheta_S[..., 2:3] * c[:, 2]
        return quat.multiply(q, quat.from_rotation_vector(dtheta_B))

    def add_noise(self, q_BN: ArrayLike, rng: Any = None) -> NDArray[np.float64]:
        """Noisy attitudes ``q_BN ⊗ dq`` for true attitudes ``q_BN`` (..., 4); no Sun check.

        The batch path shared with :meth:`measure`: a batch of ``n`` draws
        the same numbers as ``n`` calls of :meth:`measure` with one Generator.

        Parameters
        ----------
        q_BN : array_like (..., 4)
            True attitudes.
        rng : numpy.random.Generator, int or None, optional
            Random source (a Generator, a seed, or None).
        """
        q = quat.as_unit_quaternion(q_BN, "q_BN")
        return self._noisy(q, as_generator(rng).standard_normal((*q.shape[:-1], 3)))

    def measure(self, t: float, truth: Any, rng: Any = None) -> NDArray[np.float64] | None:
        """Measured attitude ``q_BN`` (4,) at ``t`` [s], or None while the Sun blinds the tracker.

        No random numbers are drawn for a blinded sample.

        Parameters
        ----------
        t : float
            Time [s] (for a time-varying Sun direction).
        truth : attitude.simulation.engine.Truth
            Anything with ``q`` (4,), the true attitude ``q_BN``.
        rng : Generator, int or None
            Random source.
        """
        q_in = finite_floats(truth.q, 4)
        q_floats = None if q_in is None else quat.unit_floats(q_in)
        if q_floats is not None:
            blinded = self._blinded_floats(t, q_floats)
            if blinded is not None:
                # The array path's operations in Python floats (bit for bit; tests/attitude/test_sensors.py).
                if blinded:
                    return None
                return self._noisy_floats(q_floats, as_generator(rng).standard_normal(3).tolist())
        q = quat.as_unit_quaternion(truth.q, "truth.q")
        if self._blinded(t, q):
            return None
        # Normalised once, as add_noise does: a sequence of measurements is bit-identical to one batch call.
        return self._noisy(q, as_generator(rng).standard_normal(3))

    def _blinded_floats(self, t: float, q: list[float]) -> bool | None:
        """:meth:`_blinded` of one normalised attitude in Python floats, bit for bit (None: take the array path)."""
        sun_N = self.sun_direction_at(t)
        if sun_N is None:
            return False
        # rotate_inverse normalises q, and rotate its conjugate, once more each: so does this.
        q_unit = quat.unit_floats(q)
        conj = None if q_unit is None else quat.unit_floats(quat.conjugate_components(q_unit))
        if conj is None:
            return None
        s0, s1, s2 = quat.rotate_components(conj, sun_N.tolist())
        b0, b1, b2 = self.boresight_B.tolist()
        cos_part = s0 * b0 + s1 * b1 + s2 * b2
        c0, c1, c2 = s1 * b2 - s2 * b1, s2 * b0 - s0 * b2, s0 * b1 - s1 * b0
        sin_part = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        return bool(np.arctan2(sin_part, cos_part) < self.sun_exclusion)

    def _noisy_floats(self, q: list[float], normals: list[float]) -> NDArray[np.float64]:
        """:meth:`_noisy` of one normalised attitude and 3 normals in Python floats, bit for bit."""
        d0, d1, d2 = normals[0] * self.sigma_cross, normals[1] * self.sigma_cross, normals[2] * self.sigma_roll
        dtheta_B = [d0 * c0 + d1 * c1 + d2 * c2 for c0, c1, c2 in self.C_BS.tolist()]
        return np.array(quat.multiply_components(q, quat.from_rotation_vector_floats(dtheta_B)))

    def measure_batch(
        self, t: float, q_BN: ArrayLike, normals: ArrayLike | NormalStreams
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """One sample per run at ``t`` [s]: run ``r`` is exactly :meth:`measure` of ``q_BN[r]``.

        A blinded run draws no numbers (as :meth:`measure`): with an array of
        normals, its row is ignored (it may be NaN); with
        :class:`attitude.rng.NormalStreams`, only the runs that sample draw
        3 numbers each. To draw the normals yourself, find the runs that
        sample first with :meth:`sun_blinded` (a batch of attitudes gives a
        boolean array).

        Parameters
        ----------
        t : float
            Time [s] (shared; for a time-varying Sun direction).
        q_BN : array_like (N, 4)
            True attitudes (unit norm; normalised here as :meth:`measure` does).
        normals : array_like (N, 3) or NormalStreams
            Standard normals of each run, in the order of
            ``gen.standard_normal(3)`` (rows of blinded runs unused); or the
            runs' streams.

        Returns
        -------
        q_meas : ndarray (N, 4)
            Measured attitudes ``q_BN``; NaN rows where the Sun blinds the tracker.
        sampled : ndarray (N,) of bool
            True where a sample was made.

        Raises
        ------
        ValueError
            If ``q_BN`` is not (N, 4) unit quaternions, ``normals`` has the
            wrong shape (or number of streams), or holds NaN/inf in a row of
            a run that samples.
        """
        q = quat.as_unit_quaternion(q_BN, "q_BN")
        if q.ndim != 2:
            raise ValueError(f"q_BN must have shape (N, 4) (one attitude per run), got shape {q.shape}")
        n = q.shape[0]
        sampled = ~self._blinded(t, q)
        if isinstance(normals, NormalStreams):
            if normals.n_runs != n:
                raise ValueError(f"normals must have {n} streams (one per run), got {normals.n_runs}")
            nrm = normals.draw(sampled, 3)
        else:
            nrm = as_float_array(normals, "normals", allow_nonfinite=True)
            if nrm.shape != (n, 3):
                raise ValueError(f"normals must have shape ({n}, 3) (one triple per run), got shape {nrm.shape}")
            bad = sampled & ~np.all(np.isfinite(nrm), axis=-1)
            if np.any(bad):
                r = int(np.argmax(bad))
                raise ValueError(
                    f"normals must be finite in the rows of runs that sample; row {r} is {describe(nrm[r])}"
                )
        out = np.full((n, 4), np.nan)
        out[sampled] = self._noisy(q[sampled], nrm[sampled])
        return out, sampled


#: Datasheet figures of the star-tracker presets (keywords of :meth:`StarTracker.from_datasheet`).
STAR_TRACKER_PRESETS: dict[str, dict[str, Any]] = {
    "typical": {
        "figures": {"cross_boresight_arcsec": 6.0, "roll_arcsec": 40.0, "period": 0.2, "sun_exclusion_deg": 45.0},
        "source": "Blue Canyon Technologies Nano Star Tracker (NST) datasheet: 6 arcsec cross-boresight, "
        "40 arcsec roll (1 sigma), 5 Hz; 45 deg Sun exclusion assumed",
    },
}


# ---------------------------------------------------------------------------
# Magnetometer


class Magnetometer:
    """A three-axis magnetometer: white noise, constant bias, scale factor, misalignment, quantisation.

    The sample at ``t`` is

    .. math::

        y = \\mathrm{quant}\\big((I + S + M)\\, B_B + b + \\sigma\\, n\\big),
        \\qquad n \\sim N(0, I_3)

    with ``B_B`` the true field in body axes (``truth.magnetic_field_B``),
    ``S = diag(scale_factor)``, ``M`` the misalignment (a small rotation
    vector ``phi`` gives ``M = -[phi x]``, the first-order rotation of the
    sensor triad by ``phi``, as :class:`Gyro` does) and ``b`` the bias; the
    usual three-axis magnetometer error model (Markley and Crassidis,
    *Fundamentals of Spacecraft Attitude Determination and Control*, 2014,
    sec. 4.3; Alonso and Shuster, "Complete linear attitude-independent
    magnetometer calibration", J. Astronaut. Sci. 50(4), 2002). Stateless:
    ``measure`` depends only on its arguments.

    Parameters
    ----------
    sigma_T : float
        Standard deviation of the white noise on each axis [T] (>= 0; 0 for
        tests of the deterministic errors).
    period : float
        Sample period [s] (> 0).
    bias_T : float or array_like (3,)
        Constant bias [T].
    scale_factor : float or array_like (3,)
        Scale-factor errors (dimensionless), each > -1.
    misalignment : array_like (3,) or (3, 3)
        Small rotation vector [rad] of the sensor triad from the body axes,
        or the matrix ``M`` (zero diagonal) of cross-axis sensitivities.
    quantization_T : float
        Output resolution [T per LSB] (0: none); each axis is rounded to the
        nearest multiple.
    name : str
        Sensor name (key of its samples in the measurements and the logs).

    Raises
    ------
    ValueError
        A negative or non-finite noise, bias or quantisation, a period <= 0,
        a scale factor <= -1, a misalignment of the wrong shape or with a
        non-zero diagonal, or an empty name.
    """

    def __init__(
        self,
        sigma_T: float,
        *,
        period: float,
        bias_T: ArrayLike = 0.0,
        scale_factor: ArrayLike = 0.0,
        misalignment: ArrayLike = (0.0, 0.0, 0.0),
        quantization_T: float = 0.0,
        name: str = "magnetometer",
    ) -> None:
        self.sigma = positive_scalar(sigma_T, "sigma_T", allow_zero=True)
        self.period = positive_scalar(period, "period")
        self.bias = _per_axis(bias_T, "bias_T")
        self.scale_factor = _per_axis(scale_factor, "scale_factor")
        if np.any(self.scale_factor <= -1.0):
            raise ValueError(f"scale_factor must be > -1 on every axis (a positive gain), got {self.scale_factor}")
        self.misalignment = _misalignment_matrix(misalignment)
        self.misalignment.flags.writeable = False
        self.quantization = positive_scalar(quantization_T, "quantization_T", allow_zero=True)
        if not isinstance(name, str) or not name:
            raise ValueError(f"name must be a non-empty string, got {name!r}")
        self.name = name
        transfer = np.eye(3) + np.diag(self.scale_factor) + self.misalignment
        transfer.flags.writeable = False
        #: ``I + S + M``: maps the true field in body axes to the noise-free output.
        self.transfer_matrix = transfer

    def __repr__(self) -> str:
        return (
            f"Magnetometer(name={self.name!r}, sigma={self.sigma / _NANOTESLA:.4g} nT, "
            f"bias={self.bias / _NANOTESLA} nT, period={self.period:g} s)"
        )

    @classmethod
    def from_datasheet(
        cls,
        *,
        noise_nT: float,
        period: float,
        bias_nT: ArrayLike = 0.0,
        scale_factor_ppm: ArrayLike = 0.0,
        misalignment_rad: ArrayLike = (0.0, 0.0, 0.0),
        quantization_nT: float = 0.0,
        name: str = "magnetometer",
    ) -> Magnetometer:
        """Build a magnetometer from datasheet figures in nT and ppm.

        ``1 nT = 1e-9 T``; scale factor ``ppm * 1e-6``. A noise quoted as a
        density [nT/sqrt(Hz)] is ``noise_nT = density * sqrt(bandwidth)``
        for the output bandwidth [Hz] (about half the sample rate for an
        unfiltered output).

        Parameters
        ----------
        noise_nT : float
            1-sigma white noise per axis and sample [nT] (>= 0).
        period : float
            Sample period [s].
        bias_nT : float or array_like (3,)
            Constant bias (offset) [nT].
        scale_factor_ppm : float or array_like (3,)
            Scale-factor error [ppm].
        misalignment_rad : array_like (3,) or (3, 3)
            See the class parameters [rad].
        quantization_nT : float
            Output resolution [nT per LSB] (0: none).
        name : str
            Sensor name.

        Returns
        -------
        Magnetometer
            The sensor in SI units.
        """
        return cls(
            positive_scalar(noise_nT, "noise_nT", allow_zero=True) * _NANOTESLA,
            period=period,
            bias_T=as_float_array(bias_nT, "bias_nT") * _NANOTESLA,
            scale_factor=as_float_array(scale_factor_ppm, "scale_factor_ppm") * 1e-6,
            misalignment=misalignment_rad,
            quantization_T=positive_scalar(quantization_nT, "quantization_nT", allow_zero=True) * _NANOTESLA,
            name=name,
        )

    def _measured(self, field_B: NDArray[np.float64], normals: NDArray[np.float64]) -> NDArray[np.float64]:
        """The sample for true fields (..., 3) and standard normals (..., 3): the one code path."""
        y = _apply_transfer(self.transfer_matrix, field_B) + self.bias + self.sigma * normals
        if self.quantization > 0:
            y = self.quantization * np.floor(y / self.quantization + 0.5)
        return y

    def _field(self, truth: Any) -> NDArray[np.float64]:
        field_B = getattr(truth, "magnetic_field_B", None)
        if field_B is None:
            raise ValueError(
                f"magnetometer {self.name!r} needs truth.magnetic_field_B (the field at the spacecraft in body "
                "axes [T]), got None: fly it with an environment (an orbit and a magnetic-field model)"
            )
        field_B = check_vector(field_B, "truth.magnetic_field_B", 3)
        if field_B.shape != (3,):
            raise ValueError(f"truth.magnetic_field_B must have shape (3,), got shape {field_B.shape}")
        return field_B

    def measure(self, t: float, truth: Any, rng: Any = None) -> NDArray[np.float64]:
        """Measured field (3,) [T] in sensor axes at ``t`` [s].

        Draws three standard normals from ``rng`` per sample (also when
        ``sigma_T`` is 0, so that the stream does not depend on the noise level).

        Parameters
        ----------
        t : float
            Time [s] (the model is stationary; kept for the sensor protocol).
        truth : attitude.simulation.protocols.Truth
            Anything with ``magnetic_field_B`` (3,) [T].
        rng : Generator, int or None
            Random source.

        Returns
        -------
        ndarray (3,)
            The sample [T].

        Raises
        ------
        ValueError
            If ``truth.magnetic_field_B`` is None (a run without an orbit
            environment) or not a finite (3,) vector.
        """
        scalar_time(t, "t")
        field_B = self._field(truth)
        return self._measured(field_B, as_generator(rng).standard_normal(3))

    def measure_batch(self, t: float, field_B: ArrayLike, normals: ArrayLike | NormalStreams) -> NDArray[np.float64]:
        """One sample per run at ``t`` [s]: run ``r`` is exactly :meth:`measure` with field ``field_B[r]``.

        Parameters
        ----------
        t : float
            Time [s] (shared).
        field_B : array_like (N, 3)
            True fields in body axes [T], one per run.
        normals : array_like (N, 3) or NormalStreams
            Standard normals of each run in the order of
            ``gen.standard_normal(3)``, or the runs' streams (3 numbers each).

        Returns
        -------
        ndarray (N, 3)
            The samples [T].

        Raises
        ------
        ValueError
            If ``field_B`` is not a finite (N, 3) array or ``normals`` has
            the wrong shape, number of streams, or non-finite entries.
        """
        scalar_time(t, "t")
        field = check_vector(field_B, "field_B", 3)
        if field.ndim != 2:
            raise ValueError(f"field_B must have shape (N, 3) (one field per run), got shape {field.shape}")
        n = field.shape[0]
        if isinstance(normals, NormalStreams):
            if normals.n_runs != n:
                raise ValueError(f"normals must have {n} streams (one per run), got {normals.n_runs}")
            nrm = normals.draw(None, 3)
        else:
            nrm = as_float_array(normals, "normals")
            if nrm.shape != (n, 3):
                raise ValueError(f"normals must have shape ({n}, 3) (one triple per run), got shape {nrm.shape}")
        return self._measured(field, nrm)

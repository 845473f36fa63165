"""Closed-form steady state of the MEKF (Farrenkopf).

------------
:func:`steady_state_covariance` and :func:`steady_state_attitude_sigma` give
the closed-form steady state of the single-axis filter (gyro with ARW
``sigma_v`` and RRW ``sigma_u``, attitude sensor with noise ``sigma_n``
every ``dt``): the quantity analysed by Farrenkopf (1978) and by Markley and
Reynolds ("Analytic steady-state accuracy of a spacecraft attitude
estimator", J. Guidance, Control, and Dynamics 23, 2000; Markley and
Crassidis 2014, ch. 6). The formula used is derived here from the
discrete algebraic Riccati equation (see :func:`steady_state_covariance`);
a test checks it against :func:`scipy.linalg.solve_discrete_are`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from attitude.validation import positive_scalar

__all__ = ["steady_state_attitude_sigma", "steady_state_covariance"]


def steady_state_covariance(
    *, sigma_v: float, sigma_u: float, sigma_n: float, dt: float
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
    *, sigma_v: float, sigma_u: float, sigma_n: float, dt: float, when: str = "post"
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
    pre, post = steady_state_covariance(sigma_v=sigma_v, sigma_u=sigma_u, sigma_n=sigma_n, dt=dt)
    return float(np.sqrt((post if when == "post" else pre)[0, 0]))

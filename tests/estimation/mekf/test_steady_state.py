"""Closed-form steady state of the MEKF (estimation.mekf.steady_state): Riccati fixed point and limits.

What the tests check against (the quantity of Farrenkopf 1978 and of Markley and Reynolds,
"Analytic steady-state accuracy of a spacecraft attitude estimator", *J. Guidance, Control, and
Dynamics* 23, 2000; Markley and Crassidis 2014, ch. 6):

* the discrete algebraic Riccati equation: the closed form is a fixed point of one measurement
  update and one propagation (hypothesis over twelve decades of the noise figures), and agrees with
  ``scipy.linalg.solve_discrete_are`` as the independent library, including Crassidis and Junkins'
  MEKF example figures (``sigma_v = sqrt(10) 1e-7``, ``sigma_u = sqrt(10) 1e-10``, 17 urad);
* the random-walk limit ``sigma_u -> 0``: the scalar Riccati solution ``a = q/2 + sqrt(q^2/4 + q r)``;
* the continuous limit ``dt -> 0`` at fixed ``r dt``: Farrenkopf's continuous-time solution
  ``p11 = sqrt(R_c) sqrt(sigma_v^2 + 2 sigma_u sqrt(R_c))``, approached at O(sqrt(dt));
* bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.linalg import solve_discrete_are

from attitude.sensors import ARCSEC
from estimation.mekf.filter import process_noise
from estimation.mekf.steady_state import steady_state_attitude_sigma, steady_state_covariance


def riccati_pre(sigma_v, sigma_u, sigma_n, dt):
    phi = np.array([[1.0, -dt], [0.0, 1.0]])
    q = process_noise(sigma_v=sigma_v, sigma_u=sigma_u, dt=dt)[[0, 3]][:, [0, 3]]
    return phi, q, np.array([[sigma_n**2]])


class TestSteadyState:
    @given(
        st.floats(-9.0, -3.0),  # log10 sigma_v [rad/s^0.5]
        st.floats(-12.0, -4.0),  # log10 sigma_u [rad/s^1.5]
        st.floats(-6.0, -2.0),  # log10 sigma_n [rad]
        st.floats(-2.0, 1.0),  # log10 dt [s]
    )
    def test_closed_form_solves_the_discrete_riccati_equation(self, lv, lu, ln, ldt):
        sv, su, sn, dt = 10.0**lv, 10.0**lu, 10.0**ln, 10.0**ldt
        pre, post = steady_state_covariance(sigma_v=sv, sigma_u=su, sigma_n=sn, dt=dt)
        phi, q, r = riccati_pre(sv, su, sn, dt)
        h = np.array([[1.0, 0.0]])
        s = h @ pre @ h.T + r
        post_check = pre - pre @ h.T @ np.linalg.solve(s, h @ pre)
        # The covariance measurement update and the propagation close the cycle: a fixed point.
        np.testing.assert_allclose(post, post_check, rtol=1e-9, atol=0)
        np.testing.assert_allclose(phi @ post @ phi.T + q, pre, rtol=1e-9, atol=0)
        # (The ranges span S_v, S_u from 1e-14 to 1e+6: real and complex roots u_i. Relative
        # residuals are rounding (~1e-13) times the conditioning of the entries that cancel.)

    @pytest.mark.parametrize(
        ("sv", "su", "sn", "dt"),
        [
            (2.036e-5, 3.22e-7, 6 * ARCSEC, 1.0),  # tactical gyro, 6 arcsec tracker at 1 Hz
            (5.8e-7, 1e-10, 6 * ARCSEC, 1.0),  # navigation gyro
            (1e-6, 1e-4, 1e-5, 1.0),  # complex roots u_i (S_u >> S_v^2)
            (np.sqrt(10) * 1e-7, np.sqrt(10) * 1e-10, 17e-6, 1.0),  # Crassidis and Junkins' example figures
        ],
    )
    def test_matches_scipy_solve_discrete_are(self, sv, su, sn, dt):
        phi, q, r = riccati_pre(sv, su, sn, dt)
        reference = solve_discrete_are(phi.T, np.array([[1.0], [0.0]]), q, r)
        pre, _ = steady_state_covariance(sigma_v=sv, sigma_u=su, sigma_n=sn, dt=dt)
        # solve_discrete_are's own accuracy on these scales (entries spanning ~12 decades) is ~1e-9.
        np.testing.assert_allclose(pre, reference, rtol=1e-7)
        assert steady_state_attitude_sigma(sigma_v=sv, sigma_u=su, sigma_n=sn, dt=dt, when="pre") == pytest.approx(
            np.sqrt(reference[0, 0])
        )

    def test_random_walk_limit(self):
        # sigma_u -> 0: the bias becomes known and the attitude is a random walk observed in noise,
        # whose steady prior variance is a = q/2 + sqrt(q^2/4 + q r) (scalar Riccati equation).
        sv, sn, dt = 2e-5, 3e-5, 0.5
        qv, r = sv**2 * dt, sn**2
        a = qv / 2 + np.sqrt(qv**2 / 4 + qv * r)
        sigma_post = steady_state_attitude_sigma(sigma_v=sv, sigma_u=1e-16, sigma_n=sn, dt=dt)
        # The S_u = 4e-23 remainder changes sqrt(l1 l2) by ~sqrt(S_u) = 7e-12.
        assert sigma_post**2 == pytest.approx(a * r / (a + r), rel=1e-9)

    def test_continuous_farrenkopf_limit(self):
        # dt -> 0 with the measurement density r dt fixed: Farrenkopf's continuous-time solution
        # p11 = sqrt(R_c) sqrt(sigma_v^2 + 2 sigma_u sqrt(R_c)) (the continuous Riccati equation).
        sv, su, rc = 2e-5, 3e-7, (6 * ARCSEC) ** 2 * 1.0
        continuous = np.sqrt(np.sqrt(rc) * np.sqrt(sv**2 + 2 * su * np.sqrt(rc)))
        gaps = []
        for dt in (1e-2, 1e-4, 1e-6):
            sigma = steady_state_attitude_sigma(sigma_v=sv, sigma_u=su, sigma_n=np.sqrt(rc / dt), dt=dt)
            gaps.append(abs(sigma / continuous - 1))
        # The discrete solution differs by O(sqrt(dt)) relative; it shrinks ~10x per 100x in dt.
        assert gaps[0] < 0.1
        assert gaps[1] < gaps[0] / 5 and gaps[2] < gaps[1] / 5
        assert gaps[2] < 1e-3

    @pytest.mark.parametrize("bad", [0.0, -1.0, np.nan, np.inf])
    def test_rejects_bad_figures(self, bad):
        for i, name in enumerate(("sigma_v", "sigma_u", "sigma_n", "dt")):
            args = [2e-5, 3e-7, 3e-5, 1.0]
            args[i] = bad
            with pytest.raises(ValueError, match=name):
                steady_state_covariance(**dict(zip(("sigma_v", "sigma_u", "sigma_n", "dt"), args)))
        with pytest.raises(ValueError, match="when"):
            steady_state_attitude_sigma(sigma_v=2e-5, sigma_u=3e-7, sigma_n=3e-5, dt=1.0, when="prior")

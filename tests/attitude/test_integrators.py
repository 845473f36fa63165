"""The step-size rule of the fixed-step methods (docs/rk4_step_rule.md), and the RKMK4 step's two evaluators.

The compiled RKMK4 step (:func:`attitude.integrators.casadi_rkmk4_step`) is checked against the numpy
evaluation of the same definition (:func:`attitude.integrators.rkmk4_step`) on random states: the same
arithmetic, so agreement to rounding.
"""

import numpy as np
import pytest

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.integrators import (
    ATTITUDE_ERROR_BUDGET_RAD,
    attitude_error_text,
    casadi_rkmk4_step,
    gyroscopic_turn_rate,
    normalize_quaternion_components,
    predicted_attitude_error,
    rk4_step,
    rkmk4_step,
    substeps_for_budget,
)


@pytest.mark.parametrize("theta", [0.01, 0.05, 0.1, 0.2])
def test_rk4_constant_rate_error_per_step_is_theta5_over_1920(theta):
    # For a constant rate q_dot = A q with A's eigenvalues +-i theta/(2h): one RK4 step multiplies
    # by the degree-4 Taylor polynomial of exp(i phi), phi = theta/2, whose phase lags by
    # phi^5/120 + O(phi^7) (Hairer, Norsett & Wanner, Solving ODEs I, sec. II.1, Taylor
    # remainder); the rotation angle is twice the quaternion phase: theta^5/1920 per step.
    body = RigidBody([2.0, 3.0, 4.0])
    omega = np.array([0.0, 0.0, 1.0])  # a principal-axis spin: the rate is constant
    x = [np.float64(v) for v in (1.0, 0.0, 0.0, 0.0, *omega)]
    x = rk4_step(lambda _t, xc: body.state_derivative_components(xc, None), 0.0, x, theta)
    x = normalize_quaternion_components(x)
    exact = quat.from_axis_angle([0, 0, 1], theta)
    error = float(quat.error_angle(exact, np.array(x[:4], dtype=float)))
    # The next term of the phase error is O(theta^7); at theta <= 0.2 it is < 1 % of the first.
    assert error == pytest.approx(theta**5 / 1920, rel=0.01)
    assert predicted_attitude_error([1.0], theta, 0.0) == pytest.approx(theta**5 / 1920, rel=1e-12)


def test_turn_rate_is_zero_for_a_principal_spin_and_at_most_the_rate_for_a_tumble():
    body = RigidBody([10.0, 12.0, 8.0])
    assert gyroscopic_turn_rate(body, [0.0, 0.0, 3.0]) == 0.0
    assert gyroscopic_turn_rate(body, [0.0, 0.0, 0.0]) == 0.0
    # |I^-1 (omega x I omega)| <= max|I_j - I_k| / I_i |omega|^2 <= |omega|^2 (triangle inequality of the moments).
    rates = np.random.default_rng(3).normal(size=(100, 3))
    assert np.all(gyroscopic_turn_rate(body, rates) <= np.linalg.norm(rates, axis=-1))


def test_substeps_meet_the_budget_and_leave_a_run_within_it_alone():
    rate = np.full(6000, 5.0)
    subs = substeps_for_budget(rate, 0.1)
    assert np.all(subs == 18)  # (0.0977 rad / 1e-6 rad)^(1/4) = 17.7
    assert predicted_attitude_error(rate, 0.1, substeps=subs) <= ATTITUDE_ERROR_BUDGET_RAD
    slow = np.full(6000, 0.05)
    assert np.all(substeps_for_budget(slow, 0.1, 0.05) == 1)
    assert np.all(substeps_for_budget(rate, 0.1, substeps=40) == 40)  # never lowers what was asked


def test_an_error_above_pi_is_printed_as_a_lost_attitude():
    # The angle between two attitudes is at most pi rad (2 atan2(|v|, |w|) with |w| >= 0): a predicted or bounded
    # error beyond it is printed as a lost attitude, not as a number of radians (issue 12).
    assert attitude_error_text(1.234e-5) == "1.23e-05 rad"
    assert attitude_error_text(np.pi) == f"{np.pi:.3g} rad"  # the largest angle there is: still a number
    assert attitude_error_text(np.nextafter(np.pi, 4.0)) == "more than pi rad (the attitude is lost)"
    assert attitude_error_text(370.0, digits=4) == "more than pi rad (the attitude is lost)"
    assert attitude_error_text(float("inf")) == "more than pi rad (the attitude is lost)"


@pytest.mark.parametrize("inertia", [[100.0, 200.0, 300.0], [[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]])
@pytest.mark.parametrize("with_torque", [False, True])
def test_the_compiled_rkmk4_step_evaluates_the_numpy_step(inertia, with_torque):
    # One definition, two evaluators: casadi's virtual machine and numpy perform the same operations in the same
    # order (measured bit for bit on this machine); a numpy whose sin and cos differ from the C library's by an ulp
    # (SIMD builds) moves a result by ~1e-16, hence 1e-15, a few ulps of the results (|q| = 1, rates below
    # 0.9 rad/s). Rates from rest to 0.85 rad/s over steps of 1e-3 to 0.5 s cover both branches of exp's
    # sin(h)/h (its series below h = 1e-4 rad: two thirds of these steps).
    body = RigidBody(inertia)
    rng = np.random.default_rng(7)
    n = 4000
    q = quat.random(n, rng=rng)
    omega = rng.normal(size=(n, 3)) * np.logspace(-7, -0.5, n)[:, None]
    omega[0] = 0.0
    tau = rng.normal(scale=0.5, size=(n, 3)) if with_torque else np.zeros((n, 3))
    dt = np.logspace(-3, np.log10(0.5), n)
    compiled = casadi_rkmk4_step(body).map(n)(np.concatenate([q, omega], axis=-1).T, tau.T, dt[None]).full().T

    def torque(_t, _q, _w):
        return [tau[:, i] for i in range(3)] if with_torque else None

    q_new, omega_new = rkmk4_step(body, torque, 0.0, [q[:, i] for i in range(4)], [omega[:, i] for i in range(3)], dt)
    np.testing.assert_allclose(compiled[:, :4], np.stack(q_new, axis=-1), rtol=0, atol=1e-15)
    np.testing.assert_allclose(compiled[:, 4:], np.stack(omega_new, axis=-1), rtol=0, atol=1e-15)

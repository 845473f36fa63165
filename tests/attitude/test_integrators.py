"""The step-size rule of the fixed-step methods (docs/rk4_step_rule.md)."""

import numpy as np
import pytest

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.integrators import (
    ATTITUDE_ERROR_BUDGET_RAD,
    attitude_error_text,
    gyroscopic_turn_rate,
    normalize_quaternion_components,
    predicted_attitude_error,
    rk4_step,
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

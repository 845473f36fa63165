"""Robust (unscented) slews: the sigma points, the robust plan against the nominal one, and bad input.

What each test checks against:

* The unscented transform (Julier and Uhlmann; filterpy's ``JulierSigmaPoints``): the weighted sigma
  points reproduce the mean and the covariance they were made from, exactly (to rounding), for several
  ``kappa`` and a singular covariance; for the uniform moments of an :class:`UncertaintySet` with
  ``kappa = 0`` they sit on the faces of the set (``sqrt(3) * p / sqrt(3) = p``: the variance of a
  uniform distribution on ``[-p, p]`` is ``p^2 / 3``).
* The robust plan flies the nominal body to the target (independent adaptive re-simulation, DOP853),
  and over an independent Monte Carlo sample of the same uncertainty (200 inertias, a seed the planner
  never saw) its open-loop terminal-error spread is smaller than the nominal (minimum-energy) plan's.
* The worst-case objective's largest sigma-point error is no larger than the expected objective's
  (each plan is optimal for its own objective; both re-simulated).
* No uncertainty: the robust problem is the minimum-energy slew, solved by :func:`plan_slew` on the
  same grid (same energy and torque to the solver's tolerance).
* Bad input names the argument, the rule and the value (DESIGN.md); a failed solve raises.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.propagate import propagate
from controllers.slew import (
    InfeasibleSlewError,
    RobustSlewComparison,
    RobustSlewPlan,
    SlewPlanningError,
    compare_robust_slew,
    plan_robust_slew,
    plan_slew,
    unscented_sigma_points,
)
from controllers.slew.robust import moment_uncertainty
from controllers.worst_case import UncertaintySet

#: A small satellite with products of inertia (kg m^2), 50 mN m per axis, 90 deg about a skew axis in
#: twice its minimum time (28.1 s): the time bound leaves room to shape the torque.
BODY = RigidBody(np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]))
TORQUE_MAX = 0.05
Q0 = np.array([1.0, 0.0, 0.0, 0.0])
QF = quat.from_axis_angle(np.array([1.0, -1.0, 0.5]) / np.linalg.norm([1.0, -1.0, 0.5]), math.radians(90.0))
DURATION = 56.0
NODES = 20
UNCERTAINTY = UncertaintySet(inertia_percent=10.0)


@pytest.fixture(scope="module")
def robust_plan() -> RobustSlewPlan:
    return plan_robust_slew(
        BODY, Q0, QF, torque_max=TORQUE_MAX, duration=DURATION, inertia_uncertainty=UNCERTAINTY, nodes=NODES
    )


@pytest.mark.parametrize("kappa", [0.0, 1.0, 2.5])
def test_sigma_points_reproduce_mean_and_covariance(kappa):
    """sum w chi = m and sum w (chi - m)(chi - m)^T = P, the defining property of the unscented transform."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal((4, 4))
    covariance = a @ a.T + 0.1 * np.eye(4)
    mean = rng.standard_normal(4)
    points, weights = unscented_sigma_points(mean, covariance, kappa=kappa)
    assert points.shape == (9, 4)
    assert np.sum(weights) == pytest.approx(1.0, abs=1e-15)
    assert np.all(weights >= 0.0)
    deviation = points - mean
    # Rounding of a Cholesky factor and of sums of 9 terms: 1e-12 relative to the covariance's scale.
    np.testing.assert_allclose(weights @ points, mean, rtol=0, atol=1e-12)
    np.testing.assert_allclose((weights[:, None] * deviation).T @ deviation, covariance, rtol=0, atol=1e-12)


def test_sigma_points_of_a_singular_covariance_reproduce_it():
    """A rank-one covariance (a moment known exactly) has no Cholesky factor; its points still reproduce it."""
    u = np.array([1.0, 2.0, 0.0])
    covariance = 0.01 * np.outer(u, u)
    points, weights = unscented_sigma_points(np.zeros(3), covariance)
    np.testing.assert_allclose((weights[:, None] * points).T @ points, covariance, rtol=0, atol=1e-15)
    np.testing.assert_allclose(weights @ points, 0.0, atol=1e-15)


def test_uniform_moments_put_the_sigma_points_on_the_faces_of_the_set():
    """Uniform on [-p, p] has variance p^2 / 3; with n = 3 and kappa = 0 the points sit at +-sqrt(3) sigma = +-p."""
    spread = moment_uncertainty(UncertaintySet(inertia_percent=10.0))
    np.testing.assert_allclose(spread.sigma, 0.1 / math.sqrt(3.0), rtol=1e-15)
    points, weights = unscented_sigma_points(np.zeros(3), np.diag(spread.sigma**2))
    np.testing.assert_allclose(np.sort(np.abs(points).max(axis=1)), [0.0] + [0.1] * 6, rtol=1e-14)
    np.testing.assert_allclose(weights, [0.0] + [1.0 / 6.0] * 6, rtol=1e-15)


def test_robust_plan_reaches_the_target_on_the_nominal_body(robust_plan):
    """The nominal body under the plan's torque (adaptive DOP853, independent of the NLP's RK4) ends on target."""
    traj = propagate(
        BODY, Q0, np.zeros(3), robust_plan.t, robust_plan.torque, method="adaptive", rtol=1e-11, atol=1e-13
    )
    # The planner's own verification tolerance (1e-4 rad), as plan_slew; measured 1e-8 rad.
    assert float(quat.error_angle(QF, traj.q[-1])) < 1e-4
    assert float(np.linalg.norm(traj.omega[-1])) < 1e-4 / robust_plan.info["scaling"]["time_s"]
    # Inside the torque box (the plan clips to it; the NLP bounds it).
    assert np.max(np.abs(robust_plan.torque)) <= TORQUE_MAX * (1 + 1e-9)
    assert robust_plan.sigma_moment_change.shape == (7, 3)
    # The summary says what the plan is for: tracked by feedback it does worse than the nominal plan (docs).
    assert "for open-loop flight" in robust_plan.summary()


def test_robust_plan_has_a_smaller_open_loop_spread_than_the_nominal_plan(robust_plan):
    """Over 200 inertias drawn uniformly within +-10 % (seed 20261128, independent of the sigma points).

    Measured, open loop (median / 95th percentile / max): combined terminal error
    ``sqrt(4 sin^2(angle / 2) + (56 s * rate error)^2)`` robust 3.26 / 6.93 / 10.3 deg against nominal
    (minimum energy over the same 56 s) 7.83 / 12.6 / 16.5 deg; attitude alone robust 3.15 / 6.91 / 10.3
    deg against 5.01 / 7.85 / 9.31 deg (the largest is worse); rate alone robust 0.013 / 0.024 / 0.036
    deg/s against 0.110 / 0.183 / 0.244 deg/s. Tracked (PD at 0.3 rad/s, 0.7, 0.5 s) the robust plan does
    worse: attitude 0.27 / 0.66 / 0.70 deg against 0.12 / 0.21 / 0.23 deg (its torque has 22 times the
    energy; docs/slew_planning.md).
    """
    comparison = compare_robust_slew(
        robust_plan, inertia_uncertainty=UNCERTAINTY, wn=0.3, zeta=0.7, period=0.5, samples=200, rng=20261128
    )
    spread = comparison.spread()
    robust, nominal = spread["robust_open_loop"], spread["nominal_open_loop"]
    # The claim is the ordering itself (measured margins: x2.4 median and x1.8 at 95 % combined, x1.14 at 95 %
    # in attitude, x7.7 at 95 % in rate).
    assert robust["terminal_median_deg"] < nominal["terminal_median_deg"]
    assert robust["terminal_p95_deg"] < nominal["terminal_p95_deg"]
    assert robust["attitude_p95_deg"] < nominal["attitude_p95_deg"]
    assert robust["rate_p95_deg_per_s"] < nominal["rate_p95_deg_per_s"]
    # The figure shows the four flights.
    fig = comparison.plot()
    assert len(fig.axes) == 6


def test_plan_and_comparison_save_and_load(robust_plan, tmp_path):
    """ResultIO round trip: the arrays bit for bit and the info dict (DESIGN.md, results)."""
    loaded = RobustSlewPlan.load(robust_plan.save(tmp_path / "plan"))
    np.testing.assert_array_equal(loaded.torque, robust_plan.torque)
    np.testing.assert_array_equal(loaded.sigma_inertia, robust_plan.sigma_inertia)
    assert loaded.info == robust_plan.info
    comparison = compare_robust_slew(
        robust_plan, inertia_uncertainty=0.03, wn=0.3, zeta=0.7, period=0.5, samples=8, rng=5
    )
    again = RobustSlewComparison.load(comparison.save(tmp_path / "mc"))
    for case in comparison.attitude_error:
        np.testing.assert_array_equal(again.attitude_error[case], comparison.attitude_error[case])
    assert again.info["distribution"] == "normal"
    assert len(robust_plan.plot().axes) == 3


def test_worst_objective_lowers_the_largest_sigma_point_error(robust_plan):
    """Each objective is optimal for itself: the epigraph plan's largest sigma error <= the mean plan's."""
    worst = plan_robust_slew(
        BODY,
        Q0,
        QF,
        torque_max=TORQUE_MAX,
        duration=DURATION,
        inertia_uncertainty=UNCERTAINTY,
        nodes=NODES,
        objective="worst",
    )
    e_worst = 4 * np.sin(worst.sigma_attitude_error / 2) ** 2 + (DURATION * worst.sigma_rate_error) ** 2
    e_mean = 4 * np.sin(robust_plan.sigma_attitude_error / 2) ** 2 + (DURATION * robust_plan.sigma_rate_error) ** 2
    # Measured 5.3 deg against 5.6 deg (rad^2: 8.7e-3 against 9.6e-3); both below the nominal plan's 11.0 deg.
    assert e_worst.max() < e_mean.max()
    assert worst.objective_value < worst.nominal_objective_value


def test_no_uncertainty_gives_the_minimum_energy_plan():
    """With the moments known, the robust problem is plan_slew's minimum-energy slew on the same grid."""
    robust = plan_robust_slew(
        BODY, Q0, QF, torque_max=TORQUE_MAX, duration=DURATION, inertia_uncertainty=UncertaintySet(), nodes=NODES
    )
    nominal = plan_slew(BODY, Q0, QF, torque_max=TORQUE_MAX, objective="energy", duration=DURATION, nodes=NODES)
    # Two IPOPT solves of the same NLP (tol 1e-9): measured 7e-14 relative in energy, 2e-11 of the torque limit.
    assert robust.energy == pytest.approx(nominal.objective_value, rel=1e-8)
    np.testing.assert_allclose(robust.torque, nominal.torque, rtol=0, atol=1e-7 * TORQUE_MAX)
    np.testing.assert_allclose(robust.q, nominal.q, rtol=0, atol=1e-7)


def test_bad_input_is_named():
    """Errors name the argument, the rule and the value."""
    kwargs = {"torque_max": TORQUE_MAX, "duration": DURATION, "nodes": NODES}
    with pytest.raises(ValueError, match=r"inertia_uncertainty .* must be >= 0"):
        plan_robust_slew(BODY, Q0, QF, inertia_uncertainty=-0.05, **kwargs)
    with pytest.raises(ValueError, match="inertia_percent must be non-negative"):
        UncertaintySet(inertia_percent=-5.0)
    with pytest.raises(ValueError, match=r"inertia_uncertainty: .*axis_rotation_deg"):
        plan_robust_slew(
            BODY, Q0, QF, inertia_uncertainty=UncertaintySet(inertia_percent=5.0, axis_rotation_deg=2.0), **kwargs
        )
    with pytest.raises(ValueError, match="objective must be one of"):
        plan_robust_slew(BODY, Q0, QF, inertia_uncertainty=UNCERTAINTY, objective="mean", **kwargs)
    with pytest.raises(ValueError, match="physical body"):
        # +-10 % of diag(1, 2, 2.9) kg m^2 breaks I3 <= I1 + I2 at the sigma point (0, -10 %, 0): 2.9 > 1 + 1.8.
        plan_robust_slew(
            RigidBody([1.0, 2.0, 2.9]), Q0, QF, inertia_uncertainty=UNCERTAINTY, torque_max=1.0, duration=10.0
        )
    with pytest.raises(InfeasibleSlewError, match=r"duration must be at least the nominal minimum time 28\.\d+ s"):
        plan_robust_slew(BODY, Q0, QF, inertia_uncertainty=UNCERTAINTY, torque_max=TORQUE_MAX, duration=20.0)


def test_a_failed_solve_raises_and_returns_no_plan():
    """Two IPOPT iterations cannot converge the robust problem: SlewPlanningError with IPOPT's status."""
    with pytest.raises(SlewPlanningError, match="did not converge") as info:
        plan_robust_slew(
            BODY,
            Q0,
            QF,
            torque_max=TORQUE_MAX,
            duration=DURATION,
            inertia_uncertainty=UNCERTAINTY,
            nodes=NODES,
            max_iter=2,
        )
    assert info.value.status == "Maximum_Iterations_Exceeded"

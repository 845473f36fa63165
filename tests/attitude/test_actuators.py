"""Reaction wheels: allocation, saturation, and momentum exchange with the body.

Model: Schaub and Junkins, *Analytical Mechanics of Space Systems*, ch. 4; Wie, *Space Vehicle
Dynamics and Control*, ch. 7 (as in :mod:`attitude.actuators`). What each group checks against:

* Geometry: unit spin axes, and the isotropic torque envelope of the pyramid whose axes are
  35.26 deg (``arctan(1 / sqrt(2))``) above the base plane (equal capacity about each body axis, by
  symmetry); bad wheel sets rejected with errors that name the argument, the rule and the value
  (DESIGN.md).
* Allocation: the minimum-norm (Moore-Penrose pseudo-inverse) solution, checked by reproducing the
  command and having no component along the null space of the distribution matrix (from
  ``numpy.linalg.svd``); saturation scaling that keeps the torque direction; wheels at their speed
  limit bypassed or cut, with the expected commands computed by hand for orthogonal and pyramid
  sets; null-space momentum management producing no body torque; numpy and casadi evaluations of
  the same allocation (rounding only).
* Momentum exchange: conservation of the total angular momentum ``H_N = C_NB (I_s omega + A h)``
  under internal (motor and friction) torques, integrated independently with scipy's
  ``solve_ivp`` (DOP853, rtol 1e-12); the hub inertia is the total minus the wheels' spin-axis
  inertia ``sum J_i a_i a_i^T``.
"""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels

SPACECRAFT = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])


def pyramid(**kw):
    # A small-satellite wheel: J = 0.005 kg m^2, 0.02 N m, 0.5 N m s (~1000 rad/s).
    return ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.02, momentum_max=0.5, **kw)


class TestGeometryAndValidation:
    def test_pyramid_axes_are_unit_and_give_equal_capacity_per_axis(self):
        wheels = pyramid()
        np.testing.assert_allclose(np.linalg.norm(wheels.axes_B, axis=1), 1.0, rtol=1e-15)
        envelope = wheels.torque_envelope()
        # The 35.26 deg pyramid is isotropic along the body axes (to rounding).
        np.testing.assert_allclose(envelope, envelope[0], rtol=1e-12)

    @pytest.mark.parametrize(
        ("args", "match"),
        [
            ({"axes_B": [[1, 0, 0], [0, 1, 0], [1, 1, 0]]}, "rank 3"),
            ({"axes_B": [[1, 0, 0], [0, 1, 0]]}, "rank 3"),
            ({"axes_B": [[1, 0, 0], [0, 0, 0], [0, 0, 1]]}, "axes_B must hold non-zero axes"),
            ({"axes_B": [1, 0, 0]}, r"axes_B must have shape"),
            ({"torque_max": -0.1}, "torque_max must be strictly positive"),
            ({"momentum_max": 0.0}, "momentum_max must be strictly positive"),
            ({"spin_inertia": [0.01, 0.01]}, "spin_inertia must be a scalar or one value per wheel"),
            ({"viscous_friction": -1e-6}, "viscous_friction must be non-negative"),
            ({"torque_max": np.nan}, "torque_max must be finite"),
        ],
    )
    def test_bad_wheel_sets_are_rejected(self, args, match):
        kw = {"axes_B": np.eye(3), "spin_inertia": 0.01, "torque_max": 0.1, "momentum_max": 1.0} | args
        with pytest.raises(ValueError, match=match):
            ReactionWheels(**kw)


class TestAllocation:
    def test_unsaturated_allocation_reproduces_the_command_with_minimum_norm(self):
        wheels = pyramid()
        tau = np.array([0.005, -0.003, 0.004])
        u = wheels.allocate(tau, np.zeros(4), np.zeros(3))
        np.testing.assert_allclose(wheels.body_torque(u), tau, atol=1e-15)
        # Minimum norm: no component in the null space of A.
        null = np.linalg.svd(wheels.distribution)[2][-1]
        assert abs(u @ null) < 1e-15

    def test_saturation_keeps_the_torque_direction(self):
        wheels = pyramid()
        tau = np.array([0.3, -0.1, 0.2])  # far beyond the 0.02 N m wheels
        u = wheels.allocate(tau, np.zeros(4), np.zeros(3))
        assert np.max(np.abs(u) / wheels.torque_max) == pytest.approx(1.0, abs=1e-12)
        applied = wheels.body_torque(u)
        cosine = applied @ tau / np.linalg.norm(applied) / np.linalg.norm(tau)
        assert cosine == pytest.approx(1.0, abs=1e-12)

    def test_wheel_at_its_speed_limit_refuses_to_spin_faster(self):
        wheels = ReactionWheels.orthogonal(spin_inertia=0.01, torque_max=0.1, momentum_max=1.0)
        h = np.array([1.0, 0.0, -1.0])  # wheels 1 and 3 at +/- the limit, body at rest
        u = wheels.allocate([-0.05, -0.05, 0.05], h, np.zeros(3))
        # Command -tau_x would need +u_1 (faster), +tau_z would need -u_3 (faster).
        assert u[0] == 0.0
        assert u[2] == 0.0
        assert u[1] == pytest.approx(0.05)
        u_back = wheels.allocate([0.05, 0.0, -0.05], h, np.zeros(3))
        np.testing.assert_allclose(u_back, [-0.05, 0.0, 0.05])

    def test_null_space_management_moves_momentum_without_body_torque(self):
        wheels = pyramid(null_space_gain=0.1, bias_momentum=[0.1, -0.1, 0.1, -0.1])
        h = np.array([0.2, 0.05, -0.1, 0.0])
        u = wheels.allocate(np.zeros(3), h, np.zeros(3))
        assert np.linalg.norm(u) > 1e-4  # it acts
        np.testing.assert_allclose(wheels.body_torque(u), 0.0, atol=1e-16)

    def test_numpy_and_casadi_allocations_agree(self):
        wheels = pyramid(null_space_gain=0.05)
        rng = np.random.default_rng(2)
        tau_s, h_s, w_s = ca.SX.sym("tau", 3), ca.SX.sym("h", 4), ca.SX.sym("w", 3)
        u_s = wheels.allocate_components(
            [tau_s[k] for k in range(3)], [h_s[i] for i in range(4)], [w_s[k] for k in range(3)]
        )
        f = ca.Function("alloc", [tau_s, h_s, w_s], [ca.vertcat(*u_s)])
        for _ in range(20):
            tau = rng.normal(scale=0.03, size=3)
            h = rng.normal(scale=0.6, size=4)
            w = rng.normal(scale=0.05, size=3)
            np.testing.assert_allclose(np.array(f(tau, h, w)).ravel(), wheels.allocate(tau, h, w), atol=1e-15)


class TestMomentumExchange:
    def test_total_angular_momentum_is_conserved_while_wheels_spin_the_body(self):
        wheels = pyramid(viscous_friction=1e-5, coulomb_friction=1e-4)
        hub = wheels.hub_body(SPACECRAFT)
        n = wheels.n_wheels

        def motor(t):
            return 0.015 * np.array([np.sin(0.3 * t), np.cos(0.2 * t), np.sin(0.5 * t + 1), -np.cos(0.1 * t)])

        def rhs(t, x):
            comps = list(x)
            return np.array(wheels.state_derivative_components(hub, comps, list(motor(t))), dtype=float)

        x0 = np.concatenate([quat.from_axis_angle([1, 1, 0], 0.3), [0.01, -0.02, 0.015], [0.1, -0.05, 0.2, 0.0]])
        sol = solve_ivp(rhs, (0.0, 300.0), x0, method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
        t = np.linspace(0.0, 300.0, 301)
        x = sol.sol(t).T
        q = x[:, :4] / np.linalg.norm(x[:, :4], axis=1, keepdims=True)
        h_b = x[:, 4:7] @ hub.inertia.T + x[:, 7:] @ wheels.distribution.T
        h_n = quat.rotate(q, h_b)
        drift = np.max(np.linalg.norm(h_n - h_n[0], axis=1)) / np.linalg.norm(h_n[0])
        # DOP853 at rtol 1e-12 over 300 s: the invariant holds to ~1e-12.
        assert drift < 1e-10
        # The wheels really moved the body: its rate changed by far more than that.
        assert np.ptp(x[:, 4:7], axis=0).max() > 1e-3
        assert n == 4

    def test_hub_body_removes_the_spin_axis_inertia(self):
        wheels = ReactionWheels.orthogonal(spin_inertia=0.01, torque_max=0.1, momentum_max=1.0)
        hub = wheels.hub_body(SPACECRAFT)
        np.testing.assert_allclose(SPACECRAFT.inertia - hub.inertia, 0.01 * np.eye(3), atol=1e-15)


def test_a_wheel_at_its_speed_limit_is_bypassed_and_the_torque_keeps_its_direction():
    wheels = pyramid()  # 0.02 N m, 0.5 N m s
    tau = np.array([0.005, -0.003, 0.004])
    free = wheels.allocate(tau, np.zeros(4), np.zeros(3))
    blocked = int(np.argmax(free))  # the wheel this command would spin up the most
    h = np.zeros(4)
    h[blocked] = 0.5  # at its momentum limit, body at rest
    u = wheels.allocate(tau, h, np.zeros(3))
    assert u[blocked] == 0.0
    # The other three still span 3-D: the full command is delivered.
    np.testing.assert_allclose(wheels.body_torque(u), tau, atol=1e-15)
    # At the opposite limit the wheel may help: nothing is re-allocated.
    h[blocked] = -0.5
    np.testing.assert_allclose(wheels.allocate(tau, h, np.zeros(3)), free, atol=1e-18)


def test_three_orthogonal_wheels_cannot_bypass_and_cut_instead():
    wheels = ReactionWheels.orthogonal(spin_inertia=0.01, torque_max=0.1, momentum_max=1.0)
    u = wheels.allocate([-0.05, 0.02, 0.0], [1.0, 0.0, 0.0], np.zeros(3))
    np.testing.assert_allclose(u, [0.0, -0.02, 0.0], atol=1e-18)

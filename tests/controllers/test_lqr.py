"""LQR design and flight: Bryson weights, Riccati solutions, bad input, nonlinear closed loops.

What each group checks against:

* Weights: Bryson's rule (Bryson and Ho, *Applied Optimal Control*): each weight is the inverse
  square of the largest acceptable value, with the attitude bound ``sin(angle / 2)`` on ``|q_ev|``.
* Continuous design: the closed-form LQR gains of a double integrator per axis for a diagonal
  body (derived in the test); the continuous algebraic Riccati equation
  ``A'S + SA - S B R^-1 B'S + Q = 0`` by its residual, ``K = R^-1 B'S``, ``S`` symmetric positive
  definite and stable poles; the closed loop ``A - BK`` as python-control's ``StateSpace``.
* Discrete design: the zero-order-hold plant against Van Loan's block exponential
  ``expm([[A, B], [0, 0]] T)`` (C. F. Van Loan, "Computing integrals involving the matrix
  exponential", IEEE TAC 23(3), 1978; ``scipy.linalg.expm``, independent of ``control.c2d``); the
  discrete Riccati equation by its residual and its gain; the discrete gain tending to the
  continuous one to first order in the period.
* Bad input: errors name the argument, the rule and the value (DESIGN.md); stabilisability of
  ``(A, B)`` and detectability of ``(Q^1/2, A)`` (the Popov-Belevitch-Hautus test of
  :func:`controllers.lqr.design_lqr`) on hand-built cases: the uncontrollable norm mode of the
  7-state quaternion model, an unstable mode with no input, unweighted attitude modes.
* Controller: ``tau = -K x`` on the shortest-way error (``q`` and ``-q`` the same attitude, 359 deg
  is -1 deg), a reference turning at ``omega_ref``; agreement between the compiled and Python
  engine paths (rounding only).
* Nonlinear flight: the nonlinear closed loop against its own linear closed loop (python-control),
  with a mismatch that is second order in the amplitude; with reaction wheels, conservation of the
  total angular momentum under internal torques and convergence at the rate of the slowest
  closed-loop pole.
"""

import control
import numpy as np
import pytest
import scipy.linalg

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.linearize import linearize, principal_spin
from attitude.simulation.engine import simulate
from attitude.simulation.protocols import Estimate
from controllers.lqr import LQRController, LQRDesign, bryson_weights, design_lqr

BODY = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
TARGET = quat.from_axis_angle([1.0, 0.5, 0.0], np.radians(30.0))
AXIS = np.array([0.3, -0.8, 0.5]) / np.linalg.norm([0.3, -0.8, 0.5])
Q_B, R_B = bryson_weights(angle_max=np.radians(5.0), rate_max=np.radians(1.0), torque_max=0.05)


def relative_peak_mismatch(actual, expected):
    return np.max(np.abs(actual - expected)) / np.max(np.abs(expected))


class TestBryson:
    def test_weights_are_inverse_squared_bounds(self):
        angle, rate, torque = np.radians([5.0, 4.0, 6.0]), np.radians([1.0, 2.0, 0.5]), np.array([0.05, 0.1, 0.02])
        Q, R = bryson_weights(angle_max=angle, rate_max=rate, torque_max=torque)
        # The state is |q_ev| = sin(angle/2): the bound on it is sin(angle_max/2), about half the angle.
        np.testing.assert_allclose(np.diag(Q), np.r_[1.0 / np.sin(angle / 2) ** 2, 1.0 / rate**2], rtol=1e-15)
        # ... which is ~angle/2: (x / sin x)^2 = 1 + x^2/3 + x^4/15 + ..., x = angle/2 (x^4/15 < 1e-6 here).
        np.testing.assert_allclose(np.diag(Q)[:3] * (angle / 2) ** 2, 1.0 + angle**2 / 12, rtol=1e-6)
        np.testing.assert_allclose(R, np.diag(1.0 / torque**2), rtol=1e-15)
        assert np.count_nonzero(Q - np.diag(np.diag(Q))) == 0

    def test_scalars_apply_to_every_axis(self):
        Q, R = bryson_weights(angle_max=0.1, rate_max=0.01, torque_max=0.5)
        np.testing.assert_allclose(np.diag(Q), [1 / np.sin(0.05) ** 2] * 3 + [1e4] * 3, rtol=1e-15)
        np.testing.assert_allclose(R, 4.0 * np.eye(3), rtol=1e-15)

    @pytest.mark.parametrize(
        ("args", "name"),
        [
            ((0.0, 0.1, 0.1), "angle_max"),
            ((4.0, 0.1, 0.1), "angle_max"),
            ((0.1, -0.1, 0.1), "rate_max"),
            ((0.1, 0.1, np.nan), "torque_max"),
            ((0.1, 0.1, [0.1, 0.2]), "torque_max"),
        ],
    )
    def test_bad_bounds_name_the_argument(self, args, name):
        with pytest.raises(ValueError, match=name):
            bryson_weights(**dict(zip(("angle_max", "rate_max", "torque_max"), args)))


class TestContinuousDesign:
    def test_diagonal_body_gives_the_closed_form_double_integrator_gains(self):
        moments = np.array([10.0, 12.0, 8.0])
        design = design_lqr(linearize(RigidBody(moments)), Q=Q_B, R=R_B)
        # Per axis q' = c w, w' = g tau (c = 1/2, g = 1/I). With z = q, v = c g tau it is z'' = v with cost
        # a z^2 + (b/c^2) z'^2 + r/(c g)^2 v^2, whose LQR gain is [sqrt(q1/rho), sqrt(q2/rho + 2 sqrt(q1/rho))].
        c, g = 0.5, 1.0 / moments
        a, b, r = np.diag(Q_B)[:3], np.diag(Q_B)[3:], np.diag(R_B)
        q1, q2, rho = a, b / c**2, r / (c * g) ** 2
        k1, k2 = np.sqrt(q1 / rho), np.sqrt(q2 / rho + 2.0 * np.sqrt(q1 / rho))
        expected = np.hstack([np.diag(k1 / (c * g)), np.diag(k2 / g)])
        # Riccati solution by Schur vectors: ~1e-13 relative for this well-conditioned problem.
        np.testing.assert_allclose(design.K, expected, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected)))

    def test_riccati_equation_gain_and_poles(self):
        sys = linearize(BODY)
        design = design_lqr(sys, Q=Q_B, R=R_B)
        A, B = sys.A, sys.B
        S, K = design.S, design.K
        residual = A.T @ S + S @ A - S @ B @ np.linalg.solve(R_B, B.T @ S) + Q_B
        # Backward-stable Schur solver: residual ~ machine eps * |Q| * condition ~ 1e-12 relative.
        assert np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(Q_B))
        np.testing.assert_allclose(K, np.linalg.solve(R_B, B.T @ S), rtol=1e-12, atol=1e-12 * np.max(np.abs(K)))
        np.testing.assert_allclose(S, S.T, atol=1e-12 * np.max(np.abs(S)))
        assert np.min(np.linalg.eigvalsh(S)) > 0
        assert np.max(design.poles.real) < 0
        assert design.period is None and not design.discrete
        assert design.plant is sys

    def test_closed_loop_is_a_named_statespace(self):
        sys = linearize(BODY)
        design = design_lqr(sys, Q=Q_B, R=R_B)
        cl = design.closed_loop
        assert isinstance(cl, control.StateSpace) and cl.isctime()
        np.testing.assert_allclose(cl.A, sys.A - sys.B @ design.K, atol=1e-15)
        assert cl.state_labels == sys.state_labels
        assert cl.input_labels == ["tau1_dist", "tau2_dist", "tau3_dist"]
        assert cl.output_labels == [*sys.output_labels, "tau1_cmd", "tau2_cmd", "tau3_cmd"]
        np.testing.assert_allclose(cl.C[6:], -design.K, atol=0)
        np.testing.assert_allclose(np.sort_complex(cl.poles()), np.sort_complex(design.poles), atol=1e-12)
        np.testing.assert_allclose(design.s_poles, design.poles, atol=0)
        assert design.slowest_decay_rate == pytest.approx(-np.max(design.poles.real), rel=1e-15)


class TestDiscreteDesign:
    def test_plant_is_the_zero_order_hold_model(self):
        sys = linearize(BODY)
        design = design_lqr(sys, Q=Q_B, R=R_B, period=0.1)
        # Van Loan: expm([[A, B], [0, 0]] T) = [[Ad, Bd], [0, I]], independent of control.c2d.
        aug = np.zeros((9, 9))
        aug[:6, :6], aug[:6, 6:] = sys.A, sys.B
        phi = scipy.linalg.expm(aug * 0.1)
        np.testing.assert_allclose(design.plant.A, phi[:6, :6], rtol=0, atol=1e-14)
        np.testing.assert_allclose(design.plant.B, phi[:6, 6:], rtol=0, atol=1e-16)
        assert design.plant.dt == 0.1

    def test_riccati_equation_and_poles(self):
        design = design_lqr(linearize(BODY), Q=Q_B, R=R_B, period=0.1)
        A, B, S, K = design.plant.A, design.plant.B, design.S, design.K
        gain = np.linalg.solve(R_B + B.T @ S @ B, B.T @ S @ A)
        residual = A.T @ S @ A - S - A.T @ S @ B @ gain + Q_B
        assert np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(S))
        np.testing.assert_allclose(K, gain, rtol=1e-10, atol=1e-10 * np.max(np.abs(K)))
        assert np.max(np.abs(design.poles)) < 1.0
        assert design.closed_loop.dt == 0.1 and design.discrete
        np.testing.assert_allclose(design.s_poles, np.log(design.poles) / 0.1, rtol=1e-15)

    def test_discrete_gain_tends_to_the_continuous_one(self):
        sys = linearize(BODY)
        k_c = design_lqr(sys, Q=Q_B, R=R_B).K

        def gap(period):
            return np.linalg.norm(design_lqr(sys, Q=Q_B, R=R_B, period=period).K - k_c) / np.linalg.norm(k_c)

        # First order in the period (per-sample sums are the integral's rectangle rule): ~0.17 T here.
        assert gap(1e-3) < 1e-3
        assert gap(1e-3) / gap(5e-4) == pytest.approx(2.0, rel=0.02)


class TestBadInput:
    SYS = linearize(BODY)

    @pytest.mark.parametrize(
        ("Q", "R", "message"),
        [
            (Q_B + np.triu(np.ones((6, 6)), 1), R_B, "Q must be symmetric"),
            (np.diag([1.0, 1.0, 1.0, 1.0, 1.0, -1e-3]), R_B, "Q must be positive semi-definite"),
            (np.eye(5), R_B, r"Q must be a \(6, 6\) matrix"),
            (Q_B, np.eye(3) + np.triu(np.ones((3, 3)), 1), "R must be symmetric"),
            (Q_B, np.diag([1.0, 1.0, 0.0]), "R must be positive definite"),
            (Q_B, np.diag([1.0, 1.0, -1.0]), "R must be positive definite"),
            (Q_B, np.diag([1.0, 1.0, 1e-13]), "R must be positive definite"),
            (Q_B, np.eye(2), r"R must be a \(3, 3\) matrix"),
            (Q_B, [[1.0, np.inf, 0.0]] * 3, "R must be finite"),
        ],
    )
    def test_bad_weights_name_the_argument(self, Q, R, message):
        with pytest.raises(ValueError, match=message):
            design_lqr(self.SYS, Q=Q, R=R)

    def test_diagonals_are_accepted(self):
        a = design_lqr(self.SYS, Q=np.diag(Q_B), R=np.diag(R_B))
        b = design_lqr(self.SYS, Q=Q_B, R=R_B)
        np.testing.assert_array_equal(a.K, b.K)

    def test_unstabilisable_pair_names_sys(self):
        # The 7-state quaternion model: the norm direction is an uncontrollable mode at eigenvalue 0.
        a7, b7 = (np.array(m) for m in BODY.casadi_jacobian()(np.r_[TARGET, 0.0, 0.0, 0.0], np.zeros(3)))
        sys7 = control.ss(a7, b7, np.eye(7), np.zeros((7, 3)))
        with pytest.raises(ValueError, match=r"sys must be stabilisable: \(A, B\)"):
            design_lqr(sys7, Q=np.eye(7), R=np.eye(3))
        with pytest.raises(ValueError, match=r"sys must be stabilisable: \(A, B\) \(zero-order hold"):
            design_lqr(sys7, Q=np.eye(7), R=np.eye(3), period=0.1)
        # An unstable mode with no input path.
        unstable = control.ss([[0.5, 0.0], [0.0, -1.0]], [[0.0], [1.0]], np.eye(2), np.zeros((2, 1)))
        with pytest.raises(ValueError, match="sys must be stabilisable"):
            design_lqr(unstable, Q=np.eye(2), R=1.0)
        # A stable uncontrollable mode is fine (stabilisable).
        stable = control.ss([[-0.5, 0.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), np.zeros((2, 1)))
        assert np.max(design_lqr(stable, Q=np.eye(2), R=1.0).poles.real) < 0

    def test_undetectable_weight_names_Q(self):
        # Weighting rates only leaves the attitude (eigenvalue 0) free of cost.
        with pytest.raises(ValueError, match=r"Q must make \(Q\^1/2, A\) detectable"):
            design_lqr(self.SYS, Q=np.diag([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]), R=R_B)
        # Spinning reference, discrete design: the attitude modes (z = 1, exp(+-i 0.3 T)) are still unweighted.
        spin = linearize(BODY, omega_ref=principal_spin(BODY, 2, 0.3))
        with pytest.raises(ValueError, match=r"\(Q\^1/2, A\) \(zero-order hold at period = 0.1 s\) detectable"):
            design_lqr(spin, Q=np.diag([0.0, 0.0, 0.0, 1.0, 1.0, 1.0]), R=R_B, period=0.1)
        # Weighting the attitude alone is enough: the rates drive it, so every mode shows in the cost.
        assert design_lqr(spin, Q=np.diag([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]), R=R_B, period=0.1).discrete

    def test_bad_sys_and_period(self):
        with pytest.raises(ValueError, match=r"sys must be a control\.StateSpace"):
            design_lqr(control.tf([1.0], [1.0, 0.0]), Q=np.eye(1), R=1.0)
        # A discrete plant is designed at its own dt (design_lqi's augmented plant): a period that contradicts
        # it is refused, and the gain is the one design_lqr gets from discretising the continuous plant itself.
        with pytest.raises(ValueError, match="designed at its own dt"):
            design_lqr(control.c2d(self.SYS, 0.1), Q=Q_B, R=R_B, period=0.2)
        own = design_lqr(control.c2d(self.SYS, 0.1), Q=Q_B, R=R_B)
        np.testing.assert_array_equal(own.K, design_lqr(self.SYS, Q=Q_B, R=R_B, period=0.1).K)
        assert own.period == 0.1
        with pytest.raises(ValueError, match="period must be strictly positive"):
            design_lqr(self.SYS, Q=Q_B, R=R_B, period=0.0)


class TestController:
    DESIGN = design_lqr(linearize(BODY), Q=Q_B, R=R_B, period=0.1)

    def test_torque_is_minus_k_times_the_linear_state(self):
        rng = np.random.default_rng(11)
        w_ref = principal_spin(BODY, 3, 0.2)
        ctrl = LQRController(self.DESIGN, q_ref=TARGET, omega_ref=w_ref)
        for t in (0.0, 3.7):
            q, w = quat.random(rng=rng), rng.normal(scale=0.05, size=3)
            q_r = quat.multiply(TARGET, quat.from_axis_angle(w_ref, np.linalg.norm(w_ref) * t))
            x = np.r_[quat.error_quaternion(q_r, q)[1:], w - w_ref]
            tau = ctrl.torque(t, Estimate(t, q, w))
            np.testing.assert_allclose(tau, -self.DESIGN.K @ x, rtol=1e-12, atol=1e-15)
            # Shortest way: q and -q are the same attitude and get the same torque.
            np.testing.assert_allclose(ctrl.torque(t, Estimate(t, -q, w)), tau, rtol=1e-12, atol=1e-15)

    def test_359_degrees_is_minus_one_degree(self):
        ctrl = LQRController(self.DESIGN, q_ref=TARGET)
        far = quat.multiply(TARGET, quat.from_axis_angle(AXIS, np.radians(359.0)))
        near = quat.multiply(TARGET, quat.from_axis_angle(AXIS, np.radians(-1.0)))
        np.testing.assert_allclose(
            ctrl.torque(0.0, Estimate(0.0, far, np.zeros(3))),
            ctrl.torque(0.0, Estimate(0.0, near, np.zeros(3))),
            rtol=1e-9,
        )

    def test_reference_turns_at_omega_ref(self):
        w_ref = principal_spin(BODY, 1, 0.2)
        ctrl = LQRController(self.DESIGN, q_ref=TARGET, omega_ref=w_ref)
        t = np.array([0.0, 1.0, 2.5])
        q_r, w_r = ctrl.reference_samples(t)
        np.testing.assert_allclose(quat.error_angle(TARGET, q_r), 0.2 * t, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(w_r, np.tile(w_ref, (3, 1)), atol=0)
        np.testing.assert_allclose(ctrl.compiled_inputs(t), np.c_[q_r, w_r].T, atol=0)
        np.testing.assert_allclose(ctrl.reference(2.5)[0], q_r[2], atol=0)

    def test_compiled_and_python_paths_agree(self):
        ctrl = LQRController(self.DESIGN, q_ref=TARGET)
        wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8)
        w0 = np.array([0.01, -0.02, 0.005])
        fast = simulate(BODY, quat.identity(), w0, 30.0, controller=ctrl, wheels=wheels)
        slow = simulate(BODY, quat.identity(), w0, 30.0, controller=ctrl, wheels=wheels, engine="python")
        assert (fast.info["engine"], slow.info["engine"]) == ("compiled", "python")
        # Same component law evaluated by casadi in one map vs per tick: rounding only.
        np.testing.assert_allclose(fast.q, slow.q, atol=1e-12)
        np.testing.assert_allclose(fast.torque_command, slow.torque_command, atol=1e-12)

    def test_bad_construction(self):
        with pytest.raises(ValueError, match="design must be an LQRDesign"):
            LQRController(np.zeros((3, 6)), period=0.1)
        small = design_lqr(control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]]), Q=1.0, R=1.0)
        with pytest.raises(ValueError, match=r"design.K must have shape \(3, 6\)"):
            LQRController(small, period=0.1)
        continuous = design_lqr(linearize(BODY), Q=Q_B, R=R_B)
        with pytest.raises(ValueError, match="period"):
            LQRController(continuous)
        with pytest.raises(ValueError, match="must equal the sample time"):
            LQRController(self.DESIGN, period=0.2)
        with pytest.raises(ValueError, match="q_ref must be a unit quaternion"):
            LQRController(self.DESIGN, q_ref=[1.0, 1.0, 0.0, 0.0])
        with pytest.raises(ValueError, match="omega_ref"):
            LQRController(self.DESIGN, omega_ref=[0.1, 0.2])
        with pytest.warns(UserWarning, match="sample rate"):
            LQRController(continuous, period=5.0)
        assert isinstance(self.DESIGN, LQRDesign)


class TestNonlinearClosedLoop:
    @staticmethod
    def run(design, angle_deg, omega_ref, period=None):
        ctrl = LQRController(design, q_ref=TARGET, period=period, omega_ref=omega_ref)
        q0 = quat.multiply(TARGET, quat.from_axis_angle(AXIS, np.radians(angle_deg)))
        result = simulate(BODY, q0, omega_ref, 60.0, controller=ctrl)
        assert result.info["engine"] == "compiled"
        x0 = np.r_[quat.error_quaternion(TARGET, q0)[1:], np.zeros(3)]
        linear = control.initial_response(design.closed_loop, T=result.t, X0=x0)
        q_r, _ = ctrl.reference_samples(result.t)
        q_err = quat.error_quaternion(q_r, result.q)[:, 1:]
        return (
            relative_peak_mismatch(q_err, linear.states[:3].T),
            relative_peak_mismatch(result.omega - omega_ref, linear.states[3:].T),
        )

    @pytest.mark.parametrize("spin_axis", [None, 2, 3])
    def test_discrete_design_matches_its_linear_closed_loop(self, spin_axis):
        w_ref = np.zeros(3) if spin_axis is None else principal_spin(BODY, spin_axis, 0.2)
        design = design_lqr(linearize(BODY, omega_ref=w_ref), Q=Q_B, R=R_B, period=0.1)
        # Same sampling and hold on both sides, so the mismatch is the plant's nonlinearity alone.
        big = self.run(design, 0.5, w_ref)
        small = self.run(design, 0.25, w_ref)
        # The bar: within 1% of the peak (measured ~5e-4 at 0.5 deg: the neglected terms are
        # second order, relative size ~|q_ev| ~ 4e-3 times O(0.1) coefficients).
        assert max(big) < 0.01
        # Second order means the relative mismatch halves with the amplitude; a modelling error (a wrong
        # sign or factor in A or B) would give a mismatch that does not shrink at all.
        for b, s in zip(big, small):
            assert b / s == pytest.approx(2.0, rel=0.05)

    def test_continuous_design_matches_its_linear_closed_loop(self):
        design = design_lqr(linearize(BODY), Q=Q_B, R=R_B)
        # Sampling the continuous law at 0.01 s adds a hold delay of T/2 against closed-loop poles of
        # |s| <= 0.3 rad/s: a relative mismatch ~ |s| T/2 * (gain spread) ~ 1e-3 (measured 1.2e-3 on
        # the rates, 4.5e-4 on q_ev), inside the 1%.
        mismatch = self.run(design, 0.5, np.zeros(3), period=0.01)
        assert max(mismatch) < 0.01

    def test_discrete_lqr_with_reaction_wheels(self):
        design = design_lqr(linearize(BODY), Q=Q_B, R=R_B, period=0.1)
        ctrl = LQRController(design, q_ref=TARGET)
        wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8)
        q0 = quat.multiply(TARGET, quat.from_axis_angle(AXIS, np.radians(20.0)))
        w0 = np.array([0.004, -0.003, 0.002])  # non-zero total momentum (0.049 N m s)
        result = simulate(BODY, q0, w0, 120.0, controller=ctrl, wheels=wheels)
        assert np.degrees(result.error_angle[0]) == pytest.approx(20.0, rel=1e-12)
        # The commands exceed what the 0.05 N m motors give at first (K q_ev ~ 0.2 N m at 20 deg).
        assert np.max(np.abs(result.motor_torque)) == pytest.approx(0.05, rel=1e-12)

        # Internal torques only: RK4 at 0.1 s keeps H_N to ~1e-12 relative.
        h = result.momentum_N
        assert np.max(np.linalg.norm(h - h[0], axis=1)) / np.linalg.norm(h[0]) < 1e-10

        # Convergence on the time scale of the poles: the unsaturated linear loop from the same state
        # reaches 0.01 deg at t_lin (~42 s, slowest pole decay 0.19 /s); saturation in the first seconds
        # may delay the nonlinear loop, but not by more than a quarter of that.
        x0 = np.r_[quat.error_quaternion(TARGET, q0)[1:], w0]
        linear = control.initial_response(design.closed_loop, T=result.t, X0=x0)
        linear_angle = 2.0 * np.arcsin(np.linalg.norm(linear.states[:3], axis=0))
        threshold = np.radians(0.01)
        t_lin = result.t[np.nonzero(linear_angle > threshold)[0][-1] + 1]
        t_settle = result.settling_time(threshold)
        assert 0.75 * t_lin < t_settle < 1.25 * t_lin
        # Stays stable: after settling it keeps decaying at about the slowest pole's rate
        # (0.01 deg * exp(-0.19 * 75 s) ~ 7e-9 deg; 1e-6 deg leaves a factor 100 for the mix of modes).
        # The rate decays with it (measured 1.4e-11 rad/s; bound 1e-9 rad/s).
        assert np.degrees(result.error_angle[-1]) < 1e-6
        assert np.linalg.norm(result.omega[-1]) < 1e-9
        # So the wheels alone hold the momentum the body started with, to |I omega| / |H| < 12.3e-9 / 0.049.
        np.testing.assert_allclose(
            quat.rotate(result.q[-1], wheels.distribution @ result.h_wheels[-1]), h[0], rtol=3e-7
        )

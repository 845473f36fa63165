"""Linear models of the plant: the nlsys, exact vs finite-difference Jacobians, spin physics, 6 vs 7 states.

Derivation in docs/linearize.md. What each group checks against:

* The python-control nonlinear system (``control.NonlinearIOSystem``): its update against the one
  definition of the dynamics (:meth:`attitude.rigid_body.RigidBody.state_derivative`) at rest;
  with a spinning reference, against the product rule applied with :mod:`attitude.quaternion`'s
  own ``multiply`` and ``derivative``; and its torque-free response
  (``control.input_output_response`` with DOP853) against the exact Jacobi elliptic solution of
  :func:`attitude.analytic.torque_free_motion` (Landau & Lifshitz, *Mechanics*, sec. 37).
* At rest: the exact (casadi) model against the hand-derived double integrator
  ``qe' = w / 2``, ``w' = I^-1 tau``; python-control's own finite-difference linearisation
  (``method="finite-difference"``) differs from it by exactly the one-sided truncation term
  ``eps / 2 d^2 f / dx_i^2`` (second derivatives from casadi; Taylor's theorem) and nothing else.
* Spin operating points: the block structure of the linearised Euler equations
  ``I dw' = (I w_ref) x dw - w_ref x (I dw)`` derived by hand; the classical torque-free spin
  results of Euler's equations: nutation at ``w sqrt((Is - Ij)(Is - Ik) / (Ij Ik))`` about the
  major and minor axes, ``(Is - It) / It w`` for a symmetric top, and growth about the middle
  axis at :func:`attitude.analytic.intermediate_axis_growth_rate`.
* 6 vs 7 states: ``|q|^2`` is a first integral, so the 7-state model has an uncontrollable zero
  mode (rank of ``control.ctrb``; ``control.lqr`` fails or leaves a pole at 0), while the 6-state
  model is controllable and LQR stabilises it.
* Bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

import casadi as ca
import control
import numpy as np
import pytest

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.analytic import intermediate_axis_growth_rate, torque_free_motion
from attitude.linearize import (
    INPUT_NAMES,
    STATE_NAMES,
    error_state_derivative_components,
    linearize,
    plant_nlsys,
    principal_spin,
    rate_block_eigenvalues,
)

BODY = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
TARGET = quat.from_axis_angle([1.0, 0.5, 0.0], np.radians(30.0))
SPIN = 0.3  # rad/s
ROTATION = quat.to_dcm(quat.from_axis_angle([0.2, -0.7, 0.4], 0.9))


def skew(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rotated(moments):
    """A full inertia tensor with the given principal moments (principal axes not the body axes)."""
    return RigidBody(ROTATION @ np.diag(moments) @ ROTATION.T)


def assert_same_spectrum(actual, expected, atol):
    """Distinct eigenvalues equal as sets (sorting complex numbers with ~1e-17 real parts is fragile)."""
    assert len(actual) == len(expected)
    for e in expected:
        assert np.min(np.abs(actual - e)) < atol, (e, actual)
    for a in actual:
        assert np.min(np.abs(expected - a)) < atol, (a, expected)


def second_derivatives(body, omega_ref):
    """Columns d^2 f / d x_i^2 at the operating point, by casadi (exact)."""
    x = ca.SX.sym("x", 6)
    u = ca.SX.sym("u", 3)
    f = ca.vertcat(
        *error_state_derivative_components(body, [x[i] for i in range(6)], [u[i] for i in range(3)], omega_ref)
    )
    jac = ca.jacobian(f, x)
    cols = ca.horzcat(*[ca.jacobian(jac[:, i], x)[:, i] for i in range(6)])
    return np.array(ca.Function("d2f", [x, u], [cols])(np.r_[0.0, 0.0, 0.0, omega_ref], np.zeros(3)))


class TestPlantNlsys:
    def test_signals_are_named(self):
        sys = plant_nlsys(BODY, name="sc")
        assert isinstance(sys, control.NonlinearIOSystem)
        assert sys.name == "sc"
        assert sys.state_labels == list(STATE_NAMES) == ["qe1", "qe2", "qe3", "w1", "w2", "w3"]
        assert sys.input_labels == list(INPUT_NAMES) == ["tau1", "tau2", "tau3"]
        assert sys.output_labels == list(STATE_NAMES)

    def test_update_is_the_one_definition_at_rest(self):
        rng = np.random.default_rng(7)
        sys = plant_nlsys(BODY)
        for _ in range(5):
            q = quat.shortest(quat.random(rng=rng))
            w, tau = rng.normal(scale=0.1, size=3), rng.normal(scale=0.05, size=3)
            x_dot = sys.dynamics(0.0, np.r_[q[1:], w], tau)
            # For a fixed reference at identity q_e = q_BN: the 7-state derivative, scalar part dropped.
            expected = BODY.state_derivative(np.r_[q, w], tau)
            # Same component formulas, but q_e0 is recomputed as sqrt(1 - |q_v|^2): rounding only.
            np.testing.assert_allclose(x_dot, np.r_[expected[1:4], expected[4:]], rtol=0, atol=1e-15)

    def test_update_with_spinning_reference_is_the_derivative_of_the_error(self):
        # q_e = q_RN* ⊗ q_BN with q_RN' = 0.5 q_RN ⊗ [0, omega_ref]: product rule with quaternion.py's own
        # multiply/derivative, an implementation independent of the component formulas under test.
        rng = np.random.default_rng(3)
        w_ref = principal_spin(BODY, "major", SPIN)
        sys = plant_nlsys(BODY, omega_ref=w_ref)
        for _ in range(5):
            q_rn = quat.random(rng=rng)
            q_e = quat.shortest(quat.random(rng=rng))
            q_bn = quat.multiply(q_rn, q_e)
            w, tau = w_ref + rng.normal(scale=0.05, size=3), rng.normal(scale=0.05, size=3)
            q_e_dot = quat.multiply(quat.conjugate(quat.derivative(q_rn, w_ref)), q_bn) + quat.multiply(
                quat.conjugate(q_rn), quat.derivative(q_bn, w)
            )
            x_dot = sys.dynamics(0.0, np.r_[q_e[1:], w], tau)
            np.testing.assert_allclose(x_dot[:3], q_e_dot[1:], rtol=0, atol=1e-15)
            np.testing.assert_allclose(x_dot[3:], BODY.omega_dot(w, tau), rtol=0, atol=1e-15)

    def test_torque_free_response_matches_the_elliptic_solution(self):
        # Spin about the major axis plus a 5% transverse kick: the rates nutate (Jacobi cn/sn/dn) while the
        # attitude relative to the spinning reference stays small (inside the 6-state chart).
        w_ref = principal_spin(BODY, 3, SPIN)
        kick = np.cross(w_ref, [1.0, 0.0, 0.0])
        w0 = w_ref + 0.015 * kick / np.linalg.norm(kick)
        t = np.linspace(0.0, 100.0, 501)
        # python-control's default solve_ivp tolerances (rtol 1e-3) leave a 3.5e-6 relative error here;
        # DOP853 at rtol 1e-12 leaves ~2e-15.
        response = control.input_output_response(
            plant_nlsys(BODY, omega_ref=w_ref),
            t,
            0.0,
            np.r_[0.0, 0.0, 0.0, w0],
            solve_ivp_method="DOP853",
            solve_ivp_kwargs={"rtol": 1e-12, "atol": 1e-14},
        )
        exact = torque_free_motion(BODY, w0).omega(t)
        # Elliptic evaluation is good to ~5e-14 absolute, the integration to ~1e-14: 1e-10 has margin and
        # still fails by four orders of magnitude at python-control's default tolerances.
        np.testing.assert_allclose(response.states[3:].T, exact, rtol=0, atol=1e-10 * np.linalg.norm(w0))
        assert np.max(np.linalg.norm(response.states[:3], axis=0)) < 0.1

    def test_update_rejects_a_state_outside_the_chart(self):
        sys = plant_nlsys(BODY)
        with pytest.raises(ValueError, match=r"\|q_ev\| <= 1"):
            sys.dynamics(0.0, np.array([0.8, 0.7, 0.0, 0.0, 0.0, 0.0]), np.zeros(3))


class TestLinearizeAtRest:
    def test_exact_model_is_the_hand_derived_one(self):
        sys = linearize(BODY)
        a = np.zeros((6, 6))
        a[:3, 3:] = 0.5 * np.eye(3)
        b = np.vstack([np.zeros((3, 3)), np.linalg.inv(BODY.inertia)])
        # Exact Jacobian: the only rounding is in I^-1 itself (a few ulp of 0.1 kg^-1 m^-2).
        np.testing.assert_allclose(sys.A, a, rtol=0, atol=1e-16)
        np.testing.assert_allclose(sys.B, b, rtol=0, atol=1e-16)
        np.testing.assert_array_equal(sys.C, np.eye(6))
        np.testing.assert_array_equal(sys.D, np.zeros((6, 3)))
        assert sys.isctime()
        assert sys.state_labels == list(STATE_NAMES)
        assert sys.input_labels == list(INPUT_NAMES)
        assert sys.output_labels == list(STATE_NAMES)
        assert sys.name == "attitude_plant$linearized"

    def test_finite_difference_model_keeps_the_names(self):
        sys = linearize(BODY, method="finite-difference")
        assert sys.state_labels == list(STATE_NAMES)
        assert sys.input_labels == list(INPUT_NAMES)
        assert sys.output_labels == list(STATE_NAMES)

    @pytest.mark.parametrize("axis", [None, 1, 2, 3])
    def test_finite_difference_differs_by_exactly_the_one_sided_truncation(self, axis):
        w_ref = np.zeros(3) if axis is None else principal_spin(BODY, axis, SPIN)
        eps = 1e-6
        exact = linearize(BODY, omega_ref=w_ref)
        fd = linearize(BODY, omega_ref=w_ref, method="finite-difference", eps=eps)
        diff = fd.A - exact.A
        # One-sided differences: column i is off by eps/2 d2f/dx_i^2 (~1.5e-7 here, ~3e-7 relative to |A|).
        assert 1e-8 < np.max(np.abs(diff)) < 1e-6 * np.max(np.abs(exact.A))
        # ... and by nothing else: what remains is O(eps^2 f''') ~ 1e-13 plus rounding of the difference
        # quotient, machine-eps * (largest term in f, |I^-1| |I| |w|^2 ~ 1) / eps ~ 2e-10.
        np.testing.assert_allclose(diff, 0.5 * eps * second_derivatives(BODY, w_ref), rtol=0, atol=1e-9)
        # f is linear in the torque: B has no truncation error, only rounding (/eps).
        np.testing.assert_allclose(fd.B, exact.B, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fd.C, exact.C, rtol=0, atol=1e-9)


class TestSpinOperatingPoints:
    @pytest.mark.parametrize("axis", [1, 2, 3])
    def test_structure_is_block_triangular(self, axis):
        w_ref = principal_spin(BODY, axis, SPIN)
        a = linearize(BODY, omega_ref=w_ref).A
        np.testing.assert_allclose(a[:3, :3], -skew(w_ref), rtol=0, atol=1e-16)
        np.testing.assert_allclose(a[:3, 3:], 0.5 * np.eye(3), rtol=0, atol=1e-16)
        np.testing.assert_array_equal(a[3:, :3], np.zeros((3, 3)))
        inertia, inv = BODY.inertia, BODY.inertia_inv
        # Linearised Euler equations: I dw' = (I w_ref) x dw - w_ref x (I dw).
        np.testing.assert_allclose(a[3:, 3:], inv @ (skew(inertia @ w_ref) - skew(w_ref) @ inertia), atol=1e-15)
        # So the spectrum is the attitude block's {0, +-i|w_ref|} plus the rate block's. The two zeros form a
        # Jordan chain (spin-axis angle driven by spin-axis rate), which eigvals resolves only to
        # ~sqrt(machine eps) ~ 1e-8; the other eigenvalues are >= 0.07 apart, so 1e-7 still identifies them.
        attitude = np.array([0.0, 1j * SPIN, -1j * SPIN])
        everything = np.concatenate([attitude, rate_block_eigenvalues(linearize(BODY, omega_ref=w_ref))])
        assert_same_spectrum(np.linalg.eigvals(a), everything, atol=1e-7)

    @pytest.mark.parametrize(("axis", "others"), [(3, (0, 1)), (1, (1, 2))])
    def test_major_and_minor_axis_spin_nutates(self, axis, others):
        moments = BODY.principal_axes().moments
        i_s = moments[axis - 1]
        i_j, i_k = moments[others[0]], moments[others[1]]
        eig = rate_block_eigenvalues(linearize(BODY, omega_ref=principal_spin(BODY, axis, SPIN)))
        # Classical body-frame nutation frequency, e.g. sqrt((I3-I1)(I3-I2)/(I1 I2)) w3 for the major axis.
        nutation = SPIN * np.sqrt((i_s - i_j) * (i_s - i_k) / (i_j * i_k))
        # Purely imaginary: real parts are eigenvalue rounding, ~1e-16 |A|.
        assert np.max(np.abs(eig.real)) < 1e-12 * SPIN
        np.testing.assert_allclose(eig.imag, [-nutation, 0.0, nutation], rtol=1e-9, atol=1e-12 * SPIN)

    @pytest.mark.parametrize("rate", [SPIN, -0.05])
    def test_middle_axis_spin_grows_at_the_analytic_rate(self, rate):
        eig = rate_block_eigenvalues(linearize(BODY, omega_ref=principal_spin(BODY, "middle", rate)))
        k = intermediate_axis_growth_rate(BODY, rate)
        assert np.max(np.abs(eig.imag)) < 1e-12 * abs(rate)
        np.testing.assert_allclose(np.sort(eig.real), [-k, 0.0, k], rtol=1e-9, atol=1e-12 * abs(rate))

    @pytest.mark.parametrize(("moments", "axis"), [((8.0, 8.0, 12.0), 3), ((6.0, 10.0, 10.0), 1)])
    def test_symmetric_top_nutates_at_the_body_frequency(self, moments, axis):
        body = rotated(moments)
        i_t = moments[1]  # transverse moment
        i_s = moments[axis - 1]  # symmetry-axis moment
        eig = rate_block_eigenvalues(linearize(body, omega_ref=principal_spin(body, axis, SPIN)))
        # +-i (I3 - I1)/I1 w3 for the oblate top, +-i (I1 - I2)/I2 w1 for the prolate one.
        nutation = abs((i_s - i_t) / i_t * SPIN)
        assert np.max(np.abs(eig.real)) < 1e-12 * SPIN
        np.testing.assert_allclose(eig.imag, [-nutation, 0.0, nutation], rtol=1e-9, atol=1e-12 * SPIN)

    def test_principal_spin_points_along_the_principal_axes(self):
        axes = BODY.principal_axes().axes_B
        for n, name in zip((1, 2, 3), ("minor", "middle", "major")):
            w = principal_spin(BODY, name, 2.0)
            assert np.linalg.norm(w) == pytest.approx(2.0, rel=1e-15)
            assert abs(w @ axes[:, n - 1]) == pytest.approx(2.0, rel=1e-15)
            np.testing.assert_array_equal(w, principal_spin(BODY, n, 2.0))
            assert w[np.argmax(np.abs(w))] > 0


class TestWhySixStates:
    def test_the_seven_state_model_has_an_uncontrollable_zero_mode(self):
        a7, b7 = (np.array(m) for m in BODY.casadi_jacobian()(np.r_[TARGET, 0.0, 0.0, 0.0], np.zeros(3)))
        # |q|^2 is a first integral: w = [q*, 0] is a left eigenvector (eigenvalue 0) that B cannot excite.
        w = np.r_[TARGET, np.zeros(3)]
        np.testing.assert_allclose(w @ a7, np.zeros(7), atol=1e-15)
        np.testing.assert_allclose(w @ b7, np.zeros(3), atol=1e-15)
        assert np.linalg.matrix_rank(control.ctrb(a7, b7)) == 6
        # No stabilising Riccati solution: with the norm direction weighted scipy's solver gives up (its
        # message depends on the data: "Failed to find a finite solution" at identity) ...
        with pytest.raises(np.linalg.LinAlgError, match=r"finite solution|too close to the imaginary axis"):
            control.lqr(a7, b7, np.eye(7), np.eye(3), method="scipy")
        # ... and with it unweighted, control.lqr silently returns a gain with a closed-loop pole at 0.
        q_weight = np.eye(7)
        q_weight[:4, :4] -= np.outer(TARGET, TARGET)
        _, _, poles = control.lqr(a7, b7, q_weight, np.eye(3), method="scipy")
        assert np.min(np.abs(poles)) < 1e-12

    def test_the_six_state_model_is_controllable_and_lqr_works(self):
        sys = linearize(BODY)
        assert np.linalg.matrix_rank(control.ctrb(sys.A, sys.B)) == 6
        _, _, poles = control.lqr(sys, np.eye(6), np.eye(3))
        assert np.max(poles.real) < -1e-3


class TestBadInput:
    def test_off_axis_spin(self):
        with pytest.raises(ValueError, match="omega_ref must lie along a principal axis"):
            linearize(BODY, omega_ref=[0.0, 0.0, 0.3])  # body z is not principal for the full tensor
        with pytest.raises(ValueError, match="omega_ref must lie along a principal axis"):
            plant_nlsys(BODY, omega_ref=principal_spin(BODY, 3, SPIN) + np.array([1e-4, 0.0, 0.0]))

    def test_bad_arguments(self):
        with pytest.raises(ValueError, match="method must be one of"):
            linearize(BODY, method="central")
        with pytest.raises(ValueError, match="eps must be"):
            linearize(BODY, method="finite-difference", eps=0.0)
        with pytest.raises(ValueError, match=r"omega_ref must have shape \(\.\.\., 3\)"):
            linearize(BODY, omega_ref=[0.1, 0.2])
        with pytest.raises(ValueError, match="omega_ref must be finite"):
            linearize(BODY, omega_ref=[np.nan, 0.0, 0.0])
        with pytest.raises(ValueError, match="body must be a RigidBody"):
            linearize(np.eye(3))
        with pytest.raises(ValueError, match="single RigidBody"):
            plant_nlsys(RigidBody([[10.0, 12.0, 8.0], [9.0, 11.0, 8.0]]))
        with pytest.raises(ValueError, match="axis must be 1, 2, 3"):
            principal_spin(BODY, 4, SPIN)
        with pytest.raises(ValueError, match="axis must be 1, 2, 3"):
            principal_spin(BODY, "spin", SPIN)
        with pytest.raises(ValueError, match="6-state StateSpace"):
            rate_block_eigenvalues(control.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]]))

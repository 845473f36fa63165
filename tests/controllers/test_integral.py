"""Integral action and anti-windup (controllers.integral), on the nonlinear plant where it matters.

What each test checks against:

* the PID's linear closed loop has the poles ``(s + a)(s^2 + 2 zeta wn s + wn^2)`` per
  axis it was placed at (analytic pole placement; the loop is assembled by
  controllers.analysis from the controller's ``feedback_system``);
* the PD's steady error to a constant torque ``tau_d`` is exactly
  ``2 asin|K^-1 tau_d|`` on the nonlinear plant (at rest the law and the
  equations of motion reduce to ``K q_e,v = tau_d``);
* the PID's error history under the same torque is python-control's sampled
  linear loop (zero-order hold, exact for a constant torque) and its residual
  is below the envelope ``sum |residue| exp(-sigma t)`` of the closed-loop
  poles, < 1e-3 of the PD's error;
* back-calculation anti-windup on a 60 deg slew that saturates the wheels:
  overshoot no larger than the PD's own on the same slew and than the linear
  design's step overshoot (``control.step_info``), where the plain integral
  winds up (overshoot above 100 %);
* the LQI gain is python-control's ``lqr``/``dlqr`` with ``integral_action``
  (its own augmentation), the flown loop has the design's poles, and the
  nonlinear plant under a constant torque settles to zero error.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.linearize import linearize
from attitude.rigid_body import RigidBody
from attitude.simulation.engine import simulate
from attitude.simulation.protocols import Estimate
from controllers.analysis import closed_loop_poles, rigid_body_at_rest, sampled_loop
from controllers.integral import LQIController, QuaternionPID, design_lqi
from controllers.lqr import bryson_weights
from controllers.pd import QuaternionPD

J_DIAG = np.array([10.0, 12.0, 8.0])
BODY = RigidBody(np.diag(J_DIAG))
WN, ZETA, POLE, PERIOD = 0.5, 0.7, 0.125, 0.1  # integral pole a = wn / 4
TAU_D = np.array([1e-3, -2e-3, 1.5e-3])  # constant disturbance torque [N m]


def _pid(**kwargs):
    kwargs.setdefault("anti_windup", "none")
    return QuaternionPID.from_bandwidth(BODY, wn=WN, zeta=ZETA, integral_pole=POLE, period=PERIOD, **kwargs)


# ---------------------------------------------------------------------------
# Linear design
# ---------------------------------------------------------------------------


def test_pid_linear_loop_has_the_placed_poles():
    """Continuous loop poles = roots of (s + a_j)(s^2 + 2 zeta_j wn_j s + wn_j^2) per axis (analytic placement).

    A coupled inertia (products of inertia) checks the matrix form ``J^-1 K / 2`` etc.; distinct values per
    axis keep the poles simple, so ``eig`` is accurate to ~1e-14 relative; 1e-9 leaves ample room.
    """
    inertia = np.array([[10.0, 0.8, -0.5], [0.8, 12.0, 0.3], [-0.5, 0.3, 8.0]])
    wn, zeta = np.array([0.4, 0.5, 0.6]), np.array([0.7, 0.8, 0.9])
    a = wn / np.array([3.0, 4.0, 5.0])
    pid = QuaternionPID.from_bandwidth(
        RigidBody(inertia), wn=wn, zeta=zeta, integral_pole=a, period=0.05, anti_windup="none"
    )
    expected = np.concatenate(
        [np.roots(np.polymul([1.0, a[j]], [1.0, 2 * zeta[j] * wn[j], wn[j] ** 2])) for j in range(3)]
    )
    poles = closed_loop_poles(RigidBody(inertia), pid, sampled=False)
    assert poles.size == 9
    for p in expected:
        assert np.min(np.abs(poles - p)) < 1e-9 * abs(p)


def test_feedback_system_is_the_flown_law():
    """The discrete ``feedback_system`` (u = -G_c y) reproduces the torques ``torque()`` commands, sample by sample.

    Random small errors and rates (no actuator model, so the law is linear in ``q_e,v`` and the integral);
    both are sums of the same few products: equal to 1e-12 relative.
    """
    pid = _pid()
    sys = pid.feedback_system(discrete=True)
    assert sys.dt == PERIOD
    rng = np.random.default_rng(3)
    z = np.zeros(3)
    for k in range(20):
        q = quat.from_rotation_vector(rng.normal(scale=0.05, size=3))
        w = rng.normal(scale=0.01, size=3)
        tau = pid.torque(k * PERIOD, Estimate(k * PERIOD, q, w))
        y = np.concatenate([q[1:] * np.sign(q[0]), w])
        expected = -(np.asarray(sys.C) @ z + np.asarray(sys.D) @ y)
        np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-15)
        z = np.asarray(sys.A) @ z + np.asarray(sys.B) @ y


# ---------------------------------------------------------------------------
# Constant disturbance torque on the nonlinear plant
# ---------------------------------------------------------------------------


def test_pd_steady_error_is_the_analytic_one():
    """PD: steady error ``2 asin|K^-1 tau_d|`` (exact at rest; ~ |tau_d| / (J wn^2) for small angles).

    After 60 s the PD's transient has decayed by ``exp(-zeta wn 60) = 8e-10``; rtol 1e-6 covers it.
    """
    pd = QuaternionPD.from_bandwidth(BODY, wn=WN, zeta=ZETA, period=PERIOD)
    run = simulate(BODY, quat.identity(), np.zeros(3), 60.0, controller=pd, disturbance=TAU_D)
    expected = 2.0 * np.arcsin(np.linalg.norm(np.linalg.solve(pd.K, TAU_D)))
    np.testing.assert_allclose(run.error_angle[-1], expected, rtol=1e-6)
    # The small-angle form |tau_d / (J wn^2)| (the factor 2 of K = 2 J wn^2 and of theta = 2 q_v cancel).
    np.testing.assert_allclose(expected, np.linalg.norm(TAU_D / (J_DIAG * WN**2)), rtol=1e-6)


def test_pid_removes_the_steady_error_at_the_linear_loops_rate():
    """PID: the nonlinear error is python-control's sampled linear loop, and decays below the pole envelope.

    1. Linear prediction: ``sampled_loop`` of the body at rest (zero-order hold: exact for a constant torque
       at the plant input) closed with the PID's discrete ``feedback_system``, driven by ``tau_d``
       (``control.forced_response``); the error angle is ``2 |q_v|``. The nonlinear terms it neglects, the
       gyroscopic torque ``|omega|^2 max|J_i - J_j|`` (|omega| < 1e-3 rad/s: < 2e-3 of tau_d, and it enters
       the error only through the loop's low-pass) and the kinematics (~theta^2 ~ 1e-6), stay below 1e-4 of
       the peak error (measured 3e-7).
    2. Envelope: per axis ``theta_j(t) = (tau_d,j / J_j) sum_i r_i exp(p_i t)`` with ``r_i = 1 / p'(p_i)``
       the residues of ``1 / p(s)``, ``p = (s + a)(s^2 + 2 zeta wn s + wn^2)`` (the continuous loop), so
       ``|theta_j| <= (|tau_d,j| / J_j) sum |r_i| exp(-sigma t)``, ``sigma = min(a, zeta wn)``. The sampled
       loop decays faster than ``sigma`` (asserted) and its residues are within O(wn T) = 5 % of these: the
       bound is doubled for that. At 90 s it is below 1e-3 of the PD's steady error.
    """
    pid = _pid()
    duration = 90.0
    run = simulate(BODY, quat.identity(), np.zeros(3), duration, controller=pid, disturbance=TAU_D)
    assert run.info["engine"] == "python"  # a controller with state flies the protocol path

    plant = sampled_loop(rigid_body_at_rest(BODY), period=PERIOD)
    loop = control.feedback(plant, pid.feedback_system(discrete=True))
    t = np.arange(run.t.size) * PERIOD
    linear = control.forced_response(loop, T=t, U=np.tile(TAU_D[:, None], (1, t.size))).outputs
    linear_angle = 2.0 * np.linalg.norm(linear[:3], axis=0)
    np.testing.assert_allclose(run.t, t, rtol=0, atol=1e-9)
    assert np.max(np.abs(run.omega)) < 1e-3
    assert np.max(np.abs(run.error_angle - linear_angle)) < 1e-4 * np.max(linear_angle)

    p = np.polymul([1.0, POLE], [1.0, 2 * ZETA * WN, WN**2])
    poles = np.roots(p)
    residues = 1.0 / np.polyval(np.polyder(p), poles)
    sigma = min(POLE, ZETA * WN)
    sampled_decay = -np.log(np.abs(closed_loop_poles(BODY, pid))) / PERIOD
    assert np.min(sampled_decay) >= sigma
    envelope = 2.0 * np.linalg.norm(np.abs(TAU_D) / J_DIAG) * np.sum(np.abs(residues)) * np.exp(-sigma * duration)
    pd_error = np.linalg.norm(TAU_D / (J_DIAG * WN**2))
    assert envelope < 1e-3 * pd_error
    assert run.error_angle[-1] < envelope


def test_each_run_starts_from_its_own_integral():
    """``prepare`` resets the integral: a second run of the same controller repeats the first bit for bit."""
    pid = _pid()
    first = simulate(BODY, quat.identity(), np.zeros(3), 10.0, controller=pid, disturbance=TAU_D)
    assert np.any(pid.integral_torque != 0.0)
    second = simulate(BODY, quat.identity(), np.zeros(3), 10.0, controller=pid, disturbance=TAU_D)
    np.testing.assert_array_equal(first.torque_command, second.torque_command)
    np.testing.assert_array_equal(first.logs["controller.integral_torque"], second.logs["controller.integral_torque"])


def test_retarget_keeps_the_integral():
    """A new target keeps the disturbance estimate (no bump): the integral term is unchanged by ``retarget``."""
    pid = _pid()
    simulate(BODY, quat.identity(), np.zeros(3), 20.0, controller=pid, disturbance=TAU_D)
    held = pid.integral_torque.copy()
    pid.retarget(quat.from_rotation_vector([0.0, 0.0, 0.1]))
    np.testing.assert_array_equal(pid.integral_torque, held)
    np.testing.assert_allclose(pid.reference(0.0)[0], quat.from_rotation_vector([0.0, 0.0, 0.1]))


# ---------------------------------------------------------------------------
# Anti-windup on a saturating slew
# ---------------------------------------------------------------------------

SLEW_ANGLE = np.deg2rad(60.0)
SLEW_AXIS = np.array([1.0, 0.0, 0.0])
Q_TARGET = quat.from_rotation_vector(SLEW_ANGLE * SLEW_AXIS)
# 0.2 N m per wheel against the PD's initial command K q_v = 2 J wn'^2 sin(30 deg) ~ 7 N m: saturated ~10 s.
WHEELS = ReactionWheels.orthogonal(spin_inertia=0.01, torque_max=0.2, momentum_max=10.0)


def _overshoot(run):
    """Largest travel past the target along the slew axis, as a fraction of the slew angle."""
    e = quat.error_quaternion(Q_TARGET, run.q)
    signed = 2.0 * np.arctan2(e[:, 1:] @ SLEW_AXIS, e[:, 0])  # negative before the target, positive past it
    return max(0.0, float(np.max(signed))) / SLEW_ANGLE


def test_back_calculation_bounds_the_overshoot_after_saturation():
    """60 deg slew, wheels saturated for a long stretch: back-calculation keeps the overshoot bounded.

    Bounds, none tuned to the result: (1) the PID's own PD part alone on the same slew (the integral with
    anti-windup must cost no overshoot over the law without it) and (2) the linear PID's step overshoot
    (``control.step_info`` on ``((wn^2 + 2 zeta wn a) s + a wn^2) / p(s)``, the P and I acting on the error).
    Measured: PD part 27.1 %, linear 24.7 %, back-calculation 15.5 %, plain integral 298 % (it winds up into
    a limit cycle and never settles). Two RK4 steps per tick: the wound-up run reaches 0.37 rad/s, where the
    engine's step rule would sub-step (and warn) anyway.
    """
    runs = {}
    for name, ctrl in {
        "pd": _pid(q_ref=Q_TARGET).pd,
        "none": _pid(q_ref=Q_TARGET),
        "back_calculation": _pid(q_ref=Q_TARGET, anti_windup="back_calculation", wheels=WHEELS),
    }.items():
        runs[name] = simulate(BODY, quat.identity(), np.zeros(3), 100.0, controller=ctrl, wheels=WHEELS, substeps=2)
    saturated = np.max(np.abs(runs["back_calculation"].torque_command - runs["back_calculation"].torque_applied), 1)
    assert np.sum(saturated > 1e-6) * PERIOD > 5.0  # the premise: a long saturated stretch
    linear = (
        control.step_info(
            control.tf([WN**2 + 2 * ZETA * WN * POLE, POLE * WN**2], np.polymul([1, POLE], [1, 2 * ZETA * WN, WN**2]))
        )["Overshoot"]
        / 100.0
    )
    overshoot = {name: _overshoot(run) for name, run in runs.items()}
    assert overshoot["none"] > 1.0
    assert overshoot["back_calculation"] <= overshoot["pd"]
    assert overshoot["back_calculation"] <= linear
    assert runs["back_calculation"].error_angle[-1] < 1e-5  # recovered and settled
    assert runs["none"].error_angle[-1] > 0.1  # the wound-up loop has not


def test_clamping_stops_the_windup():
    """Conditional integration also stops the windup: the overshoot stays below 100 % (measured 30 %)."""
    pid = _pid(q_ref=Q_TARGET, anti_windup="clamping", wheels=WHEELS)
    run = simulate(BODY, quat.identity(), np.zeros(3), 100.0, controller=pid, wheels=WHEELS)
    assert _overshoot(run) < 0.5
    assert run.error_angle[-1] < 1e-4


def test_delivered_torque_is_the_engines():
    """The wheels model predicts the torque the engine applies (same allocation), to rounding."""
    pid = _pid(q_ref=Q_TARGET, anti_windup="back_calculation", wheels=WHEELS)
    run = simulate(BODY, quat.identity(), np.zeros(3), 5.0, controller=pid, wheels=WHEELS)
    for k in range(0, run.t.size - 1, 7):
        estimate = Estimate(run.t[k], run.q[k], run.omega[k], run.h_wheels[k])
        np.testing.assert_allclose(
            pid.delivered_torque(run.torque_command[k], estimate), run.torque_applied[k], rtol=1e-12, atol=1e-15
        )


# ---------------------------------------------------------------------------
# LQI
# ---------------------------------------------------------------------------

_Q6, R_LQI = bryson_weights(angle_max=np.deg2rad(1.0), rate_max=0.01, torque_max=0.1)
Q_LQI = scipy.linalg.block_diag(_Q6, 0.05 * _Q6[0, 0] * np.eye(3))
SELECT_QV = np.hstack([np.eye(3), np.zeros((3, 3))])


@pytest.mark.parametrize("period", [None, PERIOD])
def test_lqi_gain_is_python_controls_integral_action(period):
    """``K`` equals ``control.lqr`` / ``dlqr`` with ``integral_action`` (python-control's own augmentation).

    Discrete: python-control integrates ``z_{k+1} = z_k + C x_k``, so ``C = T [I 0]`` is the flown
    forward-Euler integral. The same scipy Riccati solver on the same matrices: 1e-10 relative.
    The design's poles are the eigenvalues of python-control's closed loop ``A_aug - B_aug K``.
    """
    plant = linearize(BODY)
    design = design_lqi(plant, Q=Q_LQI, R=R_LQI, period=period)
    if period is None:
        K, _, E = control.lqr(plant, Q_LQI, R_LQI, integral_action=SELECT_QV, method="scipy")
    else:
        K, _, E = control.dlqr(
            control.c2d(plant, period), Q_LQI, R_LQI, integral_action=period * SELECT_QV, method="scipy"
        )
    np.testing.assert_allclose(design.K, K, rtol=1e-10, atol=1e-10 * np.max(np.abs(K)))
    for p in E:
        assert np.min(np.abs(design.poles - p)) < 1e-9 * max(1.0, abs(p))


def test_lqi_flown_loop_has_the_design_poles():
    """The loop controllers.analysis assembles (body at rest, zero-order hold, the controller's integrator)
    has the design's z-plane poles: the flown integrator is the designed one (1e-9: simple, well-separated)."""
    design = design_lqi(linearize(BODY), Q=Q_LQI, R=R_LQI, period=PERIOD)
    poles = closed_loop_poles(BODY, LQIController(design, anti_windup="none"))
    assert poles.size == 9
    for p in design.poles:
        assert np.min(np.abs(poles - p)) < 1e-9


def test_lqi_zero_steady_error_on_the_nonlinear_plant():
    """Constant torque: the LQI's error goes to zero where the LQR part alone keeps ``2 asin|K_q^-1 tau_d|``.

    The slowest pole decays at ``design.slowest_decay_rate`` (0.245/s); after 80 s its factor is 3e-9, and
    1e-6 of the LQR-alone error leaves a factor of 300 for the residues.
    """
    design = design_lqi(linearize(BODY), Q=Q_LQI, R=R_LQI, period=PERIOD)
    ctrl = LQIController(design, anti_windup="back_calculation", torque_max=1.0)
    run = simulate(BODY, quat.identity(), np.zeros(3), 80.0, controller=ctrl, disturbance=TAU_D)
    proportional_error = 2.0 * np.arcsin(np.linalg.norm(np.linalg.solve(ctrl.K_x[:, :3], TAU_D)))
    assert np.exp(-design.slowest_decay_rate * 80.0) < 1e-8
    assert run.error_angle[-1] < 1e-6 * proportional_error
    np.testing.assert_allclose(ctrl.integral_torque, -TAU_D, rtol=1e-6)  # the integral holds the disturbance


# ---------------------------------------------------------------------------
# Bad input
# ---------------------------------------------------------------------------


def test_bad_input_is_refused_with_the_rule():
    with pytest.raises(ValueError, match="integral_pole must be"):
        QuaternionPID.from_bandwidth(BODY, wn=WN, zeta=ZETA, integral_pole=0.0, period=PERIOD, anti_windup="none")
    with pytest.raises(ValueError, match="integral_pole must be a scalar or one value per axis"):
        QuaternionPID.from_bandwidth(BODY, wn=WN, zeta=ZETA, integral_pole=[0.1, 0.1], period=PERIOD)
    pd = QuaternionPD.from_bandwidth(BODY, wn=WN, zeta=ZETA, period=PERIOD)
    with pytest.raises(ValueError, match="K_i must be positive definite"):
        QuaternionPID(pd, K_i=[-1.0, 1.0, 1.0], anti_windup="none")
    with pytest.raises(ValueError, match=r"K_i must be 3 diagonal gains or a 3x3 matrix, got shape \(2,\)"):
        QuaternionPID(pd, K_i=[1.0, 1.0], anti_windup="none")
    with pytest.raises(ValueError, match="pd must be a QuaternionPD"):
        QuaternionPID(np.eye(3), K_i=np.ones(3))
    with pytest.raises(ValueError, match="anti_windup must be one of"):
        QuaternionPID(pd, K_i=np.ones(3), anti_windup="clip", torque_max=1.0)
    with pytest.raises(ValueError, match="needs the actuator limit"):
        QuaternionPID(pd, K_i=np.ones(3))
    with pytest.raises(ValueError, match="one actuator model"):
        QuaternionPID(pd, K_i=np.ones(3), wheels=WHEELS, torque_max=1.0)
    with pytest.raises(ValueError, match="tracking_time must be at least the period"):
        QuaternionPID(pd, K_i=np.ones(3), torque_max=1.0, tracking_time=0.5 * PERIOD)
    with pytest.raises(ValueError, match="tracking_time must be strictly positive"):
        QuaternionPID(pd, K_i=np.ones(3), torque_max=1.0, tracking_time=-1.0)
    with pytest.raises(ValueError, match="torque_max must be strictly positive"):
        QuaternionPID(pd, K_i=np.ones(3), torque_max=[1.0, 0.0, 1.0])
    pid = QuaternionPID(pd, K_i=np.ones(3), wheels=WHEELS)
    with pytest.raises(ValueError, match=r"estimate\.h_wheels must hold the 3 wheel momenta"):
        pid.torque(0.0, Estimate(0.0, quat.identity(), np.zeros(3)))

    plant = linearize(BODY)
    with pytest.raises(ValueError, match=r"Q must be a \(9, 9\) matrix"):
        design_lqi(plant, Q=_Q6, R=R_LQI)
    with pytest.raises(ValueError, match="detectable"):
        design_lqi(plant, Q=scipy.linalg.block_diag(_Q6, np.zeros((3, 3))), R=R_LQI, period=PERIOD)
    with pytest.raises(ValueError, match="plant must be continuous-time"):
        design_lqi(control.c2d(plant, PERIOD), Q=Q_LQI, R=R_LQI)
    with pytest.raises(ValueError, match="plant must be the 6-state attitude model"):
        design_lqi(control.ss(np.zeros((2, 2)), np.eye(2), np.eye(2), 0), Q=Q_LQI, R=R_LQI)
    lqr6 = design_lqi(plant, Q=Q_LQI, R=R_LQI, period=PERIOD)
    with pytest.raises(ValueError, match="must equal the sample time of the discrete design"):
        LQIController(lqr6, period=0.2, anti_windup="none")
    from controllers.lqr import design_lqr

    with pytest.raises(ValueError, match=r"design.K must have shape \(3, 9\)"):
        LQIController(design_lqr(plant, Q=_Q6, R=R_LQI, period=PERIOD), anti_windup="none")


def test_protocol_and_no_compiled_members():
    """Both laws meet the Controller protocol and offer no stateless compiled members (they hold state)."""
    from attitude.simulation.protocols import Controller

    design = design_lqi(linearize(BODY), Q=Q_LQI, R=R_LQI, period=PERIOD)
    for ctrl in (_pid(), LQIController(design, anti_windup="none")):
        assert isinstance(ctrl, Controller)
        for member in ("torque_components", "compiled_inputs", "compiled_law_cacheable"):
            assert not hasattr(ctrl, member)


def test_residues_formula_matches_scipy():
    """The envelope's residues ``1 / p'(p_i)`` are scipy.signal.residue's for ``1 / p(s)`` (independent)."""
    p = np.polymul([1.0, POLE], [1.0, 2 * ZETA * WN, WN**2])
    r, poles, _ = scipy.signal.residue([1.0], p)
    for ri, pi in zip(r, poles):
        np.testing.assert_allclose(ri, 1.0 / np.polyval(np.polyder(p), pi), rtol=1e-9)

"""The protocol engine's compiled tick (attitude.simulation.protocol_tick): fast path against reference paths.

What each test checks against:

* The C entry point against the reference path (the same casadi function evaluated by casadi's
  virtual machine, :meth:`TickRunner.advance_reference`, and the whole engine without a C
  compiler): the same trajectory, to rounding, for a user's plain-Python controller with wheels, a
  held command (controller period of two ticks), a constant disturbance and a tick the step-size
  rule sub-steps.
* The protocol path against the compiled path (the plant, wheels and built-in controller in one
  casadi ``mapaccum``, evaluated with no Python per tick): the same trajectory, to rounding.
* The step-size rule: the C projection of :class:`TickRule` gives the run's predicted error that
  the per-tick Python rule gives (same running sums).
* An independent loop of the plant's definition on numpy floats (not the generated code).
* The contract: the arrays handed to the user's objects are theirs (changing them does not change the
  record), and a non-finite command or state is named, not carried on.
"""

import numpy as np
import pytest

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.simulation import protocol_tick as pt
from attitude.simulation.engine import SimulationDivergedError, simulate
from attitude.simulation.plant import PlantModel
from attitude.simulation.step_rule import TickRule
from controllers.pd import QuaternionPD

BODY = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
WHEELS = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8, viscous_friction=2e-6)
TARGET = quat.from_axis_angle([1.0, 0.5, 0.0], np.radians(30.0))


class UserPD:
    """A plain-Python quaternion PD a user might write (no casadi, no toolkit controller)."""

    def __init__(self, period: float = 0.1, kp: float = 0.5, kd: float = 3.0) -> None:
        self.period, self.kp, self.kd = period, kp, kd
        self.calls = 0

    def torque(self, t, estimate):
        self.calls += 1
        q_err = quat.multiply(quat.conjugate(TARGET), estimate.q)
        sign = 1.0 if q_err[0] >= 0.0 else -1.0
        return -self.kp * sign * q_err[1:] - self.kd * estimate.omega


def fly(controller, *, wheels=WHEELS, duration=60.0, compiled_tick=True, monkeypatch=None, **kw):
    if not compiled_tick:
        monkeypatch.setattr(pt.TickRunner, "__init__", _reference_init)
    return simulate(
        BODY,
        quat.identity(),
        np.array([0.01, -0.02, 0.005]),
        duration,
        controller=controller,
        wheels=wheels,
        engine="python",
        **kw,
    )


_original_init = pt.TickRunner.__init__


def _reference_init(self, *args, **kwargs):
    _original_init(self, *args, **{**kwargs, "compiled": False})


def test_the_c_tick_and_the_reference_tick_fly_the_same_run(monkeypatch):
    """A plain-Python controller at twice the tick (commands held), wheels, a constant disturbance."""
    disturbance = np.array([1e-4, -2e-4, 5e-5])
    fast = fly(UserPD(period=0.2), disturbance=disturbance, dt=0.1)
    assert fast.info["protocol_tick"] == "C"
    with monkeypatch.context() as m:
        slow = fly(UserPD(period=0.2), disturbance=disturbance, dt=0.1, compiled_tick=False, monkeypatch=m)
    assert slow.info["protocol_tick"].startswith("casadi")
    # One casadi graph, evaluated by generated C and by casadi's virtual machine: the same operations in
    # the same order, so the trajectories agree to a few ulps (1e-13 leaves room for libm differences).
    for name in ("q", "omega", "h_wheels", "torque_command", "torque_applied", "motor_torque"):
        np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), rtol=0, atol=1e-13, err_msg=name)
    # The command is held between the controller's samples, in the record too.
    np.testing.assert_array_equal(fast.torque_command[1::2], fast.torque_command[0:-1:2])
    assert fast.info["step_rule"] == pytest.approx(slow.info["step_rule"], rel=1e-12)


def test_the_protocol_path_flies_what_the_compiled_path_flies():
    """The built-in PD through its Python ``torque`` per tick against its casadi ``mapaccum`` run."""
    pd = QuaternionPD.from_bandwidth(BODY, wn=0.1, zeta=0.7, period=0.1, q_ref=TARGET, gyroscopic=True)
    w0 = np.array([0.01, -0.02, 0.005])
    protocol = simulate(BODY, quat.identity(), w0, 200.0, controller=pd, wheels=WHEELS, engine="python")
    compiled = simulate(BODY, quat.identity(), w0, 200.0, controller=pd, wheels=WHEELS, engine="compiled")
    assert protocol.info["protocol_tick"] == "C" and compiled.info["engine"] == "compiled"
    # Same definitions; the controller's law is numpy in one, casadi in the other: rounding only.
    np.testing.assert_allclose(protocol.q, compiled.q, atol=1e-12)
    np.testing.assert_allclose(protocol.h_wheels, compiled.h_wheels, atol=1e-12)
    np.testing.assert_allclose(protocol.torque_applied, compiled.torque_applied, atol=1e-12)


def test_a_sub_stepped_tick_goes_through_the_python_rule_and_matches_the_reference(monkeypatch):
    """A fast tumble (2 rad/s at a 0.5 s tick) that the step-size rule sub-steps from the first tick."""
    spin = np.array([2.0, 0.3, -0.2])

    def run(m=None):
        return simulate(BODY, quat.identity(), spin, 20.0, controller=UserPD(period=0.5), engine="python", dt=0.5)

    with pytest.warns(UserWarning, match="sub-stepped"):
        fast = run()
    with monkeypatch.context() as m, pytest.warns(UserWarning, match="sub-stepped"):
        m.setattr(pt.TickRunner, "__init__", _reference_init)
        slow = run(m)
    assert fast.info["step_rule"]["most_substeps_per_tick"] > 1
    assert fast.info["step_rule"] == pytest.approx(slow.info["step_rule"], rel=1e-12)
    np.testing.assert_allclose(fast.q, slow.q, atol=1e-13)


def test_the_compiled_rule_keeps_the_python_rules_running_sums():
    """The C tick's rule sums equal TickRule.calls stepped by hand on the same states and torques."""
    model = PlantModel(WHEELS.hub_body(BODY), WHEELS)
    result = simulate(
        BODY, quat.identity(), np.array([0.05, -0.04, 0.02]), 30.0, controller=UserPD(), wheels=WHEELS, engine="python"
    )
    n_ticks = result.t.size - 1
    rule = TickRule(model, 0.1, n_ticks, 1, result.info["step_rule"]["budget_rad"])
    for k in range(n_ticks):
        assert rule.calls(k, result.omega[k], result.h_wheels[k], result.torque_applied[k]) == 1
    # Same arithmetic on floats (Python) and in C from the same inputs: rounding only.
    assert result.info["step_rule"]["predicted_error_rad"] == pytest.approx(
        rule.info()["predicted_error_rad"], rel=1e-12
    )


def test_a_controller_that_changes_its_estimate_in_place_does_not_change_the_record():
    """A user's law may normalise or edit what it is handed (it could before the compiled tick): the run's
    record is the plant's state, not the arrays handed over."""

    class Meddler(UserPD):
        def torque(self, t, estimate):
            tau = super().torque(t, estimate)
            estimate.q[:] = estimate.q / 2.0  # in place, after use
            estimate.omega[:] = 1e3
            return tau

    meddled, plain = fly(Meddler(), wheels=None), fly(UserPD(), wheels=None)
    np.testing.assert_array_equal(meddled.q, plain.q)
    np.testing.assert_array_equal(meddled.omega, plain.omega)


def test_a_controller_editing_its_estimate_does_not_change_what_the_disturbance_reads():
    """With a rate-dependent disturbance the truth is built every tick: the controller's estimate is its own
    copy, so zeroing its rate in place leaves the disturbance's rate (and so the trajectory) unchanged."""

    class Zeroing(UserPD):
        def torque(self, t, estimate):
            tau = super().torque(t, estimate)
            estimate.omega[:] = 0.0
            return tau

    def drag(t, q, omega):
        return -1e-3 * np.asarray(omega)

    edited, plain = fly(Zeroing(), disturbance=drag), fly(UserPD(), disturbance=drag)
    np.testing.assert_array_equal(edited.omega, plain.omega)


def test_the_protocol_path_equals_a_plain_numpy_loop_of_the_plant():
    """An independent loop: the plant's hold step evaluated by numpy on floats (PlantModel.hold_step, the
    definition the C tick is generated from, not the generated code), the command held over two ticks and a
    constant disturbance added, against the engine's run: rounding only (1e-12 rad over 60 s)."""
    law = UserPD(period=0.2)
    disturbance = np.array([1e-4, -2e-4, 5e-5])
    run = fly(law, wheels=None, disturbance=disturbance, dt=0.1)
    model = PlantModel(BODY, None)
    x = np.concatenate([quat.identity(), [0.01, -0.02, 0.005]])
    reference = [x]
    from attitude.simulation.protocols import Estimate

    fresh = UserPD(period=0.2)
    for k in range(run.t.size - 1):
        if k % 2 == 0:
            tau = fresh.torque(k * 0.1, Estimate(k * 0.1, x[:4], x[4:7]))
        x = np.array(model.hold_step(list(x), list(tau), list(disturbance), 0.1, 1), dtype=float)
        reference.append(x)
    reference = np.array(reference)
    np.testing.assert_allclose(run.q, reference[:, :4], rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.omega, reference[:, 4:7], rtol=0, atol=1e-12)


def test_a_non_finite_command_is_named_with_the_controller():
    class Broken(UserPD):
        def torque(self, t, estimate):
            return np.array([np.nan, 0.0, 0.0]) if t > 1.0 else super().torque(t, estimate)

    with pytest.raises(ValueError, match=r"controller\.torque\(t, estimate\)"):
        fly(Broken())


def test_a_command_of_the_wrong_shape_is_refused_not_broadcast():
    class Scalar(UserPD):
        def torque(self, t, estimate):
            return np.float64(0.1)

    with pytest.raises(ValueError, match=r"controller\.torque\(t, estimate\) must have shape"):
        fly(Scalar())


def test_a_blowing_up_loop_is_reported_with_the_time():
    class Unstable(UserPD):
        def torque(self, t, estimate):
            return 1e6 * estimate.omega  # positive rate feedback: the rates grow without bound

    with pytest.raises(SimulationDivergedError, match="became non-finite at t ="):
        fly(Unstable(), wheels=None, duration=600.0, attitude_error_budget_rad=np.inf)


def test_without_a_c_compiler_the_engine_runs_the_reference_path(monkeypatch):
    """No compiler on the machine: the same casadi function in casadi's VM, same trajectory."""
    from attitude.simulation import codegen

    fast = fly(UserPD(), wheels=None, duration=20.0)
    monkeypatch.setattr(codegen, "find_compiler", lambda: None)
    monkeypatch.setattr(pt, "_TICKS", pt.BuildCache(16))
    slow = fly(UserPD(), wheels=None, duration=20.0)
    assert "no C compiler" in slow.info["protocol_tick"] and "not available" in slow.info["protocol_tick"]
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-13)

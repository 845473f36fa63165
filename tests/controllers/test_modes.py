"""Mode sequences (controllers.modes): switching on conditions, timeouts, the timeline and a flown sequence.

* Logic, on a scripted stream of estimates: a condition must hold without a break for its hold time
  (a break restarts the clock), ``After`` counts from the mode's entry, a timeout switches and says so,
  the last mode is never left; the torque and dipole laws of the active mode only are called.
* Flown: B-dot (truth field) then an inertial hold on the wheels; the switch time is checked against the
  truth's own rate history (the rate below the threshold for the hold time just before it), the logged mode
  against ``mode_at``, and the error to each mode's reference is NaN where the mode has none.
* Bad input: errors name the mode and the rule.
"""

import numpy as np
import pytest

from attitude import ReactionWheels, RigidBody, simulate
from attitude.actuators import Magnetorquers
from attitude.environment import CircularOrbit, OrbitEnvironment
from attitude.simulation.protocols import Estimate
from controllers import BDotController, bdot_gain
from controllers.guidance import GuidanceController, InertialReference
from controllers.modes import After, Mode, ModeSequence, PointingWithin, RateBelow


class _Law:
    """A torque or dipole law that records its calls and returns a constant."""

    def __init__(self, value, period=1.0):
        self.value, self.period, self.calls = np.asarray(value, dtype=float), period, []

    def torque(self, t, estimate):
        self.calls.append(t)
        return self.value

    def dipole(self, t, measurements):
        self.calls.append(t)
        return self.value

    def reference(self, t):
        return np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3)


def _estimate(t, rate, q=(1.0, 0.0, 0.0, 0.0)):
    return Estimate(t=t, q=np.asarray(q, dtype=float), omega=np.array([rate, 0.0, 0.0]))


def test_a_condition_must_hold_for_its_hold_time_without_a_break():
    first, second = _Law([1.0, 0.0, 0.0]), _Law([0.0, 2.0, 0.0])
    seq = ModeSequence([Mode("a", first, until=RateBelow(0.1, hold_s=3.0)), Mode("b", second)], period=1.0)
    rates = [0.5, 0.05, 0.05, 0.5, 0.05, 0.05, 0.05, 0.05, 0.05]  # below at 1-2, broken at 3, below from 4
    torques = [seq.torque(float(t), _estimate(float(t), r)) for t, r in enumerate(rates)]
    # Below since t = 4: held 3 s at t = 7, so mode "b" from the sample at t = 7 on.
    assert [s.t for s in seq.switches] == [7.0]
    assert seq.switches[0].reason == "rate < 5.73 deg/s for 3 s"
    np.testing.assert_array_equal(torques[6], [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(torques[7], [0.0, 2.0, 0.0])
    assert first.calls == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0] and second.calls == [7.0, 8.0]
    assert seq.log() == {"mode": 1.0}
    np.testing.assert_array_equal(seq.mode_at([0.0, 6.9, 7.0, 100.0]), [0, 0, 1, 1])


def test_after_counts_from_entry_and_a_timeout_switches_and_says_so():
    seq = ModeSequence(
        [
            Mode("wait", until=After(2.0)),
            Mode("never", _Law([0.0, 0.0, 1.0]), until=RateBelow(1e-9), timeout_s=5.0),
            Mode("last"),
        ],
        period=1.0,
    )
    for t in range(12):
        seq.torque(float(t), _estimate(float(t), 1.0))
    assert [(s.t, s.to_mode) for s in seq.switches] == [(2.0, "never"), (7.0, "last")]
    assert seq.switches[1].reason.startswith("timeout after 5 s")
    rows = seq.timeline(12.0)
    assert [(r["mode"], r["start_s"], r["end_s"]) for r in rows] == [("wait", 0.0, 2.0), ("never", 2.0, 7.0),
                                                                    ("last", 7.0, 12.0)]  # fmt: skip
    assert rows[-1]["left_because"] is None
    # A mode without a torque law commands nothing; its dipole side too.
    np.testing.assert_array_equal(seq.torque(12.0, _estimate(12.0, 1.0)), np.zeros(3))
    np.testing.assert_array_equal(seq.dipole_law.dipole(12.0, {}), np.zeros(3))


def test_pointing_within_reads_the_mode_controllers_reference():
    law = _Law([0.0, 0.0, 0.0])
    seq = ModeSequence([Mode("point", law, until=PointingWithin(np.radians(1.0))), Mode("done")], period=1.0)
    off = np.array([np.cos(np.radians(1.0)), np.sin(np.radians(1.0)), 0.0, 0.0])  # 2 deg from the reference
    seq.torque(0.0, _estimate(0.0, 0.0, q=off))
    assert not seq.switches
    seq.torque(1.0, _estimate(1.0, 0.0))
    assert [s.to_mode for s in seq.switches] == ["done"]


def test_bad_sequences_are_refused_naming_the_mode():
    with pytest.raises(ValueError, match="non-empty sequence of Mode"):
        ModeSequence([], period=1.0)
    with pytest.raises(ValueError, match="distinct"):
        ModeSequence([Mode("a", until=After(1.0)), Mode("a")], period=1.0)
    with pytest.raises(ValueError, match="mode 'a' has no until"):
        ModeSequence([Mode("a"), Mode("b")], period=1.0)
    with pytest.raises(ValueError, match="last mode 'b' is never left"):
        ModeSequence([Mode("a", until=After(1.0)), Mode("b", until=After(1.0))], period=1.0)
    with pytest.raises(ValueError, match=r"mode 'a': its law samples every 0\.5 s"):
        ModeSequence([Mode("a", _Law([0, 0, 0], period=0.5), until=After(1.0)), Mode("b")], period=1.0)
    with pytest.raises(ValueError, match="mode 'p': PointingWithin needs a controller with reference"):
        Mode("p", until=PointingWithin(0.1))
    with pytest.raises(ValueError, match="rate_rad_s"):
        RateBelow(-1.0)


def test_a_flown_sequence_switches_when_the_truth_says_it_should():
    body = RigidBody(np.diag([0.30, 0.35, 0.21]))
    orbit = CircularOrbit.from_altitude(500e3, inclination=np.radians(97.4))
    rods = Magnetorquers.orthogonal(dipole_max_Am2=0.2)
    bdot = BDotController(bdot_gain(orbit, body), period=1.0, magnetorquers=rods, use_truth_field=True)
    hold = GuidanceController(InertialReference([1.0, 0.0, 0.0, 0.0]), body, wn=0.05, zeta=0.9, period=1.0)
    threshold, hold_s = np.radians(0.5), 30.0
    seq = ModeSequence(
        [Mode("detumble", dipole_controller=bdot, until=RateBelow(threshold, hold_s=hold_s)), Mode("hold", hold)],
        period=1.0,
    )
    run = simulate(
        body,
        [1.0, 0.0, 0.0, 0.0],
        np.radians([0.6, -0.4, 0.5]),
        1500.0,
        controller=seq,
        dipole_controller=seq.dipole_law,
        wheels=ReactionWheels.pyramid(spin_inertia=2e-5, torque_max=2e-3, momentum_max=0.02),
        magnetorquers=rods,
        environment=OrbitEnvironment(orbit, sources=()),
        dt=1.0,
        substeps=4,
    )
    assert len(seq.switches) == 1
    t_switch = seq.switches[0].t
    rate = np.linalg.norm(run.omega, axis=1)
    # The controller sees the truth: below the threshold at every sample of the hold before the switch, and
    # not over any earlier hold-long window.
    window = (run.t >= t_switch - hold_s) & (run.t <= t_switch)
    assert np.all(rate[window] < threshold)
    earlier = run.t < t_switch - hold_s
    assert np.any(rate[earlier] >= threshold) or not np.any(earlier)
    below = rate < threshold
    first_run_start = next(k for k in range(len(below)) if all(below[k : k + int(hold_s) + 1]))
    assert run.t[first_run_start] + hold_s == pytest.approx(t_switch)
    # The logged mode is mode_at; no reference while detumbling (NaN error), the hold's error after.
    logged = run.logs["controller.mode"].reshape(-1)
    sampled = np.isfinite(logged)
    np.testing.assert_array_equal(logged[sampled], seq.mode_at(run.t[sampled]))
    assert np.all(np.isnan(run.error_angle[run.t < t_switch]))
    assert np.all(np.isfinite(run.error_angle[run.t >= t_switch]))
    assert np.degrees(run.error_angle[-1]) < 0.05  # the hold settles (wn = 0.05 rad/s: ~ 100 s)


def test_a_sequence_flown_without_its_magnetic_side_says_so():
    # A new user's trial: forgetting dipole_controller=sequence.dipole_law left B-dot unflown, silently.
    seq = ModeSequence([Mode("detumble", dipole_controller=_Law([0.1, 0.0, 0.0]), until=After(10.0)), Mode("b")],
                       period=1.0)  # fmt: skip
    with pytest.warns(UserWarning, match="dipole_controller=sequence.dipole_law"):
        for t in range(5):
            seq.torque(float(t), _estimate(float(t), 1.0))
    seq.prepare(0.0, [1.0, 0.0, 0.0, 0.0], np.zeros(3))
    with pytest.warns(UserWarning, match="pass controller=sequence"):
        for t in range(5):
            seq.dipole_law.dipole(float(t), {})


def test_a_mode_law_without_its_method_and_a_timeout_inside_the_hold_are_refused():
    class NoTorque:
        period = 1.0

    with pytest.raises(ValueError, match="mode 'x': controller must have period and torque"):
        Mode("x", controller=NoTorque(), until=After(1.0))
    with pytest.raises(ValueError, match="mode 'x': dipole_controller must have period and dipole"):
        Mode("x", dipole_controller=NoTorque(), until=After(1.0))
    with pytest.raises(ValueError, match="timeout_s must exceed the condition's hold_s"):
        Mode("x", until=RateBelow(0.1, hold_s=100.0), timeout_s=10.0)


def test_the_active_laws_logs_are_kept_under_their_mode():
    # A new user's trial: B-dot's own logs (dipole, field rate) vanished inside a sequence.
    body = RigidBody(np.diag([0.30, 0.35, 0.21]))
    orbit = CircularOrbit.from_altitude(500e3, inclination=np.radians(97.4))
    rods = Magnetorquers.orthogonal(dipole_max_Am2=0.2)
    bdot = BDotController(bdot_gain(orbit, body), period=1.0, magnetorquers=rods, use_truth_field=True)
    seq = ModeSequence([Mode("detumble", dipole_controller=bdot, until=After(20.0)), Mode("idle")], period=1.0)
    run = simulate(body, [1.0, 0.0, 0.0, 0.0], np.radians([1.0, -1.0, 0.5]), 40.0, controller=seq,
                   dipole_controller=seq.dipole_law, magnetorquers=rods,
                   environment=OrbitEnvironment(orbit, sources=()), dt=1.0)  # fmt: skip
    dipole = run.logs["dipole_controller.detumble.dipole_B"]
    assert dipole.shape == (run.t.size, 3)
    during, after = run.t < 20.0, run.t > 20.0
    assert np.all(np.isfinite(dipole[during][1:])) and np.any(dipole[during] != 0.0)
    assert np.all(np.isnan(dipole[after]))  # the law is not active after the switch


def test_only_an_all_nan_reference_means_none_a_broken_one_is_refused():
    # The engine logs NaN error where a controller has no reference (an all-NaN q_ref row, as a sequence's
    # detumbling mode); a partly non-finite reference is a bug, refused as before the convention.
    class Broken:
        period = 1.0

        def torque(self, t, estimate):
            return np.zeros(3)

        def reference(self, t):
            return np.array([np.nan, 0.0, 0.0, 0.0]), np.zeros(3)

    with pytest.raises(ValueError, match="q_ref must be finite, or all NaN"):
        simulate(RigidBody([1.0, 1.2, 0.9]), [1.0, 0.0, 0.0, 0.0], np.zeros(3), 3.0, controller=Broken(), dt=1.0)

"""The held-attitude momentum budget (issue #11) against exact relations and the closed loop.

* Without unloading, for a nadir hold on a circular orbit (omega_ref = [0, -n, 0] constant), the
  pitch component of dh/dt = tau - omega x h is exactly tau_y: the pitch wheel momentum after N
  orbits is the integral of the pitch disturbance (Wertz, *Spacecraft Attitude Determination and
  Control*, 1978, sec. 19.1; Markley and Crassidis 2014, sec. 7.5: the secular build-up is the
  orbit-averaged torque along the orbit normal). The averaged torque is computed here from
  ``OrbitEnvironment.torques_B`` by an independent quadrature.
* With the cross-product law (m = k dh x B / |B|^2) the momentum stays bounded.
* The budget agrees with the engine's closed loop (NadirPointing + wheels, compiled) over one orbit
  within the effect of the pointing error, bounded from the run itself.
"""

import numpy as np
import pytest

from attitude import RigidBody
from attitude.actuators import Magnetorquers, ReactionWheels
from attitude.environment.momentum_budget import held_attitude_momentum
from attitude.environment.orbit import CircularOrbit
from attitude.environment.orbit_environment import OrbitEnvironment
from attitude.environment.surface import SurfaceModel
from attitude.simulation.engine import simulate
from controllers import CrossProductUnloading, NadirPointing

BODY = RigidBody([[10.0, 0.2, -0.1], [0.2, 12.0, 0.3], [-0.1, 0.3, 8.0]])
ORBIT = CircularOrbit.from_altitude(450e3, inclination=np.radians(97.4))
N = ORBIT.mean_motion
# A centre of pressure 5 cm behind the centre of mass along yaw: drag gives a secular pitch torque;
# the product of inertia I_xz gives a secular gravity-gradient pitch torque 3 n^2 I_xz.
SURFACE = SurfaceModel.box([1.0, 1.0, 1.5], centre_of_pressure_offset_B_m=[0.0, 0.0, 0.05])
DT = 10.0
# Track grid at the budget's step: the torques turn at 2n, chord error (2n dt)^2 / 8 = 1e-4 of
# the torque, the same on both sides of the comparisons below (they share the track).
ENV = OrbitEnvironment(ORBIT, surface=SURFACE, sources=("gravity_gradient", "aerodynamic"), sample_period=DT)
MTQ = Magnetorquers.orthogonal(dipole_max_Am2=1.0)
ORBITS = 20


def _law(gain=1e-3):
    law = CrossProductUnloading(gain, period=1.0, magnetorquers=MTQ, use_truth_field=True)
    return lambda B, h: np.array([float(v) for v in law.dipole_components(list(B), list(h), [0.0, 0.0, 0.0])])


@pytest.fixture(scope="module")
def budgets():
    t = np.arange(0.0, ORBITS * ORBIT.period, DT)
    q = ORBIT.q_LN(t)
    free = held_attitude_momentum(ENV, BODY, t, q, [0.0, -N, 0.0])
    unloaded = held_attitude_momentum(ENV, BODY, t, q, [0.0, -N, 0.0], dipole_law=_law())
    return t, free, unloaded


def test_without_unloading_pitch_momentum_grows_at_the_averaged_disturbance(budgets):
    t, free, _ = budgets
    tau = ENV.torques_B(BODY, ORBIT.q_LN(t), ENV.track(t))
    tau_y = sum(v[:, 1] for v in tau.values())
    # Independent quadrature (trapezoid; Simpson in the budget): error (2n dt)^2 / 12 = 4e-5 relative.
    predicted = np.concatenate([[0.0], np.cumsum(0.5 * (tau_y[1:] + tau_y[:-1]) * DT)])
    final = predicted[-1]
    assert abs(final) > 0.1  # N m s after 20 orbits: a real secular build-up
    assert np.abs(free.h_wheels_B[:, 1] - predicted).max() < 1e-4 * abs(final)
    # Linear: the orbit-averaged pitch torque times the time, within the cyclic part.
    rate = np.mean(tau_y)
    assert free.secular_rate_B[1] == pytest.approx(rate, rel=1e-3)
    per_orbit = round(ORBIT.period / DT)
    boundaries = free.h_wheels_B[::per_orbit, 1]
    line = rate * t[::per_orbit]
    # Residual from the line: the cyclic part at whole orbits (the grid's 10 s phase slip per orbit
    # times the torque, 7e-5 N m s) against 0.14 N m s of build-up.
    assert np.abs(boundaries - line).max() < 1e-3 * abs(final)


def test_with_cross_product_unloading_momentum_stays_bounded(budgets):
    _, free, unloaded = budgets
    per_orbit = round(ORBIT.period / DT)
    peaks = np.array(
        [np.linalg.norm(unloaded.h_wheels_B[k * per_orbit : (k + 1) * per_orbit], axis=-1).max() for k in range(ORBITS)]
    )
    # Bounded: the last ten orbits peak no higher than the first ten (the law's time constant is
    # 1 / k = 1000 s, well inside an orbit), and far below the unloaded build-up.
    assert peaks[10:].max() <= 1.05 * peaks[:10].max()
    assert peaks.max() < 0.1 * free.peak_B
    assert np.abs(unloaded.dipole).max() <= 1.0 + 1e-12


def test_budget_agrees_with_the_closed_loop_over_one_orbit():
    env = OrbitEnvironment(ORBIT, surface=SURFACE, sources=("gravity_gradient", "aerodynamic"))
    wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8)
    ctl = NadirPointing(ORBIT, BODY, wn=0.1, zeta=0.7, period=1.0)
    r = simulate(
        BODY,
        ORBIT.q_LN(0.0),
        [0.0, -N, 0.0],
        np.ceil(ORBIT.period),
        controller=ctl,
        wheels=wheels,
        environment=env,
        dt=1.0,
        engine="compiled",
    )
    h_rel = (r.wheel_speed * wheels.spin_inertia) @ wheels.axes_B  # wheels relative to the body
    held = held_attitude_momentum(env, BODY, r.t, ORBIT.q_LN(r.t), [0.0, -N, 0.0], h_wheels0_B=h_rel[0])
    diff = np.abs(h_rel - held.h_wheels_B).max()
    # Tolerance from the pointing error theta and the rate error dw of the run itself:
    # h = R^T H - I w differs by |H| theta (H seen from axes off by theta, factor 2 for the
    # quaternion's small-angle sign) + I_max |dw| + the torques' change, at most 2 |tau| theta
    # (quadratic in the body vectors), integrated over the orbit.
    theta = r.error_angle.max()
    dw = np.linalg.norm(r.omega - [0.0, -N, 0.0], axis=-1).max()
    tau = np.linalg.norm(sum(r.disturbance_torques.values()), axis=-1).max()
    bound = (
        2.0 * np.linalg.norm(r.momentum_N, axis=-1).max() * theta
        + np.linalg.eigvalsh(BODY.inertia).max() * dw
        + 2.0 * tau * theta * r.t[-1]
    )
    assert np.abs(held.h_wheels_B).max() > 100.0 * bound  # the build-up dwarfs the bound
    assert diff < bound, (diff, bound)


def test_closed_loop_unloading_cross_check():
    # Two orbits of the compiled closed loop: without unloading the pitch wheel momentum follows
    # the integrated logged pitch torque (exact relation, as above); with unloading it stays small.
    env = OrbitEnvironment(ORBIT, surface=SURFACE, sources=("gravity_gradient", "aerodynamic"))
    wheels = ReactionWheels.pyramid(spin_inertia=0.005, torque_max=0.05, momentum_max=0.8)
    ctl = NadirPointing(ORBIT, BODY, wn=0.1, zeta=0.7, period=1.0)
    law = CrossProductUnloading(1e-3, period=1.0, magnetorquers=MTQ, use_truth_field=True)
    kw = dict(controller=ctl, wheels=wheels, environment=env, dt=1.0, engine="compiled")
    duration = 2.0 * np.ceil(ORBIT.period)
    free = simulate(BODY, ORBIT.q_LN(0.0), [0.0, -N, 0.0], duration, **kw)
    unl = simulate(BODY, ORBIT.q_LN(0.0), [0.0, -N, 0.0], duration, magnetorquers=MTQ, dipole_controller=law, **kw)
    h_free = (free.wheel_speed * wheels.spin_inertia) @ wheels.axes_B
    h_unl = (unl.wheel_speed * wheels.spin_inertia) @ wheels.axes_B
    tau_y = sum(v[:, 1] for v in free.disturbance_torques.values())
    integral = np.sum(tau_y[:-1]) * 1.0
    # Pitch momentum = integral of the held pitch torque, up to the pointing-error terms (5e-5 N m s
    # from the one-orbit test's bound) against a 0.08 N m s build-up.
    assert h_free[-1, 1] - h_free[0, 1] == pytest.approx(integral, abs=1e-4)
    assert abs(integral) > 0.05
    assert np.linalg.norm(h_unl[-1]) < 0.1 * np.linalg.norm(h_free[-1])


def test_progress_reports_each_unloading_step_and_changes_no_number(monkeypatch):
    """With every report let through (no wait between reports), the callback sees ``k / (n - 1)`` before
    RK4 step ``k`` of the unloading run; the momentum is the same bits as without it."""
    import attitude.progress

    monkeypatch.setattr(attitude.progress, "REFRESH_PERIOD_S", 0.0)
    t = np.arange(0.0, 0.2 * ORBIT.period, DT)
    q = ORBIT.q_LN(t)
    reference = held_attitude_momentum(ENV, BODY, t, q, [0.0, -N, 0.0], dipole_law=_law())
    fractions: list[float] = []
    reported = held_attitude_momentum(ENV, BODY, t, q, [0.0, -N, 0.0], dipole_law=_law(), progress=fractions.append)
    np.testing.assert_array_equal(reported.h_wheels_B, reference.h_wheels_B)
    np.testing.assert_array_equal(reported.dipole, reference.dipole)
    assert fractions == [k / (t.size - 1) for k in range(t.size - 1)]

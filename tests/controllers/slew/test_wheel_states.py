"""Slews with the wheel momenta as states (controllers.slew.wheel_states): polytope, speed limit, conservation.

What each test checks against:

* The torque polytope: every vertex ``-A u`` (``u_i = +-torque_max``) of a four-wheel pyramid
  lies in ``|rows @ tau| <= 1`` with a vertex on each facet (the set is exactly the zonotope),
  and the guaranteed box's corners are inside it.
* Faster than the box and the allocation envelope: on a slew about body x the zonotope reaches
  twice the largest box the wheels guarantee in every direction, so the wheel-state plan must be
  faster than the box plan by far more than the grid error; on a slew about the direction of the
  vertex ``u = (1, 1, 1, -1) torque_max`` the minimum-norm allocation reaches only 2/3 of the
  zonotope (the vertex has a null-space part of 1/2), so the plan must beat the allocation plan.
* Independent re-simulation: the plan's motor torques flown by scipy's RK45 on
  :meth:`ReactionWheels.state_derivative_components` (numpy, not the NLP's casadi RK4 step) reach
  the target, and every motor torque and wheel momentum stays within its limit.
* The momentum limit binds: a wheel set with a small ``momentum_max`` is slower than the same
  wheels with a large one, its wheels reach the limit and never exceed it.
* Minimum energy: no dearer than a feasible slew of the same duration (the minimum-time plan, then
  rest); a duration below the minimum time is infeasible.
* Conservation: with non-zero initial wheel momenta the total inertial angular momentum
  ``C_NB (I_s omega + A h)`` of the re-simulated slew stays constant (no external torque) while
  its body components turn with the body.
* Pontryagin's minimum principle on the motor torques (Bryson and Ho, 1975, sec. 3.9: free final
  time, ``H = 1 + lambda . f = 0``; a box ``|u_i| <= u_max`` gives ``u_i = -u_max sign(sigma_i)``
  with ``sigma = (df/du)^T lambda``): small on the pyramid's minimum-time slews, and the plan of
  wheels with 0.6 times the torque, checked against the full wheels, disagrees on every decided
  (interval, wheel) pair.
* The optimiser's torques within IPOPT's bound relaxation: a relaxation widened to 1e-3 lets the
  bang-bang torques out by far more than TORQUE_BOUND_TOLERANCE and the planner refuses them.
* Bad input named by argument (DESIGN.md).
"""

import itertools
import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from controllers.slew import InfeasibleSlewError, KeepOutCone, SlewPlanningError, plan_slew
from controllers.slew.wheel_states import (
    TORQUE_BOUND_TOLERANCE,
    wheel_pontryagin_check,
    wheel_torque_box,
    wheel_torque_rows,
)

TORQUE_MAX = 0.05  # N m per wheel
SPIN_INERTIA = 0.01  # kg m^2
NODES = 30
BODY = RigidBody(np.diag([10.0, 12.0, 8.0]))
Q0 = np.array([1.0, 0.0, 0.0, 0.0])


def pyramid(momentum_max: float = 10.0) -> ReactionWheels:
    return ReactionWheels.pyramid(spin_inertia=SPIN_INERTIA, torque_max=TORQUE_MAX, momentum_max=momentum_max)


def resimulate(plan, h0):
    """The plan's motor torques flown by RK45 on the numpy wheel model; states at 8 points per interval."""
    wheels = plan.wheels()
    hub = wheels.hub_body(RigidBody(plan.inertia))
    x = np.concatenate([plan.q[0], plan.omega[0], h0])
    out = [x]
    for k in range(plan.t.size - 1):
        u = list(plan.wheel_torque[k])
        sol = solve_ivp(
            lambda _t, y, u=u: np.array(wheels.state_derivative_components(hub, list(y), u), dtype=float),
            (plan.t[k], plan.t[k + 1]),
            x,
            t_eval=np.linspace(plan.t[k], plan.t[k + 1], 9)[1:],
            rtol=1e-10,
            atol=1e-12,
        )
        out.extend(sol.y.T)
        x = sol.y[:, -1]
    x = np.array(out)
    return quat.normalize(x[:, :4]), x[:, 4:7], x[:, 7:], hub, wheels


def check_resimulation(plan, h0):
    """Target reached and every wheel within its limits on the independent re-simulation."""
    q, omega, h, _, wheels = resimulate(plan, h0)
    # The plan's own verification accepts 1e-4 rad; RK45 at rtol 1e-10 adds far less than that.
    assert quat.error_angle(plan.q_target, q[-1]) < 1e-4
    assert np.linalg.norm(omega[-1] - plan.omega_target) < 1e-4 / plan.info["scaling"]["time_s"]
    # The optimiser's torques (before the plan clips them onto their bounds) within IPOPT's bound relaxation.
    assert plan.info["verification"]["torque_ratio_max"] <= 1.0 + TORQUE_BOUND_TOLERANCE
    relative = wheels.spin_inertia * wheels.wheel_speed(h, omega)
    # Between checkpoints the momentum may pass the limit by the RK4 transcription error: 1e-6 relative.
    assert np.all(np.abs(relative) <= wheels.momentum_max * (1 + 1e-6))
    return q, omega, h, relative


def test_rows_are_the_zonotope():
    """Every vertex of {-A u : |u| <= u_max} is inside the rows' set and each facet holds a vertex."""
    wheels = pyramid()
    rows = wheel_torque_rows(wheels)
    vertices = np.array([wheels.body_torque(np.array(s) * TORQUE_MAX) for s in itertools.product([-1, 1], repeat=4)])
    ratio = np.abs(vertices @ rows.T)
    assert np.max(ratio) == pytest.approx(1.0, abs=1e-12)
    assert np.allclose(np.max(ratio, axis=0), 1.0, atol=1e-12)  # every facet touched: no row is loose
    box = wheel_torque_box(wheels)
    corners = np.array(list(itertools.product([-1, 1], repeat=3))) * box
    assert np.max(np.abs(corners @ rows.T)) == pytest.approx(1.0, abs=1e-12)
    # By hand (elevation b = atan(1 / sqrt(2)), so cos(b) cos(45 deg) = sin(b) = 1 / sqrt(3)): along body x the
    # zonotope reaches sum_i |A_xi| u_max = 4 u_max / sqrt(3); the vertex u = (1, 1, 1, -1) u_max gives the torque
    # 2 u_max / sqrt(3) (1, -1, -1), a corner of the cube of half-width 2 u_max / sqrt(3): half the reach about x.
    assert box == pytest.approx(np.full(3, 2.0 * TORQUE_MAX / np.sqrt(3.0)), rel=1e-12)
    assert np.abs(wheels.distribution) @ wheels.torque_max == pytest.approx(np.full(3, 4.0 * TORQUE_MAX / np.sqrt(3.0)))


def test_faster_than_box_and_allocation():
    """The wheel-state plan beats the guaranteed box (slew about x) and the allocation envelope (vertex axis)."""
    wheels = pyramid()
    qf = quat.from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)
    plan = plan_slew(BODY, Q0, qf, torque_max=wheels, wheel_states=True, nodes=NODES)
    box = plan_slew(BODY, Q0, qf, torque_max=wheel_torque_box(wheels), nodes=NODES, refine=False)
    # Twice the torque about the slew axis: about sqrt(2) faster; the grid error is a few T / NODES (3 %).
    assert plan.duration < 0.8 * box.duration
    check_resimulation(plan, np.zeros(4))
    axis = wheels.body_torque(np.array([1.0, 1.0, 1.0, -1.0]))
    qf = quat.from_axis_angle(axis / np.linalg.norm(axis), np.pi / 2)
    plan = plan_slew(BODY, Q0, qf, torque_max=wheels, wheel_states=True, nodes=NODES)
    allocation = plan_slew(BODY, Q0, qf, torque_max=wheels, nodes=NODES, refine=False)
    # 1.5 times the allocation's torque along the axis: about 1/sqrt(1.5) = 0.82 of its time.
    assert plan.duration < 0.9 * allocation.duration
    _, _, _, relative = check_resimulation(plan, np.zeros(4))
    assert np.max(np.abs(plan.wheel_torque)) == pytest.approx(TORQUE_MAX)  # bang-bang: the wheels at their limit
    assert np.max(np.abs(relative)) < 0.2 * wheels.momentum_max[0]  # the momentum limit is far away here
    # An extremal: measured max |H| 3.6e-3 (n max |H| 0.11 against the wheel plans' 10), the mean 1e-8 (free
    # final time: H = 0, not just constant), no torque against the switching function; headline 0.011.
    check = plan.info["pontryagin"]
    assert check["passes"] and not plan.optimality_flagged
    assert abs(check["hamiltonian_mean"]) < 1e-5 and check["hamiltonian_residual"] < 0.05
    assert check["switching_disagreement"] == 0.0 and check["switching_decided"] >= 50
    assert plan.pontryagin_residual < 0.1  # a decade below the flag at 1
    assert plan.costate.shape == (NODES + 1, 11)


def test_pontryagin_fails_for_the_plan_of_weaker_wheels():
    """Wheels of 0.6 times the torque: their plan is an extremal, checked against the full wheels it is not.

    Against the full box every decided wheel should be at +-0.05 N m and the plan gives +-0.03:
    all decided pairs disagree (headline 1 / 0.02 = 50); against its own wheels it passes. H alone
    cannot tell them apart (the same costates and torques: 2.4e-4 measured, under 10 / 30).
    """
    weaker = ReactionWheels.pyramid(spin_inertia=SPIN_INERTIA, torque_max=0.6 * TORQUE_MAX, momentum_max=10.0)
    qf = quat.from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)
    plan = plan_slew(BODY, Q0, qf, torque_max=weaker, wheel_states=True, nodes=NODES)
    assert plan.info["pontryagin"]["passes"] and plan.pontryagin_residual < 0.1
    args = (RigidBody(plan.inertia), pyramid(), plan.q, plan.omega, plan.wheel_momentum, plan.wheel_torque)
    wrong = wheel_pontryagin_check(*args, plan.costate, hamiltonian_tolerance=10.0 / NODES)
    assert wrong["hamiltonian_residual"] < 10.0 / NODES
    assert wrong["switching_decided"] >= 50 and wrong["switching_disagreement"] == 1.0
    assert wrong["residual"] > 10.0 and not wrong["passes"]


def test_torques_outside_ipopts_bound_relaxation_are_refused():
    """IPOPT's bound_relax_factor at 1e-3: bang-bang torques end up ~1e-3 past torque_max, and the plan is refused."""
    qf = quat.from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)
    with pytest.raises(SlewPlanningError, match=r"optimiser's wheel torque is 1\.00"):
        plan_slew(
            BODY,
            Q0,
            qf,
            torque_max=pyramid(),
            wheel_states=True,
            nodes=20,
            ipopt_options={"bound_relax_factor": 1e-3},
        )


def test_momentum_limit_binds():
    """A small momentum_max slows the slew; the wheels reach it and never exceed it on re-simulation."""
    qf = quat.from_axis_angle([1.0, 0.0, 0.0], np.pi / 2)
    free = plan_slew(BODY, Q0, qf, torque_max=pyramid(), wheel_states=True, nodes=NODES)
    limited = plan_slew(BODY, Q0, qf, torque_max=pyramid(0.2), wheel_states=True, nodes=NODES)
    assert limited.duration > 1.2 * free.duration
    _, _, _, relative = check_resimulation(limited, np.zeros(4))
    # The limit is reached (to IPOPT's tolerance) on the plan's nodes, so the wheel speed limit is what binds.
    assert np.max(np.abs(limited.wheel_relative_momentum)) == pytest.approx(0.2, rel=1e-6)
    assert np.max(np.abs(relative)) == pytest.approx(0.2, rel=1e-6)
    # Body-rate stand-in versus the real limit: the free plan's wheels exceed 0.2 N m s.
    assert np.max(np.abs(free.wheel_relative_momentum)) > 0.3


def test_total_momentum_conserved():
    """With initial wheel momenta the inertial total momentum is constant while it turns in the body."""
    h0 = np.array([0.08, -0.05, 0.03, 0.0])
    qf = quat.from_axis_angle([0.0, 1.0, 0.0], np.pi / 3)
    plan = plan_slew(BODY, Q0, qf, torque_max=pyramid(0.3), wheel_states=True, h_wheels0=h0, nodes=NODES)
    q, omega, h, _ = check_resimulation(plan, h0)
    wheels = plan.wheels()
    hub = wheels.hub_body(BODY)
    total_B = omega @ hub.inertia.T + h @ wheels.distribution.T
    total_N = quat.rotate(q, total_B)
    size = np.linalg.norm(total_N[0])
    # RK45 at rtol 1e-10 over ~100 steps: drift below 1e-8 of the momentum; the body components turn by 60 deg.
    assert np.max(np.linalg.norm(total_N - total_N[0], axis=1)) < 1e-8 * size
    assert np.linalg.norm(total_B[-1] - total_B[0]) > 0.5 * size
    assert np.allclose(plan.wheel_momentum[0], h0)


def test_minimum_energy_and_starts():
    """Minimum energy over 1.5 minimum times beats a feasible slew of that duration; too short is infeasible.

    The minimum-time plan followed by a rest at the target is a feasible slew of the longer duration with the
    minimum-time plan's energy, so the minimum-energy plan must cost no more (it costs about a quarter).
    """
    wheels = pyramid(0.3)
    qf = quat.from_axis_angle([0.0, 1.0, 0.0], np.pi / 3)
    fastest = plan_slew(BODY, Q0, qf, torque_max=wheels, wheel_states=True, nodes=NODES, starts=("eigenaxis", "random"))
    assert [s["family"] for s in fastest.info["starts"]] == ["eigenaxis", "random"]
    duration = 1.5 * fastest.duration
    cheapest = plan_slew(
        BODY, Q0, qf, torque_max=wheels, wheel_states=True, nodes=NODES, objective="energy", duration=duration
    )
    assert cheapest.duration == pytest.approx(duration, rel=1e-12)
    assert cheapest.objective_value < fastest.info["energy_n2m2s"]
    check_resimulation(cheapest, np.zeros(4))
    with pytest.raises(InfeasibleSlewError, match="admit no such slew"):
        plan_slew(
            BODY,
            Q0,
            qf,
            torque_max=wheels,
            wheel_states=True,
            nodes=NODES,
            objective="energy",
            duration=0.7 * fastest.duration,
        )


def test_friction_and_moving_ends():
    """Wheels with viscous and Coulomb friction, initial wheel momenta and a final rate: the re-simulation agrees.

    The NLP runs on the wheel set scaled to its units (friction included); a wrong scaling of a friction
    coefficient would leave the independent re-simulation (SI units) off the target by far more than 1e-4 rad.
    """
    wheels = ReactionWheels.pyramid(
        spin_inertia=SPIN_INERTIA,
        torque_max=TORQUE_MAX,
        momentum_max=0.3,
        viscous_friction=2e-3,
        coulomb_friction=2e-3,
        coulomb_smoothing_speed=5.0,
    )
    h0 = np.full(4, 0.02)
    qf = quat.from_axis_angle([1.0, 1.0, 0.0], 1.2)
    plan = plan_slew(BODY, Q0, qf, torque_max=wheels, wheel_states=True, nodes=NODES, h_wheels0=h0, omegaf=[0, 0, 0.01])
    check_resimulation(plan, h0)
    # Friction puts H's arcs further apart on a uniform grid (n max |H| 1.4 measured here), still an extremal.
    assert plan.info["pontryagin"]["passes"] and plan.info["pontryagin"]["switching_disagreement"] == 0.0


def test_figure_and_save(tmp_path):
    """The wheel figure draws both panels and a saved plan loads with its wheel histories."""
    qf = quat.from_axis_angle([1.0, 0.0, 0.0], np.pi / 4)
    plan = plan_slew(BODY, Q0, qf, torque_max=pyramid(0.2), wheel_states=True, nodes=20)
    fig = plan.plot_wheels()
    assert len(fig.axes) == 2
    loaded = type(plan).load(plan.save(tmp_path / "plan.npz"))
    assert np.array_equal(loaded.wheel_momentum, plan.wheel_momentum)
    assert np.array_equal(loaded.wheels().axes_B, plan.wheels().axes_B)
    fine = plan.resample(plan.duration / 100)
    # Resampled states lie on the planned trajectory: the nodes come back to the NLP's tolerance.
    assert np.allclose(fine.wheel_momentum[-1], plan.wheel_momentum[-1], atol=1e-7)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"h_wheels0": [0.5, 0.0, 0.0, 0.0]}, "h_wheels0[0]"),
        ({"h_wheels0": [0.0, 0.0, 0.0]}, "h_wheels0 must hold one momentum per wheel (4)"),
        ({"keep_out": [KeepOutCone([0, 0, 1], [0, 1, 0], 0.2)]}, "keep_out is not available"),
        ({"refine": True}, "refine is not available"),
        ({"smoothing": 0.1}, "smoothing is not available"),
        ({"workers": 2}, "workers is not available"),
        ({"wheel_states": "yes"}, "wheel_states must be True or False"),
    ],
)
def test_bad_input(kwargs, words):
    """Each bad input is refused before any solve, naming the argument."""
    args = {"torque_max": pyramid(0.2), "wheel_states": True, **kwargs}
    with pytest.raises(ValueError, match=re.escape(words)):
        plan_slew(BODY, Q0, quat.from_axis_angle([1.0, 0.0, 0.0], 0.5), **args)


def test_bad_input_other_arguments():
    """A box with wheel_states, h_wheels0 without it, and a final momentum the wheels cannot hold."""
    qf = quat.from_axis_angle([1.0, 0.0, 0.0], 0.5)
    with pytest.raises(ValueError, match="needs torque_max to be a ReactionWheels"):
        plan_slew(BODY, Q0, qf, torque_max=0.1, wheel_states=True)
    with pytest.raises(ValueError, match="h_wheels0 is only used with wheel_states=True"):
        plan_slew(BODY, Q0, qf, torque_max=pyramid(), h_wheels0=np.zeros(4))
    # At rest at the end the wheels must hold all of omegaf's momentum: 12 * 0.05 = 0.6 N m s about y,
    # more than four wheels of 0.05 N m s can (at most 4 cos(35.26 deg) sin(45 deg) 0.05 = 0.115 N m s).
    with pytest.raises(InfeasibleSlewError, match="no wheel momenta within momentum_max"):
        plan_slew(BODY, Q0, qf, torque_max=pyramid(0.05), wheel_states=True, omega0=[0.0, 0.05, 0.0])


def test_one_wheel_about_a_principal_axis_is_the_hand_derived_bang_bang():
    """Closed form, derived by hand, independent of the plant model: with the x and y wheels' torque a millionth
    of the z wheel's, a rest-to-rest turn by theta about the principal axis z is the single-axis bang-bang of the
    hub, I_s theta'' = -+ u_max with I_s = I_zz - J (the whole body minus the z wheel's spin inertia, which the
    wheel keeps to itself): T = 2 sqrt(theta I_s / u_max) = 28.8535 s. The plan matches to 1e-7 on 20 and 40
    nodes (the switch falls on the middle node: RK4 error only; measured 5e-9), and is 0.3 % away from the
    answer with the whole body's I_zz (28.9441 s), so a plant that forgot the wheel's spin inertia would fail."""
    body = RigidBody(np.diag([12.0, 10.0, 8.0]))
    spin_inertia, torque_max = 0.05, 0.02
    wheels = ReactionWheels.orthogonal(
        spin_inertia=spin_inertia, torque_max=[1e-6, 1e-6, torque_max], momentum_max=10.0
    )
    theta = np.radians(30.0)
    expected = 2.0 * np.sqrt(theta * (8.0 - spin_inertia) / torque_max)
    for nodes in (20, 40):
        plan = plan_slew(
            body,
            quat.identity(),
            quat.from_axis_angle([0, 0, 1], theta),
            torque_max=wheels,
            wheel_states=True,
            nodes=nodes,
        )
        assert plan.duration == pytest.approx(expected, rel=1e-7)
    assert abs(plan.duration / (2.0 * np.sqrt(theta * 8.0 / torque_max)) - 1.0) > 2e-3

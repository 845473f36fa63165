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
* Torque saturation modes (``torque_saturation``, "scale" and "clip"): allocations worked by hand
  for three orthogonal wheels and the 35.26 deg pyramid (``A^+ = 3/4 A^T`` there), with and without
  a wheel at its speed limit; numpy scalars, numpy arrays of runs and a casadi SX function agree;
  a closed loop whose opening command saturates flies differently in the two modes, the same on
  the python, compiled and vectorised paths; the mode is part of the wheels' pickle, repr and
  content identity, so a campaign checkpoint of one mode is refused by the other.
* Momentum exchange: conservation of the total angular momentum ``H_N = C_NB (I_s omega + A h)``
  under internal (motor and friction) torques, integrated independently with scipy's
  ``solve_ivp`` (DOP853, rtol 1e-12); the hub inertia is the total minus the wheels' spin-axis
  inertia ``sum J_i a_i a_i^T``.
"""

import pickle

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from attitude import RigidBody, simulate
from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.app.scenarios import PDWheelsScenario
from attitude.montecarlo.campaign import Campaign, run_campaign
from attitude.montecarlo.dispersions import Normal
from attitude.montecarlo.identity import scenario_identity
from attitude.simulation.batch import simulate_batch
from controllers.pd import QuaternionPD

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
            ({"torque_saturation": "clamp"}, r"torque_saturation must be one of \('scale', 'clip'\), got 'clamp'"),
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


# ---------------------------------------------------------------------------
# Torque saturation: one common scale or each motor clipped alone


def orthogonal(mode: str) -> ReactionWheels:
    # Wheel i on body axis i: u = -tau_c (A = I, body torque -A u), 0.1 N m, 1 N m s (100 rad/s).
    return ReactionWheels.orthogonal(spin_inertia=0.01, torque_max=0.1, momentum_max=1.0, torque_saturation=mode)


class TestTorqueSaturation:
    def test_clip_keeps_the_unsaturated_axes_and_scale_shrinks_all(self):
        """Only x saturates (0.3 N m against 0.1): clip keeps y and z as commanded, scale divides all by 3."""
        tau = np.array([0.3, 0.05, -0.02])
        rest = (np.zeros(3), np.zeros(3))
        clipped = orthogonal("clip").allocate(tau, *rest)
        scaled = orthogonal("scale").allocate(tau, *rest)
        # By hand: u = -tau, then wheel x at -0.1; the others are within their limit.
        np.testing.assert_array_equal(clipped, [-0.1, -0.05, 0.02])
        np.testing.assert_allclose(scaled, [-0.1, -0.05 / 3, 0.02 / 3], rtol=1e-15)
        # Within every limit the two modes are the same allocation.
        small = np.array([0.08, 0.05, -0.02])
        np.testing.assert_array_equal(
            orthogonal("clip").allocate(small, *rest), orthogonal("scale").allocate(small, *rest)
        )

    def test_pyramid_by_hand(self):
        """35.26 deg pyramid: ``a_i = [s_x, s_y, 1] / sqrt(3)`` with signs (+,+), (-,+), (-,-), (+,-).

        With ``A = S / sqrt(3)`` (``S`` the signs), ``A A^T = 4/3 I`` and ``u = -A^+ tau =
        -(sqrt(3)/4) S^T tau``; for ``tau = T [2, 0, 1]`` with ``T = 0.04/sqrt(3)``,
        ``S^T tau = T [3, -1, -1, 3]`` and ``u = [-0.03, 0.01, 0.01, -0.03]`` N m.
        Against 0.02 N m, scale multiplies all by 2/3 (the body torque ``2/3 tau``); clip cuts
        wheels 1 and 4 to -0.02 and keeps 0.01 on wheels 2 and 3, so the body torque
        ``-A u = [0.06, 0, 0.02] / sqrt(3)`` gains x and loses z.
        """
        wheels = {mode: pyramid(torque_saturation=mode) for mode in ("scale", "clip")}
        tau = 0.04 / np.sqrt(3.0) * np.array([2.0, 0.0, 1.0])
        rest = (np.zeros(4), np.zeros(3))
        # The pseudo-inverse and the axes carry rounding of a few 1e-17 N m.
        np.testing.assert_allclose(wheels["scale"].allocate(tau, *rest), [-0.02, 0.02 / 3, 0.02 / 3, -0.02], atol=1e-16)
        np.testing.assert_allclose(wheels["clip"].allocate(tau, *rest), [-0.02, 0.01, 0.01, -0.02], atol=1e-16)
        applied = wheels["clip"].body_torque(wheels["clip"].allocate(tau, *rest))
        np.testing.assert_allclose(applied, np.array([0.06, 0.0, 0.02]) / np.sqrt(3.0), atol=1e-16)
        applied = wheels["scale"].body_torque(wheels["scale"].allocate(tau, *rest))
        np.testing.assert_allclose(applied, 2.0 / 3.0 * tau, atol=1e-16)

    @pytest.mark.parametrize(
        ("mode", "expected"),
        [("clip", [0.0, -0.1, -0.05]), ("scale", [0.0, -0.1, -0.05 / 3])],
    )
    def test_the_speed_limit_cut_is_the_same_in_both_modes(self, mode, expected):
        """Wheel x at +1 N m s (its limit), command [-0.3, 0.3, 0.05] N m: u = [0.3, -0.3, -0.05] by hand.

        Wheel x would spin faster: cut to zero after the torque limit, as without the option;
        the torque limit then gives clip [., -0.1, -0.05] and scale (1/3) [., -0.3, -0.05].
        """
        u = orthogonal(mode).allocate([-0.3, 0.3, 0.05], [1.0, 0.0, 0.0], np.zeros(3))
        np.testing.assert_allclose(u, expected, rtol=1e-15, atol=0.0)

    @pytest.mark.parametrize("mode", ["scale", "clip"])
    def test_numpy_scalars_numpy_batches_and_casadi_agree(self, mode):
        """The same allocation on python floats, on arrays of 200 runs, and in a casadi SX function.

        Commands up to twice the 0.046 N m envelope and momenta up to 1.2 times the limit, so
        most draws saturate a motor and some wheels sit at their speed limit.
        """
        wheels = pyramid(null_space_gain=0.05, torque_saturation=mode)
        rng = np.random.default_rng(7)
        tau = rng.normal(scale=0.05, size=(200, 3))
        h = rng.uniform(-0.6, 0.6, size=(200, 4))
        w = rng.normal(scale=0.05, size=(200, 3))
        batched = wheels.allocate(tau, h, w)
        saturated = np.any(np.abs(batched) >= wheels.torque_max * (1 - 1e-12), axis=1)
        assert 50 < saturated.sum() < 200  # the limits are exercised, and not by every draw
        tau_s, h_s, w_s = ca.SX.sym("tau", 3), ca.SX.sym("h", 4), ca.SX.sym("w", 3)
        u_s = wheels.allocate_components(
            [tau_s[k] for k in range(3)], [h_s[i] for i in range(4)], [w_s[k] for k in range(3)]
        )
        f = ca.Function("alloc", [tau_s, h_s, w_s], [ca.vertcat(*u_s)])
        for i in range(200):
            scalars = wheels.allocate_components([float(v) for v in tau[i]], [float(v) for v in h[i]], list(w[i]))
            # Numpy on one run or on all: the same operations element by element, bit for bit.
            np.testing.assert_array_equal(np.array(scalars, dtype=float), batched[i])
            # Casadi's virtual machine folds the constants its own way: rounding of 0.02 N m only.
            np.testing.assert_allclose(np.array(f(tau[i], h[i], w[i])).ravel(), batched[i], rtol=0, atol=1e-15)

    def test_the_mode_travels_in_pickles_and_names_the_wheels(self):
        clip = pickle.loads(pickle.dumps(pyramid(torque_saturation="clip")))
        assert clip.torque_saturation == "clip"
        assert pyramid().torque_saturation == "scale"  # the default keeps the results of before
        assert repr(clip) != repr(pyramid())
        assert "torque_saturation='clip'" in repr(clip)
        assert scenario_identity(clip) != scenario_identity(pyramid())

    def test_a_campaign_checkpoint_of_one_mode_is_refused_by_the_other(self, tmp_path):
        """The built-in PD-with-wheels scenario names its wheels by their repr in its fingerprint."""

        def campaign(mode: str) -> Campaign:
            scenario = PDWheelsScenario(
                SPACECRAFT,
                pyramid(torque_saturation=mode),
                quat.identity(),
                quat.from_axis_angle([1.0, 0.5, -0.3], np.radians(40.0)),
                bandwidth=0.1,
                damping=0.8,
                period=0.1,
                duration=1.0,
            )
            return Campaign(scenario, {"initial_rate": Normal(np.zeros(3), 1e-3)}, runs=1, seed=1)

        run_campaign(campaign("scale"), workers=1, out_dir=tmp_path)
        with pytest.raises(ValueError, match="different campaign: it differs in the scenario's fingerprint"):
            run_campaign(campaign("clip"), workers=1, out_dir=tmp_path)
        assert run_campaign(campaign("scale"), workers=1, out_dir=tmp_path).info["resumed_runs"] == 1


#: The closed loop whose opening command saturates: a 40 deg slew about [1, 0.5, -0.3] from rest, PD
#: at 0.1 rad/s (damping 0.8) on the hub body, 0.02 N m pyramid wheels, 10 Hz, 120 s.
SLEW_TARGET = quat.from_axis_angle([1.0, 0.5, -0.3], np.radians(40.0))


def slew_controller(wheels: ReactionWheels) -> QuaternionPD:
    return QuaternionPD.from_bandwidth(
        wheels.hub_body(SPACECRAFT), wn=0.1, zeta=0.8, period=0.1, q_ref=SLEW_TARGET, gyroscopic=True
    )


def sine_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.cross(a, b), axis=-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))


@pytest.fixture(scope="module")
def flights():
    """The slew in both modes on both engines of :func:`attitude.simulate`."""
    out = {}
    for mode in ("scale", "clip"):
        wheels = pyramid(torque_saturation=mode)
        for engine in ("python", "compiled"):
            out[mode, engine] = simulate(
                SPACECRAFT, quat.identity(), np.zeros(3), 120.0,
                controller=slew_controller(wheels), wheels=wheels, engine=engine,
            )  # fmt: skip
    return out


class TestTorqueSaturationInClosedLoop:
    """The two modes fly the same saturated slew differently, whichever path flies it.

    Measured (python engine): the opening command [0.0635, 0.0420, -0.0162] N m (0.0778 N m) is
    2.64 times what the wheels give along it. Scale applies 0.0295 N m along it (6e-15 deg off);
    clip applies 0.0369 N m, 13.1 deg off. The attitudes of the two modes then differ by up to
    1.60 deg (at 14.7 s), the wheel speeds by up to 6.95 rad/s (66 rpm); both settle within
    0.05 deg (86.6 s scale, 85.7 s clip). The python and compiled engines agree to 4e-16 in q and
    5e-14 rad/s.
    """

    def test_scale_keeps_the_commanded_direction_and_clip_turns_it(self, flights):
        for engine in ("python", "compiled"):
            scale, clip = flights["scale", engine], flights["clip", engine]
            assert scale.info["engine"] == engine
            # The opening command is beyond the wheels in both (the command is the same: same start).
            np.testing.assert_array_equal(scale.torque_command[0], clip.torque_command[0])
            for result in (scale, clip):
                assert np.linalg.norm(result.torque_applied[0]) < 0.9 * np.linalg.norm(result.torque_command[0])
            # Scale: parallel at every tick, saturated or not (rounding of the common factor only).
            moving = np.linalg.norm(scale.torque_command, axis=1) > 1e-9
            assert np.max(sine_between(scale.torque_command[moving], scale.torque_applied[moving])) < 1e-12
            # Clip: the opening torque turns away from the command by degrees (measured 13.1 deg).
            assert sine_between(clip.torque_command[0], clip.torque_applied[0]) > np.sin(np.radians(1.0))

    def test_the_modes_fly_differently_and_each_path_flies_its_own(self, flights):
        for mode in ("scale", "clip"):
            python, compiled = flights[mode, "python"], flights[mode, "compiled"]
            # The same arithmetic in casadi's virtual machine and in numpy: rounding only.
            np.testing.assert_allclose(compiled.q, python.q, atol=1e-12)
            np.testing.assert_allclose(compiled.wheel_speed, python.wheel_speed, rtol=0, atol=1e-10)
        scale, clip = flights["scale", "python"], flights["clip", "python"]
        # Far beyond rounding (1e-12 rad, 1e-10 rad/s): measured 1.60 deg and 6.95 rad/s.
        assert np.max(quat.error_angle(scale.q, clip.q)) > 1e-6
        assert np.max(np.abs(scale.wheel_speed - clip.wheel_speed)) > 1e-6

    @pytest.mark.parametrize("backend", ["numpy", "compiled"])
    def test_the_vectorised_batch_flies_the_mode_it_is_given(self, flights, backend):
        """A batch of two runs of the slew (arrays of runs, not one) against the single-run engine."""
        for mode in ("scale", "clip"):
            wheels = pyramid(torque_saturation=mode)
            batch = simulate_batch(
                SPACECRAFT, np.stack([quat.identity(), quat.identity()]), np.zeros(3), 120.0,
                controller=slew_controller(wheels), wheels=wheels, backend=backend, history_stride=10,
            )  # fmt: skip
            assert batch.info["backend"] == backend
            single = flights[mode, "python"]
            # The same component arithmetic in C or numpy instead of casadi's virtual machine:
            # rounding only, as the batch's own agreement test (tests/attitude/simulation/test_batch.py).
            np.testing.assert_allclose(batch.q, [single.q[-1], single.q[-1]], atol=1e-12)
            np.testing.assert_allclose(
                batch.histories["wheel_speed"][0], single.wheel_speed[::10], rtol=1e-10, atol=1e-10
            )

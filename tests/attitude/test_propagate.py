"""Propagation: methods, torque inputs, batches, invariants and bad input.

What each group checks against:

* Exact torque-free motion of :mod:`attitude.analytic`: the adaptive method (scipy ``solve_ivp``,
  DOP853) against the Jacobi elliptic solution for random inertias near the major and minor axes
  over 20 periods (Landau & Lifshitz, *Mechanics*, sec. 37; docs/torque_free_motion.md), and the
  order of convergence 4 of the fixed-step RK4 and Runge-Kutta-Munthe-Kaas (RKMK4) methods
  against the exact axisymmetric free precession (log-log slope of the error vs the step).
* Torque inputs: agreement between code paths: constant, sampled (zero-order hold) and callable
  torques (casadi vs numpy evaluation, rounding only), and the fixed-step methods against DOP853 at
  rtol 1e-13 as the accuracy reference.
* Batches: a batch equals the single propagations (casadi per body vs vectorised numpy, rounding
  only), across chunk boundaries, dispersed inertias and two batch dimensions.
* The compiled geometric path (one body, casadi ``mapaccum``) against RKMK4 as the numpy
  implementation wrote it before it was compiled, re-written here in plain Python floats: the
  torque-free case of Basilisk's benchmark over 600 s, rounding only.
* Invariants: the geometric integrator keeps ``|q| = 1`` to rounding without renormalisation (a
  product of unit quaternions), batched in numpy and compiled for one body, and the reported drift
  of the torque-free invariants (rotational kinetic energy and the inertial angular momentum,
  conserved by Euler's equations).
* Results: save/load round trip bit for bit, the figure's panels.
* Bad input (also as hypothesis properties): errors name the argument, the rule and the value
  (DESIGN.md); a step far outside RK4's stability region and a non-finite torque raise instead of
  returning NaN.
"""

import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from matplotlib.figure import Figure

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.propagate import Trajectory, propagate

TENSOR = np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
BODY = RigidBody(TENSOR)
Q0 = quat.from_axis_angle([1.0, 2.0, -0.5], 0.7)
W0 = np.array([0.3, -0.2, 0.5])


def reference(t, torque=None, body=BODY, q0=Q0, w0=W0):
    # DOP853 at rtol 1e-13: errors ~1e-12 over these short spans, far below
    # the fixed-step errors compared against it (>= 1e-10).
    return propagate(body, q0, w0, t, torque, method="adaptive", rtol=1e-13, atol=1e-14)


class TestTorqueInputs:
    t = np.linspace(0.0, 5.0, 51)

    @pytest.mark.parametrize("method", ["rk4", "geometric", "adaptive"])
    def test_constant_grid_and_callable_torques_agree(self, method):
        tau = np.array([0.02, -0.01, 0.03])
        const = propagate(BODY, Q0, W0, self.t, tau, method=method)
        grid = propagate(BODY, Q0, W0, self.t, np.tile(tau, (self.t.size, 1)), method=method)
        call = propagate(BODY, Q0, W0, self.t, lambda t, q, w: tau, method=method)
        # rk4, geometric: casadi (const, grid) vs numpy (callable) evaluate the
        # same arithmetic, so agreement is to rounding; adaptive takes different
        # steps per call pattern, so it agrees to its tolerance (rtol 1e-10).
        tol = 1e-8 if method == "adaptive" else 1e-12
        np.testing.assert_allclose(grid.omega, const.omega, atol=tol)
        np.testing.assert_allclose(call.omega, const.omega, atol=tol)
        np.testing.assert_allclose(call.q, const.q, atol=tol)

    @pytest.mark.parametrize("method", ["rk4", "geometric"])
    def test_sampled_torque_is_held_over_each_interval(self, method):
        tau = np.random.default_rng(1).normal(scale=0.05, size=(self.t.size, 3))
        fixed = propagate(BODY, Q0, W0, self.t, tau, method=method, max_step=0.01)
        ref = reference(self.t, tau)
        # RK4 at h = 0.01 s on rates ~0.5 rad/s: local error ~(w h)^5 per step,
        # global ~1e-11; 1e-9 leaves margin for the 50 switches.
        np.testing.assert_allclose(fixed.omega, ref.omega, atol=1e-9)
        assert np.max(quat.error_angle(ref.q, fixed.q)) < 1e-9

    def test_feedback_torque_callable_sees_the_stage_state(self):
        damping = 3.0

        def torque(t, q, omega):
            return -damping * (TENSOR @ omega.T).T if omega.ndim > 1 else -damping * TENSOR @ omega

        rk4 = propagate(BODY, Q0, W0, self.t, torque, max_step=0.01)
        ref = reference(self.t, torque)
        np.testing.assert_allclose(rk4.omega, ref.omega, atol=1e-9)
        # The rate decays at least as e^{-3 t}: a check that the feedback acted.
        assert np.linalg.norm(rk4.omega[-1]) < 1e-5


class TestBatches:
    t = np.linspace(0.0, 10.0, 101)

    @pytest.mark.parametrize("method", ["rk4", "geometric"])
    def test_batch_equals_single_propagations(self, method):
        rng = np.random.default_rng(5)
        q0 = quat.random(7, rng=rng)
        w0 = rng.normal(scale=0.3, size=(7, 3))
        tau = rng.normal(scale=0.01, size=(7, 3))
        # The step-size rule off: a batch takes the steps its worst body asks for, a single body its own; this
        # test compares the evaluators on the same steps (the rule has its own tests).
        off = {"attitude_error_budget_rad": np.inf}
        batch = propagate(BODY, q0, w0, self.t, tau, method=method, **off)
        assert batch.q.shape == (7, 101, 4)
        for i in range(7):
            single = propagate(BODY, q0[i], w0[i], self.t, tau[i], method=method, **off)
            # The single body runs in casadi and the batch in numpy (in the principal frame):
            # same step definition, different evaluators, rounding-level agreement.
            np.testing.assert_allclose(batch.q[i], single.q, rtol=0, atol=1e-12)
            np.testing.assert_allclose(batch.omega[i], single.omega, rtol=0, atol=1e-12)

    def test_batch_larger_than_one_chunk_and_of_dispersed_inertias(self):
        from attitude import propagate as module

        rng = np.random.default_rng(6)
        n = module.BATCH_CHUNK + 3
        moments = np.sort(rng.uniform(5.0, 10.0, size=(n, 3)), axis=-1)
        body = RigidBody(moments)
        q0 = quat.random(n, rng=rng)
        w0 = rng.normal(scale=0.2, size=(n, 3))
        t = np.linspace(0.0, 2.0, 21)
        off = {"attitude_error_budget_rad": np.inf}  # the same steps for batch and single (as above)
        batch = propagate(body, q0, w0, t, **off)
        # Two balanced chunks meet at n // 2 + 1; check both sides and the ends.
        for i in (0, n // 2 - 1, n // 2, n // 2 + 1, n // 2 + 2, n - 1):
            single = propagate(RigidBody(moments[i]), q0[i], w0[i], t, **off)
            np.testing.assert_allclose(batch.omega[i], single.omega, rtol=0, atol=1e-12)
            np.testing.assert_allclose(batch.q[i], single.q, rtol=0, atol=1e-12)

    def test_two_batch_dimensions_and_adaptive(self):
        rng = np.random.default_rng(8)
        q0 = quat.random((2, 3), rng=rng)
        w0 = rng.normal(scale=0.3, size=(2, 3, 3))
        batch = propagate(BODY, q0, w0, self.t, method="adaptive", rtol=1e-12, atol=1e-14)
        assert batch.omega.shape == (2, 3, 101, 3)
        single = propagate(BODY, q0[1, 2], w0[1, 2], self.t, method="adaptive", rtol=1e-12, atol=1e-14)
        # One error control for the whole batch vs one per body: both within
        # the requested tolerance of the truth, so within ~1e-10 of each other.
        np.testing.assert_allclose(batch.omega[1, 2], single.omega, atol=1e-10)


def _raw_rk4_quaternion(q0, w0, h, n):
    """RK4 on the full state without renormalising (to show what the Lie-group step avoids)."""
    from attitude.integrators import rk4_step
    from attitude.rigid_body import split_components

    x = split_components(np.concatenate([q0, w0]), 7)
    out = []
    for _ in range(n):
        x = rk4_step(lambda t, xc: BODY.state_derivative_components(xc, None), 0.0, x, h)
        out.append(x[:4])
    return np.array(out)


class TestGeometricIntegrator:
    def test_quaternion_norm_kept_without_renormalisation(self):
        t = np.linspace(0.0, 200.0, 2001)
        w0 = np.array([0.5, 1.5, -0.8])  # fast tumble, 2000 steps of 0.1 s
        q0 = quat.random(32, rng=3)
        # The step-size rule off (inf budget): this checks the method's own steps, 2000 of them.
        traj = propagate(BODY, q0, w0, t, method="geometric", attitude_error_budget_rad=np.inf)
        # Each step multiplies unit quaternions, so |q| changes only by
        # rounding: measured as a random walk of ~5e-17 per step (RMS 1.7e-15
        # after 10^3 steps, 6.5e-15 after 10^4), well inside 1e-14 here.
        assert traj.invariant_drift()["quaternion_norm"] < 1e-14
        # Without renormalisation a plain RK4 step leaves |q| off by its
        # truncation error, orders of magnitude above rounding.
        rk4_raw = np.linalg.norm(_raw_rk4_quaternion(q0[0], w0, 0.1, 2000), axis=-1)
        assert np.max(np.abs(rk4_raw - 1.0)) > 1e-10

    def test_one_body_runs_compiled_and_keeps_the_norm(self):
        # One body takes the compiled path (casadi mapaccum of casadi_rkmk4_step): the same tumble and bound as the
        # batch above, since the compiled step multiplies unit quaternions too (measured at most 5.7e-15 here).
        t = np.linspace(0.0, 200.0, 2001)
        w0 = np.array([0.5, 1.5, -0.8])
        for q0 in quat.random(4, rng=3):
            traj = propagate(BODY, q0, w0, t, method="geometric", attitude_error_budget_rad=np.inf)
            assert traj.info["engine"] == "casadi mapaccum"
            assert traj.invariant_drift()["quaternion_norm"] < 1e-14

    def test_compiled_equals_the_previous_numpy_implementation(self):
        # Basilisk's torque-free benchmark case: I = diag(100, 200, 300) kg m^2, omega0 = [0.1, 0.01, 0.01] rad/s,
        # 0.1 s steps for 600 s, against RKMK4 as the numpy path computed it before it was compiled (weights summed
        # as b_i k_i, exp by sin and cos), re-written on Python floats.
        body = RigidBody(np.diag([100.0, 200.0, 300.0]))
        q0 = quat.from_axis_angle([1.0, -2.0, 0.5], 0.8)
        w0 = np.array([0.1, 0.01, 0.01])
        t = np.arange(6001) * 0.1
        traj = propagate(body, q0, w0, t, method="geometric")
        assert traj.info["engine"] == "casadi mapaccum" and not traj.info["step_rule"]["substeps_added"]
        q_ref, w_ref = _previous_rkmk4((100.0, 200.0, 300.0), q0, w0, 0.1, 6000)
        # Rounding only: ~1e-16 per step, as a random walk over 6000 steps (~1e-14 rad) plus the attitude a rate
        # off by ~1e-16 rad/s turns over 600 s (6e-14 rad); measured 2.7e-14 rad and 3.6e-16 rad/s. The method's
        # own error is ~1e-8 rad here, and leaving out the step's theta x (theta x omega) / 12 term moves the
        # attitude by 4.5e-9 rad: a difference in the arithmetic beyond rounding is far above these bounds.
        assert np.max(quat.error_angle(q_ref, traj.q)) < 1e-12
        np.testing.assert_allclose(traj.omega, w_ref, rtol=0, atol=1e-14)


def _previous_rkmk4(moments, q0, w0, h, n):
    """Torque-free RKMK4 of a principal-axis body on Python floats: ``n`` steps of ``h`` [s], every state returned.

    ``theta' = omega + theta x omega / 2 + theta x (theta x omega) / 12`` in the Lie algebra with the classical
    RK4 tableau (Munthe-Kaas, Appl. Numer. Math. 29, 1999; Iserles et al., Acta Numerica 9, 2000),
    ``q <- q ⊗ exp(theta / 2)``.
    """
    weights = (1.0 / 6.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 6.0)
    i1, i2, i3 = moments

    def cross(a, b):
        return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

    def euler(w):  # Euler's equations, torque-free, principal axes
        return ((i2 - i3) * w[1] * w[2] / i1, (i3 - i1) * w[2] * w[0] / i2, (i1 - i2) * w[0] * w[1] / i3)

    q, w = tuple(float(v) for v in q0), tuple(float(v) for v in w0)
    out_q, out_w = [q], [w]
    for _ in range(n):
        ks, ls = [], []
        for c, prev in ((0.0, None), (0.5, 0), (0.5, 1), (1.0, 2)):
            theta = (0.0, 0.0, 0.0) if prev is None else tuple(c * h * v for v in ks[prev])
            w_stage = w if prev is None else tuple(a + c * h * b for a, b in zip(w, ls[prev]))
            c1 = cross(theta, w_stage)
            c2 = cross(theta, c1)
            ks.append(tuple(a + b / 2.0 + d / 12.0 for a, b, d in zip(w_stage, c1, c2)))
            ls.append(euler(w_stage))
        theta = [h * sum(b * k[i] for b, k in zip(weights, ks)) for i in range(3)]
        w = tuple(w[i] + h * sum(b * lv[i] for b, lv in zip(weights, ls)) for i in range(3))
        angle = math.sqrt(sum(v * v for v in theta))
        s = math.sin(angle / 2.0) / angle if angle > 0.0 else 0.5
        p = (math.cos(angle / 2.0), s * theta[0], s * theta[1], s * theta[2])
        q = (
            q[0] * p[0] - q[1] * p[1] - q[2] * p[2] - q[3] * p[3],
            q[0] * p[1] + q[1] * p[0] + q[2] * p[3] - q[3] * p[2],
            q[0] * p[2] - q[1] * p[3] + q[2] * p[0] + q[3] * p[1],
            q[0] * p[3] + q[1] * p[2] - q[2] * p[1] + q[3] * p[0],
        )
        out_q.append(q)
        out_w.append(w)
    return np.array(out_q), np.array(out_w)


class TestResults:
    def test_save_and_load_round_trip(self, tmp_path):
        traj = propagate(BODY, Q0, W0, np.linspace(0, 1, 11), method="geometric")
        path = traj.save(tmp_path / "traj")
        back = Trajectory.load(path)
        np.testing.assert_array_equal(back.q, traj.q)
        np.testing.assert_array_equal(back.omega, traj.omega)
        np.testing.assert_array_equal(back.inertia, traj.inertia)
        assert back.method == "geometric"
        assert back.info == traj.info

    def test_plot_returns_a_figure_with_three_panels(self):
        traj = propagate(BODY, quat.random(3, rng=1), W0, np.linspace(0, 1, 11))
        fig = traj.plot(index=1)
        assert isinstance(fig, Figure)
        assert len(fig.axes) == 3

    def test_invariants_are_reported(self):
        traj = propagate(BODY, Q0, W0, np.linspace(0, 20, 201), method="rk4", max_step=0.05)
        drift = traj.invariant_drift()
        # RK4 at h = 0.05 s, |w| h ~ 0.03: energy error ~1e-11 relative.
        assert drift["energy"] < 1e-9
        assert drift["momentum"] < 1e-8
        assert drift["energy"] > 0  # a real measurement, not a constant


class TestBadInput:
    t = np.linspace(0.0, 1.0, 11)

    @pytest.mark.parametrize(
        ("kwargs", "match"),
        [
            ({"q0": [1.0, 0.1, 0.0, 0.0]}, "q0 must be a unit quaternion"),
            ({"q0": [0.0, 0.0, 0.0, 0.0]}, "q0"),
            ({"q0": [np.nan, 0.0, 0.0, 1.0]}, "q0 must be finite"),
            ({"q0": [1.0, 0.0, 0.0]}, r"q0 must have shape \(\.\.\., 4\)"),
            ({"omega0": [0.1, np.inf, 0.0]}, "omega0 must be finite"),
            ({"omega0": [[0.1, 0.0, 0.0]] * 3, "q0": quat.random(2, rng=1)}, "broadcast"),
            ({"t": [0.0, 1.0, 1.0]}, "t must be strictly increasing"),
            ({"t": [0.0, 2.0, 1.0]}, "t must be strictly increasing"),
            ({"t": [0.0]}, "t must be a 1-D time grid"),
            ({"torque": [1.0, 2.0]}, "torque"),
            ({"torque": np.zeros((5, 3))}, "torque"),
            ({"torque": [0.0, np.nan, 0.0]}, "torque must be finite"),
            ({"method": "euler"}, "method must be one of"),
            ({"max_step": -0.1}, "max_step must be strictly positive"),
            ({"rtol": 0.0}, "rtol must be strictly positive"),
        ],
    )
    def test_rejected_with_the_argument_named(self, kwargs, match):
        args = {"q0": Q0, "omega0": W0, "t": self.t} | kwargs
        with pytest.raises(ValueError, match=match):
            propagate(BODY, args.pop("q0"), args.pop("omega0"), args.pop("t"), **args)

    def test_callable_torque_returning_nan_is_caught(self):
        with pytest.raises(ValueError, match="torque"):
            propagate(BODY, Q0, W0, self.t, lambda t, q, w: np.full(3, np.nan), method="geometric")

    def test_body_must_be_a_rigid_body(self):
        with pytest.raises(ValueError, match="body must be a RigidBody"):
            propagate(np.eye(3), Q0, W0, self.t)


# ---------------------------------------------------------------------------
# Against the exact torque-free solutions of attitude.analytic
# ---------------------------------------------------------------------------


def _random_inertia_and_rate(seed: int, regime: str):
    """A random realisable full tensor and a body rate in the requested regime."""
    from scipy.spatial.transform import Rotation

    from attitude.analytic import torque_free_motion

    rng = np.random.default_rng(seed)
    while True:
        m = np.sort(rng.uniform(2.0, 20.0, 3))
        if m[2] <= m[0] + m[1] and np.min(np.diff(m)) > 0.5:
            break
    rot = Rotation.random(random_state=rng).as_matrix()
    body = RigidBody(rot @ np.diag(m) @ rot.T)
    axis = 2 if regime == "major" else 0  # near the major or the minor axis
    w_p = rng.normal(scale=0.15, size=3)
    w_p[axis] = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.0)
    omega0 = rot @ w_p
    motion = torque_free_motion(body, omega0)
    assert motion.regime == regime
    return body, omega0, motion


@pytest.mark.parametrize("regime", ["major", "minor"])
@pytest.mark.parametrize("seed", range(5))
def test_adaptive_matches_the_elliptic_solution_over_20_periods(seed, regime):
    body, omega0, motion = _random_inertia_and_rate(seed, regime)
    t = np.linspace(0.0, 20.0 * motion.period, 2001)
    traj = propagate(body, quat.random(rng=seed), omega0, t, method="adaptive", rtol=1e-12, atol=1e-14)
    exact = motion.omega(t)
    rel = np.max(np.linalg.norm(traj.omega - exact, axis=-1)) / np.linalg.norm(omega0)
    # The bound: DOP853 at rtol 1e-12 keeps the phase error over 20
    # periods near 1e-10 (observed 1e-11 to 3e-10 for these inertias).
    assert rel < 1e-8


def _convergence_slope(method: str) -> float:
    """Log-log slope of the final-state error against the step, vs the exact solution."""
    from attitude.analytic import axisymmetric_precession

    body = RigidBody(np.diag([10.0, 10.0, 16.0]) + 0.0)
    q0 = quat.from_axis_angle([1.0, -2.0, 0.5], 0.9)
    omega0 = np.array([0.4, -0.3, 1.2])
    t = np.linspace(0.0, 20.0, 11)
    exact = axisymmetric_precession(body, q0, omega0, t)
    steps = np.array([0.2, 0.1, 0.05, 0.025])
    errors = []
    for h in steps:
        # The step-size rule off (inf budget): the slope is of the steps asked for.
        traj = propagate(body, q0, omega0, t, method=method, max_step=h, attitude_error_budget_rad=np.inf)
        err_q = np.max(quat.error_angle(exact.q, traj.q))
        err_w = np.max(np.linalg.norm(traj.omega - exact.omega, axis=-1))
        errors.append(max(err_q, err_w))
    return float(np.polyfit(np.log(steps), np.log(errors), 1)[0])


@pytest.mark.parametrize("method", ["rk4", "geometric"])
def test_order_of_convergence_is_four(method):
    # Both are fourth-order methods; the measured slope must be within 0.3 of 4
    # (errors here range 1e-6 .. 1e-10, far above rounding).
    assert abs(_convergence_slope(method) - 4.0) < 0.3


# ---------------------------------------------------------------------------
# Property tests: random valid input propagates; random invalid input is named
# ---------------------------------------------------------------------------


@given(
    st.integers(0, 2**32 - 1),
    st.sampled_from(["rk4", "geometric", "adaptive"]),
    st.integers(2, 12),
)
def test_random_valid_inputs_give_finite_unit_attitudes(seed, method, n_points):
    rng = np.random.default_rng(seed)
    t = np.cumsum(np.concatenate([[rng.uniform(-5, 5)], rng.uniform(0.01, 0.5, n_points - 1)]))
    traj = propagate(
        BODY, quat.random(rng=rng), rng.normal(scale=0.5, size=3), t, rng.normal(scale=0.1, size=3), method=method
    )
    assert np.all(np.isfinite(traj.q)) and np.all(np.isfinite(traj.omega))
    # Renormalised (rk4), Lie-group (geometric) or DOP853 at rtol 1e-10 over <= 6 s.
    assert np.max(np.abs(np.linalg.norm(traj.q, axis=-1) - 1.0)) < 1e-8


@given(st.integers(0, 2**32 - 1), st.integers(3, 12))
def test_any_non_increasing_time_grid_is_rejected(seed, n_points):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.01, 1.0, n_points))
    i = int(rng.integers(1, n_points))
    t[i] = t[i - 1] - rng.uniform(0.0, 1.0)  # equal or decreasing
    with pytest.raises(ValueError, match="t must be strictly increasing"):
        propagate(BODY, Q0, W0, t)


@given(
    st.integers(0, 2**32 - 1), st.sampled_from(["q0", "omega0", "torque"]), st.sampled_from([np.nan, np.inf, -np.inf])
)
def test_any_non_finite_entry_is_rejected_with_its_name(seed, argument, bad):
    rng = np.random.default_rng(seed)
    args = {"q0": Q0.copy(), "omega0": W0.copy(), "torque": np.zeros(3)}
    args[argument][int(rng.integers(0, args[argument].size))] = bad
    with pytest.raises(ValueError, match=f"{argument} must be finite"):
        propagate(BODY, args["q0"], args["omega0"], np.linspace(0, 1, 5), args["torque"])


class TestDivergenceIsReported:
    @pytest.mark.parametrize("method", ["rk4", "geometric"])
    def test_a_step_too_long_for_the_rates_raises_instead_of_returning_nan(self, method):
        from attitude.propagate import PropagationDivergedError

        # |omega| h = 11.6: far outside RK4's stability region; the state overflows. With the
        # step-size rule on, the run is refused before it starts (TestStepSizeRule); off, the
        # divergence is still named.
        with pytest.raises(ValueError, match="max_step <="):
            propagate(BODY, Q0, [3.0, 5.0, 10.0], np.arange(0.0, 600.0, 1.0), method=method)
        with pytest.raises(PropagationDivergedError, match=r"\|omega\| h = 11.6"):
            propagate(
                BODY, Q0, [3.0, 5.0, 10.0], np.arange(0.0, 600.0, 1.0), method=method, attitude_error_budget_rad=np.inf
            )

    def test_a_mistyped_max_step_is_named(self):
        with pytest.raises(ValueError, match="max_step = 1e-300 s makes"):
            propagate(BODY, Q0, W0, np.linspace(0, 10, 11), max_step=1e-300)


def test_trajectory_load_refuses_nan_quaternions(tmp_path):
    """Issue 13, item 17: ``Trajectory.load`` accepted a file with NaN in ``q``."""
    traj = propagate(RigidBody([10.0, 12.0, 8.0]), [1.0, 0.0, 0.0, 0.0], [0.1, 0.2, 0.3], np.linspace(0.0, 1.0, 11))
    good = traj.save(tmp_path / "good")
    assert np.array_equal(Trajectory.load(good).q, traj.q)  # a valid file still loads
    traj.q[3, 0] = np.nan
    bad = traj.save(tmp_path / "bad")
    with pytest.raises(ValueError, match="q must be finite"):
        Trajectory.load(bad)


# ---------------------------------------------------------------------------
# The step-size rule (docs/rk4_step_rule.md): no silent wrong attitude from fixed-step RK4
# ---------------------------------------------------------------------------


class TestStepSizeRule:
    # A spin about a principal axis keeps a constant rate: the exact attitude is
    # q0 ⊗ exp(omega t / 2) (Wertz, Spacecraft Attitude Determination and Control, eq. 17-1).
    SPIN_BODY = RigidBody([10.0, 12.0, 8.0])

    def _spin(self, rate, t, **kwargs):
        from attitude.integrators import StepSizeWarning

        with pytest.warns(StepSizeWarning, match="step-size rule") as caught:
            traj = propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, rate], t, **kwargs)
        exact = quat.from_axis_angle([0.0, 0.0, 1.0], rate * t)
        return traj, float(np.max(quat.error_angle(exact, quat.normalize(traj.q)))), str(caught[0].message)

    def test_25_rad_s_at_0_1_s_is_sub_stepped_with_a_warning(self):
        # Before the rule: 148 deg off the exact rotation with zero invariant drift, and no warning.
        traj, error, message = self._spin(25.0, np.arange(0.0, 10.01, 0.1))
        # The rule's budget is 1e-6 rad; the prediction is exact for a constant rate (theta^5/1920 per step).
        assert error < 1e-6
        assert "method='geometric'" in message and "25 rad/s" in message and "0.1 s" in message
        assert traj.info["step_rule"]["substeps_added"]

    def test_5_rad_s_over_600_s_is_within_the_budget(self):
        # Before the rule: 5.5 deg (6000 steps of 0.5^5/1920 rad), no warning.
        _, error, message = self._spin(5.0, np.arange(0.0, 600.0001, 0.1))
        assert error < 1e-6
        assert "sub-stepped to 18 steps" in message  # (0.0977 rad / 1e-6 rad)^(1/4) = 17.7

    @pytest.mark.parametrize("batch", [(), (2,)])
    def test_the_numpy_and_batch_paths_follow_the_rule(self, batch):
        from attitude.integrators import StepSizeWarning

        t = np.arange(0.0, 10.01, 0.1)
        q0 = np.broadcast_to([1.0, 0.0, 0.0, 0.0], (*batch, 4))
        with pytest.warns(StepSizeWarning):
            traj = propagate(self.SPIN_BODY, q0, [0.0, 0.0, 25.0], t, method="rk4", torque=lambda _t, q, w: 0 * w)
        exact = quat.from_axis_angle([0.0, 0.0, 1.0], 25.0 * t[-1])
        assert np.all(quat.error_angle(exact, quat.normalize(traj.q[..., -1, :])) < 1e-6)

    def test_a_torque_that_spins_the_body_up_is_caught_after_the_run(self):
        # From rest the initial check passes; 5 N m about z on I_z = 8 kg m^2 reaches 62.5 rad/s in 100 s:
        # the exact angle is 0.5 a t^2, a = 5/8 rad/s^2.
        from attitude.integrators import StepSizeWarning

        t = np.arange(0.0, 100.01, 0.1)
        with pytest.warns(StepSizeWarning):
            traj = propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0], t, [0.0, 0.0, 5.0])
        exact = quat.from_axis_angle([0.0, 0.0, 1.0], 0.5 * 5.0 / 8.0 * t[-1] ** 2)
        # The quadratic angle is integrated exactly by RK4 in omega; the kinematic error is the rule's.
        assert float(quat.error_angle(exact, quat.normalize(traj.q[-1]))) < 1e-6

    def test_an_absurd_step_is_refused_naming_max_step(self):
        with pytest.raises(ValueError, match=r"max_step <= .*method='geometric'"):
            propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 25.0], np.arange(0.0, 1e4, 100.0))

    def test_the_geometric_method_is_exact_for_the_spin_and_not_sub_stepped(self):
        import warnings

        from attitude.integrators import StepSizeWarning

        t = np.arange(0.0, 10.01, 0.1)
        with warnings.catch_warnings():
            warnings.simplefilter("error", StepSizeWarning)
            traj = propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 25.0], t, method="geometric")
        exact = quat.from_axis_angle([0.0, 0.0, 1.0], 25.0 * t[-1])
        # Exact exponential per step: only rounding over 100 steps (1e-12 rad with margin).
        assert float(quat.error_angle(exact, traj.q[-1])) < 1e-10

    # -- What the messages say: a remedy that applies, an error bound that is an angle ---------------------------

    # A tumble of the triaxial body: its rate varies, so geometric (exact for a constant rate) breaks the rule too.
    TUMBLE = (1.0, 2.0, 5.0)

    def _message(self, method, t):
        from attitude.integrators import StepSizeWarning

        with pytest.warns(StepSizeWarning, match="step-size rule") as caught:
            propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], self.TUMBLE, t, method=method)
        return str(caught[0].message)

    def test_a_geometric_run_is_not_told_to_use_geometric(self):
        # Issue 12: the warning of a geometric run said "method='geometric' is exact for a constant rate", as if
        # the run were not geometric already. It must point to what applies: adaptive, or the step and budget.
        t = np.arange(0.0, 10.01, 0.5)
        geometric = self._message("geometric", t)
        assert "method='geometric' is exact" not in geometric
        assert "method='adaptive'" in geometric and "attitude_error_budget_rad" in geometric
        rk4 = self._message("rk4", t)  # an RK4 run is still pointed to geometric
        assert "method='geometric' is exact for a constant rate" in rk4
        # The refusal of an absurd step too (more than MAX_RULE_SUBSTEPS steps per step asked).
        with pytest.raises(ValueError, match=r"max_step <= .*method='adaptive'") as refused:
            propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], self.TUMBLE, np.arange(0.0, 1e4, 100.0), method="geometric")
        assert "method='geometric' is exact" not in str(refused.value)

    def test_a_predicted_error_above_pi_reads_as_a_lost_attitude(self):
        # Issue 12: 0.5 s steps of a 5.5 rad/s tumble predict some 44 rad, which was printed as "43.7 rad": the
        # angle between two attitudes is at most pi rad, so the message says the attitude is lost instead.
        message = self._message("rk4", np.arange(0.0, 10.01, 0.5))
        assert "predicts an accumulated attitude error of more than pi rad (the attitude is lost)" in message
        assert re.search(r"error of \d", message) is None
        # Below pi the number is printed: 5 rad/s at 0.1 s over 600 s predicts 0.098 rad (6000 steps of 0.5^5/1920).
        _, _, small = self._spin(5.0, np.arange(0.0, 600.0001, 0.1))
        assert "predicts an accumulated attitude error of 0.0977 rad" in small

    # -- The rule on the rates actually flown: between sparse samples, under a turning torque, one warning ------

    @staticmethod
    def _reference(body, omega0, t, torque):
        # DOP853 at rtol 1e-12: its own error is orders below the budgets used here.
        q0 = [1.0, 0.0, 0.0, 0.0]
        return propagate(body, q0, omega0, t, torque=torque, method="adaptive", rtol=1e-12, atol=1e-14)

    @pytest.mark.parametrize(
        "torque",
        [
            pytest.param(lambda t, q, w: np.array([0.0, 0.0, 4.0 * np.sin(2.0 * np.pi * t / 20.0)]), id="callable"),
            pytest.param([0.0, 0.0, 4.0], id="constant (compiled path)"),
        ],
    )
    def test_rates_between_sparse_samples_are_checked(self, torque):
        # Before: the rule saw only the rates at t = 0 and 20 s (0 rad/s for the sine: predicted 1e-79),
        # while the body reached 3.2 rad/s (sine) or 10 rad/s (constant) between them; 2e-2 / 2e-4 rad off.
        from attitude.integrators import StepSizeWarning

        budget = 1e-4  # a loose budget keeps the sub-stepped run short
        t = np.array([0.0, 20.0])
        with pytest.warns(StepSizeWarning, match="step-size rule"):
            traj = propagate(
                self.SPIN_BODY,
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 0.0, 0.0],
                t,
                torque=torque,
                max_step=0.5,
                attitude_error_budget_rad=budget,
            )
        ref = self._reference(self.SPIN_BODY, [0.0, 0.0, 0.0], t, torque)
        assert float(quat.error_angle(ref.q[-1], traj.q[-1])) <= budget
        assert traj.info["step_rule"]["predicted_error_rad"] <= budget

    def test_the_geometric_method_sees_a_torque_that_turns_the_rate(self):
        # A sphere spun at 5 rad/s about z, 2 N m about x: no gyroscopic term, but the torque turns the rate
        # vector in the body. Before: predicted 1.5e-11 rad, 0.029 rad off, no warning.
        from attitude.integrators import StepSizeWarning

        body, budget = RigidBody([10.0, 10.0, 10.0]), 1e-4
        t = np.arange(0.0, 30.01, 0.5)
        with pytest.warns(StepSizeWarning, match="step-size rule"):
            traj = propagate(
                body,
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 0.0, 5.0],
                t,
                torque=[2.0, 0.0, 0.0],
                method="geometric",
                attitude_error_budget_rad=budget,
            )
        ref = self._reference(body, [0.0, 0.0, 5.0], t, [2.0, 0.0, 0.0])
        assert float(np.max(quat.error_angle(ref.q, traj.q))) <= budget

    def test_one_warning_per_call_and_not_met_said_when_the_passes_run_out(self, monkeypatch):
        import warnings

        import attitude.propagate as propagate_module
        from attitude.integrators import StepSizeWarning

        t = np.arange(0.0, 100.01, 0.1)
        # The spin-up above re-runs with more steps: one warning, with the final figures.
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0], t, [0.0, 0.0, 5.0])
        assert [type(w.message) for w in caught] == [StepSizeWarning]
        # With a single pass the count the rates flown ask for is never run: the result must say so.
        monkeypatch.setattr(propagate_module, "RULE_PASSES", 1)
        with pytest.warns(StepSizeWarning, match="NOT within the budget"):
            traj = propagate(self.SPIN_BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0], t, [0.0, 0.0, 5.0])
        assert traj.info["step_rule"]["predicted_error_rad"] > traj.info["step_rule"]["budget_rad"]


class TestCallableTorqueTimeScale:
    """A callable torque changing over a few steps is outside the step-size rule: propagate says so.

    docs/rk4_step_rule.md: a review measured 3e-6 to 1.1e-5 rad (10-100 times the prediction) for torques
    with time scales of 3-5 steps; at 20 steps per time scale the error was 1e-8 to 3e-8 rad.
    """

    BODY = RigidBody([1.0, 1.0, 1.0])
    T = np.arange(101) * 0.1

    @staticmethod
    def damping(t, q, w):
        return -2.0 * np.asarray(w)  # time constant 0.5 s: 5 steps of 0.1 s

    def _run(self, torque, **kw):
        import warnings

        from attitude.integrators import StepSizeWarning

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            traj = propagate(self.BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0], self.T, torque, **kw)
        said = [str(w.message) for w in caught if issubclass(w.category, StepSizeWarning)]
        said = [m for m in said if "callable torque" in m]
        return traj, said

    def test_a_torque_faster_than_twenty_steps_is_named_with_the_max_step_that_covers_it(self):
        _, said = self._run(self.damping)
        assert len(said) == 1 and "time scale of 0.5 s" in said[0] and "max_step <= 0.025 s" in said[0]

    def test_the_remedy_it_names_is_within_the_budget_and_silent(self):
        traj, said = self._run(self.damping, max_step=0.025)
        assert not said
        ref = propagate(self.BODY, [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0], self.T, self.damping, method="adaptive",
                        rtol=1e-13, atol=1e-14)  # fmt: skip
        assert float(np.max(quat.error_angle(ref.q, traj.q))) <= 1e-6

    def test_a_slow_torque_through_zero_is_not_taken_for_a_fast_one(self):
        # 0.01 sin(0.01 t) N m: zero at t = 0, time scale 100 s. A local |tau| / |tau'| would be 0 there.
        _, said = self._run(lambda t, q, w: np.array([0.0, 0.0, 0.01 * np.sin(0.01 * t)]))
        assert not said

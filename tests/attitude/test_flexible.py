"""Flexible appendages in hybrid coordinates (attitude.flexible, linearize.flexible_plant, simulation.flexible_flight).

What each test checks against:

* the collocated torque -> rate and torque -> angle transfer functions of one
  mode about one axis: python-control's poles and zeros against the analytic
  ones, zeros at the constrained frequency ``Omega`` and poles at the
  unconstrained ``Omega / sqrt(1 - l^2 / I)`` plus the rigid integrators
  (the Laplace transform of the two equations of motion, docs/flexible_modes.md:
  the pattern of a collocated flexible structure, Hughes, *Spacecraft Attitude
  Dynamics*, 1986), alternating on the imaginary axis;
* conservation laws on the nonlinear simulation: the mechanical energy and
  the inertial angular momentum without torque and damping, over many modal
  periods (tolerances from RK4's error on an oscillator);
* the linear model against the analytic linearisation ``M [omega'; eta''] =
  [tau; -C eta' - K eta]`` and the nonlinear simulation's small-amplitude
  response against the linear model's exact solution ``expm(A t) x0``;
* the rigid limit ``L = 0`` against :class:`RigidBody` (bit for bit) and
  ``controllers.analysis.rigid_body_at_rest``;
* bad input: each error names its argument.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg

from attitude import quaternion as quat
from attitude.flexible import FlexibleBody, FlexibleModes
from attitude.integrators import casadi_rk4_step
from attitude.linearize import flexible_plant
from attitude.rigid_body import RigidBody
from attitude.simulation.flexible_flight import MODE_STEP_MAX_RAD, simulate_flexible
from controllers import QuaternionPD
from controllers.analysis import rigid_body_at_rest

#: A body with products of inertia, so no axis decouples by accident [kg m^2].
FULL_TENSOR = [[100.0, 2.0, -1.0], [2.0, 120.0, 3.0], [-1.0, 3.0, 80.0]]


def _two_modes(damping: float = 0.0) -> FlexibleModes:
    return FlexibleModes.from_hz(
        frequency_Hz=[1.0, 2.5], damping=damping, participation=[[4.0, 1.0, 0.5], [0.5, 3.0, -2.0]]
    )


def _roots_by_frequency(roots: np.ndarray) -> np.ndarray:
    """The imaginary parts of roots in the upper half plane and at the origin, ascending [rad/s]."""
    return np.sort(roots.imag[roots.imag >= -1e-9])


# ---------------------------------------------------------------------------
# The linear model: poles and zeros, the Jacobian, the rigid limit


def test_one_mode_about_one_axis_has_zeros_at_the_constrained_and_poles_at_the_unconstrained_frequency():
    """Collocated torque -> rate about x: (s^2 + W^2) / (s ((I - l^2) s^2 + I W^2)) (docs/flexible_modes.md).

    python-control's minimal realisation of the x channel has poles ``0, +-j W
    / sqrt(1 - l^2/I)`` and zeros ``+-j W``, undamped (on the imaginary axis),
    so pole (0), zero (W), pole (W_u) alternate. Roots of a 3-state system are
    accurate to ~1e-14 relative; 1e-9 leaves room for the minimal
    realisation's rounding.
    """
    inertia_x, coupling, w = 100.0, 5.0, 2.0 * np.pi * 1.5
    body = RigidBody([inertia_x, 120.0, 80.0])
    modes = FlexibleModes(frequency=[w], damping=0.0, participation=[[coupling, 0.0, 0.0]])
    w_free = w / np.sqrt(1.0 - coupling**2 / inertia_x)
    rate = control.minreal(flexible_plant(body, modes)[3, 0], verbose=False)
    poles, zeros = control.poles(rate), control.zeros(rate)
    np.testing.assert_allclose(poles.real, 0.0, atol=1e-9 * w)
    np.testing.assert_allclose(zeros.real, 0.0, atol=1e-9 * w)
    np.testing.assert_allclose(_roots_by_frequency(poles), [0.0, w_free], rtol=1e-9, atol=1e-9 * w)
    np.testing.assert_allclose(_roots_by_frequency(zeros), [w], rtol=1e-9)
    assert 0.0 < w < w_free  # alternating: pole at 0, zero at W, pole at W_u
    # The high-frequency gain is 1 / I: torque -> rate of the whole spacecraft at s -> 0 behaves as 1 / (I s),
    # i.e. s G(s) -> 1/I; and G(s) ~ 1 / ((I - l^2) s) above the mode (the appendage left behind).
    s = 1j * 1e-4 * w
    assert abs(s * rate(s) - 1.0 / inertia_x) < 1e-6 / inertia_x
    s = 1j * 1e4 * w
    assert abs(s * rate(s) - 1.0 / (inertia_x - coupling**2)) < 1e-6 / inertia_x

    # Torque -> angle (q_v = theta / 2): the same zeros, a double integrator at the origin.
    angle = control.minreal(flexible_plant(body, modes)[0, 0], verbose=False)
    np.testing.assert_allclose(_roots_by_frequency(control.poles(angle)), [0.0, 0.0, w_free], atol=1e-6 * w)
    np.testing.assert_allclose(_roots_by_frequency(control.zeros(angle)), [w], rtol=1e-9)


def test_two_modes_on_one_axis_interlace_poles_and_zeros():
    """Two modes about x: the collocated poles and zeros alternate, 0 < z1 < p1 < z2 < p2.

    The zeros are the constrained frequencies and the poles the generalised
    eigenvalues of :meth:`FlexibleBody.unconstrained_frequencies` (computed
    independently by scipy's ``eigh``), to 1e-9 relative.
    """
    body = RigidBody([100.0, 120.0, 80.0])
    modes = FlexibleModes(frequency=[5.0, 13.0], damping=0.0, participation=[[4.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    rate = control.minreal(flexible_plant(body, modes)[3, 0], verbose=False)
    poles = _roots_by_frequency(control.poles(rate))
    zeros = _roots_by_frequency(control.zeros(rate))
    np.testing.assert_allclose(zeros, [5.0, 13.0], rtol=1e-9)
    np.testing.assert_allclose(poles[1:], FlexibleBody(body, modes).unconstrained_frequencies(), rtol=1e-9)
    assert abs(poles[0]) < 1e-9 * 13.0
    assert poles[0] < zeros[0] < poles[1] < zeros[1] < poles[2]


def test_linear_model_is_the_analytic_linearisation():
    """``flexible_plant`` (casadi's exact Jacobian) equals the analytic model at rest.

    Analytic: ``theta' = omega`` and ``[[I, L^T], [L, 1]] [omega'; eta''] =
    [tau; -2 Z W eta' - W^2 eta]`` (docs/flexible_modes.md), solved here with
    numpy; both are exact to rounding, 1e-12 relative to the largest entry.
    """
    body = RigidBody(FULL_TENSOR)
    modes = _two_modes(damping=0.02)
    n = modes.n_modes
    L = modes.participation
    mass = np.block([[body.inertia, L.T], [L, np.eye(n)]])
    forces = np.zeros((3 + n, 6 + 2 * n))  # the right-hand side's dependence on [theta, omega, eta, eta_dot]
    forces[3:, 6 : 6 + n] = -np.diag(modes.frequency**2)
    forces[3:, 6 + n :] = -np.diag(2.0 * modes.damping * modes.frequency)
    a = np.zeros((6 + 2 * n, 6 + 2 * n))
    a[:3, 3:6] = np.eye(3)
    a[6 : 6 + n, 6 + n :] = np.eye(n)
    accelerations = np.linalg.solve(mass, forces)
    a[3:6], a[6 + n :] = accelerations[:3], accelerations[3:]
    b = np.zeros((6 + 2 * n, 3))
    input_acc = np.linalg.solve(mass, np.vstack([np.eye(3), np.zeros((n, 3))]))
    b[3:6], b[6 + n :] = input_acc[:3], input_acc[3:]
    sys = flexible_plant(body, modes)
    np.testing.assert_allclose(sys.A, a, atol=1e-12 * np.max(np.abs(a)))
    np.testing.assert_allclose(sys.B, b, atol=1e-12 * np.max(np.abs(b)))
    np.testing.assert_array_equal(sys.C, np.hstack([np.diag([0.5, 0.5, 0.5, 1, 1, 1]), np.zeros((6, 2 * n))]))


def test_linear_model_is_the_jacobian_of_the_numpy_equations():
    """The Jacobian agrees with central differences of the numpy evaluation of the same function.

    Central differences with step 1e-6 have a truncation error ~h^2 |f'''| and a
    rounding error ~eps |f| / h ~ 1e-10; 1e-7 relative to the largest entry
    bounds both.
    """
    flexible = FlexibleBody(RigidBody(FULL_TENSOR), _two_modes(damping=0.05))
    a, b = flexible.jacobians_at_rest()
    m, h = flexible.n_states - 1, 1e-6

    def f(x, tau):
        return np.array(flexible.error_state_derivative_components(list(x), list(tau)))

    numeric_a = np.column_stack([(f(h * e, np.zeros(3)) - f(-h * e, np.zeros(3))) / (2 * h) for e in np.eye(m)])
    numeric_b = np.column_stack([(f(np.zeros(m), h * e) - f(np.zeros(m), -h * e)) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(a, numeric_a, atol=1e-7 * np.max(np.abs(a)))
    np.testing.assert_allclose(b, numeric_b, atol=1e-7 * np.max(np.abs(b)))


def test_rigid_limit_reproduces_the_rigid_body():
    """``L = 0``: the equations are RigidBody's bit for bit, the modes decouple, and the linear model's rigid
    part is ``controllers.analysis.rigid_body_at_rest`` exactly."""
    body = RigidBody(FULL_TENSOR)
    modes = FlexibleModes(frequency=[3.0], damping=0.01, participation=[[0.0, 0.0, 0.0]])
    flexible = FlexibleBody(body, modes)
    rng = np.random.default_rng(5)
    q = rng.normal(size=(20, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, tau, h = rng.normal(size=(20, 3)), rng.normal(size=(20, 3)), rng.normal(size=(20, 3))
    x = np.hstack([q, w, rng.normal(size=(20, 2))])
    flexible_rate = flexible.state_derivative(x, tau, h)
    np.testing.assert_array_equal(flexible_rate[:, :7], body.state_derivative(x[:, :7], tau, h))
    # The mode is a free damped oscillator: eta'' = -2 Z W eta' - W^2 eta.
    np.testing.assert_allclose(flexible_rate[:, 8], -0.06 * x[:, 8] - 9.0 * x[:, 7], rtol=1e-15)

    rigid = rigid_body_at_rest(body)
    sys = flexible_plant(body, modes)
    np.testing.assert_array_equal(sys.A[:6, :6], rigid.A)
    np.testing.assert_array_equal(sys.B[:6], rigid.B)
    np.testing.assert_array_equal(sys.C[:, :6], rigid.C)
    assert not np.any(sys.A[:6, 6:]) and not np.any(sys.A[6:, :6]) and not np.any(sys.B[6:])


def test_rigid_limit_simulation_flies_the_rigid_body_rk4():
    """``L = 0`` in :func:`simulate_flexible`: the rigid body's own compiled RK4 (``casadi_rk4_step``) with the
    same step and torque gives the same attitude and rate to rounding (1e-13 over 200 steps)."""
    body = RigidBody(FULL_TENSOR)
    modes = FlexibleModes(frequency=[3.0], damping=0.0, participation=[[0.0, 0.0, 0.0]])
    q0, w0, torque = np.array([1.0, 0.0, 0.0, 0.0]), np.array([0.3, -0.2, 0.5]), np.array([0.1, 0.0, -0.05])
    result = simulate_flexible(body, modes, q0, w0, 2.0, dt=0.01, disturbance=torque)
    step = casadi_rk4_step(body, substeps=result.info["substeps"])
    x = np.r_[q0, w0]
    for k in range(1, result.t.size):
        x = np.asarray(step(x, torque, 0.01)).reshape(-1)
        np.testing.assert_allclose(result.q[k], x[:4], atol=1e-13)
        np.testing.assert_allclose(result.omega[k], x[4:], atol=1e-13)
    np.testing.assert_array_equal(result.eta, 0.0)


# ---------------------------------------------------------------------------
# The nonlinear simulation: conservation, damping, agreement with the linear model


def test_energy_and_angular_momentum_are_conserved_without_damping_and_torque():
    """Torque-free, undamped: ``T + V`` and ``H_N = rotate(q, I omega + L^T eta_dot)`` are constant.

    Both follow from the equations (docs/flexible_modes.md: ``dE/dt = omega.tau
    - sum 2 Z W eta_dot^2``; ``dH_N/dt = rotate(q, tau)``). The tumbling body
    (rates 0.05 rad/s) with both modes excited is flown over 50 s, 55 periods
    of the slower unconstrained mode and 134 of the faster one. RK4 on an
    oscillator of frequency w with step h loses a fraction ``(w h)^6 / 72`` of
    its energy per step (``|R(i w h)|^2``), so the drift is bounded by ``N (w
    h)^6 / 72`` of the energy for ``N`` steps (8.4e-5 here); the angular
    momentum, which the exact flow rotates rigidly, is kept to 1e-9 relative
    (the rigid rates' RK4 error ``(|omega| h)^5`` is ~1e-17 per step).
    """
    body = RigidBody(FULL_TENSOR)
    modes = _two_modes()
    result = simulate_flexible(
        body, modes, [1.0, 0.0, 0.0, 0.0], [0.05, -0.03, 0.04], 50.0, dt=0.05, eta0=[0.01, -0.005],
        eta_dot0=[0.02, 0.01],
    )  # fmt: skip
    w_max = FlexibleBody(body, modes).unconstrained_frequencies().max()
    nu = w_max * result.info["step_s"]
    assert nu <= MODE_STEP_MAX_RAD
    steps = (result.t.size - 1) * result.info["substeps"]
    energy_drift = np.max(np.abs(result.energy - result.energy[0])) / result.energy[0]
    assert energy_drift < steps * nu**6 / 72.0
    momentum_drift = np.max(np.linalg.norm(result.momentum_N - result.momentum_N[0], axis=1))
    assert momentum_drift < 1e-9 * np.linalg.norm(result.momentum_N[0])
    assert np.ptp(result.eta[:, 0]) > 0.01  # the modes did vibrate


def test_damping_dissipates_energy_but_keeps_the_angular_momentum():
    """Damped, torque-free: ``dE/dt = -sum 2 Z W eta_dot^2 <= 0``, so the energy never rises (beyond RK4's
    ~1e-12 relative rounding per tick) and falls; the angular momentum stays (1e-9 relative, as above)."""
    body = RigidBody(FULL_TENSOR)
    result = simulate_flexible(
        body, _two_modes(damping=0.05), [1.0, 0.0, 0.0, 0.0], [0.05, -0.03, 0.04], 20.0, dt=0.05, eta0=[0.05, 0.02]
    )
    assert np.all(np.diff(result.energy) < 1e-12 * result.energy[0])
    assert result.energy[-1] < result.energy[0] - 0.5 * (0.5 * (2 * np.pi) ** 2 * (0.05**2 + 6.25 * 0.02**2))
    momentum_drift = np.max(np.linalg.norm(result.momentum_N - result.momentum_N[0], axis=1))
    assert momentum_drift < 1e-9 * np.linalg.norm(result.momentum_N[0])


def test_small_amplitude_response_agrees_with_the_linear_model():
    """From a small initial state (rates 1e-6 rad/s, modal coordinates 1e-6), the nonlinear simulation follows
    the linear model's exact solution ``expm(A t) x0``.

    The differences: the quadratic terms (relative size ~|x| = 1e-6) and
    RK4's phase error ``(w h)^5 / 120`` per step of the fastest mode,
    accumulated over ``N`` steps (1.1e-4 rad here); the tolerance is twice
    their sum, relative to each signal's largest value.
    """
    body = RigidBody(FULL_TENSOR)
    modes = _two_modes()
    x0 = 1e-6 * np.array([0, 0, 0, 1.0, -2.0, 0.5, 1.0, -1.0, 0.5, 2.0])
    result = simulate_flexible(body, modes, [1.0, 0.0, 0.0, 0.0], x0[3:6], 10.0, dt=0.05, eta0=x0[6:8], eta_dot0=x0[8:])
    a = flexible_plant(body, modes).A
    linear = np.array([scipy.linalg.expm(a * t) @ x0 for t in result.t])
    nu = FlexibleBody(body, modes).unconstrained_frequencies().max() * result.info["step_s"]
    tolerance = 2.0 * ((result.t.size - 1) * result.info["substeps"] * nu**5 / 120.0 + 1e-6)
    for simulated, predicted in (
        (result.q[:, 1:], linear[:, :3] / 2.0),
        (result.omega, linear[:, 3:6]),
        (result.eta, linear[:, 6:8]),
        (result.eta_dot, linear[:, 8:]),
    ):
        assert np.max(np.abs(simulated - predicted)) < tolerance * np.max(np.abs(predicted))


class _RecordingRateDamper:
    """A Controller (``period``, ``torque(t, estimate)``): ``tau = -k omega``, recording when it was called."""

    def __init__(self, gain: float, period: float) -> None:
        self.gain, self.period, self.calls = gain, period, []

    def torque(self, t, estimate):
        self.calls.append(t)
        return -self.gain * estimate.omega


def test_a_controller_is_sampled_at_its_period_and_held():
    """The controller runs every 0.2 s on ticks of 0.05 s; its command is held over its period (zero-order
    hold: four equal rows), and a rate damper takes energy out of the flexible body (``dE/dt = omega.tau``)."""
    controller = _RecordingRateDamper(gain=20.0, period=0.2)
    result = simulate_flexible(
        RigidBody(FULL_TENSOR), _two_modes(), [1.0, 0.0, 0.0, 0.0], [0.02, 0.0, -0.01], 4.0, controller=controller,
        dt=0.05, eta0=[0.01, 0.0],
    )  # fmt: skip
    np.testing.assert_allclose(controller.calls, 0.2 * np.arange(20))
    held = result.torque[:-1].reshape(20, 4, 3)
    np.testing.assert_array_equal(held, np.repeat(held[:, :1], 4, axis=1))
    np.testing.assert_allclose(held[:, 0], -20.0 * result.omega[::4][:20], rtol=1e-15)
    assert result.energy[-1] < 0.5 * result.energy[0]


def test_sampled_pd_on_the_flexible_body_follows_the_discrete_linear_closed_loop():
    """A QuaternionPD flown by :func:`simulate_flexible` (held over its 0.1 s period) follows the exact
    zero-order-hold discretisation of ``flexible_plant`` closed by ``u = -[K C] y`` (the convention of
    ``controllers.analysis``), from a small error (1e-5 rad, 1e-6 rad/s).

    The differences are the quadratic terms, ~1e-5 of the signal (the error's size), and RK4's phase error
    (docstring of :mod:`attitude.simulation.flexible_flight`, below 1e-5 over these 600 steps); 1e-4 of each
    signal's peak bounds both with margin, while a torque held over the wrong interval or a sign slip
    would be off by order one.
    """
    body = RigidBody(FULL_TENSOR)
    modes = FlexibleModes.from_hz(
        frequency_Hz=[0.3, 1.1], damping=0.002, participation=[[0.0, 0.5, 6.0], [3.0, 0, 0.5]]
    )
    pd = QuaternionPD.from_bandwidth(body, wn=0.5, zeta=0.7, period=0.1)
    theta0, omega0 = 1e-5 * np.array([1.0, -2.0, 3.0]), 1e-6 * np.array([1.0, 1.0, -1.0])
    result = simulate_flexible(body, modes, quat.from_rotation_vector(theta0), omega0, 20.0, controller=pd)
    discrete = control.c2d(flexible_plant(body, modes), 0.1, method="zoh")
    closed = discrete.A - discrete.B @ np.hstack([pd.K, pd.C]) @ discrete.C
    x = [np.r_[theta0, omega0, np.zeros(4)]]
    for _ in range(result.t.size - 1):
        x.append(closed @ x[-1])
    x = np.array(x)
    for simulated, predicted in (
        (quat.to_rotation_vector(result.q), x[:, :3]),
        (result.omega, x[:, 3:6]),
        (result.eta, x[:, 6:8]),
    ):
        assert np.max(np.abs(simulated - predicted)) < 1e-4 * np.max(np.abs(predicted))
    assert np.max(np.abs(x[-1, :6])) < 1e-2 * np.max(np.abs(x[:, :6]))  # the loop did settle (wn t = 10)


def test_the_result_saves_loads_and_plots(tmp_path):
    """``save``/``load`` give back every array bit for bit (.npz, no pickle); ``plot()`` draws the four
    panels, the modes' panel one line per mode."""
    result = simulate_flexible(
        RigidBody(FULL_TENSOR), _two_modes(0.01), [1.0, 0.0, 0.0, 0.0], [0.01, 0.0, 0.0], 1.0, dt=0.1, eta0=[0.01, 0.0]
    )
    loaded = type(result).load(result.save(tmp_path / "flexible"))
    for name in ("t", "q", "omega", "eta", "eta_dot", "torque", "energy", "momentum_N"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(result, name))
    assert loaded.info == result.info
    fig = result.plot()
    fig.savefig(tmp_path / "flexible.png")
    axes = fig.get_axes()
    assert len(axes) == 4 and len(axes[2].get_lines()) == 2


# ---------------------------------------------------------------------------
# Bad input


@pytest.mark.parametrize(
    ("kwargs", "name"),
    [
        ({"frequency": [3.0], "damping": -0.01, "participation": [[1.0, 0, 0]]}, "damping"),
        ({"frequency": [3.0], "damping": 1.0, "participation": [[1.0, 0, 0]]}, "damping"),
        ({"frequency": [0.0], "damping": 0.01, "participation": [[1.0, 0, 0]]}, "frequency"),
        ({"frequency": [np.nan], "damping": 0.01, "participation": [[1.0, 0, 0]]}, "frequency"),
        ({"frequency": [3.0, 4.0], "damping": [0.01], "participation": [[1.0, 0, 0]] * 2}, "damping"),
        ({"frequency": [3.0, 4.0], "damping": 0.01, "participation": [[1.0, 0, 0]]}, "participation"),
        ({"frequency": [3.0], "damping": 0.01, "participation": [[np.inf, 0, 0]]}, "participation"),
    ],
)
def test_bad_modes_are_refused_naming_the_argument(kwargs, name):
    """Each bad value raises ValueError whose message starts with the argument's name."""
    with pytest.raises(ValueError, match=rf"^{name}"):
        FlexibleModes(**kwargs)


def test_bad_hz_frequency_and_oversized_participation_are_refused():
    """``from_hz`` names ``frequency_Hz``; ``I - L^T L`` not positive definite names ``modes.participation``
    (l^2 = 100 = I_x leaves no inertia about x: the mass matrix is singular)."""
    with pytest.raises(ValueError, match=r"^frequency_Hz must be strictly positive"):
        FlexibleModes.from_hz(frequency_Hz=[-1.0], damping=0.0, participation=[1.0, 0.0, 0.0])
    modes = FlexibleModes(frequency=[3.0], damping=0.0, participation=[[10.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"^modes.participation must leave I - L\^T L positive definite"):
        FlexibleBody(RigidBody([100.0, 120.0, 80.0]), modes)
    with pytest.raises(ValueError, match=r"modes.participation"):
        flexible_plant(RigidBody([100.0, 120.0, 80.0]), modes)


def test_simulation_arguments_are_checked():
    """A controller period that is not a whole multiple of ``dt``, a missing tick and a bad initial modal
    state are refused, each naming its argument."""
    body, modes = RigidBody(FULL_TENSOR), _two_modes()
    with pytest.raises(ValueError, match=r"controller.period"):
        simulate_flexible(body, modes, [1, 0, 0, 0], [0, 0, 0], 1.0, controller=_RecordingRateDamper(1.0, 0.15), dt=0.1)
    with pytest.raises(ValueError, match=r"^dt"):
        simulate_flexible(body, modes, [1, 0, 0, 0], [0, 0, 0], 1.0)
    with pytest.raises(ValueError, match=r"^eta0"):
        simulate_flexible(body, modes, [1, 0, 0, 0], [0, 0, 0], 1.0, dt=0.1, eta0=[1.0])


def test_a_controller_with_state_starts_each_run_at_rest():
    """A filtered PD (a notch: state of its own) flown twice on the flexible body gives the same run twice: the
    simulation calls ``prepare`` before each run, as the main engine does, so the filter does not carry the first
    run's state into the second (bit for bit: the same arithmetic)."""
    from controllers import FilteredController, NotchFilter

    body = RigidBody(FULL_TENSOR)
    pd = QuaternionPD.from_bandwidth(body, wn=0.5, zeta=0.7, period=0.1)
    notched = FilteredController(pd, [NotchFilter(frequency=12.0, depth=0.1)])
    q0 = quat.from_axis_angle([0.0, 0.0, 1.0], np.radians(5.0))
    runs = [simulate_flexible(body, _two_modes(), q0, np.zeros(3), 5.0, controller=notched) for _ in range(2)]
    np.testing.assert_array_equal(runs[0].torque, runs[1].torque)

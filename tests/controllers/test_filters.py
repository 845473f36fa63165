"""Notch and low-pass filters (controllers.filters) against analytic responses, scipy, and a flexible mode.

What each test checks against:

* The filters' responses at their centre or corner frequency, DC and high frequency, from the transfer
  functions' closed forms: the notch ``(s^2 + 2 zeta_z w s + w^2) / (s^2 + 2 zeta_p w s + w^2)`` has
  ``|H(j w)| = zeta_z / zeta_p`` and zero phase at ``w``; the first-order low-pass is -3 dB
  (``1 / sqrt(2)``) and the second-order ``1 / (2 zeta)`` at the corner.
* Tustin with pre-warping at ``w`` (Franklin, Powell and Workman, *Digital Control of Dynamic Systems*,
  3rd ed., sec. 6.3.2): the discrete response at ``w`` is the continuous one at ``w`` exactly, so the
  discrete notch's minimum sits at ``w``; without pre-warping it sits at ``(2 / T) atan(w T / 2)``. Tustin
  maps ``s = 0`` to ``z = 1`` and ``s = inf`` to ``z = -1`` (the Nyquist frequency).
* The filtered controller in the engine against an independent implementation: scipy.signal.lfilter
  with the same discrete coefficients on the logged unfiltered command.
* The loop analysis: the filtered loop's frequency response is the unfiltered one times the filter's.
* A flexible plant built here from the analytic collocated transfer function of one mode (Hughes,
  *Spacecraft Attitude Dynamics*, 1986; Wie, *Space Vehicle Dynamics and Control*, 2nd ed., ch. 7):
  the notch at the mode gives back the rigid PD loop's disk margin ``2 zeta / sqrt(1 + zeta^2)`` less
  the phase the hold, the delay and the notch take at the crossover.
* The Nichols chart's excluded region against the disk's closed-form gain and phase margins (Seiler,
  Packard and Gahinet, IEEE Control Systems Magazine 40(5), 2020).
"""

import math
import warnings

import control
import numpy as np
import pytest
import scipy.optimize
import scipy.signal

from attitude import RigidBody, simulate
from controllers import (
    FilteredController,
    LowPassFilter,
    NotchFilter,
    QuaternionPD,
    loop_disk_margins,
    loop_gain,
    plot_nichols,
)


def response(sys, w, period=None):
    """``H(j w)`` or ``H(exp(j w T))`` from the transfer function's polynomials."""
    num, den = np.ravel(sys.num[0][0]), np.ravel(sys.den[0][0])
    x = 1j * w if period is None else np.exp(1j * w * period)
    return np.polyval(num, x) / np.polyval(den, x)


# ---------------------------------------------------------------------------
# The filters
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(("zeta_pole", "depth"), [(0.5, 0.1), (0.2, 0.0), (0.7, 0.5)])
def test_the_notch_has_its_depth_at_the_centre_and_unit_gain_far_from_it(zeta_pole, depth):
    """|H(j w)| = zeta_z / zeta_p with zero phase; H(0) = 1; |H(j W) - 1| ~ 2 (zeta_p - zeta_z) w / W for
    W >> w. Rounding of the polynomial evaluation: 1e-12."""
    w0 = 3.0
    notch = NotchFilter(frequency=w0, zeta_pole=zeta_pole, depth=depth)
    assert notch.zeta_zero == pytest.approx(depth * zeta_pole, rel=1e-15)
    centre = response(notch.continuous(), w0)
    assert abs(centre) == pytest.approx(depth, abs=1e-12)
    assert abs(centre.imag) < 1e-12
    assert response(notch.continuous(), 0.0) == pytest.approx(1.0, abs=1e-15)
    high = 1e6 * w0
    assert abs(response(notch.continuous(), high) - 1.0) == pytest.approx(
        2 * (zeta_pole - notch.zeta_zero) * w0 / high, rel=1e-5
    )


def test_the_pre_warped_tustin_notch_is_centred_where_the_continuous_one_is():
    """The discrete notch at 0.6 x Nyquist: |H| = depth at exactly w (1e-12: rounding), H = 1 at DC and at
    Nyquist (Tustin's z = 1 and z = -1, exact); its minimum found by a bounded search (xatol 1e-10 rad/s)
    sits at w to 1e-7 relative. The plain Tustin notch's minimum sits at the warped (2/T) atan(w T/2)."""
    period = 0.1
    w0 = 0.6 * math.pi / period
    notch = NotchFilter(frequency=w0, zeta_pole=0.3, depth=0.05)
    discrete = notch.discrete(period)
    assert discrete.dt == period
    assert abs(response(discrete, w0, period)) == pytest.approx(0.05, abs=1e-12)
    assert response(discrete, 0.0, period) == pytest.approx(1.0, abs=1e-12)
    assert response(discrete, math.pi / period, period) == pytest.approx(1.0, abs=1e-12)

    def minimum(sys):
        found = scipy.optimize.minimize_scalar(
            lambda w: abs(response(sys, w, period)),
            bounds=(0.5 * w0, 0.99 * math.pi / period),
            method="bounded",
            options={"xatol": 1e-10},
        )
        return found.x

    assert minimum(discrete) == pytest.approx(w0, rel=1e-7)
    plain = control.sample_system(notch.continuous(), period, method="tustin")
    warped = 2.0 / period * math.atan(w0 * period / 2.0)
    assert minimum(plain) == pytest.approx(warped, rel=1e-7)
    assert warped < 0.9 * w0  # the shift pre-warping removes is large here


@pytest.mark.parametrize("sampled", [False, True])
def test_the_low_pass_filters_at_their_corner(sampled):
    """First order: 1 / sqrt(2) (-3.01 dB) and -45 deg at the corner; second order: 1 / (2 zeta) and -90 deg.
    The discrete (pre-warped) filters have the same values at the corner and DC gain 1; Tustin puts the
    zeros at infinity at z = -1, so the gain at Nyquist is 0. Rounding: 1e-12."""
    period = 0.05
    wc = 0.4 * math.pi / period
    cases = [
        (LowPassFilter(frequency=wc, order=1), 1 / math.sqrt(2), -45.0),
        (LowPassFilter(frequency=wc), 1 / (2 * (1 / math.sqrt(2))), -90.0),
        (LowPassFilter(frequency=wc, damping=0.3), 1 / 0.6, -90.0),
    ]
    for lowpass, gain, phase_deg in cases:
        sys = lowpass.discrete(period) if sampled else lowpass.continuous()
        at = response(sys, wc, period if sampled else None)
        assert abs(at) == pytest.approx(gain, abs=1e-12)
        assert math.degrees(np.angle(at)) == pytest.approx(phase_deg, abs=1e-9)
        assert response(sys, 0.0, period if sampled else None) == pytest.approx(1.0, abs=1e-12)
        if sampled:
            assert abs(response(sys, math.pi / period, period)) < 1e-12


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: NotchFilter(frequency=0.0, depth=0.1), "frequency must be strictly positive, got 0"),
        (lambda: NotchFilter(frequency=-1.0, depth=0.1), "frequency must be strictly positive"),
        (lambda: NotchFilter(frequency=1.0, zeta_pole=0.0, depth=0.1), "zeta_pole must be strictly positive"),
        (lambda: NotchFilter(frequency=1.0), "exactly one of zeta_zero"),
        (lambda: NotchFilter(frequency=1.0, depth=0.1, zeta_zero=0.05), "exactly one of zeta_zero"),
        (lambda: NotchFilter(frequency=1.0, depth=1.0), r"depth must be in \[0, 1\).*got 1.0"),
        (lambda: NotchFilter(frequency=1.0, zeta_pole=0.3, zeta_zero=0.4), "zeta_zero must be below zeta_pole"),
        (lambda: LowPassFilter(frequency=1.0, damping=0.0), "damping must be strictly positive"),
        (lambda: LowPassFilter(frequency=1.0, order=1, damping=0.7), "damping is for the second-order"),
        (lambda: LowPassFilter(frequency=1.0, order=3), "order must be 1 or 2, got 3"),
    ],
)
def test_bad_filter_arguments_are_named(make, match):
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize("frequency", [math.pi / 0.1, 40.0])
def test_a_filter_at_or_above_nyquist_is_refused_by_name(frequency):
    """pi / 0.1 s = 31.4 rad/s: at it and above it, the error names the filter, the argument, the rule and
    both values, from the filter and from the controller that would fly it."""
    pd = QuaternionPD.from_bandwidth(RigidBody(np.diag([10.0, 10.0, 10.0])), wn=0.3, zeta=0.7, period=0.1)
    pattern = r"NotchFilter frequency must be below the Nyquist frequency pi / period = 31\.4159 rad/s.*got frequency"
    with pytest.raises(ValueError, match=pattern):
        FilteredController(pd, [NotchFilter(frequency=frequency, depth=0.1)])
    with pytest.raises(ValueError, match=pattern):
        NotchFilter(frequency=frequency, depth=0.1).discrete(0.1)
    with pytest.raises(ValueError, match="LowPassFilter frequency must be below the Nyquist"):
        LowPassFilter(frequency=frequency).discrete(0.1)


def test_bad_chains_are_refused():
    pd = QuaternionPD.from_bandwidth(RigidBody(np.diag([10.0, 10.0, 10.0])), wn=0.3, zeta=0.7, period=0.1)
    with pytest.raises(ValueError, match="filters must be a non-empty sequence"):
        FilteredController(pd, [])
    with pytest.raises(ValueError, match="filters must be a non-empty sequence"):
        FilteredController(pd, [control.tf([1], [1, 1])])
    with pytest.raises(ValueError, match="axes must be distinct body axes"):
        FilteredController(pd, [LowPassFilter(frequency=5.0)], axes=(0, 3))
    with pytest.raises(ValueError, match="controller must have torque"):
        FilteredController(np.eye(3), [LowPassFilter(frequency=5.0)])


# ---------------------------------------------------------------------------
# Flying the filters
# ---------------------------------------------------------------------------


def test_the_filtered_command_is_scipy_lfilter_of_the_inner_command():
    """A 0.2 rad slew with a notch and a first-order low-pass on x and y: the engine flies the controller on
    the protocol path (no compiled law is claimed), logs the inner command, and the command it holds is
    scipy.signal.lfilter of that log through the same discrete stages (an independent direct-form
    recursion). Both are double-precision recursions of stable filters over 301 samples: 1e-12 of the peak.
    The z axis passes unfiltered (exactly), the attitude error is logged (reference forwarded), and a second
    run repeats the first bit for bit (prepare resets the filter states)."""
    body = RigidBody(np.diag([10.0, 12.0, 8.0]))
    q_ref = [math.cos(0.1), math.sin(0.1) / math.sqrt(2), 0.0, math.sin(0.1) / math.sqrt(2)]
    pd = QuaternionPD.from_bandwidth(body, wn=0.4, zeta=0.7, period=0.1, q_ref=q_ref)
    filters = [NotchFilter(frequency=6.0, zeta_pole=0.4, depth=0.1), LowPassFilter(frequency=10.0, order=1)]
    controller = FilteredController(pd, filters, axes=(0, 1))
    assert not hasattr(controller, "compiled_law_cacheable")
    assert not hasattr(controller, "torque_components") and not hasattr(controller, "compiled_inputs")
    result = simulate(body, [1.0, 0.0, 0.0, 0.0], np.zeros(3), 30.0, controller=controller)
    assert result.info["engine"] == "python"
    inner = result.logs["controller.torque_unfiltered"]
    expected = inner.copy()
    for f in filters:
        stage = f.discrete(0.1)
        expected[:, :2] = scipy.signal.lfilter(
            np.ravel(stage.num[0][0]), np.ravel(stage.den[0][0]), expected[:, :2], axis=0
        )
    peak = np.max(np.abs(result.torque_command))
    np.testing.assert_allclose(result.torque_command, expected, rtol=0, atol=1e-12 * peak)
    np.testing.assert_array_equal(result.torque_command[:, 2], inner[:, 2])
    assert np.max(np.abs(result.torque_command[:, 0] - inner[:, 0])) > 1e-3 * peak  # the filter did act
    assert result.error_angle[0] == pytest.approx(0.2, rel=1e-12)
    assert result.error_angle[-1] < 0.01 * result.error_angle[0]
    again = simulate(body, [1.0, 0.0, 0.0, 0.0], np.zeros(3), 30.0, controller=controller)
    np.testing.assert_array_equal(again.torque_command, result.torque_command)
    with pytest.raises(ValueError, match="engine='compiled' needs"):
        simulate(body, [1.0, 0.0, 0.0, 0.0], np.zeros(3), 1.0, controller=controller, engine="compiled")


@pytest.mark.parametrize("sampled", [True, False])
def test_the_loop_of_a_filtered_controller_is_the_loop_times_the_filter(sampled):
    """Diagonal inertia: the axes do not couple, so each broken loop is the unfiltered one times the chain
    (discrete at the period in the sampled loop, continuous otherwise), evaluated independently; 1e-9
    relative (the loops' state-space solves, conditioned ~1e4 at 0.01 rad/s)."""
    body = RigidBody(np.diag([10.0, 12.0, 8.0]))
    pd = QuaternionPD.from_bandwidth(body, wn=0.3, zeta=0.7, period=0.1)
    filters = [NotchFilter(frequency=8.0, zeta_pole=0.5, depth=0.2), LowPassFilter(frequency=15.0, damping=0.5)]
    controller = FilteredController(pd, filters, axes=(0, 2))
    w = np.geomspace(0.01, 0.95 * math.pi / 0.1, 40)
    period = 0.1 if sampled else None
    chain = np.ones(w.shape, dtype=complex)
    for f in filters:
        chain = chain * response(f.discrete(0.1) if sampled else f.continuous(), w, period)
    plain = loop_gain(body, pd, sampled=sampled)
    filtered = loop_gain(body, controller, sampled=sampled)
    for axis in range(3):
        expected = np.squeeze(plain[axis](np.exp(1j * w * 0.1) if sampled else 1j * w))
        if axis in (0, 2):
            expected = expected * chain
        got = np.squeeze(filtered[axis](np.exp(1j * w * 0.1) if sampled else 1j * w))
        np.testing.assert_allclose(got, expected, rtol=1e-9)


@pytest.mark.parametrize("sampled", [True, False])
def test_nested_chains_on_different_axes_multiply_per_axis(sampled):
    """Chains on different axes nest: a notch on z inside a low-pass on x and y. Each axis's loop is the plain one
    times the filters on that axis only (diagonal inertia, axes uncoupled), checked as above; and the flown command
    is the inner chain's output through the outer chain (the same two lfilter passes)."""
    body = RigidBody(np.diag([10.0, 12.0, 8.0]))
    pd = QuaternionPD.from_bandwidth(body, wn=0.3, zeta=0.7, period=0.1)
    notch, low = NotchFilter(frequency=8.0, zeta_pole=0.5, depth=0.2), LowPassFilter(frequency=15.0, damping=0.5)
    nested = FilteredController(FilteredController(pd, [notch], axes=[2]), [low], axes=[0, 1])
    w = np.geomspace(0.01, 0.95 * math.pi / 0.1, 40)
    period = 0.1 if sampled else None
    on_axis = {
        0: response(low.discrete(0.1) if sampled else low.continuous(), w, period),
        1: response(low.discrete(0.1) if sampled else low.continuous(), w, period),
        2: response(notch.discrete(0.1) if sampled else notch.continuous(), w, period),
    }
    plain = loop_gain(body, pd, sampled=sampled)
    filtered = loop_gain(body, nested, sampled=sampled)
    for axis in range(3):
        point = np.exp(1j * w * 0.1) if sampled else 1j * w
        expected = np.squeeze(plain[axis](point)) * on_axis[axis]
        np.testing.assert_allclose(np.squeeze(filtered[axis](point)), expected, rtol=1e-9)


# ---------------------------------------------------------------------------
# A flexible mode
# ---------------------------------------------------------------------------

J = 10.0  # total inertia about x [kg m^2]
COUPLING = 0.3  # l^2 / J
W_CANTILEVER = 10.0  # rad/s
DAMPING_MODE = 0.005
W_UNCONSTRAINED = W_CANTILEVER / math.sqrt(1.0 - COUPLING)
PERIOD = 0.1
DELAY = 0.1  # one frame
WN, ZETA = 0.3, 0.7


def flexible_plant():
    """Torque (3) to [q_v (3), omega (3)]: the x axis the collocated hub-plus-mode transfer function

    theta / u = (s^2 + 2 z W s + W^2) / (s^2 [(J - l^2) s^2 + 2 z W J s + J W^2])

    (Hughes' hybrid equations [J l; l 1] q'' + diag(0, 2 z W) q' + diag(0, W^2) q = [u; 0] eliminated: poles
    at W_u = W / sqrt(1 - l^2 / J), zeros at the cantilever W, 1 / (J s^2) at low frequency), realised in
    controllable canonical form with outputs theta / 2 and theta'; y and z are rigid double integrators.
    """
    a4, a3, a2 = J * (1 - COUPLING), 2 * DAMPING_MODE * W_CANTILEVER * J, J * W_CANTILEVER**2
    A = np.zeros((8, 8))
    B = np.zeros((8, 3))
    C = np.zeros((6, 8))
    A[0, 1] = A[1, 2] = A[2, 3] = 1.0
    A[3, 2], A[3, 3] = -a2 / a4, -a3 / a4
    B[3, 0] = 1.0 / a4
    numerator = [W_CANTILEVER**2, 2 * DAMPING_MODE * W_CANTILEVER, 1.0]  # on [xi, xi', xi'']
    C[0, 0:3] = 0.5 * np.array(numerator)
    C[3, 1:4] = numerator
    for axis, (angle, rate) in zip((1, 2), ((4, 5), (6, 7))):
        A[angle, rate] = 1.0
        B[rate, axis] = 1.0 / J
        C[axis, angle], C[3 + axis, rate] = 0.5, 1.0
    return control.ss(A, B, C, np.zeros((6, 3)))


def test_the_test_plant_is_hughes_hub_and_mode():
    """The transfer function above against the hybrid equations solved directly at each frequency,
    theta = [(-w^2 M + j w D + K)^-1]_00 u, and its poles: the double integrator and W_u (1e-9 relative:
    rounding of a 4x4 solve)."""
    plant = flexible_plant()
    poles = np.sort(np.abs(np.linalg.eigvals(plant.A[:4, :4])))
    assert poles[-1] == pytest.approx(W_UNCONSTRAINED, rel=1e-9)
    coupling = math.sqrt(COUPLING * J)
    mass = np.array([[J, coupling], [coupling, 1.0]])
    damping = np.diag([0.0, 2 * DAMPING_MODE * W_CANTILEVER])
    stiffness = np.diag([0.0, W_CANTILEVER**2])
    for w in (0.01, 1.0, W_CANTILEVER, 11.0, W_UNCONSTRAINED * 1.001, 30.0):
        theta = np.linalg.solve(-(w**2) * mass + 1j * w * damping + stiffness, [1.0, 0.0])[0]
        got = np.squeeze(plant[[0, 3], 0](1j * w))
        assert got[0] == pytest.approx(theta / 2, rel=1e-9)
        assert got[1] == pytest.approx(1j * w * theta, rel=1e-9)


def test_a_notch_at_the_mode_gives_back_the_rigid_disk_margin():
    """10 Hz PD (wn 0.3 rad/s, zeta 0.7) with a one-frame computation delay, x axis.

    Rigid continuous loop: disk margin alpha_c = 2 zeta / sqrt(1 + zeta^2) = 1.1469, disk phase margin
    phi_c = 2 atan(alpha_c / 2) = 59.7 deg, gain crossover w_c = wn sqrt(2 zeta^2 + sqrt(4 zeta^4 + 1))
    (|L| = 1 for L = (2 zeta wn s + wn^2) / s^2). Extra phase lag delta near the crossover leaves about
    phi_c - delta of the disk's phase, i.e. alpha >= 2 tan((phi_c - delta) / 2), with delta the hold and
    the delay, w_c (T/2 + tau), and the notch's lag -arg H(j w_c) at the crossover (6.0 deg in all). The
    bound holds for the rigid sampled loop (hold and delay only) and for the flexible loop with the notch.
    Without the notch the mode's resonance, seen with ~1.8 rad of hold-and-delay lag, brings the margin
    below half of alpha_c, at the mode's frequency (2 %: the peak of a 0.5 %-damped mode).
    """
    body = RigidBody(np.diag([J, J, J]))
    plant = flexible_plant()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # wn is far below a tenth of the sample rate: no warning
        pd = QuaternionPD.from_bandwidth(body, wn=WN, zeta=ZETA, period=PERIOD)
    notch = NotchFilter(frequency=W_UNCONSTRAINED, zeta_pole=0.5, depth=0.1)
    notched = FilteredController(pd, [notch], axes=(0,))

    alpha_c = 2 * ZETA / math.sqrt(1 + ZETA**2)
    phi_c = 2 * math.atan(alpha_c / 2)
    w_c = WN * math.sqrt(2 * ZETA**2 + math.sqrt(4 * ZETA**4 + 1))
    lag_hold = w_c * (PERIOD / 2 + DELAY)
    lag_notch = -float(np.angle(response(notch.continuous(), w_c)))
    assert math.degrees(lag_hold + lag_notch) == pytest.approx(6.0, abs=0.1)

    def x_axis(p, c):
        return loop_disk_margins(p, c, computation_delay=DELAY).per_axis[0]

    rigid, flexible, with_notch = x_axis(body, pd), x_axis(plant, pd), x_axis(plant, notched)
    assert rigid.closed_loop_stable and flexible.closed_loop_stable and with_notch.closed_loop_stable
    assert rigid.disk_margin >= 2 * math.tan((phi_c - lag_hold) / 2)
    assert with_notch.disk_margin >= 2 * math.tan((phi_c - lag_hold - lag_notch) / 2)
    assert with_notch.frequency_rad_s < 2.0  # decided near the rigid crossover again, not at the mode
    assert flexible.disk_margin < 0.5 * alpha_c
    assert flexible.frequency_rad_s == pytest.approx(W_UNCONSTRAINED, rel=0.02)


def test_the_nichols_chart_shades_the_disk_with_its_closed_form_margins():
    """For alpha = 2/3 the excluded region's boundary reaches -180 deg at +-20 log10((2 + alpha)/(2 - alpha))
    = +-6.02 dB and 0 dB at -180 +- 2 atan(alpha / 2) = +-36.9 deg; read from the drawn contour, to the
    contour grid's spacing (0.2 dB, 0.6 deg)."""
    body = RigidBody(np.diag([J, J, J]))
    pd = QuaternionPD.from_bandwidth(body, wn=WN, zeta=ZETA, period=PERIOD)
    alpha = 2.0 / 3.0
    fig = plot_nichols(loop_gain(flexible_plant(), pd)[:1], labels=["x"], disk_margin=alpha)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "open-loop phase [deg]" and ax.get_legend() is not None
    boundary = [
        path.vertices
        for collection in ax.collections
        if hasattr(collection, "get_paths") and type(collection).__name__ in ("QuadContourSet", "ContourSet")
        for path in collection.get_paths()
        if path.vertices.size and not collection.filled
    ]
    points = np.concatenate(boundary)
    near = points[np.abs(points[:, 0] + 180.0) < 0.6]
    gain_db = 20 * math.log10((2 + alpha) / (2 - alpha))
    assert np.max(near[:, 1]) == pytest.approx(gain_db, abs=0.2)
    assert np.min(near[:, 1]) == pytest.approx(-gain_db, abs=0.2)
    flat = points[np.abs(points[:, 1]) < 0.2]
    phase_deg = math.degrees(2 * math.atan(alpha / 2))
    assert np.max(flat[:, 0]) == pytest.approx(-180 + phase_deg, abs=0.6)
    assert np.min(flat[:, 0]) == pytest.approx(-180 - phase_deg, abs=0.6)
    with pytest.raises(ValueError, match=r"disk_margin must be in \(0, 2\)"):
        plot_nichols(loop_gain(body, pd)[:1], disk_margin=2.0)

"""Linear analysis: loop gains, margins against independent computations, sampling, figures.

What each group checks against:

* Loop gains and closed loops: the PD on the linearised rigid body as a double integrator per
  axis, ``(2 zeta wn s + wn^2) / s^2`` and the second-order closed loop
  ``wn^2 / (s^2 + 2 zeta wn s + wn^2)``, derived by hand; coupled channels against a direct matrix
  computation ``L_i = [(I + G F_i)^-1 G]_ii`` with ``G(jw) = Gc C (jw I - A)^-1 B`` (the
  loop-at-a-time break at the plant input, numpy only).
* Sampled loop gains (a controller with a period): against python-control's ``sample_system``
  (zero-order hold) of the plant with the gain applied to the samples, the other channels closed
  through the same hold, evaluated on the unit circle with numpy (a frame of delay as ``z^-1``);
  the phase margin lower than the continuous one by ``omega_c T / 2`` (the hold's half-period
  delay) and a gain margin at the Nyquist frequency that the continuous loop does not have.
* Margins: three independent computations agree: :func:`controllers.analysis.margins` (built on
  python-control's ``control.stability_margins``), :func:`controllers.analysis.sweep_margins` (its
  own frequency grid refined by ``scipy.optimize.brentq``), and closed forms worked by hand: the
  PD on a double integrator (no phase crossover, infinite gain margin both ways, crossover and
  phase margin by hand); the sampled PD's gain margin ``2 / (a T)`` at the Nyquist frequency from
  its zero-order-hold equivalent; the third-order loop ``2 / (s (s+1) (s+2))`` (gain margin 3 at
  ``sqrt 2``); the conditionally stable loop ``10 (s+1)^2 / (s^3 (s+10))`` (lower gain margin
  0.625, checked by closing the loop at gains on either side).
* Sampling and delay: the exact discrete equivalent with a zero-order hold and a computation
  delay (the modified z-transform, Franklin, Powell and Workman, *Digital Control of Dynamic
  Systems*, 3rd ed., sec. 4.3.4) against python-control's ``c2d(..., "zoh")`` (no delay; one frame
  of delay as ``z^-1``) and against a continuous simulation with ``scipy.signal.lsim`` (fractional
  delays); the classical estimate that the hold and the delay cost ``omega_c (T / 2 + tau_d)`` of
  phase margin, and the Pade-delay continuous approximation.
* Figures: the Bode panels mark the margins, and the step panels the second-order overshoot
  ``100 exp(-pi zeta / sqrt(1 - zeta^2))`` %.
* Bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

import math

import control
import numpy as np
import pytest
import scipy.signal
from matplotlib.figure import Figure

from attitude import RigidBody
from attitude.linearize import linearize
from controllers.analysis import (
    Margins,
    SampleTimeStudy,
    attitude_closed_loop,
    delayed_loop,
    loop_gain,
    margins,
    plot_bode,
    plot_step,
    rigid_body_at_rest,
    sample_time_study,
    sampled_loop,
    sweep_margins,
)
from controllers.lqr import bryson_weights, design_lqr
from controllers.pd import QuaternionPD, RateLimitedPD

DIAGONAL = RigidBody([10.0, 12.0, 8.0])
FULL = RigidBody([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])
WN = np.array([0.1, 0.15, 0.2])
ZETA = np.array([0.7, 0.8, 0.6])


def pd_double_integrator(wn=0.1, zeta=0.7):
    """The loop of QuaternionPD.from_bandwidth on one axis: (2 zeta wn s + wn^2) / s^2."""
    return control.tf([2 * zeta * wn, wn**2], [1.0, 0.0, 0.0])


def pd_analytic(wn, zeta):
    """Crossover [rad/s] and phase margin [deg] of (2 zeta wn s + wn^2)/s^2, by hand.

    |L(jw)| = 1  <=>  w^4 - 4 zeta^2 wn^2 w^2 - wn^4 = 0, and arg L = -180 + atan(2 zeta w / wn).
    """
    wc = wn * math.sqrt(2 * zeta**2 + math.sqrt(4 * zeta**4 + 1))
    return wc, math.degrees(math.atan(2 * zeta * wc / wn))


# ---------------------------------------------------------------------------
# Loop gains and closed loops
# ---------------------------------------------------------------------------


class TestLoopGain:
    def test_diagonal_inertia_gives_the_pd_double_integrator_per_axis(self):
        pd = QuaternionPD.from_bandwidth(DIAGONAL, wn=WN, zeta=ZETA, period=0.1)
        for L, wn, zeta in zip(loop_gain(DIAGONAL, pd, sampled=False), WN, ZETA):
            # (K/2 + C s) / (I s^2) with K = 2 I wn^2 and C = 2 I zeta wn.
            np.testing.assert_allclose(L.num[0][0], [2 * zeta * wn, wn**2], rtol=1e-12)
            np.testing.assert_array_equal(L.den[0][0], [1.0, 0.0, 0.0])

    def test_full_tensor_with_one_bandwidth_decouples_at_the_plant_input(self):
        # G = J (wn^2 + 2 zeta wn s) J^-1 / s^2 is diagonal when wn, zeta are scalars.
        pd = QuaternionPD.from_bandwidth(FULL, wn=0.1, zeta=0.7, period=0.1)
        for L in loop_gain(FULL, pd, sampled=False):
            np.testing.assert_allclose(L.num[0][0], [0.14, 0.01], rtol=1e-9)
            np.testing.assert_array_equal(L.den[0][0], [1.0, 0.0, 0.0])

    def test_coupled_channels_match_a_direct_matrix_computation(self):
        # Per-axis bandwidths on a full tensor couple the channels. Independent
        # evaluation: G(jw) = Gc C (jw I - A)^-1 B, then L_i = [(I + G F_i)^-1 G]_ii.
        pd = QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=0.1)
        loops = loop_gain(FULL, pd, sampled=False)
        plant = rigid_body_at_rest(FULL)
        gain = np.hstack([pd.K, pd.C])
        for w in (0.03, 0.15, 0.7):
            G = gain @ plant.C @ np.linalg.solve(1j * w * np.eye(6) - plant.A, plant.B)
            for i, L in enumerate(loops):
                F = np.eye(3)
                F[i, i] = 0.0
                expected = np.linalg.solve(np.eye(3) + G @ F, G)[i, i]
                # Polynomials of degree 6 with coefficients ~1e-4..1: ~1e-12 relative.
                assert complex(L(1j * w)) == pytest.approx(expected, rel=1e-9)

    def test_general_plant_and_dynamic_controller(self):
        # One axis as a plain transfer function, a PD as a dynamic (improper-free) LTI:
        # C(s) = k + c s / (tau s + 1) on the angle, plant 1 / (I s^2).
        plant = control.tf([1.0], [10.0, 0.0, 0.0])
        ctrl = control.tf([2.0 * 0.05 + 1.0, 2.0], [0.05, 1.0])  # 2 + s/(0.05 s + 1)
        (L,) = loop_gain(plant, ctrl)
        expected = control.minreal(ctrl * plant, verbose=False)
        for w in (0.1, 1.0, 10.0):
            assert complex(L(1j * w)) == pytest.approx(complex(expected(1j * w)), rel=1e-12)

    def test_rate_limited_pd_linear_region_is_the_same_loop(self):
        wl = RateLimitedPD.from_bandwidth(FULL, wn=0.1, zeta=0.7, rate_max=0.01, period=0.1)
        pd = QuaternionPD.from_bandwidth(FULL, wn=0.1, zeta=0.7, period=0.1)
        for a, b in zip(loop_gain(FULL, wl, sampled=False), loop_gain(FULL, pd, sampled=False)):
            np.testing.assert_allclose(a.num[0][0], b.num[0][0], rtol=1e-12)

    def test_mismatched_controller_is_rejected(self):
        with pytest.raises(ValueError, match="controller must map the plant's 6 outputs to its 3 inputs"):
            loop_gain(FULL, np.ones((3, 3)))
        with pytest.raises(ValueError, match="plant must be a RigidBody"):
            loop_gain("plant", np.ones((3, 6)))


def zoh_loops_by_hand(plant, gain, period, w, delay_frames=0):
    """Loop-at-a-time loops of a sampled static gain, independently: python-control's ``c2d`` (ZOH).

    ``G(z) = gain C_d (z I - A_d)^-1 B_d z^-delay_frames`` with ``(A_d, B_d, C_d)`` from
    ``control.sample_system(plant, T, "zoh")``, then ``L_i = [(I + G F_i)^-1 G]_ii`` (numpy only).
    """
    d = control.sample_system(plant, period, "zoh")
    A, B, C = (np.asarray(x, dtype=float) for x in (d.A, d.B, d.C))
    m = B.shape[1]
    out = np.empty((m, len(w)), dtype=complex)
    for k, wk in enumerate(w):
        z = np.exp(1j * wk * period)
        G = gain @ C @ np.linalg.solve(z * np.eye(A.shape[0]) - A, B) * z**-delay_frames
        for i in range(m):
            F = np.eye(m)
            F[i, i] = 0.0
            out[i, k] = np.linalg.solve(np.eye(m) + G @ F, G)[i, i]
    return out


class TestSampledLoopGain:
    """A controller with a period gives the sampled loop: ZOH on every axis, the gain on the samples."""

    T = 0.5
    W = np.geomspace(1e-2, 0.99 * math.pi / 0.5, 30)

    def response(self, loop):
        return np.array([complex(loop(np.exp(1j * w * self.T))) for w in self.W])

    @pytest.mark.parametrize("delay_frames", [0, 1])
    def test_coupled_pd_loops_match_the_c2d_plant_with_the_discrete_gain(self, delay_frames):
        # Per-axis bandwidths on a full tensor couple the channels, so the other channels' hold
        # matters too. Both sides are exact; the solves near z = 1 lose ~eps / (w T)^2 = 1e-11
        # relative at the lowest frequency, so 1e-9 is rounding with a margin.
        pd = QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=self.T)
        loops = loop_gain(FULL, pd, computation_delay=delay_frames * self.T)
        expected = zoh_loops_by_hand(rigid_body_at_rest(FULL), np.hstack([pd.K, pd.C]), self.T, self.W, delay_frames)
        for i, L in enumerate(loops):
            assert L.dt == self.T
            np.testing.assert_allclose(self.response(L), expected[i], rtol=1e-9)

    def test_lqr_design_gives_its_sampled_loop(self):
        plant = linearize(FULL)
        q_w, r_w = bryson_weights(angle_max=np.radians(2.0), rate_max=np.radians(0.5), torque_max=0.015)
        lqr = design_lqr(plant, Q=q_w, R=r_w, period=self.T)
        expected = zoh_loops_by_hand(plant, lqr.K, self.T, self.W)
        for i, L in enumerate(loop_gain(plant, lqr)):
            np.testing.assert_allclose(self.response(L), expected[i], rtol=1e-9)
        # Asked for the continuous loop, the design is its gain matrix K.
        for a, b in zip(loop_gain(plant, lqr, sampled=False), loop_gain(plant, lqr.K)):
            np.testing.assert_allclose(a.num[0][0], b.num[0][0], rtol=1e-12)

    def test_discrete_dynamic_controller_sees_the_zoh_plant(self):
        plant = control.tf([1.0], [10.0, 0.0, 0.0])
        ctrl = control.tf([2.0, -1.6], [1.0, -0.3], self.T)  # a discrete lead at dt = T
        (L,) = loop_gain(plant, ctrl)
        expected = ctrl * control.sample_system(plant, self.T, "zoh")
        np.testing.assert_allclose(self.response(L), self.response(expected), rtol=1e-9)

    def test_phase_margin_drops_by_half_a_period_of_crossover_and_the_gain_margin_appears(self):
        # Decoupled PD (diagonal inertia): continuous PM and crossover by hand (pd_analytic).
        wn, zeta = 0.2, 0.7
        wc, pm_c = pd_analytic(wn, zeta)
        period = 0.1 / wc  # omega_c T = 0.1
        pd = QuaternionPD.from_bandwidth(DIAGONAL, wn=wn, zeta=zeta, period=period)
        cont = [margins(L) for L in loop_gain(DIAGONAL, pd, sampled=False)]
        samp = [margins(L) for L in loop_gain(DIAGONAL, pd)]
        for c, s in zip(cont, samp):
            assert c.phase_margin_deg == pytest.approx(pm_c, rel=1e-9)
            assert c.dt is None and s.dt == pytest.approx(period)
            # The hold is a delay of about T/2: PM_c - PM_s ~ degrees(omega_c T / 2) = 2.86 deg.
            # Corrections of order omega_c T / 10 (crossover shift, aliasing): 1 % here, 2.5 %
            # as in the sample-time study above.
            assert pm_c - s.phase_margin_deg == pytest.approx(math.degrees(wc * period / 2), rel=0.025)
            # ... and the sampled loop, unlike the continuous one, has a gain margin (at Nyquist).
            assert math.isinf(c.gain_margin) and math.isfinite(s.gain_margin)
            assert s.phase_crossover == pytest.approx(math.pi / period)
            assert s.summary().startswith(f"sampled loop (T = {period:g} s): ")
            assert c.summary().startswith("continuous loop: ")

    @pytest.mark.parametrize(
        ("call", "match"),
        [
            (lambda: loop_gain(FULL, np.ones((3, 6)), sampled=True), "sampled=True needs a controller with a period"),
            (
                lambda: loop_gain(
                    FULL,
                    QuaternionPD.from_bandwidth(FULL, wn=0.1, zeta=0.7, period=0.1),
                    sampled=False,
                    computation_delay=0.02,
                ),
                "computation_delay = 0.02 s needs the sampled loop",
            ),
            (
                lambda: loop_gain(control.tf([1.0], [1.0, 0.0, 0.0]), control.tf([1.0], [1.0], 0.1), sampled=False),
                "sampled=False needs a continuous controller",
            ),
            (lambda: loop_gain(control.tf([1.0], [1.0, 0.0, 0.0], 0.1), 1.0), "plant must be continuous"),
            (lambda: loop_gain(FULL, np.ones((3, 6)), sampled="yes"), "sampled must be True, False or None"),
            (lambda: loop_gain(FULL, np.ones((3, 6)), computation_delay=-1.0), "computation_delay must be"),
        ],
    )
    def test_bad_input_is_rejected(self, call, match):
        with pytest.raises(ValueError, match=match):
            call()


class TestClosedLoop:
    def test_attitude_closed_loop_is_the_designed_second_order_system(self):
        pd = QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=0.1)
        cl = attitude_closed_loop(FULL, pd)
        for i, (wn, zeta) in enumerate(zip(WN, ZETA)):
            expected = control.tf([wn**2], [1.0, 2 * zeta * wn, wn**2])
            for w in (0.01, wn, 1.0):
                assert complex(cl[i, i](1j * w)) == pytest.approx(complex(expected(1j * w)), rel=1e-12)
            for j in set(range(3)) - {i}:
                assert abs(complex(cl[i, j](1j * 0.1))) < 1e-12  # decoupled

    def test_controller_without_gains_is_rejected(self):
        with pytest.raises(ValueError, match="controller must have gain matrices K and C"):
            attitude_closed_loop(FULL, object())


# ---------------------------------------------------------------------------
# Margins: python-control checked against sweeps and hand results
# ---------------------------------------------------------------------------


def assert_same_margins(a: Margins, b: Margins, rel=1e-8):
    # Crossings are refined by brentq to ~1e-14 relative on one side and by
    # polynomial roots (verified) on the other: 1e-8 is rounding plus conditioning.
    for name in ("gain_margin", "gain_margin_lower", "phase_margin_deg", "delay_margin_s", "gain_crossover"):
        x, y = getattr(a, name), getattr(b, name)
        if math.isinf(x) or math.isinf(y) or x == 0.0 or y == 0.0:
            assert x == y, name
        else:
            assert x == pytest.approx(y, rel=rel), name
    assert a.stable == b.stable
    np.testing.assert_allclose(a.gain_crossovers, b.gain_crossovers, rtol=rel)
    np.testing.assert_allclose(a.phase_crossovers, b.phase_crossovers, rtol=rel)


def loops_for_comparison():
    pd = QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=0.1)
    coupled = loop_gain(FULL, pd, sampled=False)
    return {
        "pd-double-integrator": pd_double_integrator(),
        "classic-type-1": control.tf([2.0], [1.0, 3.0, 2.0, 0.0]),
        "conditionally-stable": control.tf(np.polymul([10.0], [1.0, 2.0, 1.0]), [1.0, 10.0, 0.0, 0.0, 0.0]),
        "pd-with-pade-delay": delayed_loop(pd_double_integrator(), delay=1.0, pade_order=5),
        "coupled-full-tensor": coupled[2],
        "sampled-pd": sampled_loop(pd_double_integrator(), period=0.5),
        "sampled-coupled-with-delay": sampled_loop(coupled[0], period=2.0, computation_delay=1.0),
        "fast-sampled-coupled": sampled_loop(coupled[0], period=0.005 / 0.153),
        # The sampled MIMO loops of loop_gain (state space, the other channels' modes hidden).
        "sampled-mimo-with-delay": loop_gain(FULL, pd, computation_delay=0.05)[1],
        "fast-sampled-mimo": loop_gain(FULL, QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=0.001))[0],
        "unstable": control.tf([10.0], [1.0, 3.0, 2.0, 0.0]),
    }


class TestMargins:
    @pytest.mark.parametrize("name", list(loops_for_comparison()))
    def test_margins_agree_with_an_independent_sweep(self, name):
        loop = loops_for_comparison()[name]
        assert_same_margins(margins(loop), sweep_margins(loop))

    @pytest.mark.parametrize(("wn", "zeta"), [(0.1, 0.7), (0.5, 0.3), (2.0, 1.0)])
    def test_pd_on_a_double_integrator_edge_case(self, wn, zeta):
        # arg L -> -180 deg as omega -> 0 but never reaches it: no phase crossover,
        # infinite gain margin both ways (any gain > 0 keeps s^2 + g(2 zeta wn s + wn^2) stable).
        loop = pd_double_integrator(wn, zeta)
        wc, pm = pd_analytic(wn, zeta)
        for m in (margins(loop), sweep_margins(loop)):
            assert m.gain_margin == math.inf and m.gain_margin_db == math.inf
            assert m.gain_margin_lower == 0.0
            assert math.isnan(m.phase_crossover) and m.phase_crossovers.size == 0
            assert m.gain_crossover == pytest.approx(wc, rel=1e-12)
            assert m.phase_margin_deg == pytest.approx(pm, rel=1e-12)
            assert m.delay_margin_s == pytest.approx(math.radians(pm) / wc, rel=1e-12)
            assert m.stable
        # python-control agrees on this continuous loop (its PM and crossover).
        _, pm_ct, _, _, wc_ct, _ = control.stability_margins(loop)
        assert (pm_ct, wc_ct) == pytest.approx((pm, wc), rel=1e-12)

    def test_sampled_pd_gain_margin_sits_at_the_nyquist_frequency(self):
        # ZOH equivalent of (a s + b)/s^2: a T/(z - 1) + b T^2 (z + 1)/(2 (z - 1)^2), so
        # L(-1) = -a T / 2: gain margin 2 / (a T) exactly, at omega = pi / T.
        # (control.stability_margins returns gm ~ 3e-9 at omega ~ 5e-6 rad/s here: a
        # spurious root next to the double pole at z = 1, and it never looks at pi/T.)
        T, a = 0.5, 2 * 0.7 * 0.1
        m = margins(sampled_loop(pd_double_integrator(), period=T))
        assert m.gain_margin == pytest.approx(2.0 / (a * T), rel=1e-12)
        assert m.phase_crossover == pytest.approx(math.pi / T, rel=1e-15)
        assert m.gain_margin_lower == 0.0

    def test_classic_third_order_loop(self):
        # 2 / (s (s+1) (s+2)): arg = -180 deg at w = sqrt(2), where |L| = 1/3.
        m = margins(control.tf([2.0], [1.0, 3.0, 2.0, 0.0]))
        assert m.gain_margin == pytest.approx(3.0, rel=1e-12)
        assert m.phase_crossover == pytest.approx(math.sqrt(2.0), rel=1e-12)
        # Gain crossover: w^2 (1 + w^2) (4 + w^2) = 4.
        assert m.gain_crossover**2 * (1 + m.gain_crossover**2) * (4 + m.gain_crossover**2) == pytest.approx(4.0)

    def test_conditionally_stable_loop_reports_the_lower_gain_margin_separately(self):
        # 10 (s+1)^2 / (s^3 (s+10)): arg = -180 deg at w^2 = 5/4 where |L| = 1.6, and
        # never again: reducing the gain by 1/1.6 destabilises, increasing it never does.
        loop = control.tf(np.polymul([10.0], [1.0, 2.0, 1.0]), [1.0, 10.0, 0.0, 0.0, 0.0])
        m = margins(loop)
        assert m.stable
        assert m.gain_margin == math.inf
        assert m.gain_margin_lower == pytest.approx(0.625, rel=1e-12)
        assert m.phase_crossovers == pytest.approx([math.sqrt(1.25)], rel=1e-12)
        # python-control's single gm is this lower margin (closest to 1 in log).
        assert control.stability_margins(loop)[0] == pytest.approx(0.625, rel=1e-12)
        for g, stable in ((0.62, False), (0.63, True), (100.0, True)):
            assert margins(loop * g).stable is stable

    def test_unstable_loop_is_flagged(self):
        m = margins(control.tf([10.0], [1.0, 3.0, 2.0, 0.0]))
        assert not m.stable
        assert m.phase_margin_deg < 0.0 and m.delay_margin_s == 0.0
        assert "UNSTABLE" in m.summary()

    def test_a_collocated_mode_crossing_with_phase_lead_is_a_margin_not_instability(self):
        """A PD loop on a body with a lightly damped collocated wing mode (0.3 Hz, 0.2 % damping) crosses 0 dB
        three times; at the mode's peak the phase is a lead, 180 + arg L = -101 deg, yet the closed loop is
        stable (its poles, and the disk margin's check). The phase margin is the smallest change either way that
        reaches -1 (positive), and the delay margin the smallest lag over the crossings divided by its
        frequency: a Pade delay just below it keeps the closed loop stable and just above it does not (the
        delayed loop, closed-loop poles; Pade order 6 is exact to far better than 5 % at w tau ~ 1.5 rad)."""
        from attitude.flexible import FlexibleModes
        from attitude.linearize import flexible_plant

        body = RigidBody([100.0, 120.0, 80.0])
        wings = FlexibleModes.from_hz(frequency_Hz=[0.3], damping=0.002, participation=[[0.0, 0.0, 6.0]])
        pd = QuaternionPD.from_bandwidth(body, wn=0.5, zeta=0.7, period=0.1)
        loop = loop_gain(flexible_plant(body, wings), pd, sampled=False)[2]
        m = margins(loop)
        assert m.stable and m.gain_crossovers.size == 3
        signed = [180.0 + np.degrees(np.angle(control.evalfr(loop, 1j * w))) for w in m.gain_crossovers]
        signed = [p - 360.0 if p > 180.0 else p for p in signed]
        assert min(signed) < -90.0  # the lead at the mode's peak
        assert m.phase_margin_deg == pytest.approx(min(abs(p) for p in signed), rel=1e-9)
        assert 0.0 < m.delay_margin_s < math.inf
        for factor, stable in ((0.95, True), (1.05, False)):
            delayed = delayed_loop(loop, delay=factor * m.delay_margin_s)
            poles = control.feedback(delayed, 1).poles()
            assert bool(np.all(poles.real < 0.0)) is stable

    @pytest.mark.parametrize(
        ("loop", "match"),
        [
            (control.tf([[[1.0], [1.0]]], [[[1.0, 0.0], [1.0, 1.0]]]), "loop must be SISO"),
            ("L", "loop must be a control StateSpace or TransferFunction"),
        ],
    )
    def test_bad_loops_are_rejected(self, loop, match):
        with pytest.raises(ValueError, match=match):
            margins(loop)


# ---------------------------------------------------------------------------
# Sampling and computation delay
# ---------------------------------------------------------------------------


class TestSampledLoop:
    W = np.geomspace(1e-3, 0.99 * math.pi / 0.5, 40)

    @staticmethod
    def response(sys, w):
        return np.array([complex(sys(np.exp(1j * wk * sys.dt))) for wk in w])

    def test_without_delay_it_is_the_zero_order_hold_equivalent(self):
        L, T = pd_double_integrator(), 0.5
        exact = self.response(sampled_loop(L, period=T), self.W)
        np.testing.assert_allclose(exact, self.response(control.c2d(L, T, "zoh"), self.W), rtol=1e-9)

    def test_one_frame_delay_is_a_z_inverse(self):
        L, T = pd_double_integrator(), 0.5
        exact = self.response(sampled_loop(L, period=T, computation_delay=T), self.W)
        zoh = self.response(control.c2d(L, T, "zoh"), self.W) * np.exp(-1j * self.W * T)
        np.testing.assert_allclose(exact, zoh, rtol=1e-9)

    @pytest.mark.parametrize("fraction", [0.3, 1.7])
    def test_fractional_delay_matches_a_continuous_simulation(self, fraction):
        # Independent check of the modified z-transform: a unit step computed at t = 0,
        # applied from t = tau and held, through the continuous loop, sampled at kT.
        L, T = control.tf([1.0, 0.3], [1.0, 0.5, 0.0]), 0.5
        tau = fraction * T
        n = 12
        t = np.linspace(0.0, n * T, n * 100 + 1)  # tau and every kT on the grid
        u = (t >= tau - 1e-12).astype(float)
        num, den = L.num[0][0], L.den[0][0]
        _, y_cont, _ = scipy.signal.lsim((num, den), u, t, interp=False)
        y_disc = control.step_response(sampled_loop(L, period=T, computation_delay=tau), np.arange(n + 1) * T).outputs
        # lsim with a zero-order-hold input is exact up to the matrix exponential.
        np.testing.assert_allclose(y_disc, y_cont[::100], atol=1e-10)

    @pytest.mark.parametrize("fraction", [0.0, 0.5, 1.0])
    def test_phase_margin_drops_by_wc_times_half_period_plus_delay(self, fraction):
        loop = pd_double_integrator()
        wc = margins(loop).gain_crossover
        periods = np.array([0.01, 0.05, 0.1, 0.2]) / wc
        study = sample_time_study(loop, periods=periods, computation_delay=fraction * periods)
        drop = study.continuous_phase_margin_deg - study.phase_margin_deg
        predicted = np.degrees(wc * (periods / 2 + fraction * periods))
        np.testing.assert_allclose(study.predicted_phase_margin_deg, study.continuous_phase_margin_deg - predicted)
        # The classical estimate ignores the crossover shift (the hold's sinc gain)
        # and aliasing, relative corrections of order omega_c T / 10: 1.5 % at
        # omega_c T = 0.2 here. 2.5 % is the "few percent" the rule promises.
        np.testing.assert_allclose(drop, predicted, rtol=0.025)
        # ... and it is not trivially true: the drop grows with T as predicted.
        assert np.all(np.diff(drop) > 0)

    def test_pade_approximation_agrees_with_the_exact_sampled_loop(self):
        loop, T, tau = pd_double_integrator(), 0.5, 0.25
        exact = margins(sampled_loop(loop, period=T, computation_delay=tau)).phase_margin_deg
        approx = margins(delayed_loop(loop, delay=T / 2 + tau)).phase_margin_deg
        # Same estimate as above, omega_c T = 0.077: a fraction of a percent of the drop.
        assert approx == pytest.approx(exact, abs=0.02 * (margins(loop).phase_margin_deg - exact))

    def test_study_saves_and_loads(self, tmp_path):
        study = sample_time_study(pd_double_integrator(), periods=[0.1, 0.5, 1.0])
        back = SampleTimeStudy.load(study.save(tmp_path / "study"))
        np.testing.assert_array_equal(back.phase_margin_deg, study.phase_margin_deg)
        assert back.continuous_gain_crossover == study.continuous_gain_crossover

    @pytest.mark.parametrize(
        ("call", "match"),
        [
            (lambda: sampled_loop(pd_double_integrator(), period=0.0), "period must be strictly positive"),
            (
                lambda: sampled_loop(pd_double_integrator(), period=0.1, computation_delay=-0.01),
                "computation_delay must be non-negative",
            ),
            (
                lambda: sampled_loop(sampled_loop(pd_double_integrator(), period=0.1), period=0.1),
                "loop must be continuous",
            ),
            (lambda: delayed_loop(pd_double_integrator(), delay=0.1, pade_order=0), "pade_order must be a positive"),
            (lambda: sample_time_study(control.tf([0.1], [1.0, 10.0]), periods=[0.1]), "must have a gain crossover"),
        ],
    )
    def test_bad_input_is_rejected(self, call, match):
        with pytest.raises(ValueError, match=match):
            call()


# ---------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------


class TestFigures:
    def test_bode_has_magnitude_and_phase_per_axis_with_margins(self):
        pd = QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=0.5)
        loops = [sampled_loop(L, period=2.0, computation_delay=1.0) for L in loop_gain(FULL, pd, sampled=False)]
        fig = plot_bode(loops)
        assert isinstance(fig, Figure)
        assert len(fig.axes) == 6
        assert [ax.get_title() for ax in fig.axes[:3]] == ["x axis", "y axis", "z axis"]
        assert fig.axes[0].get_ylabel() == "|L| [dB]" and fig.axes[3].get_ylabel() == "arg L [deg]"
        texts = [t.get_text() for ax in fig.axes for t in ax.texts]
        for m in (margins(L) for L in loops):
            assert f"PM = {m.phase_margin_deg:.1f} deg @ {m.gain_crossover:.3g} rad/s\ndelay margin" in "\n".join(texts)
            assert f"GM = {m.gain_margin_db:.1f} dB" in "\n".join(texts)

    def test_bode_of_a_continuous_pd_says_the_gain_margin_is_infinite(self):
        fig = plot_bode(pd_double_integrator(), labels=["pitch"])
        assert len(fig.axes) == 2 and fig.axes[0].get_title() == "pitch"
        assert any("GM = inf" in t.get_text() for t in fig.axes[0].texts)

    def test_step_panels_mark_the_designed_overshoot(self):
        pd = QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=0.1)
        fig = plot_step(attitude_closed_loop(FULL, pd))
        assert isinstance(fig, Figure) and len(fig.axes) == 3
        for ax, zeta in zip(fig.axes, ZETA):
            assert len(ax.get_lines()) >= 3  # the axis response and two cross-couplings
            expected = 100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2))
            assert any(t.get_text() == f"overshoot {expected:.1f} %" for t in ax.texts)

    def test_study_plot(self):
        fig = sample_time_study(pd_double_integrator(), periods=[0.1, 0.5, 1.0]).plot()
        assert isinstance(fig, Figure) and len(fig.axes) == 2

    def test_margins_have_the_result_protocol(self, tmp_path):
        # save/load keeps every field (and the loop, as state-space matrices) bit for bit; plot()
        # is the Bode figure of that loop with the same margins marked.
        pd = QuaternionPD.from_bandwidth(FULL, wn=WN, zeta=ZETA, period=0.5)
        for loop in (loop_gain(FULL, pd)[1], pd_double_integrator()):
            m = margins(loop)
            back = Margins.load(m.save(tmp_path / "margins"))
            for name in ("gain_margin", "gain_margin_lower", "phase_margin_deg", "delay_margin_s", "stable", "dt"):
                assert getattr(back, name) == getattr(m, name), name
            for name in ("gain_crossover", "phase_crossover"):
                assert math.isnan(getattr(m, name)) or getattr(back, name) == getattr(m, name), name
            np.testing.assert_array_equal(back.gain_crossovers, m.gain_crossovers)
            assert back.summary() == m.summary()
            w = np.array([0.05, 0.3, 1.5])
            x = np.exp(1j * w * m.dt) if m.dt else 1j * w
            np.testing.assert_allclose([complex(back.system(v)) for v in x], [complex(loop(v)) for v in x], rtol=1e-9)
            fig = back.plot(label="PD, y axis")
            assert isinstance(fig, Figure) and len(fig.axes) == 2
            assert fig.axes[0].get_title() == "PD, y axis"
            texts = "\n".join(t.get_text() for ax in fig.axes for t in ax.texts)
            assert f"PM = {m.phase_margin_deg:.1f} deg" in texts
        kept_out = Margins(**{**{f: getattr(m, f) for f in m.__dataclass_fields__}, "loop": {}})
        with pytest.raises(ValueError, match="Margins made without their loop"):
            kept_out.plot()

    def test_bad_figure_input_is_rejected(self):
        with pytest.raises(ValueError, match="labels must have one entry per system"):
            plot_bode([pd_double_integrator()], labels=["a", "b"])
        with pytest.raises(ValueError, match="as many outputs as inputs"):
            plot_step(rigid_body_at_rest(FULL))

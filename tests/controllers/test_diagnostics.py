"""Mismatch diagnostics: each finding on a case that triggers it and one that does not.

What each group checks against:

* The sampled PD loop: Jury's stability test on the zero-order-hold PD on a double integrator,
  worked by hand. Per axis, ``x_{k+1} = [[1 - a^2/2, T (1 - zeta a)], [-wn a, 1 - 2 zeta a]] x_k``
  with ``a = wn T``: trace ``2 - a^2/2 - 2 zeta a``, determinant ``1 - 2 zeta a + a^2/2``, so
  ``1 - tr + det = a^2 > 0``, ``det < 1 <=> a < 4 zeta``, ``1 + tr + det = 4 (1 - zeta a) > 0
  <=> a < 1 / zeta`` (and ``det > -1`` always for ``zeta < 1``): stable exactly while
  ``wn T < min(4 zeta, 1 / zeta)``. With a computation delay: the delay margin of the sampled loop
  from :func:`controllers.analysis.margins` (a separate computation).
* The bandwidth rule: a tenth of ``2 pi / T``, the numbers quoted in the message recomputed here.
* The LQR scale rule: the required bandwidth ``4 / (zeta t_s)`` by hand, the LQR's own
  closed-loop poles (``LQRDesign.s_poles``) against it; the CubeSat's Bryson weights on a
  1000 kg-class body (slow), on the CubeSat (none) and with a torque bound 500 times larger (fast).
* The built-in spacecraft raises no finding.
"""

import math
import warnings
from importlib.resources import files

import numpy as np
import pytest

from attitude import RigidBody
from attitude.app import assembly
from attitude.config import load_config
from attitude.linearize import linearize
from controllers.analysis import loop_gain, margins
from controllers.diagnostics import Finding, mismatch_findings, required_bandwidth
from controllers.lqr import LQRController, bryson_weights, design_lqr
from controllers.pd import QuaternionPD

DIAGONAL = RigidBody([0.39, 0.36, 0.21])
CUBESAT_WEIGHTS = {"angle_max": np.radians(1.0), "rate_max": np.radians(0.5), "torque_max": 0.002}


def pd(wn, zeta, period):
    """The PD of ``from_bandwidth`` (its own warning above a tenth of the sample rate is not under test)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return QuaternionPD.from_bandwidth(DIAGONAL, wn=wn, zeta=zeta, period=period)


def ids(findings):
    return [f.id for f in findings]


class TestSampledPD:
    @pytest.mark.parametrize("zeta", [0.7, 0.3])
    @pytest.mark.parametrize("side", [0.98, 1.02])
    def test_unstable_exactly_where_jury_says(self, zeta, side):
        # Jury: stable while wn T < min(4 zeta, 1 / zeta) (1 / zeta at 0.7, 4 zeta at 0.3).
        period = 0.1
        wn = side * min(4 * zeta, 1 / zeta) / period
        found = mismatch_findings(body=DIAGONAL, pd=pd(wn, zeta, period))
        # Either side of the Jury limit wn is far above a tenth of the sample rate (6.28 rad/s).
        assert ids(found) == (["pd_sampled_loop_unstable"] if side > 1 else ["pd_bandwidth_above_sample_rate"])
        assert (found[0].figures["pole_radius_max"] >= 1.0) == (side > 1)

    def test_unstable_message_gives_the_reason_in_words(self):
        # wn T = 1.5 > 1 / 0.7 = 1.43: unstable; 2 pi / 1 s = 6.28 rad/s, a tenth 0.628 rad/s.
        (finding,) = mismatch_findings(body=DIAGONAL, pd=pd(1.5, 0.7, 1.0))
        assert isinstance(finding, Finding)
        assert finding.message == (
            "sampled PD loop unstable: wn 1.5 rad/s above a tenth of the 6.28 rad/s sample rate (T = 1 s)"
        )
        assert finding.figures["wn_rad_per_s"] == pytest.approx(1.5, rel=1e-9)  # |s| of the designed poles
        assert finding.figures["sample_rate_rad_per_s"] == pytest.approx(2 * math.pi)
        assert finding.figures["limit_rad_per_s"] == pytest.approx(0.2 * math.pi)

    def test_above_a_tenth_of_the_sample_rate_but_stable(self):
        # 8 rad/s > 6.28 rad/s at T = 0.1 s, and wn T = 0.8 < 1.43: flagged, still stable.
        (finding,) = mismatch_findings(body=DIAGONAL, pd=pd(8.0, 0.7, 0.1))
        assert finding.id == "pd_bandwidth_above_sample_rate"
        assert finding.message.startswith("PD bandwidth: wn 8 rad/s above a tenth of the 62.8 rad/s sample rate")
        assert finding.figures["pole_radius_max"] < 1.0

    def test_just_below_a_tenth_of_the_sample_rate_is_not_flagged(self):
        assert mismatch_findings(body=DIAGONAL, pd=pd(0.99 * 0.2 * math.pi / 0.1, 0.7, 0.1)) == []

    def test_a_computation_delay_beyond_the_delay_margin_is_unstable_within_the_bandwidth_rule(self):
        # wn = 5 rad/s < 6.28 rad/s: not flagged without delay. The sampled loop's delay margin
        # (margins, a separate computation) says which extra delays destabilise it.
        controller = pd(5.0, 0.7, 0.1)
        assert mismatch_findings(body=DIAGONAL, pd=controller) == []
        delay_margin = min(margins(L).delay_margin_s for L in loop_gain(DIAGONAL, controller))
        stable = mismatch_findings(body=DIAGONAL, pd=controller, computation_delay=0.9 * delay_margin)
        unstable = mismatch_findings(body=DIAGONAL, pd=controller, computation_delay=1.2 * delay_margin)
        assert stable == []
        assert ids(unstable) == ["pd_sampled_loop_unstable"]
        assert "outside the unit circle, with a computation delay of" in unstable[0].message


class TestLQRScale:
    def test_required_bandwidth_is_four_time_constants(self):
        assert required_bandwidth(settling_time=60.0, damping=0.7) == pytest.approx(4 / (0.7 * 60.0))

    def test_cubesat_weights_on_a_1000_kg_class_body_are_far_too_slow(self):
        big = RigidBody([400.0, 450.0, 300.0])  # kg m^2: a 1000 kg-class spacecraft
        lqr = design_lqr(linearize(big), **dict(zip("QR", bryson_weights(**CUBESAT_WEIGHTS))), period=0.1)
        wn_req = 4 / (0.7 * 60.0)
        wn_slow = float(np.min(np.abs(lqr.s_poles)))
        assert wn_slow < wn_req / 3  # the case truly crosses: 0.016 against 0.032 rad/s
        (finding,) = mismatch_findings(lqr=lqr, settling_time=60.0, damping=0.7)
        assert finding.id == "lqr_bandwidth_below_requirement"
        assert finding.figures["wn_slowest_rad_per_s"] == wn_slow
        assert finding.figures["wn_required_rad_per_s"] == pytest.approx(wn_req)
        assert f"wn {wn_slow:.3g} rad/s" in finding.message and "0.0952 rad/s" in finding.message
        assert "different scale of spacecraft" in finding.message
        # Without the requirement nothing is judged against it.
        assert mismatch_findings(lqr=lqr) == []

    def test_cubesat_weights_on_the_cubesat_are_not_flagged(self):
        lqr = design_lqr(linearize(DIAGONAL), **dict(zip("QR", bryson_weights(**CUBESAT_WEIGHTS))), period=0.1)
        wn = np.abs(lqr.s_poles)
        assert np.min(wn) > 4 / (0.7 * 60.0) / 3 and np.max(wn) < 0.2 * math.pi / 0.1
        assert mismatch_findings(lqr=lqr, settling_time=60.0, damping=0.7) == []

    def test_weights_of_a_big_spacecraft_on_the_cubesat_are_too_fast_for_the_sample_rate(self):
        weights = dict(CUBESAT_WEIGHTS, torque_max=1.0)  # a 1 N m torque bound: 500 times the CubeSat's
        lqr = design_lqr(linearize(DIAGONAL), **dict(zip("QR", bryson_weights(**weights))), period=0.1)
        wn_fast = float(np.max(np.abs(lqr.s_poles)))
        assert wn_fast > 0.2 * math.pi / 0.1
        (finding,) = mismatch_findings(lqr=lqr, settling_time=60.0, damping=0.7)
        assert finding.id == "lqr_bandwidth_above_sample_rate"
        assert f"wn {wn_fast:.3g} rad/s, is above a tenth of the 62.8 rad/s sample rate" in finding.message

    def test_continuous_design_flown_too_slowly_is_unstable(self):
        weights = dict(CUBESAT_WEIGHTS, torque_max=1.0)
        continuous = design_lqr(linearize(DIAGONAL), **dict(zip("QR", bryson_weights(**weights))))
        with pytest.warns(UserWarning, match="above a tenth of the sample rate"):
            flown = LQRController(continuous, period=0.1)
        found = mismatch_findings(lqr=flown)
        assert ids(found) == ["lqr_bandwidth_above_sample_rate", "lqr_sampled_loop_unstable"]
        assert found[1].message.startswith("sampled LQR loop unstable: wn ")


def test_the_built_in_spacecraft_raises_none():
    config = load_config(files("attitude") / "data" / "default_spacecraft.toml")
    body = assembly.rigid_body(config)
    _, lqr = assembly.lqr(config, body)
    found = mismatch_findings(
        body=body,
        pd=assembly.quaternion_pd(config, body),
        lqr=lqr,
        settling_time=config.requirements.settling_time_s,
        damping=config.control.damping,
    )
    assert found == []


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"pd": QuaternionPD.from_bandwidth(DIAGONAL, wn=0.2, zeta=0.7, period=0.1)}, "body must be the RigidBody"),
        ({"body": DIAGONAL, "pd": object()}, "pd must have a period"),
        ({"lqr": "lqr"}, "lqr must be an LQRDesign or an LQRController"),
        ({"settling_time": 60.0}, "settling_time and damping must be given together"),
        ({"computation_delay": -1.0}, "computation_delay must be non-negative"),
    ],
)
def test_bad_input_is_rejected(kwargs, match):
    with pytest.raises(ValueError, match=match):
        mismatch_findings(**kwargs)

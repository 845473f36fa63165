"""Flying the guidance modes: nadir pointing on an elliptic orbit over one orbit, a ground-target pass.

* Nadir: the boresight (body z) stays on nadir within the controller's tracking error (the error
  angle bounds the angle of any body axis from its reference), and with the reference's angular
  acceleration fed forward the closed loop is ``I omega_e' + C omega_e + K q_e,v = 0`` exactly
  (Schaub and Junkins, sec. 8.3), so after the start error decays the error is rounding, while
  without the feedforward it is the quasi-static ``q_e,v = K^-1 I omega_dot_LN`` of the elliptic
  orbit's LVLH acceleration (order ``e n^2``).
* The Python and the compiled engines fly the same law (one definition, two evaluators).
"""

from __future__ import annotations

import dataclasses
from datetime import timedelta

import numpy as np
import pytest

from attitude import quaternion as quat
from attitude.environment import Epoch, KeplerOrbit
from attitude.rigid_body import RigidBody
from attitude.simulation import simulate
from controllers import GroundTarget, GroundTargetReference, GuidanceController, NadirPointing, SunReference

ELLIPTIC = KeplerOrbit.from_altitudes(400e3, 4000e3, inclination=1.0, raan=0.3, argument_of_perigee=0.7)
BODY = RigidBody(np.diag([10.0, 12.0, 8.0]))
WN, ZETA, PERIOD = 0.05, 0.7, 1.0


def _start(reference, t0, error_deg):
    q_r, w_r, _ = reference.reference(t0)
    offset = quat.from_axis_angle([1.0, 2.0, -1.0], np.radians(error_deg))
    return quat.multiply(q_r, offset), quat.rotate_inverse(offset, w_r)


def test_nadir_boresight_on_nadir_within_the_tracking_error_over_an_elliptic_orbit():
    ctrl = NadirPointing(ELLIPTIC, BODY, wn=WN, zeta=ZETA, period=PERIOD)
    q0, w0 = _start(ctrl.guidance, 0.0, 3.0)
    duration = np.round(ELLIPTIC.period)
    res = simulate(BODY, q0, w0, duration, controller=ctrl, engine="compiled")
    assert res.info["engine"] == "compiled"
    r = ELLIPTIC.position_N(res.t)
    boresight = quat.rotate(res.q, [0.0, 0.0, 1.0])
    nadir = -r / np.linalg.norm(r, axis=1, keepdims=True)
    off_nadir = np.arctan2(np.linalg.norm(np.cross(boresight, nadir), axis=1), np.sum(boresight * nadir, axis=1))
    # Any body axis is within the attitude error of its reference axis (both angles to rounding, 1e-15).
    assert np.all(off_nadir <= res.error_angle + 1e-15)
    # Start error 3 deg decays as exp(-zeta wn t) = exp(-0.035 t): 1e-15 of it after 1000 s. The
    # feedforward makes the error dynamics exact at the ticks; what is left is the reference moving
    # under the held torque, first order in the period (measured 1.3e-7 rad at T = 1 s and 6.6e-8 at
    # 0.5 s), against 1.4e-4 rad without the feedforward (next test).
    late = res.t > 1000.0
    assert np.max(res.error_angle[late]) < 3e-7


def test_without_feedforward_the_elliptic_orbit_leaves_the_quasi_static_error():
    with_ff = NadirPointing(ELLIPTIC, BODY, wn=WN, zeta=ZETA, period=PERIOD)
    without = NadirPointing(ELLIPTIC, BODY, wn=WN, zeta=ZETA, period=PERIOD, feedforward=False)
    q0, w0 = _start(with_ff.guidance, 0.0, 0.0)
    t_end = 3000.0
    res_ff = simulate(BODY, q0, w0, t_end, controller=with_ff, engine="compiled")
    res_no = simulate(BODY, q0, w0, t_end, controller=without, engine="compiled")
    # Quasi-static balance: K q_e,v = I omega_dot (the LVLH acceleration about o2, body y here), so
    # the error angle is ~ 2 |K^-1 I omega_dot| = |omega_dot| / wn^2 (K = 2 I wn^2). The reference's
    # acceleration changes slowly (orbit rate 1e-3 << wn), so the lag term is a few percent.
    _, _, w_dot = with_ff.guidance.samples(res_no.t)
    predicted = np.linalg.norm(w_dot, axis=1) / WN**2
    window = res_no.t > 500.0
    np.testing.assert_allclose(res_no.error_angle[window].max(), predicted[window].max(), rtol=0.1)
    assert res_ff.error_angle[window].max() < 1e-2 * res_no.error_angle[window].max()


def test_python_and_compiled_engines_fly_a_ground_target_pass_alike():
    target = GroundTarget.from_degrees(48.14, 11.58, 520.0)
    t = np.arange(0.0, 86400.0, 10.0)
    t0 = float(t[np.argmax(GroundTargetReference(ELLIPTIC, target).elevation(t) > np.radians(10.0))])
    # The same orbit with its epoch at the start of the pass (simulations start at t = 0).
    orbit = dataclasses.replace(
        ELLIPTIC,
        epoch=Epoch(ELLIPTIC.epoch.utc + timedelta(seconds=t0)),
        mean_anomaly=ELLIPTIC.mean_anomaly + ELLIPTIC.mean_motion * t0,
    )
    ref = GroundTargetReference(orbit, target, secondary="velocity")
    ctrl = GuidanceController(ref, BODY, wn=0.2, zeta=0.7, period=0.5)
    q0, w0 = _start(ref, 0.0, 1.0)
    py = simulate(BODY, q0, w0, 120.0, controller=ctrl, engine="python")
    cc = simulate(BODY, q0, w0, 120.0, controller=ctrl, engine="compiled")
    # One law, numpy and casadi evaluators: agreement to accumulated rounding.
    np.testing.assert_allclose(cc.q, py.q, rtol=0, atol=1e-12)
    # 1 deg decays as exp(-0.14 t): 5e-8 of it after 120 s. What remains is the held torque lagging a
    # reference whose acceleration changes at |omega_dot| |omega| ~ 7e-5 x 1e-2 rad/s^3 during a pass:
    # I omega_ddot T / 2 balanced by K = 2 I wn^2 gives ~ 7e-7 x 0.5 / (2 x 0.04) = 4e-6 rad.
    assert py.error_angle[-1] < 1e-5
    assert py.error_angle[0] == pytest.approx(np.radians(1.0), rel=1e-9)


def test_a_sun_reference_is_a_pointing_reference_for_the_controller():
    ctrl = GuidanceController(SunReference(ELLIPTIC), BODY, wn=WN, zeta=ZETA, period=PERIOD)
    assert ctrl.compiled_inputs(np.array([0.0, 1.0])).shape == (10, 2)
    with pytest.raises(ValueError, match="guidance must be a PointingReference"):
        GuidanceController(object(), BODY, wn=WN, zeta=ZETA, period=PERIOD)

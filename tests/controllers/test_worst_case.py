"""The worst case over an uncertainty set (controllers.worst_case) against closed forms and sampling.

What each test checks against:

* Inertia only, a continuous PD on a diagonal body: each axis is ``J theta'' + C theta' + (K/2) theta`` with
  the gains designed on ``J0``, so ``zeta' = zeta sqrt(J0 / J)``. The PD loop's disk margin
  ``2 zeta' / sqrt(1 + zeta'^2)`` (Seiler, Packard and Gahinet 2020; tests/controllers/test_disk_margins.py)
  grows with ``zeta'``: the worst is the largest moment, ``J = J0 (1 + p)``, and the multiloop margin of the
  decoupled axes is the smallest axis's (slycot's bound: 1e-3). The step from the reference angle is
  ``wn'^2 / (s^2 + 2 zeta' wn' s + wn'^2)`` (no zero), whose overshoot ``exp(-pi zeta' / sqrt(1 - zeta'^2))``
  (Ogata, Modern Control Engineering, eq. 5-21) is largest there too.
* Extra delay only: the margin falls with the delay, so the worst is the largest, and equals
  ``disk_margins`` of ``input_loop`` with that computation delay evaluated directly.
* A delay beyond the delay margin: reported unstable (margin 0, the plant named), never a margin.
* Sampling the same set can never find a worse plant than the optimiser (falsifiable: the comparison is
  made, not assumed), nor can the optimiser's worst be above the nominal.
* The wheel misalignment's torque map is ``A_true A^+`` with each axis turned by exactly its tilt.
"""

import math
import warnings

import numpy as np
import pytest

from attitude import RigidBody
from attitude.actuators import ReactionWheels
from attitude.flexible import FlexibleModes
from attitude.linearize import flexible_plant
from controllers.analysis import input_loop
from controllers.disk_margins import disk_margins
from controllers.pd import QuaternionPD
from controllers.worst_case import UncertaintySet, perturbed_plant, worst_case_disk_margin, worst_case_step

pytest.importorskip("slycot")  # multiloop margins; the dev extra installs it: this runs in CI

BODY = RigidBody(np.diag([10.0, 12.0, 8.0]))
ZETA = 0.7
PD = QuaternionPD.from_bandwidth(BODY, wn=0.4, zeta=ZETA, period=0.1)
#: A small budget: the known answers sit at a corner the search evaluates first.
SMALL = {"samples": 16, "maxiter": 1, "popsize": 2, "local_starts": 1, "local_maxfev": 12, "seed": 3}


def test_inertia_only_the_worst_margin_is_the_heaviest_corner_in_closed_form():
    p = 0.2
    result = worst_case_disk_margin(BODY, PD, UncertaintySet(inertia_percent=100 * p), sampled=False, **SMALL)
    zeta = ZETA / math.sqrt(1.0 + p)
    assert not result.worst_unstable
    # slycot's structured-singular-value bound of the decoupled multiloop margin: 1e-3 relative.
    assert result.worst == pytest.approx(2 * zeta / math.sqrt(1 + zeta**2), rel=1e-3)
    assert result.nominal == pytest.approx(2 * ZETA / math.sqrt(1 + ZETA**2), rel=1e-3)
    # The smallest axis decides: some moment is at +p (the heaviest), exactly (a corner).
    assert np.max(result.worst_plant.moment_change) == pytest.approx(p, abs=1e-12)
    assert result.optimiser_at_least_as_bad and result.worst <= result.nominal


def test_inertia_only_the_worst_overshoot_is_the_heaviest_corner_in_closed_form():
    p = 0.15
    result = worst_case_step(
        BODY, PD, UncertaintySet(inertia_percent=100 * p), sampled=False, **{**SMALL, "samples": 8}
    )
    zeta = ZETA / math.sqrt(1.0 + p)
    # 1001 points over ten time constants: the sampled peak is within 3e-3 percentage points of the true one
    # (half the step squared times the response's curvature there); the overshoot is read against the DC gain.
    assert result.worst == pytest.approx(100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)), abs=1e-2)
    assert np.max(result.worst_plant.moment_change) == pytest.approx(p, abs=1e-12)
    assert result.worst >= result.sampled_worst and result.worst >= result.nominal


def test_extra_delay_only_the_worst_is_the_largest_delay_and_matches_the_direct_margin():
    delay = 0.3
    result = worst_case_disk_margin(BODY, PD, UncertaintySet(extra_delay_s=delay), **{**SMALL, "samples": 8})
    assert result.worst_plant.extra_delay_s == pytest.approx(delay, abs=1e-12)
    direct = disk_margins(input_loop(BODY, PD, computation_delay=delay))
    # The same loop through the same refined margin: equal to rounding.
    assert result.worst == pytest.approx(direct.disk_margin, rel=1e-9)
    assert result.worst < result.nominal


def test_with_modes_every_plant_is_flexible_and_the_worst_delay_matches_the_direct_margin():
    """The same delay-only set on a spacecraft with a lightly damped mode (0.5 Hz, 0.5 %, coupled about y, 8x
    the 0.4 rad/s bandwidth): every plant of the set carries the mode, so the worst is the direct margin of the
    flexible loop at the largest delay (attitude.linearize.flexible_plant through input_loop), to rounding, and
    below the rigid set's worst (the mode costs margin: measured 0.716 against 0.969)."""
    delay = 0.3
    modes = FlexibleModes.from_hz(frequency_Hz=[0.5], damping=0.005, participation=[[0.0, 1.0, 0.0]])
    unc = UncertaintySet(extra_delay_s=delay)
    result = worst_case_disk_margin(BODY, PD, unc, modes=modes, **{**SMALL, "samples": 8})
    assert result.worst_plant.extra_delay_s == pytest.approx(delay, abs=1e-12)
    direct = disk_margins(input_loop(flexible_plant(BODY, modes), PD, computation_delay=delay))
    assert result.worst == pytest.approx(direct.disk_margin, rel=1e-9)
    rigid = worst_case_disk_margin(BODY, PD, unc, **{**SMALL, "samples": 8})
    assert result.worst < rigid.worst


def test_a_destabilising_set_is_reported_unstable_with_its_plant():
    """Continuous PD, wn = 0.4 rad/s: the delay margin is about 2 s; a set reaching 5 s holds unstable loops."""
    result = worst_case_disk_margin(BODY, PD, UncertaintySet(extra_delay_s=5.0), sampled=False, **SMALL)
    assert result.worst_unstable and result.worst == 0.0
    assert result.worst_plant.extra_delay_s > 1.5
    assert "UNSTABLE" in result.summary()
    assert result.to_dict()["worst_unstable"] and result.to_dict()["samples_unstable"] > 0


def test_the_optimiser_is_never_beaten_by_sampling_the_same_set():
    """A coupled body, moments and principal axes uncertain (6 parameters): the samples' worst is checked
    against the optimiser's, and the optimiser's against the nominal."""
    body = RigidBody([[12.0, 1.5, -1.0], [1.5, 10.5, 0.8], [-1.0, 0.8, 8.5]])
    pd = QuaternionPD.from_bandwidth(RigidBody(np.diag(np.diag(body.inertia))), wn=0.4, zeta=0.6, period=0.1)
    uncertainty = UncertaintySet(inertia_percent=15.0, axis_rotation_deg=10.0)
    budget = {**SMALL, "samples": 12, "popsize": 1, "local_maxfev": 10}
    result = worst_case_disk_margin(body, pd, uncertainty, sampled=False, **budget)
    assert result.worst <= result.sampled_worst
    assert result.worst <= result.nominal
    assert np.all(result.sampled_values >= result.worst - 1e-9)
    assert np.degrees(np.linalg.norm(result.worst_plant.axis_rotation)) <= 10.0 + 1e-9


def test_the_wheel_misalignment_turns_each_axis_by_its_tilt_and_maps_the_torque():
    wheels = ReactionWheels.pyramid(spin_inertia=1e-4, torque_max=0.01, momentum_max=0.05)
    uncertainty = UncertaintySet(wheel_misalignment_deg=2.0)
    names = uncertainty.parameter_names(wheels.n_wheels)
    assert len(names) == 8
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, 8) * math.radians(2.0)
    plant = perturbed_plant(BODY, uncertainty, x, wheels=wheels)
    for i in range(4):
        tilt = np.hypot(x[2 * i], x[2 * i + 1])
        expected = min(tilt, math.radians(2.0))  # beyond the bound: pulled onto it
        angle = math.acos(np.clip(plant.wheel_axes_B[i] @ wheels.axes_B[i], -1, 1))
        assert angle == pytest.approx(expected, abs=1e-12)
    # The torque map against the actuator model itself: the flight software allocates the command on the nominal
    # axes (ReactionWheels.allocate, the engine's allocation) and the motors push on the tilted axes
    # (body_torque of a wheel set built on them); small torques at rest, so no limit acts.
    tau = np.array([3e-3, -2e-3, 1e-3])
    motors = wheels.allocate(tau, np.zeros(4), np.zeros(3))
    tilted = ReactionWheels(plant.wheel_axes_B, spin_inertia=1e-4, torque_max=0.01, momentum_max=0.05)
    assert plant.torque_map @ tau == pytest.approx(tilted.body_torque(motors), abs=1e-15)
    nominal = perturbed_plant(BODY, uncertainty, np.zeros(8), wheels=wheels)
    assert nominal.torque_map == pytest.approx(np.eye(3), abs=1e-12)


def test_the_principal_axes_turn_by_the_rotation_and_the_moments_scale():
    uncertainty = UncertaintySet(inertia_percent=10.0, axis_rotation_deg=20.0)
    x = np.array([0.1, -0.05, 0.02, 0.0, 0.0, math.radians(20.0)])
    plant = perturbed_plant(BODY, uncertainty, x)
    # Principal moments sorted I1 <= I2 <= I3: 8, 10, 12 scaled by 1.1, 0.95, 1.02.
    assert plant.body.principal_axes().moments == pytest.approx([8.8, 9.5, 12.24], rel=1e-12)
    c, s = math.cos(math.radians(20.0)), math.sin(math.radians(20.0))
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])  # about z by 20 deg
    expected = turn @ np.diag([9.5, 12.24, 8.8]) @ turn.T
    assert plant.body.inertia == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"inertia_percent": -1.0}, "inertia_percent"),
        ({"inertia_percent": 100.0}, "inertia_percent"),
        ({"axis_rotation_deg": float("nan")}, "axis_rotation_deg"),
        ({"wheel_misalignment_deg": 90.0}, "wheel_misalignment_deg"),
        ({"extra_delay_s": "0.1 s"}, "extra_delay_s"),
    ],
)
def test_a_bad_set_is_refused_by_name(kwargs, match):
    with pytest.raises(ValueError, match=match):
        UncertaintySet(**kwargs)


def test_bad_calls_are_refused_by_name():
    flat = RigidBody([1.0, 1.0, 1.9])  # I3 <= I1 + I2 holds; +-10 % breaks it at a corner
    with pytest.raises(ValueError, match="inertia_percent = 10 leaves no physical body"):
        worst_case_disk_margin(flat, PD, UncertaintySet(inertia_percent=10.0))
    with pytest.raises(ValueError, match="needs the wheels"):
        worst_case_disk_margin(BODY, PD, UncertaintySet(wheel_misalignment_deg=1.0))
    with pytest.raises(ValueError, match="samples"):
        worst_case_disk_margin(BODY, PD, UncertaintySet(extra_delay_s=0.1), samples=0)
    with pytest.raises(ValueError, match="metric"):
        worst_case_step(BODY, PD, UncertaintySet(extra_delay_s=0.1), metric="rise")
    with pytest.raises(ValueError, match=r"parameters must hold 3 values \(inertia_1"):
        perturbed_plant(BODY, UncertaintySet(inertia_percent=5.0), [0.0, 0.0])
    with pytest.raises(ValueError, match=r"parameters\[0\] \(inertia_1\)"):
        perturbed_plant(BODY, UncertaintySet(inertia_percent=5.0), [0.5, 0.0, 0.0])


def test_a_settling_time_cut_short_by_the_response_span_warns():
    """The PD settles in about 4 / (zeta wn) = 14 s (2 %): a 5 s response cannot show when it settles, so the
    figure is only a lower bound and says so (a RuntimeWarning); 60 s shows it, without a warning, and the worst
    over +-20 % moments is no shorter than the nominal (heavier axes are slower)."""
    uncertain = UncertaintySet(inertia_percent=20.0)
    with pytest.warns(RuntimeWarning, match="has not settled within duration_s = 5 s"):
        worst_case_step(BODY, PD, uncertain, metric="settling_time", sampled=False, duration_s=5.0, **SMALL)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = worst_case_step(BODY, PD, uncertain, metric="settling_time", sampled=False, duration_s=60.0, **SMALL)
    assert 10.0 < result.nominal < 20.0 and result.worst >= result.nominal

"""Magnetorquers: the torque m x B, rod allocation, saturation, quantisation, backends and input checks."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from attitude.actuators import Magnetorquers

# Exact arithmetic on small decimals: products and sums of these values round at 1 ulp, so the
# hand results are compared at a few ulps of their magnitude.
ULPS = 1e-15


def test_torque_is_the_hand_cross_product():
    # m x B by hand (Wertz 1978 sec. 17.2: tau = m x B): m = [1, 2, 3] A m^2, B = [4, -5, 6] e-5 T
    # m x B = [2*6 - 3*(-5), 3*4 - 1*6, 1*(-5) - 2*4] e-5 = [27, 6, -13] e-5 N m.
    rods = Magnetorquers.orthogonal(dipole_max_Am2=5.0)
    tau = rods.torque([1.0, 2.0, 3.0], [4e-5, -5e-5, 6e-5])
    np.testing.assert_allclose(tau, [27e-5, 6e-5, -13e-5], rtol=0, atol=30e-5 * ULPS)


def test_skewed_rods_sum_their_dipoles_and_the_allocation_inverts_them():
    axes = np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 1.0], [1.0, 1.0, 1.0]])
    rods = Magnetorquers(axes, dipole_max_Am2=10.0)
    unit = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    per_rod = np.array([0.5, -1.0, 2.0, 0.25])
    np.testing.assert_allclose(rods.dipole_B(per_rod), per_rod @ unit, rtol=0, atol=1e-14)
    # Unsaturated: the rods deliver the commanded body dipole (pseudo-inverse of a rank-3 set).
    command = np.array([0.3, -0.7, 1.1])
    np.testing.assert_allclose(rods.dipole_B(rods.command(command)), command, rtol=0, atol=1e-14)


def test_scale_saturation_keeps_the_direction_and_clip_saturates_each_rod_alone():
    command = np.array([3.0, 1.0, 0.2])
    limits = [1.0, 2.0, 0.5]
    scaled = Magnetorquers.orthogonal(dipole_max_Am2=limits).command(command)
    # Largest ratio |m_i| / max_i is 3 (x rod): every rod divided by 3.
    np.testing.assert_allclose(scaled, command / 3.0, rtol=ULPS)
    clipped = Magnetorquers.orthogonal(dipole_max_Am2=limits, saturation="clip").command(command)
    np.testing.assert_array_equal(clipped, [1.0, 1.0, 0.2])
    within = np.array([0.5, -1.5, 0.4])
    np.testing.assert_array_equal(Magnetorquers.orthogonal(dipole_max_Am2=limits).command(within), within)


def test_quantisation_rounds_to_the_nearest_level_within_the_limit():
    rods = Magnetorquers.orthogonal(dipole_max_Am2=0.25, quantum_Am2=0.1, saturation="clip")
    out = rods.command([0.26, -0.13, 0.04])
    # 0.26 -> 0.3 is beyond the 0.25 limit, clipped to it; -0.13 -> -0.1; 0.04 -> 0.
    np.testing.assert_allclose(out, [0.25, -0.1, 0.0], rtol=0, atol=1e-16)


def test_numpy_batch_and_casadi_evaluate_the_same_components():
    rods = Magnetorquers(np.eye(3) + 0.1, dipole_max_Am2=[1.0, 0.8, 1.2], quantum_Am2=1e-3)
    rng = np.random.default_rng(4)
    commands = rng.normal(scale=1.0, size=(20, 3))
    fields = rng.normal(scale=3e-5, size=(20, 3))
    batch = rods.torque(rods.command(commands), fields)
    m = ca.SX.sym("m", 3)
    b = ca.SX.sym("b", 3)
    per_rod = rods.command_components([m[0], m[1], m[2]])
    f = ca.Function("f", [m, b], [ca.vertcat(*rods.torque_components(per_rod, [b[0], b[1], b[2]]))])
    symbolic = np.array([np.array(f(c, fb)).ravel() for c, fb in zip(commands, fields)])
    # Same operations in the same order on both backends; casadi may fuse a multiply-add (1 ulp).
    np.testing.assert_allclose(symbolic, batch, rtol=1e-12, atol=1e-20)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"dipole_max_Am2": -1.0}, "dipole_max_Am2 must be strictly positive, got -1"),
        ({"dipole_max_Am2": 0.0}, "dipole_max_Am2 must be strictly positive, got 0"),
        ({"dipole_max_Am2": 1.0, "quantum_Am2": -0.1}, "quantum_Am2 must be strictly positive"),
        ({"dipole_max_Am2": [1.0, 2.0]}, "dipole_max_Am2 must be a scalar or one value per rod"),
        ({"dipole_max_Am2": 1.0, "saturation": "wrap"}, "saturation must be one of"),
        ({"axes_B": [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]], "dipole_max_Am2": 1.0}, "rod 1 has a zero axis"),
    ],
)
def test_bad_input_names_the_argument_the_rule_and_the_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Magnetorquers(**kwargs)

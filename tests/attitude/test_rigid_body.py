"""The plant: inertia checks, principal axes and the one definition of the dynamics.

What each group checks against:

* Inertia checks: the physical realisability rules of an inertia tensor (symmetric, positive
  definite, principal moments satisfying the triangle inequality ``I3 <= I1 + I2``, a thin plate on
  the boundary), on hand-picked cases and random tensors ``R diag(m) R^T`` built from known moments
  and rotations (hypothesis); errors name the argument, the rule and the value (DESIGN.md).
* Principal axes: the constructed moments and axes recovered (up to sign) by
  ``numpy.linalg.eigh``, a right-handed frame, and its quaternion against
  ``scipy.spatial.transform.Rotation`` (DESIGN.md convention).
* The one definition of Euler's equations ``I omega_dot = tau - omega x (I omega + h)``:
  numpy and casadi evaluations agree (rounding only); an independent path (``numpy.linalg.solve``
  and ``numpy.cross``); casadi's exact Jacobians against central differences; batched evaluation
  bit-identical to single evaluations.
* Invariants: torque-free Euler's equations conserve the kinetic energy ``omega . I omega / 2`` and
  ``|H|^2`` exactly (``dT/dt`` and ``d|H|^2/dt`` vanish algebraically); the energy and momentum
  formulas, the inertial momentum rotated by ``scipy.spatial.transform.Rotation``; ``skew`` against
  ``numpy.cross``.
"""

import casadi as ca
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.rigid_body import skew

# A realistic small-satellite tensor with products of inertia [kg m^2].
FULL_TENSOR = np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]])


def random_valid_tensor(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A random realisable inertia: sorted moments, rotation R, tensor R diag(m) R^T."""
    while True:
        m = np.sort(rng.uniform(1.0, 100.0, 3))
        if m[2] <= m[0] + m[1]:
            break
    rot = Rotation.random(random_state=rng).as_matrix()
    return m, rot, rot @ np.diag(m) @ rot.T


def reference_omega_dot(inertia, omega, torque, h):
    """Euler's equations by a linear solve and numpy's cross: an independent path."""
    return np.linalg.solve(inertia, torque - np.cross(omega, inertia @ omega + h))


class TestInertiaChecks:
    def test_principal_moments_become_a_diagonal_tensor(self):
        body = RigidBody([3.0, 4.0, 5.0])
        np.testing.assert_array_equal(body.inertia, np.diag([3.0, 4.0, 5.0]))
        assert body.is_diagonal

    def test_flat_plate_on_the_triangle_boundary_is_accepted(self):
        # A thin plate has I3 = I1 + I2 exactly: physically realisable.
        RigidBody([1.0, 2.0, 3.0])

    @pytest.mark.parametrize(
        ("inertia", "match"),
        [
            ([[1.0, 0.1, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "symmetric"),
            ([1.0, -1.0, 1.0], "positive definite"),
            ([1.0, 0.0, 1.0], "positive definite"),
            ([1.0, 1.0, 3.0], "realisable"),
            ([1.0, np.nan, 1.0], "finite"),
            ([1.0, np.inf, 1.0], "finite"),
            ([1.0, 2.0], "shape"),
            (np.eye(4), "shape"),
            ("abc", "numeric"),
        ],
    )
    def test_bad_inertia_is_rejected_with_the_rule(self, inertia, match):
        with pytest.raises(ValueError, match="inertia") as info:
            RigidBody(inertia)
        assert match in str(info.value)

    @given(st.integers(0, 2**32 - 1))
    def test_any_realisable_tensor_is_accepted_and_its_moments_recovered(self, seed):
        rng = np.random.default_rng(seed)
        moments, _, tensor = random_valid_tensor(rng)
        body = RigidBody(tensor)
        # eigh of a well-conditioned (cond <= 100) symmetric tensor: ~1e-14 relative.
        np.testing.assert_allclose(body.principal_axes().moments, moments, rtol=1e-12)

    @given(
        st.floats(1.0, 100.0),
        st.floats(1.0, 100.0),
        st.floats(1.01, 3.0),
        st.integers(0, 2**32 - 1),
    )
    def test_any_tensor_breaking_the_triangle_inequality_is_rejected(self, a, b, factor, seed):
        # I3 = factor * (I1 + I2) with factor > 1.01: 1% beyond the boundary.
        rot = Rotation.random(random_state=seed).as_matrix()
        tensor = rot @ np.diag([a, b, factor * (a + b)]) @ rot.T
        with pytest.raises(ValueError, match="realisable"):
            RigidBody(tensor)


class TestPrincipalAxes:
    @pytest.mark.parametrize("seed", range(20))
    def test_frame_diagonalises_the_tensor_and_is_right_handed(self, seed):
        moments, rot, tensor = random_valid_tensor(np.random.default_rng(seed))
        axes = RigidBody(tensor).principal_axes()
        # Rounding of eigh and of the products: ~1e-14 of the largest moment (<= 100).
        np.testing.assert_allclose(axes.C_PB @ tensor @ axes.C_PB.T, np.diag(moments), atol=1e-11)
        assert np.linalg.det(axes.C_PB) == pytest.approx(1.0, abs=1e-12)
        # Each principal axis equals the constructed one up to sign (distinct moments).
        for k in range(3):
            assert abs(axes.axes_B[:, k] @ rot[:, k]) == pytest.approx(1.0, abs=1e-9)
        # The quaternion is the same rotation as the DCM, in scipy's convention.
        c_pb_scipy = Rotation.from_quat(axes.q_PB, scalar_first=True).as_matrix().T
        np.testing.assert_allclose(c_pb_scipy, axes.C_PB, atol=1e-12)

    def test_rotating_principal_vectors_into_the_body_frame(self):
        axes = RigidBody(FULL_TENSOR).principal_axes()
        for k in range(3):
            e_p = np.eye(3)[k]
            np.testing.assert_allclose(quat.rotate(axes.q_PB, e_p), axes.axes_B[:, k], atol=1e-12)


class TestOneDefinition:
    @given(st.integers(0, 2**32 - 1))
    def test_numpy_and_casadi_evaluations_agree(self, seed):
        rng = np.random.default_rng(seed)
        _, _, tensor = random_valid_tensor(rng)
        body = RigidBody(tensor)
        x = np.concatenate([quat.random(rng=rng), rng.normal(size=3)])
        tau = rng.normal(size=3)
        h = rng.normal(size=3)
        xs, taus, hs = ca.SX.sym("x", 7), ca.SX.sym("t", 3), ca.SX.sym("h", 3)
        f = ca.Function("f", [xs, taus, hs], [body.state_derivative(xs, taus, hs)])
        numeric = body.state_derivative(x, tau, h)
        symbolic = np.array(f(x, tau, h)).ravel()
        # Same arithmetic in a different evaluator: equal to a few ulps of O(1) values.
        np.testing.assert_allclose(symbolic, numeric, rtol=0, atol=1e-12)

    @given(st.integers(0, 2**32 - 1))
    def test_euler_equations_match_an_independent_solve(self, seed):
        rng = np.random.default_rng(seed)
        _, _, tensor = random_valid_tensor(rng)
        body = RigidBody(tensor)
        omega, tau, h = rng.normal(size=(3, 3))
        # Inverse vs solve of a cond <= 100 tensor: agreement to ~1e-13 relative.
        np.testing.assert_allclose(
            body.omega_dot(omega, tau, h), reference_omega_dot(tensor, omega, tau, h), rtol=1e-10, atol=1e-12
        )

    def test_casadi_exact_jacobian_matches_central_differences(self):
        rng = np.random.default_rng(7)
        body = RigidBody(FULL_TENSOR)
        jac = body.casadi_jacobian()
        for _ in range(10):
            x = np.concatenate([quat.random(rng=rng), rng.normal(size=3)])
            tau = rng.normal(size=3)
            a_exact, b_exact = (np.array(m) for m in jac(x, tau))
            eps = 1e-6
            a_fd = np.column_stack(
                [
                    (body.state_derivative(x + eps * e, tau) - body.state_derivative(x - eps * e, tau)) / (2 * eps)
                    for e in np.eye(7)
                ]
            )
            b_fd = np.column_stack(
                [
                    (body.state_derivative(x, tau + eps * e) - body.state_derivative(x, tau - eps * e)) / (2 * eps)
                    for e in np.eye(3)
                ]
            )
            # Central differences: truncation eps^2 |f'''| ~ 1e-12 plus rounding 1e-16/eps ~ 1e-10.
            np.testing.assert_allclose(a_exact, a_fd, atol=1e-8)
            np.testing.assert_allclose(b_exact, b_fd, atol=1e-8)

    def test_batched_evaluation_matches_single_evaluations(self):
        rng = np.random.default_rng(3)
        tensors = np.stack([random_valid_tensor(rng)[2] for _ in range(6)]).reshape(2, 3, 3, 3)
        body = RigidBody(tensors)
        assert body.batch_shape == (2, 3)
        x = np.concatenate([quat.random((2, 3), rng=rng), rng.normal(size=(2, 3, 3))], axis=-1)
        tau = rng.normal(size=(2, 3, 3))
        batched = body.state_derivative(x, tau)
        for i in range(2):
            for j in range(3):
                single = RigidBody(tensors[i, j]).state_derivative(x[i, j], tau[i, j])
                np.testing.assert_array_equal(batched[i, j], single)

    def test_casadi_refuses_a_batch_of_inertias(self):
        body = RigidBody(np.stack([np.diag([1.0, 2.0, 2.5])] * 2))
        with pytest.raises(ValueError, match="single body"):
            body.state_derivative(ca.SX.sym("x", 7))


class TestInvariants:
    @given(st.integers(0, 2**32 - 1))
    def test_torque_free_dynamics_conserve_energy_and_momentum_magnitude(self, seed):
        rng = np.random.default_rng(seed)
        _, _, tensor = random_valid_tensor(rng)
        body = RigidBody(tensor)
        omega = rng.normal(size=3)
        omega_dot = body.omega_dot(omega)
        h = body.angular_momentum(omega)
        scale = np.linalg.norm(omega) ** 3 * np.linalg.norm(tensor)
        # dT/dt = omega . I omega_dot and d|H|^2/dt / 2 = H . I omega_dot vanish exactly.
        assert abs(omega @ (tensor @ omega_dot)) <= 1e-12 * scale
        assert abs(h @ (tensor @ omega_dot)) <= 1e-12 * scale * np.linalg.norm(tensor)

    def test_energy_and_momentum_formulas(self):
        body = RigidBody(FULL_TENSOR)
        omega = np.array([0.1, -0.2, 0.3])
        np.testing.assert_allclose(body.angular_momentum(omega), FULL_TENSOR @ omega, rtol=1e-15)
        assert body.kinetic_energy(omega) == pytest.approx(0.5 * omega @ FULL_TENSOR @ omega, rel=1e-15)
        q = quat.random(rng=1)
        h_n = Rotation.from_quat(q, scalar_first=True).apply(FULL_TENSOR @ omega)
        np.testing.assert_allclose(body.inertial_angular_momentum(q, omega), h_n, atol=1e-14)

    def test_bad_rates_are_named(self):
        body = RigidBody(FULL_TENSOR)
        with pytest.raises(ValueError, match="omega"):
            body.omega_dot([0.1, np.nan, 0.0])
        with pytest.raises(ValueError, match="torque"):
            body.omega_dot([0.1, 0.0, 0.0], [1.0, 2.0])


@pytest.mark.parametrize(
    "inertia",
    [
        [1e-310] * 3,
        [[1e308, 1e308, 0], [1e308, 1e308, 0], [0, 0, 1.0]],
        # Issue 13, item 11: accepted before, with overflow warnings, inf energy and NaN accelerations.
        [1e300, 1.1e300, 1.2e300],
    ],
)
def test_inertia_beyond_float_range_is_rejected(inertia):
    with pytest.raises(ValueError, match=r"inertia must lie within \[1e-100, 1e\+100\] kg m\^2"):
        RigidBody(inertia)


def test_inertia_at_the_edges_of_its_range_keeps_finite_energy_and_accelerations():
    """Inside the accepted range, T = w.Iw/2 and w x (Iw) stay finite for rates up to 1e20 rad/s."""
    for scale in (1e-100, 1e100):
        body = RigidBody(np.array([0.8, 0.9, 1.0]) * scale)
        omega = np.array([1e20, -3e19, 2e19]) if scale < 1 else np.array([1.0, -0.3, 0.2])
        assert np.isfinite(body.kinetic_energy(omega)) and body.kinetic_energy(omega) > 0.0
        assert np.all(np.isfinite(body.omega_dot(omega)))


@given(st.integers(0, 2**32 - 1))
def test_skew_is_the_cross_product_matrix(seed):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(4, 5, 3))
    b = rng.normal(size=(4, 5, 3))
    m = skew(a)
    assert m.shape == (4, 5, 3, 3)
    np.testing.assert_allclose((m @ b[..., None])[..., 0], np.cross(a, b), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(m, -np.swapaxes(m, -1, -2))
    np.testing.assert_allclose(skew(a[0, 0]) @ b[0, 0], np.cross(a[0, 0], b[0, 0]), rtol=0, atol=1e-15)

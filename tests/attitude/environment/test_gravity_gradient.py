"""Gravity gradient on a circular orbit: torque, LVLH frame, linearisation and stability regions.

What each group checks against (derivations in docs/gravity_gradient.md):

* Torque ``tau_B = 3 mu / |r|^5 r_B x (I r_B)`` (Wie, *Space Vehicle Dynamics and Control*,
  gravity-gradient torque; Hughes, *Spacecraft Attitude Dynamics*, gravitational torques): a hand
  computation in a principal plane, the inverse-cube scaling and the symmetry ``r -> -r``, zero
  torque with a principal axis at nadir, and, as an independent body, the exact sum of ``rho x F``
  over the point masses of three dumbbells (Newton's inverse-square law); numpy vs casadi evaluations
  of the same formula (rounding only); the small-angle stiffness ``3 n^2 [(I3 - I2) theta1,
  (I3 - I1) theta2, 0]`` (Wie) by central differences.
* Circular orbit and LVLH axes (``o3`` to nadir, ``o2`` the negative orbit normal; Wie; Hughes):
  published constants (geostationary radius 42,164.1696 km gives the sidereal day 86,164.0905 s),
  the circular speed ``sqrt(mu / r)``, the frame built by hand at the node of an equatorial orbit and
  from position and velocity, and velocity and ``q_LN`` as central-difference time derivatives.
* Linearisation: the casadi Jacobian entry by entry against Wie's linear roll / pitch / yaw
  equations re-derived for these axes (docs/gravity_gradient.md), its eigenvalues against the roots
  of the classical pitch equation and roll-yaw quartic ``s^4 + (1 + 3 k1 + k1 k3) n^2 s^2 + 4 k1 k3
  n^4``, tangency of the nonlinear model, and ``expm(A t) x0`` against a full inertial simulation
  (:func:`attitude.propagate.propagate`, through code paths independent of the casadi model).
* Stability regions: the classical conditions (Wie, gravity-gradient stabilisation; Hughes; DeBra
  and Delp, J. Astronaut. Sci. 8, 1961): the Lagrange region ``I2 > I1 > I3`` and the DeBra-Delp
  region, pitch and roll-yaw instability, the boundary, a random sweep over ``(k1, k3)`` against
  the eigenvalues of the linear model, and the pitch libration frequency ``n sqrt(3 (I1 - I3) /
  I2)`` in a nonlinear simulation with the pendulum finite-amplitude correction ``(2 theta0)^2 / 16``.
* Orbital disturbance: the exact integral of a constant-plus-orbital-rate torque on a principal
  axis at rest; shapes and biases.
* Bad input: errors name the argument, the rule and the value (DESIGN.md).
"""

from typing import ClassVar

import casadi as ca
import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import linear_sum_assignment

from attitude import RigidBody
from attitude import quaternion as quat
from attitude.environment import (
    MU_EARTH,
    R_EARTH,
    CircularOrbit,
    constant_plus_orbital_disturbance,
    gravity_gradient_stability,
    gravity_gradient_torque,
    gravity_gradient_torque_components,
    gravity_gradient_torque_function,
    linearize_gravity_gradient,
    lvlh_relative_dynamics,
)
from attitude.propagate import propagate

# A sun-synchronous-like low orbit, tilted and rotated so that no LVLH axis
# coincides with an inertial axis.
LEO = CircularOrbit.from_altitude(700e3, inclination=np.radians(98.2), raan=0.7, argument_of_latitude=0.4)

# Principal moments [I1 roll, I2 pitch, I3 yaw] in kg m^2, with the region each lies in.
LAGRANGE = [80.0, 100.0, 40.0]  # I2 > I1 > I3: k1 = 0.75, k3 = 0.5
DEBRA_DELP_K = (-0.02, -0.5)  # (k1, k3) inside the DeBra-Delp region
PITCH_UNSTABLE = [40.0, 100.0, 80.0]  # I3 > I1: k3 > k1 > 0
ROLL_YAW_UNSTABLE = [100.0, 80.0, 40.0]  # k1 > 0 > k3


def moments_from_k(k1: float, k3: float) -> list[float]:
    """Principal moments with I2 = 1 for given (k1, k3) in (-1, 1)^2.

    Solving k1 I1 = I2 - I3 and k3 I3 = I2 - I1 gives I1 = (1 - k3)/(1 - k1 k3),
    I3 = (1 - k1)/(1 - k1 k3); the triangle inequalities reduce to products of
    (1 +- k) factors, so every point of the open square is a realisable body.
    """
    d = 1.0 - k1 * k3
    return [(1.0 - k3) / d, 1.0, (1.0 - k1) / d]


def wie_matrices(moments, n):
    """A and B of Wie's linear equations rewritten for x = [e, w] with theta = 2 e and w = theta_dot.

    M theta'' + G theta' + K theta = u, with
    G = n (I1 - I2 + I3) [[0, 0, -1], [0, 0, 0], [1, 0, 0]] and
    K = n^2 diag(4 (I2 - I3), 3 (I1 - I3), I2 - I1).
    """
    i1, i2, i3 = moments
    m_inv = np.diag(1.0 / np.asarray(moments))
    g = n * (i1 - i2 + i3) * np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    k = n**2 * np.diag([4.0 * (i2 - i3), 3.0 * (i1 - i3), i2 - i1])
    a = np.block([[np.zeros((3, 3)), 0.5 * np.eye(3)], [-2.0 * m_inv @ k, -m_inv @ g]])
    b = np.vstack([np.zeros((3, 3)), m_inv])
    return a, b


def classical_roots(moments, n):
    """Roots of the pitch equation and of the roll-yaw quartic (Wie)."""
    i1, i2, i3 = moments
    k1 = (i2 - i3) / i1
    k3 = (i2 - i1) / i3
    pitch = np.roots([i2, 0.0, 3.0 * n**2 * (i1 - i3)])
    roll_yaw = np.roots([1.0, 0.0, (1.0 + 3.0 * k1 + k1 * k3) * n**2, 0.0, 4.0 * k1 * k3 * n**4])
    return np.concatenate([pitch, roll_yaw])


def matched_distance(a, b):
    """Largest distance between two multisets of complex numbers under the best pairing."""
    cost = np.abs(a[:, None] - b[None, :])
    rows, cols = linear_sum_assignment(cost)
    return cost[rows, cols].max()


def relative_state(orbit, t, q_BN, omega_BN):
    """x = [vec(q_BL), omega_BL_B] from an inertial trajectory (independent of the casadi model)."""
    q_BL = quat.shortest(quat.multiply(quat.conjugate(orbit.q_LN(t)), q_BN))
    w = omega_BN - quat.rotate_inverse(q_BL, orbit.omega_LN_L)
    return np.concatenate([q_BL[..., 1:], w], axis=-1)


def inertial_state(orbit, t, x):
    """Inverse of :func:`relative_state`."""
    e = np.asarray(x[:3])
    q_BL = np.concatenate([[np.sqrt(1.0 - e @ e)], e])
    q_BN = quat.multiply(orbit.q_LN(t), q_BL)
    omega_BN = np.asarray(x[3:]) + quat.rotate_inverse(q_BL, orbit.omega_LN_L)
    return q_BN, omega_BN


# ---------------------------------------------------------------------------


class TestTorque:
    def test_hand_computation_in_a_principal_plane(self):
        # r = r [cos a, 0, sin a] gives r x I r = r^2 [0, (I1 - I3) sin a cos a, 0] by hand.
        body = RigidBody([3.0, 5.0, 7.0])
        r, a = 7.0e6, 0.3
        tau = gravity_gradient_torque(body, r * np.array([np.cos(a), 0.0, np.sin(a)]))
        expected = 3.0 * MU_EARTH / r**3 * (3.0 - 7.0) * np.sin(a) * np.cos(a)
        # Rounding only: a dozen flops at relative precision 1e-16.
        np.testing.assert_allclose(tau, [0.0, expected, 0.0], rtol=1e-13, atol=1e-13 * abs(expected))

    def test_inverse_cube_scaling_and_sign_of_r(self):
        body = RigidBody(np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]))
        r_B = np.array([3.0e6, -4.0e6, 5.0e6])
        tau = gravity_gradient_torque(body, r_B)
        # 2^-3 scaling with distance, and the same torque for r and -r (quadratic in r); rounding only.
        np.testing.assert_allclose(gravity_gradient_torque(body, 2.0 * r_B), tau / 8.0, rtol=1e-13)
        np.testing.assert_allclose(gravity_gradient_torque(body, -r_B), tau, rtol=1e-13)
        assert np.linalg.norm(tau) > 0

    def test_zero_when_a_principal_axis_points_at_nadir(self):
        body = RigidBody(np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]))
        axes = body.principal_axes().axes_B
        r = 7.0e6
        scale = 3.0 * MU_EARTH / r**3 * 12.0  # torque magnitude scale 3 n^2 I_max [N m]
        for k in range(3):
            for sign in (1.0, -1.0):
                tau = gravity_gradient_torque(body, sign * r * axes[:, k])
                # Eigenvectors are exact to ~1e-15, so the torque vanishes to that fraction of its scale.
                assert np.max(np.abs(tau)) < 1e-12 * scale
        # ...and not in between two principal axes.
        tilted = gravity_gradient_torque(body, r * (axes[:, 0] + axes[:, 2]) / np.sqrt(2.0))
        assert np.max(np.abs(tilted)) > 0.1 * scale

    def test_matches_exact_sum_of_point_mass_forces(self):
        # Three dumbbells (pairs of equal masses at +-rho) through the centre of mass: an
        # independent body whose exact torque is the sum of rho x F over the six point masses.
        rng = np.random.default_rng(7)
        rho = rng.uniform(-5.0, 5.0, (3, 3))  # half-lengths [m]
        mass = rng.uniform(10.0, 50.0, 3)  # [kg]
        points = np.concatenate([rho, -rho])
        masses = np.concatenate([mass, mass])
        inertia = sum(m * (p @ p * np.eye(3) - np.outer(p, p)) for m, p in zip(masses, points))
        body = RigidBody(inertia)
        for r_B in (np.array([7.0e6, 1.0e6, -2.0e6]), np.array([-1.0e6, 3.0e6, 4.2e7])):
            d = points + r_B
            forces = -MU_EARTH * masses[:, None] * d / np.linalg.norm(d, axis=1, keepdims=True) ** 3
            exact = np.sum(np.cross(points, forces), axis=0)
            approx = gravity_gradient_torque(body, r_B)
            # Neglected terms are O((size/r)^2) ~ 1e-12 for a body symmetric about its centre
            # of mass (odd moments vanish); summing forces ~r/size larger than their torque
            # loses ~6 digits, leaving ~1e-10. 1e-8 keeps a margin for both.
            np.testing.assert_allclose(approx, exact, rtol=1e-8, atol=1e-8 * np.linalg.norm(exact))

    def test_batches_of_positions_and_of_bodies(self):
        rng = np.random.default_rng(1)
        moments = rng.uniform(5.0, 8.0, (4, 3))
        bodies = RigidBody(moments)
        r_B = rng.normal(size=(2, 4, 3)) * 7.0e6
        tau = gravity_gradient_torque(bodies, r_B)
        assert tau.shape == (2, 4, 3)
        for i in range(2):
            for j in range(4):
                single = gravity_gradient_torque(RigidBody(moments[j]), r_B[i, j])
                # Same arithmetic in a different order (einsum vs single): rounding only.
                np.testing.assert_allclose(tau[i, j], single, rtol=1e-12, atol=1e-12 * np.abs(single).max())

    def test_component_version_agrees_on_numpy_and_casadi(self):
        body = RigidBody(np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]))
        r_B = np.random.default_rng(2).normal(size=(5, 3)) * 7.0e6
        reference = gravity_gradient_torque(body, r_B)
        comps = gravity_gradient_torque_components(body, [r_B[:, i] for i in range(3)])
        # Both are the same formula evaluated by different code: rounding only.
        np.testing.assert_allclose(
            np.stack(comps, axis=-1), reference, rtol=1e-12, atol=1e-12 * np.abs(reference).max()
        )
        r = ca.SX.sym("r", 3)
        fun = ca.Function("gg", [r], [ca.vertcat(*gravity_gradient_torque_components(body, [r[0], r[1], r[2]]))])
        for row, ref in zip(r_B, reference):
            np.testing.assert_allclose(np.ravel(fun(row).full()), ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())

    def test_small_angle_stiffness_is_the_classical_one(self):
        # Linear gravity-gradient torque of a body rotated by small angles theta from LVLH:
        # 3 n^2 [(I3 - I2) theta1, (I3 - I1) theta2, 0] (Wie). Central differences of the
        # numpy torque, independent of casadi.
        moments = np.array([80.0, 100.0, 40.0])
        body = RigidBody(moments)
        n = LEO.mean_motion
        r_L = np.array([0.0, 0.0, -LEO.radius_m])  # spacecraft at zenith = -o3 from the centre
        h = 1e-6
        jac = np.empty((3, 3))
        for k in range(3):
            dtheta = np.zeros(3)
            dtheta[k] = h
            plus = gravity_gradient_torque(body, quat.rotate_inverse(quat.from_rotation_vector(dtheta), r_L))
            minus = gravity_gradient_torque(body, quat.rotate_inverse(quat.from_rotation_vector(-dtheta), r_L))
            jac[:, k] = (plus - minus) / (2.0 * h)
        expected = 3.0 * n**2 * np.diag([moments[2] - moments[1], moments[2] - moments[0], 0.0])
        # Truncation O(h^2) ~ 1e-12 relative; cancellation eps/h ~ 1e-10 relative. 1e-7 of the scale.
        np.testing.assert_allclose(jac, expected, atol=1e-7 * np.abs(expected).max())
        # The same stiffness is what the exact A carries, besides the gyroscopic stiffness
        # n^2 diag(I2 - I3, 0, I2 - I1) of Euler's equations (e = theta / 2 in A).
        a, _ = linearize_gravity_gradient(body, LEO)
        gyro = n**2 * np.diag([moments[1] - moments[2], 0.0, moments[1] - moments[0]])
        np.testing.assert_allclose(
            a[3:, :3], 2.0 * np.diag(1.0 / moments) @ (jac - gyro), atol=1e-7 * np.abs(a[3:, :3]).max()
        )

    @pytest.mark.parametrize(
        ("kwargs", "match"),
        [
            ({"r_B": [0.0, 0.0, 0.0]}, "r_B must be non-zero"),
            ({"r_B": [7e6, np.nan, 0.0]}, "r_B must be finite"),
            ({"r_B": [7e6, 0.0]}, r"r_B must have shape \(\.\.\., 3\)"),
            ({"r_B": [7e6, 0.0, 0.0], "mu": -1.0}, "mu must be strictly positive"),
            ({"r_B": [7e6, 0.0, 0.0], "mu": [1.0, 2.0]}, "mu must be a scalar"),
        ],
    )
    def test_bad_input_is_rejected_with_the_argument_named(self, kwargs, match):
        with pytest.raises(ValueError, match=match):
            gravity_gradient_torque(RigidBody([1.0, 2.0, 2.5]), **kwargs)

    def test_body_and_component_count_are_checked(self):
        with pytest.raises(ValueError, match="body must be a RigidBody"):
            gravity_gradient_torque(np.eye(3), [7e6, 0.0, 0.0])
        with pytest.raises(ValueError, match="r_components must hold 3"):
            gravity_gradient_torque_components(RigidBody([1.0, 2.0, 2.5]), [1.0, 2.0])


class TestCircularOrbit:
    def test_geostationary_radius_gives_a_sidereal_day(self):
        # Published numbers: GEO radius 42,164.1696 km and sidereal day 86,164.0905 s. The radius
        # is given to 9 digits and T ~ r^1.5, so 1e-7 relative.
        orbit = CircularOrbit(42_164_169.6)
        assert orbit.period == pytest.approx(86_164.0905, rel=1e-7)
        assert orbit.mean_motion == pytest.approx(2.0 * np.pi / 86_164.0905, rel=1e-7)
        assert orbit.altitude_m == pytest.approx(42_164_169.6 - R_EARTH, rel=1e-15)

    def test_from_altitude_and_radius_agree(self):
        a = CircularOrbit.from_altitude(500e3, inclination=0.5)
        b = CircularOrbit(R_EARTH + 500e3, inclination=0.5)
        assert a == b

    def test_equatorial_orbit_at_the_node(self):
        orbit = CircularOrbit(7.0e6)
        np.testing.assert_allclose(orbit.position_N(0.0), [7.0e6, 0.0, 0.0])
        # Velocity along +y; o1 = +y (along track), o2 = -z (negative normal), o3 = -x (nadir).
        # Rows of C_LN are the L axes in N components; exact up to rounding.
        np.testing.assert_allclose(quat.to_dcm(orbit.q_LN(0.0)), [[0, 1, 0], [0, 0, -1], [-1, 0, 0]], atol=1e-15)

    @pytest.mark.parametrize("incl", [0.0, 0.3, np.pi / 2, 2.5, np.pi])
    def test_lvlh_axes_from_position_and_velocity(self, incl):
        orbit = CircularOrbit(7.1e6, inclination=incl, raan=-1.1, argument_of_latitude=2.0)
        t = np.linspace(0.0, 2.0 * orbit.period, 17)
        r = orbit.position_N(t)
        v = orbit.velocity_N(t)
        h = np.cross(r, v)
        o3 = -r / np.linalg.norm(r, axis=-1, keepdims=True)
        o2 = -h / np.linalg.norm(h, axis=-1, keepdims=True)
        o1 = np.cross(o2, o3)
        c_ln = quat.to_dcm(orbit.q_LN(t))
        # Unit vectors built two ways from trigonometry of the same angles: rounding only.
        np.testing.assert_allclose(c_ln, np.stack([o1, o2, o3], axis=-2), atol=1e-14)
        np.testing.assert_allclose(o1, v / np.linalg.norm(v, axis=-1, keepdims=True), atol=1e-14)
        np.testing.assert_allclose(np.linalg.norm(r, axis=-1), orbit.radius_m, rtol=1e-15)
        # Circular orbit: speed sqrt(mu / r).
        np.testing.assert_allclose(np.linalg.norm(v, axis=-1), np.sqrt(orbit.mu / orbit.radius_m), rtol=1e-14)
        # Inclination is the angle between the orbit normal and the north pole.
        np.testing.assert_allclose(-o2[:, 2], np.cos(incl), atol=1e-14)

    def test_velocity_and_lvlh_rate_are_time_derivatives(self):
        t0, dt = 1234.5, 1e-2
        # Central differences: truncation (n dt)^2 / 6 ~ 2e-11 relative, rounding eps / (n dt) ~ 1e-11.
        dr = (LEO.position_N(t0 + dt) - LEO.position_N(t0 - dt)) / (2.0 * dt)
        np.testing.assert_allclose(dr, LEO.velocity_N(t0), rtol=1e-8, atol=1e-8 * np.linalg.norm(dr))
        dq = (LEO.q_LN(t0 + dt) - LEO.q_LN(t0 - dt)) / (2.0 * dt)
        expected = quat.derivative(LEO.q_LN(t0), LEO.omega_LN_L)  # 0.5 q ⊗ [0, 0, -n, 0]
        np.testing.assert_allclose(dq, expected, atol=1e-8 * LEO.mean_motion)
        np.testing.assert_array_equal(LEO.omega_LN_L, [0.0, -LEO.mean_motion, 0.0])

    def test_batched_times(self):
        t = np.arange(6.0).reshape(2, 3) * 100.0
        assert LEO.position_N(t).shape == (2, 3, 3)
        assert LEO.q_LN(t).shape == (2, 3, 4)
        np.testing.assert_allclose(LEO.q_LN(t)[1, 2], LEO.q_LN(500.0), rtol=0, atol=1e-15)

    @pytest.mark.parametrize(
        ("kwargs", "match"),
        [
            ({"radius_m": 0.0}, "radius_m must be strictly positive"),
            ({"radius_m": -7e6}, "radius_m must be strictly positive"),
            ({"radius_m": np.nan}, "radius_m must be finite"),
            ({"radius_m": [7e6, 8e6]}, "radius_m must be a scalar"),
            ({"radius_m": 6.0e6}, "radius_m must exceed central_body_radius_m"),
            ({"radius_m": 7e6, "inclination": 4.0}, r"inclination must be in \[0, pi\]"),
            ({"radius_m": 7e6, "inclination": -0.1}, r"inclination must be in \[0, pi\]"),
            ({"radius_m": 7e6, "raan": np.inf}, "raan must be finite"),
            ({"radius_m": 7e6, "mu": 0.0}, "mu must be strictly positive"),
            ({"radius_m": 7e6, "central_body_radius_m": -1.0}, "central_body_radius_m must be non-negative"),
        ],
    )
    def test_bad_orbit_is_rejected_with_the_argument_named(self, kwargs, match):
        with pytest.raises(ValueError, match=match):
            CircularOrbit(**kwargs)

    @pytest.mark.parametrize(
        ("altitude", "match"),
        [(0.0, "altitude_m must be strictly positive"), (-1e3, "strictly positive"), (np.nan, "must be finite")],
    )
    def test_bad_altitude_is_rejected(self, altitude, match):
        with pytest.raises(ValueError, match=f"altitude_m.*{match}|{match}"):
            CircularOrbit.from_altitude(altitude)

    def test_bad_time_is_rejected(self):
        with pytest.raises(ValueError, match="t must be finite"):
            LEO.position_N(np.nan)


class TestLinearisation:
    BODIES: ClassVar[list] = [
        LAGRANGE,
        moments_from_k(*DEBRA_DELP_K),
        PITCH_UNSTABLE,
        ROLL_YAW_UNSTABLE,
        [1.0, 1.5, 2.0],
        [7, 3, 5],
    ]

    @pytest.mark.parametrize("moments", BODIES)
    def test_a_and_b_equal_the_classical_equations(self, moments):
        # Entry by entry against Wie's roll / pitch / yaw equations re-derived for these axes
        # (see docs/gravity_gradient.md). Jacobians are exact; only rounding, entries of size n or n^2.
        a, b = linearize_gravity_gradient(RigidBody(moments), LEO)
        a_ref, b_ref = wie_matrices(moments, LEO.mean_motion)
        np.testing.assert_allclose(a, a_ref, rtol=1e-12, atol=1e-14 * LEO.mean_motion)
        np.testing.assert_allclose(b, b_ref, rtol=1e-14)

    @pytest.mark.parametrize("moments", BODIES)
    def test_eigenvalues_are_the_roots_of_the_classical_polynomials(self, moments):
        n = LEO.mean_motion
        a, _ = linearize_gravity_gradient(RigidBody(moments), LEO)
        eig = np.linalg.eigvals(a)
        # Simple roots (no boundary bodies here): eigenvalue and root errors are both rounding
        # times a modest condition number; 1e-9 of n is the brief's bound.
        assert matched_distance(eig, classical_roots(moments, n)) < 1e-9 * n

    def test_pitch_decouples_from_roll_and_yaw(self):
        a, _ = linearize_gravity_gradient(RigidBody([7.0, 3.0, 5.0]), LEO)
        pitch = [1, 4]
        roll_yaw = [0, 2, 3, 5]
        # Exact structural zeros of the Jacobian.
        assert np.all(a[np.ix_(pitch, roll_yaw)] == 0.0)
        assert np.all(a[np.ix_(roll_yaw, pitch)] == 0.0)

    def test_nonlinear_model_is_tangent_to_the_linear_one(self):
        # |f(x) - A x| = O(|x|^2): halving x must divide the residual by ~4, not ~2.
        f = lvlh_relative_dynamics(RigidBody(LAGRANGE), LEO)
        a, b = linearize_gravity_gradient(RigidBody(LAGRANGE), LEO)
        n = LEO.mean_motion
        direction = np.array([0.3, -0.5, 0.2, 0.4 * n, 0.1 * n, -0.3 * n])
        u = np.array([1e-4, -2e-4, 5e-5])
        residuals = []
        for s in (1e-3, 5e-4):
            x = s * direction
            residuals.append(np.linalg.norm(np.ravel(f(x, u).full()) - a @ x - b @ u))
        assert 3.5 < residuals[0] / residuals[1] < 4.5

    def test_linear_model_predicts_the_full_inertial_simulation(self):
        # End to end, through code paths independent of the casadi model: q_LN, the numpy
        # torque callable and the propagator on inertial states, versus expm(A t) x0.
        body = RigidBody(LAGRANGE)
        a, _ = linearize_gravity_gradient(body, LEO)
        n = LEO.mean_motion
        t = np.linspace(0.0, 0.5 * LEO.period, 11)
        torque = gravity_gradient_torque_function(body, LEO)
        errors = []
        for size in (1e-4, 1e-5):
            x0 = size * np.array([1.0, -2.0, 1.5, 2.0 * n, 1.0 * n, -1.0 * n])
            q0, w0 = inertial_state(LEO, 0.0, x0)
            traj = propagate(body, q0, w0, t, torque=torque, max_step=5.0)
            x_sim = relative_state(LEO, t, traj.q, traj.omega)
            x_lin = np.stack([expm(a * tk) @ x0 for tk in t])
            scale = np.abs(x0) + np.abs(x_lin).max(axis=0)  # per-component scale (angles vs rates)
            errors.append(np.max(np.abs(x_sim - x_lin) / scale))
        # Neglected nonlinear terms make a relative error c |x| with c ~ 10 over half an orbit
        # (measured 8.7e-5 at |x| ~ 1e-5); RK4 at n h = 0.006 adds ~1e-8. Bound: 1e-3.
        assert errors[1] < 1e-3
        # Tangency: a wrong A would leave an error independent of |x|; the exact one shrinks
        # tenfold with x0 (measured ratio 10.00; the band allows the RK4 floor).
        assert 8.0 < errors[0] / errors[1] < 12.0

    def test_requires_a_single_principal_body_and_an_orbit(self):
        with pytest.raises(ValueError, match="principal frame"):
            linearize_gravity_gradient(RigidBody([[10.0, 0.5, 0.0], [0.5, 12.0, 0.0], [0.0, 0.0, 8.0]]), LEO)
        with pytest.raises(ValueError, match="single body"):
            linearize_gravity_gradient(RigidBody([LAGRANGE, LAGRANGE]), LEO)
        with pytest.raises(ValueError, match="orbit must be a CircularOrbit"):
            linearize_gravity_gradient(RigidBody(LAGRANGE), 7e6)


def eigen_stable(moments, orbit=LEO) -> bool:
    """Linear (marginal) stability from the eigenvalues of A: all on the imaginary axis."""
    a, _ = linearize_gravity_gradient(RigidBody(moments), orbit)
    # Stable spectra have real parts at rounding level (~1e-17 n); unstable ones kept by the
    # boundary band below have real parts above ~1e-2 n. 1e-6 n splits them with margin.
    return bool(np.max(np.abs(np.linalg.eigvals(a).real)) < 1e-6 * orbit.mean_motion)


class TestStability:
    def test_lagrange_body(self):
        s = gravity_gradient_stability(RigidBody(LAGRANGE), LEO)
        assert (s.region, s.stable, s.pitch_stable, s.roll_yaw_stable) == ("Lagrange", True, True, True)
        assert (s.k1, s.k3) == pytest.approx((0.75, 0.5), rel=1e-15)
        n = LEO.mean_motion
        assert s.pitch_frequency == pytest.approx(n * np.sqrt(3.0 * 40.0 / 100.0), rel=1e-14)
        # The frequencies are the imaginary parts of A's eigenvalues (1e-9: as for the roots).
        a, _ = linearize_gravity_gradient(RigidBody(LAGRANGE), LEO)
        freqs = np.sort(np.abs(np.linalg.eigvals(a).imag))[::2]
        expected = np.sort([s.pitch_frequency, *s.roll_yaw_frequencies])
        np.testing.assert_allclose(freqs, expected, rtol=1e-9)

    def test_debra_delp_body(self):
        moments = moments_from_k(*DEBRA_DELP_K)
        s = gravity_gradient_stability(moments, LEO)
        assert (s.region, s.stable) == ("DeBra-Delp", True)
        assert (s.k1, s.k3) == pytest.approx(DEBRA_DELP_K, rel=1e-12)
        # Roll axis major, pitch axis minor.
        assert moments[0] > moments[2] > moments[1]
        assert eigen_stable(moments)

    @pytest.mark.parametrize(
        ("moments", "pitch", "roll_yaw"),
        [(PITCH_UNSTABLE, False, True), (ROLL_YAW_UNSTABLE, True, False), ([1.0, 1.5, 2.0], False, False)],
    )
    def test_unstable_bodies(self, moments, pitch, roll_yaw):
        s = gravity_gradient_stability(moments)
        assert (s.pitch_stable, s.roll_yaw_stable, s.stable, s.region) == (pitch, roll_yaw, False, "unstable")
        assert (s.pitch_frequency_ratio is None) == (not pitch)
        assert (s.roll_yaw_frequency_ratios is None) == (not roll_yaw)
        assert s.pitch_frequency is None and s.mean_motion is None  # no orbit given
        assert not eigen_stable(moments)

    def test_random_sweep_agrees_with_the_eigenvalues(self):
        rng = np.random.default_rng(2024)
        k = rng.uniform(-1.0, 1.0, (400, 2))
        regions = {"Lagrange": 0, "DeBra-Delp": 0, "unstable": 0}
        checked = 0
        for k1, k3 in k:
            b = 1.0 + 3.0 * k1 + k1 * k3
            margins = [k1 - k3, k1, k3, b, b * b - 16.0 * k1 * k3, 1.0 - abs(k1), 1.0 - abs(k3)]
            if min(abs(m) for m in margins) < 0.02:  # thin band around the region boundaries
                continue
            moments = moments_from_k(k1, k3)
            s = gravity_gradient_stability(moments)
            assert s.stable == eigen_stable(moments), (k1, k3, s)
            regions[s.region] += 1
            checked += 1
        # The sweep must actually visit every region (Lagrange ~1/8 of the square, DeBra-Delp ~1%).
        assert checked > 300
        assert regions["Lagrange"] > 20 and regions["DeBra-Delp"] > 0 and regions["unstable"] > 100

    def test_debra_delp_region_is_visited_densely(self):
        # The DeBra-Delp region is thin; sample its (k1, k3) box on its own.
        rng = np.random.default_rng(5)
        found = 0
        for k1, k3 in zip(rng.uniform(-0.35, 0.0, 120), rng.uniform(-1.0, 0.0, 120)):
            b = 1.0 + 3.0 * k1 + k1 * k3
            margins = [k1 - k3, k1, k3, b, b * b - 16.0 * k1 * k3, 1.0 - abs(k3)]
            if min(abs(m) for m in margins) < 0.01:
                continue
            moments = moments_from_k(k1, k3)
            s = gravity_gradient_stability(moments)
            assert s.stable == eigen_stable(moments), (k1, k3)
            found += s.region == "DeBra-Delp"
        assert found > 10

    def test_boundary_is_unstable(self):
        # A symmetric body (I1 = I3) has zero pitch stiffness: not (asymptotically or marginally) stable.
        s = gravity_gradient_stability([1.0, 1.5, 1.0])
        assert not s.pitch_stable and s.region == "unstable"

    @pytest.mark.parametrize(
        ("arg", "match"),
        [
            ([1.0, 2.0], "body_or_moments must be a RigidBody or 3 principal moments"),
            ([1.0, -2.0, 2.0], "body_or_moments: inertia must be positive definite"),
            ([1.0, np.nan, 2.0], "body_or_moments must be finite"),
            ([1.0, 1.0, 3.0], "body_or_moments: inertia must be physically realisable"),
            (RigidBody([[10.0, 0.5, 0.0], [0.5, 12.0, 0.0], [0.0, 0.0, 8.0]]), "principal frame"),
        ],
    )
    def test_bad_input_is_rejected(self, arg, match):
        with pytest.raises(ValueError, match=match):
            gravity_gradient_stability(arg)


class TestTorqueCallables:
    def test_pitch_libration_at_the_predicted_frequency(self):
        body = RigidBody(LAGRANGE)
        predicted = gravity_gradient_stability(body, LEO).pitch_frequency
        theta0 = 0.02  # rad
        q0, w0 = inertial_state(LEO, 0.0, [0.0, np.sin(theta0 / 2.0), 0.0, 0.0, 0.0, 0.0])
        t = np.arange(0.0, 3.0 * LEO.period, 20.0)
        traj = propagate(body, q0, w0, t, torque=gravity_gradient_torque_function(body, LEO))
        x = relative_state(LEO, t, traj.q, traj.omega)
        q_bl_w = np.sqrt(1.0 - np.sum(x[:, :3] ** 2, axis=1))
        pitch = 2.0 * np.arctan2(x[:, 1], q_bl_w)
        # Pitch-only initial conditions stay in the pitch plane (exactly, by symmetry; rounding only).
        assert np.max(np.abs(x[:, [0, 2]])) < 1e-10
        assert np.max(np.abs(pitch)) == pytest.approx(theta0, rel=1e-3)
        sign_change = np.nonzero(np.sign(pitch[:-1]) != np.sign(pitch[1:]))[0]
        crossings = t[sign_change] - pitch[sign_change] * 20.0 / (pitch[sign_change + 1] - pitch[sign_change])
        assert crossings.size >= 5
        period = 2.0 * (crossings[-1] - crossings[0]) / (crossings.size - 1)
        # Finite amplitude lengthens the period by (2 theta0)^2 / 16 = 1e-4 (pendulum in 2 theta);
        # RK4 at n h = 0.02 and linear interpolation of the crossings add < 1e-6. 1e-3 is tighter
        # than the brief's 1 % and ten times the amplitude effect.
        assert period == pytest.approx(2.0 * np.pi / predicted, rel=1e-3)
        # ...and the amplitude correction itself is visible (measured 1.000e-4).
        assert period * predicted / (2.0 * np.pi) - 1.0 == pytest.approx(theta0**2 / 4.0, rel=0.05)

    def test_torque_function_on_a_batch(self):
        body = RigidBody(np.array([[10.0, 1.2, -0.5], [1.2, 12.0, 0.3], [-0.5, 0.3, 8.0]]))
        fun = gravity_gradient_torque_function(body, LEO)
        q = quat.random((5,), rng=3)
        out = fun(321.0, q, np.zeros((5, 3)))
        assert out.shape == (5, 3)
        for qi, row in zip(q, out):
            r_B = quat.to_dcm(qi) @ LEO.position_N(321.0)
            # Same formula, rotation by DCM instead of quaternion sandwich: rounding only.
            expected = gravity_gradient_torque(body, r_B)
            np.testing.assert_allclose(row, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())

    def test_torque_function_arguments_are_checked(self):
        with pytest.raises(ValueError, match="orbit must be a CircularOrbit"):
            gravity_gradient_torque_function(RigidBody(LAGRANGE), None)
        with pytest.raises(ValueError, match="body must be a RigidBody"):
            gravity_gradient_torque_function(LAGRANGE, LEO)

    def test_disturbance_integrates_to_the_exact_rate(self):
        # On a principal axis of a body at rest there is no gyroscopic coupling, so
        # I1 w1(t) = b t + (a / n) (cos(phase) - cos(n t + phase)).
        i1, b, amp, n, phase = 10.0, 2e-5, 3e-5, 1e-3, 0.4
        fun = constant_plus_orbital_disturbance([b, 0.0, 0.0], [amp, 0.0, 0.0], n, phase=phase)
        t = np.linspace(0.0, 6000.0, 61)
        traj = propagate(RigidBody([i1, 12.0, 8.0]), quat.identity(), np.zeros(3), t, torque=fun, max_step=10.0)
        exact = (b * t + amp / n * (np.cos(phase) - np.cos(n * t + phase))) / i1
        # RK4 integrates a sinusoid at n h = 0.01 to ~1e-12 relative.
        np.testing.assert_allclose(traj.omega[:, 0], exact, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(traj.omega[:, 1:], 0.0, atol=1e-15)

    def test_disturbance_shape_and_bias(self):
        fun = constant_plus_orbital_disturbance([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], 0.0)
        out = fun(10.0, np.zeros((2, 4, 4)), np.zeros((2, 4, 3)))
        assert out.shape == (2, 4, 3)
        np.testing.assert_array_equal(out[1, 3], [1.0, 2.0, 3.0])

    @pytest.mark.parametrize(
        ("args", "match"),
        [
            (([1.0, 2.0], [0.0, 0.0, 0.0], 1e-3), "bias_Nm must have shape"),
            (([0.0, 0.0, 0.0], [[0.0, 0.0, 0.0]], 1e-3), r"amplitude_Nm must have shape \(3,\)"),
            (([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], -1e-3), "orbit_rate must be non-negative"),
            (([0.0, np.nan, 0.0], [0.0, 0.0, 0.0], 1e-3), "bias_Nm must be finite"),
        ],
    )
    def test_disturbance_arguments_are_checked(self, args, match):
        with pytest.raises(ValueError, match=match):
            constant_plus_orbital_disturbance(*args)

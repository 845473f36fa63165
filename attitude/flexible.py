"""Flexible appendages as modes: the hybrid-coordinate equations of motion, one definition for numpy and casadi.

A spacecraft with flexible appendages (solar-array wings, antennas, booms) is
modelled in *hybrid coordinates* (Hughes, *Spacecraft Attitude Dynamics*,
1986; Junkins and Kim, *Introduction to Dynamics and Control of
Flexible Structures*, 1993): the rigid rotation ``q, omega`` of the
body frame plus ``n`` modal coordinates ``eta`` of the appendages'
deformation. The equations, with ``I`` the whole spacecraft's inertia
(appendages undeformed), ``L`` the modal participation matrix ``(n, 3)``
[sqrt(kg) m], ``Omega`` the modal frequencies [rad/s] and ``Z`` the damping
ratios, are

.. math::

    I \\dot\\omega + L^T \\ddot\\eta + \\omega \\times (I \\omega + L^T \\dot\\eta + h) = \\tau

    \\ddot\\eta + 2 Z \\Omega \\dot\\eta + \\Omega^2 \\eta + L \\dot\\omega = 0

(``h`` internal momentum, e.g. of wheels, as :class:`attitude.rigid_body.RigidBody`
takes it). They are the Lagrange equations of the kinetic energy
``T = omega.I omega / 2 + omega.L^T eta_dot + |eta_dot|^2 / 2`` and the strain
energy ``V = eta.Omega^2 eta / 2`` (linear elasticity: no geometric stiffening
by the body rate, so valid for body rates well below the modal frequencies).

**Convention: constrained (cantilevered) modes.** ``Omega`` are the
frequencies of the appendages clamped to a hub that does not move, and ``L``
their participation in the rotation (``L_k = integral of r x phi_k dm`` for a
mass-normalised mode shape ``phi_k``). The mass matrix ``[[I, L^T], [L, 1]]``
is positive definite exactly when ``I - L^T L`` is (its Schur complement),
which :class:`FlexibleBody` requires. With these modes the collocated
torque -> rate transfer function has its zeros at ``Omega`` and its poles at
the higher unconstrained (free-free) frequencies, for one mode about one
axis ``Omega / sqrt(1 - l^2 / I)`` (:meth:`FlexibleBody.unconstrained_frequencies`).

The accelerations are solved in closed form: with ``f = 2 Z Omega eta_dot +
Omega^2 eta`` the modal restoring force, ``eta_ddot = -L omega_dot - f`` and
``omega_dot = (1 - I^-1 L^T L)^-1 a``, where ``a`` is the rigid body's own
Euler equations (:meth:`RigidBody.omega_dot_components`, the one definition)
under the torque ``tau + L^T f`` with the internal momentum ``h + L^T eta_dot``.
``L = 0`` gives back the rigid body exactly. See docs/flexible_modes.md for
the derivation.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.backend import sqrt
from attitude.quaternion import derivative_components as quaternion_rate
from attitude.rigid_body import Components, RigidBody, join_components, split_components
from attitude.validation import as_float_array, check_vector, describe

__all__ = [
    "MASS_MATRIX_MARGIN",
    "FlexibleBody",
    "FlexibleModes",
]

#: Smallest accepted eigenvalue of ``I - L^T L`` relative to the largest principal moment of ``I``. At zero
#: the modes carry the whole inertia about some axis and the mass matrix is singular; 1e-9 refuses matrices
#: singular to rounding (the accelerations would be amplified by more than 1e9) and accepts every real body.
MASS_MATRIX_MARGIN = 1e-9


@dataclass(frozen=True, eq=False)
class FlexibleModes:
    """The constrained (cantilevered) modes of flexible appendages.

    Parameters
    ----------
    frequency : array_like (n,)
        Natural frequency of each constrained mode [rad/s], > 0
        (:meth:`from_hz` takes them in Hz).
    damping : array_like (n,) or float
        Damping ratio of each mode [-], in ``[0, 1)`` (one value for all modes).
    participation : array_like (n, 3)
        Modal participation matrix ``L`` [sqrt(kg) m]: row ``k`` couples mode
        ``k`` to the body rotation about the body axes (``L_k = integral of
        r x phi_k dm`` for the mass-normalised mode shape ``phi_k``). One
        mode may be given as a 3-vector.

    Raises
    ------
    ValueError
        A frequency not finite and positive, a damping ratio negative or not
        below 1, a participation matrix that is not finite or not ``(n, 3)``,
        or lengths that disagree (each message names the argument).

    Examples
    --------
    >>> modes = FlexibleModes.from_hz(frequency_Hz=[1.5], damping=0.005, participation=[[0.0, 2.0, 0.0]])
    >>> modes.n_modes, round(float(modes.frequency[0]), 4)
    (1, 9.4248)
    """

    frequency: NDArray[np.float64]
    damping: NDArray[np.float64]
    participation: NDArray[np.float64]

    def __post_init__(self) -> None:
        w = as_float_array(self.frequency, "frequency").reshape(-1).copy()
        if w.size == 0:
            raise ValueError("frequency must hold at least one mode [rad/s], got none")
        if not np.all(w > 0):
            raise ValueError(f"frequency must be strictly positive (> 0) [rad/s], got {describe(w)}")
        z = as_float_array(self.damping, "damping")
        z = np.broadcast_to(z, w.shape).copy() if z.ndim == 0 else z.reshape(-1).copy()
        if z.shape != w.shape:
            raise ValueError(f"damping must have one ratio per mode ({w.size}), got {z.size}")
        if not np.all((z >= 0.0) & (z < 1.0)):
            raise ValueError(
                f"damping must be in [0, 1) (a negative ratio feeds energy in; >= 1 is no longer a mode), "
                f"got {describe(z)}"
            )
        p = as_float_array(self.participation, "participation").copy()
        if p.shape == (3,):
            p = p.reshape(1, 3)
        if p.shape != (w.size, 3):
            raise ValueError(
                f"participation must have shape (n_modes, 3) = ({w.size}, 3) [sqrt(kg) m], got shape {p.shape}"
            )
        for name, value in (("frequency", w), ("damping", z), ("participation", p)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)

    @classmethod
    def from_hz(cls, *, frequency_Hz: ArrayLike, damping: ArrayLike, participation: ArrayLike) -> FlexibleModes:
        """Modes from frequencies in Hz (the datasheet and the spacecraft file's unit).

        Parameters
        ----------
        frequency_Hz : array_like (n,)
            Natural frequency of each constrained mode [Hz], > 0.
        damping : array_like (n,) or float
            Damping ratio of each mode [-], in ``[0, 1)``.
        participation : array_like (n, 3)
            Modal participation matrix ``L`` [sqrt(kg) m].

        Returns
        -------
        FlexibleModes
            With ``frequency = 2 pi frequency_Hz`` [rad/s].

        Raises
        ------
        ValueError
            As the constructor, naming ``frequency_Hz`` for a bad frequency.
        """
        f = as_float_array(frequency_Hz, "frequency_Hz").reshape(-1)
        if not np.all(f > 0):
            raise ValueError(f"frequency_Hz must be strictly positive (> 0) [Hz], got {describe(f)}")
        return cls(frequency=2.0 * np.pi * f, damping=damping, participation=participation)

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.frequency.size)

    @property
    def frequency_Hz(self) -> NDArray[np.float64]:
        """Natural frequencies of the constrained modes [Hz]."""
        return self.frequency / (2.0 * np.pi)


def _rows(matrix: NDArray[np.float64]) -> list[list[float | None]]:
    """A constant matrix as nested lists of floats, ``None`` for exact zeros (skipped, so ``L = 0`` adds nothing)."""
    return [[None if v == 0.0 else float(v) for v in row] for row in np.asarray(matrix, dtype=float)]


def _times(rows: list[list[float | None]], v: Components) -> Components:
    """``M v`` for a constant matrix from :func:`_rows` on components (numpy or casadi); zero rows give ``0 v_0``."""
    out = []
    for row in rows:
        acc = None
        for e, vj in zip(row, v):
            if e is None:
                continue
            term = vj if e == 1.0 else e * vj
            acc = term if acc is None else acc + term
        out.append(0.0 * v[0] if acc is None else acc)
    return out


def _matrix(value: NDArray[np.float64]) -> str:
    """A small matrix's values in an error message, to 6 significant digits."""
    return str([[float(f"{v:.6g}") for v in row] for row in np.atleast_2d(value)])


class FlexibleBody:
    """A rigid hub with flexible appendages: the hybrid-coordinate equations (module docstring).

    The state is ``x = [q_BN (4), omega_BN_B (3), eta (n), eta_dot (n)]``
    (modal coordinates [sqrt(kg) m] and their rates); :meth:`state_derivative`
    evaluates on numpy arrays ``(..., 7 + 2n)`` and on casadi vectors, from one
    definition (:meth:`state_derivative_components`).

    Parameters
    ----------
    body : RigidBody
        The whole spacecraft, appendages included and undeformed (a single
        body, not a batch) [kg m^2].
    modes : FlexibleModes
        The constrained modes of the appendages.

    Raises
    ------
    ValueError
        If ``body`` is not a single RigidBody, ``modes`` not FlexibleModes, or
        ``I - L^T L`` is not positive definite (the modes would carry more
        inertia than the spacecraft has: ``modes.participation`` is named).

    Examples
    --------
    >>> body = RigidBody([100.0, 120.0, 80.0])
    >>> modes = FlexibleModes(frequency=[6.0], damping=0.0, participation=[[6.0, 0.0, 0.0]])
    >>> round(float(FlexibleBody(body, modes).unconstrained_frequencies()[0]), 12)  # 6 / sqrt(1 - 36/100)
    7.5
    """

    def __init__(self, body: RigidBody, modes: FlexibleModes) -> None:
        if not isinstance(body, RigidBody) or body.batch_shape:
            raise ValueError(f"body must be a single RigidBody, got {body!r}")
        if not isinstance(modes, FlexibleModes):
            raise ValueError(f"modes must be FlexibleModes, got {type(modes).__name__}")
        inertia = body.inertia
        L = modes.participation
        reduced = inertia - L.T @ L
        smallest = float(np.linalg.eigvalsh(reduced)[0])
        scale = float(np.max(body.principal_axes().moments))
        if smallest <= MASS_MATRIX_MARGIN * scale:
            raise ValueError(
                "modes.participation must leave I - L^T L positive definite (the modes cannot carry more inertia "
                f"than the whole spacecraft has, all modes together); its smallest eigenvalue is {smallest:.6g} kg m^2 "
                f"for the inertia {_matrix(inertia)} kg m^2 and L^T L = {_matrix(L.T @ L)} kg m^2"
            )
        self.body = body
        self.modes = modes
        self.n_modes = modes.n_modes
        self.n_states = 7 + 2 * modes.n_modes
        # omega_dot = (1 - I^-1 L^T L)^-1 a: exactly the identity (so a itself) when L = 0.
        self._coupling = np.linalg.inv(np.eye(3) - body.inertia_inv @ (L.T @ L))
        self._P = _rows(self._coupling)
        self._L = _rows(L)
        self._LT = _rows(L.T)
        self._stiffness = [float(v) for v in modes.frequency**2]
        self._damping = [float(v) for v in 2.0 * modes.damping * modes.frequency]

    def __repr__(self) -> str:
        return f"FlexibleBody({self.body!r}, {self.n_modes} modes at {describe(self.modes.frequency_Hz)} Hz)"

    # -- the one definition (components: numpy arrays or casadi scalars) ----------

    def state_derivative_components(
        self, x: Components, torque: Components | None, h: Components | None = None
    ) -> Components:
        """Time derivative of the state components ``[q, omega, eta, eta_dot]`` (numpy or casadi).

        Parameters
        ----------
        x : list of 7 + 2n numpy arrays or casadi scalars
            Attitude ``q_BN``, body rate [rad/s], modal coordinates
            [sqrt(kg) m] and their rates [sqrt(kg) m/s].
        torque : list of 3 or None
            External torque in body components [N m]; None for none.
        h : list of 3, optional
            Internal (wheel) angular momentum in body components [N m s].

        Returns
        -------
        list of 7 + 2n
            ``[q_dot, omega_dot [rad/s^2], eta_dot, eta_ddot]``, same backend as ``x``.
        """
        n = self.n_modes
        q, w = x[:4], x[4:7]
        eta, eta_dot = x[7 : 7 + n], x[7 + n : 7 + 2 * n]
        force = [c * ed + k * e for c, k, e, ed in zip(self._damping, self._stiffness, eta, eta_dot)]
        tau = _times(self._LT, force)
        if torque is not None:
            tau = [t + f for t, f in zip(torque, tau)]
        h_modes = _times(self._LT, eta_dot)
        if h is not None:
            h_modes = [a + b for a, b in zip(h, h_modes)]
        w_dot = _times(self._P, self.body.omega_dot_components(w, tau, h_modes))
        eta_ddot = [-a - f for a, f in zip(_times(self._L, w_dot), force)]
        return quaternion_rate(q, w) + w_dot + list(eta_dot) + eta_ddot

    def error_state_derivative_components(self, x: Components, torque: Components) -> Components:
        """The reduced model of linearisation: ``[q_ev (3), omega, eta, eta_dot]`` (numpy or casadi).

        The scalar part of the attitude is ``sqrt(1 - |q_ev|^2)`` (the
        shortest-way chart, as :func:`attitude.linearize.error_state_derivative_components`
        for a reference at rest) and its derivative is left out.

        Parameters
        ----------
        x : list of 6 + 2n
            Vector part of ``q_BN`` [-], body rate [rad/s], modal coordinates
            and their rates.
        torque : list of 3
            Body torque [N m].

        Returns
        -------
        list of 6 + 2n
            ``[q_ev_dot, omega_dot, eta_dot, eta_ddot]``.
        """
        qv = list(x[:3])
        q0 = sqrt(1.0 - (qv[0] * qv[0] + qv[1] * qv[1] + qv[2] * qv[2]))
        return self.state_derivative_components([q0, *qv, *x[3:]], torque)[1:]

    # -- numpy and casadi front ends ------------------------------------------------

    def state_derivative(self, x: Any, torque: Any = None, h: Any = None) -> Any:
        """Time derivative of the state ``x = [q_BN, omega_BN_B, eta, eta_dot]``.

        Parameters
        ----------
        x : array_like (..., 7 + 2n) or casadi vector (7 + 2n)
            Attitude (scalar first), body rate [rad/s], modal coordinates
            [sqrt(kg) m] and their rates [sqrt(kg) m/s].
        torque : array_like (..., 3) or casadi vector (3), optional
            External torque in body components [N m]; zero if omitted.
        h : array_like (..., 3) or casadi vector (3), optional
            Internal angular momentum in body components [N m s].

        Returns
        -------
        ndarray (..., 7 + 2n) or casadi vector
            ``[q_dot, omega_dot, eta_dot, eta_ddot]``, same backend as ``x``.

        Raises
        ------
        ValueError
            A numpy input of the wrong last dimension or holding NaN/inf, or a
            casadi input of the wrong size.
        """
        symbolic = isinstance(x, (ca.SX, ca.MX, ca.DM))
        if not symbolic:
            x = check_vector(x, "x", self.n_states)
        xs = split_components(x, self.n_states)
        tau = None if torque is None else split_components(torque if symbolic else check_vector(torque, "torque", 3), 3)
        hh = None if h is None else split_components(h if symbolic else check_vector(h, "h", 3), 3)
        return join_components(self.state_derivative_components(xs, tau, hh), x)

    def casadi_dynamics(self) -> ca.Function:
        """The equations as a casadi Function ``f(x[7 + 2n], tau[3]) -> x_dot``.

        Returns
        -------
        casadi.Function
            ``f(x, tau) -> x_dot`` with the state of :meth:`state_derivative`
            and ``tau`` in body components [N m].
        """
        x = ca.SX.sym("x", self.n_states)
        tau = ca.SX.sym("tau", 3)
        return ca.Function("flexible_dynamics", [x, tau], [self.state_derivative(x, tau)], ["x", "tau"], ["x_dot"])

    def jacobians_at_rest(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Exact Jacobians (casadi) of :meth:`error_state_derivative_components` at rest, undeformed, no torque.

        Returns
        -------
        A : ndarray (6 + 2n, 6 + 2n)
            ``d x_dot / d x`` with ``x = [q_ev, omega, eta, eta_dot]``.
        B : ndarray (6 + 2n, 3)
            ``d x_dot / d tau`` [per N m].
        """
        m = self.n_states - 1
        x = ca.SX.sym("x", m)
        tau = ca.SX.sym("tau", 3)
        f = ca.vertcat(*self.error_state_derivative_components([x[i] for i in range(m)], [tau[i] for i in range(3)]))
        jac = ca.Function("flexible_jacobian", [x, tau], [ca.jacobian(f, x), ca.jacobian(f, tau)])
        a, b = jac(np.zeros(m), np.zeros(3))
        # + 0.0 turns the -0.0 entries of structurally non-zero terms into 0.0 (cosmetic).
        return np.array(a.full()) + 0.0, np.array(b.full()) + 0.0

    # -- invariants and frequencies (numpy) -------------------------------------------

    def _parts(self, x: ArrayLike) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        x = check_vector(x, "x", self.n_states)
        n = self.n_modes
        return x[..., :4], x[..., 4:7], x[..., 7 : 7 + n], x[..., 7 + n :]

    def angular_momentum(self, x: ArrayLike) -> NDArray[np.float64]:
        """Body angular momentum ``H_B = I omega + L^T eta_dot`` [N m s] (internal momentum not included).

        Parameters
        ----------
        x : array_like (..., 7 + 2n)
            States as in :meth:`state_derivative`.

        Returns
        -------
        ndarray (..., 3)
            ``H_B`` in body components [N m s].
        """
        _, w, _, ed = self._parts(x)
        return w @ self.body.inertia.T + ed @ self.modes.participation

    def inertial_angular_momentum(self, x: ArrayLike) -> NDArray[np.float64]:
        """Angular momentum in inertial components, ``rotate(q_BN, H_B)`` [N m s] (constant without torque).

        Parameters
        ----------
        x : array_like (..., 7 + 2n)
            States as in :meth:`state_derivative`.

        Returns
        -------
        ndarray (..., 3)
            ``H_N`` [N m s].
        """
        q = self._parts(x)[0]
        return quat.rotate(q / np.linalg.norm(q, axis=-1, keepdims=True), self.angular_momentum(x))

    def energy(self, x: ArrayLike) -> NDArray[np.float64]:
        """Total mechanical energy ``T + V`` [J] (constant without torque and damping).

        ``T = omega.I omega / 2 + omega.L^T eta_dot + |eta_dot|^2 / 2`` (rotation
        and the appendages' vibration) and ``V = sum Omega_k^2 eta_k^2 / 2``
        (strain).

        Parameters
        ----------
        x : array_like (..., 7 + 2n)
            States as in :meth:`state_derivative`.

        Returns
        -------
        ndarray (...)
            Energy [J].
        """
        _, w, eta, ed = self._parts(x)
        rotation = 0.5 * np.sum(w * (w @ self.body.inertia.T), axis=-1)
        coupling = np.sum(w * (ed @ self.modes.participation), axis=-1)
        vibration = 0.5 * np.sum(ed * ed, axis=-1)
        strain = 0.5 * np.sum(self.modes.frequency**2 * eta * eta, axis=-1)
        return rotation + coupling + vibration + strain

    def unconstrained_frequencies(self) -> NDArray[np.float64]:
        """Natural frequencies of the free-floating spacecraft [rad/s], ascending (undamped).

        With the body free to rotate (``tau = 0``, at rest), ``omega_dot =
        -I^-1 L^T eta_ddot`` and the modes obey ``(1 - L I^-1 L^T) eta_ddot +
        Omega^2 eta = 0``: the generalised eigenvalues of ``(Omega^2, 1 - L
        I^-1 L^T)``. They are the poles of the collocated torque -> rate
        transfer function, above the constrained frequencies (its zeros).

        Returns
        -------
        ndarray (n,)
            Unconstrained frequencies [rad/s].
        """
        L = self.modes.participation
        mass = np.eye(self.n_modes) - L @ self.body.inertia_inv @ L.T
        mass = 0.5 * (mass + mass.T)
        eig = scipy.linalg.eigh(np.diag(self.modes.frequency**2), mass, eigvals_only=True)
        return np.sqrt(np.sort(eig))

    def initial_state(
        self, q0: ArrayLike, omega0: ArrayLike, eta0: ArrayLike | None = None, eta_dot0: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """The state vector ``[q, omega, eta, eta_dot]`` from its parts, checked.

        Parameters
        ----------
        q0 : array_like (4,)
            Attitude ``q_BN`` (normalised).
        omega0 : array_like (3,)
            Body rate [rad/s].
        eta0, eta_dot0 : array_like (n,), optional
            Modal coordinates [sqrt(kg) m] and rates [sqrt(kg) m/s]; zero by default.

        Returns
        -------
        ndarray (7 + 2n,)

        Raises
        ------
        ValueError
            A part of the wrong shape or not finite (naming the argument).
        """
        q0 = quat.as_unit_quaternion(q0, "q0")
        omega0 = check_vector(omega0, "omega0", 3)
        if q0.shape != (4,) or omega0.shape != (3,):
            raise ValueError(f"q0 must have shape (4,) and omega0 shape (3,), got {q0.shape} and {omega0.shape}")
        parts = [q0, omega0]
        for name, value in (("eta0", eta0), ("eta_dot0", eta_dot0)):
            v = np.zeros(self.n_modes) if value is None else as_float_array(value, name).reshape(-1)
            if v.shape != (self.n_modes,):
                raise ValueError(f"{name} must have one entry per mode ({self.n_modes}), got shape {np.shape(value)}")
            parts.append(v)
        return np.concatenate(parts)

"""The rigid-body plant: inertia checks, principal axes and Euler's equations.

This module holds the **one definition** of the equations of motion

.. math::

    \\dot q = \\tfrac12\\, q \\otimes [0, \\omega], \\qquad
    I \\dot\\omega = \\tau - \\omega \\times (I \\omega + h)

(``h`` is internal angular momentum in body components, e.g. of reaction
wheels; the reaction torque ``-h_dot`` is part of ``tau``). The equations are
written once, component by component, with nothing but ``+ - *``, so the same
code evaluates on numpy arrays of any batch shape (the simulation path) and on
casadi ``SX``/``MX`` symbols (exact Jacobians for linearisation and optimal
control). ``tests/attitude/test_rigid_body.py`` proves the two evaluations agree.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.backend import cross
from attitude.quaternion import derivative_components as quaternion_rate
from attitude.validation import as_float_array, check_vector, describe

__all__ = [
    "INERTIA_MAX_KG_M2",
    "INERTIA_MIN_KG_M2",
    "REALISABILITY_TOLERANCE",
    "SYMMETRY_TOLERANCE",
    "ParametricBody",
    "PrincipalAxes",
    "RigidBody",
    "skew",
    "symmetric_entries",
    "symmetric_rows",
]

#: Largest accepted ``max|I - I^T| / max|I|``: inertia tensors from CAD tools
#: are symmetric to their printed digits; 1e-9 tolerates rounding while
#: rejecting a typed-in off-diagonal that differs from its mirror.
SYMMETRY_TOLERANCE = 1e-9

#: Relative slack in the triangle inequality ``I_k <= I_i + I_j``. A flat plate
#: sits exactly on the boundary, so equality must pass despite rounding of the
#: eigenvalue solver (relative error ~1e-15); 1e-9 leaves ample margin.
REALISABILITY_TOLERANCE = 1e-9

Components = list[Any]


# ---------------------------------------------------------------------------
# Backend-neutral building blocks (lists of components: numpy arrays or casadi
# scalars). Only + - * are used so that both backends evaluate the same code.
# ---------------------------------------------------------------------------


def _split(x: Any, n: int) -> Components:
    """Split a state into its ``n`` components (numpy: last axis; casadi: rows)."""
    if isinstance(x, (ca.SX, ca.MX, ca.DM)):
        if x.numel() != n:
            raise ValueError(f"casadi state must have {n} entries, got shape {x.shape}")
        return [x[i] for i in range(n)]
    return [x[..., i] for i in range(n)]


def _join(parts: Components, like: Any) -> Any:
    """Inverse of :func:`_split` for the backend of ``like``."""
    if isinstance(like, (ca.SX, ca.MX, ca.DM)):
        return ca.vertcat(*parts)
    parts = np.broadcast_arrays(*parts)
    return np.stack(parts, axis=-1)


def _matvec(entries: list[list[Any]], v: Components) -> Components:
    """Matrix-vector product with a 3x3 nested list; ``None`` entries are zero."""
    out = []
    for row in entries:
        acc = None
        for e, vj in zip(row, v):
            if e is None:
                continue
            acc = e * vj if acc is None else acc + e * vj
        out.append(acc if acc is not None else 0.0 * v[0])
    return out


def _entries(matrix: NDArray[np.float64]) -> list[list[Any]]:
    """Nested 3x3 list of a (batched) matrix, with ``None`` for entries zero everywhere."""
    out = []
    for i in range(3):
        row = []
        for j in range(3):
            e = matrix[..., i, j]
            if np.all(e == 0.0):
                row.append(None)
            else:
                row.append(float(e) if e.ndim == 0 else np.ascontiguousarray(e))
        out.append(row)
    return out


@dataclass(frozen=True)
class PrincipalAxes:
    """Principal moments and the principal frame P of a rigid body.

    Attributes
    ----------
    moments : ndarray, shape (..., 3)
        Principal moments of inertia [kg m^2], sorted ascending
        (``I1 <= I2 <= I3``: axis 1 is the minor axis, axis 3 the major axis).
    q_PB : ndarray, shape (..., 4)
        Attitude of the principal frame P relative to the given body frame B:
        it rotates principal-frame vectors into body components,
        ``v_B = rotate(q_PB, v_P)``.
    C_PB : ndarray, shape (..., 3, 3)
        Direction cosine matrix mapping body components to principal
        components (``v_P = C_PB @ v_B``); its rows are the principal axes
        expressed in B, and ``C_PB @ I_B @ C_PB.T = diag(moments)``.
    """

    moments: NDArray[np.float64]
    q_PB: NDArray[np.float64]
    C_PB: NDArray[np.float64]

    @property
    def axes_B(self) -> NDArray[np.float64]:
        """Principal axes as the columns of a matrix in body components, shape ``(..., 3, 3)``."""
        return np.swapaxes(self.C_PB, -1, -2)


class _EulerEquations:
    """The one definition of Euler's equations on components (numpy or casadi).

    Subclasses hold the inertia and its inverse as nested 3x3 lists of
    entries in ``_I`` and ``_I_inv`` (``None`` for an entry that is zero).
    """

    _I: list[list[Any]]
    _I_inv: list[list[Any]]

    def inertia_times_components(self, v: Components) -> Components:
        """The product ``I v`` on components (numpy or casadi).

        Parameters
        ----------
        v : list of 3 numpy arrays or casadi scalars
            A vector in body components (e.g. a body rate [rad/s] or a position [m]).

        Returns
        -------
        list of 3
            ``I v`` in body components, same backend as ``v``.
        """
        return _matvec(self._I, v)

    def omega_dot_components(
        self, omega: Components, torque: Components | None, h: Components | None = None
    ) -> Components:
        """Euler's equations on components: ``I^-1 (tau - omega x (I omega + h))``.

        Parameters
        ----------
        omega, torque, h : list of 3 numpy arrays or casadi scalars
            Body rate [rad/s], torque [N m] and internal momentum [N m s], all
            in body components. ``torque`` None means torque-free and ``h``
            None means no internal momentum (both skip the arithmetic).

        Returns
        -------
        list of 3
            Body angular acceleration ``omega_dot`` [rad/s^2], same backend as
            ``omega``.
        """
        h_total = _matvec(self._I, omega)
        if h is not None:
            h_total = [a + b for a, b in zip(h_total, h)]
        if torque is None:
            # -omega x H written as H x omega: no separate negation.
            return _matvec(self._I_inv, cross(h_total, omega))
        gyro = cross(omega, h_total)
        return _matvec(self._I_inv, [t - g for t, g in zip(torque, gyro)])

    def state_derivative_components(
        self, x: Components, torque: Components | None, h: Components | None = None
    ) -> Components:
        """Time derivative of the state components ``[q (4), omega (3)]``.

        Parameters
        ----------
        x : list of 7 numpy arrays or casadi scalars
            Attitude ``q_BN`` (scalar first) and body rate ``omega_BN_B`` [rad/s].
        torque : list of 3 or None
            Torque in body components [N m]; None for torque-free motion.
        h : list of 3, optional
            Internal (wheel) angular momentum in body components [N m s].

        Returns
        -------
        list of 7
            ``[q_dot (4) [1/s], omega_dot (3) [rad/s^2]]``, same backend as ``x``.
        """
        q, w = x[:4], x[4:7]
        return quaternion_rate(q, w) + self.omega_dot_components(w, torque, h)


#: Range of the largest inertia entry accepted [kg m^2]. The kinetic energy I w^2 and the gyroscopic term
#: w x (I w) square the entries' scale; beyond 1e100 they overflow (a 1e300 inertia gave inf energy and NaN
#: accelerations), below 1e-100 they underflow. Real bodies lie between 1e-12 (a chip) and 1e10 (a station).
INERTIA_MAX_KG_M2 = 1e100
INERTIA_MIN_KG_M2 = 1e-100


class RigidBody(_EulerEquations):
    """A rigid spacecraft: inertia tensor, checks, and Euler's equations.

    Parameters
    ----------
    inertia : array_like, shape (..., 3) or (..., 3, 3)
        Principal moments (a diagonal tensor) or the full inertia tensor about
        the centre of mass, in body components [kg m^2]. Leading dimensions
        make a batch of bodies (for example a Monte Carlo set of dispersed
        inertias) that all methods evaluate at once.

    Raises
    ------
    ValueError
        If the inertia is not finite, not symmetric (to
        :data:`SYMMETRY_TOLERANCE`), not positive definite, or not physically
        realisable (a principal moment larger than the sum of the other two,
        beyond :data:`REALISABILITY_TOLERANCE`).

    Examples
    --------
    >>> body = RigidBody([10.0, 12.0, 8.0])
    >>> body.principal_axes().moments
    array([ 8., 10., 12.])
    """

    def __init__(self, inertia: ArrayLike) -> None:
        arr = as_float_array(inertia, "inertia")
        if arr.ndim >= 1 and arr.shape[-1] == 3 and (arr.ndim == 1 or arr.shape[-2:] != (3, 3)):
            tensor = np.zeros((*arr.shape[:-1], 3, 3))
            idx = np.arange(3)
            tensor[..., idx, idx] = arr
        elif arr.ndim >= 2 and arr.shape[-2:] == (3, 3):
            tensor = arr.copy()
        else:
            raise ValueError(
                f"inertia must be 3 principal moments (..., 3) or a tensor (..., 3, 3) in kg m^2, got shape {arr.shape}"
            )
        scale = np.max(np.abs(tensor), axis=(-1, -2))
        if np.any(scale > INERTIA_MAX_KG_M2) or np.any(scale < INERTIA_MIN_KG_M2):
            raise ValueError(
                f"inertia must lie within [{INERTIA_MIN_KG_M2:g}, {INERTIA_MAX_KG_M2:g}] kg m^2 (beyond it the "
                "energy and the gyroscopic terms overflow or underflow in floating point; use other units), "
                f"got entries up to {float(np.max(scale)):.6g} and down to {float(np.min(scale)):.6g} kg m^2"
            )
        asym = np.max(np.abs(tensor - np.swapaxes(tensor, -1, -2)), axis=(-1, -2))
        if np.any(asym > SYMMETRY_TOLERANCE * scale):
            raise ValueError(
                f"inertia must be symmetric (max|I - I^T| <= {SYMMETRY_TOLERANCE:g} max|I|); "
                f"found an asymmetry of {np.max(asym):.6g} kg m^2 in {describe(tensor)}"
            )
        tensor = 0.5 * tensor + 0.5 * np.swapaxes(tensor, -1, -2)
        moments, axes = np.linalg.eigh(tensor)
        if not np.all(np.isfinite(moments)):
            raise ValueError(
                f"inertia must have finite principal moments; got {describe(moments)} kg m^2 "
                f"(entries of magnitude {np.max(scale):.3g} overflow)"
            )
        if np.any(moments <= 0):
            raise ValueError(f"inertia must be positive definite; principal moments are {describe(moments)} kg m^2")
        # Triangle inequality: I3 <= I1 + I2 with I1 <= I2 <= I3 (sorted by eigh).
        excess = moments[..., 2] - moments[..., 0] - moments[..., 1]
        if np.any(excess > REALISABILITY_TOLERANCE * moments[..., 2]):
            raise ValueError(
                "inertia must be physically realisable (each principal moment at most the sum of the other two); "
                f"principal moments {describe(moments)} kg m^2 break I3 <= I1 + I2"
            )
        # Make the eigenvector frame right-handed.
        left_handed = np.linalg.det(axes) < 0
        axes[..., :, 2] = np.where(left_handed[..., None], -axes[..., :, 2], axes[..., :, 2])
        inverse = np.linalg.inv(tensor)
        if not np.all(np.isfinite(inverse)):
            raise ValueError(
                f"inertia must have a finite inverse; principal moments {describe(moments)} kg m^2 are too small"
            )
        self._inertia = tensor
        self._inertia_inv = inverse
        self._moments = moments
        self._axes_B = axes
        self._I = _entries(tensor)
        self._I_inv = _entries(self._inertia_inv)

    # -- properties ---------------------------------------------------------

    @property
    def inertia(self) -> NDArray[np.float64]:
        """Inertia tensor in body components [kg m^2], shape ``batch_shape + (3, 3)``."""
        return self._inertia.copy()

    @property
    def inertia_inv(self) -> NDArray[np.float64]:
        """Inverse inertia tensor [1/(kg m^2)], shape ``batch_shape + (3, 3)``."""
        return self._inertia_inv.copy()

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading batch dimensions (``()`` for a single body)."""
        return self._inertia.shape[:-2]

    @property
    def is_diagonal(self) -> bool:
        """True when the body frame is a principal frame (products of inertia are zero)."""
        return all(self._I[i][j] is None for i in range(3) for j in range(3) if i != j)

    def __repr__(self) -> str:
        if self.batch_shape:
            return f"RigidBody(batch of {self.batch_shape} inertias)"
        return f"RigidBody(inertia={np.array2string(self._inertia, precision=6, separator=', ')})"

    def principal_axes(self) -> PrincipalAxes:
        """Sorted principal moments and the right-handed principal frame.

        Returns
        -------
        PrincipalAxes
            Moments ``I1 <= I2 <= I3`` [kg m^2] and the rotation from the
            principal frame P to the body frame B (``q_PB``, ``C_PB``).
        """
        c_pb = np.swapaxes(self._axes_B, -1, -2).copy()
        return PrincipalAxes(moments=self._moments.copy(), q_PB=quat.from_dcm(c_pb), C_PB=c_pb)

    # -- physics on numpy arrays --------------------------------------------

    def angular_momentum(self, omega: ArrayLike) -> NDArray[np.float64]:
        """Body angular momentum ``H_B = I omega`` [N m s] for body rates ``omega`` [rad/s].

        Parameters
        ----------
        omega : array_like, shape (..., 3)
            Body rate ``omega_BN_B`` [rad/s]; broadcast against ``batch_shape``.

        Returns
        -------
        ndarray, shape (..., 3)
            ``H_B`` in body components [N m s].

        Raises
        ------
        ValueError
            If ``omega`` is not of shape ``(..., 3)`` or holds NaN/inf.
        """
        omega = check_vector(omega, "omega", 3)
        return np.einsum("...ij,...j->...i", self._inertia, omega)

    def kinetic_energy(self, omega: ArrayLike) -> NDArray[np.float64]:
        """Rotational kinetic energy ``0.5 omega . I omega`` [J].

        Parameters
        ----------
        omega : array_like, shape (..., 3)
            Body rate ``omega_BN_B`` [rad/s]; broadcast against ``batch_shape``.

        Returns
        -------
        ndarray, shape (...)
            Kinetic energy [J].

        Raises
        ------
        ValueError
            If ``omega`` is not of shape ``(..., 3)`` or holds NaN/inf.
        """
        omega = check_vector(omega, "omega", 3)
        return 0.5 * np.sum(omega * self.angular_momentum(omega), axis=-1)

    def inertial_angular_momentum(self, q: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
        """Angular momentum in inertial components ``H_N = rotate(q_BN, I omega)`` [N m s].

        Parameters
        ----------
        q : array_like, shape (..., 4)
            Unit attitude quaternion ``q_BN`` (scalar first).
        omega : array_like, shape (..., 3)
            Body rate ``omega_BN_B`` [rad/s]; batch dimensions broadcast with
            ``q`` and ``batch_shape``.

        Returns
        -------
        ndarray, shape (..., 3)
            ``H_N`` in inertial components [N m s] (constant in torque-free motion).

        Raises
        ------
        ValueError
            If ``q`` is not a unit quaternion of shape ``(..., 4)``, ``omega`` is
            not of shape ``(..., 3)``, or either holds NaN/inf.
        """
        return quat.rotate(q, self.angular_momentum(omega))

    # -- numpy and casadi front ends of the one definition (_EulerEquations) ----

    def omega_dot(self, omega: Any, torque: Any = None, h: Any = None) -> Any:
        """Body angular acceleration [rad/s^2] from Euler's equations.

        Parameters
        ----------
        omega : array_like (..., 3) or casadi vector (3)
            Body rate ``omega_BN_B`` [rad/s].
        torque : array_like (..., 3) or casadi vector (3), optional
            Total torque about the centre of mass in body components [N m],
            including any wheel reaction ``-h_dot``. Zero if omitted.
        h : array_like (..., 3) or casadi vector (3), optional
            Internal (wheel) angular momentum in body components [N m s].

        Returns
        -------
        ndarray (..., 3) or casadi vector
            ``I^-1 (tau - omega x (I omega + h))``, same backend as ``omega``.

        Raises
        ------
        ValueError
            If a numpy input is not of shape ``(..., 3)`` or holds NaN/inf, a
            casadi input does not have 3 entries, or a batched body is
            evaluated on casadi symbols.
        """
        symbolic = isinstance(omega, (ca.SX, ca.MX, ca.DM))
        if symbolic and self.batch_shape:
            raise ValueError("casadi evaluation needs a single body, not a batch of inertias")
        if not symbolic:
            omega = check_vector(omega, "omega", 3)
        w = _split(omega, 3)
        tau = (
            [0.0 * w[0]] * 3 if torque is None else _split(torque if symbolic else check_vector(torque, "torque", 3), 3)
        )
        hh = None if h is None else _split(h if symbolic else check_vector(h, "h", 3), 3)
        return _join(self.omega_dot_components(w, tau, hh), omega)

    def state_derivative(self, x: Any, torque: Any = None, h: Any = None) -> Any:
        """Time derivative of the state ``x = [q_BN (4), omega_BN_B (3)]``.

        Works on numpy arrays ``(..., 7)`` (batched, broadcasting torque and
        ``h`` of shape ``(..., 3)``) and on casadi vectors of 7 entries.

        Parameters
        ----------
        x : array_like (..., 7) or casadi vector (7)
            Attitude quaternion (scalar first) and body rate [rad/s].
        torque : array_like (..., 3) or casadi vector (3), optional
            Torque in body components [N m]; zero if omitted.
        h : array_like (..., 3) or casadi vector (3), optional
            Internal angular momentum in body components [N m s].

        Returns
        -------
        ndarray (..., 7) or casadi vector (7)
            ``[q_dot (4) [1/s], omega_dot (3) [rad/s^2]]``, same backend as ``x``.

        Raises
        ------
        ValueError
            If a numpy input has the wrong last dimension or holds NaN/inf, a
            casadi input has the wrong number of entries, or a batched body is
            evaluated on casadi symbols.
        """
        symbolic = isinstance(x, (ca.SX, ca.MX, ca.DM))
        if symbolic and self.batch_shape:
            raise ValueError("casadi evaluation needs a single body, not a batch of inertias")
        if not symbolic:
            x = check_vector(x, "x", 7)
        xs = _split(x, 7)
        tau = (
            [0.0 * xs[0]] * 3
            if torque is None
            else _split(torque if symbolic else check_vector(torque, "torque", 3), 3)
        )
        hh = None if h is None else _split(h if symbolic else check_vector(h, "h", 3), 3)
        return _join(self.state_derivative_components(xs, tau, hh), x)

    def casadi_dynamics(self, symbol: type = ca.SX) -> ca.Function:
        """The equations of motion as a casadi Function ``f(x[7], tau[3]) -> x_dot[7]``.

        Parameters
        ----------
        symbol : casadi.SX or casadi.MX
            Symbol class used to build the expression graph.

        Returns
        -------
        casadi.Function
            ``f(x, tau) -> x_dot`` with ``x = [q_BN (4), omega_BN_B (3) [rad/s]]``,
            ``tau`` in body components [N m] and ``x_dot`` as in
            :meth:`state_derivative`.

        Raises
        ------
        ValueError
            If the body is a batch of inertias.
        """
        x = symbol.sym("x", 7)
        tau = symbol.sym("tau", 3)
        return ca.Function("rigid_body_dynamics", [x, tau], [self.state_derivative(x, tau)], ["x", "tau"], ["x_dot"])

    def casadi_jacobian(self) -> ca.Function:
        """Exact Jacobians ``(A, B) = (d x_dot/d x, d x_dot/d tau)`` as a casadi Function.

        Returns
        -------
        casadi.Function
            ``jac(x[7], tau[3]) -> (A[7x7], B[7x3])`` evaluated at the state
            ``x = [q_BN, omega_BN_B [rad/s]]`` and torque ``tau`` [N m], with
            ``x_dot`` as in :meth:`state_derivative`.

        Raises
        ------
        ValueError
            If the body is a batch of inertias.
        """
        x = ca.SX.sym("x", 7)
        tau = ca.SX.sym("tau", 3)
        f = self.state_derivative(x, tau)
        return ca.Function(
            "rigid_body_jacobian", [x, tau], [ca.jacobian(f, x), ca.jacobian(f, tau)], ["x", "tau"], ["A", "B"]
        )


class ParametricBody(_EulerEquations):
    """A body whose inertia entries are given directly, for generated code.

    The compiled Monte Carlo kernels (:mod:`attitude.simulation.kernel`)
    evaluate :meth:`omega_dot_components` with the inertia and its inverse
    as casadi symbols, so that one compiled function serves every dispersed
    inertia. Nothing is checked here: the numbers fed to those symbols come
    from validated :class:`RigidBody` objects.

    Parameters
    ----------
    inertia_entries, inverse_entries : sequence of 6
        ``[I_xx, I_yy, I_zz, I_xy, I_xz, I_yz]`` of the inertia [kg m^2] and
        of its inverse [1/(kg m^2)] (symmetric tensors), any backend.
    """

    def __init__(self, inertia_entries: Sequence[Any], inverse_entries: Sequence[Any]) -> None:
        self._I = symmetric_rows(inertia_entries)
        self._I_inv = symmetric_rows(inverse_entries)


def skew(v: ArrayLike) -> NDArray[np.float64]:
    """Cross-product matrix ``[v x]`` of vectors (..., 3) -> (..., 3, 3), so that ``skew(a) @ b = a x b``.

    Parameters
    ----------
    v : array_like (..., 3)
        Vectors (any units; leading batch dimensions broadcast through).

    Returns
    -------
    ndarray (..., 3, 3)
        ``[[0, -v3, v2], [v3, 0, -v1], [-v2, v1, 0]]`` per vector (no checks:
        a hot-path helper of the filters and sensor models).
    """
    v = np.asarray(v, dtype=np.float64)
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def symmetric_entries(matrix: ArrayLike) -> NDArray[np.float64]:
    """The six independent entries ``[xx, yy, zz, xy, xz, yz]`` of symmetric 3x3 matrices (..., 3, 3) -> (..., 6).

    Parameters
    ----------
    matrix : array_like
        Symmetric matrices of shape ``(..., 3, 3)``.
    """
    m = np.asarray(matrix, dtype=float)
    return np.stack([m[..., 0, 0], m[..., 1, 1], m[..., 2, 2], m[..., 0, 1], m[..., 0, 2], m[..., 1, 2]], axis=-1)


def symmetric_rows(six: Sequence[Any]) -> list[list[Any]]:
    """The rows of a symmetric 3x3 tensor from its six entries ``[xx, yy, zz, xy, xz, yz]``, any backend.

    The inverse of :func:`symmetric_entries` on components (numbers or casadi symbols).

    Parameters
    ----------
    six : sequence of 6
        The entries (e.g. of an inertia [kg m^2]).

    Returns
    -------
    list of 3 lists of 3
    """
    if len(six) != 6:
        raise ValueError(f"a symmetric tensor needs 6 entries [xx, yy, zz, xy, xz, yz], got {len(six)}")
    xx, yy, zz, xy, xz, yz = six
    return [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]


def split_components(x: Any, n: int) -> Components:
    """Public alias of the backend-neutral split used by the integrators.

    Parameters
    ----------
    x : ndarray (..., n) or casadi vector (n)
        State or vector to split.
    n : int
        Number of components.

    Returns
    -------
    list of n
        numpy: the slices ``x[..., i]`` (views); casadi: the entries ``x[i]``.

    Raises
    ------
    ValueError
        If a casadi ``x`` does not have ``n`` entries.
    """
    return _split(x, n)


def join_components(parts: Sequence[Any], like: Any) -> Any:
    """Public alias of the backend-neutral join used by the integrators.

    Parameters
    ----------
    parts : sequence of numpy arrays or casadi scalars
        Components to join.
    like : ndarray or casadi object
        Selects the backend of the result.

    Returns
    -------
    ndarray (..., n) or casadi vector (n)
        numpy: the broadcast components stacked on a new last axis; casadi:
        their ``vertcat``.
    """
    return _join(list(parts), like)

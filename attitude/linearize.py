"""Linear models of the rigid-body plant for controller design (python-control).

The plant is built as a python-control nonlinear system
(:func:`plant_nlsys`, a ``control.NonlinearIOSystem`` with named signals) and
linearised at an operating point (:func:`linearize`), either by
python-control's own finite differences or exactly, by casadi automatic
differentiation of the same equations. The six states are the vector part
of the error quaternion ``q_e = q_RN* ⊗ q_BN`` [-] and the body rate
``omega_BN_B`` [rad/s]; the inputs are the body torque [N m].

See docs/linearize.md for the derivation (states, operating points, why
six states and not seven, finite differences versus the exact Jacobian).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import backend as bk
from attitude.flexible import FlexibleBody, FlexibleModes
from attitude.quaternion import derivative_components, multiply_components
from attitude.rigid_body import Components, RigidBody
from attitude.validation import check_vector, describe

__all__ = [
    "INPUT_NAMES",
    "OUTPUT_NAMES",
    "SPIN_AXIS_TOLERANCE",
    "STATE_NAMES",
    "error_state_derivative_components",
    "flexible_plant",
    "linearize",
    "plant_nlsys",
    "principal_spin",
    "rate_block_eigenvalues",
]

#: State names: error-quaternion vector part [-] and body rate [rad/s].
STATE_NAMES = ("qe1", "qe2", "qe3", "w1", "w2", "w3")
#: Input names: body torque [N m].
INPUT_NAMES = ("tau1", "tau2", "tau3")
#: Output names: the states themselves (``C = I``).
OUTPUT_NAMES = STATE_NAMES

#: Largest accepted ``|omega x I omega| / (max|I| |omega|^2)`` for a steady
#: spin. A principal axis computed by ``numpy.linalg.eigh`` is accurate to
#: ~1e-15; 1e-9 accepts such axes (and typed-in ones with ~9 digits) while
#: rejecting a spin that is visibly off-axis, about which there is no
#: equilibrium to linearise.
SPIN_AXIS_TOLERANCE = 1e-9

_METHODS = ("exact", "finite-difference")
_SPIN_AXES = {"minor": 1, "intermediate": 2, "middle": 2, "major": 3}


def _single_body(body: Any) -> RigidBody:
    if not isinstance(body, RigidBody):
        raise ValueError(f"body must be a RigidBody, got {type(body).__name__}")
    if body.batch_shape:
        raise ValueError(f"body must be a single RigidBody, not a batch of shape {body.batch_shape}")
    return body


def _omega_ref(body: RigidBody, omega_ref: ArrayLike | None) -> NDArray[np.float64]:
    """Validate a steady-spin rate (body components) [rad/s]; None means rest."""
    if omega_ref is None:
        return np.zeros(3)
    w = check_vector(omega_ref, "omega_ref", 3)
    if w.shape != (3,):
        raise ValueError(f"omega_ref must have shape (3,) [rad/s], got shape {w.shape}")
    inertia = body.inertia
    gyro = -inertia @ body.omega_dot(w)  # omega x I omega, from the one definition of Euler's equations
    scale = np.max(np.abs(inertia)) * float(w @ w)
    if np.linalg.norm(gyro) > SPIN_AXIS_TOLERANCE * scale:
        raise ValueError(
            "omega_ref must lie along a principal axis of the body (a steady spin, omega x I omega = 0 to "
            f"{SPIN_AXIS_TOLERANCE:g} relative); omega_ref = {describe(w)} rad/s gives "
            f"|omega x I omega| = {np.linalg.norm(gyro):.3g} N m (relative {np.linalg.norm(gyro) / scale:.3g}); "
            "use principal_spin(body, axis, rate)"
        )
    return w


def principal_spin(body: RigidBody, axis: int | str, rate: float) -> NDArray[np.float64]:
    """Body rate of a steady spin about a principal axis.

    Parameters
    ----------
    body : RigidBody
        A single rigid body (diagonal or full inertia tensor) [kg m^2].
    axis : {1, 2, 3, "minor", "middle", "intermediate", "major"}
        Principal axis, numbered as :meth:`RigidBody.principal_axes` sorts the
        moments (``I1 <= I2 <= I3``: 1 minor, 2 middle, 3 major).
    rate : float
        Spin rate [rad/s] (its sign chooses the direction).

    Returns
    -------
    ndarray, shape (3,)
        ``omega_ref`` in body components [rad/s]: ``rate`` times the unit
        principal axis, signed so that its largest body component is positive.

    Raises
    ------
    ValueError
        If ``axis`` is not one of the names above or ``rate`` is not finite.
    """
    body = _single_body(body)
    key = axis.lower() if isinstance(axis, str) else axis
    index = _SPIN_AXES.get(key) if isinstance(key, str) else key
    if isinstance(index, bool) or index not in (1, 2, 3):
        raise ValueError(f"axis must be 1, 2, 3 or one of {sorted(_SPIN_AXES)}, got {axis!r}")
    rate_arr = check_vector(np.atleast_1d(rate), "rate", 1)
    if rate_arr.shape != (1,):
        raise ValueError(f"rate must be a scalar [rad/s], got shape {np.shape(rate)}")
    direction = body.principal_axes().axes_B[:, index - 1]
    direction = direction * np.sign(direction[np.argmax(np.abs(direction))])
    return float(rate_arr[0]) * direction


def error_state_derivative_components(
    body: RigidBody, x: Components, torque: Components, omega_ref: ArrayLike | None = None
) -> Components:
    """Time derivative of the 6-state error model on components (numpy or casadi).

    Parameters
    ----------
    body : RigidBody
        A single rigid body [kg m^2].
    x : list of 6 numpy arrays or casadi scalars
        ``[qe1, qe2, qe3, w1, w2, w3]``: error-quaternion vector part [-] and
        body rate ``omega_BN_B`` [rad/s].
    torque : list of 3
        Body torque [N m].
    omega_ref : array_like (3,), optional
        Constant rate of the reference frame in its own components [rad/s]
        (not checked here; zero when None).

    Returns
    -------
    list of 6
        ``[q_ev', omega']`` from the one definition (docs/linearize.md).
    """
    qv = list(x[:3])
    w = list(x[3:6])
    q0 = bk.sqrt(1.0 - (qv[0] * qv[0] + qv[1] * qv[1] + qv[2] * qv[2]))
    q_e = [q0, *qv]
    q_dot = derivative_components(q_e, w)
    if omega_ref is not None:
        w_r = [float(v) for v in np.asarray(omega_ref, dtype=float).reshape(3)]
        if any(v != 0.0 for v in w_r):
            left = multiply_components([0.0, *w_r], q_e)
            q_dot = [a - 0.5 * b for a, b in zip(q_dot, left)]
    return q_dot[1:] + body.omega_dot_components(w, torque)


def plant_nlsys(
    body: RigidBody, *, omega_ref: ArrayLike | None = None, name: str = "attitude_plant"
) -> control.NonlinearIOSystem:
    """The rigid-body plant as a python-control nonlinear system (6 states).

    Parameters
    ----------
    body : RigidBody
        A single rigid body [kg m^2].
    omega_ref : array_like (3,), optional
        Rate of the reference frame R [rad/s], along a principal axis of the
        body (a steady spin); None (default) for a reference at rest.
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        States :data:`STATE_NAMES` (``q_ev`` [-], ``omega_BN_B`` [rad/s]),
        inputs :data:`INPUT_NAMES` (body torque [N m]), outputs the states.
        The update function evaluates :func:`error_state_derivative_components`
        on numpy; it raises ``ValueError`` if ``|q_ev| > 1`` (outside the
        shortest-way chart). Operating point: ``x = [0, 0, 0, omega_ref]``,
        ``u = 0``.

    Raises
    ------
    ValueError
        If ``body`` is not a single RigidBody or ``omega_ref`` is not a
        steady spin about a principal axis.
    """
    body = _single_body(body)
    w_ref = _omega_ref(body, omega_ref)

    def update(t: float, x: NDArray[np.float64], u: NDArray[np.float64], params: Any) -> NDArray[np.float64]:
        x = np.asarray(x, dtype=float).reshape(6)
        u = np.asarray(u, dtype=float).reshape(3)
        norm2 = float(x[:3] @ x[:3])
        if norm2 > 1.0:
            raise ValueError(
                f"state qe must satisfy |q_ev| <= 1 (shortest-way chart q_e0 = sqrt(1 - |q_ev|^2)); "
                f"got |q_ev| = {np.sqrt(norm2):.6g} at t = {float(t):.6g} s"
            )
        return np.array(error_state_derivative_components(body, list(x), list(u), w_ref), dtype=float)

    return control.nlsys(
        update,
        None,
        states=list(STATE_NAMES),
        inputs=list(INPUT_NAMES),
        outputs=list(OUTPUT_NAMES),
        name=name,
    )


def _exact_jacobians(body: RigidBody, w_ref: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    x = ca.SX.sym("x", 6)
    u = ca.SX.sym("tau", 3)
    xc = [x[i] for i in range(6)]
    uc = [u[i] for i in range(3)]
    f = ca.vertcat(*error_state_derivative_components(body, xc, uc, w_ref))
    jac = ca.Function("error_model_jacobian", [x, u], [ca.jacobian(f, x), ca.jacobian(f, u)])
    a, b = jac(np.concatenate([np.zeros(3), w_ref]), np.zeros(3))
    # + 0.0 turns the -0.0 entries of structurally non-zero terms into 0.0 (cosmetic).
    return np.array(a.full()) + 0.0, np.array(b.full()) + 0.0


def linearize(
    body: RigidBody,
    *,
    omega_ref: ArrayLike | None = None,
    method: str = "exact",
    eps: float = 1e-6,
    name: str = "attitude_plant",
) -> control.StateSpace:
    """Linear model of the plant at rest or in steady spin about a principal axis.

    Parameters
    ----------
    body : RigidBody
        A single rigid body (diagonal or full inertia tensor) [kg m^2].
    omega_ref : array_like (3,), optional
        Steady spin rate in body components [rad/s], along a principal axis
        (see :func:`principal_spin`); None (default) linearises at rest, which
        is the same model for every reference attitude.
    method : {"exact", "finite-difference"}
        "exact": casadi Jacobian of the component equations (exact to
        rounding). "finite-difference": ``control.linearize`` of
        :func:`plant_nlsys` (one-sided differences, ~1e-7 relative error).
    eps : float
        Finite-difference step (only for "finite-difference") [-, rad/s].
    name : str
        Name of the nonlinear plant; the result is named ``name + "$linearized"``.

    Returns
    -------
    control.StateSpace
        Continuous-time model in the deviation ``[q_ev, omega - omega_ref]``
        from the operating point, states :data:`STATE_NAMES`, inputs
        :data:`INPUT_NAMES` [N m], outputs :data:`OUTPUT_NAMES` (``C = I``,
        ``D = 0``).

    Raises
    ------
    ValueError
        Bad ``body``, ``omega_ref`` off a principal axis, unknown ``method``
        or non-positive ``eps``.

    Examples
    --------
    >>> body = RigidBody([10.0, 12.0, 8.0])
    >>> sys = linearize(body)
    >>> sys.A[:3, 3:]
    array([[0.5, 0. , 0. ],
           [0. , 0.5, 0. ],
           [0. , 0. , 0.5]])
    """
    body = _single_body(body)
    if method not in _METHODS:
        raise ValueError(f"method must be one of {_METHODS}, got {method!r}")
    if not (np.isfinite(eps) and eps > 0):
        raise ValueError(f"eps must be a finite positive step, got {eps!r}")
    w_ref = _omega_ref(body, omega_ref)
    lin_name = f"{name}$linearized"
    if method == "finite-difference":
        plant = plant_nlsys(body, omega_ref=w_ref, name=name)
        # copy_names=True: python-control's default (False) drops every signal name.
        return control.linearize(
            plant, np.concatenate([np.zeros(3), w_ref]), np.zeros(3), eps=eps, copy_names=True, name=lin_name
        )
    a, b = _exact_jacobians(body, w_ref)
    return control.ss(
        a,
        b,
        np.eye(6),
        np.zeros((6, 3)),
        states=list(STATE_NAMES),
        inputs=list(INPUT_NAMES),
        outputs=list(OUTPUT_NAMES),
        name=lin_name,
    )


def rate_block_eigenvalues(sys: control.StateSpace) -> NDArray[np.complex128]:
    """Eigenvalues of the rate block ``A[3:, 3:]`` (Euler's equations) [1/s].

    For a model from :func:`linearize` the matrix is block upper-triangular,
    so these are exactly the eigenvalues of ``A`` that belong to the body
    rates (nutation, middle-axis growth, and 0 along the spin axis), sorted by
    imaginary then real part; the remaining three (``0, +-i |omega_ref|``) are
    those of the attitude block ``A[:3, :3]``.

    Parameters
    ----------
    sys : control.StateSpace
        A 6-state model from :func:`linearize`.

    Raises
    ------
    ValueError
        If ``sys`` does not have the 6 states of :func:`linearize`.
    """
    if not isinstance(sys, control.StateSpace) or sys.nstates != 6:
        raise ValueError(f"sys must be a 6-state StateSpace from linearize(), got {sys!r}")
    eig = np.linalg.eigvals(np.asarray(sys.A)[3:, 3:])
    return eig[np.lexsort((eig.real, eig.imag))]


def flexible_plant(body: RigidBody, modes: FlexibleModes, *, name: str = "flexible_plant") -> control.StateSpace:
    """Linear model at rest of a spacecraft with flexible appendages, as the quaternion feedback sees it.

    The exact casadi Jacobian (:meth:`attitude.flexible.FlexibleBody.jacobians_at_rest`)
    of the hybrid-coordinate equations the nonlinear simulation integrates
    (:mod:`attitude.flexible`, docs/flexible_modes.md), in the coordinates of
    :func:`controllers.analysis.rigid_body_at_rest` so that ``loop_gain``,
    ``input_loop`` and the margins take it in place of the rigid body: states
    ``[theta (3), omega (3), eta (n), eta_dot (n)]`` (small rotation vector
    ``theta = 2 q_ev`` [rad], body rate [rad/s], modal coordinates
    [sqrt(kg) m] and their rates), inputs the body torque [N m], outputs
    ``[q_v (3), omega (3)]`` (``q_v = theta / 2``: the error quaternion's
    vector part, half the angle; then the body rate). Gyroscopic terms vanish
    at rest.

    Parameters
    ----------
    body : RigidBody
        The whole spacecraft, appendages included and undeformed [kg m^2].
    modes : FlexibleModes
        The constrained (cantilevered) modes of the appendages.
    name : str
        System name.

    Returns
    -------
    control.StateSpace
        Continuous-time model, ``6 + 2n`` states, 3 inputs, 6 outputs, ``D = 0``.
        With ``L = 0`` its rigid part is that of ``rigid_body_at_rest``.

    Raises
    ------
    ValueError
        As :class:`attitude.flexible.FlexibleBody` (a batch of bodies, or
        ``I - L^T L`` not positive definite).

    Examples
    --------
    >>> from attitude.flexible import FlexibleModes
    >>> body = RigidBody([100.0, 120.0, 80.0])
    >>> modes = FlexibleModes(frequency=[6.0], damping=0.0, participation=[[6.0, 0.0, 0.0]])
    >>> flexible_plant(body, modes).nstates
    8
    """
    flexible = FlexibleBody(_single_body(body), modes)
    a, b = flexible.jacobians_at_rest()
    n = flexible.n_modes
    # theta = 2 q_ev: the similarity T = diag(2 I, I, I, I) of rigid_body_at_rest (exact: powers of two).
    t = np.diag(np.r_[2.0 * np.ones(3), np.ones(3 + 2 * n)])
    t_inv = np.diag(np.r_[0.5 * np.ones(3), np.ones(3 + 2 * n)])
    axes = "xyz"
    return control.ss(
        t @ a @ t_inv,
        t @ b,
        t_inv[:6],
        np.zeros((6, 3)),
        inputs=[f"tau_{a}" for a in axes],
        outputs=[f"qv_{a}" for a in axes] + [f"omega_{a}" for a in axes],
        states=[f"theta_{a}" for a in axes]
        + [f"omega_{a}" for a in axes]
        + [f"eta_{k + 1}" for k in range(n)]
        + [f"eta_dot_{k + 1}" for k in range(n)],
        name=name,
    )

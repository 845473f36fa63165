"""Reaction wheels (geometry, torque allocation, saturation, wheel dynamics) and magnetorquers.

Model (Schaub and Junkins, *Analytical Mechanics of Space Systems*, ch. 4;
Wie, *Space Vehicle Dynamics and Control*, ch. 7). Wheel ``i`` spins about
the body-fixed unit axis ``a_i`` with spin inertia ``J_i``. Its spin-axis
angular momentum (absolute, i.e. including the body rate) is the state
``h_i = J_i (Omega_i + a_i . omega)`` with ``Omega_i`` the wheel speed relative
to the body. With ``A = [a_1 ... a_n]`` (3 x n) and motor torques ``u``:

.. math::

    \\dot h_i = u_i - f_i(\\Omega_i), \\qquad
    I_s \\dot\\omega = \\tau_{ext} - A \\dot h - \\omega \\times (I_s \\omega + A h)

``I_s`` is the spacecraft inertia *without* the wheels' spin-axis inertia
(``I_s = I_total - sum J_i a_i a_i^T``), because that part is carried by
``h``. Friction ``f`` (viscous and Coulomb) is internal: it slows the wheel
and pushes the body, leaving the total angular momentum
``H_N = C_NB (I_s omega + A h)`` unchanged. The body equation is the one
definition in :class:`attitude.rigid_body.RigidBody` with torque
``tau_ext - A h_dot`` and internal momentum ``A h``.

Everything here is written on component lists with the neutral functions of
:mod:`attitude.backend`, so it evaluates on numpy arrays and casadi symbols.
"""

from __future__ import annotations

from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import backend as bk
from attitude.rigid_body import Components, RigidBody
from attitude.validation import as_float_array, check_positive, check_vector, describe

__all__ = ["RANK_TOLERANCE", "SATURATION_MODES", "Magnetorquers", "ReactionWheels"]

#: Smallest accepted singular value of the wheel axis matrix (relative to the
#: largest): below it the wheels cannot produce torque about some axis.
RANK_TOLERANCE = 1e-6

#: How an actuator set keeps its commands within the per-actuator limits
#: (:class:`ReactionWheels` ``torque_saturation``, :class:`Magnetorquers`
#: ``saturation``): ``"scale"``, one common factor for all of them, so the
#: body torque or dipole keeps its direction; ``"clip"``, each actuator at its
#: own limit alone, so the direction may change.
SATURATION_MODES = ("scale", "clip")


def _per_wheel(
    value: ArrayLike, n: int, name: str, *, allow_zero: bool = False, item: str = "wheel"
) -> NDArray[np.float64]:
    """Check a scalar or per-``item`` (wheel, rod) parameter and broadcast it to shape ``(n,)``."""
    arr = check_positive(value, name, allow_zero=allow_zero)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size not in (1, n)):
        raise ValueError(f"{name} must be a scalar or one value per {item} ({n}), got shape {arr.shape}")
    return np.broadcast_to(arr, (n,)).astype(np.float64)


class ReactionWheels:
    """A set of reaction wheels on arbitrary body axes.

    Parameters
    ----------
    axes_B : array_like, shape (n, 3)
        Spin axes in body components (normalised here). They must span 3-D
        space (rank 3), otherwise some torque direction is uncontrollable.
    spin_inertia : float or array_like (n,)
        Wheel spin-axis inertia ``J`` [kg m^2].
    torque_max : float or array_like (n,)
        Largest motor torque magnitude [N m].
    momentum_max : float or array_like (n,)
        Largest wheel momentum relative to the body, ``J |Omega|`` [N m s]
        (the speed limit ``Omega_max = momentum_max / J``). At the limit the
        motor torque that would spin the wheel faster is cut, as a motor
        driver does at its back-EMF limit.
    viscous_friction : float or array_like (n,)
        Viscous friction coefficient [N m s/rad] (torque ``c Omega``).
    coulomb_friction : float or array_like (n,)
        Coulomb friction torque magnitude [N m].
    coulomb_smoothing_speed : float
        Speed [rad/s] over which the Coulomb torque is smoothed as
        ``f_c tanh(Omega / speed)``; a hard sign function would make the
        right-hand side discontinuous at zero speed and stall fixed-step
        integrators.
    null_space_gain : float
        Gain [1/s] of null-space momentum management (wheels beyond three):
        the allocation adds ``-k N (h_rel - h_bias)`` with ``N`` the null-space
        projector, which drives the wheel momenta toward ``h_bias`` without
        any body torque. Zero disables it.
    bias_momentum : float or array_like (n,)
        Target wheel momenta [N m s] for the null-space management (only its
        null-space component matters).
    torque_saturation : {"scale", "clip"}
        How a command beyond a motor's ``torque_max`` is limited
        (:meth:`allocate_components`). ``"scale"`` (the default): one common
        factor brings every motor within its limit, so the body torque keeps
        the commanded direction and loses only magnitude. ``"clip"``: each
        motor torque is clipped at its own limit, as a wheel's drive
        electronics do (and Basilisk's ``reactionWheelStateEffector``): the
        motors within their limits keep their torque, so the body torque
        turns away from the command. Either way a wheel at its speed limit
        refuses torque that would spin it faster.

    Raises
    ------
    ValueError
        Negative or non-finite limits or friction, axes of rank below 3,
        zero-length axes, mismatched per-wheel lengths, or a
        ``torque_saturation`` not in :data:`SATURATION_MODES`.
    """

    def __init__(
        self,
        axes_B: ArrayLike,
        *,
        spin_inertia: ArrayLike,
        torque_max: ArrayLike,
        momentum_max: ArrayLike,
        viscous_friction: ArrayLike = 0.0,
        coulomb_friction: ArrayLike = 0.0,
        coulomb_smoothing_speed: float = 1.0,
        null_space_gain: float = 0.0,
        bias_momentum: ArrayLike = 0.0,
        torque_saturation: str = "scale",
    ) -> None:
        if torque_saturation not in SATURATION_MODES:
            raise ValueError(f"torque_saturation must be one of {SATURATION_MODES}, got {torque_saturation!r}")
        axes = as_float_array(axes_B, "axes_B")
        if axes.ndim != 2 or axes.shape[1] != 3 or axes.shape[0] < 1:
            raise ValueError(f"axes_B must have shape (n_wheels, 3), got shape {axes.shape}")
        lengths = np.linalg.norm(axes, axis=1)
        if np.any(lengths == 0):
            raise ValueError(f"axes_B must hold non-zero axes; wheel {int(np.argmin(lengths))} has a zero axis")
        axes = axes / lengths[:, None]
        n = axes.shape[0]
        singular = np.linalg.svd(axes.T, compute_uv=False)
        if n < 3 or singular[-1] < RANK_TOLERANCE * singular[0]:
            raise ValueError(
                "axes_B must span three dimensions (rank 3) so that every torque direction is reachable; "
                f"got {n} axes with singular values {describe(singular)}"
            )
        self.axes_B = axes
        self.n_wheels = n
        self.spin_inertia = _per_wheel(spin_inertia, n, "spin_inertia")
        self.torque_max = _per_wheel(torque_max, n, "torque_max")
        self.momentum_max = _per_wheel(momentum_max, n, "momentum_max")
        self.viscous_friction = _per_wheel(viscous_friction, n, "viscous_friction", allow_zero=True)
        self.coulomb_friction = _per_wheel(coulomb_friction, n, "coulomb_friction", allow_zero=True)
        self.coulomb_smoothing_speed = float(check_positive(coulomb_smoothing_speed, "coulomb_smoothing_speed"))
        self.null_space_gain = float(check_positive(null_space_gain, "null_space_gain", allow_zero=True))
        bias = as_float_array(bias_momentum, "bias_momentum")
        if bias.shape not in ((), (1,), (n,)):
            raise ValueError(f"bias_momentum must be a scalar or one value per wheel ({n}), got shape {bias.shape}")
        self.bias_momentum = np.broadcast_to(bias, (n,)).astype(float)
        self.torque_saturation = torque_saturation
        self.distribution = axes.T.copy()  # A, 3 x n: body torque = -A u
        self.allocation = np.linalg.pinv(self.distribution)  # A^+, n x 3, minimum-norm
        self.null_projector = np.eye(n) - self.allocation @ self.distribution
        # Minimum-norm allocation with wheel i idle (None when the others lose rank 3).
        self._allocation_without: list[NDArray[np.float64] | None] = []
        for i in range(n):
            others = np.delete(axes, i, axis=0)
            sv = np.linalg.svd(others.T, compute_uv=False) if n > 3 else np.zeros(1)
            if n > 3 and sv[-1] >= RANK_TOLERANCE * sv[0]:
                self._allocation_without.append(np.insert(np.linalg.pinv(others.T), i, 0.0, axis=0))
            else:
                self._allocation_without.append(None)

    # -- construction helpers -------------------------------------------------

    @classmethod
    def orthogonal(cls, *, spin_inertia: ArrayLike, torque_max: ArrayLike, momentum_max: ArrayLike, **kw: Any) -> Self:
        """Three wheels on the body x, y and z axes.

        Parameters
        ----------
        spin_inertia : float or array_like (3,)
            Wheel spin-axis inertia ``J`` [kg m^2].
        torque_max : float or array_like (3,)
            Largest motor torque magnitude [N m].
        momentum_max : float or array_like (3,)
            Largest wheel momentum relative to the body [N m s].
        **kw
            Further keyword arguments of :class:`ReactionWheels`
            (friction, null-space management, torque saturation).

        Returns
        -------
        ReactionWheels
            Wheels with ``axes_B = eye(3)`` (wheel ``i`` on body axis ``i``).

        Raises
        ------
        ValueError
            As :class:`ReactionWheels` for invalid parameters.
        """
        return cls(np.eye(3), spin_inertia=spin_inertia, torque_max=torque_max, momentum_max=momentum_max, **kw)

    @classmethod
    def pyramid(
        cls,
        *,
        spin_inertia: ArrayLike,
        torque_max: ArrayLike,
        momentum_max: ArrayLike,
        elevation_deg: float = 35.26438968275466,
        **kw: Any,
    ) -> Self:
        """Four wheels in a pyramid about the body z axis.

        Wheel ``i`` has axis ``[cos(b) cos(az_i), cos(b) sin(az_i), sin(b)]``
        with azimuths 45, 135, 225, 315 deg and elevation ``b``; the default
        ``b = atan(1/sqrt(2))`` = 35.26 deg gives the same torque capacity
        about all three body axes.

        Parameters
        ----------
        spin_inertia : float or array_like (4,)
            Wheel spin-axis inertia ``J`` [kg m^2].
        torque_max : float or array_like (4,)
            Largest motor torque magnitude [N m].
        momentum_max : float or array_like (4,)
            Largest wheel momentum relative to the body [N m s].
        elevation_deg : float
            Elevation ``b`` of each axis above the body x-y plane [deg],
            strictly between 0 and 90.
        **kw
            Further keyword arguments of :class:`ReactionWheels`
            (friction, null-space management, torque saturation).

        Returns
        -------
        ReactionWheels
            Four wheels with the pyramid axes.

        Raises
        ------
        ValueError
            If ``elevation_deg`` is not strictly between 0 and 90 degrees, or
            as :class:`ReactionWheels` for invalid parameters.
        """
        b = np.radians(float(as_float_array(elevation_deg, "elevation_deg")))
        if not 0.0 < b < np.pi / 2:
            raise ValueError(f"elevation_deg must lie strictly between 0 and 90 degrees, got {elevation_deg}")
        az = np.radians([45.0, 135.0, 225.0, 315.0])
        axes = np.column_stack([np.cos(b) * np.cos(az), np.cos(b) * np.sin(az), np.full(4, np.sin(b))])
        return cls(axes, spin_inertia=spin_inertia, torque_max=torque_max, momentum_max=momentum_max, **kw)

    def __repr__(self) -> str:
        # Every parameter, floats exact (lists, not numpy's 8-digit print): a scenario's fingerprint
        # names its wheels with this repr, so two wheel sets that fly differently must not share it.
        return (
            f"ReactionWheels({self.axes_B.tolist()}, spin_inertia={self.spin_inertia.tolist()}, "
            f"torque_max={self.torque_max.tolist()}, momentum_max={self.momentum_max.tolist()}, "
            f"viscous_friction={self.viscous_friction.tolist()}, coulomb_friction={self.coulomb_friction.tolist()}, "
            f"coulomb_smoothing_speed={self.coulomb_smoothing_speed!r}, null_space_gain={self.null_space_gain!r}, "
            f"bias_momentum={self.bias_momentum.tolist()}, torque_saturation={self.torque_saturation!r})"
        )

    # -- plant coupling ---------------------------------------------------------

    def hub_body(self, body: RigidBody) -> RigidBody:
        """The body without the wheels' spin-axis inertia: ``I_s = I - sum J a a^T``.

        ``body`` is the whole spacecraft (wheels included) as a user measures
        or computes it.

        Parameters
        ----------
        body : RigidBody
            Whole-spacecraft inertia in body components [kg m^2].

        Returns
        -------
        RigidBody
            The hub body ``I_s`` [kg m^2] used in the equations of motion.

        Raises
        ------
        ValueError
            If ``I_s`` is not a valid inertia (e.g. the wheels' spin inertia
            exceeds the body's).
        """
        return RigidBody(body.inertia - self.spin_inertia_tensor())

    def spin_inertia_tensor(self) -> NDArray[np.float64]:
        """The wheels' spin-axis inertia in body axes, ``sum J_i a_i a_i^T`` [kg m^2] (3, 3).

        The hub body lacks it (:meth:`hub_body`); the gravity gradient acts on
        the whole spacecraft, wheels included, so the environment adds it back.
        """
        return np.einsum("i,ij,ik->jk", self.spin_inertia, self.axes_B, self.axes_B)

    def wheel_speed(self, h: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
        """Wheel speeds relative to the body ``Omega = h/J - a . omega`` [rad/s] (numpy).

        Parameters
        ----------
        h : array_like, shape (..., n)
            Absolute wheel spin-axis momenta [N m s].
        omega : array_like, shape (..., 3)
            Body rate ``omega_BN_B`` [rad/s].

        Returns
        -------
        ndarray, shape (..., n)
            Wheel speeds ``Omega`` relative to the body [rad/s].
        """
        h = np.asarray(h, dtype=float)
        omega = np.asarray(omega, dtype=float)
        return h / self.spin_inertia - omega @ self.axes_B.T

    def wheel_speed_components(self, h: Components, omega: Components) -> Components:
        """Wheel speeds ``Omega_i = h_i/J_i - a_i . omega`` on component lists (any backend).

        Parameters
        ----------
        h : list of n
            Absolute wheel spin-axis momenta [N m s].
        omega : list of 3
            Body rate ``omega_BN_B`` components [rad/s].

        Returns
        -------
        list of n
            Wheel speeds relative to the body [rad/s].
        """
        return [
            h[i] / self.spin_inertia[i] - (a[0] * omega[0] + a[1] * omega[1] + a[2] * omega[2])
            for i, a in enumerate(self.axes_B)
        ]

    def friction_components(self, speed: Components) -> Components:
        """Friction torque on each wheel [N m] (opposes its speed).

        ``f_i = c_i Omega_i + f_c,i tanh(Omega_i / coulomb_smoothing_speed)``.

        Parameters
        ----------
        speed : list of n
            Wheel speeds relative to the body [rad/s] (any backend).

        Returns
        -------
        list of n
            Friction torques [N m], positive along the wheel speed.
        """
        out = []
        for i, s in enumerate(speed):
            f = self.viscous_friction[i] * s
            if self.coulomb_friction[i] > 0:
                f = f + self.coulomb_friction[i] * bk.tanh(s / self.coulomb_smoothing_speed)
            out.append(f)
        return out

    def state_derivative_components(
        self, body: RigidBody, x: Components, motor_torque: Components, external_torque: Components | None = None
    ) -> Components:
        """Derivative of ``x = [q (4), omega (3), h (n)]`` with motor torques held.

        Parameters
        ----------
        body : RigidBody
            The hub body (see :meth:`hub_body`).
        x : list
            State components: quaternion, body rate [rad/s], wheel momenta [N m s].
        motor_torque : list of n
            Motor torques on the wheels [N m] (already limited).
        external_torque : list of 3, optional
            External torque on the spacecraft in body components [N m].

        Returns
        -------
        list of 7 + n
            ``[q_dot (4) [1/s], omega_dot (3) [rad/s^2], h_dot (n) [N m]]``,
            same backend as ``x``.
        """
        from attitude.quaternion import derivative_components

        q, omega, h = x[:4], x[4:7], x[7:]
        speed = self.wheel_speed_components(h, omega)
        friction = self.friction_components(speed)
        h_dot = [u - f for u, f in zip(motor_torque, friction)]
        reaction = self.body_components(h_dot, scale=-1.0)
        tau = reaction if external_torque is None else [e + r for e, r in zip(external_torque, reaction)]
        internal = self.body_components(h, scale=1.0)
        return derivative_components(q, omega) + body.omega_dot_components(omega, tau, internal) + h_dot

    def body_components(self, per_wheel: Components, scale: float) -> Components:
        """Map per-wheel quantities to body components: ``scale * A @ per_wheel``.

        Parameters
        ----------
        per_wheel : list of n
            One quantity per wheel (momenta [N m s] or torques [N m]), any backend.
        scale : float
            Factor applied to the sum (``-1`` for the reaction torque on the body).

        Returns
        -------
        list of 3
            Body components, same backend as ``per_wheel``; exact zeros of the
            distribution matrix are skipped so symbolic graphs stay small.
        """
        out = []
        for k in range(3):
            acc = None
            for i in range(self.n_wheels):
                c = scale * self.distribution[k, i]
                if c == 0.0:
                    continue
                term = c * per_wheel[i]
                acc = term if acc is None else acc + term
            out.append(acc if acc is not None else 0.0 * per_wheel[0])
        return out

    # -- allocation ---------------------------------------------------------------

    def _minimum_norm(self, matrix: NDArray[np.float64], torque_command: Components) -> Components:
        """``u = -M tau_c`` on components for an (n x 3) allocation matrix ``M``."""
        out = []
        for row in matrix:
            acc = 0.0 * torque_command[0]
            for k in range(3):
                if row[k] != 0.0:
                    acc = acc - row[k] * torque_command[k]
            out.append(acc)
        return out

    def allocate_components(self, torque_command: Components, h: Components, omega: Components) -> Components:
        """Motor torques for a commanded body torque, with saturation.

        1. The minimum-norm solution ``u = -A^+ tau_c`` (plus null-space
           momentum management).
        2. If a wheel sits at its speed limit and ``u`` would spin it faster,
           the command is re-allocated to the other wheels (minimum norm with
           that wheel's torque zero) when they still span three dimensions,
           as in a four-wheel pyramid: the body torque keeps its direction.
        3. The torque limits, by :attr:`torque_saturation`: ``"scale"``, one
           common factor ``1 / max(1, max_i |u_i| / u_max,i)`` keeps every
           wheel within its limit, so the body torque keeps its direction and
           loses only magnitude; ``"clip"``, each ``u_i`` clipped to
           ``[-u_max,i, u_max,i]`` alone, so the wheels within their limits
           keep their torque and the body torque may turn.
        4. Any wheel still at its speed limit refuses torque that would spin
           it faster (a motor driver at its back-EMF limit; this last cut can
           change the torque direction when no re-allocation was possible).

        The speed limit is checked when the command is computed (at the
        controller sample) and held until the next one.

        Parameters
        ----------
        torque_command : list of 3
            Commanded body torque in body components [N m] (any backend).
        h : list of n
            Absolute wheel spin-axis momenta [N m s].
        omega : list of 3
            Body rate ``omega_BN_B`` [rad/s].

        Returns
        -------
        list of n
            Motor torques on the wheels [N m], within ``torque_max``.
        """
        n = self.n_wheels
        u = self._minimum_norm(self.allocation, torque_command)
        speed = self.wheel_speed_components(h, omega)
        if self.null_space_gain > 0 and n > 3:
            rel = [self.spin_inertia[i] * speed[i] - self.bias_momentum[i] for i in range(n)]
            for i in range(n):
                corr = 0.0 * rel[0]
                for j in range(n):
                    corr = corr + self.null_projector[i, j] * rel[j]
                u[i] = u[i] - self.null_space_gain * corr
        limits = self.momentum_max / self.spin_inertia
        # Re-allocate around the first blocked wheel (selection by 0/1 weights
        # keeps the arithmetic backend-neutral).
        for i in reversed(range(n)):
            if self._allocation_without[i] is None:
                continue
            blocked = bk.if_else(speed[i] >= limits[i], bk.if_else(u[i] > 0, 1.0, 0.0), 0.0) + bk.if_else(
                speed[i] <= -limits[i], bk.if_else(u[i] < 0, 1.0, 0.0), 0.0
            )
            alternative = self._minimum_norm(self._allocation_without[i], torque_command)
            u = [blocked * a + (1.0 - blocked) * b for a, b in zip(alternative, u)]
        if self.torque_saturation == "scale":
            # Common scale so that max_i |u_i| / u_max_i <= 1 (direction preserved).
            ratio = None
            for i in range(n):
                r = bk.fabs(u[i]) / self.torque_max[i]
                ratio = r if ratio is None else bk.fmax(ratio, r)
            scale = 1.0 / bk.fmax(ratio, 1.0)
            u = [ui * scale for ui in u]
        else:
            u = [bk.clip(ui, -self.torque_max[i], self.torque_max[i]) for i, ui in enumerate(u)]
        out = []
        for i in range(n):
            over = bk.if_else(speed[i] >= limits[i], bk.fmin(u[i], 0.0), u[i])
            out.append(bk.if_else(speed[i] <= -limits[i], bk.fmax(over, 0.0), over))
        return out

    def allocate(self, torque_command: ArrayLike, h: ArrayLike, omega: ArrayLike) -> NDArray[np.float64]:
        """Numpy front end of :meth:`allocate_components`: motor torques (..., n) [N m].

        Parameters
        ----------
        torque_command : array_like, shape (..., 3)
            Commanded body torque in body components [N m].
        h : array_like, shape (..., n)
            Absolute wheel spin-axis momenta [N m s].
        omega : array_like, shape (..., 3)
            Body rate ``omega_BN_B`` [rad/s].

        Returns
        -------
        ndarray, shape (..., n)
            Motor torques [N m]; batch dimensions of the inputs broadcast.

        Raises
        ------
        ValueError
            If an input holds NaN/inf or has the wrong last dimension.
        """
        tau = as_float_array(torque_command, "torque_command")
        h = as_float_array(h, "h")
        omega = as_float_array(omega, "omega")
        if tau.shape[-1:] != (3,) or h.shape[-1:] != (self.n_wheels,) or omega.shape[-1:] != (3,):
            raise ValueError(
                f"torque_command (..., 3), h (..., {self.n_wheels}) and omega (..., 3) expected; "
                f"got {tau.shape}, {h.shape}, {omega.shape}"
            )
        u = self.allocate_components(
            [tau[..., k] for k in range(3)],
            [h[..., i] for i in range(self.n_wheels)],
            [omega[..., k] for k in range(3)],
        )
        return np.stack(np.broadcast_arrays(*u), axis=-1)

    def body_torque(self, motor_torque: ArrayLike) -> NDArray[np.float64]:
        """Reaction torque on the body ``-A u`` [N m] for motor torques (..., n).

        Parameters
        ----------
        motor_torque : array_like, shape (..., n)
            Motor torques ``u`` on the wheels [N m].

        Returns
        -------
        ndarray, shape (..., 3)
            Reaction torque on the body in body components [N m] (friction
            not included).

        Raises
        ------
        ValueError
            If ``motor_torque`` holds NaN/inf or its last axis is not ``n``.
        """
        u = as_float_array(motor_torque, "motor_torque")
        return -u @ self.distribution.T

    def torque_envelope(self) -> NDArray[np.float64]:
        """Largest body torque per body axis [N m] reachable within the wheel torque limits.

        For axis ``e_k`` this is ``1 / max_i |(A^+ e_k)_i| / u_max_i``: up to
        there the allocation delivers the command unchanged (either
        :attr:`torque_saturation`); beyond it ``"scale"`` holds the direction
        at this magnitude and ``"clip"`` lets the direction turn.

        Returns
        -------
        ndarray, shape (3,)
            Largest torque magnitude about body x, y and z [N m].
        """
        ratios = np.abs(self.allocation) / self.torque_max[:, None]
        return 1.0 / ratios.max(axis=0)

    def momentum_envelope(self) -> NDArray[np.float64]:
        """Largest body momentum per body axis [N m s] stored within the wheel momentum limits.

        The rule of :meth:`torque_envelope` with ``momentum_max`` for ``torque_max``: for axis ``e_k``,
        ``1 / max_i |(A^+ e_k)_i| / h_max_i`` (the minimum-norm distribution of the momentum).

        Returns
        -------
        ndarray, shape (3,)
            Largest momentum magnitude about body x, y and z [N m s].
        """
        ratios = np.abs(self.allocation) / self.momentum_max[:, None]
        return 1.0 / ratios.max(axis=0)


# ---------------------------------------------------------------------------
# Magnetorquers


class Magnetorquers:
    """Magnetic torque rods on body axes: dipole limits, quantisation and the torque ``m x B``.

    Rod ``i`` produces the dipole ``m_i a_i`` along its unit axis ``a_i``
    with ``|m_i| <= dipole_max_Am2[i]``; the body dipole is
    ``m = sum_i m_i a_i`` and the torque on the spacecraft in the field ``B``
    (body axes) is ``tau = m x B`` (Wertz, *Spacecraft Attitude Determination
    and Control*, 1978, sec. 17.2; Markley and Crassidis, *Fundamentals of
    Spacecraft Attitude Determination and Control*, 2014, sec. 3.3.5 and 7.5).
    A commanded body dipole is mapped to the rods by the minimum-norm
    pseudo-inverse of ``A = [a_1 ... a_n]`` (the identity for three
    orthogonal rods), then saturated and quantised.

    The command and torque are written on component lists with
    :mod:`attitude.backend` operations, so they evaluate on numpy arrays of
    any batch shape and on casadi symbols (the engine's compiled loop).

    Parameters
    ----------
    axes_B : array_like (n, 3), optional
        Rod axes in body components (normalised here; non-zero). Default:
        the three body axes.
    dipole_max_Am2 : float or array_like (n,)
        Largest dipole magnitude of each rod [A m^2] (> 0).
    quantum_Am2 : float or array_like (n,), optional
        Quantisation step of each rod [A m^2] (> 0; e.g. the dipole of one
        PWM count); None: no quantisation.
    saturation : {"scale", "clip"}
        ``"scale"``: one common factor brings every rod within its limit,
        so the body dipole keeps its direction; ``"clip"``: each rod
        saturates alone (the direction may change).

    Raises
    ------
    ValueError
        Axes of the wrong shape or zero length, a dipole limit or quantum
        that is not strictly positive and finite, per-rod values of the
        wrong length, or an unknown ``saturation``.
    """

    def __init__(
        self,
        axes_B: ArrayLike | None = None,
        *,
        dipole_max_Am2: ArrayLike,
        quantum_Am2: ArrayLike | None = None,
        saturation: str = "scale",
    ) -> None:
        axes = np.eye(3) if axes_B is None else as_float_array(axes_B, "axes_B")
        if axes.ndim != 2 or axes.shape[1] != 3 or axes.shape[0] < 1:
            raise ValueError(f"axes_B must have shape (n_rods, 3), got shape {axes.shape}")
        lengths = np.linalg.norm(axes, axis=1)
        if np.any(lengths == 0):
            raise ValueError(f"axes_B must hold non-zero axes; rod {int(np.argmin(lengths))} has a zero axis")
        if saturation not in SATURATION_MODES:
            raise ValueError(f"saturation must be one of {SATURATION_MODES}, got {saturation!r}")
        self.axes_B = axes / lengths[:, None]
        self.n_rods = self.axes_B.shape[0]
        self.dipole_max_Am2 = _per_wheel(dipole_max_Am2, self.n_rods, "dipole_max_Am2", item="rod")
        self.quantum_Am2 = (
            None if quantum_Am2 is None else _per_wheel(quantum_Am2, self.n_rods, "quantum_Am2", item="rod")
        )
        self.saturation = saturation
        #: ``A^+`` (n x 3): minimum-norm rod dipoles for a body dipole.
        self.allocation = np.linalg.pinv(self.axes_B.T)

    @classmethod
    def orthogonal(
        cls, *, dipole_max_Am2: ArrayLike, quantum_Am2: ArrayLike | None = None, saturation: str = "scale"
    ) -> Self:
        """Three rods on the body x, y and z axes.

        Parameters
        ----------
        dipole_max_Am2 : float or array_like (3,)
            Largest dipole magnitude of each rod [A m^2].
        quantum_Am2 : float or array_like (3,), optional
            Quantisation step [A m^2]; None: none.
        saturation : {"scale", "clip"}
            See :class:`Magnetorquers`.

        Returns
        -------
        Magnetorquers
            Rods with ``axes_B = eye(3)``.
        """
        return cls(np.eye(3), dipole_max_Am2=dipole_max_Am2, quantum_Am2=quantum_Am2, saturation=saturation)

    def __repr__(self) -> str:
        return (
            f"Magnetorquers(n_rods={self.n_rods}, dipole_max_Am2={self.dipole_max_Am2}, "
            f"quantum_Am2={self.quantum_Am2}, saturation={self.saturation!r})"
        )

    # -- components (any backend) ---------------------------------------------

    def command_components(self, dipole_command_B: Components) -> Components:
        """Rod dipoles [A m^2] for a commanded body dipole: allocate, saturate, quantise.

        1. ``m_rod = A^+ m_c`` (minimum norm).
        2. ``"scale"``: ``m_rod / max(1, max_i |m_i| / m_max,i)``;
           ``"clip"``: each ``m_i`` clipped to ``[-m_max,i, m_max,i]``.
        3. With ``quantum_Am2``: ``q_i floor(m_i / q_i + 1/2)`` (nearest
           level, halves rounded up), clipped again to the limit in case the
           nearest level lies beyond it.

        Parameters
        ----------
        dipole_command_B : list of 3
            Commanded body dipole [A m^2] (numpy arrays or casadi scalars).

        Returns
        -------
        list of n
            Rod dipoles [A m^2], same backend as the command.
        """
        u = []
        for row in self.allocation:
            acc = 0.0 * dipole_command_B[0]
            for k in range(3):
                if row[k] != 0.0:
                    acc = acc + row[k] * dipole_command_B[k]
            u.append(acc)
        limits = self.dipole_max_Am2
        if self.saturation == "scale":
            ratio = None
            for i in range(self.n_rods):
                r = bk.fabs(u[i]) / limits[i]
                ratio = r if ratio is None else bk.fmax(ratio, r)
            scale = 1.0 / bk.fmax(ratio, 1.0)
            u = [ui * scale for ui in u]
        else:
            u = [bk.clip(ui, -limits[i], limits[i]) for i, ui in enumerate(u)]
        if self.quantum_Am2 is not None:
            steps = self.quantum_Am2
            u = [bk.clip(steps[i] * bk.floor(ui / steps[i] + 0.5), -limits[i], limits[i]) for i, ui in enumerate(u)]
        return u

    def dipole_components(self, per_rod: Components) -> Components:
        """Body dipole ``m = sum_i m_i a_i`` [A m^2] on components (any backend).

        Parameters
        ----------
        per_rod : list of n
            Rod dipoles [A m^2].

        Returns
        -------
        list of 3
            Body dipole components [A m^2]; exact zeros of the axes are skipped.
        """
        out = []
        for k in range(3):
            acc = 0.0 * per_rod[0]
            for i in range(self.n_rods):
                if self.axes_B[i, k] != 0.0:
                    acc = acc + self.axes_B[i, k] * per_rod[i]
            out.append(acc)
        return out

    def torque_components(self, per_rod: Components, field_B: Components) -> Components:
        """Magnetic torque ``(sum_i m_i a_i) x B`` [N m] on components (any backend).

        Parameters
        ----------
        per_rod : list of n
            Rod dipoles [A m^2].
        field_B : list of 3
            Magnetic field at the spacecraft in body axes [T].

        Returns
        -------
        list of 3
            Torque on the spacecraft in body axes [N m].
        """
        return bk.cross(self.dipole_components(per_rod), field_B)

    # -- numpy front ends -------------------------------------------------------

    def command(self, dipole_command_B: ArrayLike) -> NDArray[np.float64]:
        """Numpy front end of :meth:`command_components`: rod dipoles (..., n) [A m^2].

        Parameters
        ----------
        dipole_command_B : array_like (..., 3)
            Commanded body dipole [A m^2].

        Returns
        -------
        ndarray (..., n)
            Rod dipoles after saturation and quantisation [A m^2].

        Raises
        ------
        ValueError
            If the command holds NaN/inf or its last axis is not 3.
        """
        m = check_vector(dipole_command_B, "dipole_command_B", 3)
        u = self.command_components([m[..., k] for k in range(3)])
        return np.stack(np.broadcast_arrays(*u), axis=-1)

    def dipole_B(self, per_rod: ArrayLike) -> NDArray[np.float64]:
        """Body dipole ``m = sum_i m_i a_i`` (..., 3) [A m^2] for rod dipoles (..., n).

        Parameters
        ----------
        per_rod : array_like (..., n)
            Rod dipoles [A m^2].

        Returns
        -------
        ndarray (..., 3)
            Body dipole [A m^2].

        Raises
        ------
        ValueError
            If ``per_rod`` holds NaN/inf or its last axis is not ``n``.
        """
        u = check_vector(per_rod, "per_rod", self.n_rods)
        out = self.dipole_components([u[..., i] for i in range(self.n_rods)])
        return np.stack(np.broadcast_arrays(*out), axis=-1)

    def torque(self, per_rod: ArrayLike, field_B: ArrayLike) -> NDArray[np.float64]:
        """Magnetic torque ``m x B`` (..., 3) [N m] for rod dipoles (..., n) in the field ``B`` (..., 3).

        Parameters
        ----------
        per_rod : array_like (..., n)
            Rod dipoles [A m^2].
        field_B : array_like (..., 3)
            Magnetic field in body axes [T].

        Returns
        -------
        ndarray (..., 3)
            Torque on the spacecraft in body axes [N m]; batch dimensions broadcast.

        Raises
        ------
        ValueError
            If an input holds NaN/inf or has the wrong last dimension.
        """
        u = check_vector(per_rod, "per_rod", self.n_rods)
        b = check_vector(field_B, "field_B", 3)
        out = self.torque_components([u[..., i] for i in range(self.n_rods)], [b[..., k] for k in range(3)])
        return np.stack(np.broadcast_arrays(*out), axis=-1)

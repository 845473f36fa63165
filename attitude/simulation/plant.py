"""The plant the closed loop flies: the hub body and its wheels, derivative and hold step."""

from __future__ import annotations

import pickle
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.integrators import normalize_quaternion_components, rk4_step
from attitude.rigid_body import ParametricBody, RigidBody, split_components, symmetric_entries
from attitude.simulation.build_cache import BuildCache

__all__ = ["PlantModel"]

#: Hold steps and command allocations with the hub inertia as an input, per wheel set and step count: built once
#: per process (building one costs milliseconds, a good part of a compiled run), whatever the body.
_PARAMETRIC = BuildCache(32)


class PlantModel:
    """The plant of the closed loop: hub body + wheels, its derivative and its zero-order-hold step.

    The engine (:func:`attitude.simulation.simulate`), the batch paths and the
    compiled kernels all step this one definition, so a run is the same
    arithmetic whichever path flies it.

    Parameters
    ----------
    body : RigidBody
        The hub body (wheels' spin inertia removed, :meth:`ReactionWheels.hub_body`)
        [kg m^2], or the whole body without wheels.
    wheels : ReactionWheels or None
        The wheel array; None: the command acts on the body directly.
    """

    def __init__(self, body: RigidBody, wheels: ReactionWheels | None) -> None:
        self.body = body
        self.wheels = wheels
        self.n_w = 0 if wheels is None else wheels.n_wheels
        self.n_x = 7 + self.n_w
        self.n_u = self.n_w if wheels is not None else 3
        self._steps: dict[int, ca.Function] = {}
        self._wheels_key: bytes | None = None

    def derivative(self, x: list, u: list, tau_ext: list | None) -> list:
        """State derivative of the plant under held inputs.

        Parameters
        ----------
        x : list of 7 + n
            State ``[q (4), omega (3) [rad/s], h (n) [N m s]]`` on components, any backend.
        u : list
            Motor torques per wheel [N m] with wheels, else the body torque (3) [N m].
        tau_ext : list of 3 or None
            External (disturbance) body torque [N m], or None.

        Returns
        -------
        list of 7 + n
            ``[q_dot, omega_dot [rad/s^2], h_dot [N m]]``, same backend as ``x``.
        """
        if self.wheels is None:
            tau = u if tau_ext is None else [a + b for a, b in zip(u, tau_ext)]
            return self.body.state_derivative_components(x, tau)
        return self.wheels.state_derivative_components(self.body, x, u, tau_ext)

    def hold_step(self, x: list, u: list, tau_ext: list | None, dt: Any, substeps: int) -> list:
        """The state one tick later: RK4 over ``dt`` in ``substeps`` steps, inputs held, quaternion renormalised.

        Parameters
        ----------
        x : list of 7 + n
            State ``[q (4), omega (3) [rad/s], h (n) [N m s]]`` on components, any backend.
        u : list
            Motor torques per wheel [N m] with wheels, else the body torque (3) [N m].
        tau_ext : list of 3 or None
            External (disturbance) body torque [N m], or None.
        dt : float or symbolic
            Tick length [s].
        substeps : int
            RK4 steps per tick.

        Returns
        -------
        list of 7 + n
            The state at the end of the tick, same backend as ``x``.
        """
        h = dt / substeps
        for _ in range(substeps):
            x = normalize_quaternion_components(rk4_step(lambda _t, xc: self.derivative(xc, u, tau_ext), 0.0, x, h))
        return x

    def compiled_step(self, substeps: int) -> ca.Function:
        """The hold step as a casadi Function ``(x, u, tau_ext, dt) -> x_next``, built once and cached.

        Parameters
        ----------
        substeps : int
            RK4 steps per tick.

        Returns
        -------
        casadi.Function
            :meth:`hold_step` on symbols, for the compiled engine paths.
        """
        if substeps not in self._steps:
            x = ca.SX.sym("x", self.n_x)
            u = ca.SX.sym("u", self.n_u)
            tau = ca.SX.sym("tau_ext", 3)
            dt = ca.SX.sym("dt")
            xn = self.step_expression(x, u, tau, dt, substeps)
            self._steps[substeps] = ca.Function("hold_step", [x, u, tau, dt], [xn])
        return self._steps[substeps]

    def step_expression(self, x: Any, u: Any, tau_ext: Any, dt: Any, substeps: int) -> Any:
        """:meth:`hold_step` on casadi vectors, as one column: for a :class:`RigidBody`, the step built once per
        wheel set and step count with the inertia as an input, called on this body's numbers (no Python graph
        building per plant).

        Parameters
        ----------
        x : casadi SX (n_x,)
            State.
        u : casadi SX (n_u,)
            Motor torques per wheel [N m] (the body torque without wheels).
        tau_ext : casadi SX (3,)
            External body torque [N m].
        dt : casadi SX or float
            Tick [s].
        substeps : int
            RK4 steps per tick.

        Returns
        -------
        casadi SX (n_x,)
            The state at the end of the tick.
        """
        if isinstance(self.body, RigidBody):
            step = _PARAMETRIC.get(("step", self.wheels_key(), substeps), lambda: self._parametric_step(substeps))
            return step(x, u, tau_ext, dt, self.inertia_entries())
        xn = self.hold_step(
            split_components(x, self.n_x), split_components(u, self.n_u), split_components(tau_ext, 3), dt, substeps
        )
        return ca.vertcat(*xn)

    def compiled_command(self) -> ca.Function:
        """:meth:`command` as a casadi Function ``(tau_cmd, x) -> (u, tau_applied)``, built once per wheel set.

        Returns
        -------
        casadi.Function
            The allocation on symbols (it depends on the wheels only), for the compiled engine path.
        """
        return _PARAMETRIC.get(("command", self.wheels_key()), self._command_function)

    def _command_function(self) -> ca.Function:
        tau = ca.SX.sym("tau_cmd", 3)
        x = ca.SX.sym("x", self.n_x)
        u, tau_applied = self.command(split_components(tau, 3), split_components(x, self.n_x))
        return ca.Function("command", [tau, x], [ca.vertcat(*u), ca.vertcat(*tau_applied)])

    def _parametric_step(self, substeps: int) -> ca.Function:
        """The hold step with the hub inertia and its inverse as a 12-entry input (:meth:`inertia_entries`)."""
        x = ca.SX.sym("x", self.n_x)
        u = ca.SX.sym("u", self.n_u)
        tau = ca.SX.sym("tau_ext", 3)
        dt = ca.SX.sym("dt")
        entries = ca.SX.sym("inertia", 12)
        ec = split_components(entries, 12)
        plant = PlantModel(ParametricBody(ec[:6], ec[6:]), self.wheels)
        xn = plant.hold_step(
            split_components(x, self.n_x), split_components(u, self.n_u), split_components(tau, 3), dt, substeps
        )
        return ca.Function("parametric_hold_step", [x, u, tau, dt, entries], [ca.vertcat(*xn)])

    def inertia_entries(self) -> NDArray[np.float64]:
        """The hub inertia's six entries and its inverse's (:func:`attitude.rigid_body.symmetric_entries`), (12,).

        Returns
        -------
        ndarray (12,)
            [kg m^2] then [1/(kg m^2)].
        """
        return np.concatenate([symmetric_entries(self.body.inertia), symmetric_entries(self.body.inertia_inv)])

    def wheels_key(self) -> bytes | None:
        """What of the plant is built into its compiled functions besides the inertia: the wheels (pickled).

        Returns
        -------
        bytes or None
            None without wheels.
        """
        if self.wheels is None:
            return None
        if self._wheels_key is None:
            self._wheels_key = pickle.dumps(self.wheels)
        return self._wheels_key

    def identity(self, substeps: int) -> tuple | None:
        """What a hold step of this plant is built from: a key for caches of compiled functions.

        Parameters
        ----------
        substeps : int
            RK4 steps per hold step.

        Returns
        -------
        tuple or None
            ``(substeps, inertia bytes, pickled wheels)``; None for a symbolic
            body (:class:`attitude.rigid_body.ParametricBody`), which is not shared.
        """
        if not isinstance(self.body, RigidBody):
            return None
        return (substeps, self.body.inertia.tobytes(), self.wheels_key())

    def command(self, tau_cmd: list, x: list) -> tuple[list, list]:
        """Motor (or body) torque and the applied body torque for a command.

        Parameters
        ----------
        tau_cmd : list of 3
            Commanded body torque [N m], any backend.
        x : list of 7 + n
            State ``[q, omega, h]`` (the wheel allocation needs the momenta and rate).

        Returns
        -------
        tuple of list
            ``(u, tau_applied)``: motor torques per wheel [N m] (the command itself
            without wheels) and the body torque the plant receives [N m].
        """
        if self.wheels is None:
            return tau_cmd, tau_cmd
        u = self.wheels.allocate_components(tau_cmd, x[7:], x[4:7])
        return u, self.wheels.body_components(u, scale=-1.0)

    def momentum_N(self, q: NDArray, omega: NDArray, h: NDArray) -> NDArray:
        """Total angular momentum in inertial components [N m s] along a history.

        Parameters
        ----------
        q : ndarray (..., 4)
            Attitude ``q_BN``.
        omega : ndarray (..., 3)
            Body rate [rad/s].
        h : ndarray (..., n)
            Wheel spin-axis momenta [N m s] (ignored without wheels).

        Returns
        -------
        ndarray (..., 3)
            ``q (I omega + A h) q*`` [N m s]: constant without external torque.
        """
        h_b = omega @ self.body.inertia.T
        if self.wheels is not None:
            h_b = h_b + h @ self.wheels.distribution.T
        return quat.rotate(quat.normalize(q), h_b)

    def body_momentum(self, xc: list) -> list:
        """Wheel momentum relative to the body, ``A (J Omega)``, in body components (zeros without wheels).

        Parameters
        ----------
        xc : list of 7 + n
            The state ``[q, omega, h]`` on components, any backend.

        Returns
        -------
        list of 3
            ``sum_i J_i Omega_i a_i`` [N m s], same backend as ``xc``.
        """
        if self.wheels is None:
            return [0.0 * xc[4]] * 3
        wheels = self.wheels
        relative = [wheels.spin_inertia[i] * s for i, s in enumerate(wheels.wheel_speed_components(xc[7:], xc[4:7]))]
        return wheels.body_components(relative, scale=1.0)

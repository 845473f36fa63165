"""The plant the closed loop flies: the hub body and its wheels, derivative and hold step."""

from __future__ import annotations

from typing import Any

import casadi as ca
from numpy.typing import NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.integrators import normalize_quaternion_components, rk4_step
from attitude.rigid_body import RigidBody, split_components

__all__ = ["PlantModel"]


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
        self._step: ca.Function | None = None

    def derivative(self, x: list, u: list, tau_ext: list | None) -> list:
        """x = [q, omega, h]; u = motor torques (wheels) or body torque (no wheels)."""
        if self.wheels is None:
            tau = u if tau_ext is None else [a + b for a, b in zip(u, tau_ext)]
            return self.body.state_derivative_components(x, tau)
        return self.wheels.state_derivative_components(self.body, x, u, tau_ext)

    def hold_step(self, x: list, u: list, tau_ext: list | None, dt: Any, substeps: int) -> list:
        h = dt / substeps
        for _ in range(substeps):
            x = normalize_quaternion_components(rk4_step(lambda _t, xc: self.derivative(xc, u, tau_ext), 0.0, x, h))
        return x

    def compiled_step(self, substeps: int) -> ca.Function:
        if self._step is None:
            n_u = self.n_w if self.wheels is not None else 3
            x = ca.SX.sym("x", self.n_x)
            u = ca.SX.sym("u", n_u)
            tau = ca.SX.sym("tau_ext", 3)
            dt = ca.SX.sym("dt")
            xn = self.hold_step(
                split_components(x, self.n_x), split_components(u, n_u), split_components(tau, 3), dt, substeps
            )
            self._step = ca.Function("hold_step", [x, u, tau, dt], [ca.vertcat(*xn)])
        return self._step

    def command(self, tau_cmd: list, x: list) -> tuple[list, list]:
        """Motor (or body) torque and the applied body torque for a command."""
        if self.wheels is None:
            return tau_cmd, tau_cmd
        u = self.wheels.allocate_components(tau_cmd, x[7:], x[4:7])
        return u, self.wheels.body_components(u, scale=-1.0)

    def momentum_N(self, q: NDArray, omega: NDArray, h: NDArray) -> NDArray:
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

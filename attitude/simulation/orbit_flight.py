"""What the engine adds to a tick when the spacecraft flies in its orbit: environment torques and magnetorquers.

:class:`OrbitFlight` gathers, for one run, the environment track on the
engine's ticks (:class:`attitude.environment.OrbitEnvironment`), the per-run
surface parameters, the magnetorquers and the magnetic law
(:class:`attitude.simulation.protocols.DipoleController`). The engine asks it
at each tick for the disturbance torques per source, the field and the Sun in
body axes (handed to the sensors through :class:`Truth`) and the
magnetorquers' torque. All of these are evaluated at the tick and held over
it, as the wheel commands are (zero-order hold): at a 0.1 s tick a body
turning at 1 deg/s moves 0.1 deg, which changes the torques by 0.2 % of
their size.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.actuators import Magnetorquers
from attitude.environment.orbit_environment import SURFACE_PARAMETERS, OrbitEnvironment
from attitude.environment.torques import magnetic_torque_components
from attitude.rigid_body import RigidBody, symmetric_entries
from attitude.simulation.build_cache import BuildCache
from attitude.simulation.codegen import BufferedFunction
from attitude.simulation.kernel import environment_key
from attitude.validation import as_float_array, check_vector

__all__ = ["OrbitFlight"]


class OrbitFlight:
    """The orbit environment and the magnetorquers of one run, on the engine's ticks.

    Parameters
    ----------
    environment : OrbitEnvironment or None
        The orbit and its models; None: no environment (magnetorquers then
        have no field to push against and are refused).
    body : RigidBody
        The whole spacecraft, wheels included (the gravity gradient acts on the
        wheels' spin inertia as well as on the hub).
    t : ndarray (n,)
        The engine's tick times [s] since the orbit's epoch.
    surface_parameters : array_like (7,), optional
        Per-run surface parameters (:meth:`OrbitEnvironment.surface_parameters`).
    magnetorquers : Magnetorquers, optional
        The torque rods.
    dipole_controller : object, optional
        The magnetic law (:class:`attitude.simulation.protocols.DipoleController`).

    Raises
    ------
    ValueError
        For magnetorquers or a magnetic law without an environment with a
        field, or a magnetic law without magnetorquers.
    """

    def __init__(
        self,
        environment: OrbitEnvironment | None,
        body: RigidBody,
        t: NDArray[np.float64],
        *,
        surface_parameters: ArrayLike | None = None,
        magnetorquers: Magnetorquers | None = None,
        dipole_controller: Any = None,
    ) -> None:
        if environment is not None and not isinstance(environment, OrbitEnvironment):
            raise ValueError(f"environment must be an OrbitEnvironment or None, got {type(environment).__name__}")
        if magnetorquers is not None and not isinstance(magnetorquers, Magnetorquers):
            raise ValueError(f"magnetorquers must be a Magnetorquers or None, got {type(magnetorquers).__name__}")
        if (magnetorquers is not None or dipole_controller is not None) and (
            environment is None or environment.magnetic_field is None
        ):
            raise ValueError(
                "magnetorquers and a dipole_controller need a geomagnetic field: fly them with an "
                "environment=OrbitEnvironment(...) whose magnetic_field is not None"
            )
        if dipole_controller is not None:
            if magnetorquers is None:
                raise ValueError("dipole_controller needs magnetorquers= (the rods that deliver its dipole)")
            if not hasattr(dipole_controller, "dipole"):
                raise ValueError("dipole_controller must have a 'dipole(t, measurements)' method")
        self.environment = environment
        self.body = body
        self.magnetorquers = magnetorquers
        self.dipole_controller = dipole_controller
        self.active = environment is not None
        if not self.active:
            return
        self.track = environment.track(t)
        self.rows = np.ascontiguousarray(self.track.columns().T)
        if surface_parameters is None:
            self.parameters = environment.surface_parameters()
        else:
            self.parameters = as_float_array(surface_parameters, "surface_parameters").reshape(-1)
            if self.parameters.size != len(SURFACE_PARAMETERS):
                raise ValueError(
                    f"surface_parameters must hold {len(SURFACE_PARAMETERS)} numbers {SURFACE_PARAMETERS}, "
                    f"got {self.parameters.size}"
                )
        self.sources = environment.sources
        self.n_sources = len(self.sources)
        self._tick = _environment_tick(environment)
        self._body_entries = np.concatenate([symmetric_entries(body.inertia), symmetric_entries(body.inertia_inv)])

    def at_tick(self, k: int, q: NDArray[np.float64]) -> tuple[NDArray, NDArray, NDArray]:
        """Disturbance torques (one row per source), field and Sun in body axes at tick ``k`` and attitude ``q``.

        Parameters
        ----------
        k : int
            Tick index.
        q : ndarray (4,)
            Attitude ``q_BN``.

        Returns
        -------
        tuple of ndarray
            ``(torques (n_sources, 3) [N m], field_B (3,) [T], sun_B (3,))``.
        """
        tick = self._tick
        tick.inputs[0][:] = q
        tick.inputs[1][:] = self.rows[k]
        tick.inputs[2][:] = self.parameters
        tick.inputs[3][:] = self._body_entries
        tick()
        torques, field_B, sun_B = tick.outputs
        return torques.reshape(self.n_sources, 3).copy(), field_B.copy(), sun_B.copy()

    def dipole_command(
        self, t: float, samples: Mapping[str, Any], h_body: NDArray[np.float64], field_B: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The magnetic law's dipole command [A m^2] from the newest sensor samples.

        Parameters
        ----------
        t : float
            Sample time [s].
        samples : mapping
            Newest sample per sensor name.
        h_body : ndarray (3,)
            Wheel momentum relative to the body in body axes [N m s].
        field_B : ndarray (3,)
            True field in body axes [T], handed over only to a law with
            ``use_truth_field = True``.

        Returns
        -------
        ndarray (3,)
        """
        measurements = dict(samples)
        measurements["wheel_momentum_B"] = h_body.copy()
        if getattr(self.dipole_controller, "use_truth_field", False):
            measurements["magnetic_field_B"] = field_B.copy()
        command = self.dipole_controller.dipole(t, measurements)
        return check_vector(command, "dipole_controller.dipole(t, measurements)", 3).reshape(3)

    def delivered_dipole(self, command_B: NDArray[np.float64]) -> NDArray[np.float64]:
        """The dipole the rods deliver for a command (saturation, quantisation) in body axes [A m^2].

        Parameters
        ----------
        command_B : ndarray (3,)
            Commanded dipole in body axes [A m^2].

        Returns
        -------
        ndarray (3,)
        """
        per_rod = self.magnetorquers.command_components([float(v) for v in command_B])
        return np.array([float(v) for v in self.magnetorquers.dipole_components(per_rod)])

    def magnetorquer_torque(self, dipole_B: NDArray[np.float64], field_B: NDArray[np.float64]) -> NDArray[np.float64]:
        """The rods' torque ``m x B`` [N m] (:func:`attitude.environment.magnetic_torque_components`).

        Parameters
        ----------
        dipole_B : ndarray (3,)
            Delivered dipole in body axes [A m^2].
        field_B : ndarray (3,)
            Field in body axes [T].

        Returns
        -------
        ndarray (3,)
        """
        return np.array([float(v) for v in magnetic_torque_components(list(dipole_B), list(field_B))])

    def compiled_pieces(self, q: list, row: list, dipole_B: list | None) -> tuple[list, list, list, list]:
        """The tick's torques on casadi symbols: per source, the field and Sun in body axes, the rods' torque.

        Parameters
        ----------
        q : list of 4
            Attitude symbols.
        row : list of 15
            Track row symbols.
        dipole_B : list of 3 or None
            Delivered dipole symbols (None: no magnetorquers).

        Returns
        -------
        tuple of list
            ``(torques per source (flat, 3 each), field_B (3), sun_B (3), magnetorquer torque (3))``.
        """
        params = [ca.DM(float(v)) for v in self.parameters]
        torques = self.environment.torque_components(self.body, q, row, params)
        field_B, sun_B = self.environment.body_vectors_components(q, row)
        mtq = [0.0 * field_B[0]] * 3 if dipole_B is None else magnetic_torque_components(dipole_B, field_B)
        return [c for s in self.sources for c in torques[s]], field_B, sun_B, mtq


#: The environment's per-tick function compiled, per environment structure (:func:`environment_key`) and thread
#: (its buffers), per process.
_TICKS: BuildCache[BufferedFunction] = BuildCache(16)


def _environment_tick(environment: OrbitEnvironment) -> BufferedFunction:
    """:meth:`OrbitEnvironment.tick_function` with the inertia as an input, compiled once per structure.

    Its buffers are this process's and thread's; :meth:`OrbitFlight.at_tick` writes every input at each call.
    """
    key = (environment_key(environment), threading.get_ident())
    return _TICKS.get(key, lambda: BufferedFunction(environment.tick_function(None)))

"""The orbit environment a closed loop flies: what the orbit brings at each instant, and the torques on the body.

Two parts with different costs:

* **The track** (:class:`EnvironmentTrack`): position and velocity, the
  velocity relative to the co-rotating atmosphere, the Sun direction, the
  illumination (eclipse), the solar radiation pressure, the geomagnetic field
  and the air density. None of them depends on the attitude, so a run computes
  them once, on a grid of ``sample_period`` seconds, and interpolates them
  linearly to its ticks. At the default 1 s on a low Earth orbit the
  interpolation error is below 1e-6 of each quantity (they turn at about twice
  the orbital rate, 2e-3 rad/s: the error of a chord over 1 s is
  ``(2e-3)^2 / 8``); a penumbra crossing (about 8 s in LEO) is resolved.
* **The torques** (:meth:`OrbitEnvironment.torque_components`): gravity
  gradient, aerodynamic, solar radiation pressure and the residual magnetic
  dipole, from one row of the track and the attitude. They are written on
  components (numpy arrays or casadi symbols), so the single-run engine, its
  compiled path and the vectorised Monte Carlo kernels evaluate the same
  definitions.

Per-run surface parameters (dispersed in Monte Carlo campaigns) are a vector
of :data:`SURFACE_PARAMETERS`: a scale on every plate's drag coefficient, the
residual dipole [A m^2] and an offset of every centre of pressure [m]. A
common offset ``d`` moves each torque by ``d x F`` (``F`` the total force),
so the dispersed torque is exact, not a linearisation.

Frames: N is the TEME frame of the orbit's epoch (:mod:`attitude.environment.epoch`);
body vectors come from ``q_BN`` (:func:`attitude.quaternion.rotate_inverse_components`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.backend import cross
from attitude.environment.atmosphere import ExponentialAtmosphere
from attitude.environment.gravity_gradient import gravity_gradient_torque_components
from attitude.environment.magnetic_field import IGRF
from attitude.environment.sun import AU_M, illumination_fraction, sun_position_N
from attitude.environment.surface import SurfaceModel
from attitude.environment.torques import (
    SOLAR_PRESSURE_1AU_PA,
    aerodynamic_force_components,
    aerodynamic_torque_components,
    magnetic_torque_components,
    solar_pressure_force_components,
    solar_pressure_torque_components,
)
from attitude.rigid_body import Components, ParametricBody, RigidBody
from attitude.validation import as_float_array, check_positive, check_vector

__all__ = [
    "DISTURBANCE_SOURCES",
    "EARTH_ROTATION_RATE",
    "SAMPLES_PER_ORBIT_MIN",
    "SURFACE_PARAMETERS",
    "TRACK_COLUMNS",
    "EnvironmentTrack",
    "OrbitEnvironment",
]

#: The disturbance torques an environment can fly, in the order they are logged.
DISTURBANCE_SOURCES = ("gravity_gradient", "aerodynamic", "solar_pressure", "magnetic")

#: Earth's rotation rate [rad/s], WGS-84 (NIMA TR8350.2, 3rd ed., Table 3.1): the atmosphere co-rotates with it.
EARTH_ROTATION_RATE = 7.292115e-5

#: Rows of :meth:`EnvironmentTrack.columns`, one number each.
TRACK_COLUMNS = (
    *(f"position_N[{i}]" for i in range(3)),
    *(f"velocity_relative_N[{i}]" for i in range(3)),
    *(f"sun_N[{i}]" for i in range(3)),
    "solar_pressure_Pa",
    "illumination",
    *(f"field_N[{i}]" for i in range(3)),
    "density_kg_m3",
)

#: Where each quantity sits in a track row (slices of :data:`TRACK_COLUMNS`).
_POSITION = slice(TRACK_COLUMNS.index("position_N[0]"), TRACK_COLUMNS.index("position_N[2]") + 1)
_VELOCITY = slice(TRACK_COLUMNS.index("velocity_relative_N[0]"), TRACK_COLUMNS.index("velocity_relative_N[2]") + 1)
_SUN = slice(TRACK_COLUMNS.index("sun_N[0]"), TRACK_COLUMNS.index("sun_N[2]") + 1)
_PRESSURE = TRACK_COLUMNS.index("solar_pressure_Pa")
_FIELD = slice(TRACK_COLUMNS.index("field_N[0]"), TRACK_COLUMNS.index("field_N[2]") + 1)
_DENSITY = TRACK_COLUMNS.index("density_kg_m3")

#: Entries of a per-run surface parameter vector (:meth:`OrbitEnvironment.surface_parameters`).
SURFACE_PARAMETERS = (
    "drag_scale",
    *(f"residual_dipole_Am2[{i}]" for i in range(3)),
    *(f"centre_of_pressure_offset_B_m[{i}]" for i in range(3)),
)

_ECLIPSE_MODELS = ("conical", "cylindrical", "none")

#: Fewest track samples per orbit: a chord of 1/100 of a circle is within 5e-4 of the arc, and the
#: torques follow the quantities linearly, so the interpolated track stays within that of the truth.
SAMPLES_PER_ORBIT_MIN = 100


@dataclass(frozen=True)
class EnvironmentTrack:
    """The attitude-independent environment along a run, one row per time.

    Attributes
    ----------
    t : ndarray (n,)
        Times since the orbit's epoch [s].
    position_N : ndarray (n, 3)
        Spacecraft position from the Earth's centre [m].
    velocity_relative_N : ndarray (n, 3)
        Velocity relative to the atmosphere co-rotating with the Earth [m/s].
    sun_N : ndarray (n, 3)
        Unit vector from the spacecraft to the Sun.
    solar_pressure_Pa : ndarray (n,)
        Radiation pressure on a surface facing the Sun [Pa]: the 1 AU value
        scaled by the inverse square of the distance and by the illumination.
    illumination : ndarray (n,)
        Fraction of the solar disk seen (1 full sun, 0 umbra).
    field_N : ndarray (n, 3)
        Geomagnetic field [T] (zeros without a field model).
    density_kg_m3 : ndarray (n,)
        Air density [kg/m^3] (zeros without an atmosphere model).
    """

    t: NDArray[np.float64]
    position_N: NDArray[np.float64]
    velocity_relative_N: NDArray[np.float64]
    sun_N: NDArray[np.float64]
    solar_pressure_Pa: NDArray[np.float64]
    illumination: NDArray[np.float64]
    field_N: NDArray[np.float64]
    density_kg_m3: NDArray[np.float64]

    def columns(self) -> NDArray[np.float64]:
        """The track as one column per time, rows in the order of :data:`TRACK_COLUMNS`.

        Returns
        -------
        ndarray (15, n)
        """
        return np.concatenate(
            [
                self.position_N.T,
                self.velocity_relative_N.T,
                self.sun_N.T,
                self.solar_pressure_Pa[None],
                self.illumination[None],
                self.field_N.T,
                self.density_kg_m3[None],
            ],
            axis=0,
        )


@dataclass(frozen=True)
class OrbitEnvironment:
    """An orbit and the models of what it brings to the spacecraft.

    Parameters
    ----------
    orbit : object
        Any orbit of :mod:`attitude.environment.orbit` (``position_N``,
        ``velocity_N``, ``epoch``, ``mu``).
    surface : SurfaceModel, optional
        Flat plates and residual dipole; None flies gravity gradient only (the
        surface torques need the plates).
    magnetic_field : object, optional
        ``field_N(r_N, epoch, t)`` [T]: :class:`IGRF` (default) or
        :class:`TiltedDipole`; None: no field (no magnetic torques, no magnetometer).
    atmosphere : object, optional
        ``density(r_N, epoch, t)`` [kg/m^3]: :class:`ExponentialAtmosphere`
        (default) or :class:`NRLMSIS`; None: no drag.
    eclipse : {"conical", "cylindrical", "none"}
        Shadow model of the Earth (:func:`attitude.environment.sun.illumination_fraction`).
    sources : sequence of str
        The disturbance torques flown, a subset of :data:`DISTURBANCE_SOURCES`.
    sample_period : float
        Grid of the track [s] (module docstring).

    Raises
    ------
    ValueError
        For an unknown eclipse model or source, a surface source without a
        surface, or a non-positive ``sample_period``.
    """

    orbit: Any
    surface: SurfaceModel | None = None
    magnetic_field: Any = field(default_factory=IGRF)
    atmosphere: Any = field(default_factory=ExponentialAtmosphere)
    eclipse: str = "conical"
    sources: tuple[str, ...] = DISTURBANCE_SOURCES
    sample_period: float = 1.0

    def __post_init__(self) -> None:
        for member in ("position_N", "velocity_N", "epoch", "mu"):
            if not hasattr(self.orbit, member):
                raise ValueError(
                    f"orbit must be an orbit of attitude.environment.orbit (with {member!r}), "
                    f"got {type(self.orbit).__name__}"
                )
        if self.surface is not None and not isinstance(self.surface, SurfaceModel):
            raise ValueError(f"surface must be a SurfaceModel or None, got {type(self.surface).__name__}")
        if self.eclipse not in _ECLIPSE_MODELS:
            raise ValueError(f"eclipse must be one of {_ECLIPSE_MODELS}, got {self.eclipse!r}")
        sources = tuple(self.sources) if not isinstance(self.sources, str) else (self.sources,)
        for s in sources:
            if s not in DISTURBANCE_SOURCES:
                raise ValueError(f"sources must be drawn from {DISTURBANCE_SOURCES}, got {s!r}")
        if len(set(sources)) != len(sources):
            raise ValueError(f"sources must not repeat a source, got {sources}")
        needs_surface = [s for s in sources if s != "gravity_gradient"]
        if needs_surface and self.surface is None:
            raise ValueError(
                f"sources {needs_surface} need a surface model (plates and residual dipole): give surface= "
                "or fly sources=('gravity_gradient',)"
            )
        object.__setattr__(self, "sources", sources)
        period = float(check_positive(self.sample_period, "sample_period"))
        if period > self.orbit.period / SAMPLES_PER_ORBIT_MIN:
            raise ValueError(
                f"sample_period must be at most 1/{SAMPLES_PER_ORBIT_MIN} of the orbit period "
                f"({self.orbit.period / SAMPLES_PER_ORBIT_MIN:.4g} s here: the track is interpolated linearly "
                f"between samples), got {period!r} s"
            )
        if "magnetic" in sources and self.magnetic_field is None:
            raise ValueError("sources 'magnetic' needs a magnetic_field model (got None)")
        if "aerodynamic" in sources and self.atmosphere is None:
            raise ValueError("sources 'aerodynamic' needs an atmosphere model (got None)")
        object.__setattr__(self, "sample_period", period)

    @property
    def epoch(self) -> Any:
        """The orbit's epoch (t = 0 of every run)."""
        return self.orbit.epoch

    # -- the track -------------------------------------------------------------------------

    def track(self, t: ArrayLike) -> EnvironmentTrack:
        """The attitude-independent environment at times ``t`` (module docstring).

        Parameters
        ----------
        t : array_like (n,)
            Increasing times since the orbit's epoch [s].

        Returns
        -------
        EnvironmentTrack
        """
        t = as_float_array(t, "t").reshape(-1)
        if t.size == 0 or np.any(np.diff(t) < 0.0):
            raise ValueError("t must be a non-empty array of non-decreasing times in s")
        n_grid = max(2, int(np.ceil((t[-1] - t[0]) / self.sample_period - 1e-9)) + 1)
        grid = t[0] + self.sample_period * np.arange(n_grid)
        samples = self._samples(grid)

        def at_t(values: NDArray[np.float64]) -> NDArray[np.float64]:
            if values.ndim == 1:
                return np.interp(t, grid, values)
            return np.stack([np.interp(t, grid, values[:, i]) for i in range(values.shape[1])], axis=-1)

        sun = at_t(samples["sun_N"])
        return EnvironmentTrack(
            t=t,
            position_N=at_t(samples["position_N"]),
            velocity_relative_N=at_t(samples["velocity_relative_N"]),
            sun_N=sun / np.linalg.norm(sun, axis=-1, keepdims=True),
            solar_pressure_Pa=at_t(samples["solar_pressure_Pa"]),
            illumination=at_t(samples["illumination"]),
            field_N=at_t(samples["field_N"]),
            density_kg_m3=at_t(samples["density_kg_m3"]),
        )

    def _samples(self, t: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        r = np.asarray(self.orbit.position_N(t), dtype=float)
        v = np.asarray(self.orbit.velocity_N(t), dtype=float)
        earth_rate = np.array([0.0, 0.0, EARTH_ROTATION_RATE])
        v_rel = v - np.cross(earth_rate, r)
        r_sun = sun_position_N(self.epoch.julian_date(t))
        to_sun = r_sun - r
        distance = np.linalg.norm(to_sun, axis=-1)
        if self.eclipse == "none":
            light = np.ones(t.shape)
        else:
            light = np.asarray(illumination_fraction(r, r_sun, model=self.eclipse), dtype=float)
        pressure = SOLAR_PRESSURE_1AU_PA * (AU_M / distance) ** 2 * light
        field_N = np.zeros_like(r) if self.magnetic_field is None else self.magnetic_field.field_N(r, self.epoch, t)
        density = np.zeros(t.shape) if self.atmosphere is None else self.atmosphere.density(r, self.epoch, t)
        return {
            "position_N": r,
            "velocity_relative_N": v_rel,
            "sun_N": to_sun / distance[:, None],
            "solar_pressure_Pa": pressure,
            "illumination": light,
            "field_N": np.asarray(field_N, dtype=float),
            "density_kg_m3": np.asarray(density, dtype=float),
        }

    # -- the torques -------------------------------------------------------------------------

    def surface_parameters(
        self,
        *,
        drag_scale: float = 1.0,
        residual_dipole_Am2: ArrayLike | None = None,
        centre_of_pressure_offset_B_m: ArrayLike = (0.0, 0.0, 0.0),
    ) -> NDArray[np.float64]:
        """A per-run surface parameter vector (:data:`SURFACE_PARAMETERS`).

        Parameters
        ----------
        drag_scale : float
            Factor on every plate's drag coefficient (>= 0).
        residual_dipole_Am2 : array_like (3,), optional
            Residual dipole in body axes [A m^2]; default the surface model's.
        centre_of_pressure_offset_B_m : array_like (3,)
            Offset added to every plate's centre of pressure [m].

        Returns
        -------
        ndarray (7,)
        """
        scale = float(check_positive(drag_scale, "drag_scale", allow_zero=True))
        if residual_dipole_Am2 is None:
            dipole = np.zeros(3) if self.surface is None else self.surface.residual_dipole_Am2
        else:
            dipole = check_vector(residual_dipole_Am2, "residual_dipole_Am2", 3).reshape(3)
        offset = check_vector(centre_of_pressure_offset_B_m, "centre_of_pressure_offset_B_m", 3).reshape(3)
        return np.concatenate([[scale], np.asarray(dipole, dtype=float), offset])

    def body_vectors_components(self, q: Components, row: Sequence[Any]) -> tuple[Components, Components]:
        """The geomagnetic field [T] and the unit Sun vector in body axes, on components.

        Parameters
        ----------
        q : list of 4
            Attitude ``q_BN``.
        row : sequence of 15
            One column of :meth:`EnvironmentTrack.columns`.

        Returns
        -------
        tuple of list of 3
            ``(field_B, sun_B)``.
        """
        field_B = quat.rotate_inverse_components(q, list(row[_FIELD]))
        sun_B = quat.rotate_inverse_components(q, list(row[_SUN]))
        return field_B, sun_B

    def torque_components(
        self, body: RigidBody | ParametricBody, q: Components, row: Sequence[Any], parameters: Sequence[Any]
    ) -> dict[str, Components]:
        """The disturbance torques [N m] in body axes, per source, on components (numpy or casadi).

        Parameters
        ----------
        body : RigidBody or ParametricBody
            Inertia for the gravity gradient.
        q : list of 4
            Attitude ``q_BN``.
        row : sequence of 15
            One column of :meth:`EnvironmentTrack.columns`.
        parameters : sequence of 7
            Surface parameters (:meth:`surface_parameters`).

        Returns
        -------
        dict
            One list of 3 per source of :attr:`sources`, in that order.
        """
        row = list(row)
        scale, dipole, offset = parameters[0], list(parameters[1:4]), list(parameters[4:7])
        out: dict[str, Components] = {}
        for source in self.sources:
            if source == "gravity_gradient":
                r_B = quat.rotate_inverse_components(q, row[_POSITION])
                out[source] = gravity_gradient_torque_components(body, r_B, self.orbit.mu)
            elif source == "aerodynamic":
                v_B = quat.rotate_inverse_components(q, row[_VELOCITY])
                tau = aerodynamic_torque_components(self.surface, v_B, row[_DENSITY])
                force = aerodynamic_force_components(self.surface, v_B, row[_DENSITY])
                out[source] = [scale * (a + b) for a, b in zip(tau, cross(offset, force))]
            elif source == "solar_pressure":
                s_B = quat.rotate_inverse_components(q, row[_SUN])
                tau = solar_pressure_torque_components(self.surface, s_B, row[_PRESSURE])
                force = solar_pressure_force_components(self.surface, s_B, row[_PRESSURE])
                out[source] = [a + b for a, b in zip(tau, cross(offset, force))]
            else:
                field_B = quat.rotate_inverse_components(q, row[_FIELD])
                out[source] = magnetic_torque_components(dipole, field_B)
        return out

    def torques_B(
        self, body: RigidBody, q: ArrayLike, track: EnvironmentTrack, parameters: ArrayLike | None = None
    ) -> dict[str, NDArray[np.float64]]:
        """The disturbance torques along a track, per source [N m], shape (n, 3) each.

        Parameters
        ----------
        body : RigidBody
            The spacecraft (gravity gradient).
        q : array_like (n, 4) or (4,)
            Attitudes ``q_BN`` at the track's times (one attitude: held).
        track : EnvironmentTrack
            From :meth:`track`.
        parameters : array_like (7,), optional
            Surface parameters; default :meth:`surface_parameters` with its defaults.

        Returns
        -------
        dict of ndarray (n, 3)
        """
        q = quat.as_unit_quaternion(q, "q")
        n = track.t.size
        q = np.broadcast_to(q, (n, 4))
        p = self.surface_parameters() if parameters is None else as_float_array(parameters, "parameters")
        if p.shape != (len(SURFACE_PARAMETERS),):
            raise ValueError(f"parameters must have shape ({len(SURFACE_PARAMETERS)},), got {p.shape}")
        cols = track.columns()
        comps = self.torque_components(body, [q[:, i] for i in range(4)], list(cols), [float(v) for v in p])
        return {k: np.stack(np.broadcast_arrays(*v), axis=-1) for k, v in comps.items()}

    def tick_function(self, body: RigidBody | ParametricBody | None) -> ca.Function:
        """``(q, row, parameters[, body]) -> (torques (3 per source), field_B, sun_B)`` as one casadi Function.

        The single-run engine calls it once per tick (one call instead of a few
        hundred numpy operations on scalars).

        Parameters
        ----------
        body : RigidBody, ParametricBody or None
            Inertia for the gravity gradient. None: the inertia is a fourth
            input, the six entries of the whole body's inertia and of its
            inverse (:func:`attitude.rigid_body.symmetric_entries`), so that
            one compiled function serves every body.

        Returns
        -------
        casadi.Function
        """
        q = ca.SX.sym("q", 4)
        row = ca.SX.sym("row", len(TRACK_COLUMNS))
        p = ca.SX.sym("p", len(SURFACE_PARAMETERS))
        inputs = [q, row, p]
        if body is None:
            entries = ca.SX.sym("body", 12)
            body = ParametricBody([entries[i] for i in range(6)], [entries[i] for i in range(6, 12)])
            inputs.append(entries)
        qc = [q[i] for i in range(4)]
        rc = [row[i] for i in range(len(TRACK_COLUMNS))]
        torques = self.torque_components(body, qc, rc, [p[i] for i in range(len(SURFACE_PARAMETERS))])
        field_B, sun_B = self.body_vectors_components(qc, rc)
        flat = [c for source in self.sources for c in torques[source]]
        return ca.Function(
            "environment",
            inputs,
            [ca.vertcat(*flat) if flat else ca.SX(0, 1), ca.vertcat(*field_B), ca.vertcat(*sun_B)],
        )

    def describe(self) -> str:
        """One line for reports: the models flown (the orbit describes itself)."""
        parts = []
        for name, model in (("field", self.magnetic_field), ("atmosphere", self.atmosphere)):
            if model is None:
                parts.append(f"no {name}")
            else:
                parts.append(model.describe() if hasattr(model, "describe") else type(model).__name__)
        parts.append(f"eclipse {self.eclipse}")
        parts.append("torques: " + ", ".join(s.replace("_", " ") for s in self.sources))
        return "; ".join(parts)

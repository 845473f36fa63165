"""Aerodynamic, solar-radiation-pressure and magnetic disturbance torques on a plate model.

Forces act on the flat plates of a :class:`~attitude.environment.surface.SurfaceModel`
at their centres of pressure; the torque about the centre of mass is
``sum_i r_i x F_i`` with ``r_i`` the centre of pressure relative to the centre
of mass. Everything is in body axes. Per plate ``i`` (outward unit normal
``n_i``, area ``A_i``):

* free-molecular drag (Vallado, *Fundamentals of Astrodynamics and
  Applications*, 4th ed., sec. 8.6.2; Wertz, *Spacecraft Attitude
  Determination and Control*, 1978, sec. 17.2; the same model as Basilisk's
  ``facetDragDynamicEffector``)::

      F_i = -1/2 rho Cd_i A_i |v|^2 max(0, n_i . v_hat) v_hat = -1/2 rho Cd_i A_i max(0, n_i . v) v

  with ``v`` the velocity of the spacecraft relative to the (co-rotating)
  atmosphere, in body axes: the flow comes from ``+v``, so the plates whose
  normal has a positive component along ``v`` are wetted;
* solar radiation pressure (Montenbruck and Gill, *Satellite Orbits*, 2000,
  sec. 3.4.1 for the absorbed and specular parts; Wertz 1978, sec. 17.2 with
  the Lambertian diffuse part; the same model as Basilisk's
  ``facetSRPDynamicEffector``)::

      F_i = -P A_i c_i [(1 - specular_i) s + 2 (specular_i c_i + diffuse_i / 3) n_i],   c_i = max(0, n_i . s)

  with ``s`` the unit vector from the spacecraft to the Sun and ``P`` the
  radiation pressure at the spacecraft [Pa] (``SOLAR_PRESSURE_1AU_PA (AU/d)^2``
  times the illumination fraction);
* a magnetic dipole ``m`` in the field ``B``: ``tau = m x B``.

The ``max(0, .)`` drops the plates facing away from the flow or the Sun.
No shadowing of one plate by another is modelled: exact for a convex body.

The ``*_components`` functions are backend-neutral like
:func:`attitude.environment.gravity_gradient.gravity_gradient_torque_components`:
lists of three numpy arrays (any batch shape, broadcasting) or casadi
scalars, built from ``+ - *`` and :func:`attitude.backend.fmax`, so the
engine's compiled path and the batch kernels can fold them into generated
code. The surface's numbers enter as constants. The other functions are the
numpy front doors, with argument checks, returning ``(..., 3)`` arrays.
See docs/environment_torques.md.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.backend import cross, fmax, is_symbolic
from attitude.environment.surface import SurfaceModel
from attitude.rigid_body import Components
from attitude.validation import as_float_array, check_positive, check_vector

__all__ = [
    "SOLAR_PRESSURE_1AU_PA",
    "aerodynamic_force",
    "aerodynamic_force_components",
    "aerodynamic_torque",
    "aerodynamic_torque_components",
    "magnetic_torque",
    "magnetic_torque_components",
    "solar_pressure_force",
    "solar_pressure_force_components",
    "solar_pressure_torque",
    "solar_pressure_torque_components",
]

#: Solar radiation pressure on a perfect absorber facing the Sun at 1 AU [Pa]:
#: the total solar irradiance 1361 W/m^2 (Kopp and Lean, Geophys. Res. Lett. 38,
#: L01706, 2011) over the speed of light; about 4.54e-6 N/m^2. Basilisk's
#: ``facetSRPDynamicEffector`` uses 1368 W/m^2 (0.5 % more).
SOLAR_PRESSURE_1AU_PA = 1361.0 / 299_792_458.0


def _check_surface(surface: Any) -> SurfaceModel:
    if not isinstance(surface, SurfaceModel):
        raise ValueError(f"surface must be a SurfaceModel, got {type(surface).__name__}")
    return surface


def _check_components(value: Any, name: str, unit: str) -> list[Any]:
    if len(value) != 3:
        raise ValueError(f"{name} must hold 3 components (x, y, z) in {unit}, got {len(value)}")
    return list(value)


def _dot(n: NDArray[np.float64], v: list[Any]) -> Any:
    return float(n[0]) * v[0] + float(n[1]) * v[1] + float(n[2]) * v[2]


# ---------------------------------------------------------------------------
# Aerodynamic drag (free-molecular flat plates)
# ---------------------------------------------------------------------------


def _aerodynamic(surface: SurfaceModel, v: list[Any], density: Any) -> tuple[Components, Components]:
    """Force and torque ``(-1/2 rho W v, -1/2 rho C x v)``.

    ``W = sum_i w_i`` and ``C = sum_i w_i r_i`` with the wetted weights
    ``w_i = Cd_i A_i max(0, n_i . v)`` [m^3/s]: the per-plate forces are all
    along ``-v``, so their moments collapse into one cross product.
    """
    total: Any = 0.0
    moment_arm: list[Any] = [0.0, 0.0, 0.0]
    for i in range(surface.n_plates):
        wetted = fmax(_dot(surface.normal_B[i], v), 0.0)
        w = float(surface.drag_coefficient[i] * surface.area_m2[i]) * wetted
        total = total + w
        r = surface.centre_of_pressure_B_m[i]
        moment_arm = [moment_arm[k] + float(r[k]) * w for k in range(3)]
    scale = -0.5 * density
    force = [scale * total * c for c in v]
    torque = [scale * c for c in cross(moment_arm, v)]
    return force, torque


def aerodynamic_force_components(surface: SurfaceModel, v_rel_B: Components, density_kg_m3: Any) -> Components:
    """Free-molecular drag force ``sum_i -1/2 rho Cd_i A_i max(0, n_i . v) v`` [N], backend-neutral.

    Parameters
    ----------
    surface : SurfaceModel
        The plates (areas, normals, drag coefficients).
    v_rel_B : list of 3 numpy arrays or casadi scalars
        Velocity of the spacecraft relative to the co-rotating atmosphere, body axes [m/s].
    density_kg_m3 : numpy array_like or casadi scalar
        Atmospheric density [kg/m^3] (broadcasts against the components).

    Returns
    -------
    list of 3
        Force in body axes [N], same backend as the inputs.
    """
    surface = _check_surface(surface)
    v = _check_components(v_rel_B, "v_rel_B", "m/s")
    return _aerodynamic(surface, v, density_kg_m3)[0]


def aerodynamic_torque_components(surface: SurfaceModel, v_rel_B: Components, density_kg_m3: Any) -> Components:
    """Free-molecular drag torque ``sum_i r_i x F_i`` about the centre of mass [N m], backend-neutral.

    ``F_i = -1/2 rho Cd_i A_i max(0, n_i . v) v`` at the plate's centre of
    pressure ``r_i`` (Vallado 4th ed. sec. 8.6.2; Wertz 1978 sec. 17.2;
    Basilisk ``facetDragDynamicEffector``).

    Parameters
    ----------
    surface : SurfaceModel
        The plates (areas, normals, centres of pressure, drag coefficients).
    v_rel_B : list of 3 numpy arrays or casadi scalars
        Velocity of the spacecraft relative to the co-rotating atmosphere, body axes [m/s].
    density_kg_m3 : numpy array_like or casadi scalar
        Atmospheric density [kg/m^3] (broadcasts against the components).

    Returns
    -------
    list of 3
        Torque in body axes [N m], same backend as the inputs.
    """
    surface = _check_surface(surface)
    v = _check_components(v_rel_B, "v_rel_B", "m/s")
    return _aerodynamic(surface, v, density_kg_m3)[1]


# ---------------------------------------------------------------------------
# Solar radiation pressure
# ---------------------------------------------------------------------------


def _solar(surface: SurfaceModel, s: list[Any], pressure: Any) -> tuple[Components, Components]:
    """Force and torque ``-P [a s + sum_i b_i n_i]`` and ``-P [A x s + sum_i b_i (r_i x n_i)]``.

    With ``c_i = max(0, n_i . s)``: ``a_i = A_i c_i (1 - specular_i)`` (the
    part along the light), ``b_i = 2 A_i c_i (specular_i c_i + diffuse_i / 3)``
    (the part along the normal), ``a = sum a_i``, ``A = sum a_i r_i``.
    """
    along_sun: Any = 0.0
    along_sun_arm: list[Any] = [0.0, 0.0, 0.0]
    normal_force: list[Any] = [0.0, 0.0, 0.0]
    normal_torque: list[Any] = [0.0, 0.0, 0.0]
    for i in range(surface.n_plates):
        n = surface.normal_B[i]
        r = surface.centre_of_pressure_B_m[i]
        area = float(surface.area_m2[i])
        spec = float(surface.specular[i])
        diff = float(surface.diffuse[i])
        lit = fmax(_dot(n, s), 0.0)
        a = (area * (1.0 - spec)) * lit
        b = 2.0 * area * lit * (spec * lit + diff / 3.0)
        r_x_n = np.cross(r, n)
        along_sun = along_sun + a
        along_sun_arm = [along_sun_arm[k] + float(r[k]) * a for k in range(3)]
        normal_force = [normal_force[k] + float(n[k]) * b for k in range(3)]
        normal_torque = [normal_torque[k] + float(r_x_n[k]) * b for k in range(3)]
    force = [-pressure * (along_sun * s[k] + normal_force[k]) for k in range(3)]
    arm_x_s = cross(along_sun_arm, s)
    torque = [-pressure * (arm_x_s[k] + normal_torque[k]) for k in range(3)]
    return force, torque


def solar_pressure_force_components(surface: SurfaceModel, sun_B: Components, pressure_Pa: Any) -> Components:
    """Solar radiation pressure force on the plates [N], backend-neutral.

    Per plate with ``c = n . s > 0``:
    ``F = -P A c [(1 - specular) s + 2 (specular c + diffuse / 3) n]``.

    Parameters
    ----------
    surface : SurfaceModel
        The plates (areas, normals, optical coefficients).
    sun_B : list of 3 numpy arrays or casadi scalars
        Unit vector from the spacecraft to the Sun in body axes [-] (not
        normalised here).
    pressure_Pa : numpy array_like or casadi scalar
        Radiation pressure at the spacecraft [Pa]: ``SOLAR_PRESSURE_1AU_PA
        (1 AU / d)^2`` times the illumination fraction (0 in umbra).

    Returns
    -------
    list of 3
        Force in body axes [N], same backend as the inputs.
    """
    surface = _check_surface(surface)
    s = _check_components(sun_B, "sun_B", "unit vector components")
    return _solar(surface, s, pressure_Pa)[0]


def solar_pressure_torque_components(surface: SurfaceModel, sun_B: Components, pressure_Pa: Any) -> Components:
    """Solar radiation pressure torque ``sum_i r_i x F_i`` about the centre of mass [N m], backend-neutral.

    ``F_i`` as in :func:`solar_pressure_force_components` (Montenbruck and
    Gill 2000 sec. 3.4.1; Wertz 1978 sec. 17.2; Basilisk
    ``facetSRPDynamicEffector``), at the plate's centre of pressure ``r_i``.

    Parameters
    ----------
    surface : SurfaceModel
        The plates (areas, normals, centres of pressure, optical coefficients).
    sun_B : list of 3 numpy arrays or casadi scalars
        Unit vector from the spacecraft to the Sun in body axes [-] (not
        normalised here).
    pressure_Pa : numpy array_like or casadi scalar
        Radiation pressure at the spacecraft [Pa], illumination included.

    Returns
    -------
    list of 3
        Torque in body axes [N m], same backend as the inputs.
    """
    surface = _check_surface(surface)
    s = _check_components(sun_B, "sun_B", "unit vector components")
    return _solar(surface, s, pressure_Pa)[1]


# ---------------------------------------------------------------------------
# Magnetic dipole
# ---------------------------------------------------------------------------


def magnetic_torque_components(dipole_B: Components, field_B: Components) -> Components:
    """Torque ``m x B`` of a magnetic dipole in a field [N m], backend-neutral.

    Parameters
    ----------
    dipole_B : list of 3 numpy arrays, floats or casadi scalars
        Magnetic dipole moment in body axes [A m^2] (e.g.
        ``list(surface.residual_dipole_Am2)``).
    field_B : list of 3 numpy arrays or casadi scalars
        Magnetic flux density at the spacecraft in body axes [T].

    Returns
    -------
    list of 3
        Torque in body axes [N m].
    """
    m = _check_components(dipole_B, "dipole_B", "A m^2")
    b = _check_components(field_B, "field_B", "T")
    if not is_symbolic(*m):
        m = [np.asarray(c, dtype=float) if np.ndim(c) else float(c) for c in m]
    return cross(m, b)


# ---------------------------------------------------------------------------
# numpy front doors
# ---------------------------------------------------------------------------


def _stack(components: Components, *shapes: tuple[int, ...]) -> NDArray[np.float64]:
    full = np.broadcast_shapes(*shapes)
    return np.stack([np.broadcast_to(np.asarray(c, dtype=float), full) for c in components], axis=-1)


def _velocity_density(v_rel_B: ArrayLike, density_kg_m3: ArrayLike) -> tuple[NDArray[np.float64], Any]:
    v = check_vector(v_rel_B, "v_rel_B", 3)
    rho = check_positive(density_kg_m3, "density_kg_m3", allow_zero=True)
    return v, rho


def _sun_pressure(sun_B: ArrayLike, pressure_Pa: ArrayLike) -> tuple[NDArray[np.float64], Any]:
    s = check_vector(sun_B, "sun_B", 3)
    length = np.linalg.norm(s, axis=-1, keepdims=True)
    if np.any(length == 0.0):
        raise ValueError("sun_B must be a non-zero direction to the Sun; found a zero vector")
    pressure = check_positive(pressure_Pa, "pressure_Pa", allow_zero=True)
    return s / length, pressure


def aerodynamic_force(surface: SurfaceModel, v_rel_B: ArrayLike, density_kg_m3: ArrayLike) -> NDArray[np.float64]:
    """Free-molecular drag force on the plates, body axes [N].

    Parameters
    ----------
    surface : SurfaceModel
        The plates.
    v_rel_B : array_like, shape (..., 3)
        Velocity relative to the co-rotating atmosphere, body axes [m/s].
    density_kg_m3 : array_like, shape (...) or scalar
        Atmospheric density [kg/m^3], ``>= 0``.

    Returns
    -------
    ndarray, shape broadcast(...) + (3,)
        Force [N].

    Raises
    ------
    ValueError
        If ``surface`` is not a SurfaceModel, ``v_rel_B`` is not ``(..., 3)``
        and finite, or ``density_kg_m3`` is negative or not finite.
    """
    surface = _check_surface(surface)
    v, rho = _velocity_density(v_rel_B, density_kg_m3)
    force = aerodynamic_force_components(surface, [v[..., k] for k in range(3)], rho)
    return _stack(force, v.shape[:-1], np.shape(rho))


def aerodynamic_torque(surface: SurfaceModel, v_rel_B: ArrayLike, density_kg_m3: ArrayLike) -> NDArray[np.float64]:
    """Free-molecular drag torque about the centre of mass, body axes [N m].

    Parameters
    ----------
    surface : SurfaceModel
        The plates.
    v_rel_B : array_like, shape (..., 3)
        Velocity relative to the co-rotating atmosphere, body axes [m/s].
    density_kg_m3 : array_like, shape (...) or scalar
        Atmospheric density [kg/m^3], ``>= 0``.

    Returns
    -------
    ndarray, shape broadcast(...) + (3,)
        Torque [N m].

    Raises
    ------
    ValueError
        As :func:`aerodynamic_force`.
    """
    surface = _check_surface(surface)
    v, rho = _velocity_density(v_rel_B, density_kg_m3)
    torque = aerodynamic_torque_components(surface, [v[..., k] for k in range(3)], rho)
    return _stack(torque, v.shape[:-1], np.shape(rho))


def solar_pressure_force(surface: SurfaceModel, sun_B: ArrayLike, pressure_Pa: ArrayLike) -> NDArray[np.float64]:
    """Solar radiation pressure force on the plates, body axes [N].

    Parameters
    ----------
    surface : SurfaceModel
        The plates.
    sun_B : array_like, shape (..., 3)
        Direction to the Sun in body axes (normalised here; must be non-zero) [-].
    pressure_Pa : array_like, shape (...) or scalar
        Radiation pressure at the spacecraft, illumination included [Pa], ``>= 0``.

    Returns
    -------
    ndarray, shape broadcast(...) + (3,)
        Force [N].

    Raises
    ------
    ValueError
        If ``surface`` is not a SurfaceModel, ``sun_B`` is not ``(..., 3)``,
        finite and non-zero, or ``pressure_Pa`` is negative or not finite.
    """
    surface = _check_surface(surface)
    s, pressure = _sun_pressure(sun_B, pressure_Pa)
    force = solar_pressure_force_components(surface, [s[..., k] for k in range(3)], pressure)
    return _stack(force, s.shape[:-1], np.shape(pressure))


def solar_pressure_torque(surface: SurfaceModel, sun_B: ArrayLike, pressure_Pa: ArrayLike) -> NDArray[np.float64]:
    """Solar radiation pressure torque about the centre of mass, body axes [N m].

    Parameters
    ----------
    surface : SurfaceModel
        The plates.
    sun_B : array_like, shape (..., 3)
        Direction to the Sun in body axes (normalised here; must be non-zero) [-].
    pressure_Pa : array_like, shape (...) or scalar
        Radiation pressure at the spacecraft, illumination included [Pa], ``>= 0``.

    Returns
    -------
    ndarray, shape broadcast(...) + (3,)
        Torque [N m].

    Raises
    ------
    ValueError
        As :func:`solar_pressure_force`.
    """
    surface = _check_surface(surface)
    s, pressure = _sun_pressure(sun_B, pressure_Pa)
    torque = solar_pressure_torque_components(surface, [s[..., k] for k in range(3)], pressure)
    return _stack(torque, s.shape[:-1], np.shape(pressure))


def magnetic_torque(dipole_B: ArrayLike, field_B: ArrayLike) -> NDArray[np.float64]:
    """Torque ``m x B`` of a magnetic dipole, body axes [N m].

    Parameters
    ----------
    dipole_B : array_like, shape (..., 3)
        Dipole moment in body axes [A m^2] (e.g. ``surface.residual_dipole_Am2``).
    field_B : array_like, shape (..., 3)
        Magnetic flux density in body axes [T].

    Returns
    -------
    ndarray, shape broadcast(...) + (3,)
        Torque [N m].

    Raises
    ------
    ValueError
        If either argument is not a finite ``(..., 3)`` array.
    """
    m = check_vector(dipole_B, "dipole_B", 3)
    b = as_float_array(check_vector(field_B, "field_B", 3), "field_B")
    return np.cross(m, b)

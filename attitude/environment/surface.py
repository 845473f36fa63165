"""Surface model of a spacecraft: flat plates for drag and solar pressure, plus a residual dipole.

A :class:`SurfaceModel` is the geometry the disturbance torques of
:mod:`attitude.environment.torques` act on: ``n`` one-sided flat plates, each
with an area, an outward unit normal and a centre of pressure in body axes
(relative to the centre of mass), optical coefficients (specular, diffuse;
the rest is absorbed) and a free-molecular drag coefficient; and the
spacecraft's residual magnetic dipole. Plates are one-sided: a plate only
feels the flow or the light arriving on its outward face, so a closed
convex body is modelled by all of its outer faces (no self-shadowing is
computed). See docs/environment_torques.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.validation import as_float_array, check_vector, describe

__all__ = ["DEFAULT_DRAG_COEFFICIENT", "SurfaceModel"]

#: Free-molecular drag coefficient of a flat plate used when none is given [-]
#: (the customary value for satellites in low orbit, Vallado, *Fundamentals of
#: Astrodynamics and Applications*, 4th ed., sec. 8.6.2).
DEFAULT_DRAG_COEFFICIENT = 2.2

# Rounding allowance on ``specular + diffuse <= 1`` (e.g. 0.7 + 0.2 + 0.1 typed in as
# fractions that do not add exactly in binary); far below any meaningful optical datum.
_SUM_TOLERANCE = 1e-12


def _per_plate(value: ArrayLike, name: str, n: int) -> NDArray[np.float64]:
    """A scalar or an (n,) array as a fresh (n,) float array."""
    arr = as_float_array(value, name)
    if arr.ndim == 0:
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be a scalar or have shape ({n},) (one value per plate), got shape {arr.shape}")
    return arr.astype(np.float64, copy=True)


def _plate_vectors(value: ArrayLike, name: str, n: int | None) -> NDArray[np.float64]:
    arr = check_vector(value, name, 3)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or (n is not None and arr.shape[0] != n):
        want = "(n, 3)" if n is None else f"({n}, 3)"
        raise ValueError(f"{name} must have shape {want} (one 3-vector per plate), got shape {np.shape(value)}")
    return arr.astype(np.float64, copy=True)


def _check_fraction(values: NDArray[np.float64], name: str) -> None:
    for i, v in enumerate(values):
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"{name}[{i}] must be in [0, 1] (a fraction of the incident light), got {float(v)!r}")


@dataclass(frozen=True, eq=False)
class SurfaceModel:
    """Flat plates (area, outward normal, centre of pressure, optics, drag) and a residual dipole.

    Scalars given for the per-plate coefficients apply to every plate. The
    arrays are copied, normals normalised, and everything checked in
    ``__post_init__``; the instance is immutable.

    Attributes
    ----------
    area_m2 : array_like, shape (n,)
        Plate areas [m^2], each ``>= 0``.
    normal_B : array_like, shape (n, 3)
        Outward normals in body axes (any non-zero length; stored as unit vectors) [-].
    centre_of_pressure_B_m : array_like, shape (n, 3)
        Centre of pressure of each plate (its centroid for a uniform plate),
        in body axes, relative to the centre of mass [m].
    specular : array_like, shape (n,) or scalar
        Fraction of the incident light reflected specularly, in [0, 1] [-]. Default 0.
    diffuse : array_like, shape (n,) or scalar
        Fraction reflected diffusely (Lambertian), in [0, 1], with
        ``specular + diffuse <= 1``; the absorbed fraction is the rest [-]. Default 0.
    drag_coefficient : array_like, shape (n,) or scalar
        Free-molecular drag coefficient of each plate, ``>= 0`` [-]. Default
        :data:`DEFAULT_DRAG_COEFFICIENT` (2.2).
    residual_dipole_Am2 : array_like, shape (3,)
        Residual magnetic dipole of the spacecraft in body axes [A m^2]. Default zero.

    Raises
    ------
    ValueError
        Naming the argument, the plate index, the rule and the value: a zero
        normal, a negative area, an optical coefficient outside [0, 1] or a
        pair summing above 1, a negative drag coefficient, mismatched shapes,
        NaN or inf.
    """

    area_m2: NDArray[np.float64]
    normal_B: NDArray[np.float64]
    centre_of_pressure_B_m: NDArray[np.float64]
    specular: NDArray[np.float64] = field(default_factory=lambda: np.zeros(()))
    diffuse: NDArray[np.float64] = field(default_factory=lambda: np.zeros(()))
    drag_coefficient: NDArray[np.float64] = field(default_factory=lambda: np.array(DEFAULT_DRAG_COEFFICIENT))
    residual_dipole_Am2: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        area = as_float_array(self.area_m2, "area_m2")
        if area.ndim != 1 or area.size == 0:
            raise ValueError(f"area_m2 must have shape (n,) with n >= 1 plates, got shape {area.shape}")
        n = area.size
        for i, a in enumerate(area):
            if a < 0.0:
                raise ValueError(f"area_m2[{i}] must be non-negative (a plate area in m^2), got {float(a)!r}")
        normal = _plate_vectors(self.normal_B, "normal_B", n)
        lengths = np.linalg.norm(normal, axis=1)
        for i, length in enumerate(lengths):
            if not length > 0.0:
                raise ValueError(
                    f"normal_B[{i}] must be a non-zero outward normal (its direction is used), "
                    f"got {describe(normal[i])}"
                )
        cop = _plate_vectors(self.centre_of_pressure_B_m, "centre_of_pressure_B_m", n)
        specular = _per_plate(self.specular, "specular", n)
        diffuse = _per_plate(self.diffuse, "diffuse", n)
        _check_fraction(specular, "specular")
        _check_fraction(diffuse, "diffuse")
        for i, (s, d) in enumerate(zip(specular, diffuse)):
            if s + d > 1.0 + _SUM_TOLERANCE:
                raise ValueError(
                    f"specular[{i}] + diffuse[{i}] must be <= 1 (the absorbed fraction 1 - specular - diffuse "
                    f"cannot be negative), got {float(s)!r} + {float(d)!r} = {float(s + d)!r}"
                )
        cd = _per_plate(self.drag_coefficient, "drag_coefficient", n)
        for i, c in enumerate(cd):
            if c < 0.0:
                raise ValueError(f"drag_coefficient[{i}] must be non-negative, got {float(c)!r}")
        dipole = check_vector(self.residual_dipole_Am2, "residual_dipole_Am2", 3)
        if dipole.shape != (3,):
            raise ValueError(f"residual_dipole_Am2 must have shape (3,) in A m^2, got shape {dipole.shape}")
        values: dict[str, NDArray[np.float64]] = {
            "area_m2": area.astype(np.float64, copy=True),
            "normal_B": normal / lengths[:, None],
            "centre_of_pressure_B_m": cop,
            "specular": specular,
            "diffuse": diffuse,
            "drag_coefficient": cd,
            "residual_dipole_Am2": dipole.astype(np.float64, copy=True),
        }
        for name, arr in values.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    # ------------------------------------------------------------------
    @property
    def n_plates(self) -> int:
        """Number of plates."""
        return int(self.area_m2.size)

    @property
    def absorbed(self) -> NDArray[np.float64]:
        """Absorbed fraction ``1 - specular - diffuse`` of each plate, shape (n,) [-]."""
        return np.clip(1.0 - self.specular - self.diffuse, 0.0, 1.0)

    def describe(self) -> str:
        """One line for reports: plate count, total area, optics and drag ranges, residual dipole.

        Returns
        -------
        str
            A human-readable summary.
        """
        cd = self.drag_coefficient
        cd_text = f"Cd {cd.min():.3g}" if cd.min() == cd.max() else f"Cd {cd.min():.3g}-{cd.max():.3g}"
        return (
            f"{self.n_plates} plates, {self.area_m2.sum():.4g} m^2 in total, "
            f"specular {self.specular.min():.3g}-{self.specular.max():.3g}, "
            f"diffuse {self.diffuse.min():.3g}-{self.diffuse.max():.3g}, {cd_text}, "
            f"residual dipole {np.linalg.norm(self.residual_dipole_Am2):.3g} A m^2"
        )

    # ------------------------------------------------------------------
    @classmethod
    def box(
        cls,
        size_m: ArrayLike,
        *,
        specular: ArrayLike = 0.0,
        diffuse: ArrayLike = 0.0,
        drag_coefficient: ArrayLike = DEFAULT_DRAG_COEFFICIENT,
        centre_of_pressure_offset_B_m: ArrayLike = (0.0, 0.0, 0.0),
        residual_dipole_Am2: ArrayLike = (0.0, 0.0, 0.0),
    ) -> SurfaceModel:
        """Six faces of a cuboid centred on the centre of mass, edges along the body axes.

        Plates in the order ``+x, -x, +y, -y, +z, -z``; each has the area of
        its face and its centre of pressure at the face centre, shifted by
        ``centre_of_pressure_offset_B_m`` (the geometric centre of the box
        relative to the centre of mass, e.g. a dispersed centre of mass).

        Parameters
        ----------
        size_m : array_like, shape (3,)
            Edge lengths along body x, y, z [m], each ``> 0``.
        specular : array_like, shape (6,) or scalar
            Specular fraction of each face [-].
        diffuse : array_like, shape (6,) or scalar
            Diffuse fraction of each face [-].
        drag_coefficient : array_like, shape (6,) or scalar
            Drag coefficient of each face [-].
        centre_of_pressure_offset_B_m : array_like, shape (3,)
            Box centre minus centre of mass, body axes [m].
        residual_dipole_Am2 : array_like, shape (3,)
            Residual magnetic dipole in body axes [A m^2].

        Returns
        -------
        SurfaceModel
            Six plates.

        Raises
        ------
        ValueError
            If ``size_m`` is not three positive lengths, or as the constructor.
        """
        size = check_vector(size_m, "size_m", 3)
        if size.shape != (3,):
            raise ValueError(f"size_m must have shape (3,) (edge lengths along x, y, z in m), got shape {size.shape}")
        for i, s in enumerate(size):
            if not s > 0.0:
                raise ValueError(f"size_m[{i}] must be strictly positive (an edge length in m), got {float(s)!r}")
        offset = check_vector(centre_of_pressure_offset_B_m, "centre_of_pressure_offset_B_m", 3)
        if offset.shape != (3,):
            raise ValueError(f"centre_of_pressure_offset_B_m must have shape (3,) in m, got shape {offset.shape}")
        normals = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=float)
        face_area = np.array([size[1] * size[2], size[0] * size[2], size[0] * size[1]])
        area = np.repeat(face_area, 2)
        cop = normals * (0.5 * size) + offset
        return cls(
            area_m2=area,
            normal_B=normals,
            centre_of_pressure_B_m=cop,
            specular=specular,
            diffuse=diffuse,
            drag_coefficient=drag_coefficient,
            residual_dipole_Am2=residual_dipole_Am2,
        )

    def with_panels(
        self,
        area_m2: ArrayLike,
        normal_B: ArrayLike,
        centre_of_pressure_B_m: ArrayLike,
        *,
        specular: ArrayLike = 0.0,
        diffuse: ArrayLike = 0.0,
        back_specular: ArrayLike | None = None,
        back_diffuse: ArrayLike | None = None,
        drag_coefficient: ArrayLike = DEFAULT_DRAG_COEFFICIENT,
    ) -> SurfaceModel:
        """This model plus thin two-sided panels (e.g. solar arrays), each added as two opposite plates.

        Each panel becomes a front plate (normal ``normal_B``) and a back
        plate (normal ``-normal_B``) with the same area and centre of
        pressure, appended after the existing plates (all fronts, then all
        backs). Shadowing of the body by the panels, or of the panels by the
        body, is not modelled.

        Parameters
        ----------
        area_m2 : array_like, shape (k,) or scalar
            Panel areas (one face) [m^2].
        normal_B : array_like, shape (k, 3) or (3,)
            Front-face normals in body axes [-].
        centre_of_pressure_B_m : array_like, shape (k, 3) or (3,)
            Panel centres relative to the centre of mass, body axes [m].
        specular : array_like, shape (k,) or scalar
            Specular fraction of the front faces (cells) [-].
        diffuse : array_like, shape (k,) or scalar
            Diffuse fraction of the front faces [-].
        back_specular : array_like, shape (k,) or scalar, optional
            Specular fraction of the back faces; the front's if None [-].
        back_diffuse : array_like, shape (k,) or scalar, optional
            Diffuse fraction of the back faces; the front's if None [-].
        drag_coefficient : array_like, shape (k,) or scalar
            Drag coefficient of both faces [-].

        Returns
        -------
        SurfaceModel
            A new model with ``n + 2 k`` plates and the same residual dipole.
        """
        normal = _plate_vectors(normal_B, "normal_B", None)
        k = normal.shape[0]
        cop = _plate_vectors(centre_of_pressure_B_m, "centre_of_pressure_B_m", k)
        area = _per_plate(area_m2, "area_m2", k)
        spec = _per_plate(specular, "specular", k)
        diff = _per_plate(diffuse, "diffuse", k)
        back_spec = spec if back_specular is None else _per_plate(back_specular, "back_specular", k)
        back_diff = diff if back_diffuse is None else _per_plate(back_diffuse, "back_diffuse", k)
        cd = _per_plate(drag_coefficient, "drag_coefficient", k)
        return SurfaceModel(
            area_m2=np.concatenate([self.area_m2, area, area]),
            normal_B=np.concatenate([self.normal_B, normal, -normal]),
            centre_of_pressure_B_m=np.concatenate([self.centre_of_pressure_B_m, cop, cop]),
            specular=np.concatenate([self.specular, spec, back_spec]),
            diffuse=np.concatenate([self.diffuse, diff, back_diff]),
            drag_coefficient=np.concatenate([self.drag_coefficient, cd, cd]),
            residual_dipole_Am2=self.residual_dipole_Am2,
        )

    def __eq__(self, other: Any) -> bool:
        if not isinstance(other, SurfaceModel):
            return NotImplemented
        return all(
            np.array_equal(getattr(self, name), getattr(other, name))
            for name in (
                "area_m2",
                "normal_B",
                "centre_of_pressure_B_m",
                "specular",
                "diffuse",
                "drag_coefficient",
                "residual_dipole_Am2",
            )
        )

    __hash__ = None  # type: ignore[assignment]

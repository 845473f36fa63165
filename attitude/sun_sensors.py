"""Sun sensors: coarse cosine cells (with a least-squares Sun vector) and a two-axis fine sensor.

Both meet the sensor protocol of :mod:`attitude.simulation.engine` (``name``,
``period`` [s], ``measure(t, truth, rng)``). They read ``truth.sun_B`` (unit
vector to the Sun in body axes) and ``truth.illumination`` (1 full Sun, 0
umbra), which the engine fills only when it flies an orbit environment;
without it they raise a ValueError saying so rather than inventing a Sun.
Everything inside is SI (rad, A); degrees, mA and percent appear only in the
``from_datasheet`` constructors, whose argument names carry the unit.

See docs/sensors.md ("Sun sensors") for the models and their references
(Markley and Crassidis 2014, sec. 4.4; Wertz 1978, sec. 6.1).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.rng import as_generator
from attitude.validation import as_float_array, check_direction, check_vector, describe, positive_scalar, scalar_time

__all__ = ["CUBE_NORMALS_B", "CoarseSunSensors", "FineSunSample", "FineSunSensor", "SunVectorEstimate"]

_DEG = np.pi / 180.0
_MILLIAMPERE = 1e-3  # [A]
# Rank test of the lit cells' normals: below this smallest singular value the least-squares
# Sun vector is not determined (the normals span a plane or a line).
_RANK_TOLERANCE = 1e-6


def _name(name: str) -> str:
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string, got {name!r}")
    return name


def _fov(value: ArrayLike, name: str, *, to_rad: float, unit: str, closed_at_90: bool) -> float:
    """A field-of-view half-angle in (0, 90 deg) (or (0, 90 deg]) converted to rad."""
    if value is None:
        raise ValueError(f"{name} is required: the half-angle of the field of view [{unit}], got None")
    half = positive_scalar(value, name, why="one half-angle of a conical field of view")
    right = 90.0 if unit == "deg" else np.pi / 2
    if half > right or (half == right and not closed_at_90):
        right_text = "90 deg" if unit == "deg" else "pi/2 rad"
        rule = f"(0, {right_text}]" if closed_at_90 else f"(0, {right_text})"
        raise ValueError(f"{name} must be in {rule} (a half-angle about the boresight or normal), got {half!r} {unit}")
    return half * to_rad


def _sun(truth: Any, who: str) -> tuple[NDArray[np.float64], float]:
    """``(sun_B, illumination)`` from the truth, or a ValueError when the run has no Sun."""
    sun_B = getattr(truth, "sun_B", None)
    illumination = getattr(truth, "illumination", None)
    if sun_B is None or illumination is None:
        raise ValueError(
            f"{who} needs truth.sun_B (the Sun direction in body axes) and truth.illumination (0 umbra .. 1 full "
            "Sun), got None: fly it with an environment (simulate(..., environment=OrbitEnvironment(...)))"
        )
    sun_B = check_direction(sun_B, "truth.sun_B")
    illum = float(as_float_array(illumination, "truth.illumination"))
    if not 0.0 <= illum <= 1.0:
        raise ValueError(f"truth.illumination must be in [0, 1], got {illum!r}")
    return sun_B, illum


# ---------------------------------------------------------------------------
# Coarse sun sensors


class SunVectorEstimate(NamedTuple):
    """The Sun direction estimated from coarse-sun-sensor currents.

    Parameters
    ----------
    sun_B : ndarray (3,)
        Unit vector to the Sun in body axes when ``valid``; the zero vector
        otherwise (it cannot be normalised, so it is never taken for a direction).
    valid : bool
        True when at least three lit cells with independent normals gave the
        estimate; False in eclipse or with too few lit cells.
    n_lit : int
        Number of cells above the lit threshold.
    covariance_B : ndarray (3, 3)
        First-order covariance of ``sun_B`` from the current noise (rank 2,
        perpendicular to ``sun_B``) [rad^2]; zeros when not ``valid``.
    """

    sun_B: NDArray[np.float64]
    valid: bool
    n_lit: int
    covariance_B: NDArray[np.float64]


def _opposite_pairs(
    normals: NDArray[np.float64], hemispheres: bool
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
    """Cells in opposite pairs (``n_j = -n_i`` to 1e-9) when each sees its hemisphere; the other cells.

    Returns ``(first, second, single)``: the pairs' cell indices and a mask of the cells in no pair.
    """
    n = normals.shape[0]
    single = np.ones(n, dtype=bool)
    first: list[int] = []
    second: list[int] = []
    if hemispheres:
        for i in range(n):
            for j in range(i + 1, n):
                if single[i] and single[j] and normals[i] @ normals[j] < -1.0 + 1e-9:
                    first.append(i)
                    second.append(j)
                    single[i] = single[j] = False
    return np.array(first, dtype=np.intp), np.array(second, dtype=np.intp), single


#: Normals of six cells on the faces of a cube, body axes: ``+x, -x, +y, -y, +z, -z``.
CUBE_NORMALS_B = np.vstack([np.eye(3), -np.eye(3)])[[0, 3, 1, 4, 2, 5]]
CUBE_NORMALS_B.flags.writeable = False


class CoarseSunSensors:
    """A set of coarse sun sensors (photodiodes) with cosine response, field of view and eclipse.

    Cell ``i`` with unit normal ``n_i`` (body axes) outputs

    .. math::

        I_i = I_{fs} (1 + k_i) \\big[\\lambda\\, \\max(0, n_i \\cdot s)\\, [\\theta_i \\le \\theta_{fov}]
              + a\\, \\max(0, -e \\cdot s)\\, \\max(0, n_i \\cdot e)\\, [\\psi_i \\le \\theta_{fov}]\\big]
              + \\sigma I_{fs}\\, w_i

    with ``s`` the Sun direction (``truth.sun_B``), ``lambda`` the
    illumination (1 full Sun, 0 umbra, in between in penumbra), ``theta_i``
    the angle between ``n_i`` and ``s``, ``I_fs`` the full-scale current,
    ``k_i`` the scale-factor errors, ``w_i ~ N(0, 1)`` and ``sigma`` the noise
    as a fraction of full scale (the cosine law of a flat detector, Markley
    and Crassidis 2014, sec. 4.4; Wertz 1978, sec. 6.1). The albedo term
    (``a`` the albedo fraction, ``e`` the nadir direction, ``psi_i`` its
    angle from ``n_i``) treats the Earth as a Lambertian point source at nadir
    lit as the sub-satellite point is: ``max(0, -e . s)``, the cosine of the
    Sun's zenith angle there (zero over the night side, so in eclipse). A
    crude bound that ignores the Earth's extent and the phase of the rest of
    its disk; it is used only when a nadir direction is given
    (:meth:`ideal_currents`), see docs/sensors.md. The noise is not clipped:
    a dark cell reads zero-mean noise, as a readout before its threshold.

    Parameters
    ----------
    normals_B : array_like (n, 3)
        Cell normals in body axes (each normalised here; n >= 1).
    period : float
        Sample period [s] (> 0).
    fov_half_angle_rad : float
        Half-angle of each cell's field of view about its normal [rad], in
        ``(0, pi/2]`` (a bare cosine cell sees its whole hemisphere: pi/2).
    full_scale_A : float
        Current at normal incidence in full Sun [A] (> 0).
    noise_fraction : float
        1-sigma noise per cell and sample as a fraction of full scale (>= 0).
    scale_factor : float or array_like (n,)
        Scale-factor error of each cell (dimensionless), each > -1; the
        estimator assumes nominal cells.
    albedo_fraction : float
        Earth-albedo current at normal incidence as a fraction of full scale
        (>= 0, 0: no albedo).
    lit_threshold : float, optional
        A cell counts as lit for the Sun estimate above this fraction of full
        scale; default ``max(5 noise_fraction, 1e-3)`` (a dark cell crosses
        5 sigma with probability 3e-7 per sample).
    name : str
        Sensor name (key of its samples in the measurements and the logs).

    Raises
    ------
    ValueError
        Normals of the wrong shape or zero, a missing or out-of-range field of
        view, a period, full scale, noise, albedo or threshold out of range,
        scale factors <= -1 or of the wrong length, or an empty name.
    """

    def __init__(
        self,
        normals_B: ArrayLike,
        *,
        period: float,
        fov_half_angle_rad: float | None,
        full_scale_A: float = 1e-3,
        noise_fraction: float = 0.0,
        scale_factor: ArrayLike = 0.0,
        albedo_fraction: float = 0.0,
        lit_threshold: float | None = None,
        name: str = "coarse_sun_sensors",
    ) -> None:
        normals = as_float_array(normals_B, "normals_B")
        if normals.ndim != 2 or normals.shape[1] != 3 or normals.shape[0] < 1:
            raise ValueError(f"normals_B must have shape (n, 3) with n >= 1 (one normal per cell), got {normals.shape}")
        lengths = np.linalg.norm(normals, axis=1)
        if np.any(lengths == 0.0):
            raise ValueError(f"normals_B must be non-zero vectors, got zero rows {np.flatnonzero(lengths == 0.0)}")
        self.normals_B = normals / lengths[:, None]
        self.normals_B.flags.writeable = False
        self.n_cells = normals.shape[0]
        self.period = positive_scalar(period, "period")
        self.fov_half_angle = _fov(fov_half_angle_rad, "fov_half_angle_rad", to_rad=1.0, unit="rad", closed_at_90=True)
        self.full_scale = positive_scalar(full_scale_A, "full_scale_A")
        self.noise = positive_scalar(noise_fraction, "noise_fraction", allow_zero=True)
        k = as_float_array(scale_factor, "scale_factor")
        if k.ndim > 1 or (k.ndim == 1 and k.size != self.n_cells):
            raise ValueError(f"scale_factor must be a scalar or have shape ({self.n_cells},), got shape {k.shape}")
        self.scale_factor = np.array(np.broadcast_to(k, (self.n_cells,)))
        if np.any(self.scale_factor <= -1.0):
            raise ValueError(f"scale_factor must be > -1 for every cell (a positive gain), got {self.scale_factor}")
        self.scale_factor.flags.writeable = False
        self.albedo_fraction = positive_scalar(albedo_fraction, "albedo_fraction", allow_zero=True)
        if lit_threshold is None:
            lit_threshold = max(5.0 * self.noise, 1e-3)
        self.lit_threshold = positive_scalar(lit_threshold, "lit_threshold")
        if self.lit_threshold >= 1.0:
            raise ValueError(f"lit_threshold must be below 1 (a fraction of full scale), got {self.lit_threshold!r}")
        self.name = _name(name)
        self._cos_fov = float(np.cos(self.fov_half_angle))
        self._pairs = _opposite_pairs(self.normals_B, self.fov_half_angle >= np.pi / 2)

    def __repr__(self) -> str:
        return (
            f"CoarseSunSensors(name={self.name!r}, cells={self.n_cells}, "
            f"fov_half_angle={np.degrees(self.fov_half_angle):.4g} deg, noise={self.noise:.3g} of full scale, "
            f"period={self.period:g} s)"
        )

    @classmethod
    def cube(cls, *, period: float, fov_half_angle_rad: float = np.pi / 2, **options: Any) -> CoarseSunSensors:
        """Six cells on the faces of a cube: normals ``+x, -x, +y, -y, +z, -z``.

        Parameters
        ----------
        period : float
            Sample period [s].
        fov_half_angle_rad : float
            Field-of-view half-angle of each cell [rad] (default pi/2).
        **options
            Further keyword arguments of the class (``full_scale_A``,
            ``noise_fraction``, ``scale_factor``, ``albedo_fraction``,
            ``lit_threshold``, ``name``).

        Returns
        -------
        CoarseSunSensors
        """
        return cls(CUBE_NORMALS_B, period=period, fov_half_angle_rad=fov_half_angle_rad, **options)

    @classmethod
    def pyramid(
        cls,
        *,
        period: float,
        tilt_rad: float,
        axis_B: ArrayLike = (0.0, 0.0, 1.0),
        n_cells: int = 4,
        fov_half_angle_rad: float = np.pi / 2,
        **options: Any,
    ) -> CoarseSunSensors:
        """``n_cells`` cells tilted by ``tilt_rad`` from ``axis_B``, evenly spread in azimuth.

        Parameters
        ----------
        period : float
            Sample period [s].
        tilt_rad : float
            Angle of each normal from the axis [rad], in ``(0, pi/2)``.
        axis_B : array_like (3,)
            Pyramid axis in body axes (normalised).
        n_cells : int
            Number of cells (>= 3).
        fov_half_angle_rad : float
            Field-of-view half-angle of each cell [rad].
        **options
            Further keyword arguments of the class.

        Returns
        -------
        CoarseSunSensors
        """
        tilt = positive_scalar(tilt_rad, "tilt_rad")
        if tilt >= np.pi / 2:
            raise ValueError(f"tilt_rad must be in (0, pi/2) [rad], got {tilt!r}")
        if not isinstance(n_cells, int | np.integer) or n_cells < 3:
            raise ValueError(f"n_cells must be an integer >= 3 (fewer cannot span 3 axes), got {n_cells!r}")
        axis = check_direction(axis_B, "axis_B")
        helper = np.zeros(3)
        helper[int(np.argmin(np.abs(axis)))] = 1.0
        u = np.cross(helper, axis)
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        az = 2.0 * np.pi * np.arange(n_cells) / n_cells
        normals = np.cos(tilt) * axis + np.sin(tilt) * (np.cos(az)[:, None] * u + np.sin(az)[:, None] * v)
        return cls(normals, period=period, fov_half_angle_rad=fov_half_angle_rad, **options)

    @classmethod
    def from_datasheet(
        cls,
        normals_B: ArrayLike,
        *,
        period: float,
        fov_half_angle_deg: float | None,
        full_scale_mA: float,
        noise_percent: float = 0.0,
        albedo_percent: float = 0.0,
        name: str = "coarse_sun_sensors",
    ) -> CoarseSunSensors:
        """Build the cells from datasheet figures in deg, mA and percent of full scale.

        Parameters
        ----------
        normals_B : array_like (n, 3)
            Cell normals in body axes.
        period : float
            Sample period [s].
        fov_half_angle_deg : float
            Field-of-view half-angle of each cell [deg], in ``(0, 90]``.
        full_scale_mA : float
            Short-circuit current at normal incidence in full Sun [mA].
        noise_percent : float
            1-sigma noise per cell [% of full scale].
        albedo_percent : float
            Albedo current at normal incidence [% of full scale].
        name : str
            Sensor name.

        Returns
        -------
        CoarseSunSensors
            The cells in SI units.
        """
        fov = _fov(fov_half_angle_deg, "fov_half_angle_deg", to_rad=_DEG, unit="deg", closed_at_90=True)
        return cls(
            normals_B,
            period=period,
            fov_half_angle_rad=fov,
            full_scale_A=positive_scalar(full_scale_mA, "full_scale_mA") * _MILLIAMPERE,
            noise_fraction=positive_scalar(noise_percent, "noise_percent", allow_zero=True) / 100.0,
            albedo_fraction=positive_scalar(albedo_percent, "albedo_percent", allow_zero=True) / 100.0,
            name=name,
        )

    def _response(self, direction_B: NDArray[np.float64]) -> NDArray[np.float64]:
        """``max(0, n_i . d)`` inside the field of view, 0 outside, for directions (..., 3) -> (..., n)."""
        cosines = direction_B @ self.normals_B.T
        return np.where(cosines >= self._cos_fov, np.maximum(cosines, 0.0), 0.0)

    def ideal_currents(
        self, sun_B: ArrayLike, illumination: ArrayLike = 1.0, nadir_B: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        """Noise-free currents [A] for Sun directions (..., 3) and illuminations (...).

        Parameters
        ----------
        sun_B : array_like (3,) or (..., 3)
            Sun direction(s) in body axes (normalised here).
        illumination : float or array_like (...)
            Fraction of the solar disk seen, in [0, 1].
        nadir_B : array_like (3,) or (..., 3), optional
            Direction to the Earth's centre in body axes; with it, the albedo
            term is added (``albedo_fraction`` > 0).

        Returns
        -------
        ndarray (..., n)
            One current per cell [A].
        """
        s = as_float_array(sun_B, "sun_B")
        if s.shape[-1:] != (3,):
            raise ValueError(f"sun_B must have shape (3,) or (..., 3), got shape {s.shape}")
        norms = np.linalg.norm(s, axis=-1, keepdims=True)
        if np.any(norms == 0.0):
            raise ValueError("sun_B must be non-zero vectors (they are normalised)")
        lam = as_float_array(illumination, "illumination")
        if np.any((lam < 0.0) | (lam > 1.0)):
            raise ValueError(f"illumination must be in [0, 1], got {describe(lam)}")
        out = lam[..., None] * self._response(s / norms)
        if nadir_B is not None and self.albedo_fraction > 0.0:
            e = as_float_array(nadir_B, "nadir_B")
            if e.shape[-1:] != (3,) or np.any(np.linalg.norm(e, axis=-1) == 0.0):
                raise ValueError(f"nadir_B must be non-zero vectors of shape (..., 3), got shape {e.shape}")
            e = e / np.linalg.norm(e, axis=-1, keepdims=True)
            # The sub-satellite point's Sun elevation: -e . s is the cosine of its solar zenith angle.
            day = np.maximum(0.0, -np.sum(e * (s / norms), axis=-1))
            out = out + self.albedo_fraction * day[..., None] * self._response(e)
        return self.full_scale * (1.0 + self.scale_factor) * out

    def measure(self, t: float, truth: Any, rng: Any = None) -> NDArray[np.float64]:
        """Cell currents (n,) [A] at ``t`` [s]: zero-mean noise only in umbra.

        Draws ``n`` standard normals from ``rng`` per sample (also when the
        noise is 0). Albedo is added only when ``truth`` carries a
        ``nadir_B`` (the engine's :class:`Truth` does when it flies an orbit
        environment).

        Parameters
        ----------
        t : float
            Time [s] (the model is stationary; kept for the sensor protocol).
        truth : attitude.simulation.protocols.Truth
            Anything with ``sun_B`` (3,) and ``illumination`` in [0, 1].
        rng : Generator, int or None
            Random source.

        Returns
        -------
        ndarray (n,)
            The currents [A]; :meth:`sun_vector` turns them into a Sun direction.

        Raises
        ------
        ValueError
            If ``truth.sun_B`` or ``truth.illumination`` is None (a run
            without an orbit environment) or invalid.
        """
        scalar_time(t, "t")
        sun_B, illum = _sun(truth, f"coarse sun sensors {self.name!r}")
        ideal = self.ideal_currents(sun_B, illum, getattr(truth, "nadir_B", None))
        return ideal + self.noise * self.full_scale * as_generator(rng).standard_normal(self.n_cells)

    def sun_vector(self, currents_A: ArrayLike) -> SunVectorEstimate:
        """Least-squares Sun direction from the cells' currents.

        Two kinds of rows, with ``y`` the currents over full scale:

        - **opposite pairs** (cells ``i``, ``j`` with ``n_j = -n_i``, when the
          cells see their whole hemisphere, ``fov_half_angle = pi/2``): when
          exactly one is lit, that cell alone (``y_i = lambda n_i . s``,
          variance ``sigma^2``: the dark one reads noise only); otherwise
          the difference ``y_i - y_j = lambda n_i . s``, exact lit or dark
          since ``max(0, c) - max(0, -c) = c``, variance ``2 sigma^2``. A
          cube of six cells thus measures every component of the Sun vector
          wherever the Sun is;
        - **other cells**, when lit (above ``lit_threshold``):
          ``y_k = lambda n_k . s``, variance ``sigma^2`` (a dark cell only
          says ``n_k . s <= 0``, which is not a linear measurement).

        The weighted least squares ``x = M^{-1} sum_rows w n y`` with
        ``M = sum_rows w n n^T``
        estimates ``lambda s``, and ``s = x / |x|`` (Markley and Crassidis
        2014, sec. 4.4). ``w`` is 1 for a single cell, 1/2 for a difference.
        Exact without noise inside the cells' field of view.
        Not ``valid`` in eclipse (no cell lit), or when the rows do not span
        three dimensions (a smallest eigenvalue of ``M`` below 1e-12). The
        covariance is ``(I - s s^T) sigma^2 M^{-1} (I - s s^T) / |x|^2``
        (first order in the noise ``sigma``, full-scale units).

        Parameters
        ----------
        currents_A : array_like (n,)
            One current per cell [A] (e.g. from :meth:`measure`).

        Returns
        -------
        SunVectorEstimate
            ``(sun_B, valid, n_lit, covariance_B)``.
        """
        y = check_vector(currents_A, "currents_A", self.n_cells)
        if y.shape != (self.n_cells,):
            raise ValueError(f"currents_A must have shape ({self.n_cells},), got shape {y.shape}")
        sun_B, valid, n_lit, cov = self.sun_vectors(y[None])
        return SunVectorEstimate(sun_B[0], bool(valid[0]), int(n_lit[0]), cov[0])

    def sun_vectors(
        self, currents_A: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.int64], NDArray[np.float64]]:
        """:meth:`sun_vector` for many samples at once: currents (..., n) in, the estimates' arrays out.

        Parameters
        ----------
        currents_A : array_like (..., n)
            One current per cell [A] for each sample.

        Returns
        -------
        sun_B : ndarray (..., 3)
            Unit Sun vectors in body axes (zeros where not valid).
        valid : ndarray (...) of bool
            A cell lit and rows spanning three dimensions.
        n_lit : ndarray (...) of int
            Cells above the lit threshold.
        covariance_B : ndarray (..., 3, 3)
            First-order covariances [rad^2] (zeros where not valid).
        """
        y = as_float_array(currents_A, "currents_A")
        if y.shape[-1:] != (self.n_cells,):
            raise ValueError(f"currents_A must have shape (..., {self.n_cells}), got shape {y.shape}")
        y = y / self.full_scale
        lit = y > self.lit_threshold
        n_lit = np.count_nonzero(lit, axis=-1)
        first, second, single = self._pairs
        # Cells in no pair: a row each when lit, weight 1.
        w = np.where(single, lit, False).astype(np.float64)
        normal_matrix = np.einsum("...c,ci,cj->...ij", w, self.normals_B, self.normals_B)
        rhs = (w * y) @ self.normals_B
        # A pair: the lit cell alone when exactly one is lit (weight 1; the dark one reads noise only), else
        # the difference (weight 1/2: its noise is 2 sigma^2), both as rows along the first normal n_i.
        lit_i, lit_j = lit[..., first], lit[..., second]
        y_i, y_j = y[..., first], y[..., second]
        value = np.where(lit_i & ~lit_j, y_i, np.where(lit_j & ~lit_i, -y_j, y_i - y_j))
        weight = np.where(lit_i ^ lit_j, 1.0, 0.5)
        pair_normals = self.normals_B[first]
        normal_matrix = normal_matrix + np.einsum("...k,ki,kj->...ij", weight, pair_normals, pair_normals)
        rhs = rhs + (weight * value) @ pair_normals
        smallest = np.linalg.eigvalsh(normal_matrix)[..., 0]
        valid = (n_lit >= 1) & (smallest >= _RANK_TOLERANCE**2)
        safe = np.where(valid[..., None, None], normal_matrix, np.eye(3))
        x = np.linalg.solve(safe, rhs[..., None])[..., 0]
        size = np.linalg.norm(x, axis=-1)
        valid &= size > 0.0
        size = np.where(valid, size, 1.0)
        sun = np.where(valid[..., None], x / size[..., None], 0.0)
        perp = np.eye(3) - sun[..., :, None] * sun[..., None, :]
        cov = self.noise**2 * perp @ np.linalg.inv(safe) @ perp / size[..., None, None] ** 2
        cov = np.where(valid[..., None, None], cov, 0.0)
        return sun, valid, n_lit, cov


# ---------------------------------------------------------------------------
# Fine sun sensor


class FineSunSample(NamedTuple):
    """One fine-sun-sensor sample.

    Parameters
    ----------
    alpha : float
        Sun angle in the sensor x-z plane, ``atan2(s_x, s_z)`` [rad].
    beta : float
        Sun angle in the sensor y-z plane, ``atan2(s_y, s_z)`` [rad].
    sun_B : ndarray (3,)
        The measured unit Sun vector in body axes.
    """

    alpha: float
    beta: float
    sun_B: NDArray[np.float64]


class FineSunSensor:
    """A two-axis fine sun sensor: two Sun angles with noise, a conical field of view, eclipse.

    In the sensor frame (axes ``x``, ``y``, boresight ``z``, columns of
    ``C_BS`` in body axes) the Sun ``s_S = C_BS^T s_B`` gives the two angles

    .. math::

        \\alpha = \\operatorname{atan2}(s_x, s_z) + b_\\alpha + \\sigma w_1, \\qquad
        \\beta = \\operatorname{atan2}(s_y, s_z) + b_\\beta + \\sigma w_2

    (``tan alpha`` and ``tan beta`` are the spot's coordinates on the
    detector over the mask height; Markley and Crassidis 2014, sec. 4.4;
    Wertz 1978, sec. 6.1) and the unit vector
    ``s_S = (tan alpha, tan beta, 1) / |.|``. No sample (None) when the Sun
    is farther than the field-of-view half-angle from the boresight or the
    illumination is below ``illumination_min`` (the detector needs most of
    the disk: a partial disk shifts the spot's centroid).

    Parameters
    ----------
    sigma_rad : float
        1-sigma noise on each angle [rad] (>= 0).
    period : float
        Sample period [s] (> 0).
    fov_half_angle_rad : float
        Half-angle of the conical field of view [rad], in ``(0, pi/2)``.
    boresight_B : array_like (3,)
        Boresight in body axes (normalised).
    x_axis_B : array_like (3,), optional
        Direction of the sensor x axis in body axes (its part perpendicular
        to the boresight is used); default: a fixed perpendicular.
    bias_rad : float or array_like (2,)
        Constant bias on ``(alpha, beta)`` [rad].
    illumination_min : float
        Illumination below which the sensor reports nothing, in ``(0, 1]``.
    name : str
        Sensor name.

    Raises
    ------
    ValueError
        A missing field of view or one outside ``(0, pi/2)``, a negative
        noise, a period <= 0, a zero boresight or an x axis along it, a bias
        of the wrong shape, an illumination threshold outside ``(0, 1]`` or an
        empty name.
    """

    def __init__(
        self,
        sigma_rad: float,
        *,
        period: float,
        fov_half_angle_rad: float | None,
        boresight_B: ArrayLike = (0.0, 0.0, 1.0),
        x_axis_B: ArrayLike | None = None,
        bias_rad: ArrayLike = 0.0,
        illumination_min: float = 0.9,
        name: str = "fine_sun_sensor",
    ) -> None:
        self.sigma = positive_scalar(sigma_rad, "sigma_rad", allow_zero=True)
        self.period = positive_scalar(period, "period")
        self.fov_half_angle = _fov(fov_half_angle_rad, "fov_half_angle_rad", to_rad=1.0, unit="rad", closed_at_90=False)
        z = check_direction(boresight_B, "boresight_B")
        if x_axis_B is None:
            helper = np.zeros(3)
            helper[int(np.argmin(np.abs(z)))] = 1.0
            x = np.cross(helper, z)
        else:
            x_in = check_direction(x_axis_B, "x_axis_B")
            x = x_in - (x_in @ z) * z
            if np.linalg.norm(x) < 1e-6:
                raise ValueError(f"x_axis_B must not be along boresight_B, got {describe(x_in)} and {describe(z)}")
        x = x / np.linalg.norm(x)
        #: Sensor axes in body components (columns); the third is the boresight.
        self.C_BS = np.column_stack([x, np.cross(z, x), z])
        self.C_BS.flags.writeable = False
        b = as_float_array(bias_rad, "bias_rad")
        if b.ndim > 1 or (b.ndim == 1 and b.size != 2):
            raise ValueError(f"bias_rad must be a scalar or have shape (2,) (alpha, beta), got shape {b.shape}")
        self.bias = np.array(np.broadcast_to(b, (2,)))
        self.bias.flags.writeable = False
        self.illumination_min = positive_scalar(illumination_min, "illumination_min")
        if self.illumination_min > 1.0:
            raise ValueError(f"illumination_min must be in (0, 1], got {self.illumination_min!r}")
        self.name = _name(name)

    def __repr__(self) -> str:
        return (
            f"FineSunSensor(name={self.name!r}, sigma={np.degrees(self.sigma):.3g} deg, "
            f"fov_half_angle={np.degrees(self.fov_half_angle):.4g} deg, period={self.period:g} s)"
        )

    @classmethod
    def from_datasheet(
        cls,
        *,
        accuracy_deg: float,
        accuracy_sigma_level: float,
        period: float,
        fov_half_angle_deg: float | None,
        boresight_B: ArrayLike = (0.0, 0.0, 1.0),
        x_axis_B: ArrayLike | None = None,
        bias_deg: ArrayLike = 0.0,
        illumination_min: float = 0.9,
        name: str = "fine_sun_sensor",
    ) -> FineSunSensor:
        """Build the sensor from an accuracy [deg] at a stated sigma level and a field of view [deg].

        Datasheets quote the accuracy at 1 sigma or 3 sigma; the level is
        required so that a 3-sigma figure is never read as 1 sigma
        (``sigma = accuracy_deg / accuracy_sigma_level``).

        Parameters
        ----------
        accuracy_deg : float
            Angle accuracy per axis [deg] (>= 0).
        accuracy_sigma_level : float
            How many sigma ``accuracy_deg`` is (1 or 3 on most datasheets; > 0).
        period : float
            Sample period [s].
        fov_half_angle_deg : float
            Field-of-view half-angle [deg], in ``(0, 90)``.
        boresight_B : array_like (3,)
            Boresight in body axes.
        x_axis_B : array_like (3,), optional
            Sensor x axis in body axes.
        bias_deg : float or array_like (2,)
            Constant bias on ``(alpha, beta)`` [deg].
        illumination_min : float
            Illumination below which the sensor reports nothing.
        name : str
            Sensor name.

        Returns
        -------
        FineSunSensor
            The sensor in SI units.
        """
        accuracy = positive_scalar(accuracy_deg, "accuracy_deg", allow_zero=True)
        level = positive_scalar(accuracy_sigma_level, "accuracy_sigma_level")
        fov = _fov(fov_half_angle_deg, "fov_half_angle_deg", to_rad=_DEG, unit="deg", closed_at_90=False)
        return cls(
            accuracy / level * _DEG,
            period=period,
            fov_half_angle_rad=fov,
            boresight_B=boresight_B,
            x_axis_B=x_axis_B,
            bias_rad=as_float_array(bias_deg, "bias_deg") * _DEG,
            illumination_min=illumination_min,
            name=name,
        )

    @staticmethod
    def angles_to_vector(alpha: float, beta: float) -> NDArray[np.float64]:
        """Unit Sun vector in sensor axes ``(tan alpha, tan beta, 1) / |.|`` from the two angles [rad].

        Parameters
        ----------
        alpha : float
            Angle in the x-z plane [rad], in ``(-pi/2, pi/2)``.
        beta : float
            Angle in the y-z plane [rad], in ``(-pi/2, pi/2)``.

        Returns
        -------
        ndarray (3,)
        """
        v = np.array([np.tan(alpha), np.tan(beta), 1.0])
        return v / np.linalg.norm(v)

    def in_view(self, sun_B: ArrayLike) -> bool:
        """True when the Sun direction is within the field-of-view half-angle of the boresight.

        Parameters
        ----------
        sun_B : array_like (3,)
            Sun direction in body axes (normalised here).

        Returns
        -------
        bool
        """
        s = check_direction(sun_B, "sun_B")
        return bool(s @ self.C_BS[:, 2] >= np.cos(self.fov_half_angle))

    def sample(self, t: float, truth: Any, rng: Any = None) -> FineSunSample | None:
        """The two angles and the unit vector at ``t`` [s], or None outside the field of view or in eclipse.

        Draws two standard normals from ``rng`` per call, also when it
        returns None (the stream does not depend on visibility).

        Parameters
        ----------
        t : float
            Time [s].
        truth : attitude.simulation.protocols.Truth
            Anything with ``sun_B`` (3,) and ``illumination`` in [0, 1].
        rng : Generator, int or None
            Random source.

        Returns
        -------
        FineSunSample or None
            ``(alpha, beta, sun_B)``; None when the Sun is outside the field of
            view or ``truth.illumination < illumination_min``.

        Raises
        ------
        ValueError
            If ``truth.sun_B`` or ``truth.illumination`` is None (a run
            without an orbit environment) or invalid.
        """
        scalar_time(t, "t")
        sun_B, illum = _sun(truth, f"fine sun sensor {self.name!r}")
        w = as_generator(rng).standard_normal(2)
        if illum < self.illumination_min or not self.in_view(sun_B):
            return None
        angles, vector_B = self._measured(sun_B, w)
        return FineSunSample(float(angles[0]), float(angles[1]), vector_B)

    def _measured(
        self, sun_B: NDArray[np.float64], normals: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The angles (..., 2) [rad] and unit vectors (..., 3) (body axes) for unit Sun vectors and normals (..., 2)."""
        s = sun_B @ self.C_BS  # sensor axes: C_BS^T s_B
        angles = np.arctan2(s[..., :2], s[..., 2:3]) + self.bias + self.sigma * normals
        v = np.concatenate([np.tan(angles), np.ones((*angles.shape[:-1], 1))], axis=-1)
        return angles, (v / np.linalg.norm(v, axis=-1, keepdims=True)) @ self.C_BS.T

    def sample_batch(self, sun_B: ArrayLike, illumination: ArrayLike, normals: ArrayLike) -> NDArray[np.float64]:
        """Many samples at once: run ``i`` is :meth:`sample`'s vector with standard normals ``normals[i]``.

        Parameters
        ----------
        sun_B : array_like (..., 3)
            Sun directions in body axes (normalised here).
        illumination : array_like (...)
            Fractions of the solar disk seen, in [0, 1].
        normals : array_like (..., 2)
            Standard normals, in the order of ``gen.standard_normal(2)``.

        Returns
        -------
        ndarray (..., 3)
            Measured unit Sun vectors in body axes; NaN rows outside the field
            of view or below ``illumination_min``.
        """
        s = as_float_array(sun_B, "sun_B")
        if s.shape[-1:] != (3,) or np.any(np.linalg.norm(s, axis=-1) == 0.0):
            raise ValueError(f"sun_B must be non-zero vectors of shape (..., 3), got shape {s.shape}")
        s = s / np.linalg.norm(s, axis=-1, keepdims=True)
        lam = np.broadcast_to(as_float_array(illumination, "illumination"), s.shape[:-1])
        w = as_float_array(normals, "normals")
        if w.shape != (*s.shape[:-1], 2):
            raise ValueError(f"normals must have shape {(*s.shape[:-1], 2)}, got shape {w.shape}")
        seen = (lam >= self.illumination_min) & (s @ self.C_BS[:, 2] >= np.cos(self.fov_half_angle))
        _, vector_B = self._measured(s, w)
        return np.where(seen[..., None], vector_B, np.nan)

    def measure(self, t: float, truth: Any, rng: Any = None) -> NDArray[np.float64] | None:
        """The measured unit Sun vector (3,) in body axes, or None (outside the field of view, eclipse).

        Parameters
        ----------
        t : float
            Time [s].
        truth : attitude.simulation.protocols.Truth
            Anything with ``sun_B`` (3,) and ``illumination`` in [0, 1].
        rng : Generator, int or None
            Random source.

        Returns
        -------
        ndarray (3,) or None
            ``sample(t, truth, rng).sun_B``; :meth:`sample` also gives the angles.
        """
        out = self.sample(t, truth, rng)
        return None if out is None else out.sun_B

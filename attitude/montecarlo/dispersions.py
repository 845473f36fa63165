"""Monte Carlo dispersions: how one run's parameters are drawn, and the seeds they are drawn from.

A dispersion is an object with ``sample(rng)`` returning one value (a float
or an array, SI units), and ``columns(name)`` / ``flatten(value)`` naming and
listing the scalar table columns the value occupies (``inertia.xx``,
``initial_rate.x`` ...). The built-in ones:

=========================  ==================================================
:class:`Normal`            ``mean + sigma N(0, 1)`` per entry
:class:`Uniform`           uniform on ``[low, high]`` per entry
:class:`InertiaDispersion` physically valid inertia tensors (see its docstring)
:class:`RandomAttitude`    attitude uniformly distributed on SO(3)
:class:`AttitudeDispersion` small rotation about a nominal attitude, per axis
:class:`Misalignment`      small rotation vector [rad], per axis
:class:`RelativeScale`     a positive factor ``1 + d`` (e.g. the drag scale)
=========================  ==================================================

Seeds
-----
Run ``i`` of a campaign with master seed ``s`` owns the stream
``numpy.random.SeedSequence(s).spawn(runs)[i]``, i.e. the seed sequence with
``spawn_key = (i,)`` (:func:`run_seed_sequence`); it depends only on ``s``
and ``i``, never on the number of runs, the workers or the order in which
runs finish, so a campaign is bit-for-bit reproducible and extending it
from 1,000 to 2,000 runs keeps the first 1,000. Below it:

* each dispersion draws from its own child ``spawn_key = (i, 0, crc32(name))``
  (:func:`draw_parameters`): adding, removing or reordering a dispersion does
  not change the values drawn for the others (common random numbers when two
  designs are compared);
* the scenario gets a generator on ``spawn_key = (i, 1)`` for its own noise
  (sensor noise ...) (:func:`scenario_generator`, :func:`scenario_spawn_key`).

The campaign's table holds, on each row, the master seed (``seed``) and the
spawn key of that run's scenario generator (``spawn_key``, e.g. ``(12, 1)``):
``numpy.random.default_rng(numpy.random.SeedSequence(seed,
spawn_key=(12, 1)))`` is the generator run 12 received, and the row's
dispersed values are the draws from ``spawn_key = (12, 0, crc32(name))``.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.rigid_body import REALISABILITY_TOLERANCE, RigidBody
from attitude.validation import as_float_array, check_positive, describe

__all__ = [
    "AttitudeDispersion",
    "Dispersion",
    "InertiaDispersion",
    "Misalignment",
    "Normal",
    "RandomAttitude",
    "RelativeScale",
    "Uniform",
    "dispersions_from_config",
    "draw_parameters",
    "flatten_parameters",
    "parameter_columns",
    "run_seed_sequence",
    "scenario_generator",
    "scenario_spawn_key",
]


# ---------------------------------------------------------------------------
# Seeds


def _check_seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def run_seed_sequence(seed: int, run: int) -> np.random.SeedSequence:
    """The stream of run ``run``: ``SeedSequence(seed).spawn(runs)[run]`` (``spawn_key = (run,)``).

    Parameters
    ----------
    seed : int
        The campaign seed.
    run : int
        Run index, >= 0.
    """
    return np.random.SeedSequence(_check_seed(seed), spawn_key=(int(run),))


def _name_key(name: str) -> int:
    return zlib.crc32(name.encode("utf-8"))


def scenario_spawn_key(run: int) -> tuple[int, int]:
    """The spawn key of the generator handed to the scenario of run ``run``: ``(run, 1)``.

    With the campaign seed it rebuilds that generator with numpy alone,
    ``numpy.random.default_rng(numpy.random.SeedSequence(seed, spawn_key=key))``
    (the ``seed`` and ``spawn_key`` columns of the campaign's table).

    Parameters
    ----------
    run : int
        Run index, >= 0.
    """
    if isinstance(run, bool) or not isinstance(run, (int, np.integer)) or run < 0:
        raise ValueError(f"run must be a non-negative integer, got {run!r}")
    return (int(run), 1)


def scenario_generator(seed: int, run: int) -> np.random.Generator:
    """The generator handed to the scenario of run ``run`` (``spawn_key = (run, 1)``: :func:`scenario_spawn_key`).

    Parameters
    ----------
    seed : int
        The campaign seed.
    run : int
        Run index, >= 0.
    """
    return np.random.default_rng(np.random.SeedSequence(_check_seed(seed), spawn_key=scenario_spawn_key(run)))


def draw_parameters(dispersions: Mapping[str, Dispersion], seed: int, run: int) -> dict[str, Any]:
    """The dispersed parameters of run ``run``: ``{name: value}``, each from its own stream (module docstring).

    Parameters
    ----------
    dispersions : mapping of str to Dispersion
        The campaign's dispersed parameters by name.
    seed : int
        The campaign seed.
    run : int
        Run index, >= 0.
    """
    seed = _check_seed(seed)
    out = {}
    for name, dispersion in dispersions.items():
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(int(run), 0, _name_key(name))))
        out[name] = dispersion.sample(rng)
    return out


def parameter_columns(dispersions: Mapping[str, Dispersion]) -> list[str]:
    """Table column names of the dispersed parameters, in the order of ``dispersions``.

    Parameters
    ----------
    dispersions : mapping of str to Dispersion
        The campaign's dispersed parameters by name.
    """
    return [c for name, d in dispersions.items() for c in d.columns(name)]


def flatten_parameters(dispersions: Mapping[str, Dispersion], params: Mapping[str, Any]) -> list[float]:
    """One run's parameters as the scalar values of :func:`parameter_columns`.

    Parameters
    ----------
    dispersions : mapping of str to Dispersion
        The campaign's dispersed parameters by name.
    params : mapping of str to value
        One run's parameters, as returned by :func:`draw_parameters`.
    """
    return [float(v) for name, d in dispersions.items() for v in d.flatten(params[name])]


# ---------------------------------------------------------------------------
# Dispersions

_VECTOR_NAMES = {3: ("x", "y", "z"), 4: ("w", "x", "y", "z")}


class Dispersion:
    """Base class: one value per run, drawn by :meth:`sample`.

    Subclasses define ``shape`` (the value's shape, ``()`` for a scalar),
    :meth:`sample` and ``__repr__`` (which must describe every setting: it is
    part of the campaign fingerprint that guards checkpoint resumption).
    """

    shape: tuple[int, ...] = ()

    def sample(self, rng: np.random.Generator) -> Any:  # pragma: no cover - abstract
        """Draw one value of the parameter.

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        raise NotImplementedError

    def columns(self, name: str) -> list[str]:
        """Column names of this value in the table: ``name``, ``name.x`` ..., ``name[i]``.

        Parameters
        ----------
        name : str
            The parameter's name in the campaign.
        """
        if self.shape == ():
            return [name]
        if len(self.shape) == 1 and self.shape[0] in _VECTOR_NAMES:
            return [f"{name}.{c}" for c in _VECTOR_NAMES[self.shape[0]]]
        return [f"{name}[{','.join(map(str, idx))}]" for idx in np.ndindex(*self.shape)]

    def flatten(self, value: Any) -> list[float]:
        """The scalar column values of ``value`` (same order as :meth:`columns`).

        Parameters
        ----------
        value : scalar or array_like
            One value drawn by :meth:`sample`.
        """
        return [float(v) for v in np.asarray(value, dtype=float).reshape(-1)]


def _two_sided(
    sigma: Any, half_width: Any, what: str, names: tuple[str, str] = ("sigma", "half_width")
) -> tuple[str, NDArray[np.float64]]:
    if (sigma is None) == (half_width is None):
        raise ValueError(f"{what}: give exactly one of {names[0]} (normal) or {names[1]} (uniform on [-h, h])")
    if sigma is not None:
        return "normal", check_positive(sigma, names[0], allow_zero=True)
    return "uniform", check_positive(half_width, names[1], allow_zero=True)


def _draw(rng: np.random.Generator, distribution: str, scale: NDArray, shape: tuple[int, ...]) -> NDArray:
    if distribution == "normal":
        return scale * rng.standard_normal(shape)
    return scale * rng.uniform(-1.0, 1.0, shape)


class Normal(Dispersion):
    """Normal dispersion ``mean + sigma N(0, 1)`` (entries independent).

    Parameters
    ----------
    mean : float or array_like
        Mean (its unit is the parameter's, SI).
    sigma : float or array_like
        Standard deviation (>= 0), broadcast against ``mean``.
    """

    def __init__(self, mean: ArrayLike, sigma: ArrayLike) -> None:
        self.mean = as_float_array(mean, "mean")
        self.sigma = check_positive(sigma, "sigma", allow_zero=True)
        try:
            self.shape = np.broadcast_shapes(self.mean.shape, self.sigma.shape)
        except ValueError as exc:
            raise ValueError(
                f"sigma shape {self.sigma.shape} does not broadcast to mean shape {self.mean.shape}"
            ) from exc

    def __repr__(self) -> str:
        return f"Normal(mean={self.mean.tolist()!r}, sigma={self.sigma.tolist()!r})"

    def sample(self, rng: np.random.Generator) -> Any:
        """Draw one value from the normal distribution.

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        value = self.mean + self.sigma * rng.standard_normal(self.shape)
        return float(value) if self.shape == () else value


class Uniform(Dispersion):
    """Uniform dispersion on ``[low, high]`` (entries independent).

    Parameters
    ----------
    low, high : float or array_like
        Bounds (``low <= high``), broadcast together.
    """

    def __init__(self, low: ArrayLike, high: ArrayLike) -> None:
        self.low = as_float_array(low, "low")
        self.high = as_float_array(high, "high")
        try:
            self.shape = np.broadcast_shapes(self.low.shape, self.high.shape)
        except ValueError as exc:
            raise ValueError(f"low shape {self.low.shape} and high shape {self.high.shape} do not broadcast") from exc
        if np.any(self.high < self.low):
            raise ValueError(f"high must be >= low, got low={describe(self.low)} and high={describe(self.high)}")

    @classmethod
    def centered(cls, center: ArrayLike, half_width: ArrayLike) -> Uniform:
        """Uniform on ``[center - half_width, center + half_width]``.

        Parameters
        ----------
        center : array_like
            Centre of the interval (same units as the parameter).
        half_width : array_like
            Half width of the interval, >= 0 (same units).
        """
        c = as_float_array(center, "center")
        h = check_positive(half_width, "half_width", allow_zero=True)
        return cls(c - h, c + h)

    def __repr__(self) -> str:
        return f"Uniform(low={self.low.tolist()!r}, high={self.high.tolist()!r})"

    def sample(self, rng: np.random.Generator) -> Any:
        """Draw one value from the uniform distribution.

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        value = self.low + (self.high - self.low) * rng.random(self.shape)
        return float(value) if self.shape == () else value


class Misalignment(Dispersion):
    """A small mounting misalignment: a rotation vector [rad], each axis drawn independently.

    Parameters
    ----------
    sigma : float or array_like (3,), optional
        Standard deviation per axis [rad] (normal).
    half_width : float or array_like (3,), optional
        Half-width per axis [rad] (uniform on ``[-h, h]``). Exactly one of
        ``sigma`` and ``half_width``.
    """

    shape = (3,)

    def __init__(self, sigma: ArrayLike | None = None, half_width: ArrayLike | None = None) -> None:
        self.distribution, scale = _two_sided(sigma, half_width, "Misalignment")
        if scale.shape not in ((), (3,)):
            raise ValueError(f"the misalignment scale must be a scalar or one value per axis (3,), got {scale.shape}")
        self.scale = np.broadcast_to(scale, (3,)).copy()

    def __repr__(self) -> str:
        return f"Misalignment({self.distribution}, scale_rad={self.scale.tolist()!r})"

    def sample(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """Draw one misalignment rotation vector [rad].

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        return _draw(rng, self.distribution, self.scale, (3,))


class RelativeScale(Dispersion):
    """A factor ``1 + d`` about 1 that stays non-negative (e.g. the scale on every drag coefficient).

    ``d`` is normal (``sigma``) or uniform on ``[-h, h]`` (``half_width``),
    relative (0.1 = 10 %). A normal draw below ``-1`` (a negative factor, which
    has no physical meaning) is **rejected and redrawn**, so the distribution
    is the requested one truncated at 0; that changes nothing unless
    ``sigma`` is a sizeable fraction of 1 (at 30 %, one draw in 3,400 is
    redrawn). A uniform half-width must be at most 1.

    Parameters
    ----------
    sigma : float, optional
        Relative standard deviation (normal), >= 0.
    half_width : float, optional
        Relative half-width (uniform), in [0, 1]. Exactly one of ``sigma`` and ``half_width``.
    max_tries : int
        Draws before giving up (default 1000).
    """

    shape = ()

    def __init__(self, sigma: float | None = None, half_width: float | None = None, *, max_tries: int = 1000) -> None:
        self.distribution, scale = _two_sided(sigma, half_width, "RelativeScale")
        if scale.ndim != 0:
            raise ValueError(f"the relative scale must be one value, got shape {scale.shape}")
        self.scale = float(scale)
        if self.distribution == "uniform" and self.scale > 1.0:
            raise ValueError(f"half_width must be at most 1 (the factor must stay >= 0), got {self.scale!r}")
        if isinstance(max_tries, bool) or not isinstance(max_tries, int) or max_tries < 1:
            raise ValueError(f"max_tries must be a positive integer, got {max_tries!r}")
        self.max_tries = max_tries

    def __repr__(self) -> str:
        return f"RelativeScale({self.distribution}, relative={self.scale!r})"

    def sample(self, rng: np.random.Generator) -> float:
        """Draw one factor, >= 0.

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        for _ in range(self.max_tries):
            value = 1.0 + float(_draw(rng, self.distribution, np.asarray(self.scale), ()))
            if value >= 0.0:
                return value
        raise ValueError(
            f"RelativeScale: no non-negative factor in {self.max_tries} draws; the relative dispersion "
            f"{self.scale!r} is too wide"
        )


class RandomAttitude(Dispersion):
    """An attitude ``q_BN`` uniformly distributed on SO(3) (normalised 4-D Gaussian; Haar measure)."""

    shape = (4,)

    def __repr__(self) -> str:
        return "RandomAttitude()"

    def sample(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """Draw one attitude ``q_BN``, uniform on SO(3).

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        return quat.random(rng=rng)


class AttitudeDispersion(Dispersion):
    """An attitude near a nominal one: ``q = q_nominal ⊗ exp(theta / 2)``, ``theta`` per body axis.

    Parameters
    ----------
    nominal : array_like (4,)
        Nominal attitude ``q_BN``.
    sigma, half_width : float or array_like (3,)
        Per-axis standard deviation (normal) or half-width (uniform) of the
        rotation vector ``theta`` [rad], in body axes. Exactly one.
    """

    shape = (4,)

    def __init__(self, nominal: ArrayLike, sigma: ArrayLike | None = None, half_width: ArrayLike | None = None) -> None:
        self.nominal = quat.as_unit_quaternion(nominal, "nominal")
        if self.nominal.shape != (4,):
            raise ValueError(f"nominal must be one quaternion (4,), got shape {self.nominal.shape}")
        self.distribution, scale = _two_sided(sigma, half_width, "AttitudeDispersion")
        if scale.shape not in ((), (3,)):
            raise ValueError(f"the attitude scale must be a scalar or one value per axis (3,), got {scale.shape}")
        self.scale = np.broadcast_to(scale, (3,)).copy()

    def __repr__(self) -> str:
        return (
            f"AttitudeDispersion(nominal={self.nominal.tolist()!r}, {self.distribution}, "
            f"scale_rad={self.scale.tolist()!r})"
        )

    def sample(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """Draw one attitude ``q_BN`` near the nominal one.

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        theta = _draw(rng, self.distribution, self.scale, (3,))
        return quat.normalize(quat.multiply(self.nominal, quat.from_rotation_vector(theta)))


class InertiaDispersion(Dispersion):
    """A dispersed inertia tensor that is always physically valid.

    Each draw perturbs the *principal moments* of the nominal tensor and then
    turns the principal axes by a small random rotation:

    1. ``lambda_k' = lambda_k (1 + d_k)`` with ``d_k`` independent, normal
       (``moment_sigma``) or uniform on ``[-h, h]`` (``moment_half_width``),
       relative (0.05 = 5 %);
    2. the draw is **rejected and redrawn** unless every moment is positive
       and the triangle inequality ``lambda_max <= sum of the other two``
       holds (to :data:`attitude.rigid_body.REALISABILITY_TOLERANCE`), the
       conditions for a mass distribution to exist. Rejection (not clipping)
       keeps the distribution smooth: it is the requested one *truncated* to
       the valid set, which changes nothing unless the nominal body is within
       a few sigma of a flat plate (``I3 = I1 + I2``). After ``max_tries``
       rejections a ValueError says the dispersion is too wide for the body;
    3. ``I' = R V diag(lambda') V^T R^T`` with ``V`` the nominal principal
       axes and ``R`` the rotation of a rotation vector drawn per axis with
       ``axis_sigma`` [rad] (normal; 0 keeps the axes). Rotation preserves the
       moments, so the tensor stays valid.

    The table columns are the six independent entries ``xx yy zz xy xz yz``
    of the tensor in body axes [kg m^2].

    Parameters
    ----------
    nominal : array_like (3,) or (3, 3) or RigidBody
        Nominal inertia [kg m^2].
    moment_sigma, moment_half_width : float
        Relative dispersion of each principal moment (exactly one).
    axis_sigma : float
        Standard deviation of the axis rotation per axis [rad] (default 0).
    max_tries : int
        Draws before giving up (default 1000).
    """

    shape = (3, 3)
    _ENTRIES = (("xx", 0, 0), ("yy", 1, 1), ("zz", 2, 2), ("xy", 0, 1), ("xz", 0, 2), ("yz", 1, 2))

    def __init__(
        self,
        nominal: ArrayLike | RigidBody,
        moment_sigma: float | None = None,
        moment_half_width: float | None = None,
        *,
        axis_sigma: float = 0.0,
        max_tries: int = 1000,
    ) -> None:
        body = nominal if isinstance(nominal, RigidBody) else RigidBody(nominal)
        if body.batch_shape:
            raise ValueError("nominal must be a single inertia, not a batch")
        self.nominal = body.inertia
        axes = body.principal_axes()
        self.moments = axes.moments
        self.axes_B = axes.axes_B
        self.distribution, scale = _two_sided(
            moment_sigma, moment_half_width, "InertiaDispersion", ("moment_sigma", "moment_half_width")
        )
        if scale.ndim != 0:
            raise ValueError(f"the moment dispersion must be one relative value, got shape {scale.shape}")
        self.scale = float(scale)
        self.axis_sigma = float(check_positive(axis_sigma, "axis_sigma", allow_zero=True))
        if isinstance(max_tries, bool) or not isinstance(max_tries, int) or max_tries < 1:
            raise ValueError(f"max_tries must be a positive integer, got {max_tries!r}")
        self.max_tries = max_tries

    def __repr__(self) -> str:
        return (
            f"InertiaDispersion(nominal={self.nominal.tolist()!r}, {self.distribution}, relative={self.scale!r}, "
            f"axis_sigma_rad={self.axis_sigma!r})"
        )

    def sample(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """Draw one physically valid inertia tensor [kg m^2].

        Parameters
        ----------
        rng : numpy.random.Generator
            The run's generator.
        """
        for _ in range(self.max_tries):
            moments = self.moments * (1.0 + _draw(rng, self.distribution, np.asarray(self.scale), (3,)))
            ordered = np.sort(moments)
            if ordered[0] > 0 and ordered[2] - ordered[0] - ordered[1] <= REALISABILITY_TOLERANCE * ordered[2]:
                break
        else:
            raise ValueError(
                f"InertiaDispersion: no physically valid inertia in {self.max_tries} draws; the relative dispersion "
                f"{self.scale!r} is too wide for principal moments {describe(self.moments)} kg m^2"
            )
        axes = self.axes_B
        if self.axis_sigma > 0:
            rotation = quat.to_dcm(quat.from_rotation_vector(self.axis_sigma * rng.standard_normal(3))).T
            axes = rotation @ axes
        tensor = axes @ np.diag(moments) @ axes.T
        return 0.5 * (tensor + tensor.T)

    def columns(self, name: str) -> list[str]:
        """Column names of the inertia in the table: the six independent entries ``name.xx`` ... ``name.yz``.

        Parameters
        ----------
        name : str
            The parameter's name in the campaign.
        """
        return [f"{name}.{label}" for label, _, _ in self._ENTRIES]

    def flatten(self, value: Any) -> list[float]:
        """The six independent entries of one drawn inertia tensor (same order as :meth:`columns`).

        Parameters
        ----------
        value : array_like
            One inertia tensor drawn by :meth:`sample` [kg m^2].
        """
        tensor = np.asarray(value, dtype=float)
        return [float(tensor[i, j]) for _, i, j in self._ENTRIES]


# ---------------------------------------------------------------------------
# From the spacecraft file


def dispersions_from_config(
    montecarlo: Any,
    inertia: ArrayLike,
    q_start: ArrayLike,
    *,
    residual_dipole_Am2: ArrayLike = (0.0, 0.0, 0.0),
) -> dict[str, Dispersion]:
    """The dispersions of a ``[montecarlo]`` table (:class:`attitude.config.model.MonteCarloConfig`).

    Parameters
    ----------
    montecarlo : MonteCarloConfig
        The table (scales in its units; converted with ``Dispersion.scale_si``).
    inertia : array_like (3, 3)
        Nominal inertia (whole spacecraft) [kg m^2].
    q_start : array_like (4,)
        Nominal start attitude ``q_BN`` (the centre of ``initial_attitude``).
    residual_dipole_Am2 : array_like (3,)
        Nominal residual dipole in body axes [A m^2] (the centre of ``residual_dipole``).

    Returns
    -------
    dict
        ``inertia`` (:class:`InertiaDispersion`: principal moments, and the
        axes when ``axis_sigma_deg`` is given), ``initial_rate`` and
        ``gyro_bias`` [rad/s] (:class:`Normal` or :class:`Uniform` about 0),
        ``initial_attitude`` (:class:`AttitudeDispersion` or
        :class:`RandomAttitude`), ``gyro_misalignment`` and
        ``star_tracker_misalignment`` [rad] (:class:`Misalignment`), and
        the surface's: ``drag_scale`` (:class:`RelativeScale` about 1),
        ``residual_dipole`` [A m^2] (:class:`Normal` or :class:`Uniform`
        about ``residual_dipole_Am2``, per axis) and
        ``centre_of_pressure_offset`` [m] (about 0, per axis); the tables
        left out of the file are left out here.
    """
    out: dict[str, Dispersion] = {}

    def two_sided(entry: Any) -> dict[str, float]:
        return {"sigma" if entry.distribution == "normal" else "half_width": entry.scale_si}

    if montecarlo.inertia is not None:
        key = "moment_sigma" if montecarlo.inertia.distribution == "normal" else "moment_half_width"
        axis_sigma = math.radians(montecarlo.inertia.axis_sigma_deg)
        out["inertia"] = InertiaDispersion(inertia, **{key: montecarlo.inertia.scale_si}, axis_sigma=axis_sigma)
    for name in ("initial_rate", "gyro_bias"):
        entry = getattr(montecarlo, name, None)
        if entry is not None:
            scale = entry.scale_si
            out[name] = (
                Normal(np.zeros(3), scale) if entry.distribution == "normal" else Uniform.centered(np.zeros(3), scale)
            )
    if montecarlo.initial_attitude is not None:
        entry = montecarlo.initial_attitude
        if entry.distribution == "uniform_so3":
            out["initial_attitude"] = RandomAttitude()
        else:
            out["initial_attitude"] = AttitudeDispersion(q_start, **two_sided(entry))
    for name in ("gyro_misalignment", "star_tracker_misalignment"):
        entry = getattr(montecarlo, name)
        if entry is not None:
            out[name] = Misalignment(**two_sided(entry))
    if getattr(montecarlo, "drag_scale", None) is not None:
        out["drag_scale"] = RelativeScale(**two_sided(montecarlo.drag_scale))
    centres = {"residual_dipole": residual_dipole_Am2, "centre_of_pressure_offset": np.zeros(3)}
    for name, centre in centres.items():
        entry = getattr(montecarlo, name, None)
        if entry is not None:
            c = np.broadcast_to(as_float_array(centre, name), (3,)).copy()
            scale = entry.scale_si
            out[name] = Normal(c, scale) if entry.distribution == "normal" else Uniform.centered(c, scale)
    return out

"""What the engine exchanges with the parts a user plugs in: the data it hands over and the protocols.

The engine (:func:`attitude.simulation.simulate`) and the batch paths talk to
controllers, sensors and estimators only through these protocols, so the
core never imports :mod:`controllers` or :mod:`estimation` and a user's own
object drops in. They are :class:`typing.Protocol` classes: an object meets
one by having the members, without inheriting from it
(``isinstance(obj, Controller)`` checks the members' presence).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.validation import as_float_array, describe, positive_scalar

__all__ = [
    "BatchEstimator",
    "CompiledController",
    "Controller",
    "DipoleController",
    "Disturbance",
    "Estimate",
    "Estimator",
    "Sensor",
    "Truth",
    "VectorMeasurement",
    "check_vector_covariances",
]


@dataclass(frozen=True)
class Truth:
    """The true state handed to sensors.

    Attributes
    ----------
    t : float
        Time [s].
    q : ndarray (4,)
        Attitude ``q_BN``.
    omega : ndarray (3,)
        Body rate [rad/s].
    h_wheels : ndarray (n,)
        Wheel spin-axis momenta [N m s] (empty without wheels).
    magnetic_field_B : ndarray (3,) or None
        Geomagnetic field at the spacecraft in body axes [T]; None when the run
        flies no orbit environment.
    sun_B : ndarray (3,) or None
        Unit vector from the spacecraft to the Sun in body axes; None without
        an orbit environment.
    illumination : float or None
        Fraction of the solar disk seen (1 full sun, 0 umbra); None without
        an orbit environment.
    nadir_B : ndarray (3,) or None
        Unit vector from the spacecraft to the Earth's centre in body axes
        (the coarse Sun sensors' albedo source); None without an orbit
        environment.
    """

    t: float
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    h_wheels: NDArray[np.float64]
    magnetic_field_B: NDArray[np.float64] | None = None
    sun_B: NDArray[np.float64] | None = None
    illumination: float | None = None
    nadir_B: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class Estimate:
    """What the controller sees: attitude, body rate and wheel momenta.

    ``h_body`` is the wheels' momentum *relative to the body*,
    ``sum_i J_i Omega_i a_i`` in body components [N m s] (the engine fills it
    from the wheel tachometers). With the whole-spacecraft inertia ``I`` a
    controller uses, ``I omega + h_body`` is then exactly the total angular
    momentum ``I_s omega + A h`` (the wheels' spin inertia is counted once).
    ``covariance`` is optional (an estimator's error covariance).

    Parameters
    ----------
    t : float
        Time of the estimate [s].
    q : ndarray (4,)
        Attitude ``q_BN``.
    omega : ndarray (3,)
        Body rate ``omega_BN_B`` [rad/s].
    h_wheels : ndarray (n,), optional
        Wheel momenta [N m s] (empty without wheels).
    h_body : ndarray (3,), optional
        Wheel momentum relative to the body, in body components [N m s].
    covariance : ndarray, optional
        The estimator's error covariance.
    """

    t: float
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    h_wheels: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    h_body: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    covariance: NDArray[np.float64] | None = None


@dataclass(frozen=True, init=False)
class VectorMeasurement:
    """A measured direction in body axes with its reference direction in N and its noise.

    The sample a vector sensor (a Sun sensor, a magnetometer with the field
    model's direction) hands an attitude estimator: the measured direction
    ``vector_B``, the known direction of the same thing in the inertial frame
    ``reference_N`` at the sample time (the Sun direction, the model field),
    and the noise of the measured *unit* vector, either

    - ``sigma`` [rad]: the QUEST measurement model (Shuster and Oh 1981;
      Markley and Crassidis, *Fundamentals of Spacecraft Attitude
      Determination and Control*, 2014, sec. 5.5 and 6.2), covariance
      ``sigma^2 (I - b b^T)``: isotropic angular noise perpendicular to the
      unit vector ``b``, none along it; or
    - ``covariance`` (3, 3) [rad^2]: the covariance of the unit vector's
      error, symmetric positive semi-definite, positive definite on the plane
      perpendicular to ``vector_B`` (its component along the vector is
      ignored: a unit vector's error along itself is second order and says
      nothing about the attitude).

    Both vectors are normalised on construction (their magnitudes, e.g. the
    field strength in tesla, carry no attitude information): a magnetometer
    with noise ``sigma_T`` per axis on a field of magnitude ``|B|`` has
    ``sigma ~ sigma_T / |B|``. A ``vector_B`` with a NaN or infinite
    component is kept as a failed sample, which an estimator skips; every
    other bad value raises ValueError. Estimators read it from
    ``Estimator.update``'s measurements under the sensor's name (None: no
    sample at that time); :class:`estimation.mekf.MEKF` also accepts a
    mapping with the same keys.

    Parameters
    ----------
    vector_B : array_like (3,)
        Measured direction in body axes (any non-zero length; NaN: failed sample).
    reference_N : array_like (3,)
        The same direction in N at the sample time (any non-zero length).
    sigma : float, optional
        Angular noise per axis perpendicular to the vector [rad] (> 0).
    covariance : array_like (3, 3), optional
        Covariance of the unit vector's error [rad^2]; exactly one of
        ``sigma`` and ``covariance`` is given.

    Raises
    ------
    ValueError
        A vector of the wrong shape or zero length, a non-finite reference,
        a non-positive ``sigma``, neither or both noise descriptions, or a
        covariance that is not symmetric positive semi-definite with a
        positive-definite part perpendicular to ``vector_B``.
    """

    vector_B: NDArray[np.float64]
    reference_N: NDArray[np.float64]
    sigma: float | None
    covariance: NDArray[np.float64] | None

    def __init__(
        self,
        vector_B: ArrayLike,
        reference_N: ArrayLike,
        *,
        sigma: float | None = None,
        covariance: ArrayLike | None = None,
    ) -> None:
        b = _direction(vector_B, "vector_B", allow_nonfinite=True)
        r = _direction(reference_N, "reference_N", allow_nonfinite=False)
        if (sigma is None) == (covariance is None):
            raise ValueError(
                "give exactly one of sigma [rad] (the QUEST model sigma^2 (I - b b^T)) and covariance (3, 3) "
                f"[rad^2], got sigma={sigma!r} and covariance={describe(covariance)}"
            )
        sig = None if sigma is None else positive_scalar(sigma, "sigma")
        cov = None if covariance is None else _vector_covariance(covariance, b)
        object.__setattr__(self, "vector_B", b)
        object.__setattr__(self, "reference_N", r)
        object.__setattr__(self, "sigma", sig)
        object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "_valid", bool(np.all(np.isfinite(b))))

    @property
    def valid(self) -> bool:
        """False for a failed sample (a non-finite ``vector_B``)."""
        return self._valid


def _direction(value: ArrayLike, name: str, *, allow_nonfinite: bool) -> NDArray[np.float64]:
    v = as_float_array(value, name, allow_nonfinite=allow_nonfinite)
    if v.shape != (3,):
        raise ValueError(f"{name} must have shape (3,), got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        out = np.full(3, np.nan)
        out.flags.writeable = False
        return out
    n = float(np.sqrt(v @ v))
    if not n > 0.0:
        raise ValueError(f"{name} must have a non-zero length (it is normalised to a direction), got {describe(v)}")
    out = v / n
    out.flags.writeable = False
    return out


def _vector_covariance(value: ArrayLike, b: NDArray[np.float64]) -> NDArray[np.float64]:
    c = as_float_array(value, "covariance")
    if c.shape != (3, 3):
        raise ValueError(f"covariance must have shape (3, 3) [rad^2], got shape {c.shape}")
    out = check_vector_covariances(c, b, "covariance")
    out.flags.writeable = False
    return out


def check_vector_covariances(covariance: ArrayLike, vector_B: ArrayLike, name: str) -> NDArray[np.float64]:
    """The rules of a direction's noise covariance, for one (3, 3) or many (..., 3, 3); symmetrised copies.

    Each must be finite, non-zero, symmetric (to 1e-12 of its largest
    entry), positive semi-definite (eigenvalues above -1e-12 of it), and,
    where its ``vector_B`` is finite, positive definite on the plane
    perpendicular to it (the part the attitude sees). The one check of
    :class:`VectorMeasurement` and of the batch MEKF's
    ``estimation.mekf.batch.VectorSamples``.

    Parameters
    ----------
    covariance : array_like (..., 3, 3)
        Covariances of the unit vectors' errors [rad^2].
    vector_B : array_like (..., 3)
        The unit vectors (non-finite rows: failed samples, no plane check).
    name : str
        Argument name used in error messages (with the index of a bad one).

    Returns
    -------
    ndarray (..., 3, 3)
        The symmetrised covariances.

    Raises
    ------
    ValueError
        Naming the first covariance that breaks a rule, its index and values.
    """
    c = as_float_array(covariance, name)
    b = np.asarray(vector_B, dtype=float)
    lead = c.shape[:-2]

    def where(mask: NDArray[np.bool_]) -> str:
        if not lead:
            return name
        return f"{name}{[int(i) for i in np.argwhere(mask)[0]]}"

    def value(mask: NDArray[np.bool_], array: NDArray[np.float64]) -> str:
        return describe(array if not lead else array[tuple(np.argwhere(mask)[0])])

    scale = np.abs(c).max(axis=(-2, -1))
    asym = np.abs(c - np.swapaxes(c, -1, -2)).max(axis=(-2, -1))
    bad = ~(scale > 0.0) | (asym > 1e-12 * scale)
    if np.any(bad):
        raise ValueError(f"{where(bad)} must be symmetric and non-zero, got {value(bad, c)}")
    c = 0.5 * (c + np.swapaxes(c, -1, -2))
    eig = np.linalg.eigvalsh(c)
    bad = eig[..., 0] < -1e-12 * scale
    if np.any(bad):
        raise ValueError(f"{where(bad)} must be positive semi-definite, got eigenvalues {value(bad, eig)}")
    finite = np.all(np.isfinite(b), axis=-1)
    if np.any(finite):
        # Its part perpendicular to the vector: with u = b / |b|, (I - u u^T) C (I - u u^T) has a zero
        # eigenvalue along u and the two of the plane; the smaller of those must be positive.
        u = np.where(finite[..., None], b, 0.0)
        u = u / np.where(finite, np.linalg.norm(u, axis=-1), 1.0)[..., None]
        proj = np.eye(3) - u[..., :, None] * u[..., None, :]
        plane = np.linalg.eigvalsh(proj @ c @ proj)[..., 1:]
        bad = finite & ~(plane[..., 0] > 1e-12 * scale)
        if np.any(bad):
            raise ValueError(
                f"{where(bad)} must be positive definite on the plane perpendicular to vector_B, got eigenvalues "
                f"{value(bad, plane)} there"
            )
    return c


@runtime_checkable
class Controller(Protocol):
    """A feedback law sampled every ``period`` seconds.

    Optional members the engine uses when present: ``prepare(t0, q0, omega0)``
    (called once before the run, e.g. to latch limits from the initial error),
    ``reference(t) -> (q_ref, omega_ref)`` (the engine then logs the attitude
    error; ``reference_samples(t_array)`` does it in one call; a NaN ``q_ref``
    says there is no reference at that time, and the error is NaN there) and
    ``log() -> dict`` of floats or arrays logged at each sample.
    """

    period: float
    """Sample period [s], a whole multiple of the engine tick."""

    def torque(self, t: float, estimate: Estimate) -> NDArray[np.float64]:
        """Commanded body torque at time ``t`` from what the controller sees.

        Parameters
        ----------
        t : float
            Sample time [s].
        estimate : Estimate
            Attitude, rate and wheel momenta as the controller sees them.

        Returns
        -------
        ndarray (3,)
            Commanded body torque [N m].
        """
        ...


@runtime_checkable
class CompiledController(Controller, Protocol):
    """A controller the compiled (casadi) path can fold into the plant step.

    ``torque_components`` is written on components with the backend-neutral
    operations of :mod:`attitude.backend`, so numpy, casadi and generated C
    evaluate the same law.
    """

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Time-varying inputs of the law at the sample times (references, feedforward).

        Parameters
        ----------
        t : ndarray (N,)
            Sample times [s].

        Returns
        -------
        ndarray (m, N)
            One column of inputs per sample.
        """
        ...

    def torque_components(
        self, q: Sequence[Any], omega: Sequence[Any], h_body: Sequence[Any], inputs: Sequence[Any]
    ) -> list:
        """Commanded body torque on components, any backend (numpy, casadi).

        Parameters
        ----------
        q : sequence of 4
            Attitude ``q_BN``.
        omega : sequence of 3
            Body rate [rad/s].
        h_body : sequence of 3
            Wheel momentum relative to the body, in body components [N m s].
        inputs : sequence of m
            One column of :meth:`compiled_inputs`.

        Returns
        -------
        list of 3
            Commanded body torque [N m].
        """
        ...


@runtime_checkable
class Sensor(Protocol):
    """A sensor sampled every ``period`` seconds; its samples reach the estimator under ``name``."""

    name: str
    period: float

    def measure(self, t: float, truth: Truth, rng: np.random.Generator) -> Any:
        """The sample at time ``t`` from the true state.

        Parameters
        ----------
        t : float
            Sample time [s].
        truth : Truth
            The true state.
        rng : numpy.random.Generator
            The run's random stream (the only source of noise, for reproducibility).

        Returns
        -------
        object or None
            The sample, or None when the sensor has none (e.g. blinded).
        """
        ...


@runtime_checkable
class Estimator(Protocol):
    """An estimator updated every ``period`` seconds from the newest sensor samples.

    ``measurements`` maps sensor names to their newest sample (None when the
    sensor did not sample at ``t``), plus ``"torque_command"`` (the body
    torque command held over the last interval [N m]) and
    ``"wheel_momentum"`` (wheel tachometers [N m s]). Optional ``log() -> dict``.

    Convention for direction sensors: a sensor whose sample is a measured
    direction returns a :class:`VectorMeasurement` (the body vector, its
    reference in N at the sample time and its noise), so the estimator needs
    no environment model of its own; :class:`estimation.mekf.MEKF` reads the
    names listed in its ``vector_names``.
    """

    period: float

    def update(self, t: float, measurements: Mapping[str, Any]) -> Estimate:
        """The estimate at time ``t``.

        Parameters
        ----------
        t : float
            Update time [s].
        measurements : mapping
            Newest sample per sensor name (None when it did not sample at ``t``),
            plus ``"torque_command"`` [N m] and ``"wheel_momentum"`` [N m s].

        Returns
        -------
        Estimate
            What the controller will see.
        """
        ...


@runtime_checkable
class BatchEstimator(Protocol):
    """N estimators stepped together by :func:`attitude.simulation.simulate_batch_estimated`.

    :class:`estimation.mekf.MEKFBatch` meets it.
    """

    period: float

    def step(
        self,
        t: float,
        gyro: NDArray[np.float64] | None,
        tracker: NDArray[np.float64] | None = None,
        mask: NDArray[np.bool_] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """One estimator step for all runs.

        Parameters
        ----------
        t : float
            Step time [s].
        gyro : ndarray (N, 3) or None
            The runs' gyro samples [rad/s].
        tracker : ndarray (N, 4), optional
            The runs' star-tracker quaternions (rows used where ``mask``).
        mask : ndarray of bool (N,), optional
            True where the tracker sampled.

        Returns
        -------
        tuple of ndarray
            ``(q_hat (N, 4), omega_hat (N, 3) [rad/s])``.
        """
        ...


@runtime_checkable
class DipoleController(Protocol):
    """A magnetic law commanding the magnetorquers' dipole every ``period`` seconds.

    It runs beside the torque :class:`Controller` (B-dot detumbling, momentum
    unloading). Optional ``log() -> dict`` of floats or arrays logged at each
    sample.
    """

    period: float
    """Sample period [s], a whole multiple of the engine tick."""

    def dipole(self, t: float, measurements: Mapping[str, Any]) -> NDArray[np.float64]:
        """Commanded magnetic dipole in body axes at time ``t``.

        Parameters
        ----------
        t : float
            Sample time [s].
        measurements : mapping
            Newest sample per sensor name (e.g. ``"magnetometer"``, (3,) [T]; None
            when it did not sample at ``t``), ``"wheel_momentum_B"`` (the wheels'
            momentum relative to the body in body axes, (3,) [N m s]) and, only when
            the engine is asked to hand the law the truth, ``"magnetic_field_B"``
            (3,) [T].

        Returns
        -------
        ndarray (3,)
            Commanded dipole [A m^2] in body axes (the magnetorquers saturate it).
        """
        ...


#: A disturbance: None, a constant body torque ``(3,)`` [N m], or
#: ``torque(t, q, omega) -> (3,)`` evaluated at each tick and held over it.
Disturbance = (
    None
    | Sequence[float]
    | NDArray[np.float64]
    | Callable[[float, NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]
)

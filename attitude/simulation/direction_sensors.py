"""Direction sensors as an attitude estimator reads them: samples turned into :class:`VectorMeasurement`.

A magnetometer samples the field in body axes [T] and a Sun sensor a
direction (or cell currents); an estimator such as
:class:`estimation.mekf.MEKF` (``vector_names=``) needs the measured unit
vector, the same direction in the inertial frame N at the sample time and
the noise of the unit vector (the convention of
:class:`attitude.simulation.protocols.Estimator`). The adapters here wrap a
sensor, keep its name and period, and hand the estimator that
:class:`VectorMeasurement`, so ``simulate(..., sensors=[gyro,
MagnetometerDirection(magnetometer), SunDirection(fine_sun_sensor)],
estimator=MEKF(..., vector_names=[...]))`` flies a star-tracker-free
determination loop.

The reference in N is the truth's (``truth.magnetic_field_B`` and
``truth.sun_B`` rotated to N with the true attitude): the on-board field
and Sun models are taken as perfect, so the errors the estimator sees are
the sensors' own. The default noise of the unit vector is the sensor's
white noise. Its systematic errors (bias, scale factor, misalignment) are
NOT noise: the estimators do not estimate them, and a filter averaging
thousands of samples shrinks its covariance below them (a 300 nT
magnetometer bias gave a mean NEES of 235 in a new user's trial). An
adapter around a sensor with systematic errors therefore warns
(:class:`UnmodelledErrorWarning`); see docs/sensors.md.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.sensors import Magnetometer
from attitude.simulation.protocols import VectorMeasurement
from attitude.sun_sensors import CoarseSunSensors, FineSunSensor
from attitude.validation import positive_scalar

__all__ = ["MagnetometerDirection", "SunDirection", "UnmodelledErrorWarning", "field_direction_sigma"]


class UnmodelledErrorWarning(UserWarning):
    """A direction sensor has systematic errors the estimators do not model: their covariance will not cover them."""


def _require_noise(who: str, noise: float, sigma_rad: float | None) -> None:
    """Refuse a sensor whose directions would be taken as exact: no white noise and no ``sigma_rad``."""
    if sigma_rad is None and noise == 0.0:
        raise ValueError(
            f"sigma_rad is needed for {who}: it has no white noise, so its directions would be taken as exact; "
            "pass the angular noise the estimator should assume"
        )


def _warn_systematic(who: str, what: list[str]) -> None:
    if what:
        warnings.warn(
            f"{who} has {', '.join(what)}, which the estimators do not model: a filter averaging its samples "
            "converges to the biased direction while its covariance shrinks below the error (over-confident; "
            "docs/sensors.md). Calibrate them out of the samples, or fly the sensor without them to study the "
            "noise alone",
            UnmodelledErrorWarning,
            stacklevel=3,
        )


def _name(name: str | None, default: str) -> str:
    if name is None:
        return default
    if not isinstance(name, str) or not name:
        raise ValueError(f"name must be a non-empty string or None (the sensor's own), got {name!r}")
    return name


def _sigma(sigma_rad: float | None) -> float | None:
    return None if sigma_rad is None else positive_scalar(sigma_rad, "sigma_rad")


def field_direction_sigma(noise_T: float, field_B: ArrayLike) -> NDArray[np.float64]:
    """Angular noise [rad] of a magnetometer's field direction: the per-axis white noise over ``|B|``.

    A noise ``sigma_T`` per axis perpendicular to a field of magnitude ``|B|``
    turns the direction by ``sigma_T / |B|`` per axis (first order).

    Parameters
    ----------
    noise_T : float
        1-sigma white noise per axis [T].
    field_B : array_like (..., 3)
        The field [T].

    Returns
    -------
    ndarray (...)
        [rad]
    """
    return noise_T / np.linalg.norm(np.asarray(field_B, dtype=float), axis=-1)


class MagnetometerDirection:
    """A magnetometer as a direction sensor: the field's direction in body axes and in N.

    Parameters
    ----------
    magnetometer : Magnetometer
        The sensor (its samples [T], period and name).
    sigma_rad : float, optional
        Angular noise of the measured direction per axis [rad] (> 0). Default:
        ``sigma_T / |B|`` at each sample, the white noise over the field's
        magnitude.
    name : str, optional
        Name the estimator reads it under (default: the magnetometer's).
    """

    def __init__(self, magnetometer: Magnetometer, sigma_rad: float | None = None, name: str | None = None) -> None:
        if not isinstance(magnetometer, Magnetometer):
            raise TypeError(f"magnetometer must be an attitude.sensors.Magnetometer, got {type(magnetometer).__name__}")
        self.magnetometer = magnetometer
        self.sigma_rad = _sigma(sigma_rad)
        self.name = _name(name, magnetometer.name)
        self.period = magnetometer.period
        #: The per-axis noise the default sigma divides by |B| [T].
        self.equivalent_noise_T = float(magnetometer.sigma)
        _require_noise(f"magnetometer {magnetometer.name!r}", self.equivalent_noise_T, self.sigma_rad)
        systematic = []
        if np.any(magnetometer.bias):
            systematic.append(f"a bias of {np.round(np.asarray(magnetometer.bias) * 1e9, 3).tolist()} nT")
        if np.any(magnetometer.scale_factor):
            ppm = np.round(np.asarray(magnetometer.scale_factor) * 1e6, 1).tolist()
            systematic.append(f"scale-factor errors of {ppm} ppm")
        if np.any(magnetometer.misalignment):
            systematic.append("a misalignment")
        _warn_systematic(f"magnetometer {magnetometer.name!r}", systematic)

    def __repr__(self) -> str:
        return f"MagnetometerDirection({self.magnetometer!r}, sigma_rad={self.sigma_rad!r}, name={self.name!r})"

    def measure(self, t: float, truth: Any, rng: Any = None) -> VectorMeasurement:
        """The sample at ``t`` as a :class:`VectorMeasurement`.

        Parameters
        ----------
        t : float
            Sample time [s].
        truth : Truth
            The true state (``q``, ``magnetic_field_B``).
        rng : numpy.random.Generator or int, optional
            Noise source.

        Returns
        -------
        VectorMeasurement

        Raises
        ------
        ValueError
            Without an orbit environment (no field). (A noise-free magnetometer
            without ``sigma_rad`` is refused when the adapter is made.)
        """
        sample_T = self.magnetometer.measure(t, truth, rng)
        field_B = np.asarray(truth.magnetic_field_B, dtype=float)
        sigma = self.sigma_rad
        if sigma is None:
            sigma = float(field_direction_sigma(self.equivalent_noise_T, field_B))
        return VectorMeasurement(sample_T, quat.rotate(truth.q, field_B), sigma=sigma)


class SunDirection:
    """A Sun sensor as a direction sensor: the Sun's direction in body axes and in N.

    Parameters
    ----------
    sensor : FineSunSensor or CoarseSunSensors
        The sensor. A fine sensor's sample is its direction (None out of view
        or in eclipse); coarse cells give theirs through
        :meth:`CoarseSunSensors.sun_vector` (None when not valid).
    sigma_rad : float, optional
        Angular noise of the direction per axis [rad] (> 0). Default: for the
        fine sensor its two-axis noise ``sigma``; for the coarse cells the
        first-order covariance of each estimate
        (:attr:`SunVectorEstimate.covariance_B`).
    name : str, optional
        Name the estimator reads it under (default: the sensor's).
    """

    def __init__(
        self, sensor: FineSunSensor | CoarseSunSensors, sigma_rad: float | None = None, name: str | None = None
    ) -> None:
        if not isinstance(sensor, (FineSunSensor, CoarseSunSensors)):
            raise TypeError(
                f"sensor must be an attitude.sun_sensors.FineSunSensor or CoarseSunSensors, got {type(sensor).__name__}"
            )
        self.sensor = sensor
        self.sigma_rad = _sigma(sigma_rad)
        self.name = _name(name, sensor.name)
        self.period = sensor.period
        if isinstance(sensor, FineSunSensor):
            #: The per-axis angular noise the default assumes for a fine sensor [rad].
            self.equivalent_noise_rad = float(sensor.sigma)
            _require_noise(f"Sun sensor {sensor.name!r}", self.equivalent_noise_rad, self.sigma_rad)
            bias = [f"a bias of {np.round(np.degrees(sensor.bias), 4).tolist()} deg"] if np.any(sensor.bias) else []
            _warn_systematic(f"Sun sensor {sensor.name!r}", bias)
        else:
            _require_noise(f"coarse Sun sensors {sensor.name!r}", sensor.noise, self.sigma_rad)
            _warn_systematic(
                f"coarse Sun sensors {sensor.name!r}",
                ["scale-factor errors"] if np.any(sensor.scale_factor) else [],
            )

    def __repr__(self) -> str:
        return f"SunDirection({self.sensor!r}, sigma_rad={self.sigma_rad!r}, name={self.name!r})"

    def measure(self, t: float, truth: Any, rng: Any = None) -> VectorMeasurement | None:
        """The sample at ``t`` as a :class:`VectorMeasurement`, or None when the Sun gives no direction.

        Parameters
        ----------
        t : float
            Sample time [s].
        truth : Truth
            The true state (``q``, ``sun_B``, ``illumination``).
        rng : numpy.random.Generator or int, optional
            Noise source.

        Returns
        -------
        VectorMeasurement or None
            None out of the field of view, in eclipse, or (coarse cells) with
            fewer than three independent lit cells.

        Raises
        ------
        ValueError
            Without an orbit environment (no Sun). (A noise-free sensor without
            ``sigma_rad`` is refused when the adapter is made.)
        """
        out = self.sensor.measure(t, truth, rng)
        if out is None:
            return None
        reference_N = quat.rotate(truth.q, np.asarray(truth.sun_B, dtype=float))
        if isinstance(self.sensor, CoarseSunSensors):
            estimate = self.sensor.sun_vector(out)
            if not estimate.valid:
                return None
            if self.sigma_rad is not None:
                return VectorMeasurement(estimate.sun_B, reference_N, sigma=self.sigma_rad)
            return VectorMeasurement(estimate.sun_B, reference_N, covariance=estimate.covariance_B)
        sigma = self.sigma_rad
        if sigma is None:
            sigma = self.equivalent_noise_rad
        return VectorMeasurement(out, reference_N, sigma=sigma)

"""Magnetic control laws: B-dot detumbling and cross-product momentum unloading.

Both command a magnetic dipole ``m`` [A m^2] in body axes every ``period``
seconds and meet :class:`attitude.simulation.protocols.DipoleController`.
The torque they produce is ``m x B`` (:class:`attitude.actuators.Magnetorquers`).

**B-dot** (Stickler and Alfriend, "Elementary magnetic attitude control
system", J. Spacecraft and Rockets 13(5), 1976; Markley and Crassidis,
*Fundamentals of Spacecraft Attitude Determination and Control*, Springer
2014, sec. 7.5). In a field fixed in inertial space the body-axes field
changes only by the rotation, ``dB/dt = -omega x B``. The law
``m = -k dB/dt`` then gives the torque ``k (omega x B) x B`` and the kinetic
energy rate ``dT/dt = omega . (m x B) = -k |omega x B|^2 <= 0``: the rate
component across the field is damped. The normalised form of Avanzini and
Giulietti ("Magnetic detumbling of a rigid spacecraft", J. Guidance, Control,
and Dynamics 35(4), 1326-1334, 2012), ``m = -(k_w / |B|) db/dt`` with the unit
vector ``b = B / |B|``, gives ``dT/dt = -k_w |omega x b|^2`` and has the gain
criterion of :func:`bdot_gain`. The rate of the field is a finite
difference of successive magnetometer samples.

**Cross-product unloading** (Camillo and Markley, "Orbit-averaged behavior
of magnetic control laws for momentum unloading", J. Guidance and Control
3(6), 1980; Markley and Crassidis 2014, sec. 7.5):
``m = k (dh x B) / |B|^2`` with ``dh`` the wheels' momentum minus its target.
By ``(a x b) x c = b (a . c) - a (b . c)``,
``m x B = -k (dh - (dh . b) b) = -k dh_perp``: the torque removes the part of
the excess momentum across the field at rate ``k`` and cannot touch the part
along it (which the field's rotation over the orbit makes reachable later).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import backend as bk
from attitude.actuators import Magnetorquers
from attitude.rigid_body import Components, RigidBody
from attitude.validation import as_float_array, check_vector, positive_scalar, scalar_angle, scalar_time

__all__ = ["BDOT_LAWS", "BDotController", "CrossProductUnloading", "bdot_gain"]

#: Forms of the B-dot law (see :class:`BDotController`).
BDOT_LAWS = ("unit", "field")

#: Floor on ``|B|^2`` [T^2] in the compiled unloading law: the geomagnetic
#: field in orbit is above 1e-6 T (1e-12 T^2); the floor only keeps a zero
#: field (a misconfigured run) from dividing by zero.
_FIELD_SQUARED_FLOOR_T2 = 1e-30


def bdot_gain(orbit: Any, body: RigidBody, *, magnetic_inclination: float | None = None) -> float:
    """The B-dot gain ``k_w = 2 n (1 + sin xi_m) J_min`` of Avanzini and Giulietti (2012) [kg m^2/s].

    For the normalised law ``m = -(k_w / |B|) db/dt`` (:class:`BDotController`
    with ``law="unit"``): Avanzini and Giulietti, "Magnetic detumbling of a
    rigid spacecraft", J. Guidance, Control, and Dynamics 35(4), 1326-1334,
    2012 (doi:10.2514/1.53074), the gain criterion of their sec. IV for a
    quasi-minimum detumbling time: ``n`` the orbit's mean motion, ``xi_m``
    the inclination of the orbit on the geomagnetic equator and ``J_min``
    the smallest principal inertia.

    Parameters
    ----------
    orbit : object
        Anything with ``mean_motion`` [rad/s] and, unless
        ``magnetic_inclination`` is given, ``inclination`` [rad]
        (e.g. :class:`attitude.environment.CircularOrbit`).
    body : RigidBody
        The spacecraft (its inertia [kg m^2]).
    magnetic_inclination : float, optional
        ``xi_m`` [rad], in ``[0, pi]``. Default: the orbit's geographic
        inclination, which differs from ``xi_m`` by at most the dipole tilt
        (9.2 deg for IGRF-14 at 2025.5) depending on the node.

    Returns
    -------
    float
        ``k_w`` [kg m^2/s] (``N m s``; with ``1/|B|`` and ``db/dt`` [1/s] the dipole is in A m^2).

    Raises
    ------
    ValueError
        If ``body`` is not a single RigidBody, the orbit's mean motion is not
        positive, or the inclination lies outside ``[0, pi]``.
    """
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single RigidBody, got {type(body).__name__}")
    n = positive_scalar(getattr(orbit, "mean_motion", None), "orbit.mean_motion")
    if magnetic_inclination is None:
        xi = scalar_angle(getattr(orbit, "inclination", None), "orbit.inclination")
        name = "orbit.inclination"
    else:
        xi = scalar_angle(magnetic_inclination, "magnetic_inclination")
        name = "magnetic_inclination"
    if not 0.0 <= xi <= np.pi:
        raise ValueError(f"{name} must be in [0, pi] rad, got {xi!r}")
    j_min = float(np.min(np.linalg.eigvalsh(body.inertia)))
    return 2.0 * n * (1.0 + np.sin(xi)) * j_min


def _torquers(magnetorquers: Magnetorquers | None, dipole_max_Am2: ArrayLike | None) -> Magnetorquers | None:
    """The rods that limit a law's command: given, built from ``dipole_max_Am2`` (orthogonal, scaled), or None."""
    if magnetorquers is not None and dipole_max_Am2 is not None:
        raise ValueError(
            "give magnetorquers or dipole_max_Am2, not both (the rods carry their own limits), got "
            f"magnetorquers={magnetorquers!r} and dipole_max_Am2={dipole_max_Am2!r}"
        )
    if magnetorquers is not None:
        if not isinstance(magnetorquers, Magnetorquers):
            raise ValueError(f"magnetorquers must be a Magnetorquers, got {type(magnetorquers).__name__}")
        return magnetorquers
    if dipole_max_Am2 is not None:
        return Magnetorquers.orthogonal(dipole_max_Am2=dipole_max_Am2, saturation="scale")
    return None


def _limited(torquers: Magnetorquers | None, dipole_B: NDArray[np.float64]) -> NDArray[np.float64]:
    return dipole_B if torquers is None else torquers.dipole_B(torquers.command(dipole_B))


def _field_sample(measurements: Mapping[str, Any], key: str) -> NDArray[np.float64] | None:
    value = measurements.get(key)
    if value is None:
        return None
    field = check_vector(value, f'measurements["{key}"]', 3)
    if field.shape != (3,):
        raise ValueError(f'measurements["{key}"] must have shape (3,) [T], got shape {field.shape}')
    return field


class BDotController:
    """B-dot detumbling from successive magnetometer samples (module docstring).

    ``law="unit"`` (default): ``m = -(k / |B_k|) (b_k - b_{k-1}) / dt`` with
    ``b = B / |B|`` (Avanzini and Giulietti 2012; gain from :func:`bdot_gain`,
    [kg m^2/s]). ``law="field"``: ``m = -k (B_k - B_{k-1}) / dt`` (Stickler
    and Alfriend 1976; gain [A m^2 s/T]). The first sample of a run, and a
    tick where the field was not sampled (the sensor's period longer than
    the law's), give no new command: the law holds its last dipole (zero at
    first).

    Parameters
    ----------
    gain : float
        ``k`` (> 0), units as above.
    period : float
        Sample period [s].
    magnetorquers : Magnetorquers, optional
        The rods: the command is allocated, saturated and quantised as they
        would (:meth:`Magnetorquers.command`), so the returned dipole is
        what they deliver.
    dipole_max_Am2 : float or array_like (3,), optional
        Instead of ``magnetorquers``: per-axis limits of three orthogonal
        rods [A m^2], the command scaled to keep its direction. Neither:
        unlimited.
    law : {"unit", "field"}
        Form of the law (above).
    sensor : str
        Name of the magnetometer whose samples the law reads.
    use_truth_field : bool
        Read ``measurements["magnetic_field_B"]`` (the true field) instead of
        the sensor: for design studies.

    Raises
    ------
    ValueError
        A gain or period that is not strictly positive, an unknown ``law``,
        or both ``magnetorquers`` and ``dipole_max_Am2``.
    """

    def __init__(
        self,
        gain: float,
        *,
        period: float,
        magnetorquers: Magnetorquers | None = None,
        dipole_max_Am2: ArrayLike | None = None,
        law: str = "unit",
        sensor: str = "magnetometer",
        use_truth_field: bool = False,
    ) -> None:
        self.gain = positive_scalar(gain, "gain")
        self.period = positive_scalar(period, "period")
        if law not in BDOT_LAWS:
            raise ValueError(f"law must be one of {BDOT_LAWS}, got {law!r}")
        self.law = law
        self.magnetorquers = _torquers(magnetorquers, dipole_max_Am2)
        self.use_truth_field = bool(use_truth_field)
        self.field_key = "magnetic_field_B" if use_truth_field else sensor
        self.reset()

    def reset(self) -> None:
        """Forget the previous sample and command (call before reusing the law in a new run)."""
        self._last: tuple[float, NDArray[np.float64]] | None = None
        self._command = np.zeros(3)
        self._dipole = np.zeros(3)
        self._field_rate = np.zeros(3)

    def dipole_command(self, field_B: ArrayLike, field_rate_B: ArrayLike) -> NDArray[np.float64]:
        """The unsaturated law ``m`` (..., 3) [A m^2] for a field and its rate in body axes.

        ``law="field"``: ``-k dB/dt``; ``law="unit"``: ``-(k/|B|) db/dt``
        with ``b = B/|B|`` (exactly, ``db/dt = (dB/dt - b (b . dB/dt)) / |B|``;
        :meth:`dipole` passes the finite difference of the unit vectors).

        Parameters
        ----------
        field_B : array_like (..., 3)
            Magnetic field in body axes [T] (non-zero for ``law="unit"``).
        field_rate_B : array_like (..., 3)
            ``dB/dt`` [T/s] for ``law="field"``, ``db/dt`` [1/s] for
            ``law="unit"``, in body axes.

        Returns
        -------
        ndarray (..., 3)
            The commanded dipole [A m^2] before the rods' limits.
        """
        field = check_vector(field_B, "field_B", 3)
        rate = check_vector(field_rate_B, "field_rate_B", 3)
        if self.law == "field":
            return -self.gain * rate
        return -self.gain * rate / np.linalg.norm(field, axis=-1, keepdims=True)

    def dipole(self, t: float, measurements: Mapping[str, Any]) -> NDArray[np.float64]:
        """Commanded dipole (3,) [A m^2] in body axes at ``t`` [s], after the rods' limits.

        Parameters
        ----------
        t : float
            Sample time [s].
        measurements : mapping
            Holds the magnetometer sample (3,) [T] under the sensor's name
            (None when it did not sample), or ``"magnetic_field_B"`` with
            ``use_truth_field``.

        Returns
        -------
        ndarray (3,)
            Dipole [A m^2].
        """
        t = scalar_time(t, "t")
        field = _field_sample(measurements, self.field_key)
        if field is None:
            return self._dipole.copy()
        norm = float(np.linalg.norm(field))
        if norm == 0.0:
            raise ValueError(f'measurements["{self.field_key}"] must be a non-zero field [T], got {field}')
        current = field if self.law == "field" else field / norm
        if self._last is not None:
            t_prev, prev = self._last
            if not t > t_prev:
                raise ValueError(f"t must increase from sample to sample (call reset() between runs): {t} <= {t_prev}")
            self._field_rate = (current - prev) / (t - t_prev)
            self._command = self.dipole_command(field, self._field_rate)
            self._dipole = _limited(self.magnetorquers, self._command)
        self._last = (t, current)
        return self._dipole.copy()

    def log(self) -> dict[str, NDArray[np.float64]]:
        """The last command before and after the rods' limits [A m^2] and the field rate used."""
        return {"dipole_command_B": self._command.copy(), "dipole_B": self._dipole.copy(), "rate": self._field_rate}


class CrossProductUnloading:
    """Cross-product momentum unloading ``m = k (dh x B) / |B|^2`` (module docstring).

    ``dh = h_B - target_momentum_B`` with ``h_B`` the wheels' momentum
    relative to the body in body axes (``measurements["wheel_momentum_B"]``).
    The torque ``m x B = -k dh_perp`` drives the excess momentum across the
    field to zero with time constant ``1/k``; the wheel controller, holding
    the attitude, takes the opposite torque out of the wheels.

    Parameters
    ----------
    gain : float
        ``k`` [1/s] (> 0).
    period : float
        Sample period [s].
    target_momentum_B : array_like (3,)
        Wheel momentum to keep [N m s] (default zero).
    magnetorquers : Magnetorquers, optional
        The rods (their limits and quantisation apply to the command).
    dipole_max_Am2 : float or array_like (3,), optional
        Instead of ``magnetorquers``: limits of three orthogonal rods [A m^2]
        (command scaled). Neither: unlimited.
    sensor : str
        Name of the magnetometer whose samples the law reads.
    use_truth_field : bool
        Read ``measurements["magnetic_field_B"]`` (the true field) instead.

    Raises
    ------
    ValueError
        A gain or period that is not strictly positive, a target that is not
        a finite (3,) vector, or both ``magnetorquers`` and ``dipole_max_Am2``.
    """

    def __init__(
        self,
        gain: float,
        *,
        period: float,
        target_momentum_B: ArrayLike = (0.0, 0.0, 0.0),
        magnetorquers: Magnetorquers | None = None,
        dipole_max_Am2: ArrayLike | None = None,
        sensor: str = "magnetometer",
        use_truth_field: bool = False,
    ) -> None:
        self.gain = positive_scalar(gain, "gain")
        self.period = positive_scalar(period, "period")
        target = check_vector(target_momentum_B, "target_momentum_B", 3)
        if target.shape != (3,):
            raise ValueError(f"target_momentum_B must have shape (3,) [N m s], got shape {target.shape}")
        self.target_momentum_B = target.copy()
        self.magnetorquers = _torquers(magnetorquers, dipole_max_Am2)
        self.use_truth_field = bool(use_truth_field)
        self.field_key = "magnetic_field_B" if use_truth_field else sensor
        self._dipole = np.zeros(3)

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """The target momentum ``[h_target]`` (3, len(t)) [N m s] for the compiled engine.

        Parameters
        ----------
        t : ndarray
            Tick times [s].
        """
        t = np.atleast_1d(as_float_array(t, "t"))
        return np.tile(self.target_momentum_B[:, None], (1, t.size))

    def dipole_components(self, field_B: Components, h_body_B: Components, inputs: Components) -> Components:
        """The law on components (any backend), after the rods' limits: body dipole [A m^2].

        Parameters
        ----------
        field_B : list of 3
            Magnetic field in body axes [T].
        h_body_B : list of 3
            Wheel momentum relative to the body, body axes [N m s].
        inputs : list of 3
            A column of :meth:`compiled_inputs`: the target momentum [N m s].

        Returns
        -------
        list of 3
            Body dipole [A m^2] (``k (dh x B) / |B|^2`` through the rods).
        """
        dh = [h - r for h, r in zip(h_body_B, inputs[:3])]
        b2 = field_B[0] * field_B[0] + field_B[1] * field_B[1] + field_B[2] * field_B[2]
        b2 = bk.fmax(b2, _FIELD_SQUARED_FLOOR_T2)
        m = [self.gain * c / b2 for c in bk.cross(dh, field_B)]
        if self.magnetorquers is None:
            return m
        return self.magnetorquers.dipole_components(self.magnetorquers.command_components(m))

    def dipole(self, t: float, measurements: Mapping[str, Any]) -> NDArray[np.float64]:
        """Commanded dipole (3,) [A m^2] in body axes at ``t`` [s], after the rods' limits.

        Holds the last command when the field was not sampled at ``t``.

        Parameters
        ----------
        t : float
            Sample time [s].
        measurements : mapping
            The field sample (3,) [T] under the sensor's name (or
            ``"magnetic_field_B"``) and ``"wheel_momentum_B"`` (3,) [N m s].

        Returns
        -------
        ndarray (3,)
            Dipole [A m^2].

        Raises
        ------
        ValueError
            If ``"wheel_momentum_B"`` is missing or not a finite (3,) vector.
        """
        scalar_time(t, "t")
        field = _field_sample(measurements, self.field_key)
        if "wheel_momentum_B" not in measurements:
            raise ValueError('measurements must hold "wheel_momentum_B" (the wheels\' momentum in body axes, N m s)')
        h = check_vector(measurements["wheel_momentum_B"], 'measurements["wheel_momentum_B"]', 3)
        if field is None:
            return self._dipole.copy()
        out = self.dipole_components(list(field), list(h.reshape(3)), list(self.target_momentum_B))
        self._dipole = np.array([float(v) for v in out])
        return self._dipole.copy()

    def log(self) -> dict[str, NDArray[np.float64]]:
        """The last commanded dipole [A m^2] after the rods' limits."""
        return {"dipole_B": self._dipole.copy()}

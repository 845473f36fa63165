"""Quaternion-feedback PD control (Wie, Weiss and Arapostathis, 1989).

.. math::

    \\tau = -K\\, \\mathrm{sgn}(q_{e,0})\\, q_{e,v} - C\\, \\omega_e
            \\;[+\\; \\omega \\times (I \\omega + h)]

with ``q_e = q_ref* ⊗ q`` (attitude of B relative to the reference R),
``omega_e = omega - C_BR omega_ref`` and the sign of the scalar part choosing
the shortest way (a 359 degree error is a 1 degree error). The optional
gyroscopic term cancels ``omega x H`` exactly.

Design from natural frequency and damping: for small errors
``q_e,v ≈ theta / 2``, so each axis obeys
``I theta'' + C theta' + (K/2) theta = 0``: ``K = 2 I wn^2`` and
``C = 2 I zeta wn`` (with ``I`` the diagonal inertia in the control axes; the
full tensor is used when the products of inertia are not zero, so
``I^-1 K/2 = wn^2`` holds as a matrix). The factor 2 is the whole point of
:meth:`QuaternionPD.from_bandwidth`: forgetting it gives sqrt(2) too slow a
loop.

:class:`RateLimitedPD` is the Wie-Lu (1995) variant for large slews: the
attitude term is saturated so that the slew coasts along the eigenaxis at a
set rate limit (derivation in its docstring).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import backend as bk
from attitude import quaternion as quat
from attitude.backend import cross
from attitude.rigid_body import Components, RigidBody
from attitude.validation import check_positive, gain_matrix, positive_per_axis, positive_scalar

__all__ = ["QuaternionPD", "RateLimitedPD", "quaternion_error_components"]

Reference = Callable[[float], tuple[ArrayLike, ArrayLike]]

#: Why the rate-limited PD takes scalar gains: one value for all axes keeps ``J^-1 K = k I``.
_SCALAR_GAIN = "one value for all axes keeps J^-1 K = k I, which the eigenaxis property needs"


def quaternion_error_components(q_ref: Components, q: Components) -> tuple[Components, Components]:
    """Shortest-way error quaternion ``q_ref* ⊗ q`` on components.

    Returns the error quaternion with non-negative scalar part, and its raw
    (unsigned) form.

    Parameters
    ----------
    q_ref : list
        Components ``[w, x, y, z]`` of the reference quaternion (numbers or casadi expressions).
    q : list
        Components ``[w, x, y, z]`` of the attitude quaternion, same backend.
    """
    conj = [q_ref[0], -q_ref[1], -q_ref[2], -q_ref[3]]
    e = quat.multiply_components(conj, q)
    if isinstance(e[0], float):  # one attitude in numbers: a branch (np.where would turn them into 0-d arrays)
        sign = -1.0 if e[0] < 0 else 1.0
    else:
        sign = bk.if_else(e[0] < 0, -1.0, 1.0)
    return [sign * c for c in e], e


@dataclass(kw_only=True)
class QuaternionPD:
    """Quaternion-feedback PD controller (module docstring).

    Parameters
    ----------
    K : array_like (3,) or (3, 3)
        Attitude gain on the error quaternion vector part [N m].
    C : array_like (3,) or (3, 3)
        Rate gain [N m s].
    period : float
        Sample time [s].
    q_ref : array_like (4,)
        Constant reference attitude ``q_RN`` (ignored if ``reference_fn`` given).
    reference_fn : callable, optional
        ``reference_fn(t) -> (q_RN, omega_RN_R)`` for a moving reference.
    inertia : array_like (3, 3), optional
        Needed for the gyroscopic compensation.
    gyroscopic : bool
        Add ``omega x (I omega + h)`` (requires ``inertia``).
    """

    #: The compiled path may keep this law's closed loop by the class and its pickle: the law reads nothing else
    #: (attitude.simulation.engine caches the compiled loop; a user's law without this flag is rebuilt each run).
    compiled_law_cacheable = True

    K: NDArray[np.float64]
    C: NDArray[np.float64]
    period: float
    q_ref: NDArray[np.float64] = field(default_factory=lambda: quat.identity())
    reference_fn: Reference | None = None
    inertia: NDArray[np.float64] | None = None
    gyroscopic: bool = False

    def __post_init__(self) -> None:
        self.K = gain_matrix(self.K, "K")
        self.C = gain_matrix(self.C, "C")
        self.period = float(check_positive(self.period, "period"))
        self.q_ref = quat.as_unit_quaternion(self.q_ref, "q_ref")
        if self.gyroscopic and self.inertia is None:
            raise ValueError("inertia is required when gyroscopic=True")
        if self.inertia is not None:
            self.inertia = RigidBody(self.inertia).inertia

    @classmethod
    def from_bandwidth(
        cls,
        body: RigidBody,
        *,
        wn: ArrayLike,
        zeta: ArrayLike,
        period: float,
        **kwargs: Any,
    ) -> QuaternionPD:
        """Gains that place each axis at natural frequency ``wn`` [rad/s] and damping ``zeta``.

        ``K = 2 I Wn^2`` and ``C = 2 I Z Wn`` with diagonal ``Wn``, ``Z`` (the
        factor 2 because ``q_v`` is half the angle). Warns when ``wn`` exceeds
        a tenth of the sample rate ``2 pi / period``, where the continuous
        design no longer predicts the sampled loop.

        Parameters
        ----------
        body : RigidBody
            The spacecraft (its inertia [kg m^2] sets the gains).
        wn : array_like
            Natural frequency per axis [rad/s], scalar or (3,).
        zeta : array_like
            Damping ratio per axis [-], scalar or (3,).
        period : float
            Sample time of the controller [s].
        **kwargs
            Further fields of :class:`QuaternionPD` (``q_ref``, ``reference_fn``, ``gyroscopic`` ...).
        """
        if not isinstance(body, RigidBody) or body.batch_shape:
            raise ValueError(f"body must be a single RigidBody, got {type(body).__name__}")
        wn = positive_per_axis(wn, "wn")
        zeta = positive_per_axis(zeta, "zeta")
        period = float(check_positive(period, "period"))
        sample_rate = 2.0 * np.pi / period
        if np.max(wn) > 0.1 * sample_rate:
            warnings.warn(
                f"wn = {np.max(wn):.4g} rad/s is above a tenth of the sample rate ({sample_rate:.4g} rad/s): "
                "sampling and delay will erode the designed damping",
                stacklevel=2,
            )
        inertia = body.inertia
        K = 2.0 * inertia @ np.diag(wn**2)
        C = 2.0 * inertia @ np.diag(zeta * wn)
        kwargs.setdefault("inertia", inertia)
        return cls(K=K, C=C, period=period, **kwargs)

    # -- reference --------------------------------------------------------------

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitude ``q_RN`` and rate ``omega_RN_R`` [rad/s] at ``t``.

        Parameters
        ----------
        t : float
            Time [s].
        """
        if self.reference_fn is None:
            return self.q_ref, np.zeros(3)
        q_r, w_r = self.reference_fn(t)
        return quat.as_unit_quaternion(q_r, "reference q"), np.asarray(w_r, dtype=float)

    # -- law ------------------------------------------------------------------------

    def torque_components(self, q: Components, omega: Components, h_body: Components, inputs: Components) -> Components:
        """The control law on components; ``inputs = [q_ref (4), omega_ref (3)]``.

        Parameters
        ----------
        q : list
            Attitude components ``[w, x, y, z]`` of ``q_BN`` (numbers or casadi expressions).
        omega : list
            Body rate components ``omega_BN_B`` [rad/s].
        h_body : list
            Internal (wheel) momentum in body components [N m s] (gyroscopic term).
        inputs : list
            ``[q_ref (4), omega_ref (3)]`` components.
        """
        q_e, _ = quaternion_error_components(inputs[:4], q)
        w_ref_b = quat.rotate_inverse_components(q_e, inputs[4:7])
        w_e = [w - r for w, r in zip(omega, w_ref_b)]
        # The gains as Python floats (read at every call: the fields may be reassigned), not numpy scalars.
        gain_k, gain_c = self.K.tolist(), self.C.tolist()
        tau = []
        for i in range(3):
            acc = 0.0 * omega[0]
            for j in range(3):
                if gain_k[i][j] != 0.0:
                    acc = acc - gain_k[i][j] * q_e[1 + j]
                if gain_c[i][j] != 0.0:
                    acc = acc - gain_c[i][j] * w_e[j]
            tau.append(acc)
        if self.gyroscopic:
            inertia = self.inertia.tolist()
            h_tot = [sum(inertia[i][j] * omega[j] for j in range(3)) + h_body[i] for i in range(3)]
            tau = [a + b for a, b in zip(tau, cross(omega, h_tot))]
        return tau

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """References at many times: ``q_ref`` (n, 4) and ``omega_ref`` (n, 3).

        Parameters
        ----------
        t : array_like
            Times [s], shape (n,).
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.reference_fn is None:
            return np.tile(self.q_ref, (t.size, 1)), np.zeros((t.size, 3))
        pairs = [self.reference(float(tk)) for tk in t]
        return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Reference samples ``[q_ref; omega_ref]`` (7, len(t)) for the compiled engine.

        Parameters
        ----------
        t : ndarray
            Tick times [s].
        """
        q_r, w_r = self.reference_samples(t)
        return np.concatenate([q_r, w_r], axis=1).T

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque [N m] for an estimate with ``q``, ``omega`` (and ``h_wheels``).

        Parameters
        ----------
        t : float
            Time [s].
        estimate : Estimate
            The estimator's output (``q``, ``omega`` and, for the gyroscopic term, ``h_wheels``).
        """
        q_r, w_r = self.reference(t)
        q = quat.as_unit_quaternion(estimate.q, "estimate.q")
        w = np.asarray(estimate.omega, dtype=float)
        h_b = getattr(estimate, "h_body", None)
        h_b = np.zeros(3) if h_b is None else np.asarray(h_b, dtype=float)
        out = self.torque_components(list(q), list(w), list(h_b), [*q_r, *w_r])
        return np.array([float(v) for v in out])


# ---------------------------------------------------------------------------
# Rate-limited eigenaxis slews (Wie and Lu, 1995)
# ---------------------------------------------------------------------------

SATURATION_MODES = ("initial", "norm")


def _warn_if_above_tenth_of_sample_rate(wn_max: float, period: float, stacklevel: int) -> None:
    """The :meth:`QuaternionPD.from_bandwidth` warning, shared with :class:`RateLimitedPD`."""
    sample_rate = 2.0 * np.pi / period
    if wn_max > 0.1 * sample_rate:
        warnings.warn(
            f"wn = {wn_max:.4g} rad/s is above a tenth of the sample rate ({sample_rate:.4g} rad/s): "
            "sampling and delay will erode the designed damping",
            stacklevel=stacklevel + 1,
        )


class RateLimitedPD:
    """Quaternion feedback with a slew-rate limit (Wie and Lu, 1995).

    .. math::

        \\tau = -J\\,(k\\, \\mathrm{sat}_L(q_{e,v}) + c\\, \\omega)
                \\;[+\\; \\omega \\times (J \\omega + h)]

    with ``K = k J``, ``C = c J`` (one ``k`` and one ``c`` for all axes),
    ``q_e = q_ref* ⊗ q`` on the shortest way and ``sat_L`` the per-axis
    saturation ``sat_L(x)_i = clip(x_i, -L_i, L_i)``. Sources: B. Wie and
    J. Lu, "Feedback control logic for spacecraft eigenaxis rotations under
    slew rate and control constraints", J. Guidance, Control, and Dynamics
    18(6), 1372-1379, 1995; B. Wie, *Space Vehicle Dynamics and Control*,
    2nd ed., AIAA 2008, section on rapid multitarget acquisition.

    **Saturation limits (derivation).** With the gyroscopic term and the
    true inertia, the closed loop is ``omega_dot = -k sat_L(e) - c omega``
    (``e = q_e,v``), whatever ``J`` is (full tensors included). While every
    axis is saturated the torque term is constant and ``omega`` relaxes with
    time constant ``1/c`` to the coast rate ``omega_c = -(k/c) sat_L(e)``,
    ``|omega_c,i| = (k/c) L_i``. Asking the coast to run *along the
    eigenaxis* ``e(0)/|e(0)|`` *at exactly* ``rate_max`` gives

    .. math::

        L_i = \\frac{c}{k}\\, \\omega_{max}\\, \\frac{|e_i(0)|}{\\lVert e(0) \\rVert}.

    Starting at rest, ``omega`` stays parallel to ``e(0)`` and the kinematics
    ``e_dot = 0.5 (e_0 omega + e x omega) = 0.5 e_0 omega`` keep ``e``
    parallel to ``e(0)``: every component leaves its limit at the same
    instant (when ``|e| = (c/k) rate_max``) and the rest of the slew is the
    linear quaternion feedback on the same axis. ``|omega|`` never exceeds
    ``rate_max``: it approaches it from below during the acceleration, and
    in the linear region ``d|omega|/dt = k|e| - c|omega|`` is negative
    whenever ``|omega| = rate_max`` because ``k|e| < c rate_max`` there.
    (The same bound holds for the zero-order-hold sampled law when
    ``c T < 1``: each step is a convex combination of the previous rate and
    a rate below ``rate_max``.)

    **Where the factor 2 goes.** ``q_v`` is half the rotation angle, so the
    linear closed loop about the target is ``theta'' + c theta' + (k/2)
    theta = 0``: ``k = 2 wn^2`` and ``c = 2 zeta wn``
    (:meth:`from_bandwidth`), the same factor as in :class:`QuaternionPD`.
    The limits involve only the ratio ``c/k`` and the coast-rate condition
    ``(k/c) L = rate_max`` contains no half-angle factor: the rate is set
    by ``sat_L(e)`` directly, not by the angle. The equivalent "cascade"
    writing ``J P sat(P^-1 k e)`` with ``P = c rate_max |e(0)|/|e(0)|``
    (per axis) is the same law.

    **How the controller learns the initial error.** ``saturation="initial"``
    (the published law) needs ``e(0)`` of each new target. It is *latched*:

    * from ``q_start`` at construction, or from ``q_now`` in
      :meth:`retarget` (``retarget(q_ref, q_now)``); or
    * otherwise at the first :meth:`torque` call after construction or after
      :meth:`retarget` without ``q_now`` (from that call's estimate).

    The compiled engine evaluates the law without Python state, so it needs
    the limits before the run (``q_start`` or ``retarget(q_ref, q0)``); the
    limits are then constant inputs. A slew with ``|e(0)| <= (c/k)
    rate_max`` never reaches the rate limit (the linear loop started there
    keeps ``|omega| <= rate_max``, same argument as above): its limits are
    ``(c/k) rate_max`` on every axis, so the law is the plain linear PD for
    that target, stiff about every axis (this also covers ``e(0) = 0``,
    whose direction is rounding noise). The limits are continuous across
    ``|e(0)| = (c/k) rate_max``: either choice leaves that slew unsaturated.

    A flaw of the published law, corrected here: in a slew that does reach
    the limit, an axis with ``e_i(0) = 0`` gets ``L_i = 0``, i.e. no
    attitude stiffness about it until the next retarget (only rate damping),
    so a small off-axis rate never settles. The limits are therefore opened
    near the target, ``L'_i = max(L_i, (c/k) rate_max - |e|)``: identical to
    the published law while ``|e| >= (c/k) rate_max`` and along the
    eigenaxis, linear on every axis as ``|e|`` goes to zero, continuous, and
    ``|sat(e)| <= (c/k) rate_max`` still bounds the coast rate.
    ``saturation="norm"`` is the memoryless variant
    ``sat(e) = e min(1, (c/k) rate_max / |e|)``: identical to the latched
    law along the eigenaxis (``e`` parallel to ``e(0)``), stiff about every
    axis, and it needs no latching.

    Actuator torque limits are left to the actuators; a direction-preserving
    allocation (:class:`attitude.actuators.ReactionWheels` with
    ``torque_saturation="scale"``, the default) keeps the torque along
    ``J e(0)``. The torque peaks at the start of a rate-limited slew at
    ``c rate_max |J e(0)|/|e(0)|`` (without gyroscopic term).

    Parameters
    ----------
    k : float
        Attitude gain per unit inertia [1/s^2] (``K = k J``).
    c : float
        Rate gain per unit inertia [1/s] (``C = c J``).
    rate_max : float
        Slew-rate limit [rad/s].
    inertia : array_like (3,) or (3, 3)
        Spacecraft inertia ``J`` [kg m^2] (principal moments or tensor).
    period : float
        Sample time [s].
    q_ref : array_like (4,)
        Target attitude ``q_RN`` (held constant; the law is for rest-to-rest
        slews).
    q_start : array_like (4,), optional
        Attitude at the start of the slew, to latch the limits at once.
    gyroscopic : bool
        Add ``omega x (J omega + h)`` (default True: the eigenaxis derivation
        assumes it).
    saturation : {"initial", "norm"}
        The published per-axis law with limits from the initial error, or the
        memoryless norm saturation (see above).

    Raises
    ------
    ValueError
        Non-positive or non-scalar gains or rate limit, a bad inertia or
        quaternion, or an unknown ``saturation``.
    """

    #: The compiled path may keep this law's closed loop by the class and its pickle: the law reads nothing else
    #: (attitude.simulation.engine caches the compiled loop; a user's law without this flag is rebuilt each run).
    compiled_law_cacheable = True

    def __init__(
        self,
        *,
        k: float,
        c: float,
        rate_max: float,
        inertia: ArrayLike,
        period: float,
        q_ref: ArrayLike | None = None,
        q_start: ArrayLike | None = None,
        gyroscopic: bool = True,
        saturation: str = "initial",
    ) -> None:
        self.k = positive_scalar(k, "k", why=_SCALAR_GAIN)
        self.c = positive_scalar(c, "c", why=_SCALAR_GAIN)
        self.rate_max = positive_scalar(rate_max, "rate_max", why=_SCALAR_GAIN)
        self.inertia = RigidBody(inertia).inertia
        if self.inertia.shape != (3, 3):
            raise ValueError(f"inertia must describe one body, got a batch of shape {self.inertia.shape[:-2]}")
        self.period = positive_scalar(period, "period", why=_SCALAR_GAIN)
        if saturation not in SATURATION_MODES:
            raise ValueError(f"saturation must be one of {SATURATION_MODES}, got {saturation!r}")
        self.saturation = saturation
        self.gyroscopic = bool(gyroscopic)
        self.q_ref = quat.identity() if q_ref is None else quat.as_unit_quaternion(q_ref, "q_ref")
        if self.q_ref.shape != (4,):
            raise ValueError(f"q_ref must have shape (4,), got {self.q_ref.shape}")
        self.limits: NDArray[np.float64] | None = None
        if q_start is not None:
            self.retarget(self.q_ref, q_start)

    def __repr__(self) -> str:
        return (
            f"RateLimitedPD(k={self.k:.6g}, c={self.c:.6g}, rate_max={self.rate_max:.6g}, "
            f"period={self.period:.6g}, saturation={self.saturation!r}, limits={self.limits})"
        )

    @classmethod
    def from_bandwidth(
        cls,
        body: RigidBody,
        *,
        wn: float,
        zeta: float,
        rate_max: float,
        period: float,
        **kwargs: Any,
    ) -> RateLimitedPD:
        """Gains ``k = 2 wn^2`` [1/s^2], ``c = 2 zeta wn`` [1/s] for the linear region.

        Parameters
        ----------
        body : RigidBody
            The spacecraft (its inertia becomes ``J``) [kg m^2].
        wn : float
            Natural frequency [rad/s] of the linear closed loop about the
            target (one value: the eigenaxis property needs ``K = k J``).
        zeta : float
            Damping ratio of the linear closed loop.
        rate_max : float
            Slew-rate limit [rad/s].
        period : float
            Sample time [s]. Warns when ``wn`` exceeds a tenth of the sample
            rate ``2 pi / period``, like :meth:`QuaternionPD.from_bandwidth`.
        **kwargs
            Passed to the constructor (``q_ref``, ``q_start``, ...).
        """
        if not isinstance(body, RigidBody) or body.batch_shape:
            raise ValueError("body must be a single RigidBody")
        wn = positive_scalar(wn, "wn", why=_SCALAR_GAIN)
        zeta = positive_scalar(zeta, "zeta", why=_SCALAR_GAIN)
        period = positive_scalar(period, "period", why=_SCALAR_GAIN)
        _warn_if_above_tenth_of_sample_rate(wn, period, stacklevel=2)
        return cls(k=2.0 * wn**2, c=2.0 * zeta * wn, rate_max=rate_max, inertia=body.inertia, period=period, **kwargs)

    # -- gains and limits ------------------------------------------------------------

    @property
    def K(self) -> NDArray[np.float64]:
        """Attitude gain ``k J`` [N m] (linear region; for linear analysis)."""
        return self.k * self.inertia

    @property
    def C(self) -> NDArray[np.float64]:
        """Rate gain ``c J`` [N m s]."""
        return self.c * self.inertia

    @property
    def error_limit(self) -> float:
        """``(c/k) rate_max``: the ``|q_e,v|`` below which the law is linear [-]."""
        return self.c / self.k * self.rate_max

    def saturation_limits(self, q_ref: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
        """Limits ``L_i = (c/k) rate_max |e_i| / |e|`` [-] for the error from ``q`` to ``q_ref``.

        ``e`` is the vector part of the shortest-way error ``q_ref* ⊗ q``.
        When ``|e| <= (c/k) rate_max`` (a slew too small to reach the rate
        limit) every limit is ``(c/k) rate_max`` (class docstring).

        Parameters
        ----------
        q_ref : array_like
            Target attitude ``q_RN`` (4,).
        q : array_like
            Attitude ``q_BN`` (4,) at the start of the slew.
        """
        e = quat.error_quaternion(q_ref, q)
        if e.shape != (4,):
            raise ValueError(f"q_ref and q must be single quaternions, got shape {e.shape}")
        v = e[1:]
        n = float(np.linalg.norm(v))
        if n <= self.error_limit:
            return np.full(3, self.error_limit)
        return self.error_limit * np.abs(v) / n

    def retarget(self, q_ref: ArrayLike, q_now: ArrayLike | None = None) -> None:
        """Start a new slew to ``q_ref``.

        Parameters
        ----------
        q_ref : array_like (4,)
            New target attitude ``q_RN``.
        q_now : array_like (4,), optional
            Attitude at the start of the slew: latches the limits now.
            Without it they are latched at the next :meth:`torque` call.
        """
        q_ref = quat.as_unit_quaternion(q_ref, "q_ref")
        if q_ref.shape != (4,):
            raise ValueError(f"q_ref must have shape (4,), got {q_ref.shape}")
        self.q_ref = q_ref
        self.limits = None
        if q_now is not None:
            q_now = quat.as_unit_quaternion(q_now, "q_now")
            self.limits = self.saturation_limits(q_ref, q_now)

    def prepare(self, t: float, q: ArrayLike, omega: ArrayLike) -> None:
        """Engine hook before each run: latch the limits from that run's initial attitude.

        A controller reused for a second run (another start attitude) must not
        keep the first run's limits: they would hold the error at zero on the
        axes the first slew did not use.

        Parameters
        ----------
        t : float
            Start time of the run [s].
        q : array_like
            Initial attitude ``q_BN`` (4,).
        omega : array_like
            Initial body rate ``omega_BN_B`` [rad/s] (3,).
        """
        if self.saturation == "initial":
            self.limits = self.saturation_limits(self.q_ref, q)

    # -- reference (rest-to-rest: the target is at rest) ---------------------------

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Target attitude ``q_RN`` and rate (zero) [rad/s] at ``t``.

        Parameters
        ----------
        t : float
            Time [s].
        """
        return self.q_ref, np.zeros(3)

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Targets at many times: ``q_ref`` (n, 4) and zero rates (n, 3).

        Parameters
        ----------
        t : array_like
            Times [s], shape (n,).
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.tile(self.q_ref, (t.size, 1)), np.zeros((t.size, 3))

    def _limits_for_compiled(self) -> NDArray[np.float64]:
        if self.saturation == "norm":
            return np.full(3, self.error_limit)
        if self.limits is None:
            raise ValueError(
                "RateLimitedPD limits are not latched: the compiled engine needs the initial error before the "
                "run; pass q_start=q0, call retarget(q_ref, q0), use saturation='norm' or engine='python'"
            )
        return self.limits

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Constant inputs ``[q_ref; L]`` (7, len(t)) for the compiled engine.

        Parameters
        ----------
        t : ndarray
            Tick times [s].
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        column = np.concatenate([self.q_ref, self._limits_for_compiled()])
        return np.tile(column[:, None], (1, t.size))

    # -- law ------------------------------------------------------------------------

    def torque_components(self, q: Components, omega: Components, h_body: Components, inputs: Components) -> Components:
        """The control law on components; ``inputs = [q_ref (4), L (3)]``.

        Parameters
        ----------
        q : list
            Attitude components ``[w, x, y, z]`` of ``q_BN`` (numbers or casadi expressions).
        omega : list
            Body rate components ``omega_BN_B`` [rad/s].
        h_body : list
            Internal (wheel) momentum in body components [N m s].
        inputs : list
            ``[q_ref (4), L (3)]`` components.
        """
        q_e, _ = quaternion_error_components(inputs[:4], q)
        e = q_e[1:]
        if self.saturation == "norm":
            norm = bk.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
            scale = self.error_limit / bk.fmax(norm, self.error_limit)
            sat = [scale * ei for ei in e]
        else:
            # The latched limits, opened to the linear region near the target: L'_i = max(L_i, (c/k) rate_max
            # - |e|). Unchanged while |e| >= (c/k) rate_max (the published coast) and along the eigenaxis,
            # where the published law is linear there too; near the target every axis is linear again, so an
            # axis with L_i ~ 0 (off the slew) regains its stiffness. |sat| <= (c/k) rate_max still holds.
            norm = bk.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
            opening = self.error_limit - norm
            sat = [bk.clip(ei, -bk.fmax(li, opening), bk.fmax(li, opening)) for ei, li in zip(e, inputs[4:7])]
        accel = [-(self.k * s + self.c * w) for s, w in zip(sat, omega)]
        tau = []
        for i in range(3):
            acc = 0.0 * omega[0]
            for j in range(3):
                if self.inertia[i, j] != 0.0:
                    acc = acc + self.inertia[i, j] * accel[j]
            tau.append(acc)
        if self.gyroscopic:
            h_tot = [sum(self.inertia[i, j] * omega[j] for j in range(3)) + h_body[i] for i in range(3)]
            tau = [a + b for a, b in zip(tau, cross(omega, h_tot))]
        return tau

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque [N m]; latches the limits at the first call of a slew.

        Parameters
        ----------
        t : float
            Time [s].
        estimate : Estimate
            The estimator's output (anything with ``q`` and ``omega``).
        """
        q = np.asarray(estimate.q, dtype=float)
        w = np.asarray(estimate.omega, dtype=float)
        if self.saturation == "initial" and self.limits is None:
            self.limits = self.saturation_limits(self.q_ref, q)
        h_b = getattr(estimate, "h_body", None)
        h_b = np.zeros(3) if h_b is None else np.asarray(h_b, dtype=float)
        limits = self.limits if self.saturation == "initial" else np.full(3, self.error_limit)
        out = self.torque_components(list(q), list(w), list(h_b), [*self.q_ref, *limits])
        return np.array([float(v) for v in out])

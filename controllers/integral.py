"""Integral action with anti-windup: a quaternion PID and an LQR with integral states (LQI).

Both laws are a static feedback on the attitude error plus an integral term,
sampled every ``T = period``:

.. math::

    \\tau_k = -G\\, x_k + I_k, \\qquad x = [q_{e,v},\\ \\omega_e],

    I_{k+1} = I_k + T\\,\\bigl(-K_i\\, q_{e,v,k}
              + (\\hat\\tau_k - \\tau_k) / T_t\\bigr)

with ``q_e = q_ref* ⊗ q`` on the shortest way
(:func:`controllers.pd.quaternion_error_components`), ``I`` the integral
term [N m] (``I = -K_i z`` with ``z = sum_k T q_e,v,k`` [s] the forward-Euler
integral of the error), and ``tau_hat`` the torque the actuators will
deliver for the command ``tau`` (the actuator model below). A constant
disturbance torque ``tau_d`` leaves the PD an exact steady error
``q_e,v = K^-1 tau_d`` (at rest every other term of the law and of the
equations of motion vanishes); with the integral the only equilibrium is
``q_e,v = 0``, ``I = -tau_d``.

**Anti-windup** (K. J. Åström and R. M. Murray, *Feedback Systems*, 2nd ed.,
Princeton 2021, ch. 11, PID control, on integrator windup; K. J. Åström and
T. Hägglund, *Advanced PID Control*, ISA 2006, the section on integrator
windup):

* ``"back_calculation"`` (the default): the difference between the
  delivered and the commanded torque is fed back into the integrator with
  the tracking time constant ``T_t`` (the equation above). While the
  actuator is saturated ``I`` relaxes to the value that puts the command on
  the actuator limit, geometrically with ratio ``1 - T / T_t`` per sample:
  ``T_t >= T`` keeps that relaxation monotone (``T_t < T/2`` would make it
  diverge), so smaller values are refused. Default ``T_t = sqrt(T_i T_d)``
  per axis (Åström and Hägglund's rule; on the diagonal gains
  ``T_i = K / K_i``, ``T_d = 2 C / K``, the 2 because ``q_e,v`` is half the
  angle, so ``sqrt(T_i T_d) = sqrt(2 C / K_i)``), the smallest over the axes,
  at least ``T``.
* ``"clamping"`` (conditional integration): an axis stops integrating while
  the actuators do not deliver its command and the integration would push
  the command further beyond what they deliver.
* ``"none"``: the plain integral (it winds up; for comparison).

**Actuator model.** ``wheels``: the :class:`~attitude.actuators.ReactionWheels`
the run flies; the delivered torque is ``wheels.body_torque(wheels.allocate(
tau, h_wheels, omega))`` on the estimate's wheel momenta and rate, the same
allocation (torque and speed limits, ``torque_saturation`` ``"scale"`` or
``"clip"``) the engine applies to the command (friction aside). Or
``torque_max``: a per-axis limit, each body torque clipped alone. Anti-windup
needs one of them.

**State.** The integral advances once per :meth:`torque` call, i.e. at the
controller's period, after the command of that sample is formed with the
previous ``I`` (so ``I_k`` shapes ``tau_k``). :meth:`prepare` (called by
:func:`attitude.simulate` before each run) and :meth:`reset` set ``I`` to
``integral_torque0`` (zero unless given); :meth:`retarget` changes the
reference and keeps ``I``, the estimate of the disturbance, so a new target
starts without a bump. ``log()`` gives ``I`` after the update.

These controllers carry state, so they fly on the engine's protocol path
only: they offer no ``torque_components``/``compiled_inputs`` (the compiled
path evaluates a stateless law) and do not set ``compiled_law_cacheable``.

**Linear form.** :meth:`feedback_system` gives the law as an LTI from
``[q_v, omega]`` to the torque with the negative-feedback convention of
:mod:`controllers.analysis` (``u = -G_c y``): state ``z``, ``z' = q_v`` (or
``z_{k+1} = z_k + T q_v,k`` when discrete), output ``G x + K_i z``. It is
exact while the actuators deliver the command (the anti-windup term is then
zero), so :func:`controllers.analysis.loop_gain`, ``margins`` and the disk
margins read it; each loop gains a pole at the origin (type 3 with the
double integrator).

**PID by pole placement.** Per axis, the linearised body ``J theta'' = tau``
with ``q_e,v = theta / 2`` and ``tau = -K q_v - C omega - K_i z``
(``z' = q_v``) has the characteristic polynomial
``J s^3 + C s^2 + (K/2) s + K_i/2``. Matching it to
``J (s + a)(s^2 + 2 zeta wn s + wn^2)`` (the pole-placement form of PID
design for a second-order process in Åström and Hägglund, *Advanced PID
Control*, with ``a`` the third, real pole; ``a = wn / alpha`` with ``alpha`` in 2 to 10 keeps the integral slow
beside the attitude loop) gives

.. math::

    C = J (a + 2 \\zeta \\omega_n), \\quad
    K = 2 J (\\omega_n^2 + 2 \\zeta \\omega_n a), \\quad
    K_i = 2 J a \\omega_n^2,

with ``J`` the inertia tensor and diagonal ``wn``, ``zeta``, ``a`` (as in
:meth:`controllers.pd.QuaternionPD.from_bandwidth`, so ``J^-1 K / 2`` etc.
hold as matrices). The integral time ``T_i = K / K_i = (wn^2 + 2 zeta wn a)
/ (a wn^2)``. The PD part is exactly
``QuaternionPD.from_bandwidth(wn=wn_pd, zeta=zeta_pd)`` with
``wn_pd^2 = wn^2 + 2 zeta wn a`` and ``2 zeta_pd wn_pd = a + 2 zeta wn``.

**LQI.** :func:`design_lqi` augments the 6-state model of
:func:`attitude.linearize.linearize` (states ``[q_ev, omega]``) with
``z = integral of q_ev``: continuous ``z' = q_ev``; at a sample time ``T``
the zero-order-hold plant with the flown forward-Euler integrator
``z_{k+1} = z_k + T q_ev,k`` (python-control's ``integral_action``
convention for ``dlqr`` with the matrix ``T [I 0]``), then
:func:`controllers.lqr.design_lqr` on the 9-state system: ``u = -K_x x -
K_z z``, flown by :class:`LQIController` with ``K_i = K_z``.
"""

from __future__ import annotations

from typing import Any

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.actuators import ReactionWheels
from attitude.rigid_body import RigidBody
from attitude.validation import (
    check_positive,
    check_vector,
    describe,
    gain_matrix,
    positive_per_axis,
    positive_scalar,
)
from controllers.lqr import LQRDesign, design_lqr
from controllers.pd import QuaternionPD, quaternion_error_components

__all__ = [
    "ANTI_WINDUP_MODES",
    "SATURATION_TOLERANCE",
    "LQIController",
    "QuaternionPID",
    "design_lqi",
]

#: How the integrator is kept from winding up (module docstring).
ANTI_WINDUP_MODES = ("back_calculation", "clamping", "none")

#: A delivered torque within this fraction of the command's largest component counts as the command itself:
#: the allocation round trip ``A A^+ tau`` returns an unsaturated command to ~1e-16 relative, which must not
#: read as saturation (clamping would freeze the integral on rounding); 1e-9 is far above that and far below
#: any real saturation.
SATURATION_TOLERANCE = 1e-9

_STATE_COUNT = 6  # [q_ev, omega] of attitude.linearize


def _tracking_time_rule(C: NDArray[np.float64], K_i: NDArray[np.float64], period: float) -> float:
    """``sqrt(T_i T_d) = sqrt(2 C_jj / K_i,jj)``, the smallest over the axes and at least ``period`` [s]."""
    c, k_i = np.diag(C), np.diag(K_i)
    if np.any(c <= 0) or np.any(k_i <= 0):
        raise ValueError(
            "tracking_time [s] must be given: the rule sqrt(T_i T_d) = sqrt(2 C_jj / K_i,jj) needs positive "
            f"diagonal rate and integral gains, got {describe(c)} and {describe(k_i)}"
        )
    return max(period, float(np.min(np.sqrt(2.0 * c / k_i))))


class _IntegralAction:
    """The integral term, its anti-windup and its linear form (module docstring); the laws add the static part."""

    def _init_integral(
        self,
        *,
        K_i: NDArray[np.float64],
        period: float,
        anti_windup: str,
        tracking_time: float | None,
        wheels: ReactionWheels | None,
        torque_max: ArrayLike | None,
        integral_torque0: ArrayLike | None,
        default_tracking_time: float | None,
    ) -> None:
        self.K_i = K_i
        self.period = period
        if anti_windup not in ANTI_WINDUP_MODES:
            raise ValueError(f"anti_windup must be one of {ANTI_WINDUP_MODES}, got {anti_windup!r}")
        self.anti_windup = anti_windup
        if wheels is not None and not isinstance(wheels, ReactionWheels):
            raise ValueError(f"wheels must be a ReactionWheels or None, got {type(wheels).__name__}")
        if wheels is not None and torque_max is not None:
            raise ValueError("give one actuator model: wheels (ReactionWheels) or torque_max (per axis), not both")
        self.wheels = wheels
        self.torque_max = None
        if torque_max is not None:
            limit = check_positive(torque_max, "torque_max")
            if limit.shape not in ((), (1,), (3,)):
                raise ValueError(f"torque_max must be a scalar or one limit per axis (3,) [N m], got {limit.shape}")
            self.torque_max = np.broadcast_to(limit.reshape(-1), (3,)).astype(float)
        if anti_windup != "none" and wheels is None and self.torque_max is None:
            raise ValueError(
                f"anti_windup={anti_windup!r} needs the actuator limit: pass wheels (the ReactionWheels flown) "
                "or torque_max (per-axis body torque limit [N m]); anti_windup='none' for the plain integral"
            )
        self.tracking_time: float | None = None
        if anti_windup == "back_calculation":
            if tracking_time is None:
                tracking_time = default_tracking_time
            if tracking_time is None:
                raise ValueError("tracking_time [s] is required for anti_windup='back_calculation'")
            tracking_time = positive_scalar(tracking_time, "tracking_time")
            if tracking_time < period:
                raise ValueError(
                    f"tracking_time must be at least the period ({period!r} s): the sampled back-calculation "
                    f"relaxes by 1 - period / tracking_time per sample, got tracking_time = {tracking_time!r} s"
                )
            self.tracking_time = tracking_time
        elif tracking_time is not None:
            raise ValueError(f"tracking_time is used by anti_windup='back_calculation' only, got {anti_windup!r}")
        start = np.zeros(3) if integral_torque0 is None else check_vector(integral_torque0, "integral_torque0", 3)
        if start.shape != (3,):
            raise ValueError(f"integral_torque0 must have shape (3,) [N m], got {start.shape}")
        self.integral_torque0 = np.array(start, dtype=float)
        self.integral_torque = self.integral_torque0.copy()

    # -- the actuator model ----------------------------------------------------------

    def delivered_torque(self, torque_command: ArrayLike, estimate: Any) -> NDArray[np.float64]:
        """Body torque [N m] the actuator model delivers for ``torque_command`` (the command without a model).

        Parameters
        ----------
        torque_command : array_like (3,)
            Commanded body torque [N m].
        estimate : Estimate
            What the controller sees (``omega`` and, with ``wheels``, ``h_wheels``).
        """
        tau = check_vector(torque_command, "torque_command", 3)
        if self.wheels is not None:
            h = np.asarray(getattr(estimate, "h_wheels", np.zeros(0)), dtype=float).reshape(-1)
            if h.size != self.wheels.n_wheels:
                raise ValueError(
                    f"estimate.h_wheels must hold the {self.wheels.n_wheels} wheel momenta of the wheels model "
                    f"[N m s], got {h.size}: fly the controller with the same wheels"
                )
            omega = check_vector(estimate.omega, "estimate.omega", 3)
            return self.wheels.body_torque(self.wheels.allocate(tau, h, omega))
        if self.torque_max is not None:
            return np.clip(tau, -self.torque_max, self.torque_max)
        return tau

    # -- the integral ----------------------------------------------------------------

    def reset(self) -> None:
        """Set the integral term back to ``integral_torque0`` [N m]."""
        self.integral_torque = self.integral_torque0.copy()

    def prepare(self, t: float, q: ArrayLike, omega: ArrayLike) -> None:
        """Engine hook before each run: the integral starts from ``integral_torque0`` (a run never inherits one).

        Parameters
        ----------
        t : float
            Start time of the run [s].
        q : array_like
            Initial attitude ``q_BN`` (4,) (unused).
        omega : array_like
            Initial body rate [rad/s] (3,) (unused).
        """
        self.reset()

    def log(self) -> dict[str, NDArray[np.float64]]:
        """``integral_torque``: the integral term [N m] after this sample's update."""
        return {"integral_torque": self.integral_torque.copy()}

    def _command(self, error_v: NDArray[np.float64], static_torque: NDArray[np.float64], estimate: Any) -> Any:
        """``tau_k = static + I_k``, then ``I_{k+1}`` with the anti-windup (module docstring)."""
        tau = static_torque + self.integral_torque
        increment = -self.period * (self.K_i @ error_v)
        if self.anti_windup != "none":
            excess = tau - self.delivered_torque(tau, estimate)
            excess[np.abs(excess) <= SATURATION_TOLERANCE * float(np.max(np.abs(tau)))] = 0.0
            if self.anti_windup == "back_calculation":
                increment = increment - (self.period / self.tracking_time) * excess
            else:
                increment = np.where(excess * increment > 0.0, 0.0, increment)
        self.integral_torque = self.integral_torque + increment
        return tau

    # -- linear form -----------------------------------------------------------------

    def _static_gain(self) -> NDArray[np.float64]:  # pragma: no cover - each law defines it
        raise NotImplementedError

    def feedback_system(self, *, discrete: bool) -> control.StateSpace:
        """The law as an LTI from ``[q_v (3), omega (3)]`` to the torque, ``u = -G_c y`` (module docstring).

        Parameters
        ----------
        discrete : bool
            True: the sampled law, ``z_{k+1} = z_k + T q_v,k``, ``dt`` the period.
            False: the continuous law, ``z' = q_v``.

        Returns
        -------
        control.StateSpace
            States ``z`` (3) [s], inputs ``[q_v, omega]``, outputs the torque with the sign reversed [N m].
        """
        step = self.period if discrete else 1.0
        b = np.hstack([step * np.eye(3), np.zeros((3, 3))])
        return control.ss(
            np.eye(3) if discrete else np.zeros((3, 3)),
            b,
            np.asarray(self.K_i, dtype=float),
            self._static_gain(),
            self.period if discrete else 0,
        )


# ---------------------------------------------------------------------------
# PID
# ---------------------------------------------------------------------------


class QuaternionPID(_IntegralAction):
    """Quaternion PD plus the integral of the error-quaternion vector part, with anti-windup (module docstring).

    ``tau = tau_PD + I``, ``tau_PD`` the law of ``pd`` (its reference,
    gyroscopic term and gains), ``I`` the integral term.

    Parameters
    ----------
    pd : QuaternionPD
        The proportional-derivative part (its ``period`` is the PID's).
    K_i : array_like (3,) or (3, 3)
        Integral gain on ``z = integral of q_e,v`` [N m / s], positive definite.
    anti_windup : {"back_calculation", "clamping", "none"}
        See the module docstring.
    tracking_time : float, optional
        Back-calculation time constant ``T_t`` [s] (>= period); default
        ``sqrt(T_i T_d)`` (module docstring).
    wheels : ReactionWheels, optional
        Actuator model: the wheels flown.
    torque_max : float or array_like (3,), optional
        Actuator model: per-axis body torque limit [N m].
    integral_torque0 : array_like (3,), optional
        Integral term at the start of each run [N m] (default zero).

    Raises
    ------
    ValueError
        ``pd`` not a QuaternionPD; ``K_i`` of the wrong shape or not
        positive definite; an unknown ``anti_windup``; anti-windup without an
        actuator model, or with both; a ``tracking_time`` below the period.
    """

    def __init__(
        self,
        pd: QuaternionPD,
        *,
        K_i: ArrayLike,
        anti_windup: str = "back_calculation",
        tracking_time: float | None = None,
        wheels: ReactionWheels | None = None,
        torque_max: ArrayLike | None = None,
        integral_torque0: ArrayLike | None = None,
    ) -> None:
        if not isinstance(pd, QuaternionPD):
            raise ValueError(f"pd must be a QuaternionPD, got {type(pd).__name__}")
        self.pd = pd
        gain = gain_matrix(K_i, "K_i")
        default = _tracking_time_rule(pd.C, gain, pd.period) if anti_windup == "back_calculation" else None
        self._init_integral(
            K_i=gain,
            period=pd.period,
            anti_windup=anti_windup,
            tracking_time=tracking_time,
            wheels=wheels,
            torque_max=torque_max,
            integral_torque0=integral_torque0,
            default_tracking_time=default,
        )

    def __repr__(self) -> str:
        return (
            f"QuaternionPID(K={self.pd.K.tolist()}, C={self.pd.C.tolist()}, K_i={self.K_i.tolist()}, "
            f"period={self.period!r}, anti_windup={self.anti_windup!r}, tracking_time={self.tracking_time!r})"
        )

    @classmethod
    def from_bandwidth(
        cls,
        body: RigidBody,
        *,
        wn: ArrayLike,
        zeta: ArrayLike,
        integral_pole: ArrayLike,
        period: float,
        anti_windup: str = "back_calculation",
        tracking_time: float | None = None,
        wheels: ReactionWheels | None = None,
        torque_max: ArrayLike | None = None,
        integral_torque0: ArrayLike | None = None,
        **kwargs: Any,
    ) -> QuaternionPID:
        """Gains placing each axis at ``(s + a)(s^2 + 2 zeta wn s + wn^2)`` (module docstring).

        Parameters
        ----------
        body : RigidBody
            The spacecraft (its inertia [kg m^2] sets the gains).
        wn : array_like
            Natural frequency of the complex pair per axis [rad/s], scalar or (3,).
        zeta : array_like
            Damping ratio of the pair per axis [-], scalar or (3,).
        integral_pole : array_like
            The real pole ``a`` per axis [rad/s] (> 0), scalar or (3,);
            e.g. ``wn / 4``.
        period : float
            Sample time [s] (warns like :meth:`QuaternionPD.from_bandwidth`
            when the PD part's ``wn_pd`` is above a tenth of the sample rate).
        anti_windup : {"back_calculation", "clamping", "none"}
            See the module docstring.
        tracking_time : float, optional
            Back-calculation time constant [s]; default ``sqrt(T_i T_d)``.
        wheels : ReactionWheels, optional
            Actuator model: the wheels flown.
        torque_max : float or array_like (3,), optional
            Actuator model: per-axis body torque limit [N m].
        integral_torque0 : array_like (3,), optional
            Integral term at the start of each run [N m] (default zero).
        **kwargs
            Further fields of the :class:`QuaternionPD` part (``q_ref``, ``reference_fn``, ``gyroscopic``).
        """
        if not isinstance(body, RigidBody) or body.batch_shape:
            raise ValueError(f"body must be a single RigidBody, got {type(body).__name__}")
        wn = positive_per_axis(wn, "wn")
        zeta = positive_per_axis(zeta, "zeta")
        a = positive_per_axis(integral_pole, "integral_pole")
        wn_pd = np.sqrt(wn**2 + 2.0 * zeta * wn * a)
        zeta_pd = (a + 2.0 * zeta * wn) / (2.0 * wn_pd)
        pd = QuaternionPD.from_bandwidth(body, wn=wn_pd, zeta=zeta_pd, period=period, **kwargs)
        K_i = 2.0 * body.inertia @ np.diag(a * wn**2)
        return cls(
            pd,
            K_i=K_i,
            anti_windup=anti_windup,
            tracking_time=tracking_time,
            wheels=wheels,
            torque_max=torque_max,
            integral_torque0=integral_torque0,
        )

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitude ``q_RN`` and rate ``omega_RN_R`` [rad/s] at ``t`` (the PD part's).

        Parameters
        ----------
        t : float
            Time [s].
        """
        return self.pd.reference(t)

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """References at many times (the PD part's): ``q_ref`` (n, 4), ``omega_ref`` (n, 3).

        Parameters
        ----------
        t : array_like
            Times [s], shape (n,).
        """
        return self.pd.reference_samples(t)

    def retarget(self, q_ref: ArrayLike) -> None:
        """Hold a new constant reference ``q_RN``; the integral term is kept (no bump).

        Parameters
        ----------
        q_ref : array_like (4,)
            New reference attitude.
        """
        q_ref = quat.as_unit_quaternion(q_ref, "q_ref")
        if q_ref.shape != (4,):
            raise ValueError(f"q_ref must have shape (4,), got {q_ref.shape}")
        self.pd.q_ref = q_ref
        self.pd.reference_fn = None

    def _static_gain(self) -> NDArray[np.float64]:
        return np.hstack([self.pd.K, self.pd.C])

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque [N m]; advances the integral by one period.

        Parameters
        ----------
        t : float
            Time [s].
        estimate : Estimate
            The estimator's output (``q``, ``omega``; ``h_wheels`` with a wheels model).
        """
        q_r, _ = self.pd.reference(t)
        q = quat.as_unit_quaternion(estimate.q, "estimate.q")
        q_e, _ = quaternion_error_components(list(q_r), list(q))
        return self._command(np.array(q_e[1:], dtype=float), self.pd.torque(t, estimate), estimate)


# ---------------------------------------------------------------------------
# LQI
# ---------------------------------------------------------------------------


def design_lqi(plant: control.StateSpace, *, Q: ArrayLike, R: ArrayLike, period: float | None = None) -> LQRDesign:
    """LQR with integral states: the plant augmented with ``z = integral of q_ev`` (module docstring).

    Parameters
    ----------
    plant : control.StateSpace
        Continuous 6-state model of :func:`attitude.linearize.linearize`
        (states ``[q_ev, omega]``, inputs the body torque [N m]).
    Q : array_like (9, 9) or (9,)
        Weight on ``[q_ev, omega, z]`` (``z`` in s), symmetric positive
        semi-definite; the ``z`` block must be non-zero (the integrators are
        marginal modes only the cost can see).
    R : array_like (3, 3) or (3,)
        Torque weight [1/(N m)^2], symmetric positive definite.
    period : float, optional
        Sample time [s]: the discrete design on the zero-order-hold plant with
        the flown integrator ``z_{k+1} = z_k + T q_ev,k``. None: continuous.

    Returns
    -------
    LQRDesign
        ``K`` (3, 9) ``= [K_x, K_z]`` on the states ``[q_ev, omega, z]``, the
        augmented closed loop and its poles.

    Raises
    ------
    ValueError
        ``plant`` not a continuous StateSpace with 6 states and 3 inputs; the
        checks of :func:`controllers.lqr.design_lqr` on the augmented system
        (weights, stabilisability, detectability).
    """
    if not isinstance(plant, control.StateSpace):
        raise ValueError(f"plant must be a control.StateSpace, got {type(plant).__name__}")
    if not plant.isctime(strict=True):
        raise ValueError(f"plant must be continuous-time (dt = 0; period discretises it), got dt = {plant.dt!r}")
    if plant.nstates != _STATE_COUNT or plant.ninputs != 3:
        raise ValueError(
            "plant must be the 6-state attitude model of attitude.linearize (states [q_ev, omega], 3 torques), "
            f"got {plant.nstates} states and {plant.ninputs} inputs"
        )
    selector = np.hstack([np.eye(3), np.zeros((3, 3))])  # z integrates q_ev, the first three states
    if period is None:
        A, B, dt = np.asarray(plant.A, dtype=float), np.asarray(plant.B, dtype=float), 0
        A_aug = np.block([[A, np.zeros((6, 3))], [selector, np.zeros((3, 3))]])
    else:
        dt = float(check_positive(period, "period"))
        sampled = control.c2d(plant, dt, "zoh")
        A, B = np.asarray(sampled.A, dtype=float), np.asarray(sampled.B, dtype=float)
        A_aug = np.block([[A, np.zeros((6, 3))], [dt * selector, np.eye(3)]])
    B_aug = np.vstack([B, np.zeros((3, 3))])
    augmented = control.ss(
        A_aug,
        B_aug,
        np.eye(9),
        np.zeros((9, 3)),
        dt,
        states=[*plant.state_labels, "z1", "z2", "z3"],
        inputs=list(plant.input_labels),
        outputs=[*plant.state_labels, "z1", "z2", "z3"],
        name=f"{plant.name}$integral",
    )
    return design_lqr(augmented, Q=Q, R=R)


class LQIController(_IntegralAction):
    """Flies an LQI design: ``tau = -K_x [q_ev; omega] + I``, ``I = -K_z z``, with anti-windup.

    Parameters
    ----------
    design : LQRDesign
        From :func:`design_lqi` (``K`` of shape (3, 9)).
    q_ref : array_like (4,), optional
        Constant reference attitude ``q_RN`` (identity when None; the design
        is at rest, so the reference rate is zero).
    period : float, optional
        Sample time [s]; defaults to ``design.period`` (required for a
        continuous design, which is then flown with the forward-Euler
        integrator).
    anti_windup : {"back_calculation", "clamping", "none"}
        See the module docstring.
    tracking_time : float, optional
        Back-calculation time constant [s] (>= period); default
        ``sqrt(2 C_jj / K_z,jj)`` with ``C`` the rate block of ``K_x``.
    wheels : ReactionWheels, optional
        Actuator model: the wheels flown.
    torque_max : float or array_like (3,), optional
        Actuator model: per-axis body torque limit [N m].
    integral_torque0 : array_like (3,), optional
        Integral term at the start of each run [N m] (default zero).

    Raises
    ------
    ValueError
        ``design`` not an LQRDesign with a (3, 9) gain; a period other than
        the discrete design's; the integral-action checks of
        :class:`QuaternionPID`.
    """

    def __init__(
        self,
        design: LQRDesign,
        *,
        q_ref: ArrayLike | None = None,
        period: float | None = None,
        anti_windup: str = "back_calculation",
        tracking_time: float | None = None,
        wheels: ReactionWheels | None = None,
        torque_max: ArrayLike | None = None,
        integral_torque0: ArrayLike | None = None,
    ) -> None:
        if not isinstance(design, LQRDesign):
            raise ValueError(f"design must be an LQRDesign (from design_lqi), got {type(design).__name__}")
        K = np.asarray(design.K, dtype=float)
        if K.shape != (3, 9):
            raise ValueError(f"design.K must have shape (3, 9) (design_lqi: [q_ev, omega, z]), got {K.shape}")
        if period is None:
            if design.period is None:
                raise ValueError("period [s] is required for a continuous design (the controller samples)")
            period = design.period
        period = float(check_positive(period, "period"))
        if design.period is not None and abs(period - design.period) > 1e-9 * design.period:
            raise ValueError(
                f"period = {period!r} s must equal the sample time of the discrete design ({design.period!r} s)"
            )
        self.design = design
        self.K_x = K[:, :_STATE_COUNT].copy()
        self.q_ref = quat.identity() if q_ref is None else quat.as_unit_quaternion(q_ref, "q_ref")
        if self.q_ref.shape != (4,):
            raise ValueError(f"q_ref must have shape (4,), got {self.q_ref.shape}")
        K_z = K[:, _STATE_COUNT:].copy()
        default = None
        if anti_windup == "back_calculation" and tracking_time is None:
            default = _tracking_time_rule(self.K_x[:, 3:], K_z, period)
        self._init_integral(
            K_i=K_z,
            period=period,
            anti_windup=anti_windup,
            tracking_time=tracking_time,
            wheels=wheels,
            torque_max=torque_max,
            integral_torque0=integral_torque0,
            default_tracking_time=default,
        )

    def __repr__(self) -> str:
        return (
            f"LQIController(K_x={self.K_x.tolist()}, K_z={self.K_i.tolist()}, period={self.period!r}, "
            f"anti_windup={self.anti_windup!r}, tracking_time={self.tracking_time!r})"
        )

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitude ``q_RN`` and rate (zero) [rad/s] at ``t``.

        Parameters
        ----------
        t : float
            Time [s].
        """
        return self.q_ref, np.zeros(3)

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """References at many times: ``q_ref`` (n, 4) and zero rates (n, 3).

        Parameters
        ----------
        t : array_like
            Times [s], shape (n,).
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.tile(self.q_ref, (t.size, 1)), np.zeros((t.size, 3))

    def retarget(self, q_ref: ArrayLike) -> None:
        """Hold a new reference ``q_RN``; the integral term is kept (no bump).

        Parameters
        ----------
        q_ref : array_like (4,)
            New reference attitude.
        """
        q_ref = quat.as_unit_quaternion(q_ref, "q_ref")
        if q_ref.shape != (4,):
            raise ValueError(f"q_ref must have shape (4,), got {q_ref.shape}")
        self.q_ref = q_ref

    def _static_gain(self) -> NDArray[np.float64]:
        return self.K_x

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque [N m]; advances the integral by one period.

        Parameters
        ----------
        t : float
            Time [s].
        estimate : Estimate
            The estimator's output (``q``, ``omega``; ``h_wheels`` with a wheels model).
        """
        q = check_vector(estimate.q, "estimate.q", 4)
        q = q / np.linalg.norm(q)
        omega = check_vector(estimate.omega, "estimate.omega", 3)
        q_e, _ = quaternion_error_components(list(self.q_ref), list(q))
        error_v = np.array(q_e[1:], dtype=float)
        return self._command(error_v, -self.K_x @ np.concatenate([error_v, omega]), estimate)

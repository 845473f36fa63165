"""Linear analysis of attitude loops: loop gains, margins, sampling and delay, figures.

The linearised rigid body at rest is a double integrator per axis,
``J theta'' = tau``, and the quaternion feedback sees ``q_e,v ≈ theta / 2``
(half the angle). :func:`loop_gain` breaks the loop at the plant input, one
channel at a time with the other channels closed (the classical
loop-at-a-time margins of a MIMO loop), and returns one SISO loop per
channel: for a controller that samples (it has a ``period``) the sampled
loop that flies, with the zero-order hold of :func:`sampled_loop` on every
channel; the continuous loop only when asked for (``sampled=False``).

Margins
-------
:func:`margins` uses :func:`control.stability_margins` (polynomial method)
and then keeps only what it can verify, because python-control 0.10.2 has
edge cases that matter for attitude loops:

* A loop with a double pole at the origin (PD on a double integrator) has
  ``arg L -> -180 deg`` as ``omega -> 0`` without crossing it. Continuous
  loops come out right, but for the zero-order-hold equivalent (double pole
  at ``z = 1``) the polynomial root finder returns a spurious "phase
  crossover" at ``omega ~ 1e-6`` rad/s with a gain margin of ``~1e-9``.
  :func:`margins` keeps a phase crossover only where ``Im L`` changes sign
  and ``Re L < 0``.
* Discrete loops: python-control searches ``0 <= omega T < pi`` only, so a
  crossing *at* the Nyquist frequency (where ``L(-1)`` is real; the usual
  gain margin of a sampled PD loop) is missed. :func:`margins` adds it.
* Discrete loops sampled fast (``omega_c T`` below ~0.01) lose their gain
  crossover altogether: the polynomial roots cluster at ``z = 1`` next to
  the double pole and fail the unit-circle filter. :func:`margins` analyses
  discrete loops in the w-plane (``z = (1 + w T/2)/(1 - w T/2)``, exact:
  ``nu = (2/T) tan(omega T/2)``), where the same routine is well
  conditioned, and maps the crossings back.
* The single ``gm`` it returns is the crossing closest to gain 1 in
  log-scale, which may be a *lower* gain margin (a gain decrease that
  destabilises a conditionally stable loop). :class:`Margins` reports the
  upward and the downward margins separately.

:func:`sweep_margins` is the independent check: it evaluates ``L`` on a fine
logarithmic grid with its own arithmetic, brackets the sign changes of
``log|L|`` and ``Im L / |L|`` and refines them with :func:`scipy.optimize.brentq`.

Sampling and computation delay
------------------------------
:func:`sampled_loop` is the exact discrete equivalent of a loop with a
zero-order hold at the plant input and an input delay (a computation delay,
any fraction of the period: the modified z-transform of Franklin, Powell and
Workman, *Digital Control of Dynamic Systems*, 3rd ed., section 4.3.4).
:func:`delayed_loop` is the continuous approximation with a Pade delay.
The classical estimate is that the zero-order hold costs a delay of ``T/2``,
so the phase margin drops by ``omega_c (T/2 + tau_d)`` rad
(:func:`sample_time_study` tabulates both).

All frequencies are in rad/s, times in s, angles of margins in degrees.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import control
import numpy as np
import scipy.linalg
import scipy.optimize
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from attitude.linearize import linearize
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody
from attitude.validation import as_float_array, check_positive, positive_scalar

__all__ = [
    "Margins",
    "SampleTimeStudy",
    "attitude_closed_loop",
    "broken_channels",
    "closed_loop_poles",
    "controller_period",
    "delayed_loop",
    "input_loop",
    "loop_gain",
    "margins",
    "output_loop",
    "plot_bode",
    "plot_nichols",
    "plot_step",
    "rigid_body_at_rest",
    "sample_time_study",
    "sampled_loop",
    "sweep_margins",
]

#: The linear systems the functions accept.
LTI = control.TransferFunction | control.StateSpace

#: Relative frequency offset used to confirm a crossing: ``Im L`` (or
#: ``|L| - 1``) must change sign between ``omega (1 -+ CROSSING_CHECK)``.
#: Roots of well-conditioned loop polynomials are accurate to ~1e-12
#: relative; 1e-6 is far above that and far below any spacing of genuine
#: crossings.
CROSSING_CHECK = 1e-6

#: Leading polynomial coefficients below this fraction of the largest one
#: are rounding residue of the state-space to transfer-function conversion
#: (which works to ~1e-15 relative) and are dropped.
COEFFICIENT_NOISE = 1e-12

#: Poles and zeros of a loop from :func:`loop_gain` below this fraction of
#: its largest root magnitude are put at the origin: eigenvalues of the
#: double integrator's Jordan block are only computed to ~sqrt(eps) = 1.5e-8
#: relative. (A genuine pole seven decades below the fastest one would be
#: taken for an integrator.)
ORIGIN_SNAP = 1e-7

_AXES = "xyz"
_BOX = {"boxstyle": "round,pad=0.3", "facecolor": "white", "edgecolor": "0.8", "alpha": 0.9}


# ---------------------------------------------------------------------------
# Plant, loop gains and closed loops
# ---------------------------------------------------------------------------


def _single_body(body: Any) -> RigidBody:
    if not isinstance(body, RigidBody) or body.batch_shape:
        raise ValueError(f"body must be a single RigidBody, got {body!r}")
    return body


def rigid_body_at_rest(body: RigidBody) -> control.StateSpace:
    """Linearised rigid body at rest, as the quaternion feedback sees it.

    States ``[theta (3), omega (3)]`` (small rotation vector [rad] and body
    rate [rad/s]), input the body torque [N m], outputs
    ``[q_v (3), omega (3)]`` with ``q_v = theta / 2`` (the vector part of the
    error quaternion is half the angle). Gyroscopic coupling vanishes at
    rest, so each body axis is a double integrator through ``J^-1``.

    Parameters
    ----------
    body : RigidBody
        Inertia ``J`` [kg m^2] (the full tensor is kept).

    Notes
    -----
    The matrices are those of :func:`attitude.linearize.linearize` at rest
    (states ``[q_ev, omega]``) in the coordinates ``theta = 2 q_ev``: the
    similarity transform ``T = diag(2 I, I)``, ``A = T A_q T^-1``,
    ``B = T B_q``, ``C = T^-1`` (exact: powers of two).
    """
    plant = linearize(_single_body(body))
    t = np.diag([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])
    t_inv = np.diag([0.5, 0.5, 0.5, 1.0, 1.0, 1.0])
    return control.ss(
        t @ plant.A @ t_inv,
        t @ plant.B,
        t_inv,
        np.zeros((6, 3)),
        inputs=[f"tau_{a}" for a in _AXES],
        outputs=[f"qv_{a}" for a in _AXES] + [f"omega_{a}" for a in _AXES],
        states=[f"theta_{a}" for a in _AXES] + [f"omega_{a}" for a in _AXES],
        name="rigid_body_at_rest",
    )


def _controller_system(controller: Any, sampled: bool = False) -> control.StateSpace:
    """Controller as an LTI from plant outputs to the torque (``u = -G y``).

    A controller with states of its own (integral action: :mod:`controllers.integral`) gives its linear form
    through ``feedback_system(discrete=sampled)``, discrete at its period for the sampled loop.
    """
    if callable(getattr(controller, "feedback_system", None)):
        return controller.feedback_system(discrete=sampled)
    if hasattr(controller, "K") and hasattr(controller, "C"):
        gain = np.hstack([np.asarray(controller.K, dtype=float), np.asarray(controller.C, dtype=float)])
        return control.ss([], [], [], gain)
    if hasattr(controller, "K"):  # state feedback: an LQRDesign or LQRController
        return control.ss([], [], [], np.atleast_2d(as_float_array(controller.K, "controller.K")))
    if isinstance(controller, (control.StateSpace, control.TransferFunction)):
        return control.ss(controller)
    gain = np.atleast_2d(as_float_array(controller, "controller"))
    if gain.ndim != 2:
        raise ValueError(f"controller must be a static gain matrix (m, p), got shape {gain.shape}")
    return control.ss([], [], [], gain)


def _trim(p: ArrayLike) -> NDArray[np.float64]:
    """A polynomial without leading rounding residue (see :data:`COEFFICIENT_NOISE`)."""
    p = np.atleast_1d(np.asarray(p, dtype=float))
    scale = float(np.max(np.abs(p))) if p.size else 0.0
    if scale == 0.0:
        return np.zeros(1)
    return p[int(np.argmax(np.abs(p) > COEFFICIENT_NOISE * scale)) :].copy()


def _clean_tf(sys: control.TransferFunction) -> control.TransferFunction:
    """A SISO transfer function without leading rounding residue, monic denominator."""
    num, den = _trim(sys.num[0][0]), _trim(sys.den[0][0])
    return control.tf(num / den[0], den / den[0], sys.dt)


def _snap_origin(sys: control.TransferFunction) -> control.TransferFunction:
    """Put the poles and zeros that are numerically at the origin exactly there.

    Without slycot, python-control converts state space to polynomials
    through the eigenvalues of ``A``; the double integrator is a Jordan
    block whose eigenvalues come out at ``~sqrt(eps) rho`` (``rho`` the
    largest root magnitude) instead of 0. Roots below :data:`ORIGIN_SNAP`
    ``rho`` are set to 0, so a double integrator reads ``s^2``.
    """
    num, den = _trim(sys.num[0][0]), _trim(sys.den[0][0])
    z = np.roots(num) if num.size > 1 else np.zeros(0)
    p = np.roots(den) if den.size > 1 else np.zeros(0)
    rho = float(np.max(np.abs(np.concatenate([z, p])), initial=0.0))
    if rho == 0.0:
        return _clean_tf(sys)
    z = np.where(np.abs(z) < ORIGIN_SNAP * rho, 0.0, z)
    p = np.where(np.abs(p) < ORIGIN_SNAP * rho, 0.0, p)
    num = np.real_if_close(num[0] * np.poly(z)) if z.size else num[:1]
    den = np.real_if_close(den[0] * np.poly(p)) if p.size else den[:1]
    return _clean_tf(control.tf(np.real(num), np.real(den), sys.dt))


def controller_period(controller: Any) -> float | None:
    """Sample time [s] of a controller, or None for a continuous one.

    Parameters
    ----------
    controller : object
        A controller with a ``period`` attribute (every controller the
        simulation flies; an :class:`~controllers.lqr.LQRDesign` made at a
        sample time), a discrete control LTI (its ``dt``), or a gain matrix or
        continuous LTI (None: nothing says it samples).

    Returns
    -------
    float or None
        The period [s].
    """
    if isinstance(controller, (control.StateSpace, control.TransferFunction)):
        return float(controller.dt) if _is_discrete(controller) else None
    period = getattr(controller, "period", None)
    return None if period is None else float(check_positive(period, "controller.period"))


def _open_loop(
    plant: Any, controller: Any, sampled: bool | None, computation_delay: float
) -> tuple[control.StateSpace, control.StateSpace, bool]:
    """The plant ``P`` and controller ``G_c`` of the loop, sampled or continuous (see :func:`loop_gain`)."""
    P = rigid_body_at_rest(plant) if isinstance(plant, RigidBody) else plant
    if not isinstance(P, (control.StateSpace, control.TransferFunction)):
        raise ValueError(f"plant must be a RigidBody or a control StateSpace/TransferFunction, got {plant!r}")
    if _is_discrete(P):
        raise ValueError(f"plant must be continuous (loop_gain samples it for a sampled controller), got dt = {P.dt}")
    P = control.ss(P)
    # Filter chains on the command (controllers.filters.FilteredController, nested for chains on different axes)
    # go in series after the law, the innermost first.
    wrappers = []
    law = controller
    while hasattr(law, "filter_system"):
        wrappers.append(law)
        law = law.controller
    if sampled is not None and not isinstance(sampled, bool):
        raise ValueError(f"sampled must be True, False or None, got {sampled!r}")
    delay = float(check_positive(computation_delay, "computation_delay", allow_zero=True))
    period = controller_period(controller)
    if sampled is None:
        sampled = period is not None
    Gc = _controller_system(law, sampled)
    if Gc.ninputs != P.noutputs or Gc.noutputs != P.ninputs:
        raise ValueError(
            f"controller must map the plant's {P.noutputs} outputs to its {P.ninputs} inputs, "
            f"got {Gc.ninputs} inputs and {Gc.noutputs} outputs"
        )
    if sampled:
        if period is None:
            raise ValueError(
                f"sampled=True needs a controller with a period (its sample time in s), got {type(controller).__name__}"
            )
        P = sampled_loop(P, period=period, computation_delay=delay)
        # A gain with a period is static; a dynamic controller with a period is discrete at it.
        Gc = control.ss(Gc.A, Gc.B, Gc.C, Gc.D, period)
    elif delay:
        raise ValueError(
            f"computation_delay = {delay!r} s needs the sampled loop (a controller with a period and sampled=None "
            "or True); a delay on the continuous loop is delayed_loop"
        )
    elif _is_discrete(Gc):
        raise ValueError(f"sampled=False needs a continuous controller, got a discrete one (dt = {Gc.dt} s)")
    for wrapper in reversed(wrappers):
        Gc = control.series(Gc, wrapper.filter_system(sampled=sampled))
    return P, Gc, sampled


def input_loop(plant: Any, controller: Any, *, sampled: bool | None = None, computation_delay: float = 0.0) -> Any:
    """The MIMO loop ``G = G_c P`` broken at the plant input, all channels at once (multiloop margins).

    Parameters
    ----------
    plant : RigidBody or control LTI
        As :func:`loop_gain`.
    controller : object
        As :func:`loop_gain`.
    sampled : bool, optional
        As :func:`loop_gain` (the sampled loop for a controller with a period).
    computation_delay : float
        As :func:`loop_gain` [s].

    Returns
    -------
    control.StateSpace
        ``m x m`` (``m`` plant inputs), discrete at the period when sampled.
    """
    P, Gc, _ = _open_loop(plant, controller, sampled, computation_delay)
    return control.series(P, Gc)  # G_c P: plant input to controller output


def output_loop(plant: Any, controller: Any, *, sampled: bool | None = None, computation_delay: float = 0.0) -> Any:
    """The MIMO loop ``P G_c`` broken at the plant output (the measurements), all channels at once.

    A perturbation here stands for the sensors' gain and phase errors (a star tracker's or gyro's scale and
    lag), where :func:`input_loop` stands for the actuators'. For a rigid body the outputs are ``[q_v, omega]``:
    six channels for three torques, so the loop has rank three.

    Parameters
    ----------
    plant : RigidBody or control LTI
        As :func:`loop_gain`.
    controller : object
        As :func:`loop_gain`.
    sampled : bool, optional
        As :func:`loop_gain` (the sampled loop for a controller with a period).
    computation_delay : float
        As :func:`loop_gain` [s].

    Returns
    -------
    control.StateSpace
        ``p x p`` (``p`` plant outputs), discrete at the period when sampled.
    """
    P, Gc, _ = _open_loop(plant, controller, sampled, computation_delay)
    return control.series(Gc, P)  # P G_c: controller input to plant output


def broken_channels(loop: Any) -> list[Any]:
    """Each channel of a square MIMO loop broken alone, the others closed: ``[(I + L F_i)^-1 L]_ii``.

    Parameters
    ----------
    loop : control.StateSpace
        The square loop ``L`` (:func:`input_loop` or :func:`output_loop`).

    Returns
    -------
    list of control.StateSpace
        One SISO loop per channel (``loop`` itself for one channel).
    """
    m = loop.ninputs
    if m == 1:
        return [loop]
    channels = []
    for i in range(m):
        F = np.eye(m)
        F[i, i] = 0.0
        channels.append(control.feedback(loop, F)[i, i])
    return channels


def loop_gain(
    plant: Any,
    controller: Any,
    *,
    sampled: bool | None = None,
    computation_delay: float = 0.0,
    minimal: bool = True,
) -> list[control.TransferFunction | control.StateSpace]:
    """Loop transfer functions broken at the plant input, one per input channel.

    With negative feedback ``u = -G_c y`` and ``G = G_c P`` (input to input),
    channel ``i`` is broken while the other channels stay closed:
    ``L_i = [(I + G F_i)^-1 G]_ii`` with ``F_i`` the identity without its
    ``i``-th one. For one input this is ``G`` itself.

    A controller that samples (one with a ``period``, as every controller
    the simulation flies) gives the **sampled loop**, the one that flies:
    the plant with a zero-order hold on every input and the computation
    delay (:func:`sampled_loop`, exact), the gain applied to the samples, the
    other channels closed through the same hold. ``L_i`` is then a
    discrete transfer function (``dt`` = the period) and :func:`margins`
    reads it as such (``Margins.dt``, named by ``Margins.summary``). The
    continuous loop, which ignores the hold (``omega_c T / 2`` rad less
    phase margin, and a gain margin at the Nyquist frequency it cannot
    show), is given only when asked for with ``sampled=False``.

    Parameters
    ----------
    plant : RigidBody or control LTI
        A :class:`~attitude.rigid_body.RigidBody` (linearised at rest by
        :func:`rigid_body_at_rest`, outputs ``[q_v, omega]``) or any
        continuous ``control.StateSpace`` / ``TransferFunction`` (``m``
        inputs, ``p`` outputs).
    controller : object with ``K`` (and ``C``), array_like (m, p), or control LTI
        A PD controller (:class:`~controllers.pd.QuaternionPD`,
        :class:`~controllers.pd.RateLimitedPD` in its linear region: static
        gain ``[K, C]`` on ``[q_v, omega]``), a state-feedback gain ``K``
        (:class:`~controllers.lqr.LQRDesign`,
        :class:`~controllers.lqr.LQRController`: ``K`` on the states of
        :func:`attitude.linearize.linearize`, which are ``[q_v, omega]``), a
        static gain, or a dynamic controller (continuous, or discrete at its
        ``dt``), all mapping plant outputs to the torque with the
        negative-feedback sign convention. A controller with states of its
        own (:class:`~controllers.integral.QuaternionPID`,
        :class:`~controllers.integral.LQIController`) gives its linear form
        by ``feedback_system(discrete=...)``. A
        :class:`~controllers.filters.FilteredController` gives its law with
        its filter chain in series (the discrete filters in the sampled loop).
    sampled : bool, optional
        None (default): the sampled loop when the controller has a period
        (:func:`controller_period`), else the continuous one. False: the
        continuous loop even for a sampled controller, on purpose. True:
        the sampled loop (an error when the controller has no period).
    computation_delay : float
        Delay [s] from sampling to applying the torque, for the sampled
        loop (>= 0). The simulation engine applies each command at its
        sample time, so the loop it flies has none; a flight computer's
        frame delay is studied with this.
    minimal : bool
        Cancel coinciding poles and zeros of the continuous loops
        (``control.minreal``), leaving the loop the channel really sees.

    Returns
    -------
    list of control.TransferFunction or control.StateSpace
        One SISO loop per plant input (body axis for a rigid body): the
        continuous ``L_i(s)`` as a transfer function, or the sampled
        ``L_i(z)`` as a state-space system with ``dt`` the period (not
        reduced: the polynomials of a fast-sampled loop lose the digits its
        margins depend on, see the module docstring; its extra modes are the
        other channels' closed-loop poles, hidden from ``L_i``).

    Raises
    ------
    ValueError
        A plant or controller of the wrong kind or size; ``sampled=True``
        for a controller without a period; a computation delay for the
        continuous loop.

    Examples
    --------
    For a diagonal inertia and ``QuaternionPD.from_bandwidth(body, wn=wn,
    zeta=zeta, period=T)``, ``sampled=False`` gives ``(2 zeta wn s + wn^2) /
    s^2`` per axis, and the default gives its zero-order-hold equivalent at
    ``T``.
    """
    P, Gc, sampled = _open_loop(plant, controller, sampled, computation_delay)
    loops: list[control.TransferFunction | control.StateSpace] = []
    for Li in broken_channels(control.series(P, Gc)):
        if sampled:
            # Kept in state space: the polynomials of a loop sampled fast (poles crowded at z = 1)
            # lose the digits its margins depend on (module docstring).
            loops.append(Li)
            continue
        tf = _snap_origin(control.tf(Li))
        if minimal:
            tf = _snap_origin(control.minreal(tf, verbose=False))
        loops.append(tf)
    return loops


def closed_loop_poles(
    plant: Any, controller: Any, *, sampled: bool | None = None, computation_delay: float = 0.0
) -> NDArray[np.complex128]:
    """Poles of the loop closed on every channel: the s-plane, or the z-plane for the sampled loop.

    The eigenvalues of ``(I + G)^-1`` with ``G = G_c P`` as in
    :func:`loop_gain` (the same plant, controller and sampling rules): the
    sampled loop is stable when every pole has ``|z| < 1``.

    Parameters
    ----------
    plant : RigidBody or control LTI
        As for :func:`loop_gain`.
    controller : object with ``K`` (and ``C``), array_like (m, p), or control LTI
        As for :func:`loop_gain`.
    sampled : bool, optional
        As for :func:`loop_gain` (None: sampled when the controller has a period).
    computation_delay : float
        Delay [s] from sampling to applying the command, sampled loop only (>= 0).

    Returns
    -------
    ndarray of complex
        The poles, sorted by magnitude: ``s`` [1/s] for the continuous loop,
        ``z`` [-] for the sampled one (the computation delay's buffer states
        included).
    """
    P, Gc, _ = _open_loop(plant, controller, sampled, computation_delay)
    G = control.series(P, Gc)
    A, B, C, D = (np.asarray(x, dtype=float) for x in (G.A, G.B, G.C, G.D))
    m = B.shape[1]
    if A.shape[0] == 0:
        return np.zeros(0, dtype=complex)
    poles = np.linalg.eigvals(A - B @ np.linalg.solve(np.eye(m) + D, C)).astype(complex)
    return poles[np.argsort(np.abs(poles), kind="stable")]


def attitude_closed_loop(body: RigidBody, controller: Any) -> control.StateSpace:
    """Linear closed loop from the reference angle to the attitude angle, per axis.

    The PD law ``tau = -K q_e,v - C omega`` with ``q_e,v ≈ (theta -
    theta_ref)/2`` on the linearised body at rest:
    ``J theta'' + C theta' + (K/2) theta = (K/2) theta_ref``.
    Inputs ``theta_ref`` (3) [rad], outputs ``theta`` (3) [rad] (small
    rotation vector about the body axes). For ``QuaternionPD.from_bandwidth``
    each axis is ``wn^2 / (s^2 + 2 zeta wn s + wn^2)``.

    Parameters
    ----------
    body : RigidBody
        Inertia ``J`` [kg m^2].
    controller : object with ``K`` [N m] and ``C`` [N m s] (3, 3)
        E.g. :class:`~controllers.pd.QuaternionPD`.
    """
    plant = rigid_body_at_rest(body)
    if not (hasattr(controller, "K") and hasattr(controller, "C")):
        raise ValueError(f"controller must have gain matrices K and C (3, 3), got {controller!r}")
    K = np.asarray(controller.K, dtype=float)
    C = np.asarray(controller.C, dtype=float)
    if K.shape != (3, 3) or C.shape != (3, 3):
        raise ValueError(f"controller.K and controller.C must be 3x3, got {K.shape} and {C.shape}")
    j_inv = plant.B[3:]  # J^-1
    z, eye = np.zeros((3, 3)), np.eye(3)
    stiffness = 0.5 * j_inv @ K
    return control.ss(
        np.block([[z, eye], [-stiffness, -j_inv @ C]]),
        np.vstack([z, stiffness]),
        np.hstack([eye, z]),
        np.zeros((3, 3)),
        inputs=[f"theta_ref_{a}" for a in _AXES],
        outputs=[f"theta_{a}" for a in _AXES],
        states=[f"theta_{a}" for a in _AXES] + [f"omega_{a}" for a in _AXES],
        name="attitude_closed_loop",
    )


# ---------------------------------------------------------------------------
# Margins
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Margins(ResultIO):
    """Stability margins of a SISO loop ``L`` (negative unity feedback).

    The toolkit's result protocol: :meth:`summary` (one line),
    :meth:`plot` (the Bode figure of the loop with these margins marked),
    ``save(path)`` / ``load(path)`` (``.npz``, the loop kept as its
    state-space matrices).

    Attributes
    ----------
    gain_margin : float
        Smallest gain *increase* factor that destabilises the loop (> 1;
        ``inf`` when no phase crossover has ``|L| < 1``).
    gain_margin_lower : float
        Largest gain *decrease* factor that destabilises it (< 1; 0 when
        none: e.g. a PD loop on a double integrator stays stable for any
        lower gain).
    phase_margin_deg : float
        For a stable closed loop, the smallest phase change either way
        (lag or lead) that puts ``L`` on -1 at a gain crossover: ``min
        |PM_i|`` with ``PM_i = 180 + arg L`` in (-180, 180] [deg]. A
        collocated flexible mode can cross 0 dB with ``PM_i < 0``, a lead
        away from -1, not an unstable loop. For an unstable closed loop the
        smallest signed ``PM_i`` (``inf`` without gain crossover).
    delay_margin_s : float
        Smallest pure delay that destabilises a stable closed loop: ``min
        (PM_i mod 360) / omega_c,i`` [s], the lag each crossover can take
        (0 for an unstable closed loop; ``inf`` without gain crossover).
    gain_crossover : float
        Gain-crossover frequency of the reported phase margin [rad/s]
        (NaN if none).
    phase_crossover : float
        Phase-crossover frequency of the upward gain margin [rad/s] (NaN if
        none).
    gain_crossovers, phase_crossovers : ndarray
        All crossings found [rad/s], ascending.
    stable : bool
        Whether the closed loop ``L / (1 + L)`` is stable. The gain margins
        bound the stable gain interval only when it is; for an unstable loop
        they still list the crossings (python-control's convention) but mean
        the gains at which stability would be *gained*.
    dt : float or None
        Sample time of a discrete loop [s] (None: continuous).
    loop : dict of ndarray
        The analysed loop as state-space matrices ``A``, ``B``, ``C``, ``D``
        (with ``dt``, :attr:`system`); empty when not kept.
    """

    gain_margin: float
    gain_margin_lower: float
    phase_margin_deg: float
    delay_margin_s: float
    gain_crossover: float
    phase_crossover: float
    gain_crossovers: NDArray[np.float64]
    phase_crossovers: NDArray[np.float64]
    stable: bool
    dt: float | None = None
    loop: dict[str, Any] = field(default_factory=dict)

    @property
    def system(self) -> control.StateSpace:
        """The analysed loop (continuous, or discrete at :attr:`dt`)."""
        if not self.loop:
            raise ValueError("Margins made without their loop (loop = {}) have no system to show")
        return control.ss(*(np.asarray(self.loop[k], dtype=float) for k in "ABCD"), self.dt or 0)

    def plot(self, label: str | None = None) -> Figure:
        """Bode plot of the loop with its margins marked (:func:`plot_bode`).

        Parameters
        ----------
        label : str, optional
            Title of the panel (default: the loop's kind, sampled or continuous).

        Returns
        -------
        matplotlib.figure.Figure
        """
        title = label if label is not None else self.summary().split(":")[0]
        return plot_bode(self.system, labels=[title])

    @property
    def gain_margin_db(self) -> float:
        """Upward gain margin [dB] (``inf`` when none)."""
        return _db(self.gain_margin)

    @property
    def gain_margin_lower_db(self) -> float:
        """Downward gain margin [dB] (negative; ``-inf`` when none)."""
        return _db(self.gain_margin_lower)

    def summary(self) -> str:
        """One line for figure titles and logs, naming the loop: sampled (at its period) or continuous."""
        gm = "inf" if math.isinf(self.gain_margin) else f"{self.gain_margin_db:.1f}"
        kind = f"sampled loop (T = {self.dt:g} s)" if self.dt else "continuous loop"
        text = f"{kind}: GM = {gm} dB, PM = {self.phase_margin_deg:.1f} deg"
        if math.isfinite(self.gain_crossover):
            text += f" at {self.gain_crossover:.3g} rad/s, delay margin {self.delay_margin_s:.3g} s"
        return text if self.stable else text + " (closed loop UNSTABLE)"


def _db(x: float) -> float:
    if x == 0.0:
        return -math.inf
    return 20.0 * math.log10(x) if math.isfinite(x) else math.inf


def _siso_tf(loop: Any, name: str = "loop") -> control.TransferFunction:
    if not isinstance(loop, (control.StateSpace, control.TransferFunction)):
        raise ValueError(f"{name} must be a control StateSpace or TransferFunction, got {type(loop).__name__}")
    if loop.ninputs != 1 or loop.noutputs != 1:
        raise ValueError(f"{name} must be SISO (one loop per channel), got {loop.noutputs}x{loop.ninputs}")
    return _clean_tf(control.tf(loop))


def _frequency_response(loop: Any, w: NDArray[np.float64]) -> NDArray[np.complex128]:
    """``L(j w)`` (continuous) or ``L(exp(j w T))`` (discrete) with plain numpy arithmetic."""
    w = np.asarray(w, dtype=float)
    x = 1j * w if not _is_discrete(loop) else np.exp(1j * w * loop.dt)
    if isinstance(loop, control.StateSpace):
        A, B, C, D = (np.asarray(m, dtype=float) for m in (loop.A, loop.B, loop.C, loop.D))
        n = A.shape[0]
        if n == 0:
            return np.full(w.shape, D[0, 0], dtype=complex)
        out = np.empty(w.shape, dtype=complex)
        for k, xk in enumerate(x.ravel()):
            out.flat[k] = (C @ np.linalg.solve(xk * np.eye(n) - A, B))[0, 0] + D[0, 0]
        return out
    num = np.asarray(loop.num[0][0], dtype=float)
    den = np.asarray(loop.den[0][0], dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.polyval(num, x) / np.polyval(den, x)


def _is_discrete(loop: Any) -> bool:
    dt = loop.dt
    return dt is not None and not isinstance(dt, bool) and dt > 0


def _closed_loop_stable(loop: Any) -> bool:
    """Stability of ``L / (1 + L)`` from the eigenvalues of a state-space realisation.

    (Eigenvalues, not polynomial roots: a fast-sampled discrete loop has its
    poles crowded at ``z = 1`` where polynomial roots lose all accuracy.)
    """
    ss = control.ss(loop)
    A, B, C, D = (np.asarray(x, dtype=float) for x in (ss.A, ss.B, ss.C, ss.D))
    if A.shape[0] == 0:
        return True
    if abs(1.0 + D[0, 0]) < 1e-12:
        return False  # algebraic loop: 1 + L(inf) = 0
    poles = np.linalg.eigvals(A - B @ C / (1.0 + D[0, 0]))
    if _is_discrete(loop):
        return bool(np.all(np.abs(poles) < 1.0))
    return bool(np.all(poles.real < 0.0))


def _distinct(w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Sorted frequencies without repeats (a double root counted once)."""
    w = np.sort(np.asarray(w, dtype=float))
    if w.size < 2:
        return w
    keep = np.concatenate([[True], np.diff(w) > 1e-9 * w[1:]])
    return w[keep]


def _assemble(
    loop: Any, w_phase: NDArray[np.float64], w_gain: NDArray[np.float64], stable: bool, dt: float | None
) -> Margins:
    w_phase, w_gain = _distinct(w_phase), _distinct(w_gain)
    up, down, w_up = math.inf, 0.0, math.nan
    for w in w_phase:
        g = 1.0 / abs(complex(_frequency_response(loop, np.array([w]))[0]))
        if g >= 1.0 and g < up:
            up, w_up = g, float(w)
        elif g < 1.0 and g > down:
            down = g
    pm, wc, dm = math.inf, math.nan, math.inf
    for w in w_gain:
        Lw = complex(_frequency_response(loop, np.array([w]))[0])
        pm_i = 180.0 + math.degrees(math.atan2(Lw.imag, Lw.real))
        pm_i = pm_i - 360.0 if pm_i > 180.0 else pm_i
        # A stable loop may cross 0 dB with its phase above -180 deg + 180 (a collocated mode's lead): a phase
        # *lead* of |pm_i| reaches -1 there, a lag needs pm_i mod 360. The margin is the smaller change either
        # way, and the delay margin the lag. An unstable loop keeps the signed figure (and no delay margin).
        size_i = abs(pm_i) if stable else pm_i
        if size_i < pm:
            pm, wc = size_i, float(w)
        dm = min(dm, math.radians(pm_i % 360.0) / w if stable else 0.0)
    return Margins(
        gain_margin=up,
        gain_margin_lower=down,
        phase_margin_deg=pm,
        delay_margin_s=dm,
        gain_crossover=wc,
        phase_crossover=w_up,
        gain_crossovers=w_gain,
        phase_crossovers=w_phase,
        stable=stable,
        dt=dt,
        loop=_matrices(loop),
    )


def _matrices(loop: Any) -> dict[str, NDArray[np.float64]]:
    """The state-space matrices of a SISO loop, to keep with its margins."""
    ss = control.ss(loop)
    return {k: np.array(getattr(ss, k), dtype=float) for k in "ABCD"}


def _sign_change(f: Any, w: float) -> bool:
    lo, hi = f(w * (1.0 - CROSSING_CHECK)), f(w * (1.0 + CROSSING_CHECK))
    return bool(lo * hi <= 0.0)


def _w_plane(loop: Any) -> control.TransferFunction:
    """Continuous w-plane image of a discrete loop, ``z = (1 + w T/2) / (1 - w T/2)``.

    On the unit circle ``w = j nu`` with ``nu = (2/T) tan(omega T / 2)``, so
    crossings map one to one (the Nyquist frequency goes to infinity). The
    map is applied to a state-space realisation (``A_w = (2/T) (I + A)^-1
    (A - I)``, ...), whose eigenvalues stay well conditioned when fast
    sampling crowds the z-plane poles at 1; the polynomial form is used
    only when ``A`` has an eigenvalue at ``z = -1``.
    """
    dt = float(loop.dt)
    alpha = 2.0 / dt
    ss = control.ss(loop)
    A, B, C, D = (np.asarray(x, dtype=float) for x in (ss.A, ss.B, ss.C, ss.D))
    n = A.shape[0]
    M = np.eye(n) + A
    if n and np.linalg.cond(M) < 1e12:
        Aw = alpha * np.linalg.solve(M, A - np.eye(n))
        Bw = np.linalg.solve(M, B)
        return _clean_tf(control.tf(control.ss(Aw, Bw, C @ (alpha * np.eye(n) - Aw), D - C @ Bw)))
    tf = _siso_tf(loop)
    num, den = np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float)
    order = max(num.size, den.size) - 1
    plus, minus = np.array([0.5 * dt, 1.0]), np.array([-0.5 * dt, 1.0])

    def substitute(p: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros(1)
        for i, a in enumerate(p):
            k = p.size - 1 - i  # coefficient of z^k
            term = np.array([a])
            for _ in range(k):
                term = np.polymul(term, plus)
            for _ in range(order - k):
                term = np.polymul(term, minus)
            out = np.polyadd(out, term)
        return out

    return _clean_tf(control.tf(substitute(num), substitute(den)))


def margins(loop: LTI) -> Margins:
    """Gain, phase and delay margins of a SISO loop via :func:`control.stability_margins`.

    The candidates of python-control's polynomial method (run on the w-plane
    image of a discrete loop) are verified and completed (module
    docstring): a phase crossover counts only where
    ``Im L`` changes sign with ``Re L < 0`` (this removes the spurious
    near-zero crossings of loops with a double integrator), a gain crossover
    only where ``|L| - 1`` changes sign, and discrete loops get the Nyquist
    frequency ``pi / T`` checked (``L(-1)`` real and negative).

    Parameters
    ----------
    loop : control.TransferFunction or control.StateSpace
        SISO loop transfer function (negative feedback), continuous or
        discrete.

    Returns
    -------
    Margins
    """
    tf = _siso_tf(loop)
    dt = float(tf.dt) if _is_discrete(tf) else None
    analysed = _w_plane(loop) if dt else tf
    with np.errstate(all="ignore"):  # python-control compares NaN responses at omega = 0
        _, _, _, w180, wc, _ = control.stability_margins(analysed, returnall=True, method="poly")
    w180 = np.atleast_1d(np.asarray(w180, dtype=float))
    wc = np.atleast_1d(np.asarray(wc, dtype=float))
    if dt:
        # Back from the w-plane: nu = (2/T) tan(omega T/2).
        w180, wc = (2.0 / dt * np.arctan(0.5 * dt * x) for x in (w180, wc))

    def im_ratio(w: float) -> float:
        Lw = complex(_frequency_response(loop, np.array([w]))[0])
        return Lw.imag / abs(Lw)

    def log_mag(w: float) -> float:
        return math.log(abs(complex(_frequency_response(loop, np.array([w]))[0])))

    nyquist = math.pi / dt if dt else math.inf
    phase = []
    for w in w180[np.isfinite(w180) & (w180 > 0.0) & (w180 < nyquist)]:
        Lw = complex(_frequency_response(loop, np.array([w]))[0])
        if np.isfinite(Lw) and Lw.real < 0.0 and _sign_change(im_ratio, w):
            phase.append(float(w))
    if dt:
        L_nyq = complex(_frequency_response(loop, np.array([nyquist]))[0])
        if np.isfinite(L_nyq) and L_nyq.real < 0.0:
            phase.append(nyquist)
    gain = [
        float(w)
        for w in wc[np.isfinite(wc) & (wc > 0.0) & (wc < nyquist)]
        if np.isfinite(log_mag(w)) and _sign_change(log_mag, w)
    ]
    return _assemble(loop, np.array(phase), np.array(gain), _closed_loop_stable(loop), dt)


def _default_grid(tf: control.TransferFunction, points_per_decade: int) -> NDArray[np.float64]:
    """Log grid spanning three decades beyond the loop's characteristic frequencies [rad/s]."""
    num, den = np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float)
    roots = np.concatenate([np.roots(num), np.roots(den)]) if num.size > 1 or den.size > 1 else np.zeros(0)
    dt = float(tf.dt) if _is_discrete(tf) else None
    if dt:
        roots = roots[np.abs(roots) > 0]
        chars = np.abs(np.log(roots.astype(complex))) / dt
    else:
        chars = np.abs(roots)
    # Roots far below the largest are integrators blurred by rounding (see ORIGIN_SNAP).
    chars = list(chars[chars > ORIGIN_SNAP * float(np.max(chars, initial=0.0))])
    if not dt:
        # Where the low- and high-frequency asymptotes of |L| cross 1.
        nz_num, nz_den = np.flatnonzero(num), np.flatnonzero(den)
        rel = (den.size - 1 - nz_den[-1]) - (num.size - 1 - nz_num[-1])  # integrators minus differentiators
        if rel > 0:
            chars.append(abs(num[nz_num[-1]] / den[nz_den[-1]]) ** (1.0 / rel))
        excess = (den.size - 1 - nz_den[0]) - (num.size - 1 - nz_num[0])
        if excess > 0:
            chars.append(abs(num[nz_num[0]] / den[nz_den[0]]) ** (1.0 / excess))
    if not chars:
        chars = [1.0]
    lo, hi = 1e-3 * min(chars), 1e3 * max(chars)
    if dt:
        hi = math.pi / dt * (1.0 - 1e-9)
        lo = min(lo, 1e-3 * hi)
    n = max(int(points_per_decade * math.log10(hi / lo)), 100)
    return np.geomspace(lo, hi, n)


def sweep_margins(loop: LTI, omega: ArrayLike | None = None, *, points_per_decade: int = 400) -> Margins:
    """Margins by a frequency sweep and root bracketing, independent of python-control's algorithm.

    ``L`` is evaluated with plain numpy (polynomials or state-space solves)
    on a logarithmic grid; every sign change of ``log|L|`` (gain crossover)
    and of ``Im L / |L|`` with ``Re L < 0`` (phase crossover) between two
    grid points is refined with :func:`scipy.optimize.brentq`. Discrete
    loops also check the Nyquist frequency, where ``L(-1)`` is real.
    Crossings outside the grid, or two crossings within one grid cell, are
    not found: the grid spans three decades beyond the loop's poles, zeros
    and asymptote crossings unless ``omega`` is given.

    Parameters
    ----------
    loop : control.TransferFunction or control.StateSpace
        SISO loop (negative feedback).
    omega : array_like, optional
        Increasing grid [rad/s].
    points_per_decade : int
        Grid density of the default grid.

    Returns
    -------
    Margins
    """
    _siso_tf(loop)
    dt = float(loop.dt) if _is_discrete(loop) else None
    if omega is None:
        w = _default_grid(_siso_tf(loop), points_per_decade)
    else:
        w = check_positive(omega, "omega")
        if w.ndim != 1 or w.size < 2 or np.any(np.diff(w) <= 0):
            raise ValueError(f"omega must be a 1-D increasing grid of at least 2 frequencies, got shape {w.shape}")
    L = _frequency_response(loop, w)

    def im_ratio(x: float) -> float:
        v = complex(_frequency_response(loop, np.array([x]))[0])
        return v.imag / abs(v)

    def log_mag(x: float) -> float:
        return math.log(abs(complex(_frequency_response(loop, np.array([x]))[0])))

    mag = np.abs(L)
    s = L.imag / mag
    g = np.log(mag)
    phase, gain = [], []
    for i in range(w.size - 1):
        if s[i] * s[i + 1] < 0.0 and L.real[i] < 0.0 and L.real[i + 1] < 0.0:
            phase.append(scipy.optimize.brentq(im_ratio, w[i], w[i + 1], xtol=1e-14 * w[i], rtol=1e-15))
        elif s[i] == 0.0 and L.real[i] < 0.0:
            phase.append(float(w[i]))
        if g[i] * g[i + 1] < 0.0:
            gain.append(scipy.optimize.brentq(log_mag, w[i], w[i + 1], xtol=1e-14 * w[i], rtol=1e-15))
    if dt:
        nyquist = math.pi / dt
        L_nyq = complex(_frequency_response(loop, np.array([nyquist]))[0])
        if L_nyq.real < 0.0:
            phase.append(nyquist)
    return _assemble(loop, np.array(phase), np.array(gain), _closed_loop_stable(loop), dt)


# ---------------------------------------------------------------------------
# Sampling and delay
# ---------------------------------------------------------------------------


def _hold_integrals(A: NDArray, B: NDArray, t: float) -> tuple[NDArray, NDArray]:
    """``exp(A t)`` and ``int_0^t exp(A s) ds B`` (Van Loan block exponential)."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A * t, B * t
    E = scipy.linalg.expm(M)
    return E[:n, :n], E[:n, n:]


def sampled_loop(loop: LTI, *, period: float, computation_delay: float = 0.0) -> control.StateSpace:
    """Exact discrete equivalent: zero-order hold at the input plus a computation delay.

    The input ``u_k`` computed at ``t_k = k T`` is applied from
    ``t_k + tau_d`` and held for one period. With ``tau_d = m T + tau'``
    (``0 <= tau' < T``) the state obeys (modified z-transform)
    ``x_{k+1} = Phi x_k + Gamma_0 u_{k-m} + Gamma_1 u_{k-m-1}`` with
    ``Phi = e^{AT}``, ``Gamma_0 = int_0^{T-tau'} e^{As} ds B`` and
    ``Gamma_1 = e^{A(T-tau')} int_0^{tau'} e^{As} ds B``; past inputs are
    extra states. Without delay this is ``control.c2d(loop, T, 'zoh')``.
    This is the one home of the hold and delay model: :func:`loop_gain`
    samples a multi-input plant with it.

    Parameters
    ----------
    loop : control LTI
        Continuous system: a SISO loop (e.g. from ``loop_gain(...,
        sampled=False)``) or a multi-input plant (every input held).
    period : float
        Sample time ``T`` [s].
    computation_delay : float
        Delay ``tau_d`` [s] from sampling to applying the command (>= 0).

    Returns
    -------
    control.StateSpace
        Discrete system with ``dt = period``.
    """
    if isinstance(loop, (control.StateSpace, control.TransferFunction)) and loop.ninputs * loop.noutputs > 1:
        ss = control.ss(loop)
    else:
        ss = control.ss(_siso_tf(loop))
    if _is_discrete(ss):
        raise ValueError(f"loop must be continuous to be sampled, got dt = {ss.dt}")
    T = float(check_positive(period, "period"))
    tau = float(check_positive(computation_delay, "computation_delay", allow_zero=True))
    A, B, C, D = (np.asarray(x, dtype=float) for x in (ss.A, ss.B, ss.C, ss.D))
    n, m = B.shape
    p = C.shape[0]
    m_int = math.floor(tau / T + 1e-12)
    frac = max(tau - m_int * T, 0.0)
    if frac < 1e-12 * T:
        frac = 0.0
    Phi, gamma_full = _hold_integrals(A, B, T)
    if frac > 0.0:
        e_rest, gamma0 = _hold_integrals(A, B, T - frac)
        _, g_frac = _hold_integrals(A, B, frac)
        gamma1 = e_rest @ g_frac
    else:
        gamma0, gamma1 = gamma_full, np.zeros_like(gamma_full)
    d = m_int + (1 if frac > 0.0 else 0)  # past inputs kept as states
    N = n + d * m
    Ad = np.zeros((N, N))
    Bd = np.zeros((N, m))
    Cd = np.zeros((p, N))
    Dd = np.zeros((p, m))
    Ad[:n, :n] = Phi
    Cd[:, :n] = C

    def past(j: int) -> slice:
        """Columns of the state vector holding ``u_{k-j}``: buffer ``b_k = [u_{k-1}, ..., u_{k-d}]``."""
        return slice(n + (j - 1) * m, n + j * m)

    for j, gamma in ((m_int, gamma0), (m_int + 1, gamma1)):
        if j == m_int + 1 and frac == 0.0:
            continue
        if j == 0:
            Bd[:n] += gamma
        else:
            Ad[:n, past(j)] += gamma
    # Output feedthrough: y_k = C x_k + D u(kT), u(kT) = u_{k-m-1} if tau' > 0 else u_{k-m}.
    j_out = m_int + 1 if frac > 0.0 else m_int
    if j_out == 0:
        Dd += D
    else:
        Cd[:, past(j_out)] += D
    if d > 0:
        Bd[past(1)] = np.eye(m)
        for j in range(2, d + 1):
            Ad[past(j), past(j - 1)] = np.eye(m)
    return control.ss(Ad, Bd, Cd, Dd, T)


def delayed_loop(loop: LTI, *, delay: float, pade_order: int = 6) -> control.TransferFunction:
    """Continuous loop times a Pade approximation of ``exp(-delay s)``.

    Use ``delay = T/2 + tau_d`` for the classical approximation of a
    zero-order hold (half a period) plus a computation delay. It predicts the
    phase margin of the sampled loop well (0.3 % of the drop for a PD at
    ``omega_c T = 0.08``) but not its gain margin, which a sampled PD loop
    has at the Nyquist frequency where a delay is no model of the hold
    (22 dB instead of 28 dB in the same case): use :func:`sampled_loop`.

    Parameters
    ----------
    loop : control LTI
        Continuous SISO loop.
    delay : float
        Delay [s] (>= 0).
    pade_order : int
        Order of the Pade approximant (>= 1).
    """
    tf = _siso_tf(loop)
    if _is_discrete(tf):
        raise ValueError(f"loop must be continuous, got dt = {tf.dt}")
    delay = float(check_positive(delay, "delay", allow_zero=True))
    if isinstance(pade_order, bool) or not isinstance(pade_order, int) or pade_order < 1:
        raise ValueError(f"pade_order must be a positive integer, got {pade_order!r}")
    if delay == 0.0:
        return tf
    num, den = control.pade(delay, pade_order)
    return _clean_tf(tf * control.tf(num, den))


@dataclass
class SampleTimeStudy(ResultIO):
    """Margins of one loop against sample time and computation delay.

    Attributes
    ----------
    period, computation_delay : ndarray (n,)
        Sample times and computation delays [s].
    phase_margin_deg, gain_margin, delay_margin_s, gain_crossover : ndarray (n,)
        Margins of the exact sampled loop (:func:`sampled_loop`): phase
        margin [deg], upward gain margin [-], delay margin [s], gain
        crossover [rad/s].
    predicted_phase_margin_deg : ndarray (n,)
        Classical estimate ``PM_c - omega_c (T/2 + tau_d)`` [deg].
    continuous_phase_margin_deg, continuous_gain_crossover : float
        The continuous loop's phase margin [deg] and crossover [rad/s].
    """

    period: NDArray[np.float64]
    computation_delay: NDArray[np.float64]
    phase_margin_deg: NDArray[np.float64]
    gain_margin: NDArray[np.float64]
    delay_margin_s: NDArray[np.float64]
    gain_crossover: NDArray[np.float64]
    predicted_phase_margin_deg: NDArray[np.float64]
    continuous_phase_margin_deg: float
    continuous_gain_crossover: float

    def plot(self) -> Figure:
        """Phase margin (exact and predicted) and gain margin against sample time."""
        fig = Figure(figsize=(8, 6), layout="constrained")
        ax_pm, ax_gm = fig.subplots(2, 1, sharex=True)
        x = self.period * self.continuous_gain_crossover
        ax_pm.plot(x, self.phase_margin_deg, "o-", label="exact (zero-order hold + delay)")
        ax_pm.plot(x, self.predicted_phase_margin_deg, "k--", label=r"$PM_c - \omega_c (T/2 + \tau_d)$")
        ax_pm.axhline(self.continuous_phase_margin_deg, color="0.5", lw=1.0, ls=":", label="continuous loop")
        ax_pm.set_ylabel("phase margin [deg]")
        ax_pm.legend()
        ax_pm.grid(True, alpha=0.3)
        ax_gm.plot(x, [_db(g) for g in self.gain_margin], "o-")
        ax_gm.set_ylabel("gain margin [dB]")
        ax_gm.set_xlabel(r"$\omega_c T$ [rad] (sample time times continuous crossover)")
        ax_gm.grid(True, alpha=0.3)
        return fig


def sample_time_study(loop: LTI, *, periods: ArrayLike, computation_delay: ArrayLike = 0.0) -> SampleTimeStudy:
    """Tabulate the margins of the sampled loop for several sample times.

    Parameters
    ----------
    loop : control LTI
        Continuous SISO loop.
    periods : array_like (n,)
        Sample times [s].
    computation_delay : float or array_like (n,)
        Computation delay [s], one for all or one per period (e.g.
        ``computation_delay=periods`` for a one-frame delay).
    """
    periods = np.atleast_1d(check_positive(periods, "periods")).astype(float)
    delays = np.broadcast_to(
        check_positive(computation_delay, "computation_delay", allow_zero=True), periods.shape
    ).astype(float)
    cont = margins(loop)
    if not math.isfinite(cont.gain_crossover):
        raise ValueError("loop must have a gain crossover for a sample-time study (|L| never crosses 1)")
    rows = [margins(sampled_loop(loop, period=T, computation_delay=tau)) for T, tau in zip(periods, delays)]
    predicted = cont.phase_margin_deg - np.degrees(cont.gain_crossover * (periods / 2 + delays))
    return SampleTimeStudy(
        period=periods,
        computation_delay=delays,
        phase_margin_deg=np.array([r.phase_margin_deg for r in rows]),
        gain_margin=np.array([r.gain_margin for r in rows]),
        delay_margin_s=np.array([r.delay_margin_s for r in rows]),
        gain_crossover=np.array([r.gain_crossover for r in rows]),
        predicted_phase_margin_deg=predicted,
        continuous_phase_margin_deg=float(cont.phase_margin_deg),
        continuous_gain_crossover=float(cont.gain_crossover),
    )


# ---------------------------------------------------------------------------
# Figures
# ---------------------------------------------------------------------------


def _as_list(systems: Any, name: str) -> list[Any]:
    items = list(systems) if isinstance(systems, Sequence) else [systems]
    if not items:
        raise ValueError(f"{name} must hold at least one system")
    return items


def _labels(labels: Sequence[str] | None, n: int, default: Sequence[str]) -> list[str]:
    if labels is None:
        return list(default[:n]) if n <= len(default) else [f"loop {i}" for i in range(n)]
    labels = list(labels)
    if len(labels) != n:
        raise ValueError(f"labels must have one entry per system ({n}), got {len(labels)}")
    return labels


def plot_bode(
    loops: LTI | Sequence[LTI],
    *,
    labels: Sequence[str] | None = None,
    omega: ArrayLike | None = None,
) -> Figure:
    """Bode plot of each loop (one column per axis) with its margins marked.

    Parameters
    ----------
    loops : control LTI or sequence of them
        SISO loops, e.g. from :func:`loop_gain` (continuous or discrete).
    labels : sequence of str, optional
        Column titles (default ``"x axis"``, ``"y axis"``, ``"z axis"``).
    omega : array_like, optional
        Frequency grid [rad/s] (default: spans every loop's features).

    Returns
    -------
    matplotlib.figure.Figure
        Two rows (magnitude [dB], phase [deg]) by one column per loop. The
        gain crossover and phase margin, and the phase crossover and gain
        margin are drawn as vertical bars; discrete loops show the Nyquist
        frequency.
    """
    items = _as_list(loops, "loops")
    for sys in items:
        _siso_tf(sys, "loops")
    names = _labels(labels, len(items), [f"{a} axis" for a in _AXES])
    n = len(items)
    fig = Figure(figsize=(4.6 * n, 6.4), layout="constrained")
    axes = np.atleast_2d(fig.subplots(2, n, sharex="col", squeeze=False))
    for k, (sys, name) in enumerate(zip(items, names)):
        m = margins(sys)
        focus = [x for x in (m.gain_crossover, m.phase_crossover) if math.isfinite(x)]
        if omega is not None:
            grid = check_positive(omega, "omega")
        elif focus:
            # Two decades either side of the crossovers (up to Nyquist for a discrete loop).
            lo, hi = min(focus) / 100.0, max(focus) * 100.0
            grid = np.geomspace(lo, min(hi, math.pi / m.dt) if m.dt else hi, 1200)
        else:
            grid = _default_grid(_siso_tf(sys), 200)
        L = _frequency_response(sys, grid)
        mag_db = 20 * np.log10(np.abs(L))
        phase = np.degrees(np.unwrap(np.angle(L)))
        # Choose the branch that puts the phase at the crossover in (-360, 0] deg.
        ref = m.gain_crossover if math.isfinite(m.gain_crossover) else grid[grid.size // 2]
        phase = phase - 360.0 * np.ceil(float(np.interp(np.log(ref), np.log(grid), phase)) / 360.0)
        ax_m, ax_p = axes[0, k], axes[1, k]
        ax_m.semilogx(grid, mag_db, color="tab:blue", lw=1.6)
        ax_p.semilogx(grid, phase, color="tab:blue", lw=1.6)
        ax_m.axhline(0.0, color="0.4", lw=0.8)
        ax_p.axhline(-180.0, color="0.4", lw=0.8)
        if math.isfinite(m.gain_crossover):
            wc = m.gain_crossover
            ph_c = float(np.interp(np.log(wc), np.log(grid), phase))
            for ax in (ax_m, ax_p):
                ax.axvline(wc, color="tab:red", ls=":", lw=1.0)
            ax_p.plot([wc, wc], [-180.0, ph_c], color="tab:red", lw=3, solid_capstyle="butt")
            ax_p.text(
                0.03,
                0.95,
                f"PM = {m.phase_margin_deg:.1f} deg @ {wc:.3g} rad/s\ndelay margin {m.delay_margin_s:.3g} s",
                transform=ax_p.transAxes,
                ha="left",
                va="top",
                color="tab:red",
                bbox=_BOX,
            )
        if math.isfinite(m.phase_crossover):
            wp = m.phase_crossover
            mag_p = float(np.interp(np.log(wp), np.log(grid), mag_db))
            for ax in (ax_m, ax_p):
                ax.axvline(wp, color="tab:green", ls=":", lw=1.0)
            ax_m.plot([wp, wp], [mag_p, 0.0], color="tab:green", lw=3, solid_capstyle="butt")
            gm_text = f"GM = {m.gain_margin_db:.1f} dB @ {wp:.3g} rad/s"
        else:
            gm_text = "GM = inf (phase never reaches -180 deg)"
        ax_m.text(0.97, 0.95, gm_text, transform=ax_m.transAxes, ha="right", va="top", color="tab:green", bbox=_BOX)
        lo_p = min(float(np.min(phase)), -180.0) - 20.0
        hi_p = max(float(np.max(phase)), -180.0) + 55.0  # room for the text box
        ax_p.set_ylim(lo_p, hi_p)
        ax_p.set_yticks(np.arange(45.0 * np.ceil(lo_p / 45.0), hi_p, 45.0))
        if m.dt:
            for ax in (ax_m, ax_p):
                ax.axvline(math.pi / m.dt, color="0.3", ls="--", lw=0.8)
            ax_p.text(math.pi / m.dt, lo_p, "Nyquist ", rotation=90, va="bottom", ha="right", fontsize=8)
        status = "" if m.stable else " (closed loop UNSTABLE)"
        ax_m.set_title(f"{name}{status}", fontsize=10)
        ax_m.grid(True, which="both", alpha=0.3)
        ax_p.grid(True, which="both", alpha=0.3)
        ax_p.set_xlabel("frequency [rad/s]")
        if k == 0:
            ax_m.set_ylabel("|L| [dB]")
            ax_p.set_ylabel("arg L [deg]")
    fig.suptitle("Loop gain broken at the plant input", fontsize=11)
    return fig


def plot_step(
    system: LTI,
    *,
    duration: float | None = None,
    labels: Sequence[str] | None = None,
) -> Figure:
    """Step responses of a closed loop, one panel per input.

    Parameters
    ----------
    system : control LTI
        Closed loop with ``n`` inputs and ``n`` outputs, e.g.
        :func:`attitude_closed_loop` (reference angle to attitude angle).
    duration : float, optional
        Simulated time [s] (default: eight times the slowest time constant).
    labels : sequence of str, optional
        Axis names (default ``"x"``, ``"y"``, ``"z"``).

    Returns
    -------
    matplotlib.figure.Figure
        Panel ``j``: every output for a unit step on input ``j`` (the
        matching output solid, the cross-coupling dashed), with the overshoot
        and the 2 % settling time of the matching output marked.
    """
    if not isinstance(system, (control.StateSpace, control.TransferFunction)):
        raise ValueError(f"system must be a control StateSpace or TransferFunction, got {type(system).__name__}")
    n = system.ninputs
    if system.noutputs != n:
        raise ValueError(f"system must have as many outputs as inputs, got {system.noutputs}x{n}")
    names = _labels(labels, n, list(_AXES))
    if duration is None:
        rates = np.abs(np.real(system.poles()))
        rates = rates[rates > 0]
        duration = 8.0 / float(np.min(rates)) if rates.size else 10.0
    duration = float(check_positive(duration, "duration"))
    t = np.linspace(0.0, duration, 2001)
    colors = ("tab:blue", "tab:orange", "tab:green")
    fig = Figure(figsize=(4.4 * n, 3.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, n, sharey=True, squeeze=False)[0])
    for j in range(n):
        ax = axes[j]
        resp = control.step_response(system, t, input_indices=[j])
        y = np.asarray(resp.outputs).reshape(system.noutputs, -1)
        for i in range(system.noutputs):
            ax.plot(
                resp.time,
                y[i],
                color=colors[i % 3],
                ls="-" if i == j else "--",
                lw=1.8 if i == j else 1.0,
                label=f"angle {names[i]}",
            )
        info = control.step_info(y[j], resp.time, SettlingTimeThreshold=0.02)
        ax.axhline(1.0, color="0.4", lw=0.8)
        ax.axhspan(0.98, 1.02, color="0.85", zorder=0)
        peak = float(np.max(y[j]))
        ax.plot([info["PeakTime"]], [peak], "v", color="k")
        ax.annotate(
            f"overshoot {info['Overshoot']:.1f} %",
            (info["PeakTime"], peak),
            xytext=(6, 4),
            textcoords="offset points",
        )
        ax.axvline(info["SettlingTime"], color="k", ls=":", lw=0.8)
        ax.annotate(
            f"2 % settling {info['SettlingTime']:.3g} s",
            (info["SettlingTime"], 0.5),
            xytext=(4, 0),
            textcoords="offset points",
            fontsize=9,
        )
        ax.set_title(f"unit step on reference {names[j]}", fontsize=10)
        ax.set_xlabel("time [s]")
        ax.grid(True, alpha=0.3)
        if j == 0:
            ax.set_ylabel("attitude angle per unit step [rad/rad]")
            ax.legend(loc="lower right")
    lo, hi = axes[0].get_ylim()
    axes[0].set_ylim(lo, hi + 0.08 * (hi - lo))  # room for the overshoot labels (shared y)
    fig.suptitle("Closed-loop step responses (linearised at rest)", fontsize=11)
    return fig


#: Longest step of a Nichols curve [deg or dB, their Euclidean sum] before points are added, and the rounds.
NICHOLS_STEP = 1.0
NICHOLS_REFINEMENTS = 6
NICHOLS_POINTS_MAX = 20_000


def plot_nichols(
    loops: LTI | Sequence[LTI],
    *,
    labels: Sequence[str] | None = None,
    omega: ArrayLike | None = None,
    disk_margin: float | None = None,
) -> Figure:
    """Nichols chart of loops on one set of axes, with the region a disk margin keeps them out of.

    A loop with balanced disk margin ``alpha`` (Seiler, Packard and Gahinet,
    IEEE Control Systems Magazine 40(5), 2020; :mod:`controllers.disk_margins`)
    keeps ``2 |1 + L| / |1 - L| >= alpha`` at every frequency: the shaded
    region around ``(-180 deg, 0 dB)`` is where that fails, so a curve that
    stays out of it has at least that disk margin when its closed loop is
    stable (the legend says when it is not) (its width at 0 dB is the
    disk phase margin ``2 atan(alpha / 2)``, its height at -180 deg the disk
    gain margin ``(2 + alpha) / (2 - alpha)``). The closed-loop gain and phase
    contours are python-control's :func:`control.nichols_grid`.

    Parameters
    ----------
    loops : control LTI or sequence of them
        SISO loops, e.g. from :func:`loop_gain` (continuous, or discrete: drawn up to the Nyquist frequency).
    labels : sequence of str, optional
        One legend entry per loop (default ``"x axis"``, ``"y axis"``, ``"z axis"``).
    omega : array_like, optional
        First frequency grid [rad/s] for every loop (default: spans each
        loop's features); where a step of a curve is longer than
        :data:`NICHOLS_STEP` (a lightly damped resonance), points are added.
    disk_margin : float, optional
        The disk margin ``alpha`` in (0, 2) whose excluded region is shaded (e.g. the requirement).

    Returns
    -------
    matplotlib.figure.Figure
        Open-loop gain [dB] against open-loop phase [deg]; each curve's phase
        on the branch that puts it in (-360, 0] deg at its gain crossover.
    """
    items = _as_list(loops, "loops")
    for sys in items:
        _siso_tf(sys, "loops")
    names = _labels(labels, len(items), [f"{a} axis" for a in _AXES])
    alpha = None
    if disk_margin is not None:
        alpha = positive_scalar(disk_margin, "disk_margin")
        if alpha >= 2.0:
            raise ValueError(
                f"disk_margin must be in (0, 2) (a balanced disk; 2 is infinite gain margin), got {alpha!r}"
            )
    fig = Figure(figsize=(7.5, 6.0), layout="constrained")
    ax = fig.subplots()
    mags, phases = [], []
    for sys, name in zip(items, names):
        tf = _siso_tf(sys)
        grid = check_positive(omega, "omega") if omega is not None else _default_grid(tf, 200)
        L = _frequency_response(sys, grid)
        for _ in range(NICHOLS_REFINEMENTS):
            # Where a step of the curve is long (a resonance), points are added between its ends.
            step = np.hypot(np.diff(np.degrees(np.unwrap(np.angle(L)))), np.diff(20 * np.log10(np.abs(L))))
            long = np.flatnonzero(step > NICHOLS_STEP)
            if not long.size or grid.size > NICHOLS_POINTS_MAX:
                break
            extra = np.concatenate([np.geomspace(grid[i], grid[i + 1], 12)[1:-1] for i in long])
            grid = np.concatenate([grid, extra])
            order = np.argsort(grid)
            grid, L = grid[order], np.concatenate([L, _frequency_response(sys, extra)])[order]
        mag_db = 20 * np.log10(np.abs(L))
        phase = np.degrees(np.unwrap(np.angle(L)))
        crossing = np.flatnonzero(np.diff(np.sign(mag_db)) != 0)
        ref = float(phase[crossing[0]]) if crossing.size else float(phase[phase.size // 2])
        phase = phase - 360.0 * np.ceil(ref / 360.0)
        status = "" if _closed_loop_stable(sys) else " (closed loop UNSTABLE)"
        ax.plot(phase, mag_db, lw=1.6, label=f"{name}{status}")
        mags.append(mag_db)
        phases.append(phase)
    mag_all, phase_all = np.concatenate(mags), np.concatenate(phases)
    finite = np.isfinite(mag_all)
    lo_db = max(float(np.min(mag_all[finite])), -40.0) - 5.0
    hi_db = min(float(np.max(mag_all[finite])), 40.0) + 5.0
    lo_db, hi_db = min(lo_db, -20.0), max(hi_db, 20.0)
    shown = finite & (mag_all >= lo_db) & (mag_all <= hi_db)
    lo_ph = min(float(np.min(phase_all[shown])), -270.0) - 10.0
    hi_ph = max(float(np.max(phase_all[shown])), -90.0) + 10.0
    ax.set_xlim(lo_ph, hi_ph)
    ax.set_ylim(lo_db, hi_db)
    control.nichols_grid(ax=ax)
    if alpha is not None:
        ph, db = np.meshgrid(np.linspace(lo_ph, hi_ph, 721), np.linspace(lo_db, hi_db, 601))
        L = 10.0 ** (db / 20.0) * np.exp(1j * np.radians(ph))
        with np.errstate(divide="ignore", invalid="ignore"):
            local = 2.0 * np.abs(1.0 + L) / np.abs(1.0 - L)
        gain_db = 20.0 * math.log10((2.0 + alpha) / (2.0 - alpha))
        phase_deg = math.degrees(2.0 * math.atan(alpha / 2.0))
        ax.contourf(ph, db, local, levels=[0.0, alpha], colors=["tab:red"], alpha=0.18)
        ax.contour(ph, db, local, levels=[alpha], colors=["tab:red"], linewidths=1.0)
        ax.plot(
            [],
            [],
            color="tab:red",
            lw=6,
            alpha=0.3,
            label=(f"inside: disk margin < {alpha:.3g} (+-{gain_db:.3g} dB, +-{phase_deg:.3g} deg)"),
        )
    ax.plot([-180.0 + 360.0 * k for k in range(-2, 2)], [0.0] * 4, "k+", ms=10, mew=1.5)
    ax.set_xlim(lo_ph, hi_ph)
    ax.set_ylim(lo_db, hi_db)
    ax.set_xlabel("open-loop phase [deg]")
    ax.set_ylabel("open-loop gain [dB]")
    ax.legend(loc="best", fontsize=9)
    ax.set_title("Nichols chart of the loop gain broken at the plant input", fontsize=11)
    return fig

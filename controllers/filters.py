"""Notch and low-pass filters on a controller's torque command, and the controller that flies them.

A lightly damped structural mode near the attitude loop's bandwidth puts a
resonance peak into the loop (Wie, *Space Vehicle Dynamics and Control*,
2nd ed., AIAA 2008, ch. 7; Hughes, *Spacecraft Attitude Dynamics*, 1986):
a notch at the mode's frequency, or a low-pass filter below it, gain-
stabilises it at the cost of some phase at the crossover.

* :class:`NotchFilter`:
  ``H(s) = (s^2 + 2 zeta_z w s + w^2) / (s^2 + 2 zeta_p w s + w^2)``: unit
  gain at DC and at high frequency, ``|H(j w)| = zeta_z / zeta_p`` (the
  depth) with zero phase at the centre ``w``; ``zeta_p`` sets the width.
* :class:`LowPassFilter`: first order ``w / (s + w)`` (-3 dB at ``w``) or
  second order ``w^2 / (s^2 + 2 zeta w s + w^2)`` (``|H(j w)| = 1 / (2 zeta)``).

Each filter is a continuous transfer function (:meth:`~NotchFilter.continuous`)
and its discrete equivalent at a controller period
(:meth:`~NotchFilter.discrete`): Tustin with pre-warping at the filter's
centre or corner frequency (:func:`control.sample_system`), so the discrete
filter has exactly the continuous response at that frequency (Franklin,
Powell and Workman, *Digital Control of Dynamic Systems*, 3rd ed., sec. 6.3.2).
A frequency at or above the Nyquist frequency ``pi / period`` is refused.

:class:`FilteredController` runs a chain of them on each torque axis of
any controller (the ``Controller`` protocol of
:mod:`attitude.simulation.protocols`), so it flies in
:func:`attitude.simulation.simulate` on the protocol path, and the loop
analysis (:func:`controllers.analysis.loop_gain`, ``input_loop``, the disk
margins, the Bode and Nichols plots) puts the same filters in series with
the controller: the discrete ones in the sampled loop, the continuous ones
in the continuous loop.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import control
import numpy as np
from numpy.typing import NDArray

from attitude.validation import check_vector, positive_scalar

__all__ = ["FilteredController", "LowPassFilter", "NotchFilter"]

#: The damping of the default second-order low-pass filter (Butterworth: maximally flat).
BUTTERWORTH_DAMPING = 1.0 / math.sqrt(2.0)


def _discrete(filt: Any, period: float) -> control.TransferFunction:
    """Tustin equivalent of ``filt`` at ``period``, pre-warped at its frequency (below Nyquist, checked)."""
    period = positive_scalar(period, "period")
    nyquist = math.pi / period
    if filt.frequency >= nyquist:
        raise ValueError(
            f"{type(filt).__name__} frequency must be below the Nyquist frequency pi / period = {nyquist:.6g} rad/s "
            f"(period = {period:.6g} s), got frequency = {filt.frequency:.6g} rad/s"
        )
    return control.sample_system(filt.continuous(), period, method="tustin", prewarp_frequency=filt.frequency)


@dataclass(frozen=True, kw_only=True)
class NotchFilter:
    """Second-order notch ``(s^2 + 2 zeta_zero w s + w^2) / (s^2 + 2 zeta_pole w s + w^2)``.

    Parameters
    ----------
    frequency : float
        Centre frequency ``w`` [rad/s] (> 0): the structural mode's.
    zeta_pole : float
        Damping of the poles [-] (> 0): the notch's width (the -3 dB band of
        an infinitely deep notch is ``2 zeta_pole w`` wide).
    zeta_zero : float, optional
        Damping of the zeros [-], in ``[0, zeta_pole)``; 0 is an infinitely
        deep notch.
    depth : float, optional
        The gain at the centre, ``|H(j w)| = zeta_zero / zeta_pole`` [-], in
        ``[0, 1)`` (0.1 is a 20 dB notch). Give exactly one of ``zeta_zero``
        and ``depth``.

    Raises
    ------
    ValueError
        A non-positive frequency or ``zeta_pole``, neither or both of
        ``zeta_zero`` and ``depth``, or one outside its range.
    """

    frequency: float
    zeta_pole: float = 0.5
    zeta_zero: float | None = None
    depth: float | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "frequency", positive_scalar(self.frequency, "frequency"))
        set_(self, "zeta_pole", positive_scalar(self.zeta_pole, "zeta_pole"))
        if (self.zeta_zero is None) == (self.depth is None):
            raise ValueError(
                "give exactly one of zeta_zero (the zeros' damping) and depth (the gain at the centre, "
                f"zeta_zero / zeta_pole), got zeta_zero = {self.zeta_zero!r} and depth = {self.depth!r}"
            )
        if self.depth is not None:
            depth = positive_scalar(self.depth, "depth", allow_zero=True)
            if depth >= 1.0:
                raise ValueError(f"depth must be in [0, 1) (the gain at the centre of a notch), got {depth!r}")
            set_(self, "depth", depth)
            set_(self, "zeta_zero", depth * self.zeta_pole)
        else:
            zeta_zero = positive_scalar(self.zeta_zero, "zeta_zero", allow_zero=True)
            if zeta_zero >= self.zeta_pole:
                raise ValueError(
                    f"zeta_zero must be below zeta_pole = {self.zeta_pole!r} (else it is no notch), got {zeta_zero!r}"
                )
            set_(self, "zeta_zero", zeta_zero)
            set_(self, "depth", zeta_zero / self.zeta_pole)

    def continuous(self) -> control.TransferFunction:
        """The notch ``H(s)``."""
        w = self.frequency
        return control.tf([1.0, 2.0 * self.zeta_zero * w, w * w], [1.0, 2.0 * self.zeta_pole * w, w * w])

    def discrete(self, period: float) -> control.TransferFunction:
        """Tustin equivalent at ``period``, pre-warped at the centre: ``|H(exp(j w T))| = depth`` exactly.

        Parameters
        ----------
        period : float
            Sample time [s]; ``frequency`` must be below ``pi / period``.
        """
        return _discrete(self, period)


@dataclass(frozen=True, kw_only=True)
class LowPassFilter:
    """Low-pass filter: first order ``w / (s + w)`` or second order ``w^2 / (s^2 + 2 zeta w s + w^2)``.

    Parameters
    ----------
    frequency : float
        Corner frequency ``w`` [rad/s] (> 0).
    order : int
        1 or 2.
    damping : float, optional
        ``zeta`` of the second-order filter [-] (> 0; default ``1/sqrt(2)``,
        Butterworth); not for the first order.

    Raises
    ------
    ValueError
        A non-positive frequency or damping, an order other than 1 or 2, or a
        damping for the first order.
    """

    frequency: float
    order: int = 2
    damping: float | None = None

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "frequency", positive_scalar(self.frequency, "frequency"))
        if isinstance(self.order, bool) or self.order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {self.order!r}")
        if self.order == 1:
            if self.damping is not None:
                raise ValueError(f"damping is for the second-order filter only (order = 2), got {self.damping!r}")
        else:
            damping = BUTTERWORTH_DAMPING if self.damping is None else self.damping
            set_(self, "damping", positive_scalar(damping, "damping"))

    def continuous(self) -> control.TransferFunction:
        """The filter ``H(s)``."""
        w = self.frequency
        if self.order == 1:
            return control.tf([w], [1.0, w])
        return control.tf([w * w], [1.0, 2.0 * self.damping * w, w * w])

    def discrete(self, period: float) -> control.TransferFunction:
        """Tustin equivalent at ``period``, pre-warped at the corner (the same gain there as continuous).

        Parameters
        ----------
        period : float
            Sample time [s]; ``frequency`` must be below ``pi / period``.
        """
        return _discrete(self, period)


#: What a filter chain may hold.
Filter = NotchFilter | LowPassFilter

_FORWARDED = ("reference", "reference_samples")


class FilteredController:
    """A controller whose torque command passes through a chain of discrete filters, per axis.

    At each sample the inner controller's command ``u`` goes through the
    filters in order (each the Tustin equivalent at the controller's period,
    run as its state-space difference equation ``y = C x + D u``,
    ``x <- A x + B u`` with one state per axis kept between samples); the
    axes not in ``axes`` pass unfiltered. The states start at rest and are
    reset by :meth:`prepare` (the engine calls it before each run).

    It meets the ``Controller`` protocol (``period``, ``torque``) and
    forwards ``reference`` and ``reference_samples`` when the inner
    controller has them; it has no compiled law (the engine flies it on the
    protocol path). :meth:`log` adds the unfiltered command to the inner
    controller's log. The loop analysis (:func:`controllers.analysis.loop_gain`)
    sees ``controller`` and :meth:`filter_system` in series. Chains on
    different axes nest: ``FilteredController(FilteredController(pd,
    [notch], axes=[2]), [low_pass], axes=[0, 1])``; the analysis unwraps
    each, the innermost first.

    Parameters
    ----------
    controller : Controller
        The inner controller (``period`` [s], ``torque(t, estimate)``).
    filters : sequence of NotchFilter and LowPassFilter
        The chain, applied in order (at least one).
    axes : sequence of int
        The body axes filtered (0, 1, 2 for x, y, z; default all).

    Raises
    ------
    ValueError
        A controller without ``torque`` or ``period``, an empty chain or an
        element that is not a filter, bad axes, or a filter frequency at or
        above the Nyquist frequency ``pi / controller.period``.
    """

    def __init__(self, controller: Any, filters: Sequence[Filter], *, axes: Sequence[int] = (0, 1, 2)) -> None:
        if not hasattr(controller, "torque") or getattr(controller, "period", None) is None:
            raise ValueError(f"controller must have torque(t, estimate) and a period [s], got {controller!r}")
        self.controller = controller
        self.period = positive_scalar(controller.period, "controller.period")
        items = list(filters) if isinstance(filters, Sequence) else [filters]
        if not items or not all(isinstance(f, (NotchFilter, LowPassFilter)) for f in items):
            raise ValueError(f"filters must be a non-empty sequence of NotchFilter and LowPassFilter, got {filters!r}")
        self.filters = tuple(items)
        axes = tuple(axes)
        if not axes or len(set(axes)) != len(axes) or not all(a in (0, 1, 2) for a in axes):
            raise ValueError(f"axes must be distinct body axes among 0, 1, 2, got {axes!r}")
        self.axes = tuple(sorted(axes))
        self._stages = []
        for f in self.filters:
            d = control.ss(f.discrete(self.period))
            self._stages.append(tuple(np.asarray(m, dtype=float) for m in (d.A, d.B, d.C, d.D)))
        self.reset()

    def __getattr__(self, name: str) -> Any:
        # Only the optional members the engine looks for are forwarded, and only when the inner controller has them.
        if name in _FORWARDED and "controller" in self.__dict__:
            return getattr(self.__dict__["controller"], name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def reset(self) -> None:
        """Put every filter state at rest (zero)."""
        k = len(self.axes)
        self._states = [np.zeros((a.shape[0], k)) for a, _, _, _ in self._stages]
        self._unfiltered = np.zeros(3)

    def prepare(self, t0: float, q0: Any, omega0: Any) -> None:
        """Reset the filters and prepare the inner controller (when it has ``prepare``).

        Parameters
        ----------
        t0 : float
            Start time [s].
        q0 : array_like (4,)
            Initial attitude ``q_BN``.
        omega0 : array_like (3,)
            Initial body rate [rad/s].
        """
        self.reset()
        if hasattr(self.controller, "prepare"):
            self.controller.prepare(t0, q0, omega0)

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """The inner controller's command [N m], filtered on ``axes``.

        Parameters
        ----------
        t : float
            Sample time [s].
        estimate : Estimate
            What the inner controller sees.
        """
        u = check_vector(self.controller.torque(t, estimate), "controller.torque(t, estimate)", 3).astype(float)
        self._unfiltered = u.copy()
        v = u[list(self.axes)]
        for (a, b, c, d), x in zip(self._stages, self._states):
            y = (c @ x)[0] + d[0, 0] * v if x.size else d[0, 0] * v
            x[...] = a @ x + b * v
            v = y
        u[list(self.axes)] = v
        return u

    def log(self) -> dict[str, Any]:
        """The inner controller's log (when it has one) and ``torque_unfiltered`` (3,) [N m], its last command."""
        inner = dict(self.controller.log()) if hasattr(self.controller, "log") else {}
        inner["torque_unfiltered"] = self._unfiltered.copy()
        return inner

    def filter_system(self, *, sampled: bool = True) -> control.StateSpace:
        """The chain as a 3-input 3-output system from the inner command to the filtered torque.

        Parameters
        ----------
        sampled : bool
            True: the discrete chain that flies (Tustin, pre-warped, at
            ``period``); False: the continuous filters.

        Returns
        -------
        control.StateSpace
            Diagonal: the chain on ``axes``, unity on the others.
        """
        dt = self.period if sampled else 0
        chain = control.ss([], [], [], [[1.0]], dt)
        for f in self.filters:
            chain = control.series(chain, control.ss(f.discrete(self.period) if sampled else f.continuous()))
        unity = control.ss([], [], [], [[1.0]], dt)
        return control.append(*(chain if i in self.axes else unity for i in range(3)))

    def __repr__(self) -> str:
        return f"FilteredController({self.controller!r}, {list(self.filters)!r}, axes={self.axes!r})"

"""A mode sequence: detumble, Sun acquisition, then nadir or a target, switched on conditions.

An attitude control system flies in modes, each a control law (and its
actuators) with a condition to leave it for the next: B-dot on the
magnetorquers until the body rate is low, Sun pointing on the wheels until
the arrays face the Sun, then nadir or target tracking. :class:`ModeSequence`
holds the modes and their exit conditions and is both the torque law
(``controller=sequence``) and, through :attr:`ModeSequence.dipole_law`, the
magnetic law (``dipole_controller=sequence.dipole_law``) that ``simulate``
flies. The conditions are judged on what the controller sees (the estimate,
or the truth without an estimator) at the torque law's samples:

* :class:`RateBelow` -- ``|omega| < rate`` without a break for ``hold_s``;
* :class:`PointingWithin` -- the mode controller's attitude error to its own
  reference below ``angle`` for ``hold_s`` (the Sun in the arrays' cone, the
  boresight on nadir);
* :class:`After` -- ``duration_s`` in the mode.

``timeout_s`` on a mode bounds it: a mode still active after its timeout is
left for the next one and the switch is logged as a timeout (a flight
software would enter a safe mode there; a design study wants to see that it
happened). The engine logs the active mode's index every sample
(``logs["controller.mode"]``); :meth:`ModeSequence.timeline` gives the
switches and :meth:`ModeSequence.plot_timeline` the figure. A sequence runs
on ``simulate``'s Python engine (``engine="auto"`` picks it; the compiled
engine takes only laws that compile). A sequence whose magnetic laws are
not flown (``dipole_controller=sequence.dipole_law`` forgotten), or whose
dipole side is flown without the sequence as the controller, warns once.
See docs/guidance.md ("Mode sequences").
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.validation import positive_scalar

__all__ = ["After", "Mode", "ModeSequence", "ModeSwitch", "PointingWithin", "RateBelow"]


@dataclass(frozen=True)
class RateBelow:
    """Leave when the body rate seen stays below ``rate_rad_s`` for ``hold_s`` seconds.

    Parameters
    ----------
    rate_rad_s : float
        Rate threshold [rad/s] (> 0).
    hold_s : float
        Time the rate must stay below it without a break [s] (>= 0).
    """

    rate_rad_s: float
    hold_s: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "rate_rad_s", positive_scalar(self.rate_rad_s, "rate_rad_s"))
        object.__setattr__(self, "hold_s", positive_scalar(self.hold_s, "hold_s", allow_zero=True))

    def met(self, t: float, estimate: Any, controller: Any) -> bool:
        """Whether the condition holds at this sample (before the hold).

        Parameters
        ----------
        t : float
            Sample time [s].
        estimate : Estimate
            What the controller sees.
        controller : object or None
            The mode's torque law (unused).

        Returns
        -------
        bool
        """
        return float(np.linalg.norm(estimate.omega)) < self.rate_rad_s

    def describe(self) -> str:
        """The condition in words, for the timeline."""
        return f"rate < {math.degrees(self.rate_rad_s):.3g} deg/s for {self.hold_s:g} s"


@dataclass(frozen=True)
class PointingWithin:
    """Leave when the mode controller's attitude error to its reference stays below ``angle_rad`` for ``hold_s``.

    Parameters
    ----------
    angle_rad : float
        Error threshold [rad] (> 0).
    hold_s : float
        Time the error must stay below it without a break [s] (>= 0).
    """

    angle_rad: float
    hold_s: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "angle_rad", positive_scalar(self.angle_rad, "angle_rad"))
        object.__setattr__(self, "hold_s", positive_scalar(self.hold_s, "hold_s", allow_zero=True))

    def met(self, t: float, estimate: Any, controller: Any) -> bool:
        """Whether the condition holds at this sample (before the hold).

        Parameters
        ----------
        t : float
            Sample time [s].
        estimate : Estimate
            What the controller sees.
        controller : object
            The mode's torque law (its ``reference(t)``).

        Returns
        -------
        bool
        """
        q_ref = np.asarray(controller.reference(t)[0], dtype=float)
        return float(quat.error_angle(q_ref, quat.normalize(np.asarray(estimate.q, dtype=float)))) < self.angle_rad

    def describe(self) -> str:
        """The condition in words, for the timeline."""
        return f"pointing error < {math.degrees(self.angle_rad):.3g} deg for {self.hold_s:g} s"


@dataclass(frozen=True)
class After:
    """Leave after ``duration_s`` seconds in the mode.

    Parameters
    ----------
    duration_s : float
        Time in the mode [s] (> 0).
    """

    duration_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "duration_s", positive_scalar(self.duration_s, "duration_s"))

    @property
    def hold_s(self) -> float:
        """The condition holds from its first sample on (the duration is the condition)."""
        return 0.0

    def met(self, t: float, estimate: Any, controller: Any, entered: float = 0.0) -> bool:
        """Whether ``duration_s`` has passed since the mode was entered.

        Parameters
        ----------
        t : float
            Sample time [s].
        estimate : Estimate
            What the controller sees (unused).
        controller : object or None
            The mode's torque law (unused).
        entered : float
            When the mode was entered [s].

        Returns
        -------
        bool
        """
        return t - entered >= self.duration_s

    def describe(self) -> str:
        """The condition in words, for the timeline."""
        return f"{self.duration_s:g} s in the mode"


Condition = RateBelow | PointingWithin | After


@dataclass(frozen=True)
class Mode:
    """One mode: its laws and the condition to leave it.

    Parameters
    ----------
    name : str
        Shown on the timeline.
    controller : object, optional
        The torque law (``period``, ``torque(t, estimate)``); None: no torque.
        :class:`PointingWithin` needs its ``reference(t)``.
    dipole_controller : object, optional
        The magnetic law (``period``, ``dipole(t, measurements)``); None: no dipole.
    until : RateBelow or PointingWithin or After, optional
        When to leave for the next mode; None only for the last mode.
    timeout_s : float, optional
        Leave for the next mode after this long even if ``until`` never held
        (logged as a timeout) [s]; None: stay until it holds.
    """

    name: str
    controller: Any = None
    dipole_controller: Any = None
    until: Condition | None = None
    timeout_s: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"name must be a non-empty string, got {self.name!r}")
        if self.until is not None and not isinstance(self.until, (RateBelow, PointingWithin, After)):
            raise ValueError(
                f"mode {self.name!r}: until must be RateBelow, PointingWithin, After or None, got {self.until!r}"
            )
        for law, method, what in ((self.controller, "torque", "controller"), (self.dipole_controller, "dipole",
                                                                               "dipole_controller")):  # fmt: skip
            if law is not None and not (callable(getattr(law, method, None)) and hasattr(law, "period")):
                raise ValueError(
                    f"mode {self.name!r}: {what} must have period and {method}(t, ...), got {type(law).__name__}"
                )
        if isinstance(self.until, PointingWithin) and not callable(getattr(self.controller, "reference", None)):
            raise ValueError(
                f"mode {self.name!r}: PointingWithin needs a controller with reference(t) (the attitude it points "
                f"to), got {type(self.controller).__name__}"
            )
        if self.timeout_s is not None:
            object.__setattr__(self, "timeout_s", positive_scalar(self.timeout_s, "timeout_s"))
            hold = 0.0 if self.until is None else self.until.hold_s
            if self.timeout_s <= hold:
                raise ValueError(
                    f"mode {self.name!r}: timeout_s must exceed the condition's hold_s ({hold:g} s), got "
                    f"{self.timeout_s:g} s: the condition could never be met before the timeout"
                )


@dataclass(frozen=True)
class ModeSwitch:
    """One switch of a flown sequence.

    Parameters
    ----------
    t : float
        Time of the switch [s] (the torque sample it was decided at).
    from_mode, to_mode : str
        Names of the modes left and entered.
    reason : str
        The condition that held, or ``"timeout after ... s"``.
    """

    t: float
    from_mode: str
    to_mode: str
    reason: str


class ModeSequence:
    """Modes flown in order, each left when its condition holds (module docstring).

    Parameters
    ----------
    modes : sequence of Mode
        In the order flown; every mode but the last has ``until``, the last has none.
    period : float
        Torque-law sample time [s]: every mode's ``controller`` has this period.
    dipole_period : float, optional
        Magnetic-law sample time [s]: every mode's ``dipole_controller`` has
        this period (default: ``period``).

    Raises
    ------
    ValueError
        No modes, duplicate names, a missing or extra ``until``, or a law whose
        period differs from the sequence's.
    """

    def __init__(self, modes: Sequence[Mode], *, period: float, dipole_period: float | None = None) -> None:
        self.modes = tuple(modes)
        if not self.modes or not all(isinstance(m, Mode) for m in self.modes):
            raise ValueError(f"modes must be a non-empty sequence of Mode, got {modes!r}")
        names = [m.name for m in self.modes]
        if len(set(names)) != len(names):
            raise ValueError(f"mode names must be distinct, got {names}")
        for m in self.modes[:-1]:
            if m.until is None:
                raise ValueError(f"mode {m.name!r} has no until: every mode but the last needs a condition to leave")
        if self.modes[-1].until is not None or self.modes[-1].timeout_s is not None:
            raise ValueError(f"the last mode {self.modes[-1].name!r} is never left: give it no until and no timeout_s")
        self.period = positive_scalar(period, "period")
        self.dipole_period = self.period if dipole_period is None else positive_scalar(dipole_period, "dipole_period")
        for m in self.modes:
            for law, want, what in ((m.controller, self.period, "period"), (m.dipole_controller, self.dipole_period,
                                                                            "dipole_period")):  # fmt: skip
                if law is not None and not math.isclose(float(law.period), want, rel_tol=1e-12):
                    raise ValueError(
                        f"mode {m.name!r}: its law samples every {float(law.period):g} s, the sequence's {what} is "
                        f"{want:g} s; give every mode's laws the sequence's periods"
                    )
        self.dipole_law = _DipoleLaw(self)
        self.prepare(0.0, quat.identity(), np.zeros(3))

    def __repr__(self) -> str:
        return f"ModeSequence([{', '.join(m.name for m in self.modes)}], period={self.period:g})"

    @property
    def mode(self) -> Mode:
        """The active mode."""
        return self.modes[self._index]

    def prepare(self, t0: float, q0: ArrayLike, omega0: ArrayLike) -> None:
        """Start (again) in the first mode; the engine calls it before a run.

        Parameters
        ----------
        t0 : float
            Start time [s].
        q0 : array_like (4,)
            Initial attitude ``q_BN``.
        omega0 : array_like (3,)
            Initial body rate [rad/s].
        """
        self._index = 0
        self._entered = float(t0)
        self._held_since: float | None = None
        self._starts = [float(t0)]
        self.switches: list[ModeSwitch] = []
        self._torque_calls = 0
        self._wiring_checked = False
        self.dipole_law.calls = 0
        self._enter(t0, q0, omega0)

    def _enter(self, t: float, q: ArrayLike, omega: ArrayLike) -> None:
        mode = self.mode
        if hasattr(mode.controller, "prepare"):
            mode.controller.prepare(t, q, omega)
        if hasattr(mode.dipole_controller, "reset"):
            mode.dipole_controller.reset()

    def _advance(self, t: float, estimate: Any) -> None:
        """Switch to the next mode when the active one's condition has held long enough (or it timed out)."""
        while self._index < len(self.modes) - 1:
            mode = self.mode
            until = mode.until
            if isinstance(until, After):
                met = until.met(t, estimate, mode.controller, self._entered)
            else:
                met = until.met(t, estimate, mode.controller)
            if not met:
                self._held_since = None
            elif self._held_since is None:
                self._held_since = t
            if met and t - self._held_since >= until.hold_s:
                reason = until.describe()
            elif mode.timeout_s is not None and t - self._entered >= mode.timeout_s:
                reason = f"timeout after {mode.timeout_s:g} s ({until.describe()} never held)"
            else:
                return
            self.switches.append(ModeSwitch(float(t), mode.name, self.modes[self._index + 1].name, reason))
            self._index += 1
            self._entered = float(t)
            self._held_since = None
            self._starts.append(float(t))
            self._enter(t, estimate.q, estimate.omega)

    def _check_wiring(self, t: float) -> None:
        """Warn once when one side of the sequence is not flown (its laws would silently do nothing)."""
        if self._wiring_checked:
            return
        late = t - self._starts[0]
        mode = self.mode
        if mode.dipole_controller is not None and self.dipole_law.calls == 0 and late > 2.0 * self.dipole_period:
            self._wiring_checked = True
            warnings.warn(
                f"mode {mode.name!r} has a magnetic law but the sequence's dipole_law is not flown: pass "
                "dipole_controller=sequence.dipole_law to simulate (with magnetorquers=)",
                UserWarning,
                stacklevel=4,
            )
        if self._torque_calls == 0 and self.dipole_law.calls > 0 and late > 2.0 * self.period:
            self._wiring_checked = True
            warnings.warn(
                "the sequence's dipole_law is flown but the sequence itself is not the controller, so its modes "
                "never advance: pass controller=sequence to simulate",
                UserWarning,
                stacklevel=4,
            )

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """The active mode's torque command, after judging its exit condition.

        Parameters
        ----------
        t : float
            Sample time [s].
        estimate : Estimate
            What the controller sees.

        Returns
        -------
        ndarray (3,)
            Commanded body torque [N m] (zero in a mode without a torque law).
        """
        self._torque_calls += 1
        self._check_wiring(t)
        self._advance(t, estimate)
        law = self.mode.controller
        return np.zeros(3) if law is None else np.asarray(law.torque(t, estimate), dtype=float)

    def log(self) -> dict[str, Any]:
        """``{"mode": index of the active mode}`` and the active torque law's own log under ``"<mode>.<key>"``.

        Returns
        -------
        dict
            Logged by the engine at every sample (``logs["controller.mode"]``,
            ``logs["controller.<mode>.<key>"]``, NaN while that mode is not active).
        """
        return {"mode": float(self._index), **_mode_log(self.mode, self.mode.controller)}

    def mode_at(self, t: ArrayLike) -> NDArray[np.int64]:
        """Index of the mode active at each time of the last run.

        Parameters
        ----------
        t : array_like (n,)
            Times [s].

        Returns
        -------
        ndarray of int (n,)
        """
        return np.searchsorted(np.asarray(self._starts), np.asarray(t, dtype=float), side="right") - 1

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The active mode's reference at each time of the last run (NaN in a mode without one).

        Parameters
        ----------
        t : array_like (n,)
            Times [s].

        Returns
        -------
        q_ref : ndarray (n, 4)
        omega_ref : ndarray (n, 3)
            [rad/s]; NaN rows where the active mode has no reference (detumbling).
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q_ref, omega_ref = np.full((t.size, 4), np.nan), np.full((t.size, 3), np.nan)
        index = np.clip(self.mode_at(t), 0, len(self.modes) - 1)
        for i, mode in enumerate(self.modes):
            rows = np.nonzero(index == i)[0]
            law = mode.controller
            if rows.size == 0 or not callable(getattr(law, "reference", None)):
                continue
            if callable(getattr(law, "reference_samples", None)):
                q_i, w_i = law.reference_samples(t[rows])
            else:
                pairs = [law.reference(tk) for tk in t[rows]]
                q_i, w_i = np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])
            q_ref[rows], omega_ref[rows] = q_i, w_i
        return q_ref, omega_ref

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`reference_samples` at one time.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        q_ref : ndarray (4,)
        omega_ref : ndarray (3,)
        """
        q_ref, omega_ref = self.reference_samples([t])
        return q_ref[0], omega_ref[0]

    def timeline(self, end_s: float) -> list[dict[str, Any]]:
        """The modes of the last run, one row per mode entered.

        Parameters
        ----------
        end_s : float
            End of the run [s] (closes the last mode).

        Returns
        -------
        list of dict
            ``mode``, ``start_s``, ``end_s``, ``duration_s`` and ``left_because``
            (None for the mode the run ended in).
        """
        rows = []
        for k, start in enumerate(self._starts):
            stop = self._starts[k + 1] if k + 1 < len(self._starts) else float(end_s)
            reason = self.switches[k].reason if k < len(self.switches) else None
            rows.append(
                {"mode": self.modes[k].name, "start_s": start, "end_s": stop, "duration_s": stop - start,
                 "left_because": reason}
            )  # fmt: skip
        return rows

    def plot_timeline(self, result: Any, path: Any = None) -> Any:
        """Figure of the last run: the modes over time, the body rate and the pointing error to each mode's reference.

        Parameters
        ----------
        result : SimulationResult
            The run flown with this sequence (its ``t``, ``omega`` and ``error_angle``).
        path : str or path-like, optional
            Save the figure there (PNG) as well as returning it.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from attitude.plotting import plot_mode_timeline

        names = [m.name for m in self.modes]
        fig = plot_mode_timeline(result.t, self.mode_at(result.t), names, result.omega, result.error_angle,
                                 [s.t for s in self.switches])  # fmt: skip
        if path is not None:
            fig.savefig(path, dpi=120)
        return fig


def _mode_log(mode: Mode, law: Any) -> dict[str, Any]:
    """A law's ``log()`` under its mode's name (one series per mode: their keys and shapes may differ)."""
    if law is None or not callable(getattr(law, "log", None)):
        return {}
    return {f"{mode.name}.{key}": value for key, value in law.log().items()}


class _DipoleLaw:
    """The sequence's magnetic side: the active mode's dipole law (zero dipole in a mode without one)."""

    def __init__(self, sequence: ModeSequence) -> None:
        self._sequence = sequence
        self.period = sequence.dipole_period
        self.calls = 0  # samples flown in this run (the sequence's wiring check reads it)

    def dipole(self, t: float, measurements: Mapping[str, Any]) -> NDArray[np.float64]:
        self.calls += 1
        self._sequence._check_wiring(t)
        law = self._sequence.mode.dipole_controller
        return np.zeros(3) if law is None else np.asarray(law.dipole(t, measurements), dtype=float)

    def log(self) -> dict[str, Any]:
        """The active magnetic law's own log under ``"<mode>.<key>"`` (``logs["dipole_controller.<mode>.<key>"]``)."""
        mode = self._sequence.mode
        return _mode_log(mode, mode.dipole_controller)

    @property
    def use_truth_field(self) -> bool:
        return any(getattr(m.dipole_controller, "use_truth_field", False) for m in self._sequence.modes)

"""Disk margins of a loop, checked: closed-loop stability first, then the worst frequency refined.

A disk margin ``alpha`` says how much simultaneous gain *and* phase change a
loop tolerates: every gain and phase inside the disk of size ``alpha`` keeps
the closed loop stable (Seiler, Packard and Gahinet, "An introduction to
disk margins", IEEE Control Systems Magazine 40(5), 2020). For a MIMO loop
the multiloop margin perturbs all channels at once, which loop-at-a-time
gain and phase margins miss (the spinning satellite of that paper, sec.
"Multiloop disk margins").

:func:`disk_margins` wraps :func:`control.disk_margins` (python-control
0.10.2; MIMO loops need the optional ``slycot``, extra ``robust``) and mends
its pitfalls:

* it does not check closed-loop stability: an unstable closed loop can
  report comfortable margins. Here the closed-loop poles are checked first
  and an unstable loop is reported unstable, with no margin;
* it takes the minimum over the frequencies it is given: on a coarse grid
  the minimum can be far above the true one. Here the first grid is a wide
  logarithmic one plus the neighbourhood of every lightly damped open- or
  closed-loop root sampled at a quarter of its resonance's width (a 0.5 %
  mode between two points of a plain logarithmic grid left the margin 15 to
  26 % optimistic), and each of its lowest local minima is refined (a dense
  grid between its neighbours) until the margin changes by less than
  ``rtol``; every figure is the minimum over the union of the grids, so
  refining never raises it;
* ``omega`` must be an array: the grid is built here (sampled loops up to
  their Nyquist frequency).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude.rigid_body import RigidBody
from controllers.analysis import broken_channels, input_loop, output_loop

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "BREAK_POINTS",
    "DiskMargins",
    "LoopDiskMargins",
    "disk_margin_curve",
    "disk_margins",
    "loop_disk_margins",
    "plot_disk_margins",
]

#: Points of the first logarithmic grid and of each refinement between the worst frequency's neighbours.
GRID_POINTS = 400
REFINE_POINTS = 60
#: Refinements at most (each shrinks the bracket about REFINE_POINTS / 2 times).
MAX_REFINEMENTS = 12
#: Extensions of the grid by three decades where the smallest margin sits at one of its ends.
EDGE_EXTENSIONS = 3
#: Roots (open- and closed-loop) damped below this get their resonance sampled finely in the first grid.
LIGHT_DAMPING = 0.2
#: A root above this [rad/s] is a root at infinity computed in floating point (an attitude loop has none there).
INFINITE_ROOT_RAD_S = 1e10
#: A root smaller than this fraction of the largest is a numerical zero, not a frequency: a sampled double
#: integrator's poles come out at ``z = 1 +- sqrt(eps)``, ``|log z| / T`` about 1e-7 rad/s at 10 Hz.
ZERO_ROOT = 1e-6
#: Local minima of the first grid refined, the lowest first (a resonance's dip besides the global one) ...
LOCAL_MINIMA_REFINED = 6
#: ... among those within this factor of the grid's lowest margin: a dip sampled at a quarter of its width
#: (the resonance seeds) shows within a few per cent of its bottom, so one 10 % higher cannot be the minimum.
LOCAL_MINIMUM_RANGE = 1.1


@dataclass(frozen=True)
class DiskMargins:
    """The disk margins of a loop and how they were found.

    Attributes
    ----------
    closed_loop_stable : bool
        Whether the closed loop ``(I + L)^-1`` is stable (else no margin is reported: the figures are NaN).
    disk_margin : float
        ``alpha`` [-] (balanced for ``skew = 0``).
    gain_margin_db : float
        The disk-based gain margin [dB] (the gain may change by this much either way for ``skew = 0``).
    phase_margin_deg : float
        The disk-based phase margin [deg] (either way).
    frequency_rad_s : float
        Where the margin is smallest [rad/s].
    skew : float
        The disk's skew (0 balanced, 1 sensitivity, -1 complementary sensitivity).
    grid_points : int
        Frequencies evaluated (first grid and refinements).
    converged : bool
        Whether the last refinement changed the margin by less than the tolerance and the smallest margin is
        inside the grid (or at a sampled loop's Nyquist frequency), not at an end it could not extend past.
    sampled : bool
        Whether the loop is discrete (its grid ends at the Nyquist frequency).
    """

    closed_loop_stable: bool
    disk_margin: float
    gain_margin_db: float
    phase_margin_deg: float
    frequency_rad_s: float
    skew: float
    grid_points: int
    converged: bool
    sampled: bool

    def summary(self) -> str:
        """One line: the margins and where, or that the closed loop is unstable."""
        kind = "sampled loop" if self.sampled else "loop"
        if not self.closed_loop_stable:
            return f"{kind}: closed loop UNSTABLE, no disk margin (python-control alone would report one)"
        note = "" if self.converged else " (NOT converged: smallest at an open end of the grid, or refinement stopped)"
        return (
            f"{kind}: disk margin {self.disk_margin:.4g} (gain +-{self.gain_margin_db:.3g} dB, phase "
            f"+-{self.phase_margin_deg:.3g} deg) at {self.frequency_rad_s:.4g} rad/s{note}"
        )


def disk_margins(loop: Any, *, skew: float = 0.0, omega: ArrayLike | None = None, rtol: float = 1e-6) -> DiskMargins:
    """Disk margins of a loop transfer function, closed-loop stability checked and the worst frequency refined.

    Parameters
    ----------
    loop : control.StateSpace or control.TransferFunction
        The loop ``L`` (square; continuous, or discrete with its sample time): SISO, or MIMO for the
        multiloop margin (all channels perturbed at once; needs ``slycot``).
    skew : float
        The disk's skew (module docstring); 0 balanced.
    omega : array_like, optional
        A first grid [rad/s] (positive, increasing); default a logarithmic grid four decades around the
        loop's poles and zeros (up to the Nyquist frequency for a sampled loop). Either way the resonances of
        the lightly damped roots within it are added (module docstring).
    rtol : float
        Relative change of the margin at which refinement stops.

    Returns
    -------
    DiskMargins

    Raises
    ------
    ValueError
        For a loop that is not a python-control system, not square, or a bad ``omega``, ``skew`` or ``rtol``.
    ImportError
        For a MIMO loop without ``slycot`` (the ``robust`` extra).
    """
    if not isinstance(loop, (control.StateSpace, control.TransferFunction)):
        raise ValueError(f"loop must be a control StateSpace or TransferFunction, got {type(loop).__name__}")
    if loop.ninputs != loop.noutputs:
        raise ValueError(f"loop must be square (as many inputs as outputs), got {loop.noutputs} x {loop.ninputs}")
    if not math.isfinite(float(skew)):
        raise ValueError(f"skew must be a finite number, got {skew!r}")
    if not (math.isfinite(float(rtol)) and 0.0 < float(rtol) < 1.0):
        raise ValueError(f"rtol must be in (0, 1), got {rtol!r}")
    sampled = bool(loop.isdtime(strict=True))
    nyquist = math.pi / float(loop.dt) if sampled else math.inf
    stable = _closed_loop_stable(loop)
    if omega is None:
        grid = _first_grid(loop, nyquist)
    else:  # the given grid, with the lightly damped resonances inside its span sampled (a coarse grid misses them)
        grid = _checked_grid(omega, nyquist)
        grid = np.union1d(grid, _resonance_seeds(_s_plane_roots(loop), float(grid[0]), float(grid[-1])))
    if not stable:
        nan = float("nan")
        return DiskMargins(False, nan, nan, nan, nan, float(skew), grid.size, True, sampled)
    margins = {}

    def evaluate(points: NDArray[np.float64]) -> None:
        try:
            dm, dgm, dpm = control.disk_margins(loop, points, skew=skew, returnall=True)
        except control.ControlMIMONotImplemented as exc:
            raise ImportError(
                "multiloop disk margins of a MIMO loop need slycot: pip install 'attitude-toolkit[robust]'"
            ) from exc
        for w, a, g, p in zip(points, np.ravel(dm), np.ravel(dgm), np.ravel(dpm)):
            margins[float(w)] = (float(a), float(g), float(p))

    evaluate(grid)
    top = nyquist * (1.0 - 1e-9)  # the highest frequency a grid may reach (inf for a continuous loop)
    best = min(margins.items(), key=lambda item: item[1][0])
    # The smallest margin at an end of the grid: the grid is extended a few decades that way (a margin that
    # is smallest at DC, as for the spinning satellite, or at high frequency in a continuous loop).
    for _ in range(EDGE_EXTENSIONS):
        points = np.array(sorted(margins))
        if best[0] == points[0] and points[0] > 1e-12:
            evaluate(np.logspace(math.log10(points[0]) - 3.0, math.log10(points[0]), 60)[:-1])
        elif best[0] == points[-1] and points[-1] < top:
            evaluate(np.logspace(math.log10(points[-1]), math.log10(min(points[-1] * 1e3, top)), 60)[1:])
        else:
            break
        best = min(margins.items(), key=lambda item: item[1][0])
    # Every local minimum of the grid so far (the lowest LOCAL_MINIMA_REFINED) is refined: the global one of a
    # coarse grid need not be the true one (a lightly damped resonance's dip).
    points = np.array(sorted(margins))
    values = np.array([margins[float(w)][0] for w in points])
    interior = np.r_[True, values[1:] <= values[:-1]] & np.r_[values[:-1] <= values[1:], True]
    near = values <= LOCAL_MINIMUM_RANGE * values.min()  # dips near the lowest (a resonance's, a crossover's)
    candidates = sorted(points[interior & near], key=lambda w: margins[float(w)][0])[:LOCAL_MINIMA_REFINED]
    if best[0] not in candidates:
        candidates.append(best[0])
    settled = {_refine(margins, evaluate, float(start), rtol) for start in candidates}
    best = min(margins.items(), key=lambda item: item[1][0])
    converged = best[0] in settled  # the global minimum is one whose refinement converged
    points = np.array(sorted(margins))
    # Still smallest at an open end of the grid (not the Nyquist frequency of a sampled loop): the true minimum
    # may lie beyond it, so the figure is not claimed converged.
    if best[0] == points[0] or (best[0] == points[-1] and points[-1] < top * (1.0 - 1e-6)):
        converged = False
    w, (alpha, gain_db, phase_deg) = best
    return DiskMargins(True, alpha, gain_db, phase_deg, w, float(skew), len(margins), converged, sampled)


@dataclass(frozen=True)
class LoopDiskMargins:
    """A controller's disk margins at one break point: each channel alone and all at once.

    Attributes
    ----------
    per_axis : tuple of DiskMargins
        Loop-at-a-time: channel ``i`` perturbed, the others closed
        (:func:`controllers.analysis.broken_channels`). At the plant input of a rigid body: the torque about
        x, y, z; at its output: the measured ``q_v`` x, y, z, then ``omega`` x, y, z.
    multiloop : DiskMargins or None
        Every channel perturbed at once (None without ``slycot``: ``note`` says so).
    note : str
        Why the multiloop margin is missing, or "".
    break_point : str
        "input" (the actuators' gain and phase) or "output" (the sensors').
    channels : tuple of str
        The channels' names, one per entry of ``per_axis``.
    """

    per_axis: tuple[DiskMargins, ...]
    multiloop: DiskMargins | None
    note: str = ""
    break_point: str = "input"
    channels: tuple[str, ...] = ("x", "y", "z")

    @property
    def smallest(self) -> float:
        """The smallest disk margin of all (NaN when a closed loop is unstable)."""
        values = [m.disk_margin for m in self.per_axis]
        if self.multiloop is not None:
            values.append(self.multiloop.disk_margin)
        return float("nan") if any(math.isnan(v) for v in values) else min(values)

    def summary(self) -> str:
        """One line per channel and one for the multiloop margin."""
        lines = [f"{name}: {m.summary()}" for name, m in zip(self.channels, self.per_axis)]
        lines.append(
            f"multiloop: {self.multiloop.summary()}" if self.multiloop is not None else f"multiloop: {self.note}"
        )
        return "\n".join(lines)


#: Where a loop may be broken, and the loop each gives.
BREAK_POINTS = {"input": input_loop, "output": output_loop}


def _channel_names(loop: Any, plant: Any, break_point: str) -> tuple[str, ...]:
    if isinstance(plant, RigidBody):
        return ("x", "y", "z") if break_point == "input" else ("q_x", "q_y", "q_z", "omega_x", "omega_y", "omega_z")
    return tuple(str(n) for n in (loop.input_labels if break_point == "input" else loop.output_labels))


def loop_disk_margins(
    plant: Any,
    controller: Any,
    *,
    sampled: bool | None = None,
    computation_delay: float = 0.0,
    skew: float = 0.0,
    break_point: str = "input",
) -> LoopDiskMargins:
    """Disk margins of a controller at the plant input or output: loop-at-a-time per channel and multiloop.

    The loops are those of :func:`controllers.analysis.input_loop` or :func:`controllers.analysis.output_loop`
    (the sampled loop that flies for a controller with a period, zero-order hold and computation delay
    included), each channel broken alone by :func:`controllers.analysis.broken_channels` (at the input these
    are the loops of :func:`controllers.analysis.loop_gain`).

    Parameters
    ----------
    plant : RigidBody or control LTI
        As :func:`controllers.analysis.loop_gain`.
    controller : object
        As :func:`controllers.analysis.loop_gain`.
    sampled : bool, optional
        As :func:`controllers.analysis.loop_gain`.
    computation_delay : float
        Delay from sampling to the torque [s], sampled loops only.
    skew : float
        The disks' skew (:func:`disk_margins`).
    break_point : {"input", "output"}
        Where the loop is broken: the plant input (the actuators' gain and phase uncertainty) or the plant
        output (the sensors').

    Returns
    -------
    LoopDiskMargins
    """
    if break_point not in BREAK_POINTS:
        raise ValueError(f"break_point must be one of {sorted(BREAK_POINTS)}, got {break_point!r}")
    loop = BREAK_POINTS[break_point](plant, controller, sampled=sampled, computation_delay=computation_delay)
    per_axis = tuple(disk_margins(channel, skew=skew) for channel in broken_channels(loop))
    names = _channel_names(loop, plant, break_point)
    if loop.ninputs == 1:
        return LoopDiskMargins(per_axis, per_axis[0], "", break_point, names)
    try:
        return LoopDiskMargins(per_axis, disk_margins(loop, skew=skew), "", break_point, names)
    except ImportError as exc:
        return LoopDiskMargins(per_axis, None, str(exc), break_point, names)


def _refine(margins: dict[float, tuple[float, float, float]], evaluate: Any, start: float, rtol: float) -> float:
    """Refine about ``start`` (a dense grid between its neighbours, again about the new local minimum) until the
    local minimum changes by less than ``rtol``; returns the frequency where it converged (NaN if it did not)."""
    here = start
    for _ in range(MAX_REFINEMENTS):
        points = np.array(sorted(margins))
        i = int(np.searchsorted(points, here))
        low, high = points[max(i - 1, 0)], points[min(i + 1, points.size - 1)]
        before = margins[here][0]
        evaluate(np.linspace(low, high, REFINE_POINTS))
        inside = [w for w in margins if low <= w <= high]
        here = min(inside, key=lambda w: margins[w][0])
        if abs(before - margins[here][0]) <= rtol * max(abs(margins[here][0]), 1e-300):
            return here
    return math.nan


def _closed_loop_stable(loop: Any) -> bool:
    """Whether ``(I + L)^-1`` is stable: poles in the left half-plane, or inside the unit circle when sampled."""
    closed = control.feedback(control.ss(loop), np.eye(loop.ninputs))
    poles = np.asarray(closed.poles())
    if poles.size == 0:
        return True
    if loop.isdtime(strict=True):
        return bool(np.all(np.abs(poles) < 1.0))
    return bool(np.all(poles.real < 0.0))


def _s_plane_roots(loop: Any) -> NDArray[np.complex128]:
    """The open loop's poles (and a SISO loop's zeros) and the closed loop's poles, in the s-plane [1/s]."""
    ss = control.ss(loop)
    closed = control.feedback(ss, np.eye(ss.ninputs))
    roots = np.concatenate(
        [
            np.atleast_1d(ss.poles()),
            np.atleast_1d(closed.poles()),
            np.atleast_1d(control.ss2tf(ss).zeros()) if ss.ninputs == 1 else [],
        ]
    ).astype(complex)
    if loop.isdtime(strict=True):
        roots = np.log(roots[np.abs(roots) > 0]) / float(loop.dt)
    return roots[np.isfinite(roots)]


def _resonance_seeds(roots: NDArray[np.complex128], low: float, high: float) -> NDArray[np.float64]:
    """Frequencies across every lightly damped root's resonance: ``wn (1 + k zeta)``, ``|k| <= 8`` (module docstring).

    A resonance of damping ``zeta`` is ``2 zeta wn`` wide at half power: a logarithmic grid of GRID_POINTS over
    eight or more decades steps 5 % in frequency and can step over it entirely (a mode at 0.5 % damping
    between two grid points left a disk margin 22 % optimistic), so its neighbourhood is sampled at a
    quarter of its width.
    """
    wn = np.abs(roots)
    keep = (wn > 0) & (wn >= low) & (wn <= high)
    zeta = -roots.real[keep] / wn[keep]
    wn = wn[keep]
    light = (zeta < LIGHT_DAMPING) & (roots.imag[keep] >= 0)
    width = np.maximum(zeta[light], 1e-6)
    steps = np.linspace(-8.0, 8.0, 65)
    seeds = (wn[light][:, None] * (1.0 + width[:, None] * steps[None, :])).ravel()
    return seeds[(seeds > low) & (seeds < high)]


def _first_grid(loop: Any, nyquist: float) -> NDArray[np.float64]:
    """From two decades below the loop's slowest pole or zero to four above its fastest (``1e-3 .. 1e3`` rad/s
    without any), and the neighbourhoods of the lightly damped open- and closed-loop roots
    (:func:`_resonance_seeds`). Two decades, not more, below: far below the loop's dynamics a MIMO loop's gain is
    huge and slycot's ab13md slows a hundredfold (273 ms per frequency at 1e-4 rad/s against 1.3 ms at
    crossover, measured on the default spacecraft's output loop), and a smallest margin at the grid's low end
    extends the grid anyway (EDGE_EXTENSIONS)."""
    roots = _s_plane_roots(loop)
    magnitudes = np.abs(roots)
    magnitudes = magnitudes[np.isfinite(magnitudes) & (magnitudes > 0)]
    # Roots at infinity computed as 1e15 rad/s (a transfer function's missing zeros) and integrators computed as
    # 1e-15 to 1e-7 rad/s are not frequencies to span (INFINITE_ROOT_RAD_S, ZERO_ROOT).
    magnitudes = magnitudes[magnitudes < INFINITE_ROOT_RAD_S]
    magnitudes = magnitudes[magnitudes > ZERO_ROOT * magnitudes.max()] if magnitudes.size else magnitudes
    low, high = (magnitudes.min() * 1e-2, magnitudes.max() * 1e4) if magnitudes.size else (1e-3, 1e3)
    high = min(high, nyquist * (1.0 - 1e-9))
    grid = np.logspace(math.log10(low), math.log10(high), GRID_POINTS)
    return np.union1d(grid, _resonance_seeds(roots, low, high))


def _checked_grid(omega: ArrayLike, nyquist: float) -> NDArray[np.float64]:
    grid = np.asarray(omega, dtype=float)
    if grid.ndim != 1 or grid.size < 2 or not np.all(np.isfinite(grid)) or np.any(grid <= 0):
        raise ValueError(f"omega must be a 1-D array of at least 2 positive finite frequencies [rad/s], got {omega!r}")
    if np.any(np.diff(grid) <= 0):
        raise ValueError("omega must be increasing")
    if grid[-1] >= nyquist:
        raise ValueError(f"omega must stay below the Nyquist frequency {nyquist:.6g} rad/s, got up to {grid[-1]:.6g}")
    return grid


def disk_margin_curve(
    loop: Any, *, skew: float = 0.0, omega: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The disk margin at each frequency of a grid: where the loop is weakest, and by how much elsewhere.

    Parameters
    ----------
    loop : control.StateSpace or control.TransferFunction
        As :func:`disk_margins` (a closed-loop-unstable loop is refused: its curve would mean nothing).
    skew : float
        The disk's skew.
    omega : array_like, optional
        Frequencies [rad/s]; default the first grid of :func:`disk_margins`.

    Returns
    -------
    omega_rad_s, alpha : ndarray
        The grid and the disk margin at each frequency (its minimum is the loop's margin, :func:`disk_margins`
        refines it).

    Raises
    ------
    ValueError
        For an unstable closed loop or a bad grid.
    """
    if not isinstance(loop, (control.StateSpace, control.TransferFunction)):
        raise ValueError(f"loop must be a control StateSpace or TransferFunction, got {type(loop).__name__}")
    nyquist = math.pi / float(loop.dt) if loop.isdtime(strict=True) else math.inf
    if not _closed_loop_stable(loop):
        raise ValueError("loop: the closed loop is unstable, so it has no disk margin at any frequency")
    if omega is None:
        grid = _first_grid(loop, nyquist)
    else:  # the given grid, with the lightly damped resonances inside its span sampled (a coarse grid misses them)
        grid = _checked_grid(omega, nyquist)
        grid = np.union1d(grid, _resonance_seeds(_s_plane_roots(loop), float(grid[0]), float(grid[-1])))
    alpha = np.ravel(control.disk_margins(loop, grid, skew=skew, returnall=True)[0]).astype(float)
    return grid, alpha


def plot_disk_margins(
    loops: dict[str, Any], *, floor: float | None = None, title: str = "Disk margin over frequency"
) -> Figure:
    """The disk margin against frequency of each loop, its minimum marked, on one axis.

    Parameters
    ----------
    loops : dict of str to control LTI
        Label -> loop (SISO, or MIMO for the multiloop margin), e.g. :func:`controllers.analysis.input_loop`.
    floor : float, optional
        A required disk margin, drawn as a line.
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        Disk margin ``alpha`` (left axis) and the matching balanced gain margin [dB] (right axis) against
        frequency; each loop's refined minimum (:func:`disk_margins`) as a dot; a closed-loop-unstable loop is
        named UNSTABLE in the legend, with no curve.
    """
    from matplotlib.figure import Figure

    if not loops:
        raise ValueError("loops must hold at least one loop")
    fig = Figure(figsize=(8.0, 4.6), layout="constrained")
    ax = fig.subplots()
    top = 0.0
    for (label, loop), color in zip(loops.items(), ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")):
        if not _closed_loop_stable(loop):
            ax.plot([], [], color=color, lw=1.5, label=f"{label}: closed loop UNSTABLE, no disk margin")
            continue
        w, alpha = disk_margin_curve(loop)
        shown = np.minimum(alpha, 2.0)  # alpha >= 2 is an unbounded gain margin: drawn at 2
        best = disk_margins(loop)
        ax.semilogx(
            w, shown, color=color, lw=1.5, label=f"{label}: {best.disk_margin:.4g} at {best.frequency_rad_s:.3g} rad/s"
        )
        ax.plot([best.frequency_rad_s], [best.disk_margin], "o", color=color, ms=6)
        top = max(top, float(np.max(shown)))
        if best.sampled:
            ax.axvline(math.pi / float(loop.dt), color="0.5", ls=":", lw=0.9)
    if floor is not None:
        ax.axhline(floor, color="tab:red", ls="--", lw=1.0, label=f"required {floor:.3g}")
    ax.set_ylim(0.0, max(top, floor or 0.0) * 1.08 + 1e-9)
    ax.set_xlabel("frequency [rad/s] (dotted: Nyquist)")
    ax.set_ylabel("disk margin alpha [-]")
    ax.grid(True, which="both", alpha=0.3)
    # The balanced gain margin of a disk margin alpha is 20 log10((2 + alpha) / (2 - alpha)) dB (unbounded at
    # alpha = 2): its ticks are placed at their alpha on a twin axis sharing the left one's limits, so they sit
    # exactly where the left scale puts that alpha.
    right = ax.twinx()
    right.set_ylim(ax.get_ylim())
    gains_db = np.array([0.0, 2.0, 4.0, 6.0, 10.0, 20.0])
    right.set_yticks(2.0 * (10 ** (gains_db / 20) - 1) / (10 ** (gains_db / 20) + 1))
    right.set_yticklabels([f"{g:g}" for g in gains_db])
    right.set_ylabel("balanced gain margin [+-dB]")
    ax.set_title(title)
    ax.legend(loc="lower right", fontsize=8)
    return fig

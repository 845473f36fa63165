"""Running the MEKF over recorded samples (:func:`run_mekf`) and its histories (:class:`MEKFResult`).

One run steps an :class:`estimation.mekf.filter.MEKF` (filterpy) sample by
sample; a batch (or ``vectorized=True``) runs the histories through
:class:`estimation.mekf.batch.MEKFBatch`, the one definition of the batch
equations.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.results import ResultIO
from attitude.sensors import ARCSEC
from attitude.simulation.protocols import VectorMeasurement
from attitude.validation import as_float_array
from estimation.consistency import NisHealth, nees, nis_health, plot_errors_with_bounds
from estimation.mekf.batch import MEKFBatch, VectorSamples, check_vector_samples, initial_states, non_unit_rows
from estimation.mekf.filter import MEKF, attitude_residual

__all__ = ["MEKFResult", "run_mekf"]

#: Accepted deviation of a tracker quaternion's norm from 1 (that of attitude.quaternion).
_UNIT_TOL = quat.UNIT_NORM_TOLERANCE
_DEG_PER_H = np.pi / 180.0 / 3600.0  # [rad/s] in one deg/h


@dataclass
class MEKFResult(ResultIO):
    """Histories of one MEKF run, or of many runs at once (leading runs axis).

    Shapes below are for one run; a batch adds a leading ``n_runs`` axis to
    every field except ``t``.

    Attributes
    ----------
    t : ndarray (n,)
        Step times [s].
    q : ndarray (n, 4)
        Attitude estimates ``q_BN`` after each step.
    bias : ndarray (n, 3)
        Gyro bias estimates [rad/s].
    omega : ndarray (n, 3)
        Rate estimates ``omega_meas - b_hat`` [rad/s] (last valid gyro sample held).
    P : ndarray (n, 6, 6)
        Error covariances of ``[delta_theta, delta_b]`` after each step.
    innovation : ndarray (n, 3)
        Tracker residuals ``rotvec(q_hat_prior* ⊗ q_meas)`` [rad] (NaN
        without a tracker sample; present for a gated one).
    innovation_covariance : ndarray (n, 3, 3)
        Their covariances ``S = H P_prior H^T + R`` [rad^2] (NaN without a sample).
    nis : ndarray (n,)
        Normalised innovation squared of each tracker sample, applied or
        gated (NaN without one).
    updated : ndarray (n,) of bool
        A tracker update happened at the step (see :attr:`gated` for the
        samples the innovation gate rejected).
    tracker_nan, gyro_nan : ndarray (n,) of bool
        A NaN tracker (gyro) sample was skipped at the step.
    info : dict
        Counts (per run for a batch), settings and wall time [s].
    vector_nis : dict of str to ndarray (n,)
        Per direction sensor: the NIS (2 degrees of freedom) of each sample,
        applied or gated (NaN without one); empty without vector sensors.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    bias: NDArray[np.float64]
    omega: NDArray[np.float64]
    P: NDArray[np.float64]
    innovation: NDArray[np.float64]
    innovation_covariance: NDArray[np.float64]
    nis: NDArray[np.float64]
    updated: NDArray[np.bool_]
    tracker_nan: NDArray[np.bool_]
    gyro_nan: NDArray[np.bool_]
    info: dict[str, Any] = field(default_factory=dict)
    vector_nis: dict[str, NDArray[np.float64]] = field(default_factory=dict)

    @property
    def n_runs(self) -> int | None:
        """Number of runs of a batch result (None for a single run)."""
        return None if self.q.ndim == 2 else int(self.q.shape[0])

    @property
    def gated(self) -> NDArray[np.bool_]:
        """Steps (..., n) whose tracker sample the innovation gate rejected (a NIS but no update)."""
        return ~np.isnan(self.nis) & ~self.updated

    @property
    def sigma(self) -> NDArray[np.float64]:
        """Standard deviations ``sqrt(diag P)`` (..., n, 6) [rad, rad/s]."""
        return np.sqrt(np.diagonal(self.P, axis1=-2, axis2=-1))

    def errors(self, q_true: ArrayLike, bias_true: ArrayLike) -> NDArray[np.float64]:
        """Estimation errors (..., n, 6): ``[rotvec(q_hat* ⊗ q_true), b_true - b_hat]`` [rad, rad/s].

        The attitude part is the MEKF error ``delta_theta`` (``q_true = q_hat ⊗
        exp(delta_theta / 2)``), in body axes.

        Parameters
        ----------
        q_true : array_like (..., n, 4)
            True attitudes (broadcast against the runs axis).
        bias_true : array_like (..., n, 3)
            True gyro biases at the step times [rad/s].
        """
        qt = quat.as_unit_quaternion(q_true, "q_true")
        bt = as_float_array(bias_true, "bias_true")
        n = self.t.size
        if qt.shape[-2:] != (n, 4) or bt.shape[-2:] != (n, 3):
            raise ValueError(
                f"q_true must have shape (..., {n}, 4) and bias_true (..., {n}, 3), got {qt.shape} and {bt.shape}"
            )
        dtheta = attitude_residual(self.q, qt)
        return np.concatenate([dtheta, np.broadcast_to(bt, self.bias.shape) - self.bias], axis=-1)

    def nees(self, q_true: ArrayLike, bias_true: ArrayLike) -> NDArray[np.float64]:
        """NEES (..., n) of the 6-component error (chi-square, 6 dof, for a consistent filter).

        Parameters
        ----------
        q_true : array_like (..., n, 4)
            True attitudes ``q_BN`` (broadcast against the runs axis).
        bias_true : array_like (..., n, 3)
            True gyro biases at the step times [rad/s].
        """
        return nees(self.errors(q_true, bias_true), self.P)

    def nis_health(self, window: int = 50, confidence: float = 0.999, run: int = 0) -> NisHealth:
        """Moving-window NIS check (:func:`estimation.consistency.nis_health`) of one run.

        Parameters
        ----------
        window : int, optional
            Number of samples per window.
        confidence : float, optional
            Two-sided confidence of each window's chi-square band, in (0, 1).
        run : int, optional
            The run of a batch to check.
        """
        values = self.nis if self.nis.ndim == 1 else self.nis[run]
        return nis_health(values, 3, window, confidence, t=self.t)

    def plot(self, q_true: ArrayLike | None = None, bias_true: ArrayLike | None = None, run: int = 0) -> Figure:
        """Errors with +-3 sigma bounds (with the truth), else tracker residuals with +-3 sqrt(S).

        Attitude in arcsec, bias in deg/h. With the truth, every run of a
        batch is drawn; without it, the residuals of run ``run``.

        Parameters
        ----------
        q_true : array_like (..., n, 4), optional
            True attitudes ``q_BN``.
        bias_true : array_like (..., n, 3), optional
            True gyro biases [rad/s].
        run : int, optional
            The run of a batch whose residuals are drawn (without the truth).
        """
        if (q_true is None) != (bias_true is None):
            raise ValueError("q_true and bias_true must be given together (or neither)")
        labels = ["δθ1", "δθ2", "δθ3"]
        if q_true is not None:
            err = self.errors(q_true, bias_true)
            return plot_errors_with_bounds(
                self.t,
                err,
                self.sigma,
                labels=[*labels, "δb1", "δb2", "δb3"],
                units=["arcsec"] * 3 + ["deg/h"] * 3,
                scale=[1.0 / ARCSEC] * 3 + [1.0 / _DEG_PER_H] * 3,
                title=r"MEKF errors with $\pm 3\sigma$ bounds",
            )
        pick = (lambda a: a) if self.q.ndim == 2 else (lambda a: a[run])
        mask = pick(self.updated)
        if not np.any(mask):
            raise ValueError("no tracker update to plot (and no truth given)")
        s = np.sqrt(np.diagonal(pick(self.innovation_covariance)[mask], axis1=-2, axis2=-1))
        return plot_errors_with_bounds(
            self.t[mask],
            pick(self.innovation)[mask],
            s,
            labels=["residual 1", "residual 2", "residual 3"],
            units="arcsec",
            scale=1.0 / ARCSEC,
            title=r"MEKF tracker residuals with $\pm 3\sqrt{S}$ bounds",
        )


def run_mekf(
    mekf: MEKF,
    t: ArrayLike,
    gyro_meas: ArrayLike,
    tracker_meas: ArrayLike | None,
    *,
    tracker_mask: ArrayLike | None = None,
    q0: ArrayLike | None = None,
    bias0: ArrayLike | None = None,
    vectors: Mapping[str, VectorSamples] | None = None,
    vectorized: bool | None = None,
) -> MEKFResult:
    """Run the MEKF over recorded samples: one run, or many runs at once.

    The filter passed in is not modified: a copy runs from its current state
    (if it has no time yet, it starts at ``t[0]`` with no propagation).

    Parameters
    ----------
    mekf : MEKF
        Filter settings and initial state.
    t : array_like (n,)
        Step times [s], non-decreasing (shared by all runs).
    gyro_meas : array_like (n, 3) or (n_runs, n, 3)
        Gyro samples [rad/s]; ``gyro_meas[..., k, :]`` is the mean rate over
        ``(t[k-1], t[k]]`` (row 0 only sets the first rate estimate). Rows
        with NaN, or with a component above the filter's ``gyro_rate_max``,
        are skipped, counted, and the last valid sample is held.
    tracker_meas : array_like (n, 4) or (n_runs, n, 4), or None
        Tracker quaternions ``q_BN``; all-NaN rows mean "no sample" (None: no
        tracker at all). Samples
        above the innovation gate are rejected and counted (``info["gated"]``,
        :attr:`MEKFResult.gated`).
    tracker_mask : array_like (n,) or (n_runs, n) of bool, optional
        True where the tracker sampled; a NaN anywhere in such a row is a
        skipped (counted) NaN sample. Default: the rows that are not all NaN.
    q0 : array_like (4,) or (n_runs, 4), optional
        Initial attitude estimate(s) replacing the filter's.
    bias0 : float or array_like (3,) or (n_runs, 3), optional
        Initial bias estimate(s) [rad/s] replacing the filter's.
    vectors : mapping of str to VectorSamples, optional
        Direction sensors' histories, applied in order after the tracker
        (:class:`estimation.mekf.batch.VectorSamples`: ``vector_B`` (n, 3) or
        (n_runs, n, 3), all-NaN rows meaning no sample; ``reference_N``
        (3,), (n, 3) or (n_runs, n, 3); ``sigma`` a scalar, (n,) per step or
        (n_runs, n); or ``covariance`` (3, 3), (n, 3, 3) or (n_runs, n, 3,
        3)). Applied as given, in their order (a warning when their names
        differ from the filter's ``vector_names``). Any subset of tracker and
        vectors may be present at a step.
    vectorized : bool, optional
        True: the numpy path over a runs axis; False: :class:`MEKF` steps
        (filterpy) run by run. Default: vectorised for a batch, steps for one run.

    Returns
    -------
    MEKFResult

    Raises
    ------
    ValueError
        For a time grid that goes backwards or is not finite, inconsistent
        shapes, a finite non-unit tracker quaternion, or invalid ``q0``/``bias0``.
    """
    if not isinstance(mekf, MEKF):
        raise ValueError(f"mekf must be an MEKF, got {type(mekf).__name__}")
    tt = as_float_array(t, "t")
    if tt.ndim != 1 or tt.size < 1:
        raise ValueError(f"t must be a 1-D array of step times, got shape {tt.shape}")
    steps = np.diff(tt)
    if np.any(steps < 0):
        i = int(np.argmax(steps < 0))
        raise ValueError(f"t must not go backwards; t[{i + 1}]={tt[i + 1]!r} < t[{i}]={tt[i]!r}")
    if mekf.t is not None and tt[0] < mekf.t:
        raise ValueError(f"t[0] = {tt[0]!r} s is before the filter's time {mekf.t!r} s")
    n = tt.size
    g = as_float_array(gyro_meas, "gyro_meas", allow_nonfinite=True)
    if tracker_meas is None:  # no tracker flies
        if tracker_mask is not None:
            raise ValueError("tracker_mask was given without tracker samples (tracker_meas is None)")
        tracker_meas = np.full((*g.shape[:-1], 4), np.nan)
    y = as_float_array(tracker_meas, "tracker_meas", allow_nonfinite=True)
    batch = g.ndim == 3
    if g.shape[-2:] != (n, 3) or g.ndim not in (2, 3):
        raise ValueError(f"gyro_meas must have shape ({n}, 3) or (n_runs, {n}, 3), got {g.shape}")
    if y.shape[-2:] != (n, 4) or y.ndim != g.ndim or (batch and y.shape[0] != g.shape[0]):
        raise ValueError(f"tracker_meas must have shape {(*g.shape[:-1], 4)} to match gyro_meas, got {y.shape}")
    if np.any(np.isinf(g)) or np.any(np.isinf(y)):
        raise ValueError("gyro_meas and tracker_meas must not hold inf (NaN marks a skipped sample)")
    if tracker_mask is None:
        mask = ~np.all(np.isnan(y), axis=-1)
    else:
        mask = np.asarray(tracker_mask)
        if mask.dtype != np.bool_ or mask.shape not in ((n,), y.shape[:-1]):
            raise ValueError(
                f"tracker_mask must be a boolean array of shape ({n},) or {y.shape[:-1]}, "
                f"got dtype {mask.dtype} and shape {mask.shape}"
            )
        mask = np.broadcast_to(mask, y.shape[:-1])
    bad, norms = non_unit_rows(y, mask)
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ValueError(
            f"tracker_meas must hold unit quaternions (| |q| - 1 | <= {_UNIT_TOL:g}); found |q| = "
            f"{norms[idx]!r} at index {idx}"
        )

    runs = g.shape[0] if batch else 1
    if vectors is not None and not isinstance(vectors, Mapping):
        raise ValueError(f"vectors must be a mapping name -> VectorSamples, got {type(vectors).__name__}")
    v3 = {name: _vector_histories(v, name, runs, n, batch) for name, v in (vectors or {}).items()}
    if mekf.vector_names and set(v3) != set(mekf.vector_names):
        warnings.warn(
            f"vectors has the sensors {sorted(v3)} but the filter's vector_names are {list(mekf.vector_names)}: "
            "run_mekf applies the vectors it is given, in their order; check the names",
            UserWarning,
            stacklevel=2,
        )
    qs, bs = initial_states(mekf, runs, q0, bias0)
    g3 = g if batch else g[None]
    y3 = y if batch else y[None]
    m3 = mask if batch else mask[None]
    vec = batch if vectorized is None else bool(vectorized)
    start = time.perf_counter()
    if vec:
        out = _run_vectorized(mekf, tt, g3, y3, m3, qs, bs, v3)
    else:
        out = _run_steps(mekf, tt, g3, y3, m3, qs, bs, v3)
    wall = time.perf_counter() - start
    vector_nis = out.pop("vector_nis")
    vector_counts = out.pop("vector_counts")
    if not batch:
        out = {k: v[0] for k, v in out.items()}
        vector_nis = {k: v[0] for k, v in vector_nis.items()}
    gyro_rejected = out.pop("gyro_rejected")
    counts = {
        "updates": np.sum(out["updated"], axis=-1),
        "tracker_nan": np.sum(out["tracker_nan"], axis=-1),
        "gyro_nan": np.sum(out["gyro_nan"], axis=-1),
        "gated": np.sum(~np.isnan(out["nis"]) & ~out["updated"], axis=-1),
        "gyro_rejected": np.sum(gyro_rejected, axis=-1),
    }
    for key, per_run in vector_counts.items():
        counts[key] = per_run if batch else per_run[0]
    info: dict[str, Any] = {k: v.tolist() for k, v in counts.items()}
    info.update(
        {
            "n_steps": n,
            "n_runs": runs if batch else None,
            "path": "vectorized" if vec else "filterpy steps",
            "covariance_reset": mekf.covariance_reset,
            "sigma_v": mekf.sigma_v,
            "sigma_u": mekf.sigma_u,
            "gate_probability": mekf.gate_probability,
            "gate_threshold": None if mekf.gate_probability is None else mekf.gate_threshold,
            "gyro_rate_max": mekf.gyro_rate_max,
            "vector_names": list(v3),
            "wall_time_s": wall,
            "filter_steps_per_s": runs * n / wall if wall > 0 else float("inf"),
        }
    )
    return MEKFResult(t=tt.copy(), info=info, vector_nis=vector_nis, **out)


def _vector_histories(samples: Any, name: str, runs: int, n: int, batch: bool) -> VectorSamples:
    """A sensor's histories checked and broadcast to (runs, n, ...): a shared (n, ...) history is every run's."""
    if not isinstance(samples, VectorSamples):
        raise ValueError(f"vectors[{name!r}] must be a VectorSamples, got {type(samples).__name__}")

    def lift(value: Any, tail: int) -> Any:
        # A single run's (n, ...) history gains the runs axis; a batch's shared (n, ...) one broadcasts.
        if value is None:
            return None
        arr = np.asarray(value, dtype=np.float64)
        return arr[None] if arr.ndim == tail + 1 else arr

    lifted = VectorSamples(
        lift(samples.vector_B, 1),
        lift(samples.reference_N, 1),
        lift(samples.sigma, 0),
        lift(samples.covariance, 2),
    )
    if not batch and np.ndim(samples.vector_B) != 2:
        raise ValueError(
            f"vectors[{name!r}].vector_B must have shape ({n}, 3) for one run, got {np.shape(samples.vector_B)}"
        )
    return check_vector_samples(lifted, name, (runs, n))


def _empty_histories(runs: int, n: int) -> dict[str, NDArray]:
    return {
        "q": np.empty((runs, n, 4)),
        "bias": np.empty((runs, n, 3)),
        "omega": np.empty((runs, n, 3)),
        "P": np.empty((runs, n, 6, 6)),
        "innovation": np.full((runs, n, 3), np.nan),
        "innovation_covariance": np.full((runs, n, 3, 3), np.nan),
        "nis": np.full((runs, n), np.nan),
        "updated": np.zeros((runs, n), dtype=bool),
        "tracker_nan": np.zeros((runs, n), dtype=bool),
        "gyro_nan": np.zeros((runs, n), dtype=bool),
        "gyro_rejected": np.zeros((runs, n), dtype=bool),
    }


def _vector_outputs(out: dict[str, Any], vectors: dict[str, VectorSamples], runs: int, n: int) -> None:
    out["vector_nis"] = {name: np.full((runs, n), np.nan) for name in vectors}
    out["vector_counts"] = {
        key: np.zeros(runs, dtype=np.int64) for key in ("vector_updates", "vector_nan", "vector_gated")
    }


def _measurement(v: VectorSamples, r: int, k: int) -> VectorMeasurement | None:
    """Sample ``k`` of run ``r`` as the single filter's input (None: no sample)."""
    vb = v.vector_B[r, k]
    if np.all(np.isnan(vb)):
        return None
    if v.sigma is not None:
        return VectorMeasurement(vb, v.reference_N[r, k], sigma=float(v.sigma[r, k]))
    return VectorMeasurement(vb, v.reference_N[r, k], covariance=v.covariance[r, k])


def _run_steps(mekf, t, g, y, mask, qs, bs, vectors) -> dict[str, NDArray]:
    """One :class:`MEKF` (filterpy) per run, stepped in Python."""
    runs, n = g.shape[:2]
    out = _empty_histories(runs, n)
    _vector_outputs(out, vectors, runs, n)
    for r in range(runs):
        f = mekf.with_state(qs[r], bs[r])
        for k in range(n):
            gk = g[r, k]
            out["gyro_nan"][r, k] = not np.all(np.isfinite(gk))
            tracker = y[r, k] if mask[r, k] else None
            if tracker is not None and not np.all(np.isfinite(tracker)):
                out["tracker_nan"][r, k] = True
            before = f.counts
            samples = {name: _measurement(v, r, k) for name, v in vectors.items()} or None
            est = f.step(float(t[k]), gk, tracker, samples)
            after = f.counts
            for name, value in f.last_vector_nis.items():
                out["vector_nis"][name][r, k] = value
            out["q"][r, k] = est.q
            out["bias"][r, k] = f.bias
            out["omega"][r, k] = est.omega
            out["P"][r, k] = f.P
            out["gyro_rejected"][r, k] = after["gyro_rejected"] > before["gyro_rejected"]
            applied = after["updates"] > before["updates"]
            if applied or after["tracker_gated"] > before["tracker_gated"]:
                out["updated"][r, k] = applied
                out["innovation"][r, k] = f.last_innovation
                out["innovation_covariance"][r, k] = f.last_innovation_covariance
                out["nis"][r, k] = f.last_nis
        for key in out["vector_counts"]:
            out["vector_counts"][key][r] = f.counts[key]
    return out


def _run_vectorized(mekf, t, g, y, mask, qs, bs, vectors) -> dict[str, NDArray]:
    """:meth:`MEKFBatch.step` over the recorded histories (the one definition of the batch equations)."""
    runs, n = g.shape[:2]
    out = _empty_histories(runs, n)
    _vector_outputs(out, vectors, runs, n)
    batch = MEKFBatch.from_states(mekf, qs, bs)
    for k in range(n):
        step_vectors = {
            name: VectorSamples(
                v.vector_B[:, k],
                v.reference_N[:, k],
                None if v.sigma is None else v.sigma[:, k],
                None if v.covariance is None else v.covariance[:, k],
            )
            for name, v in vectors.items()
        }
        batch.step_unchecked(float(t[k]), g[:, k], y[:, k], mask[:, k], step_vectors)
        for name, nis in batch.vector_nis.items():
            out["vector_nis"][name][:, k] = nis
        out["q"][:, k] = batch.q
        out["bias"][:, k] = batch.bias
        out["omega"][:, k] = batch.omega
        out["P"][:, k] = batch.P
        out["innovation"][:, k] = batch.innovation
        out["innovation_covariance"][:, k] = batch.innovation_covariance
        out["nis"][:, k] = batch.nis
        out["updated"][:, k] = batch.updated
        out["tracker_nan"][:, k] = batch.tracker_nan
        out["gyro_nan"][:, k] = batch.gyro_nan
        out["gyro_rejected"][:, k] = batch.gyro_rejected
    for key in out["vector_counts"]:
        out["vector_counts"][key] = batch.counts[key]
    return out

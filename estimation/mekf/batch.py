"""N MEKFs stepped together along a leading runs axis (:class:`MEKFBatch`).

The Monte Carlo batch path does not use filterpy: filterpy runs one filter
at a time in Python, and a campaign gets fast by doing each step for all
runs in one numpy operation. :class:`MEKFBatch` holds N filters along a
leading runs axis and is stepped from outside, one time at a time (what a
vectorised closed loop does); :func:`estimation.mekf.runner.run_mekf` with
``vectorized=True`` runs recorded histories through the same step. It
repeats the equations of :class:`estimation.mekf.filter.MEKF` over the runs
axis; tests prove the two agree (to rounding) and that ``run_mekf`` and a
hand-stepped :class:`MEKFBatch` agree bit for bit.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.rigid_body import skew
from attitude.sensors import farrenkopf_process_noise
from attitude.simulation.protocols import check_vector_covariances
from attitude.validation import as_float_array, scalar_time
from estimation.consistency import NIS_CAP
from estimation.mekf.filter import (
    MEASUREMENT_MATRIX,
    MEKF,
    attitude_residual,
    compose_rotation_vector,
    error_transition,
)

__all__ = ["MEKFBatch", "VectorSamples", "check_vector_samples", "initial_states", "non_unit_rows"]

_EYE6 = np.eye(6)
#: Accepted deviation of a tracker quaternion's norm from 1 (that of attitude.quaternion).
_UNIT_TOL = quat.UNIT_NORM_TOLERANCE
_BATCH_COUNT_KEYS = (
    "steps",
    "updates",
    "tracker_nan",
    "tracker_gated",
    "gyro_nan",
    "gyro_rejected",
    "vector_updates",
    "vector_nan",
    "vector_gated",
)


class VectorSamples(NamedTuple):
    """One direction sensor's samples for a batch of runs: the batch form of ``VectorMeasurement``.

    At one step (:meth:`MEKFBatch.step`) the arrays have a leading runs axis
    ``N``; as histories (:func:`estimation.mekf.run_mekf`) they also have a
    time axis (``(n, ...)`` shared by all runs or ``(n_runs, n, ...)``). The
    noise model is that of :class:`attitude.simulation.protocols.VectorMeasurement`
    (``sigma``: the QUEST model ``sigma^2 (I - b b^T)``; ``covariance``: of the
    unit vector's error). Give exactly one of ``sigma`` and ``covariance``.

    Parameters
    ----------
    vector_B : array_like (N, 3)
        Measured directions in body axes (any non-zero length). An all-NaN
        row means no sample; a row with some NaN is a failed sample, skipped
        and counted as ``vector_nan``.
    reference_N : array_like (3,) or (N, 3)
        The same direction in N at the sample time (any non-zero length).
    sigma : float or array_like (N,), optional
        Angular noise perpendicular to the vector [rad] (> 0).
    covariance : array_like (3, 3) or (N, 3, 3), optional
        Covariance of the unit vector's error [rad^2].
    """

    vector_B: Any
    reference_N: Any
    sigma: Any = None
    covariance: Any = None


def initial_states(
    mekf: MEKF, runs: int, q0: ArrayLike | None, bias0: ArrayLike | None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Checked initial attitudes (runs, 4) and biases (runs, 3): ``q0``/``bias0``, else the filter's (broadcast views).

    Parameters
    ----------
    mekf : MEKF
        The filter whose state is the default.
    runs : int
        Number of runs N.
    q0 : array_like (4,) or (N, 4), optional
        Initial attitude estimates ``q_BN`` (unit norm); None: the filter's.
    bias0 : float or array_like (3,) or (N, 3), optional
        Initial gyro bias estimates [rad/s]; None: the filter's.

    Returns
    -------
    tuple of ndarray
        ``(q (N, 4), bias (N, 3))``.

    Raises
    ------
    ValueError
        If ``q0`` is not (4,) or (runs, 4) unit quaternions, or ``bias0`` not a
        scalar, (3,) or (runs, 3).
    """
    if q0 is not None and np.shape(q0) not in ((4,), (runs, 4)):
        raise ValueError(f"q0 must have shape (4,) or ({runs}, 4), got {np.shape(q0)}")
    if bias0 is not None and np.shape(bias0) not in ((), (3,), (runs, 3)):
        raise ValueError(f"bias0 must be a scalar or have shape (3,) or ({runs}, 3), got {np.shape(bias0)}")
    qs = np.broadcast_to(mekf.q if q0 is None else quat.as_unit_quaternion(q0, "q0"), (runs, 4))
    bs = np.broadcast_to(mekf.bias if bias0 is None else as_float_array(bias0, "bias0"), (runs, 3))
    return qs, bs


def non_unit_rows(y: NDArray[np.float64], mask: NDArray[np.bool_]) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """Sampled (``mask``) finite tracker rows of ``y`` (..., 4) with a norm off 1 by more than 1e-6; the norms.

    Parameters
    ----------
    y : ndarray (..., 4)
        Tracker quaternion samples (NaN rows: no sample).
    mask : ndarray of bool (...)
        True where the tracker sampled.

    Returns
    -------
    tuple of ndarray
        ``(bad, norms)``: the rows that are not unit quaternions, and every row's norm.
    """
    finite_rows = np.all(np.isfinite(y), axis=-1)
    norms = np.sqrt(np.sum(np.where(finite_rows[..., None], y, 0.0) ** 2, axis=-1))
    return mask & finite_rows & (np.abs(norms - 1.0) > _UNIT_TOL), norms


class MEKFBatch:
    """N MEKFs advancing together, one step at a time: the batched state of a vectorised Monte Carlo loop.

    The filter of :class:`MEKF` (same equations, innovation gate,
    covariance reset option, handling of NaN and implausible gyro samples
    with the last valid rate held, NaN tracker samples skipped, vector samples
    applied in order after the tracker) for ``N`` runs stacked along a leading
    axis, each step one numpy operation for all runs. Stepped from outside (a
    closed loop calls :meth:`step` each estimator tick with the runs' gyro,
    tracker and vector samples);
    :func:`run_mekf` (``vectorized=True``) runs its recorded histories
    through the same :meth:`step` code, so there is one definition of the
    batch equations. No filterpy: it runs one filter at a time.

    The filter passed in is not modified: the batch starts from its state
    and settings (time, covariance, held gyro rate, attitude and bias unless
    ``q0``/``bias0`` replace them), like :func:`run_mekf`.

    Parameters
    ----------
    mekf : MEKF
        Settings (noise figures, tracker covariance, gate, reset option,
        ``gyro_rate_max``) and initial state.
    n_runs : int
        Number of runs N (>= 1).
    q0 : array_like (4,) or (N, 4), optional
        Initial attitude estimates ``q_BN`` (unit norm) replacing the filter's.
    bias0 : float or array_like (3,) or (N, 3), optional
        Initial gyro bias estimates [rad/s] replacing the filter's.

    Attributes
    ----------
    n_runs : int
        N.
    innovation : ndarray (N, 3)
        Tracker residuals [rad] of the last step (NaN where no sample was tested).
    innovation_covariance : ndarray (N, 3, 3)
        Their covariances ``S`` [rad^2] (NaN where no sample was tested).
    nis : ndarray (N,)
        NIS of the last step's tracker samples, applied or gated (NaN without one).
    updated, gated : ndarray (N,) of bool
        The last step applied a tracker sample / the gate rejected one.
    tracker_nan, gyro_nan, gyro_rejected : ndarray (N,) of bool
        The last step skipped a NaN tracker sample / a NaN gyro sample /
        rejected a gyro sample above ``gyro_rate_max``.
    vector_nis : dict of str to ndarray (N,)
        Per direction sensor, the NIS (2 dof) of the last step's samples,
        applied or gated (NaN without one).

    Raises
    ------
    ValueError
        If ``mekf`` is not an :class:`MEKF`, ``n_runs`` is not a positive
        integer, or ``q0``/``bias0`` have a wrong shape or value.
    """

    def __init__(self, mekf: MEKF, n_runs: int, q0: ArrayLike | None = None, bias0: ArrayLike | None = None) -> None:
        if not isinstance(mekf, MEKF):
            raise ValueError(f"mekf must be an MEKF, got {type(mekf).__name__}")
        if not isinstance(n_runs, (int, np.integer)) or isinstance(n_runs, bool) or n_runs < 1:
            raise ValueError(f"n_runs must be a positive integer, got {n_runs!r}")
        self._init(mekf, *initial_states(mekf, int(n_runs), q0, bias0))

    @classmethod
    def from_states(cls, mekf: MEKF, qs: NDArray[np.float64], bs: NDArray[np.float64]) -> MEKFBatch:
        """A batch from validated (N, 4) attitudes and (N, 3) biases, used as given (no renormalisation).

        Parameters
        ----------
        mekf : MEKF
            Settings and covariance (not modified).
        qs : ndarray (N, 4)
            Initial attitude estimates ``q_BN``, checked by :func:`initial_states`.
        bs : ndarray (N, 3)
            Initial gyro bias estimates [rad/s], checked likewise.

        Returns
        -------
        MEKFBatch
            The batch.
        """
        self = cls.__new__(cls)
        self._init(mekf, qs, bs)
        return self

    def _init(self, mekf: MEKF, qs: NDArray[np.float64], bs: NDArray[np.float64]) -> None:
        runs = int(qs.shape[0])
        self.n_runs = runs
        self._q = np.array(qs, dtype=np.float64)
        self._b = np.array(bs, dtype=np.float64)
        self._P = np.broadcast_to(mekf.P, (runs, 6, 6)).copy()
        self._R = mekf.tracker_covariance
        held = mekf.held_gyro
        self._last = np.zeros((runs, 3)) if held is None else np.broadcast_to(held, (runs, 3)).copy()
        self._t: float | None = mekf.t
        self._sv2 = mekf.sigma_v**2
        self._su2 = mekf.sigma_u**2
        self._gate = mekf.gate_threshold
        self._vector_gate = mekf.vector_gate_threshold
        self._second = mekf.covariance_reset == "second_order"
        #: Settings copied from the filter.
        self.covariance_reset = mekf.covariance_reset
        self.gate_threshold = mekf.gate_threshold
        self.gyro_rate_max = mekf.gyro_rate_max
        #: Step period [s] (the filter's; what a closed loop steps it at).
        self.period = mekf.period
        self._counts = {k: np.zeros(runs, dtype=np.int64) for k in _BATCH_COUNT_KEYS}
        self._clear_step_outputs()

    def __repr__(self) -> str:
        return f"MEKFBatch(n_runs={self.n_runs}, t={self._t!r}, covariance_reset={self.covariance_reset!r})"

    # -- state ----------------------------------------------------------------------

    @property
    def q(self) -> NDArray[np.float64]:
        """Attitude estimates ``q_BN`` (N, 4) (a copy)."""
        return self._q.copy()

    @property
    def bias(self) -> NDArray[np.float64]:
        """Gyro bias estimates (N, 3) [rad/s] (a copy)."""
        return self._b.copy()

    @property
    def P(self) -> NDArray[np.float64]:
        """Error covariances (N, 6, 6) of ``[delta_theta, delta_b]`` (a copy)."""
        return self._P.copy()

    @property
    def t(self) -> float | None:
        """Time [s] of the estimates (None before the first step if the filter had no time)."""
        return self._t

    @property
    def omega(self) -> NDArray[np.float64]:
        """Rate estimates ``omega_meas - b_hat`` (N, 3) [rad/s] from the held gyro rate (zeros before one)."""
        return self._last - self._b

    @property
    def counts(self) -> dict[str, NDArray[np.int64]]:
        """Per-run counts (N,) so far: steps, updates, tracker_nan, tracker_gated, gyro_nan, gyro_rejected."""
        return {k: v.copy() for k, v in self._counts.items()}

    # -- the filter -------------------------------------------------------------------

    def step(
        self,
        t: float,
        gyro: ArrayLike | None,
        tracker: ArrayLike | None = None,
        mask: ArrayLike | None = None,
        vectors: Mapping[str, VectorSamples] | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Propagate every run to ``t`` with its gyro sample, then update with its tracker and vector samples.

        Run ``r`` follows :meth:`MEKF.step` of ``(t, gyro[r], tracker[r]
        if mask[r] else None, {name: sample r of each vector sensor})``.

        Parameters
        ----------
        t : float
            Time [s] of the samples (shared); not before the previous step
            (a repeated time propagates nothing and may still update).
        gyro : array_like (N, 3) or None
            Gyro samples [rad/s], the mean rate since the previous step. A
            row with a non-finite entry (NaN) or a component above
            ``gyro_rate_max`` is skipped and counted (``gyro_nan``,
            ``gyro_rejected``) and the run's last valid rate is held (zero
            before one); None: no sample in any run (held rates).
        tracker : array_like (N, 4), optional
            Tracker quaternions ``q_BN``; rows outside ``mask`` are ignored.
            A masked row with a non-finite entry is skipped and counted
            (``tracker_nan``); finite masked rows must have unit norm (to
            1e-6, as :meth:`MEKF.step`). Samples above the innovation gate are
            rejected and counted (``gated``).
        mask : array_like (N,) of bool, optional
            Runs whose tracker sampled (default: the rows of ``tracker``
            that are not all NaN).
        vectors : mapping of str to VectorSamples, optional
            Each direction sensor's samples (:class:`VectorSamples`, rows
            ``(N, ...)``), applied in order after the tracker, each with its
            own 2-degree-of-freedom gate (:attr:`MEKF.vector_gate_threshold`).

        Returns
        -------
        q : ndarray (N, 4)
            Attitude estimates ``q_BN`` after the step.
        omega : ndarray (N, 3)
            Rate estimates ``omega_meas - b_hat`` [rad/s].

        Raises
        ------
        ValueError
            If ``t`` is not a finite scalar or goes backwards, an array has
            the wrong shape (or dtype for ``mask``), ``mask`` comes without
            ``tracker``, a sampled finite tracker row is not unit norm, or a
            vector sensor's samples are malformed (:func:`check_vector_samples`).
            Every check runs before the state changes.
        """
        n = self.n_runs
        tk = scalar_time(t)
        if self._t is not None and tk < self._t:
            raise ValueError(f"t must not go backwards: t = {tk!r} s < previous time {self._t!r} s")
        g = None
        if gyro is not None:
            g = as_float_array(gyro, "gyro", allow_nonfinite=True)
            if g.shape != (n, 3):
                raise ValueError(f"gyro must have shape ({n}, 3) (one rate sample per run), got shape {g.shape}")
        y = None
        m = None
        if tracker is not None:
            y = as_float_array(tracker, "tracker", allow_nonfinite=True)
            if y.shape != (n, 4):
                raise ValueError(f"tracker must have shape ({n}, 4) (one quaternion per run), got shape {y.shape}")
            if mask is None:
                m = ~np.all(np.isnan(y), axis=-1)
            else:
                m = np.asarray(mask)
                if m.dtype != np.bool_ or m.shape != (n,):
                    raise ValueError(
                        f"mask must be a boolean array of shape ({n},), got dtype {m.dtype} and shape {m.shape}"
                    )
            bad, norms = non_unit_rows(y, m)
            if np.any(bad):
                r = int(np.argmax(bad))
                raise ValueError(
                    f"tracker must hold unit quaternions (| |q| - 1 | <= {_UNIT_TOL:g}) in sampled rows; found "
                    f"|q| = {norms[r]!r} in row {r}"
                )
        elif mask is not None:
            raise ValueError("mask was given without tracker samples (pass tracker (N, 4) with it)")
        checked = None
        if vectors is not None:
            if not isinstance(vectors, Mapping):
                raise ValueError(f"vectors must be a mapping name -> VectorSamples, got {type(vectors).__name__}")
            checked = {name: check_vector_samples(v, name, (n,)) for name, v in vectors.items()}
        self.step_unchecked(tk, g, y, m, checked)
        return self._q.copy(), self._last - self._b

    def _clear_step_outputs(self) -> None:
        n = self.n_runs
        self.innovation = np.full((n, 3), np.nan)
        self.innovation_covariance = np.full((n, 3, 3), np.nan)
        self.nis = np.full(n, np.nan)
        self.updated = np.zeros(n, dtype=bool)
        self.gated = np.zeros(n, dtype=bool)
        self.tracker_nan = np.zeros(n, dtype=bool)
        self.gyro_nan = np.zeros(n, dtype=bool)
        self.gyro_rejected = np.zeros(n, dtype=bool)
        self.vector_nis: dict[str, NDArray[np.float64]] = {}

    def step_unchecked(
        self,
        tk: float,
        g: NDArray[np.float64] | None,
        y: NDArray[np.float64] | None,
        mask: NDArray[np.bool_] | None,
        vectors: Mapping[str, VectorSamples] | None = None,
    ) -> None:
        """The batch equations for one step, without the checks of :meth:`step` (:func:`run_mekf` validates).

        Parameters
        ----------
        tk : float
            Step time [s].
        g : ndarray (N, 3) or None
            Gyro samples [rad/s] (NaN rows: missing).
        y : ndarray (N, 4) or None
            Tracker quaternions (rows used where ``mask``).
        mask : ndarray of bool (N,) or None
            True where the tracker sampled.
        vectors : mapping of str to VectorSamples, optional
            Checked samples (:func:`check_vector_samples`: unit rows, ``sigma``
            (N,) or ``covariance`` (N, 3, 3)).
        """
        self._clear_step_outputs()
        q, b, P, R = self._q, self._b, self._P, self._R
        # Gyro: NaN rows and rows above gyro_rate_max are skipped, the last valid rate is held.
        if g is None:
            rate = self._last
        else:
            finite = np.all(np.isfinite(g), axis=-1)
            largest = np.max(np.abs(np.where(finite[:, None], g, 0.0)), axis=-1)
            rejected = finite & (largest > self.gyro_rate_max)
            self.gyro_nan = ~finite
            self.gyro_rejected = rejected
            rate = np.where((finite & ~rejected)[:, None], g, self._last)
        t_prev = self._t
        if t_prev is not None and tk > t_prev:
            dt = tk - t_prev
            w = rate - b
            q = compose_rotation_vector(q, w * dt)
            phi = error_transition(w, dt)
            P = phi @ P @ np.swapaxes(phi, -1, -2) + farrenkopf_process_noise(self._sv2, self._su2, dt)
        self._t = tk
        self._last = rate
        # Tracker: NaN samples are skipped; the others are gated on their NIS, then applied.
        if y is not None:
            y_ok = np.all(np.isfinite(y), axis=-1)
            self.tracker_nan = mask & ~y_ok
            tested = np.nonzero(mask & y_ok)[0]
        else:
            tested = np.zeros(0, dtype=np.intp)
        if tested.size:
            qm = y[tested] / np.sqrt(np.sum(y[tested] ** 2, axis=-1, keepdims=True))
            z_all = attitude_residual(q[tested], qm)
            S_all = P[tested, :3, :3] + R
            SI_all = np.linalg.inv(S_all)
            nis_all = np.einsum("ri,rij,rj->r", z_all, SI_all, z_all)
            self.innovation[tested] = z_all
            self.innovation_covariance[tested] = S_all
            self.nis[tested] = np.where(nis_all <= NIS_CAP, nis_all, NIS_CAP)
            accept = nis_all <= self._gate  # the innovation gate (NaN is rejected too)
            self.gated[tested[~accept]] = True
            sel, z, SI = tested[accept], z_all[accept], SI_all[accept]
        else:
            sel = tested
        if sel.size:
            Ps = P[sel]
            pht = Ps[:, :, :3]
            K = pht @ SI
            x = (K @ z[..., None])[..., 0]
            ikh = _EYE6 - K @ MEASUREMENT_MATRIX
            Pn = ikh @ Ps @ np.swapaxes(ikh, -1, -2) + K @ R @ np.swapaxes(K, -1, -2)
            dtheta = x[:, :3]
            q[sel] = compose_rotation_vector(q[sel], dtheta)
            b[sel] = b[sel] + x[:, 3:]
            if self._second:
                gm = np.broadcast_to(_EYE6, Pn.shape).copy()
                gm[:, :3, :3] -= 0.5 * skew(dtheta)
                Pn = gm @ Pn @ np.swapaxes(gm, -1, -2)
            P[sel] = 0.5 * (Pn + np.swapaxes(Pn, -1, -2))
            self.updated[sel] = True
        self._q, self._b, self._P = q, b, P
        for name, samples in (vectors or {}).items():
            self._correct_vectors(name, samples)
        c = self._counts
        c["steps"] += 1
        c["updates"] += self.updated
        c["tracker_nan"] += self.tracker_nan
        c["tracker_gated"] += self.gated
        c["gyro_nan"] += self.gyro_nan
        c["gyro_rejected"] += self.gyro_rejected

    def _correct_vectors(self, name: str, samples: VectorSamples) -> None:
        """The update of :meth:`MEKF._correct_vector` for every run with a sample of sensor ``name``.

        Residual ``z = T b`` with ``T`` the basis perpendicular to the predicted
        ``b_hat = A(q_hat) r`` (``t1 = b_hat x e / |.|`` with ``e`` the axis least
        aligned with ``b_hat``, ``t2 = b_hat x t1``), ``H = [-t2; t1]``, the gain
        and covariance ``P - (P H^T) S^-1 (P H^T)^T`` of the single-run filter.
        """
        n = self.n_runs
        vb, ref = samples.vector_B, samples.reference_N
        nan = np.isnan(vb)  # checked rows: finite, all NaN (no sample) or a failed sample (inf and NaN)
        finite = ~nan.any(axis=-1)
        every = bool(finite.all())
        if not every:
            self._counts["vector_nan"] += ~finite & ~nan.all(axis=-1)  # partly NaN: a failed sample
        nis_out = np.full(n, np.nan)
        sel = slice(None) if every else np.nonzero(finite)[0]
        if every or sel.size:
            # Written out per component (columns of m runs): a step's cost is numpy's per-call overhead.
            # b_hat = C_BN(q_hat) r_N, by the one rotation of attitude.quaternion (on columns of m runs).
            p0, p1, p2 = quat.rotate_inverse_components(list(self._q[sel].T), list(ref[sel].T))
            # t1 = b_hat x e / |.| with e the axis least aligned with b_hat; t2 = b_hat x t1.
            a0, a1, a2 = np.abs(p0), np.abs(p1), np.abs(p2)
            e0 = (a0 <= a1) & (a0 <= a2)
            e1 = ~e0 & (a1 <= a2)
            e2 = ~e0 & ~e1
            u0, u1, u2 = p1 * e2 - p2 * e1, p2 * e0 - p0 * e2, p0 * e1 - p1 * e0
            norm = np.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            u0, u1, u2 = u0 / norm, u1 / norm, u2 / norm
            v0, v1, v2 = p1 * u2 - p2 * u1, p2 * u0 - p0 * u2, p0 * u1 - p1 * u0
            b0, b1, b2 = vb[sel].T
            z0, z1 = u0 * b0 + u1 * b1 + u2 * b2, v0 * b0 + v1 * b1 + v2 * b2
            if samples.covariance is None:
                r00 = r11 = samples.sigma[sel] ** 2
                r01 = 0.0
            else:
                c = samples.covariance[sel]
                u = np.stack([u0, u1, u2], axis=-1)
                v = np.stack([v0, v1, v2], axis=-1)
                cu, cv = (c @ u[..., None])[..., 0], (c @ v[..., None])[..., 0]
                r00, r01, r11 = np.sum(u * cu, axis=-1), np.sum(u * cv, axis=-1), np.sum(v * cv, axis=-1)
            P = self._P[sel]
            # P H^T with H = [-t2; t1] on the attitude: columns g0 = -P[:, :3] t2, g1 = P[:, :3] t1 (m, 6).
            g0 = -(P[:, :, 0] * v0[:, None] + P[:, :, 1] * v1[:, None] + P[:, :, 2] * v2[:, None])
            g1 = P[:, :, 0] * u0[:, None] + P[:, :, 1] * u1[:, None] + P[:, :, 2] * u2[:, None]
            # S = H P H^T + R, symmetric positive definite (R is); its inverse in closed form.
            s00 = -(v0 * g0[:, 0] + v1 * g0[:, 1] + v2 * g0[:, 2]) + r00
            s01 = -(v0 * g1[:, 0] + v1 * g1[:, 1] + v2 * g1[:, 2]) + r01
            s11 = u0 * g1[:, 0] + u1 * g1[:, 1] + u2 * g1[:, 2] + r11
            det = s00 * s11 - s01 * s01
            i00, i01, i11 = s11 / det, -s01 / det, s00 / det
            c0, c1 = i00 * z0 + i01 * z1, i01 * z0 + i11 * z1  # S^-1 z
            nis = z0 * c0 + z1 * c1
            # More than 90 deg off the prediction: rejected (MEKF._correct_vector).
            reversed_ = p0 * b0 + p1 * b1 + p2 * b2 <= 0.0
            if reversed_.any():
                nis = np.where(reversed_, NIS_CAP, nis)
            nis_out[sel] = np.where(nis <= NIS_CAP, nis, NIS_CAP)
            accept = (nis <= self._vector_gate) & ~reversed_
            all_accepted = bool(accept.all())
            rows = np.arange(n)[sel]
            ok = rows if all_accepted else rows[accept]
            if not all_accepted:
                self._counts["vector_gated"][rows[~accept]] += 1
            if ok.size:
                if not all_accepted:
                    g0, g1, P = g0[accept], g1[accept], P[accept]
                    i00, i01, i11, c0, c1 = i00[accept], i01[accept], i11[accept], c0[accept], c1[accept]
                    sel = ok
                k0 = g0 * i00[:, None] + g1 * i01[:, None]  # K = P H^T S^-1, its two columns
                k1 = g0 * i01[:, None] + g1 * i11[:, None]
                dx = g0 * c0[:, None] + g1 * c1[:, None]  # K z
                # P - K S K^T = P - (P H^T) S^-1 (P H^T)^T, the single filter's form.
                Pn = P - k0[:, :, None] * g0[:, None, :] - k1[:, :, None] * g1[:, None, :]
                dtheta = dx[:, :3]
                self._q[sel] = compose_rotation_vector(self._q[sel], dtheta)
                self._b[sel] = self._b[sel] + dx[:, 3:]
                if self._second:
                    gm = np.broadcast_to(_EYE6, Pn.shape).copy()
                    gm[:, :3, :3] -= 0.5 * skew(dtheta)
                    Pn = gm @ Pn @ np.swapaxes(gm, -1, -2)
                self._P[sel] = 0.5 * (Pn + np.swapaxes(Pn, -1, -2))
                self._counts["vector_updates"][ok] += 1
        self.vector_nis[name] = nis_out


def check_vector_samples(samples: Any, name: str, lead: tuple[int, ...]) -> VectorSamples:
    """Checked :class:`VectorSamples` with unit rows, broadcast to the leading shape ``lead``.

    The rules of :class:`attitude.simulation.protocols.VectorMeasurement`,
    row by row: a ``vector_B`` row that is all NaN is no sample; one with
    another non-finite entry is a failed sample (skipped and counted);
    otherwise it must be non-zero. Where there is a sample, the reference
    must be finite and non-zero, ``sigma`` positive, and the covariance pass
    :func:`attitude.simulation.protocols.check_vector_covariances`; rows
    without a sample may hold anything (NaN) there.

    Parameters
    ----------
    samples : VectorSamples
        One sensor's samples.
    name : str
        The sensor's name (named in errors).
    lead : tuple of int
        Leading shape of the rows: ``(N,)`` at one step, ``(n_runs, n)`` for histories.

    Returns
    -------
    VectorSamples
        ``vector_B`` (lead, 3) normalised (NaN rows where no sample or a
        failed one), ``reference_N`` (lead, 3) normalised, and ``sigma``
        (lead) or ``covariance`` (lead, 3, 3); unit vectors, unit sigma and
        the identity fill the rows without a sample.

    Raises
    ------
    ValueError
        Not a :class:`VectorSamples`, shapes that do not broadcast to
        ``lead``, or a sampled row that breaks a rule (its index and value
        named).
    """
    if not isinstance(samples, VectorSamples):
        raise ValueError(f"vectors[{name!r}] must be a VectorSamples, got {type(samples).__name__}")
    where = f"vectors[{name!r}]"

    def rows(value: Any, field: str, tail: tuple[int, ...]) -> NDArray[np.float64]:
        arr = as_float_array(value, f"{where}.{field}", allow_nonfinite=True)
        try:
            return np.broadcast_to(arr, (*lead, *tail))
        except ValueError:
            raise ValueError(
                f"{where}.{field} must broadcast to shape {(*lead, *tail)}, got shape {arr.shape}"
            ) from None

    def first(mask: NDArray[np.bool_]) -> list[int]:
        return [int(i) for i in np.argwhere(mask)[0]]

    vb = rows(samples.vector_B, "vector_B", (3,))
    sampled = np.all(np.isfinite(vb), axis=-1)
    lengths = np.linalg.norm(np.where(sampled[..., None], vb, 1.0), axis=-1)
    bad = sampled & (lengths == 0.0)
    if np.any(bad):
        raise ValueError(
            f"{where}.vector_B must have non-zero rows (normalised to directions); row {first(bad)} is zero"
        )
    ref = rows(samples.reference_N, "reference_N", (3,))
    ref_len = np.linalg.norm(ref, axis=-1)
    bad = sampled & ~(np.isfinite(ref_len) & (ref_len > 0.0))
    if np.any(bad):
        i = first(bad)
        raise ValueError(
            f"{where}.reference_N must be finite and non-zero where there is a sample; row {i} is "
            f"{ref[tuple(i)].tolist()}"
        )
    if (samples.sigma is None) == (samples.covariance is None):
        raise ValueError(f"{where} must give exactly one of sigma and covariance")
    sigma = cov = None
    if samples.sigma is not None:
        sigma = rows(samples.sigma, "sigma", ())
        bad = sampled & ~(np.isfinite(sigma) & (sigma > 0.0))
        if np.any(bad):
            i = first(bad)
            raise ValueError(
                f"{where}.sigma must be finite and > 0 [rad] where there is a sample; row {i} is "
                f"{float(sigma[tuple(i)])!r}"
            )
        sigma = np.where(sampled, sigma, 1.0)
    else:
        cov = rows(samples.covariance, "covariance", (3, 3))
        cov = np.where(sampled[..., None, None], cov, np.eye(3))
        unit = np.where(sampled[..., None], vb, np.nan)
        cov = check_vector_covariances(cov, unit, f"{where}.covariance")
    # Failed rows keep their NaN pattern (partly NaN: counted; all NaN: no sample); inf becomes NaN.
    failed = ~sampled & ~np.all(np.isnan(vb), axis=-1)
    unit_B = np.where(sampled[..., None], vb / lengths[..., None], np.nan)
    unit_B[failed, 0] = np.inf  # a failed sample: non-finite but not all NaN
    unit_ref = np.where(sampled[..., None], ref / np.where(sampled, ref_len, 1.0)[..., None], np.array([1.0, 0.0, 0.0]))
    return VectorSamples(unit_B, unit_ref, sigma, cov)

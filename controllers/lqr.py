"""Linear-quadratic regulators on the 6-state attitude model.

Design on a linear model from :func:`attitude.linearize.linearize` (states
``x = [q_ev, omega - omega_ref]``, inputs body torque ``tau`` [N m]):

* continuous: minimise ``int (x' Q x + tau' R tau) dt`` with ``control.lqr``;
* discrete at the controller sample time ``T``: the zero-order-hold model
  ``(A_d, B_d) = c2d(sys, T, "zoh")`` (exactly what a sampled controller with
  held torque sees) and ``control.dlqr`` minimising
  ``sum_k (x_k' Q x_k + tau_k' R tau_k)``. Both sums are per sample, which is
  the continuous cost times ``1/T`` as ``T -> 0`` (the same ``Q : R`` ratio),
  so the discrete gain tends to the continuous one for fast sampling.

Weights are given directly or by Bryson's rule (:func:`bryson_weights`).
Before any Riccati solver runs, :func:`design_lqr` checks the inputs and the
system-theoretic conditions the solvers need (``(A, B)`` stabilisable and
``(Q^1/2, A)`` detectable, by the Popov-Belevitch-Hautus test on the
eigenvalues that are not strictly stable), so a bad design fails with a
``ValueError`` naming the culprit instead of a solver's ``LinAlgError`` or a
silently non-stabilising gain.

:class:`LQRController` flies the gain in :func:`attitude.simulation.engine.simulate`:
``tau = -K [q_ev; omega - omega_ref]`` with ``q_e = q_ref* ⊗ q`` on the
shortest way, through the Python path (``torque``) and the compiled path
(``compiled_inputs`` and backend-neutral ``torque_components``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import control
import numpy as np
from numpy.typing import ArrayLike, NDArray

from attitude import quaternion as quat
from attitude.rigid_body import Components
from attitude.validation import as_float_array, check_positive, check_vector, describe, positive_per_axis
from controllers.pd import quaternion_error_components

__all__ = [
    "PBH_TOLERANCE",
    "PSD_TOLERANCE",
    "R_CONDITION_LIMIT",
    "SYMMETRY_TOLERANCE",
    "LQRController",
    "LQRDesign",
    "bryson_weights",
    "design_lqr",
]

#: Largest accepted ``max|M - M^T| / max|M|`` for the weights ``Q`` and
#: ``R``. Weights assembled in floating point (``M^T M``, rotations) are
#: symmetric to ~1e-16 relative; 1e-12 tolerates that and rejects a typed-in
#: off-diagonal that differs from its mirror. (python-control's own check is
#: an *absolute* ``M - M^T < 2.2e-16``; the weights are symmetrised before
#: they reach it.)
SYMMETRY_TOLERANCE = 1e-12

#: ``Q`` is accepted as positive semi-definite when its smallest eigenvalue
#: is at least ``-PSD_TOLERANCE * max|eig|``: ``eigvalsh`` is accurate to
#: ~1e-16 of the largest eigenvalue, so a true zero eigenvalue comes out
#: within 1e-12 of it with a wide margin.
PSD_TOLERANCE = 1e-12

#: ``R`` must be positive definite with condition number below this limit:
#: the gain ``R^-1 B' S`` loses every digit beyond it.
R_CONDITION_LIMIT = 1e12

#: Popov-Belevitch-Hautus threshold on the smallest singular value of
#: ``[A - lam I, B]`` (and ``[A - lam I; Q^1/2]``), both blocks scaled to unit
#: norm. A defective eigenvalue of multiplicity 2 is computed only to
#: ~sqrt(machine eps) = 1.5e-8 relative, which is how far an exactly
#: uncontrollable mode can appear to be from losing rank; 1e-7 catches it,
#: and a pair that close to uncontrollable would need gains ~1e7 anyway. The
#: same number decides which eigenvalues count as not strictly stable
#: (``Re lam >= -1e-7 |A|``, or ``|z| >= 1 - 1e-7``).
PBH_TOLERANCE = 1e-7


# ---------------------------------------------------------------------------
# Weights
# ---------------------------------------------------------------------------


def bryson_weights(
    *, angle_max: ArrayLike, rate_max: ArrayLike, torque_max: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """LQR weights by Bryson's rule: each term is 1 at its largest acceptable value.

    The attitude state is the error-quaternion vector part, whose magnitude
    for an error angle ``theta`` is ``sin(theta/2) ≈ theta/2``: the angle
    bound maps to the state bound ``sin(angle_max/2)`` (about half the angle;
    forgetting the half weights attitude four times too lightly).

    Parameters
    ----------
    angle_max : float or array_like (3,)
        Largest acceptable attitude error per axis [rad], in ``(0, pi]``.
    rate_max : float or array_like (3,)
        Largest acceptable rate deviation per axis [rad/s].
    torque_max : float or array_like (3,)
        Largest acceptable control torque per axis [N m].

    Returns
    -------
    Q : ndarray (6, 6)
        ``diag(1/sin(angle_max/2)^2, 1/rate_max^2)`` [1, (s/rad)^2].
    R : ndarray (3, 3)
        ``diag(1/torque_max^2)`` [1/(N m)^2].

    Raises
    ------
    ValueError
        A bound that is not finite and strictly positive, an angle above pi,
        or a shape other than scalar or (3,).
    """
    angle = positive_per_axis(angle_max, "angle_max", "rad")
    if np.any(angle > np.pi):
        raise ValueError(f"angle_max must not exceed pi (the largest attitude error), got {describe(angle)}")
    rate = positive_per_axis(rate_max, "rate_max", "rad/s")
    torque = positive_per_axis(torque_max, "torque_max", "N m")
    q_max = np.sin(0.5 * angle)
    Q = np.diag(np.concatenate([1.0 / q_max**2, 1.0 / rate**2]))
    R = np.diag(1.0 / torque**2)
    return Q, R


def _weight(value: ArrayLike, n: int, name: str, *, definite: bool) -> NDArray[np.float64]:
    """Validate a weight matrix (or its diagonal) and return it symmetrised."""
    arr = as_float_array(value, name)
    if arr.ndim == 0 and n == 1:
        arr = arr.reshape(1, 1)
    elif arr.ndim == 1 and arr.size == n:
        arr = np.diag(arr)
    if arr.shape != (n, n):
        raise ValueError(f"{name} must be a ({n}, {n}) matrix or its diagonal ({n},), got shape {arr.shape}")
    scale = float(np.max(np.abs(arr)))
    asym = float(np.max(np.abs(arr - arr.T)))
    if asym > SYMMETRY_TOLERANCE * scale:
        raise ValueError(
            f"{name} must be symmetric (max|{name} - {name}^T| <= {SYMMETRY_TOLERANCE:g} max|{name}|); "
            f"found an asymmetry of {asym:.6g} in {describe(arr)}"
        )
    arr = 0.5 * (arr + arr.T)
    eig = np.linalg.eigvalsh(arr)
    top = float(np.max(np.abs(eig)))
    if definite:
        if eig[0] <= 0 or eig[0] * R_CONDITION_LIMIT < eig[-1]:
            raise ValueError(
                f"{name} must be positive definite (condition number below {R_CONDITION_LIMIT:g}); "
                f"its eigenvalues are {describe(eig)}"
            )
    elif eig[0] < -PSD_TOLERANCE * top:
        raise ValueError(
            f"{name} must be positive semi-definite (eigenvalues >= -{PSD_TOLERANCE:g} max|eig|); "
            f"its eigenvalues are {describe(eig)}"
        )
    return arr


# ---------------------------------------------------------------------------
# PBH tests
# ---------------------------------------------------------------------------


def _not_strictly_stable(A: NDArray[np.float64], discrete: bool) -> NDArray[np.complex128]:
    eig = np.linalg.eigvals(A)
    if discrete:
        return eig[np.abs(eig) >= 1.0 - PBH_TOLERANCE]
    scale = max(float(np.linalg.norm(A, 2)), np.finfo(float).tiny)
    return eig[eig.real >= -PBH_TOLERANCE * scale]


def _unit(M: NDArray[np.float64]) -> NDArray[np.float64]:
    norm = float(np.linalg.norm(M, 2))
    return M / norm if norm > 0 else M


def _pbh_defects(A: NDArray[np.float64], M: NDArray[np.float64], discrete: bool, *, columns: bool) -> list[complex]:
    """Eigenvalues that fail the PBH rank test with ``[A - lam I, M]`` (or stacked rows)."""
    n = A.shape[0]
    scale = max(float(np.linalg.norm(A, 2)), 1.0 if discrete else np.finfo(float).tiny)
    a_n = A / scale
    m_n = _unit(M)
    bad = []
    for lam in _not_strictly_stable(A, discrete):
        shifted = a_n - (lam / scale) * np.eye(n)
        stacked = np.hstack([shifted, m_n]) if columns else np.vstack([shifted, m_n])
        sigma = np.linalg.svd(stacked, compute_uv=False)
        if sigma[-1] <= PBH_TOLERANCE:
            bad.append(complex(lam))
    return bad


def _sqrtm_psd(Q: NDArray[np.float64]) -> NDArray[np.float64]:
    d, v = np.linalg.eigh(Q)
    return (v * np.sqrt(np.clip(d, 0.0, None))) @ v.T


# ---------------------------------------------------------------------------
# Design
# ---------------------------------------------------------------------------


@dataclass(frozen=True)
class LQRDesign:
    """A linear-quadratic regulator and its closed loop.

    Attributes
    ----------
    K : ndarray (m, n)
        State-feedback gain, ``u = -K x`` [N m per state unit].
    S : ndarray (n, n)
        Solution of the (continuous or discrete) algebraic Riccati equation.
    poles : ndarray (n,), complex
        Closed-loop eigenvalues: s-plane [1/s] (continuous) or z-plane [-]
        (discrete), sorted by magnitude.
    closed_loop : control.StateSpace
        ``x' = (A - B K) x + B d`` (or the discrete ``x_{k+1}``) with the
        plant's state names; inputs ``<input>_dist`` are disturbances added
        to the control (e.g. torque [N m]); outputs are the plant outputs
        (``(C - D K) x + D d``) followed by the commands ``<input>_cmd``
        (``-K x``). ``dt`` is 0 or the period.
    plant : control.StateSpace
        The model the gain was designed on: ``sys`` itself, or its
        zero-order-hold discretisation at ``period``.
    Q, R : ndarray
        The (symmetrised) weights.
    period : float or None
        Sample time [s] of a discrete design; None for a continuous one.
    """

    K: NDArray[np.float64]
    S: NDArray[np.float64]
    poles: NDArray[np.complex128]
    closed_loop: control.StateSpace
    plant: control.StateSpace
    Q: NDArray[np.float64]
    R: NDArray[np.float64]
    period: float | None

    @property
    def discrete(self) -> bool:
        """True for a design at a sample time."""
        return self.period is not None

    @property
    def s_poles(self) -> NDArray[np.complex128]:
        """Closed-loop poles in the s-plane [1/s] (``log(z) / period`` for a discrete design)."""
        if self.period is None:
            return self.poles.copy()
        return np.log(self.poles.astype(complex)) / self.period

    @property
    def slowest_decay_rate(self) -> float:
        """Smallest ``-Re(s)`` over the closed-loop poles [1/s]: errors decay at least like ``exp(-rate t)``."""
        return float(np.min(-self.s_poles.real))


def design_lqr(sys: control.StateSpace, *, Q: ArrayLike, R: ArrayLike, period: float | None = None) -> LQRDesign:
    """Continuous or discrete (zero-order hold) LQR design with checked inputs.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous-time plant, e.g. from :func:`attitude.linearize.linearize`;
        or a discrete-time one (``dt > 0``), designed at its own ``dt`` as it
        is (no further discretisation; :func:`controllers.integral.design_lqi`
        passes its augmented sampled plant this way).
    Q : array_like (n, n) or (n,)
        State weight, symmetric positive semi-definite (a vector is its
        diagonal); see :func:`bryson_weights`.
    R : array_like (m, m) or (m,)
        Input weight, symmetric positive definite.
    period : float, optional
        Controller sample time [s]. None: continuous design (``control.lqr``).
        Given: ``control.dlqr`` on ``control.c2d(sys, period, "zoh")``. For a
        discrete-time ``sys``: None or its ``dt``.

    Returns
    -------
    LQRDesign

    Raises
    ------
    ValueError
        ``sys`` not a StateSpace (continuous, or discrete with a number
        ``dt`` that ``period`` does not contradict); ``Q``/``R`` of the wrong
        shape, not symmetric, ``Q`` not positive semi-definite, ``R`` not
        positive definite; ``(A, B)`` not stabilisable (an unstable or
        marginal mode the input cannot reach); ``(Q^1/2, A)`` not detectable
        (an unstable or marginal mode the cost does not see); a non-positive
        ``period``.
    """
    if not isinstance(sys, control.StateSpace):
        raise ValueError(f"sys must be a control.StateSpace, got {type(sys).__name__}")
    sampled_plant = sys.isdtime(strict=True)
    if sampled_plant:
        if sys.dt is True or (period is not None and abs(float(period) - sys.dt) > 1e-9 * sys.dt):
            raise ValueError(
                f"a discrete-time sys is designed at its own dt: period must be None or dt = {sys.dt!r} s "
                f"(and dt a number), got period = {period!r}"
            )
        period = float(sys.dt)
    elif not sys.isctime(strict=True):
        raise ValueError(f"sys must be continuous-time (dt = 0) or discrete with a number dt; got dt = {sys.dt!r}")
    A = np.asarray(sys.A, dtype=float)
    B = np.asarray(sys.B, dtype=float)
    n, m = B.shape
    if n == 0 or m == 0:
        raise ValueError(f"sys must have states and inputs, got {n} states and {m} inputs")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(B))):
        raise ValueError("sys must have finite A and B matrices")
    Q = _weight(Q, n, "Q", definite=False)
    R = _weight(R, m, "R", definite=True)
    if sampled_plant:
        plant = sys
        A_p, B_p = A, B
    elif period is not None:
        period = float(check_positive(period, "period"))
        plant = control.c2d(sys, period, "zoh")
        A_p, B_p = np.asarray(plant.A, dtype=float), np.asarray(plant.B, dtype=float)
    else:
        plant = sys
        A_p, B_p = A, B
    discrete = period is not None
    where = f" (zero-order hold at period = {period!r} s)" if discrete and not sampled_plant else ""
    where = f" (discrete at dt = {period!r} s)" if sampled_plant else where

    bad = _pbh_defects(A_p, B_p, discrete, columns=True)
    if bad:
        raise ValueError(
            f"sys must be stabilisable: (A, B){where} has modes the input cannot reach at eigenvalues "
            f"{describe(np.array(bad))} that are not strictly stable (PBH rank test, tolerance {PBH_TOLERANCE:g}); "
            "no LQR gain can stabilise them"
        )
    bad = _pbh_defects(A_p, _sqrtm_psd(Q), discrete, columns=False)
    if bad:
        raise ValueError(
            f"Q must make (Q^1/2, A){where} detectable: the modes at eigenvalues {describe(np.array(bad))} are not "
            "strictly stable and carry no cost, so the Riccati equation has no stabilising solution; "
            "weight those states"
        )

    # scipy's Riccati solvers, named: with slycot installed (the robust extra) python-control switches to
    # slycot's by default, and the tests measured a Riccati residual 8 times the 1e-9 relative bound scipy's
    # meets and a discrete gain off by 30 % on a fast-sampled design (tests/controllers/test_lqr.py).
    if discrete:
        K, S, _ = control.dlqr(A_p, B_p, Q, R, method="scipy")
    else:
        K, S, _ = control.lqr(A_p, B_p, Q, R, method="scipy")
    K = np.asarray(K, dtype=float)
    S = np.asarray(S, dtype=float)
    A_cl = A_p - B_p @ K
    poles = np.linalg.eigvals(A_cl)
    poles = poles[np.argsort(np.abs(poles), kind="stable")]
    stable = np.all(np.abs(poles) < 1.0) if discrete else np.all(poles.real < 0.0)
    if not stable:  # pragma: no cover - the checks above exclude it
        raise ValueError(f"the LQR closed loop of sys is not stable (poles {describe(poles)}); check Q, R and sys")

    C = np.asarray(sys.C, dtype=float)
    D = np.asarray(sys.D, dtype=float)
    closed_loop = control.ss(
        A_cl,
        B_p,
        np.vstack([C - D @ K, -K]),
        np.vstack([D, np.zeros((m, m))]),
        dt=period if discrete else 0,
        states=list(sys.state_labels),
        inputs=[f"{u}_dist" for u in sys.input_labels],
        outputs=[*sys.output_labels, *(f"{u}_cmd" for u in sys.input_labels)],
        name=f"{sys.name}$lqr",
    )
    return LQRDesign(K=K, S=S, poles=poles, closed_loop=closed_loop, plant=plant, Q=Q, R=R, period=period)


# ---------------------------------------------------------------------------
# Controller
# ---------------------------------------------------------------------------


class LQRController:
    """State feedback ``tau = -K [q_ev; omega - omega_ref]`` for the simulation engine.

    Parameters
    ----------
    design : LQRDesign
        A design on the 6-state model of :mod:`attitude.linearize` (``K`` of
        shape (3, 6), states ``[q_ev, omega - omega_ref]``).
    q_ref : array_like (4,)
        Reference attitude ``q_RN`` at ``t = 0``.
    period : float, optional
        Sample time [s]. Defaults to ``design.period``; required for a
        continuous design (warns when the closed-loop bandwidth exceeds a
        tenth of the sample rate ``2 pi / period``).
    omega_ref : array_like (3,), optional
        Rate of the reference frame in its own components [rad/s], the same
        steady spin the design was linearised at (zero when None). The
        reference turns as ``q_RN(t) = q_ref ⊗ exp(omega_ref t / 2)`` and the
        rate feedback is ``omega - omega_ref`` (body components), exactly the
        linear model's deviation state.

    Notes
    -----
    ``q_e = q_RN* ⊗ q_BN`` is taken on the shortest way (scalar part >= 0),
    so a 359 degree error is a 1 degree error.
    """

    #: The compiled path may keep this law's closed loop by the class and its pickle: the law reads nothing else
    #: (attitude.simulation.engine caches the compiled loop; a user's law without this flag is rebuilt each run).
    compiled_law_cacheable = True

    def __init__(
        self,
        design: LQRDesign,
        *,
        q_ref: ArrayLike | None = None,
        period: float | None = None,
        omega_ref: ArrayLike | None = None,
    ) -> None:
        if not isinstance(design, LQRDesign):
            raise ValueError(f"design must be an LQRDesign (from design_lqr), got {type(design).__name__}")
        K = np.asarray(design.K, dtype=float)
        if K.shape != (3, 6):
            raise ValueError(
                f"design.K must have shape (3, 6) (the 6-state attitude model of attitude.linearize), got {K.shape}"
            )
        self.design = design
        self.K = K.copy()
        if period is None:
            if design.period is None:
                raise ValueError("period [s] is required for a continuous design (the controller samples)")
            period = design.period
        period = float(check_positive(period, "period"))
        if design.period is not None and abs(period - design.period) > 1e-9 * design.period:
            raise ValueError(
                f"period = {period!r} s must equal the sample time of the discrete design ({design.period!r} s)"
            )
        if design.period is None:
            bandwidth = float(np.max(np.abs(design.poles)))
            if bandwidth > 0.1 * 2.0 * np.pi / period:
                warnings.warn(
                    f"the continuous design's fastest pole ({bandwidth:.4g} rad/s) is above a tenth of the sample "
                    f"rate ({2.0 * np.pi / period:.4g} rad/s): design at the sample time (design_lqr(..., period=))",
                    stacklevel=2,
                )
        self.period = period
        self.q_ref = quat.identity() if q_ref is None else quat.as_unit_quaternion(q_ref, "q_ref")
        if self.q_ref.shape != (4,):
            raise ValueError(f"q_ref must have shape (4,), got {self.q_ref.shape}")
        w = np.zeros(3) if omega_ref is None else check_vector(omega_ref, "omega_ref", 3)
        if w.shape != (3,):
            raise ValueError(f"omega_ref must have shape (3,) [rad/s], got shape {w.shape}")
        self.omega_ref = np.array(w, dtype=float)

    # -- reference ------------------------------------------------------------

    def reference_samples(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """References at many times: ``q_RN`` (n, 4) and ``omega_ref`` (n, 3) [rad/s].

        Parameters
        ----------
        t : array_like
            Times [s], shape (n,).
        """
        t = np.atleast_1d(as_float_array(t, "t")).reshape(-1)
        if np.any(self.omega_ref != 0.0):
            turn = quat.from_rotation_vector(t[:, None] * self.omega_ref)
            q_r = quat.multiply(self.q_ref, turn)
        else:
            q_r = np.tile(self.q_ref, (t.size, 1))
        return q_r, np.tile(self.omega_ref, (t.size, 1))

    def reference(self, t: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Reference attitude ``q_RN`` and rate ``omega_ref`` [rad/s] at time ``t`` [s].

        Parameters
        ----------
        t : float
            Time [s].
        """
        q_r, w_r = self.reference_samples(t)
        return q_r[0], w_r[0]

    def compiled_inputs(self, t: NDArray[np.float64]) -> NDArray[np.float64]:
        """Reference samples ``[q_ref; omega_ref]`` (7, len(t)) for the compiled engine.

        Parameters
        ----------
        t : ndarray
            Tick times [s].
        """
        q_r, w_r = self.reference_samples(t)
        return np.concatenate([q_r, w_r], axis=1).T

    # -- law ------------------------------------------------------------------

    def state_components(self, q: Components, omega: Components, inputs: Components) -> Components:
        """The linear model's state ``[q_ev, omega - omega_ref]`` on components (numpy or casadi).

        Parameters
        ----------
        q : list
            Attitude components ``[w, x, y, z]`` of ``q_BN`` (numbers or casadi expressions).
        omega : list
            Body rate components ``omega_BN_B`` [rad/s].
        inputs : list
            ``[q_ref (4), omega_ref (3)]`` components.
        """
        q_e, _ = quaternion_error_components(list(inputs[:4]), list(q))
        return [q_e[1], q_e[2], q_e[3], *(w - r for w, r in zip(omega, inputs[4:7]))]

    def torque_components(self, q: Components, omega: Components, h_body: Components, inputs: Components) -> Components:
        """``-K x`` on components; ``inputs = [q_ref (4), omega_ref (3)]`` (``h_body`` unused).

        Parameters
        ----------
        q : list
            Attitude components ``[w, x, y, z]`` of ``q_BN`` (numbers or casadi expressions).
        omega : list
            Body rate components ``omega_BN_B`` [rad/s].
        h_body : list
            Internal (wheel) momentum in body components [N m s]; unused.
        inputs : list
            ``[q_ref (4), omega_ref (3)]`` components.
        """
        x = self.state_components(q, omega, inputs)
        tau = []
        for i in range(3):
            acc = 0.0 * omega[0]
            for j in range(6):
                if self.K[i, j] != 0.0:
                    acc = acc - self.K[i, j] * x[j]
            tau.append(acc)
        return tau

    def torque(self, t: float, estimate: Any) -> NDArray[np.float64]:
        """Commanded body torque [N m] for an estimate with ``q`` and ``omega`` [rad/s].

        Parameters
        ----------
        t : float
            Time [s].
        estimate : Estimate
            The estimator's output (anything with ``q`` and ``omega``).
        """
        q_r, w_r = self.reference(t)
        q = check_vector(estimate.q, "estimate.q", 4)
        q = q / np.linalg.norm(q)  # estimators may drift off the unit sphere; the compiled path sees unit q
        w = check_vector(estimate.omega, "estimate.omega", 3)
        out = self.torque_components(list(q), list(w), [0.0, 0.0, 0.0], [*q_r, *w_r])
        return np.array([float(v) for v in out])

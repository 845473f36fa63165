"""Exact torque-free motion of a rigid body, for teaching and verification.

Three closed forms, each the exact solution of the one definition of the
dynamics in :mod:`attitude.rigid_body` (Euler's equations with zero torque):

* :func:`torque_free_motion` -- the body rates of any rigid body, from Jacobi
  elliptic functions (Jacobi 1849; Landau & Lifshitz, *Mechanics*, section 37).
  Rates only, no attitude: with the angular momentum fixed in space, two
  Euler angles follow from the rates algebraically, but the third needs an
  elliptic integral of the third kind (Landau & Lifshitz, section 37), which
  is not implemented. For the attitude of a triaxial body integrate with
  :func:`attitude.propagate.propagate` (whose rates this closed form
  checks); an axisymmetric body has both in closed form (next item).
* :func:`axisymmetric_precession` -- rates *and* attitude quaternion of an
  axisymmetric body (free precession), with the Earth's Euler (Chandler)
  period as a named example (:func:`earth_euler_period`).
* :func:`intermediate_axis_growth_rate` and :func:`flip_period` -- the
  instability of spin about the middle axis (Dzhanibekov effect).

Conventions are the toolkit's (``DESIGN.md``): SI units, ``omega`` is the
angular velocity of the body B relative to the inertial frame N in body
components [rad/s], ``q = q_BN`` is scalar-first Hamilton and rotates body
vectors into inertial ones.

See docs/torque_free_motion.md for the derivation (the elliptic solution and
its signs, why the elliptic functions are evaluated here, the separatrix).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ellipkm1, elliprf

from attitude import quaternion as quat
from attitude.results import ResultIO
from attitude.rigid_body import RigidBody
from attitude.validation import as_float_array, check_vector, describe

__all__ = [
    "AXISYMMETRY_TOLERANCE",
    "EARTH_DYNAMICAL_FLATTENING",
    "EARTH_POLAR_MOMENT",
    "EARTH_PRINCIPAL_MOMENTS",
    "EARTH_ROTATION_RATE",
    "SEPARATRIX_TOLERANCE",
    "SPIN_TOLERANCE",
    "AxisymmetricPrecession",
    "TorqueFreeMotion",
    "axisymmetric_precession",
    "earth_euler_period",
    "flip_period",
    "intermediate_axis_growth_rate",
    "jacobi_sncndn",
    "torque_free_motion",
]

#: Two principal moments closer than ``AXISYMMETRY_TOLERANCE * I3`` are taken
#: as equal (axisymmetric body; all three: a sphere). Eigenvalues of a rotated
#: ``diag(a, a, c)`` tensor come out of ``eigh`` split by ~1e-15 relative, so
#: 1e-12 leaves a factor 1000 for rounding while treating any physically
#: meaningful asymmetry as real. Pass a larger ``axisymmetry_rtol`` for
#: tensors typed with fewer digits.
AXISYMMETRY_TOLERANCE = 1e-12

#: A rate whose components off one principal axis (or off a degenerate
#: principal plane) are below ``SPIN_TOLERANCE * |omega|`` is a pure principal
#: spin: the rates are constant. The conversion ``C_PB @ omega_B`` leaves
#: ~1e-16 |omega| off-axis, so 1e-12 recognises a spin given along a computed
#: principal axis. About the middle axis this is the *unstable* equilibrium: a
#: real perturbation ``eps`` would flip the body after about
#: ``2 ln(1/eps) / k`` (see :func:`flip_period`).
SPIN_TOLERANCE = 1e-12

#: ``omega0`` is rejected as "on the separatrix" when
#: ``|D2| <= SEPARATRIX_TOLERANCE * (I3 (I3-I2) w3^2 + I1 (I2-I1) w1^2)``,
#: i.e. when the rate lies within an angle of about ``SEPARATRIX_TOLERANCE / 2``
#: rad of a separatrix plane in the (scaled) ``w1``-``w3`` plane. The test is
#: scale free, so a tiny perturbation of a middle-axis spin is accepted as long
#: as its *direction* decides the regime. Rounding in the principal-frame
#: conversion and in the moments changes the ratio by ~1e-15 (times
#: ``I3 / gap`` for nearly equal moments), so 1e-9 keeps the regime decided by
#: the data with a margin of 1e4 or more for moment gaps down to 1e-3 I3.
#: The elliptic evaluation itself is accurate for any ``1 - m > 0`` (see the
#: docs/torque_free_motion.md); scipy's ``ellipj`` would not be (error up to 1e11 for
#: ``1 - m <= 1e-10``).
SEPARATRIX_TOLERANCE = 1e-9

#: Earth's nominal mean angular velocity [rad/s] (IERS Conventions 2010,
#: IERS Technical Note 36, Table 1.1). ``2 pi / EARTH_ROTATION_RATE`` is one
#: rotation relative to the stars, 86164.1 s.
EARTH_ROTATION_RATE = 7.292115e-5

#: Earth's dynamical flattening ``H = (C - A) / C`` (IERS Conventions 2010,
#: TN 36, Table 1.1: 3273795e-9, uncertainty 1e-9), with ``A`` the mean
#: equatorial moment.
EARTH_DYNAMICAL_FLATTENING = 3.273795e-3

#: Earth's polar moment of inertia ``C`` [kg m^2] (F. D. Stacey and
#: P. M. Davis, *Physics of the Earth*, 4th ed., Cambridge 2008, Appendix A:
#: 8.034e37, i.e. ``C = 0.3307 M a^2``).
EARTH_POLAR_MOMENT = 8.034e37

#: Earth as an axisymmetric rigid body ``(A, A, C)`` [kg m^2]: ``C`` from
#: :data:`EARTH_POLAR_MOMENT` and ``A = C (1 - H)`` = 8.0077e37 from
#: :data:`EARTH_DYNAMICAL_FLATTENING` (the four-digit values 8.034e37 and
#: 8.008e37 quoted in textbooks give ``C - A`` to one digit only, which moves
#: the Euler period by 1 %). The equatorial triaxiality ``(B - A) / A ~ 2e-5``
#: is neglected.
EARTH_PRINCIPAL_MOMENTS = (
    EARTH_POLAR_MOMENT * (1.0 - EARTH_DYNAMICAL_FLATTENING),
    EARTH_POLAR_MOMENT * (1.0 - EARTH_DYNAMICAL_FLATTENING),
    EARTH_POLAR_MOMENT,
)

# AGM convergence test of Bulirsch's algorithm: the iteration stops when
# |a - b| <= _AGM_TOLERANCE a; one more mean is then exact to ~(1e-9)^2.
_AGM_TOLERANCE = 1e-9
# Below |v| = 1e-6 the Taylor series sn = v - (1+m) v^3/6, cn = 1 - v^2/2,
# dn = 1 - m v^2/2 is exact to ~1e-25 and avoids cot(v)^2 overflowing.
_SERIES_LIMIT = 1e-6

_CONSTANT_REGIMES = ("rest", "sphere", "principal axis spin")


# ---------------------------------------------------------------------------
# Input helpers
# ---------------------------------------------------------------------------


def _single_body(body: RigidBody | ArrayLike) -> RigidBody:
    """Return ``body`` as a single :class:`RigidBody` (moments or tensor accepted)."""
    if not isinstance(body, RigidBody):
        try:
            body = RigidBody(body)
        except ValueError as exc:
            raise ValueError(f"body must be a RigidBody or a valid inertia [kg m^2]: {exc}") from exc
    if body.batch_shape:
        raise ValueError(f"body must be a single rigid body, got a batch of inertias of shape {body.batch_shape}")
    return body


def _rate_vector(omega0: ArrayLike, name: str = "omega0") -> NDArray[np.float64]:
    arr = check_vector(omega0, name, 3)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a single body rate of shape (3,) [rad/s], got shape {arr.shape}")
    return arr.copy()


def _times(t: ArrayLike, name: str = "t") -> NDArray[np.float64]:
    arr = as_float_array(t, name)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array of times [s], got shape {arr.shape}")
    return arr


def _check_rtol(rtol: float) -> float:
    arr = as_float_array(rtol, "axisymmetry_rtol")
    if arr.ndim != 0 or not 0.0 <= float(arr) < 1.0:
        raise ValueError(f"axisymmetry_rtol must be a number in [0, 1), got {describe(arr)}")
    return float(arr)


def _symmetry(moments: NDArray[np.float64], rtol: float) -> tuple[str, NDArray[np.float64]]:
    """Classify sorted moments and snap nearly equal ones to their mean."""
    i1, i2, i3 = (float(x) for x in moments)
    tol = rtol * i3
    if i3 - i1 <= tol:
        mean = (i1 + i2 + i3) / 3.0
        return "sphere", np.array([mean, mean, mean])
    if i2 - i1 <= i3 - i2:
        if i2 - i1 <= tol:
            mean = 0.5 * (i1 + i2)
            return "oblate", np.array([mean, mean, i3])
    elif i3 - i2 <= tol:
        mean = 0.5 * (i2 + i3)
        return "prolate", np.array([i1, mean, mean])
    return "asymmetric", np.array([i1, i2, i3])


# ---------------------------------------------------------------------------
# Jacobi elliptic functions with the complementary parameter
# ---------------------------------------------------------------------------


def _sncndn_reduced(v: NDArray[np.float64], mc: float) -> tuple[NDArray[np.float64], ...]:
    """Bulirsch's sn, cn, dn for ``|v| <= K/2`` and ``0 < mc <= 1``.

    R. Bulirsch, Numer. Math. 7 (1965) 78-90 (algorithm ``sncndn``): an
    arithmetic-geometric mean started from ``sqrt(mc)``, then a backward
    recurrence on the ratio ``cn/sn`` that keeps relative accuracy.
    """
    a = 1.0
    b = mc
    means: list[float] = []
    roots: list[float] = []
    c = 1.0
    for _ in range(64):
        means.append(a)
        b = math.sqrt(b)
        roots.append(b)
        c = 0.5 * (a + b)
        if abs(a - b) <= _AGM_TOLERANCE * a:
            break
        b *= a
        a = c
    small = np.abs(v) < _SERIES_LIMIT
    x = np.where(small, 1.0, v) * c
    s = np.sin(x)
    ratio = np.cos(x) / s
    cc = c * ratio
    dn = np.ones_like(x)
    for mean, root in zip(reversed(means), reversed(roots)):
        ratio = ratio * cc
        cc = cc * dn
        dn = (root + ratio) / (mean + ratio)
        ratio = cc / mean
    sn = np.copysign(1.0 / np.sqrt(cc * cc + 1.0), s)
    cn = cc * sn
    m = 1.0 - mc
    sn = np.where(small, v - (1.0 + m) * v**3 / 6.0, sn)
    cn = np.where(small, 1.0 - 0.5 * v * v, cn)
    dn = np.where(small, 1.0 - 0.5 * m * v * v, dn)
    return sn, cn, dn


def jacobi_sncndn(u: ArrayLike, mc: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Jacobi elliptic functions ``sn, cn, dn (u | m)`` from the complementary parameter.

    Unlike ``scipy.special.ellipj(u, m)`` this takes ``mc = 1 - m`` itself, so
    it keeps full accuracy as ``m -> 1`` (see docs/torque_free_motion.md for the
    measured errors of both).

    Parameters
    ----------
    u : array_like
        Argument (any shape), dimensionless.
    mc : float
        Complementary parameter ``1 - m`` in ``[0, 1]`` (``mc = 1`` gives
        ``sin, cos, 1``; ``mc = 0`` gives ``tanh, sech, sech``).

    Returns
    -------
    sn, cn, dn : ndarray
        Same shape as ``u``.

    Raises
    ------
    ValueError
        If ``u`` is not finite or ``mc`` is not a finite number in ``[0, 1]``.
    """
    u = as_float_array(u, "u")
    mc_arr = as_float_array(mc, "mc")
    if mc_arr.ndim != 0 or not 0.0 <= float(mc_arr) <= 1.0:
        raise ValueError(f"mc (the complementary parameter 1 - m) must be a number in [0, 1], got {describe(mc_arr)}")
    mc = float(mc_arr)
    if mc == 0.0:
        e = np.exp(-np.abs(u))
        sech = 2.0 * e / (1.0 + e * e)
        return np.tanh(u), sech, sech.copy()
    quarter = float(ellipkm1(mc))
    j = np.round(u / quarter)
    v = u - j * quarter
    sn0, cn0, dn0 = _sncndn_reduced(v, mc)
    kc = math.sqrt(mc)
    quadrant = np.mod(j, 4.0)
    # Quarter-period shifts (DLMF 22.4.3): sn(v+K) = cd v, cn(v+K) = -k' sd v, dn(v+K) = k' nd v.
    sn = np.select([quadrant == 0, quadrant == 1, quadrant == 2], [sn0, cn0 / dn0, -sn0], -cn0 / dn0)
    cn = np.select([quadrant == 0, quadrant == 1, quadrant == 2], [cn0, -kc * sn0 / dn0, -cn0], kc * sn0 / dn0)
    dn = np.where((quadrant == 0) | (quadrant == 2), dn0, kc / dn0)
    return sn, cn, dn


def _argument_of(sn0: float, cn0: float, mc: float, quarter: float) -> float:
    """The ``u`` in ``(-K, 3K]`` with ``sn u = sn0`` and ``cn u = cn0`` (``sn0^2 + cn0^2 = 1``).

    Uses Carlson's form of the incomplete integral of the first kind,
    ``F(phi | m) = sin(phi) R_F(cos^2 phi, 1 - m sin^2 phi, 1)`` with
    ``1 - m sin^2 = cn^2 + mc sn^2`` (no cancellation), and
    ``sn(2K - u) = sn u``, ``cn(2K - u) = -cn u`` for ``cn0 < 0``.
    """
    c2 = cn0 * cn0
    f = sn0 * float(elliprf(c2, c2 + mc * sn0 * sn0, 1.0))
    return f if cn0 >= 0.0 else 2.0 * quarter - f


# ---------------------------------------------------------------------------
# General torque-free motion
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class TorqueFreeMotion(ResultIO):
    """Exact torque-free body rates of one rigid body from one initial rate.

    Create it with :func:`torque_free_motion`; evaluate it with
    :meth:`omega`. The closed form gives the body rates only, not the
    attitude (module docstring). The toolkit's result protocol:
    :meth:`summary`, :meth:`plot` (the rates over two periods),
    ``save(path)`` / ``load(path)`` (``.npz``).

    Attributes
    ----------
    regime : str
        ``"major"`` (rate circles the major axis, ``H^2 > 2 T I2``),
        ``"minor"`` (circles the minor axis, ``H^2 < 2 T I2``), or a constant
        rate: ``"principal axis spin"``, ``"sphere"`` or ``"rest"``
        (``omega0 = 0``). An oblate body (``I1 = I2``) is always ``"major"``,
        a prolate one (``I2 = I3``) always ``"minor"``, both with ``m = 0``.
    symmetry : str
        ``"asymmetric"``, ``"oblate"`` (``I1 = I2 < I3``), ``"prolate"``
        (``I1 < I2 = I3``) or ``"sphere"``, to :data:`AXISYMMETRY_TOLERANCE`.
    moments : ndarray, shape (3,)
        Principal moments used ``I1 <= I2 <= I3`` [kg m^2] (nearly equal
        ones replaced by their mean).
    C_PB : ndarray, shape (3, 3)
        Body-to-principal direction cosine matrix (``v_P = C_PB @ v_B``).
    omega0 : ndarray, shape (3,)
        Initial body rate [rad/s], body components.
    H : float
        Magnitude of the angular momentum [N m s].
    T : float
        Rotational kinetic energy [J].
    m : float
        Elliptic parameter ``k^2`` in ``[0, 1)`` (0 for a constant rate).
    mc : float
        Complementary parameter ``1 - m``, computed without cancellation.
    lam : float
        Rate of the elliptic argument ``u = lam t + u0`` [rad/s] (0 for a
        constant rate).
    K : float
        Quarter period of the elliptic functions, ``K(m)`` (dimensionless).
    period : float
        Period of the body rates ``4 K / lam`` [s]; ``inf`` for a constant
        rate.
    amplitudes : ndarray, shape (3,)
        ``(A, B, C)`` [rad/s]: the largest magnitude of each principal rate
        component (for a constant rate, ``|omega_P|`` component-wise).
    sign : float
        ``s``: sign of ``w3`` (major) or ``w1`` (minor), which never changes.
    u0 : float
        Elliptic argument at ``t = 0``.
    """

    regime: str
    symmetry: str
    moments: NDArray[np.float64]
    C_PB: NDArray[np.float64]
    omega0: NDArray[np.float64]
    H: float
    T: float
    m: float
    mc: float
    lam: float
    K: float
    period: float
    amplitudes: NDArray[np.float64]
    sign: float
    u0: float

    @property
    def flip_period(self) -> float:
        """Time between successive sign reversals of the middle-axis rate ``2 K / lam`` [s]."""
        return math.inf if self.regime in _CONSTANT_REGIMES else 2.0 * self.K / self.lam

    def check_loaded(self, path: str) -> None:
        """Refuse a loaded file with an unknown regime or symmetry.

        Parameters
        ----------
        path : str
            The file read, named in the error.
        """
        if self.regime not in ("major", "minor", *_CONSTANT_REGIMES):
            raise ValueError(f"{path}: regime must be major, minor or one of {_CONSTANT_REGIMES}, got {self.regime!r}")
        if self.symmetry not in ("asymmetric", "oblate", "prolate", "sphere"):
            raise ValueError(f"{path}: symmetry must be asymmetric, oblate, prolate or sphere, got {self.symmetry!r}")

    def summary(self) -> str:
        """One line: the regime, the invariants and the periods (rates only: no attitude)."""
        text = (
            f"torque-free rates, {self.regime} regime ({self.symmetry} body, principal moments "
            f"{', '.join(f'{i:.4g}' for i in self.moments)} kg m^2): |H| = {self.H:.4g} N m s, T = {self.T:.4g} J"
        )
        if self.regime in _CONSTANT_REGIMES:
            return text + ", constant rates"
        text += f", rate period {self.period:.4g} s"
        if self.symmetry == "asymmetric":
            text += f", middle-axis flip every {self.flip_period:.4g} s"
        return text

    def plot(self, t: ArrayLike | None = None) -> Any:
        """Body rates in body and principal axes against time; returns the matplotlib Figure.

        Parameters
        ----------
        t : array_like, optional
            Times [s] (default: two periods of the rates; ten seconds for
            constant rates).
        """
        from matplotlib.figure import Figure

        if t is None:
            span = 2.0 * self.period if math.isfinite(self.period) else 10.0
            t = np.linspace(0.0, span, 801)
        t = _times(t)
        fig = Figure(figsize=(9, 6), layout="constrained")
        ax_b, ax_p = fig.subplots(2, 1, sharex=True)
        for i, name in enumerate("xyz"):
            ax_b.plot(t, self.omega(t)[:, i], label=f"omega_{name}")
        principal = self.omega_principal(t)
        # The dn component keeps its sign s (w1 in the minor regime, w3 in the major one);
        # the sn and cn components swing between -amplitude and +amplitude.
        kept = {"minor": 0, "major": 2}.get(self.regime)
        for i in range(3):
            line = ax_p.plot(t, principal[:, i], label=f"omega_{i + 1} (I{i + 1} = {self.moments[i]:.4g} kg m^2)")[0]
            if kept is not None:
                for sign in (self.sign,) if i == kept else (-1.0, 1.0):
                    ax_p.axhline(sign * self.amplitudes[i], color=line.get_color(), ls=":", lw=0.8)
        ax_b.set_ylabel("body axes [rad/s]")
        ax_p.set_ylabel("principal axes [rad/s]")
        ax_p.set_xlabel("time [s]")
        for ax in (ax_b, ax_p):
            ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8)
            ax.grid(True, alpha=0.3)
        if kept is None:
            title = f"Torque-free body rates (closed form): {self.regime}, constant"
        else:
            title = (
                f"Torque-free body rates (closed form): {self.regime}-axis regime, {self.symmetry} body, "
                f"period {self.period:.4g} s; dotted: amplitudes"
            )
        fig.suptitle(title, fontsize=10)
        return fig

    def omega_principal(self, t: ArrayLike) -> NDArray[np.float64]:
        """Body rates in principal components [rad/s], shape ``(len(t), 3)``.

        Parameters
        ----------
        t : array_like, shape (n,)
            Times since the initial condition [s] (any order, may be negative).
        """
        t = _times(t)
        if self.regime in _CONSTANT_REGIMES:
            return np.tile(self.C_PB @ self.omega0, (t.size, 1))
        sn, cn, dn = jacobi_sncndn(self.lam * t + self.u0, self.mc)
        a, b, c = self.amplitudes
        s = self.sign
        if self.regime == "major":
            return np.stack([a * cn, s * b * sn, s * c * dn], axis=-1)
        return np.stack([s * a * dn, s * b * sn, c * cn], axis=-1)

    def omega(self, t: ArrayLike) -> NDArray[np.float64]:
        """Body rates ``omega_BN_B(t)`` in body components [rad/s], shape ``(len(t), 3)``.

        Parameters
        ----------
        t : array_like, shape (n,)
            Times since the initial condition [s] (any order, may be negative).
        """
        t = _times(t)
        if self.regime in _CONSTANT_REGIMES:
            return np.tile(self.omega0, (t.size, 1))
        return self.omega_principal(t) @ self.C_PB


def torque_free_motion(
    body: RigidBody | ArrayLike, omega0: ArrayLike, *, axisymmetry_rtol: float = AXISYMMETRY_TOLERANCE
) -> TorqueFreeMotion:
    """Exact solution of Euler's equations without torque, from Jacobi elliptic functions.

    Parameters
    ----------
    body : RigidBody or array_like
        A single rigid body, or its principal moments (3,) or inertia tensor
        (3, 3) [kg m^2]. Products of inertia are fine: the solution is built
        in the principal frame and returned in body components.
    omega0 : array_like, shape (3,)
        Initial body rate ``omega_BN_B(0)`` [rad/s].
    axisymmetry_rtol : float, optional
        Principal moments within ``axisymmetry_rtol * I3`` of each other are
        treated as equal (default :data:`AXISYMMETRY_TOLERANCE`).

    Returns
    -------
    TorqueFreeMotion
        Regime, invariants, elliptic parameters and :meth:`TorqueFreeMotion.omega`.

    Raises
    ------
    ValueError
        If ``body`` is not a single valid inertia, ``omega0`` is not a finite
        (3,) vector, or ``omega0`` lies on the separatrix of an asymmetric
        body to :data:`SEPARATRIX_TOLERANCE` (the regime is undecided there).

    Examples
    --------
    >>> motion = torque_free_motion([1.0, 2.0, 3.0], [0.1, 0.0, 1.0])
    >>> motion.regime
    'major'
    >>> bool(np.allclose(motion.omega([0.0])[0], [0.1, 0.0, 1.0]))
    True
    """
    body = _single_body(body)
    omega0 = _rate_vector(omega0)
    rtol = _check_rtol(axisymmetry_rtol)
    axes = body.principal_axes()
    symmetry, moments = _symmetry(axes.moments, rtol)
    c_pb = axes.C_PB
    w_p = c_pb @ omega0
    rate = float(np.linalg.norm(omega0))
    h_mag = float(np.linalg.norm(moments * w_p))
    energy = 0.5 * float(np.dot(w_p, moments * w_p))

    def constant(regime: str) -> TorqueFreeMotion:
        return TorqueFreeMotion(
            regime=regime,
            symmetry=symmetry,
            moments=moments,
            C_PB=c_pb,
            omega0=omega0,
            H=h_mag,
            T=energy,
            m=0.0,
            mc=1.0,
            lam=0.0,
            K=0.5 * math.pi,
            period=math.inf,
            amplitudes=np.abs(w_p),
            sign=1.0,
            u0=0.0,
        )

    if rate == 0.0:
        return constant("rest")
    if symmetry == "sphere":
        return constant("sphere")
    # Work with the unit rate and moments scaled by I3: no overflow or underflow.
    w1, w2, w3 = w_p / rate
    j1, j2, j3 = moments / moments[2]
    groups = {"asymmetric": ((0,), (1,), (2,)), "oblate": ((0, 1), (2,)), "prolate": ((0,), (1, 2))}[symmetry]
    unit = (w1, w2, w3)
    for group in groups:
        off_axis = math.sqrt(sum(unit[i] ** 2 for i in range(3) if i not in group))
        if off_axis <= SPIN_TOLERANCE:
            return constant("principal axis spin")

    fa = math.sqrt(j3 * (j3 - j2))
    fb = math.sqrt(j1 * (j2 - j1))
    d2 = (fa * w3 - fb * w1) * (fa * w3 + fb * w1)
    scale = (fa * w3) ** 2 + (fb * w1) ** 2
    if symmetry == "asymmetric" and abs(d2) <= SEPARATRIX_TOLERANCE * scale:
        raise ValueError(
            "omega0 must not lie on the separatrix H^2 = 2 T I2 of an asymmetric body (the regime is undecided): "
            f"|H^2 - 2 T I2| = {abs(d2) / scale:.3g} * (I3 (I3-I2) w3^2 + I1 (I2-I1) w1^2) in principal axes, "
            f"rule requires > {SEPARATRIX_TOLERANCE:g}; omega0 = {describe(omega0)} rad/s"
        )
    d1 = j2 * (j2 - j1) * w2 * w2 + j3 * (j3 - j1) * w3 * w3
    d3 = j1 * (j3 - j1) * w1 * w1 + j2 * (j3 - j2) * w2 * w2
    jjj = j1 * j2 * j3
    if d2 > 0.0:
        regime = "major"
        sign = math.copysign(1.0, w3)
        amp = np.array([d3 / (j1 * (j3 - j1)), d3 / (j2 * (j3 - j2)), d1 / (j3 * (j3 - j1))])
        lam = math.sqrt((j3 - j2) * d1 / jjj)
        m = (j2 - j1) * d3 / ((j3 - j2) * d1)
        mc = (j3 - j1) * d2 / ((j3 - j2) * d1)
    else:
        regime = "minor"
        sign = math.copysign(1.0, w1)
        amp = np.array([d3 / (j1 * (j3 - j1)), d1 / (j2 * (j2 - j1)), d1 / (j3 * (j3 - j1))])
        lam = math.sqrt((j2 - j1) * d3 / jjj)
        m = (j3 - j2) * d1 / ((j2 - j1) * d3)
        mc = (j3 - j1) * (-d2) / ((j2 - j1) * d3)
    amp = np.sqrt(amp)
    mc = min(max(mc, 0.0), 1.0)
    m = min(max(m, 0.0), 1.0)
    quarter = float(ellipkm1(mc))
    # Initial amplitude: (sn0, cn0) proportional to (s w2 / B, w1 / A) or (s w2 / B, w3 / C).
    if regime == "major":
        y, x = sign * w2 * amp[0], w1 * amp[1]
    else:
        y, x = sign * w2 * amp[2], w3 * amp[1]
    norm = math.hypot(x, y)
    u0 = _argument_of(y / norm, x / norm, mc, quarter)
    lam_si = lam * rate
    return TorqueFreeMotion(
        regime=regime,
        symmetry=symmetry,
        moments=moments,
        C_PB=c_pb,
        omega0=omega0,
        H=h_mag,
        T=energy,
        m=m,
        mc=mc,
        lam=lam_si,
        K=quarter,
        period=4.0 * quarter / lam_si,
        amplitudes=amp * rate,
        sign=sign,
        u0=u0,
    )


# ---------------------------------------------------------------------------
# Middle-axis instability
# ---------------------------------------------------------------------------


def intermediate_axis_growth_rate(body: RigidBody | ArrayLike, omega2: ArrayLike) -> float | NDArray[np.float64]:
    """Linear growth rate of a perturbed spin about the middle principal axis.

    For a spin ``omega2`` about the middle axis, small perturbations
    ``w1, w3`` grow like ``exp(k t)`` with

    .. math:: k = |\\omega_2| \\sqrt{(I_2 - I_1)(I_3 - I_2) / (I_1 I_3)}.

    Parameters
    ----------
    body : RigidBody or array_like
        A single rigid body or its inertia [kg m^2].
    omega2 : float or array_like
        Spin rate about the middle principal axis [rad/s].

    Returns
    -------
    float or ndarray
        ``k`` [1/s], the shape of ``omega2`` (0 for an axisymmetric body).

    Raises
    ------
    ValueError
        If ``body`` is invalid or ``omega2`` is not finite.
    """
    body = _single_body(body)
    w2 = as_float_array(omega2, "omega2")
    i1, i2, i3 = body.principal_axes().moments
    k = np.abs(w2) * math.sqrt(max(i2 - i1, 0.0) * max(i3 - i2, 0.0) / (i1 * i3))
    return float(k) if k.ndim == 0 else k


def flip_period(
    body: RigidBody | ArrayLike, omega0: ArrayLike, *, axisymmetry_rtol: float = AXISYMMETRY_TOLERANCE
) -> float:
    """Exact time between successive flips (sign reversals of the middle-axis rate) [s].

    The middle principal rate is ``w2 = s B sn(lam t + u0)`` in both regimes,
    so it reverses sign every half period of ``sn``: ``T_flip = 2 K(m) / lam``.

    For a spin ``W`` about the middle axis perturbed by a small ``eps``
    (relative), ``1 - m = O(eps^2)``, ``lam -> k`` (the linear growth rate of
    :func:`intermediate_axis_growth_rate`) and ``K(m) = ln(4 / sqrt(1 - m)) +
    O((1 - m) ln(1 - m))``, so

    .. math:: T_{flip} \\approx \\ln(16 / (1 - m)) / k = (2 \\ln(1/\\varepsilon) + O(1)) / k:

    each flip is one escape from the ``eps``-neighbourhood of the axis at the
    linear rate ``k`` (time ``ln(1/eps)/k``) plus one mirror-image approach to
    the opposite direction (another ``ln(1/eps)/k``). Halving ``eps`` adds
    ``2 ln 2 / k`` to the flip period; it diverges only logarithmically.

    Parameters
    ----------
    body : RigidBody or array_like
        A single rigid body with three distinct principal moments [kg m^2].
    omega0 : array_like, shape (3,)
        Initial body rate [rad/s], body components.
    axisymmetry_rtol : float, optional
        Tolerance for equal moments (default :data:`AXISYMMETRY_TOLERANCE`).

    Returns
    -------
    float
        ``2 K / lam`` [s]; ``inf`` for a pure principal-axis spin (constant
        rates never flip).

    Raises
    ------
    ValueError
        If the body has no distinct middle axis (axisymmetric or sphere), or
        for the reasons of :func:`torque_free_motion` (bad input, separatrix).
    """
    motion = torque_free_motion(body, omega0, axisymmetry_rtol=axisymmetry_rtol)
    if motion.symmetry != "asymmetric":
        raise ValueError(
            "body must have three distinct principal moments for a middle-axis flip; "
            f"principal moments {describe(motion.moments)} kg m^2 are {motion.symmetry} "
            f"(equal to within axisymmetry_rtol = {axisymmetry_rtol:g} of I3)"
        )
    return motion.flip_period


# ---------------------------------------------------------------------------
# Axisymmetric free precession
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class AxisymmetricPrecession(ResultIO):
    """Exact free precession of an axisymmetric body (see :func:`axisymmetric_precession`).

    Rates and attitude. :meth:`plot`, ``save(path)`` / ``load(path)`` (``.npz``).

    Attributes
    ----------
    t : ndarray, shape (n,)
        Times [s].
    q : ndarray, shape (n, 4)
        Attitude ``q_BN(t)`` (scalar first).
    omega : ndarray, shape (n, 3)
        Body rates ``omega_BN_B(t)`` [rad/s].
    body_precession_rate : float
        ``lam = (Is - It) / It * ws`` [rad/s]: the transverse rate circles the
        symmetry axis at this rate *in the body frame* (right-handed about
        ``symmetry_axis_B``; positive, i.e. with the spin, for an oblate body,
        negative for a prolate one). Also called the body nutation rate.
    inertial_precession_rate : float
        ``H / It`` [rad/s]: the symmetry axis and the rate vector cone about
        the inertial angular momentum at this rate.
    nutation_angle : float
        Constant angle between the symmetry axis and the angular momentum
        [rad], in ``[0, pi/2]``.
    symmetry_axis_B : ndarray, shape (3,)
        Unit symmetry axis in body components, oriented so that the spin
        ``ws = omega . symmetry_axis_B >= 0``.
    angular_momentum_N : ndarray, shape (3,)
        Constant angular momentum in inertial components [N m s].
    symmetry_moment, transverse_moment : float
        ``Is`` and ``It`` [kg m^2].
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    omega: NDArray[np.float64]
    body_precession_rate: float
    inertial_precession_rate: float
    nutation_angle: float
    symmetry_axis_B: NDArray[np.float64]
    angular_momentum_N: NDArray[np.float64]
    symmetry_moment: float
    transverse_moment: float

    def plot(self) -> Any:
        """Body rates and attitude quaternion against time; returns the matplotlib Figure."""
        from matplotlib.figure import Figure

        fig = Figure(figsize=(8, 6))
        ax_w, ax_q = fig.subplots(2, 1, sharex=True)
        for i, name in enumerate("xyz"):
            ax_w.plot(self.t, self.omega[:, i], label=f"omega_{name}")
        ax_w.set_ylabel("body rate [rad/s]")
        ax_w.legend(loc="upper right")
        for i, name in enumerate("wxyz"):
            ax_q.plot(self.t, self.q[:, i], label=f"q_{name}")
        ax_q.set_ylabel("q_BN")
        ax_q.set_xlabel("time [s]")
        ax_q.legend(loc="upper right")
        fig.suptitle(
            f"free precession: body rate {self.body_precession_rate:.4g} rad/s, "
            f"inertial rate {self.inertial_precession_rate:.4g} rad/s, "
            f"nutation {np.degrees(self.nutation_angle):.3g} deg"
        )
        return fig


def axisymmetric_precession(
    body: RigidBody | ArrayLike,
    q0: ArrayLike,
    omega0: ArrayLike,
    t: ArrayLike,
    *,
    axisymmetry_rtol: float = AXISYMMETRY_TOLERANCE,
) -> AxisymmetricPrecession:
    """Closed-form attitude and rates of a torque-free axisymmetric body.

    With ``e`` the symmetry axis (moment ``Is``), ``It`` the transverse
    moment and ``ws = omega . e``, the body angular momentum is
    ``H_B = It omega + (Is - It) ws e``, so

    .. math:: \\omega = (H / I_t)\\, h_B - \\lambda e,
              \\qquad \\lambda = (I_s - I_t) / I_t \\; \\omega_s

    (``h`` the unit angular momentum): a rotation at ``H/It`` about the
    inertially fixed ``h`` composed with one at ``-lam`` about the body-fixed
    ``e``. Hence

    .. math:: q(t) = q_{rot}(h_N, (H/I_t)\\, t) \\otimes q_0 \\otimes q_{rot}(e, -\\lambda t),

    and in the body frame the transverse rate turns about ``e`` at ``+lam``.

    Parameters
    ----------
    body : RigidBody or array_like
        A single axisymmetric rigid body (or its inertia) [kg m^2]; the
        symmetry axis is found from the principal moments (the odd one out). A
        sphere is accepted (every axis is a symmetry axis: ``e`` is taken along
        ``omega0`` and ``lam = 0``).
    q0 : array_like, shape (4,)
        Initial attitude ``q_BN`` (scalar first, unit norm).
    omega0 : array_like, shape (3,)
        Initial body rate [rad/s].
    t : array_like, shape (n,)
        Times [s] (any order).
    axisymmetry_rtol : float, optional
        Two principal moments within ``axisymmetry_rtol * I3`` count as equal
        (default :data:`AXISYMMETRY_TOLERANCE`); the model then uses their
        mean.

    Returns
    -------
    AxisymmetricPrecession

    Raises
    ------
    ValueError
        If the body is not axisymmetric, or ``q0``, ``omega0``, ``t`` are
        invalid.
    """
    body = _single_body(body)
    rtol = _check_rtol(axisymmetry_rtol)
    q0 = quat.as_unit_quaternion(q0, "q0")
    if q0.ndim != 1:
        raise ValueError(f"q0 must be a single quaternion of shape (4,), got shape {q0.shape}")
    omega0 = _rate_vector(omega0)
    t = _times(t)
    axes = body.principal_axes()
    symmetry, moments = _symmetry(axes.moments, rtol)
    if symmetry == "asymmetric":
        raise ValueError(
            "body must be axisymmetric (two principal moments equal to within "
            f"axisymmetry_rtol * I3 = {rtol:g} * I3); principal moments are {describe(axes.moments)} kg m^2"
        )
    rate = float(np.linalg.norm(omega0))
    if symmetry == "sphere":
        e = omega0 / rate if rate > 0.0 else axes.axes_B[:, 2]
        i_s = i_t = float(moments[0])
    elif symmetry == "oblate":
        e, i_s, i_t = axes.axes_B[:, 2], float(moments[2]), float(moments[0])
    else:
        e, i_s, i_t = axes.axes_B[:, 0], float(moments[0]), float(moments[2])
    e = np.array(e, dtype=float)
    w_s = float(np.dot(omega0, e))
    if w_s < 0.0:
        e, w_s = -e, -w_s
    w_t = omega0 - w_s * e
    h_b = i_t * omega0 + (i_s - i_t) * w_s * e
    h_mag = float(np.linalg.norm(h_b))
    lam = (i_s - i_t) / i_t * w_s
    cone = h_mag / i_t
    h_n = quat.rotate(q0, h_b)
    h_axis = h_n / h_mag if h_mag > 0.0 else quat.rotate(q0, e)
    q = quat.multiply(quat.multiply(quat.from_axis_angle(h_axis, cone * t), q0), quat.from_axis_angle(e, -lam * t))
    h_hat_b = h_b / h_mag if h_mag > 0.0 else np.zeros(3)
    omega = cone * quat.rotate(quat.from_axis_angle(e, lam * t), h_hat_b) - lam * e
    nutation = math.atan2(i_t * float(np.linalg.norm(w_t)), i_s * w_s)
    return AxisymmetricPrecession(
        t=t.copy(),
        q=q,
        omega=omega,
        body_precession_rate=lam,
        inertial_precession_rate=cone,
        nutation_angle=nutation,
        symmetry_axis_B=e,
        angular_momentum_N=h_n,
        symmetry_moment=i_s,
        transverse_moment=i_t,
    )


def earth_euler_period(spin_rate: float = EARTH_ROTATION_RATE) -> float:
    """Euler's free-precession (rigid-Earth Chandler) period [s].

    A rigid Earth with moments :data:`EARTH_PRINCIPAL_MOMENTS` spinning at
    ``spin_rate`` would see its rotation axis circle the figure axis, in
    Earth-fixed axes, at ``lam = (C - A) / A * spin_rate``
    (:attr:`AxisymmetricPrecession.body_precession_rate`). Its period
    ``A / (C - A)`` rotations is 304.5 sidereal days (2.623e7 s, 303.6 mean
    solar days of 86400 s): Euler's "about 305 days". The observed Chandler
    wobble is ~433 days, lengthened by the elastic mantle and the oceans.

    Parameters
    ----------
    spin_rate : float, optional
        Rotation rate [rad/s] (default :data:`EARTH_ROTATION_RATE`).

    Returns
    -------
    float
        ``2 pi / |lam|`` [s].
    """
    arr = as_float_array(spin_rate, "spin_rate")
    if arr.ndim != 0 or float(arr) <= 0.0:
        raise ValueError(f"spin_rate must be a positive rotation rate [rad/s], got {describe(arr)}")
    rate = float(arr)
    motion = axisymmetric_precession(EARTH_PRINCIPAL_MOMENTS, quat.identity(), [0.0, 0.0, rate], [0.0])
    return 2.0 * math.pi / abs(motion.body_precession_rate)

"""Keep-out cones of the slew planner: the cone, its between-checkpoint bound, and a blocked-path check.

Part of :mod:`controllers.slew.planner` (import the public names from there).

A boresight ``b_B`` must stay outside a cone about an inertial direction
``s_N``; the planner imposes the cone at checkpoints with a second-order
margin ``M eta^2 / 8`` (``M`` a bound on the boresight acceleration) that
keeps the path between checkpoints out too, and a sphere-grid check proves
when the cones leave no path at all.

See docs/keep_out.md for the derivation of the bound and of the blocked-path
check.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from attitude import quaternion as quat
from attitude.backend import cross
from attitude.rigid_body import RigidBody
from attitude.validation import as_float_array, describe

__all__ = ["SPEED_EPS", "KeepOutCone", "blocked_boresights", "cone_rows"]

#: Regularisation of the norms in the bound ``M`` (``sqrt(x . x + eps^2)``,
#: nondimensional units of 1/T_s and 1/T_s^2): keeps them differentiable at
#: rest and only enlarges ``M``, by less than ``eps (1 + eps + |omega| + |omega x b|)``.
SPEED_EPS = 1e-3

#: Cell size [deg] of the blocked-path check (a 360 x 720 grid: a few ms).
BLOCKED_CHECK_CELL_DEG = 0.5


@dataclass(frozen=True)
class KeepOutCone:
    """A body-fixed boresight that must stay away from an inertial direction.

    Parameters
    ----------
    boresight_B : array_like (3,)
        Body-fixed boresight (e.g. a star-tracker axis), body components;
        normalised here.
    direction_N : array_like (3,)
        Inertial direction to avoid (e.g. the Sun), inertial components;
        normalised here.
    half_angle : float
        Smallest allowed angle between the two [rad], in ``(0, pi)``.
    name : str
        Label for plots and messages.

    Examples
    --------
    >>> sun = KeepOutCone.from_degrees([0, 0, 1], [1, 0, 0], half_angle_deg=30.0, name="sun")
    """

    boresight_B: NDArray[np.float64]
    direction_N: NDArray[np.float64]
    half_angle: float
    name: str = ""

    def __post_init__(self) -> None:
        for attr in ("boresight_B", "direction_N"):
            v = as_float_array(getattr(self, attr), attr)
            if v.shape != (3,):
                raise ValueError(f"KeepOutCone {attr} must have shape (3,), got shape {v.shape}")
            n = float(np.linalg.norm(v))
            if n == 0.0:
                raise ValueError(f"KeepOutCone {attr} must be a non-zero vector, got {describe(v)}")
            object.__setattr__(self, attr, v / n)
        angle = float(as_float_array(self.half_angle, "half_angle"))
        if not 0.0 < angle < math.pi:
            raise ValueError(f"KeepOutCone half_angle must lie in (0, pi) rad, got {angle!r}")
        object.__setattr__(self, "half_angle", angle)

    @classmethod
    def from_degrees(
        cls, boresight_B: ArrayLike, direction_N: ArrayLike, half_angle_deg: float, name: str = ""
    ) -> KeepOutCone:
        """Build a cone from a half angle in degrees.

        Parameters
        ----------
        boresight_B : array_like (3,)
            Body-fixed boresight, body components (any non-zero length).
        direction_N : array_like (3,)
            Inertial direction to avoid, inertial components (any non-zero length).
        half_angle_deg : float
            Smallest allowed angle between the two [deg], in ``(0, 180)``.
        name : str
            Label for plots and messages.

        Returns
        -------
        KeepOutCone
            The cone with its half angle in radians.

        Raises
        ------
        ValueError
            If a vector is zero or not of shape (3,), or the half angle is
            not finite or outside ``(0, 180)`` deg.
        """
        return cls(
            np.asarray(boresight_B, dtype=float),
            np.asarray(direction_N, dtype=float),
            math.radians(float(as_float_array(half_angle_deg, "half_angle_deg"))),
            name,
        )

    def separation(self, q: ArrayLike) -> NDArray[np.float64]:
        """Angle [rad] between the boresight and the avoided direction at attitudes ``q_BN`` (..., 4).

        Parameters
        ----------
        q : array_like
            Attitudes ``q_BN``, shape (..., 4).
        """
        return quat.unit_vector_angle(quat.rotate(quat.normalize(q), self.boresight_B), self.direction_N)


def _norm(v: Sequence[Any]) -> Any:
    """Regularised Euclidean norm of 3 casadi components (:data:`SPEED_EPS`)."""
    return ca.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + SPEED_EPS**2)


def _checkpoint(body_s: RigidBody, x: Any, u: Any, cone: KeepOutCone) -> tuple[Any, Any, Any]:
    """``(f, f', M)`` of one cone at a state ``x`` (7) under the torque ``u`` (3), nondimensional."""
    q = [x[i] for i in range(4)]
    w = [x[i] for i in range(4, 7)]
    b = [float(c) for c in cone.boresight_B]
    s_b = quat.rotate_inverse_components(q, [float(c) for c in cone.direction_N])  # R^T s_N
    w_x_b = cross(w, b)
    w_dot = body_s.omega_dot_components(w, [u[i] for i in range(3)])
    f = sum(bi * si for bi, si in zip(b, s_b))
    f_dot = sum(a * si for a, si in zip(w_x_b, s_b))
    bound = _norm(w) * _norm(w_x_b) + _norm(cross(w_dot, b))
    return f, f_dot, bound


@dataclass(frozen=True)
class ConeRows:
    """Keep-out constraints (``<= 0``) of one multiple-shooting interval.

    ``inner`` holds the rows of every sub-step treated as free at both ends;
    ``first_drop`` / ``last_drop`` index the rows to leave out on the first
    / last interval of the slew, whose first / last sub-step touches a fixed
    end and is covered by ``from_start`` / ``from_end`` instead (empty
    without the margin: the fixed checkpoint is then simply not constrained).
    """

    inner: Any
    from_start: Any
    from_end: Any
    first_drop: tuple[int, ...]
    last_drop: tuple[int, ...]


def cone_rows(
    body_s: RigidBody, points: Sequence[Any], u: Any, eta: Any, cones: Sequence[KeepOutCone], *, margin: bool = True
) -> ConeRows:
    """Keep-out constraints at the checkpoints ``points`` (m + 1 states) of one interval (docs/keep_out.md).

    Parameters
    ----------
    body_s : RigidBody
        The nondimensional body.
    points : sequence of casadi vectors (7)
        States at the sub-step boundaries of the interval, first and last
        included.
    u : casadi vector (3)
        Torque held over the interval (nondimensional).
    eta : casadi scalar
        Sub-step length (nondimensional).
    cones : sequence of KeepOutCone
        The cones.
    margin : bool
        Apply the between-checkpoint bound; False constrains the checkpoints
        only (the path may then cut the corner of a cone between them).

    Returns
    -------
    ConeRows
        The constraint rows.
    """
    m = len(points) - 1
    # Rows per cone: (checkpoint j, bound of checkpoint k) for |j - k| <= 1 with margin, (j, j) without.
    pairs = [(j, k) for j in range(m + 1) for k in (j - 1, j, j + 1) if 0 <= k <= m and (margin or k == j)]
    first_drop = [i for i, (j, k) in enumerate(pairs) if j == 0 or (margin and (j, k) == (1, 0))]
    last_drop = [i for i, (j, k) in enumerate(pairs) if j == m or (margin and (j, k) == (m - 1, m))]
    inner, start, end = [], [], []
    for cone in cones:
        cos_a = math.cos(cone.half_angle)
        terms = [_checkpoint(body_s, p, u, cone) for p in points]
        f = [t[0] for t in terms]
        k2 = eta * eta / 8.0 if margin else 0.0
        inner += [f[j] + k2 * terms[k][2] - cos_a for j, k in pairs]
        if margin:
            # Taylor bound from a fixed end over the adjacent sub-step, with M at both of its checkpoints.
            f0, fd0 = terms[0][0], terms[0][1]
            fm, fdm = terms[m][0], terms[m][1]
            start += [f0 + fd0 * eta + 0.5 * eta * eta * terms[k][2] - cos_a for k in (0, 1)]
            end += [fm - fdm * eta + 0.5 * eta * eta * terms[k][2] - cos_a for k in (m - 1, m)]
    return ConeRows(
        inner=ca.vertcat(*inner),
        from_start=ca.vertcat(*start) if start else ca.SX(0, 1),
        from_end=ca.vertcat(*end) if end else ca.SX(0, 1),
        first_drop=tuple(first_drop),
        last_drop=tuple(last_drop),
    )


def blocked_boresights(
    cones: Sequence[KeepOutCone],
    q0: NDArray[np.float64],
    qf: NDArray[np.float64],
    cell_deg: float = BLOCKED_CHECK_CELL_DEG,
) -> list[dict[str, Any]]:
    """Boresights whose cones provably separate their initial and final directions (docs/keep_out.md).

    Parameters
    ----------
    cones : sequence of KeepOutCone
        The cones (grouped here by boresight).
    q0, qf : ndarray (4,)
        Initial and final attitude ``q_BN``.
    cell_deg : float
        Cell size of the sphere grid [deg].

    Returns
    -------
    list of dict
        One entry per blocked boresight: ``boresight_B``, the indices and
        names of its cones. Empty when no boresight is provably blocked.
    """
    groups: dict[tuple[float, ...], list[int]] = {}
    for i, cone in enumerate(cones):
        groups.setdefault(tuple(np.round(cone.boresight_B, 12)), []).append(i)
    blocked = []
    for idx in groups.values():
        b = cones[idx[0]].boresight_B
        start, end = quat.rotate(q0, b), quat.rotate(qf, b)
        group = [cones[i] for i in idx]
        if not _reachable(start, end, group, cell_deg):
            blocked.append(
                {"boresight_B": b.tolist(), "cones": idx, "names": [cones[i].name or f"keep_out[{i}]" for i in idx]}
            )
    return blocked


def _reachable(start: NDArray, end: NDArray, cones: Sequence[KeepOutCone], cell_deg: float) -> bool:
    """False only if no path on the sphere from ``start`` to ``end`` avoids the cones' interiors."""
    n_t = max(4, math.ceil(180.0 / cell_deg))
    n_p = 2 * n_t
    d = math.pi / n_t  # cell size in colatitude and longitude
    theta = (np.arange(n_t) + 0.5) * d
    phi = (np.arange(n_p) + 0.5) * d
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    centres = np.stack(np.broadcast_arrays(st * np.cos(phi), st * np.sin(phi), ct), axis=-1)
    # Any point of a cell is within d/2 (along the meridian) + d/2 (along the parallel) of its centre.
    radius = d
    blocked = np.zeros((n_t, n_p), dtype=bool)
    for cone in cones:
        dist = quat.unit_vector_angle(centres, cone.direction_N)
        blocked |= dist + radius < cone.half_angle
    labels, count = ndimage.label(~blocked, structure=np.ones((3, 3), dtype=int))
    parent = list(range(count + 1))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    def union(a: int, b: int) -> None:
        if a and b:
            parent[find(a)] = find(b)

    for i in range(n_t):  # across the date line, edges and corners
        for di in (-1, 0, 1):
            if 0 <= i + di < n_t:
                union(int(labels[i, 0]), int(labels[i + di, -1]))
    for row in (0, n_t - 1):  # every cell of the first and last row touches its pole
        ids = [int(v) for v in np.unique(labels[row]) if v]
        for a in ids[1:]:
            union(a, ids[0])

    def cell(v: NDArray) -> int:
        t = math.acos(max(-1.0, min(1.0, float(v[2]))))
        p = math.atan2(float(v[1]), float(v[0])) % (2.0 * math.pi)
        return int(labels[min(int(t / d), n_t - 1), min(int(p / d), n_p - 1)])

    a, b = cell(start), cell(end)
    if not a or not b:  # cannot happen for directions outside the cones; never claim a block then
        return True
    return find(a) == find(b)

"""Two-vector alignment: the frame against scipy's ``Rotation.align_vectors``, the geometry, the singularities.

* With an infinite weight on the primary pair, ``scipy.spatial.transform.Rotation.align_vectors``
  aligns the primary exactly and the secondary as closely as possible (scipy >= 1.11, the
  documented "primary/secondary" case): an independent solution of the same problem (Markley and
  Crassidis 2014, sec. 5.2, TRIAD).
* The primary body axis lands exactly on the primary direction; the secondary body axis lands in
  the plane of the two directions, on the secondary's side.
* Parallel directions or parallel body axes are refused with a ValueError naming the argument.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude import quaternion as quat
from controllers.guidance import VectorAlignmentReference, VectorTrack, align_two_vectors, body_triad
from controllers.guidance.directions import constant_direction

RNG = np.random.default_rng(20260320)


def _track(v):
    v = np.atleast_2d(v)
    return VectorTrack(v, np.zeros_like(v), np.zeros_like(v))


@pytest.mark.parametrize("k", range(8))
def test_frame_matches_scipy_align_vectors_with_the_primary_weighted_infinitely(k):
    b1, b2, p, s = RNG.normal(size=(4, 3))
    q, _, _ = align_two_vectors(body_triad(b1, b2), _track(p), _track(s))
    expected, _ = Rotation.align_vectors([p, s], [b1, b2], weights=[np.inf, 1.0])
    # Both are exact constructions in double precision: agreement to rounding (a few 1e-16 on a
    # unit quaternion, up to sign).
    np.testing.assert_allclose(quat.shortest(q[0]), quat.shortest(expected.as_quat(scalar_first=True)), atol=1e-14)


def test_primary_axis_exactly_on_target_and_secondary_in_the_plane_on_its_side():
    b1, b2 = np.array([0.0, 0.0, 2.0]), np.array([1.0, 1.0, 0.3])
    p, s = RNG.normal(size=(50, 3)), RNG.normal(size=(50, 3))
    q, _, _ = align_two_vectors(body_triad(b1, b2), _track(p), _track(s))
    p_hat = p / np.linalg.norm(p, axis=1, keepdims=True)
    # Rounding of a rotation applied to a unit vector: a few ulps.
    np.testing.assert_allclose(quat.rotate(q, b1 / 2.0), p_hat, atol=1e-15 * 8)
    b2_N = quat.rotate(q, b2)
    normal = np.cross(p, s)
    np.testing.assert_allclose(np.sum(b2_N * normal, axis=1) / np.linalg.norm(normal, axis=1), 0.0, atol=1e-14)
    s_perp = s - np.sum(s * p_hat, axis=1, keepdims=True) * p_hat
    assert np.all(np.sum(b2_N * s_perp, axis=1) > 0.0)
    # With orthogonal body axes the secondary lands exactly on s's component across p.
    q2, _, _ = align_two_vectors(body_triad([1.0, 0, 0], [0, 1.0, 0]), _track(p), _track(s))
    np.testing.assert_allclose(
        quat.rotate(q2, [0.0, 1.0, 0.0]), s_perp / np.linalg.norm(s_perp, axis=1, keepdims=True), atol=1e-14
    )


def test_parallel_directions_are_refused_with_the_times_not_nan():
    ref = VectorAlignmentReference(
        [0, 0, 1.0], constant_direction([1.0, 0, 0]), [0, 1.0, 0], constant_direction([1.0, 1e-3, 0.0])
    )
    with pytest.raises(ValueError, match=r"separation_min = .* from parallel.*at t = "):
        ref.samples([0.0, 1.0])
    # Just outside the limit it is flown (2 deg apart, default limit 1 deg).
    ok = VectorAlignmentReference(
        [0, 0, 1.0], constant_direction([1.0, 0, 0]), [0, 1.0, 0], constant_direction([1.0, np.tan(0.035), 0.0])
    )
    q, w, w_dot = ok.samples([0.0])
    assert np.all(np.isfinite(q)) and np.all(w == 0.0) and np.all(w_dot == 0.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"primary_axis_B": [0, 0, 1.0], "secondary_axis_B": [0, 0, -3.0]}, "primary_axis_B and secondary_axis_B"),
        ({"primary_axis_B": [0, 0, 0.0], "secondary_axis_B": [0, 1.0, 0]}, "primary_axis_B must be one non-zero"),
        ({"primary_axis_B": [0, 1.0], "secondary_axis_B": [0, 1.0, 0]}, r"primary_axis_B must have shape"),
    ],
)
def test_bad_body_axes_are_refused_by_name(kwargs, match):
    with pytest.raises(ValueError, match=match):
        VectorAlignmentReference(
            kwargs["primary_axis_B"], constant_direction([1.0, 0, 0]), kwargs["secondary_axis_B"],
            constant_direction([0, 1.0, 0]),
        )  # fmt: skip


def test_zero_direction_and_bad_separation_are_refused_by_name():
    with pytest.raises(ValueError, match=r"primary.vector must be non-zero"):
        align_two_vectors(body_triad([0, 0, 1.0], [0, 1.0, 0]), _track([0.0, 0, 0]), _track([0, 1.0, 0]))
    with pytest.raises(ValueError, match="separation_min"):
        VectorAlignmentReference(
            [0, 0, 1.0], constant_direction([1.0, 0, 0]), [0, 1.0, 0], constant_direction([0, 1.0, 0]),
            separation_min=-1.0,
        )  # fmt: skip
    with pytest.raises(ValueError, match="secondary must be a callable"):
        VectorAlignmentReference([0, 0, 1.0], constant_direction([1.0, 0, 0]), [0, 1.0, 0], [0, 1.0, 0])

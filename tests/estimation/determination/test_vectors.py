"""Bad input to the static attitude solvers: ValueErrors that name the argument, the rule and the value.

Also the observability measure against its closed forms for two directions
(``(1 - c^2) / (5 - c^2)``) and an isotropic set (2/9), and its bracket on the
smallest eigenvalue of the information matrix (``numpy.linalg.eigvalsh``).
"""

import numpy as np
import pytest

from estimation import q_method, quest, triad
from estimation.determination import observability, triad_covariance, wahba_covariance
from estimation.determination.vectors import information_matrix

B = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
N = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


@pytest.mark.parametrize("solver", [quest, q_method])
class TestWahbaSolvers:
    def test_zero_vector(self, solver):
        with pytest.raises(ValueError, match=r"vectors_B must be non-zero directions; the vector at index \(1,\)"):
            solver([[0, 0, 1], [0, 0, 0]], N)

    def test_non_finite_vector(self, solver):
        with pytest.raises(ValueError, match=r"vectors_N must be finite.*nan"):
            solver(B, [[1, 0, 0], [np.nan, 1, 0]])

    def test_parallel_vectors(self, solver):
        with pytest.raises(ValueError, match=r"vectors_B must hold at least two non-parallel.*observability 0"):
            solver([[0, 0, 1], [0, 0, 2]], N)
        with pytest.raises(ValueError, match=r"vectors_N must hold at least two non-parallel"):
            solver(B, [[1, 0, 0], [-1, 0, 0]])  # antiparallel is parallel too

    def test_one_pair_is_not_enough(self, solver):
        with pytest.raises(ValueError, match=r"vectors_B must have shape \(\.\.\., m, 3\) with at least 2.*\(1, 3\)"):
            solver(B[:1], N[:1])

    def test_weights_not_positive(self, solver):
        with pytest.raises(ValueError, match=r"weights must be strictly positive, got \[ 1\. -1\.\]"):
            solver(B, N, weights=[1.0, -1.0])
        with pytest.raises(ValueError, match=r"weights must be strictly positive, got \[1\. 0\.\]"):
            solver(B, N, weights=[1.0, 0.0])
        with pytest.raises(ValueError, match=r"sigma must be strictly positive"):
            solver(B, N, sigma=[1e-3, 0.0])
        with pytest.raises(ValueError, match=r"weights must be finite"):
            solver(B, N, weights=[1.0, np.inf])

    def test_weights_and_sigma_are_exclusive(self, solver):
        with pytest.raises(ValueError, match="give weights or sigma, not both"):
            solver(B, N, weights=[1.0, 1.0], sigma=[1e-3, 1e-3])

    def test_mismatched_shapes(self, solver):
        with pytest.raises(
            ValueError, match=r"vectors_B and vectors_N must have broadcastable shapes.*\(2, 3\).*\(3, 3\)"
        ):
            solver(B, np.vstack([N, [[0, 0, 1]]]))
        with pytest.raises(ValueError, match=r"weights must have one entry per vector pair.*got shape \(3,\)"):
            solver(B, N, weights=[1.0, 1.0, 1.0])
        with pytest.raises(ValueError, match=r"vectors_B must have shape \(\.\.\., 3\), got shape \(2, 2\)"):
            solver(B[:, :2], N)


class TestTriad:
    def test_parallel_or_antiparallel(self):
        with pytest.raises(ValueError, match=r"primary_B and secondary_B must not be parallel.*sine 0"):
            triad([0, 0, 1], [1, 0, 0], [0, 0, 3], [0, 1, 0])
        with pytest.raises(ValueError, match=r"primary_N and secondary_N must not be parallel"):
            triad([0, 0, 1], [1, 0, 0], [1, 0, 0], [-1, 0, 0])

    def test_zero_and_non_finite(self):
        with pytest.raises(ValueError, match="secondary_N must be non-zero directions"):
            triad([0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 0, 0])
        with pytest.raises(ValueError, match="primary_B must be finite"):
            triad([0, np.inf, 1], [1, 0, 0], [1, 0, 0], [0, 1, 0])

    def test_sigmas(self):
        with pytest.raises(ValueError, match="give both sigma_primary and sigma_secondary"):
            triad([0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 1, 0], sigma_primary=1e-3)
        with pytest.raises(ValueError, match=r"sigma_secondary must be strictly positive, got -0\.001"):
            triad([0, 0, 1], [1, 0, 0], [1, 0, 0], [0, 1, 0], sigma_primary=1e-3, sigma_secondary=-1e-3)

    def test_mismatched_shapes(self):
        with pytest.raises(ValueError, match=r"primary_B and secondary_B must have broadcastable shapes"):
            triad(np.ones((2, 3)), [1, 0, 0], np.ones((3, 3)), [0, 1, 0])


def test_covariance_bad_input():
    with pytest.raises(ValueError, match="vectors_B must hold at least two non-parallel directions"):
        wahba_covariance([[0, 0, 1], [0, 0, -1]], [1e-3, 1e-3])
    with pytest.raises(ValueError, match="sigma must be strictly positive"):
        wahba_covariance(B, [1e-3, -1.0])
    with pytest.raises(ValueError, match="primary_B and secondary_B must not be parallel"):
        triad_covariance([0, 0, 1], [0, 0, 2], 1e-3, 1e-3)


def test_observability_closed_forms_and_bracket():
    rng = np.random.default_rng(30)
    theta = rng.uniform(0, np.pi, 100)
    pairs = np.stack(
        [np.broadcast_to([1.0, 0, 0], (100, 3)), np.stack([np.cos(theta), np.sin(theta), 0 * theta], -1)], 1
    )
    c = np.cos(theta)
    np.testing.assert_allclose(observability(pairs, np.ones((100, 2))), (1 - c**2) / (5 - c**2), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(observability(np.eye(3), np.ones(3)), 2 / 9, rtol=1e-15)  # F = 2 I, sum a = 3
    b = rng.standard_normal((500, 4, 3))
    b /= np.linalg.norm(b, axis=-1, keepdims=True)
    a = rng.uniform(0.01, 1.0, (500, 4))
    lowest = np.linalg.eigvalsh(information_matrix(b, a))[..., 0] / a.sum(-1)
    rho = observability(b, a)
    assert np.all((rho <= lowest * (1 + 1e-12)) & (rho >= lowest / 3 * (1 - 1e-12)))

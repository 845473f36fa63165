"""QUEST and Davenport's q method: exact on noise-free vectors, the ahrs package, the covariance by Monte Carlo.

What each test checks against:

* noise-free vectors: the true attitude (Wahba's loss is zero there, so it is
  the unique optimum; Markley and Crassidis, *Fundamentals of Spacecraft
  Attitude Determination and Control*, 2014, ch. 5, Wahba's problem);
* the ``ahrs`` package (0.4), an independent implementation of Shuster's
  QUEST (its Newton iteration and Gibbs-vector formula) and of Davenport's q
  method (``numpy.linalg.eig``). Its ``estimate`` returns the scalar-first
  quaternion of the textbook's attitude matrix ``A = C_BN``, which is this
  package's ``q_BN`` itself (not the conjugate; checked on noise-free
  vectors below). It takes two vector pairs, the body ones as ``acc`` and
  ``mag`` and the references in ``g_q`` and ``m_q``;
* the covariance ``[sum sigma_i^-2 (I - b_i b_i^T)]^-1`` (Shuster and Oh, J.
  Guidance and Control 4(1), 1981) against the scatter of 2,000 estimates
  from noisy draws of the QUEST measurement model, bounded by chi-square
  quantiles (scipy.stats.chi2).
"""

import numpy as np
import pytest
from ahrs.filters import QUEST as AhrsQuest
from ahrs.filters import Davenport as AhrsDavenport
from scipy.stats import chi2

from attitude import quaternion as quat
from estimation import q_method, quest
from estimation.determination import observability, wahba_covariance
from estimation.determination.quest import QUEST_RHO_MIN

EPS = np.finfo(float).eps


def noise_free(rng, n, m):
    """Random attitudes (n,), random reference directions (n, m, 3) and the exact body ones."""
    q_true = quat.random(n, rng)
    r = rng.standard_normal((n, m, 3))
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    return q_true, r, quat.rotate_inverse(q_true[:, None, :], r)


def qmm_noise(rng, b, sigma):
    """Noisy unit vectors of the QUEST measurement model: b + v, v ~ N(0, sigma^2 (I - b b^T)), renormalised."""
    g = rng.standard_normal(b.shape)
    v = g - np.sum(g * b, axis=-1, keepdims=True) * b
    noisy = b + sigma[..., None] * v
    return noisy / np.linalg.norm(noisy, axis=-1, keepdims=True)


@pytest.mark.parametrize("solver", [quest, q_method])
@pytest.mark.parametrize("m", [2, 3, 5, 10])
def test_exact_on_noise_free_vectors(solver, m):
    rng = np.random.default_rng(10 + m)
    q_true, r, b = noise_free(rng, 500, m)
    weights = rng.uniform(0.1, 10.0, (500, m))
    sol = solver(b, r, weights=weights)
    err = quat.error_angle(q_true, sol.q_BN)
    rho = observability(b, weights)
    # Rounding alone: an eigenvector is accurate to ~eps / gap rad about the worst-observed axis,
    # the relative gap being 2 rho to 6 rho (estimation.determination.vectors.observability);
    # 100 eps / rho leaves a factor ~50 over the observed ~2 eps / rho.
    assert np.all(err <= 100 * EPS / rho)
    # Sets spread over more than ~10 degrees (rho >= 1e-3) are exact to 1e-12 rad.
    assert np.max(err[rho >= 1e-3]) < 1e-12
    assert np.all(sol.q_BN[..., 0] >= 0)
    # Wahba's loss at the truth is zero: the residuals are rounding only.
    assert np.max(sol.loss / weights.sum(-1)) < 1e-20


def test_non_unit_vectors_are_normalised():
    """Measured vectors in physical units (a field in tesla) give the attitude of their directions."""
    rng = np.random.default_rng(3)
    _q_true, r, b = noise_free(rng, 20, 3)
    scale = rng.uniform(1e-5, 1e5, (20, 3, 1))
    err = quat.error_angle(quest(b * scale, r * scale[::-1]).q_BN, quest(b, r).q_BN)
    assert np.max(err) < 1e-12  # the same unit vectors up to one rounding each


def test_batch_shapes_and_shared_reference():
    rng = np.random.default_rng(4)
    q_true = quat.random((2, 3), rng)
    catalogue = rng.standard_normal((4, 3))  # one reference set for the whole batch
    catalogue /= np.linalg.norm(catalogue, axis=-1, keepdims=True)
    b = quat.rotate_inverse(q_true[..., None, :], catalogue)
    sol = quest(b, catalogue, sigma=[1e-4, 2e-4, 3e-4, 4e-4])
    assert sol.q_BN.shape == (2, 3, 4)
    assert sol.covariance.shape == (2, 3, 3, 3)
    assert sol.loss.shape == (2, 3)
    assert np.max(quat.error_angle(q_true, sol.q_BN)) < 1e-12
    # Each set solved alone gives the same answer (no cross-talk in the batch).
    single = quest(b[1, 2], catalogue, sigma=[1e-4, 2e-4, 3e-4, 4e-4])
    assert np.max(quat.error_angle(single.q_BN, sol.q_BN[1, 2])) < 1e-14
    np.testing.assert_allclose(single.covariance, sol.covariance[1, 2], rtol=1e-12)


def _noisy_pairs(rng, n):
    q_true, r, b = noise_free(rng, n, 2)
    # Vectors at least 30 degrees from parallel and weights within a factor 10: rho >= 0.02,
    # where Shuster's formula without refinement (ahrs) is accurate to ~eps / rho^2 ~ 1e-13.
    keep = np.abs(np.sum(r[:, 0] * r[:, 1], axis=-1)) < np.cos(np.radians(30))
    sigma = rng.uniform(1e-3, 1e-2, (n, 2))
    return q_true[keep], r[keep], qmm_noise(rng, b, sigma)[keep], sigma[keep]


def test_quest_agrees_with_ahrs_quest():
    rng = np.random.default_rng(5)
    _, r, b, sigma = _noisy_pairs(rng, 60)
    weights = sigma**-2 / np.sum(sigma**-2, axis=-1, keepdims=True)
    ours = quest(b, r, weights=weights).q_BN
    theirs = np.empty_like(ours)
    for i in range(len(b)):
        est = AhrsQuest(weights=weights[i])
        est.g_q, est.m_q = r[i, 0], r[i, 1]
        theirs[i] = est.estimate(acc=b[i, 0], mag=b[i, 1])
    # Both solve Wahba's problem (a unique optimum here); they differ by rounding amplified by the
    # eigenvalue gap, ~eps / rho^2 <= 1e-12 rad for rho >= 0.02: 1e-10 leaves a factor 100.
    assert np.max(quat.error_angle(ours, theirs)) < 1e-10


def test_q_method_agrees_with_ahrs_davenport():
    rng = np.random.default_rng(6)
    _, r, b, sigma = _noisy_pairs(rng, 60)
    weights = sigma**-2 / np.sum(sigma**-2, axis=-1, keepdims=True)
    ours = q_method(b, r, weights=weights).q_BN
    theirs = np.empty_like(ours)
    for i in range(len(b)):
        est = AhrsDavenport(weights=weights[i])
        est.g_q, est.m_q = r[i, 0], r[i, 1]  # its default g_q is not a unit vector
        theirs[i] = np.real(est.estimate(acc=b[i, 0], mag=b[i, 1]))
    # Two eigenvector solvers (eigh, eig) of the same matrix: ~eps / rho <= 1e-14 rad; 1e-12 is a margin of 100.
    assert np.max(quat.error_angle(ours, theirs)) < 1e-12


def test_ahrs_returns_q_BN_itself():
    """The convention check behind the two comparisons: on exact vectors ahrs's QUEST returns q_BN, not q_BN*."""
    rng = np.random.default_rng(7)
    q_true, r, b = noise_free(rng, 1, 2)
    est = AhrsQuest(weights=np.array([0.5, 0.5]))
    est.g_q, est.m_q = r[0, 0], r[0, 1]
    q_ahrs = est.estimate(acc=b[0, 0], mag=b[0, 1])
    assert quat.error_angle(q_true[0], q_ahrs) < 1e-12
    assert quat.error_angle(quat.conjugate(q_true[0]), q_ahrs) > 1e-3


def test_quest_equals_q_method_on_noisy_sets():
    """QUEST finds the same optimum as the eigenvalue solver, including sets it hands over to it."""
    rng = np.random.default_rng(8)
    _q_true, r, b = noise_free(rng, 2000, 4)
    sigma = 10.0 ** rng.uniform(-6, -2, (2000, 4))  # weights differing by up to 1e8: some sets below QUEST_RHO_MIN
    b = qmm_noise(rng, b, sigma)
    rho = observability(b, sigma**-2)
    assert np.any(rho < QUEST_RHO_MIN) and np.any(rho >= QUEST_RHO_MIN)
    err = quat.error_angle(quest(b, r, sigma=sigma).q_BN, q_method(b, r, sigma=sigma).q_BN)
    # Both at the eigensolver's rounding, ~eps / rho about the weakest axis (see the exactness test).
    assert np.all(err <= 100 * EPS / rho)


def test_degenerate_weights_fall_back_to_the_q_method():
    """Weights 1e9 apart (rho ~ 1e-9): Shuster's root alone gives a wrong eigenvector; the fallback does not."""
    rng = np.random.default_rng(9)
    q_true, r, b = noise_free(rng, 200, 2)
    keep = np.abs(np.sum(r[:, 0] * r[:, 1], axis=-1)) < np.cos(np.radians(30))
    q_true, r, b = q_true[keep], r[keep], b[keep]
    weights = np.array([1.0, 1e-9])
    sol = quest(b, r, weights=weights)
    rho = observability(b, np.broadcast_to(weights, b.shape[:-1]))
    assert np.all(rho < QUEST_RHO_MIN)
    assert np.all(quat.error_angle(q_true, sol.q_BN) <= 100 * EPS / rho)


def test_covariance_matches_monte_carlo_scatter():
    """2,000 noisy draws: the whitened estimation errors have unit covariance within chi-square sampling bounds."""
    rng = np.random.default_rng(11)
    n = 2000
    q_true = quat.random((), rng)
    r = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    sigma = np.array([1e-3, 3e-3, 2e-3])
    b_true = quat.rotate_inverse(q_true, r)
    b = qmm_noise(rng, np.broadcast_to(b_true, (n, 3, 3)), np.broadcast_to(sigma, (n, 3)))
    sol = quest(b, r, sigma=sigma)
    predicted = wahba_covariance(b_true, sigma)
    chol = np.linalg.cholesky(predicted)
    # Evaluated at the estimated directions the covariance moves by first order in the direction
    # errors (a few sigma ~ 1e-2 rad at most): whitened by the truth's, it is the identity to 2 %.
    relative = np.linalg.solve(chol, np.linalg.solve(chol, sol.covariance).swapaxes(-1, -2))
    assert np.max(np.abs(relative - np.eye(3))) < 0.02
    errors = quat.to_rotation_vector(quat.error_quaternion(q_true, sol.q_BN))  # body axes
    whitened = np.linalg.solve(chol, errors.T).T
    scatter = whitened.T @ whitened / n  # the mean is known (zero): n * diagonal ~ chi2(n)
    alpha = 1e-4  # two-sided, per statistic; 7 statistics: a false alarm below 1e-3 at any seed
    lo, hi = chi2.ppf(alpha / 2, n) / n, chi2.ppf(1 - alpha / 2, n) / n  # [0.876, 1.128]
    assert np.all((lo <= np.diag(scatter)) & (np.diag(scatter) <= hi)), np.diag(scatter)
    # Total NEES: n * trace ~ chi2(3 n).
    trace = np.trace(scatter)
    assert chi2.ppf(alpha / 2, 3 * n) / n <= trace <= chi2.ppf(1 - alpha / 2, 3 * n) / n
    # Off-diagonal sample correlations of independent unit normals: ~N(0, 1/n); 4.4 sigma is two-sided 1e-5.
    off = scatter[np.triu_indices(3, 1)]
    assert np.all(np.abs(off) <= 4.4 / np.sqrt(n)), off
    # The mean error: ~N(0, 1/n) per whitened axis (first-order unbiased).
    assert np.all(np.abs(whitened.mean(axis=0)) <= 4.4 / np.sqrt(n))
    # 2 * loss ~ chi2(2 m - 3) = chi2(3) per draw (Shuster 1989): its mean over n draws is 3 +- sqrt(6 / n).
    assert abs(np.mean(2 * sol.loss) - 3.0) <= 4.4 * np.sqrt(6 / n)


def test_monte_carlo_check_detects_a_wrong_covariance():
    """The same bounds refuse a covariance 20 % too large: the check has the power to catch an error of that size."""
    rng = np.random.default_rng(11)
    n = 2000
    q_true = quat.random((), rng)
    r = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.6, 0.0, 0.8]])
    sigma = np.array([1e-3, 3e-3, 2e-3])
    b = qmm_noise(rng, np.broadcast_to(quat.rotate_inverse(q_true, r), (n, 3, 3)), np.broadcast_to(sigma, (n, 3)))
    errors = quat.to_rotation_vector(quat.error_quaternion(q_true, quest(b, r, sigma=sigma).q_BN))
    wrong = 1.2 * wahba_covariance(quat.rotate_inverse(q_true, r), sigma)
    nees = np.einsum("ni,ij,nj->n", errors, np.linalg.inv(wrong), errors)
    assert np.sum(nees) / n < chi2.ppf(1e-4 / 2, 3 * n) / n

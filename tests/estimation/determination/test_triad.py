"""TRIAD: exact on noise-free vectors, the ahrs package, its covariance by Monte Carlo, and against QUEST.

What each test checks against:

* noise-free vectors: the true attitude (TRIAD matches the primary vector
  exactly and the plane of the two; Shuster and Oh, J. Guidance and Control
  4(1), 1981; Markley and Crassidis, *Fundamentals of Spacecraft Attitude
  Determination and Control*, 2014, ch. 5, TRIAD);
* ``ahrs.filters.TRIAD`` (0.4), an independent implementation: its
  ``estimate(w1, w2)`` with references ``v1, v2`` returns the matrix
  ``A = M_b M_r^T = C_BN`` (compared as matrices; its ``'quaternion'``
  representation is the conjugate of ``q_BN``, checked below);
* Shuster and Oh's TRIAD covariance against the scatter of 2,000 estimates
  (chi-square bounds from scipy.stats.chi2);
* with the primary vector much more accurate, TRIAD is nearly optimal (Shuster
  and Oh 1981): it agrees with QUEST and Davenport's q method to
  ``(sigma_1 / sigma_2)^2 sigma_2``, and the covariances agree.
"""

import numpy as np
from ahrs.filters import TRIAD as AhrsTriad
from scipy.stats import chi2

from attitude import quaternion as quat
from estimation import q_method, quest, triad
from estimation.determination import observability, triad_covariance, wahba_covariance

EPS = np.finfo(float).eps


def noise_free(rng, n):
    q_true = quat.random(n, rng)
    r = rng.standard_normal((n, 2, 3))
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    return q_true, r, quat.rotate_inverse(q_true[:, None, :], r)


def qmm_noise(rng, b, sigma):
    g = rng.standard_normal(b.shape)
    v = g - np.sum(g * b, axis=-1, keepdims=True) * b
    noisy = b + sigma[..., None] * v
    return noisy / np.linalg.norm(noisy, axis=-1, keepdims=True)


def test_exact_on_noise_free_vectors():
    rng = np.random.default_rng(20)
    q_true, r, b = noise_free(rng, 2000)
    sol = triad(b[:, 0], r[:, 0], b[:, 1], r[:, 1])
    err = quat.error_angle(q_true, sol.q_BN)
    sine = np.linalg.norm(np.cross(r[:, 0], r[:, 1]), axis=-1)
    # Rounding of the normalised cross product: ~eps / sine rad; 50 eps / sine is a margin of ~20.
    assert np.all(err <= 50 * EPS / sine)
    assert np.max(err[sine > 0.1]) < 1e-13
    # The primary vector is matched to rounding.
    assert np.max(np.abs(quat.rotate_inverse(sol.q_BN, r[:, 0]) - b[:, 0])) < 1e-14


def test_agrees_with_ahrs_triad():
    rng = np.random.default_rng(21)
    _, r, b = noise_free(rng, 50)
    b = qmm_noise(rng, b, np.full((50, 2), 1e-2))
    ours = quat.to_dcm(triad(b[:, 0], r[:, 0], b[:, 1], r[:, 1]).q_BN)
    for i in range(50):
        theirs = AhrsTriad(v1=r[i, 0], v2=r[i, 1]).estimate(w1=b[i, 0], w2=b[i, 1])
        sine = np.linalg.norm(np.cross(r[i, 0], r[i, 1]))
        # The same construction; ours goes through a quaternion: ~10 eps / sine per entry.
        np.testing.assert_allclose(ours[i], theirs, atol=100 * EPS / sine, rtol=0)


def test_ahrs_triad_quaternion_is_the_conjugate():
    rng = np.random.default_rng(22)
    q_true, r, b = noise_free(rng, 1)
    q_ahrs = AhrsTriad(v1=r[0, 0], v2=r[0, 1]).estimate(w1=b[0, 0], w2=b[0, 1], representation="quaternion")
    assert quat.error_angle(quat.conjugate(q_true[0]), q_ahrs) < 1e-12


def test_covariance_matches_monte_carlo_scatter():
    rng = np.random.default_rng(23)
    n = 2000
    q_true = quat.random((), rng)
    r = np.array([[1.0, 0.0, 0.0], [0.5, 0.8, 0.0]])
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    sigma = np.array([1e-3, 4e-3])
    b_true = quat.rotate_inverse(q_true, r)
    b = qmm_noise(rng, np.broadcast_to(b_true, (n, 2, 3)), np.broadcast_to(sigma, (n, 2)))
    sol = triad(b[:, 0], r[0], b[:, 1], r[1], sigma_primary=sigma[0], sigma_secondary=sigma[1])
    predicted = triad_covariance(b_true[0], b_true[1], sigma[0], sigma[1])
    errors = quat.to_rotation_vector(quat.error_quaternion(q_true, sol.q_BN))
    whitened = np.linalg.solve(np.linalg.cholesky(predicted), errors.T).T
    scatter = whitened.T @ whitened / n  # n * diagonal ~ chi2(n)
    alpha = 1e-4  # two-sided per statistic
    lo, hi = chi2.ppf(alpha / 2, n) / n, chi2.ppf(1 - alpha / 2, n) / n
    assert np.all((lo <= np.diag(scatter)) & (np.diag(scatter) <= hi)), np.diag(scatter)
    off = scatter[np.triu_indices(3, 1)]
    assert np.all(np.abs(off) <= 4.4 / np.sqrt(n)), off  # ~N(0, 1/n): two-sided 1e-5
    # TRIAD is not optimal: its covariance exceeds the optimal (Cramer-Rao) one in every direction,
    # here by ~(sigma_1 / sigma_2)^2 = 6 % about the weak axis (whitened by the optimal covariance).
    excess = np.linalg.eigvalsh(_whitened(predicted, wahba_covariance(b_true, sigma))) - 1.0
    assert excess.min() > -1e-12 and excess.max() > 0.03


def test_accurate_primary_makes_triad_nearly_optimal():
    rng = np.random.default_rng(24)
    q_true, r, b = noise_free(rng, 500)
    keep = np.abs(np.sum(r[:, 0] * r[:, 1], axis=-1)) < np.cos(np.radians(30))
    q_true, r, b = q_true[keep], r[keep], b[keep]
    sigma = np.array([1e-5, 1e-3])  # weights 1e4 apart: QUEST's own path (rho >= QUEST_RHO_MIN)
    b = qmm_noise(rng, b, np.broadcast_to(sigma, b.shape[:-1]))
    t = triad(b[:, 0], r[:, 0], b[:, 1], r[:, 1], sigma_primary=sigma[0], sigma_secondary=sigma[1])
    qu = quest(b, r, sigma=sigma)
    qm = q_method(b, r, sigma=sigma)
    # The optimum moves off the primary vector by ~(sigma_1 / sigma_2)^2 times the secondary's
    # residual (<= ~5 sigma_2): <= 5e-7 rad; TRIAD's error itself is ~sigma_1 = 1e-5.
    assert np.max(quat.error_angle(t.q_BN, qu.q_BN)) < 5 * (sigma[0] / sigma[1]) ** 2 * sigma[1]
    # One optimum, two solvers: rounding ~eps / rho about the weak axis (rho ~ 1e-4 here).
    rho = observability(b, np.broadcast_to(sigma**-2, b.shape[:-1]))
    assert np.all(quat.error_angle(qm.q_BN, qu.q_BN) <= 100 * EPS / rho)
    # At the same directions the two covariances agree to (sigma_1 / sigma_2)^2 = 1e-4 (whitened by
    # the optimal one), TRIAD's the larger; rounding amplified by the condition number 1e4 is ~1e-12.
    b_true = quat.rotate_inverse(q_true[:, None, :], r)
    relative = _whitened(triad_covariance(b_true[:, 0], b_true[:, 1], *sigma), wahba_covariance(b_true, sigma))
    excess = np.linalg.eigvalsh(relative) - 1.0
    assert excess.min() > -1e-9 and excess.max() < 2 * (sigma[0] / sigma[1]) ** 2
    # TRIAD's loss is at least the optimum's (the optimum minimises it).
    assert np.all(t.loss >= qu.loss * (1 - 1e-9))


def test_swapping_primary_and_secondary_changes_the_trusted_vector():
    rng = np.random.default_rng(25)
    _, r, b = noise_free(rng, 10)
    b = qmm_noise(rng, b, np.full((10, 2), 1e-2))
    first = triad(b[:, 0], r[:, 0], b[:, 1], r[:, 1])
    second = triad(b[:, 1], r[:, 1], b[:, 0], r[:, 0])
    np.testing.assert_allclose(quat.rotate_inverse(first.q_BN, r[:, 0]), b[:, 0], atol=1e-14)
    np.testing.assert_allclose(quat.rotate_inverse(second.q_BN, r[:, 1]), b[:, 1], atol=1e-14)
    assert np.min(quat.error_angle(first.q_BN, second.q_BN)) > 1e-4


def _whitened(covariance, reference):
    """``L^-1 P L^-T`` with ``reference = L L^T``: the identity when the two agree."""
    chol = np.linalg.cholesky(reference)
    return np.linalg.solve(chol, np.linalg.solve(chol, covariance).swapaxes(-1, -2))

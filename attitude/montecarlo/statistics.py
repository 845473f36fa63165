"""Campaign statistics: percentiles and what N runs prove about the probability of success.

Success bound
-------------
Each run succeeds independently with an unknown probability ``p``. After
``N`` runs with ``s`` successes, the one-sided Clopper-Pearson bound at
confidence ``C`` is the ``p_L`` below which observing ``s`` or more successes
would have had probability at most ``1 - C``:

.. math:: p_L = \\mathrm{Beta}^{-1}(1 - C;\\ s,\\ N - s + 1)

(:func:`success_lower_bound`; exact, not a normal approximation; it is
conservative because the binomial is discrete). With zero failures
(``s = N``) the Beta quantile has the closed form ``p_L = (1 - C)^{1/N}``:
the classical statement "N runs without a failure give confidence C that
the success probability is at least ``(1 - C)^{1/N}``"; for example 2,995
runs prove 99.9 % success at 95 % confidence, and 59 runs 95 % at 95 %
(:func:`runs_for_zero_failures`). ``(1 - C)^{1/N} = p`` is simply
``P(N successes | p) = p^N = 1 - C``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import stats

__all__ = [
    "DEFAULT_PERCENTILES",
    "percentiles",
    "runs_for_zero_failures",
    "success_lower_bound",
    "success_statement",
    "zero_failure_bound",
]

#: Percentiles reported by default [%].
DEFAULT_PERCENTILES = (1.0, 5.0, 50.0, 95.0, 99.0)


def _confidence(confidence: float) -> float:
    c = float(confidence)
    if not 0.0 < c < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    return c


def zero_failure_bound(runs: int, confidence: float = 0.95) -> float:
    """Success probability proven by ``runs`` runs without a failure: ``(1 - C)^(1/N)``.

    Parameters
    ----------
    runs : int
        Number of runs, all successful, >= 1.
    confidence : float, optional
        Confidence level of the one-sided bound, in (0, 1).
    """
    if not isinstance(runs, (int, np.integer)) or runs < 1:
        raise ValueError(f"runs must be a positive integer, got {runs!r}")
    return float((1.0 - _confidence(confidence)) ** (1.0 / runs))


def runs_for_zero_failures(success: float, confidence: float = 0.95) -> int:
    """Fewest runs without a failure that prove ``success`` at ``confidence``: ``ceil(ln(1-C) / ln p)``.

    Parameters
    ----------
    success : float
        Success probability to prove, in (0, 1).
    confidence : float, optional
        Confidence level of the proof, in (0, 1).
    """
    p = float(success)
    if not 0.0 < p < 1.0:
        raise ValueError(f"success must be in (0, 1), got {success!r}")
    n = math.log(1.0 - _confidence(confidence)) / math.log(p)
    # Guard the ceiling against rounding of an exact integer quotient.
    return max(1, math.ceil(n - 1e-9))


def success_lower_bound(successes: int, runs: int, confidence: float = 0.95) -> float:
    """One-sided Clopper-Pearson lower bound on the success probability (module docstring).

    Returns 0 when there is no success, ``(1 - C)^(1/N)`` when every run succeeded.

    Parameters
    ----------
    successes : int
        Number of successful runs, ``0 <= successes <= runs``.
    runs : int
        Number of runs, >= 1.
    confidence : float, optional
        Confidence level of the one-sided bound, in (0, 1).
    """
    if not isinstance(runs, (int, np.integer)) or runs < 1:
        raise ValueError(f"runs must be a positive integer, got {runs!r}")
    if not isinstance(successes, (int, np.integer)) or not 0 <= successes <= runs:
        raise ValueError(f"successes must be an integer in [0, runs={runs}], got {successes!r}")
    c = _confidence(confidence)
    if successes == 0:
        return 0.0
    if successes == runs:
        return zero_failure_bound(int(runs), c)
    return float(stats.beta.ppf(1.0 - c, successes, runs - successes + 1))


def success_statement(successes: int, runs: int, confidence: float = 0.95) -> str:
    """The bound in words, e.g. ``"1000 runs, 0 failures: with 95% confidence P(success) >= 99.70%"``.

    Parameters
    ----------
    successes : int
        Number of successful runs, ``0 <= successes <= runs``.
    runs : int
        Number of runs, >= 1.
    confidence : float, optional
        Confidence level of the one-sided bound, in (0, 1).
    """
    bound = success_lower_bound(successes, runs, confidence)
    return (
        f"{runs} runs, {runs - successes} failures: with {100 * confidence:g}% confidence the probability of "
        f"success is at least {100 * bound:.2f}%"
    )


def percentiles(values: ArrayLike, q: Sequence[float] = DEFAULT_PERCENTILES) -> dict[str, float]:
    """Count, mean, standard deviation, min, the percentiles ``q`` [%] and max of the finite values.

    Non-finite values (a failed run's NaN, a never-settled run's inf) are
    counted apart as ``nonfinite`` and left out of the others.

    Parameters
    ----------
    values : array_like
        The values of one metric over the runs (any shape; flattened).
    q : sequence of float, optional
        Percentiles to report [%], each in ``[0, 100]``.
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    finite: NDArray[np.float64] = v[np.isfinite(v)]
    out: dict[str, float] = {"count": float(finite.size), "nonfinite": float(v.size - finite.size)}
    if finite.size == 0:
        out.update({"mean": math.nan, "std": math.nan, "min": math.nan, "max": math.nan})
        out.update({f"p{p:g}": math.nan for p in q})
        return out
    out["mean"] = float(np.mean(finite))
    out["std"] = float(np.std(finite, ddof=1)) if finite.size > 1 else 0.0
    out["min"] = float(np.min(finite))
    for p, value in zip(q, np.percentile(finite, list(q))):
        out[f"p{p:g}"] = float(value)
    out["max"] = float(np.max(finite))
    return out

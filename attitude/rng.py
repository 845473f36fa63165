"""Random-number sources: every stochastic function takes ``rng``."""

from __future__ import annotations

import numpy as np

__all__ = ["as_generator"]


def as_generator(rng: object = None) -> np.random.Generator:
    """Return a :class:`numpy.random.Generator` for ``rng``.

    Parameters
    ----------
    rng : numpy.random.Generator, numpy.random.SeedSequence, int or None
        An existing generator (returned as is), a seed sequence or an integer
        seed (a new PCG64 generator; the same seed reproduces a run bit for
        bit), or None (fresh OS entropy).

    Returns
    -------
    numpy.random.Generator
        ``rng`` itself if it is a generator, else a new one.

    Raises
    ------
    ValueError
        If ``rng`` is of another type or a negative seed.
    """
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, np.random.SeedSequence):
        return np.random.default_rng(rng)
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        if rng < 0:
            raise ValueError(f"rng seed must be a non-negative integer, got {rng}")
        return np.random.default_rng(int(rng))
    raise ValueError(f"rng must be a numpy Generator, a SeedSequence, a non-negative int seed or None, got {rng!r}")

"""Random-number sources: every stochastic function takes ``rng``; per-run normal streams for batches."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["NormalStreams", "as_generator"]


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


class NormalStreams:
    """Per-run streams of standard normals for N runs advancing together, buffered in blocks.

    A vectorised Monte Carlo campaign advances N runs one tick at a time, but
    each run must draw its random numbers from its own generator, in the
    order a single run would (so that run ``r`` of the batch reproduces, bit
    for bit, the same run simulated alone with ``generators[r]``). Calling N
    generators every tick costs N Python calls; this class draws ``block``
    normals per generator ahead into an (N, block) buffer and serves each
    tick's request with a few numpy operations. Generators are refilled only
    when their buffered numbers run out.

    The numbers are those of ``generators[r].standard_normal`` called in
    sequence: numpy's :meth:`numpy.random.Generator.standard_normal` (ziggurat)
    consumes the bit stream sequentially and keeps no cached value between
    calls, so drawing ``a`` then ``b`` normals gives the same numbers as
    drawing ``a + b`` at once (tests/attitude/test_sensors_batch.py checks this for
    any block size and any interleaving of sizes and active masks).

    The streams own the generators: after construction, draw from them only
    through :meth:`draw` (the buffer has already taken numbers ahead of what
    :meth:`draw` has handed out).

    Parameters
    ----------
    generators : sequence of numpy.random.Generator
        One generator per run (e.g. ``[np.random.default_rng(s) for s in
        SeedSequence(seed).spawn(n)]``); at least one.
    block : int
        Numbers drawn ahead per generator at each refill (>= 1); larger
        blocks mean fewer generator calls and more memory (``8 N block``
        bytes).

    Raises
    ------
    ValueError
        If ``generators`` is empty or holds something that is not a
        Generator, or ``block`` is not a positive integer.
    """

    def __init__(self, generators: Sequence[np.random.Generator], block: int = 4096) -> None:
        gens = list(generators)
        if not gens:
            raise ValueError("generators must hold at least one numpy Generator, got an empty sequence")
        for i, g in enumerate(gens):
            if not isinstance(g, np.random.Generator):
                raise ValueError(f"generators must hold numpy Generators; generators[{i}] is {type(g).__name__}")
        if not isinstance(block, (int, np.integer)) or isinstance(block, bool) or block < 1:
            raise ValueError(f"block must be a positive integer, got {block!r}")
        self._gens = gens
        self.block = int(block)
        n = len(gens)
        self._buf = np.empty((n, self.block))
        # Every row starts exhausted: the first draw of a run fills it (so a run that never draws consumes nothing).
        self._pos = np.full(n, self.block, dtype=np.intp)
        self._rows = np.arange(n)

    @property
    def n_runs(self) -> int:
        """Number of runs (generators)."""
        return len(self._gens)

    @property
    def generators(self) -> list[np.random.Generator]:
        """The generators (drawn ahead by the buffer: do not draw from them directly)."""
        return list(self._gens)

    def draw(self, active: ArrayLike | None, size: int) -> NDArray[np.float64]:
        """The next ``size`` standard normals of each active run's generator.

        Parameters
        ----------
        active : array_like (n_runs,) of bool, or None
            Runs that draw (None: all). Inactive runs consume nothing.
        size : int
            Numbers per active run (>= 0).

        Returns
        -------
        ndarray (n_runs, size)
            Row ``r`` holds the next ``size`` numbers of ``generators[r]``
            for an active run, NaN for an inactive one.

        Raises
        ------
        ValueError
            If ``active`` is not a boolean array of shape (n_runs,) or
            ``size`` is not a non-negative integer.
        """
        n = self.n_runs
        if not isinstance(size, (int, np.integer)) or isinstance(size, bool) or size < 0:
            raise ValueError(f"size must be a non-negative integer, got {size!r}")
        size = int(size)
        if active is None:
            act = np.ones(n, dtype=bool)
        else:
            act = np.asarray(active)
            if act.dtype != np.bool_ or act.shape != (n,):
                raise ValueError(
                    f"active must be a boolean array of shape ({n},) (one flag per run), "
                    f"got dtype {act.dtype} and shape {act.shape}"
                )
        out = np.full((n, size), np.nan)
        if size == 0 or not act.any():
            return out
        width = self.block
        short = act & (self._pos + size > width)
        for r in np.nonzero(short)[0]:
            tail = self._buf[r, self._pos[r] :]
            if size > width:  # larger than a block: serve this request directly, leave the buffer empty
                out[r] = np.concatenate([tail, self._gens[r].standard_normal(size - tail.size)])
                self._pos[r] = width
                continue
            # Keep the unused tail in front, then continue the run's stream behind it.
            self._buf[r, : tail.size] = tail.copy()
            self._buf[r, tail.size :] = self._gens[r].standard_normal(width - tail.size)
            self._pos[r] = 0
        take = act & ~(short & (size > width))
        rows = self._rows[take]
        if rows.size:
            cols = self._pos[rows, None] + np.arange(size)
            out[rows] = self._buf[rows[:, None], cols]
            self._pos[rows] += size
        return out

"""Built objects (casadi graphs, compiled libraries) kept per process: the one bounded cache of the engines.

Building a closed loop's casadi graph, or loading a compiled library, costs
milliseconds, a good part of a short run; the engines keep what they built
by what it was built from (its *key*), a few at a time.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

__all__ = ["BuildCache"]

V = TypeVar("V")


class BuildCache(Generic[V]):
    """A thread-safe least-recently-used map from keys to built objects, at most ``size`` kept.

    Parameters
    ----------
    size : int
        Objects kept (the least recently used goes first).
    """

    def __init__(self, size: int) -> None:
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ValueError(f"size must be a positive integer, got {size!r}")
        self._items: OrderedDict[Hashable, V] = OrderedDict()
        self._size = size
        self._lock = threading.Lock()

    def get(self, key: Hashable, build: Callable[[], V]) -> V:
        """The object built for ``key``, built by ``build()`` the first time (outside the lock).

        Parameters
        ----------
        key : hashable
            What the object is built from.
        build : callable
            Builds it; two threads asking for a new key at once may both build it (the last one is kept).

        Returns
        -------
        object
        """
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        value = build()
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self._size:
                self._items.popitem(last=False)
        return value

    def clear(self) -> None:
        """Forget every object (e.g. after the compiler or the cache folder changed)."""
        with self._lock:
            self._items.clear()

    def __len__(self) -> int:
        return len(self._items)

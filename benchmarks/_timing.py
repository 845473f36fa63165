"""Timing and memory helpers shared by the benchmarks (medians on a noisy machine)."""

from __future__ import annotations

import statistics
import time
import tracemalloc
from collections.abc import Callable
from typing import Any


def cpu_time_median(fun: Callable[[], Any], repeats: int = 5) -> dict[str, float]:
    """Run ``fun`` once to warm up, then ``repeats`` times; CPU seconds (process time).

    Returns the median, minimum and maximum CPU time [s] of the timed runs.
    """
    fun()
    samples = []
    for _ in range(repeats):
        start = time.process_time()
        fun()
        samples.append(time.process_time() - start)
    return {"median_s": statistics.median(samples), "min_s": min(samples), "max_s": max(samples), "repeats": repeats}


def memory_peak_mib(fun: Callable[[], Any]) -> float:
    """Peak traced allocation [MiB] while ``fun`` runs (numpy buffers are traced)."""
    tracemalloc.start()
    try:
        fun()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return peak / 2**20

"""Static attitude determination speed: QUEST, Davenport's q method and TRIAD on 1,000 vector sets per call.

Each call solves 1,000 sets at once (the vectorised path): four unit vectors
per set for QUEST and the q method (with ``sigma``, so the covariance is
included), two for TRIAD, QUEST-measurement-model noise of 1e-3 rad.
Figures are CPU-time medians; calls per second and sets per second.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude import quaternion as quat
from estimation import q_method, quest, triad

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

N_SETS = 1000
N_VECTORS = 4


def _data() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    q_true = quat.random(N_SETS, rng)
    r = rng.standard_normal((N_SETS, N_VECTORS, 3))
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    b = quat.rotate_inverse(q_true[:, None, :], r) + 1e-3 * rng.standard_normal((N_SETS, N_VECTORS, 3))
    sigma = np.full((N_SETS, N_VECTORS), 1e-3)
    return b, r, sigma


def run() -> dict[str, Any]:
    b, r, sigma = _data()
    cases = {
        "quest": lambda: quest(b, r, sigma=sigma),
        "q_method": lambda: q_method(b, r, sigma=sigma),
        "triad": lambda: triad(b[:, 0], r[:, 0], b[:, 1], r[:, 1], sigma_primary=1e-3, sigma_secondary=1e-3),
    }
    report: dict[str, Any] = {"case": f"{N_SETS} sets per call, {N_VECTORS} vectors (TRIAD: 2), with covariance"}
    for name, fun in cases.items():
        cpu = cpu_time_median(fun, repeats=15)
        report[name] = {
            "cpu_s": cpu,
            "calls_per_s": 1.0 / cpu["median_s"],
            "sets_per_s": N_SETS / cpu["median_s"],
        }
    return report


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

"""Tuning the PD and the LQR to the requirements (issue #14): `attitude tune` on the default spacecraft.

Target: a tuning run on the default spacecraft in under a minute. Timed, for each structure (``--structure pd``
and ``lqr``): the linear search (:func:`controllers.tuning.tune_pd` / :func:`controllers.tuning.tune_lqr` with
the trade-off sweep, as `attitude tune` runs it) and the nonlinear confirmation; the dispersed check is
`attitude design`'s own and timed there (bench_montecarlo). CPU seconds
(``time.process_time``), median of two after a warm-up. No Basilisk case does this (it has no tuner).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from attitude.app.design.tune import tune_config
from attitude.config import default_config

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

TARGET_S = 60.0


def run() -> dict[str, Any]:
    return {structure: _one(structure) for structure in ("pd", "lqr")}


def _one(structure: str) -> dict[str, Any]:
    config = default_config()
    timing = cpu_time_median(lambda: tune_config(config, structure=structure, dispersed_runs=0), repeats=2)
    start = time.perf_counter()
    outcome = tune_config(config, structure=structure, dispersed_runs=0)
    wall = time.perf_counter() - start
    result = outcome.result
    return {
        "case": f"attitude tune --structure {structure}, default 12U CubeSat: settling minimised, the 1 deg step of "
        "[control.lqr], 10 Hz",
        "cpu_s": timing,
        "wall_s": wall,
        "target_s": TARGET_S,
        "ratio_to_target": timing["median_s"] / TARGET_S,
        "bandwidth_rad_per_s": np.asarray(result.wn).tolist(),
        "damping": np.asarray(result.zeta).tolist(),
        "settling_time_s": result.metrics.settling_time,
        "disk_margin": result.metrics.disk_margin,
        "binding": list(result.binding),
        "nonlinear_settling_time_s": outcome.nonlinear["settling_time_s"],
        "nonlinear_pointing_deg": math.degrees(outcome.nonlinear["pointing_error_rad"]),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

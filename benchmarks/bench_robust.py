"""Robust-design speed: the multiloop disk margin of the default 3-axis loop, and the worst-case search.

Cases, on the default spacecraft (its [control] PD sampled at 0.1 s on the whole body):

* ``disk_margin_multiloop``: :func:`controllers.disk_margins.disk_margins` of the sampled input loop
  (:func:`controllers.analysis.input_loop`, 3 x 3, slycot's structured singular value bound per frequency)
  on its refined default grid. Median of 7 CPU times. Target: below 1 s.
* ``worst_case_search``: :func:`controllers.worst_case.worst_case_disk_margin` over moments +-10 %,
  principal axes turned up to 5 deg, wheel axes tilted up to 1 deg and up to 0.1 s of extra delay (15
  parameters with the four-wheel pyramid), the default budget: one run's CPU time, its evaluations, and
  the worst margin against the nominal and the sampled worst. Target: 10 to 30 s.

No Basilisk case does this work (Basilisk has no disk margin): no peer ratio.
"""

from __future__ import annotations

import time
from typing import Any

from attitude.app import assembly
from attitude.config import default_config
from controllers.analysis import input_loop
from controllers.disk_margins import disk_margins
from controllers.worst_case import UncertaintySet, worst_case_disk_margin

try:
    from benchmarks._timing import cpu_time_median
except ImportError:  # run as a script from the benchmarks folder
    from _timing import cpu_time_median

SET = UncertaintySet(inertia_percent=10.0, axis_rotation_deg=5.0, wheel_misalignment_deg=1.0, extra_delay_s=0.1)


def run() -> dict[str, Any]:
    config = default_config()
    body, pd, wheels = assembly.rigid_body(config), assembly.quaternion_pd(config), assembly.reaction_wheels(config)
    loop = input_loop(body, pd)
    margin = disk_margins(loop)
    cpu = cpu_time_median(lambda: disk_margins(loop), repeats=7)
    report: dict[str, Any] = {
        "disk_margin_multiloop": {
            "cpu_s": cpu,
            "target_s": 1.0,
            "disk_margin": margin.disk_margin,
            "frequencies": margin.grid_points,
            "basilisk_note": "no Basilisk case computes disk margins",
        }
    }
    start, wall = time.process_time(), time.perf_counter()
    result = worst_case_disk_margin(body, pd, SET, wheels=wheels)
    report["worst_case_search"] = {
        "cpu_s": time.process_time() - start,
        "wall_s": time.perf_counter() - wall,
        "target_s": [10.0, 30.0],
        "parameters": len(SET.parameter_names(wheels.n_wheels)),
        "evaluations": result.evaluations,
        "budget": result.budget,
        "worst_disk_margin": result.worst,
        "nominal_disk_margin": result.nominal,
        "sampled_worst_disk_margin": result.sampled_worst,
        "optimiser_at_least_as_bad_as_samples": result.optimiser_at_least_as_bad,
        "basilisk_note": "no Basilisk case computes disk margins",
    }
    result.plot().savefig("/tmp/bench_robust_disk_margin.png", dpi=100)
    return report


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))

"""Run every benchmark and print one JSON document (``make bench``).

Figures are CPU-time medians (``time.process_time``) over repeated runs,
since the 2-core machine is noisy; ratios to the stated targets are included.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from benchmarks import (
    bench_closed_loop,
    bench_determination,
    bench_mekf,
    bench_montecarlo,
    bench_orbit,
    bench_propagation,
    bench_rate_ekf,
    bench_robust,
    bench_slew,
    bench_slew_design,
    bench_slew_multistart,
    bench_slew_robust,
    bench_slew_wheels,
    bench_tune,
)

SUITES = {
    "propagation": bench_propagation.run,
    "closed_loop": bench_closed_loop.run,
    "slew": bench_slew.run,
    "rate_ekf": bench_rate_ekf.run,
    "mekf": bench_mekf.run,
    "determination": bench_determination.run,
    "montecarlo": bench_montecarlo.run,
    "orbit": bench_orbit.run,
    "robust": bench_robust.run,
    "tune": bench_tune.run,
    "slew_multistart": bench_slew_multistart.run,
    "slew_wheels": bench_slew_wheels.run,
    "slew_robust": bench_slew_robust.run,
    "slew_design": bench_slew_design.run,
}


def main() -> None:
    selected = sys.argv[1:] or list(SUITES)
    unknown = [s for s in selected if s not in SUITES]
    if unknown:
        raise SystemExit(f"unknown benchmark suite(s) {unknown}; choose from {list(SUITES)}")
    report = {
        "machine": {"python": platform.python_version(), "processor": platform.machine(), "cpus": _cpus()},
        "started": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }
    for name in selected:
        report[name] = SUITES[name]()
    out = Path(__file__).resolve().parent / "results"
    out.mkdir(exist_ok=True)
    text = json.dumps(report, indent=2)
    (out / "latest.json").write_text(text + "\n")
    print(text)


def _cpus() -> int:
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


if __name__ == "__main__":
    main()

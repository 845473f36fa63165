"""The Monte Carlo benchmark's CPU accounting counts each piece of work once.

Checked against a known amount of work: a scenario that burns a set CPU time
per run (a busy loop on ``time.process_time``), flown in this process (one
worker, and vectorised) and in a pool of two worker processes. The
campaign's ``cpu_s`` must be that burnt CPU plus the campaign's own small
overhead: about 1x. Counting the in-process runs both in ``process_time``
and again as the runs' own measured CPU (the mistake this guards against)
gives about 2x; losing the workers' CPU gives about 0x.
"""

from __future__ import annotations

import time

import pytest

from attitude.montecarlo.campaign import Campaign
from attitude.montecarlo.dispersions import Uniform
from attitude.montecarlo.executors import RunOutput
from benchmarks import bench_montecarlo

#: CPU each run burns [s]: long enough that the campaign's own overhead (parameters, records, table: well
#: under a millisecond per run here) is a few per cent of it.
BURN_S = 0.04
RUNS = 10
#: The known work: RUNS * BURN_S. A figure within [0.95, 1.4] of it counts the work once; the double count
#: gives 2.0 and more, losing the workers' CPU about 0.
LOW, HIGH = 0.95, 1.4


def burn(cpu_s: float) -> None:
    """Busy-loop until this process has used ``cpu_s`` more CPU seconds."""
    end = time.process_time() + cpu_s
    while time.process_time() < end:
        pass


class BurnsCPU:
    """Each run burns BURN_S CPU seconds wherever it runs; run_batch burns that per run of the batch."""

    fingerprint = "BurnsCPU"

    def __call__(self, params, rng):
        burn(BURN_S)
        return {"x_seen": float(params["x"])}

    def run_batch(self, params_list, rngs):
        burn(BURN_S * len(params_list))
        return [RunOutput({"x_seen": float(p["x"])}) for p in params_list]


def campaign() -> Campaign:
    return Campaign(BurnsCPU(), {"x": Uniform(0.0, 1.0)}, runs=RUNS, seed=3)


@pytest.mark.parametrize(
    ("kwargs", "executor"),
    [
        ({"workers": 1}, "serial"),
        ({"vectorized": True, "runs_per_task": 5}, "serial"),
        ({"workers": 2}, "processes"),
    ],
    ids=["one-worker", "vectorised", "two-worker-processes"],
)
def test_campaign_cpu_counts_the_runs_once(kwargs, executor):
    """cpu_s is about the burnt CPU (1x): not twice it in this process, not nothing in the workers."""
    known = RUNS * BURN_S
    figures = bench_montecarlo._measure(campaign(), 1.0, **kwargs)
    assert figures["executor"] == executor and figures["completed"] == RUNS
    assert LOW * known <= figures["cpu_s"] <= HIGH * known, (figures["cpu_s"], known, figures["cpu_s_basis"])
    # The runs' own measure sees the same work (each run's process_time where it ran).
    assert LOW * known <= figures["cpu_s_in_runs"] <= HIGH * known
    assert figures["sim_s_per_cpu_s"] == pytest.approx(RUNS * 1.0 / figures["cpu_s"])

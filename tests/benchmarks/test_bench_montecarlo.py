"""The Monte Carlo benchmark's CPU accounting counts each piece of work once.

Checked against a known amount of work: a scenario that burns a set CPU time
per run (a busy loop on ``time.process_time``), flown in this process (one
worker, and vectorised) and in a pool of two worker processes. The
campaign's ``cpu_s`` must be that burnt CPU plus the campaign's own small
overhead: about 1x. Counting the in-process runs both in ``process_time``
and again as the runs' own measured CPU (the mistake this guards against)
gives about 2x; losing the workers' CPU gives about 0x.

And the peer: every speed figure names its Basilisk case, with a null ratio
and a reason when ``benchmarks/basilisk_reference.json`` is absent, and the
ratio to the case's median when it is there.
"""

from __future__ import annotations

import json
import time

import pytest

from attitude.montecarlo.campaign import Campaign
from attitude.montecarlo.dispersions import Uniform
from attitude.montecarlo.executors import RunOutput
from benchmarks import _peer, bench_montecarlo

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


def test_a_figure_without_the_reference_file_has_no_ratio_and_says_why(tmp_path, monkeypatch):
    """No reference: the case is named, the ratio is null and the note says the file is absent."""
    monkeypatch.setattr(_peer, "REFERENCE_FILE", tmp_path / "basilisk_reference.json")
    peer = _peer.versus_basilisk(300_000.0, "rw_no_earth")
    assert peer["basilisk_case"] == "rw_no_earth"
    assert peer["ratio_to_basilisk"] is None and peer["basilisk_sim_s_per_cpu_s"] is None
    assert "absent" in peer["basilisk_note"]


def test_a_figure_is_divided_by_its_own_case(tmp_path, monkeypatch):
    """With the file: the ratio is the figure over the named case's median, not another case's."""
    path = tmp_path / "basilisk_reference.json"
    cases = {"torquefree": 20_000.0, "closed_nodelay": 8_300.0, "rw_no_earth": 5_000.0}
    path.write_text(
        json.dumps(
            {
                "machine": "test box",
                "date": "2025-01-01",
                "cases": {k: {"sim_s_per_cpu_s": {"median": v}} for k, v in cases.items()},
            }
        )
    )
    monkeypatch.setattr(_peer, "REFERENCE_FILE", path)
    peer = _peer.versus_basilisk(300_000.0, "rw_no_earth", note="differs")
    assert peer["basilisk_sim_s_per_cpu_s"] == 5_000.0
    assert peer["ratio_to_basilisk"] == 300_000.0 / 5_000.0
    assert "test box" in peer["basilisk_note"] and "differs" in peer["basilisk_note"]
    with pytest.raises(ValueError, match="case must be one of"):
        _peer.versus_basilisk(1.0, "rw_with_earth")
    path.write_text("{}")
    with pytest.raises(ValueError, match="'cases'"):
        _peer.load_basilisk_reference(path)

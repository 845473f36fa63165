"""The design's dispersed check (attitude.app.design.dispersed): a small campaign that can fail the design.

What each test checks against:

- the campaign itself: the check's counts are those of
  :func:`attitude.app.scenarios.run_campaign_from_config` flown with the
  arguments the row names (the command ``attitude montecarlo`` runs), run by
  run, and its bound is the one-sided Clopper-Pearson bound computed here
  with ``scipy.stats.beta`` (Clopper and Pearson 1934; for zero failures
  ``0.05^(1/N)``);
- a design that passes nominally but whose dispersions break a requirement
  (initial rates of 1.5 deg/s, 1 sigma, against a 2 deg/s rate limit) is not
  a PASS: the dispersed row fails and names the requirements missed.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from attitude.app.design.dispersed import dispersed_check
from attitude.app.design.run import requirement_verdicts
from attitude.app.scenarios import run_campaign_from_config
from attitude.config import default_config, default_config_text, parse_config

SLEW_S = 38.7  # a planned slew of the default file at 30 nodes [s] (the check adds settling and hold)


def test_the_check_is_the_campaign_its_row_names():
    config = default_config()
    out = dispersed_check(config, 6, SLEW_S, 30)
    # In the file's orbit, as the design's flight (and `attitude montecarlo` on a file with an [orbit]) fly.
    campaign = run_campaign_from_config(
        config, runs=6, workers=1, nodes=30, progress=False, figures=False, vectorized=True, environment=True
    )
    assert out["failures"] == int(np.sum(~campaign.passed)) and out["seed"] == campaign.seed == 12345
    assert out["command"].endswith("--runs 6 --vectorized --nodes 30")
    successes = 6 - out["failures"]
    expected = 0.05 ** (1 / 6) if successes == 6 else float(stats.beta.ppf(0.05, successes, 6 - successes + 1))
    assert out["success_lower_bound"] == pytest.approx(expected, rel=1e-12)
    # The runs last the slew, the settling time and the hold (the file's hold_time_s), to the 0.1 s tick.
    req = config.requirements
    assert out["duration_s"] == pytest.approx(SLEW_S + req.settling_time_s + req.hold_time_s, abs=0.1)


def test_a_nominal_pass_that_fails_dispersed_is_not_a_pass():
    text = default_config_text().replace(
        'initial_rate = { distribution = "normal", sigma_deg_per_s = 0.05 }',
        'initial_rate = { distribution = "normal", sigma_deg_per_s = 1.5 }',
    )
    config = parse_config(text)
    out = dispersed_check(config, 8, SLEW_S, 30)
    assert out["failures"] > 0 and out["requirements"]["rate"]["passed"] < 8
    assert all("rate" in f["missed"] for f in out["failing_runs"] if f["run"] in (0, 1))
    # The row judged with results that pass every other requirement: the verdict fails on it alone.
    results = {"slews": {"angle_deg": 60.0}, "closed_loop": None, "linear": {"margins": []}, "dispersed": out}
    verdict = requirement_verdicts(config, results)
    row = next(r for r in verdict["requirements"] if r["id"] == "dispersed")
    assert not row["pass"] and row["achieved"] == out["failures"] and "dispersed" in verdict["verdict"]["failed"]


def test_no_montecarlo_table_no_check():
    text = default_config_text()
    start = text.index("[montecarlo]")
    assert dispersed_check(parse_config(text[:start]), 4, SLEW_S, 30) is None

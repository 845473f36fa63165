"""Why a requirement row failed (attitude.app.design.reasons): every line is true of the stored numbers.

Each case is a row as attitude.app.design.run.requirement_verdicts builds it, with the few result entries
its reason reads; the expected words follow from the numbers given here.
"""

from __future__ import annotations

import math

from attitude.app.design.reasons import failure_reason

FLIGHT = {
    "slew_end_s": 38.8,
    "pointing_window_start_s": 98.8,
    "pointing_window_end_s": 158.8,
    "pointing_error_end_deg": 0.2,
    "pointing_error_max_in_window_at_s": 120.0,
    "settling_dwell_s": 30.0,
}
RESULTS = {"closed_loop": FLIGHT, "slews": {"plan": {"duration_s": 38.8}}, "linear": {"findings": []}}


def row(rid: str, required: float, achieved: float | None, unit: str = "s") -> dict:
    return {"id": rid, "required": required, "achieved": achieved, "unit": unit, "comparison": "<=", "pass": False}


def test_a_passing_row_has_no_reason():
    assert failure_reason({**row("slew_time", 120.0, 40.0), "pass": True}, RESULTS) is None


def test_a_finite_miss_quotes_both_numbers():
    line = failure_reason(row("settling_time", 60.0, 71.5), RESULTS)
    assert "71.5 s after the slew ended at 38.8 s, 60 s allowed" in line
    line = failure_reason(row("pointing_accuracy", 0.05, 0.0528, "deg"), RESULTS)
    assert "reached 0.0528 deg at 120 s in the hold (98.8 to 158.8 s), 0.05 deg allowed" in line


def test_never_settled_and_not_a_number_are_said_in_words_not_as_inf_or_nan():
    # The review found "only never s after the slew" and "reached never deg": no number, no unit after it.
    line = failure_reason(row("settling_time", 60.0, math.inf), RESULTS)
    assert "never stays within the accuracy for the 30 s dwell by the end of the hold (158.8 s" in line
    line = failure_reason(row("pointing_accuracy", 0.05, math.nan, "deg"), RESULTS)
    assert "not a number in the hold" in line
    for text in (line, failure_reason(row("settling_time", 60.0, math.inf), RESULTS)):
        assert "only never" not in text and "inf" not in text and "nan" not in text


def test_an_unstable_sampled_loop_names_itself_as_the_cause():
    findings = [{"id": "pd_sampled_loop_unstable", "message": "sampled PD loop unstable: wn 20 rad/s", "figures": {}}]
    results = {**RESULTS, "linear": {"findings": findings}}
    assert failure_reason(row("pointing_accuracy", 0.05, 0.2, "deg"), results).endswith(
        "; likely cause: sampled PD loop unstable: wn 20 rad/s"
    )
    # A margin check without a figure (an unstable loop has none) says why, not "no figure could be computed".
    check = {**row("pd_gain_margin", 6.0, None, "dB"), "comparison": ">="}
    assert failure_reason(check, results) == "no margin: sampled PD loop unstable: wn 20 rad/s"

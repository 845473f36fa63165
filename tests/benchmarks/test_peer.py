"""The Basilisk peer of a speed figure (benchmarks/_peer.py).

Checked against a reference file written here with known medians: a figure
is divided by its own case's median (not another case's), names the case,
and has a null ratio with the reason when the file is absent; a file that is
not a reference is refused with its path.
"""

from __future__ import annotations

import json

import pytest

from benchmarks import _peer


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

"""Progress on stderr from the ``attitude`` command: status lines, progress bars and ``--quiet``.

What each test checks against: the rule the command documents (module
docstring of :mod:`attitude.app.cli` and ``--help``), read off stderr. On a
terminal (a stderr whose ``isatty()`` is True) the long commands draw tqdm
bars besides their status lines; on a pipe or a log (CI) only the status
lines are written; ``--quiet`` writes neither (design, slew, momentum and
montecarlo). stdout holds the results
only (with ``--json``, a document that parses). The design's bar counts the
nine steps of :func:`attitude.app.design.run.run_design` and names the
current one; it is tested on a stand-in for the design (the whole design
takes tens of seconds and is run end to end in test_cli.py).
"""

from __future__ import annotations

import io
import json
import re
import sys
from types import SimpleNamespace

import pytest

import attitude.app.design.run as design_run
import attitude.app.report.writer as report_writer
import attitude.progress
from attitude.app.cli import main
from attitude.app.design.run import STEPS


class Terminal(io.StringIO):
    """A text stream that says it is a terminal."""

    def isatty(self) -> bool:
        return True


def bar_frames(text: str, desc: str) -> list[str]:
    """The frames of the bar called ``desc`` (tqdm redraws its line after a carriage return)."""
    return [f for f in re.split(r"[\r\n]", text) if f.startswith(f"{desc}:") and "%|" in f]


LABELS = [f"step {k}: what it does" for k in range(1, STEPS + 1)]


@pytest.fixture
def stand_in_design(monkeypatch, tmp_path):
    """``run_design`` replaced by its progress calls alone, and the report writer by a stub."""

    def run_design(config, options=None, progress=None, on_step=None):
        for k, label in enumerate(LABELS, start=1):
            on_step(k, label)
            progress(f"[{k}/{STEPS}] {label} ...")
            progress(f"[{k}/{STEPS}] {label}: done in 0.0 s")
        return SimpleNamespace(results={"verdict": {"pass": True}}, passed=True)

    def write_report(result, out):
        return {name: str(tmp_path / name) for name in ("report_md", "report_html", "results_json")}

    monkeypatch.setattr(design_run, "run_design", run_design)
    monkeypatch.setattr(report_writer, "write_report", write_report)
    monkeypatch.setattr(report_writer, "requirements_text", lambda results: "the requirements table")
    return ["design", "--out", str(tmp_path / "report")]


def test_design_draws_a_bar_over_its_steps_on_a_terminal(stand_in_design, monkeypatch, capsys):
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    assert main(stand_in_design) == 0
    text = stderr.getvalue()
    frames = bar_frames(text, "attitude design")
    # Each step's frame shows the steps done before it and the step's name (its label up to the colon,
    # not the rest); the last, every step done.
    for k, label in enumerate(LABELS, start=1):
        assert any(f"{k - 1}/{STEPS}" in f and f"step {k}" in f for f in frames), label
    assert not any("what it does" in f for f in frames)
    assert f"{STEPS}/{STEPS}" in frames[-1] and "100%" in frames[-1]
    # The status lines are still written, whole (above the bar).
    lines = text.splitlines()
    for k, label in enumerate(LABELS, start=1):
        assert any(line.endswith(f"[{k}/{STEPS}] {label}: done in 0.0 s") for line in lines)
    assert capsys.readouterr().out.startswith("the requirements table")


def test_design_off_a_terminal_writes_the_status_lines_only(stand_in_design, capsys):
    assert main(stand_in_design) == 0
    err = capsys.readouterr().err  # pytest's capture: not a terminal
    assert bar_frames(err, "attitude design") == [] and "\r" not in err
    for k, label in enumerate(LABELS, start=1):
        assert f"[{k}/{STEPS}] {label} ...\n" in err


def test_design_quiet_writes_nothing_on_stderr(stand_in_design, monkeypatch, capsys):
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    assert main([*stand_in_design, "--quiet"]) == 0
    assert stderr.getvalue() == ""
    assert "the requirements table" in capsys.readouterr().out


MONTECARLO = ["montecarlo", "--guidance", "eigenaxis", "--no-keep-out", "--runs", "2", "--workers", "1", "--json"]


def test_montecarlo_bar_on_a_terminal_and_quiet(monkeypatch, capsys, tmp_path):
    from attitude.config import default_config_text

    # Requirements judged over 5 s (an allowed slew of 2 s, 1 s of settling, a 2 s hold): short runs.
    short = tmp_path / "short.toml"
    short.write_text(
        default_config_text()
        .replace("time_max_s = 120.0", "time_max_s = 2.0")
        .replace("settling_time_s = 60.0", "settling_time_s = 1.0")
        .replace("hold_time_s = 60.0", "hold_time_s = 2.0")
    )
    argv = [MONTECARLO[0], str(short), *MONTECARLO[1:]]
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    assert main([*argv, "--out", str(tmp_path / "mc")]) in (0, 1)
    frames = bar_frames(stderr.getvalue(), "Monte Carlo")
    assert frames and "2/2" in frames[-1] and "errors" in frames[-1]
    assert "Monte Carlo campaign of" in stderr.getvalue()  # the status line
    assert json.loads(capsys.readouterr().out)["runs"] == 2  # --json: stdout is the document alone

    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    assert main([*argv, "--out", str(tmp_path / "quiet"), "--quiet"]) in (0, 1)
    assert stderr.getvalue() == ""
    assert json.loads(capsys.readouterr().out)["runs"] == 2


def test_slew_planner_bar_on_a_terminal_and_quiet(monkeypatch, capsys):
    monkeypatch.setattr(attitude.progress, "REFRESH_PERIOD_S", 0.0)  # every update drawn: a frame per start
    args = ["slew", "--nodes", "20", "--json"]
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    main(args)
    frames = bar_frames(stderr.getvalue(), "slew planning")
    assert any("1/2" in f for f in frames) and any("2/2" in f for f in frames)  # PLAN_STARTS = 2
    assert "planning the slew" in stderr.getvalue()
    planned = json.loads(capsys.readouterr().out)

    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    main([*args, "--quiet"])
    assert stderr.getvalue() == ""
    again = json.loads(capsys.readouterr().out)["slews"]["plan"]
    for key in ("duration_s", "rate_peak_deg_per_s", "torque_peak_mNm", "energy_N2m2s"):  # the same plan
        assert again[key] == planned["slews"]["plan"][key], key


def test_momentum_unloading_bar_on_a_terminal_and_quiet(monkeypatch, capsys):
    args = ["momentum", "--orbits", "0.5", "--json"]
    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    main(args)
    frames = bar_frames(stderr.getvalue(), "unloading over 0.5 orbits")
    assert frames and "attitude momentum:" in stderr.getvalue()
    budget = json.loads(capsys.readouterr().out)["momentum"]

    stderr = Terminal()
    monkeypatch.setattr(sys, "stderr", stderr)
    main([*args, "--quiet"])
    assert stderr.getvalue() == ""
    assert json.loads(capsys.readouterr().out)["momentum"]["unloading"] == budget["unloading"]


@pytest.mark.parametrize("command", ["design", "slew", "momentum", "montecarlo"])
def test_quiet_is_documented_in_each_long_command(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--quiet" in text
    assert "neither the status lines nor the progress bars" in text
    assert "progress bars with an ETA when stderr is a terminal" in text

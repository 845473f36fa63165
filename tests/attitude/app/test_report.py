"""The design report: its writers, and the HTML report in a real headless browser.

The browser test loads ``report.html`` in Debian's ``chromium`` (headless),
checks that every image decoded (``naturalWidth > 0``, at the PNG's own
size) and saves a screenshot next to the report. CI installs chromium
(``.ci/run``); on a machine without it the test is skipped with the reason.

Method: a copy of the report gets a small script that, on the ``load``
event, writes each image's ``complete``/``naturalWidth``/``naturalHeight``
into a ``<pre id="image-check">`` element; ``chromium --dump-dom`` prints
the DOM after the page has loaded (``--virtual-time-budget`` lets the
script run first), and the test parses that element. The screenshot is a
second run with ``--screenshot``. Both read a local file with networking
off, so nothing depends on the network.
"""

from __future__ import annotations

import base64
import copy
import json
import math
import os
import re
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest

from attitude.app.design.run import DesignOptions, requirement_verdicts, run_design
from attitude.app.report.sections import Figure, Heading, Paragraph, Table, build_blocks, fmt
from attitude.app.report.writer import (
    dumps_json,
    is_numeric,
    render_html,
    render_markdown,
    requirements_text,
    to_jsonable,
    write_report,
)
from attitude.config import default_config

CHROMIUM = shutil.which("chromium")
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--hide-scrollbars",
    "--virtual-time-budget=10000",
]
#: Upper bound of one browser run [s]; a load takes about a second.
BROWSER_TIMEOUT_S = 120

_CHECK_SCRIPT = """<script>
window.addEventListener("load", function () {
  var out = Array.from(document.images).map(function (img) {
    return {id: img.closest("figure") ? img.closest("figure").id : "", complete: img.complete,
            width: img.naturalWidth, height: img.naturalHeight};
  });
  var pre = document.createElement("pre");
  pre.id = "image-check";
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
});
</script>"""


@pytest.fixture(scope="module")
def design():
    """A real design of the default spacecraft (--quick)."""
    return run_design(default_config(), DesignOptions(quick=True))


@pytest.fixture(scope="module")
def report(design, tmp_path_factory) -> tuple[Path, dict]:
    """Its report, written by the same code as `attitude design`."""
    out = tmp_path_factory.mktemp("report")
    write_report(design, out)
    return out, json.loads((out / "results.json").read_text(encoding="utf-8"))


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


# ---------------------------------------------------------------------------
# Writers


def test_json_is_strict_and_keeps_non_finite_numbers_as_strings():
    data = {"a": np.float64(1.5), "b": [math.inf, -math.inf, math.nan], "c": np.arange(3), "d": np.bool_(True)}
    text = dumps_json(data)
    assert json.loads(text) == {"a": 1.5, "b": ["inf", "-inf", "nan"], "c": [0, 1, 2], "d": True}
    assert [float(v) for v in json.loads(text)["b"]][:2] == [math.inf, -math.inf]
    with pytest.raises(TypeError, match="cannot write"):
        to_jsonable({"x": object()})


def test_number_format_and_alignment():
    assert [fmt(v) for v in (None, True, 3, 0.0, 35.354795, 1.1153e-6, math.inf, -math.inf)] == [
        "n/a",
        "yes",
        "3",
        "0",
        "35.35",
        "1.115e-06",
        "inf",
        "-inf",
    ]
    assert all(is_numeric(t) for t in ("12.5", "-0.3", "inf", "n/a", "<= 0.05 deg", "[1, 0, 0]", ".5"))
    assert not any(is_numeric(t) for t in ("PD", "stable", "sampled (10 Hz)", "requirements.slew.time_max_s"))


def test_markdown_and_html_render_the_same_blocks():
    blocks = [
        Heading(1, "Title <&>", "top"),
        Heading(2, "1. Section", "s1"),
        Paragraph("a | b & c"),
        Table(("name", "value", "verdict"), (("x|y", "1.5", "PASS"), ("z", "n/a", "FAIL")), "cap"),
        Figure("fig", "A figure"),
    ]
    md = render_markdown(blocks)
    assert "| name | value | verdict |" in md and "| :--- | ---: | :--- |" in md
    assert "x\\|y" in md and "![A figure](figures/fig.png)" in md
    png = b"\x89PNG\r\n\x1a\n" + b"\x00" * 16
    html = render_html(blocks, {"fig": png}, title="T", passed=False)
    assert "Title &lt;&amp;&gt;" in html and "a | b &amp; c" in html
    assert '<td class="num">1.5</td>' in html and '<td class="pass">PASS</td>' in html and 'class="fail"' in html
    assert 'href="#s1"' in html and "data:image/png;base64," in html
    assert '<span class="verdict fail">FAIL</span>' in html


def test_markdown_neutralises_raw_html_from_the_spacecraft_file():
    """Issue 13, item 15: report.md copied raw HTML from the file (a name or description with ``<script>``
    or ``<img onerror>``) that a Markdown viewer would run; report.html already escaped it."""
    hostile = 'Sat <script>alert(1)</script> <img src=x onerror="alert(2)"> <!-- c -->'
    blocks = [
        Heading(1, hostile, "top"),
        Paragraph(hostile),
        Table(("name", "value"), ((hostile, "1.5"),), hostile),
        Figure("fig", hostile),
    ]
    md = render_markdown(blocks)
    assert "<script" not in md and "<img" not in md and "</script" not in md and "<!--" not in md
    assert md.count("&lt;script>") == 6  # heading, paragraph, table caption, cell, figure alt text and caption
    # The report's own comparisons stay readable text.
    assert "<= 120 s" in render_markdown([Paragraph("slew time <= 120 s, error < 0.05 deg")])


def test_report_folder(report):
    out, results = report
    md = (out / "report.md").read_text(encoding="utf-8")
    html = (out / "report.html").read_text(encoding="utf-8")
    # The terminal table is the report's requirements table.
    text = requirements_text(results)
    for row in results["requirements"]:
        assert row["requirement"] in text and row["requirement"] in md
    verdict_line = next(line for line in text.splitlines() if line.startswith("Verdict: "))
    assert verdict_line.startswith("Verdict: PASS" if results["verdict"]["pass"] else "Verdict: FAIL")
    # After the verdict: the FAIL reasons, then the diagnostics (mismatch findings, saturation), nothing else.
    tail = text.splitlines()[text.splitlines().index(verdict_line) + 1 :]
    assert all(line.startswith(("  FAIL ", "Mismatch: ", "Saturation (closed loop): ")) for line in tail), tail
    # Each embedded image is the PNG in figures/, byte for byte.
    embedded = re.findall(r'<figure id="fig-([\w]+)"><img src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    assert sorted(name for name, _ in embedded) == sorted(results["figures"])
    for name, data in embedded:
        assert base64.b64decode(data) == (out / "figures" / f"{name}.png").read_bytes()
    # Settings and timings are reported.
    assert "quick run" in md and "Wall time per step" in md


def test_missing_sections_fail_their_requirements_and_still_render(design):
    """Nothing flown (neither slew could be planned): the rows that need a flight fail, the report says why."""
    results = copy.deepcopy(design.results)
    results["slews"]["plan"] = None
    results["slews"]["error"] = "SlewPlanningError: no start converged"
    results["closed_loop"] = None
    results["estimation"] = None
    # The dispersed check plans the same slew, so it cannot fly either (dispersed_check's error form).
    results["dispersed"] = {"runs": 10, "error": "SlewPlanningError: no start converged", "command": "attitude ..."}
    verdicts = requirement_verdicts(design.config, results)
    rows = {r["id"]: r for r in verdicts["requirements"]}
    # The momentum budget of section 6 needs no flown slew: it is judged on its own figures.
    budget = rows.pop("wheel_momentum_budget")
    assert budget["achieved"] == max(results["orbit"]["momentum"]["unloading"]["peak_per_wheel_mNms"])
    # Nor does the disk margin of section 2: the linear design's smallest PD margin at the input.
    margin = rows.pop("disk_margin")
    at_input = [m for m in results["linear"]["disk_margins"] if m["controller"] == "PD" and m["break_point"] == "input"]
    assert margin["achieved"] == min(m["disk_margin"] for m in at_input) and margin["pass"]
    assert all(r["achieved"] is None and not r["pass"] for r in rows.values())
    assert not verdicts["verdict"]["pass"] and set(verdicts["verdict"]["failed"]) == set(rows)
    results.update(verdicts)
    md = render_markdown(build_blocks(results))
    assert "no start converged" in md and "Nothing to fly" in md and "estimation not analysed" in md
    assert "The dispersed check could not be flown, so it fails" in md
    assert "| n/a | FAIL |" in md


# ---------------------------------------------------------------------------
# A real browser


def run_chromium(*args: str, profile: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [CHROMIUM, *CHROMIUM_FLAGS, f"--user-data-dir={profile}", *args],
        capture_output=True,
        text=True,
        timeout=BROWSER_TIMEOUT_S,
        check=False,
    )


def test_html_report_shows_every_figure_in_chromium(report, tmp_path):
    if CHROMIUM is None:
        # CI installs chromium (.ci/run), so there a missing browser is a failure, not a skip.
        if os.environ.get("CI"):
            pytest.fail("no `chromium` on PATH under CI: .ci/run should have installed it")
        pytest.skip("no `chromium` on PATH (Debian: apt-get install chromium); CI installs it")
    out, results = report
    html = (out / "report.html").read_text(encoding="utf-8")
    probe = out / "report_image_check.html"
    probe.write_text(html.replace("</body>", _CHECK_SCRIPT + "\n</body>"), encoding="utf-8")
    proc = run_chromium("--dump-dom", probe.as_uri(), profile=tmp_path / "profile-dom")
    match = re.search(r'<pre id="image-check">(.*?)</pre>', proc.stdout, flags=re.DOTALL)
    assert match, f"chromium did not run the check (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    images = json.loads(match.group(1))
    assert len(images) == len(results["figures"]) > 0
    for img in images:
        name = img["id"].removeprefix("fig-")
        assert img["complete"] and img["width"] > 0, f"image {name} did not decode: {img}"
        expected = png_size((out / "figures" / f"{name}.png").read_bytes())
        assert (img["width"], img["height"]) == expected, f"{name} decoded at the wrong size"

    shot = out / "report_screenshot.png"
    proc = run_chromium(
        f"--screenshot={shot}",
        "--window-size=1280,2400",
        (out / "report.html").as_uri(),
        profile=tmp_path / "profile-shot",
    )
    assert shot.is_file(), f"no screenshot (exit {proc.returncode}):\n{proc.stderr[-3000:]}"
    assert png_size(shot.read_bytes()) == (1280, 2400) and shot.stat().st_size > 50_000
    print(f"screenshot of the report: {shot}")


def test_the_report_records_what_it_was_made_with(report):
    # Issue 12: the toolkit version, the date, the spacecraft file's hash and the package versions.
    import hashlib

    from attitude.config import default_config_text

    out, results = report
    p = results["provenance"]
    digest = hashlib.sha256(default_config_text().encode("utf-8")).hexdigest()
    assert p["input"]["sha256"] == digest
    text = (out / "report.md").read_text(encoding="utf-8")
    assert f"Spacecraft file SHA-256: {digest}" in text and f"attitude-toolkit {p['toolkit_version']}" in text
    assert f"numpy {p['packages']['numpy']}" in text


def test_the_linear_section_reports_disk_margins_at_both_break_points(report):
    """Section 2's disk-margin table: for each controller, the three axes alone and all at once at the plant
    input, all six measurements at once at the output. The multiloop margin can never exceed a loop-at-a-time one
    at the same break point (the single-channel perturbations are among the simultaneous ones), so a row
    breaking that order would be a wrong table; every row is stable and converged on the default spacecraft."""
    out, results = report
    rows = results["linear"]["disk_margins"]
    for controller in ("PD", "LQR"):
        mine = [r for r in rows if r["controller"] == controller]
        assert [(r["break_point"], r["channel"]) for r in mine] == [
            ("input", "x alone"),
            ("input", "y alone"),
            ("input", "z alone"),
            ("input", "all at once"),
            ("output", "all at once"),
        ]
        assert all(r["stable"] and r["converged"] for r in mine)
        alone = min(float(r["disk_margin"]) for r in mine[:3])
        assert float(mine[3]["disk_margin"]) <= alone * (1 + 1e-3)  # slycot's bound: 1e-3
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "| PD | rigid | output | all at once |" in md and "(figures/disk_margins.png)" in md


def test_section_two_reports_the_tuning_before_and_after_and_the_worst_case(design):
    """The default file has requirements.disk_margin_min: section 2 shows the file's gains before and the tuned ones
    after, each metric with its requirement, and the tuned step confirmed on the nonlinear plant. With an
    [uncertainty] study (a small budget here: a test of the rendering, not of the search) the worst case and its
    plant are stated; without one the report says there is none."""
    from attitude.app.design.robust import robust_study
    from attitude.config import default_config_text, parse_config

    tuning = design.results["linear"]["tuning"]
    assert tuning["feasible"] and tuning["before"]["bandwidth_rad_per_s"] == design.config.control.bandwidth_rad_per_s
    assert tuning["after"]["disk_margin"] >= design.config.requirements.disk_margin_min
    assert tuning["nonlinear"]["passed"]
    md = render_markdown(build_blocks(design.results))
    assert "| disk_margin | 1.125 |" in md and "before (the file)" in md
    assert "No [uncertainty] table in the spacecraft file" in md
    results = copy.deepcopy(design.results)
    config = parse_config(default_config_text() + "\n[uncertainty]\ninertia_percent = 10.0\n", "test.toml")
    budget = {"samples": 6, "maxiter": 1, "popsize": 1, "local_starts": 1, "local_maxfev": 4, "seed": 2}
    results["linear"]["robust"], _ = robust_study(config, step_metric=None, **budget)
    md = render_markdown(build_blocks(results))
    assert "Worst case over the [uncertainty] set" in md and "worst plant: moments" in md

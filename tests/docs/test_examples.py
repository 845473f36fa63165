"""Every script in ``examples/`` runs to completion and saves its figures.

The rule for examples (each new script is picked up by the glob below, so it
must follow it):

* it is runnable as ``python examples/NAME.py`` and accepts two flags:
  ``--quick`` (a shorter run, a few seconds, that still exercises every code
  path) and ``--out DIR`` (where to write its figures; the directory may not
  exist yet);
* it saves at least one non-empty PNG into ``--out``;
* it exits with status 0 and works headless (``MPLBACKEND=Agg``).

Each example runs in its own interpreter (``sys.executable``), from the
repository root, with a bounded time.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))
#: Upper bound per example [s]; a --quick run takes seconds, this only stops a hang.
TIMEOUT_S = 300


def test_examples_exist():
    assert EXAMPLES, f"no example scripts found in {ROOT / 'examples'}"


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_example_runs_and_saves_figures(script: Path, tmp_path: Path):
    out = tmp_path / "figures"
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.run(
        [sys.executable, str(script), "--quick", "--out", str(out)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        check=False,
    )
    assert proc.returncode == 0, (
        f"{script.name} exited with {proc.returncode}\n--- stdout ---\n{proc.stdout[-4000:]}\n"
        f"--- stderr ---\n{proc.stderr[-4000:]}"
    )
    pngs = sorted(out.rglob("*.png")) if out.exists() else []
    assert pngs, f"{script.name} wrote no PNG into --out {out}"
    empty = [p.name for p in pngs if p.stat().st_size == 0]
    assert not empty, f"{script.name} wrote empty PNG files: {empty}"
    for png in pngs:
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f"{png.name} is not a PNG file"

"""The floors of DESIGN.md: import-linter contracts (pyproject.toml) and what importing the physics costs.

`make test` runs ``lint-imports`` on the tree. These tests show the contracts
can fail (a copy of the packages with one forbidden import, or one cycle,
breaks them) and check what import-linter cannot see: that importing a math
or dynamics module leaves matplotlib, python-control and filterpy unloaded.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")

#: The math and dynamics modules of the contract "import neither matplotlib nor control nor filterpy".
PHYSICS_MODULES = (
    "attitude.quaternion",
    "attitude.euler_angles",
    "attitude.rigid_body",
    "attitude.analytic",
    "attitude.flexible",
    "attitude.integrators",
    "attitude.propagate",
    "attitude.backend",
    "attitude.actuators",
    "attitude.environment",
    "attitude.sensors",
    "attitude.sun_sensors",
    "attitude.simulation",
    "attitude.simulation.batch",
    "attitude.simulation.batch_estimated",
    "attitude.simulation.kernel",
    "attitude.simulation.codegen",
    "attitude.environment.orbit",
    "attitude.environment.gravity_gradient",
    "attitude.rng",
    "attitude.validation",
)


def _lint_copy(tmp_path: Path, edit_file: str, line: str) -> subprocess.CompletedProcess:
    """Run lint-imports on a copy of the packages with ``line`` appended to ``edit_file``."""
    for package in ("attitude", "controllers", "estimation"):
        shutil.copytree(ROOT / package, tmp_path / package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    target = tmp_path / edit_file
    target.write_text(target.read_text(encoding="utf-8") + "\n" + line + "\n", encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    return subprocess.run(
        [str(LINT_IMPORTS), "--no-cache"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )


def test_the_contracts_hold_on_the_tree():
    proc = subprocess.run([str(LINT_IMPORTS), "--no-cache"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout[-3000:]
    assert "0 broken" in proc.stdout


@pytest.mark.parametrize(
    ("edit_file", "line", "broken"),
    [
        # The core importing a controller (the floors' first rule).
        ("attitude/quaternion.py", "import controllers.pd", "The attitude core never imports"),
        # estimation importing controllers (independence).
        ("estimation/consistency.py", "import controllers.pd", "independent"),
        # A file-level cycle between two siblings: rigid_body already imports quaternion.
        ("attitude/quaternion.py", "import attitude.rigid_body", "No import cycles"),
        # The report writing with a controller in hand.
        ("attitude/app/report/sections.py", "import controllers.pd", "The report and the body study"),
        # A physics module importing matplotlib at module level.
        ("attitude/integrators.py", "import matplotlib.figure", "import neither matplotlib"),
    ],
)
def test_a_forbidden_import_breaks_its_contract(tmp_path, edit_file, line, broken):
    proc = _lint_copy(tmp_path, edit_file, line)
    assert proc.returncode != 0, proc.stdout[-3000:]
    assert broken in proc.stdout.split("Broken contracts")[-1], proc.stdout[-3000:]


@pytest.mark.parametrize("module", PHYSICS_MODULES)
def test_importing_the_physics_leaves_matplotlib_control_and_filterpy_unloaded(module):
    code = f"import sys, {module}\nprint(sorted(m for m in ('matplotlib', 'control', 'filterpy') if m in sys.modules))"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert proc.stdout.strip() == "[]", f"{module} loads {proc.stdout.strip()}"


def test_importing_propagate_shows_no_matplotlib_or_scipy_integrate_in_importtime():
    """The issue's check: ``python -X importtime -c "from attitude.propagate import propagate"``."""
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "from attitude.propagate import propagate"],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    imported = {line.split("|")[-1].strip() for line in proc.stderr.splitlines() if line.startswith("import time:")}
    assert "attitude.propagate" in imported  # the check reads the right output
    assert not {m for m in imported if m.split(".")[0] == "matplotlib" or m.startswith("scipy.integrate")}

"""The design's robust study (attitude.app.design.robust) on the default spacecraft with an [uncertainty] table.

Checked against: the study's own promises on a file (a JSON document; the optimiser's worst at least as bad as
the sampled worst and as the nominal, on the same set; the figures named), the direct worst case of
worst plant's moments against the file's within the bounds, and the empty study
of a file without the table.
"""

import json

import numpy as np
import pytest

from attitude.app import assembly
from attitude.app.design.robust import robust_study
from attitude.config import default_config, default_config_text, parse_config

pytest.importorskip("slycot")  # multiloop margins; the dev extra installs it: this runs in CI

#: Moments only (3 parameters) and a small budget: a test, not the design's search.
TABLE = "\n[uncertainty]\ninertia_percent = 10.0\n"
BUDGET = {"samples": 6, "maxiter": 1, "popsize": 1, "local_starts": 1, "local_maxfev": 4, "seed": 2}


def test_the_study_reports_the_worst_case_of_the_files_pd_and_its_figures(tmp_path):
    config = parse_config(default_config_text() + TABLE, "test.toml")
    data, figures = robust_study(config, **BUDGET)
    json.dumps(data, allow_nan=False)  # JSON-ready, no NaN or inf
    margin = data["disk_margin"]
    assert margin["worst"] <= margin["sampled_worst"] and margin["worst"] <= margin["nominal"]
    assert data["step"]["worst"] >= data["step"]["sampled_worst"]
    assert set(figures) == {"robust_disk_margin", "robust_overshoot_percent"}
    figures["robust_disk_margin"].savefig(tmp_path / "robust_disk_margin.png")
    # The worst plant is the file's body with its moments changed within the bounds.
    change = np.array(margin["worst_plant"]["moment_change_percent"])
    assert np.all(np.abs(change) <= 10.0 + 1e-9)
    nominal = np.sort(np.linalg.eigvalsh(assembly.rigid_body(config).inertia))
    assert margin["worst_plant"]["principal_moments_kg_m2"] == pytest.approx(np.sort(nominal * (1 + change / 100)))


def test_without_the_table_the_study_is_empty_and_a_bad_metric_is_named():
    data, figures = robust_study(default_config())
    assert data["uncertainty"] is None and figures == {}
    with pytest.raises(ValueError, match="step_metric"):
        robust_study(default_config(), step_metric="rise_time")

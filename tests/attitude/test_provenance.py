"""Provenance (issue 12: every report and campaign records the toolkit version, the date, a hash of the input
file and the package versions): attitude.results.provenance, checked against hashlib, importlib.metadata and
the clock, and found in a campaign's campaign.json and a design report.
"""

import hashlib
import json
from datetime import UTC, datetime, timedelta
from importlib import metadata

import numpy as np

from attitude.results import provenance


def test_provenance_records_versions_the_date_and_the_files_hash(tmp_path):
    from attitude.config import default_config_text, load_config

    path = tmp_path / "craft.toml"
    path.write_text(default_config_text(), encoding="utf-8")
    config = load_config(path)
    # The hash is taken of the text parsed, when it is parsed: editing the file afterwards does not change it.
    assert config.source_sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    path.write_text("edited\n", encoding="utf-8")
    p = provenance(config.source, config.source_sha256)
    assert p["input"] == {"source": str(path), "sha256": hashlib.sha256(default_config_text().encode()).hexdigest()}
    assert p["packages"]["numpy"] == np.__version__ == metadata.version("numpy")
    assert p["toolkit_version"] == metadata.version("attitude-toolkit")
    made = datetime.fromisoformat(p["created_utc"])
    assert made.tzinfo is not None and abs(datetime.now(UTC) - made) < timedelta(minutes=1)
    assert "input" not in provenance()  # a result made in code, from no file
    json.dumps(p)  # JSON-ready


def test_a_campaign_records_its_provenance(tmp_path):
    from attitude.app.cli import main
    from attitude.config import DEFAULT_CONFIG_FILE, default_config_text

    argv = ["montecarlo", "--runs", "2", "--nodes", "30", "--vectorized", "--workers", "1"]
    main([*argv, "--out", str(tmp_path / "mc")])
    p = json.loads((tmp_path / "mc" / "campaign.json").read_text())["info"]["provenance"]
    assert p["input"]["source"].endswith(DEFAULT_CONFIG_FILE)
    assert p["input"]["sha256"] == hashlib.sha256(default_config_text().encode("utf-8")).hexdigest()
    assert "casadi" in p["packages"] and "filterpy" in p["packages"]

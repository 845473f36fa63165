"""`attitude tune`: the tuned file reads back with the new gains and its other keys, and nothing is overwritten.

Checked against: the config reader (the written file parses, with the gains the tuning printed and every other
key as the input's), and the files on disk before and after.
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import math

import numpy as np
import pytest

from attitude.app import assembly
from attitude.app.cli import main
from attitude.app.design.tune import margin_loop, tune_config, tuning_requirements
from attitude.config import ConfigError, default_config, default_config_text, load_config, parse_config
from controllers.disk_margins import loop_disk_margins
from controllers.pd import QuaternionPD
from controllers.tuning import lqr_metrics, tune_pd


@pytest.fixture(scope="module")
def tuned(tmp_path_factory):
    """One tuning of the built-in file without the dispersed check (tested in the design), its JSON and files."""
    folder = tmp_path_factory.mktemp("tune")
    source = folder / "sat.toml"
    source.write_text(default_config_text(), encoding="utf-8")
    out = folder / "sat_tuned.toml"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["tune", str(source), "--runs", "0", "--json", "--quiet"])
    return source, out, code, json.loads(printed.getvalue())


def test_tune_writes_a_new_file_that_reads_back(tuned, capsys):
    """The new file parses with the tuned bandwidth and damping and every other table equal to the input's; the
    input is untouched; the trade-off figure is written beside it."""
    source, out, code, _ = tuned
    assert code == 0
    assert source.read_text(encoding="utf-8") == default_config_text()
    before, after = load_config(source), load_config(out)
    assert (after.control.bandwidth_rad_per_s, after.control.damping) != (0.4, 0.7)
    assert after.requirements == before.requirements and after.wheels_config == before.wheels_config
    assert after.control.lqr == before.control.lqr and after.control.period_s == before.control.period_s
    assert out.with_suffix(".png").stat().st_size > 10_000
    assert "# Tuned by `attitude tune`" in out.read_text(encoding="utf-8")


def test_tune_refuses_to_overwrite(tuned, capsys):
    """An existing NEWFILE is refused (exit 2, the file named) without --force, and the input never."""
    source, out, _, _ = tuned
    text = out.read_text(encoding="utf-8")
    assert main(["tune", str(source), "--out", str(out), "--runs", "0", "--quiet"]) == 2
    assert "exists; not overwritten" in capsys.readouterr().err
    assert out.read_text(encoding="utf-8") == text
    assert main(["tune", str(source), "--out", str(source), "--force", "--quiet"]) == 2
    assert "is the input file" in capsys.readouterr().err


def test_contradictory_file_names_the_keys():
    """A settling time below the bang-bang time of the step is refused naming the settling and torque keys: the
    1 deg step of [control.lqr] angle_max_deg takes 2 sqrt(theta I / tau) = 2 sqrt(0.01745 x 0.39 / 0.0162) = 1.30 s
    at the x axis's torque envelope, so 1 s contradicts it; with --step-deg 60 the 60 deg step takes 10.1 s, so 5 s
    does. A disk margin floor of 2 is refused by the reader with its key."""
    text = default_config_text().replace("settling_time_s = 60.0 ", "settling_time_s = 1.0  ")
    with pytest.raises(ConfigError, match=r"requirements\.settling_time_s, wheels\.torque_max_Nm"):
        tune_config(parse_config(text), dispersed_runs=0, tradeoff_points=0)
    text = default_config_text().replace("settling_time_s = 60.0 ", "settling_time_s = 5.0  ")
    tune_config(parse_config(text), dispersed_runs=0, tradeoff_points=0)  # 5 s is more than the 1 deg step's 1.3 s
    with pytest.raises(ConfigError, match=r"requirements\.settling_time_s, wheels\.torque_max_Nm"):
        tune_config(parse_config(text), dispersed_runs=0, tradeoff_points=0, step_deg=60.0)
    with pytest.raises(ConfigError, match=r"requirements\.disk_margin_min"):
        parse_config(default_config_text().replace("disk_margin_min = 0.8 ", "disk_margin_min = 2.0 "))


def test_requirements_from_the_file():
    """The step is the file's largest acceptable attitude error ([control.lqr] angle_max_deg = 1 deg: the planned
    slew's feedforward does the rest), or the whole 60 deg slew without [control.lqr] or with --step-deg; the
    accuracy 0.05 deg, the floor the file's 0.8."""
    req = tuning_requirements(default_config())
    assert req.step_angle == pytest.approx(math.radians(1.0), rel=1e-12)
    assert tuning_requirements(default_config(), step_deg=60.0).step_angle == pytest.approx(math.radians(60.0))
    without_lqr = dataclasses.replace(default_config().control, lqr=None)
    req = tuning_requirements(dataclasses.replace(default_config(), control=without_lqr))
    assert req.step_angle == pytest.approx(math.radians(60.0), rel=1e-12)
    assert req.pointing_accuracy == pytest.approx(math.radians(0.05), rel=1e-12)
    assert req.disk_margin_min == 0.8


def test_json_output_has_before_and_after(tuned):
    """--json prints the file's gains before and the binding requirement (the wheels' torque for the 1 deg step)."""
    summary = tuned[3]
    assert summary["before"]["bandwidth_rad_per_s"] == 0.4
    assert summary["feasible"] and summary["binding"] == ["torque_max"]
    assert [row["metric"] for row in summary["table"]][:2] == ["bandwidth_rad_per_s", "damping"]


def test_the_tuned_gains_are_judged_on_the_loops_that_fly():
    """The tuning judges the disk margin on the loops that fly: a file with a 2 Hz solar-array mode coupled strongly
    about z (participation 0.3 sqrt(kg) m: L^T L = 0.09 of the 0.21 kg m^2 about z) and a notch gets the flexible
    plant and the filters in its margin loop, as the design's verdict judges them. On that loop the rigid tuning's
    bandwidth (1.54 rad/s) leaves the z loop below the 0.8 floor (recomputed here with loop_disk_margins on
    assembly.flexible_plant_model), so the tuned PD is slower and meets the floor there, per axis and multiloop.
    The damping is fixed at the rigid optimum to keep the search short (the damping optimum is not what is
    tested)."""
    text = default_config_text().replace(
        "[requirements]\n",
        "[[flexible_modes]]\nfrequency_Hz = 2.0\ndamping = 0.005\nparticipation_B_sqrt_kg_m = [0.0, 0.0, 0.3]\n\n"
        "[requirements]\n",
        1,
    )
    config = parse_config(text)
    loop = margin_loop(config)
    assert loop.plant is not None and loop.command_filter is None and margin_loop(default_config()).rigid
    body, req = assembly.rigid_body(config), tuning_requirements(config)
    flexible = assembly.flexible_plant_model(config)
    rigid_tuned = QuaternionPD.from_bandwidth(body, wn=1.541, zeta=0.69, period=0.1)
    assert loop_disk_margins(flexible, rigid_tuned).smallest < 0.8
    result = tune_pd(body, req, period=0.1, loop=loop, damping_bounds=(0.69, 0.69), tradeoff_points=0)
    assert result.feasible and "disk_margin_min" in result.binding
    assert result.zeta == 0.69 and result.wn < 1.5  # equal damping bounds fix the damping
    tuned = QuaternionPD.from_bandwidth(body, wn=result.wn, zeta=result.zeta, period=0.1)
    assert loop_disk_margins(flexible, tuned).smallest >= 0.8


def test_a_contradictory_file_is_not_blamed_on_step_deg(tmp_path, capsys):
    """Contradictory requirements name their keys, not --step-deg (which was not given); a bad --step-deg is named."""
    path = tmp_path / "bad.toml"
    path.write_text(default_config_text().replace("settling_time_s = 60.0 ", "settling_time_s = 1.0  "))
    assert main(["tune", str(path), "--runs", "0", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "requirements.settling_time_s" in err and "--step-deg" not in err
    assert main(["tune", str(path), "--runs", "0", "--quiet", "--step-deg", "-1"]) == 2
    assert "--step-deg" in capsys.readouterr().err


@pytest.fixture(scope="module")
def tuned_lqr(tmp_path_factory):
    """`attitude tune --structure lqr` on the built-in file, with one dispersed body."""
    folder = tmp_path_factory.mktemp("tune_lqr")
    source = folder / "sat.toml"
    source.write_text(default_config_text(), encoding="utf-8")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["tune", str(source), "--structure", "lqr", "--runs", "1", "--json", "--quiet"])
    return source, folder / "sat_tuned.toml", code, json.loads(printed.getvalue())


def test_tune_lqr_writes_the_bryson_bounds_and_keeps_the_pd(tuned_lqr):
    """--structure lqr: the new file reads back with the tuned rate and torque bounds per axis (to the 6 digits
    written), angle_max_deg and the PD unchanged; the LQR designed from the file again meets the requirements on the
    same metrics (controllers.tuning.lqr_metrics of assembly.lqr), was flown in the nonlinear step and on a
    dispersed body of montecarlo.inertia."""
    source, out, code, summary = tuned_lqr
    assert code == 0, summary["message"]
    before, after = load_config(source), load_config(out)
    assert after.control.lqr.angle_max_deg == before.control.lqr.angle_max_deg
    assert (after.control.bandwidth_rad_per_s, after.control.damping) == (0.4, 0.7)
    rows = {row["metric"]: row for row in summary["table"]}
    for k, axis in enumerate("xyz"):
        assert after.control.lqr.rate_max_deg_per_s[k] == pytest.approx(
            rows[f"lqr.rate_max_deg_per_s ({axis})"]["after"], rel=1e-5
        )
        assert after.control.lqr.torque_max_Nm[k] == pytest.approx(
            rows[f"lqr.torque_max_Nm ({axis})"]["after"], rel=1e-5
        )
    req = tuning_requirements(after)
    metrics = lqr_metrics(assembly.rigid_body(after), req, assembly.lqr(after)[1])
    assert metrics.settling_time <= req.settling_time and metrics.disk_margin >= req.disk_margin_min
    assert np.all(metrics.peak_torque <= req.torque_max * (1 + 1e-4))  # 6 written digits: 1e-5 of the torque
    assert summary["structure"] == "lqr" and summary["nonlinear"]["passed"]
    assert summary["dispersed"]["runs"] == 1 and summary["dispersed"]["failures"] == 0


def test_tune_lqr_without_its_table_names_the_key():
    """--structure lqr tunes [control.lqr]: a file without it is refused naming control.lqr."""
    without_lqr = dataclasses.replace(default_config().control, lqr=None)
    with pytest.raises(ConfigError, match=r"control\.lqr"):
        tune_config(dataclasses.replace(default_config(), control=without_lqr), structure="lqr", dispersed_runs=0)


def test_tune_pd_per_axis_writes_three_values_that_fly(tmp_path, capsys):
    """--structure pd_per_axis: the new file reads back with a bandwidth and damping per axis (six digits, the
    bandwidth rounded down so the limits the search met still hold: the peak torque J wn^2 theta_0 of each axis
    recomputed here stays within the wheels' envelope), faster than the shared PD on the axes the weakest does not
    hold back (y and z), and its tuned PD flew the nonlinear step and one run of the dispersed campaign (the
    planned slew tracked with the per-axis gains)."""
    source = tmp_path / "sat.toml"
    source.write_text(default_config_text(), encoding="utf-8")
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["tune", str(source), "--structure", "pd_per_axis", "--runs", "1", "--json", "--quiet"])
    summary = json.loads(printed.getvalue())
    assert code == 0, summary["message"]
    after = load_config(tmp_path / "sat_tuned.toml")
    wn, zeta = np.array(after.control.bandwidth_rad_per_s), np.array(after.control.damping)
    assert wn.shape == (3,) and zeta.shape == (3,) and wn[1] > wn[0] and wn[2] > wn[0]
    req = tuning_requirements(after)
    body = assembly.rigid_body(after)
    peak_torque = np.linalg.norm(body.inertia, axis=0) * wn**2 * req.step_angle
    assert np.all(peak_torque <= req.torque_max)
    assert summary["nonlinear"]["passed"] and summary["dispersed"]["runs"] == 1
    assert summary["dispersed"]["failures"] == 0

"""The ``attitude`` command: design, slew, physics and init (top floor: may import controllers and estimation).

Run ``attitude --help`` (or ``python -m attitude --help``) and
``attitude COMMAND --help``. Every command reads a spacecraft file (TOML,
see ``attitude init``) or, without one, the built-in default spacecraft.

Exit codes (the same in ``--help``)
    0: done, and every requirement judged passes (``physics`` and ``init``
    judge none: 0 unless the input is bad);
    1: a requirement fails: ``design`` (any row, the dispersed check
    included), ``slew`` (the plan against ``[requirements.slew]``, or no plan
    found), ``momentum`` (a wheel's momentum beyond ``[momentum]
    wheel_momentum_margin``), ``montecarlo`` (a run failed a requirement,
    raised or was not run, or no plan was found; with ``--replay``, that run
    fails);
    2: bad input: the file or the command line cannot be used. The message
    names the file and the key, with no traceback;
    130: interrupted (Ctrl-C): one line with the command that starts the
    work again (a Monte Carlo campaign resumes from its checkpoint);
    141: stdout closed early (``attitude physics | head -3``), quietly.

Progress goes to stderr: one status line per long step, and, when stderr is
a terminal, progress bars with an ETA (tqdm: the design's steps, the slew
planner's starts, a campaign's runs). ``--quiet`` silences both; errors are
still printed. Results go to stdout (with ``--json``, stdout holds only the
JSON document; ``--json`` does not change stderr).
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import re
import sys
import time
import tomllib
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from attitude import __version__
from attitude.config import (
    ConfigError,
    SpacecraftConfig,
    config_from_dict,
    config_to_toml,
    default_config,
    default_config_text,
    load_config,
)

__all__ = ["main"]

EXIT_PASS, EXIT_FAIL, EXIT_BAD_INPUT = 0, 1, 2
#: Exit code after Ctrl-C: 128 + SIGINT, what a shell reports for a tool stopped by it.
EXIT_INTERRUPTED = 130

_FILE_HELP = "spacecraft file (TOML); default: the built-in 12U CubeSat (write it out with `attitude init FILE`)"
_EPILOG = """\
exit codes:
  0    done, and every requirement judged passes (physics and init judge
       none: 0 unless the input is bad)
  1    a requirement fails: design (any row, the dispersed check included),
       slew (the plan against [requirements.slew], or no plan found), momentum
       (a wheel's momentum beyond [momentum] wheel_momentum_margin), montecarlo
       (a run failed a requirement, raised or was not run, or no plan was
       found; with --replay, that run fails)
  2    bad input: the file or the command line (the message names the file and
       the key)
  130  interrupted (Ctrl-C): the same command starts again (montecarlo resumes
       its checkpoint)

progress: status lines on stderr, and progress bars with an ETA when stderr
is a terminal; --quiet (design, slew, momentum, montecarlo) silences both
(errors are still printed).

examples:
  attitude init my_sat.toml              # a commented starting point
  attitude design my_sat.toml --out report/
  attitude slew my_sat.toml --to "angle_deg=90 axis_B=0,1,0"
  attitude physics my_sat.toml --json
"""


class UsageError(ValueError):
    """A command-line value that cannot be used (exit code 2)."""


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text!r}")
    return value


def _count(minimum: int) -> Any:
    """An argparse type: an integer at least ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}, got {value}")
        return value

    return parse


def _scheduler_address(text: str) -> str:
    if not re.match(r"^((tcp|tls|ws|wss)://[^\s:/]+:\d+|(inproc|ucx)://\S+)/?$", text):
        raise argparse.ArgumentTypeError(f"expected a Dask scheduler address like tcp://HOST:8786, got {text!r}")
    return text


def _nodes(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 4:
        raise argparse.ArgumentTypeError(f"must be at least 4, got {value}")
    return value


#: Help of ``--quiet`` (design, slew, momentum, montecarlo).
_QUIET_HELP = (
    "print no progress on stderr: neither the status lines nor the progress bars (errors are still printed; "
    "without --quiet the bars are drawn only when stderr is a terminal)"
)


def _progress(message: str, quiet: bool = False) -> None:
    """One status line on stderr, written above any progress bar being drawn; nothing when ``quiet``."""
    if quiet:
        return
    from tqdm import tqdm

    tqdm.write(message, file=sys.stderr)
    sys.stderr.flush()


def _status_lines(logger_name: str, quiet: bool) -> Callable[[], None]:
    """Print a library logger's INFO records as status lines (:func:`_progress`) until the returned call."""

    class Lines(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            _progress(record.getMessage(), quiet)

    logger, handler = logging.getLogger(logger_name), Lines(logging.INFO)
    level = logger.level
    logger.addHandler(handler)
    logger.setLevel(min(level or logging.INFO, logging.INFO))

    def stop() -> None:
        logger.removeHandler(handler)
        logger.setLevel(level)

    return stop


def _bars(args: argparse.Namespace) -> bool | None:
    """The ``progress`` of the progress bars: False with ``--quiet``, else None (drawn on a terminal only)."""
    return False if args.quiet else None


def _load(file: str | None) -> SpacecraftConfig:
    if file is None:
        return default_config()
    return load_config(file)


# ---------------------------------------------------------------------------
# design


#: What ``attitude design`` writes into its folder (besides figures/*.png).
REPORT_FILES = ("report.md", "report.html", "results.json", "spacecraft.toml")


def _check_report_folder(out: Path, input_file: str | None, force: bool) -> None:
    """Refuse to overwrite the input file (ever) or an existing report (without ``--force``)."""
    if input_file is not None:
        resolved = out / "spacecraft.toml"
        source = Path(input_file)
        if resolved.exists() and source.exists() and resolved.samefile(source):
            raise UsageError(
                f"--out {out}: the report's resolved copy spacecraft.toml would overwrite the input file "
                f"{input_file}; choose another folder"
            )
    existing = [str(out / name) for name in REPORT_FILES if (out / name).exists()]
    if existing and not force:
        raise UsageError(
            f"--out {out}: holds a report already ({', '.join(existing)}); use --force to replace it, or "
            "choose another folder"
        )


def _cmd_design(args: argparse.Namespace) -> int:
    from attitude.app.design.run import STEPS, DesignOptions, run_design
    from attitude.app.report.writer import dumps_json, requirements_text, write_report
    from attitude.progress import progress_bar

    if args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out {args.out}: exists and is not a folder")
    _check_report_folder(args.out, args.file, args.force)
    config = _load(args.file)
    options = DesignOptions(quick=args.quick, spin_rate_deg_per_s=args.spin_rate_deg_per_s, seed=args.seed)
    start = time.perf_counter()
    _progress(f"attitude design: {config.name} ({config.source}) -> {args.out}/", args.quiet)
    # A bar over the steps, the current step's name after it (the status lines are written above it),
    # from the first step on: a file refused before any step leaves no empty bar behind its error.
    bar = None

    def on_step(number: int, label: str) -> None:
        nonlocal bar
        if bar is None:
            bar = progress_bar(STEPS, desc="attitude design", unit="step", enabled=_bars(args))
        bar.set_postfix_str(label.split(":")[0], refresh=False)  # the step's name; the status line has the rest
        bar.update(number - 1 - bar.n)

    try:
        result = run_design(config, options, progress=lambda m: _progress(m, args.quiet), on_step=on_step)
        if bar is not None:
            bar.set_postfix_str("done", refresh=False)
            bar.update(STEPS - bar.n)
    finally:
        if bar is not None:
            bar.close()
    _progress("writing the report ...", args.quiet)
    try:
        paths = write_report(result, args.out)
    except OSError as exc:
        raise UsageError(f"--out {args.out}: cannot write the report: {exc}") from exc
    _progress(f"report written in {time.perf_counter() - start:.1f} s: {paths['report_html']}", args.quiet)
    if args.json:
        sys.stdout.write(dumps_json(result.results))
    else:
        print(requirements_text(result.results))
        print(f"Report: {paths['report_md']} and {paths['report_html']} (numbers in {paths['results_json']})")
    return EXIT_PASS if result.passed else EXIT_FAIL


# ---------------------------------------------------------------------------
# slew

#: Keys ``--to`` accepts: those of ``[requirements.slew]``.
SLEW_KEYS = ("angle_deg", "axis_B", "target_q_BN", "start_q_BN", "time_max_s", "rate_max_deg_per_s")


def _parse_value(text: str) -> Any:
    parts = [p.strip() for p in text.split(",")]
    values: list[Any] = []
    for p in parts:
        try:
            values.append(float(p))
        except ValueError:
            values.append(p)  # left as text: the file validation names the key and the problem
    return values[0] if len(values) == 1 else values


def with_slew(config: SpacecraftConfig, spec: str) -> SpacecraftConfig:
    """``config`` with ``[requirements.slew]`` keys replaced by ``KEY=VALUE`` pairs (``--to``).

    Validated exactly as the file is, so a bad value raises :class:`ConfigError`
    naming ``requirements.slew.KEY``. ``target_q_BN`` replaces ``angle_deg``
    and ``axis_B`` of the file and the other way round.
    """
    pairs: dict[str, Any] = {}
    for token in spec.split():
        key, sep, value = token.partition("=")
        if not sep or not key or not value:
            raise UsageError(
                f'--to: expected KEY=VALUE pairs separated by spaces (e.g. "angle_deg=90 axis_B=0,1,0"), got {token!r}'
            )
        pairs[key] = _parse_value(value)
    if not pairs:
        raise UsageError('--to: give at least one KEY=VALUE pair (e.g. "angle_deg=90 axis_B=0,1,0")')
    data = tomllib.loads(config_to_toml(config))
    slew = data["requirements"]["slew"]
    if "target_q_BN" in pairs:
        slew.pop("angle_deg", None)
        slew.pop("axis_B", None)
    if "angle_deg" in pairs or "axis_B" in pairs:
        slew.pop("target_q_BN", None)
    slew.update(pairs)
    return config_from_dict(data, file=f"{config.source} with --to {spec!r}")


def _quat_text(q: Sequence[float]) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in q) + "]"


def _cmd_slew(args: argparse.Namespace) -> int:
    from attitude.app.design.run import plan_verdicts
    from attitude.app.report.sections import fmt
    from attitude.app.report.writer import dumps_json, requirements_text
    from attitude.app.slew_study import plan_slews

    config = _load(args.file)
    if args.to is not None:
        config = with_slew(config, args.to)
    if args.duration_s is not None and args.objective != "energy":
        raise UsageError("--duration-s is only for --objective energy (minimum time chooses its own duration)")
    _progress(f"planning the slew ({args.objective}, {args.nodes} intervals) ...", args.quiet)
    study = plan_slews(
        config, nodes=args.nodes, objective=args.objective, duration_s=args.duration_s, progress=_bars(args)
    )
    results = {
        "spacecraft": {"name": config.name, "description": config.description, "source": config.source},
        "slews": study.summary,
        **plan_verdicts(config, study.summary),
    }
    passed = bool(results["verdict"]["pass"])
    if args.json:
        sys.stdout.write(dumps_json(results))
        return EXIT_PASS if passed else EXIT_FAIL
    s = study.summary
    print(
        f"Slew of {config.name}: {fmt(s['angle_deg'])} deg, q_BN {_quat_text(s['q_start_BN'])} -> "
        f"{_quat_text(s['q_target_BN'])}"
    )
    if study.error:
        print(f"  planning problem: {study.error}")
    labels = [
        ("duration [s]", "duration_s"),
        ("peak body rate [deg/s]", "rate_peak_deg_per_s"),
        ("peak torque [mN m]", "torque_peak_mNm"),
        ("energy [N^2 m^2 s]", "energy_N2m2s"),
    ]
    table = [["", "optimal plan", "eigenaxis"]]
    for label, key in labels:
        table.append([label] + [fmt(None if x is None else x[key]) for x in (s["plan"], s["eigenaxis"])])
    for cone in s["keep_out"]:
        name = cone["name"]
        table.append(
            [f"separation '{name}' [deg]"]
            + [fmt(None if x is None else x["separation_min_deg"][name]) for x in (s["plan"], s["eigenaxis"])]
        )
    widths = [max(len(r[i]) for r in table) for i in range(3)]
    for row in table:
        print("  " + row[0].ljust(widths[0]) + "  " + "  ".join(c.rjust(w) for c, w in zip(row[1:], widths[1:])))
    print(requirements_text(results))
    return EXIT_PASS if passed else EXIT_FAIL


# ---------------------------------------------------------------------------
# physics


def _cmd_physics(args: argparse.Namespace) -> int:
    from attitude.app.design.body import body_analysis
    from attitude.app.report.sections import fmt
    from attitude.app.report.writer import dumps_json

    config = _load(args.file)
    b = body_analysis(config, args.spin_rate_deg_per_s)
    if args.json:
        sys.stdout.write(dumps_json({"spacecraft": {"name": config.name, "source": config.source}, "body": b}))
        return EXIT_PASS
    spin = fmt(b["spin_rate_deg_per_s"])
    print(f"Torque-free behaviour of {config.name} (whole spacecraft, wheels at rest), spin of {spin} deg/s")
    header = [
        "axis",
        "moment [kg m^2]",
        "closest body axis",
        "torque-free",
        "with dissipation",
        "nutation [s]",
        "e-fold [s]",
    ]
    rows = [header]
    for a in b["axes"]:
        rows.append(
            [
                a["name"],
                fmt(a["moment_kg_m2"]),
                f"{a['closest_body_axis']} ({fmt(a['angle_from_body_axis_deg'], 2)} deg)",
                a["torque_free"],
                a["with_energy_dissipation"],
                fmt(a["nutation_period_exact_s"] or a["nutation_period_s"]),
                fmt(a["e_folding_time_s"]),
            ]
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(header))]
    for row in rows:
        print("  " + "  ".join(c.ljust(w) for c, w in zip(row, widths)))
    if b["flip_period_s"] is not None:
        print(
            f"  middle-axis spin perturbed by {fmt(b['perturbation_percent'])} %: "
            f"flips every {fmt(b['flip_period_s'])} s"
        )
    gg = b["gravity_gradient"]
    if gg is None:
        print("Gravity gradient: no [orbit] in the file")
    else:
        print(f"Gravity gradient at {fmt(gg['altitude_km'])} km: peak torque {fmt(gg['torque_peak_uNm'])} uN m")
        for o in gg["orientations"]:
            pitch = "stable" if o["pitch_stable"] else "unstable"
            roll_yaw = "stable" if o["roll_yaw_stable"] else "unstable"
            print(f"  {o['orientation']}: {o['region']} (pitch {pitch}, roll-yaw {roll_yaw})")
    return EXIT_PASS


# ---------------------------------------------------------------------------
# momentum


def _cmd_momentum(args: argparse.Namespace) -> int:
    from attitude.app.design.orbit import momentum_budget, momentum_figures
    from attitude.app.report.sections import fmt
    from attitude.app.report.writer import dumps_json

    config = _load(args.file)
    if config.orbit_config is None:
        raise UsageError(f"{config.source}: no [orbit] table: the momentum budget needs an orbit")
    targets = []
    if args.out is not None:
        if args.out.exists() and not args.out.is_dir():
            raise UsageError(f"--out {args.out}: exists and is not a folder")
        targets = [args.out / f"{name}.png" for name in ("orbit_torques", "orbit_momentum")]
        existing = [str(p) for p in targets if p.exists()]
        if existing and not args.force:
            raise UsageError(f"--out {args.out}: would overwrite {', '.join(existing)}; use --force to replace them")
    _progress(f"attitude momentum: {config.name}, {args.orbits or ('the file' + chr(39) + 's')} orbits ...", args.quiet)
    budget = momentum_budget(config, args.orbits, progress=_bars(args))
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        for name, fig in momentum_figures(budget).items():
            fig.savefig(args.out / f"{name}.png", dpi=120)
    plain = {k: v for k, v in budget.items() if not k.startswith("_")}
    if args.json:
        sys.stdout.write(dumps_json({"spacecraft": {"name": config.name, "source": config.source}, "momentum": plain}))
        return EXIT_PASS if budget["pass"] else EXIT_FAIL
    print(f"Momentum budget of {config.name}: {plain['orbit']}")
    print(f"  {plain['pointing']}; {plain['environment']}")
    print("  disturbance torques over one orbit [uN m]: peak, mean magnitude, orbit average (body)")
    for source, v in plain["torques"].items():
        average = ", ".join(fmt(x) for x in v["orbit_average_body_uNm"])
        print(f"    {source:<17} {fmt(v['peak_uNm']):>10} {fmt(v['mean_uNm']):>10}  [{average}]")
    for label, case in (("no dumping", plain["no_dumping"]), ("unloading", plain["unloading"])):
        if case is None:
            print(f"  {label}: not configured ([magnetorquers] and [momentum] unloading_gain_per_s)")
            continue
        print(
            f"  {label} over {fmt(plain['orbits'])} orbits: |h| peak {fmt(case['peak_body_mNms'])} mN m s, largest "
            f"wheel {fmt(max(case['peak_per_wheel_mNms']))} of {fmt(min(case['allowed_per_wheel_mNms']))} mN m s "
            f"allowed ({fmt(plain['wheel_momentum_margin'])} of capacity)"
        )
    free = plain["no_dumping"]
    rate = ", ".join(fmt(v) for v in free["secular_rate_inertial_uNms_per_orbit"])
    print(
        f"  secular build-up without dumping: {fmt(free['secular_rate_magnitude_uNms_per_orbit'])} uN m s per orbit "
        f"([{rate}] in the inertial frame)"
    )
    verdict = "PASS" if budget["pass"] else "FAIL"
    print(f"Wheel momentum ({plain['judged_case']}) within the margin: {verdict}")
    if targets:
        print(f"Figures: {', '.join(str(p) for p in targets)}")
    return EXIT_PASS if budget["pass"] else EXIT_FAIL


# ---------------------------------------------------------------------------
# montecarlo


def _scenario_usage_error(exc: Exception, args: argparse.Namespace) -> UsageError:
    """A scenario's refusal as a usage error naming the flag that set the refused value (exit 2)."""
    text = str(exc)
    flag = f"--duration-s {args.duration_s:g}: " if text.startswith("duration") and args.duration_s else ""
    if "environment" in text and not flag:
        flag = "--environment: " if args.environment else ""
    return UsageError(f"{flag}{text}")


def _cmd_montecarlo(args: argparse.Namespace) -> int:
    from attitude.app.scenarios import ScenarioError, nees_consistency, run_campaign_from_config
    from controllers.slew.problem import SlewPlanningError

    config = _load(args.file)
    if args.workers is not None and args.scheduler is not None:
        raise UsageError("--workers and --scheduler exclude each other (the cluster decides its workers)")
    if args.environment is None:  # as the design flies: in the file's orbit when it has one
        args.environment = config.orbit_config is not None
    out = Path(args.out)
    mc = config.montecarlo
    if args.runs is None and mc is None:
        raise UsageError("--runs: the spacecraft file has no [montecarlo] table, so give the number of runs")
    so3 = mc is not None and mc.initial_attitude is not None and mc.initial_attitude.distribution == "uniform_so3"
    if so3 and args.guidance == "plan":
        raise UsageError(
            "--guidance plan: the file's montecarlo.initial_attitude is 'uniform_so3', but a planned slew starts "
            "from the file's start attitude; disperse the attitude about the start, or use --guidance eigenaxis"
        )
    if args.replay is not None:
        return _replay_montecarlo(args, config, out)
    if args.force:
        raise UsageError(
            "--force: only with --replay (a campaign resumes its checkpoint, or starts afresh with --fresh)"
        )
    _progress(f"Monte Carlo campaign of {config.name}: results in {out}/", args.quiet)
    if args.guidance == "plan":
        _progress(f"planning the slew ({args.nodes} intervals, once, on the nominal spacecraft) ...", args.quiet)
    stop_lines = _status_lines("attitude.montecarlo", args.quiet)  # "resuming: 37 of 200 runs from the checkpoint"
    try:
        result = run_campaign_from_config(
            config,
            runs=args.runs,
            workers=args.workers,
            scheduler=args.scheduler,
            out_dir=out,
            seed=args.seed,
            duration=args.duration_s,
            progress=_bars(args),  # the planner's and the runs' bars
            keep_out=not args.no_keep_out,
            guidance=args.guidance,
            nodes=args.nodes,
            vectorized=args.vectorized,
            resume=not args.fresh,
            environment=args.environment,
        )
    except ScenarioError as exc:
        raise _scenario_usage_error(exc, args) from None
    except SlewPlanningError as exc:
        print(f"attitude montecarlo: {exc}", file=sys.stderr)
        return EXIT_FAIL
    except ValueError as exc:
        if "checkpoint of a different campaign" in str(exc):
            what = str(exc).split("; use another out_dir")[0]  # the library's advice names its own arguments
            raise UsageError(f"--out {out}: {what}; use another --out, or --fresh") from None
        raise
    except OSError as exc:
        if getattr(exc, "filename", None) is not None or not args.scheduler:  # the output folder
            raise UsageError(f"--out {out}: {exc}") from None
        raise UsageError(f"--scheduler {args.scheduler}: {exc}") from None  # nobody answers at that address
    finally:
        stop_lines()
    if args.json:
        from attitude.app.report.writer import dumps_json

        sys.stdout.write(dumps_json(result.statistics()))
    else:
        print(result.summary())
        line = nees_consistency(result)
        if line is not None:
            print(line)
        from attitude.app.design.linear import controller_findings

        # The likely cause of failing runs, as attitude design prints it (issue 12: failures explain themselves).
        for finding in controller_findings(config):
            print(f"Mismatch: {finding['message']}")
    if result.info.get("interrupted"):
        # Ctrl-C in the run loop: the completed runs are in the checkpoint; exit as for any Ctrl-C (130).
        raise KeyboardInterrupt
    # Signed off only when every run completed (no error, nothing left undone) and met every requirement.
    return EXIT_PASS if bool(np.all(result.status == "ok")) and bool(np.all(result.passed)) else EXIT_FAIL


def _replay_montecarlo(args: argparse.Namespace, config: SpacecraftConfig, out: Path) -> int:
    """``attitude montecarlo FILE --replay RUN``: one run of the campaign again, alone, with its figures."""
    from attitude.app.scenarios import ScenarioError, replay_from_config
    from attitude.montecarlo.results import RunReplay
    from controllers.slew.problem import SlewPlanningError

    if args.scheduler is not None or args.workers is not None or args.fresh:
        flag = "--scheduler" if args.scheduler is not None else "--workers" if args.workers is not None else "--fresh"
        raise UsageError(f"{flag}: not with --replay (the run is flown alone, in this process, with no checkpoint)")
    folder = out / f"replay_run{args.replay}"
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"--out {out}: {folder} exists and is not a folder")
    existing = [str(folder / name) for name in RunReplay.FILES if (folder / name).exists()]
    if existing and not args.force:
        raise UsageError(f"--out {out}: would overwrite {', '.join(existing)}; use --force to replace them")
    path = "the vectorised path" if args.vectorized else "the per-run engine"
    _progress(
        f"Replaying run {args.replay} of the Monte Carlo campaign of {config.name} on {path}: files in {folder}/",
        args.quiet,
    )
    try:
        replay = replay_from_config(
            config,
            args.replay,
            args.runs,
            vectorized=args.vectorized,
            seed=args.seed,
            duration=args.duration_s,
            keep_out=not args.no_keep_out,
            guidance=args.guidance,
            nodes=args.nodes,
            environment=args.environment,
        )
    except ScenarioError as exc:
        raise _scenario_usage_error(exc, args) from None
    except SlewPlanningError as exc:
        print(f"attitude montecarlo: {exc}", file=sys.stderr)
        return EXIT_FAIL
    except ValueError as exc:
        if str(exc).startswith("run must be"):
            hint = "" if args.runs is not None else " (the file's montecarlo.runs; give --runs as the campaign did)"
            raise UsageError(f"--replay {args.replay}: {exc}{hint}") from None
        raise
    try:
        paths = replay.save(folder)
    except OSError as exc:
        raise UsageError(f"--out {out}: {exc}") from None
    if args.json:
        from attitude.app.report.writer import dumps_json

        sys.stdout.write(dumps_json(replay.to_dict()))
    else:
        print(replay.summary())
        print(f"Files: {', '.join(str(p) for p in paths)}")
    return EXIT_PASS if replay.passed else EXIT_FAIL


# ---------------------------------------------------------------------------
# init


def _cmd_init(args: argparse.Namespace) -> int:
    path = Path(args.file)
    if path.exists() and not args.force:
        raise UsageError(f"{path}: the file exists; not overwritten (use --force to replace it)")
    if not path.parent.exists():
        raise UsageError(f"{path}: the folder {path.parent} does not exist")
    path.write_text(default_config_text(), encoding="utf-8")
    print(f"Wrote {path}: the built-in 12U CubeSat, every key commented. Edit it, then run `attitude design {path}`.")
    return EXIT_PASS


# ---------------------------------------------------------------------------
# tune


def _cmd_tune(args: argparse.Namespace) -> int:
    from attitude.app.design.tune import step_source, tune_config, tuned_file_text
    from attitude.app.report.writer import dumps_json

    config = _load(args.file)
    source = Path(args.file) if args.file is not None else Path("default_spacecraft.toml")
    out = args.out if args.out is not None else source.with_name(f"{source.stem}_tuned.toml")
    if args.file is not None and out.exists() and Path(args.file).exists() and out.samefile(args.file):
        raise UsageError(f"--out {out}: is the input file; the tuned file is always a new one")
    if out.exists() and not args.force:
        raise UsageError(
            f"the tuned file {out} exists; not overwritten (use --force to replace it, or --out for another name)"
        )
    if not out.parent.exists():
        raise UsageError(f"--out {out}: the folder {out.parent} does not exist")
    law = "the LQR's Bryson bounds" if args.structure == "lqr" else "the PD"
    _progress(f"tuning {law} on the linear metrics, then the nonlinear step and the dispersed check ...", args.quiet)
    figure = args.figure if args.figure is not None else out.with_suffix(".png")
    if figure.exists() and not args.force:
        raise UsageError(f"--figure {figure}: the file exists; not overwritten (use --force to replace it)")
    try:
        step_source(config, args.step_deg)
    except ValueError as exc:
        raise UsageError(f"--step-deg: {exc}") from exc
    outcome = tune_config(
        config, cost=args.cost, structure=args.structure, dispersed_runs=args.runs, step_deg=args.step_deg
    )
    outcome.result.plot(outcome.before).savefig(figure, dpi=120)
    if outcome.tuned is not None:
        out.write_text(tuned_file_text(outcome), encoding="utf-8")
    if args.json:
        print(dumps_json(outcome.summary()))
    else:
        print(f"{'metric':<26} {'before':>12} {'after':>12}  required")
        for row in outcome.table():
            print(f"{row['metric']:<26} {row['before']:>12.5g} {row['after']:>12.5g}  {row['required'] or ''}")
        print(outcome.result.message)
        if outcome.nonlinear is not None:
            nl = outcome.nonlinear
            print(
                f"nonlinear step through the wheels: settles in {nl['settling_time_s']:.4g} s, pointing "
                f"{math.degrees(nl['pointing_error_rad']):.3g} deg: {'PASS' if nl['passed'] else 'FAIL'}"
            )
        if outcome.nonlinear_flexible is not None:
            nl = outcome.nonlinear_flexible
            print(
                f"nonlinear step on the {nl['plant']}: settles in {nl['settling_time_s']:.4g} s, pointing "
                f"{math.degrees(nl['pointing_error_rad']):.3g} deg: {'PASS' if nl['passed'] else 'FAIL'}"
            )
        if outcome.dispersed is not None:
            print(f"dispersed check: {outcome.dispersed.get('statement', outcome.dispersed.get('error'))}")
        if outcome.flown_disk_margin is not None:
            floor = config.requirements.disk_margin_min
            verdict = "" if floor is None else (" PASS" if outcome.flown_disk_margin >= floor else " FAIL")
            print(
                f"disk margin with the file's flexible modes and filters (the loops that fly, per axis and "
                f"multiloop): {outcome.flown_disk_margin:.4g}{verdict}"
            )
        print(f"Wrote {out}" if outcome.tuned is not None else "INFEASIBLE: no file written", end="")
        print(f" and the trade-off figure {figure}")
    return EXIT_PASS if outcome.passed else EXIT_FAIL


# ---------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``attitude`` and its subcommands."""
    fmt_class = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(
        prog="attitude",
        description="Spacecraft attitude-control design: from a spacecraft description (TOML) to a design report.",
        epilog=_EPILOG,
        formatter_class=fmt_class,
    )
    parser.add_argument("--version", action="version", version=f"attitude {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser(
        "design",
        help="the whole design and its report (requirements pass/fail)",
        formatter_class=fmt_class,
        description=(
            "Run the whole design of a spacecraft and write the report: 1 the body (principal axes, torque-free\n"
            "stability, gravity gradient), 2 linear design (PD and LQR gains, poles, margins, Bode and step),\n"
            "3 slews (the required slew time-optimal and eigenaxis), 4 closed loop (the slew flown with tracking\n"
            "control, wheels, gyro, star tracker and MEKF), 5 estimation (rate EKF and MEKF errors, NEES over a\n"
            "Monte Carlo set), 6 orbit (disturbance torques, momentum budget and unloading, nadir hold,\n"
            "detumbling; with an [orbit]), 7 attitude determination from the Sun and the field (QUEST, TRIAD\n"
            "and a star-tracker-free MEKF over an orbit; with direction sensors), 8 requirements (pass/fail;\n"
            "with a [montecarlo] table, a dispersed check: a small vectorised campaign that a failing run fails).\n"
            "Writes report.md, report.html (self-contained), figures/*.png, results.json (every number of the\n"
            "report) and spacecraft.toml (the resolved file) into --out, and prints the requirements table.\n"
            "The slew is planned with 80 % of the wheels' torque and 85 % of the rate limit, leaving the rest to\n"
            "the feedback that tracks it. About 70 s for the default spacecraft on a 2-core machine (--quick:\n"
            "about 50 s)."
        ),
        epilog=_EPILOG,
    )
    p.add_argument("file", nargs="?", metavar="FILE", help=_FILE_HELP)
    p.add_argument(
        "--out", type=Path, default=Path("attitude-report"), metavar="DIR", help="report folder (default: %(default)s)"
    )
    p.add_argument("--json", action="store_true", help="print results.json to stdout instead of the table")
    p.add_argument(
        "--quick",
        action="store_true",
        help="a first look: 30 planner intervals instead of 60, 8 MEKF and 4 rate-EKF Monte Carlo runs "
        "instead of 50 and 20, 10 runs of the dispersed check instead of 50, and in orbit"
        " a 3-orbit momentum budget and a 2-orbit detumbling run instead of "
        "the file's spans (same verdict rules)",
    )
    p.add_argument(
        "--force", action="store_true", help="replace a report already in DIR (the input file is never overwritten)"
    )
    p.add_argument(
        "--seed", type=_count(0), default=None, help="master seed (default: montecarlo.seed of the file, else 0)"
    )
    p.add_argument(
        "--spin-rate-deg-per-s",
        type=_positive,
        default=10.0,
        metavar="RATE",
        help="reference spin rate of the torque-free analysis [deg/s] (default: %(default)s)",
    )
    p.add_argument("--quiet", action="store_true", help=_QUIET_HELP)
    p.set_defaults(run=_cmd_design)

    p = sub.add_parser(
        "slew",
        help="plan one slew (time-optimal or minimum energy) against the eigenaxis slew",
        formatter_class=fmt_class,
        description=(
            "Plan one slew with 80 % of the wheels' torque and 85 % of the rate limit, at rates that keep the\n"
            "wheel momentum within 80 % of its capacity (the rest is left to the feedback that tracks the plan),\n"
            "around the keep-out cones of the file widened by up to 0.5 deg, and the eigenaxis slew with the same\n"
            "limits; print duration [s], peak rate [deg/s], peak torque [mN m], energy and keep-out separation\n"
            "[deg] side by side, and judge the plan against [requirements.slew] and [[requirements.keep_out]].\n"
            "Without --to, the file's required slew. About 6 s for the default spacecraft on a 2-core machine."
        ),
        epilog=_EPILOG,
    )
    p.add_argument("file", nargs="?", metavar="FILE", help=_FILE_HELP)
    p.add_argument(
        "--to",
        metavar="'KEY=VALUE ...'",
        help="the slew to plan, as [requirements.slew] keys replacing the file's: angle_deg=60 axis_B=1,0,0 "
        "(a rotation about a body axis from start_q_BN, in deg) or target_q_BN=w,x,y,z (scalar first); "
        "also start_q_BN, time_max_s [s], rate_max_deg_per_s [deg/s]",
    )
    p.add_argument(
        "--objective",
        choices=("time", "energy"),
        default="time",
        help="minimum time, or minimum integral of |torque|^2 over --duration-s (default: %(default)s)",
    )
    p.add_argument(
        "--duration-s",
        type=_positive,
        default=None,
        metavar="S",
        help="slew time for --objective energy [s] (default: requirements.slew.time_max_s)",
    )
    p.add_argument("--nodes", type=_nodes, default=60, help="planner intervals, at least 4 (default: %(default)s)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.add_argument("--quiet", action="store_true", help=_QUIET_HELP)
    p.set_defaults(run=_cmd_slew)

    p = sub.add_parser(
        "physics",
        help="torque-free behaviour of the body: stable axes, nutation and flip, gravity gradient",
        formatter_class=fmt_class,
        description=(
            "The torque-free behaviour of the body (wheels included, at rest): principal moments and axes, which\n"
            "spin axes are stable (and with energy dissipation), nutation periods, the middle-axis e-folding\n"
            "time and flip period at a reference spin rate, and gravity-gradient stability if the file has an\n"
            "[orbit]. Exit code 0 (no requirement is judged). About 3 s for the default spacecraft."
        ),
        epilog=_EPILOG,
    )
    p.add_argument("file", nargs="?", metavar="FILE", help=_FILE_HELP)
    p.add_argument(
        "--spin-rate-deg-per-s",
        type=_positive,
        default=10.0,
        metavar="RATE",
        help="reference spin rate [deg/s]; every rate scales with it (default: %(default)s)",
    )
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.set_defaults(run=_cmd_physics)

    p = sub.add_parser(
        "montecarlo",
        help="a dispersed closed-loop campaign from the file's [montecarlo] table",
        formatter_class=fmt_class,
        description=(
            "Run the spacecraft's closed loop (wheels, gyro, star tracker, MEKF) many times with the dispersions\n"
            "of the file's [montecarlo] table (inertia, initial rate and attitude, sensor misalignments, gyro\n"
            "turn-on bias). The guidance is the design's: the required slew planned once on the nominal\n"
            "spacecraft (time-optimal around the keep-out cones, as `attitude design` plans it, with 80 % of the\n"
            "wheels' torque and 85 % of the rate limit) and tracked with the plan's torque as feedforward, the\n"
            "feedback using the rest; --guidance eigenaxis flies the rate-limited PD straight to the target\n"
            "instead, which cannot avoid a keep-out cone (add --no-keep-out to judge it on the other\n"
            "requirements). The design's windows judge the error to the target attitude at every tick: the slew\n"
            "time is when it enters the pointing accuracy to stay (at most time_max_s), the settling that time\n"
            "after the end of the planned slew (at most settling_time_s), the pointing its largest value over\n"
            "the hold that follows (hold_time_s long); each run lasts to the end of that hold. Seeds come from\n"
            "one master seed, so a campaign is reproducible whatever the number of workers. Writes the per-run\n"
            "table (CSV), statistics, time histories (npz), a checkpoint (an interrupted campaign resumes, and\n"
            "says how many runs it took from the checkpoint) and figures to --out. The table's metrics and\n"
            "parameters are in the summary's units, named in the column (final_pointing_error_deg,\n"
            "wheel_speed_peak_rpm; campaign.json holds the schema), and each row's seed and spawn_key rebuild\n"
            "that run's generator: numpy.random.default_rng(numpy.random.SeedSequence(seed, spawn_key=...)).\n"
            "--replay RUN flies one run again alone, with the same options, and draws its figures. Exit code 0\n"
            "when every run completed and met every requirement; 1 when one failed a requirement, raised or was\n"
            "not run, or when the slew cannot be planned. 200 runs with --vectorized: about 20 s for the default\n"
            "spacecraft on a 2-core machine, the slew planning included.\n\n"
            "On a Dask cluster: start `dask scheduler` on one machine and `dask worker tcp://HOST:8786` on\n"
            "each of the others (with this package installed), then pass --scheduler tcp://HOST:8786."
        ),
        epilog=_EPILOG,
    )
    p.add_argument("file", nargs="?", metavar="FILE", help="spacecraft TOML file (default: the built-in one)")
    p.add_argument("--runs", type=_count(1), default=None, help="number of runs (default: montecarlo.runs of the file)")
    p.add_argument(
        "--workers",
        type=_count(1),
        default=None,
        help="local worker processes (default: one per CPU this process may run on, its affinity mask, which "
        "taskset and container limits set; with --vectorized too, each worker flying batches of up to 1000 runs)",
    )
    p.add_argument(
        "--scheduler",
        type=_scheduler_address,
        default=None,
        metavar="ADDR",
        help="Dask scheduler address tcp://HOST:PORT",
    )
    p.add_argument("--out", default="montecarlo", metavar="DIR", help="output folder (default: montecarlo)")
    p.add_argument("--seed", type=_count(0), default=None, help="master seed (default: montecarlo.seed of the file)")
    p.add_argument(
        "--fresh",
        action="store_true",
        help="start afresh: discard the checkpoint in --out (default: resume the campaign it holds, if the same)",
    )
    p.add_argument(
        "--duration-s",
        type=_positive,
        default=None,
        help="simulated time per run [s] (default: to the end of the requirements' hold: the planned slew, or "
        "slew.time_max_s with --guidance eigenaxis, plus settling_time_s and hold_time_s; the pointing is judged "
        "over that hold only, so a longer run adds nothing to the verdict)",
    )
    p.add_argument(
        "--guidance",
        choices=("plan", "eigenaxis"),
        default="plan",
        help="plan: the design's planned slew, tracked (default); eigenaxis: rate-limited PD straight to the target",
    )
    p.add_argument(
        "--nodes",
        type=_nodes,
        default=60,
        help="planner intervals of the planned slew, at least 4 (default: %(default)s)",
    )
    p.add_argument(
        "--no-keep-out",
        action="store_true",
        help="do not count the keep-out cones as requirements (for --guidance eigenaxis, which cannot avoid them)",
    )
    p.add_argument(
        "--vectorized",
        action="store_true",
        help="advance the runs together in batches (truth, sensors, MEKF, control as batched states; same metrics "
        "to rounding, tens of times less CPU; the plant step compiled to C when a C compiler is found)",
    )
    p.add_argument(
        "--environment",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="fly the file's [orbit], [environment] and [surface]: the disturbance torques act on every run, with "
        "the surface dispersions of [montecarlo] (drag_scale, residual_dipole, centre_of_pressure_offset). "
        "Default: when the file has an [orbit], as attitude design flies its slew and its dispersed check; "
        "--no-environment flies empty inertial space",
    )
    p.add_argument(
        "--replay",
        type=_count(0),
        default=None,
        metavar="RUN",
        help="fly run RUN of the campaign again, alone, with its history at every tick (give the campaign's "
        "options: --runs, --seed, --guidance, --vectorized, --environment, --duration-s ...); prints its metrics "
        "and verdicts and writes replay.json, history.npz and its figures to DIR/replay_runRUN; exit code 0 when "
        "it meets every requirement",
    )
    p.add_argument("--force", action="store_true", help="with --replay: replace the files of an earlier replay")
    p.add_argument("--json", action="store_true", help="print the statistics (with --replay: the run) as JSON")
    p.add_argument("--quiet", action="store_true", help=_QUIET_HELP)
    p.set_defaults(run=_cmd_montecarlo)

    p = sub.add_parser(
        "momentum",
        help="the momentum budget in orbit alone: disturbance torques, build-up, magnetic unloading",
        formatter_class=fmt_class,
        description=(
            "The momentum budget of the file's [orbit], [environment] and [surface] for a nadir-pointing\n"
            "spacecraft: the disturbance torques per source over one orbit, the wheel momentum over N orbits\n"
            "without dumping and with cross-product magnetic unloading ([magnetorquers], [momentum]), and the\n"
            "largest wheel's momentum against [momentum] wheel_momentum_margin of its capacity (exit code 0\n"
            "within the margin, 1 beyond it). About 8 s for the default spacecraft on a 2-core machine."
        ),
        epilog=_EPILOG,
    )
    p.add_argument("file", nargs="?", metavar="FILE", help=_FILE_HELP)
    p.add_argument(
        "--orbits",
        type=_positive,
        default=None,
        metavar="N",
        help="length of the budget [orbits] (default: the file's)",
    )
    p.add_argument("--out", type=Path, default=None, metavar="DIR", help="write the two figures (PNG) into DIR")
    p.add_argument("--force", action="store_true", help="replace figures already in DIR")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    p.add_argument("--quiet", action="store_true", help=_QUIET_HELP)
    p.set_defaults(run=_cmd_momentum)

    p = sub.add_parser(
        "init",
        help="write the built-in spacecraft file, commented, as a starting point",
        formatter_class=fmt_class,
        description=(
            "Write the built-in default spacecraft (a 12U CubeSat; the source of every figure is in its\n"
            "comments) to FILE as a starting point. Refuses to overwrite an existing file unless --force."
        ),
        epilog=_EPILOG,
    )
    p.add_argument("file", metavar="FILE", help="where to write the spacecraft file")
    p.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    p.set_defaults(run=_cmd_init)

    p = sub.add_parser(
        "tune",
        help="tune the PD (or the LQR weights) to the file's requirements and write them into a new file",
        formatter_class=fmt_class,
        description=(
            "Find the PD bandwidth and damping that meet the file's requirements (a step of --step-deg, by\n"
            "default [control.lqr] angle_max_deg, the largest error the feedback corrects while the planned slew's\n"
            "feedforward does the rest, or without [control.lqr] the whole required slew; settled within the\n"
            "pointing accuracy in the settling time, within the wheels' torque and momentum\n"
            "and requirements.disk_margin_min at the control period) at the least settling time or effort;\n"
            "confirm it on the nonlinear plant and the dispersed check; write the file with the new gains\n"
            "(every other key and comment kept) and the trade-off figure (settling time vs disk margin).\n"
            "--structure lqr tunes the [control.lqr] rate and torque bounds per axis instead (angle_max_deg kept),\n"
            "flies the LQR in the nonlinear step and on the file's dispersed inertias.\n"
            "Exit code 1 when infeasible (the binding requirement is named) or a confirmation fails."
        ),
        epilog=_EPILOG,
    )
    p.add_argument("file", nargs="?", default=None, metavar="FILE", help="spacecraft file (default: the built-in)")
    p.add_argument("--out", type=Path, default=None, metavar="NEWFILE", help="the tuned file (default FILE_tuned.toml)")
    p.add_argument("--cost", choices=("settling", "effort"), default="settling", help="what to minimise")
    p.add_argument(
        "--structure",
        choices=("pd", "pd_per_axis", "lqr"),
        default="pd",
        help="the controller tuned: the [control] PD (one bandwidth and damping, or pd_per_axis: one per body axis) "
        "or the [control.lqr] Bryson bounds per axis (rate and torque; angle_max_deg kept)",
    )
    p.add_argument(
        "--step-deg",
        type=float,
        default=None,
        metavar="DEG",
        help="the step the feedback must settle [deg] (default: [control.lqr] angle_max_deg, else the slew angle)",
    )
    p.add_argument("--runs", type=_count(0), default=10, help="runs of the dispersed check (0: none; default 10)")
    p.add_argument(
        "--figure", type=Path, default=None, metavar="PNG", help="the trade-off figure (default NEWFILE.png)"
    )
    p.add_argument("--force", action="store_true", help="overwrite NEWFILE if it exists (never the input)")
    p.add_argument("--json", action="store_true", help="print the outcome as JSON")
    p.add_argument("--quiet", action="store_true", help=_QUIET_HELP)
    p.set_defaults(run=_cmd_tune)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``attitude`` command; returns the exit code (module docstring).

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments without the program name; default ``sys.argv[1:]``.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "run", None) is None:
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    try:
        code = args.run(args)
        sys.stdout.flush()  # a pipe closed early fails here, inside the handler, not at interpreter exit
        return code
    except BrokenPipeError:
        # The reader went away (`attitude physics | head -5`): exit quietly, as Unix tools do.
        # Point stdout at devnull so the interpreter's final flush does not raise again.
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141  # 128 + SIGPIPE, what a shell reports for a tool killed by the broken pipe
    except KeyboardInterrupt:
        # Ctrl-C (planning, a campaign's run loop, figures): one line, not a traceback.
        again = " ".join(["attitude", *(sys.argv[1:] if argv is None else argv)])
        what = "resumes the campaign from its checkpoint" if args.command == "montecarlo" else "starts it again"
        print(f"attitude {args.command}: interrupted (Ctrl-C); the same command {what}: {again}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ConfigError as exc:
        print(f"attitude {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except UsageError as exc:
        print(f"attitude {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT

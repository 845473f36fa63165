"""Writing the design report: ``report.md``, ``report.html``, ``figures/*.png``, ``results.json``, ``spacecraft.toml``.

Top floor, with :mod:`attitude.app.design.run` (which computes) and
:mod:`attitude.app.cli` (which runs both). This module only writes: the content
of the report is built by :func:`attitude.app.report.sections.build_blocks` from
the results dict alone, and rendered twice from the same blocks, so the
markdown, the HTML and ``results.json`` show the same numbers.

* ``report.html`` is self-contained: its CSS is inline and every figure is
  embedded as a base64 PNG data URI, so the one file can be mailed or
  archived and opens in any browser without the ``figures`` folder.
* ``results.json`` is strict JSON (RFC 8259): numbers that are not finite
  are written as the strings ``"inf"``, ``"-inf"`` and ``"nan"``
  (:func:`to_jsonable`); ``float(value)`` reads them back.
* ``spacecraft.toml`` is the resolved spacecraft file
  (:func:`attitude.config.writer.config_to_toml`): every default filled in, so the
  design can be reproduced from the report folder alone.
"""

from __future__ import annotations

import base64
import html
import json
import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from attitude.app.report.sections import (
    Block,
    Figure,
    Heading,
    Paragraph,
    Table,
    build_blocks,
    diagnostics_lines,
    requirement_rows,
)
from attitude.config import config_to_toml

if TYPE_CHECKING:
    from attitude.app.design.run import DesignResult

__all__ = [
    "FIGURE_DPI",
    "dumps_json",
    "is_numeric",
    "render_html",
    "render_markdown",
    "requirements_text",
    "to_jsonable",
    "write_report",
]

#: Resolution of the saved figures [dots per inch] (a 10-inch-wide figure is 1000 pixels).
FIGURE_DPI = 100


def to_jsonable(obj: Any) -> Any:
    """``obj`` as plain JSON types: numpy scalars and arrays to numbers and lists, non-finite floats to strings.

    Parameters
    ----------
    obj : object
        Results made of dicts, lists, numbers, strings and numpy values.
    """
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        if math.isfinite(x):
            return x
        return "nan" if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"cannot write {type(obj).__name__} {obj!r} as JSON")


def dumps_json(obj: Any) -> str:
    """Strict JSON text of ``obj`` (see :func:`to_jsonable`), indented.

    Parameters
    ----------
    obj : object
        Results made of dicts, lists, numbers, strings and numpy values.
    """
    return json.dumps(to_jsonable(obj), indent=2, allow_nan=False, ensure_ascii=False) + "\n"


# ---------------------------------------------------------------------------
# Terminal


def requirements_text(results: Mapping[str, Any]) -> str:
    """The requirements table for the terminal, with the overall verdict.

    Parameters
    ----------
    results : mapping
        The JSON-ready results of the design.
    """
    header = ["requirement", "required", "achieved", "verdict"]
    rows = [[r[0], r[2], r[3], r[4]] for r in requirement_rows(list(results["requirements"]))]
    widths = [max(len(x) for x in col) for col in zip(header, *rows)]
    lines = [f"Requirements: {results['spacecraft']['name']}"]
    for i, cells in enumerate([header, *rows]):
        lines.append(
            "  " + "  ".join(c.ljust(w) if j == 0 else c.rjust(w) for j, (c, w) in enumerate(zip(cells, widths)))
        )
        if i == 0:
            lines.append("  " + "  ".join("-" * w for w in widths))
    dispersed = results.get("dispersed")
    if dispersed is not None:
        lines.append(f"Dispersed check: {dispersed.get('statement') or 'not flown: ' + str(dispersed.get('error'))}")
    verdict = results["verdict"]
    n = len(results["requirements"])
    if verdict["pass"]:
        lines.append(f"Verdict: PASS (all {n} requirements met)")
    else:
        lines.append(
            f"Verdict: FAIL ({len(verdict['failed'])} of {n} requirements not met: {', '.join(verdict['failed'])})"
        )
        # One line per failing requirement with its reason (issue 12: failures explain themselves).
        for r in results["requirements"]:
            if not r["pass"]:
                lines.append(f"  FAIL {r['id']}: {r.get('reason') or 'no reason recorded'}")
    lines += diagnostics_lines(results)
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# Markdown


_NUMERIC = re.compile(r"^(<=|>=)?\s*([-+]?(\d|\.\d)|[-+]?inf\b|nan\b|n/a\b|\[[-+\d.])")


def is_numeric(text: str) -> bool:
    """A cell that reads as a number (right-aligned): "12.5", "-inf", "n/a", "<= 0.05 deg", "[1, 0, 0]".

    Parameters
    ----------
    text : str
        A table cell.
    """
    return bool(_NUMERIC.match(text.strip()))


def _md_cell(text: str) -> str:
    return _md_text(text).replace("|", "\\|").replace("\n", " ")


#: Markup that opens an HTML tag or comment (``<script``, ``</p``, ``<!--``); a bare ``<`` or ``<=`` is text.
_HTML_OPENING = re.compile(r"<(?=[A-Za-z/!?])")


def _md_text(text: str) -> str:
    """Text with raw HTML neutralised: Markdown renderers pass tags through, so ``<`` before a tag becomes ``&lt;``."""
    return _HTML_OPENING.sub("&lt;", text)


def render_markdown(blocks: list[Block]) -> str:
    """GitHub-flavoured markdown; figures link to ``figures/<name>.png``.

    Parameters
    ----------
    blocks : list of Block
        The report's blocks (:func:`attitude.app.report.sections.build_blocks`).
    """
    out: list[str] = []
    for b in blocks:
        if isinstance(b, Heading):
            out.append(f"{'#' * b.level} {_md_text(b.text)}")
        elif isinstance(b, Paragraph):
            out.append(_md_text(b.text))
        elif isinstance(b, Table):
            lines = []
            if b.caption:
                lines.append(f"*{_md_text(b.caption)}*")
                lines.append("")
            lines.append("| " + " | ".join(_md_cell(c) for c in b.header) + " |")
            right = [i > 0 and all(is_numeric(row[i]) for row in b.rows) for i in range(len(b.header))]
            lines.append("| " + " | ".join("---:" if r else ":---" for r in right) + " |")
            lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            out.append("\n".join(lines))
        elif isinstance(b, Figure):
            caption = _md_text(b.caption)
            out.append(f"![{caption}](figures/{b.name}.png)\n\n*Figure: {caption}*")
    return "\n\n".join(out) + "\n"


# ---------------------------------------------------------------------------
# HTML

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: #1d2330; background: #fff;
       max-width: 1100px; margin: 2rem auto; padding: 0 1.2rem; line-height: 1.5; }
h1 { font-size: 1.7rem; border-bottom: 3px solid #1d4f91; padding-bottom: .3rem; }
h2 { font-size: 1.35rem; margin-top: 2.4rem; border-bottom: 1px solid #c8d0dc; padding-bottom: .2rem; }
nav { background: #f3f6fa; border: 1px solid #dbe2ec; padding: .6rem 1rem; border-radius: 6px; }
nav a { margin-right: 1.1rem; text-decoration: none; color: #1d4f91; white-space: nowrap; }
table { border-collapse: collapse; margin: .8rem 0 1.2rem; font-size: .88rem; display: block; overflow-x: auto; }
caption { caption-side: top; text-align: left; font-style: italic; padding-bottom: .3rem; }
th, td { border: 1px solid #d5dbe5; padding: .28rem .55rem; text-align: left; vertical-align: top; }
th { background: #eef2f8; }
td.num { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
tbody tr:nth-child(even) { background: #fafbfd; }
td.pass { color: #0b6b2b; font-weight: 600; background: #e5f5ea; }
td.fail { color: #a4161a; font-weight: 600; background: #fbe6e6; }
.verdict { display: inline-block; padding: .15rem .6rem; border-radius: 4px; font-weight: 700; }
.verdict.pass { background: #e5f5ea; color: #0b6b2b; } .verdict.fail { background: #fbe6e6; color: #a4161a; }
figure { margin: 1.2rem 0 2rem; } figure img { max-width: 100%; height: auto; border: 1px solid #e3e7ee; }
figcaption { font-size: .9rem; color: #4a5568; margin-top: .3rem; }
"""


def _cell(text: str, tag: str) -> str:
    if text in ("PASS", "FAIL"):
        cls = f' class="{text.lower()}"'
    elif tag == "td" and is_numeric(text):
        cls = ' class="num"'
    else:
        cls = ""
    return f"<{tag}{cls}>{html.escape(text)}</{tag}>"


def render_html(blocks: list[Block], images: Mapping[str, bytes], *, title: str, passed: bool) -> str:
    """A self-contained HTML page: inline CSS, figures as base64 PNG data URIs.

    Parameters
    ----------
    blocks : list of Block
        The report content.
    images : mapping of str to bytes
        PNG bytes of each figure by name.
    title : str
        Page title.
    passed : bool
        Overall verdict, shown as a badge under the title.
    """
    body: list[str] = []
    toc = [b for b in blocks if isinstance(b, Heading) and b.level == 2]
    for b in blocks:
        if isinstance(b, Heading):
            anchor = f' id="{html.escape(b.anchor)}"' if b.anchor else ""
            body.append(f"<h{b.level}{anchor}>{html.escape(b.text)}</h{b.level}>")
            if b.level == 1:
                badge = "pass" if passed else "fail"
                body.append(f'<p><span class="verdict {badge}">{"PASS" if passed else "FAIL"}</span></p>')
                links = " ".join(f'<a href="#{html.escape(h.anchor)}">{html.escape(h.text)}</a>' for h in toc)
                body.append(f"<nav>{links}</nav>")
        elif isinstance(b, Paragraph):
            body.append(f"<p>{html.escape(b.text)}</p>")
        elif isinstance(b, Table):
            rows = "\n".join("<tr>" + "".join(_cell(c, "td") for c in row) + "</tr>" for row in b.rows)
            caption = f"<caption>{html.escape(b.caption)}</caption>" if b.caption else ""
            head = "<tr>" + "".join(_cell(c, "th") for c in b.header) + "</tr>"
            body.append(f"<table>{caption}<thead>{head}</thead><tbody>\n{rows}\n</tbody></table>")
        elif isinstance(b, Figure):
            data = base64.b64encode(images[b.name]).decode("ascii")
            caption = html.escape(b.caption)
            body.append(
                f'<figure id="fig-{html.escape(b.name)}"><img src="data:image/png;base64,{data}" '
                f'alt="{caption}"><figcaption>Figure: {caption}</figcaption></figure>'
            )
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
        + "\n".join(body)
        + "\n</body>\n</html>\n"
    )


# ---------------------------------------------------------------------------
# The report folder


def write_report(result: DesignResult, out_dir: str | Path) -> dict[str, Path]:
    """Write every artefact of the design into ``out_dir`` (created if needed).

    Parameters
    ----------
    result : DesignResult
        The design (:func:`attitude.app.design.run_design`).
    out_dir : str or Path
        Output directory.

    Returns
    -------
    dict of str to Path
        ``report_md``, ``report_html``, ``results_json``, ``spacecraft_toml``
        and ``figures`` (the folder).
    """
    out = Path(out_dir)
    fig_dir = out / "figures"
    fig_dir.mkdir(parents=True, exist_ok=True)
    images: dict[str, bytes] = {}
    for name, fig in result.figures.items():
        path = fig_dir / f"{name}.png"
        fig.savefig(path, dpi=FIGURE_DPI)
        images[name] = path.read_bytes()
    results = result.results
    blocks = build_blocks(results)
    title = f"Attitude-control design report: {results['spacecraft']['name']}"
    paths = {
        "report_md": out / "report.md",
        "report_html": out / "report.html",
        "results_json": out / "results.json",
        "spacecraft_toml": out / "spacecraft.toml",
        "figures": fig_dir,
    }
    paths["results_json"].write_text(dumps_json(results), encoding="utf-8")
    paths["spacecraft_toml"].write_text(config_to_toml(result.config), encoding="utf-8")
    paths["report_md"].write_text(render_markdown(blocks), encoding="utf-8")
    paths["report_html"].write_text(
        render_html(blocks, images, title=title, passed=bool(results["verdict"]["pass"])), encoding="utf-8"
    )
    return paths

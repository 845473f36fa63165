"""The design report writer (Markdown, HTML, JSON) and its sections."""

from attitude.app.report.writer import (
    FIGURE_DPI,
    dumps_json,
    is_numeric,
    render_html,
    render_markdown,
    requirements_text,
    to_jsonable,
    write_report,
)

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

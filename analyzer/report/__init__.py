"""The HTML report: jinja2 templates (``reports/templates``) that only display numbers
computed here and in the pipeline."""

from __future__ import annotations

from typing import Any

from jinja2 import Environment, PackageLoader, select_autoescape

_env: Environment | None = None


def environment() -> Environment:
    global _env
    if _env is None:
        _env = Environment(
            loader=PackageLoader("analyzer.templates", ""),
            autoescape=select_autoescape(["html"]),
        )
    return _env


def render_report(analysis: Any, doc: dict[str, Any]) -> str:
    """The self-contained ``report.html`` for one analysis."""
    return environment().get_template("report.html").render(doc=doc)


__all__ = ["environment", "render_report"]

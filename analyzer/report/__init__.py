"""The HTML report: one self-contained page (inline CSS and SVG figures, no script, no
external reference) that reads as a forensic audit: verdict first, then the evidence of
each finding, the archive, the models and the method.

Jinja2 templates (``reports/templates``, shipped as ``analyzer.templates``) only display
strings the view layer (:mod:`analyzer.report.view`) computed from the analysis and its
``findings.json`` document; autoescaping is on for every ``.html`` template.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

from analyzer.report.decimate import Envelope, envelope
from analyzer.report.view import MAX_DETAILED, ReportView, build_view

_env: Environment | None = None


def environment() -> Environment:
    """The report's Jinja2 environment (autoescaped HTML, undefined names are errors)."""
    global _env
    if _env is None:
        _env = Environment(
            loader=PackageLoader("analyzer.templates", ""),
            autoescape=select_autoescape(["html"]),
            undefined=StrictUndefined,
            trim_blocks=False,
            lstrip_blocks=False,
        )
    return _env


def render_view(view: ReportView) -> str:
    """The page for an already built view."""
    return environment().get_template("report.html").render(report=view)


def render_report(analysis: Any, doc: Mapping[str, Any]) -> str:
    """The self-contained ``report.html`` for one analysis and its ``findings.json``
    document (:func:`analyzer.pipeline.findings_document`)."""
    return render_view(build_view(analysis, doc))


__all__ = [
    "MAX_DETAILED",
    "Envelope",
    "ReportView",
    "build_view",
    "envelope",
    "environment",
    "render_report",
    "render_view",
]

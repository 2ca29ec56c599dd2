"""The HTML report: one self-contained page (inline CSS and SVG figures, no script, no
external reference) that reads as a forensic audit: verdict first, then the evidence of
each finding, the archive, the models and the method.

Jinja2 templates (``reports/templates``, shipped as ``analyzer.templates``) only display
strings the view layer (:mod:`analyzer.report.view`) computed from the analysis and its
``findings.json`` document; autoescaping is on for every ``.html`` template. The view's
figures are drawn by the worker processes of :func:`analyzer.report.workers.figure_workers`
when the CLI started them (the main process then never imports matplotlib), else
in-process; the page is the same byte for byte.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from jinja2 import (
    BaseLoader,
    Environment,
    FileSystemLoader,
    PackageLoader,
    StrictUndefined,
    select_autoescape,
)
from markupsafe import Markup

from analyzer.report.decimate import Envelope, envelope
from analyzer.report.format import visible_controls
from analyzer.report.view import MAX_DETAILED, ReportView, build_view
from analyzer.report.workers import FigureWorkers, figure_workers

_env: Environment | None = None


SOURCE_TEMPLATES = Path(__file__).resolve().parents[2] / "reports" / "templates"
"""The templates in a source checkout (``analyzer`` imported from the repository without
being installed, as the benchmarks' children and ``PYTHONPATH=. python -m analyzer`` do):
the installed package maps them to ``analyzer.templates``."""


def _loader() -> BaseLoader:
    """The templates of the checkout ``analyzer`` was imported from, else the installed
    ones. The checkout's first: an editable install maps ``analyzer.templates`` to its
    own checkout whatever ``analyzer`` was imported from, so a second checkout run with
    ``PYTHONPATH`` (a git worktree at another commit) rendered the first one's
    templates, which need other fields of the view."""
    if (SOURCE_TEMPLATES / "report.html").is_file() and (
        SOURCE_TEMPLATES.parents[1] / "pyproject.toml"
    ).is_file():
        return FileSystemLoader(SOURCE_TEMPLATES)
    if importlib.util.find_spec("analyzer.templates") is not None:
        return PackageLoader("analyzer.templates", "")
    return FileSystemLoader(SOURCE_TEMPLATES)


def _finalize(value: Any) -> Any:
    """Every printed text (not the SVG figures, already :class:`Markup`) with its control
    and bidi formatting characters made visible (:func:`~analyzer.report.format.visible_controls`):
    escaping stops markup, this stops a channel name from reversing the text after it."""
    if isinstance(value, str) and not isinstance(value, Markup):
        return visible_controls(value)
    return value


def environment() -> Environment:
    """The report's Jinja2 environment (autoescaped HTML, undefined names are errors,
    control characters in printed text made visible)."""
    global _env
    if _env is None:
        _env = Environment(
            loader=_loader(),
            autoescape=select_autoescape(["html"]),
            finalize=_finalize,
            undefined=StrictUndefined,
            trim_blocks=False,
            lstrip_blocks=False,
        )
    return _env


def render_view(view: ReportView) -> str:
    """The page for an already built view."""
    return environment().get_template("report.html").render(report=view)


def render_report(
    analysis: Any, doc: Mapping[str, Any], workers: FigureWorkers | None = None
) -> str:
    """The self-contained ``report.html`` for one analysis and its ``findings.json``
    document (:func:`analyzer.findings.findings_document`); figures drawn by
    ``workers`` (by default those of the enclosing :func:`figure_workers` context, if
    any), else in-process."""
    return render_view(build_view(analysis, doc, workers))


__all__ = [
    "MAX_DETAILED",
    "Envelope",
    "FigureWorkers",
    "ReportView",
    "build_view",
    "envelope",
    "environment",
    "figure_workers",
    "render_report",
    "render_view",
]

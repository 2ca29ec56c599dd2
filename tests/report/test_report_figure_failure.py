"""A figure that the plotting library cannot draw costs that figure, not the page: a line
in its place, a note in report.html and findings.json, a warning on stderr (it used to
fail the whole run with exit 2 after the analysis had found its faults)."""

import json

import analyzer.report.workers as report_workers
from analyzer.findings import write_outputs
from analyzer.report.jobs import draw
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType


def _analysis():
    return synthetic_analysis(
        120.0, 3, 50.0, [SyntheticFault(1, FaultType.ADDITIVE, 60.0, None, 1.0)]
    )


def test_a_figure_that_cannot_be_drawn_leaves_a_line_and_a_note(monkeypatch, tmp_path):
    drawn = []

    def spy(job):
        drawn.append(job.figure)
        return draw(job)

    def breaking(job):
        if job.figure == "coverage_figure":
            raise ValueError("Image size of 1x2000000 pixels is too large")
        return draw(job)

    good = tmp_path / "good"
    good.mkdir()
    monkeypatch.setattr(report_workers, "draw", spy)
    write_outputs(_analysis(), good)
    assert drawn.count("coverage_figure") == 1 and len(drawn) > 1, drawn

    monkeypatch.setattr(report_workers, "draw", breaking)
    warned = []
    doc = write_outputs(_analysis(), tmp_path, warned.append)
    html = (tmp_path / "report.html").read_text()
    assert "This figure could not be drawn (ValueError: Image size of 1x2000000" in html
    assert html.count("<svg") == (good / "report.html").read_text().count("<svg") - 1
    on_disk = json.loads((tmp_path / "findings.json").read_text())
    assert on_disk == doc and on_disk["faults"]  # the analysis is all there
    notes = [n for n in on_disk["notes"] if "could not be drawn" in n]
    assert len(notes) == 1 and "ValueError" in notes[0]
    assert warned == notes
    assert notes[0].replace("'", "&#39;") in html  # among the page's notes too


def test_without_failures_nothing_is_added(tmp_path):
    warned = []
    doc = write_outputs(_analysis(), tmp_path, warned.append)
    assert warned == [] and not any("could not be drawn" in n for n in doc["notes"])
    assert "could not be drawn" not in (tmp_path / "report.html").read_text()

"""What report.html says: verdict, findings, figures, escaping, self-containment.

The analyses come from the real pipeline on short simulated buildings written as CSV in
a temporary folder (a few seconds each), and from :mod:`analyzer.report.synthetic` where
a test needs more findings or a longer record than a quick pipeline run gives."""

import dataclasses
import json
import re
from types import SimpleNamespace

import numpy as np
import pytest
from markupsafe import escape

import analyzer.report.view as report_view
from analyzer.pipeline import RunOptions, analyze, findings_document, write_outputs
from analyzer.report import environment, render_report
from analyzer.report.figures import MAX_POINTS
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType
from analyzer.writers import write_archive

RATE = 50.0
EVIL = "<script>alert(1)</script>"
EXTERNAL = (
    'src="http',
    "src='http",
    'href="http',
    "href='http",
    "@import",
    "url(http",
    "url('http",
    'url("http',
    "<link",
    "<script",
    "<iframe",
    "<img",
)


def _building(path, fault: bool):
    t, y, names = simulate_building(3, 60.0, RATE, seed=1)
    names = ["s0", EVIL, "s2"]
    if fault:
        y[:, 1] = inject_fault(y[:, 1], RATE, "additive", 36.0, 3.0 * float(np.std(y[:, 1])))
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path,
        "csv",
        t_ns,
        {n: y[:, i] for i, n in enumerate(names)},
        start_iso="2026-01-01T00:00:00Z",
    )
    return path


@pytest.fixture(scope="module")
def faulty(tmp_path_factory):
    path = _building(tmp_path_factory.mktemp("faulty") / "faulty.csv", fault=True)
    analysis = analyze([path], RunOptions(train="0:15", corrected=True))
    assert analysis.findings, "the simulated offset must be found for these tests to mean much"
    doc = findings_document(analysis)
    return analysis, doc, render_report(analysis, doc)


@pytest.fixture(scope="module")
def healthy(tmp_path_factory):
    path = _building(tmp_path_factory.mktemp("healthy") / "healthy.csv", fault=False)
    analysis = analyze([path], RunOptions(train="0:15"))
    assert not analysis.findings
    doc = findings_document(analysis)
    return analysis, doc, render_report(analysis, doc)


def _figures(html: str) -> list[str]:
    return re.findall(r'<figure class="plot" data-kind="(\w+)">', html)


def test_verdict_lists_every_finding(faulty):
    _, doc, html = faulty
    n = len(doc["faults"])
    assert f"{n} sensor fault" in html and "No sensor fault found" not in html
    verdict = html[html.index('id="verdict"') : html.index('id="findings"')]
    assert EVIL in {f["channel"] for f in doc["faults"]}
    for f in doc["faults"]:
        assert escape(f["channel"]) in verdict
        assert f["type"] in verdict
        assert f"{f['onset_s']:.2f} s" in verdict  # (to the sample period: 50 Hz)
        assert f["onset"] in verdict  # absolute UTC onset
        for d in f["evidence"]["detectors"]:
            assert d in verdict


def test_each_detailed_finding_has_its_figures_and_tests(faulty):
    analysis, doc, html = faulty
    kinds = _figures(html)
    # coverage, levels + per finding: signal, residual, innovation tests, corrected
    n = min(len(doc["faults"]), report_view.MAX_DETAILED)
    assert kinds.count("coverage") == 1 and kinds.count("levels") == 1
    for k in ("signal", "residual", "tests", "corrected"):
        assert kinds.count(k) == n, k
    assert len(kinds) == 2 + 4 * n
    f = doc["faults"][0]
    section = html[html.index('id="finding-1"') :]
    for det in f["evidence"]["tests"]:
        assert f"Innovation tests: {det}" in section
    for name in (
        "Anderson-Darling",
        "Cramér-von Mises",
        "Ljung-Box Q",
        "Zero mean",
        "Unit covariance",
        "Shewhart chart",
    ):
        assert name in section
    lead = f["evidence"]["tests"][f["detector"]]["after"]
    assert f"{lead['anderson_darling']['critical']:.4g}" in section
    assert "Correction" in section and doc["corrections"][0]["method"] in section


def test_without_corrections_the_corrected_figure_is_skipped(faulty):
    """An analysis-like object without ``corrected``/``corrections`` renders, without the
    corrected-signal figure and saying how to get it."""
    analysis, doc, html = faulty
    fields = {f.name: getattr(analysis, f.name) for f in dataclasses.fields(analysis)}
    del fields["corrected"], fields["corrections"]
    plain = render_report(SimpleNamespace(**fields), {**doc, "corrections": []})
    assert _figures(plain) == [k for k in _figures(html) if k != "corrected"]
    assert "run with --corrected" in plain and "run with --corrected" not in html


def test_report_is_self_contained(faulty, healthy):
    for _, _, html in (faulty, healthy):
        low = html.lower()
        for bad in EXTERNAL:
            assert bad not in low, bad
        assert "<style>" in html and "@media print" in html and "max-width: 40rem" in html
        assert html.count("<svg") == len(_figures(html))


def test_channel_name_is_escaped_everywhere(faulty):
    _, _, html = faulty
    assert EVIL not in html
    assert html.count("&lt;script&gt;alert(1)&lt;/script&gt;") >= 5
    assert environment().get_template("report.html").environment.autoescape("report.html")


def test_healthy_report_says_what_was_checked(healthy):
    analysis, doc, html = healthy
    assert "No sensor fault found." in html and "sensor fault found on" not in html
    checked = html[html.index("What was checked") : html.index('id="archive"')]
    assert f"{len(analysis.analyzed)}: s0, &lt;script&gt;" in checked
    for r in doc["detectors"]:
        assert r["name"] in checked
    assert "0.00 s to 15.00 s" in checked and "1e-06 false alarms per sample" in checked
    assert "at most about one false alarm per" in checked
    for name, why in doc["skipped_detectors"].items():
        assert name in checked and why.split("(")[0].strip() in checked
    assert _figures(html) == ["coverage", "levels"] and 'class="finding"' not in html


def test_archive_and_models_sections(faulty):
    analysis, doc, html = faulty
    archive = html[html.index('id="archive"') : html.index('id="models"')]
    i = doc["inputs"][0]
    assert i["sha256"] in archive and i["format"] in archive and "kB" in archive
    assert "0.00 s to 15.00 s" in archive
    models = html[html.index('id="models"') : html.index('id="method"')]
    for r in analysis.results:
        assert f"<h3>{r.detector}</h3>" in models
        assert "Innovation tests on the training residual" in models
    method = html[html.index('id="method"') :]
    for ref in (
        "Chang",
        "Li, Koh &amp; Nagarajaiah",
        "Park, Rizzoni &amp; Ribbens",
        "Wang &amp; Song",
        "Innovation sequence tests (IST)",
    ):
        assert ref in method


def test_write_outputs_writes_the_same_report(faulty, tmp_path):
    analysis, doc, html = faulty
    write_outputs(analysis, tmp_path)
    assert (tmp_path / "report.html").read_text(encoding="utf-8") == html
    assert json.loads((tmp_path / "findings.json").read_text())["faults"] == doc["faults"]


def test_a_source_checkout_renders_the_same_report(faulty, monkeypatch):
    """``analyzer`` imported from the repository without being installed (the
    benchmarks' children, ``PYTHONPATH=. python -m analyzer``) has no
    ``analyzer.templates`` package: the report is rendered from ``reports/templates``
    (it ended with an internal error, exit 2, after findings.json was written)."""
    import importlib.util

    import analyzer.report as report

    analysis, doc, html = faulty
    real = importlib.util.find_spec
    monkeypatch.setattr(
        report.importlib.util,
        "find_spec",
        lambda name, *a: None if name == "analyzer.templates" else real(name, *a),
    )
    monkeypatch.setattr(report, "_env", None)
    assert type(report._loader()).__name__ == "FileSystemLoader"
    assert render_report(analysis, doc) == html


def test_the_checkout_analyzer_comes_from_renders_with_its_own_templates(tmp_path, monkeypatch):
    """An editable install maps ``analyzer.templates`` to its own checkout; a second
    checkout imported with ``PYTHONPATH`` (a git worktree at another commit) must render
    with its own templates, not the installed checkout's (which need other view fields)."""
    import analyzer.report as report

    checkout = tmp_path / "wt"
    (checkout / "reports" / "templates").mkdir(parents=True)
    (checkout / "pyproject.toml").write_text("[project]\n")
    (checkout / "reports" / "templates" / "report.html").write_text("own {{ report }}")
    monkeypatch.setattr(report, "SOURCE_TEMPLATES", checkout / "reports" / "templates")
    loader = report._loader()
    assert type(loader).__name__ == "FileSystemLoader"
    assert loader.get_source(report.environment(), "report.html")[0] == "own {{ report }}"
    # without a checkout around it (an installed wheel): the package's templates
    (checkout / "pyproject.toml").unlink()
    installed = report.importlib.util.find_spec("analyzer.templates") is not None
    want = "PackageLoader" if installed else "FileSystemLoader"
    assert type(report._loader()).__name__ == want


def test_only_the_most_confident_findings_get_figures(monkeypatch):
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    faults = [SyntheticFault(j, FaultType.ADDITIVE, 60.0 + 10 * j, None, 1.0) for j in range(3)]
    a = synthetic_analysis(120.0, 3, RATE, faults)
    doc = findings_document(a)
    html = render_report(a, doc)
    assert len(doc["faults"]) == 3
    assert len(_figures(html)) == 2 + 3  # coverage, levels + one finding's signal, residual, tests
    assert html.count('<section class="finding"') == 1
    assert "the other 2 are listed in the verdict table" in html
    for f in doc["faults"]:
        assert f"{f['onset_s']:.2f} s" in html


def test_long_record_figures_stay_small(tmp_path):
    """Two hours at 100 Hz (720 k samples per channel, memory-mapped): every plotted path
    is decimated, the gap shows in the coverage figure, the page stays small."""
    a = synthetic_analysis(
        7200.0,
        2,
        100.0,
        [SyntheticFault(0, FaultType.DRIFT, 3000.0, 5000.0, 1e-3)],
        gap=(1, 1000.0, 1300.0),
        workdir=tmp_path,
    )
    doc = findings_document(a)
    html = render_report(a, doc)
    assert len(html) < 1_500_000
    longest = max(len(re.findall(r"[ML] ", d)) for d in re.findall(r'\sd="([^"]*)"', html))
    assert longest <= 2 * MAX_POINTS + 8
    start = html.index('data-kind="coverage"')
    coverage = html[start : html.index("</figure>", start)]
    assert "#d62728" in coverage  # the gap colour
    # (a 2-hour record's times in minutes, as its charts)
    assert "+0.001 per s" in html and "50 min 0.00 s" in html and "83 min 20.00 s" in html


def test_relative_timestamps_show_time_into_the_record(monkeypatch):
    monkeypatch.setattr(report_view, "MAX_DETAILED", 0)  # the verdict table only
    a = synthetic_analysis(120.0, 2, RATE, [SyntheticFault(1, FaultType.ADDITIVE, 75.5, None, 1.0)])
    a = dataclasses.replace(a, absolute_time=False)
    doc = findings_document(a)
    html = render_report(a, doc)
    assert doc["faults"][0]["onset"] is None
    assert "+00:01:15.50" in html and "relative timestamps" in html
    assert _figures(html) == ["coverage", "levels"]


def test_input_errors_skipped_detectors_and_notes_are_listed(monkeypatch):
    monkeypatch.setattr(report_view, "MAX_DETAILED", 0)
    a = synthetic_analysis(120.0, 2, RATE, [])
    a.inputs[0].errors.append("chunk 3: truncated record at byte 4096")
    a.skipped["error_function"] = "needs [[group]] reference/uncertain sensors"
    a.skipped["detection_filter"] = "too little healthy data to calibrate"
    html = render_report(a, findings_document(a))
    verdict = html[html.index('id="verdict"') : html.index('id="archive"')]
    assert "Input errors" in verdict and "truncated record at byte 4096" in verdict
    assert "Detectors not run" in verdict and "detection_filter</b>: too little" in verdict
    # (the error functions' need of a config is the normal case, said apart)
    assert "One more check, <b>error_function</b>, was not run" in verdict
    assert "synthetic analysis" in verdict  # the analysis notes
    archive = html[html.index('id="archive"') : html.index('id="models"')]
    assert "truncated record at byte 4096" in archive

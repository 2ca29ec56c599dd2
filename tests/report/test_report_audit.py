"""Report fixes from the audit of report.html against findings.json: an onset that is
only an upper bound, the warm-up's label, times at high rates, gains near zero, the
fault evidence beyond the detectors', long names, value ranges, which findings get a
section, sorting and the tests figure's title.

Analyses come from :mod:`analyzer.report.synthetic` (no detector run: a second or two);
where a case needs evidence the synthetic run does not produce (``--model``'s
``onset_at_or_before``, a frozen sensor), it is added to the document as the pipeline
writes it."""

import copy
import dataclasses
import re

import pytest

import analyzer.report.view as report_view
from analyzer.findings import findings_document
from analyzer.report import format as fmt
from analyzer.report import render_report
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType

RATE = 50.0


def _figure(html: str, kind: str) -> str:
    start = html.index(f'data-kind="{kind}"')
    return html[start : html.index("</figure>", start)]


def _texts(svg: str) -> list[str]:
    return re.findall(r"<text[^>]*>(.*?)</text>", svg, re.S)


def _fact(html: str, label: str) -> str:
    return re.search(rf"<dt>{label}</dt><dd>([^<]*)</dd>", html).group(1)


def _with_model(doc: dict, warm_up_s: float) -> dict:
    """``doc`` as a ``--model`` run writes it: a ``model`` object, the warm-up as
    ``train``, the first finding present when the search started."""
    doc = copy.deepcopy(doc)
    doc["model"] = {
        "path": "/models/fit.model",
        "trained_on": [{"path": "/data/fit.mcap"}],
        "train": {"start_s": 0.0, "end_s": 24.0},
    }
    doc["train"] = {"start_s": 0.0, "end_s": warm_up_s}
    f = doc["faults"][0]
    f["onset_s"] = warm_up_s + 1 / RATE
    f["evidence"]["onset_at_or_before"] = True
    return doc


@pytest.fixture
def model_run(monkeypatch):
    """A ``--model`` run whose fault was there from the first sample: found at the end of
    the filters' warm-up (4.3 s), its onset an upper bound."""
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    a = synthetic_analysis(60.0, 3, RATE, [SyntheticFault(1, FaultType.ADDITIVE, 4.32, None, 1.0)])
    doc = _with_model(findings_document(a), 4.3)
    return a, doc, render_report(a, doc)


# -- an onset that is an upper bound -------------------------------------------------------


def test_a_fault_there_from_the_start_is_said_alike_wherever_it_is_shown(model_run):
    _, doc, html = model_run
    f = doc["faults"][0]
    verdict = html[html.index('id="verdict"') : html.index('id="findings"')]
    # there when the filters could first judge: "from the start", as the run's line says
    # it (it read "at or before 4.310 s", a constant channel's "at or before 0.000 s")
    said = f"from the start (not judged before {f['onset_s']:.2f} s"  # (50 Hz: 2 decimals)
    assert said + ")" in verdict
    assert _fact(html, "Onset").startswith(said)
    # and the figures in the same words (their legends read "onset: at or before")
    for kind in ("signal", "residual"):
        assert "from the start (not judged before)" in _texts(_figure(html, kind)), kind
    assert "nothing was judged (the fault was there from the start" in _figure(html, "signal")
    for kind in ("coverage", "levels"):
        assert "may have begun (not judged)" in _texts(_figure(html, kind)), kind
        assert "upper bound" in _figure(html, kind)  # the caption, of every such finding
    assert "from the start (not judged before then" in _fact(html, "Onset bound")
    assert "at or before" not in html.replace("an onset that is an upper bound", "")


def test_an_exact_onset_is_shown_as_it_is(monkeypatch):
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    a = synthetic_analysis(60.0, 3, RATE, [SyntheticFault(1, FaultType.ADDITIVE, 30.0, None, 1.0)])
    html = render_report(a, findings_document(a))
    assert "at or before" not in html and "may have begun" not in html
    assert "onset" in _texts(_figure(html, "signal"))


# -- the warm-up's name ---------------------------------------------------------------------


def test_with_a_model_every_figure_calls_the_first_seconds_the_filters_warm_up(model_run):
    """The level map called the span "training window" while the page said nothing was
    trained on the archive and the other figures called it the filters' warm-up."""
    _, _, html = model_run
    for kind in ("coverage", "levels", "residual"):
        texts = _texts(_figure(html, kind))
        assert "filters' warm-up" in texts and "training window" not in texts, kind


# -- times at high rates --------------------------------------------------------------------


def test_time_decimals_follow_the_rate():
    # (to the sample period, ux60 item 8: 3 decimals at 1 Hz read "2121.000 s")
    assert [fmt.time_decimals(r) for r in (0.1, 1.0, 50.0, 1000.0, 1024.0, 2000.0, 50_000.0)] == [
        0,
        0,
        2,
        3,
        4,
        4,
        4,  # findings.json keeps 4
    ]
    assert fmt.time_decimals(None) == 3 and fmt.time_decimals(float("nan")) == 3
    assert fmt.clock(20.0005, 4) == "+00:00:20.0005" and fmt.clock(3725.5) == "+01:02:05.500"


@pytest.mark.parametrize("absolute", [True, False])
def test_an_onset_at_2_khz_reads_as_findings_json_has_it(monkeypatch, absolute):
    """An offset from 60.0005 s at 2 kHz: the cell showed ``60.000 s`` above
    ``2026-01-01T00:01:00.001Z`` (or ``+00:01:00.000``)."""
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    a = synthetic_analysis(
        100.0, 2, 2000.0, [SyntheticFault(1, FaultType.ADDITIVE, 60.0005, 80.0, 1.0)]
    )
    a = dataclasses.replace(a, absolute_time=absolute)
    doc = findings_document(a)
    f = doc["faults"][0]
    f["onset_s"], f["end_s"] = 60.0005, 80.0
    f["onset"] = "2026-01-01T00:01:00.001Z" if absolute else None
    html = render_report(a, doc)
    verdict = html[html.index('id="verdict"') : html.index('id="findings"')]
    assert "60.0005 s" in verdict and "80.0000 s" in verdict and "60.000 s" not in verdict
    assert _fact(html, "Onset").startswith("60.0005 s from the start")
    if not absolute:
        assert "+00:01:00.0005" in verdict


# -- gains near zero -------------------------------------------------------------------------


def test_only_a_gain_of_zero_is_called_a_dead_sensor():
    """The contract's dead sensor is gain 0; below the classifier's 0.1 the sensor still
    reads a share of its signal, which the label gives."""
    assert fmt.magnitude({"gain": 0.0}) == "gain ×0 (dead sensor)"
    assert fmt.magnitude({"gain": 0.02557}) == (
        "gain ×0.02557 (reads 2.56 % of its signal: nearly dead)"
    )
    assert "inverted" in fmt.magnitude({"gain": -0.05})
    for g in (0.1, 0.5, 1.5):
        assert "dead" not in fmt.magnitude({"gain": g})


# -- the fault's own evidence -------------------------------------------------------------


def test_the_fault_evidence_findings_json_documents_is_in_the_finding(monkeypatch):
    """``frozen``, ``clipped``, ``searched_after``, ``searched_without``, ``after_gap_s``
    and ``onset_at_or_before`` reached findings.json only (a dead sensor's frozen readings:
    no "frozen" nor "std_ratio" anywhere on its page)."""
    monkeypatch.setattr(report_view, "MAX_DETAILED", 2)
    a = synthetic_analysis(
        120.0,
        3,
        RATE,
        [
            SyntheticFault(1, FaultType.ADDITIVE, 60.0, None, 1.0),
            SyntheticFault(2, FaultType.ADDITIVE, 90.0, None, 1.0),
        ],
    )
    doc = findings_document(a)
    first, second = sorted(doc["faults"], key=lambda f: f["onset_s"])
    first["evidence"].update(
        frozen={"level": 0.0, "std_ratio": 0.0, "was": "multiplicative"},
        clipped={
            "clipped_high": 4.25,
            "clipped_low": -4.25,
            "readings": 812,
            "fraction": 0.315,
            "first_s": 60.0,
            "last_s": 110.0,
            "in_healthy_window_from_s": None,
            "findings_merged": 21,
            "types_merged": ["additive", "other"],
        },
        after_gap_s=[50.0, 59.5],
    )
    second["evidence"].update(
        searched_after={
            "stretch_s": [70.0, 80.0],
            "search_start_s": 90.0,
            "onset_at_or_before": True,
        },
        searched_without=["/accel.data[0]"],
    )
    html = render_report(a, doc)
    one = html[html.index(f'id="finding-{doc["faults"].index(first) + 1}"') :]
    two = html[html.index(f'id="finding-{doc["faults"].index(second) + 1}"') :]
    one, two = one[: one.index("</dl>")], two[: two.index("</dl>")]
    assert "<dt>Frozen readings</dt><dd>median reading 0, varying 0 × their healthy" in one
    assert "(the residual alone gave multiplicative)" in one
    assert "<dt>Clipping</dt><dd>at 4.25 (high) and -4.25 (low): 812 readings (31.5 %" in one
    # (times to the sample period: 2 decimals at 50 Hz)
    assert "from 60.00 s to 110.00 s; 21 findings merged (additive, other)" in one
    assert "<dt>After a gap</dt><dd>found soon after a gap in its data from 50.00 s" in one
    assert "from 90.00 s, after a stretch (70.000-80.000 s)" in two
    assert "so it may have begun in the stretch" in two
    assert "<dt>Searched without</dt><dd>/accel.data[0]: found by a second search" in two
    assert _fact(two, "Onset").startswith("at or before 90.")  # searched_after's bound


def test_a_model_onset_bound_says_why(model_run):
    _, _, html = model_run
    assert "from the start (not judged before then" in _fact(html, "Onset bound")
    assert "after the filters&#39; warm-up" in _fact(html, "Onset bound")


# -- value ranges ---------------------------------------------------------------------------


def test_a_range_reads_apart_when_its_ends_differ(monkeypatch):
    """A barometer at 101321-101329 Pa read "1.013e+05 to 1.013e+05": a constant channel."""
    assert fmt.num_range(101321.0, 101329.0) == "101321 to 101329"
    assert fmt.num_range(101321.12, 101321.13) == "101321.12 to 101321.13"
    assert fmt.num_range(-1.234, 2.5) == "-1.234 to 2.5"  # 4 digits where they do
    assert fmt.num_range(5.0, 5.0) == "5 to 5" and fmt.num_range(None, 1.0) == "n/a to 1"
    monkeypatch.setattr(report_view, "MAX_DETAILED", 0)
    a = synthetic_analysis(60.0, 2, RATE, [], names=["baro_Pa", "s1"])
    a.channels[0].minimum, a.channels[0].maximum = 101321.0, 101329.0
    html = render_report(a, findings_document(a))
    archive = html[html.index('id="archive"') : html.index('id="models"')]
    assert "<td>101321 to 101329</td>" in archive


# -- which findings have a section ----------------------------------------------------------


def _many(monkeypatch, detailed: int, reverse: bool = False):
    monkeypatch.setattr(report_view, "MAX_DETAILED", detailed)
    faults = [SyntheticFault(j, FaultType.ADDITIVE, 40.0 + 10 * j, None, 1.0) for j in range(5)]
    a = synthetic_analysis(120.0, 5, RATE, faults)
    doc = findings_document(a)
    for f in doc["faults"]:
        f["confidence"] = 1.0  # all tied, as twelve clear offsets were
    if reverse:
        doc["faults"].reverse()
    return doc, render_report(a, doc)


def test_the_page_says_which_findings_have_a_section(monkeypatch):
    """The footer said each finding's innovation tests were on the page; findings beyond
    the detailed ones had a verdict row only."""
    doc, html = _many(monkeypatch, 2)
    assert len(doc["faults"]) == 5
    findings = html[html.index('id="findings"') : html.index('id="archive"')]
    text = " ".join(findings.split())
    assert (
        "The 2 most confident findings (the earliest first among equally confident ones), " in text
    )
    assert "findings 1-2, have a section below" in text and "the other 3 are listed in" in text
    footer = " ".join(html[html.rindex("<footer") :].split())
    assert "on this page the tests and evidence of findings 1-2 only" in footer
    doc, html = _many(monkeypatch, 6)  # all have one: no such text
    assert "most confident findings" not in html and "only, the findings with a section" not in html


def test_among_equally_confident_findings_the_earliest_get_a_section(monkeypatch):
    doc, html = _many(monkeypatch, 2, reverse=True)
    numbers = [i + 1 for i, f in enumerate(doc["faults"]) if f["onset_s"] < 55.0]
    assert numbers == [4, 5]
    assert html.count('<section class="finding"') == 2
    for n in numbers:
        assert f'id="finding-{n}"' in html
    assert "findings 4-5, have a section below" in " ".join(html.split())


# -- cosmetics ------------------------------------------------------------------------------


def test_the_headline_sorts_sensor_names_by_their_numbers(monkeypatch):
    assert sorted(["s10", "s2", "s1", "a", "s1b"], key=fmt.natural_key) == [
        "a",
        "s1",
        "s1b",
        "s2",
        "s10",
    ]
    # (a review: a number met a name and the report was not written)
    assert sorted(["acc1_x2", "acc1_x", "0a", "a0"], key=fmt.natural_key) == [
        "0a",
        "a0",
        "acc1_x",
        "acc1_x2",
    ]
    monkeypatch.setattr(report_view, "MAX_DETAILED", 0)
    faults = [SyntheticFault(j, FaultType.ADDITIVE, 60.0 + 10 * j, None, 1.0) for j in range(2)]
    a = synthetic_analysis(120.0, 3, RATE, faults, names=["s10", "s2", "s0"])
    html = render_report(a, findings_document(a))
    assert "2 sensor faults found on 2 sensors: s2, s10." in html


def test_the_tests_figure_names_the_whitened_residual_it_plots(monkeypatch):
    """Its title said "standardized residual of ar_kalman_bank" and its axis
    "standardized residual z", of the whitened residual the tests ran on."""
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    a = synthetic_analysis(120.0, 3, RATE, [SyntheticFault(1, FaultType.ADDITIVE, 60.0, None, 1.0)])
    doc = findings_document(a)
    f = doc["faults"][0]
    assert f["evidence"]["tests"][f["detector"]].get("whitening")
    texts = _texts(_figure(render_report(a, doc), "tests"))
    assert f"whitened residual of {f['detector']}" in texts and "whitened residual z" in texts
    assert not [t for t in texts if "standardized" in t]
    # without a whitening the residual is the standardized one, and the figure says so
    for t in f["evidence"]["tests"].values():
        t.pop("whitening", None)
    texts = _texts(_figure(render_report(a, doc), "tests"))
    assert f"standardized residual of {f['detector']}" in texts

"""Report fixes from the probe of report.html / findings.json: control and bidi
characters in names, long names, the footer's claim, End without absolute time, slow
records, the SVG clean-up and matplotlib's glyph warnings.

Analyses come from :mod:`analyzer.report.synthetic` (no detector run: a second or two)."""

import dataclasses
import json
import re
import warnings

import pytest

import analyzer.report as report
import analyzer.report.view as report_view
from analyzer.findings import findings_document, write_outputs
from analyzer.report import environment, render_report
from analyzer.report.format import shorten, visible_controls
from analyzer.report.svg import clean_svg
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType

RATE = 50.0
RLO = "ctl\x07bell\u202eRLO"
LONG = "/robot/" + "sensor_array_" * 11 + "x"  # 151 characters: crashed the coverage figure


def _faulty(names, monkeypatch, detailed=1, **kw):
    monkeypatch.setattr(report_view, "MAX_DETAILED", detailed)
    a = synthetic_analysis(
        120.0,
        len(names),
        RATE,
        [SyntheticFault(1, FaultType.ADDITIVE, 60.0, None, 1.0)],
        names=names,
        **kw,
    )
    doc = findings_document(a)
    return a, doc, render_report(a, doc)


def _figure(html: str, kind: str) -> str:
    start = html.index(f'data-kind="{kind}"')
    return html[start : html.index("</figure>", start)]


# -- control and bidi characters ----------------------------------------------------------


def test_visible_controls_escapes_bidi_and_c0_c1_but_not_tab():
    assert visible_controls("a\u202eb\u2066c\u200fd") == "a\\u202eb\\u2066c\\u200fd"
    assert visible_controls("x\x07y\x85z\nw") == "x\\u0007y\\u0085z\\u000aw"
    assert visible_controls("tab\there é 温") == "tab\there é 温"


def test_environment_neutralizes_printed_text_but_not_markup():
    env = environment()
    assert env.from_string("{{ x }}").render(x="a\u202eb") == "a\\u202eb"
    assert env.from_string("{{ x|join(', ') }}").render(x=["\u202e", "b"]) == "\\u202e, b"


def test_bidi_and_control_characters_never_reach_the_page(monkeypatch):
    _, doc, html = _faulty(["s0", RLO], monkeypatch)
    assert doc["faults"] and doc["faults"][0]["channel"] == RLO  # findings.json keeps the name
    for ch in ("\u202e", "\x07"):
        assert ch not in html
    assert "ctl\\u0007bell\\u202eRLO" in html
    assert "ctl\\u0007bell\\u202eRLO" in _figure(html, "coverage")  # SVG text too


# -- long names ---------------------------------------------------------------------------


def test_shorten_keeps_both_ends():
    s = shorten(LONG, 48)
    assert len(s) == 48 and s.startswith("/robot/sensor_") and s.endswith("_x") and "…" in s
    assert shorten("short", 48) == "short"


def test_a_long_channel_name_is_ellipsized_in_figures_and_whole_in_tables(monkeypatch):
    _, doc, html = _faulty(["s0", LONG, "s2"], monkeypatch)
    assert doc["faults"][0]["channel"] == LONG
    coverage = _figure(html, "coverage")
    assert LONG not in coverage and "…" in coverage
    assert f'<td class="name">{LONG}</td>' in html


def test_a_failed_report_leaves_the_previous_outputs_as_a_pair(monkeypatch, tmp_path):
    a = synthetic_analysis(120.0, 2, RATE, [SyntheticFault(1, FaultType.ADDITIVE, 60.0, None, 1.0)])
    (tmp_path / "findings.json").write_text('{"faults": []}\n')
    (tmp_path / "report.html").write_text("<p>No sensor fault found.</p>\n")

    def broken(*args, **kwargs):
        raise ValueError("left cannot be >= right")

    monkeypatch.setattr(report, "render_view", broken)
    with pytest.raises(ValueError, match="left cannot be"):
        write_outputs(a, tmp_path)
    assert json.loads((tmp_path / "findings.json").read_text()) == {"faults": []}
    assert (tmp_path / "report.html").read_text() == "<p>No sensor fault found.</p>\n"


# -- footer, End --------------------------------------------------------------------------


def test_footer_says_which_numbers_are_in_findings_json(monkeypatch):
    _, _, html = _faulty(["s0", "s1"], monkeypatch, detailed=0)
    footer = html[html.rindex("<footer") :]
    assert "Every number on this page is also in" not in footer
    assert "residual σ" in footer and "not in <code>findings.json</code>" in footer


def test_end_without_absolute_time_is_shown_like_the_onset(monkeypatch):
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    a = synthetic_analysis(120.0, 2, RATE, [SyntheticFault(1, FaultType.ADDITIVE, 60.0, 90.0, 1.0)])
    a = dataclasses.replace(a, absolute_time=False)
    doc = findings_document(a)
    html = render_report(a, doc)
    assert doc["faults"][0]["end_s"] is not None and doc["faults"][0]["end"] is None
    onset = re.search(r"<dt>Onset</dt><dd>([^<]*)</dd>", html).group(1)
    end = re.search(r"<dt>End</dt><dd>([^<]*)</dd>", html).group(1)
    assert "(" not in onset and "(" not in end, (onset, end)


# -- slow records -------------------------------------------------------------------------


def test_a_slow_record_has_no_promised_close_up_and_reads_in_hours(monkeypatch):
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    day = 86400.0
    a = synthetic_analysis(
        4 * day, 2, 1 / 60.0, [SyntheticFault(1, FaultType.ADDITIVE, 3 * day, None, 1.0)]
    )
    doc = findings_document(a)
    html = render_report(a, doc)
    signal = _figure(html, "signal")
    assert "close-up" not in signal  # one panel: neither drawn nor promised
    caption = signal[signal.index("<figcaption>") :]
    assert not re.search(r"\d{5,}\.\d+ s", caption), caption
    assert re.search(r"time from start \((h|min|d)\)", signal)
    assert doc["faults"][0]["onset_s"] > 100_000  # findings.json keeps seconds


def test_a_fast_record_keeps_its_close_up_and_seconds(monkeypatch):
    _, _, html = _faulty(["s0", "s1"], monkeypatch)
    signal = _figure(html, "signal")
    assert "close-up: onset ± 4 s" in signal and "Below: close-up of the onset (± 4 s" in signal
    assert "time from start (s)" in signal


# -- SVG clean-up -------------------------------------------------------------------------


def test_clean_svg_rewrites_tags_but_not_text():
    name = 'x="1.23456" d="M 1.23456 2.34567" href="#top" id="z" url(#foo)'
    svg = (
        '<?xml version="1.0"?>\n<svg width="10pt" height="5pt" viewBox="0 0 10 5">'
        '<path id="p1" d="M 1.23456 2.34567" clip-path="url(#c1)"/>'
        f'<text x="1.23456" y="2.5678">{name}</text><use href="#p1"/></svg>'
    )
    out = clean_svg(svg, "k")
    assert f">{name}</text>" in out
    assert '<path id="k-p1" d="M 1.2 2.3" clip-path="url(#k-c1)"/>' in out
    assert '<text x="1.2" y="2.5">' in out and '<use href="#k-p1"/>' in out


# -- warnings -----------------------------------------------------------------------------


def test_missing_glyphs_do_not_warn(monkeypatch):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _faulty(["s0", "温度\u2603"], monkeypatch)
    assert not [w for w in caught if "Glyph" in str(w.message)]


def test_names_that_differ_in_the_middle_stay_apart_in_a_figure():
    """Three wings' deep paths, cut in the middle, all read alike: drawn whole instead."""
    from analyzer.report.svg import shown_names

    names = [
        f"building_A/structural_health/{wing}_wing/floor_accelerometer_raw_x"
        for wing in ("north", "south", "east_")
    ]
    shown = shown_names(names)
    assert len(set(shown)) == 3 and shown == names
    assert shown_names(["a" * 60, "b" * 60]) == [shorten("a" * 60), shorten("b" * 60)]

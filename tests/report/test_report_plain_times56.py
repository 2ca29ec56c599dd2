"""The report's times in one unit with its charts, to the sample period (ux60 item 8), and
the healthy verdict in words an engineer reads without a statistician (ux60 item 10).

A 1-hour record at 1 Hz gave ``2121.000 s`` in the verdict table beside charts in
minutes: a millisecond the record does not have, in a unit its charts do not use. A
healthy record's verdict said "None of the detectors found a residual that left its
threshold band" and "False-alarm rate 1e-06 per sample (shared among each detector's
channels)"."""

from __future__ import annotations

import re

import pytest

from analyzer.findings import findings_document
from analyzer.report import format as fmt
from analyzer.report import render_report
from analyzer.report.synthetic import DETECTORS, SyntheticFault, synthetic_analysis
from analyzer.types import FaultType


def _verdict(html: str) -> str:
    end = html.index('id="findings"') if 'id="findings"' in html else html.index('id="archive"')
    return html[html.index('id="verdict"') : end]


def _fact(html: str, label: str) -> str:
    return re.search(rf"<dt>{label}</dt><dd>(.*?)</dd>", html, re.S).group(1)


def _render(duration_s: float, rate_hz: float, faults: list[SyntheticFault]) -> tuple[dict, str]:
    a = synthetic_analysis(duration_s, 2, rate_hz, faults)
    doc = findings_document(a)
    return doc, render_report(a, doc)


def _min_s(x: float) -> str:
    """``35 min 21 s``: ``x`` seconds to the whole second (a 1 Hz record's)."""
    m, s = divmod(round(x), 60)
    return f"{m} min {s} s"


def test_a_long_record_s_onset_reads_in_minutes_as_its_charts_and_to_the_second_at_1_hz():
    doc, html = _render(3600.0, 1.0, [SyntheticFault(1, FaultType.ADDITIVE, 2121.0, 3000.0, 1.0)])
    f = doc["faults"][0]
    assert f["onset_s"] == pytest.approx(2121.0, abs=2.0)  # findings.json keeps seconds
    onset, end = (_min_s(f[k]) for k in ("onset_s", "end_s"))
    verdict = _verdict(html)
    assert onset in verdict and end in verdict
    assert "Onset and end in minutes and seconds from the first sample" in verdict
    assert not re.search(r"\d\.\d+ s\b", verdict), "a fraction of a second at 1 Hz"
    assert not re.search(r"\b\d{3,} s\b", verdict), "seconds where the charts use minutes"
    assert _fact(html, "Onset").startswith(f"{onset} from the start")
    # the charts of the whole record use minutes, as the table now does
    assert "time from start (min)" in html


def test_a_short_record_keeps_seconds_to_the_sample_period():
    doc, html = _render(120.0, 100.0, [SyntheticFault(1, FaultType.ADDITIVE, 75.5, None, 1.0)])
    verdict = _verdict(html)
    onset = f"{doc['faults'][0]['onset_s']:.2f} s"
    assert onset in verdict and f"{doc['faults'][0]['onset_s']:.3f} s" not in verdict
    assert "Onset and end in seconds from the first sample" in verdict


def test_the_clock_rounds_before_it_splits_and_follows_the_chart_unit():
    assert fmt.Clock.of(3600.0, 100.0)(1799.999) == "30 min 0.00 s"
    assert fmt.Clock.of(3600.0, 1.0)(2121.0) == "35 min 21 s"
    assert fmt.Clock.of(20 * 3600.0, 10.0)(4123.46) == "1 h 8 min 43.5 s"
    assert fmt.Clock.of(600.0, 1.0)(16.0) == "16 s"  # a short record: seconds
    assert fmt.Clock.of(300.0, 2000.0)(20.0005) == "20.0005 s"
    assert fmt.Clock.of(3600.0, 1.0).range(2120.0, 2122.0) == "35 min 20 s to 35 min 22 s"
    assert fmt.Clock.of(300.0, 100.0).range(151.2, 151.4) == "151.20 to 151.40 s"
    assert fmt.clock(2121.0, 0) == "+00:35:21"


def test_the_healthy_verdict_says_what_was_taken_as_healthy_and_false_alarms_per_hours():
    rate = 50.0
    a = synthetic_analysis(600.0, 3, rate, [])
    doc = findings_document(a)
    html = render_report(a, doc)
    verdict = _verdict(html)
    assert "residual" not in verdict and "threshold band" not in verdict
    assert "per sample (shared" not in verdict
    assert "No sensor behaved differently from the training window" in verdict
    assert "taken as healthy and was not itself checked" in verdict
    # each pseudo-detector shares the run's rate among its channels: 1e-6 per sample
    # each, two detectors, 50 samples a second
    hours = 1.0 / (len(DETECTORS) * 1e-6 * rate * 3600.0)
    assert hours == pytest.approx(2.78, abs=0.01)
    line = _fact(html, "False alarms")
    assert line.startswith("at most about one false alarm per 2.8 hours of healthy record")


def test_the_rates_are_read_from_the_thresholds_as_the_detectors_set_them():
    """The bank shares the run's rate among its channels, the error functions give each
    sensor the whole rate: the sum over a detector's residuals is what it allows."""
    from analyzer.report.healthy import detector_rates, hours_per_false_alarm

    a = synthetic_analysis(600.0, 4, 50.0, [], false_alarm_rate=1e-5)
    rates = detector_rates(a.results)
    assert rates == pytest.approx({d: 1e-5 for d in DETECTORS})
    assert hours_per_false_alarm(rates, 50.0) == pytest.approx(1 / (2e-5 * 50 * 3600))
    assert hours_per_false_alarm({}, 50.0) is None


def test_hours_are_spoken_in_the_unit_that_reads_best():
    from analyzer.report.healthy import spoken_hours

    assert spoken_hours(0.93) == "56 minutes"
    assert spoken_hours(19.3) == "19 hours"
    assert spoken_hours(926.0) == "39 days"
    assert spoken_hours(9.3e4) == "11 years"

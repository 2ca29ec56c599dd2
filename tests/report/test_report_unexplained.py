"""The verdict's warning on alarms the findings do not explain (``findings.json``'s
``unexplained_alarms``): one line right under the headline naming the sensors, when,
and the run that searches the others without one of them; none without such alarms or
for a ``findings.json`` written before the field; in a report without findings, the
alarms the detectors could not place on a sensor, with no run to try (the sensors
named there may all be healthy)."""

from __future__ import annotations

import re

from markupsafe import escape

from analyzer.diagnosis.unexplained import Unexplained
from analyzer.findings import findings_document
from analyzer.report import render_report
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType

EVIL = "<b>s3</b>"
NAMES = ["s0", "s1", "s2", EVIL]
WARNING = re.compile(r'<p class="unexplained"[^>]*>(.*?)</p>', re.S)


def _report(unexplained: list[Unexplained], faults: bool = True) -> tuple[dict, str]:
    found = [SyntheticFault(0, FaultType.ADDITIVE, 40.0, None, 2.0)] if faults else []
    a = synthetic_analysis(duration_s=120.0, channels=4, faults=found, names=NAMES)
    a.unexplained = unexplained
    doc = findings_document(a)
    return doc, render_report(a, doc)


def test_the_warning_sits_under_the_headline_and_names_sensors_time_and_the_rerun():
    doc, html = _report([Unexplained(("s0", EVIL), 61.25, ("equivalent_model",), ("s0",))])
    assert doc["unexplained_alarms"] == [
        {
            "channels": ["s0", EVIL],
            "onset_s": 61.25,
            "onset": doc["unexplained_alarms"][0]["onset"],
            "detectors": ["equivalent_model"],
            "beside": ["s0"],
            "seam": None,
        }
    ]
    (warning,) = WARNING.findall(html)
    assert html.index('<p class="headline">') < html.index('<p class="unexplained"')
    assert html.index('<p class="unexplained"') < html.index("Record start")
    # (61.25 s to a tenth: half up, as every time of the run is rounded, ISO times too)
    utc = doc["unexplained_alarms"][0]["onset"]  # (and the clock time: ux55 item 10)
    assert f"on s0 and {escape(EVIL)} from 61.3 s at {utc} (seen by equivalent_model)" in warning
    # one of the sensors without a finding is the one to leave out, not the one found
    assert f"--channels &#39;!{escape(EVIL)}&#39;" in warning
    assert EVIL not in html.split('<p class="headline">')[1].split("</div>")[0]


def test_more_than_three_are_counted():
    many = [Unexplained((f"s{k % 3}",), 50.0 + 10 * k, ("ar_kalman_bank",), ()) for k in range(5)]
    (warning,) = WARNING.findall(_report(many)[1])
    assert warning.count(" from ") == 3 and "and 2 more (notes)" in warning


def test_no_warning_without_unexplained_alarms():
    doc, html = _report([])
    assert doc["unexplained_alarms"] == [] and not WARNING.findall(html)


def test_without_findings_the_alarms_no_sensor_was_placed_for_are_said():
    # (analyzer.diagnosis.unexplained.unplaced: the detection filter's lone shapeless
    # alarms the bank could not place, the only unexplained alarms of a run without a
    # finding; a ground-floor gain was reported on a healthy floor before, ux54 item 1)
    alarm = [Unexplained(("s2",), 61.0, ("ar_kalman_bank", "detection_filter"), ())]
    doc, html = _report(alarm, faults=False)
    (warning,) = WARNING.findall(html)
    assert warning.startswith("<strong>&#9888; Alarms the detectors could not place on a sensor: ")
    utc = doc["unexplained_alarms"][0]["onset"]  # (and the clock time: ux55 item 10)
    assert f"on s2 from 61.0 s at {utc} (seen by ar_kalman_bank, detection_filter)" in warning
    assert "Another sensor" not in warning and "ground floor" in warning
    # no run leaving out a named sensor: the faulty one may be one they are estimated
    # from (leaving out s2 of a 4-floor building with a gain on s0 found the healthy s1)
    assert "--channels" not in warning and "Run again" not in warning


def test_a_findings_document_written_before_the_field_renders_without_it():
    a = synthetic_analysis(
        duration_s=120.0,
        channels=4,
        faults=[SyntheticFault(0, FaultType.ADDITIVE, 40.0, None, 2.0)],
        names=NAMES,
    )
    doc = findings_document(a)
    del doc["unexplained_alarms"]
    assert not WARNING.findall(render_report(a, doc))

"""Audit ux55, item 10: the verdict gave the times of alarms no finding explains in
seconds only (``from 7199.8 s``); in a 24 h archive a user needs the clock time, which
the findings give beside their seconds. With absolute times the warning says both;
with relative times (no date), the seconds alone."""

from __future__ import annotations

import re

from analyzer.diagnosis.unexplained import Unexplained
from analyzer.findings import findings_document
from analyzer.report import render_report
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.types import FaultType

WARNING = re.compile(r'<p class="unexplained"[^>]*>(.*?)</p>', re.S)
ISO = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?Z")


def _warning(absolute: bool) -> tuple[dict, str]:
    found = [SyntheticFault(0, FaultType.ADDITIVE, 40.0, None, 2.0)]
    a = synthetic_analysis(duration_s=120.0, channels=4, faults=found)
    a.absolute_time = absolute
    a.unexplained = [Unexplained(("/accel.data[2]",), 61.25, ("equivalent_model",), ())]
    doc = findings_document(a)
    (warning,) = WARNING.findall(render_report(a, doc))
    return doc, warning


def test_with_absolute_times_the_alarm_says_its_utc_time():
    doc, warning = _warning(True)
    utc = doc["unexplained_alarms"][0]["onset"]
    assert utc is not None and ISO.fullmatch(utc)
    assert f"from 61.3 s at {utc} (seen by equivalent_model)" in warning, warning


def test_with_relative_times_the_seconds_alone():
    doc, warning = _warning(False)
    assert doc["unexplained_alarms"][0]["onset"] is None
    assert "from 61.3 s (seen by equivalent_model)" in warning, warning
    assert not ISO.search(warning), warning

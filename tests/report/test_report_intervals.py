"""The report shows each fault's 95 % intervals beside its size and its onset
(findings.json's ``magnitude_interval`` and ``onset_interval_s``), and nothing where
they are null (an onset that is a bound)."""

from __future__ import annotations

from analyzer.report import format as fmt
from analyzer.report.view import _onset_fact


def test_size_shows_its_interval():
    said = fmt.magnitude({"gain": 0.93}, {"level": 0.95, "gain": [0.91, 0.95]})
    assert said.startswith("gain ×0.93") and "(95 %: 0.91 to 0.95)" in said
    assert fmt.magnitude({"offset": 2.0}, None) == "offset +2"
    assert "95 %" not in fmt.magnitude({"offset": 2.0}, {"level": 0.95, "offset": None})


def test_onset_shows_its_interval_and_a_bound_none():
    f = {"onset_s": 151.3, "onset_interval_s": [151.2, 151.4], "evidence": {}}
    assert "151.300 s from the start (95 %: 151.200 to 151.400 s)" in _onset_fact(f, 3)
    bound = {"onset_s": 4.31, "onset_interval_s": None, "evidence": {"onset_at_or_before": True}}
    assert "95 %" not in _onset_fact(bound, 3)

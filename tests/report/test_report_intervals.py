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


def test_a_partial_size_interval_reads_noise_only_with_the_sizes_digits():
    """A gain's interval (interval_notes.magnitude beside it) is labelled noise only, not
    95 %; the bounds keep the same decimals (no dropped trailing zero)."""
    gain = fmt.magnitude({"gain": 0.6}, {"level": 0.95, "gain": [0.59672, 0.59973]}, True)
    assert "(noise only: 0.5967 to 0.5997)" in gain and "95 %" not in gain
    off = fmt.magnitude(
        {"offset": 9.992212852925862}, {"level": 0.95, "offset": [9.88698, 10.09745]}
    )
    assert off == "offset +9.992 (95 %: 9.887 to 10.097)"


def test_onset_shows_its_interval_and_a_bound_none():
    f = {"onset_s": 151.3, "onset_interval_s": [151.2, 151.4], "evidence": {}}
    assert "151.300 s from the start (95 %: 151.200 to 151.400 s)" in _onset_fact(f, 3)
    bound = {"onset_s": 4.31, "onset_interval_s": None, "evidence": {"onset_at_or_before": True}}
    assert "95 %" not in _onset_fact(bound, 3)

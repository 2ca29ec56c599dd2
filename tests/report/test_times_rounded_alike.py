"""One time is written alike everywhere (ux52): an onset at 300.0625 s read ``at or
before 300.062 s`` in the report and ``from 300.063 s or earlier`` on stderr, and the
run's lines wrote times and spans as ``41.1003 s``, ``--train 47.4004:225.206``, ``±
12.0001 s``."""

from __future__ import annotations

from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.training_check import _sides
from analyzer.pipeline import faults_words
from analyzer.report import format as fmt
from analyzer.timeutil import iso_utc
from analyzer.types import FaultType


def test_the_report_and_the_summary_round_an_onset_alike():
    onset = 300.0625  # (exactly halfway between two milliseconds)
    assert fmt.seconds(onset) == "300.063 s"
    # a hair either side, as the onset computed from rows and the rate is
    assert fmt.seconds(onset + 1e-11) == fmt.seconds(onset - 1e-11) == "300.063 s"
    # the ISO time of the same onset says the same millisecond
    assert iso_utc(int(onset * 1e9)).endswith("00:05:00.063Z")
    f = Finding("s0", FaultType.DRIFT, onset - 1e-11, None, {}, 0.5, "ar_kalman_bank")
    assert "s0 drift from 300.063 s" in faults_words([f])


def test_times_in_lines_have_no_six_figures_or_exponents():
    from analyzer.timeutil import seconds_text, short_seconds, window_text  # (new)

    assert seconds_text(41.1003) == "41.100"
    assert window_text(47.4004, 225.2061) == "47.4:225.206"
    assert short_seconds(12.0001) == "12"  # (the close-up's ± 12.0001 s)
    # a change in a training window from 47.4004 s: the windows it gives are typed alike
    before, after, _ = _sides(0.0, 47.4004, 60.2, 47.4004, 900.0, None)
    assert before == "--train 0:47.4" and after == "--train 60.2:107.6"

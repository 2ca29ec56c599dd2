"""Times and spans in messages through the one formatter (the rest of ux61 M1, M2):
after the notes of cod56a, about 46 ``{x:.3f}`` remained in detectors' notes, the
readers' lines, ``what to check``, the report's spans and durations. A time is said by
:func:`analyzer.timeutil.seconds_text` (half up, as the report and the ISO times: an
onset at 300.0625 s, a 16 Hz sample, is ``300.063``; ``:.3f`` said ``300.062``); a span
by :func:`analyzer.timeutil.spoken_duration` (``60 min``, ``8.0 s``, where the CSV
reader said one step back ``2.0 h`` and another ``3599.980 s``)."""

from __future__ import annotations

from analyzer.detectors.base import Event
from analyzer.types import FaultType

ONSET = 300.0625
"""A sample time at 16 Hz, halfway between two milliseconds."""


def _event(channel: str, onset: float, peak: float) -> Event:
    """An error function's event on ``channel`` from ``onset`` (its first alarm there)."""
    return Event(
        channel,
        onset,
        None,
        FaultType.ADDITIVE,
        {"offset": 1.0},
        0.9,
        "error_function",
        {"peak_over_threshold": peak},
    )


def test_a_detector_note_says_its_time_as_the_report_does():
    """Two error functions alarming together without ``[[group]]``: one fault, said at
    the first alarm's time, rounded as the report rounds it."""
    from analyzer.detectors.error_function import _one_per_fault

    notes: list[str] = []
    _one_per_fault([_event("s1", ONSET, 3.0), _event("s2", ONSET + 0.5, 2.0)], 2.0, notes)
    assert notes and notes[0].startswith("alarms near 300.063 s on s1 and s2: "), notes


def test_what_to_check_says_a_time_from_the_start_as_the_report_does():
    from analyzer.what_to_check import what_to_check

    frozen = {"type": "other", "magnitude": {"stuck_at": 2.0}, "onset_s": ONSET, "end_s": None}
    assert what_to_check(frozen) == (
        "no reading since 300.063 s from the start: check power and cable"
    )


def test_the_not_finite_note_says_its_time_as_the_report_does():
    from analyzer.diagnosis.merge import Finding
    from analyzer.findings import not_finite_note

    f = Finding("s1", FaultType.ADDITIVE, ONSET, None, {"offset": float("nan")}, 0.9, "x")
    note = not_finite_note(f)
    assert note is not None and note.startswith("s1's additive fault at 300.063 s: "), note


def test_the_report_says_a_span_and_a_short_duration_as_its_times():
    from analyzer.report import format as fmt
    from analyzer.report.view_figures import _span

    assert _span((ONSET, 400.0)) == "300.063-400.000 s"
    assert fmt.duration(0.0625) == "0.063 s" and fmt.duration(130.0) == "2 min 10.0 s"


def test_a_simulation_clock_stamp_is_said_as_the_report_does():
    from analyzer.readers._common import stamp_text

    assert stamp_text(300_062_500_000) == "300.063 s (not a Unix time)"


def test_the_readers_say_a_span_as_spoken_duration_does():
    """The seam lines and the ROS 1 reader's count of what was read say spans in the
    unit they read best in, as the CSV reader's other step-back lines did."""
    from analyzer.readers.ros1_reader import _ScanCount
    from analyzer.readers.seams import dropped_line

    line = dropped_line(None, {"x": 3}, {"x": (0, 3_590_000_000_000)}, {})
    assert "(60 min read already); dropped" in line, line
    read = _ScanCount()
    read.count, read.first, read.last = 7, 10**9, 10**9 + 8_250_000_000
    assert str(read) == "the 7 messages before it were read, up to 8.2 s after the first"
    assert read.in_all() == "7 message(s) read in all, up to 8.2 s after the first"


def test_a_span_near_ten_has_no_decimal_above_ten():
    """One decimal below 10, none above, by the number as written: 9.98 s was
    ``10.0 s`` (a step back of 9.98 s in a CSV), 598 s ``10.0 min``."""
    from analyzer.timeutil import spoken_duration

    assert spoken_duration(9.98) == "10 s" and spoken_duration(598.0) == "10 min"
    assert spoken_duration(9.94) == "9.9 s"

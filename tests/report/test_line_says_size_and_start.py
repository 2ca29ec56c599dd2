"""The run's (and the watcher's) one line says the size a fault's type word hides, and
one convention for a fault there when the detectors could first judge the record (ux53
item 8): a dead sensor read ``s3 multiplicative from 0.000 s or earlier``, "dead" only
in the index and the report, and a gain present from the first sample read ``from 3.600 s
or earlier`` (the filters' warm-up), the same fault as a constant channel's ``from 0.000
s or earlier``. ``onset_s`` stays as it was; only the words change."""

from __future__ import annotations

from typing import Any

from analyzer.diagnosis.merge import Finding
from analyzer.pipeline import faults_words
from analyzer.types import FaultType
from analyzer.watch_index import index_view


def _finding(
    channel: str, kind: FaultType, onset: float, magnitude: dict[str, float], **evidence: Any
) -> Finding:
    f = Finding(channel, kind, onset, None, magnitude, 1.0, "ar_kalman_bank")
    f.evidence.update(evidence)
    return f


def test_the_line_says_a_dead_sensor_a_gain_and_a_stuck_value():
    dead = _finding("s3", FaultType.MULTIPLICATIVE, 0.0, {"gain": 0.0}, onset_at_or_before=True)
    gain = _finding("s2", FaultType.MULTIPLICATIVE, 3.6, {"gain": 1.5}, onset_at_or_before=True)
    stuck = _finding("s1", FaultType.OTHER, 20.0, {"stuck_at": 0.37, "offset": 0.38})
    silent = _finding("s0", FaultType.OTHER, 40.0, {"no_data_s": 20.0})
    assert faults_words([dead, gain, stuck, silent]) == (
        "4 sensor faults found on 4 sensors: s3 multiplicative (gain ×0: dead sensor) from "
        "the start, s2 multiplicative (gain ×1.5) from the start (not judged before 3.600 "
        "s), s1 other (stuck at 0.37) from 20.000 s and 1 more"
    )
    assert faults_words([silent]).endswith(
        "s0 other (no reading: dead sensor, silent) from 40.000 s"
    )
    assert dead.onset_s == 0.0 and gain.onset_s == 3.6  # (the numbers are left as found)


def test_an_offset_a_drift_and_a_bound_after_the_training_window_read_as_before():
    # the bundled sample's line, pinned elsewhere: an offset's type word says what it does
    offset = _finding("/s4.data", FaultType.ADDITIVE, 16.0, {"offset": 1.0})
    assert faults_words([offset]).endswith(": /s4.data additive from 16.000 s")
    drift = _finding("s0", FaultType.DRIFT, 30.0, {"rate_per_s": 0.5})
    assert faults_words([drift]).endswith(": s0 drift from 30.000 s")
    # there when the search began after --train: the window was taken as healthy, not
    # left unjudged, so not "the start"
    after = _finding("s1", FaultType.ADDITIVE, 12.0, {"offset": 1.0}, onset_at_search_start=True)
    assert faults_words([after]).endswith(": s1 additive from 12.000 s or earlier")


def test_the_report_says_the_start_as_the_line_does():
    from analyzer.report.view import onset_words  # (new)

    def f(onset: float, **ev: Any) -> dict[str, Any]:
        return {"onset_s": onset, "evidence": ev}

    assert onset_words(f(0.0, onset_at_or_before=True), 3) == "from the start"
    assert onset_words(f(3.6, onset_at_or_before=True), 3) == (
        "from the start (not judged before 3.600 s)"
    )
    assert onset_words(f(12.0, onset_at_search_start=True), 3) == "at or before 12.000 s"
    assert onset_words(f(30.0), 3) == "30.000 s"


def _index(archives: list[dict[str, Any]], episodes: list[dict[str, Any]]) -> dict[str, Any]:
    rows = []
    for a in archives:
        rows.append(
            {
                "verdict": "fault",
                "error": None,
                "report": f"{a['name']}/report.html",
                "faulty_sensors": ["s2"],
                "duration_s": 60.0,
                "moved_to": [],
                **a,
            }
        )
    counts = {"fault": len(rows), "no fault": 0, "error": 0}
    return {
        "analyzer_version": "test",
        "updated": "now",
        "archives": rows,
        "episodes": episodes,
        "counts": counts,
    }


def _episode(onset: str, archives: list[str], from_start: bool = True) -> dict[str, Any]:
    return {
        "channel": "s2",
        "types": ["multiplicative"],
        "size": "gain ×9.956",
        "onset": onset,
        "from_start": from_start,
        "end": None,
        "archives": archives,
    }


def test_the_index_says_the_start_as_the_line_does():
    start = "2026-03-03T14:00:00.000Z"
    rows = [{"name": "a.csv", "sha256": "1", "start": start, "processed": "p1"}]
    view = index_view(
        _index(
            rows,
            [
                _episode("2026-03-03T14:00:03.600Z", ["a.csv"]),
                _episode(start, ["a.csv"]),
                _episode("2026-03-03T14:00:30.000Z", ["a.csv"], from_start=False),
            ],
        )
    )
    assert [e.onset for e in view.episodes] == [
        "from the start (not judged before 2026-03-03T14:00:03.600Z)",
        f"from the start ({start})",
        "2026-03-03T14:00:30.000Z",
    ]


# -- edge sizes and onsets (review of ux53 item 8) --------------------------------------


def _line(f: Finding) -> str:
    return faults_words([f]).split(": ", 1)[1]


def test_a_gain_near_1_reads_apart_from_1():
    """A gain of 1.0004 read ``(gain ×1)``, no change at all."""
    near = [_finding("s2", FaultType.MULTIPLICATIVE, 5.0, {"gain": g}) for g in (1.0004, 0.99996)]
    assert [_line(f) for f in near] == [
        "s2 multiplicative (gain ×1.0004) from 5.000 s",
        "s2 multiplicative (gain ×0.99996) from 5.000 s",
    ]
    from analyzer.report.format import magnitude

    assert magnitude({"gain": 1.00004}) == "gain ×1.00004"  # (the report's words alike)
    assert magnitude({"gain": 1.0}) == "gain ×1" and magnitude({"gain": 1.5}) == "gain ×1.5"


def test_a_nearly_dead_gain_says_one_colon():
    """``(gain ×0.0256: reads 2.56 % of its signal: nearly dead)`` read two colons."""
    f = _finding("s2", FaultType.MULTIPLICATIVE, 5.0, {"gain": 0.0256})
    assert _line(f) == (
        "s2 multiplicative (gain ×0.0256: reads 2.56 % of its signal, nearly dead) from 5.000 s"
    )


def test_a_size_or_an_onset_not_measured_is_not_said_as_nan():
    """A NaN gain read ``(gain ×n/a)``, a NaN stuck value ``(stuck at n/a)``, a NaN onset
    there from the start ``from the start (not judged before nan s)`` in the line and
    ``... before n/a`` in the report."""
    from analyzer.report.view import onset_words

    nan = float("nan")
    gain = _finding("s2", FaultType.MULTIPLICATIVE, 5.0, {"gain": nan})
    stuck = _finding("s1", FaultType.OTHER, 5.0, {"stuck_at": nan})
    assert _line(gain) == "s2 multiplicative from 5.000 s"
    assert _line(stuck) == "s1 other from 5.000 s"
    bound = _finding("s2", FaultType.MULTIPLICATIVE, nan, {"gain": 2.0}, onset_at_or_before=True)
    assert _line(bound) == "s2 multiplicative (gain ×2) from the start"
    loose = _finding("s2", FaultType.MULTIPLICATIVE, nan, {"gain": 2.0})
    assert _line(loose) == "s2 multiplicative (gain ×2) from an unknown time"
    said = onset_words({"onset_s": nan, "evidence": {"onset_at_or_before": True}}, 3)
    assert said == "from the start"

"""The run's notes on anomalies the detectors attributed to no sensor
(``pipeline._unattributed_notes``): before them, two sensors faulty from the same instant
on a 6-channel building gave no finding and exit 0, the anomaly only in each detector's
own notes."""

from __future__ import annotations

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis.merge import Finding
from analyzer.pipeline import _unattributed_notes
from analyzer.types import FaultType

RATE = 100.0


def result(detector, unattributed):
    return DetectorResult(detector, ("a", "b", "c"), {}, [], {}, unattributed=unattributed)


def finding(onset, end=None):
    return Finding("a", FaultType.ADDITIVE, onset, end, {"offset": 1.0}, 1.0, "x")


def test_an_anomaly_two_detectors_left_unattributed_with_no_finding_is_noted():
    results = [
        result("ar_kalman_bank", [(300.0, ("a", "b"), ())]),
        result("detection_filter", [(301.5, ("c",), ())]),
    ]
    (note,) = _unattributed_notes(results, [], RATE)
    assert note.startswith("anomaly at 300.0 s on a, b, c attributed to no sensor by ")
    assert "ar_kalman_bank, detection_filter" in note and "several sensors at once" in note


def test_one_detector_alone_or_a_finding_under_way_is_no_note():
    alone = [result("ar_kalman_bank", [(300.0, ("a", "b"), ())])]
    assert _unattributed_notes(alone, [], RATE) == []
    both = [
        result("ar_kalman_bank", [(300.0, ("a", "b"), ())]),
        result("detection_filter", [(300.5, ("b",), ())]),
    ]
    assert _unattributed_notes(both, [finding(299.0)], RATE) == []  # lasting from before
    assert _unattributed_notes(both, [finding(100.0, 120.0)], RATE) != []  # long over
    assert _unattributed_notes(both, [finding(2000.0)], RATE) != []  # not yet begun


def test_a_second_fault_beside_a_found_one_is_noted_once():
    em = result(
        "equivalent_model",
        [(720.1, ("s0", "s1"), ("s3",)), (721.0, ("s0", "s1"), ("s3",))],
    )
    s3 = Finding("s3", FaultType.ADDITIVE, 720.0, None, {"offset": 1.0}, 1.0, "x")
    (note,) = _unattributed_notes([em], [s3], RATE)
    assert note.startswith("equivalent_model: beside the fault on s3 at 720.1 s, a fault on one")
    assert "s0, s1" in note


def test_a_second_fault_beside_one_not_reported_does_not_name_it_as_the_fault():
    """The network's first fault (s3) is no finding of the run: the note named "the fault
    on s3", which findings.json did not have (the ux55 audit); it says neither is one."""
    em = result("equivalent_model", [(720.1, ("s0", "s1"), ("s3",))])
    (note,) = _unattributed_notes([em], [finding(720.0)], RATE)
    assert "beside the fault on" not in note
    assert note.startswith("equivalent_model: anomaly at 720.1 s that a fault on s3 together")
    assert "neither is a finding of this run" in note


def test_many_anomalies_are_counted_past_the_first_three():
    results = [
        result(d, [(100.0 + 1000.0 * k, ("a",), ()) for k in range(5)])
        for d in ("ar_kalman_bank", "detection_filter")
    ]
    notes = _unattributed_notes(results, [], RATE)
    assert len(notes) == 4 and notes[-1].startswith("2 more such anomalies")


def test_a_fault_lasting_since_long_before_does_not_silence_a_new_anomaly():
    """A stuck s1 from 30 s to the end kept an anomaly at 45 s out of the run's notes (an
    offset on s4 that every detector noted, none attributed; signal-pathology probe)."""
    both = [
        result("ar_kalman_bank", [(300.0, ("a", "b"), ())]),
        result("detection_filter", [(300.5, ("b",), ())]),
    ]
    (note,) = _unattributed_notes(both, [finding(200.0)], RATE)
    assert note.startswith("anomaly at 300.0 s on a, b attributed to no sensor")
    assert "(while the additive fault on a from 200.0 s lasted: it may be a second" in note
    assert _unattributed_notes(both, [finding(200.0, 300.5)], RATE) == []  # it ended there

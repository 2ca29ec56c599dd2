"""Which findings the run searches again without (``reconfigure.beside_faults``): a
lasting fault beside which anomalies no sensor explained came and went."""

from __future__ import annotations

from types import SimpleNamespace

from analyzer.diagnosis.merge import Finding
from analyzer.reconfigure import LOST_MIN_S, beside_faults, note
from analyzer.types import FaultType

RATE = 100.0
N = 120_000
SLACK = 2.0


def _finding(channel: str, onset: float, end: float | None = None) -> Finding:
    return Finding(channel, FaultType.ADDITIVE, onset, end, {"offset": 1.0}, 0.9, "x")


def _result(detector: str, *entries: tuple[float, tuple[str, ...], tuple[str, ...]]):
    return SimpleNamespace(detector=detector, unattributed=list(entries))


def test_two_detectors_leaving_an_anomaly_beside_a_fault():
    f = _finding("s3", 720.0)
    results = [
        _result("ar_kalman_bank", (720.0, ("s0", "s1", "s3"), ())),
        _result("detection_filter", (721.5, ("s1",), ())),
    ]
    assert beside_faults([f], results, N, RATE, SLACK) == {"s3": [(71_800, N)]}


def test_the_network_naming_the_fault_beside_another():
    f = _finding("s3", 720.0, 900.0)
    results = [_result("equivalent_model", (760.0, ("s0", "s1"), ("s3",)))]
    assert beside_faults([f], results, N, RATE, SLACK) == {"s3": [(71_800, 90_000)]}


def test_one_detector_alone_or_far_apart_or_elsewhere_is_not_enough():
    f = _finding("s3", 720.0)
    alone = [_result("detection_filter", (730.0, ("s1",), ()), (731.0, ("s2",), ()))]
    apart = [
        _result("ar_kalman_bank", (730.0, ("s1",), ())),
        _result("detection_filter", (740.0, ("s1",), ())),
    ]
    before = [
        _result("ar_kalman_bank", (600.0, ("s1",), ())),
        _result("detection_filter", (600.5, ("s1",), ())),
    ]
    other = [_result("equivalent_model", (760.0, ("s0", "s1"), ("s5",)))]
    for results in (alone, apart, before, other):
        assert beside_faults([f], results, N, RATE, SLACK) == {}


def test_a_short_finding_is_not_searched_without():
    f = _finding("s3", 720.0, 720.0 + LOST_MIN_S / 2)
    results = [_result("equivalent_model", (720.5, ("s0", "s1"), ("s3",)))]
    assert beside_faults([f], results, N, RATE, SLACK) == {}


def test_the_note_names_why_each_channel_was_left_out():
    """A suspect is named with its fault's onset, as its finding has it (720.0 s), and
    where the rows left out begin, the slack before it: the note said "faulty from
    718.0 s" of the fault found at 720.0 s."""
    f = _finding("s3", 720.0)
    suspects = beside_faults(
        [f], [_result("equivalent_model", (760.0, ("s0", "s1"), ("s3",)))], N, RATE, SLACK
    )
    added = [_finding("s1", 720.1)]
    text = note({"s4": [(4800, N)]}, suspects, added, RATE, SLACK)
    assert text.startswith(
        "the other channels were searched again without s3, s4 (s4 missing 48-1200 s; s3 "
        "faulty from 720.0 s (left out from 718.0 s) with anomalies beside its fault that no "
        "sensor explained)"
    )
    assert "lost its view of them or isolated one fault at a time" in text
    assert text.endswith("1 finding(s) added from it: additive on s1 from 720.1 s")


def test_a_suspect_left_out_from_the_start_is_not_given_an_onset():
    """Within the slack of the record's start the rows begin at 0: the onset is not
    where they begin plus the slack."""
    text = note({}, {"s3": [(0, N)]}, [], RATE, SLACK)
    assert "s3 faulty from within 2 s of the start (left out from 0.0 s)" in text


def test_beside_a_fault_the_second_search_needs_two_detectors():
    """Where a channel was missing, any finding of the second search counts; beside a
    fault found, one that a single detector saw does not (when two or more ran)."""
    from analyzer.reconfigure import found_again

    def again(channel: str, detectors: list[str]) -> Finding:
        f = _finding(channel, 800.0)
        f.evidence["detectors"] = detectors
        return f

    suspects = {"s3": [(71_800, N)]}
    one, two = again("s1", ["equivalent_model"]), again("s2", ["ar_kalman_bank", "x"])
    kept = found_again([one, two], [], {}, RATE, SLACK, suspects, detectors=3)
    assert kept == [two] and two.evidence["searched_without"] == ["s3"]
    lone = again("s1", ["equivalent_model"])
    assert found_again([lone], [], {}, RATE, SLACK, suspects, detectors=1) == [lone]
    blind = again("s1", ["equivalent_model"])
    assert found_again([blind], [], {"s3": [(71_800, N)]}, RATE, SLACK, {}, detectors=3) == [blind]
    # the first search's finding on the same channel then: not added again
    dup = again("s2", ["ar_kalman_bank", "x"])
    assert found_again([dup], [_finding("s2", 799.0)], {}, RATE, SLACK, suspects, 3) == []


def test_a_fault_the_first_search_saw_only_from_later_takes_the_second_searchs_onset():
    """An offset on s1 from 100 to 200 s and one on s4 from 150 to 250 s: the detection
    filter named s4 from 200.1 s (every filter off its direction while both lasted),
    the second search without s1 from 150.0 s. Its finding is added and replaces the
    first's; one the first search saw from its onset, or to another end, stays."""
    from analyzer.reconfigure import found_again, seen_late

    def again() -> Finding:
        f = _finding("s4", 150.0, 250.0)
        f.evidence["detectors"] = ["ar_kalman_bank", "equivalent_model"]
        return f

    suspects = {"s1": [(9_800, 20_000)]}
    late = _finding("s4", 200.1, 250.0)
    f = again()
    assert found_again([f], [late], {}, RATE, SLACK, suspects, 3) == [f]
    assert seen_late(f, [late, _finding("s1", 100.0, 200.0)], SLACK) == [late]
    for first in (_finding("s4", 151.0, 250.0), _finding("s4", 200.1, 240.0)):
        assert found_again([again()], [first], {}, RATE, SLACK, suspects, 3) == []
        assert seen_late(again(), [first], SLACK) == []

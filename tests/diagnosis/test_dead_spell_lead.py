"""A dead spell reported as dead over its whole period: a detector's stretch of it does not
lead where another detector saw it whole, and readings that froze a little after the
finding's traced onset are found (ux54 item 2)."""

from __future__ import annotations

import numpy as np

from analyzer.detectors.base import Event
from analyzer.diagnosis import merge_events
from analyzer.diagnosis.merge import Finding, _fragment
from analyzer.diagnosis.stuck import relabel_frozen
from analyzer.types import FaultType

M = FaultType.MULTIPLICATIVE
RATE = 200.0


def _gain(detector: str, onset: float, end: float, gain: float, first: float) -> Event:
    return Event("s3", onset, end, M, {"gain": gain}, 1.0, detector, {"first_alarm_s": first})


def test_a_stretch_its_detector_saw_again_does_not_lead():
    """The events of a sensor dead from 150 to 200 s (4 floors, one sensor each, seed
    107): the equivalent model saw it from 148.29 to 169.09 s (a gain of 0.21: alive
    readings in its fit) and again from 170.72 s, the bank and the detection filter from
    150.0 s to 200.0 s. All tie at confidence 1; the first stretch led, and the finding
    ended at 169.09 s. The detector that saw it whole leads."""
    events = [
        _gain("equivalent_model", 148.29, 169.09, 0.2123, 150.15),
        _gain("ar_kalman_bank", 150.0, 200.0, -0.0115, 150.0),
        _gain("detection_filter", 150.0, 200.01, -0.0079, 150.01),
        _gain("equivalent_model", 170.72, 200.0, -0.0007, 172.79),
    ]
    (f,) = merge_events(events)
    assert (f.onset_s, f.end_s, f.detector) == (150.0, 200.0, "ar_kalman_bank")
    assert f.magnitude == {"gain": -0.0115}
    # each detector's evidence is one of its events': the lead's, else its first (the
    # model's second stretch, kept last, showed a first alarm of 172.79 s)
    alarms = {d: x["first_alarm_s"] for d, x in f.evidence["by_detector"].items()}
    assert alarms == {
        "ar_kalman_bank": 150.0,
        "detection_filter": 150.01,
        "equivalent_model": 150.15,
    }
    # with no second stretch, the same first event leads as before (earliest of equals)
    (g,) = merge_events(events[:3])
    assert (g.onset_s, g.end_s, g.detector) == (148.29, 169.09, "equivalent_model")


def test_readings_that_froze_soon_after_the_traced_onset_are_a_dead_sensor():
    """A sensor dead from row 3000 to 4400 (15 to 22 s) whose finding was traced back to
    14.0 s, a second before the freeze (within a long alarm window, 2 s at 200 Hz), and
    ran on to 30 s as a gain of 0.21: dead from where its readings froze to where they
    moved again. Traced back 3 s, more than that window, the finding keeps its shape."""
    rng = np.random.default_rng(5)
    values = rng.standard_normal((9000, 2))
    values[3000:4400, :] = 0.0
    found = [
        Finding("a", M, 14.0, 30.0, {"gain": 0.21}, 1.0, "equivalent_model"),
        Finding("b", M, 12.0, 30.0, {"gain": 0.21}, 1.0, "equivalent_model"),
    ]
    (note,) = relabel_frozen(found, values, ["a", "b"], RATE, (0, 2000))
    assert (found[0].onset_s, found[0].end_s, found[0].magnitude) == (15.0, 22.0, {"gain": 0.0})
    assert found[0].evidence["frozen"]["alarmed_from_s"] == 14.0
    assert note.startswith("a from 15.000 s to 22.000 s: dead (reads 0)")
    assert "the detectors saw it from 14.000 s: it starts where they froze" in note
    assert (found[1].onset_s, found[1].end_s, found[1].magnitude) == (12.0, 30.0, {"gain": 0.21})
    assert "frozen" not in found[1].evidence


A = FaultType.ADDITIVE


def _offset(detector: str, onset: float, end: float, conf: float, first: float) -> Event:
    return Event("s1", onset, end, A, {"offset": 1.0}, conf, detector, {"first_alarm_s": first})


def test_a_stretch_stays_when_the_spanning_detector_began_late():
    """An offset from 100 s that the equivalent model saw from 100 to 120 s and again
    from 125 s, and the bank only from 119 s: the bank did not see the fault from the
    model's start, so the model's first stretch is no mere stretch, and it leads (the
    model's second stretch is no detector agreeing on a later start). Led by the bank,
    the fault's first 19 s were reported nowhere."""
    events = [
        _offset("equivalent_model", 100.0, 120.0, 1.0, 100.2),
        _offset("equivalent_model", 125.0, 200.0, 1.0, 125.3),
        _offset("ar_kalman_bank", 119.0, 200.0, 1.0, 119.5),
    ]
    (f,) = merge_events(events)
    assert (f.onset_s, f.end_s, f.detector) == (100.0, 120.0, "equivalent_model")
    # the first stretch is a mere stretch only where the spanning detector saw the fault
    # from its start (no later than slack after the stretch's first alarm)
    assert not _fragment(events[0], events, 1.0)
    whole = [*events[:2], _offset("ar_kalman_bank", 100.5, 200.0, 1.0, 101.0)]
    assert _fragment(whole[0], whole, 1.0)


def test_the_detector_that_saw_it_whole_leads_over_two_that_saw_stretches():
    """The model (100-120 s, 125-200 s) and the detection filter (100.1-130 s,
    135-200 s) each saw an offset in two stretches, the bank whole (100-200 s, less
    confident). The later stretches are no two detectors agreeing on a later start:
    the bank leads, from 100 s to 200 s (was the model's second stretch, from 125 s)."""
    events = [
        _offset("equivalent_model", 100.0, 120.0, 1.0, 100.2),
        _offset("equivalent_model", 125.0, 200.0, 1.0, 125.3),
        _offset("detection_filter", 100.1, 130.0, 1.0, 100.3),
        _offset("detection_filter", 135.0, 200.0, 1.0, 135.3),
        _offset("ar_kalman_bank", 100.0, 200.0, 0.9, 100.5),
    ]
    (f,) = merge_events(events)
    assert (f.onset_s, f.end_s, f.detector) == (100.0, 200.0, "ar_kalman_bank")

"""The ends and onsets a search without one sensor gives (``pipeline._ends_without``,
``pipeline._onset_without``): what the searches without each sensor found is given here
(the detectors' runs are not what is tested), the rules that take from it are. The
event times are those of a 6-channel simulated building at 100 Hz (a long alarm window:
2 s), as in ``benchmarks/sweep_two_faults.py``."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer import pipeline
from analyzer.detectors.base import Event, RunContext
from analyzer.diagnosis import merge_events, onsets_hidden_by_earlier
from analyzer.options import RunOptions
from analyzer.types import FaultType

A = FaultType.ADDITIVE
BANK, DF, EM = "ar_kalman_bank", "detection_filter", "equivalent_model"
CHOSEN = [f"s{k}" for k in range(6)]
RATE = 100.0


def _ev(channel, detector, onset, end, size=3.4):
    return Event(channel, onset, end, A, {"offset": size}, 1.0, detector, {})


def _finding(*events):
    (f,) = merge_events(events)
    return f


def _fault(channel, onset, end):
    return _finding(*[_ev(channel, d, onset, end) for d in (BANK, DF, EM)])


def _searched(monkeypatch, found_without):
    """``_ends_without`` with ``found_without[sensor]`` as the findings of the search
    without that sensor."""
    monkeypatch.setattr(pipeline, "_run_again", lambda *a, **k: ["ran"])

    def diagnose(results, sub, keep, *rest):
        (left,) = set(CHOSEN) - set(keep)
        return found_without[left], []

    monkeypatch.setattr(pipeline, "_diagnose", diagnose)

    def run(hidden, early):
        values = np.random.default_rng(0).normal(size=(4000, len(CHOSEN)))
        matrix = (values, CHOSEN, (0, 2000), RATE)
        return pipeline._ends_without(
            hidden,
            [BANK, DF, EM],
            RunOptions(),
            matrix,
            RunContext(),
            None,  # type: ignore[arg-type]
            None,
            frozenset(),
            early,
        )

    return run


@pytest.mark.parametrize("earlier, later", [("s5", "s3"), ("s1", "s3")])
def test_a_finding_with_an_earlier_and_a_later_fault_takes_the_onset_and_the_end(
    monkeypatch, earlier, later
):
    """An offset on s2 from 150 to 200 s, inside one on ``earlier`` from 100 to 250 s
    and beside one on ``later`` from 190 to 300 s: the bank saw s2's from 142.89 s (the
    earlier fault's trace) to 300.0 s (the later one's end), the observers from 150.0 s.
    Without ``later`` s2's ends at 200.0 s (still from 142.89 s); without ``earlier`` it
    begins at 150.0 s (still to 300.0 s). The finding is 150.0-200.0 s whichever sensor's
    name comes first: before, the onset search undid the end (``s5``) or the moved onset
    kept the end search from matching (``s1``)."""
    f = _finding(_ev("s2", BANK, 142.89, 300.0), _ev("s2", EM, 150.0, 200.0))
    g_early, g_late = _fault(earlier, 100.0, 250.0), _fault(later, 190.0, 300.0)
    found = {
        later: [_finding(_ev("s2", BANK, 142.89, 200.0))],
        earlier: [_finding(_ev("s2", BANK, 150.0, 300.0), _ev("s2", EM, 150.0, 300.0))],
    }
    notes = _searched(monkeypatch, found)([(f, g_late)], [(f, g_early)])
    assert (f.onset_s, f.end_s) == (150.0, 200.0), notes
    assert f.evidence["end_without"]["left_out"] == later
    assert f.evidence["onset_without"]["left_out"] == earlier
    assert len(notes) == 2
    assert notes[-1].startswith(
        f"additive fault on s2: from 150.000 s to 200.000 s (its end as seen with {later} left"
    )


def test_an_onset_seen_again_without_the_earlier_sensor_stays(monkeypatch):
    """An offset on s2 from 150 to 170 s and again from 180 to 200 s, inside one on s5
    from 100 to 250 s: the bank saw one fault from 150.0 s, the observers only the second
    part, from 180.0 s (late, so the onset rule asks). Without s5 the bank still sees s2
    faulty from 150.0 s: the onset is s2's own, and the finding keeps it (before, it was
    moved to 180.0 s, the first part lost)."""
    f = _finding(_ev("s2", BANK, 150.0, 200.0), _ev("s2", EM, 180.0, 200.0))
    g = _fault("s5", 100.0, 250.0)
    early = onsets_hidden_by_earlier([f, g], lambda *_: True)
    assert early == [(f, g)]
    found = {
        "s5": [
            _finding(_ev("s2", BANK, 150.0, 170.0), _ev("s2", DF, 150.0, 170.0)),
            _finding(_ev("s2", BANK, 180.0, 200.0), _ev("s2", EM, 180.0, 200.0)),
        ]
    }
    notes = _searched(monkeypatch, found)([], early)
    assert (f.onset_s, f.end_s) == (150.0, 200.0)
    assert "onset_without" not in f.evidence
    assert notes == []


def test_an_early_onset_without_the_earlier_sensor_moves(monkeypatch):
    """The rule still does its work: seed 17 of ``nested``, s2's offset from 150 to
    200 s inside s5's, the bank's 142.89-215.04 s (offset 2.33), the observers'
    150.0-200.0 s; without s5, 150.0-200.0 s (offset 3.43)."""
    f = _finding(_ev("s2", BANK, 142.89, 215.04, 2.33), _ev("s2", EM, 150.0, 200.0))
    g = _fault("s5", 100.0, 250.0)
    early = onsets_hidden_by_earlier([f, g], lambda *_: True)
    found = {"s5": [_finding(_ev("s2", BANK, 150.0, 200.0, 3.43), _ev("s2", EM, 150.0, 200.0))]}
    (note,) = _searched(monkeypatch, found)([], early)
    assert (f.onset_s, f.end_s, f.magnitude) == (150.0, 200.0, {"offset": 3.43})
    assert f.evidence["onset_without"] == {
        "left_out": "s5",
        "detector": BANK,
        "was_s": [142.89, 215.04],
    }
    assert note.startswith("additive fault on s2: from 150.000 s to 200.000 s (offset 3.43)")


def test_an_end_lost_where_a_later_fault_began_is_not_taken_past_every_detector_s_end(
    monkeypatch,
):
    """A drift on s0 from 100 to 200 s and an offset on s3 from 150 to 250 s (seed 12 of
    ``drift-offset``): the bank and the detection filter ended the drift at 150.08 s,
    where s3's began, the observers at 200.01 s. Without s3 the bank saw s0 to 200.0 s,
    and then again from 262.0 s to the record's end (another alarm on s0, after every
    end the detectors gave with s3 in). That is not this fault going on: before, the
    finding was taken to the record's end; now no end beyond 202.01 s (the observers'
    end and a long alarm window) is taken, and the finding stays as it was."""
    f = _finding(_ev("s0", BANK, 100.0, 150.08), _ev("s0", DF, 100.0, 150.08))
    f.events.append(_ev("s0", EM, 100.0, 200.01))
    g = _fault("s3", 150.0, 250.0)
    (pair,) = pipeline.ends_hidden_by_later([f, g], lambda *_: True)
    assert pair == (f, g)
    h = _finding(_ev("s0", BANK, 100.0, 200.0))
    h.events.append(_ev("s0", BANK, 262.0, None))
    notes = _searched(monkeypatch, {"s3": [h]})([pair], [])
    assert (f.end_s, notes) == (150.08, [])
    assert "end_without" not in f.evidence


def test_an_end_lost_where_a_later_fault_began_takes_the_end_seen_without_it(monkeypatch):
    """The same drift, without s3 seen to 200.0 s: the finding ends there, the end
    before in its evidence."""
    f = _finding(_ev("s0", BANK, 100.0, 150.08), _ev("s0", DF, 100.0, 150.08))
    f.events.append(_ev("s0", EM, 100.0, 200.01))
    g = _fault("s3", 150.0, 250.0)
    hidden = pipeline.ends_hidden_by_later([f, g], lambda *_: True)
    found = {"s3": [_finding(_ev("s0", BANK, 100.0, 200.0), _ev("s0", EM, 100.0, 200.0))]}
    (note,) = _searched(monkeypatch, found)(hidden, [])
    assert f.end_s == 200.0
    assert f.evidence["end_without"] == {"left_out": "s3", "detector": BANK, "was_s": 150.08}
    assert note.startswith("additive fault on s0: ended at 200.000 s as ar_kalman_bank saw")


def test_an_end_lost_where_a_later_fault_began_takes_the_end_both_searches_allow(monkeypatch):
    """A gain on s1 from 100 to 200 s and an offset on s4 from 150 to 250 s (seed 7 of
    ``gain-offset``): the observers and the detection filter lost the gain at 150.13 s,
    where s4's began, the bank saw it to 250.04 s. Without s4 the three saw it alone: the
    bank and the filter to 200.0 s, the observers, whose event leads (it alarmed first,
    the confidences all 1), to 272.68 s, past every end of the first search. Before, the
    lead's end was refused and nothing taken (the finding ended at 150.13 s); now the
    latest end of the search's other events within the first search's (200.01 s, the
    filter's) is."""
    g = Event("s1", 100.01, 250.04, FaultType.MULTIPLICATIVE, {"gain": 1.51}, 1.0, BANK, {})
    f = _finding(
        Event("s1", 99.88, 150.13, FaultType.MULTIPLICATIVE, {"gain": 1.50}, 1.0, EM, {}),
        Event("s1", 100.01, 150.07, FaultType.MULTIPLICATIVE, {"gain": 1.51}, 1.0, DF, {}),
    )
    f.events.append(g)
    later = _fault("s4", 150.0, 250.0)
    hidden = pipeline.ends_hidden_by_later([f, later], lambda *_: True)
    assert hidden == [(f, later)]
    h = _finding(
        Event("s1", 99.88, 272.68, FaultType.MULTIPLICATIVE, {"gain": 1.49}, 1.0, EM, {}),
        Event("s1", 100.01, 200.0, FaultType.MULTIPLICATIVE, {"gain": 1.51}, 1.0, BANK, {}),
        Event("s1", 100.01, 200.01, FaultType.MULTIPLICATIVE, {"gain": 1.508}, 1.0, DF, {}),
    )
    assert (h.detector, h.end_s) == (EM, 272.68)
    (note,) = _searched(monkeypatch, {"s4": [h]})(hidden, [])
    assert f.end_s == 200.01 and f.magnitude == {"gain": 1.508}
    assert f.evidence["end_without"] == {"left_out": "s4", "detector": DF, "was_s": 150.13}
    assert note.startswith("multiplicative fault on s1: ended at 200.010 s as detection_filter")


def test_an_end_lost_where_one_detector_saw_the_later_fault_begin_is_lost_there(monkeypatch):
    """A gain on s1 from 100 to 200 s and an offset on s4 from 150 to 250 s (seed 25 of
    ``gain-offset``): the filter and the observers lost the gain at 150.08 s, the bank
    saw it to 250.04 s; s4's finding began at the filter's 147.73 s (its trace of s1's
    gain; the onset search moves it to 150.0 s, after the ends), the bank saw it begin at
    150.0 s. Without s4 the gain ends at 200.08 s. Before, 150.08 s was no end lost
    where s4's fault began (more than a long window after 147.73 s), and no end of the
    search without s4 was before it: the finding stayed at 150.08 s."""
    gain = FaultType.MULTIPLICATIVE
    f = _finding(
        Event("s1", 99.99, 150.08, gain, {"gain": 1.497}, 1.0, EM, {}),
        Event("s1", 100.0, 150.09, gain, {"gain": 1.494}, 1.0, DF, {}),
    )
    f.events.append(Event("s1", 99.99, 250.04, gain, {"gain": 1.496}, 1.0, BANK, {}))
    later = _finding(_ev("s4", DF, 147.73, 250.01), _ev("s4", BANK, 150.0, 250.0))
    assert later.onset_s == 147.73
    hidden = pipeline.ends_hidden_by_later([f, later], lambda *_: True)
    assert hidden == [(f, later)]
    h = _finding(
        Event("s1", 99.99, 200.08, gain, {"gain": 1.497}, 1.0, BANK, {}),
        Event("s1", 100.0, 200.08, gain, {"gain": 1.494}, 1.0, DF, {}),
    )
    (note,) = _searched(monkeypatch, {"s4": [h]})(hidden, [])
    assert f.end_s == 200.08
    assert f.evidence["end_without"]["was_s"] == 150.08
    assert note.startswith("multiplicative fault on s1: ended at 200.080 s")


def test_a_fault_that_began_again_as_a_finding_of_its_own_without_the_later_sensor_goes_on(
    monkeypatch,
):
    """A gain on s1 from 100 to 160 s and again from 170 s to the record's end, beside an
    offset on s4 from 150 s to the end (seed 1): the filter and the observers lost the
    gain at 150.1 s, the bank saw it to the end. Without s4 the bank sees the gain end at
    160.0 s (the gain's end test) and begin again at 170.1 s, a finding of its own. Before,
    only the events of the finding that ended counted as the fault seen again, and the
    finding ended at 160.0 s with s1 reported healthy after it; the fault goes on."""
    gain = FaultType.MULTIPLICATIVE
    f = _finding(
        Event("s1", 100.0, 150.06, gain, {"gain": 1.50}, 1.0, DF, {}),
        Event("s1", 100.03, 150.11, gain, {"gain": 1.53}, 1.0, EM, {}),
    )
    f.events.append(Event("s1", 100.0, None, gain, {"gain": 1.50}, 1.0, BANK, {}))
    later = _fault("s4", 150.0, None)
    hidden = pipeline.ends_hidden_by_later([f, later], lambda *_: True)
    assert hidden == [(f, later)]
    h = _finding(Event("s1", 100.0, 160.0, gain, {"gain": 1.50}, 1.0, BANK, {}))
    k = _finding(Event("s1", 170.1, None, gain, {"gain": 1.50}, 1.0, BANK, {}))
    (note,) = _searched(monkeypatch, {"s4": [h, k]})(hidden, [])
    assert f.end_s is None
    assert note.startswith("multiplicative fault on s1: ended at the record's end")


def test_a_later_finding_of_another_type_on_the_sensor_does_not_extend_its_end(monkeypatch):
    """A gain on s1 lost where s4's offset began (the bank saw it to 250 s, s4's fault in
    its residual); without s4 the gain ends at 160 s, and an offset on s1 from 170 to
    190 s is another fault, not the gain seen again: the gain ends at 160 s (it took
    the offset's 190 s when the search's later findings on the sensor counted whatever
    their type)."""
    gain = FaultType.MULTIPLICATIVE
    f = _finding(
        Event("s1", 100.0, 150.06, gain, {"gain": 1.50}, 1.0, DF, {}),
        Event("s1", 100.03, 150.11, gain, {"gain": 1.53}, 1.0, EM, {}),
    )
    f.events.append(Event("s1", 100.0, 250.0, gain, {"gain": 1.50}, 1.0, BANK, {}))
    later = _fault("s4", 150.0, 250.0)
    hidden = pipeline.ends_hidden_by_later([f, later], lambda *_: True)
    assert hidden == [(f, later)]
    h = _finding(Event("s1", 100.0, 160.0, gain, {"gain": 1.50}, 1.0, BANK, {}))
    k = _finding(_ev("s1", BANK, 170.0, 190.0))
    _searched(monkeypatch, {"s4": [h, k]})(hidden, [])
    assert f.end_s == 160.0


def _shaped(channel, detector, onset, end, kind, magnitude):
    return Event(channel, onset, end, kind, magnitude, 1.0, detector, {})


def test_a_shape_fitted_over_a_later_faults_trace_is_read_without_its_sensor(monkeypatch):
    """Chang et al.'s Fig. 15 (3x2 building, seed 4): an offset of 5.36 on s4 from 16 s
    and a drift on s5 from 32 s, both to the record's end. The detection filter and the
    observers, whose estimates of s4 take s5's drift in, read s4's stretch as a gain of
    0.41 and outvoted the bank's offset; without s5 all three read an offset from 16 s
    to the end. The finding takes that type and size (before: the gain stood, the search
    without s5 looked for an end only)."""
    M = FaultType.MULTIPLICATIVE
    f = _finding(
        _shaped("s4", BANK, 16.0, None, A, {"offset": 5.056}),
        _shaped("s4", DF, 16.0, None, M, {"gain": 0.4145}),
        _shaped("s4", EM, 16.0, None, M, {"gain": 0.4125}),
    )
    assert f.type is M
    g = _finding(_shaped("s5", EM, 32.03, None, FaultType.DRIFT, {"rate_per_s": 1.34}))
    found = {
        "s5": [
            _finding(
                _shaped("s4", BANK, 16.0, None, A, {"offset": 5.351}),
                _shaped("s4", DF, 16.0, None, A, {"offset": 5.295}),
                _shaped("s4", EM, 15.99, None, A, {"offset": 5.29}),
            )
        ]
    }
    (h,) = found["s5"]
    notes = _searched(monkeypatch, found)([(f, g)], [])
    assert f.type is A and f.magnitude == h.magnitude and f.detector == h.detector
    assert (f.onset_s, f.end_s) == (16.0, None)
    assert f.evidence["shape_without"] == {
        "left_out": "s5",
        "detector": h.detector,
        "was": {"type": "multiplicative", "magnitude": {"gain": 0.4145}, "detector": DF},
    }
    assert len(notes) == 1 and notes[0].startswith(
        f"additive fault on s4 (offset {h.magnitude['offset']:.4g}) as {h.detector} saw it "
        "with s5 left out; with s5 detection_filter read a multiplicative fault, gain 0.4145"
    )


def test_a_shape_without_the_later_sensor_over_another_period_is_not_taken(monkeypatch):
    """Only a finding of the search over the finding's own period gives its shape: one
    that ends 50 s earlier (its end is the end rule's business) leaves the type as it
    was."""
    M = FaultType.MULTIPLICATIVE
    f = _finding(
        _shaped("s4", DF, 100.0, None, M, {"gain": 0.5}),
        _shaped("s4", EM, 100.0, None, M, {"gain": 0.5}),
    )
    g = _fault("s5", 150.0, None)
    found = {"s5": [_finding(_shaped("s4", BANK, 100.0, 150.0, A, {"offset": 2.0}))]}
    _searched(monkeypatch, found)([(f, g)], [])
    assert f.type is M and "shape_without" not in f.evidence


def test_a_shape_without_the_later_sensor_of_the_same_type_keeps_its_own_size(monkeypatch):
    """A gain of 1.8 on s4 of the 3x2 building from 16 s, a drift on s5 from 32 s (seed
    1, as the detectors read it at 3ab2b72; on 796cd85 the same record was read as a
    drift, so the findings are built here by hand): every detector read a gain, the
    bank's 1.796. Without s5, the same floor's pair and s4's best neighbour, the estimate
    of s4 is worse and the gain came out 1.871. The type agrees, so the finding keeps its
    own size, detector and confidence (before: it took 1.871, 4 % off)."""
    M = FaultType.MULTIPLICATIVE
    f = _finding(
        _shaped("s4", BANK, 16.14, None, M, {"gain": 1.796}),
        _shaped("s4", DF, 16.1, None, M, {"gain": 1.79}),
        _shaped("s4", EM, 16.12, None, M, {"gain": 1.81}),
    )
    kept = (f.magnitude, f.detector, f.confidence)
    g = _finding(_shaped("s5", BANK, 31.99, None, FaultType.DRIFT, {"rate_per_s": 1.167}))
    found = {
        "s5": [
            _finding(
                _shaped("s4", BANK, 16.14, None, M, {"gain": 1.871}),
                _shaped("s4", EM, 16.1, None, M, {"gain": 1.88}),
            )
        ]
    }
    notes = _searched(monkeypatch, found)([(f, g)], [])
    assert f.type is M and (f.magnitude, f.detector, f.confidence) == kept
    assert "shape_without" not in f.evidence
    assert not [n for n in notes if "left out" in n]

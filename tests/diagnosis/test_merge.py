"""Merging the detectors' events into findings: one finding per physical fault, its type
voted by the detectors."""

from __future__ import annotations

import re

import pytest

from analyzer.detectors.base import Event
from analyzer.diagnosis import merge_events, one_fault_at_a_time
from analyzer.types import FaultType

A, D = FaultType.ADDITIVE, FaultType.DRIFT


def _ev(detector: str, kind: FaultType, conf: float, onset: float = 20.0) -> Event:
    mag = {"offset": 6.8} if kind is A else {"rate_per_s": -0.03}
    return Event("s4", onset, None, kind, {**mag, "by": len(detector)}, conf, detector)


def test_two_agreeing_detectors_outvote_one_more_confident():
    """A step on s4 and a later drift on another sensor: the detection filter reads s4 as
    a drift (its shape blurred by the second fault), the bank and the equivalent model as
    an offset: the finding is the offset, with the most confident additive event's
    magnitude, and every detector as evidence."""
    events = [
        _ev("ar_kalman_bank", A, 0.9),
        _ev("detection_filter", D, 0.99, 20.1),
        _ev("equivalent_model", A, 0.8),
    ]
    (f,) = merge_events(events)
    assert f.type is A and f.detector == "ar_kalman_bank" and "offset" in f.magnitude
    assert f.evidence["detectors"] == ["ar_kalman_bank", "detection_filter", "equivalent_model"]
    assert f.confidence == pytest.approx(1 - 0.1 * 0.01 * 0.2)


def test_a_detector_votes_once_and_ties_go_to_the_most_confident_event():
    events = [
        _ev("ar_kalman_bank", A, 0.6),
        _ev("ar_kalman_bank", A, 0.5, 20.5),
        _ev("detection_filter", D, 0.95),
    ]
    (f,) = merge_events(events)
    assert f.type is D  # 0.95 against the bank's best 0.6 (its events do not add up)
    (f,) = merge_events([_ev("ar_kalman_bank", A, 0.7), _ev("detection_filter", D, 0.7)])
    assert f.type is A and f.confidence == pytest.approx(1 - 0.3 * 0.3)  # the first of equals


def _on(channel, detector, kind, onset, end=None, conf=1.0, first=None):
    mag = {"offset": 1.0} if kind is A else {"rate_per_s": 0.003}
    evidence = {} if first is None else {"first_alarm_s": first}
    return Event(channel, onset, end, kind, mag, conf, detector, evidence)


def _all_coupled(detector, a, b):
    return True


def test_one_detectors_finding_during_an_agreed_fault_is_taken_for_it():
    """A drift on s15 (bank and observers) that the detection filter alone put on s11
    7 s later (a 16-channel building in the robustness sweep): one finding, on s15, and a
    note for the other."""
    findings = merge_events(
        [
            _on("s15", "ar_kalman_bank", D, 719.6),
            _on("s15", "equivalent_model", D, 719.3),
            _on("s11", "detection_filter", D, 726.4),
        ]
    )
    kept, notes = one_fault_at_a_time(findings, _all_coupled)
    assert [f.channel for f in kept] == ["s15"]
    (note,) = notes
    assert "detection_filter's drift fault on s11 at 726.400 s not reported" in note
    assert "drift fault on s15 (from 719.300 s, found by ar_kalman_bank, equivalent_model)" in note


@pytest.mark.parametrize(
    "single, coupled",
    [
        (_on("s11", "detection_filter", A, 700.0), True),  # began before the agreed fault
        (_on("s11", "detection_filter", A, 800.0), True),  # after the agreed fault ended
        (_on("s11", "detection_filter", A, 726.4), False),  # not modelled together
    ],
)
def test_other_single_detector_findings_stay(single, coupled):
    agreed = [
        _on("s15", "ar_kalman_bank", D, 719.6, 760.0),
        _on("s15", "equivalent_model", D, 719.3, 760.0),
    ]
    findings = merge_events([*agreed, single])
    kept, notes = one_fault_at_a_time(findings, lambda d, a, b: coupled)
    assert sorted(f.channel for f in kept) == ["s11", "s15"] and notes == []


def test_two_single_detector_findings_both_stay():
    findings = merge_events(
        [_on("s15", "ar_kalman_bank", D, 719.6), _on("s11", "detection_filter", D, 726.4)]
    )
    kept, notes = one_fault_at_a_time(findings, _all_coupled)
    assert len(kept) == 2 and notes == []


def test_drifts_are_compared_by_their_first_alarms():
    """A drift's fitted onset goes back to where its line meets zero: the detection
    filter's drift on s11 was fitted 11 s before the agreed drift on s14, but first
    alarmed 44 s after it (a sweep of 16-channel buildings)."""
    findings = merge_events(
        [
            _on("s14", "ar_kalman_bank", D, 719.17, first=747.62),
            _on("s14", "equivalent_model", D, 719.37, first=752.24),
            _on("s11", "detection_filter", D, 708.52, first=791.96),
        ]
    )
    kept, notes = one_fault_at_a_time(findings, _all_coupled)
    assert [f.channel for f in kept] == ["s14"] and len(notes) == 1


def test_an_agreed_drift_is_under_way_from_its_onset_when_it_alarms_late():
    """A drift on s1 of a 3-floor building (sweep seed 35, ``--floors 3 --until 0.8``):
    the bank's estimator of s0, which models s0 from its floor partner s1, alarms first,
    at 741.5 s, with the drift's sign turned; the equivalent model names s1 from 720.4 s
    (first alarm 754.1 s), and the bank names s1 too, later. The agreed drift had begun
    when the bank's s0 alarmed: the s0 finding is taken for it. A finding that alarmed
    before the agreed fault's fitted onset stays."""
    events = [
        _on("s0", "ar_kalman_bank", D, 719.31, 960.07, 0.75, first=741.53),
        _on("s1", "equivalent_model", D, 720.43, 960.0, first=754.1),
        _on("s1", "ar_kalman_bank", D, 803.77, None, 0.75, first=806.27),
    ]
    kept, notes = one_fault_at_a_time(merge_events(events), _all_coupled)
    assert [f.channel for f in kept] == ["s1"]
    (note,) = notes
    assert note.startswith("ar_kalman_bank's drift fault on s0 at 719.310 s not reported")
    early = _on("s0", "ar_kalman_bank", D, 700.0, 960.07, 0.75, first=719.0)
    kept, notes = one_fault_at_a_time(merge_events([early, *events[1:]]), _all_coupled)
    assert sorted(f.channel for f in kept) == ["s0", "s1"] and notes == []


def test_a_finding_resting_on_one_detector_and_followers_is_taken_for_the_agreed_fault():
    """A drift on s15 that the bank and the observers reported; the detection filter put
    it on s11 50 s later, and the bank, as the drift grew, on s11 too, 165 s after its own
    s15 (a 16-channel building, the drift ending at 80 % of the record). The bank follows
    on s11: the s11 finding rests on the detection filter alone."""
    findings = merge_events(
        [
            _on("s15", "ar_kalman_bank", D, 742.41, 1025.94, first=743.28),
            _on("s15", "equivalent_model", D, 719.68, 960.01, first=743.32, conf=0.75),
            _on("s11", "detection_filter", D, 725.33, 960.22, first=792.91),
            _on("s11", "ar_kalman_bank", A, 906.28, 960.21, first=908.34, conf=0.6),
        ]
    )
    assert [f.channel for f in findings] == ["s11", "s15"]
    assert len(findings[0].evidence["detectors"]) == 2  # both findings have two detectors
    kept, notes = one_fault_at_a_time(findings, _all_coupled)
    assert [f.channel for f in kept] == ["s15"]
    (note,) = notes
    assert note.startswith("detection_filter's drift fault on s11 at 725.330 s not reported")
    assert note.endswith("(ar_kalman_bank reported s11 too, after reporting s15)")
    # the bank not modelling the two together: it is no follower, two detectors stand
    kept, notes = one_fault_at_a_time(findings, lambda d, a, b: d != "ar_kalman_bank")
    assert len(kept) == 2 and notes == []


def test_a_second_fault_every_detector_moved_on_to_is_kept():
    """An offset on s5, then, while it lasts, one on s6 that every detector reports after
    its own s5: a second fault, not a spread of the first."""
    dets = ("ar_kalman_bank", "detection_filter", "equivalent_model")
    findings = merge_events(
        [_on("s5", d, A, 600.0 + i) for i, d in enumerate(dets)]
        + [_on("s6", d, A, 800.0 + i) for i, d in enumerate(dets)]
    )
    kept, notes = one_fault_at_a_time(findings, _all_coupled)
    assert [f.channel for f in kept] == ["s5", "s6"] and notes == []
    # two detectors of their own on s6 (the detection filter modelling the two apart, the
    # observers new to it) and one follower: kept as well
    findings = merge_events(
        [_on("s5", d, A, 600.0 + i) for i, d in enumerate(dets[:2])]
        + [_on("s6", d, A, 800.0 + i) for i, d in enumerate(dets)]
    )
    kept, notes = one_fault_at_a_time(findings, lambda d, a, b: d == "ar_kalman_bank")
    assert [f.channel for f in kept] == ["s5", "s6"] and notes == []


def test_a_second_fault_one_detector_moved_on_to_and_isolated_is_kept():
    """A gain on s10 from 480 s that all three detectors reported, and, while it lasts, a
    gain on s11 from 840 s that only the bank reported, after its own s10, and isolated
    to s11 (16 channels, ``sweep_isolation.py --onset 0.4 --second 0.7``, seed 16): the
    bank had corrected s10 and confirmed s11 on its own, a second fault. Without the
    bank's confirmation, it is the first fault spreading, as before."""
    M = FaultType.MULTIPLICATIVE

    def bank(channel, onset, first, isolated, kind=M):
        e = _on(channel, "ar_kalman_bank", kind, onset, first=first)
        e.evidence["isolated"] = isolated
        return e

    first = [
        bank("s10", 480.08, 480.11, True),
        _on("s10", "detection_filter", M, 480.08, first=480.11),
        _on("s10", "equivalent_model", M, 480.07, first=480.3),
    ]
    kept, notes = one_fault_at_a_time(
        merge_events([*first, bank("s11", 840.17, 840.34, True)]), _all_coupled
    )
    assert sorted(f.channel for f in kept) == ["s10", "s11"] and notes == []
    kept, notes = one_fault_at_a_time(
        merge_events([*first, bank("s11", 840.17, 840.34, False)]), _all_coupled
    )
    assert [f.channel for f in kept] == ["s10"]
    (note,) = notes
    assert note.startswith("ar_kalman_bank's multiplicative fault on s11 at 840.170 s not")
    # beside another detector (seed 19: a gain on s5, then a drift on s4 that the bank
    # isolated after its own s5 and the equivalent model reported too): kept as well
    first = [
        bank("s5", 480.04, 480.08, True),
        _on("s5", "detection_filter", M, 480.0, first=480.07),
    ]
    for isolated, expected in ((True, ["s4", "s5"]), (False, ["s5"])):
        second = [
            _on("s4", "equivalent_model", D, 831.78, first=926.0),
            bank("s4", 838.65, 861.67, isolated, D),
        ]
        kept, notes = one_fault_at_a_time(merge_events([*first, *second]), _all_coupled)
        assert sorted(f.channel for f in kept) == expected


def test_an_unconfirmed_finding_is_taken_for_a_confirmed_one_under_way():
    """A drift on s1 of a 3-floor building to 960 s that only the equivalent model named,
    confirmed by the residuals of s2 and s3, while the bank put it on s0 with no estimator
    that uses s0 confirming it (``sweep_isolation.py --floors 3 --until 0.8``, seed 35):
    one detector each, but only one of them confirmed its sensor. The s0 finding is taken
    for the s1 fault; when the bank had confirmed s0, or the model not confirmed s1, both
    stay."""

    def pair(isolated, confirmed_by):
        bank = _on("s0", "ar_kalman_bank", D, 719.31, 960.07, 0.75, first=741.53)
        bank.evidence["isolated"] = isolated
        model = _on("s1", "equivalent_model", D, 720.43, 960.0, first=754.1)
        model.evidence["confirmed_by"] = confirmed_by
        return merge_events([bank, model])

    kept, notes = one_fault_at_a_time(pair(False, ["s2", "s3"]), _all_coupled)
    assert [f.channel for f in kept] == ["s1"]
    (note,) = notes
    assert note.startswith("ar_kalman_bank's drift fault on s0 at 719.310 s not reported")
    assert note.endswith(
        "(ar_kalman_bank did not confirm its fault on s0; equivalent_model confirmed the one on s1)"
    )
    for isolated, confirmed_by in ((True, ["s2", "s3"]), (False, [])):
        kept, notes = one_fault_at_a_time(pair(isolated, confirmed_by), _all_coupled)
        assert sorted(f.channel for f in kept) == ["s0", "s1"] and notes == []


def test_a_tie_of_votes_goes_to_the_event_that_alarmed_first():
    """A half-size drift on s6 to 960 s that the bank traced from 720.9 s (first alarm
    765.3 s, confidence 0.749966) and the equivalent model caught at 834.4 s with no end,
    reading its stretch, most of it after the drift's end, as an offset (0.749997): a tie
    within VOTE_TIE, which goes to the bank's drift, the first to alarm. A clearly more
    confident offset wins the vote."""
    bank = _on("s6", "ar_kalman_bank", D, 720.89, 960.0, 0.749966, first=765.27)
    for conf, kind, onset in ((0.749997, D, 720.89), (0.9, A, 834.39)):
        model = _on("s6", "equivalent_model", A, 834.39, None, conf, first=835.7)
        (f,) = merge_events([bank, model])
        assert (f.type, f.onset_s) == (kind, onset)


def test_an_event_that_saw_only_a_faults_tail_does_not_vote():
    """A half-size drift on a 16-channel building (sweep seed 5): the bank traces it from
    717.4 s (first alarm 749.4 s, confidence 0.75: not confirmed by another estimator),
    the equivalent model catches it at 896 s, at a level it reads as an offset
    (confidence 0.96). The model's stretch lies inside the bank's, whose drift was
    fitted on it too: the finding is the bank's drift. Both detectors stay evidence."""
    bank = _on("s6", "ar_kalman_bank", D, 717.38, 960.0, 0.75, first=749.44)
    em = _on("s6", "equivalent_model", A, 896.03, 960.38, 0.963, first=898.51)
    (f,) = merge_events([bank, em])
    assert (f.type, f.onset_s, f.end_s, f.detector) == (D, 717.38, 960.0, "ar_kalman_bank")
    assert f.evidence["detectors"] == ["ar_kalman_bank", "equivalent_model"]
    assert f.confidence == pytest.approx(1 - 0.25 * 0.037)
    # the model's event lasting past the bank's (it saw what the bank did not), or
    # beginning before the bank alarmed: it votes, and the more confident offset wins
    late_end = _on("s6", "equivalent_model", A, 896.03, 975.0, 0.963, first=898.51)
    assert merge_events([bank, late_end])[0].type is A
    early = _on("s6", "equivalent_model", A, 750.0, 960.0, 0.963, first=751.0)
    assert merge_events([bank, early])[0].type is A
    # an open bank event covers a late one to the end of the record
    open_bank = _on("s6", "ar_kalman_bank", D, 717.38, None, 0.75, first=749.44)
    open_em = _on("s6", "equivalent_model", A, 896.03, None, 0.963, first=898.51)
    assert merge_events([open_bank, open_em])[0].type is D


def test_a_tail_may_end_a_tenth_of_its_span_after_the_fault_it_saw():
    """A half-size drift that ends at 960 s (sweep seed 11, ``--scale 0.5 --until 0.8``):
    the bank traces it from 717.5 s to its end; the equivalent model catches it at 854 s
    and reads an offset, whose end it sees 5.4 s late. Its 111 s stretch ends within a
    tenth of that stretch of the bank's end: a tail, and the finding is the drift. An
    event that lasts longer past that still votes."""
    bank = _on("s4", "ar_kalman_bank", D, 717.46, 960.0, 0.75, first=761.74)
    em = _on("s4", "equivalent_model", A, 854.26, 965.36, 0.807, first=856.7)
    (f,) = merge_events([bank, em])
    assert (f.type, f.onset_s, f.end_s, f.detector) == (D, 717.46, 960.0, "ar_kalman_bank")
    span = 965.36 - 854.26
    late = 965.36 - 960.0
    assert late < 0.1 * span  # the case is inside the allowance
    later = _on("s4", "equivalent_model", A, 854.26, 960.0 + 0.12 * span, 0.807, first=856.7)
    assert merge_events([bank, later])[0].type is A
    # a short late event keeps the fixed slack: 1 s past the bank's end, not a tenth of 5 s
    short = _on("s4", "equivalent_model", A, 955.0, 961.5, 0.9, first=955.5)
    assert merge_events([bank, short])[0].type is A


def test_a_late_event_of_the_winning_type_does_not_lead():
    """A half-size drift on an 8-channel building (sweep seed 20, ``--floors 4 --scale 0.5
    --until 0.8``): the bank traces it from 720.9 s (first alarm 765.3 s) to its end at
    960.0 s; the equivalent model catches it at 834.4 s, also as a drift, with no end and
    the wrong sign. Both vote for the drift; the model's confidence is higher in the
    fifth decimal, but its event began after the bank had alarmed: the finding is the
    bank's, onset, end and rate. An event that began before the other alarmed still
    leads when it is the more confident."""
    bank = Event("s6", 720.89, 960.0, D, {"rate_per_s": 0.0022}, 0.749966, "ar_kalman_bank",
                 {"first_alarm_s": 765.27})  # fmt: skip
    em = Event("s6", 834.39, None, D, {"rate_per_s": -0.0014}, 0.749997, "equivalent_model",
               {"first_alarm_s": 835.7})  # fmt: skip
    (f,) = merge_events([bank, em])
    assert (f.detector, f.onset_s, f.end_s) == ("ar_kalman_bank", 720.89, 960.0)
    assert f.magnitude == {"rate_per_s": 0.0022}
    assert f.evidence["detectors"] == ["ar_kalman_bank", "equivalent_model"]
    early = Event("s6", 760.0, 960.5, D, {"rate_per_s": 0.0021}, 0.749997, "equivalent_model",
                  {"first_alarm_s": 766.0})  # fmt: skip
    assert merge_events([bank, early])[0].detector == "equivalent_model"
    # two detectors that agree on a later start outweigh one early alarm of the same type
    # (a false alarm whose shape took in the fault): the most confident event leads
    em_early = _on("s2", "equivalent_model", A, 12.92, None, 0.75, first=22.705)
    bank_a = _on("s2", "ar_kalman_bank", A, 30.0, None, 0.959, first=30.015)
    df_a = _on("s2", "detection_filter", A, 30.0, None, 0.958, first=30.025)
    f = merge_events([em_early, bank_a, df_a])[0]
    assert (f.detector, f.onset_s) == ("ar_kalman_bank", 30.0)
    assert merge_events([em_early, bank_a])[0].detector == "equivalent_model"


def test_two_detectors_that_agree_late_vote_against_an_earlier_alarm():
    """A step at 30 s on a 60 s record (the CLI's fixture): the equivalent model alarms
    at 22.7 s, before the step, and reads the stretch as a drift traced from 12.9 s; the
    bank and the detection filter both put an offset at 30.0 s. Their events begin after
    the model's alarm and end within its span, but they agree: the finding is the
    offset."""
    em = _on("s2", "equivalent_model", D, 12.92, None, 0.75, first=22.705)
    bank = _on("s2", "ar_kalman_bank", A, 30.0, None, 0.959, first=30.015)
    df = _on("s2", "detection_filter", A, 30.0, None, 0.958, first=30.025)
    (f,) = merge_events([em, bank, df])
    assert (f.type, f.onset_s, f.detector) == (A, 30.0, "ar_kalman_bank")
    # either alone is a tail of the model's drift
    assert merge_events([em, bank])[0].type is D


def _observer_event(channel, onset, first, assistants, confirmed_by):
    """An equivalent-model gain event with its network evidence."""
    evidence = {"first_alarm_s": first, "assistants": assistants, "confirmed_by": confirmed_by}
    return Event(
        channel, onset, 959.82, FaultType.MULTIPLICATIVE, {"gain": 0.875}, 0.75,
        "equivalent_model", evidence,
    )  # fmt: skip


def test_an_unconfirmed_observer_finding_is_taken_for_its_assistants_fault():
    """A half-size gain (1.15) on s0 (sweep seed 7, ``--scale 0.5 --until 0.8``): the bank
    names s0 from 719.93 s; the equivalent model, which models s1 from s0, puts a gain of
    0.875 (about 1 / 1.15) on s1 from 719.98 s, and no residual of the sensors s1 assists
    confirms it. The assistant's fault explains it: one finding, on s0, and a note."""
    bank = Event(
        "s0", 719.93, 967.68, FaultType.MULTIPLICATIVE, {"gain": 1.165}, 0.75,
        "ar_kalman_bank", {"first_alarm_s": 721.48},
    )  # fmt: skip
    em = _observer_event("s1", 719.98, 721.78, ["s0", "s3"], [])
    kept, notes = one_fault_at_a_time(merge_events([bank, em]), _all_coupled)
    assert [(f.channel, f.detector) for f in kept] == [("s0", "ar_kalman_bank")]
    assert len(notes) == 1 and "on s1" in notes[0] and "assistant sensor s0" in notes[0]
    # confirmed by a sensor s1 assists, s0 not its assistant, s0's fault found only
    # later, or a detector that reports no confirmation: both findings stay
    for other in (
        _observer_event("s1", 719.98, 721.78, ["s0", "s3"], ["s2"]),
        _observer_event("s1", 719.98, 721.78, ["s2", "s3"], []),
        Event("s1", 719.98, 959.82, FaultType.MULTIPLICATIVE, {"gain": 0.875}, 0.75,
              "equivalent_model", {"first_alarm_s": 721.78}),
    ):  # fmt: skip
        kept, notes = one_fault_at_a_time(merge_events([bank, other]), _all_coupled)
        assert len(kept) == 2 and not notes
    late = Event(
        "s0", 730.0, 967.68, FaultType.MULTIPLICATIVE, {"gain": 1.165}, 0.75,
        "ar_kalman_bank", {"first_alarm_s": 731.0},
    )  # fmt: skip
    kept, notes = one_fault_at_a_time(merge_events([late, em]), _all_coupled)
    assert len(kept) == 2 and not notes


def _gain_seen_through_law_0() -> tuple[Event, Event, Event]:
    """The bank's gain on s0, the equivalent model's unconfirmed alarm on s1 (modelled
    from s0) and the detection filter's lone ``other`` on s2 409 s into it (sweep seed 7,
    ``--scale 0.5``)."""
    bank = Event(
        "s0", 719.93, None, FaultType.MULTIPLICATIVE, {"gain": 1.168}, 0.75,
        "ar_kalman_bank", {"first_alarm_s": 721.48},
    )  # fmt: skip
    em = _observer_event("s1", 719.98, 721.78, ["s0", "s3"], [])
    em.end_s = None
    df = Event(
        "s2", 1128.82, 1130.82, FaultType.OTHER, {"offset": 0.025}, 0.573,
        "detection_filter", {"first_alarm_s": 1130.81},
    )  # fmt: skip
    return bank, em, df


def test_a_detector_the_assistants_fault_explains_agrees_on_that_fault():
    """A half-size gain (1.15) on s0 lasting to the end (sweep seed 7, ``--scale 0.5``):
    the bank names s0; the equivalent model's unconfirmed gain on s1 (modelled from s0)
    is taken for it (law 0), so two detectors saw s0's fault. The detection filter's lone
    2 s ``other`` on s2, 409 s into it, is then taken for it too, with a note naming both.
    Without the model's alarm, s0's fault rests on the bank alone, and a single detector's
    finding does not outweigh another's: both stay."""
    bank, em, df = _gain_seen_through_law_0()
    kept, notes = one_fault_at_a_time(merge_events([bank, em, df]), _all_coupled)
    assert [(f.channel, f.detector) for f in kept] == [("s0", "ar_kalman_bank")]
    assert len(notes) == 2 and "on s2" in notes[1]
    assert (
        "found by ar_kalman_bank; equivalent_model's alarm on s1 taken for it through law 0)"
        in notes[1]
    )
    kept, notes = one_fault_at_a_time(merge_events([bank, df]), _all_coupled)
    assert [f.channel for f in kept] == ["s0", "s2"] and not notes


def test_a_note_says_found_by_the_detectors_the_findings_evidence_lists():
    """The realdata audit (SKAB anomaly-free.csv, ``--train 0:2000``): a note said the
    drift on Thermocouple was "found by ar_kalman_bank, and by equivalent_model through
    law 0" while the finding's ``evidence.detectors`` was the bank alone. The evidence is
    right: the equivalent model reported no fault on that sensor; its unconfirmed alarm on
    another, modelled from it, was taken for it. So the note's "found by" names the
    finding's own detectors, and the observers' alarm apart, with the sensor it was on."""
    bank, em, df = _gain_seen_through_law_0()
    kept, notes = one_fault_at_a_time(merge_events([bank, em, df]), _all_coupled)
    (s0,) = kept
    (note,) = [n for n in notes if "fault on s2" in n]
    found = re.search(r"found by ([^;)]*)", note)
    assert found is not None and found.group(1).split(", ") == s0.evidence["detectors"]
    assert "equivalent_model's alarm on s1 taken for it through law 0" in note


def test_an_unconfirmed_observer_does_not_count_as_a_findings_own_detector():
    """A half-size gain on s5 of a 3-floor building (sweep seed 1, ``--floors 3 --until
    0.8 --scale 0.5``): the bank names s5 at 722 s; the detection filter puts an inverse
    gain on the floor partner s4 at 724.6 s, and the equivalent model, which models s4
    from s5, alarms on s4 in three stretches no sensor s4 assists confirmed. Its part in
    the s4 finding is s5's fault, so that finding rests on the detection filter alone and
    is taken for s5's (the bank's, and the observers' later). With the observer's
    stretches confirmed, s4 has two detectors of its own and stays."""

    def em_s4(onset, end, first, confirmed_by=()):
        return Event(
            "s4", onset, end, FaultType.MULTIPLICATIVE, {"gain": 0.92}, 0.75,
            "equivalent_model",
            {"first_alarm_s": first, "assistants": ["s5", "s3"],
             "confirmed_by": list(confirmed_by)},
        )  # fmt: skip

    def gain(channel, detector, onset, end, first, g):
        return Event(
            channel, onset, end, FaultType.MULTIPLICATIVE, {"gain": g}, 1.0, detector,
            {"first_alarm_s": first},
        )  # fmt: skip

    events = [
        gain("s5", "ar_kalman_bank", 720.17, 961.23, 722.05, 1.152),
        gain("s4", "detection_filter", 723.73, 960.16, 724.59, 0.89),
        em_s4(727.0, 730.79, 728.65),
        em_s4(736.2, 742.41, 737.94),
        em_s4(754.63, 768.06, 757.03),
        Event(
            "s5", 808.35, 984.07, FaultType.MULTIPLICATIVE, {"gain": 1.13}, 1.0,
            "equivalent_model",
            {"first_alarm_s": 810.68, "assistants": ["s2", "s3"], "confirmed_by": ["s4"]},
        ),
    ]  # fmt: skip
    kept, notes = one_fault_at_a_time(merge_events(events), _all_coupled)
    assert [f.channel for f in kept] == ["s5"]
    (note,) = notes
    assert note.startswith("detection_filter's multiplicative fault on s4 at 723.730 s")
    assert "assistant sensor s5 was already faulty" in note
    confirmed = [*events[:2], *(em_s4(e.onset_s, e.end_s, _alarm(e), ["s3"])
                                for e in events[2:5]), events[5]]  # fmt: skip
    kept, notes = one_fault_at_a_time(merge_events(confirmed), _all_coupled)
    assert sorted(f.channel for f in kept) == ["s4", "s5"] and notes == []


def _alarm(e):
    return e.evidence["first_alarm_s"]


def test_a_fault_is_under_way_until_the_detector_saw_it_end():
    """A half-size gain on s1 of a 4-floor building, from 720 to 960 s (sweep seed 13,
    ``--floors 4 --until 0.8 --scale 0.5``): all three detectors name s1; the detection
    filter and the observers see it end at 960.0 s, the bank at 965.1 s, and until then
    the bank's estimator of the floor partner s0 alarms (961.8 s). For the bank the s1
    gain was still under way: the s0 finding is taken for it. Had the bank seen s1 end
    with the others, s0 would stay."""

    def gain(channel, detector, onset, end, first):
        return Event(
            channel, onset, end, FaultType.MULTIPLICATIVE, {"gain": 1.15}, 0.75, detector,
            {"first_alarm_s": first},
        )  # fmt: skip

    s1 = [
        gain("s1", "detection_filter", 720.04, 960.02, 721.66),
        gain("s1", "equivalent_model", 720.04, 960.02, 721.65),
    ]
    s0 = gain("s0", "ar_kalman_bank", 959.96, 965.17, 961.75)
    bank = gain("s1", "ar_kalman_bank", 720.91, 965.09, 721.83)
    kept, notes = one_fault_at_a_time(merge_events([*s1, bank, s0]), _all_coupled)
    assert [(f.channel, f.end_s) for f in kept] == [("s1", 960.02)]
    (note,) = notes
    assert note.startswith("ar_kalman_bank's multiplicative fault on s0 at 959.960 s")
    assert note.endswith("one fault at a time")  # the bank named alone, not as a follower
    bank_on_time = gain("s1", "ar_kalman_bank", 720.91, 960.1, 721.83)
    kept, notes = one_fault_at_a_time(merge_events([*s1, bank_on_time, s0]), _all_coupled)
    assert sorted(f.channel for f in kept) == ["s0", "s1"] and notes == []


def test_a_single_detectors_finding_that_ends_with_its_own_fault_nearby_is_that_fault():
    """A half-size gain on s0 to 960 s (16-channel sweep seed 7, ``--until 0.8 --scale
    0.5``) that only the bank named; it saw the end at 967.7 s, and its estimator of the
    floor partner s1 alarmed from 963.4 to 968.3 s meanwhile. The s1 finding ends with
    the bank's s0 fault: taken for it. One that outlasts it, has no end, or that another
    detector reports too, stays."""

    def gain(channel, detector, onset, end, first):
        return Event(
            channel, onset, end, FaultType.MULTIPLICATIVE, {"gain": 1.17}, 0.75, detector,
            {"first_alarm_s": first},
        )  # fmt: skip

    s0 = gain("s0", "ar_kalman_bank", 719.93, 967.68, 721.48)
    s1 = gain("s1", "ar_kalman_bank", 963.36, 968.26, 965.83)
    kept, notes = one_fault_at_a_time(merge_events([s0, s1]), _all_coupled)
    assert [f.channel for f in kept] == ["s0"]
    (note,) = notes
    assert note.startswith("ar_kalman_bank's multiplicative fault on s1 at 963.360 s")
    for other in (
        [gain("s1", "ar_kalman_bank", 963.36, 990.0, 965.83)],
        [gain("s1", "ar_kalman_bank", 963.36, None, 965.83)],
        [s1, gain("s1", "detection_filter", 963.5, 968.2, 965.9)],
    ):
        kept, notes = one_fault_at_a_time(merge_events([s0, *other]), _all_coupled)
        assert sorted(f.channel for f in kept) == ["s0", "s1"] and notes == []
    # not modelled together: both stay
    kept, notes = one_fault_at_a_time(merge_events([s0, s1]), lambda d, a, b: False)
    assert len(kept) == 2 and notes == []


def test_a_finding_traced_back_into_the_healthy_window_gets_a_note():
    """A drift that the bank traced back to 1 109 s while the healthy window ends at
    1 993 s starts at the window's end; the note names it, the traced onset and what tells
    a slow change of the system from a sensor's; a finding without such an event gets
    none."""
    from analyzer.diagnosis.merge import traced_into_training

    early = Event(
        "acc1",
        1993.0,
        None,
        D,
        {"rate_per_s": -2e-6},
        0.375,
        "ar_kalman_bank",
        evidence={"traced_onset_s": 1108.96, "starts_in_training": True},
    )
    late = Event("acc1", 7756.0, None, D, {"rate_per_s": -2e-6}, 0.9, "detection_filter")
    other = Event("temp", 5000.0, None, A, {"offset": 0.3}, 0.9, "equivalent_model")
    findings = merge_events([early, late, other])
    notes = traced_into_training(findings)
    assert len(notes) == 1
    assert notes[0].startswith("drift fault on acc1 from 1993.000 s")
    assert "traced back to 1108.960 s" in notes[0] and "--train" in notes[0]

"""A fault whose end some detectors saw only where a later fault of a sensor modelled
with it ended (:func:`analyzer.diagnosis.merge.ends_of_later_faults`), and a later fault
one detector isolated while it kept that detector's estimate of the first alarmed
(:func:`analyzer.diagnosis.merge.one_fault_at_a_time`). The event times are those of a
6-channel simulated building (``benchmarks/sweep_two_faults.py``)."""

from __future__ import annotations

from analyzer.detectors.base import Event
from analyzer.diagnosis import (
    ends_hidden_by_later,
    ends_of_later_faults,
    merge_events,
    one_fault_at_a_time,
    onsets_hidden_by_earlier,
)
from analyzer.types import FaultType

A, D, M = FaultType.ADDITIVE, FaultType.DRIFT, FaultType.MULTIPLICATIVE
BANK, DF, EM = "ar_kalman_bank", "detection_filter", "equivalent_model"


def _ev(channel, detector, onset, end, size, kind=A, **evidence):
    mag = {A: {"offset": size}, D: {"rate_per_s": size}}.get(kind, {"gain": size})
    return Event(
        channel, onset, end, kind, mag, 1.0, detector, {"first_alarm_s": onset, **evidence}
    )


def _coupled(detector, a, b):
    return True


def _second(onset=150.0, end=250.0, size=3.88):
    return [_ev("s4", d, onset, end, size) for d in (BANK, DF, EM)]


def test_an_end_only_a_later_fault_explains_gives_way_to_the_detectors_that_saw_it():
    """An offset on s1 from 100 to 200 s and one on s4 from 150 to 250 s: the bank and
    the observers saw s1's to s4's end (the bank's offset averaged over both, 1.84 for
    3.22), the detection filter to 200.0 s. The finding takes the filter's end and
    size, with a note; every detector stays in its evidence."""
    first = [
        _ev("s1", BANK, 100.0, 250.09, 1.84),
        _ev("s1", DF, 100.0, 200.0, 2.82),
        _ev("s1", EM, 100.01, 250.12, 3.2),
    ]
    findings = merge_events([*first, *_second()])
    s1 = next(f for f in findings if f.channel == "s1")
    assert s1.end_s == 250.09  # before: the bank's end
    (note,) = ends_of_later_faults(findings, _coupled)
    assert (s1.onset_s, s1.end_s, s1.magnitude, s1.detector) == (100.0, 200.0, {"offset": 2.82}, DF)
    assert s1.evidence["detectors"] == [BANK, DF, EM]
    assert note.startswith("additive fault on s1: ended at 200.000 s as detection_filter saw it")
    assert "ar_kalman_bank, equivalent_model saw it to 250.090 s" in note
    assert "the additive fault on s4 (from 150.000 s) ended" in note
    s4 = next(f for f in findings if f.channel == "s4")
    assert (s4.onset_s, s4.end_s) == (150.0, 250.0)


def test_the_end_stays_where_nothing_explains_it():
    first = [_ev("s1", BANK, 100.0, 250.09, 1.84), _ev("s1", DF, 100.0, 200.0, 2.82)]
    cases = [
        ([*first, *_second(end=240.0)], _coupled),  # the later fault ended elsewhere
        ([*first, *_second(onset=100.5)], _coupled),  # it began with this one
        ([*first, *_second()], lambda d, a, b: False),  # not modelled together
        # the filter saw s1 faulty again before the bank's end: the fault went on
        ([*first, _ev("s1", DF, 200.0, 250.0, 0.2, changed_at_s=200.0), *_second()], _coupled),
        # another detector saw it go on past the later fault's end
        ([*first, _ev("s1", EM, 100.0, 280.0, 3.2), *_second()], _coupled),
    ]
    for events, coupled in cases:
        findings = merge_events(events)
        ends = [(f.channel, f.end_s) for f in findings]
        assert ends_of_later_faults(findings, coupled) == []
        assert [(f.channel, f.end_s) for f in findings] == ends


def test_an_end_where_the_later_fault_began_needs_two_detectors():
    """A gain on s3 from 100 to 200 s and an offset on s0 from 150 s: the detection
    filter, which isolates one fault at a time, lost the gain at 150.1 s, the observers
    saw it to 200.8 s, the bank to s0's end: the observers' end. With only the filter's
    end at s0's onset the finding keeps its end; with two detectors there (an offset on
    s1 to 200 s, one on s4 from 200 s) theirs counts."""
    second = [_ev("s0", BANK, 150.0, 250.0, 2.63), _ev("s0", EM, 150.01, 250.0, 2.63)]
    gain = [
        _ev("s3", BANK, 100.03, 250.14, 1.49, M),
        _ev("s3", DF, 100.03, 150.12, 1.49, M),
        _ev("s3", EM, 100.04, 200.77, 1.486, M),
    ]
    findings = merge_events([*gain, *second])
    assert len(ends_of_later_faults(findings, _coupled)) == 1
    assert next(f for f in findings if f.channel == "s3").end_s == 200.77
    lost = [gain[0], gain[1]]  # the filter alone ended it at s0's onset
    findings = merge_events([*lost, *second])
    assert ends_of_later_faults(findings, _coupled) == []
    assert next(f for f in findings if f.channel == "s3").end_s == 250.14
    abut = [
        _ev("s1", BANK, 100.0, 260.08, 3.22),
        _ev("s1", DF, 100.0, 200.0, 3.22),
        _ev("s1", EM, 100.01, 200.06, 3.21),
    ]
    findings = merge_events([*abut, *_second(onset=200.0, end=260.0)])
    assert len(ends_of_later_faults(findings, _coupled)) == 1
    assert next(f for f in findings if f.channel == "s1").end_s == 200.0


def test_a_later_fault_one_detector_isolated_is_not_taken_for_the_first():
    """A gain on s2 from 100 to 200 s that all three detectors named (the observers to
    199.97 s, the bank to 250.11 s) and an offset on s5 from 150 to 250 s that only the
    bank reported, isolated: it began while the others still saw the gain under way, so
    it is a fault of its own, not the gain's end seen on s5. Not isolated, it is taken
    for the gain, as before."""
    gain = [
        _ev("s2", EM, 99.69, 199.97, 1.504, M),
        _ev("s2", BANK, 100.0, 250.11, 1.504, M, isolated=True),
        _ev("s2", DF, 100.0, 149.77, 1.502, M),
    ]
    s5 = _ev("s5", BANK, 150.0, 250.0, 4.31, isolated=True)
    kept, notes = one_fault_at_a_time(merge_events([*gain, s5]), _coupled)
    assert sorted(f.channel for f in kept) == ["s2", "s5"] and notes == []
    unisolated = _ev("s5", BANK, 150.0, 250.0, 4.31, isolated=False)
    kept, notes = one_fault_at_a_time(merge_events([*gain, unisolated]), _coupled)
    assert [f.channel for f in kept] == ["s2"] and len(notes) == 1


def test_an_end_the_first_fault_gave_the_later_ones_part_explains_nothing():
    """A drift on s1 from 100 to 200 s and an offset on s4 from 150 to 250 s: the
    detection filter saw the drift to 200.0 s and its part of s4's offset end there too
    (200.1 s: the drift's end, seen on s4); only s4's reported end (250.0 s) explains an
    end of s1's. The bank's end there gives way to the filter's drift, not to the
    observers' late, short ``other`` (a tail of the drift, which does not vote)."""
    s1 = [
        _ev("s1", DF, 89.36, 200.01, 0.02, D, first_alarm_s=103.63),
        _ev("s1", BANK, 100.0, 250.09, 0.032, D, first_alarm_s=103.71),
        Event(
            "s1",
            110.69,
            174.37,
            FaultType.OTHER,
            {"offset": 0.31},
            0.88,
            EM,
            {"first_alarm_s": 112.88},
        ),  # fmt: skip
    ]
    s4 = [
        _ev("s4", BANK, 150.0, 250.0, 3.88),
        _ev("s4", DF, 150.0, 200.12, 3.36, changed_at_s=150.0),
    ]
    findings = merge_events([*s1, *s4])
    assert len(ends_of_later_faults(findings, _coupled)) == 1
    f = next(f for f in findings if f.channel == "s1")
    assert (f.type, f.onset_s, f.end_s, f.detector) == (D, 89.36, 200.01, DF)


def test_only_the_end_moves_when_the_detector_that_saw_it_reads_another_type():
    """A review's case: a drift on s1 that the bank and the observers traced from 95 s
    (to s4's end), caught late by the detection filter at 120 s as an offset ending at
    200 s: the finding keeps its onset, type and rate, and takes the filter's end."""
    drift = {"rate_per_s": 0.02}
    events = [
        _ev("s1", BANK, 95.0, 250.09, 0.02, D),
        _ev("s1", EM, 95.2, 250.12, 0.02, D),
        _ev("s1", DF, 120.0, 200.0, 1.5),
        *_second(),
    ]
    findings = merge_events(events)
    (note,) = ends_of_later_faults(findings, _coupled)
    s1 = next(f for f in findings if f.channel == "s1")
    assert (s1.type, s1.onset_s, s1.end_s, s1.magnitude) == (D, 95.0, 200.0, drift)
    assert "its size is theirs" not in note


def test_a_finding_without_events_explains_no_end():
    (f,) = merge_events([_ev("s1", BANK, 100.0, 250.0, 1.0)])
    empty = merge_events([_ev("s4", BANK, 150.0, 250.0, 1.0)])[0]
    empty.events = []
    assert ends_of_later_faults([f, empty], _coupled) == []


def test_a_single_detectors_isolated_finding_ends_with_that_detectors_own_fault():
    """The bank's isolated gain on s1 from 963.4 to 968.3 s, during its own gain on s0
    that only it reported (to 967.7 s): nothing says s0's gain went on, so s1's is its
    end seen on s1, taken for it (the isolation exception needs another detector that saw
    s0's fault under way when s1's began)."""
    s0 = _ev("s0", BANK, 719.93, 967.68, 1.17, M, isolated=True)
    s1 = _ev("s1", BANK, 963.36, 968.26, 1.17, M, isolated=True)
    kept, notes = one_fault_at_a_time(merge_events([s0, s1]), _coupled)
    assert [f.channel for f in kept] == ["s0"] and len(notes) == 1


def _s3_then_s0(bank_end=250.14, df_end=200.0):
    """An offset on s3 from 100 to 200 s and one on s0 from 150 to 250 s (seed 3 of
    ``sweep_two_faults.py``'s ``overlap``): all three detectors named s3, the bank to
    s0's end; only the detection filter named s0, from where it saw s3's fault end."""
    s3 = [
        _ev("s3", BANK, 100.0, bank_end, 3.62, isolated=True),
        _ev("s3", DF, 100.0, df_end, 3.75, confirmed=True),
        _ev("s3", EM, 100.0, 200.0, 3.85),
    ]
    s0 = _ev("s0", DF, 200.07, 250.0, 2.63, changed_at_s=200.07, confirmed=True)
    return merge_events([*s3, s0])


def test_a_later_fault_from_where_its_detector_saw_the_first_end_is_its_own():
    """The filter saw s3's fault end at 200.0 s, then s0's from 200.07 s to 250.0 s; the
    bank saw s3's to 250.14 s, where s0's ended (s0's fault in its estimate of s3). s0's
    finding was taken for s3's fault (the bank's end: under way), and s0 had none; it
    stays, and s3's end is then the filter's and the observers'."""
    findings = _s3_then_s0()
    kept, notes = one_fault_at_a_time(findings, _coupled)
    assert sorted(f.channel for f in kept) == ["s0", "s3"] and notes == []
    ends_of_later_faults(kept, _coupled)
    assert {(f.channel, f.onset_s, f.end_s) for f in kept} == {
        ("s3", 100.0, 200.0),
        ("s0", 200.07, 250.0),
    }


def test_a_later_fault_is_still_taken_for_one_that_went_on():
    """As before where the first fault went on past the later one's first alarm as its
    own detector saw it, or where another detector saw it go on to elsewhere than the
    later fault's end."""
    for findings in (_s3_then_s0(df_end=230.0), _s3_then_s0(bank_end=235.0)):
        kept, notes = one_fault_at_a_time(findings, _coupled)
        assert [f.channel for f in kept] == ["s3"] and len(notes) == 1


def test_an_end_no_detector_saw_is_hidden_by_the_later_fault():
    """A gain on s1 from 100 to 200 s and an offset on s4 from 150 to 250 s (seed 1): the
    bank and the observers saw the gain to s4's end, the detection filter lost it at
    150.06 s, where s4's began. No end counts (one detector lost it where the other
    began): the finding stays at 250.09 s, its end hidden by s4's fault, which the
    pipeline then searches without."""
    first = [
        _ev("s1", BANK, 100.0, 250.09, 1.503, M),
        _ev("s1", DF, 100.0, 150.06, 1.502, M),
        _ev("s1", EM, 99.35, 250.12, -0.024, D),
    ]
    findings = merge_events([*first, *_second()])
    assert ends_of_later_faults(findings, _coupled) == []
    s1, s4 = (next(f for f in findings if f.channel == c) for c in ("s1", "s4"))
    assert s1.end_s == 250.09
    assert ends_hidden_by_later(findings, _coupled) == [(s1, s4)]


def test_an_end_a_detector_saw_is_not_hidden():
    """The same faults with the filter's end at 200.0 s: the finding takes it
    (:func:`ends_of_later_faults`) and nothing is hidden; nor where the sensors are not
    modelled together, nor where the later fault ended elsewhere."""
    first = [_ev("s1", BANK, 100.0, 250.09, 1.84), _ev("s1", DF, 100.0, 200.0, 2.82)]
    findings = merge_events([*first, *_second()])
    ends_of_later_faults(findings, _coupled)
    assert ends_hidden_by_later(findings, _coupled) == []
    alone = [_ev("s1", BANK, 100.0, 250.09, 1.84)]
    assert ends_hidden_by_later(merge_events([*alone, *_second()]), lambda d, a, b: False) == []
    assert ends_hidden_by_later(merge_events([*alone, *_second(end=240.0)]), _coupled) == []


def test_an_end_inside_a_later_fault_the_detectors_disagree_on_is_hidden():
    """An offset on s0 from 100 to 200 s and one on s1, the next floor's, from 150 to
    250 s (seed 6): the bank, leading, saw s0's end at 225.76 s, inside s1's fault, the
    detection filter at 200.0 s. The end is hidden by s1's fault; not when the
    detectors agree, nor when the end is not inside a later fault (it began after the
    end, or with the first)."""

    def first(bank_end, df_end):
        return [_ev("s0", BANK, 100.0, bank_end, 1.77), _ev("s0", DF, 100.0, df_end, 1.0)]

    def s1(onset=150.0, end=250.0):
        return [_ev("s1", d, onset, end, 3.09) for d in (DF, EM)]

    findings = merge_events([*first(225.76, 200.0), *s1()])
    s0, later = (next(f for f in findings if f.channel == c) for c in ("s0", "s1"))
    assert (s0.end_s, s0.detector) == (225.76, BANK)
    assert ends_of_later_faults(findings, _coupled) == []
    assert ends_hidden_by_later(findings, _coupled) == [(s0, later)]
    for events in (
        [*first(225.76, 225.76), *s1()],  # they agree
        [*first(225.76, 200.0), *s1(onset=230.0, end=280.0)],  # it ended before
        [*first(225.76, 200.0), *s1(onset=100.5)],  # it began with this one
    ):
        assert ends_hidden_by_later(merge_events(events), _coupled) == []
    apart = merge_events([*first(225.76, 200.0), *s1()])
    assert ends_hidden_by_later(apart, lambda d, a, b: False) == []


def test_an_end_where_a_later_fault_began_is_hidden_when_another_detector_saw_it_go_on():
    """The event times of seed 12 and seed 17 (``sweep_two_faults.py``): a drift on s0
    from 100 s whose end the bank and the detection filter saw at 150.08 s, where s3's
    offset began, the observers at 200.01 s; a gain on s5 whose end the filter and the
    observers saw at 150.14 s, where s2's began, the bank at 250.13 s, s2's end. Either
    fault may have ended where the later began, or been lost there: the end is hidden by
    the later fault (the pipeline searches without its sensor). Not when every detector
    saw it end there, nor when the sensors are not modelled together."""
    drift = [
        _ev("s0", BANK, 95.61, 150.08, 0.026, D),
        _ev("s0", DF, 98.22, 150.08, 0.026, D),
        _ev("s0", EM, 99.68, 200.01, 0.027, D),
    ]
    s3 = [_ev("s3", d, 150.0, 250.0, 4.57) for d in (DF, EM)]
    findings = merge_events([*drift, *s3])
    assert ends_of_later_faults(findings, _coupled) == []
    s0, later = (next(f for f in findings if f.channel == c) for c in ("s0", "s3"))
    assert s0.end_s == 150.08
    assert ends_hidden_by_later(findings, _coupled) == [(s0, later)]
    gain = [
        _ev("s5", BANK, 100.0, 250.13, 1.5, M),
        _ev("s5", DF, 100.0, 150.14, 1.51, M),
        _ev("s5", EM, 100.0, 150.13, 1.5, M),
    ]
    s2 = [_ev("s2", d, 150.0, 250.0, 3.43) for d in (BANK, DF, EM)]
    findings = merge_events([*gain, *s2])
    ends_of_later_faults(findings, _coupled)
    s5, later = (next(f for f in findings if f.channel == c) for c in ("s5", "s2"))
    assert s5.end_s == 150.14
    assert ends_hidden_by_later(findings, _coupled) == [(s5, later)]
    ended = [_ev("s0", d, 100.0, 150.08, 0.026, D) for d in (BANK, DF, EM)]
    assert ends_hidden_by_later(merge_events([*ended, *s3]), _coupled) == []
    assert ends_hidden_by_later(merge_events([*drift, *s3]), lambda d, a, b: False) == []


def test_an_onset_inside_an_earlier_fault_another_detector_saw_later_is_hidden():
    """The event times of seed 17 (``nested``) and seed 15 (``neighbour``): the bank saw
    s2's offset from 142.89 s to 215.04 s, inside s5's fault from 100 s, the observers
    from 150.0 s to 200.0 s; the bank saw s4's from 111.56 s (offset -0.08), inside s3's
    from 100 s, the detection filter from 150.0 s. The bank's onset leads (one detector
    against one) and may be the earlier fault's trace: hidden by it. Not when the
    detectors agree on the onset, nor when the earlier fault had ended, nor when the
    sensors are not modelled together."""
    s5 = [_ev("s5", d, 100.0, 250.0, 4.55) for d in (BANK, DF)]
    s2 = [_ev("s2", BANK, 142.89, 215.04, 2.33), _ev("s2", EM, 150.0, 200.0, 3.43)]
    findings = merge_events([*s5, *s2])
    ends_of_later_faults(findings, _coupled)
    earlier, f = (next(x for x in findings if x.channel == c) for c in ("s5", "s2"))
    assert (f.onset_s, f.detector) == (142.89, BANK)
    assert onsets_hidden_by_earlier(findings, _coupled) == [(f, earlier)]
    s3 = [_ev("s3", d, 100.0, 200.0, 3.7) for d in (BANK, DF, EM)]
    s4 = [_ev("s4", BANK, 111.56, 257.57, -0.08), _ev("s4", DF, 150.0, 250.0, 4.03)]
    findings = merge_events([*s3, *s4])
    earlier, f = (next(x for x in findings if x.channel == c) for c in ("s3", "s4"))
    assert onsets_hidden_by_earlier(findings, _coupled) == [(f, earlier)]
    agreed = [_ev("s2", d, 150.0, 200.0, 3.43) for d in (BANK, EM)]
    assert onsets_hidden_by_earlier(merge_events([*s5, *agreed]), _coupled) == []
    over = [_ev("s5", d, 100.0, 140.0, 4.55) for d in (BANK, DF)]
    assert onsets_hidden_by_earlier(merge_events([*over, *s2]), _coupled) == []
    assert onsets_hidden_by_earlier(merge_events([*s5, *s2]), lambda d, a, b: False) == []


def test_an_onset_inside_an_earlier_fault_is_asked_about_after_its_end_moved():
    """Three offsets, s5 from 100 to 250 s, s2 from 150 to 200 s and s3 from 190 to
    290 s (seed 17, a third fault beside ``nested``): the bank saw s3's from 120.57 s (s5's
    trace) to the record's end, where the bank's drift on s2 ended, the detection filter
    from 190.0 s to 290.01 s. The end is the filter's, and so is the finding's
    ``detector``, but the onset is still the bank's, inside s5's fault, the filter seeing
    it begin 69 s later: its onset is asked about (before, the filter, now named, began
    where the finding did not, and it was not)."""
    events = [_ev("s5", d, 100.0, 250.0, 4.7) for d in (BANK, DF, EM)]
    events += [_ev("s3", BANK, 120.57, None, 2.1), _ev("s3", DF, 190.0, 290.01, 3.8)]
    events += [_ev("s2", BANK, 128.27, None, 0.02, D), _ev("s2", EM, 150.0, 200.0, 3.4)]
    findings = merge_events(events)
    ends_of_later_faults(findings, _coupled)
    s3 = next(f for f in findings if f.channel == "s3")
    assert (s3.onset_s, s3.end_s, s3.detector) == (120.57, 290.01, DF)
    s5 = next(f for f in findings if f.channel == "s5")
    assert (s3, s5) in onsets_hidden_by_earlier(findings, _coupled)

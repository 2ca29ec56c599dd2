"""One physical fault, one finding: events of several detectors on the same channel
whose intervals overlap are merged; the finding's type, onset and magnitude come from
the most confident event, and ``evidence.detectors`` lists every detector that saw it."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from analyzer.detectors.base import Event
from analyzer.timeutil import seconds_text
from analyzer.types import FaultType


@dataclass(slots=True)
class Finding:
    channel: str
    type: FaultType
    onset_s: float
    end_s: float | None
    magnitude: dict[str, float]
    confidence: float
    detector: str
    evidence: dict[str, Any] = field(default_factory=dict)
    events: list[Event] = field(default_factory=list)


def _overlap(a0: float, a1: float | None, b0: float, b1: float | None, slack: float) -> bool:
    a_end = float("inf") if a1 is None else a1
    b_end = float("inf") if b1 is None else b1
    return a0 <= b_end + slack and b0 <= a_end + slack


def found_already(f: Finding, findings: Sequence[Finding], slack_s: float) -> bool:
    """Whether ``findings`` hold one on ``f``'s channel that overlaps it in time (within
    ``slack_s``): what a second search found that the first had already."""
    return any(
        g.channel == f.channel and _overlap(f.onset_s, f.end_s, g.onset_s, g.end_s, slack_s)
        for g in findings
    )


def merge_events(events: Iterable[Event], slack_s: float = 1.0) -> list[Finding]:
    """Group overlapping events per channel (``slack_s`` tolerates onset disagreement).
    An event does not join a group that holds an earlier event of its own detector,
    which ended before it began (to within ``slack_s``), unless another detector's event
    of the group spans the two (:func:`_told_apart`): the detector told them apart (a
    drift from 100 to 160 s and a new one from 160 s: each detector found both, and the
    slack joined them into one finding that ended at 160 s, the second lost)."""
    by_channel: dict[str, list[Event]] = {}
    for ev in events:
        by_channel.setdefault(ev.channel, []).append(ev)
    # a change a detector saw on one sensor where a fault of another ended: that fault's
    # trace leaving the residual, not this sensor's fault changing (:func:`_other_ended`)
    traces = {
        id(e) for evs in by_channel.values() for e in evs if _other_ended(e, by_channel, slack_s)
    }
    findings: list[Finding] = []
    for channel, evs in by_channel.items():
        evs.sort(key=lambda e: e.onset_s)
        groups: list[list[Event]] = []
        for ev in evs:
            for g in groups:
                if any(
                    _overlap(ev.onset_s, ev.end_s, o.onset_s, o.end_s, slack_s) for o in g
                ) and not _told_apart(ev, g, slack_s, id(ev) in traces):
                    g.append(ev)
                    break
            else:
                groups.append([ev])
        changes = {
            (e.detector, e.evidence["changed_at_s"])
            for e in evs
            if "changed_at_s" in e.evidence and id(e) not in traces
        }
        for g in groups:
            # the events of detectors that saw this fault change into the next (their
            # event ends where their next begins) lead: one that did not averaged the two
            split = [e for e in g if e.end_s is not None and (e.detector, e.end_s) in changes]
            lead = _lead(split or g, slack_s)
            detectors = sorted({e.detector for e in g})
            # independent detectors agreeing raise the confidence: 1 - prod(1 - c_i)
            miss = 1.0
            for d in detectors:
                miss *= 1.0 - max(e.confidence for e in g if e.detector == d)
            evidence: dict[str, Any] = {"detectors": detectors, "tests": {}}
            # each detector's evidence is that of one of its events: the lead's for its
            # detector, else the detector's first (a detector's later stretch, kept
            # last, showed a first alarm after the end the lead gave)
            for e in [lead, *(x for x in g if x is not lead)]:
                tests = e.evidence.get("tests")
                if tests:
                    evidence["tests"].setdefault(e.detector, tests)
                extra = {k: v for k, v in e.evidence.items() if k != "tests"}
                if extra:
                    evidence.setdefault("by_detector", {}).setdefault(e.detector, extra)
            findings.append(
                Finding(
                    channel=channel,
                    type=lead.type,
                    onset_s=lead.onset_s,
                    end_s=lead.end_s,
                    magnitude=dict(lead.magnitude),
                    confidence=float(1.0 - miss),
                    detector=lead.detector,
                    evidence=evidence,
                    events=list(g),
                )
            )
    findings.sort(key=lambda f: (f.onset_s, f.channel))
    return findings


def _other_ended(e: Event, by_channel: dict[str, list[Event]], slack_s: float) -> bool:
    """Whether ``e`` is a part from a change (evidence ``changed_at_s``) that its detector
    saw within ``slack_s`` of where an event on another channel, under way since more
    than ``slack_s`` before, ended: the other sensor's fault left the residual of ``e``'s
    sensor there (a detector that models the two together carries each fault into the
    other's residual), so the change is that fault's end, not this sensor's fault
    changing.

    An offset on s0 from 100 to 200 s and one on s3 from 150 to 250 s (6 floors, seed 3):
    the bank and the equivalent model saw s3's fault whole, 150.0-250.0 s (offsets 3.91
    and 3.85 for 3.85 injected); the detection filter saw it change at 200.13 s, where
    s0's ended (the equivalent model's s0 event ended at 200.0 s). Its part before the
    change (3.66: s0's fault in it) led, the finding ended at 200.13 s, and the part
    after it was taken for s0's fault, whose end the detectors had not yet agreed on."""
    at = e.evidence.get("changed_at_s")
    if at is None:
        return False
    return any(
        o.end_s is not None and abs(o.end_s - at) <= slack_s and o.onset_s < at - slack_s
        for channel, evs in by_channel.items()
        if channel != e.channel
        for o in evs
    )


def _told_apart(e: Event, group: list[Event], slack_s: float, trace: bool = False) -> bool:
    """Whether ``e``'s detector has an earlier event in ``group`` that ended before ``e``
    began, with no event of another detector in ``group`` spanning the two (from before
    the first's end to ``slack_s`` past ``e``'s onset): one fault that a detector saw in
    stretches, while another saw it whole, stays one finding; not so where ``e`` begins
    at a change of the fault its detector found (evidence ``changed_at_s``), unless that
    change is another sensor's fault ending (``trace``, :func:`_other_ended`): then
    the detectors that saw the fault whole across it keep it one finding."""

    def spans(x: Event, o: Event) -> bool:
        return (
            x.detector != e.detector
            and o.end_s is not None
            and x.onset_s <= o.end_s
            and (x.end_s is None or x.end_s >= e.onset_s + slack_s)
        )

    if e.evidence.get("changed_at_s") is not None and not trace:  # the fault changed
        return any(_after(e, o, slack_s) for o in group)
    return any(_after(e, o, slack_s) and not any(spans(x, o) for x in group) for o in group)


def _after(e: Event, o: Event, slack_s: float) -> bool:
    """``e`` is a later event of ``o``'s detector on its channel: it begins once ``o``
    has ended (a detector's events on a channel are disjoint; ``slack_s``: an onset
    traced back a little before the other's end)."""
    return (
        e.detector == o.detector
        and o.end_s is not None
        and e.onset_s >= o.onset_s
        and e.onset_s > o.end_s - slack_s
    )


def _lead(group: list[Event], slack_s: float = 1.0) -> Event:
    """The event a finding reports: the most confident of the type that the detectors,
    each with the confidence of its own most confident event, vote for. One confident
    detector misled (a second fault blurring its shape, say) does not outvote two that
    agree.

    An event that begins after another event of the group had alarmed, and ends within
    that event's span, saw only the later part of the fault, which the other's shape
    was fitted on as well: alone in its type, it does not vote (a slow drift that one
    detector traces from its start, and another catches late, at a level it reads as an
    offset). Two detectors that agree on the type vote, late or not: one detector's
    earlier alarm does not overrule them (an early false alarm whose shape then takes
    in the fault). The event that alarmed first is never such a tail, so some event
    always votes.

    Of the winning type's events, one that began after another of that type had alarmed
    does not lead, however confident (:func:`_late`): the earlier event traced the fault
    from its start, the late one saw only its later part, so its onset, end and magnitude
    are the earlier one's. Unless the late events come from more detectors than the
    early ones: detectors that agree on a later start outweigh one early alarm (which
    may be a false alarm whose shape took in the fault), and the most confident event
    leads. A detector with an early event is not among the late ones: its later stretch
    is the same fault seen again, not a later start. Stretches (:func:`_fragment`) are
    set aside only after that count, among the events that may lead.

    Confidences that saturate differ in their fifth decimal: a half-size drift traced by
    the bank from 720.9 s to its end at 960.0 s (rate 0.0022 per s, confidence 0.74997)
    and caught by the equivalent model at 834.4 s with no end and a rate of -0.0014
    (0.74999) was reported as the model's.

    Votes within :data:`VOTE_TIE` of each other are a tie, which goes to the event that
    alarmed first (then to the most confident of those that alarmed within ``slack_s``
    of it), for the same reason: the same drift, with the model's stretch then read as
    an offset of 0.14 (its line meeting zero long after its onset: no drift), outvoted
    the bank's drift by 0.749997 to 0.749966."""

    def alone(e: Event) -> bool:
        return not any(o.detector != e.detector and o.type is e.type for o in group)

    voters = [
        e
        for e in group
        if not (alone(e) and any(_tail_of(o, e, slack_s) for o in group if o is not e))
    ]
    voters = voters or group  # pragma: no cover - an onset after its own first alarm
    best: dict[str, Event] = {}
    for e in voters:
        if e.detector not in best or e.confidence > best[e.detector].confidence:
            best[e.detector] = e
    votes: dict[Any, float] = {}
    for e in best.values():
        votes[e.type] = votes.get(e.type, 0.0) + e.confidence
    winner = max(votes, key=lambda t: votes[t])
    top = max(votes.values())
    tied = {t for t, v in votes.items() if v >= top * (1.0 - VOTE_TIE)}
    if len(tied) > 1:
        # a tie: the event that alarmed first (it traced the fault from its start), the
        # most confident of those that alarmed together
        even = [e for e in voters if e.type in tied]
        first = min(_alarmed(e) for e in even)
        return max((e for e in even if _alarmed(e) <= first + slack_s), key=lambda e: e.confidence)
    leads = [e for e in voters if e.type == winner]
    # early and late are judged on every stretch: a detector that saw the fault from its
    # start, lost it and saw it again agrees on no later start (its later stretch is not
    # a late detector's)
    early = [e for e in leads if not any(_late(e, o, slack_s) for o in leads if o is not e)]
    early_by = {e.detector for e in early}
    late = {e.detector for e in leads if all(e is not x for x in early)} - early_by
    if len(late) > len(early_by):
        early = leads  # they agree on a later start: the early alarm may be a false one
    # then a stretch of the fault its detector saw again after it ended, where another
    # detector saw the fault whole, does not lead (:func:`_fragment`)
    whole = [e for e in early if not _fragment(e, group, slack_s)] or early
    return max(whole, key=lambda e: e.confidence)


def _fragment(e: Event, group: list[Event], slack_s: float) -> bool:
    """``e`` is one stretch of a fault its own detector saw in stretches: a later event
    of its detector in ``group`` begins after ``e`` ended (:func:`_after`), and an event
    of another detector spans ``e``'s end and that later onset (the two stretches are
    one finding only because of it, :func:`_told_apart`) and saw the fault from ``e``'s
    start (its onset no later than ``slack_s`` after ``e``'s first alarm: one that began
    later would report the fault's first seconds nowhere). Its end is where its detector
    lost the fault for a while, not where the fault ended, and its shape was fitted on
    that stretch only; the detector that saw the fault whole gives the finding's period
    and size. A sensor dead from 150 to 200 s (4 floors, one sensor each, seed 107) was
    seen from 150.0 s to 200.0 s by the bank and the detection filter, and by the
    equivalent model from 148.29 to 169.09 s (gain 0.21: the alive readings before the
    freeze in its fit) and again from 170.72 s to 200.0 s: the first stretch, the
    earliest of the events that tied at confidence 1, led, and the finding was a gain
    of 0.21 ending at 169.09 s, the dead readings after it reported nowhere."""
    later = [o for o in group if o is not e and _after(o, e, slack_s)]
    return any(
        x.detector != e.detector
        and x.onset_s <= _alarmed(e) + slack_s
        and x.onset_s <= (e.end_s if e.end_s is not None else x.onset_s)
        and (x.end_s is None or x.end_s >= o.onset_s)
        for o in later
        for x in group
    )


VOTE_TIE = 1e-3
"""Votes within this share of the largest are a tie (:func:`_lead`): confidences saturate
(at 1, or at 0.75 for an unconfirmed bank fault) and then differ in their fourth or fifth
decimal, which is no evidence for either type."""


def _late(e: Event, first: Event, slack_s: float) -> bool:
    """``e`` began more than ``slack_s`` after ``first`` had alarmed: it saw only the later
    part of the fault ``first`` traced from its start."""
    return e.onset_s > _alarmed(first) + slack_s


TAIL_END_SHARE = 0.1
"""How far past another event's end (as a share of its own span) a late event may end and
still count as that event's tail (:func:`_tail_of`): an end is found when the residual
corrected by the event's shape alarms, which takes seconds for a small fault."""


def _tail_of(first: Event, e: Event, slack_s: float) -> bool:
    """``e`` began more than ``slack_s`` after ``first`` alarmed and ends within
    ``first``'s span (``first`` open, or ``e`` closed by its end), or after it by no more
    than ``slack_s`` or :data:`TAIL_END_SHARE` of ``e``'s own span, whichever is longer
    (a half-size drift's late offset, fitted on the drift's last 80-110 s, ended 1.4 and
    5.4 s after the drift's end, the time its detector took to see the end)."""
    if not _late(e, first, slack_s):
        return False
    if first.end_s is None:
        return True
    if e.end_s is None:
        return False
    return e.end_s - first.end_s <= max(slack_s, TAIL_END_SHARE * (e.end_s - e.onset_s))


def one_fault_at_a_time(
    findings: list[Finding],
    coupled: Callable[[str, str, str], bool],
    slack_s: float = 1.0,
) -> tuple[list[Finding], list[str]]:
    """The findings without those that are one detector's misattribution of a fault the
    other detectors agree on, and a note for each of those.

    The seed methods isolate one sensor fault at a time among the sensors they model
    together. A fault spreads into the estimates of the sensors it is modelled with, and
    a detector can name one of those instead (a drift on s15 that the detection filter,
    alone, put on s11 while the bank and the observers named s15). So a finding that
    rests on a single detector's attribution is taken for the fault of another finding
    when that one is reported by more detectors (a detector whose alarm law 0 takes for
    that fault counts: :func:`_support`), or, when the single detector did not confirm
    its own attribution (:func:`_confirmation`: the bank's estimators that use the sensor
    stayed consistent), by a detector that confirmed it (a drift on s1 of a 3-floor
    building that only the equivalent model named, confirmed by the residuals of s2 and
    s3, while the bank put it, unconfirmed, on s0, then s3 and s2: ``sweep_isolation.py
    --floors 3 --until 0.8``, seed 35), on another channel the single detector
    models jointly with it (``coupled(detector, channel, other)``), and is already under
    way when the single detector's first alarm rang (that finding's fitted onset or first
    alarm, whichever is earlier, no later than ``slack_s`` after it, its end, or the end
    the single detector saw if later (:func:`_not_over`), not before it). The agreed
    fault counts from its onset because a sensor's fault can show in a
    jointly modelled sensor's residual before it shows in its own: a drift on s1 of a
    3-floor building turned up, sign turned, in the bank's estimate of its floor partner
    s0 at 741.5 s, while the detectors that named s1, from 720.4 s, first alarmed at
    754.1 s.

    A finding rests on a single detector's attribution when it has one detector, or when
    all its detectors but one are *followers*: detectors that had reported the other
    fault first (their first alarm on it no later than ``slack_s`` after their first on
    this one) and model the two sensors together, so that their part in this finding is
    that fault spreading, not evidence of its own (a drift on s15 that the bank and the
    observers reported, the detection filter put on s11 47 s later, and the bank, as the
    drift grew, on s11 too, 165 s after its own s15). A finding every detector of which
    followed (each reported the other fault, then this one) is kept: they all moved on,
    as they would for a second fault. So is one that a follower isolated (evidence
    ``isolated``: the bank, having corrected the other fault's sensor, saw the estimator
    that leaves this sensor out stay consistent while one that uses it did not), alone
    or beside others: a gain on s11 from 840 s that only the bank reported, isolated,
    360 s after its own gain on s10, which all three detectors had reported from 480 s
    (16 channels, two lasting faults, ``sweep_isolation.py --onset 0.4 --second 0.7``,
    seed 16); a drift on s4 from 840 s that the bank isolated after its own gain on
    s5, and that the equivalent model reported too (seed 19).

    First alarms, not fitted onsets: a drift's onset is extrapolated back to where its
    line meets zero, tens of seconds before anything alarmed (the detection filter's
    misplaced drifts in the sweep were fitted up to 11 s before the agreed one's onset,
    and first alarmed 40-50 s after it). The note names the detector, the type, the
    sensor, the onset, the fault it was taken for and the followers.

    A detector whose events in a finding none of the sensors they assist confirmed, on a
    sensor whose assistant other detectors had already found faulty, is not counted as
    the finding's own (:func:`_assistants_faults`): a finding that rests on such
    detectors alone is taken for the assistant's fault, with a note, and one that rests
    on them and a single other detector is taken for another finding as above."""
    # each finding taken for others: (the findings it is taken for, the note)
    drops: dict[int, tuple[list[Finding], str]] = {}
    explains = [_assistants_faults(f, findings, slack_s) for f in findings]
    support = _support(findings, explains)
    for f, explained in zip(findings, explains, strict=True):
        if explained and len(explained) == len(_detectors(f)):
            drops[id(f)] = (
                list(explained.values()),
                f"{f.detector}'s {f.type.value} fault on {f.channel} at "
                f"{seconds_text(f.onset_s)} s not "
                f"reported: {_explained_text(explained)}: taken for that fault (law 0), one "
                "fault at a time",
            )
            continue
        taken = _taken_for(f, findings, coupled, slack_s, set(explained), support)
        if taken is None:
            within = _ended_with(f, findings, coupled, slack_s)
            if within is None:
                continue
            drops[id(f)] = (
                [within],
                f"{f.detector}'s {f.type.value} fault on {f.channel} at "
                f"{seconds_text(f.onset_s)} s not "
                f"reported: it began while {f.detector} had the {within.type.value} fault "
                f"on {within.channel} (from {seconds_text(within.onset_s)} s) under way and ended "
                f"when that one did, on sensors {f.detector} models together: taken for "
                "that fault, one fault at a time",
            )
            continue
        cause, single, followers = taken
        note = (
            f"{single}'s {f.type.value} fault on {f.channel} at {seconds_text(f.onset_s)} s not "
            f"reported: it began while the {cause.type.value} fault on {cause.channel} "
            f"(from {seconds_text(cause.onset_s)} s, found by {', '.join(_detectors(cause))}"
            f"{_through_text(cause, findings, explains)}) "
            f"was under way, and {single} models the two sensors together: taken for that "
            "fault, one fault at a time"
        )
        if len(support[id(cause)]) < 2:
            note += (
                f" ({single} did not confirm its fault on {f.channel}; "
                f"{', '.join(_detectors(cause))} confirmed the one on {cause.channel})"
            )
        others = [d for d in followers if d != single]
        if others:
            note += (
                f" ({', '.join(others)} reported {f.channel} too, after reporting {cause.channel})"
            )
        if explained:
            note += f" ({_explained_text(explained)})"
        drops[id(f)] = ([cause], note)
    return _resolve_drops(findings, drops, support, slack_s)


def ends_of_later_faults(
    findings: list[Finding],
    coupled: Callable[[str, str, str], bool],
    slack_s: float = 1.0,
) -> list[str]:
    """Each finding whose end some of its detectors saw only where a later fault of
    another sensor ended takes its end from its other detectors, and their size where
    they read the same type, with a note; changes ``findings`` in place and returns the
    notes. Its onset and type stay (one detector that saw the end does not overrule two
    that agree on the fault's start and shape).

    A detector that estimates a sensor from others sees a fault of one of those others in
    its residual of the sensor too: when that fault began while the sensor's own was under
    way, the residual stays alarmed until it ends, and the detector's event on the sensor
    ends where the other fault did. An offset on s1 from 100 to 200 s and one on s4 from
    150 to 250 s of a 6-channel building: the bank and the observers saw s1's to 250.1 s,
    the detection filter, which tells the two sensors' directions apart, to 200.0 s; the
    finding, led by the bank, ended at 250.1 s with an offset of 1.84 (3.22 injected).
    An event's end is so explained when it is within ``slack_s`` of where a finding on
    another sensor was last seen (:func:`_same_end`) that began more than ``slack_s`` after
    this one and before that end, and that sensor is ``coupled`` to this one for the
    event's detector. Its end then counts only if no other detector of the finding saw
    the fault end earlier, no earlier than the other fault began (less ``slack_s``), and
    not again on this sensor before the explained end (a detector whose event ended
    there and that then saw this sensor faulty again saw the fault go on), and every
    event of the finding is either so explained or so ended. An end where the other
    fault began counts only when no other detector saw the fault go on past it and two
    detectors saw it: the detection filter, which isolates one fault at a time, can lose
    a fault where a second begins (a gain on s3 from 100 to 200 s and an offset on s0
    from 150 s: it ended the gain at 150.1 s, the observers at 200.8 s, the bank at
    250.1 s), while two that agree saw a fault end where the next began (an offset on s1
    to 200 s and one on s4 from 200 s: the filter and the observers ended s1's at 200 s,
    the bank at s4's end)."""
    notes: list[str] = []
    for f in findings:
        if "frozen" in f.evidence:
            continue  # its readings decided its period (analyzer.diagnosis.stuck)
        explained = _explained_by_later(f, findings, coupled, slack_s)
        if not explained:
            continue
        later = min(explained.values(), key=lambda g: g.onset_s)
        ended = _ended_before(f, explained, later, findings, slack_s)
        if not ended:
            continue
        lead = _lead(ended, slack_s)
        assert lead.end_s is not None  # (ended: the events of ``ended`` all have an end)
        was, size = f.end_s, ""
        f.end_s = lead.end_s
        if lead.type is f.type and lead.magnitude != f.magnitude:
            # its size over the fault's own stretch (the others' took in the later one)
            f.magnitude, f.detector = dict(lead.magnitude), lead.detector
            size = f", and its size is theirs ({_sized(f.magnitude)})"
        others = sorted({e.detector for e in f.events if id(e) in explained})
        notes.append(
            f"{f.type.value} fault on {f.channel}: ended at {seconds_text(lead.end_s)} s as "
            f"{', '.join(sorted({e.detector for e in ended}))} saw it{size}; "
            f"{', '.join(others)} saw it to "
            + ("the record's end" if was is None else f"{seconds_text(was)} s")
            + f", where the {later.type.value} fault on {later.channel} (from "
            f"{seconds_text(later.onset_s)} s) ended, a sensor they model together with {f.channel}"
        )
    return notes


def ends_hidden_by_later(
    findings: list[Finding],
    coupled: Callable[[str, str, str], bool],
    slack_s: float = 1.0,
) -> list[tuple[Finding, Finding]]:
    """The findings whose end no detector saw, each with the later fault that hid it: the
    finding ends where a later fault of a coupled sensor was last seen, as one of its
    events did (:func:`ends_of_later_faults`' explained ends), and no other end of its
    events counted there (one detector that lost the fault where the later one began,
    say). Run after :func:`ends_of_later_faults`; a frozen sensor's period is its
    readings'.

    A gain on s1 from 100 to 200 s and an offset on s4 from 150 to 250 s: the bank and
    the observers saw the gain to 250.1 s, the detection filter lost it at 150.1 s, where
    the offset began (both faults at once: every filter off its direction); no detector
    that models s1 with s4 sees s1's fault end while s4's goes on.

    So too a finding that ends inside such a later fault (more than ``slack_s`` after it
    began and before it was last seen) where another of its detectors saw it end
    elsewhere (not where the later fault was last seen): the detectors disagree on an
    end the later fault blurs for each of them.
    An offset on s0 from 100 to 200 s and one on s1, the next floor's, from 150 to 250 s
    (seed 6): the detection filter saw s0's end at 200.0 s, the bank, leading, at
    225.8 s, where its residual of s0 with s1's fault in it fell under its threshold.

    And a finding that ends (within ``slack_s``) where a later fault of a coupled sensor
    began, as an event of a detector modelling the two did, while another of its events
    went on past that end: the first fault ended where the second began, or was lost
    there, and only a search without the second's sensor tells which. A drift on s0 from
    100 to 200 s and an offset on s3 from 150 to 250 s (seed 12 of
    ``sweep_two_faults.py``): the bank and the detection filter ended the drift at
    150.08 s, the observers at 200.01 s; a gain on s5 from 100 to 200 s beside an offset
    on s2 from 150 s (seed 17): the filter and the observers ended it at 150.14 s, the
    bank at 250.13 s, where s2's ended."""
    hidden: list[tuple[Finding, Finding]] = []
    for f in findings:
        if "frozen" in f.evidence:
            continue
        explained = _explained_by_later(f, findings, coupled, slack_s)
        ends = [e for e in f.events if id(e) in explained and e.end_s == f.end_s]
        if ends:
            hidden.append((f, explained[id(ends[0])]))
            continue
        inside = [g for g in findings if _ends_inside(f, g, coupled, slack_s)]
        if inside and any(e.end_s != f.end_s and id(e) not in explained for e in f.events):
            hidden.append((f, min(inside, key=lambda g: g.onset_s)))
            continue
        began = [g for g in findings if _ends_where_began(f, g, coupled, slack_s)]
        end = f.end_s
        if (
            began
            and end is not None
            and any(e.end_s is None or e.end_s > end + slack_s for e in f.events)
        ):
            hidden.append((f, min(began, key=lambda g: g.onset_s)))
    return hidden


def onsets_hidden_by_earlier(
    findings: list[Finding],
    coupled: Callable[[str, str, str], bool],
    slack_s: float = 1.0,
) -> list[tuple[Finding, Finding]]:
    """The findings whose onset may be an earlier fault's trace, each with that fault:
    the finding's lead event (its onset) began while a fault of another sensor, which
    its detector models with this one, was under way (begun more than ``slack_s``
    before, not yet ended), and another detector saw this finding begin more than
    ``slack_s`` later. Run after :func:`ends_of_later_faults`; a frozen sensor's period
    is its readings'.

    A detector that estimates a sensor from another sees that one's fault in its
    residual of the sensor, and can alarm on the sensor early, its fault's shape fitted
    over both: an offset on s2 from 150 to 200 s inside one on s5 from 100 to 250 s
    (seed 17 of ``sweep_two_faults.py``, ``nested``) was reported from the bank's
    142.89 s to 215.04 s (offset 2.33 for 3.43), the observers' 150.0-200.0 s outvoted
    one to one; an offset on s4 from 150 to 250 s beside one on s3 from 100 to 200 s
    (seed 15, ``neighbour``) from the bank's 111.56 s to 257.57 s (offset -0.08 for
    4.03), the detection filter's 150.0-250.0 s. Without the earlier fault's sensor the
    bank, the filter and the observers all saw 150.0-200.0 s and 150.0-250.0 s: the
    pipeline searches without it.

    The lead is the event that gives the onset, whichever detector the finding names
    after :func:`ends_of_later_faults` gave it another's end: a third fault, an offset
    on s3 from 190 to 290 s beside that nested pair (seed 17), was the bank's from
    120.57 s, the detection filter's from 190.0 s, and named the filter's (its end)."""
    hidden: list[tuple[Finding, Finding]] = []
    for f in findings:
        if "frozen" in f.evidence:
            continue
        # the detectors whose events give the onset (the finding's ``detector`` may be
        # another's since: the one that gave its end, :func:`ends_of_later_faults`)
        leads = {e.detector for e in f.events if e.onset_s == f.onset_s} or {f.detector}
        if not any(e.detector not in leads and e.onset_s > f.onset_s + slack_s for e in f.events):
            continue
        under = [
            g
            for g in findings
            if g.channel != f.channel
            and g.onset_s + slack_s < f.onset_s
            and (g.end_s is None or f.onset_s < g.end_s)
            and any(coupled(d, f.channel, g.channel) for d in leads)
        ]
        if under:
            hidden.append((f, min(under, key=lambda g: g.onset_s)))
    return hidden


def _ends_where_began(
    f: Finding, g: Finding, coupled: Callable[[str, str, str], bool], slack_s: float
) -> bool:
    """Whether ``f`` ends within ``slack_s`` of where ``g``, a later fault of another
    sensor (begun more than ``slack_s`` after ``f``), began, with a detector of ``f``'s
    event that gives that end modelling the two sensors together: the first fault ended
    where the second began, or was lost there (both on at once)."""
    if g.channel == f.channel or f.end_s is None or not f.onset_s + slack_s < g.onset_s:
        return False
    if abs(f.end_s - g.onset_s) > slack_s:
        return False
    return any(e.end_s == f.end_s and coupled(e.detector, f.channel, g.channel) for e in f.events)


def _ends_inside(
    f: Finding, g: Finding, coupled: Callable[[str, str, str], bool], slack_s: float
) -> bool:
    """Whether ``f`` ends inside ``g``, a later fault of another sensor (begun more than
    ``slack_s`` after ``f``), more than ``slack_s`` after ``g`` began and before ``g``
    was last seen (the latest end of its events, open when one is), with a detector of
    ``f``'s event that gives that end modelling the two sensors together."""
    if g.channel == f.channel or f.end_s is None or not g.events:
        return False
    if not f.onset_s + slack_s < g.onset_s < f.end_s - slack_s:
        return False
    ends = [e.end_s for e in g.events]
    last = None if any(x is None for x in ends) else max(x for x in ends if x is not None)
    if last is not None and f.end_s >= last - slack_s:
        return False
    return any(e.end_s == f.end_s and coupled(e.detector, f.channel, g.channel) for e in f.events)


def _sized(magnitude: dict[str, float]) -> str:
    return ", ".join(f"{k} {v:.4g}" for k, v in magnitude.items())


def _explained_by_later(
    f: Finding,
    findings: list[Finding],
    coupled: Callable[[str, str, str], bool],
    slack_s: float,
) -> dict[int, Finding]:
    """The events of ``f`` (by ``id``) whose end a later finding on a coupled sensor
    explains (:func:`ends_of_later_faults`), each with that finding."""
    explained: dict[int, Finding] = {}
    for e in f.events:
        for g in findings:
            if (
                g.channel != f.channel
                and f.onset_s + slack_s < g.onset_s
                and _same_end(e, g, slack_s)
                and (e.end_s is None or g.onset_s < e.end_s)
                and coupled(e.detector, f.channel, g.channel)
            ):
                explained[id(e)] = g
                break
    return explained


def _ended_before(
    f: Finding,
    explained: dict[int, Finding],
    later: Finding,
    findings: list[Finding],
    slack_s: float,
) -> list[Event]:
    """The events of ``f`` that saw it end before the ``explained`` ends and no earlier
    than the ``later`` fault began, when they count (:func:`ends_of_later_faults`), else
    none."""
    last = min(float("inf") if e.end_s is None else e.end_s for e in f.events if id(e) in explained)
    ended = [
        e
        for e in f.events
        if id(e) not in explained
        and e.end_s is not None
        and later.onset_s - slack_s <= e.end_s < last - slack_s
        and not _again(e, findings, f.channel, last, slack_s)
    ]
    if len(ended) + len(explained) < len(f.events):
        return []  # an event that saw the fault go on, beyond explaining
    past = [e for e in ended if e.end_s is not None and e.end_s > later.onset_s + slack_s]
    if past:
        return past  # they saw it go on after the other began: not lost there
    if len({e.detector for e in ended}) < 2:
        return []  # one detector that lost the fault when the other began
    return ended


def _same_end(e: Event, g: Finding, slack_s: float) -> bool:
    """Whether ``e`` ended within ``slack_s`` of where ``g`` was last seen: the latest end
    its detectors saw (or both none). Not the end ``g`` reports, nor any of its events':
    a detector's event on ``g``'s sensor can end where ``e``'s fault did, having seen that
    fault's end there (a drift on s1 to 200 s and an offset on s4 from 150 to 250 s: the
    detection filter saw the drift to 200.0 s and its part of s4's offset to 200.1 s;
    when that part led s4's finding, the finding ended at 200.1 s, and the observers'
    and the filter's right ends of the drift were taken for it)."""
    ends = [o.end_s for o in g.events]
    if not ends:
        return False
    if e.end_s is None or any(x is None for x in ends):
        return e.end_s is None and any(x is None for x in ends)
    return abs(max(x for x in ends if x is not None) - e.end_s) <= slack_s


def _again(e: Event, findings: list[Finding], channel: str, until: float, slack_s: float) -> bool:
    """Whether ``e``'s detector saw ``channel`` faulty again after ``e`` ended, before
    ``until``."""
    assert e.end_s is not None
    return any(
        o.detector == e.detector and e.end_s - slack_s < o.onset_s < until
        for g in findings
        if g.channel == channel
        for o in g.events
        if o is not e
    )


def _resolve_drops(
    findings: list[Finding],
    drops: dict[int, tuple[list[Finding], str]],
    support: dict[int, set[str]],
    slack_s: float = 1.0,
) -> tuple[list[Finding], list[str]]:
    """The findings :func:`one_fault_at_a_time` keeps and its notes: a finding is left out
    only for a finding that stays, directly or through findings left out for it. Where
    none of its chains ends at one that stays (two findings each taken for the other),
    the best supported of those is kept (more
    detectors agreeing, then more of its own, then the higher confidence, then the
    earlier): a drift on s4 of a 6-channel building that the bank reported and one on
    s5 that the detection filter reported were each taken for the other, and neither
    was reported (exit 0; 4 of 24 drifts on healthy simulated records)."""
    by_id = {id(f): f for f in findings}
    dropped = set(drops)
    restored: list[Finding] = []
    while True:
        # left out for good: taken for a finding that stays, or for one left out for good
        # (a lone drift on a floor partner taken for the fault, and an offset taken for
        # that drift, are both that fault's doing)
        settled: set[int] = set()
        grew = True
        while grew:
            grew = False
            for k in dropped - settled:
                if any(id(c) not in dropped or id(c) in settled for c in drops[k][0]):
                    settled.add(k)
                    grew = True
        orphans = dropped - settled
        if not orphans:
            break

        def in_cycle(k: int, orphans: set[int] = orphans) -> bool:
            seen, todo = set(), [id(c) for c in drops[k][0]]
            while todo:
                j = todo.pop()
                if j == k:
                    return True
                if j in orphans and j not in seen:
                    seen.add(j)
                    todo.extend(id(c) for c in drops[j][0])
            return False

        best = max(
            (by_id[k] for k in orphans if in_cycle(k)),
            key=lambda f: (len(support[id(f)]), len(_detectors(f)), f.confidence, -f.onset_s),
        )
        dropped.discard(id(best))
        restored.append(best)
    for k in sorted(dropped, key=lambda k: by_id[k].onset_s):
        f = by_id[k]
        roots = _roots(k, drops, dropped)
        if roots and all(_over_before(r, f, slack_s) for r in (by_id[j] for j in roots)):
            dropped.discard(k)  # the sensor's own fault again, not the other's doing
    notes = [drops[id(f)][1] for f in findings if id(f) in dropped]
    for f in restored:
        causes = ", ".join(
            f"{c.channel} (from {seconds_text(c.onset_s)} s)" for c in drops[id(f)][0]
        )
        notes.append(
            f"the {f.type.value} fault on {f.channel} from {seconds_text(f.onset_s)} s is reported "
            f"although it could be taken for the fault on {causes}: that one was taken for "
            "it in turn (directly or through others), and of them this one has the most "
            "support"
        )
    return [f for f in findings if id(f) not in dropped], notes


def _roots(k: int, drops: dict[int, tuple[list[Finding], str]], dropped: set[int]) -> set[int]:
    """The findings that stay at the ends of the chains of findings taken for others
    that start at the dropped finding ``k``."""
    roots, seen, todo = set(), {k}, [id(c) for c in drops[k][0]]
    while todo:
        j = todo.pop()
        if j in seen:
            continue
        seen.add(j)
        if j in dropped:
            todo.extend(id(c) for c in drops[j][0])
        else:
            roots.add(j)
    return roots


def _over_before(r: Finding, f: Finding, slack_s: float) -> bool:
    """``r`` is an earlier fault of ``f``'s own sensor, over before ``f`` began: ``f``,
    taken through other sensors' findings for ``r``, is the sensor's fault again (a drift
    on s0 from 100 to 160 s and a new one from 160 s: the second was taken for an offset
    the bank put on s1 during the first, which was taken for the first)."""
    return r.channel == f.channel and r.end_s is not None and r.end_s <= f.onset_s + slack_s


def _taken_for(
    f: Finding,
    findings: list[Finding],
    coupled: Callable[[str, str, str], bool],
    slack_s: float,
    explained: set[str],
    support: dict[int, set[str]],
) -> tuple[Finding, str, list[str]] | None:
    """``(the finding f is taken for, its single detector, its followers)`` when
    :func:`one_fault_at_a_time` takes ``f`` for another finding, else None. The
    ``explained`` detectors (:func:`_assistants_faults`) do not count as its own;
    ``support``: the detectors that agree on each finding (:func:`_support`)."""
    detectors = _detectors(f)
    unconfirmed = len(detectors) == 1 and _confirmation(f) is False
    for g in findings:
        if g is f or g.channel == f.channel:
            continue
        if len(support[id(g)]) < 2 and not (unconfirmed and _confirmation(g)):
            continue
        followers = [
            d
            for d in detectors
            if d in _detectors(g)
            and coupled(d, f.channel, g.channel)
            and _first_alarm(g, d) <= _first_alarm(f, d) + slack_s
        ]
        if any(_isolated(f, d) for d in followers):
            continue  # one reported g first, then isolated this one: a second fault
        own = [d for d in detectors if d not in followers and d not in explained]
        if len(own) > 1 or (not own and len(detectors) > 1):
            continue
        single = own[0] if own else detectors[0]
        t = _first_alarm(f, single)
        if (
            min(g.onset_s, _first_alarm(g)) <= t + slack_s
            and _not_over(g, single, t - slack_s)
            and not _over_until(g, f, single, t, slack_s)
            and coupled(single, f.channel, g.channel)
        ):
            return g, single, followers
    return None


def _confirmation(f: Finding) -> bool | None:
    """Whether a detector confirmed ``f`` on its sensor: True when one of its events was
    confirmed (the bank's ``isolated``, the detection filter's ``confirmed``, the
    equivalent model's ``confirmed_by`` a sensor it assists), False when every event says
    it was not, None when none says either way."""
    said = []
    for e in f.events:
        ev = e.evidence
        if "isolated" in ev:
            said.append(ev["isolated"] is True)
        elif "confirmed" in ev:
            said.append(ev["confirmed"] is True)
        elif "confirmed_by" in ev:
            said.append(bool(ev["confirmed_by"]))
    return any(said) if said else None


def _isolated(f: Finding, detector: str) -> bool:
    """Whether ``detector`` confirmed each of its events in ``f`` on that sensor alone
    (evidence ``isolated``)."""
    mine = [e for e in f.events if e.detector == detector]
    return bool(mine) and all(e.evidence.get("isolated") is True for e in mine)


def _support(findings: list[Finding], explains: list[dict[str, Finding]]) -> dict[int, set[str]]:
    """The detectors that agree on each finding (by ``id``): its own, and those whose part
    in another finding its fault explains (law 0, :func:`_assistants_faults`). A detector
    that alarmed on a sensor modelled from the faulty one, unconfirmed, saw that fault
    too: a gain of 1.15 on s0 of a 16-channel building that only the bank named, and
    that the equivalent model saw in s1's residual (s1 modelled from s0), is the fault
    two detectors agree on (``sweep_isolation.py --scale 0.5``, seed 7), and the
    detection filter's lone 2 s ``other`` on s2, 409 s into it, is taken for it. Agree
    on, not found: the finding's ``evidence.detectors`` stays the detectors that reported
    a fault on its sensor, and a note names such a detector apart, with the sensor it
    alarmed on (:func:`_through_text`)."""
    support = {id(g): set(_detectors(g)) for g in findings}
    for explained in explains:
        for d, g in explained.items():
            support[id(g)].add(d)
    return support


def _ended_with(
    f: Finding,
    findings: list[Finding],
    coupled: Callable[[str, str, str], bool],
    slack_s: float,
) -> Finding | None:
    """The finding whose fault ``f`` lasted only as long as, or None.

    A finding that rests on one detector, began while that detector had a fault on a
    jointly modelled sensor under way, and ended within ``slack_s`` of the end that
    detector saw for that fault, was that fault showing in the other sensor's estimate
    (a detector that corrects the faulty sensor's readings by the fault's shape until it
    sees the fault end alarms on a neighbour between the real end and the one it sees:
    16-channel seed 7 of ``sweep_isolation.py --until 0.8 --scale 0.5``, a gain of 1.15
    on s0 to 960 s that the bank saw end at 967.7 s, and a bank gain on s1 from 963.4 to
    968.3 s). A second fault that outlasts the first, or one without an end, is not
    affected; neither is one that another detector reports too, nor one the detector
    isolated (evidence ``isolated``) that began while the other detectors still saw the
    first fault under way (:func:`_seen_over`): that one is a fault of its own, which kept
    the detector's estimate of the first sensor alarmed to its end (a gain on s2 from 100
    to 200 s and an offset on s5 from 150 to 250 s of a 6-channel building: the bank saw
    the gain to 250.1 s, the observers to 200.0 s; the bank's isolated offset on s5,
    reported by it alone, was taken for the gain and lost)."""
    detectors = _detectors(f)
    if len(detectors) != 1 or f.end_s is None:
        return None
    d = detectors[0]
    t = _first_alarm(f, d)
    for g in findings:
        mine = [e for e in g.events if e.detector == d]
        if g is f or g.channel == f.channel or not mine or not coupled(d, f.channel, g.channel):
            continue
        ends = [e.end_s for e in mine]
        if any(end is None for end in ends):
            continue
        end = max(e for e in ends if e is not None)
        if _isolated(f, d) and f.onset_s < _seen_over(g, d) - slack_s:
            continue  # a second fault that kept d's estimate of g alarmed (above)
        if min(_alarmed(e) for e in mine) < t and f.onset_s < end and abs(f.end_s - end) <= slack_s:
            return g
    return None


def _seen_over(g: Finding, detector: str) -> float:
    """When the detectors of ``g`` other than ``detector`` saw it end (the latest of
    their ends; infinite when one saw no end; minus infinite when none but ``detector``
    saw ``g``: the bank's isolated gain on s1 during its own gain on s0, which only it
    reported, is that gain's end seen on s1, as before)."""
    ends = [e.end_s for e in g.events if e.detector != detector]
    if not ends:
        return float("-inf")  # only ``detector`` saw it: nothing says it went on
    if any(end is None for end in ends):
        return float("inf")
    return max(end for end in ends if end is not None)


def _not_over(g: Finding, detector: str, t: float) -> bool:
    """Whether ``g`` was still under way at ``t``, as the finding saw it or as
    ``detector`` did: a detector that saw ``g`` end later than the others (the bank sees
    a half-size gain's end some seconds late, and corrects the sensor's readings by the
    gain until then) still had it under way. (8-channel seed 13 of
    ``sweep_isolation.py --until 0.8 --scale 0.5``: a gain on s1 that all three
    detectors named, ended at 960.0 s by the detection filter and the observers and at
    965.1 s by the bank, whose estimator of the floor partner s0 alarmed from 961.8 to
    965.2 s.)"""
    ends = [g.end_s, *(e.end_s for e in g.events if e.detector == detector)]
    return any(end is None or end >= t for end in ends)


def _over_until(g: Finding, f: Finding, detector: str, t: float, slack_s: float) -> bool:
    """Whether ``detector``, which first alarmed on ``f`` at ``t``, saw ``g`` end before:
    its events on ``g`` all ended by ``t`` (within ``slack_s``), and the other events of
    ``g`` that went on past ``t`` (one at least) all ended where ``f`` was last seen
    (:func:`_same_end`): there the other detectors' estimates of ``g``'s sensor took in
    ``f``'s fault, which began as ``g``'s ended (:func:`ends_of_later_faults` moves such
    an end). An offset on s3 from 100 to 200 s and one on s0 from 150 to 250 s of a
    6-channel building: the detection filter and the observers saw s3's end at 200.0 s,
    the bank at 250.1 s; the filter's offset on s0 from 200.07 s to 250.0 s, reported by
    it alone, was taken for s3's fault, and s0 had no finding."""
    mine = [e.end_s for e in g.events if e.detector == detector]
    if not mine or any(end is None or end > t + slack_s for end in mine):
        return False
    on = [
        e for e in g.events if e.detector != detector and (e.end_s is None or e.end_s > t + slack_s)
    ]
    return bool(on) and all(_same_end(e, f, slack_s) for e in on)


def _assistants_faults(f: Finding, findings: list[Finding], slack_s: float) -> dict[str, Finding]:
    """The detectors of ``f`` whose part in it the fault of an assistant sensor explains,
    each with the finding on that assistant.

    An observer with assistant sensors (the equivalent model, Wang & Song 2014) sees a
    fault of an assistant in its target's residual too; its own laws then name the
    assistant only if the assistant's residual alarms as well, which it cannot do for a
    sensor the network does not observe. When a detector's events in ``f`` are all
    unconfirmed by a residual of the sensors they assist (``confirmed_by`` empty), and
    other detectors had found one of those events' assistants faulty no later than
    ``slack_s`` after that detector's first alarm on ``f``, and that fault was not over
    then, the other finding stands in for the assistant's alarm: law 0 explains the
    detector's part in ``f`` by it. Two cases of ``sweep_isolation.py --until 0.8 --scale
    0.5``: a gain of 1.15 on a floor's first sensor that the bank named, while the
    equivalent model, which models the floor's other sensor from the first, put a gain
    of 0.875 (about 1 / 1.15) on that one 0.3 s later (16 channels, seed 7); and a gain
    on s5 that the bank named at 722 s, while the detection filter put an inverse gain
    on s4 at 725 s and the equivalent model, modelling s4 from s5, alarmed on s4 in three
    unconfirmed stretches from 729 s (6 channels, seed 1)."""
    explained: dict[str, Finding] = {}
    for d in _detectors(f):
        mine = [e for e in f.events if e.detector == d]
        if not mine or any(e.evidence.get("confirmed_by", True) for e in mine):
            continue  # confirmed, or a detector that does not report confirmation
        assistants = {a for e in mine for a in e.evidence.get("assistants", ())}
        t = _first_alarm(f, d)
        for g in findings:
            others = [e for e in g.events if e.detector != d]
            if (
                g is not f
                and g.channel in assistants
                and others
                and min(_alarmed(e) for e in others) <= t + slack_s
                and (g.end_s is None or g.end_s >= t - slack_s)
            ):
                explained[d] = g
                break
    return explained


def _through_text(
    cause: Finding, findings: list[Finding], explains: list[dict[str, Finding]]
) -> str:
    """What else agrees on ``cause`` (:func:`_support`) beside the detectors that found it:
    each other detector whose alarms on other sensors law 0 takes for ``cause``'s fault,
    with those sensors (``"; equivalent_model's alarm on s1 taken for it through law
    0"``), or nothing. Such a detector is not among the finding's own
    (``evidence.detectors``: it reported no fault on ``cause``'s sensor), so the note
    names it apart, where its alarm was."""
    own = set(_detectors(cause))
    alarms: dict[str, list[str]] = {}
    for f, explained in zip(findings, explains, strict=True):
        for d, g in explained.items():
            if g is cause and d not in own and f.channel not in alarms.get(d, []):
                alarms.setdefault(d, []).append(f.channel)
    return "".join(
        f"; {d}'s {'alarms' if len(chs) > 1 else 'alarm'} on {', '.join(chs)} taken for "
        "it through law 0"
        for d, chs in sorted(alarms.items())
    )


def _explained_text(explained: dict[str, Finding]) -> str:
    """Why the ``explained`` detectors' part in a finding is their assistants' fault."""
    return "; ".join(
        f"no residual of the sensors {d} assists confirmed it, and its assistant sensor "
        f"{g.channel} was already faulty ({g.type.value} from {seconds_text(g.onset_s)} s, found "
        f"by {', '.join(x for x in _detectors(g) if x != d)})"
        for d, g in explained.items()
    )


def _detectors(f: Finding) -> list[str]:
    detectors: list[str] = f.evidence.get("detectors", [f.detector])
    return detectors


def _first_alarm(f: Finding, detector: str | None = None) -> float:
    """When a finding's first detector (or ``detector``) alarmed (an event's
    ``first_alarm_s``, else its onset)."""
    return min(
        (_alarmed(e) for e in f.events if detector is None or e.detector == detector),
        default=f.onset_s,
    )


def _alarmed(e: Event) -> float:
    """When an event's detector first alarmed (``first_alarm_s``, else its onset)."""
    return float(e.evidence.get("first_alarm_s", e.onset_s))


def traced_into_training(findings: list[Finding], reused: bool = False) -> list[str]:
    """A note for each finding whose shape one of its detectors traced back into the
    healthy window (evidence ``starts_in_training``: a drift's line meets zero before the
    window's end, so the finding starts at the end and its confidence was halved).

    The trend was there while the window was taken as healthy: a sensor drifting since
    before the window's end, or the monitored system's own slow change, which the methods,
    whose healthy model is fitted on a stationary window, cannot tell from a sensor's. On
    a real pump that warms up over its run (SKAB's anomaly-free record, trained on its
    first 20 %) a vibration RMS was reported drifting from the window's end, traced to
    1 109 s, and while it lasted, the faults of the sensors modelled with it were taken for
    it (one fault at a time). The note says so and what tells them apart.

    With ``reused`` (``--model``: fitted on another recording) the window is only the
    filters' warm-up at the record's start, and a shape traced back into it means the
    fault was already there when the record began."""
    notes = []
    for f in findings:
        traced = [
            float(e.evidence["traced_onset_s"])
            for e in f.events
            if e.evidence.get("starts_in_training") and "traced_onset_s" in e.evidence
        ]
        if not traced:
            continue
        if reused:
            back = (
                "the record's start"
                if min(traced) <= 0
                else f"{seconds_text(min(traced))} s, inside the warm-up"
            )
            notes.append(
                f"{f.type.value} fault on {f.channel} from {seconds_text(f.onset_s)} s (the end of "
                f"the filters' warm-up, where the search starts): traced back to {back}, so it was "
                "probably there when the record began (see the archive before this one)"
            )
            continue
        notes.append(
            f"{f.type.value} fault on {f.channel} from {seconds_text(f.onset_s)} s (the end of the "
            f"healthy window): traced back to {seconds_text(min(traced))} s, inside the window, so "
            "the trend was there while the window was taken as healthy; it may be the monitored "
            "system's own slow change (warming, load, season) rather than the sensor's, and while "
            "it lasts, faults of the sensors modelled with it are taken for it; a healthy window "
            "that covers such changes (--train) tells them apart"
        )
    return notes


def present_at_search_start(findings: list[Finding], start_s: float, rate_hz: float) -> list[str]:
    """With ``--model`` the fault search starts after the filters' warm-up (``start_s``):
    a finding that starts there was already present, so its onset is only an upper
    bound. Its evidence says so (``onset_at_or_before``) and a note says it (unless
    :func:`traced_into_training` already traced its shape back), in the words of the
    report's table and ``analyzer run``'s last line: "from the start", not judged before
    (it said "at or before then" beside them)."""
    notes = []
    for f in findings:
        if f.onset_s > start_s + 1.5 / rate_hz:
            continue
        f.evidence["onset_at_or_before"] = True
        traced = any(e.evidence.get("starts_in_training") for e in f.events)
        if not traced:
            notes.append(
                f"{f.type.value} fault on {f.channel}: present when the search started at "
                f"{seconds_text(start_s)} s (after the filters' warm-up): there from the start, "
                "not judged before then (see the archive before this one)"
            )
    return notes

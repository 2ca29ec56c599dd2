"""Notes on log times that jitter against the messages' header stamps (``--time log``).

The readers measure, per topic with header stamps, how far each message's log time
departs from the topic's usual delay (:mod:`analyzer.readers.delays`). Here that is
judged against the topic's sample period (the period of its analyzed channels, from
their rate): a departure of more than :data:`JITTER_SHARE` of it moves that sample by a
sizeable share of a step on the log-time axis, which the header clock does not. On the
real ``rosbag2_test`` a ``/battery`` message written 16 ms late (of a 40 ms period) at
54.86 s became a confident ``other`` fault at 54.84 s, and ``--time header`` found
none (the robotics audit ux58 item 3). Two notes, both said on stderr:

* :func:`jitter_note`: the analyzed topics whose log times so jitter, by how much, and
  what to try;
* :func:`onset_cautions`: a finding whose onset lies within :data:`NEAR_PERIODS` sample
  periods of such a delayed message of its topic: the fault may be the recorder's.

The default stays log time: the header stamps have failure modes of their own (stamps
of 0, a simulation clock, a clock set while recording, topics without a header beside
topics with one), which ``--time header`` says and copes with, and on most real
recordings the two give the same result (README, *Log time or header stamps*).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np

from analyzer.errors import capped
from analyzer.readers import ArchiveNote
from analyzer.readers.base import InputInfo, known_topics, topic_of
from analyzer.readers.delays import KEPT, TopicDelays
from analyzer.store import ChannelInfo
from analyzer.timeutil import seconds_text
from analyzer.types import NS_PER_S

JITTER_SHARE = 0.25
"""A message whose log time departs from its topic's usual delay by more than this
share of the topic's sample period is *delayed*: interpolated on the common clock (one
tick per period), its sample is moved by a quarter of a step and more, and a step the
signal takes there is seen that much early or late on this topic alone."""

NEAR_PERIODS = 2.0
"""A finding's onset within this many sample periods of a delayed message of its topic
coincides with it (the onset is placed to a tick or two of the common clock)."""

SAID_TOPICS = 4
"""Topics named in the jitter note; the rest are counted."""


class JitterNote(ArchiveNote):
    """The note on analyzed topics whose log times jitter against their header stamps:
    said on stderr with the archive's notes."""

    __slots__ = ()


class DelayCaution(ArchiveNote):
    """The caution on a finding whose onset coincides with a delayed message of its
    topic: said on stderr with the archive's notes."""

    __slots__ = ()


@dataclass(frozen=True, slots=True)
class Jitter:
    """One analyzed topic's log-time jitter against its sample period."""

    topic: str
    period_s: float
    delays: TopicDelays

    @property
    def share(self) -> float:
        """The largest departure, as a share of the sample period."""
        return self.delays.largest_ns / NS_PER_S / self.period_s

    def delayed(self) -> int:
        """How many messages depart by more than :data:`JITTER_SHARE` of a period."""
        return self.delays.over(JITTER_SHARE * self.period_s * NS_PER_S)


def jitters(
    inputs: Sequence[InputInfo], infos: Sequence[ChannelInfo], chosen: Sequence[str]
) -> list[Jitter]:
    """The analyzed topics whose log times depart from their header stamps by more than
    :data:`JITTER_SHARE` of their sample period (the fastest of their analyzed
    channels'), largest share first. A topic in several inputs (the files of a folder)
    is measured over them all."""
    rates: dict[str, float] = {}
    by_name = {i.name: i for i in infos}
    topics = known_topics(inputs)
    for name in chosen:
        info = by_name.get(name)
        if info is not None and info.rate_hz > 0:
            topic = topic_of(name, topics)
            rates[topic] = max(rates.get(topic, 0.0), info.rate_hz)
    merged: dict[str, TopicDelays] = {}
    for i in inputs:
        for topic, d in i.log_delays.items():
            if topic in rates:
                merged[topic] = _merged(merged[topic], d) if topic in merged else d
    found = [Jitter(t, 1.0 / rates[t], d) for t, d in merged.items() if d.measured]
    found = [j for j in found if j.share > JITTER_SHARE]
    return sorted(found, key=lambda j: -j.share)


def _merged(a: TopicDelays, b: TopicDelays) -> TopicDelays:
    """One topic's measures over two inputs."""
    late = np.concatenate((a.late_ns, b.late_ns))
    when = np.concatenate((a.late_log_ns, b.late_log_ns))
    if late.size > KEPT:
        keep = np.argpartition(-np.abs(late), KEPT - 1)[:KEPT]
        late, when = late[keep], when[keep]
    return TopicDelays(a.measured + b.measured, a.counts + b.counts, when, late, b.tail)


def _ms(ns: float) -> str:
    """A delay in milliseconds, as people say it (``41 ms``, ``2.5 ms``)."""
    ms = ns / 1e6
    return f"{ms:.0f} ms" if ms >= 10 else f"{ms:.1f} ms"


def jitter_note(found: Sequence[Jitter]) -> list[str]:
    """``log times of /battery jitter by up to 41 ms against their header stamps (103 %
    of its 40 ms sample period; 3 messages by more than a quarter period); a fault found
    there may be the recorder's delay: try --time header``; nothing where no analyzed
    topic jitters that much."""
    if not found:
        return []
    parts = []
    for k, j in enumerate(found[:SAID_TOPICS]):
        count = j.delayed()
        many = f"{count} message{'s' if count != 1 else ''}"
        parts.append(
            f"{j.topic}{' jitter' if k == 0 else ''} by up to {_ms(j.delays.largest_ns)}"
            f"{' against their header stamps' if k == 0 else ''} ({100 * j.share:.0f} % "
            f"of its {_ms(j.period_s * NS_PER_S)} sample period; {many} by more than a "
            "quarter period)"
        )
    more = len(found) - SAID_TOPICS
    rest = f", and {more} more topic{'s' if more != 1 else ''}" if more > 0 else ""
    return [
        JitterNote(
            f"log times of {', '.join(parts)}{rest}: the recorder wrote "
            f"{'this topic' if len(found) == 1 else 'these topics'} with an uneven delay, "
            "which moves samples on the log-time axis; a fault found there may be the "
            "recorder's delay: try --time header"
        )
    ]


def onset_cautions(
    findings: Sequence[tuple[str, float, str]],
    found: Sequence[Jitter],
    start_ns: int,
    topics: Collection[str],
) -> dict[tuple[str, float], str]:
    """Per finding (channel, onset in seconds from ``start_ns``, and how it is said:
    ``/battery.voltage other from 54.840 s``) whose onset lies within
    :data:`NEAR_PERIODS` sample periods of a message of its topic delayed by more than
    :data:`JITTER_SHARE` of a period (among the largest departures kept), the caution:
    the message nearest the onset, how late and when, and what to try. ``topics``: the
    record's (:func:`~analyzer.readers.base.known_topics`), which tell a channel's topic."""
    by_topic = {j.topic: j for j in found}
    out: dict[tuple[str, float], str] = {}
    for channel, onset_s, said in findings:
        j = by_topic.get(topic_of(channel, topics))
        if j is None:
            continue
        late = j.delays.late_ns
        when = (j.delays.late_log_ns - start_ns) / NS_PER_S
        near = (np.abs(late) > JITTER_SHARE * j.period_s * NS_PER_S) & (
            np.abs(when - onset_s) <= NEAR_PERIODS * j.period_s
        )
        if not bool(near.any()):
            continue
        k = int(np.flatnonzero(near)[np.argmin(np.abs(when[near] - onset_s))])
        way = "late" if late[k] > 0 else "early"
        out[(channel, onset_s)] = (
            f"{said}: its onset coincides with a message of {j.topic} logged "
            f"{_ms(abs(int(late[k])))} {way} (at {seconds_text(when[k])} s; "
            f"{100 * abs(int(late[k])) / NS_PER_S / j.period_s:.0f} % of its sample period): "
            "the fault may be the recorder's delay, not the sensor's: try --time header"
        )
    return out


def cautions_line(cautions: dict[tuple[str, float], str]) -> list[str]:
    """The cautions as notes (said on stderr), at most :data:`SAID_TOPICS`, the rest
    counted."""
    texts = list(cautions.values())
    if len(texts) > SAID_TOPICS:
        return [DelayCaution(capped(texts, SAID_TOPICS, "; ", "findings"))]
    return [DelayCaution(t) for t in texts]

"""The note on analyzed channels that stop for a while mid-record (:func:`silence_note`).

A 200 Hz IMU that published nothing for 5 s while the odometry and the joints went on
was said nowhere in text: ``gaps: 1`` in ``channels[]`` and a mark on the coverage
chart (the robotics audit ux58 item 6). A topic that *stops* is no fault finding
(README, *How it decides*), but which sensor went quiet, and when, is what a user
asks. A silence is said where a channel's step between two consecutive samples is
longer than :data:`SILENT_PERIODS` of its sample periods or :data:`SILENT_SHARE` of the
record, whichever is shorter, and at least :data:`SILENT_LEAST_S`: far beyond the
store's own gap rule (2.5 periods, which a few lost messages meet), so a recorder's
dropped messages are not listed. Channels with the same silences (the fields of one
topic) are one item, named by their topic; at most :data:`LISTED` items and
:data:`SPANS` silences each are said, the rest counted.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence

import numpy as np

from analyzer.errors import capped
from analyzer.paging import release
from analyzer.readers import ArchiveNote
from analyzer.readers.base import topic_of
from analyzer.readers.seams import Seam, gap_between_files
from analyzer.store import ChannelInfo, ChannelStore
from analyzer.timeutil import plain_number, seconds_text, short_seconds
from analyzer.types import NS_PER_S

SILENT_PERIODS = 50
"""A step of more than this many sample periods is a silence (or one of
:data:`SILENT_SHARE` of the record, where shorter)."""

SILENT_SHARE = 0.01
"""A step of more than this share of the record is a silence (a slow topic's: 50
periods of a 1 Hz battery is most of a short record)."""

SILENT_LEAST_S = 1.0
"""No step shorter than this (seconds) is a silence: 50 periods of a 1 kHz channel is
50 ms, a recorder's hiccup."""

LISTED = 4
"""Items (topics, or channels) named; the rest counted."""

SPANS = 3
"""Silences named per item; the rest counted."""

BLOCK = 1 << 22
"""Times read at once (a spilled channel's pages are released after each block)."""


class SilenceNote(ArchiveNote):
    """The note on analyzed channels silent mid-record: said on stderr with the
    archive's notes."""

    __slots__ = ()


class StoppedNote(ArchiveNote):
    """The note on analyzed channels without a reading for long at the record's start or
    end (:func:`analyzer.pipeline._partial_channels`: a sensor that started late, or a
    topic that stopped for good while the others went on), said on stderr with the
    archive's notes and beside the report's verdict. An IMU that stopped at 40 % of a
    record was said in findings.json's notes and among the report's "other notes" alone:
    stderr ended with "no sensor fault found", which read as the whole record audited
    (rob56). ``stopped``: the channels that stop before the record's end, and the time
    (seconds from the start) from which they have no reading, which the run's last line
    names, with the topic of each (:func:`~analyzer.readers.base.topic_of`)."""

    stopped: tuple[tuple[str, float, str], ...] = ()

    @classmethod
    def of(cls, text: str, names: Sequence[str], stop_s: float | None, topic: str) -> StoppedNote:
        """The note ``text`` on ``names`` (the channels of ``topic``, or one), which have no
        reading from ``stop_s`` to the record's end (None: they run to it); built from its
        text, the rest added, so that it pickles as a note does."""
        note = cls(text)
        if stop_s is not None:
            note.stopped = tuple((n, stop_s, topic) for n in names)
        return note


def stopped_words(notes: Sequence[str]) -> str:
    """The run's last line's words on the channels that stop before the record's end
    (:class:`StoppedNote`): ``/imu has no reading after 48 s``, the fields of one topic
    named by it, or how many stop; empty where none does."""
    ends: dict[str, float] = {}
    topics: set[str] = set()
    for n in notes:
        for name, at, topic in getattr(n, "stopped", ()) if isinstance(n, StoppedNote) else ():
            ends[name] = min(at, ends.get(name, at))
            topics.add(topic)
    if not ends:
        return ""
    if len(topics) == 1:
        (topic,) = topics
        who = topic if len(ends) > 1 else next(iter(ends))
        return f"{who} has no reading after {short_seconds(min(ends.values()))} s"
    return f"{len(topics)} topics (or sensors) stop before the record ends"


def silences(
    store: ChannelStore,
    info: ChannelInfo,
    limit_ns: float,
    seen: dict[tuple[int, int, float], list[tuple[int, int]]],
) -> list[tuple[int, int]]:
    """The steps of ``info``'s channel longer than ``limit_ns``: (last sample before, first
    after), in nanoseconds (a channel has few such steps). The fields of one message
    share their times in the store (the same memory): read once, the answer kept in
    ``seen`` by that memory and the limit."""
    t, _ = store.raw(info.name)
    key = (int(t.__array_interface__["data"][0]), int(t.shape[0]), float(limit_ns))
    if key in seen:
        return seen[key]
    n = t.shape[0]
    found: list[tuple[int, int]] = []
    for s in range(0, n - 1, BLOCK):
        e = min(n, s + BLOCK + 1)
        tt = np.asarray(t[s:e])
        at = np.flatnonzero(np.diff(tt) > limit_ns)
        found.extend(zip(tt[at].tolist(), tt[at + 1].tolist(), strict=True))
        release(t[s:e])
    seen[key] = found
    return found


def _went_on(
    store: ChannelStore, others: Sequence[str], topics: Collection[str], span: tuple[int, int]
) -> list[str]:
    """The topics (of the record's ``topics``; or CSV columns) among ``others`` with a
    sample in the middle half of ``span`` (a silence of another channel; not merely near
    its ends, as a topic that paused with it, a few milliseconds apart, has): one binary
    search per topic, its first channel's."""
    a, b = span
    a, b = a + (b - a) // 4, b - (b - a) // 4
    out: list[str] = []
    firsts: dict[str, str] = {}
    for n in others:
        firsts.setdefault(topic_of(n, topics), n)
    for topic, first in firsts.items():
        t, _ = store.raw(first)
        k = int(np.searchsorted(t, a, side="right"))
        if k < t.shape[0] and int(t[k]) < b:
            out.append(topic)
    return out


def _between(seams: list[Seam], a: int, b: int) -> str:
    """``; no file covers it ...`` where the silence ``a``-``b`` is a gap between files."""
    words = gap_between_files(seams, a, b)
    return f"; {words}" if words else ""


def silence_note(
    store: ChannelStore,
    names: Sequence[str],
    topics: Collection[str],
    start_ns: int,
    span_s: float,
    seams: Sequence[Seam] = (),
) -> list[str]:
    """The note on the channels ``names`` (analyzed, with samples) that are silent
    mid-record (module doc), times in seconds from ``start_ns`` (the common clock's
    start); nothing where none is. ``topics``: the record's
    (:func:`~analyzer.readers.base.known_topics`; none for a CSV, whose columns are each
    named). A silence that is a gap between two files of the archive (``seams``:
    :func:`~analyzer.readers.seams.gap_between_files`) says so."""
    groups: dict[tuple[tuple[int, int], ...], list[str]] = {}
    seen: dict[tuple[int, int, float], list[tuple[int, int]]] = {}
    rates: dict[tuple[tuple[int, int], ...], float] = {}
    for name in names:
        info = store.info(name)
        if not isinstance(info, ChannelInfo) or not info.gaps or info.rate_hz <= 0:
            continue
        period = NS_PER_S / info.rate_hz
        limit = max(
            min(SILENT_PERIODS * period, SILENT_SHARE * span_s * NS_PER_S),
            SILENT_LEAST_S * NS_PER_S,
            info.bridge * period,
        )
        found = tuple(silences(store, info, limit, seen))
        if found:
            groups.setdefault(found, []).append(name)
            rates[found] = max(rates.get(found, 0.0), info.rate_hz)
    if not groups:
        return []
    items = []
    for found, members in sorted(groups.items(), key=lambda g: g[0][0][0]):
        heads = list(dict.fromkeys(topic_of(m, topics) for m in members))
        who = capped(heads, 2) if len(heads) < len(members) else capped(members, 2)
        rate = rates[found]
        spans = [
            f"from {seconds_text((a - start_ns) / NS_PER_S)} to "
            f"{seconds_text((b - start_ns) / NS_PER_S)} s "
            f"({short_seconds((b - a) / NS_PER_S)} s: about "
            f"{plain_number(max(1, round((b - a) / NS_PER_S * rate) - 1), 3)} samples missing "
            f"at {plain_number(rate, 4)} Hz{_between(list(seams), a, b)})"
            for a, b in found[:SPANS]
        ]
        more = f" and {len(found) - SPANS} more" if len(found) > SPANS else ""
        # (other topics only: a topic's other fields, such as another frame of /tf, are
        # no sign that the sensor went on)
        others = _went_on(
            store, [n for n in names if topic_of(n, topics) not in heads], topics, found[0]
        )
        beside = f" while {capped(others, 2)} went on" if others else ""
        items.append(f"{who}: no sample {', '.join(spans)}{more}{beside}")
    said = capped(items, LISTED, "; ", "channels with such silences")
    return [
        SilenceNote(
            f"analyzed channels silent mid-record (no sample for longer than "
            f"{SILENT_PERIODS} sample periods or {100 * SILENT_SHARE:.0f} % of the record, "
            f"whichever is shorter, and at least {short_seconds(SILENT_LEAST_S)} s): {said}; "
            "a sensor or topic that stops is no fault finding, and the detectors do not "
            "see it there"
        )
    ]

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

from collections.abc import Sequence

import numpy as np

from analyzer.delay_note import topic_of
from analyzer.errors import capped
from analyzer.paging import release
from analyzer.readers import ArchiveNote
from analyzer.readers.seams import Seam, gap_between_files
from analyzer.store import ChannelInfo, ChannelStore
from analyzer.timeutil import plain_number, short_seconds
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


def _went_on(store: ChannelStore, others: Sequence[str], span: tuple[int, int]) -> list[str]:
    """The topics (or CSV columns) among ``others`` with a sample in the middle half of
    ``span`` (a silence of another channel; not merely near its ends, as a topic that
    paused with it, a few milliseconds apart, has): one binary search per topic, its
    first channel's."""
    a, b = span
    a, b = a + (b - a) // 4, b - (b - a) // 4
    out: list[str] = []
    firsts: dict[str, str] = {}
    for n in others:
        firsts.setdefault(topic_of(n), n)
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
    start_ns: int,
    span_s: float,
    seams: Sequence[Seam] = (),
) -> list[str]:
    """The note on the channels ``names`` (analyzed, with samples) that are silent
    mid-record (module doc), times in seconds from ``start_ns`` (the common clock's
    start); nothing where none is. A silence that is a gap between two files of the
    archive (``seams``: :func:`~analyzer.readers.seams.gap_between_files`) says so."""
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
        topics = list(dict.fromkeys(topic_of(m) for m in members))
        who = capped(topics, 2) if len(topics) < len(members) else capped(members, 2)
        rate = rates[found]
        spans = [
            f"from {(a - start_ns) / NS_PER_S:.3f} to {(b - start_ns) / NS_PER_S:.3f} s "
            f"({short_seconds((b - a) / NS_PER_S)} s: about "
            f"{plain_number(max(1, round((b - a) / NS_PER_S * rate) - 1), 3)} samples missing "
            f"at {plain_number(rate, 4)} Hz{_between(list(seams), a, b)})"
            for a, b in found[:SPANS]
        ]
        more = f" and {len(found) - SPANS} more" if len(found) > SPANS else ""
        # (other topics only: a topic's other fields, such as another frame of /tf, are
        # no sign that the sensor went on)
        others = _went_on(store, [n for n in names if topic_of(n) not in topics], found[0])
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

"""How much of an archive's span has no data at all (:func:`span_gaps`) and the line that
says so (:func:`gaps_line`): four 600-s files an hour apart made a ``duration_s`` of
11 400 s, 79 % of it without a sample, and nothing but the report's coverage figure
said so (the audit). ``run`` puts the line in its notes (and on stderr when most of the
span is missing: :class:`MostlyMissingNote`), ``inspect`` in its summary."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analyzer.errors import capped
from analyzer.paging import release
from analyzer.readers import ArchiveNote
from analyzer.store import ChannelInfo, ChannelStore
from analyzer.timeutil import iso_utc, spoken_duration
from analyzer.types import NS_PER_S

SAID_SHARE = 0.01
"""A span with at least this share without data gets the line: ``duration_s`` (the span)
overstates the data by more than a rounding."""

WARNED_SHARE = 0.5
"""A span with more than this share without data (most of it) is warned of on stderr."""

FEW_SAMPLES = 16
"""A channel with fewer samples tells no rate of its own (its median step is the
distance between a handful of messages): its samples count as instants, not stretches,
where other channels have more (:func:`span_gaps`)."""

BLOCK = 1 << 22
"""Times read at once when looking for a channel's gaps (a spilled channel's pages are
released after each block)."""


@dataclass(frozen=True)
class SpanGaps:
    """Stretches of an archive's span where none of its channels has a sample."""

    span_s: float
    """From the first sample of any channel to the last one."""
    gaps: int
    """How many stretches have no sample of any channel."""
    missing_s: float
    """Their total, in seconds."""

    @property
    def share(self) -> float:
        """The share of the span without data (0 to 1)."""
        return self.missing_s / self.span_s if self.span_s > 0 else 0.0

    def as_json(self) -> dict[str, float | int]:
        """For ``inspect --json``."""
        return {
            "span_s": round(self.span_s, 6),
            "gaps": self.gaps,
            "without_data_s": round(self.missing_s, 6),
        }


def span_gaps(store: ChannelStore, names: Sequence[str]) -> SpanGaps | None:
    """The stretches of the span of channels ``names`` where none of them has a sample:
    each channel's stretches with data (between its gaps, by the store's own rule:
    :attr:`~analyzer.store.ChannelInfo.bridge` periods) merged over the channels; a hole
    between them longer than that rule for the coarsest channel counts. Only channels
    with gaps are read (a block of times at a time); None where no hole is left or
    fewer than two samples."""
    infos = [i for i in (store.info(n) for n in names) if isinstance(i, ChannelInfo)]
    infos = [i for i in infos if i.samples > 1 and i.rate_hz > 0]
    if not infos:
        return None
    # a channel of a few samples tells no rate: its period is the distance between them
    # (a /tf_static published once in each of two bags 735 days apart: one "period"
    # bridging both, the whole span covered, no gap said); its samples are points, and
    # the rule for a hole comes from the channels that are sampled
    sampled = [i for i in infos if i.samples >= FEW_SAMPLES] or infos
    pieces: list[tuple[int, int]] = []
    for info in infos:
        if info.samples < FEW_SAMPLES and len(sampled) < len(infos):
            pieces.extend(_points(store, info))
        elif info.gaps:
            pieces.extend(_pieces(store, info))
        else:
            pieces.append((info.start_ns, info.end_ns))
    least = max(i.bridge * NS_PER_S / i.rate_hz for i in sampled)
    pieces.sort()
    holes = []
    reach = pieces[0][1]
    for a, b in pieces[1:]:
        if a - reach > least:
            holes.append(a - reach)
        reach = max(reach, b)
    span = reach - pieces[0][0]
    if not holes or span <= 0:
        return None
    return SpanGaps(span / NS_PER_S, len(holes), sum(holes) / NS_PER_S)


def _points(store: ChannelStore, info: ChannelInfo) -> list[tuple[int, int]]:
    """A channel of fewer than :data:`FEW_SAMPLES` samples: each one a stretch of no
    length (it covers its instant, not the time to the next one)."""
    t, _ = store.raw(info.name)
    return [(int(x), int(x)) for x in np.asarray(t[: info.samples])]


def _pieces(store: ChannelStore, info: ChannelInfo) -> list[tuple[int, int]]:
    """One channel's stretches with data: first and last sample between its gaps."""
    t, _ = store.raw(info.name)
    step = info.bridge * NS_PER_S / info.rate_hz
    n = t.shape[0]
    cuts: list[np.ndarray] = []
    for s in range(0, n - 1, BLOCK):
        e = min(n, s + BLOCK + 1)
        tt = np.asarray(t[s:e])
        cuts.append(s + np.flatnonzero(np.diff(tt) > step))
        release(t[s:e])
    at = np.concatenate(cuts) if cuts else np.zeros(0, dtype=np.int64)
    starts = [0, *(at + 1).tolist()]
    ends = [*at.tolist(), n - 1]
    return [(int(t[a]), int(t[b])) for a, b in zip(starts, ends, strict=True)]


def gaps_line(gaps: SpanGaps) -> str:
    """``79 % of the 3.2 h span has no data: 3 gaps, 2.5 h in all``."""
    count = f"{gaps.gaps} gap{'s' if gaps.gaps != 1 else ''}"
    return (
        f"{100 * gaps.share:.0f} % of the {spoken_duration(gaps.span_s)} span has no data: "
        f"{count}, {spoken_duration(gaps.missing_s)} in all"
    )


class MostlyMissingNote(ArchiveNote):
    """The note on a span mostly without data: repeated on stderr with the archive's
    notes (an :class:`~analyzer.readers.ArchiveNote`)."""

    __slots__ = ()


def span_note(gaps: SpanGaps | None) -> list[str]:
    """``run``'s note on the analyzed channels' span (:func:`gaps_line`), where at least
    :data:`SAID_SHARE` of it has no data; a :class:`MostlyMissingNote` (said on stderr
    too) where more than :data:`WARNED_SHARE` has none."""
    if gaps is None or gaps.share < SAID_SHARE:
        return []
    text = f"{gaps_line(gaps)} (duration_s is the span from the first sample to the last)"
    return [MostlyMissingNote(text) if gaps.share > WARNED_SHARE else text]


class OutsideNote(ArchiveNote):
    """The note on samples of channels not analyzed that lie far outside the analyzed
    span: said on stderr with the archive's notes."""

    __slots__ = ()


def outside_note(
    infos: Sequence[ChannelInfo],
    chosen: Sequence[str],
    start_ns: int,
    duration_s: float,
    absolute: bool,
) -> list[str]:
    """A note where channels not analyzed have samples outside the analyzed span
    (``start_ns`` on, ``duration_s`` long) for longer than that span lasts: a file
    recorded years before the others, whose topics were left out of the analysis or
    merged into another file's, was read and then said nothing of (``tf_example.bag``
    of 2024 beside ``nav2_turtlebot.mcap`` of 2026: "no sensor fault found" on nav2's
    97 s alone). Empty otherwise."""
    wanted = set(chosen)
    end_ns = start_ns + int(round(duration_s * NS_PER_S))
    out = [
        i
        for i in infos
        if i.name not in wanted and i.samples > 0 and (i.start_ns < start_ns or i.end_ns > end_ns)
    ]
    if not out:
        return []
    before = max(0, start_ns - min(i.start_ns for i in out)) / NS_PER_S
    after = max(0, max(i.end_ns for i in out) - end_ns) / NS_PER_S
    if before + after <= duration_s:
        return []
    sides = " and ".join(
        f"{spoken_duration(x)} {word} it"
        for x, word in ((before, "before"), (after, "after"))
        if x > 0
    )
    since = f" from {iso_utc(start_ns)}" if absolute else ""
    names = capped(sorted(i.name for i in out), what="channels")
    return [
        OutsideNote(
            f"the analysis spans {spoken_duration(duration_s)}{since}, while {len(out)} "
            f"channel(s) not analyzed have samples up to {sides} ({names}): what lies "
            "outside the analyzed span is not analyzed (an input recorded apart from the "
            "others: analyze it on its own)"
        )
    ]

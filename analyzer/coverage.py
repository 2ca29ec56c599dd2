"""How much of an archive's span has no data at all (:func:`span_gaps`) and the line that
says so (:func:`gaps_line`): four 600-s files an hour apart made a ``duration_s`` of
11 400 s, 79 % of it without a sample, and nothing but the report's coverage figure
said so (the audit). ``run`` puts the line in its notes (and on stderr when most of the
span is missing: :class:`MostlyMissingNote`), ``inspect`` in its summary."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from analyzer.paging import release
from analyzer.readers import ArchiveNote
from analyzer.store import ChannelInfo, ChannelStore
from analyzer.timeutil import spoken_duration
from analyzer.types import NS_PER_S

SAID_SHARE = 0.01
"""A span with at least this share without data gets the line: ``duration_s`` (the span)
overstates the data by more than a rounding."""

WARNED_SHARE = 0.5
"""A span with more than this share without data (most of it) is warned of on stderr."""

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
    pieces: list[tuple[int, int]] = []
    for info in infos:
        pieces.extend(_pieces(store, info) if info.gaps else [(info.start_ns, info.end_ns)])
    least = max(i.bridge * NS_PER_S / i.rate_hz for i in infos)
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

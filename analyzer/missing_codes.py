"""Missing-value codes: numbers a data logger writes where it has no reading (``-9999``
of HOBO, many SCADA exports and FLUXNET-style files; ``-999``, ``9999``...).

Read as values they are confident faults: a single ``-9999`` every thousand rows was
"s2 clipped at -9999" (confidence 0.99, "the sensor saturates"), fifty rows of it "s4
stuck at -9999", and the real fault beside them was seen by fewer detectors (the ux55
audit). The tool does not guess which numbers mean "no reading": ``--missing-values``
names them (as pandas' ``na_values``), and the samples equal to one are taken as gaps,
as blank cells are (:func:`as_gaps`, a note counting them). Where a clipped or stuck
finding's value is a usual code or lies far outside the channel's other readings, a
note says how to declare it (:func:`code_hints`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.readers.base import ChannelChunk
from analyzer.store.store import UNREADABLE
from analyzer.types import Note

USUAL_CODES = (-9999.0, -99999.0, 9999.0, -999.0)
"""Missing-value codes in common use, which a clipped or stuck value equal to one is
named as possibly being."""

FAR_SPANS = 10.0
"""A value further than this many times the spread of a channel's other readings (its
0.5-99.5 % range) beyond that range is "far outside" them: no clipping or sticking of
the sensor reads there (a sensor clips at the edge of what it reads)."""


def parse_codes(text: str) -> tuple[float, ...]:
    """``--missing-values CODE[,CODE...]``: finite numbers; a ValueError naming the item
    otherwise."""
    codes = []
    for item in text.split(","):
        item = item.strip()
        try:
            v = float(item)
        except ValueError:
            raise ValueError(f"expected numbers separated by commas, got {item!r}") from None
        if not math.isfinite(v):
            raise ValueError(f"expected finite numbers, got {item!r}")
        codes.append(v)
    return tuple(dict.fromkeys(codes))


@dataclass(slots=True)
class Unread:
    """What :func:`as_gaps` dropped, by channel: ``coded`` the samples equal to a
    ``--missing-values`` code, ``absurd`` the infinite ones and those beyond
    :data:`~analyzer.store.store.UNREADABLE` in magnitude, ``nan`` the NaN ones (a reader's
    "no reading"), ``kept`` the samples handed on, ``last`` the latest time of one
    dropped."""

    coded: dict[str, int] = field(default_factory=dict)
    absurd: dict[str, int] = field(default_factory=dict)
    nan: dict[str, int] = field(default_factory=dict)
    kept: dict[str, int] = field(default_factory=dict)
    last: dict[str, int] = field(default_factory=dict)
    """Each channel's latest time (ns) of a sample dropped: a topic that goes on
    publishing NaN after its sensor died marks its silence so (:mod:`analyzer.silent`)."""

    def lost(self) -> dict[str, tuple[str, int]]:
        """The channels every sample of which was dropped (none handed on): the words
        for what their samples were, and how many there were."""
        out = {}
        for name in {**self.absurd, **self.coded, **self.nan}:
            if self.kept.get(name):
                continue
            kinds = [
                (words, counts[name])
                for counts, words in (
                    (
                        self.absurd,
                        "infinite or beyond 1e30 in magnitude (an overrange or error code?)",
                    ),
                    (self.coded, "a missing-value code (--missing-values)"),
                    (self.nan, "NaN (no reading)"),
                )
                if counts.get(name)
            ]
            out[name] = (" or ".join(w for w, _ in kinds), sum(k for _, k in kinds))
        return out


def as_gaps(
    chunks: Iterator[ChannelChunk], codes: Sequence[float], unread: Unread
) -> Iterator[ChannelChunk]:
    """``chunks`` without their samples that are no reading: NaN, infinite, beyond
    :data:`~analyzer.store.store.UNREADABLE` in magnitude (an overrange or error code, a
    corrupt cell) or equal to one of ``codes``, each counted by channel into ``unread``.

    Dropped before the store, as a CSV reader drops a blank cell: a gap of one sample is
    then bridged by the alignment as a blank cell's is, where a NaN kept as a sample was
    a gap every model's filter had to settle after (a -9999 or an infinity every 250
    rows of one channel left no detector able to run, while blank cells at the same
    rows gave the finding: the ux56 audit). A block at a time: one vectorized mask per
    chunk, no per-sample work; a chunk with nothing to drop is handed on as it is (its
    times still the very array the store may share among a message's fields)."""
    wanted = np.asarray(codes, dtype=np.float64)
    for chunk in chunks:
        values = np.asarray(chunk.values)
        with np.errstate(invalid="ignore"):
            ok = np.abs(values) <= UNREADABLE  # (False for NaN and the infinities)
        hit = np.isin(values, wanted) if wanted.size else None
        if hit is not None:
            ok &= ~hit
        name = chunk.name
        n = int(np.count_nonzero(ok))
        unread.kept[name] = unread.kept.get(name, 0) + n
        if n == ok.shape[0]:
            yield chunk
            continue
        nan = int(np.count_nonzero(np.isnan(values[~ok])))
        coded = 0 if hit is None else int(np.count_nonzero(hit))
        absurd = ok.shape[0] - n - nan - coded
        for counts, k in ((unread.nan, nan), (unread.coded, coded), (unread.absurd, absurd)):
            if k:
                counts[name] = counts.get(name, 0) + k
        t_ns = np.asarray(chunk.t_ns)
        at = int(t_ns[~ok].max())
        unread.last[name] = max(unread.last.get(name, at), at)
        if n:
            yield ChannelChunk(name, t_ns[ok], values[ok])


def absurd_note(counts: Mapping[str, int]) -> str:
    """The note on the infinite or absurd samples taken as gaps (by channel), or ""
    (:func:`analyzer.pipeline._analyze` appends it to an error where no detector could
    run, by its first words)."""
    if not counts:
        return ""
    return (
        "infinite or absurd values (beyond 1e30: an overrange or error code?) taken as gaps: "
        + ", ".join(f"{c} ({n})" for c, n in counts.items() if n)
    )


class UnreadNote(Note):
    """The note (repeated on stderr) naming the channels none of whose samples is a
    reading (every one NaN, infinite, beyond 1e30 or a ``--missing-values`` code), which
    are not analyzed, with their ``names``. Said for what it is: the training window's
    "no sample in the training window ... give --train" (which such a channel also
    met) sent the user looking for a window no ``--train`` can give (the ux56 audit)."""

    names: tuple[str, ...] = ()

    def __new__(cls, lost: Mapping[str, tuple[str, int]]) -> UnreadNote:
        note = super().__new__(
            cls,
            "; ".join(
                f"{name}: every one of its {n} values is {words}, so all were taken as "
                "gaps: not analyzed, in any training window (it has no reading)"
                for name, (words, n) in lost.items()
            ),
        )
        note.names = tuple(lost)
        return note


def read_notes(unread: Unread, codes: Sequence[float]) -> list[str]:
    """The notes on what :func:`as_gaps` dropped as the record was read, as ``run``
    gives them (``inspect`` and ``export`` read the record as it does, and say it in the
    same words): the codes taken as gaps, the infinite or absurd values taken as gaps,
    each by channel with its count, and the channels none of whose samples is a reading
    (:class:`UnreadNote`). NaN samples, as blank cells, are gaps without a note."""
    notes: list[str] = [
        n for n in (gaps_note(unread.coded, codes), absurd_note(unread.absurd)) if n
    ]
    lost = unread.lost()
    if lost:
        notes.append(UnreadNote(lost))
    return notes


def no_reading_line(unread: Unread) -> str | None:
    """The reason an archive whose every channel was dropped has no channel, in
    ``run``'s words (``no channel has a reading (...)``), or None where some channel was
    kept or none was dropped whole."""
    lost = unread.lost()
    if not lost or any(unread.kept.values()):
        return None
    return f"no channel has a reading ({UnreadNote(lost)})"


def gaps_note(counts: Mapping[str, int], codes: Sequence[float]) -> str:
    """The note on the samples ``--missing-values`` made gaps (by channel), or ""."""
    if not counts:
        return ""
    listed = ", ".join(f"{c} ({n})" for c, n in counts.items())
    return f"missing-value codes ({_codes_text(codes)}, --missing-values) taken as gaps: {listed}"


def _codes_text(codes: Sequence[float]) -> str:
    return ", ".join(f"{v:g}" for v in codes)


SUSPECT_KEYS = {
    "clipped_low": "clipping limit",
    "clipped_high": "clipping limit",
    "stuck_at": "stuck level",
}
"""The ``magnitude`` keys of a finding whose value may be a code, and their words."""


def _suspect_value(f: Any) -> tuple[float, str] | None:
    """The value a clipped or stuck finding reads (its ``magnitude``): the clipping
    limit, the stuck level, with its words; None for other findings."""
    for key, words in SUSPECT_KEYS.items():
        v = f.magnitude.get(key)
        if isinstance(v, (int, float)) and math.isfinite(v):
            return float(v), words
    return None


def _far_outside(column: npt.NDArray[Any], value: float) -> bool:
    """Whether ``value`` lies far outside the channel's other readings (:data:`FAR_SPANS`)."""
    col = np.asarray(column, dtype=np.float64)
    others = col[np.isfinite(col) & (col != value)]
    if others.size < 2:
        return False
    lo, hi = np.percentile(others, [0.5, 99.5])
    span = float(hi - lo)
    if not span > 0:
        return bool(value != lo)
    return value < lo - FAR_SPANS * span or value > hi + FAR_SPANS * span


class CodeHint(Note):
    """A note of :func:`code_hints`: a plain string to every reader of ``notes``,
    recognisable so that ``run`` repeats it on stderr (the finding it is about changes
    the exit code; the user must hear that it may be no reading at all)."""

    __slots__ = ()


def code_hints(
    findings: Sequence[Any], values: npt.NDArray[Any], chosen: Sequence[str]
) -> list[CodeHint]:
    """Notes (one per finding) on the clipped or stuck findings whose value is a usual
    missing-value code (:data:`USUAL_CODES`) or lies far outside the channel's other
    readings: it may be a logger's "no reading", and ``--missing-values`` reads it as a
    gap. The tool does not decide: a real sensor may stick at -999."""
    notes = []
    for f in findings:
        suspect = _suspect_value(f)
        if suspect is None or f.channel not in chosen:
            continue
        v, words = suspect
        usual = any(math.isclose(v, c, rel_tol=1e-9) for c in USUAL_CODES)
        if not usual and not _far_outside(values[:, chosen.index(f.channel)], v):
            continue
        why = (
            "a usual missing-value code of data loggers"
            if usual
            else "far outside the channel's other readings"
        )
        notes.append(
            CodeHint(
                f"{f.channel}: its {words} {v:g} is {why}: if it "
                f"marks no reading, give --missing-values {v:g} (its samples are then gaps)"
            )
        )
    return notes


__all__ = [
    "USUAL_CODES",
    "CodeHint",
    "Unread",
    "UnreadNote",
    "absurd_note",
    "as_gaps",
    "code_hints",
    "gaps_note",
    "no_reading_line",
    "parse_codes",
    "read_notes",
]

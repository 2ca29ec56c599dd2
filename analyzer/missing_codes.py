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
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.readers.base import ChannelChunk

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


def as_gaps(
    chunks: Iterator[ChannelChunk], codes: Sequence[float], counts: dict[str, int]
) -> Iterator[ChannelChunk]:
    """``chunks`` with each sample equal to one of ``codes`` made NaN (a gap, as a blank
    cell), counted by channel into ``counts``. A block at a time: no per-sample work."""
    if not codes:
        yield from chunks
        return
    wanted = np.asarray(codes, dtype=np.float64)
    for chunk in chunks:
        hit = np.isin(chunk.values, wanted)
        n = int(np.count_nonzero(hit))
        if n:
            counts[chunk.name] = counts.get(chunk.name, 0) + n
            chunk = ChannelChunk(chunk.name, chunk.t_ns, np.where(hit, np.nan, chunk.values))
        yield chunk


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


class CodeHint(str):
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


__all__ = ["USUAL_CODES", "CodeHint", "as_gaps", "code_hints", "gaps_note", "parse_codes"]

"""Integer nanoseconds inside, seconds and ISO-8601 at the edges."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np

from analyzer.types import NS_PER_S


def iso_utc(ns: int | None) -> str | None:
    """``2026-01-01T00:01:43.990Z`` for epoch nanoseconds, rounded to the nearest
    millisecond (so it agrees with a time in seconds rounded to three decimals)."""
    if ns is None:
        return None
    ms = (int(ns) + 500_000) // 1_000_000
    sec, rem = divmod(ms * 1_000_000, NS_PER_S)
    dt = datetime.fromtimestamp(sec, tz=UTC)
    return dt.strftime("%Y-%m-%dT%H:%M:%S") + f".{rem // 1_000_000:03d}Z"


def parse_time(text: str) -> tuple[str, float | int]:
    """``("s", seconds)`` for a number, ``("ns", epoch ns)`` for an ISO-8601 time
    (UTC when it has no zone). Raises ValueError otherwise."""
    t = text.strip()
    try:
        return "s", float(t)
    except ValueError:
        pass
    dt = datetime.fromisoformat(t.replace("Z", "+00:00"))
    if dt.tzinfo is None:
        dt = dt.replace(tzinfo=UTC)
    return "ns", int(round(dt.timestamp() * NS_PER_S))


def plausible_epoch(ns: int) -> bool:
    """True when ``ns`` looks like an absolute time (after 1990): relative clocks and
    bags recorded with simulated time start near zero."""
    return bool(ns > np.int64(631152000) * NS_PER_S)

"""Integer nanoseconds inside, seconds and ISO-8601 at the edges."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Literal

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


IsoUnit = Literal["ms", "us", "ns"]


def exact_unit(start_ns: int, rate_hz: float) -> IsoUnit:
    """The coarsest of ms, us and ns in which every tick ``start_ns + round(k * 1e9 /
    rate_hz)`` of a clock is exact: a record that starts on a millisecond at 200 Hz is
    written ``...13.383Z``, one that starts at a ROS log time ``...13.382747123Z``."""
    period = NS_PER_S / rate_hz
    units: tuple[tuple[IsoUnit, int], ...] = (("ms", 1_000_000), ("us", 1_000))
    for unit, size in units:
        if start_ns % size == 0 and period == round(period) and round(period) % size == 0:
            return unit
    return "ns"


def iso_times(times_ns: np.ndarray, unit: IsoUnit) -> np.ndarray:
    """Epoch nanoseconds as ISO-8601 UTC strings (``2026-05-08T09:59:13.383Z``) written to
    ``unit`` (truncated: :func:`exact_unit` gives the unit that loses nothing), vectorized
    (a column of an export, ``--utc``)."""
    stamps = np.asarray(times_ns, dtype=np.int64).astype("datetime64[ns]")
    return np.datetime_as_string(stamps, unit=unit, timezone="UTC")


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


def spoken_duration(seconds: float) -> str:
    """A duration in a user's line, in the unit it reads best in, to two or three
    significant digits: ``400 ms``, ``5.8 s``, ``100 s``, ``2.0 min``, ``90 min``,
    ``3.5 h``, ``2.3 days``. The one way every line says a span (notes, stderr, the
    watcher's log, the readers' clock lines); the report's tables keep exact cells
    (:func:`analyzer.report.format.duration`). Six functions said them six ways: 100 s
    was ``100 s``, ``2 min``, ``100.0 s``; 200 000 s ``2.3 d``, ``55 h 33 min``, ``2.3
    days``. The lines wrote them ``{x:.3g}`` in one unit: ``a 5.81e+03-ms period``."""
    s = float(seconds)
    if not np.isfinite(s):
        return f"{s} s"
    if abs(s) < 1.0 and "e" not in (ms := f"{1e3 * s:.3g}"):  # (999.7 ms: 1.0 s)
        return f"{ms} ms"
    # (the largest unit of which it is two or more, as written: 7199.98 s is 2.0 h, not
    # 120 min)
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        text = spoken_digits(s / size)
        if abs(float(text)) >= 2:
            return f"{text} {unit}"
    return f"{spoken_digits(s)} s"


def spoken_digits(x: float) -> str:
    """``x`` as :func:`spoken_duration` (and a time left,
    :func:`~analyzer.time_left.left_text`) writes it: one decimal below 10, none above,
    by the number as written (9.98 is ``10``: ``10.0`` had a decimal above 10)."""
    text = f"{x:.1f}"
    return text if abs(float(text)) < 10 else f"{x:.0f}"


def seconds_text(x: float, decimals: int = 3) -> str:
    """A time (or span) in seconds to ``decimals`` decimals, without an exponent, rounded
    half up from whole nanoseconds as :func:`iso_utc` rounds to the millisecond: every
    line, the report and findings.json's ISO times then say one time alike. An onset at
    300.0625 s was ``300.062 s`` in the report (half to even) and ``300.063 s`` on
    stderr (a value a hair above it), a note's time ``41.1003 s`` (``:.6g``)."""
    v = float(x)
    if not np.isfinite(v):
        return f"{v}"
    ns = int(round(v * NS_PER_S))
    unit = 10 ** (9 - decimals)
    q = (ns + unit // 2) // unit  # (half up: toward the later time, as iso_utc)
    whole, frac = divmod(abs(q), 10**decimals)
    sign = "-" if q < 0 else ""
    return f"{sign}{whole}.{frac:0{decimals}d}" if decimals > 0 else f"{sign}{whole}"


def window_text(start_s: float, end_s: float) -> str:
    """A ``--train`` window as a user types it, each end to the millisecond without
    trailing zeros (``47.4:225.206``, not ``47.4004:225.206``)."""
    return f"{short_seconds(start_s)}:{short_seconds(end_s)}"


def short_seconds(x: float) -> str:
    """:func:`seconds_text` without trailing zeros (``12``, ``47.4``)."""
    text = seconds_text(x)
    return text.rstrip("0").rstrip(".") if "." in text else text


def plain_number(x: float, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits without an exponent from 1e-3 to 1e9
    (``2000``, not ``2e+03``; ``1234``, not ``1.23e+03``: digits before the point are
    kept), for rates and counts in a user's line."""
    v = float(x)
    text = f"{v:.{digits}g}"
    if "e" in text and np.isfinite(v) and 1e-3 <= abs(v) < 1e9:
        return f"{v:.0f}" if abs(v) >= 1 else f"{v:.{digits + 3}f}".rstrip("0")
    return text


EPOCH_LINE_NS = 100_000_000 * NS_PER_S
"""An input's times at or after this (1e8 s since 1970: 1973-03-03T09:46:40Z) are Unix
times (UTC); before it, relative times (seconds from a start, a simulation clock,
nanoseconds since boot). The one line by which the readers decide
(:attr:`~analyzer.readers.base.InputInfo.absolute_time`), which ``run``, ``inspect`` and
``export`` then take as it is. Why 1973 and not later: a logger whose clock was never
set writes dates from 1980-01-01 (the FAT file system's and GPS's start), and that
date, said as such, is what shows the user the clock was never set (relative seconds
hide it); a relative clock reaches 1e8 s only after 3.2 years of counting. Header stamps,
judged beside the recorder's log times, keep a later line of their own
(:data:`~analyzer.readers._common.HEADER_EPOCH_NS`)."""


def plausible_epoch(ns: int) -> bool:
    """True when ``ns`` is a Unix time by :data:`EPOCH_LINE_NS` (relative clocks and bags
    recorded with simulated time start near zero)."""
    return bool(ns >= EPOCH_LINE_NS)


TIME_DECIMALS = 4
"""Decimals findings.json (and the saved model, the corrections) keep of a time in
seconds: ``onset_s``, ``end_s``, a window's ``start_s``... A tenth of a millisecond
tells one sample from the next up to 10 kHz (:func:`json_time`)."""

DURATION_DECIMALS = 6
"""Decimals findings.json keeps of the record's length ``duration_s``, and of the
record's end where it is written as a time (``saved_model.searched.end_s``): it is the
same number, so it reads alike in both fields."""


def json_time(x: float) -> float:
    """A time in seconds as findings.json writes it: to :data:`TIME_DECIMALS`."""
    return round(x, TIME_DECIMALS)


ROW_SLACK = 1e-6
"""Of a sample period: how far a window's end may lie past a row's time (float error in
``seconds * rate``) and still be read as on it."""


def rows_within(start_s: float, end_s: float, rate_hz: float) -> tuple[int, int]:
    """The rows ``[a, b)`` of a clock at ``rate_hz`` from 0 s whose times lie inside the
    window ``start_s``-``end_s`` (both ends in): its first row at or after the start, its
    last at or before the end. Rounded to the nearest row, ``--train 20:300`` on a
    16.67 Hz clock trained from 19.98 s, a sample before the window asked for."""
    a = int(np.ceil(start_s * rate_hz - ROW_SLACK))
    b = int(np.floor(end_s * rate_hz + ROW_SLACK)) + 1
    return a, b

"""Logger outages: stretches in which every analyzed channel reads one common value at
once (the logger wrote zeros) or repeats its own previous value exactly (the logger hung
and wrote its last row again and again).

Neither is a sensor fault, but the detectors saw one: a 6-channel building that read
exactly 0.0 on every channel for 2 s got a fault on s2 from the equivalent model
(``other``, or a gain of 0.008 beside a real offset on s4), and a record whose rows all
froze for 2 s an anomaly "attributed to no sensor". Such rows are taken as missing data
here (NaN in every channel: a gap to every detector, which settles again after it, as
after any gap), before any detector sees them, and a note of the run says so
(:func:`treat_outages`).

The rule. A row *holds* when every analyzed channel (at least :data:`MIN_CHANNELS`)
reads exactly its value of the row before; a stretch is a run of held rows (and, when the
row before the run has every channel at one value, the zeros case, that row too). A
stretch that holds at least :data:`MIN_ROWS` rows is a candidate, and an outage when at
least :data:`MIN_WITNESSES` of its channels *witness* it: a witness is a busy channel
(one that changes value from one row to the next in at least :data:`BUSY_SHARE` of the
record's rows, outages included, so an outage never makes a channel look busier) whose
longest run of exact repeats in the record, with the rows of this stretch and of the
record's other outages taken out, is shorter than half the stretch's length. Every
other row counts: the other candidates that are no outage (a quiet spell's holds, the
channels' own repeats) and the parts of the channel's run holding the stretch that
reach beyond it. Which candidates are outages thus depends on which others are, so they
are decided together: every candidate is taken as one at first, and those that fail
are dropped, their rows then counting against the rest, until none fails (a drop only
lengthens the runs that count, so a few passes end it). Why that is safe:

* Slow, quantized channels (a temperature at 0.1 K that holds for minutes, a status
  flag) are never witnesses: they change in fewer than half the rows. A record of such
  channels alone, all holding through a quiet night, gets no note; a stuck sensor (a
  real fault) beside slow channels has one witness, not two, and stays a finding.
* A quantized accelerometer in a quiet stretch repeats its counts, and its runs of
  repeats are longest where it is quietest: the longest of them outside the stretch
  under test, ``R``, is the one a record of ``N`` rows shows at chance ``~1/N`` per row
  in that regime. Runs shorten at least geometrically with their length, so a run of
  ``2 R`` rows has a chance ``~1/N**2`` per row, ``~1/N`` over the record, for one
  channel; two witnesses at once, however correlated, no more. A floating-point
  channel (``R`` of 0 or 1) witnesses any stretch of :data:`MIN_ROWS` rows or more.
  Real data needs this: in PlotJuggler's ``motor_data.csv`` every channel holds for 23
  rows at once, and its busy channels hold for 15-28 rows on their own elsewhere: no
  outage.
* The quiet spell's other holds count in ``R``: there, every channel reads one count
  together now and then, for stretches of every length, and those stretches are its
  longest runs. Leaving every candidate's rows out of ``R`` took ``R`` from the lively
  part of the record instead: a building at 1/30 of its amplitude for its last 40 s, on
  counts of 1/10 of its healthy sd, had 7.8 s of quiet data called outages. Only other
  outages' rows are left out, so a 0.4 s outage beside a 3 s one is found too.
* What no rule on the values can tell apart: a quiet spell in which every channel reads
  one count for all of it, with nothing as long elsewhere (that building at 1/100 of
  its amplitude reads exactly 0.0 on every channel from 80 s to its end), is what a
  logger writing zeros writes, and is an outage here; so is a single hold of a quiet
  spell more than twice as long as any other run of its channels (in simulations, at
  times, at 1/25 to 1/15 of the amplitude).
* Two channels never make an outage (:data:`MIN_CHANNELS`), and one channel frozen
  while another moves is no held row at all.

The pass is vectorized, a block of rows at a time with one row carried across block
boundaries (an outage spanning two blocks is one stretch), and reads a memory-mapped
record a block at a time (:func:`~analyzer.paging.row_blocks`). A record without a
stretch of :data:`MIN_ROWS` held rows (every record with a vibrating channel and no
outage) costs one comparison of each row with the row before; only a record with one
takes the passes that count each channel's repeats (one, and one more after each drop).

Exact equality is what a logger that repeats or zeroes its rows writes, and what the
alignment keeps for channels sampled on the common clock (and interpolated between two
equal samples); a channel decimated by the low-pass filter before resampling does not
repeat exactly, and a stretch in which some channels are missing (NaN) is no held row:
both are left to the detectors as before.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.errors import counted
from analyzer.paging import RELEASE_ROWS, release, row_blocks
from analyzer.readers import ArchiveNote

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

MIN_CHANNELS = 3
"""Analyzed channels below which no stretch is an outage: two channels that hold together
may be one sensor's, or two quiet ones."""

MIN_ROWS = 10
"""Held rows a stretch needs at the least (and more where a witness repeats its values
for longer elsewhere): a row written twice or thrice is left alone, since as a gap it
would make the detectors settle again for longer than the repeat lasts."""

MIN_WITNESSES = 2
"""Busy channels that must hold for more than twice their longest run of repeats
outside the stretch (and the other outages): one alone is a stuck sensor, a fault."""

BUSY_SHARE = 0.5
"""Share of a channel's consecutive pairs of rows (both finite) that differ, from which
the channel is busy (a vibrating or noisy sensor, not a slow or quantized one)."""

SCAN_VALUES = 1 << 20
"""Values (rows times channels) a block of the scan holds, at most :data:`RELEASE_ROWS`
rows: the counting pass keeps a few integer arrays of a block's shape."""

LISTED = 3
"""Stretches a note names one by one; the rest are counted."""


@dataclass(frozen=True, slots=True)
class Outage:
    """Rows ``start .. end - 1`` of the aligned matrix, in which every analyzed channel
    read ``value`` (the zeros case) or, with ``value`` None, repeated its values of row
    ``start - 1`` (the logger repeated its last row)."""

    start: int
    end: int
    value: float | None


class OutageNote(ArchiveNote):
    """The note on a run's logger outages (:func:`outage_note`): a plain string among the
    run's notes (``findings.json``, the report) that ``analyzer run`` also repeats on
    stderr, with the archive's own notes (an :class:`~analyzer.readers.ArchiveNote`: a
    note on the recording, not on a sensor)."""

    __slots__ = ()


def treat_outages(values: Any, channels: Sequence[str], rate_hz: float, notes: list[str]) -> None:
    """Find the logger outages of the aligned matrix ``values`` (rows on the common clock,
    a column per channel of ``channels``; in memory or memory-mapped), make their rows
    missing data (NaN, in place) and add a note to ``notes`` when there is one."""
    outages = find_outages(values)
    if not outages:
        return
    mask_outages(values, outages)
    notes.append(outage_note(outages, channels, rate_hz))


def find_outages(values: Any) -> list[Outage]:
    """The logger outages of ``values`` ((n, m) rows by channels), by the module's rule,
    in time order."""
    n, m = values.shape
    if m < MIN_CHANNELS or n < MIN_ROWS + 1:
        return []
    rows = max(1, min(RELEASE_ROWS, SCAN_VALUES // m))
    starts, ends = _held_stretches(values, rows)
    if starts.size == 0:
        return []
    # every stretch an outage at first; drop those that fail, whose rows then count as
    # the channels' own repeats against the rest, until none fails
    out = np.ones(starts.size, dtype=bool)
    length = ends - starts
    while True:
        busy, longest = _repeats(values, starts, ends, rows, out)
        if np.count_nonzero(busy) < MIN_WITNESSES:
            return []
        witnesses = (busy[None, :] & (length[:, None] > 2 * longest)).sum(axis=1)
        keep = out & (witnesses >= MIN_WITNESSES)
        if not keep.any():
            return []
        if np.array_equal(keep, out):
            break
        out = keep
    starts, ends = starts[out], ends[out]
    # the row before each stretch: at one value in every channel, it is the outage's
    # first row (the logger's first zero row); else the last row the logger read
    before = np.asarray(values[starts - 1], dtype=np.float64)
    common = (before == before[:, :1]).all(axis=1)
    return [
        Outage(int(s) - 1, int(e), float(row[0])) if one else Outage(int(s), int(e), None)
        for s, e, row, one in zip(starts, ends, before, common, strict=True)
    ]


def mask_outages(values: Any, outages: Sequence[Outage]) -> None:
    """Every channel of the rows of ``outages`` made NaN (missing data), in place."""
    for o in outages:
        for lo in range(o.start, o.end, RELEASE_ROWS):
            hi = min(o.end, lo + RELEASE_ROWS)
            values[lo:hi] = np.nan
            release(values[lo:hi])


def outage_note(outages: Sequence[Outage], channels: Sequence[str], rate_hz: float) -> OutageNote:
    """One line on ``outages`` (at least one): each stretch with its times when there is
    one, else their count, their total time and the first :data:`LISTED` of them."""
    digits = max(2, int(np.ceil(np.log10(rate_hz)))) if rate_hz > 0 else 2
    m = len(channels)

    def span(o: Outage) -> str:
        return f"{o.start / rate_hz:.{digits}f} s to {o.end / rate_hz:.{digits}f} s"

    def what(o: Outage) -> str:
        if o.value is not None:
            text = f"{o.value + 0.0:.6g}"  # + 0.0: a quantized zero may be -0.0
            return f"read exactly {text if any(c in text for c in '.en') else text + '.0'}"
        return f"repeated their values of {(o.start - 1) / rate_hz:.{digits}f} s exactly"

    if len(outages) == 1:
        o = outages[0]
        rows = o.end - o.start
        return OutageNote(
            f"logger outage: all {m} channels {what(o)} from {span(o)} ({counted(rows, 'row')}; "
            "the data acquisition, not a sensor); treated as missing data"
        )
    total = sum(o.end - o.start for o in outages)
    listed = "; ".join(f"{span(o)}, {what(o)}" for o in outages[:LISTED])
    more = f"; {len(outages) - LISTED} more" if len(outages) > LISTED else ""
    return OutageNote(
        f"logger outages: {len(outages)} stretches in which all {m} channels read one value "
        f"at once or repeated their values exactly, {total / rate_hz:.{digits}f} s in all "
        f"({total} rows; the data acquisition, not a sensor), treated as missing data: "
        f"{listed}{more}"
    )


def _held_stretches(values: Any, rows: int) -> tuple[IntArray, IntArray]:
    """Starts and ends (exclusive) of the runs of at least :data:`MIN_ROWS` held rows
    (every channel equal to its value of the row before; NaN never is), a block of
    ``rows`` rows at a time with the last row carried."""
    starts: list[IntArray] = []
    ends: list[IntArray] = []
    carry: npt.NDArray[np.float64] | None = None
    open_at = -1
    for lo, block in row_blocks(values, rows):
        b = np.asarray(block, dtype=np.float64)
        held = np.empty(b.shape[0], dtype=bool)
        held[0] = carry is not None and bool((b[0] == carry).all())
        held[1:] = (b[1:] == b[:-1]).all(axis=1)
        carry = b[-1].copy()
        s, e, open_at = _runs(held, lo, open_at)
        long = e - s >= MIN_ROWS
        starts.append(s[long])
        ends.append(e[long])
    if open_at >= 0 and values.shape[0] - open_at >= MIN_ROWS:
        starts.append(np.array([open_at], dtype=np.int64))
        ends.append(np.array([values.shape[0]], dtype=np.int64))
    return np.concatenate(starts), np.concatenate(ends)


def _runs(mask: BoolArray, lo: int, open_at: int) -> tuple[IntArray, IntArray, int]:
    """The runs of True in ``mask`` (rows ``lo .. lo + len(mask) - 1``, not empty) that
    end in it, as starts and ends (exclusive), a run open since row ``open_at`` (-1:
    none) continuing into it; and the start of the run still open at its end (-1:
    none)."""
    edges = np.diff(mask.astype(np.int8), prepend=np.int8(open_at >= 0), append=np.int8(0))
    starts = np.flatnonzero(edges == 1).astype(np.int64) + lo
    ends = np.flatnonzero(edges == -1).astype(np.int64) + lo
    if open_at >= 0:
        starts = np.concatenate(([open_at], starts)).astype(np.int64)
    if mask[-1]:  # the last run goes on into the next block
        return starts[:-1], ends[:-1], int(starts[-1])
    return starts, ends, -1


def _repeats(
    values: Any, starts: IntArray, ends: IntArray, rows: int, out: BoolArray
) -> tuple[BoolArray, IntArray]:
    """Per channel, whether it is busy (:data:`BUSY_SHARE` of its consecutive finite
    pairs differ, counted over every row); and per held stretch ``starts[i] ..
    ends[i] - 1`` (rows) and channel (columns), the channel's longest run of exact
    repeats (rows equal to the row before, counted) with the rows of that stretch and of
    the stretches taken as outages (``out``) taken out: every other row counts, those of
    the other held stretches included.

    With the outages' rows taken out, every channel repeats in each row of a stretch that
    is not one of them, so exactly one of its runs holds that stretch; the longest run
    with the stretch taken out too is the longest of the channel's other runs (its
    longest, or its second longest when the holding run is as long as the longest) or
    the longer of the holding run's two parts before and after the stretch. For an
    outage, it is the channel's longest run. A pass a block of ``rows`` rows at a time
    keeps the lengths of each channel's two longest runs closed so far and its open run
    (carried to the next block, so a run across a block boundary counts whole), and
    notes the length and end of each channel's run holding each tested stretch once it
    closes."""
    n, m = values.shape
    cols = np.arange(m)
    out_starts, out_ends = starts[out], ends[out]
    tested = np.flatnonzero(~out)  # the stretches whose holding runs are wanted
    test_ends = ends[tested]
    pairs = np.zeros(m, dtype=np.int64)
    same = np.zeros(m, dtype=np.int64)
    run = np.zeros(m, dtype=np.int64)  # each channel's open run at the last row read
    top = np.zeros((2, m), dtype=np.int64)  # its two longest runs closed so far, rising
    held_len = np.zeros((tested.size, m), dtype=np.int64)  # the run holding a stretch
    held_end = np.full((tested.size, m), -1, dtype=np.int64)  # its end; -1: still open
    done = 0  # the tested stretches before it have their holding runs closed everywhere
    carry: npt.NDArray[np.float64] | None = None
    for lo, block in row_blocks(values, rows):
        b = np.asarray(block, dtype=np.float64)
        k = b.shape[0]
        fin = np.isfinite(b)
        eq = np.empty(b.shape, dtype=bool)
        both = np.empty(b.shape, dtype=bool)
        if carry is None:
            eq[0] = both[0] = False
        else:
            eq[0] = b[0] == carry
            both[0] = fin[0] & np.isfinite(carry)
        np.equal(b[1:], b[:-1], out=eq[1:])
        np.logical_and(fin[1:], fin[:-1], out=both[1:])
        carry = b[-1].copy()
        pairs += both.sum(axis=0)
        same += eq.sum(axis=0)
        # the outages' rows are the logger's, no evidence of a channel's own repeats
        lo_k = np.searchsorted(out_ends, lo, "right")
        hi_k = np.searchsorted(out_starts, lo + k)
        if hi_k > lo_k:
            edge = np.zeros(k + 1, dtype=np.int64)
            np.add.at(edge, np.clip(out_starts[lo_k:hi_k] - lo, 0, k), 1)
            np.add.at(edge, np.clip(out_ends[lo_k:hi_k] - lo, 0, k), -1)
            eq &= ~(np.cumsum(edge[:k]) > 0)[:, None]
        # each row's run of repeats so far: rows since the last row that is no repeat
        at = np.arange(1, k + 1, dtype=np.int64)[:, None]
        last = np.maximum.accumulate(np.where(eq, 0, at), axis=0)
        length = at - last + np.where(last == 0, run[None, :], 0)
        # the runs that close here, each at index x (its end is row lo + x): x = 0 for
        # the run left open by the last block that this block's first row breaks, r + 1
        # for a run whose last repeat is the block's row r and not its last row (that
        # run closes in the next block, or here at the record's end)
        stop = np.empty((k + 1, m), dtype=bool)
        stop[0] = (run > 0) & ~eq[0]
        np.logical_and(eq[:-1], ~eq[1:], out=stop[1:k])
        stop[k] = eq[-1] if lo + k == n else False
        closed = np.empty((k + 1, m), dtype=np.int64)  # their lengths, 0 elsewhere
        np.multiply(run, stop[0], out=closed[0])
        np.multiply(length, stop[1:], out=closed[1:])
        # the two longest (a tie: the same length twice); only lengths are kept, since a
        # longest run that ties with the holding run of a stretch has the same length
        first = closed.max(axis=0)
        ties = np.count_nonzero(closed == first, axis=0) > 1
        second = np.where(ties, first, np.where(closed < first, closed, 0).max(axis=0))
        top = np.sort(np.vstack([top, first, second]), axis=0)[2:]
        # the runs holding the tested stretches that end by this block's last row: each
        # closes at the first index at or after the stretch's last row (index 0 for a
        # stretch of an earlier block, whose run was still open at that block's end)
        upto = int(np.searchsorted(test_ends, lo + k, "right"))
        if upto > done:
            index = np.where(stop, np.arange(k + 1, dtype=np.int64)[:, None], k + 1)
            following = np.minimum.accumulate(index[::-1], axis=0)[::-1]
            for i in range(done, upto):
                x = following[max(int(test_ends[i]) - lo, 0)]
                now = (x <= k) & (held_end[i] < 0)
                x, j = x[now], cols[now]
                held_len[i, now] = np.where(x == 0, run[j], length[x - 1, j])
                held_end[i, now] = lo + x
            while done < upto and (held_end[done] >= 0).all():
                done += 1
        run = length[-1]
    busy = (pairs > 0) & (pairs - same >= BUSY_SHARE * pairs)
    longest = np.empty((starts.size, m), dtype=np.int64)
    longest[out] = top[1]
    other = np.where(top[1] == held_len, top[0], top[1])
    begun = held_end - held_len
    before, after = starts[tested, None] - begun, held_end - ends[tested, None]
    longest[tested] = np.maximum(other, np.maximum(before, after))
    return busy, longest

"""Pieces every reader shares: byte gathering, decoded batches, time ordering, hashing.

The readers cut an input into *batches* (an MCAP chunk, a ROS 1 chunk, a few thousand
rows of a sqlite table or CSV), decode every channel of a batch with whole-array
operations, and hand the samples to a :class:`Reorderer`, which makes sure the
:class:`~analyzer.readers.base.ChannelChunk` stream of each channel is in time order
without holding more than a batch or two in memory.
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import stat
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path, PurePath
from typing import Any

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from analyzer.errors import (
    IntegrityError,
    ReaderError,
    capped,
    counted,
    one_line,  # noqa: F401 - re-exported for the readers
)
from analyzer.readers.base import DAMAGE, ChannelChunk
from analyzer.readers.delays import LogDelays
from analyzer.readers.quaternions import QuaternionSigns
from analyzer.readers.tally import Tally
from analyzer.timeutil import iso_utc, plausible_epoch, seconds_text, spoken_duration
from analyzer.types import NS_PER_S

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]
ByteArray = npt.NDArray[np.uint8]

NO_STAMP = np.iinfo(np.int64).min
"""Header-stamp placeholder for a message without a header (its log time is used)."""

HASH_BLOCK = 1 << 20
"""Files are hashed in 1 MiB blocks so that hashing a large archive needs no memory."""

RELEASE_SAMPLES = 1 << 21
"""Samples (all channels) a :class:`Reorderer` gathers before releasing: fewer, larger
chunks downstream, at most ~32 MB held."""

REORDER_WINDOW_NS = 2_000_000_000
"""Where no bound on future timestamps is known (header stamps, unindexed files), samples
within this many nanoseconds of the newest one are held back for the next batch."""

DST_STEP_NS = (1_800_000_000_000, 3_600_000_000_000 + REORDER_WINDOW_NS)
"""A step back in this range (more than half an hour, at most an hour) in times without
a zone is named as the change from summer to winter time (refused where more than
:data:`LEAD_GLITCH_MESSAGES` rows in a row lie that far back);
a jump forward in this range over a whole hour of the clock, as the change to summer
time (:func:`hour_skipped`)."""
HOUR_NS = 3_600_000_000_000


def hour_skipped(t: IntArray, previous: int | None) -> int | None:
    """The index in ``t`` of the first time that follows the time before it (``previous``
    before ``t[0]``) by more than half an hour and at most an hour and the reorder window
    (:data:`DST_STEP_NS`) and skips a whole hour of the clock (``01:59:59.98`` to
    ``03:00:00.00``, the change to summer time in local times), else None."""
    ext = t if previous is None else np.concatenate(([previous], t))
    if ext.size < 2:
        return None
    d = np.diff(ext)
    jump = (d > DST_STEP_NS[0]) & (d <= DST_STEP_NS[1])
    if not bool(jump.any()):
        return None
    before, after = ext[:-1], ext[1:]
    skipped = jump & (after >= (before // HOUR_NS + 2) * HOUR_NS)
    if not bool(skipped.any()):
        return None
    return int(np.argmax(skipped)) + (0 if previous is not None else 1)


EMPTY_T: IntArray = np.zeros(0, dtype=np.int64)
EMPTY_V: FloatArray = np.zeros(0, dtype=np.float64)


# --------------------------------------------------------------------------- bytes


def as_bytes_array(data: bytes | bytearray | memoryview) -> ByteArray:
    """A read-only uint8 view of ``data`` (no copy)."""
    return np.frombuffer(data, dtype=np.uint8)


def gather_uint(buf: ByteArray, offsets: IntArray, width: int, endian: str = "<") -> IntArray:
    """Unsigned integers of ``width`` bytes read at every offset of ``offsets`` in ``buf``,
    as int64 (uint64 values above 2**63 wrap; callers use this for lengths and times)."""
    if offsets.size == 0:
        return EMPTY_T.copy()
    rows = sliding_window_view(buf, width)[offsets]
    values = np.ascontiguousarray(rows).view(f"{endian}u{width}").ravel()
    return values.astype(np.int64)


def field_view(rows: ByteArray, offset: int, dtype: str) -> npt.NDArray[Any]:
    """Column ``offset`` of a C-contiguous (n, size) byte matrix read as ``dtype`` (a view)."""
    return np.ndarray(
        shape=(rows.shape[0],), dtype=dtype, buffer=rows, offset=offset, strides=(rows.shape[1],)
    )


def gather_rows(buf: ByteArray, starts: IntArray, size: int) -> ByteArray:
    """The ``size``-byte records starting at ``starts`` as one C-contiguous (n, size) array.

    Equally spaced records (one channel per chunk, the common case) are copied with one
    strided copy; otherwise rows are gathered with one fancy-indexing copy.
    """
    n = int(starts.shape[0])
    if n == 0 or size == 0:
        return np.zeros((n, size), dtype=np.uint8)
    if n > 1:
        steps = np.diff(starts)
        step = int(steps[0])
        if step >= size and bool(np.all(steps == step)):
            view = np.lib.stride_tricks.as_strided(
                buf[int(starts[0]) :], shape=(n, size), strides=(step, 1), writeable=False
            )
            return np.array(view, dtype=np.uint8, order="C")
    return np.ascontiguousarray(sliding_window_view(buf, size)[starts])


def concat_payloads(payloads: Sequence[bytes]) -> tuple[ByteArray, IntArray, IntArray]:
    """Join message payloads into one buffer; returns (buffer, starts, sizes).

    ``b"".join`` and ``map(len, ...)`` run in C: no Python bytecode per message.
    """
    count = len(payloads)
    sizes = np.fromiter(map(len, payloads), dtype=np.int64, count=count)
    starts = np.cumsum(sizes) - sizes
    return as_bytes_array(b"".join(payloads)), starts, sizes


# --------------------------------------------------------------------------- decoded batches


@dataclass(frozen=True, slots=True)
class Relabel:
    """A change of a string array (``name`` of a ``JointState``) between two messages of
    a batch, or between a batch's first message and the message before it: the numeric
    arrays beside it (``siblings``) keep their index, so ``position[0]`` now belongs to
    another name. ``count`` is the number of such changes in the batch."""

    field: str
    row: int
    before: tuple[str, ...]
    after: tuple[str, ...]
    count: int
    siblings: tuple[str, ...] = ()


LabelEnds = tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...], tuple[tuple[str, ...], ...]]
"""A string array in a batch: its first and last message's strings, its siblings and its
contents (:attr:`Decoded.label_ends`)."""

LabelRows = tuple[IntArray, IntArray, tuple[tuple[str, ...], ...]]
"""A string array in a batch, message by message: the rows that have it, the index of
each one's content among the contents, and the contents (:attr:`Decoded.label_rows`)."""


@dataclass(slots=True)
class Decoded:
    """Numeric fields of a batch of ``n`` messages of one topic.

    ``columns`` maps a field path (``linear_acceleration.x``, ``data[3]``) to the message
    rows that have it (``None``: every row) and its values. ``stamps`` holds each
    message's header stamp in nanoseconds (``NO_STAMP`` where it has none), or is
    ``None`` when no message has a header.
    """

    n: int
    columns: dict[str, tuple[IntArray | None, FloatArray]] = field(default_factory=dict)
    stamps: IntArray | None = None
    failed: int = 0
    first_error: str = ""
    relabels: list[Relabel] = field(default_factory=list)
    """Where a string array beside numeric arrays (``JointState.name``) changed content."""
    label_ends: dict[str, LabelEnds] = field(default_factory=dict)
    """Per such string array: its strings in the batch's first and last message, its
    siblings (:class:`Relabel`) and its contents in the batch, for the comparison with
    the topic's batches before."""
    label_rows: dict[str, LabelRows] = field(default_factory=dict)
    """Per such string array whose content changes in the batch, into at most
    :data:`BY_NAME_ORDERS` contents: which content each message has (the topic's
    tracker puts a ``JointState``'s values back in one order by name:
    :func:`by_name`)."""

    def note_failure(self, err: BaseException | str, count: int = 1) -> None:
        """Count ``count`` undecodable messages, keeping the first reason."""
        self.failed += count
        if not self.first_error:
            self.first_error = str(err).splitlines()[0] if str(err) else type(err).__name__

    def subset(self, keep: npt.NDArray[np.bool_]) -> Decoded:
        """The messages (rows) where ``keep`` is true, their columns renumbered."""
        new_row = np.cumsum(keep) - 1
        columns: dict[str, tuple[IntArray | None, FloatArray]] = {}
        for name, (rows, values) in self.columns.items():
            if rows is None:
                columns[name] = (None, values[keep])
                continue
            inside = keep[rows]
            if bool(inside.any()):
                columns[name] = (new_row[rows[inside]], values[inside])
        n = int(np.count_nonzero(keep))
        stamps = None if self.stamps is None else self.stamps[keep]
        return Decoded(
            n, columns, stamps, self.failed, self.first_error, self.relabels, self.label_ends
        )


class ColumnAccumulator:
    """Collects (row, value) pairs per field from a per-message fallback decoder and
    turns them into :class:`Decoded` columns."""

    def __init__(self) -> None:
        self._rows: dict[str, list[int]] = {}
        self._values: dict[str, list[float]] = {}

    def add(self, row: int, flat: dict[str, float]) -> None:
        for name, value in flat.items():
            rows = self._rows.get(name)
            if rows is None:
                rows = self._rows[name] = []
                self._values[name] = []
            rows.append(row)
            self._values[name].append(value)

    def into(self, decoded: Decoded) -> None:
        for name, rows in self._rows.items():
            r = np.asarray(rows, dtype=np.int64)
            v = np.asarray(self._values[name], dtype=np.float64)
            decoded.columns[name] = (None if r.size == decoded.n else r, v)


def merge_parts(
    parts: dict[str, list[tuple[IntArray | None, FloatArray]]], n: int
) -> dict[str, tuple[IntArray | None, FloatArray]]:
    """Merge per-group columns (one group per message layout) back into row order."""
    merged: dict[str, tuple[IntArray | None, FloatArray]] = {}
    for name, pieces in parts.items():
        if len(pieces) == 1:
            rows, values = pieces[0]
            merged[name] = (None if rows is not None and rows.size == n else rows, values)
            continue
        all_rows = np.concatenate(
            [np.arange(n, dtype=np.int64) if r is None else r for r, _ in pieces]
        )
        all_values = np.concatenate([v for _, v in pieces])
        order = np.argsort(all_rows, kind="stable")
        rows_sorted = all_rows[order]
        merged[name] = (None if rows_sorted.size == n else rows_sorted, all_values[order])
    return merged


BY_NAME_ORDERS = 16
"""Most contents a string array takes in one batch for the numeric arrays beside it to be
put back in one order by name (:func:`by_name`): a driver restarted now and then
publishes its joints in another order; more contents than this in a batch are no order
of a few names, and are left out as before."""


def by_name(
    columns: dict[str, tuple[IntArray | None, FloatArray]],
    siblings: Sequence[str],
    n: int,
    rows: IntArray,
    codes: IntArray,
    targets: Sequence[Sequence[int]],
) -> dict[str, tuple[IntArray | None, FloatArray]]:
    """``columns`` (of a batch of ``n`` messages) with the elements of the numeric arrays
    ``siblings`` (``position[j]``) of the messages ``rows``, whose string array has the
    content ``codes``, moved to the index ``targets[code][j]``: that of their name in the
    topic's first order. One selection per element and content, not per message; the
    other columns, and the messages without the string array, as they are."""
    width = max((len(t) for t in targets), default=0)
    table = np.tile(np.arange(width, dtype=np.int64), (len(targets), 1))
    for k, t in enumerate(targets):
        table[k, : len(t)] = t
    row_code = np.full(n, -1, dtype=np.int64)
    row_code[rows] = codes
    pattern = re.compile(rf"({'|'.join(map(re.escape, siblings))})\[(\d+)\]")
    parts: dict[str, list[tuple[IntArray | None, FloatArray]]] = {}
    for name, (r, v) in columns.items():
        m = pattern.fullmatch(name)
        j = int(m[2]) if m else width
        if m is None or j >= width:
            parts.setdefault(name, []).append((r, v))
            continue
        at = np.arange(n, dtype=np.int64) if r is None else r
        code = row_code[at]
        target = np.where(code >= 0, table[np.maximum(code, 0), j], j)
        for t in np.unique(target).tolist():
            sel = target == t
            parts.setdefault(f"{m[1]}[{t}]", []).append((at[sel], v[sel]))
    merged = merge_parts(parts, n)
    first = {name: k for k, name in enumerate(columns)}
    return {k: merged[k] for k in sorted(merged, key=lambda k: first.get(k, len(first)))}


# --------------------------------------------------------------------------- per-topic notes

BoolArray = npt.NDArray[np.bool_]

HEADER_EPOCH_NS = 10**18
"""Header stamps at or above this (1e9 s, 2001-09-09T01:46:40Z) are wall-clock (Unix
epoch) times; a topic whose nonzero stamps are mostly below it runs on a simulation clock
(Gazebo's ``/clock`` starts at 0; 1e9 s is 31.7 years of simulated time), on which a
stamp of 0 is a real time, not "unset". Later than the line of an input's own times
(:data:`~analyzer.timeutil.EPOCH_LINE_NS`, 1973) on purpose: header stamps are judged
beside the recorder's log times, a wall clock of this century, and a node whose clock
was never set (stamps from 1980) keeps a clock of its own as a simulation does; the
input's own times have no other clock beside them, and their date, 1980 or not, is
said."""

CLOCKS_APART_NS = 3600 * 10**9
"""Header stamps that lie this far (an hour) and more from the other topics' times, and
further than the recording lasts, are on a second clock (:meth:`TopicTracker._apart`):
far beyond any delay from stamp to log; a message latched that long before the
recording (a map stamped when its server started) cannot be aligned with the rest
either, its one sample stretching the common clock over the empty hour."""


WALL_CLOCK_STEP_NS = 10 * 10**9
"""A header clock of Unix (wall-clock) times that moves against the log times by more
than this (10 s) and stays, its stamps jumping by as much, was set during the recording
(:meth:`TopicTracker._steps`). The offset from stamp to log is a transport latency and a
recorder's queue (milliseconds to about a second), or an estimate stamped with the time
of the data it was made from (AMCL's pose: seconds); NTP steps a clock from 128 ms on.
The real recordings' largest sustained change of that offset is 1.7 s, their widest
spread 4.9 s (``/amcl_pose`` of ``nav2_turtlebot.mcap``). A simulation clock in the
headers (stamps below :data:`HEADER_EPOCH_NS`) keeps :data:`CLOCKS_APART_NS`: a simulation
paused or slowed moves it against the recorder's wall clock by any amount."""


def absolute_log_time(
    start: Callable[[], int | None],
    end: Callable[[], int | None] | None = None,
    damage: tuple[type[Exception], ...] = (),
) -> bool:
    """Whether a recording whose first and last log times ``start()`` and ``end()``
    give keeps Unix (wall-clock) times (:attr:`InputInfo.absolute_time`): False where it
    ends before 1973 (:func:`~analyzer.timeutil.plausible_epoch`, the one rule by which a
    report gives ``start: null``): a simulation clock (Gazebo's ``/clock`` from 0, a
    harness from 0.1 s), counted from its own start like a CSV without dates, so that
    files of several such runs are not stitched as one (:func:`analyzer.readers._one_span`).
    The end decides, not the start: a 2023 recording with one message logged at 0 (a
    constant published before the clock was set) keeps its dates (the review). True
    where it has no message, or its times cannot be read: ``start`` or ``end`` raises
    :data:`~analyzer.readers.base.DAMAGE` or ``damage`` (the reader's libraries', whose
    damage is said while reading); any other exception is a bug, and raised."""
    damaged: tuple[type[Exception], ...] = (ReaderError, *DAMAGE, *damage)
    try:
        last = end() if end is not None else None
        if last is None:
            last = start()
    except damaged:  # a damaged file: its reader says so when read
        return True
    return last is None or plausible_epoch(last)


def two_clocks(clocks: dict[str, str], spans: dict[str, tuple[int, int]]) -> str:
    """What ``--time header`` did where the topics' times come from two clocks
    (:meth:`TopicTracker.clocks`: topic to ``"header"``, the side timed by header
    stamps on a clock of their own, or ``"log"``/``"stamped"``, the other side's topics
    timed by their log times or their header stamps), each side's topics with the span
    of their times (``spans``: first and last, nanoseconds), and what to do."""

    def listed(topics: list[str]) -> str:
        return capped(topics)

    def side(*sources: str) -> tuple[list[str], int, int]:
        topics = [t for t, s in clocks.items() if s in sources]
        lo = min(spans[t][0] for t in topics if t in spans)
        hi = max(spans[t][1] for t in topics if t in spans)
        return topics, lo, hi

    def when(lo: int, hi: int) -> str:
        if hi >= HEADER_EPOCH_NS:
            return f"Unix times, {iso_utc(lo)} to {iso_utc(hi)}"
        return (
            f"{seconds_text(lo / NS_PER_S)} to {seconds_text(hi / NS_PER_S)} s, not Unix "
            "times: a simulation clock?"
        )

    stamped, lo, hi = side("header")
    others, other_lo, other_hi = side("log", "stamped")
    stamped_when = when(lo, hi)
    if min(hi, other_hi) >= HEADER_EPOCH_NS:  # (both Unix times: how far apart)
        apart = spoken_duration(max(lo - other_hi, other_lo - hi) / NS_PER_S)
        stamped_when += f", {apart} {'before' if hi < other_lo else 'after'} the others"
    logged = [t for t in others if clocks[t] == "log"]
    also = [t for t in others if clocks[t] == "stamped"]
    if not also:
        rest = f"{listed(logged)} by their log times (no header.stamp, or 0; "
    elif not logged:
        rest = f"{listed(also)} by theirs ("
    else:
        rest = (
            f"{listed(also)} by their header.stamp and {listed(logged)} by their log times "
            "(no header.stamp, or 0; together "
        )
    pick = ",".join(f"{t}.*" for t in stamped[:4])
    return (
        f"--time header: two clocks: {listed(stamped)} timed by their header.stamp "
        f"({stamped_when}), {rest}{when(other_lo, other_hi)}); one analysis needs one clock: "
        f"use --time log, or --channels to choose topics of one clock (such as '{pick}')"
    )


def clock_step_refusal(steps: dict[str, str]) -> str:
    """What ``--time header`` did where a topic's header clock was set during the
    recording (:meth:`TopicTracker.clock_steps`: topic to what its clock did, the
    earliest step first), and what to do: the reason ``run`` and ``export`` of its
    channels stop."""
    topics = list(steps)
    first = topics[0]
    also = f" (also {', '.join(topics[1:4])}{', ...' if len(topics) > 4 else ''})"
    out = ",".join(f"!{t}.*" for t in topics[:4]) + (",..." if len(topics) > 4 else "")
    return (
        f"--time header: {first}: {steps[first]}{also if len(topics) > 1 else ''}; one "
        f"analysis needs one clock: use --time log, or leave "
        f"{'it' if len(topics) == 1 else 'them'} out with --channels '{out}'"
    )


def stamp_text(ns: int) -> str:
    """A time as the lines say it: UTC where a Unix time, else seconds (a simulation
    clock)."""
    if ns >= HEADER_EPOCH_NS:
        return str(iso_utc(ns))
    return f"{seconds_text(ns / NS_PER_S)} s (not a Unix time)"


LOG_SET_BACK_NS = CLOCKS_APART_NS + REORDER_WINDOW_NS
"""Log times that go back in the file's order by more than this (an hour and the reorder
window, as a CSV's time column set back, ``csv_reader.CLOCK_SET_BACK_NS``) are the
recorder's own clock set back during the recording (see :class:`LogClock`)."""


SET_BACK_MATCH_NS = 5 * 10**9
"""A header clock's step or jump back within this (5 s: a message's latency, a 1 Hz
topic's period) of the size of the recorder's log clock set back is that set back's
(:meth:`TopicTracker._explained`)."""


class LogClock:
    """The recorder's clock set back during the recording (by NTP, from an RTC that ran
    ahead): the messages it logged after it have log times before those of the messages
    written before them. An MCAP or a ROS 1 bag is read in log-time order (its chunks by
    their start times, each channel's messages by log time), so they were sorted in
    among the earlier messages, or before them all, silently: with ``--time header`` its stamps
    then seemed to go back, and the messages were dropped. A clock set forward (the
    recorder's, or both clocks) is a gap, as a pause of the recorder is.

    Found per topic, in the file's order: more than
    :data:`~analyzer.readers._common.LEAD_GLITCH_MESSAGES` messages of a chunk logged
    more than :data:`LOG_SET_BACK_NS` before one of the topic written before them, in
    the chunk or in a chunk written before it (a message or a few off are left to the
    reorderer, as before). Per topic only: a file need not be written in log-time order
    across topics (a converter may write one topic's whole recording, then the next
    one's). :meth:`messages` takes one topic's messages of one chunk; the chunks in the
    file's order where ``in_file_order`` (a stream, or a pass over an indexed file's
    message indexes: :meth:`may_step_back` says whether one is needed), else inside each
    chunk only. ``line`` says the first (:attr:`InputInfo.set_back`); with ``stop`` (an
    input of a multi-file archive) it is raised there instead, naming ``stop``: the file
    is read up to there."""

    def __init__(self, *, in_file_order: bool, stop: Path | None = None) -> None:
        self.line = ""
        self.back_ns = 0
        """How far back the first set back said in ``line`` went."""
        self.in_file_order = in_file_order
        self._stop = stop
        self._newest: dict[str, int] = {}
        """Per topic: its newest log time in the chunks given before."""

    @staticmethod
    def may_step_back(starts: IntArray, ends: IntArray) -> bool:
        """Whether chunks logging from ``starts`` to ``ends`` (in the file's order) may
        hold a topic set back: one starts more than :data:`LOG_SET_BACK_NS` before the
        end of one written before it (needed for it, not enough: the chunks may hold
        other topics)."""
        if starts.size < 2:
            return False
        newest = np.maximum.accumulate(ends)[:-1]
        return bool((newest - starts[1:] > LOG_SET_BACK_NS).any())

    def messages(self, topic: str, offsets: IntArray, log_ns: IntArray) -> None:
        """The messages of ``topic`` in one chunk, at ``offsets`` in it, logged at
        ``log_ns``."""
        if self.line or log_ns.size == 0:
            return
        before = self._newest.get(topic) if self.in_file_order else None
        in_order = bool((log_ns[1:] >= log_ns[:-1]).all()) and bool(
            (offsets[1:] >= offsets[:-1]).all()
        )
        written = log_ns if in_order else log_ns[np.argsort(offsets, kind="stable")]
        newest = int(written[-1]) if in_order else int(written.max())
        if before is not None:
            self._newest[topic] = max(before, newest)
        elif self.in_file_order:
            self._newest[topic] = newest
        if written.size <= LEAD_GLITCH_MESSAGES:
            return
        lowest = int(written[0]) if in_order else int(written.min())
        if before is not None and before - lowest > LOG_SET_BACK_NS:
            # (the chunks before: the fifth earliest message against them)
            fifth = int(np.partition(written, LEAD_GLITCH_MESSAGES)[LEAD_GLITCH_MESSAGES])
            if before - fifth > LOG_SET_BACK_NS:
                first = int(np.flatnonzero(before - written > LOG_SET_BACK_NS)[0])
                newest = max(before, int(written[:first].max(initial=before)))
                self._said(newest, int(written[first]), f"{topic}: a message logged at")
                return
        if in_order:
            return  # (the common case: two comparisons)
        running = np.maximum.accumulate(written)
        behind = np.flatnonzero(running[:-1] - written[1:] > LOG_SET_BACK_NS) + 1
        if behind.size > LEAD_GLITCH_MESSAGES:
            k = int(behind[0])
            self._said(int(running[k - 1]), int(written[k]), f"{topic}: a message logged at")

    def _said(self, newest: int, time: int, where: str) -> None:
        self.back_ns = newest - time
        self.line = (
            f"the log times step back by {spoken_duration((newest - time) / NS_PER_S)}: {where} "
            f"{stamp_text(time)}, after messages logged up to {stamp_text(newest)} (the "
            "recorder's clock set back during the recording?); its messages cannot be placed "
            "among those logged before them (they would be sorted in among them): split the "
            "recording there"
        )
        if self._stop is not None:
            raise ReaderError(f"{self._stop}: {self.line}")


BETWEEN_STRETCHES = 16
"""Short stretches (glitches) after a topic's last lasting one that :class:`_Levels`
keeps, to place a step at its first message (:func:`_placed`)."""


@dataclass(slots=True)
class _Levels:
    """The stretches of one topic's header-minus-log offsets (:meth:`TopicTracker._steps`),
    carried from batch to batch. A message is a row ``(offset, log time, number,
    stamp)``, a stretch its first and last message. ``anchor`` is the last message of
    the last stretch that was a clock (:func:`_lasting`), ``between`` the shorter
    stretches after it (the first :data:`BETWEEN_STRETCHES`; first and last messages,
    two arrays of rows), ``open`` the stretch still open (rows 0 and 1), ``closed``
    whether a stretch was closed before it; ``before`` and ``after`` the two messages
    of the first step found, ``steps`` how many."""

    anchor: IntArray | None = None
    between: tuple[IntArray, IntArray] = (
        np.zeros((0, 4), dtype=np.int64),
        np.zeros((0, 4), dtype=np.int64),
    )
    closed: bool = False
    open: IntArray | None = None
    before: IntArray | None = None
    after: IntArray | None = None
    steps: int = 0


def _lasting(first: IntArray, last: IntArray, window: int, edge: BoolArray) -> BoolArray:
    """Which stretches of a topic's header-minus-log offsets (first and last messages,
    rows of ``(offset, log time, number, stamp)``) are a clock, not a glitch: those
    lasting longer than ``window`` in log time (a shorter one between two others is a
    glitch: a stamp with a flipped bit, or two publishers on two clocks, message by
    message, which the rules of :class:`TopicTracker` drop); at the topic's start or
    end (``edge``), with nothing on one side, also one of more than
    :data:`LEAD_GLITCH_MESSAGES` messages (as :func:`forward_outliers` takes a longer
    first run for the clock)."""
    lasting = last[:, 1] - first[:, 1] > window
    return lasting | (edge & (last[:, 2] - first[:, 2] >= LEAD_GLITCH_MESSAGES))


def _placed(
    before: IntArray, after: IntArray, between: tuple[IntArray, IntArray], floor: int
) -> tuple[IntArray, IntArray]:
    """Where a step between the lasting stretches ending at ``before`` and starting at
    ``after`` is: at the first message of the short stretches ``between`` them that is
    already on the new clock (within ``floor``, the topic's step, of ``after``'s
    offset), from the last one before it still on the old clock. A glitch right after
    a clock was set would otherwise move the step past it."""
    first, last = between
    new = np.flatnonzero(np.abs(first[:, 0] - after[0]) <= floor)
    if new.size:
        after = first[new[0]]
        first, last = first[: new[0]], last[: new[0]]
    old = np.flatnonzero(np.abs(last[:, 0] - before[0]) <= floor)
    if old.size:
        before = last[old[-1]]
    return before, after


def _stepped(tails: IntArray, first: IntArray, last: IntArray, floor: int) -> BoolArray:
    """Which lasting stretches (``first`` and ``last`` messages, rows of :class:`_Levels`)
    are a header clock stepped from the lasting stretch before each (its last message
    in ``tails``): the offset it settles at (its last message's) lies more than
    ``floor`` from the one before, and its first stamp jumped by more than ``floor``
    from that message's (where the stamps go on and only the log times jumped, the
    source paused or the recorder's clock was set, not this clock)."""
    moved = np.abs(last[:, 0] - tails[:, 0]) > floor
    return moved & (np.abs(first[:, 3] - tails[:, 3]) > floor)


LEAD_GLITCH_MESSAGES = 4
"""The longest run of messages at the start of a topic that :func:`forward_outliers` may
take for a glitch (with nothing before it, only its length tells it from a clock that
steps back after a while)."""


@dataclass(slots=True)
class _Jumps:
    """Header clock jumps of one topic: how many, messages dropped, the first one."""

    events: int = 0
    dropped: int = 0
    index: int = 0
    log_ns: int = 0
    back_ns: int = 0


@dataclass(slots=True)
class _Glitches:
    """Messages of one topic stamped ahead of the messages around them: how many were
    dropped, how many had been passed on before the next message showed it (at a batch
    boundary), the first one and by how much it was ahead."""

    dropped: int = 0
    kept: int = 0
    index: int = 0
    log_ns: int = 0
    ahead_ns: int = 0


@dataclass(slots=True)
class _Clock:
    """The header-clock state of one topic, carried from batch to batch.

    ``high`` and ``behind`` are the running maximum of the stamps and whether the last
    message was dropped (a stretch behind ``high``), ``ref`` the header-minus-log offset
    of the last message, all three over the *settled* messages. The ``open_*`` arrays
    (stamps, log times, message numbers) hold a trailing run that is ahead of ``ref``
    by more than the window and could still be a glitch: it was passed on, but it sets
    neither ``high`` nor ``ref`` until the next batch shows what follows it (what is left
    at the end of the topic is said by :meth:`TopicTracker.lines`).
    """

    high: int | None = None
    behind: bool = False
    ref: int | None = None
    open_t: IntArray = field(default_factory=lambda: EMPTY_T)
    open_log: IntArray = field(default_factory=lambda: EMPTY_T)
    open_idx: IntArray = field(default_factory=lambda: EMPTY_T)


@dataclass(slots=True)
class _Relabels:
    """Changes of one string array of one topic: how many, and the first one."""

    count: int
    log_ns: int
    first: Relabel


def forward_outliers(
    t: IntArray, log_ns: IntArray, ref: int | None, window: int
) -> tuple[BoolArray, BoolArray, IntArray, BoolArray]:
    """Short runs of messages stamped ahead of the messages around them.

    ``t`` and ``log_ns`` are the header stamps and log times of messages in log-time
    order; ``ref`` is the header-minus-log offset of the message before them (None at the
    start of a topic). On a healthy topic the offset ``o_i = t_i - log_i`` is nearly
    constant whatever the rate. A run of messages ``a .. b-1`` is a *glitch* (a GPS/PTP
    hiccup, bit flips in the stamps) when

    * its offsets *all* exceed those of the message before it (``o_{a-1}``) and the
      message after it (``o_b``) by more than ``window``, and those two agree within
      ``window``. The run's own offsets need not agree with each other: two garbage
      stamps in a row (+100 s, +37 s) are one run. For a given start the run is the
      messages up to the first one back within ``window`` above ``o_{a-1}``; it starts
      where the offset jumps up by more than ``window``;
    * it lasts at most ``window`` in log time (one message, or a short run);
    * at the start of a topic, where no message before it tells which clock is right, it
      is at most :data:`LEAD_GLITCH_MESSAGES` long and the two messages after it agree
      (the longest such first run is taken; a longer one sets the clock: a clock that
      steps back after it is a step);
    * the stamp goes back by more than ``window`` after it (the running-maximum rule of
      :class:`TopicTracker` would otherwise take the glitch for the newest stamp and drop
      what follows: a monotonic clock never has a glitch).

    Runs found from different starts nest (0, +50, +100, +50, 0: the +100 s message and
    the three); a message is a glitch when it is in any of them.

    Returns ``(glitch, open, ahead, aside)``: the messages of a glitch; the trailing run
    that could still be one once the next messages are known (ahead of the message before
    it by more than ``window`` throughout and lasting at most ``window`` so far, the
    earliest such start; at the start of a topic the whole batch while it may still be
    the first run: at most :data:`LEAD_GLITCH_MESSAGES` messages within ``window``, or a
    first run followed by a single message); by how much each message's offset exceeds
    those around its outermost run (meaningful where ``glitch``); and the messages the
    running maximum must leave out (the glitches, and an undecided start of a topic but
    for its last message).
    """
    m = int(t.shape[0])
    glitch = np.zeros(m, dtype=bool)
    pending = np.zeros(m, dtype=bool)
    ahead = np.zeros(m, dtype=np.int64)
    if m == 0:
        return glitch, pending, ahead, glitch
    o = t - log_ns
    lead = 0 if ref is None else 1
    full = o if ref is None else np.concatenate((np.array([ref], dtype=np.int64), o))
    steps = np.diff(full)
    if ref is not None and not bool(np.any(np.abs(steps) > window)):
        return glitch, pending, ahead, glitch  # one stretch, continuing the settled one
    size = int(full.shape[0])
    # with ``ref`` position 0 is the settled message before: never in a run
    ft = t if ref is None else np.concatenate((t[:1], t))
    fl = log_ns if ref is None else np.concatenate((log_ns[:1], log_ns))
    # candidate starts: the offset jumps up; the run ends at the first message whose
    # offset is back within ``window`` above the one before the start (``size``: not yet)
    starts = np.flatnonzero(steps > window) + 1
    before = full[starts - 1]
    ends = _first_at_most(full, starts, before + window)
    found = ends < size
    s, e, b = starts[found], ends[found], before[found]
    after = full[e]
    low = np.minimum.reduceat(full, np.column_stack((s, e)).ravel())[::2]
    top = np.maximum.reduceat(ft, np.column_stack((s, e)).ravel())[::2]
    closed = (
        (after >= b - window)
        & (low - after > window)
        & (fl[e - 1] - fl[s] <= window)
        & (top - ft[e] > window)
    )
    run_s, run_e = s[closed], e[closed]
    around = np.maximum(b[closed], after[closed])
    waiting = False
    if ref is None:
        waiting, first = _lead_run(full, ft, fl, window)
        if first:
            run_s = np.concatenate((np.zeros(1, dtype=np.int64), run_s))
            run_e = np.concatenate((np.array([first], dtype=np.int64), run_e))
            around = np.concatenate((full[first : first + 1], around))
    inside = np.zeros(size, dtype=bool)
    if run_s.size:
        depth = np.cumsum(
            np.bincount(run_s, minlength=size + 1) - np.bincount(run_e, minlength=size + 1)
        )[:size]
        inside = depth > 0
        # the runs nest; each message is measured against its outermost run, the one
        # that starts where the depth rises from 0
        outer = (run_s == 0) | (depth[np.maximum(run_s - 1, 0)] == 0)
        label = np.full(size, -1, dtype=np.int64)
        label[run_s[outer]] = np.arange(int(np.count_nonzero(outer)))
        label = np.maximum.accumulate(label)
        base = np.where(label >= 0, around[outer][np.maximum(label, 0)], full)
        ahead = (full - base)[lead:]
        glitch = inside[lead:]
    aside = glitch.copy()
    if waiting:
        # a topic's first messages, which may still be a glitch: all wait, all but the
        # last out of the running maximum
        pending[:] = True
        aside[: m - 1] = True
    else:
        open_ = ~found & (fl[size - 1] - fl[starts] <= window)
        if bool(open_.any()):
            pending[int(starts[np.argmax(open_)]) - lead :] = True
    pending &= ~glitch  # a glitch inside it is dropped now, not carried
    return glitch, pending, ahead, aside


def _lead_run(full: IntArray, ft: IntArray, fl: IntArray, window: int) -> tuple[bool, int]:
    """The first run of a topic (:func:`forward_outliers`, no message before it): whether
    the batch must wait for more messages, and the length of the first run that is a
    glitch (0: none). A first run of ``j`` messages must be at most
    :data:`LEAD_GLITCH_MESSAGES` long and ``window`` in log time, its offsets all more
    than ``window`` above the message after it, its stamps more than ``window`` after
    that message's, and the two messages after it must agree; the longest such run is
    taken. With none, the batch waits while it ends with a candidate run and one message,
    or is itself short enough to be one."""
    size = int(full.shape[0])
    cap = min(LEAD_GLITCH_MESSAGES, size - 1)
    if cap >= 1:
        j = np.arange(1, cap + 1)
        low = np.minimum.accumulate(full[:cap])
        top = np.maximum.accumulate(ft[:cap])
        fits = (low - full[j] > window) & (fl[j - 1] - fl[0] <= window) & (top - ft[j] > window)
        nxt = np.minimum(j + 1, size - 1)
        agree = (j + 1 < size) & (np.abs(full[nxt] - full[j]) <= window)
        valid = np.flatnonzero(fits & agree)
        if valid.size:
            return False, int(j[valid[-1]])
        if bool(fits[-1]) and cap == size - 1:
            return True, 0  # the run and one message after it: which is right is not known
    short = size <= LEAD_GLITCH_MESSAGES and int(fl[size - 1]) - int(fl[0]) <= window
    return short, 0


def _first_at_most(values: IntArray, begin: IntArray, limit: IntArray) -> IntArray:
    """For each query ``q``, the first index ``i >= begin[q]`` with ``values[i] <=
    limit[q]`` (``len(values)`` where there is none): a greedy descent over a sparse table
    of minima, ``log2(len(values))`` vectorized steps for all queries at once."""
    n = int(values.shape[0])
    pos = begin.astype(np.int64, copy=True)
    if pos.size == 0:
        return pos
    tables = [values]  # tables[k][i] = min(values[i : i + 2**k])
    while (1 << len(tables)) <= n:
        prev, half = tables[-1], 1 << (len(tables) - 1)
        tables.append(np.minimum(prev[:-half], prev[half:]))
    for k in range(len(tables) - 1, -1, -1):
        table = tables[k]
        fits = pos < table.shape[0]
        skip = fits & (table[np.minimum(pos, table.shape[0] - 1)] > limit)
        pos += skip.astype(np.int64) << k
    return pos


def _running_max(
    t: IntArray, high: int | None, behind: bool, window: int
) -> tuple[BoolArray, BoolArray, IntArray, IntArray]:
    """The running-maximum rule of :class:`TopicTracker` over stamps ``t`` (log-time
    order) following a topic's state ``high``/``behind``: returns which messages to drop,
    where a jump back starts (``events``), the newest stamp before each message and the
    running maximum after it."""
    n = int(t.shape[0])
    runmax = np.maximum.accumulate(t)
    if high is not None:
        np.maximum(runmax, high, out=runmax)
    prev = np.empty_like(t)
    prev[1:] = runmax[:-1]
    prev[0] = int(t[0]) - 1 if high is None else high
    advancing = t > prev
    if not behind and bool(advancing.all()):
        nothing = np.zeros(n, dtype=bool)
        return nothing, nothing, prev, runmax
    far = ~advancing & (t < prev - window)
    index = np.arange(n)
    run_start = np.maximum.accumulate(np.where(advancing, index, -1))
    last_far = np.maximum.accumulate(np.where(far, index, -1))
    drop = ~advancing & (last_far > run_start)
    if behind:
        drop |= run_start < 0
    dropped_before = np.empty(n, dtype=bool)
    dropped_before[0] = behind
    dropped_before[1:] = drop[:-1]
    return drop, far & ~dropped_before, prev, runmax


def _newest(
    t: IntArray, out: BoolArray, high: int | None, behind: bool, window: int
) -> tuple[BoolArray, BoolArray, IntArray, IntArray, IntArray]:
    """:func:`_running_max` over the messages of ``t`` not ``out``: which of all the
    messages to drop, where a jump back starts (over those used), the messages used, the
    newest stamp before each of them and the running maximum after it."""
    m = int(t.shape[0])
    used = np.flatnonzero(~out) if bool(out.any()) else np.arange(m)
    if used.size == 0:
        return np.zeros(m, dtype=bool), np.zeros(0, dtype=bool), used, EMPTY_T, EMPTY_T
    drop_u, events_u, prev_u, runmax_u = _running_max(
        t[used] if used.size < m else t, high, behind, window
    )
    drop = drop_u
    if used.size < m:
        drop = np.zeros(m, dtype=bool)
        drop[used] = drop_u
    return drop, events_u, used, prev_u, runmax_u


class TopicTracker:
    """What one pass of a ROS or MCAP reader notes per topic beside the samples, and the
    time each message gets; :meth:`push` hands the samples on to a :class:`Reorderer`.

    * messages that could not be decoded (counted, the first reason kept);
    * with ``--time header``: a ``header.stamp`` of 0 (a driver that does not set it) is
      no stamp where the topic's stamps are wall-clock times (:data:`HEADER_EPOCH_NS`): the
      message's log time is used, and counted. On a simulation clock (stamps mostly below
      :data:`HEADER_EPOCH_NS`) 0 is a real time (Gazebo starts at 0). Each topic is decided by
      the nonzero stamps of its first batch that has any, and keeps that decision; a
      batch of only zeros before that is taken as unset. Messages given their log time
      (or without a header) take no part in the two rules below;
    * with ``--time header``: a short stretch stamped ahead of the messages around it
      (:func:`forward_outliers`: one message stamped 100 s in the future) is dropped and
      counted. Otherwise it would be the newest stamp, and everything after it "behind".
      A run of bad stamps need not agree with itself (+100 s, +37 s): it is tested as a
      whole against the messages around it. A run at the end of a batch is decided by
      the next batch of its topic: it has been passed on by then, so such a glitch is
      kept (counted apart), but it does not set the newest stamp. One still open at the
      end of the topic is kept and said (with nothing after it, a glitch cannot be told
      from a clock that stepped forward). A topic's first few messages
      (:data:`LEAD_GLITCH_MESSAGES`) are taken as a glitch only when the two messages
      after them agree;
    * with ``--time header``: a header clock that goes back by more than the reorder
      window (a clock step, a restarted simulator). Sorting would interleave the stretch
      after the step with the one before it (the aligner then keeps one of two samples
      per tick, silently). The rule: in log-time order, a message stamped more than the
      window before the newest stamp of its topic so far, and the messages after it that
      stay at or below that newest stamp, are dropped and counted; the stamps within the
      window behind are reordered, as before. Vectorized: a running maximum per batch,
      carried across batches;
    * string arrays beside numeric arrays (``JointState.name``) that change content
      (:class:`Relabel`, found by the decoders): ``position[i]`` follows the index;
    * quaternions (``pose.orientation``) whose sign changes between messages: made
      continuous as the reorderer releases them, in time order (:attr:`signs`).
    """

    def __init__(self, time: str, window_ns: int = REORDER_WINDOW_NS) -> None:
        self.time = time
        self._window = window_ns
        self._t0: int | None = None
        self._seen: dict[str, int] = {}
        self._clocks: dict[str, _Clock] = {}
        self._epoch: dict[str, bool] = {}
        self._jumps: dict[str, _Jumps] = {}
        self._levels: dict[str, _Levels] = {}
        self.log_set_back_ns = 0
        """How far the recorder's log clock was set back (:class:`LogClock`, said by the
        reader): the header clock's steps and jumps back it explains are not said
        (:meth:`_explained`)."""
        self._explained_at: dict[str, int] = {}
        """Per topic: the message of its step :meth:`_explained` left out."""
        self._glitches: dict[str, _Glitches] = {}
        self._zero: dict[str, int] = {}
        self._failures: dict[str, list[Any]] = {}
        self._relabels: dict[tuple[str, str], _Relabels] = {}
        self._orders: dict[tuple[str, str], list[str]] = {}
        """Per topic and string array beside flat numeric arrays (``JointState.name``):
        the names in their first order, those that appear later added at the end; the
        arrays' elements are put back in this order (:meth:`_in_first_order`)."""
        self._unordered: set[tuple[str, str]] = set()
        """Those whose order could not be followed (names repeated or empty, or more
        contents in a batch than :data:`BY_NAME_ORDERS`): left out as before."""
        self._moved: set[tuple[str, str]] = set()
        """Those whose elements were moved back in order (said by the reader)."""
        self._changes: dict[tuple[str, str], _Moved] = {}
        """Their names that appeared or went missing."""
        self._seen_labels: dict[tuple[str, str], dict[tuple[str, ...], None]] = {}
        """Per topic and string array: the contents seen (at the batches' ends and first
        changes; at most :data:`SEEN_LABELS`), in order."""
        self.signs = QuaternionSigns(self.relabelled)
        """The quaternions' signs, made continuous along time (:mod:`~analyzer.readers.
        quaternions`) by the reader's :class:`Reorderer` (one a storage file of a split
        ROS 2 bag: kept here, across them)."""
        self._messages: dict[str, int] = {}
        """Per topic: the messages decoded (numeric fields or not: :meth:`messages`)."""
        self._siblings: dict[tuple[str, str], tuple[str, ...]] = {}
        """Per topic and string array: the numeric arrays beside it (:class:`Relabel`)."""
        self._labels: dict[tuple[str, str], tuple[str, ...]] = {}
        """Per topic and string array: its strings in the topic's last message so far (of
        any publisher: two publishing different frames on one topic relabel it too)."""
        self._spans: dict[tuple[str, str], tuple[int, int]] = {}
        """With ``--time header``, per topic and source (``"header"``: its own stamps,
        ``"log"``: log times, for messages without a header or with a stamp of 0 taken
        as unset): the first and last time so given (see :meth:`clocks`)."""
        self._logged: tuple[int, int] | None = None
        """With ``--time header``: the first and last log time of any message, the span
        of the recording on the recorder's clock (see :meth:`_apart`)."""
        self.delays = LogDelays()
        """With ``--time log``: how far each topic's log times depart from its header
        stamps (:mod:`~analyzer.readers.delays`)."""

    def push(self, reorder: Reorderer, topic: str, decoded: Decoded, log_ns: IntArray) -> None:
        """Note what ``decoded`` (messages of ``topic`` logged at ``log_ns``) holds beside
        its samples, and push them with their times."""
        if decoded.failed:
            seen = self._failures.setdefault(topic, [0, decoded.first_error])
            seen[0] += decoded.failed
        self._messages[topic] = self._messages.get(topic, 0) + decoded.n
        if decoded.n == 0:
            return
        if self._t0 is None:
            self._t0 = int(log_ns.min())
        changes = list(decoded.relabels)
        for name, (first, last, siblings, kinds) in decoded.label_ends.items():
            before = self._labels.get((topic, name))
            if before is not None and before != first:  # since the topic's last batch
                changes.insert(0, Relabel(name, 0, before, first, 1, siblings))
            self._labels[(topic, name)] = last
            self._siblings[(topic, name)] = siblings
            contents = self._seen_labels.setdefault((topic, name), {})
            for names in kinds:
                if len(contents) < SEEN_LABELS:
                    contents[names] = None
            self._in_first_order(topic, name, decoded, log_ns)
        for change in changes:
            key = (topic, change.field)
            known = self._relabels.get(key)
            if known is None:
                self._relabels[key] = _Relabels(change.count, int(log_ns[change.row]), change)
            else:
                known.count += change.count
        times = log_ns
        if self.time == "header":
            lo, hi = int(log_ns.min()), int(log_ns.max())
            was = self._logged
            self._logged = (lo, hi) if was is None else (min(was[0], lo), max(was[1], hi))
        if self.time == "header" and decoded.stamps is not None:
            stamps = decoded.stamps
            unset = stamps == NO_STAMP
            zero = stamps == 0
            if self._zero_is_unset(topic, stamps, unset, zero):
                zeros = int(np.count_nonzero(zero))
                if zeros:
                    self._zero[topic] = self._zero.get(topic, 0) + zeros
                    unset |= zero
            times = np.where(unset, log_ns, stamps) if bool(unset.any()) else stamps
            real = None if not bool(unset.any()) else np.flatnonzero(~unset)
            self._span(topic, "header", stamps if real is None else stamps[real])
            if real is not None:
                self._span(topic, "log", log_ns[unset])
            keep = self._clock(topic, times, log_ns, real)
            if keep is not None:
                decoded = decoded.subset(keep)
                times = times[keep]
        elif self.time == "header":
            self._span(topic, "log", log_ns)
        elif decoded.stamps is not None:  # (--time log: how far the log times depart)
            self.delays.add(topic, log_ns, decoded.stamps, NO_STAMP)
        self._seen[topic] = self._seen.get(topic, 0) + int(log_ns.shape[0])
        reorder.push_decoded(topic, decoded, times)

    def _span(self, topic: str, source: str, t: IntArray) -> None:
        """Widen the span of the times ``source`` gave ``topic`` by ``t``."""
        if t.size == 0:
            return
        lo, hi = int(t.min()), int(t.max())
        seen = self._spans.get((topic, source))
        self._spans[(topic, source)] = (
            (lo, hi) if seen is None else (min(seen[0], lo), max(seen[1], hi))
        )

    def clocks(self) -> dict[str, str]:
        """With ``--time header``, where the topics' times come from two clocks: each
        topic's clock, ``"header"`` (its own stamps) or ``"log"`` (its log times: no
        header, or stamps of 0 taken as unset), else ``{}``. Two clocks: the stamps of
        the topics timed by their headers are Unix times (:data:`HEADER_EPOCH_NS`) and the log
        times of the others are not, or the other way round (a simulation clock in the
        headers, as Gazebo's ``use_sim_time`` gives, beside a recorder's wall clock).
        Their samples lie years apart, which one common clock cannot hold. A topic with
        messages of both sources counts as ``"header"`` (its unset stamps are on the
        header clock's epoch, see :meth:`_zero_is_unset`). Else, two clocks that lie far
        apart, both giving Unix times or not (:meth:`_apart`)."""
        by_topic: dict[str, str] = {}
        for topic, source in self._spans:
            if by_topic.get(topic) != "header":
                by_topic[topic] = source
        epoch = {
            topic: self._spans[(topic, source)][1] >= HEADER_EPOCH_NS
            for topic, source in by_topic.items()
        }
        header = {epoch[t] for t, s in by_topic.items() if s == "header"}
        log = {epoch[t] for t, s in by_topic.items() if s == "log"}
        if len(header) == 1 and len(log) == 1 and header != log:
            return by_topic
        return self._apart(by_topic)

    def _apart(self, by_topic: dict[str, str]) -> dict[str, str]:
        """For :meth:`clocks`: two clocks that both give Unix times, far apart (a robot
        whose unsynchronised clock stamps its headers in 2021 beside topics without a
        header at the recorder's 2026 log times; one topic stamped years off): the
        topics split at the widest stretch that none of their spans covers, where that
        stretch is longer than the recording itself (its log times, all topics) and than
        :data:`CLOCKS_APART_NS`. Every message was logged within the recording's span,
        so the times of one clock and one recording cannot lie further apart than that
        plus the delay from stamp to log; the floor keeps a short recording's late or
        latched messages (a map stamped when its server started) on one clock. The side
        farther from the log times is the one apart (``"header"``: only header stamps
        lie outside the log times); the other side's topics are ``"log"`` or, stamped
        on its clock, ``"stamped"``. Else ``{}``."""
        if len(by_topic) < 2 or self._logged is None:
            return {}
        spans = sorted((*self._spans[(t, s)], t) for t, s in by_topic.items())
        gap, split, reach = 0, 0, spans[0][1]
        for k, (start, end, _) in enumerate(spans[1:], 1):
            if start - reach > gap:
                gap, split = start - reach, k
            reach = max(reach, end)
        logged = self._logged
        if gap <= max(logged[1] - logged[0], CLOCKS_APART_NS):
            return {}
        early, late = [t for *_, t in spans[:split]], [t for *_, t in spans[split:]]

        def distance(topics: list[str]) -> int:
            lo = min(self._spans[(t, by_topic[t])][0] for t in topics)
            hi = max(self._spans[(t, by_topic[t])][1] for t in topics)
            return max(logged[0] - hi, lo - logged[1], 0)

        apart, near = (early, late) if distance(early) > distance(late) else (late, early)
        out = {t: "header" for t in apart}
        out.update({t: "stamped" if by_topic[t] == "header" else "log" for t in near})
        return {t: out[t] for t in by_topic}

    def _steps(self, topic: str, t: IntArray, log_ns: IntArray, idx: IntArray) -> None:
        """Follow the header clock of ``topic`` against its log times (messages stamped
        ``t``, logged at ``log_ns``, numbered ``idx``, in log-time order) for a step: the
        clock set during the recording (by NTP or PTP, from 1970 plus the uptime, or a
        day off), which moves the header-minus-log offset by more than the topic's floor
        (:meth:`_floor`: 10 s on a wall clock, an hour on a simulation clock) and keeps
        it there, the stamps jumping by as much. The topic's span then covers the
        jump, so the two-clock rule (:meth:`_apart`, which compares the topics' spans)
        cannot see it, and one clock for all topics would stretch over the jump (or the
        topic is analyzed shifted by the step). A pause of the recorder moves both
        times, and not the offset; a pause of the source (a simulation or a playback
        paused) or the recorder's own clock set moves the log times, not the stamps;
        jitter, a latency and a short stretch off (:func:`_lasting`) are no step, nor
        a burst of messages queued through an outage: the level a stretch settles at
        (its last message) is compared with the last one's. Vectorized: the messages
        split into stretches where the offset moves by more than the floor from one
        message to the next; only each stretch's first and last message are compared,
        and the open stretch is carried to the next batch."""
        if t.size == 0:
            return
        levels = self._levels.setdefault(topic, _Levels())
        floor = self._floor(topic)
        o = t - log_ns
        split = np.flatnonzero(np.abs(np.diff(o)) > floor) + 1
        starts = np.concatenate((np.zeros(1, dtype=np.int64), split))
        ends = np.concatenate((split - 1, np.array([o.shape[0] - 1], dtype=np.int64)))

        def rows(at: IntArray) -> IntArray:
            return np.column_stack((o[at], log_ns[at], idx[at], t[at]))

        first, last = rows(starts), rows(ends)
        held = levels.open
        if held is not None:
            if abs(int(o[0]) - int(held[1, 0])) <= floor:
                first[0] = held[0]  # (the open stretch goes on)
            else:
                first = np.concatenate((held[:1], first))
                last = np.concatenate((held[1:], last))
        levels.open = np.stack((first[-1], last[-1]))
        first, last = first[:-1], last[:-1]
        if first.shape[0] == 0:
            return
        edge = np.zeros(first.shape[0], dtype=bool)
        edge[0] = not levels.closed
        levels.closed = True
        keys = np.flatnonzero(_lasting(first, last, self._window, edge))
        # consecutive lasting stretches (the anchor first), and the step between them
        tails = last[keys] if levels.anchor is None else np.vstack((levels.anchor, last[keys]))
        pairs = max(min(keys.size, tails.shape[0] - 1), 0)
        later = keys[keys.size - pairs :]
        step = _stepped(tails[:pairs], first[later], last[later], floor)
        levels.steps += int(np.count_nonzero(step))
        if levels.before is None:
            k = int(np.argmax(step)) if bool(step.any()) else -1
            # the short stretches after the last lasting one before the step (or all)
            after_key = int(later[k]) if k >= 0 else first.shape[0]
            lasting_before = keys[keys < after_key]
            since = int(lasting_before[-1]) + 1 if lasting_before.size else 0
            kept = levels.between if not lasting_before.size else (first[:0], last[:0])
            between = (
                np.concatenate((kept[0], first[since:after_key])),
                np.concatenate((kept[1], last[since:after_key])),
            )
            if k >= 0:
                levels.before, levels.after = _placed(tails[k], first[after_key], between, floor)
            else:
                levels.between = (
                    between[0][:BETWEEN_STRETCHES],
                    between[1][:BETWEEN_STRETCHES],
                )
        if keys.size:
            levels.anchor = last[keys[-1]]

    def clock_steps(self) -> dict[str, str]:
        """With ``--time header``: the topics whose header clock was set during the
        recording (:meth:`_steps`, the stretch still open at the end counted as it
        stands), each with what its clock did, the earliest step first; else ``{}``."""
        found: list[tuple[int, str, str]] = []
        for topic, levels in self._levels.items():
            before, after, count = levels.before, levels.after, levels.steps
            held, anchor = levels.open, levels.anchor
            if held is not None and anchor is not None:
                edge = np.ones(1, dtype=bool)
                lasting = bool(_lasting(held[:1], held[1:], self._window, edge)[0])
                floor = self._floor(topic)
                if lasting and bool(_stepped(anchor[None], held[:1], held[1:], floor)[0]):
                    count += 1
                    if before is None:
                        before, after = _placed(anchor, held[0], levels.between, floor)
            if before is None or after is None:
                continue
            moved = int(after[0]) - int(before[0])
            if self._explained(moved):
                self._explained_at[topic] = int(after[2])
                continue
            more = f"; {count} such jumps" if count > 1 else ""
            way = "forward" if moved > 0 else "back"
            found.append(
                (
                    int(after[1]),
                    topic,
                    f"header.stamp jumps {spoken_duration(abs(moved) / NS_PER_S)} {way} at "
                    f"message {int(after[2])} ({self._at(int(after[1]))}), from "
                    f"{stamp_text(int(before[3]))} to {stamp_text(int(after[3]))}, while "
                    f"its log times go on (a clock set during the recording?){more}",
                )
            )
        return {topic: text for _, topic, text in sorted(found)}

    def _explained(self, moved: int) -> bool:
        """Whether a move of a header clock by ``moved`` against the log times (a step),
        or a jump back by ``moved``, is of the size of the recorder's log clock set back
        (:attr:`log_set_back_ns`, within :data:`SET_BACK_MATCH_NS`): the messages logged
        after it were read before those logged before, their stamps a step off, then
        going back. Not the header clock's doing: not said (nor a jump back at the
        place of such a step, :attr:`_explained_at`)."""
        size = self.log_set_back_ns
        return bool(size) and abs(abs(moved) - size) <= SET_BACK_MATCH_NS

    def _floor(self, topic: str) -> int:
        """The least move of ``topic``'s header clock against the log times that is a
        step (:meth:`_steps`): :data:`WALL_CLOCK_STEP_NS` where its stamps are Unix
        times, else (a simulation clock, or not yet known) :data:`CLOCKS_APART_NS`."""
        return WALL_CLOCK_STEP_NS if self._epoch.get(topic) else CLOCKS_APART_NS

    def clock_spans(self) -> dict[str, tuple[int, int]]:
        """Of each topic of :meth:`clocks`: the first and last time its clock gave it."""
        clocks = self.clocks()
        return {t: self._spans[(t, "log" if s == "log" else "header")] for t, s in clocks.items()}

    def clock_line(self) -> str | None:
        """The line :meth:`lines` says of two clocks (see :meth:`clocks`), else None."""
        clocks = self.clocks()
        if not clocks:
            return None
        return two_clocks(clocks, self.clock_spans())

    def _zero_is_unset(
        self, topic: str, stamps: IntArray, unset: BoolArray, zero: BoolArray
    ) -> bool:
        """Whether a stamp of 0 means "not set" on ``topic`` (see the class): decided by
        the first batch with nonzero stamps, and kept."""
        epoch = self._epoch.get(topic)
        if epoch is None:
            valid = stamps[~(unset | zero)]
            if valid.size:
                epoch = 2 * int(np.count_nonzero(valid >= HEADER_EPOCH_NS)) >= int(valid.size)
                self._epoch[topic] = epoch
        return epoch is None or epoch

    def _clock(
        self, topic: str, t: IntArray, log_ns: IntArray, real: IntArray | None
    ) -> BoolArray | None:
        """Which messages to keep (None: all) by the header-clock rules of the class;
        ``real`` (None: all) are the messages whose time is their own header stamp."""
        n = int(t.shape[0])
        idx = self._seen.get(topic, 0) + (np.arange(n) if real is None else real)
        if real is not None:
            t, log_ns = t[real], log_ns[real]
            if t.size == 0:
                return None
        clock = self._clocks.setdefault(topic, _Clock())
        carried = int(clock.open_t.shape[0])
        if carried:
            t = np.concatenate((clock.open_t, t))
            log_ns = np.concatenate((clock.open_log, log_ns))
            idx = np.concatenate((clock.open_idx, idx))
        m = int(t.shape[0])
        order = None
        if m > 1 and bool(np.any(log_ns[1:] < log_ns[:-1])):
            order = np.argsort(log_ns, kind="stable")
            t, log_ns, idx = t[order], log_ns[order], idx[order]
        new = np.ones(m, dtype=bool)
        if carried:
            new = (np.arange(m) if order is None else order) >= carried
            self._steps(topic, t[new], log_ns[new], idx[new])
        else:
            self._steps(topic, t, log_ns, idx)
        glitch, pending, ahead, aside = forward_outliers(t, log_ns, clock.ref, self._window)
        # the open run is left out of the running maximum (its stamps need not agree with
        # each other), unless that rule drops some of it against the settled newest stamp:
        # then it is behind, not a glitch, and settled with the rest as before
        drop, events_u, used, prev_u, runmax_u = _newest(
            t, aside | pending, clock.high, clock.behind, self._window
        )
        if bool(pending.any()):
            high = int(runmax_u[-1]) if used.size else clock.high
            behind = bool(drop[used[-1]]) if used.size else clock.behind
            if high is not None:
                later = t[pending]
                if bool(np.any(later < high - self._window)) or (
                    behind and bool(np.any(later <= high))
                ):
                    pending[:] = False
                    drop, events_u, used, prev_u, runmax_u = _newest(
                        t, aside, clock.high, clock.behind, self._window
                    )
        if used.size:
            clock.high = int(runmax_u[-1])
            clock.behind = bool(drop[used[-1]])
            at = int(used[-1])
            clock.ref = int(t[at]) - int(log_ns[at])
        clock.open_t, clock.open_log, clock.open_idx = t[pending], log_ns[pending], idx[pending]
        self._note(topic, glitch, new, drop, events_u, used, prev_u, t, log_ns, idx, ahead)
        if not bool((glitch | drop)[new].any()):
            return None
        keep_sorted = ~(glitch | drop)
        keep_all = keep_sorted
        if order is not None:
            keep_all = np.empty(m, dtype=bool)
            keep_all[order] = keep_sorted
        keep_real = keep_all[carried:]
        if real is None:
            return keep_real
        keep = np.ones(n, dtype=bool)
        keep[real] = keep_real
        return keep

    def _note(
        self,
        topic: str,
        glitch: BoolArray,
        new: BoolArray,
        drop: BoolArray,
        events_u: BoolArray,
        used: IntArray,
        prev_u: IntArray,
        t: IntArray,
        log_ns: IntArray,
        idx: IntArray,
        ahead: IntArray,
    ) -> None:
        """Count what :meth:`_clock` dropped among the new messages, and glitches found
        among those passed on before (``~new``)."""
        if bool(glitch.any()):
            found = self._glitches.setdefault(topic, _Glitches())
            dropped = glitch & new
            if not (found.dropped or found.kept):
                first = int(np.flatnonzero(glitch)[0])
                found.index, found.log_ns = int(idx[first]), int(log_ns[first])
                found.ahead_ns = int(ahead[first])
            found.dropped += int(np.count_nonzero(dropped))
            found.kept += int(np.count_nonzero(glitch & ~new))
        if not bool(drop.any()):
            return
        jumps = self._jumps.setdefault(topic, _Jumps())
        events = np.flatnonzero(events_u & new[used])
        if events.size:
            if jumps.events == 0:
                first = int(events[0])
                at = int(used[first])
                jumps.index, jumps.log_ns = int(idx[at]), int(log_ns[at])
                jumps.back_ns = int(prev_u[first]) - int(t[at])
            jumps.events += int(events.size)
        jumps.dropped += int(np.count_nonzero(drop & new))

    def _moved_line(self, topic: str, field_: str, change: _Relabels) -> str:
        """The line on a string array whose numeric arrays were put back in its first
        order by name (:meth:`_in_first_order`): where its order first changed, the
        order kept, and the names that appeared or went missing."""
        first = change.first
        moved = self._changes[(topic, field_)]
        arrays = ", ".join(f"{name}[i]" for name in first.siblings)
        more = f"; {change.count} changes" if change.count > 1 else ""
        line = (
            f"{topic}: {first.field}[] changed order at {self._at(change.log_ns)} "
            f"({_names(first.before)} -> {_names(first.after)}){more}; {arrays} put back in "
            f"the first order by name, {_names(tuple(self._orders[(topic, field_)]))}"
        )
        for what, found in (("added", moved.added), ("missing", moved.missing)):
            if found:
                said = [f"{n} from {self._at(t)}" for n, t in list(found.items())[:3]]
                rest = f" and {len(found) - 3} more" if len(found) > 3 else ""
                line += f"; {what}: {', '.join(said)}{rest}"
        return line

    def _at(self, log_ns: int) -> str:
        return f"t={(log_ns - (self._t0 or 0)) / 1e9:.2f} s"

    def _in_first_order(self, topic: str, field_: str, decoded: Decoded, log_ns: IntArray) -> None:
        """Put the elements of the flat numeric arrays beside the string array ``field_``
        of ``decoded`` (``JointState.position[j]`` beside ``name``) back in the topic's
        first order by name (:attr:`_orders`): a driver restarted mid-record that
        publishes the same joints in another order moved ``position[4]`` to another
        joint, whose channel then mixed two joints (a false fault, or, said as a
        relabelling, the joints left out). Per content of the batch (a few), not per
        message (:func:`by_name`); a name that appears later gets the next index."""
        key = (topic, field_)
        first, _, siblings, kinds = decoded.label_ends[field_]
        if key in self._unordered or not siblings or any(s.endswith("]") for s in siblings):
            return
        got = decoded.label_rows.get(field_)
        if got is None and len(kinds) > 1:  # (more contents than BY_NAME_ORDERS)
            self._unordered.add(key)
            return
        rows, codes, contents = got or (
            np.arange(decoded.n, dtype=np.int64),
            np.zeros(decoded.n, dtype=np.int64),
            (first,),
        )
        if any(len(set(c)) < len(c) or "" in c for c in contents):
            self._unordered.add(key)  # (names repeated or empty: no order to follow)
            return
        _, seen_at = np.unique(codes, return_index=True)
        came = np.argsort(seen_at).tolist()  # (the contents as they came)
        if key not in self._orders:
            self._orders[key] = list(contents[came[0]])
            self._changes[key] = _Moved()
        order, said = self._orders[key], self._changes[key]
        index = {name: i for i, name in enumerate(order)}
        known = [0] * len(contents)  # (the names known when each content came)
        for k in came:
            for name in contents[k]:
                if name not in index:
                    index[name] = len(order)
                    order.append(name)
                    said.added.setdefault(name, int(log_ns[rows[seen_at[k]]]))
            known[k] = len(order)
        for k in came:
            for name in order[: known[k]]:
                if name not in contents[k]:
                    said.missing.setdefault(name, int(log_ns[rows[seen_at[k]]]))
        targets = [[index[name] for name in c] for c in contents]
        if all(t == list(range(len(t))) for t in targets):
            return
        decoded.columns = by_name(decoded.columns, siblings, decoded.n, rows, codes, targets)
        self._moved.add(key)

    def relabelled(self) -> list[str]:
        """Prefixes of the channels whose meaning changed between messages: an array's
        element (``/tf.transforms[0].``) or a numeric array beside a string array
        (``/joint_states.position[``)."""
        out: dict[str, None] = {}
        for (topic, name_), change in self._relabels.items():
            if not self._renamed(topic, name_):
                continue
            for name in change.first.siblings:
                out[f"{topic}.{name}." if name.endswith("]") else f"{topic}.{name}["] = None
        return list(out)

    def messages(self) -> dict[str, int]:
        """The messages decoded per topic, a topic without a numeric field too (a
        ``std_msgs/String``: no channel, which ``inspect`` names: ux58 #9)."""
        return dict(self._messages)

    def labels(self) -> dict[str, str]:
        """The names the messages give their numeric arrays' elements, where no index
        names two things (:meth:`_renamed`; those are left out, said by
        :meth:`relabelled`): ``JointState.name`` labels ``/joint_states.position[4]``
        and ``velocity[4]`` (the channel) with its 5th name; an element's own name
        (``transforms[0].child_frame_id``) labels the element (``/tf.transforms[0]``,
        the prefix of its channels). A list that grows or shrinks gives each index the
        name of the longest seen; an empty name labels nothing."""
        out: dict[str, str] = {}
        for (topic, field_), contents in self._seen_labels.items():
            if not contents or self._renamed(topic, field_):
                continue
            names = max(contents, key=len)
            if (topic, field_) in self._orders and (topic, field_) not in self._unordered:
                names = tuple(self._orders[(topic, field_)])
            for sibling in self._siblings.get((topic, field_), ()):
                if sibling.endswith("]"):  # (an element named by its own string)
                    if names and names[0]:
                        out[f"{topic}.{sibling}"] = names[0]
                    continue
                for i, name in enumerate(names):
                    if name:
                        out[f"{topic}.{sibling}[{i}]"] = name
        return out

    def _renamed(self, topic: str, field: str) -> bool:
        """Whether two contents seen of a string array name different things at one index
        (a name list that only grows or shrinks, ``[a, b, c]`` then ``[a, b]``, keeps
        every index's meaning)."""
        if (topic, field) in self._orders and (topic, field) not in self._unordered:
            return False  # (put back in one order by name: each index keeps its name)
        seen = list(self._seen_labels.get((topic, field), {}))
        return any(
            any(x != y for x, y in zip(a, b, strict=False))
            for i, a in enumerate(seen)
            for b in seen[i + 1 :]
        )

    def lines(self) -> list[str]:
        """The error lines, one per topic and kind."""
        two = self.clock_line()
        out = [two] if two else []
        out += [
            f"{topic}: {text}; use --time log, or leave it out with --channels '!{topic}.*'"
            for topic, text in self.clock_steps().items()
        ]
        out += [
            f"{topic}: {counted(count, 'message')} could not be decoded ({reason})"
            for topic, (count, reason) in self._failures.items()
        ]
        out += [
            f"{topic}: {counted(count, 'message')} "
            + (
                "has header.stamp 0 (not set); its"
                if count == 1
                else "have header.stamp 0 (not set); their"
            )
            + " log time is used"
            for topic, count in self._zero.items()
        ]
        window = f"{self._window / 1e9:g} s"
        for topic, found in self._glitches.items():
            kept = (
                f", {found.kept} kept (passed on at the end of a batch, before the next "
                "message showed them; they no longer count as the newest stamp)"
                if found.kept
                else ""
            )
            out.append(
                f"{topic}: {counted(found.dropped + found.kept, 'message')} stamped more than "
                f"{window} "
                f"ahead of the messages around them (the first: message {found.index}, "
                f"{self._at(found.log_ns)}, {found.ahead_ns / 1e9:.1f} s ahead): "
                f"{found.dropped} dropped{kept} (--time log keeps them)"
            )
        for topic, clock in self._clocks.items():
            if clock.ref is None or not clock.open_t.size:
                continue
            k = int(clock.open_t.size)
            lead = int(clock.open_t[0]) - int(clock.open_log[0]) - clock.ref
            last, them, which = (
                ("the last message read is", "it", "")
                if k == 1
                else (f"the last {k} messages read are", "them", "the first: ")
            )
            out.append(
                f"{topic}: {last} stamped more than {window} ahead of the message before "
                f"{them} ({which}message {int(clock.open_idx[0])}, "
                f"{self._at(int(clock.open_log[0]))}, {lead / 1e9:.1f} s ahead): kept (with "
                f"no message after {them}, a glitch cannot be told from a clock that stepped "
                f"forward) (--time log keeps {them})"
            )
        for topic, jumps in self._jumps.items():
            if not jumps.events or self._explained(jumps.back_ns):
                continue
            if self._explained_at.get(topic) == jumps.index:
                continue
            more = f"; {jumps.events} such jumps" if jumps.events > 1 else ""
            out.append(
                f"{topic}: header.stamp goes back by {jumps.back_ns / 1e9:.1f} s at message "
                f"{jumps.index} ({self._at(jumps.log_ns)}); "
                f"{counted(jumps.dropped, 'message')} stamped before the newest stamp so far "
                f"dropped{more} (--time log keeps them)"
            )
        for (topic, name_), change in self._relabels.items():
            if (topic, name_) in self._moved and not self._renamed(topic, name_):
                out.append(self._moved_line(topic, name_, change))
        elements: dict[str, list[tuple[str, _Relabels]]] = {}
        for (topic, name_), change in self._relabels.items():
            if not self._renamed(topic, name_):
                continue
            first = change.first
            if first.siblings and first.siblings[0].endswith("]"):
                elements.setdefault(topic, []).append((name_, change))
                continue
            arrays = ", ".join(f"{name}[i]" for name in first.siblings) or "the arrays"
            verb = "follows" if len(first.siblings) == 1 else "follow"
            more = f"; {change.count} changes" if change.count > 1 else ""
            out.append(
                f"{topic}: {first.field}[] changed at {self._at(change.log_ns)} "
                f"({_names(first.before)} -> {_names(first.after)}); {arrays} {verb} the "
                f"index, not the name{more} (not analyzed unless --channels names them)"
            )
        for topic, changes in elements.items():
            # an array's elements named by their own strings (frames): one line a topic,
            # showing the field seen with most contents
            label, _ = max(changes, key=lambda fc: len(self._seen_labels[(topic, fc[0])]))
            names = list(dict.fromkeys(c.first.siblings[0] for _, c in changes))
            which = (
                f"{topic}.{names[0]}.*"
                if len(names) == 1
                else f"the channels of {len(names)} elements ({', '.join(names[:2])}, ...)"
            )
            seen = [" ".join(v) for v in self._seen_labels[(topic, label)]]
            shown = ", ".join(seen[: SEEN_LABELS - 1]) + (
                " and more" if len(seen) >= SEEN_LABELS else ""
            )
            at = min(c.log_ns for _, c in changes)
            out.append(
                f"{topic}: {label} changes between messages ({shown}; first at "
                f"{self._at(at)}): {which} hold whatever it names, message by message, not "
                "one quantity (not analyzed unless --channels names them)"
            )
        return out


SEEN_LABELS = 9
"""Contents of a relabelled string array kept for its line (one more than it shows)."""


@dataclass(slots=True)
class _Moved:
    """A string array beside numeric arrays: the names that appeared after the topic's
    first message, and those missing from a message after they were seen, each with its
    first log time (said where the arrays were put back in one order by name)."""

    added: dict[str, int] = field(default_factory=dict)
    missing: dict[str, int] = field(default_factory=dict)


def _names(names: tuple[str, ...], most: int = 8) -> str:
    shown = ", ".join(names[:most]) + (f", ... ({len(names)})" if len(names) > most else "")
    return f"[{shown}]"


# --------------------------------------------------------------------------- time order


@dataclass(slots=True)
class _Times:
    """Held times shared by channels (see :meth:`Reorderer.release`); ``parts`` keeps
    the arrays whose ids key them alive while they are looked up."""

    parts: list[IntArray]
    t: IntArray
    order: IntArray | None
    cut: int
    rest: IntArray
    repeats: bool | None = None
    """Whether two of the released times are equal (worked out once, on demand)."""


class Reorderer:
    """Turns per-batch samples into per-channel chunks in non-decreasing time order.

    Samples are held until :meth:`release` is told a bound below which no further sample
    will arrive (for indexed files, the start time of the next chunk), or, with no bound,
    until they are :data:`REORDER_WINDOW_NS` older than the newest sample of their
    channel. A sample that still arrives later than an already released one cannot be
    placed; it is dropped and counted in :attr:`dropped`.

    With ``signs`` (the ROS and MCAP readers), the quaternions among the channels of a
    release are made continuous in sign (:class:`~analyzer.readers.quaternions.
    QuaternionSigns`) after they are counted as released.

    With ``repeats`` (the ROS and MCAP readers), samples at the same time as the one
    before them on their channel are counted in :attr:`duplicates` (and kept: they are
    raw samples of the input, which ``inspect`` counts; the aligned channels can hold
    one value per time, which :meth:`drop_report` says). ``topics`` (filled by
    :meth:`push_decoded`) maps channels to their topic, for reports per topic.

    What it is given and what it releases or drops are tallied (:class:`~analyzer.
    readers.tally.Tally`); :meth:`flush` checks that they agree and raises
    :class:`~analyzer.errors.IntegrityError` where they do not: samples changed while
    held (a CSV's values are views of Arrow's buffers until the final release).
    """

    def __init__(
        self,
        window_ns: int = REORDER_WINDOW_NS,
        batch_samples: int = RELEASE_SAMPLES,
        *,
        repeats: bool = False,
        topics: dict[str, str] | None = None,
        signs: QuaternionSigns | None = None,
    ) -> None:
        self._window = window_ns
        self._signs = signs
        self._batch = batch_samples
        self._repeats = repeats
        self._held = 0
        self._t: dict[str, list[IntArray]] = {}
        self._v: dict[str, list[FloatArray]] = {}
        self._last: dict[str, int] = {}
        self.dropped: dict[str, int] = {}
        self.duplicates: dict[str, int] = {}
        self.topics: dict[str, str] = {} if topics is None else topics
        self.pushed = Tally()
        """What :meth:`push` was given."""
        self.passed = Tally()
        """What :meth:`release` released, and what it dropped."""

    def push(self, name: str, t: IntArray, values: FloatArray) -> None:
        if t.size == 0:
            return
        self.pushed.add(name, t, values)
        if name not in self._t:
            self._t[name] = []
            self._v[name] = []
        self._t[name].append(t)
        self._v[name].append(values)
        self._held += int(t.size)

    def push_decoded(
        self, topic: str, decoded: Decoded, times: IntArray, separator: str = "."
    ) -> None:
        """Push every column of ``decoded`` under ``{topic}{separator}{field}``."""
        for fieldname, (rows, values) in decoded.columns.items():
            t = times if rows is None else times[rows]
            name = f"{topic}{separator}{fieldname}" if topic else fieldname
            self.topics[name] = topic or name
            self.push(name, t, values)

    def release(self, bound: int | None, *, final: bool = False) -> Iterator[ChannelChunk]:
        """Yield what is known to be complete: samples before ``bound``, or, with
        ``bound=None``, samples older than the window; with ``final``, everything.
        Nothing is released before :data:`RELEASE_SAMPLES` samples are held."""
        if not final and self._held < self._batch:
            return
        self._held = 0
        if self._signs is None:
            yield from self._release(bound, final)
            return
        # (counted as released before: the signs are a change of the reader's own)
        yield from self._signs.released(self._release(bound, final), self.topics)

    def _release(self, bound: int | None, final: bool) -> Iterator[ChannelChunk]:
        """:meth:`release`'s chunks, each counted as released (:attr:`passed`)."""
        # the fields of one topic (a CSV's columns) share their time arrays: their
        # concatenation, order and cut are worked out once, and the part held back
        # stays shared for the next release
        shared: dict[tuple[int, ...], _Times] = {}
        for name in list(self._t):
            parts_t, parts_v = self._t[name], self._v[name]
            key = tuple(map(id, parts_t))
            times = shared.get(key)
            if times is None:
                times = shared[key] = self._order(parts_t, bound, final)
            order, t, cut = times.order, times.t, times.cut
            v = parts_v[0] if len(parts_v) == 1 else np.concatenate(parts_v)
            if order is not None:
                v = v[order]
            if cut < t.size:
                self._t[name], self._v[name] = [times.rest], [v[cut:]]
                self._held += int(t.size - cut)
            else:
                del self._t[name], self._v[name]
            if cut == 0:
                continue
            out_t, out_v = t[:cut], v[:cut]
            last = self._last.get(name)
            if last is not None and int(out_t[0]) < last:
                keep = out_t >= last
                self.dropped[name] = self.dropped.get(name, 0) + int(np.count_nonzero(~keep))
                self.passed.add(name, out_t[~keep], out_v[~keep])
                out_t, out_v = out_t[keep], out_v[keep]
                if out_t.size == 0:
                    continue
            if self._repeats:
                if times.repeats is None:
                    times.repeats = bool(np.any(t[1:cut] == t[: cut - 1]))
                if times.repeats or (last is not None and int(out_t[0]) == last):
                    self._count_repeats(name, out_t, last)
            self._last[name] = int(out_t[-1])
            chunk = ChannelChunk(name, np.ascontiguousarray(out_t), np.ascontiguousarray(out_v))
            self.passed.add(name, chunk.t_ns, chunk.values)
            yield chunk

    def _order(self, parts_t: list[IntArray], bound: int | None, final: bool) -> _Times:
        """The held times of a channel in order, their sorting order (None when they are
        in order) and where :meth:`release` cuts them."""
        t = parts_t[0] if len(parts_t) == 1 else np.concatenate(parts_t)
        order = None
        if t.size > 1 and bool(np.any(t[1:] < t[:-1])):
            order = np.argsort(t, kind="stable")
            t = t[order]
        if final:
            cut = t.size
        else:
            limit = bound if bound is not None else int(t[-1]) - self._window
            cut = int(np.searchsorted(t, limit, side="left"))
        return _Times(parts_t, t, order, cut, t[cut:])

    def _count_repeats(self, name: str, t: IntArray, last: int | None) -> None:
        """Count the samples of ``t`` (sorted) at the time of the one before."""
        count = int(np.count_nonzero(t[1:] == t[:-1]))
        count += int(last is not None and int(t[0]) == last)
        if count:
            self.duplicates[name] = self.duplicates.get(name, 0) + count

    def flush(self) -> Iterator[ChannelChunk]:
        """Release everything still held, then check that every sample pushed was
        released or dropped, unchanged (:class:`IntegrityError` naming the channel)."""
        yield from self.release(None, final=True)
        lost = self.pushed.differences(self.passed, "pushed", "released or dropped")
        if lost:
            said = capped(lost, 2, "; ", "channels")
            raise IntegrityError(f"internal check failed in the reader's reordering: {said}")

    def drop_report(self) -> list[str]:
        """One error line per topic (per channel without one) that lost samples: out of
        order by more than the reorder window, or repeating a time."""
        lines = [
            f"{label}: {count} {unit} dropped because their timestamps went back in time "
            f"by more than the reorder window ({self._window / 1e9:g} s)"
            for label, unit, count in per_topic(self.dropped, self.topics)
        ]
        lines += [
            f"{label}: {count} {unit} repeat the timestamp of the one before (two "
            "publishers, or a recorder's coarse clock); the aligned channels keep one "
            "value per time"
            for label, unit, count in per_topic(self.duplicates, self.topics)
        ]
        return lines


@dataclass(slots=True)
class _Undecoded:
    """Messages of one channel from one batch, not decoded yet: their payloads in
    ``buf`` (``starts``, ``sizes``) and their log times."""

    buf: ByteArray
    starts: IntArray
    sizes: IntArray
    log_ns: IntArray
    first: int = 0
    """The earliest of ``log_ns``."""

    @classmethod
    def of(cls, buf: ByteArray, starts: IntArray, sizes: IntArray, log_ns: IntArray) -> _Undecoded:
        return cls(buf, starts, sizes, log_ns, int(log_ns.min()))

    def part(self, keep: BoolArray) -> _Undecoded:
        return _Undecoded.of(self.buf, self.starts[keep], self.sizes[keep], self.log_ns[keep])

    def compact(self) -> _Undecoded:
        """The same messages with their payloads alone in a buffer of their own (a part
        held across chunks keeps no chunk's whole buffer alive)."""
        buf, starts = _gathered(self.buf, self.starts, self.sizes)
        return _Undecoded(buf, starts, self.sizes, self.log_ns, self.first)


def _gathered(buf: ByteArray, starts: IntArray, sizes: IntArray) -> tuple[ByteArray, IntArray]:
    """The payloads ``buf[starts[i] : starts[i] + sizes[i]]`` one after the other in a new
    buffer, and their starts there (one gather: no loop over the messages)."""
    ends = np.cumsum(sizes)
    new_starts = ends - sizes
    index = np.repeat(starts - new_starts, sizes) + np.arange(int(ends[-1]) if ends.size else 0)
    return buf[index], new_starts.astype(np.int64)


class LogOrder:
    """Undecoded messages held until no message logged before them can still come, so
    that each channel's messages are decoded, and reach the :class:`TopicTracker`, in
    log-time order where the chunks of an indexed file overlap in time.

    An indexed file is read chunk by chunk in start-time order; after a chunk, ``bound``
    is the start time of the next one: no later chunk holds a message logged before it.
    A chunk may end after the next ones start (a ROS 1 bag with a chunk of 9.5-889 s
    read before one of 425-814 s): its messages logged after ``bound`` wait for
    the chunks that interleave with them. With ``--time log`` the :class:`Reorderer`
    would sort them all the same, but the tracker's header-clock rule reads each topic's
    stamps in log-time order: a late stretch handed to it first made the next chunk's
    messages a clock stepping back (dropped). Messages of a chunk that overlaps no later
    one pass through as they came (no copy); those held back are copied into a buffer of
    their own (no chunk's whole buffer held), and where those of several chunks are
    taken together, their payloads are gathered into one buffer and sorted by log time
    (stable). A part whose earliest message is after the bound is passed over with one
    comparison. Used with ``--time header`` only: with ``--time log`` the
    :class:`Reorderer` orders the samples by log time anyway."""

    def __init__(self) -> None:
        self._held: dict[int, list[_Undecoded]] = {}

    def push(
        self, key: int, buf: ByteArray, starts: IntArray, sizes: IntArray, log_ns: IntArray
    ) -> None:
        """Hold the messages of channel ``key`` of one batch."""
        if log_ns.size:
            self._held.setdefault(key, []).append(_Undecoded.of(buf, starts, sizes, log_ns))

    def take(
        self, bound: int | None
    ) -> Iterator[tuple[int, ByteArray, IntArray, IntArray, IntArray]]:
        """Per channel, ``(key, buf, starts, sizes, log_ns)`` of its messages logged
        at or before ``bound`` (None: all of them), in log-time order across batches; the
        others stay held. (Those logged at ``bound`` itself go: the next batch may hold
        more at that time, none before it, and equal times keep their order.)"""
        for key in list(self._held):
            now: list[_Undecoded] = []
            later: list[_Undecoded] = []
            for held in self._held[key]:
                if bound is None:
                    now.append(held)
                    continue
                if held.first > bound:  # (a part held from before: one comparison)
                    later.append(held)
                    continue
                early = held.log_ns <= bound
                if bool(early.all()):
                    now.append(held)
                else:
                    now.append(held.part(early))
                    later.append(held.part(~early).compact())
            if later:
                self._held[key] = later
            else:
                del self._held[key]
            if len(now) == 1:
                one = now[0]
                yield key, one.buf, one.starts, one.sizes, one.log_ns
            elif now:
                yield (key, *_joined(now))


def _joined(parts: Sequence[_Undecoded]) -> tuple[ByteArray, IntArray, IntArray, IntArray]:
    """The messages of ``parts`` (from different buffers) in one buffer, in log-time order
    (stable): of each part, its payloads alone are copied (the span from its first to its
    last payload held the other topics' messages too: 202 MB copied for 6 MB of
    payloads of 20 topics with a jitter of 50 ms, the review)."""
    pieces: list[ByteArray] = []
    starts: list[IntArray] = []
    offset = 0
    for part in parts:
        buf, at = _gathered(part.buf, part.starts, part.sizes)
        pieces.append(buf)
        starts.append(at + offset)
        offset += buf.shape[0]
    log_ns = np.concatenate([p.log_ns for p in parts])
    order = np.argsort(log_ns, kind="stable")
    sizes = np.concatenate([p.sizes for p in parts])
    return np.concatenate(pieces), np.concatenate(starts)[order], sizes[order], log_ns[order]


def per_topic(counts: dict[str, int], topics: dict[str, str]) -> list[tuple[str, str, int]]:
    """Per-channel counts summed up per topic: ``(topic, "messages", count)`` with the
    largest count among the topic's channels (a message holds one sample of each), or
    ``(channel, "samples", count)`` for a channel without a topic (a CSV column)."""
    out: dict[str, tuple[str, int]] = {}
    for name, count in counts.items():
        topic = topics.get(name, name)
        unit = "samples" if topic == name else "messages"
        seen = out.get(topic)
        out[topic] = (unit, count if seen is None else max(seen[1], count))
    return [(topic, unit, count) for topic, (unit, count) in out.items()]


def monotonic(
    chunks: Iterable[ChannelChunk],
    last: dict[str, int],
    dropped: dict[str, int],
    *,
    strict: bool = False,
    spans: dict[str, tuple[int, int]] | None = None,
) -> Iterator[ChannelChunk]:
    """Pass ``chunks`` through, dropping samples earlier than the last one already passed
    for the same channel (with ``strict``, also samples at the same time: duplicates where
    two files overlap). ``last`` and ``dropped`` are updated in place, and ``spans``
    (where given) with the first and last time dropped of each channel. Used where
    several sources are concatenated: the files of a directory archive, the split files
    of a ROS 2 bag."""
    for chunk in chunks:
        if len(chunk) == 0:
            continue
        prev = last.get(chunk.name)
        first = int(chunk.t_ns[0])
        if prev is not None and (first < prev or (strict and first == prev)):
            keep = chunk.t_ns > prev if strict else chunk.t_ns >= prev
            dropped[chunk.name] = dropped.get(chunk.name, 0) + int(np.count_nonzero(~keep))
            if spans is not None:
                gone = chunk.t_ns[~keep]
                lo, hi = int(gone.min()), int(gone.max())
                was = spans.get(chunk.name)
                spans[chunk.name] = (lo, hi) if was is None else (min(was[0], lo), max(was[1], hi))
            if not bool(np.any(keep)):
                continue
            chunk = ChannelChunk(chunk.name, chunk.t_ns[keep], chunk.values[keep])
        last[chunk.name] = int(chunk.t_ns[-1])
        yield chunk


# --------------------------------------------------------------------------- files


def file_digest(paths: Sequence[Path]) -> tuple[int, str]:
    """Total size and sha256 of the concatenated bytes of ``paths``, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    total = 0
    for path in paths:
        with path.open("rb") as handle:
            while block := handle.read(HASH_BLOCK):
                digest.update(block)
                total += len(block)
    return total, digest.hexdigest()


LFS_MAGIC = b"version https://git-lfs.github.com/spec/"


def lfs_pointer(path: Path) -> str | None:
    """What to say about ``path`` when it is a Git LFS pointer (a repository cloned
    without ``git lfs``: a ~130-byte text naming the real file's hash and size) instead of
    the data, else None. Every reader's own error would only say the bytes are wrong."""
    try:
        with path.open("rb") as handle:
            head = handle.read(512)
    except OSError:
        return None  # the reader says why it cannot be read
    if not head.startswith(LFS_MAGIC):
        return None
    size = next(
        (
            line.split()[1].decode("ascii", "replace")
            for line in head.splitlines()
            if line.startswith(b"size ") and len(line.split()) == 2
        ),
        None,
    )
    target = f" (to a {size}-byte file)" if size is not None and size.isdigit() else ""
    return (
        f"{path}: a Git LFS pointer{target}, not the data itself (fetch it with `git lfs pull` "
        "in its repository)"
    )


SIDECARS = ("-shm", "-wal", "-journal")


def bag_files(path: Path) -> list[Path]:
    """The files that make up a bag (hashed for ``findings.json``): for a directory its
    regular files except sqlite sidecars, sorted; for a bare storage file itself."""
    if path.is_dir():
        return sorted(p for p in path.iterdir() if p.is_file() and not p.name.endswith(SIDECARS))
    return [path]


def bag_listed_files(path: Path) -> list[str] | None:
    """The names of the storage files a ROS 2 bag folder's ``metadata.yaml`` lists, or
    None where it cannot be read. A listed path stands for the file of its name in the
    bag folder, as rosbags opens it: old rosbag2 versions list
    ``rosbag2_test/rosbag2_test_0.db3`` in the folder ``rosbag2_test``."""
    from ruamel.yaml import YAML  # the YAML library rosbags itself uses

    try:
        doc = YAML(typ="safe").load((path / "metadata.yaml").read_text(encoding="utf-8"))
        names = doc["rosbag2_bagfile_information"]["relative_file_paths"]
        return [PurePath(str(name)).name for name in names]
    except Exception:  # noqa: BLE001 - any malformed metadata: rosbags reports it
        return None


SPECIAL_KINDS = (
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
)


def special_kind(path: Path) -> str | None:
    """What ``path`` is when it is neither a regular file nor a directory (``a FIFO``,
    ``a socket``...), from ``os.stat`` alone (opening a FIFO blocks until a writer comes);
    None for a file, a directory, or a path that cannot be stat-ed (a dangling link)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return next((kind for test, kind in SPECIAL_KINDS if test(mode)), "a special file")


LINK_LOOP = "a symbolic link loop"
"""What :func:`link_out` says of a link that leads back to itself."""


def link_out(path: Path, root: Path, where: str = "the watched folder") -> str | None:
    """Why ``path``, a member of the folder ``root`` (the watcher's INBOX, given by its
    real path), is not read: a symbolic link whose real path is outside ``root``
    (``a symbolic link to /etc/passwd, outside {where}``), or a link loop;
    None for anything else (a link whose target is inside ``root`` is followed). A
    dangling link is not one: nothing can be read through it, and its callers say so.

    Only links can lead out: a file reached through real folders under ``root`` lies
    in it, so a walk asks this of its links alone (one ``resolve`` each)."""
    if not path.is_symlink():
        return None
    try:
        real = path.resolve(strict=True)
    except RuntimeError:  # (a loop, on Python < 3.13)
        return LINK_LOOP
    except OSError as err:
        if err.errno == errno.ELOOP:
            return LINK_LOOP
        return None  # (dangling, or gone meanwhile: said where it is read)
    if real == root or real.is_relative_to(root):
        return None
    return f"a symbolic link to {real}, outside {where}"


def open_inside(path: Path, root: Path) -> int:
    """A read-only descriptor of the regular file ``path`` of the folder ``root`` (the
    watcher's INBOX, by its real path), opened by its real path with ``O_NOFOLLOW``
    (and ``O_NONBLOCK``: a FIFO put in its place opens at once and is refused), so that
    a file swapped for a link after it was checked is not read through it; on Linux the
    descriptor's own path (``/proc/self/fd``) is checked to lie in ``root`` too (a
    folder above it swapped for a link). Raises ``OSError`` for a path leading out of
    ``root`` or not a regular file."""
    why = link_out(path, root)
    if why is not None:
        raise OSError(errno.EACCES, why, str(path))
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0)
    fd = os.open(path.resolve(), flags)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise OSError(errno.EINVAL, "not a regular file", str(path))
        try:
            real = Path(os.readlink(f"/proc/self/fd/{fd}"))
        except OSError:  # (no /proc: the O_NOFOLLOW open above is what there is)
            real = root
        if real != root and not real.is_relative_to(root):
            raise OSError(errno.EACCES, f"a link to {real}, outside the watched folder", str(path))
    except BaseException:
        os.close(fd)
        raise
    return fd

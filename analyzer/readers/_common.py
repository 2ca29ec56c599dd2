"""Pieces every reader shares: byte gathering, decoded batches, time ordering, hashing.

The readers cut an input into *batches* (an MCAP chunk, a ROS 1 chunk, a few thousand
rows of a sqlite table or CSV), decode every channel of a batch with whole-array
operations, and hand the samples to a :class:`Reorderer`, which makes sure the
:class:`~analyzer.readers.base.ChannelChunk` stream of each channel is in time order
without holding more than a batch or two in memory.
"""

from __future__ import annotations

import hashlib
import os
import stat
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from analyzer.errors import one_line  # noqa: F401 - re-exported for the readers
from analyzer.readers.base import ChannelChunk

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
        return Decoded(n, columns, stamps, self.failed, self.first_error, self.relabels)


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


# --------------------------------------------------------------------------- per-topic notes


@dataclass(slots=True)
class _Jumps:
    """Header clock jumps of one topic: how many, messages dropped, the first one."""

    events: int = 0
    dropped: int = 0
    index: int = 0
    log_ns: int = 0
    back_ns: int = 0


@dataclass(slots=True)
class _Relabels:
    """Changes of one string array of one topic: how many, and the first one."""

    count: int
    log_ns: int
    first: Relabel


class TopicTracker:
    """What one pass of a ROS or MCAP reader notes per topic beside the samples, and the
    time each message gets; :meth:`push` hands the samples on to a :class:`Reorderer`.

    * messages that could not be decoded (counted, the first reason kept);
    * with ``--time header``: a ``header.stamp`` of 0 (a driver that does not set it) is
      no stamp: the message's log time is used, and counted;
    * with ``--time header``: a header clock that goes back by more than the reorder
      window (a clock step, a restarted simulator). Sorting would interleave the stretch
      after the step with the one before it (the aligner then keeps one of two samples
      per tick, silently). The rule: in log-time order, a message stamped more than the
      window before the newest stamp of its topic so far, and the messages after it that
      stay at or below that newest stamp, are dropped and counted; the stamps within the
      window behind are reordered, as before. Vectorized: a running maximum per batch,
      carried across batches;
    * string arrays beside numeric arrays (``JointState.name``) that change content
      (:class:`Relabel`, found by the decoders): ``position[i]`` follows the index.
    """

    def __init__(self, time: str, window_ns: int = REORDER_WINDOW_NS) -> None:
        self.time = time
        self._window = window_ns
        self._t0: int | None = None
        self._seen: dict[str, int] = {}
        self._high: dict[str, int] = {}
        self._behind: dict[str, bool] = {}
        self._jumps: dict[str, _Jumps] = {}
        self._zero: dict[str, int] = {}
        self._failures: dict[str, list[Any]] = {}
        self._relabels: dict[tuple[str, str], _Relabels] = {}

    def push(self, reorder: Reorderer, topic: str, decoded: Decoded, log_ns: IntArray) -> None:
        """Note what ``decoded`` (messages of ``topic`` logged at ``log_ns``) holds beside
        its samples, and push them with their times."""
        if decoded.failed:
            seen = self._failures.setdefault(topic, [0, decoded.first_error])
            seen[0] += decoded.failed
        if decoded.n == 0:
            return
        if self._t0 is None:
            self._t0 = int(log_ns.min())
        for change in decoded.relabels:
            key = (topic, change.field)
            known = self._relabels.get(key)
            if known is None:
                self._relabels[key] = _Relabels(change.count, int(log_ns[change.row]), change)
            else:
                known.count += change.count
        times = log_ns
        if self.time == "header" and decoded.stamps is not None:
            stamps = decoded.stamps
            unset = stamps == 0
            zeros = int(np.count_nonzero(unset))
            if zeros:
                self._zero[topic] = self._zero.get(topic, 0) + zeros
            unset |= stamps == NO_STAMP
            times = np.where(unset, log_ns, stamps) if bool(unset.any()) else stamps
            keep = self._clock(topic, times, log_ns)
            if keep is not None:
                decoded = decoded.subset(keep)
                times = times[keep]
        self._seen[topic] = self._seen.get(topic, 0) + int(log_ns.shape[0])
        reorder.push_decoded(topic, decoded, times)

    def _clock(self, topic: str, t: IntArray, log_ns: IntArray) -> npt.NDArray[np.bool_] | None:
        """Which messages to keep (None: all) by the header-clock rule of the class."""
        n = int(t.shape[0])
        order = None
        if n > 1 and bool(np.any(log_ns[1:] < log_ns[:-1])):
            order = np.argsort(log_ns, kind="stable")
            t = t[order]
        high = self._high.get(topic)
        runmax = np.maximum.accumulate(t)
        prev = np.empty_like(t)
        prev[1:] = runmax[:-1]
        prev[0] = int(t[0]) - 1 if high is None else high
        if high is not None:
            np.maximum(prev, high, out=prev)
        self._high[topic] = int(runmax[-1]) if high is None else max(high, int(runmax[-1]))
        advancing = t > prev
        carry = self._behind.get(topic, False)
        if bool(advancing.all()):
            self._behind[topic] = False
            return None
        far = ~advancing & (t < prev - self._window)
        if not carry and not bool(far.any()):
            self._behind[topic] = False
            return None
        index = np.arange(n)
        run_start = np.maximum.accumulate(np.where(advancing, index, -1))
        last_far = np.maximum.accumulate(np.where(far, index, -1))
        drop = ~advancing & (last_far > run_start)
        if carry:
            drop |= run_start < 0
        before = np.empty(n, dtype=bool)
        before[0] = carry
        before[1:] = drop[:-1]
        events = np.nonzero(far & ~before)[0]
        jumps = self._jumps.setdefault(topic, _Jumps())
        if events.size:
            if jumps.events == 0:
                first = int(events[0])
                at = first if order is None else int(order[first])
                jumps.index = self._seen.get(topic, 0) + first
                jumps.log_ns = int(log_ns[at])
                jumps.back_ns = int(prev[first]) - int(t[first])
            jumps.events += int(events.size)
        jumps.dropped += int(np.count_nonzero(drop))
        self._behind[topic] = bool(drop[-1])
        if order is None:
            return ~drop
        keep = np.empty(n, dtype=bool)
        keep[order] = ~drop
        return keep

    def _at(self, log_ns: int) -> str:
        return f"t={(log_ns - (self._t0 or 0)) / 1e9:.2f} s"

    def lines(self) -> list[str]:
        """The error lines, one per topic and kind."""
        out = [
            f"{topic}: {count} messages could not be decoded ({reason})"
            for topic, (count, reason) in self._failures.items()
        ]
        out += [
            f"{topic}: {count} messages have header.stamp 0 (not set); their log time is used"
            for topic, count in self._zero.items()
        ]
        for topic, jumps in self._jumps.items():
            if not jumps.events:
                continue
            more = f"; {jumps.events} such jumps" if jumps.events > 1 else ""
            out.append(
                f"{topic}: header.stamp goes back by {jumps.back_ns / 1e9:.1f} s at message "
                f"{jumps.index} ({self._at(jumps.log_ns)}); {jumps.dropped} messages stamped "
                f"before the newest stamp so far dropped{more} (--time log keeps them)"
            )
        for (topic, _), change in self._relabels.items():
            first = change.first
            arrays = ", ".join(f"{name}[i]" for name in first.siblings) or "the arrays"
            verb = "follows" if len(first.siblings) == 1 else "follow"
            more = f"; {change.count} changes" if change.count > 1 else ""
            out.append(
                f"{topic}: {first.field}[] changed at {self._at(change.log_ns)} "
                f"({_names(first.before)} -> {_names(first.after)}); {arrays} {verb} the "
                f"index, not the name{more}"
            )
        return out


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

    With ``repeats`` (the ROS and MCAP readers), samples at the same time as the one
    before them on their channel are counted in :attr:`duplicates` (and kept: they are
    raw samples of the input, which ``inspect`` counts; the aligned channels can hold
    one value per time, which :meth:`drop_report` says). ``topics`` (filled by
    :meth:`push_decoded`) maps channels to their topic, for reports per topic.
    """

    def __init__(
        self,
        window_ns: int = REORDER_WINDOW_NS,
        batch_samples: int = RELEASE_SAMPLES,
        *,
        repeats: bool = False,
        topics: dict[str, str] | None = None,
    ) -> None:
        self._window = window_ns
        self._batch = batch_samples
        self._repeats = repeats
        self._held = 0
        self._t: dict[str, list[IntArray]] = {}
        self._v: dict[str, list[FloatArray]] = {}
        self._last: dict[str, int] = {}
        self.dropped: dict[str, int] = {}
        self.duplicates: dict[str, int] = {}
        self.topics: dict[str, str] = {} if topics is None else topics

    def push(self, name: str, t: IntArray, values: FloatArray) -> None:
        if t.size == 0:
            return
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
                out_t, out_v = out_t[keep], out_v[keep]
                if out_t.size == 0:
                    continue
            if self._repeats:
                if times.repeats is None:
                    times.repeats = bool(np.any(t[1:cut] == t[: cut - 1]))
                if times.repeats or (last is not None and int(out_t[0]) == last):
                    self._count_repeats(name, out_t, last)
            self._last[name] = int(out_t[-1])
            yield ChannelChunk(name, np.ascontiguousarray(out_t), np.ascontiguousarray(out_v))

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
        """Release everything still held."""
        yield from self.release(None, final=True)

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
) -> Iterator[ChannelChunk]:
    """Pass ``chunks`` through, dropping samples earlier than the last one already passed
    for the same channel (with ``strict``, also samples at the same time: duplicates where
    two files overlap). ``last`` and ``dropped`` are updated in place. Used where several
    sources are concatenated: the files of a directory archive, the split files of a
    ROS 2 bag."""
    for chunk in chunks:
        if len(chunk) == 0:
            continue
        prev = last.get(chunk.name)
        first = int(chunk.t_ns[0])
        if prev is not None and (first < prev or (strict and first == prev)):
            keep = chunk.t_ns > prev if strict else chunk.t_ns >= prev
            dropped[chunk.name] = dropped.get(chunk.name, 0) + int(np.count_nonzero(~keep))
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

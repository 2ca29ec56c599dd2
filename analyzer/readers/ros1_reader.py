"""ROS 1 bag (format 2.0) reader.

The bag's index (connection and chunk-info records at ``index_pos``, IndexData records
after every chunk) gives, per chunk and connection, the time and offset of every message.
The reader decompresses a whole chunk (none, bz2, lz4) and locates the message data
records of a connection with numpy from those offsets; the payloads are decoded in bulk
by :class:`~analyzer.readers.rosdecode.RosBatchDecoder` with the types parsed by rosbags
from the connection's embedded ``message_definition``.

A bag without a usable index (recording killed: ``index_pos`` 0; truncated file) is
scanned record by record from the start; what is readable is read and the problem is
recorded in ``info.errors``, with how many messages were read and up to when. A file
that ends inside a chunk (a power loss mid-write) keeps that chunk's complete messages,
as ``rosbag reindex`` does: an uncompressed chunk's records are walked up to the cut; an
lz4 chunk is decompressed up to the cut (its complete frame blocks, then the cut block
sequence by sequence: :mod:`~analyzer.readers.cut_chunk`) and walked the same way; a cut
bz2 chunk (one block, in practice) does not decompress, which the error says. The error
says how many messages were recovered and that the rest of the chunk is lost.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, ClassVar

import numpy as np
from rosbags.serde import SerdeError

from analyzer.errors import ReaderError
from analyzer.readers import chunk_limits
from analyzer.readers._common import (
    ByteArray,
    IntArray,
    LogClock,
    LogOrder,
    Reorderer,
    TopicTracker,
    absolute_log_time,
    as_bytes_array,
    file_digest,
    gather_uint,
    one_line,
)
from analyzer.readers.base import (
    ChannelChunk,
    InputInfo,
    TimeSource,
    add_log_topics,
    add_time_fields,
    add_topics,
    check_limit,
)
from analyzer.readers.cut_chunk import CutDataError, cut_prefix, recovered_share
from analyzer.readers.rosdecode import RosBatchDecoder
from analyzer.readers.rostypes import TypeResolutionError, normalize_msgtype, store_from_definition
from analyzer.timeutil import spoken_duration
from analyzer.types import Format

MAGIC = b"#ROSBAG V2.0\n"
OP_MSG_DATA, OP_BAG_HEADER, OP_INDEX_DATA, OP_CHUNK, OP_CHUNK_INFO, OP_CONNECTION = 2, 3, 4, 5, 6, 7
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")


class _BagError(Exception):
    """A record cannot be parsed."""


@dataclass(frozen=True, slots=True)
class _Connection:
    conn: int
    topic: str
    msgtype: str
    msgdef: str


@dataclass(frozen=True, slots=True)
class _ChunkInfo:
    pos: int
    start_ns: int
    end_ns: int
    connections: int


def _fields(header: bytes) -> dict[str, bytes]:
    """The ``name=value`` fields of a record header."""
    out: dict[str, bytes] = {}
    pos, end = 0, len(header)
    while pos + 4 <= end:
        size = _U32.unpack_from(header, pos)[0]
        pos += 4
        if pos + size > end:
            raise _BagError("record header field runs past the header")
        name, sep, value = header[pos : pos + size].partition(b"=")
        if not sep:
            raise _BagError("record header field without '='")
        out[name.decode("ascii", "replace")] = value
        pos += size
    return out


def _time(value: bytes) -> int:
    sec, nsec = struct.unpack("<II", value)
    return sec * 1_000_000_000 + nsec


def _read_record(handle: BinaryIO) -> tuple[dict[str, bytes], bytes] | None:
    """One record at the current position; None at a clean end of file."""
    record = _read_cut_record(handle)
    if record is None:
        return None
    fields, data, data_len = record
    if len(data) < data_len:
        raise _BagError("truncated record")
    return fields, data


def _read_cut_record(handle: BinaryIO) -> tuple[dict[str, bytes], bytes, int] | None:
    """One record at the current position, with the length its header gives its data:
    ``data`` is shorter where the file ends inside it. None at a clean end of file;
    raises where the file ends before the data starts."""
    raw = handle.read(4)
    if not raw:
        return None
    if len(raw) < 4:
        raise _BagError("truncated record")
    header_len = _U32.unpack(raw)[0]
    header = handle.read(header_len)
    raw = handle.read(4)
    if len(header) < header_len or len(raw) < 4:
        raise _BagError("truncated record")
    data_len = _U32.unpack(raw)[0]
    return _fields(header), handle.read(data_len), data_len


def _cut_chunk(compression: str, data: bytes, size: int, packed: int) -> tuple[ByteArray, str]:
    """The record bytes that can be had from a chunk the file ends inside (``data``, the
    part of its ``packed`` bytes of compressed data before the cut: :func:`cut_prefix`,
    at most its declared ``size``), and why none can where that is so."""
    chunk_limits.check_chunk(size, packed, compression)
    try:
        out = cut_prefix(compression, data, size)[:size]
    except CutDataError as err:
        return as_bytes_array(b""), one_line(err)
    if not out:
        return as_bytes_array(b""), (
            f"its {compression}-compressed data holds no complete block before the cut, so "
            "none of its messages can be recovered"
        )
    return as_bytes_array(out), ""


class _ScanCount:
    """How many messages a sequential scan has found, and their first and last log
    times; ``str`` says so for the line that tells where the scan stopped."""

    def __init__(self) -> None:
        self.count = 0
        self.first: int | None = None
        self.last: int | None = None

    def taken(
        self, chunks: list[tuple[ByteArray, IntArray, IntArray, IntArray]]
    ) -> Iterator[tuple[ByteArray, IntArray, IntArray, IntArray]]:
        """``chunks`` (of the scan) counted and passed on; those without a message are
        dropped."""
        for chunk in chunks:
            times = chunk[2]
            if not times.size:
                continue
            self.count += int(times.size)
            low, high = int(times.min()), int(times.max())
            self.first = low if self.first is None else min(self.first, low)
            self.last = high if self.last is None else max(self.last, high)
            yield chunk

    def __str__(self) -> str:
        if self.first is None or self.last is None:
            return "no message before it could be read"
        plural, were = ("s", "were") if self.count != 1 else ("", "was")
        until = (self.last - self.first) / 1e9
        return (
            f"the {self.count} message{plural} before it {were} read, up to "
            f"{spoken_duration(until)} "
            "after the first"
        )

    def in_all(self) -> str:
        """How much was read, said where the file ends."""
        if self.first is None or self.last is None:
            return "no message read in all"
        until = (self.last - self.first) / 1e9
        return (
            f"{self.count} message(s) read in all, up to {spoken_duration(until)} after the first"
        )


def _op(fields: dict[str, bytes]) -> int:
    value = fields.get("op")
    if value is None or len(value) != 1:
        raise _BagError("record without an op field")
    return value[0]


def _decompress(compression: str, data: bytes, size: int) -> ByteArray:
    if compression not in ("none", "bz2", "lz4"):
        raise _BagError(f"unsupported chunk compression {compression!r}")
    try:
        # (at most size + 1 bytes; a size beyond the limits refuses the file)
        out = chunk_limits.decompress(compression, data, size)
    except (OSError, ValueError, RuntimeError, EOFError) as err:
        check_limit(err)  # (the machine's limit is not the file's damage)
        raise _BagError(f"cannot decompress ({compression}): {one_line(err)}") from err
    if len(out) > size:  # (stopped at size + 1 bytes)
        raise _BagError(f"its data decompresses to more than the {size} bytes it declares")
    if len(out) != size:
        raise _BagError(f"decompressed {len(out)} bytes, expected {size}")
    return as_bytes_array(out)


class Ros1BagReader:
    """One ROS 1 bag file."""

    damage: ClassVar[tuple[type[Exception], ...]] = (
        _BagError,
        RuntimeError,  # (lz4.frame's, on a damaged frame)
        SerdeError,
        TypeResolutionError,
    )
    """Its libraries' errors on a damaged file (:func:`~analyzer.readers.base.damage_of`)."""

    def __init__(self, path: str | Path, *, bulk: bool = True) -> None:
        self.path = Path(path)
        try:
            size = self.path.stat().st_size
            with self.path.open("rb") as handle:
                head = handle.read(len(MAGIC))
                bag_header = _read_record(handle) if head == MAGIC else None
        except _BagError as err:
            raise ReaderError(f"{self.path}: truncated ROS 1 bag (no complete bag header)") from err
        except OSError as err:
            check_limit(err)  # (the machine's limit, not the file's)
            raise ReaderError(f"{self.path}: cannot read: {one_line(err.strerror or err)}") from err
        if size == 0:
            raise ReaderError(f"{self.path}: empty file (0 bytes)")
        if head != MAGIC:
            if head.startswith(b"#ROSBAG V"):
                version = head[9:].split(b"\n")[0].decode("ascii", "replace")
                raise ReaderError(
                    f"{self.path}: ROS bag version {version} is not supported (2.0 is)"
                )
            raise ReaderError(f"{self.path}: not a ROS 1 bag (missing '#ROSBAG V2.0' magic)")
        if bag_header is None or _op(bag_header[0]) != OP_BAG_HEADER:
            raise ReaderError(f"{self.path}: damaged ROS 1 bag (no bag header record)")
        fields = bag_header[0]
        total, sha = file_digest([self.path])
        self.info = InputInfo(self.path, Format.ROS1BAG, size_bytes=total, sha256=sha)
        self.bulk = bulk
        self._size = size
        self._connections: dict[int, _Connection] = {}
        self._chunk_infos: list[_ChunkInfo] = []
        self._index_error = ""
        try:
            index_pos = _U64.unpack(fields["index_pos"])[0]
            conn_count = _U32.unpack(fields["conn_count"])[0]
            chunk_count = _U32.unpack(fields["chunk_count"])[0]
        except (KeyError, struct.error) as err:
            raise ReaderError(f"{self.path}: damaged ROS 1 bag header ({one_line(err)})") from err
        if index_pos == 0:
            self._index_error = "bag is not indexed (recording not closed?); read sequentially"
        elif index_pos > size or (index_pos == size and (conn_count or chunk_count)):
            self._index_error = (
                "bag index lies past the end of the file (truncated?); read sequentially"
            )
        else:
            try:
                self._read_index(index_pos, conn_count, chunk_count)
            except (_BagError, struct.error, KeyError, OverflowError, MemoryError) as err:
                check_limit(err)  # (the machine's limit is not the file's damage)
                self._connections.clear()
                self._chunk_infos.clear()
                self._index_error = f"bag index damaged ({one_line(err)}); read sequentially"
        self._decoders: dict[int, RosBatchDecoder | None] = {}
        self._tracker = TopicTracker("log")
        self._log_clock = LogClock(in_file_order=False)
        self.stop_at_set_back = False
        """Whether a recorder's clock set back stops the reading, raised (an input of a
        multi-file archive: see ``Reader``), instead of said in ``info.set_back``."""
        self.topics: dict[str, str] = {}
        """The topic of every channel read (for reports per topic)."""
        self.info.absolute_time = absolute_log_time(self.start_ns, self._end_ns, self.damage)

    # ------------------------------------------------------------------ protocol
    def start_ns(self) -> int | None:
        if not self._index_error:
            starts = [c.start_ns for c in self._chunk_infos if c.connections]
            return min(starts) if starts else None
        for chunk in self._scan(errors=False):
            times = chunk[2]
            if times.size:
                return int(times.min())
        return None

    def _end_ns(self) -> int | None:
        """The last log time the chunk index gives (None without one)."""
        ends = [c.end_ns for c in self._chunk_infos if c.connections]
        return max(ends) if ends and not self._index_error else None

    def chunks(self, time: TimeSource = "log") -> Iterator[ChannelChunk]:
        self._tracker = TopicTracker(time)
        stop = self.path if self.stop_at_set_back else None
        self._log_clock = LogClock(in_file_order=True, stop=stop)
        reorder = Reorderer(repeats=True, topics=self.topics, signs=self._tracker.signs)
        if self._index_error:
            self._error(self._index_error)
            gate = LogOrder()
            for records, conns, times, offsets in self._scan(errors=True):
                self._locate_all(records, conns, times, offsets, gate)
                self._decode(gate, None, reorder)
                yield from reorder.release(None)
        else:
            self._written_order()
            self._log_clock.in_file_order = False  # (read in log-time order)
            yield from self._indexed(reorder, time)
        yield from reorder.flush()
        if self._log_clock.line:
            self.info.set_back = self._log_clock.line
            self._error(self._log_clock.line)
            self._tracker.log_set_back_ns = self._log_clock.back_ns
        for line in self._tracker.lines() + reorder.drop_report():
            self._error(line)
        self.info.relabelled = self._tracker.relabelled()
        self.info.labels = self._tracker.labels()
        types = {c.topic: c.msgtype for c in self._connections.values()}
        add_log_topics(self.info, types)
        add_topics(self.info, types, self._tracker.messages())
        add_time_fields(
            self.info,
            (
                (self._connections[c].topic, d)
                for c, d in self._decoders.items()
                if c in self._connections
            ),
        )
        self.info.sign_flips = self._tracker.signs.changed()
        self.info.clocks = self._tracker.clocks()
        self.info.clock_spans = self._tracker.clock_spans()
        self.info.clock_steps = self._tracker.clock_steps()
        self.info.log_delays = self._tracker.delays.topics

    # ------------------------------------------------------------------ index
    def _read_index(self, index_pos: int, conn_count: int, chunk_count: int) -> None:
        with self.path.open("rb") as handle:
            handle.seek(index_pos)
            for _ in range(conn_count):
                self._add_connection(self._expect(handle, OP_CONNECTION))
            for _ in range(chunk_count):
                fields, data = self._expect(handle, OP_CHUNK_INFO)
                if _U32.unpack(fields["ver"])[0] != 1:
                    raise _BagError("unsupported chunk info version")
                count = _U32.unpack(fields["count"])[0]
                self._chunk_infos.append(
                    _ChunkInfo(
                        pos=_U64.unpack(fields["chunk_pos"])[0],
                        start_ns=_time(fields["start_time"]),
                        end_ns=_time(fields["end_time"]),
                        connections=count,
                    )
                )
                if len(data) != 8 * count:
                    raise _BagError("chunk info record of the wrong size")

    @staticmethod
    def _expect(handle: BinaryIO, op: int) -> tuple[dict[str, bytes], bytes]:
        record = _read_record(handle)
        if record is None or _op(record[0]) != op:
            raise _BagError(f"expected a record with op {op}")
        return record

    def _add_connection(self, record: tuple[dict[str, bytes], bytes]) -> None:
        fields, data = record
        conn = _U32.unpack(fields["conn"])[0]
        topic = fields["topic"].decode("utf-8", "replace")
        details = _fields(data)
        self._connections[conn] = _Connection(
            conn=conn,
            topic=topic,
            msgtype=normalize_msgtype(details["type"].decode("utf-8", "replace")),
            msgdef=details.get("message_definition", b"").decode("utf-8", "replace"),
        )

    def _written_order(self) -> None:
        """Before the bag is read (in log-time order): where its chunks, in the file's
        order, may hold a topic whose log times step back by hours
        (:meth:`LogClock.may_step_back`: rare, also a bag written connection by
        connection), each chunk's index data records (each message's log time), in the
        file's order, to the :class:`LogClock` (a damaged chunk is said when read)."""
        written = sorted(self._chunk_infos, key=lambda c: c.pos)
        if not LogClock.may_step_back(
            np.array([c.start_ns for c in written], dtype=np.int64),
            np.array([c.end_ns for c in written], dtype=np.int64),
        ):
            return
        with self.path.open("rb") as handle:
            for info in written:
                try:
                    handle.seek(info.pos)
                    header_len = _U32.unpack(handle.read(4))[0]
                    handle.seek(header_len, io.SEEK_CUR)
                    handle.seek(_U32.unpack(handle.read(4))[0], io.SEEK_CUR)  # (the chunk's data)
                    for _ in range(info.connections):
                        fields, data = self._expect(handle, OP_INDEX_DATA)
                        conn = _U32.unpack(fields["conn"])[0]
                        if _U32.unpack(fields["ver"])[0] != 1 or conn not in self._connections:
                            continue
                        entries = np.frombuffer(data, dtype="<u4").reshape(-1, 3).astype(np.int64)
                        self._log_clock.messages(
                            self._connections[conn].topic,
                            entries[:, 2],
                            entries[:, 0] * 1_000_000_000 + entries[:, 1],
                        )
                except (_BagError, struct.error, KeyError, ValueError, OverflowError, MemoryError):
                    continue  # (said when the chunk is read)

    # ------------------------------------------------------------------ indexed path
    def _indexed(self, reorder: Reorderer, time: TimeSource) -> Iterator[ChannelChunk]:
        """The chunks in start-time order. After each, with ``--time header``, the
        messages logged up to the next chunk's start are decoded (:class:`LogOrder`: a
        chunk may reach past the next ones' start, and the header clock's tracker reads
        each topic in log-time order); with ``--time log`` all of its messages (the
        :class:`Reorderer` orders log times) and the samples before the next chunk
        released."""
        infos = sorted(self._chunk_infos, key=lambda c: (c.start_ns, c.pos))
        gate = LogOrder()
        with self.path.open("rb") as handle:
            for k, info in enumerate(infos):
                bound = infos[k + 1].start_ns if k + 1 < len(infos) else None
                try:
                    handle.seek(info.pos)
                    fields, data = self._expect(handle, OP_CHUNK)
                    records = _decompress(
                        fields["compression"].decode("ascii", "replace"),
                        data,
                        _U32.unpack(fields["size"])[0],
                    )
                    conns, times, offsets = [], [], []
                    for _ in range(info.connections):
                        ifields, idata = self._expect(handle, OP_INDEX_DATA)
                        count = _U32.unpack(ifields["count"])[0]
                        if _U32.unpack(ifields["ver"])[0] != 1 or len(idata) != 12 * count:
                            raise _BagError("unsupported or damaged index data record")
                        entries = (
                            np.frombuffer(idata, dtype="<u4").reshape(count, 3).astype(np.int64)
                        )
                        conns.append(
                            np.full(count, _U32.unpack(ifields["conn"])[0], dtype=np.int64)
                        )
                        times.append(entries[:, 0] * 1_000_000_000 + entries[:, 1])
                        offsets.append(entries[:, 2])
                except (_BagError, struct.error, KeyError, OverflowError, MemoryError) as err:
                    check_limit(err)  # (the machine's limit is not the file's damage)
                    self._error(f"chunk at byte {info.pos}: {one_line(err)}; skipped")
                    continue
                if conns:
                    self._locate_all(
                        records,
                        np.concatenate(conns),
                        np.concatenate(times),
                        np.concatenate(offsets),
                        gate,
                    )
                self._decode(gate, bound if time != "log" else None, reorder)
                if time == "log" and bound is not None:
                    yield from reorder.release(bound)
                elif time != "log":
                    yield from reorder.release(None)
        self._decode(gate, None, reorder)  # (held back where the last chunk was damaged)

    # ------------------------------------------------------------------ sequential scan
    def _scan(self, *, errors: bool) -> Iterator[tuple[ByteArray, IntArray, IntArray, IntArray]]:
        """Chunks read from the start of the file: (records, conn, time, offset) per chunk.

        Where the file ends inside a chunk, the complete records before the cut are
        yielded (:func:`_cut_chunk`). Message records outside any chunk (rosbag writes a
        chunk's header with sizes of 0 and completes it when the chunk closes: a
        recording killed meanwhile leaves its records loose after an empty chunk) are
        yielded as one chunk per run. With ``errors``, where and why the scan stopped is
        recorded, with how many messages were read and up to when."""
        read = _ScanCount()
        loose = bytearray()
        with self.path.open("rb") as handle:
            handle.seek(len(MAGIC))
            position = handle.tell()
            try:
                _read_record(handle)  # bag header
                while True:
                    position = handle.tell()
                    record = _read_cut_record(handle)
                    if record is None:
                        yield from read.taken(self._loose(loose))
                        if errors:
                            self._error(
                                f"file ends at byte {position} without an index section; {read}"
                            )
                        return
                    fields, data, data_len = record
                    op = _op(fields)
                    if len(data) < data_len and op != OP_CHUNK:
                        raise _BagError("truncated record")
                    if op == OP_MSG_DATA:
                        end = handle.tell()
                        handle.seek(position)
                        loose += handle.read(end - position)
                        continue
                    if op == OP_CONNECTION:
                        self._add_connection((fields, data))
                        continue
                    yield from read.taken(self._loose(loose))
                    if op == OP_CHUNK:
                        if data_len == 0:
                            continue  # (a chunk never completed: its records follow loose)
                        compression = fields["compression"].decode("ascii", "replace")
                        if len(data) < data_len:  # the file ends inside this chunk
                            records, why = _cut_chunk(
                                compression, data, _U32.unpack(fields["size"])[0], data_len
                            )
                            found = self._scan_chunk(records, cut=True)
                            yield from read.taken([(records, *found)])
                            if errors:
                                kind = (
                                    "uncompressed"
                                    if compression == "none"
                                    else f"{compression}-compressed"
                                )
                                what = why or recovered_share(
                                    int(found[1].size),
                                    int(records.size),
                                    _U32.unpack(fields["size"])[0],
                                    compressed=compression != "none",
                                )
                                self._error(
                                    f"truncated inside the {kind} chunk that starts at byte "
                                    f"{position} (the file ends at byte {handle.tell()}); "
                                    f"{what}; "
                                    f"{read.in_all()}"
                                )
                            return
                        records = _decompress(compression, data, _U32.unpack(fields["size"])[0])
                        yield from read.taken([(records, *self._scan_chunk(records))])
                    elif op == OP_CHUNK_INFO:
                        return  # the index section starts: all data was read
            except (_BagError, struct.error, KeyError, OverflowError, MemoryError) as err:
                check_limit(err)  # (the machine's limit is not the file's damage)
                yield from read.taken(self._loose(loose))
                if errors:
                    self._error(
                        f"truncated or damaged at byte {position} ({one_line(err)}); {read}"
                    )

    def _loose(self, loose: bytearray) -> list[tuple[ByteArray, IntArray, IntArray, IntArray]]:
        """The message records gathered outside any chunk, as one chunk (emptied)."""
        if not loose:
            return []
        records = as_bytes_array(bytes(loose))
        loose.clear()
        return [(records, *self._scan_chunk(records))]

    def _scan_chunk(
        self, records: ByteArray, *, cut: bool = False
    ) -> tuple[IntArray, IntArray, IntArray]:
        """(conn, time, offset) of the message data records of a chunk's ``records``,
        connection records taken in. With ``cut`` (the part of a chunk before the file
        ended), the walk stops at the first record that is not whole."""
        data = records.tobytes()
        end = len(data)
        conns: list[int] = []
        times: list[int] = []
        offsets: list[int] = []
        pos = 0
        while pos + 8 <= end:
            header_len = _U32.unpack_from(data, pos)[0]
            hdr_end = pos + 4 + header_len
            if hdr_end + 4 > end:
                if cut:
                    break
                raise _BagError(f"record at chunk offset {pos} runs past the chunk")
            data_len = _U32.unpack_from(data, hdr_end)[0]
            if cut and hdr_end + 4 + data_len > end:
                break
            fields = _fields(data[pos + 4 : hdr_end])
            op = _op(fields)
            if op == OP_CONNECTION:
                self._add_connection((fields, data[hdr_end + 4 : hdr_end + 4 + data_len]))
            elif op == OP_MSG_DATA:
                conns.append(_U32.unpack(fields["conn"])[0])
                times.append(_time(fields["time"]))
                offsets.append(pos)
            pos = hdr_end + 4 + data_len
        return (
            np.asarray(conns, dtype=np.int64),
            np.asarray(times, dtype=np.int64),
            np.asarray(offsets, dtype=np.int64),
        )

    # ------------------------------------------------------------------ decoding
    def _locate_all(
        self,
        records: ByteArray,
        conns: IntArray,
        times: IntArray,
        offsets: IntArray,
        gate: LogOrder,
    ) -> None:
        """The payloads of a chunk's messages, per connection that can be decoded, handed
        to ``gate``."""
        for conn in np.unique(conns).tolist():
            sel = np.nonzero(conns == conn)[0]
            decoder = self._decoder(int(conn))
            if decoder is None:
                continue
            topic = self._connections[int(conn)].topic
            try:
                starts, sizes = self._locate(records, offsets[sel], int(conn))
            except _BagError as err:
                self._error(f"{topic}: {one_line(err)}")
                continue
            self._log_clock.messages(topic, offsets[sel], times[sel])
            gate.push(int(conn), records, starts, sizes, times[sel])

    def _decode(self, gate: LogOrder, bound: int | None, reorder: Reorderer) -> None:
        """Decode the messages of ``gate`` logged up to ``bound`` (None: all) and
        push them, in log-time order per connection, through the tracker."""
        for conn, buf, starts, sizes, times in gate.take(bound):
            decoder = self._decoders.get(conn)
            if decoder is None:
                continue
            decoded = decoder.decode(buf, starts, sizes)
            self._tracker.push(reorder, self._connections[conn].topic, decoded, times)

    @staticmethod
    def _locate(records: ByteArray, offsets: IntArray, conn: int) -> tuple[IntArray, IntArray]:
        """Payload starts and sizes of the message data records at ``offsets``.

        The header of the first record is parsed to find where ``op`` and ``conn`` sit;
        every record is then checked against it with vectorized comparisons (writers put
        the same fields in the same order in every message record).
        """
        end = records.shape[0]
        if bool(np.any((offsets < 0) | (offsets + 8 > end))):
            raise _BagError("index offsets point outside the chunk")
        header_len = gather_uint(records, offsets, 4)
        first = int(offsets[0])
        template_len = int(header_len[0])
        header = records[first + 4 : first + 4 + template_len].tobytes()
        op_at = conn_at = -1
        pos = 0
        while pos + 4 <= len(header):
            size = _U32.unpack_from(header, pos)[0]
            name = header[pos + 4 : pos + 4 + size].partition(b"=")[0]
            value_at = pos + 4 + len(name) + 1
            if name == b"op":
                op_at = value_at
            elif name == b"conn":
                conn_at = value_at
            pos += 4 + size
        if op_at < 0 or conn_at < 0:
            raise _BagError("message record header without op or conn")
        same = header_len == template_len
        data_len_at = offsets + 4 + template_len
        ok = same & (data_len_at + 4 <= end)
        ok[ok] &= records[offsets[ok] + 4 + op_at] == OP_MSG_DATA
        ok[ok] &= gather_uint(records, offsets[ok] + 4 + conn_at, 4) == conn
        sizes = np.zeros(offsets.shape[0], dtype=np.int64)
        sizes[ok] = gather_uint(records, data_len_at[ok], 4)
        starts = data_len_at + 4
        for i in np.nonzero(~ok)[0].tolist():
            starts[i], sizes[i] = Ros1BagReader._locate_one(records, int(offsets[i]), conn)
        if bool(np.any(starts + sizes > end)):
            raise _BagError("message data runs past the chunk")
        return starts, sizes

    @staticmethod
    def _locate_one(records: ByteArray, offset: int, conn: int) -> tuple[int, int]:
        """Slow path for one index entry: skip connection records until the message."""
        end = records.shape[0]
        pos = offset
        while pos + 8 <= end:
            header_len = int(gather_uint(records, np.asarray([pos]), 4)[0])
            hdr_end = pos + 4 + header_len
            if hdr_end + 4 > end:
                break
            fields = _fields(records[pos + 4 : hdr_end].tobytes())
            data_len = int(gather_uint(records, np.asarray([hdr_end]), 4)[0])
            op = _op(fields)
            if op == OP_MSG_DATA and _U32.unpack(fields["conn"])[0] == conn:
                return hdr_end + 4, data_len
            if op != OP_CONNECTION:
                break
            pos = hdr_end + 4 + data_len
        raise _BagError(
            f"index entry at chunk offset {offset} does not point at a message of its connection"
        )

    def _decoder(self, conn: int) -> RosBatchDecoder | None:
        if conn in self._decoders:
            return self._decoders[conn]
        info = self._connections.get(conn)
        decoder: RosBatchDecoder | None = None
        if info is None:
            self._error(f"messages of connection {conn} have no connection record; skipped")
        else:
            try:
                store = store_from_definition(info.msgtype, info.msgdef, "msg")
                decoder = RosBatchDecoder([store], info.msgtype, "ros1", bulk=self.bulk)
            except TypeResolutionError as err:
                self._error(f"{info.topic}: {one_line(err)}; skipped")
        self._decoders[conn] = decoder
        return decoder

    def _error(self, line: str) -> None:
        if line not in self.info.errors:
            self.info.errors.append(line)

"""MCAP reader.

Indexed files (summary with chunk indexes, the normal case) are read chunk by chunk in
start-time order: the reader reads the Chunk record and its MessageIndex records itself,
decompresses the whole chunk (zstd, lz4 or none) into one buffer, and locates every
message of a channel with numpy from the index offsets (a Message record is opcode u8,
length u64, channel u16, sequence u32, log_time u64, publish_time u64, then the payload).
The payloads of each channel are then decoded in bulk (see :mod:`rosdecode` and
:mod:`decoders`). No Python code runs per message on this path.

Files without a usable summary (truncated, not finalized, unchunked) are streamed with
``mcap.stream_reader.StreamReader``: what is readable is read, the point where reading
stopped is recorded in ``info.errors`` (the recorder's clock set back is looked for in
the file's order, :class:`~analyzer.readers._common.LogClock`: in each chunk and each batch
of loose messages against those before). A file that ends inside a Chunk record (a power
loss mid-write) keeps that chunk's complete messages: its data is decompressed as far as
it goes (:mod:`~analyzer.readers.cut_chunk`) and its whole records read, and the error
says how many messages were kept and that the rest of the chunk is lost.

Channels whose encoding cannot be decoded (e.g. ``data_tamer``) are recorded as errors;
the other channels are still read.
"""

from __future__ import annotations

import contextlib
import io
import os
import struct
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO, ClassVar

import numpy as np
import numpy.typing as npt
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, ChunkIndex, DataEnd, Footer, Message, MessageIndex, Schema
from mcap.stream_reader import StreamReader
from rosbags.serde import SerdeError

from analyzer.errors import ReaderError, counted
from analyzer.readers import chunk_limits
from analyzer.readers._common import (
    ByteArray,
    Decoded,
    IntArray,
    LogClock,
    LogOrder,
    Reorderer,
    TopicTracker,
    absolute_log_time,
    as_bytes_array,
    concat_payloads,
    field_view,
    file_digest,
    gather_rows,
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
from analyzer.readers.rosdecode import Encoding, RosBatchDecoder
from analyzer.readers.rostypes import (
    EMPTY_MESSAGE_BYTES,
    EmptyMessageType,
    NestedTooDeep,
    TypeResolutionError,
    candidate_stores,
    msg_path_hint,
    normalize_msgtype,
    refuse_service_event,
    store_from_definition,
)
from analyzer.types import Format

if TYPE_CHECKING:  # the JSON and protobuf decoders (pyarrow) load with their first topic
    from analyzer.readers.decoders import BatchDecoder

MAGIC = b"\x89MCAP0\r\n"
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_MESSAGE_INDEX = range(1, 8)
OP_DATA_END = 0x0F
FOOTER_RECORD = 1 + 8 + 8 + 8 + 4
"""Bytes of the Footer record (opcode, length, summary start, summary offset start, crc)."""
MESSAGE_PREFIX = 1 + 8 + 2 + 4 + 8 + 8
"""Bytes of a Message record before its payload."""
LOOSE_BATCH = 20_000
"""Unchunked messages are decoded in batches of this many."""

_U64 = struct.Struct("<Q")
_U32 = struct.Struct("<I")
_U16 = struct.Struct("<H")


class _ChunkError(Exception):
    """A chunk cannot be read (bad record, unknown compression, CRC mismatch)."""


_DAMAGE = (
    _ChunkError,
    McapError,
    struct.error,
    ValueError,
    IndexError,
    OverflowError,
    MemoryError,
    OSError,
)
"""What damaged bytes raise while a chunk is parsed: recorded, the chunk skipped."""


def check_magic(path: Path, head: bytes) -> None:
    """Raise ReaderError unless ``head`` starts with the MCAP magic."""
    if head[:8] == MAGIC:
        return
    shown = " ".join(f"{b:02x}" for b in head[:8])
    hint = ""
    if head.startswith(b"\x89MCAP0") and head[6:7] != b"\r":
        hint = ", possibly mangled by a CRLF conversion"
    elif len(head) < 8 and MAGIC.startswith(head):
        raise ReaderError(
            f"{path}: truncated MCAP file ({counted(len(head), 'byte')}, no complete magic)"
        )
    raise ReaderError(f"{path}: not an MCAP file (bad magic {shown}){hint}")


class McapReader:
    """One MCAP file. ``info`` may be shared with a containing ROS 2 bag. CDR channels
    whose schema has no definition text fall back to rosbags' standard ROS 2 types;
    ``bulk=False`` forces the reference (per-message) decoders."""

    damage: ClassVar[tuple[type[Exception], ...]] = (
        McapError,
        _ChunkError,
        zstandard.ZstdError,
        RuntimeError,  # (lz4.frame's, on a damaged frame)
        SerdeError,
        TypeResolutionError,
    )
    """Its libraries' errors on a damaged file (:func:`~analyzer.readers.base.damage_of`)."""

    def __init__(
        self,
        path: str | Path,
        *,
        info: InputInfo | None = None,
        bulk: bool = True,
        tracker: TopicTracker | None = None,
    ) -> None:
        self.path = Path(path)
        self._shared_tracker = tracker
        """A ROS 2 bag's, shared by its storage files: what it notes across the files
        (a frame that changes from one file to the next) is the bag's to say."""
        try:
            size = self.path.stat().st_size
            with self.path.open("rb") as handle:
                head = handle.read(8)
        except OSError as err:
            check_limit(err)  # (the machine's limit, not the file's)
            raise ReaderError(f"{self.path}: cannot read: {one_line(err.strerror or err)}") from err
        if size == 0:
            raise ReaderError(f"{self.path}: empty file (0 bytes)")
        check_magic(self.path, head)
        own_info = info is None
        if info is None:
            total, sha = file_digest([self.path])
            info = InputInfo(self.path, Format.MCAP, size_bytes=total, sha256=sha)
        self.info = info
        self.bulk = bulk
        self._summary_error = ""
        self._size = size
        self._summary = self._read_summary(size)
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        if self._summary is not None:
            self._schemas.update(self._summary.schemas)
            self._channels.update(self._summary.channels)
        self._decoders: dict[int, tuple[str, BatchDecoder] | None] = {}
        self._tracker = TopicTracker("log")
        self._log_clock = LogClock(in_file_order=False)
        self.stop_at_set_back = False
        """Whether a recorder's clock set back stops the reading, raised (an input of a
        multi-file archive: see ``Reader``), instead of said in ``info.set_back``."""
        self.topics: dict[str, str] = {}
        """The topic of every channel read (for reports per topic)."""
        self._protobuf: Any = None  # one mcap_protobuf factory: it caches per schema
        self.fraction_read = 0.0
        """The share of the file :meth:`chunks` has got through (see ``Reader``)."""
        if own_info:  # (a ROS 2 bag's storage file: the bag decides)
            self.info.absolute_time = absolute_log_time(self.start_ns, self._end_ns, self.damage)

    # ------------------------------------------------------------------ protocol
    def start_ns(self) -> int | None:
        summary = self._summary
        if summary is not None:
            stats = summary.statistics
            if stats is not None and stats.message_count:
                return int(stats.message_start_time)
            starts = [c.message_start_time for c in summary.chunk_indexes]
            if starts:
                return int(min(starts))
        return self._scan_first_time()

    def _end_ns(self) -> int | None:
        """The last log time the summary gives (None without one)."""
        summary = self._summary
        if summary is None:
            return None
        stats = summary.statistics
        if stats is not None and stats.message_count:
            return int(stats.message_end_time)
        ends = [c.message_end_time for c in summary.chunk_indexes]
        return int(max(ends)) if ends else None

    def chunks(self, time: TimeSource = "log") -> Iterator[ChannelChunk]:
        own = self._shared_tracker is None
        self._tracker = self._shared_tracker or TopicTracker(time)
        self.fraction_read = 0.0
        reorder = Reorderer(repeats=True, topics=self.topics, signs=self._tracker.signs)
        stop = self.path if self.stop_at_set_back else None
        with self.path.open("rb") as handle:
            if self._summary is not None and self._summary.chunk_indexes:
                self._log_clock = LogClock(in_file_order=True, stop=stop)
                self._written_order(handle)
                self._log_clock.in_file_order = False  # (read in log-time order)
                yield from self._indexed(handle, reorder, time)
            else:
                self._log_clock = LogClock(in_file_order=True, stop=stop)
                if self._summary_error:
                    self._error(self._summary_error)
                yield from self._streaming(handle, reorder, time)
        if self._log_clock.line:
            self.info.set_back = self._log_clock.line
            self._error(self._log_clock.line)
            self._tracker.log_set_back_ns = self._log_clock.back_ns
        for line in self._shared_topics():
            self._error(line)
        add_log_topics(self.info, self._types())
        add_topics(self.info, self._types(), self._tracker.messages())
        add_time_fields(self.info, (e for e in self._decoders.values() if e is not None))
        for entry in self._decoders.values():
            if entry is not None and isinstance(entry[1], RosBatchDecoder) and entry[1].notice:
                self._error(f"{entry[0]}: {entry[1].notice}")
        for line in (self._tracker.lines() if own else []) + reorder.drop_report():
            self._error(line)
        if own:
            self.info.relabelled = self._tracker.relabelled()
            self.info.labels = self._tracker.labels()
            self.info.sign_flips = self._tracker.signs.changed()
            self.info.clocks = self._tracker.clocks()
            self.info.clock_spans = self._tracker.clock_spans()
            self.info.clock_steps = self._tracker.clock_steps()
            self.info.log_delays = self._tracker.delays.topics

    def _types(self) -> dict[str, str]:
        """Each topic's message type (its schema's name), where it has a schema."""
        types = {}
        for channel in self._channels.values():
            schema = self._schemas.get(channel.schema_id) if channel.schema_id else None
            if schema is not None:
                types[channel.topic] = schema.name
        return types

    def _shared_topics(self) -> list[str]:
        """One line per topic that several channels of one message type (publishers)
        wrote to: their samples are merged into one set of channels. Channels of one
        topic with different types give channels of different names (no line)."""
        channels: dict[tuple[str, str], int] = {}
        for cid, entry in self._decoders.items():
            channel = self._channels.get(cid)
            if entry is None or channel is None:
                continue
            schema = self._schemas.get(channel.schema_id) if channel.schema_id else None
            kind = schema.name if schema is not None else channel.message_encoding
            key = (channel.topic, kind)
            channels[key] = channels.get(key, 0) + 1
        return [
            f"{topic}: {count} MCAP channels (publishers) share this topic; merged"
            for (topic, _), count in channels.items()
            if count > 1
        ]

    # ------------------------------------------------------------------ summary
    def _read_summary(self, size: int) -> Any:
        with self.path.open("rb") as handle:
            handle.seek(max(size - 8, 0))
            if size < 2 * len(MAGIC) + FOOTER_RECORD or handle.read(8) != MAGIC:
                return None  # truncated or not finalized: streamed, the error is recorded then
            handle.seek(0)
            try:
                return SeekingReader(handle).get_summary()
            except (McapError, struct.error, ValueError, EOFError, OSError) as err:
                check_limit(err)  # (the machine's limit is not the file's damage)
                self._summary_error = (
                    f"summary section unreadable ({one_line(err)}); read sequentially"
                )
                return None

    def _scan_first_time(self) -> int | None:
        """First message time of an unindexed file, from the first Chunk or Message record
        (None where no record before the damage has one: a record length past the file's
        end is damage, not a seek to make)."""
        with self.path.open("rb") as handle:
            size = os.fstat(handle.fileno()).st_size
            handle.seek(8)
            while True:
                head = handle.read(9)
                if len(head) < 9:
                    return None
                opcode, length = head[0], _U64.unpack_from(head, 1)[0]
                if opcode == OP_CHUNK:
                    body = handle.read(8)
                    return _U64.unpack(body)[0] if len(body) == 8 else None
                if opcode == OP_MESSAGE:
                    body = handle.read(14)
                    return _U64.unpack_from(body, 6)[0] if len(body) == 14 else None
                if opcode in (OP_DATA_END, OP_FOOTER) or length > size - handle.tell():
                    return None
                handle.seek(length, io.SEEK_CUR)

    # ------------------------------------------------------------------ indexed path
    def _indexed(
        self, handle: BinaryIO, reorder: Reorderer, time: TimeSource
    ) -> Iterator[ChannelChunk]:
        """The chunks in start-time order. After each, with ``--time header``, the
        messages logged up to the next chunk's start are decoded (:class:`LogOrder`: a
        chunk may reach past the next ones' start, and the header clock's tracker reads
        each topic in log-time order); with ``--time log`` all of its messages (the
        :class:`Reorderer` orders log times) and the samples before the next chunk
        released."""
        indexes: list[ChunkIndex] = sorted(
            self._summary.chunk_indexes, key=lambda c: (c.message_start_time, c.chunk_start_offset)
        )
        gate = LogOrder()
        for k, index in enumerate(indexes):
            bound = indexes[k + 1].message_start_time if k + 1 < len(indexes) else None
            try:
                if index.chunk_start_offset + index.chunk_length > self._size:
                    raise _ChunkError("the chunk index points past the end of the file")
                handle.seek(index.chunk_start_offset)
                raw = handle.read(index.chunk_length)
                records = _chunk_records(memoryview(raw))
                by_channel: dict[int, IntArray] | None = None
                if index.message_index_offsets:
                    handle.seek(index.chunk_start_offset + index.chunk_length)
                    by_channel = _parse_message_indexes(handle.read(index.message_index_length))
                    if any(cid not in self._channels for cid in by_channel):
                        by_channel = None
                if by_channel is None:
                    by_channel = self._scan_chunk(records)
                self._locate_chunk(records, by_channel, gate)
            except _DAMAGE as err:
                check_limit(err)  # (the machine's limit is not the file's damage)
                self._error(f"chunk at byte {index.chunk_start_offset}: {one_line(err)}; skipped")
                continue
            finally:
                self.fraction_read = (k + 1) / len(indexes)
            self._decode_held(gate, bound if time != "log" else None, reorder)
            if time == "log" and bound is not None:
                yield from reorder.release(bound)
            elif time != "log":
                yield from reorder.release(None)
        self._decode_held(gate, None, reorder)  # (held back where the last chunk was damaged)
        yield from reorder.flush()

    def _written_order(self, handle: BinaryIO) -> None:
        """Before an indexed file is read (in log-time order): where its chunks, in the
        file's order, may hold a topic whose log times step back by hours
        (:meth:`LogClock.may_step_back`: rare, also a file written topic by topic), each
        chunk's message indexes, in the file's order, to the :class:`LogClock` (a chunk
        without them, or damaged, is checked inside itself when read)."""
        assert self._summary is not None
        written = sorted(self._summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
        if not LogClock.may_step_back(
            np.array([c.message_start_time for c in written], dtype=np.uint64).astype(np.int64),
            np.array([c.message_end_time for c in written], dtype=np.uint64).astype(np.int64),
        ):
            return
        for index in written:
            if not index.message_index_offsets or index.message_index_length <= 0:
                continue
            try:
                handle.seek(index.chunk_start_offset + index.chunk_length)
                pairs = _message_index_pairs(handle.read(index.message_index_length))
            except _DAMAGE as err:
                check_limit(err)  # (the machine's limit is not the file's damage)
                continue  # (said when the chunk is read)
            for cid, entries in pairs.items():
                channel = self._channels.get(cid)
                if channel is not None:
                    self._log_clock.messages(
                        channel.topic,
                        entries[1::2].astype(np.int64),
                        entries[0::2].astype(np.int64),
                    )

    # ------------------------------------------------------------------ streaming path
    def _streaming(
        self, handle: BinaryIO, reorder: Reorderer, time: TimeSource
    ) -> Iterator[ChannelChunk]:
        handle.seek(0)
        reader = StreamReader(handle, emit_chunks=True)
        pending: tuple[Chunk, list[MessageIndex]] | None = None
        loose: list[tuple[int, int, bytes]] = []
        finished = False
        count = 0
        damage: str | None = None
        at = [0]  # where the record being read starts
        try:
            for record in _positioned(handle, reader.records, at):
                if isinstance(record, MessageIndex) and pending is not None:
                    pending[1].append(record)
                    continue
                if pending is not None:
                    count += self._stream_chunk(*pending, reorder, time)
                    pending = None
                    self.fraction_read = max(self.fraction_read, handle.tell() / self._size)
                    nxt = record.message_start_time if isinstance(record, Chunk) else None
                    yield from reorder.release(nxt if time == "log" else None)
                if isinstance(record, Schema):
                    self._schemas[record.id] = record
                elif isinstance(record, Channel):
                    self._channels[record.id] = record
                elif isinstance(record, Chunk):
                    pending = (record, [])
                elif isinstance(record, Message):
                    loose.append((record.channel_id, record.log_time, record.data))
                    if len(loose) >= LOOSE_BATCH:
                        count += self._decode_loose(loose, reorder, time)
                        loose = []
                        yield from reorder.release(None)
                elif isinstance(record, DataEnd | Footer):
                    finished = True
                    break
        except (
            McapError,
            struct.error,
            ValueError,
            EOFError,
            OSError,
            OverflowError,
            MemoryError,
        ) as err:
            eof = isinstance(err, EndOfFile)
            reason = "unexpected end of file" if eof else one_line(err)
            damage = f"truncated or damaged at byte {handle.tell()} ({reason})"
            finished = True
        if pending is not None:
            # cut among the chunk's MessageIndex records, it may hold only some of them:
            # the chunk's own records say which messages it has (read once, one chunk)
            indexes = pending[1] if damage is None else []
            count += self._stream_chunk(pending[0], indexes, reorder, time)
        if loose:
            count += self._decode_loose(loose, reorder, time)
        cut = self._cut_chunk(handle, at[0], reorder) if damage is not None else None
        if cut is not None:
            count += cut[0]
            self._error(f"{cut[1]}; {count} message(s) read in all")
        elif damage is not None:  # counted once what was read before the damage is decoded
            before = (
                "the message before it was"
                if count == 1
                else f"the {count} messages before it were"
            )
            self._error(f"{damage}; {before} read")
        if not finished:
            self._error("truncated: the file ends without a DataEnd/Footer record")
        elif damage is None and not self._ends_with_magic(handle):
            self._error(
                "the file ends without its closing magic (its summary or footer is missing "
                "or cut short); every message of its data section was read"
            )
        yield from reorder.flush()

    def _ends_with_magic(self, handle: BinaryIO) -> bool:
        handle.seek(max(self._size - len(MAGIC), 0))
        return handle.read(len(MAGIC)) == MAGIC

    def _stream_chunk(
        self, chunk: Chunk, indexes: list[MessageIndex], reorder: Reorderer, time: TimeSource
    ) -> int:
        try:
            records = _decompress(
                chunk.compression, chunk.data, chunk.uncompressed_size, chunk.uncompressed_crc
            )
            by_channel: dict[int, IntArray] | None = None
            if indexes and all(ix.channel_id in self._channels for ix in indexes):
                by_channel = {
                    ix.channel_id: np.asarray([o for _, o in ix.records], dtype=np.uint64).astype(
                        np.int64
                    )
                    for ix in indexes
                }
            if by_channel is None:
                by_channel = self._scan_chunk(records)
            gate = LogOrder()
            self._locate_chunk(records, by_channel, gate)
            self._decode_held(gate, None, reorder)
        except _DAMAGE as err:
            check_limit(err)  # (the machine's limit is not the file's damage)
            self._error(f"chunk starting at t={chunk.message_start_time}: {one_line(err)}; skipped")
            return 0
        return int(sum(v.size for v in by_channel.values()))

    def _cut_chunk(
        self, handle: BinaryIO, start: int, reorder: Reorderer
    ) -> tuple[int, str] | None:
        """The complete messages of a Chunk record at ``start`` that the file ends
        inside (a power loss mid-write), decoded, and what the error says of it: the
        chunk is decompressed as far as its data goes (:func:`cut_prefix`) and its whole
        records are read. None where no chunk is cut there (the damage is elsewhere)."""
        handle.seek(start)
        raw = handle.read()
        head = 9 + 8 + 8 + 8 + 4 + 4
        if len(raw) < head or raw[0] != OP_CHUNK or 9 + _U64.unpack_from(raw, 1)[0] <= len(raw):
            return None
        size = _U64.unpack_from(raw, 9 + 16)[0]
        comp_len = _U32.unpack_from(raw, 9 + 28)[0]
        compression = raw[head : head + comp_len].decode("utf-8", "replace")
        data_at = head + comp_len + 8
        if data_at > len(raw):
            return None  # cut before its data starts: nothing of it can be had
        chunk_limits.check_chunk(size, _U64.unpack_from(raw, data_at - 8)[0], compression)
        kind = f"{compression}-compressed" if compression else "uncompressed"
        where = (
            f"truncated inside the {kind} chunk that starts at byte {start} (the file ends at byte "
        )
        where += f"{self._size})"
        try:
            records = as_bytes_array(cut_prefix(compression, raw[data_at:], size)[:size])
        except CutDataError as err:
            return 0, f"{where}; {one_line(err)}, so none of its messages can be recovered"
        if not records.size:
            what = (
                f"its {kind} data holds no complete block before the cut"
                if compression
                else "none of its data is in the file"
            )
            return 0, f"{where}; {what}, so none of its messages can be recovered"
        try:
            by_channel = self._scan_chunk(records, cut=True)
            gate = LogOrder()
            self._locate_chunk(records, by_channel, gate)
            self._decode_held(gate, None, reorder)
        except _DAMAGE as err:
            check_limit(err)  # (the machine's limit is not the file's damage)
            return 0, f"{where}; its records are damaged ({one_line(err)}); skipped"
        found = int(sum(v.size for v in by_channel.values()))
        got = int(records.size)
        return found, f"{where}; {recovered_share(found, got, size, compressed=bool(compression))}"

    def _decode_loose(
        self, loose: list[tuple[int, int, bytes]], reorder: Reorderer, time: TimeSource
    ) -> int:
        channel_ids = np.fromiter((m[0] for m in loose), dtype=np.int64, count=len(loose))
        log_u = np.fromiter((m[1] for m in loose), dtype=np.uint64, count=len(loose))
        log_ns = log_u.astype(np.int64)
        buf, starts, sizes = concat_payloads([m[2] for m in loose])
        for cid in np.unique(channel_ids).tolist():
            sel = np.nonzero(channel_ids == cid)[0]
            entry = self._decoder(int(cid), int(sizes[sel].max(initial=0)))
            if entry is not None:  # (the batch in the file's order: a chunk's messages)
                self._log_clock.messages(entry[0], sel, log_ns[sel])
            self._decode_channel(int(cid), buf, starts[sel], sizes[sel], log_ns[sel], reorder)
        return len(loose)

    # ------------------------------------------------------------------ chunk contents
    def _scan_chunk(self, records: ByteArray, *, cut: bool = False) -> dict[int, IntArray]:
        """Message offsets per channel of a chunk without usable MessageIndex records;
        registers the Schema and Channel records found inside. With ``cut`` (the part
        of a chunk before the file ended), the walk stops at the first record that is
        not whole."""
        data = records.tobytes()
        end = len(data)
        offsets: dict[int, list[int]] = {}
        pos = 0
        while pos + 9 <= end:
            opcode = data[pos]
            length = _U64.unpack_from(data, pos + 1)[0]
            body = pos + 9
            if body + length > end:
                if cut:
                    break
                raise _ChunkError(f"record at offset {pos} runs past the end of the chunk")
            if opcode == OP_MESSAGE:
                offsets.setdefault(_U16.unpack_from(data, body)[0], []).append(pos)
            elif opcode in (OP_SCHEMA, OP_CHANNEL):
                stream = ReadDataStream(io.BytesIO(data[body : body + length]))
                if opcode == OP_SCHEMA:
                    schema = Schema.read(stream)
                    self._schemas[schema.id] = schema
                else:
                    channel = Channel.read(stream)
                    self._channels[channel.id] = channel
            pos = body + length
        return {cid: np.asarray(offs, dtype=np.int64) for cid, offs in offsets.items()}

    def _locate_chunk(
        self, records: ByteArray, by_channel: dict[int, IntArray], gate: LogOrder
    ) -> None:
        """The payloads and log times of a chunk's messages, per channel that can be
        decoded, handed to ``gate``."""
        end = records.shape[0]
        for cid, offsets in by_channel.items():
            if offsets.size == 0:
                continue
            inside = (offsets >= 0) & (offsets + MESSAGE_PREFIX <= end)
            offs = offsets if bool(inside.all()) else offsets[inside]
            heads = gather_rows(records, offs, MESSAGE_PREFIX)
            length = field_view(heads, 1, "<u8").astype(np.int64)
            ok = (heads[:, 0] == OP_MESSAGE) & (field_view(heads, 9, "<u2") == cid)
            ok &= (length >= MESSAGE_PREFIX - 9) & (offs + 9 + length <= end)
            log_ns = field_view(heads, 15, "<u8").astype(np.int64)
            if not bool(ok.all()) or offs.size != offsets.size:
                bad = int(offsets.size - np.count_nonzero(ok))
                self._error(f"channel {cid}: {bad} message index entries do not point at messages")
                offs, length, log_ns = offs[ok], length[ok], log_ns[ok]
            sizes = length - (MESSAGE_PREFIX - 9)
            entry = self._decoder(cid, int(sizes.max(initial=0)))
            if entry is not None:
                self._log_clock.messages(entry[0], offs, log_ns)
                gate.push(cid, records, offs + MESSAGE_PREFIX, sizes, log_ns)

    def _decode_held(self, gate: LogOrder, bound: int | None, reorder: Reorderer) -> None:
        """Decode the messages of ``gate`` logged up to ``bound`` (None: all) and push
        them, in log-time order per channel, through the tracker."""
        for cid, buf, starts, sizes, log_ns in gate.take(bound):
            self._decode_channel(cid, buf, starts, sizes, log_ns, reorder)

    def _decode_channel(
        self,
        cid: int,
        buf: ByteArray,
        starts: IntArray,
        sizes: IntArray,
        log_ns: IntArray,
        reorder: Reorderer,
    ) -> None:
        entry = self._decoder(cid, int(sizes.max(initial=0)))
        if entry is None:
            return
        topic, decoder = entry
        decoded: Decoded = decoder.decode(buf, starts, sizes)
        self._tracker.push(reorder, topic, decoded, log_ns)

    # ------------------------------------------------------------------ decoders
    def _decoder(self, cid: int, largest: int) -> tuple[str, BatchDecoder] | None:
        """The channel's topic and decoder, made for its first batch of messages (the
        largest ``largest`` bytes long), or None: no channel (reported where wrong)."""
        if cid in self._decoders:
            return self._decoders[cid]
        channel = self._channels.get(cid)
        entry: tuple[str, BatchDecoder] | None = None
        if channel is None:
            self._error(f"messages of channel id {cid} have no Channel record; skipped")
        else:
            schema = self._schemas.get(channel.schema_id) if channel.schema_id else None
            try:
                entry = (channel.topic, self._make_decoder(channel, schema, largest))
            except EmptyMessageType:
                pass  # no field, no channel: nothing is wrong
            except TypeResolutionError as err:
                if not any(e.startswith(f"{channel.topic}: ") for e in self.info.errors):
                    self._error(f"{channel.topic}: {one_line(err)}; skipped")
        self._decoders[cid] = entry
        return entry

    def _make_decoder(self, channel: Channel, schema: Schema | None, largest: int) -> BatchDecoder:
        encoding = channel.message_encoding
        if encoding in ("cdr", "ros1"):
            return self._ros_decoder(channel, schema, largest)
        if encoding == "json":
            from analyzer.readers.decoders import JsonBatchDecoder

            return JsonBatchDecoder(bulk=self.bulk)
        if encoding == "protobuf":
            if schema is None or schema.encoding != "protobuf" or not schema.data:
                raise TypeResolutionError("protobuf messages without a protobuf schema")
            if self._protobuf is None:
                from mcap_protobuf.decoder import DecoderFactory as ProtobufFactory

                self._protobuf = ProtobufFactory()
            try:
                decode = self._protobuf.decoder_for("protobuf", schema)
            except Exception as err:  # noqa: BLE001 - protobuf raises several types
                raise TypeResolutionError(f"cannot load protobuf schema: {one_line(err)}") from err
            if decode is None:
                raise TypeResolutionError("cannot load the protobuf schema")
            from google.protobuf.message import DecodeError

            from analyzer.readers.decoders import ObjectDecoder

            return ObjectDecoder(decode, (DecodeError,))
        raise TypeResolutionError(f"unsupported message encoding {encoding!r}")

    def _ros_decoder(self, channel: Channel, schema: Schema | None, largest: int) -> BatchDecoder:
        wire: Encoding = "cdr" if channel.message_encoding == "cdr" else "ros1"
        expected = ("ros2msg", "ros2idl") if wire == "cdr" else ("ros1msg",)
        if schema is None:
            raise TypeResolutionError(f"{wire} messages without a schema: unknown message type")
        msgtype = normalize_msgtype(schema.name)
        if wire == "cdr":
            refuse_service_event(msgtype)
        if schema.data and schema.encoding in expected:
            fmt = "idl" if schema.encoding == "ros2idl" else "msg"
            try:
                store = store_from_definition(msgtype, schema.data.decode(), fmt)
            except NestedTooDeep:  # (mcap_ros2's decoder would recurse as deep)
                raise
            except (TypeResolutionError, UnicodeDecodeError) as err:
                if schema.encoding != "ros2msg":
                    raise TypeResolutionError(one_line(err)) from err
                return _mcap_ros2_fallback(schema, err)
            fallback = (lambda: candidate_stores(msgtype)) if wire == "cdr" else None
            return RosBatchDecoder([store], msgtype, wire, bulk=self.bulk, fallback=fallback)
        if schema.encoding not in expected and schema.encoding and not _no_definition(schema):
            raise TypeResolutionError(
                f"schema encoding {schema.encoding!r} is not a ROS message definition "
                f"(expected {' or '.join(expected)})"
            )
        stores = candidate_stores(msgtype) if wire == "cdr" else []
        if not stores:
            # a definition, and it is empty: a type without fields (a marker topic), or
            # a recorder that did not find the type's definition (rosbag2 then writes an
            # empty one); the messages tell which
            if schema.encoding in expected and largest <= EMPTY_MESSAGE_BYTES[wire]:
                raise EmptyMessageType(msgtype)
            if schema.encoding in expected:
                raise TypeResolutionError(
                    f"message type {msgtype!r} has an empty definition in the file but "
                    f"{largest}-byte messages: unknown without definitions "
                    f"({msg_path_hint(msgtype)})"
                )
            raise TypeResolutionError(
                f"unknown message type {msgtype!r} without definitions ({msg_path_hint(msgtype)})"
            )
        return RosBatchDecoder(stores, msgtype, wire, bulk=self.bulk)

    def _error(self, line: str) -> None:
        if line not in self.info.errors:
            self.info.errors.append(line)


UNKNOWN_ENCODING = "unknown"
"""The schema encoding rosbag2 (Iron on) gives a type whose definition it did not find
where it recorded (``rosbag2_storage::MessageDefinition::empty_message_definition_for``),
with no text: a type without definitions, as a schema of encoding ``""``."""


def _no_definition(schema: Schema) -> bool:
    """Whether ``schema`` is rosbag2's mark of a definition not found (encoding
    :data:`UNKNOWN_ENCODING`, no text): decoded from ``--msg-path`` or a standard
    typestore, or its topic skipped with the ``--msg-path`` hint, not refused as a
    schema of another kind."""
    return schema.encoding == UNKNOWN_ENCODING and not schema.data


def _mcap_ros2_fallback(schema: Schema, cause: BaseException) -> BatchDecoder:
    """``mcap_ros2``'s dynamic decoder, for ros2msg schemas rosbags cannot parse."""
    from mcap_ros2.decoder import DecoderFactory as Ros2Factory

    try:
        sink = io.StringIO()
        with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):  # it prints
            decode = Ros2Factory().decoder_for("cdr", schema)
    except Exception as err:  # noqa: BLE001
        raise TypeResolutionError(f"{one_line(cause)}; mcap_ros2: {one_line(err)}") from err
    if decode is None:
        raise TypeResolutionError(one_line(cause))
    from analyzer.readers.decoders import ObjectDecoder

    return ObjectDecoder(decode)


# ---------------------------------------------------------------------- record parsing


def _positioned(handle: BinaryIO, records: Iterator[Any], at: list[int]) -> Iterator[Any]:
    """``records`` (a :class:`StreamReader`'s, reading ``handle`` without a buffer of its
    own), with ``at[0]`` set, before each is read, to where it starts: where the stream
    stops, the record it was reading."""
    while True:
        at[0] = handle.tell()
        try:
            record = next(records)
        except StopIteration:
            return
        yield record


def _chunk_records(raw: memoryview) -> ByteArray:
    """Decompressed records of a Chunk record (``raw`` starts at its opcode)."""
    if len(raw) < 9 + 8 + 8 + 8 + 4 + 4 or raw[0] != OP_CHUNK:
        raise _ChunkError("no Chunk record at the indexed offset")
    pos = 9
    uncompressed_size = _U64.unpack_from(raw, pos + 16)[0]
    crc = _U32.unpack_from(raw, pos + 24)[0]
    comp_len = _U32.unpack_from(raw, pos + 28)[0]
    pos += 32
    compression = bytes(raw[pos : pos + comp_len]).decode("utf-8", "replace")
    pos += comp_len
    if pos + 8 > len(raw):
        raise _ChunkError("Chunk record truncated")
    data_len = _U64.unpack_from(raw, pos)[0]
    pos += 8
    if pos + data_len > len(raw):
        raise _ChunkError("Chunk record truncated")
    return _decompress(compression, raw[pos : pos + data_len], uncompressed_size, crc)


def _decompress(compression: str, data: bytes | memoryview, size: int, crc: int) -> ByteArray:
    if compression not in ("zstd", "lz4", ""):
        raise _ChunkError(f"unsupported chunk compression {compression!r}")
    try:
        # (at most size + 1 bytes; a size beyond the limits refuses the file)
        out = chunk_limits.decompress(compression, data, size)
    except (zstandard.ZstdError, RuntimeError) as err:
        raise _ChunkError(f"cannot decompress ({compression}): {one_line(err)}") from err
    if len(out) > size:  # (stopped at size + 1 bytes)
        raise _ChunkError(f"its data decompresses to more than the {size} bytes it declares")
    if len(out) != size:
        raise _ChunkError(f"decompressed {len(out)} bytes, expected {size}")
    if crc and zlib.crc32(out) != crc:
        raise _ChunkError("CRC mismatch (corrupted chunk)")
    return as_bytes_array(out)


def _parse_message_indexes(data: bytes) -> dict[int, IntArray]:
    """MessageIndex records (one per channel) -> message offsets per channel."""
    return {cid: pairs[1::2].astype(np.int64) for cid, pairs in _message_index_pairs(data).items()}


def _message_index_pairs(data: bytes) -> dict[int, npt.NDArray[np.uint64]]:
    """MessageIndex records (one per channel) -> their (log time, offset) pairs per
    channel, flat."""
    out: dict[int, npt.NDArray[np.uint64]] = {}
    pos = 0
    end = len(data)
    while pos + 9 <= end:
        opcode = data[pos]
        length = _U64.unpack_from(data, pos + 1)[0]
        if opcode == OP_MESSAGE_INDEX and pos + 9 + 6 <= end:
            cid = _U16.unpack_from(data, pos + 9)[0]
            nbytes = _U32.unpack_from(data, pos + 11)[0]
            if pos + 15 + nbytes > end or nbytes % 16:
                raise _ChunkError("MessageIndex record truncated")
            pairs = np.frombuffer(data, dtype="<u8", count=nbytes // 8, offset=pos + 15)
            out[cid] = pairs
        pos += 9 + length
    return out

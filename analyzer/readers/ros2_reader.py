"""ROS 2 bag reader (rosbag2 directory with ``metadata.yaml``, or a bare ``.db3`` file).

rosbags opens the bag: metadata, split files, topics, embedded message definitions
(sqlite3 ``message_definitions`` table or MCAP schemas). Bags that embed no definitions
(rosbag2 before Iron) fall back to rosbags' standard typestores, newest first.

The data is then read in bulk:

* sqlite3 storage: ``SELECT topic_id, timestamp, data ... ORDER BY timestamp`` fetched a
  few ten thousand rows at a time; the payloads are joined into one buffer in C
  (``b"".join``) and decoded per topic by :class:`~analyzer.readers.rosdecode.RosBatchDecoder`
  (before, where they may, the rows' log times in the order written, to find the
  recorder's clock set back: :class:`~analyzer.readers._common.LogClock`);
* MCAP storage: every storage file is read by :class:`~analyzer.readers.mcap_reader.McapReader`
  (numpy chunk parsing);
* per-message compressed bags: rosbags' own message iterator, decoded in batches.

A bag none of whose topics can be decoded (unsupported serialization format, unknown
message type without definitions) raises :class:`ReaderError`; otherwise the undecodable
topics are recorded in ``info.errors``.
"""

from __future__ import annotations

import re
import sqlite3
import threading
from collections.abc import Iterator
from contextlib import closing, contextmanager
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from rosbags.interfaces import MessageDefinition, MessageDefinitionFormat
from rosbags.rosbag2 import Reader as BagReader
from rosbags.rosbag2 import ReaderError as BagReaderError
from rosbags.rosbag2 import storage_mcap

from analyzer.errors import ReaderError
from analyzer.readers._common import (  # noqa: F401 - bag_files re-exported
    LOG_SET_BACK_NS,
    LogClock,
    Reorderer,
    TopicTracker,
    absolute_log_time,
    bag_files,
    bag_listed_files,
    concat_payloads,
    file_digest,
    lfs_pointer,
    monotonic,
    one_line,
    per_topic,
    special_kind,
)
from analyzer.readers.base import (
    ChannelChunk,
    InputInfo,
    TimeSource,
    add_log_topics,
    add_time_fields,
    add_topics,
)
from analyzer.readers.mcap_reader import McapReader
from analyzer.readers.rosdecode import RosBatchDecoder
from analyzer.readers.rostypes import (
    EmptyMessageType,
    TypeResolutionError,
    candidate_stores,
    msg_path_hint,
    normalize_msgtype,
    refuse_service_event,
    store_from_definition,
)
from analyzer.types import Format

try:  # rosbags reads sqlite3 storage through apsw (0.11 on)
    import apsw
except ImportError:  # pragma: no cover - an older rosbags: the standard library's sqlite3
    apsw = None  # type: ignore[assignment]

SQL_BATCH = 50_000
"""Rows fetched from a sqlite3 storage file per batch."""

STORAGE_SUFFIXES = (".db3", ".mcap", ".db3.zstd", ".mcap.zstd")
"""Names of the storage files of a bag folder (``.zstd``: rosbag2's file compression)."""


class Ros2BagReader:
    """One ROS 2 bag."""

    damage: ClassVar[tuple[type[Exception], ...]] = (
        BagReaderError,
        sqlite3.Error,
        *((apsw.Error,) if apsw is not None else ()),
        *McapReader.damage,  # (MCAP storage files)
    )
    """Its libraries' errors on a damaged bag (:func:`~analyzer.readers.base.damage_of`)."""

    def __init__(self, path: str | Path, *, bulk: bool = True) -> None:
        self.path = Path(path)
        self.bulk = bulk
        if self.path.is_file() and self.path.stat().st_size == 0:
            raise ReaderError(f"{self.path}: empty file (0 bytes)")
        listed = bag_listed_files(self.path) if self.path.is_dir() else None
        for name in listed or ():
            # rosbags would open it: a FIFO blocks until a writer comes, forever
            if (kind := special_kind(self.path / name)) is not None:
                raise ReaderError(f"{self.path}: {name}: not a regular file ({kind}): not read")
        for member in bag_files(self.path):
            if pointer := lfs_pointer(member):
                raise ReaderError(pointer)
        try:
            with _open_bag(self.path) as bag:
                connections = list(bag.connections)
                self._start = bag.start_time if bag.message_count else None
                self._end = bag.end_time if bag.message_count else None
                self._message_compressed = bag.compression_mode == "message"
        except ReaderError:
            raise
        except Exception as err:  # rosbags raises several error types
            raise ReaderError(f"{self.path}: {_bag_error(err)}") from err
        self._decoders: dict[tuple[str, str], RosBatchDecoder | None] = {}
        problems: list[str] = []
        for conn in connections:
            key = (conn.topic, conn.msgtype)
            if key in self._decoders:
                continue
            try:
                self._decoders[key] = self._make_decoder(conn)
            except EmptyMessageType:
                self._decoders[key] = None  # no field, no channel: nothing is wrong
            except TypeResolutionError as err:
                self._decoders[key] = None
                if conn.msgcount:
                    problems.append(f"{conn.topic}: {one_line(err)}")
        decodable = [c for c in connections if self._decoders[(c.topic, c.msgtype)] is not None]
        if problems and not any(c.msgcount for c in decodable):
            raise ReaderError(f"{self.path}: {problems[0]}")
        total, sha = file_digest(bag_files(self.path))
        self.info = InputInfo(self.path, Format.ROS2BAG, size_bytes=total, sha256=sha)
        self.info.absolute_time = absolute_log_time(self.start_ns, lambda: self._end, self.damage)
        for line in problems:
            self._error(f"{line}; skipped")
        for line in _unlisted(self.path, listed):
            self._error(line)
        self._tracker = TopicTracker("log")
        self._log_clock = LogClock(in_file_order=True)
        self.stop_at_set_back = False
        """Whether a recorder's clock set back stops the reading, raised (an input of a
        multi-file archive: see ``Reader``), instead of said in ``info.set_back``; passed
        to its MCAP storage files' readers."""
        self.topics: dict[str, str] = {}
        """The topic of every channel read (for reports per topic)."""

    # ------------------------------------------------------------------ protocol
    def start_ns(self) -> int | None:
        return self._start

    def chunks(self, time: TimeSource = "log") -> Iterator[ChannelChunk]:
        """The storage files are read one after the other in the time order of their
        data (not in the order metadata.yaml lists them); a later file's samples at or
        before the last one read of their channel (split files that overlap) are
        dropped, counted per topic and file."""
        self._tracker = TopicTracker(time)
        self._log_clock = LogClock(in_file_order=True)
        last: dict[str, int] = {}
        with _open_bag(self.path) as bag:
            storages = _storages(bag)
            if storages is not None and len(storages) > 1:
                storages = _in_time_order(bag, storages)
            if self._message_compressed or storages is None:
                dropped: dict[str, int] = {}
                yield from monotonic(self._generic(bag, time), last, dropped, strict=True)
                self._overlap(self.path.name, dropped)
            else:
                for storage in storages:
                    storage_path = Path(storage.path)
                    dropped = {}
                    if storage_path.suffix == ".mcap":
                        try:
                            reader = McapReader(
                                storage_path, info=self.info, bulk=self.bulk, tracker=self._tracker
                            )
                        except ReaderError as err:
                            self._error(f"{storage_path.name}: {one_line(err)}; skipped")
                            continue
                        reader.topics = self.topics
                        reader.stop_at_set_back = self.stop_at_set_back
                        source = reader.chunks(time)
                    else:
                        label = storage_path.name if len(storages) > 1 else ""
                        source = self._sqlite(storage, time, label)
                    yield from monotonic(source, last, dropped, strict=True)
                    self._overlap(storage_path.name, dropped)
        if self._log_clock.line:
            self.info.set_back = self._log_clock.line
            self._error(self._log_clock.line)
        for (topic, _), decoder in self._decoders.items():
            if decoder is not None and decoder.notice:
                self._error(f"{topic}: {decoder.notice}")
        for line in self._tracker.lines():
            self._error(line)
        self.info.relabelled = self._tracker.relabelled()
        self.info.labels = self._tracker.labels()
        add_log_topics(self.info, dict(self._decoders.keys()))
        add_topics(self.info, dict(self._decoders.keys()), self._tracker.messages())
        add_time_fields(self.info, ((t, d) for (t, _), d in self._decoders.items()))
        self.info.sign_flips = self._tracker.signs.changed()
        self.info.clocks = self._tracker.clocks()
        self.info.clock_spans = self._tracker.clock_spans()
        self.info.clock_steps = self._tracker.clock_steps()
        self.info.log_delays = self._tracker.delays.topics

    def _overlap(self, name: str, dropped: dict[str, int]) -> None:
        for topic, unit, count in per_topic(dropped, self.topics):
            self._error(
                f"{name}: {topic}: {count} {unit} overlap an earlier split file of the bag "
                "in time; dropped"
            )

    # ------------------------------------------------------------------ types
    def _make_decoder(self, conn: Any) -> RosBatchDecoder:
        serialization = getattr(conn.ext, "serialization_format", "cdr")
        if serialization != "cdr":
            raise TypeResolutionError(
                f"unsupported serialization_format {serialization!r} (only cdr)"
            )
        msgtype = normalize_msgtype(conn.msgtype)
        refuse_service_event(msgtype)
        fmt = conn.msgdef.format
        if fmt in (MessageDefinitionFormat.MSG, MessageDefinitionFormat.IDL) and conn.msgdef.data:
            kind = "idl" if fmt == MessageDefinitionFormat.IDL else "msg"
            stores = [store_from_definition(msgtype, conn.msgdef.data, kind)]
            return RosBatchDecoder(
                stores, msgtype, "cdr", bulk=self.bulk, fallback=lambda: candidate_stores(msgtype)
            )
        else:
            stores = candidate_stores(msgtype)
            if not stores:
                if fmt in (MessageDefinitionFormat.MSG, MessageDefinitionFormat.IDL):
                    raise EmptyMessageType(msgtype)  # a definition, and it is empty
                raise TypeResolutionError(
                    f"unknown message type {msgtype!r} without definitions "
                    f"({msg_path_hint(msgtype)})"
                )
        return RosBatchDecoder(stores, msgtype, "cdr", bulk=self.bulk)

    # ------------------------------------------------------------------ sqlite3
    def _sqlite(self, storage: Any, time: TimeSource, label: str = "") -> Iterator[ChannelChunk]:
        topics = {c.id: (c.topic, c.msgtype) for c in storage.connections}
        reorder = Reorderer(repeats=True, topics=self.topics, signs=self._tracker.signs)
        uri = Path(storage.path).resolve().as_uri() + "?immutable=1"
        try:
            with closing(sqlite3.connect(uri, uri=True)) as db:
                self._written_order(db, topics, label)
                cursor = db.execute(
                    "SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id"
                )
                while rows := cursor.fetchmany(SQL_BATCH):
                    ids_raw, times_raw, payloads = zip(*rows, strict=True)
                    ids = np.asarray(ids_raw, dtype=np.int64)
                    times = np.asarray(times_raw, dtype=np.int64)
                    buf, starts, sizes = concat_payloads(payloads)
                    for tid in np.unique(ids).tolist():
                        key = topics.get(int(tid))
                        decoder = self._decoders.get(key) if key else None
                        if decoder is None or key is None:
                            continue
                        sel = np.nonzero(ids == tid)[0]
                        decoded = decoder.decode(buf, starts[sel], sizes[sel])
                        self._tracker.push(reorder, key[0], decoded, times[sel])
                    yield from reorder.release(int(times[-1]) if time == "log" else None)
        except sqlite3.Error as err:
            self._error(
                f"{Path(storage.path).name}: sqlite error ({one_line(err)}); "
                "the rows before it were read"
            )
        yield from reorder.flush()
        for line in reorder.drop_report():
            self._error(f"{label}: {line}" if label else line)

    def _written_order(
        self, db: sqlite3.Connection, topics: dict[int, tuple[str, str]], label: str
    ) -> None:
        """Before a sqlite3 storage file is read (in log-time order): where its rows may
        hold a topic whose log times step back by hours (:meth:`_may_step_back`: rare),
        their log times in the order written (``id``: the recorder's inserts), a block of
        rows at a time, per topic to a :class:`LogClock` of its own (the files of a split
        bag are read in the order of their first times, not written). A set back found is
        said for the bag (``label``: the file of a split bag), or raised naming it with
        ``stop_at_set_back``; the header clock's tracker told its size before the
        messages reach it (:meth:`TopicTracker._explained`)."""
        stop = self.path if self.stop_at_set_back else None
        clock = LogClock(in_file_order=True, stop=stop)
        try:
            if self._log_clock.line or not _may_step_back(db):
                return
            cursor = db.execute("SELECT topic_id, timestamp FROM messages ORDER BY id")
            while not clock.line and (rows := cursor.fetchmany(SQL_BATCH)):
                ids_raw, times_raw = zip(*rows, strict=True)
                ids = np.asarray(ids_raw, dtype=np.int64)
                times = np.asarray(times_raw, dtype=np.int64)
                for tid in np.unique(ids).tolist():
                    key = topics.get(int(tid))
                    if key is not None:
                        sel = np.nonzero(ids == tid)[0]
                        where = f"{label}: {key[0]}" if label else key[0]
                        clock.messages(where, sel, times[sel])
        except sqlite3.Error:
            return  # (a damaged file: the read says where, the rows before it read)
        if clock.line:
            self._log_clock = clock
            self._tracker.log_set_back_ns = clock.back_ns

    # ------------------------------------------------------------------ fallback
    def _generic(self, bag: Any, time: TimeSource) -> Iterator[ChannelChunk]:
        """rosbags' message iterator (per-message compressed bags), decoded in batches."""
        reorder = Reorderer(repeats=True, topics=self.topics, signs=self._tracker.signs)
        batch: list[tuple[Any, int, bytes]] = []

        def flush() -> None:
            keys = [(c.topic, c.msgtype) for c, _, _ in batch]
            times = np.asarray([t for _, t, _ in batch], dtype=np.int64)
            buf, starts, sizes = concat_payloads([d for _, _, d in batch])
            for key in dict.fromkeys(keys):
                decoder = self._decoders.get(key)
                if decoder is None:
                    continue
                sel = np.asarray([i for i, k in enumerate(keys) if k == key], dtype=np.int64)
                decoded = decoder.decode(buf, starts[sel], sizes[sel])
                self._tracker.push(reorder, key[0], decoded, times[sel])

        for conn, timestamp, data in bag.messages(connections=bag.connections):
            batch.append((conn, timestamp, data))
            if len(batch) >= SQL_BATCH:
                flush()
                batch = []
                yield from reorder.release(None)
        if batch:
            flush()
        yield from reorder.flush()
        for line in reorder.drop_report():
            self._error(line)

    def _error(self, line: str) -> None:
        if line not in self.info.errors:
            self.info.errors.append(line)


KNOWN_DEFINITION_ENCODINGS = ("ros2msg", "ros2idl")
"""The ``message_definitions`` encodings rosbags reads. rosbag2 (Iron on) writes a row of
encoding ``""`` (or ``"unknown"``) and no text for a type whose definition it could not
find where it recorded (ros2/rosbag2#1352: a custom package not sourced in the recording
shell); rosbags 0.11 then fails to open the whole bag (``KeyError: ''``)."""

_HIDE_UNKNOWN_DEFINITIONS = (
    "CREATE TEMP VIEW message_definitions AS SELECT * FROM main.message_definitions "
    f"WHERE encoding IN {KNOWN_DEFINITION_ENCODINGS!r}"
)

_OPENING = threading.Lock()


class _Bag(BagReader):
    """rosbags' reader, whose sqlite3 storage files are opened with their
    ``message_definitions`` rows of an encoding rosbags does not read hidden
    (:data:`KNOWN_DEFINITION_ENCODINGS`): those types are then without a definition, as
    in a bag recorded before Iron: decoded from ``--msg-path`` or a standard typestore,
    or their topics skipped with a line that names ``--msg-path``; the rest of the bag
    is read."""

    def open(self) -> None:
        with _known_definitions_only():
            super().open()


@contextmanager
def _known_definitions_only() -> Iterator[None]:
    """While it lasts, every sqlite connection rosbags opens (through ``apsw``, which
    calls ``apsw.connection_hooks`` on each new connection) sees ``message_definitions``
    as a temporary view of the rows of a known encoding: a temporary object shadows the
    file's table of that name, and the file is not written (opened read-only); and an
    MCAP storage file's schema of an encoding rosbags does not read is no definition
    (:func:`_known_msgdef`). One bag opened at a time (the hook list and rosbags' module
    are the process's)."""
    with _OPENING:
        storage_mcap.get_msgdef = _known_msgdef
        if apsw is not None:
            apsw.connection_hooks.append(_hide_unknown_definitions)
        try:
            yield
        finally:
            storage_mcap.get_msgdef = _ROSBAGS_MSGDEF
            if apsw is not None:
                apsw.connection_hooks.remove(_hide_unknown_definitions)


_ROSBAGS_MSGDEF = storage_mcap.get_msgdef
"""rosbags' reading of an MCAP storage file's schema record, which fails with
``KeyError: 'unknown'`` on the schema rosbag2 writes for a type it did not find where it
recorded (encoding ``unknown``, no text): the whole bag was refused."""


def _known_msgdef(schema: Any) -> Any:
    """:data:`_ROSBAGS_MSGDEF`, with a schema of an encoding rosbags does not read taken
    as no definition (as one of encoding ``""``): the type is then decoded from
    ``--msg-path`` or a standard typestore, or its topic skipped with the line that names
    ``--msg-path`` (:meth:`Ros2BagReader._make_decoder`); the rest of the bag is read."""
    try:
        return _ROSBAGS_MSGDEF(schema)
    except KeyError:
        return MessageDefinition(MessageDefinitionFormat.NONE, "")


def _hide_unknown_definitions(conn: Any) -> None:
    """:func:`_known_definitions_only`'s hook: a file without the table is left as it is,
    and one that cannot be read too (rosbags then says why)."""
    try:
        found = conn.execute(
            "SELECT count(*) FROM main.sqlite_master "
            "WHERE type = 'table' AND name = 'message_definitions'"
        ).fetchone()
        if found and found[0]:
            conn.execute(_HIDE_UNKNOWN_DEFINITIONS)
    except apsw.Error:
        return


def _open_bag(path: Path) -> BagReader:
    """An unopened rosbags reader; ``with`` opens and closes it."""
    return _Bag(path)


def _storages(bag: BagReader) -> list[Any] | None:
    """The storage readers of an open bag, in file (= time) order, or None if the
    layout of rosbags' internals is not the expected one."""
    storage = getattr(bag, "storage", None)
    inner = getattr(storage, "storages", None)
    if inner is not None:
        items = list(inner)
    elif storage is not None:
        items = [storage]
    else:
        return None
    if all(hasattr(s, "path") and hasattr(s, "connections") for s in items):
        return items
    return None


def _may_step_back(db: sqlite3.Connection) -> bool:
    """Whether a sqlite3 storage file's rows, in the order written, may log a message
    more than :data:`LOG_SET_BACK_NS` before one written before it (needed for a topic
    set back, not enough: a file written topic by topic, whose rows :class:`LogClock`
    then reads): its log times span more than that (the timestamp index's ends), and
    its blocks of :data:`SQL_BATCH` rows (the least and greatest log time of each,
    summed up in sqlite) span more than that or start that far before the end of one
    before (:meth:`LogClock.may_step_back`). A pass over the table in C: the rows'
    times fetched into Python cost 4 times more (1.44 M rows: 0.4 s against 1.9 s)."""
    low, high = db.execute(
        "SELECT (SELECT MIN(timestamp) FROM messages), (SELECT MAX(timestamp) FROM messages)"
    ).fetchone()
    if low is None or high - low <= LOG_SET_BACK_NS:
        return False
    first, last = db.execute("SELECT MIN(id), MAX(id) FROM messages").fetchone()
    step = max(SQL_BATCH, (last - first) // 1000 + 1)  # (ids far apart: at most 1000 blocks)
    spans = [
        db.execute(
            "SELECT MIN(timestamp), MAX(timestamp) FROM messages WHERE id >= ? AND id < ?",
            (at, at + step),
        ).fetchone()
        for at in range(first, last + 1, step)
    ]
    known = np.array([span for span in spans if span[0] is not None], dtype=np.int64)
    starts, ends = known[:, 0], known[:, 1]
    return bool((ends - starts > LOG_SET_BACK_NS).any()) or LogClock.may_step_back(starts, ends)


def _unlisted(path: Path, listed: list[str] | None) -> list[str]:
    """A line per storage file in a bag folder that metadata.yaml does not list (a
    recorder stopped before it rewrote metadata.yaml, a file copied in): not read, for
    it may as well belong to another recording; given as an input of its own, it is."""
    if listed is None:
        return []
    names = set(listed)
    out = []
    for entry in sorted(path.iterdir()):
        if entry.name in names or not entry.name.lower().endswith(STORAGE_SUFFIXES):
            continue
        kind = special_kind(entry)
        what = f"not a regular file ({kind}) " if kind else ""
        hint = "" if kind else " (give it as an input of its own to read it)"
        out.append(
            f"{entry.name}: {what}in the bag folder but not in metadata.yaml; not read{hint}"
        )
    return out


def _storage_start(storage: Any) -> int | None:
    """The first log time of a storage file's data (None: none, or unreadable)."""
    path = Path(storage.path)
    try:
        if path.suffix == ".mcap":
            return McapReader(path, info=InputInfo(path, Format.MCAP)).start_ns()
        uri = path.resolve().as_uri() + "?immutable=1"
        with closing(sqlite3.connect(uri, uri=True)) as db:
            row = db.execute("SELECT MIN(timestamp) FROM messages").fetchone()
    except (ReaderError, sqlite3.Error, OSError):
        return None
    return None if row is None or row[0] is None else int(row[0])


def _in_time_order(bag: BagReader, storages: list[Any]) -> list[Any]:
    """``storages`` sorted by the first time of their data (a file without data last),
    and rosbags' own list too (its message iterator reads in that order)."""
    starts = {id(s): _storage_start(s) for s in storages}
    ordered = sorted(storages, key=lambda s: (starts[id(s)] is None, starts[id(s)] or 0))
    inner = getattr(getattr(bag, "storage", None), "storages", None)
    if isinstance(inner, list) and len(inner) == len(ordered):
        inner[:] = ordered
    return ordered


MISSING_FILES = re.compile(r"Some database files are missing: \[(.*)\]")
"""rosbags' error on storage files metadata.yaml names that are not there (a Python
list of them)."""


def _bag_error(err: BaseException) -> str:
    """The line on a ROS 2 bag rosbags could not open: the files metadata.yaml names that
    are missing said as a list of names, not a Python list (``['b2/nodb/x_0.db3']``); an
    error whose text says nothing (a ``KeyError``'s bare key, ``''``) named by its kind."""
    text = one_line(err)
    missing = MISSING_FILES.search(text)
    if missing:
        names = [n.strip().strip("'\"") for n in missing.group(1).split(",") if n.strip()]
        what = "a storage file" if len(names) == 1 else "storage files"
        return (
            f"cannot open ROS 2 bag: {what} its metadata.yaml lists "
            f"{'is' if len(names) == 1 else 'are'} missing: {', '.join(names)}"
        )
    if isinstance(err, BagReaderError) and "Serialization format" in text:
        formats = text.split("{", 1)[-1].split("}", 1)[0]
        return f"unsupported serialization_format {formats} (only cdr is supported)"
    if isinstance(err, FileNotFoundError):
        return f"not a ROS 2 bag ({text})"
    raw = " ".join(str(err).split())
    if isinstance(err, LookupError) or not raw:
        # a KeyError's text is only the key (``''``): say what failed
        said = f" {raw}" if raw else " and no message"
        return f"cannot open ROS 2 bag: the rosbags library failed with {type(err).__name__}{said}"
    return f"cannot open ROS 2 bag: {text}"

"""The input layer: files in, :class:`~analyzer.readers.base.ChannelChunk` streams out.

* :func:`open_input` opens one input (MCAP file, ROS 1 bag, ROS 2 bag directory or bare
  ``.db3``, CSV/TSV optionally gzipped, a LabVIEW ``.lvm``), detected by magic bytes
  first, then by suffix.
* :func:`open_archive` opens the inputs that together form one archive (several paths,
  and/or a directory of files such as one file per hour, its subfolders included) and
  streams them in time order.

Errors: a missing path, an unknown format or a file that cannot be opened raises
:class:`~analyzer.errors.ReaderError` with one line naming the file and the problem. Inside
a multi-file archive a damaged file does not stop the others: it is listed in
``Archive.inputs`` with the problem in its ``errors``.
"""

from __future__ import annotations

import contextlib
import os
import queue
import threading
import time as time_module
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from analyzer.errors import IntegrityError, ReaderError, UsageError, capped
from analyzer.readers._common import (
    REORDER_WINDOW_NS,
    bag_files,
    file_digest,
    lfs_pointer,
    link_out,
    monotonic,
    one_line,
    per_topic,
    special_kind,
)
from analyzer.readers.base import (
    ChannelChunk,
    InputInfo,
    Reader,
    TimeSource,
    check_limit,
    damage_of,
)
from analyzer.readers.chunk_limits import OversizedChunk
from analyzer.readers.seams import Seam, dropped_line, forward_line, is_gap, set_back_line
from analyzer.timeutil import plausible_epoch, spoken_duration
from analyzer.types import Format, Note

# The format readers are imported when a file of theirs is opened: an MCAP run need not
# import pyarrow (the CSV reader) nor the ROS 2 bag stack (rosbags.rosbag2, YAML, sqlite),
# about 0.1 s of every start.

__all__ = [
    "Archive",
    "ArchiveNote",
    "ChannelChunk",
    "InputInfo",
    "Reader",
    "RenameError",
    "RenamedNote",
    "Unstitchable",
    "applied_renames",
    "check_renames",
    "detect_format",
    "open_archive",
    "open_input",
    "parse_renames",
    "renamed_from_json",
    "renamed_successors",
    "renamed_words",
    "skipped_folder",
]

SUFFIXES: dict[str, Format] = {
    ".mcap": Format.MCAP,
    ".bag": Format.ROS1BAG,
    ".db3": Format.ROS2BAG,
    ".csv": Format.CSV,
    ".tsv": Format.CSV,
    ".csv.gz": Format.CSV,
    ".tsv.gz": Format.CSV,
    ".lvm": Format.CSV,
}
"""Suffixes of the files taken from a directory archive, and their format."""

TOA5_MAGICS = (b'"TOA5",', b'\xef\xbb\xbf"TOA5",', b"TOA5,", b"\xef\xbb\xbfTOA5,")
"""How a Campbell Scientific logger's table (mostly named .dat) starts, with or without a
UTF-8 byte order mark, quoted as the logger writes it or not (opened in a spreadsheet and
saved again)."""

LVM_MAGIC = b"LabVIEW Measure"
"""How an NI LabVIEW measurement file (``.lvm``, tab-separated text) starts: its first
line is ``LabVIEW Measurement`` (the 16 bytes read hold this much of it)."""

_MAGICS: tuple[tuple[bytes, Format], ...] = (
    (b"\x89MCAP0\r\n", Format.MCAP),
    (b"#ROSBAG V", Format.ROS1BAG),
    (b"SQLite format 3\x00", Format.ROS2BAG),
    *((magic, Format.CSV) for magic in TOA5_MAGICS),
    (LVM_MAGIC, Format.CSV),
)

TOA5_SUFFIX = ".dat"
"""Files of a directory archive with this suffix are inputs when they are TOA5 tables (a
Campbell logger's CardConvert output): ``.dat`` names many other kinds of file."""


def _suffix(path: Path) -> str:
    name = path.name.lower()
    for suffix in sorted(SUFFIXES, key=len, reverse=True):
        if name.endswith(suffix):
            return suffix
    return ""


def is_ros2_bag(path: Path) -> bool:
    """A ROS 2 bag directory: one holding ``metadata.yaml``."""
    return path.is_dir() and (path / "metadata.yaml").is_file()


def detect_format(path: str | Path) -> Format:
    """The format of ``path``: magic bytes first, then the suffix."""
    path = Path(path)
    if not path.exists():
        raise ReaderError(f"{path}: no such file or directory")
    if path.is_dir():
        if is_ros2_bag(path):
            return Format.ROS2BAG
        raise ReaderError(
            f"{path}: a directory without metadata.yaml is not a ROS 2 bag "
            "(open it as a multi-file archive)"
        )
    special = special_kind(path)
    if special:  # opening a FIFO would wait for a writer, forever
        raise ReaderError(f"{path}: not a regular file ({special}): not read")
    try:
        with path.open("rb") as handle:
            head = handle.read(16)
    except OSError as err:
        check_limit(err)  # (the machine's limit, not the file's)
        raise ReaderError(f"{path}: cannot read: {one_line(err.strerror or err)}") from err
    for magic, fmt in _MAGICS:
        if head.startswith(magic):
            return fmt
    if head.startswith(b"version ") and (pointer := lfs_pointer(path)):
        raise ReaderError(pointer)
    suffix = _suffix(path)
    if suffix:
        return SUFFIXES[suffix]
    if not head:
        raise ReaderError(f"{path}: empty file (0 bytes) of unknown format")
    if head.startswith(b"\x89MCAP"):
        return Format.MCAP  # damaged magic: the MCAP reader says how
    raise ReaderError(
        f"{path}: unknown format (expected .mcap, .bag, .db3, .csv, .tsv, .csv.gz, a TOA5 "
        "table or a ROS 2 bag directory)"
    )


OPEN_THREADS = 4
"""Inputs opened at once (each reads its header and hashes its bytes, without the GIL)."""


def _open_members(members: Sequence[Path]) -> list[Reader | ReaderError]:
    """:func:`open_input` of each member, in order (its ReaderError in its place). MCAP and
    CSV files are opened on threads; other formats (a ROS bag's sqlite connection belongs
    to the thread that opened it) in this one."""

    def attempt(member: Path) -> Reader | ReaderError:
        try:
            return open_input(member)
        except ReaderError as err:
            check_limit(err)  # (too many open files: the run's error, not this member's)
            return err

    def threadable(member: Path) -> bool:
        try:
            return detect_format(member) in (Format.MCAP, Format.CSV)
        except ReaderError:
            return False  # opened here, where it raises its error

    threaded = [threadable(m) for m in members]
    with ThreadPoolExecutor(min(OPEN_THREADS, max(1, sum(threaded)))) as pool:
        pending = [
            pool.submit(attempt, m) if t else None for m, t in zip(members, threaded, strict=True)
        ]
        return [
            attempt(m) if handle is None else handle.result()
            for m, handle in zip(members, pending, strict=True)
        ]


def open_input(path: str | Path) -> Reader:
    """Open one input; raises ReaderError (one line, naming the file) if it cannot be read:
    the reader's own refusals, and what its parsing libraries raise on a damaged or foreign
    file (:func:`~analyzer.readers.base.damage_of`). Any other exception is a bug of ours
    and is left to reach the CLI's "internal error" line."""
    path = Path(path)
    fmt = detect_format(path)
    try:
        kind = _reader_class(fmt)
    except ImportError as err:  # (a library missing from the installation)
        raise ReaderError(f"{path}: cannot be read as {fmt.value} ({one_line(err)})") from err
    try:
        return kind(path)
    except OversizedChunk as err:  # (raised without the file's name)
        raise ReaderError(f"{path}: {one_line(err)}") from err
    except ReaderError:
        raise
    except damage_of(kind) as err:  # a corrupt file fails in the parsing libraries
        check_limit(err)  # (unless the machine ran out of open files or memory)
        raise ReaderError(f"{path}: cannot be read as {fmt.value} ({one_line(err)})") from err


def _reader_class(fmt: Format) -> Callable[[Path], Reader]:
    """The reader of ``fmt``, imported only when an input of that format is given (each
    pulls in its own libraries: pyarrow for CSV, rosbags' storage for ROS 2 bags)."""
    if fmt is Format.MCAP:
        from analyzer.readers.mcap_reader import McapReader

        return McapReader
    if fmt is Format.ROS1BAG:
        from analyzer.readers.ros1_reader import Ros1BagReader

        return Ros1BagReader
    if fmt is Format.ROS2BAG:
        from analyzer.readers.ros2_reader import Ros2BagReader

        return Ros2BagReader
    from analyzer.readers.csv_reader import CsvReader

    return CsvReader


def _safe_start(reader: Reader) -> int | None:
    """A reader's start time, or None when finding it fails (a corrupt file fails later,
    where its error is recorded or raised with the file's name)."""
    try:
        return reader.start_ns()
    except damage_of(reader) as err:
        check_limit(err)
        return None


class ArchiveNote(Note):
    """A note on how an archive was put together (a file not read, one given twice):
    a plain string to every reader of ``notes``, recognisable among a run's other notes
    so that ``run`` can repeat it on stderr (:attr:`Archive.notes`)."""

    __slots__ = ()


def _one_date_order(readers: Sequence[Reader]) -> None:
    """CSV files of one archive whose dates could be read either way round (no day above
    12: ``01/03/2026``) are read day first when the archive's other CSV files with
    such dates are all day first (one has ``13/03/2026``): a logger writes one order."""
    if not any(r.info.format == Format.CSV for r in readers):
        return  # (nor its import: pyarrow's, ~0.1 s of an MCAP run's start-up)
    from analyzer.readers.csv_reader import CsvReader

    csvs = [r for r in readers if isinstance(r, CsvReader) and r.dates_first]
    known = {r.dates_first for r in csvs if not r.either_way_dates}
    if known == {"day"}:
        for r in csvs:
            r.read_day_first()


class RenameError(UsageError):
    """``--rename NEW=OLD`` (or the config's ``[rename]``) that this archive cannot take:
    an input holds both names. Raised through :meth:`Archive.chunks` whatever the
    number of inputs (an option's error: exit 2, not one input's damage)."""


def check_renames(archive: Archive) -> None:
    """Raise :class:`RenameError` for a NEW name of ``archive``'s :attr:`~Archive.renames`
    that no input held, once its chunks were all read: a typo would otherwise join
    nothing without a word."""
    unknown = [new for new in archive.renames if new not in archive.renamed]
    if unknown:
        new = unknown[0]
        raise RenameError(
            f"{archive.rename_given(new)}: no input has a channel {new} "
            "(NEW=OLD: the name the sensor has in the later files, then the one it replaces)"
        )


def parse_renames(
    given: Sequence[str], config: Mapping[str, str] | None = None
) -> tuple[tuple[str, str], ...]:
    """``--rename``'s ``NEW=OLD`` texts, checked, after the config's ``[rename]`` pairs
    (the option's win on one NEW name): :class:`UsageError` for a text without ``=``, an
    empty name, a name renamed to itself, one NEW given twice, or an OLD that is
    itself renamed (two NEW names may read as one OLD: a sensor replaced twice; an input
    holding two of them at once is the reading's error). One parsing for ``run``,
    ``watch``, ``inspect`` and ``export`` (here, not in :mod:`analyzer.options`, whose
    imports ``inspect`` need not pay for)."""
    pairs = dict(config or {})
    seen: set[str] = set()
    for text in given:
        new, sep, old = text.partition("=")
        new, old = new.strip(), old.strip()
        if not sep or not new or not old:
            raise UsageError(
                f"--rename {text}: expected NEW=OLD (the channel's name in the later "
                "files, then the name it replaces: --rename s3b=s3)"
            )
        if new in seen:
            raise UsageError(f"--rename {text}: {new} is renamed twice")
        seen.add(new)
        pairs[new] = old
    for new, old in pairs.items():
        if new == old:
            raise UsageError(f"--rename {new}={old}: a name renamed to itself")
        if old in pairs:
            raise UsageError(
                f"--rename {new}={old}: {old} is itself renamed (--rename {old}={pairs[old]}); "
                f"give --rename {new}={pairs[old]}"
            )
    return tuple(pairs.items())


def applied_renames(archive: Archive) -> dict[str, dict[str, tuple[str, ...]]]:
    """The renames of ``archive`` that were applied, once its chunks were all read: by
    OLD channel name, each NEW name read as it and the inputs that held NEW (as their
    paths are written in findings.json's ``inputs``), in the order they were read.
    findings.json's and ``inspect --json``'s ``renamed_from`` of a channel: a reader of
    them could not tell that a channel's later samples came from another column."""
    out: dict[str, dict[str, tuple[str, ...]]] = {}
    for new, paths in archive.renamed.items():
        out.setdefault(archive.renames[new], {})[new] = tuple(str(p) for p in paths)
    return out


def renamed_from_json(renamed: Mapping[str, tuple[str, ...]]) -> list[dict[str, object]]:
    """A channel's ``renamed_from`` (of :func:`applied_renames`): each NEW name and the
    inputs its samples came from."""
    return [{"name": new, "inputs": list(paths)} for new, paths in renamed.items()]


def renamed_words(renamed: Mapping[str, tuple[str, ...]]) -> str:
    """``read from s3b in log_02.csv, log_03.csv``: a channel's :func:`applied_renames`
    entry in the report's channel table and ``inspect``'s note."""
    return "; ".join(
        f"read from {new} in {capped([Path(p).name for p in paths], 3, what='inputs')}"
        for new, paths in renamed.items()
    )


class Unstitchable(ReaderError):
    """Inputs of one archive that cannot be placed in time against each other (relative
    times that overlap): a refusal of the whole archive, not one input's damage."""


class Archive:
    """The inputs of one archive, stitched in time order (by each reader's start time).

    ``inputs`` lists every input, readable or not (in stitching order, unreadable ones
    last). :meth:`chunks` streams the readable ones one after the other; a sample not later
    than one already streamed for the same channel (files overlapping in time) is dropped
    and counted in the later file's errors. Two inputs with relative times (seconds from
    their own start) whose spans of one channel overlap cannot be stitched: each starts
    at 0 s, so dropping the overlap would keep the first file alone; :meth:`chunks`
    raises :class:`Unstitchable` instead. Relative-time inputs holding different channels
    over the same span (one file per sensor node) are merged.
    """

    def __init__(
        self,
        readers: Sequence[Reader],
        failed: Sequence[InputInfo] = (),
        notes: Sequence[str] = (),
    ) -> None:
        _one_date_order(readers)
        starts = [(_safe_start(r), str(r.info.path), r) for r in readers]
        starts.sort(key=lambda s: (s[0] is None, s[0] or 0, s[1]))
        self.readers: list[Reader] = [s[2] for s in starts]
        self.inputs: list[InputInfo] = [r.info for r in self.readers] + list(failed)
        self.notes: list[str] = [ArchiveNote(n) for n in notes]
        """What the archive's folders held that is not read (the analyzer's own outputs, a
        FIFO, a folder reached twice through a link) and inputs given twice, as
        :class:`ArchiveNote`."""
        self.renames: dict[str, str] = {}
        """``--rename NEW=OLD`` (and the config's ``[rename]``): each NEW channel name, as
        read, and the OLD one its samples are read as (:meth:`chunks`), a sensor
        replaced under a new name from one file on joined to the one it replaces."""
        self.rename_origin: dict[str, str] = {}
        """How each NEW name of :attr:`renames` that did not come from ``--rename`` was
        given, for its errors (:meth:`rename_given`): the config's ``[rename]`` line."""
        self.renamed: dict[str, list[Path]] = {}
        """The inputs each NEW name of :attr:`renames` was read from, once :meth:`chunks`
        has streamed them all (a NEW name no input holds is the option's error:
        :func:`check_renames`)."""
        self.seams: list[Seam] = []
        """Once :meth:`chunks` has streamed the inputs: the seams between files where
        samples were dropped (times read already), a file was left out (a zone-less
        clock set back an hour) or a gap begins (:class:`~analyzer.readers.seams.Seam`),
        so that an alarm no finding explains beside one is tied to it."""
        self.sources: dict[str, Path] = {}
        """The input each channel was first read from, once :meth:`chunks` has streamed
        them all (the same recording in two inputs: :class:`~analyzer.selection.
        TwinInputNote`)."""

    def start_ns(self) -> int | None:
        """Start time of the first readable input."""
        return next((s for r in self.readers if (s := _safe_start(r)) is not None), None)

    def chunks(
        self, time: TimeSource = "log", progress: Callable[[float], None] | None = None
    ) -> Iterator[ChannelChunk]:
        """Every channel chunk of every readable input, input after input.

        ``progress`` is called with the share of the archive read so far (by input bytes:
        the inputs before this one, and this one's ``fraction_read`` where its reader
        keeps one), at most every :data:`PROGRESS_EVERY_S` seconds and after each input,
        below 1 (the caller says when reading is done)."""
        if time not in ("log", "header"):
            raise ValueError(f"time must be 'log' or 'header', not {time!r}")
        last: dict[str, int] = {}
        owner: dict[str, tuple[Reader, int]] = {}
        single = len(self.inputs) == 1
        for reader in self.readers:  # (one input: said in info.set_back, refused by one_clock)
            if hasattr(reader, "stop_at_set_back"):
                reader.stop_at_set_back = not single
        report = None if progress is None else _ReadProgress(progress, self.readers)
        # the next input is read ahead on a thread while this one is consumed: decoding
        # (zstd, Arrow's CSV parser, numpy) runs without the GIL, so two files' worth of
        # work overlaps; the queue bounds what is held ahead
        ahead: dict[int, _ReadAhead] = {}
        held = [_Held() for _ in self.readers]
        try:
            for i, reader in enumerate(self.readers):
                nxt = i + 1
                if nxt < len(self.readers) and _threadable(self.readers[nxt]):
                    ahead[nxt] = _ReadAhead(self.readers[nxt].chunks, time)
                before, end = _latest(self.readers[:i], held[:i])
                if before is not None and self._at_seam(before, end, reader):
                    if i in ahead:  # (left out: a zone-less clock set back an hour)
                        ahead.pop(i).close()
                    if report is not None:
                        report.finished(i)
                    continue
                source = ahead.pop(i) if i in ahead else reader.chunks(time)
                if self.renames:
                    source = self._renamed(reader, source)
                lost: list[str] = []  # (samples dropped as times read already, said)
                for chunk in self._stream(reader, source, last, owner, single, before, lost):
                    if report is not None:
                        report.inside(i)
                    held[i].add(chunk)
                    yield chunk
                if report is not None:
                    report.finished(i)
                if before is not None and end.last is not None and lost:
                    self._seam(before, reader, end.last, f"where {lost[0]} were dropped")
            for reader, h in zip(self.readers, held, strict=True):
                for name in sorted(h.names):
                    self.sources.setdefault(name, reader.info.path)
            self.notes.extend(ArchiveNote(n) for n in apart_names(self.readers, held))
            self.notes.extend(renamed_columns(self.readers, held))
            columns_left_out(self.readers, held)
        finally:
            for pending in ahead.values():
                pending.close()

    def rename_given(self, new: str) -> str:
        """How the rename of ``new`` was given, as its errors name it: ``--rename
        NEW=OLD``, or the config's line (``F: [rename] NEW = "OLD"``), which named
        ``--rename`` to a user who had given none."""
        return self.rename_origin.get(new, f"--rename {new}={self.renames[new]}")

    def _renamed(self, reader: Reader, source: Iterator[ChannelChunk]) -> Iterator[ChannelChunk]:
        """One input's chunks with each NEW name of :attr:`renames` read as its OLD one
        (chunk by chunk, no per-sample work), and its blank columns' names too
        (:attr:`~analyzer.readers.base.InputInfo.blank_until`). An input that holds
        both names is refused: two sensors at once cannot be one channel."""
        held: set[str] = set()
        for chunk in source:
            old = self.renames.get(chunk.name)
            if old is None:
                held.add(chunk.name)
                yield chunk
                continue
            held.add(chunk.name)
            yield ChannelChunk(old, chunk.t_ns, chunk.values)
        both = sorted(n for n in held if self.renames.get(n) in held)
        if both:
            new = both[0]
            raise RenameError(
                f"{self.rename_given(new)}: {reader.info.path} holds both "
                f"{new} and {self.renames[new]} (two sensors at once cannot be one channel)"
            )
        for new, old in self.renames.items():
            if new in held or new in reader.info.blank_until:
                self.renamed.setdefault(new, []).append(Path(reader.info.path))
            if new in reader.info.blank_until:
                at = reader.info.blank_until.pop(new)
                reader.info.blank_until[old] = max(at, reader.info.blank_until.get(old, at))

    @staticmethod
    def _stream(
        reader: Reader,
        source: Iterator[ChannelChunk],
        last: dict[str, int],
        owner: dict[str, tuple[Reader, int]],
        single: bool,
        before: Reader | None = None,
        lost: list[str] | None = None,
    ) -> Iterator[ChannelChunk]:
        """One input's chunks, time-ordered against the inputs before it (``before``:
        the one whose times end last); its errors recorded (several inputs) or raised
        (one input). The samples dropped as times read already are said in one line,
        and how many put in ``lost`` (``6000 overlapping messages``)."""
        dropped: dict[str, int] = {}
        spans: dict[str, tuple[int, int]] = {}
        try:
            yield from monotonic(
                _one_span(reader, source, last, owner), last, dropped, strict=True, spans=spans
            )
        except (Unstitchable, IntegrityError, RenameError):  # (an internal check's, an option's)
            raise
        except OversizedChunk as err:  # (raised without the file's name)
            if single:
                raise ReaderError(f"{reader.info.path}: {one_line(err)}") from err
            reader.info.errors.append(f"reading stopped: {one_line(err)}")
        except ReaderError as err:
            check_limit(err)  # (the machine's limit: the run's error, not the file's)
            if single:
                raise
            reader.info.errors.append(f"reading stopped: {one_line(err)}")
        except damage_of(reader) as err:  # a damaged file must not stop the others
            check_limit(err)
            if single:
                raise ReaderError(f"{reader.info.path}: {one_line(err)}") from err
            reader.info.errors.append(f"reading stopped: {one_line(err)}")
        finally:
            if isinstance(source, _ReadAhead):
                source.close()
        topics: dict[str, str] = getattr(reader, "topics", {})
        if single:  # (the readers order their own samples: not expected)
            for name, unit, count in per_topic(dropped, topics):
                line = f"{name}: {count} {unit} not after an earlier one of the input; dropped"
                reader.info.errors.append(line)
        elif dropped:
            reader.info.errors.append(dropped_line(before, dropped, spans, topics))
            if lost is not None:
                counts = per_topic(dropped, topics)
                unit = "messages" if any(u == "messages" for _, u, _ in counts) else "samples"
                lost.append(f"{max(c for _, _, c in counts)} overlapping {unit}")

    def _at_seam(self, before: Reader, end: _Held, reader: Reader) -> bool:
        """What the seam between ``before`` (the input read before ``reader`` whose times
        end last; ``end``, what it held) and ``reader`` tells, said as a CSV file's own times are
        (:mod:`analyzer.readers.seams`): True where ``reader`` is left out, its zone-less
        clock set back an hour (a damaged file, as one whose own times step back so:
        ``reading stopped: ...``; before, every sample of it was dropped as overlapping,
        a line per channel, and no clock named: ux62 HIGH 1); a jump forward over a
        clock hour said on it; the seam kept where it was left out or a gap begins."""
        start = _safe_start(reader)
        if start is None or end.last is None:
            return False
        spacing, last = end.spacing(), end.last
        # (files of other channels over the same hour, one per sensor node, are no clock
        # change: only a file sharing a channel with those before it is judged so)
        columns = getattr(reader, "column_names", None)
        shared = columns is None or bool(set(columns()) & end.names)
        line = set_back_line(reader, before, last, start) if shared else None
        if line is not None:
            reader.info.errors.append(f"reading stopped: {line}")
            words = f"where {_name(reader)} was left out (its times repeat an hour read already)"
            self._seam(before, reader, last, words)
            return True
        line = forward_line(reader, before, last, start, spacing) if shared else None
        if line is not None:
            reader.info.errors.append(line)
        if is_gap(start - last, spacing, REORDER_WINDOW_NS):
            words = f"where a gap of {spoken_duration((start - last) / 1e9)} begins"
            self._seam(before, reader, last, words, gap_to=start)
        return False

    def _seam(
        self, before: Reader, reader: Reader, end: int, where: str, gap_to: int | None = None
    ) -> None:
        """Keep the seam of ``before`` and ``reader`` at ``end`` (:attr:`seams`; ``gap_to``,
        where a gap begins there, the later file's first time)."""
        files = (_name(before), _name(reader))
        words = f"the seam of {files[0]} and {files[1]}, {where}"
        self.seams.append(Seam(end, words, gap_to, files))


def _name(reader: Reader) -> str:
    """An input as a seam's note names it: its file name."""
    return Path(reader.info.path).name


def _latest(readers: Sequence[Reader], held: Sequence[_Held]) -> tuple[Reader | None, _Held]:
    """Of the inputs read so far, the one whose times end last, and what it held (None
    and an empty record before any input held data)."""
    best: tuple[Reader | None, _Held] = (None, _Held())
    for reader, h in zip(readers, held, strict=True):
        if h.last is not None and (best[1].last is None or h.last > best[1].last):
            best = (reader, h)
    return best


class _Held:
    """What one input of an archive streamed: its channels' names and the first and last
    time of any of its samples (:func:`apart_names`)."""

    __slots__ = ("count", "first", "last", "names")

    def __init__(self) -> None:
        self.names: set[str] = set()
        self.first: int | None = None
        self.last: int | None = None
        self.count = 0  # samples, of every channel

    def spacing(self) -> float | None:
        """The mean time between two samples of a channel (ns), None where unknown."""
        per = self.count / max(1, len(self.names))
        if self.first is None or self.last is None or per < 2:
            return None
        return (self.last - self.first) / (per - 1)

    def add(self, chunk: ChannelChunk) -> None:
        """Count ``chunk`` in (a block of samples: no per-sample work)."""
        if not len(chunk):
            return
        self.names.add(chunk.name)
        self.count += len(chunk)
        a, b = int(chunk.t_ns[0]), int(chunk.t_ns[-1])
        self.first = a if self.first is None else min(self.first, a)
        self.last = b if self.last is None else max(self.last, b)


NAMES_SHOWN = 3
"""Channel names a note on an input apart from the others shows, of its and of theirs."""


def apart_names(readers: Sequence[Reader], held: Sequence[_Held]) -> list[str]:
    """The notes on the inputs of a multi-file archive that share no channel name with
    any other input and hold data only where the others have none (their times do not
    overlap): most likely the same sensors under other names (a CSV hour beside MCAP
    hours: ``s0`` for ``/s0.data``), which the analysis keeps as separate channels, each
    with no data where the other has it (an audit: the CSV's channels left out as "empty
    in the training window", and a fault inside its hour found 61 s late, where the MCAP
    names' data resumed). Inputs that hold different channels over the same time (one
    file per sensor node) are how such archives are meant to be: no note."""
    full = [(r, h) for r, h in zip(readers, held, strict=True) if h.first is not None]
    if len(full) < 2:
        return []
    notes = []
    for r, h in full:
        others = [o for o in full if o[1] is not h]
        theirs = set().union(*(o[1].names for o in others))
        if h.names & theirs:
            continue
        if any(_overlap(h, o) for _, o in others):
            continue
        mine = capped(sorted(h.names), NAMES_SHOWN, what="channels")
        them = capped(sorted(theirs), NAMES_SHOWN, what="channels")
        notes.append(
            f"{r.info.path} shares no channel name with the archive's other files ({mine} "
            f"against {them}) and holds data only where they have none: likely other "
            "names for the same sensors (a CSV written beside MCAP files, say): its "
            "channels are taken as other sensors, with no data outside its time, and the "
            "others have a gap over it (give its columns the others' names to join them)"
        )
    return notes


def _in_turn(readers: Sequence[Reader], held: Sequence[_Held]) -> list[tuple[Reader, _Held]]:
    """The inputs that held data, by their first time, where each one's times lie after
    the one's before it (an archive of hourly files); empty where any two overlap (one
    file per sensor node over the same time: different columns are how it is meant)."""
    full = sorted(
        ((r, h) for r, h in zip(readers, held, strict=True) if h.first is not None),
        key=lambda rh: rh[1].first or 0,
    )
    for (_, a), (_, b) in zip(full, full[1:], strict=False):
        if _overlap(a, b):
            return []
    return full


class RenamedNote(ArchiveNote):
    """:func:`renamed_columns`' note, with the channels that begin in its file by each
    one that ends there (``successors``): a finding of a channel that ended says it
    may be renamed (findings.json's ``check``, :func:`renamed_successors`)."""

    successors: dict[str, tuple[str, ...]]

    def __new__(
        cls, text: str, successors: dict[str, tuple[str, ...]] | None = None
    ) -> RenamedNote:
        note = super().__new__(cls, text)
        note.successors = dict(successors or {})
        return note


def renamed_successors(notes: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """The channels that begin where each channel ends in an archive of files in turn,
    by the ending one, from a run's :class:`RenamedNote` notes."""
    out: dict[str, tuple[str, ...]] = {}
    for note in notes:
        for ended, begun in getattr(note, "successors", {}).items():
            out[ended] = tuple(dict.fromkeys([*out.get(ended, ()), *begun]))
    return out


def renamed_columns(readers: Sequence[Reader], held: Sequence[_Held]) -> list[str]:
    """The notes on the files of an archive of files in turn (:func:`_in_turn`) from
    which some channels begin exactly where others end: ``s2`` in the files before,
    ``s2_new`` from this one on (a re-labelled or re-wired logger channel). The two are
    separate channels to the analysis, and the new name has no data in the training
    window: a fault on it was never searched for, and a run said "no sensor fault found"
    without a word (a new user's audit, ux55). Names that share no name with the
    others at all are :func:`apart_names`'s."""
    full = _in_turn(readers, held)
    notes: list[str] = []
    for k in range(1, len(full)):
        before = set().union(*(h.names for _, h in full[:k]))
        after = set().union(*(h.names for _, h in full[k:]))
        ended = sorted(before - after)
        begun = sorted(full[k][1].names - before)
        if not ended or not begun or not (before & after):
            continue
        one = len(begun) == len(ended) == 1
        fix = f"--rename {begun[0]}={ended[0]}" if one else "--rename NEW=OLD for each"
        notes.append(
            RenamedNote(
                f"{full[k][0].info.path}: {capped(begun, NAMES_SHOWN, what='channels')} "
                f"{'begins' if len(begun) == 1 else 'begin'} in this file where "
                f"{capped(ended, NAMES_SHOWN, what='channels')} "
                f"{'ends' if len(ended) == 1 else 'end'}: the same "
                f"{'sensor' if one else 'sensors'} renamed? Each name is analyzed as its "
                f"own channel (give {fix} to join them)",
                {name: tuple(begun) for name in ended},
            )
        )
    return notes


def columns_left_out(readers: Sequence[Reader], held: Sequence[_Held]) -> None:
    """Mark, in each CSV file of an archive of files in turn (:func:`_in_turn`), the
    columns of the files before it that its header lacks as without a reading to its
    last time (:attr:`~analyzer.readers.base.InputInfo.blank_until`), as blank cells
    are: the files are rows of one table, and a column missing from a file's header is
    a sensor with no reading in its rows (``s2`` after it became ``s2_new``: a note
    only, exit 0, where the same silence in blank cells is a finding; the ux55 audit).
    A topic that stops in MCAP or bag files stays unmarked (a node stopped, not
    necessarily the sensor: :mod:`analyzer.silent`)."""
    full = _in_turn(readers, held)
    seen: set[str] = set()
    for reader, h in full:
        if reader.info.format == Format.CSV and h.last is not None:
            for name in seen - h.names:
                at = reader.info.blank_until.get(name, h.last)
                reader.info.blank_until[name] = max(at, h.last)
        seen |= h.names


def _overlap(a: _Held, b: _Held) -> bool:
    """Whether two inputs' times (``first``-``last``) overlap."""
    assert a.first is not None and a.last is not None
    assert b.first is not None and b.last is not None
    return a.first <= b.last and b.first <= a.last


def _one_span(
    reader: Reader,
    source: Iterator[ChannelChunk],
    last: dict[str, int],
    owner: dict[str, tuple[Reader, int]],
) -> Iterator[ChannelChunk]:
    """``source`` (the chunks of ``reader``) passed through, after checking that where it
    and an earlier input both have relative times, its first sample of each channel does
    not lie in the first half of that channel's span in the earlier input (``owner``:
    which input that was and its first sample's time; ``last``: its last). Raises
    :class:`Unstitchable` before yielding a chunk that does: files that each count
    seconds from their own start overlap by construction, and their overlap, dropped as a
    repeat, was every sample of the later files. A few samples of overlap at a seam
    (pieces that repeat the previous one's last rows) are dropped as before."""
    relative = not reader.info.absolute_time
    seen: set[str] = set()
    for chunk in source:
        name = chunk.name
        if name not in seen and len(chunk):
            seen.add(name)
            before = owner.get(name)
            start = int(chunk.t_ns[0])
            if (
                relative
                and before is not None
                and before[0] is not reader
                and not before[0].info.absolute_time
                and start <= before[1] + (last.get(name, start) - before[1]) // 2
            ):
                raise Unstitchable(
                    f"{before[0].info.path} and {reader.info.path} have relative times "
                    f"(seconds from their own start) and both hold {one_line(name)} over the "
                    "same span: they cannot be stitched in time; give them absolute times "
                    "(dates), or analyze them one at a time"
                )
            owner[name] = (reader, start)
        yield chunk


class _ReadProgress:
    """The reading's progress for :meth:`Archive.chunks`: the share of the archive's
    input bytes read, below :data:`PROGRESS_CAP`, at most every
    :data:`PROGRESS_EVERY_S` seconds inside an input and always at its end."""

    def __init__(self, progress: Callable[[float], None], readers: Sequence[Reader]) -> None:
        self._progress = progress
        self._readers = readers
        self._sizes = [max(1, r.info.size_bytes) for r in readers]
        self._total = float(sum(self._sizes))
        self._done = 0  # bytes of the inputs before the current one
        self._shown = time_module.monotonic()

    def inside(self, i: int) -> None:
        """Input ``i`` is being read: its reader's ``fraction_read`` of it counts."""
        now = time_module.monotonic()
        if now - self._shown >= PROGRESS_EVERY_S:
            within = float(getattr(self._readers[i], "fraction_read", 0.0))
            self._show(self._done + min(1.0, max(0.0, within)) * self._sizes[i], now)

    def finished(self, i: int) -> None:
        """Input ``i`` is read whole."""
        self._done += self._sizes[i]
        self._show(self._done, time_module.monotonic())

    def _show(self, read: float, now: float) -> None:
        self._shown = now
        self._progress(min(PROGRESS_CAP, read / self._total))


PROGRESS_EVERY_S = 0.2
"""Seconds between two reports of the reading's progress (:meth:`Archive.chunks`)."""
PROGRESS_CAP = 0.99
"""The reading's progress stays below this until the caller has finished with the chunks
(a fraction of 1 ends the stage's line)."""

READ_AHEAD_CHUNKS = 64
"""Chunks of the next input held ahead at most (a few tens of MB)."""


def _threadable(reader: Reader) -> bool:
    """Readers whose files may be read on another thread than the one that opened them
    (a ROS 2 bag's sqlite connection may not)."""
    return reader.info.format in (Format.MCAP, Format.CSV)


class _End:
    pass


class _ReadAhead(Iterator[ChannelChunk]):
    """``chunks(time)`` run on a thread into a bounded queue; iterating yields its chunks
    and raises its exception where it occurred. :meth:`close` stops the thread."""

    def __init__(self, chunks: Callable[[TimeSource], Iterator[ChannelChunk]], time: TimeSource):
        self._queue: queue.Queue[object] = queue.Queue(READ_AHEAD_CHUNKS)
        self._stop = threading.Event()
        self._done = False
        self._thread = threading.Thread(
            target=self._produce, args=(chunks, time), name="analyzer-read-ahead", daemon=True
        )
        self._thread.start()

    def _put(self, item: object) -> bool:
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def _produce(self, chunks: Callable[[TimeSource], Iterator[ChannelChunk]], time: TimeSource):
        try:
            for chunk in chunks(time):
                if not self._put(chunk):
                    return
            self._put(_End())
        except BaseException as err:  # noqa: BLE001 - handed to the consumer, raised there
            self._put(err)

    def __next__(self) -> ChannelChunk:
        if self._done:
            raise StopIteration
        item = self._queue.get()
        if isinstance(item, _End):
            self._done = True
            raise StopIteration
        if isinstance(item, BaseException):
            self._done = True
            raise item
        assert isinstance(item, ChannelChunk)
        return item

    def close(self) -> None:
        self._stop.set()
        self._done = True
        self._thread.join()


OWN_OUTPUTS = ("corrected.csv",)
"""Files an analysis writes into its ``--out`` folder that a reader would take for data:
in a folder that also holds a ``findings.json`` (the analysis was written into the
archive's own folder) they are the analyzer's, not inputs (a ``corrected.csv`` read
back spans the time from 0 beside the archive's epoch times: the archive became
unreadable)."""


SKIPPED_FOLDER_ENDINGS = ("~", ".bak", ".orig", ".old", ".tmp", ".part")
"""Folders of a directory archive that are not descended into, by how their name ends:
backups and copies in progress, whose files would repeat (or half repeat) the archive's
own. They are named in the archive's notes; hidden folders are skipped without a word,
as hidden files are."""


def _members(
    directory: Path, skipped: list[str] | None = None, inside: Path | None = None
) -> list[Path]:
    """The inputs of a directory archive: files with a known suffix, and ROS 2 bags
    (each one input), in it and in its subfolders at any depth, in sorted order.

    Not read, and named in ``skipped``: the analyzer's own outputs beside a
    ``findings.json`` (:data:`OWN_OUTPUTS`), FIFOs and other special files with a known
    suffix, backup folders (:data:`SKIPPED_FOLDER_ENDINGS`), a folder that cannot be
    listed, and a folder reached a second time through a symbolic link (a link to a
    folder above it would loop). Hidden files and folders are skipped without a word.
    With ``inside`` (the watcher's INBOX, by its real path), a symbolic link leading out
    of it is not followed, and a ROS 2 bag with such a file is not read (named in
    ``skipped`` too): whoever may drop files would otherwise have the analysis read,
    and publish in its report, what only the watcher's account may read."""
    try:
        entries = sorted(directory.iterdir())
    except OSError as err:
        raise ReaderError(
            f"{directory}: cannot list the folder: {one_line(err.strerror or err)}"
        ) from err
    found: list[Path] = []
    seen = {directory.resolve()}
    _walk(directory, entries, seen, found, [] if skipped is None else skipped, inside)
    return found


def bag_link_out(bag: Path, inside: Path) -> str | None:
    """Why the ROS 2 bag folder ``bag`` is not read under the watcher's INBOX
    ``inside`` (its real path): one of its files is a symbolic link leading out of it
    (:func:`~analyzer.readers._common.link_out`; ``x.db3 is a symbolic link to ...``),
    or it is one itself; None when it may be read."""
    if (why := link_out(bag, inside)) is not None:
        return why
    for f in bag_files(bag):
        if (why := link_out(f, inside)) is not None:
            return f"its file {f.name} is {why}"
    return None


def skipped_folder(entry: Path, seen: set[Path]) -> str | None:
    """Why the walk of a directory archive does not go into the folder ``entry`` (a
    backup folder, :data:`SKIPPED_FOLDER_ENDINGS`; one whose real path is in ``seen``,
    reached again through a link), as a note; None when it does, its real path then
    added to ``seen``. The readers (:func:`_members`) and the watcher's completeness
    check walk alike."""
    ending = next((e for e in SKIPPED_FOLDER_ENDINGS if entry.name.lower().endswith(e)), None)
    if ending is not None:
        return f"{entry} not read: a backup or temporary folder (ends in {ending})"
    real = entry.resolve()
    if real in seen:
        return (
            f"{entry} not read: a link to {real}, a folder read already"
            if entry.is_symlink()
            else f"{entry} not read: read already through a symbolic link to it"
        )
    seen.add(real)
    return None


def _walk(
    directory: Path,
    entries: list[Path],
    seen: set[Path],
    found: list[Path],
    skipped: list[str],
    inside: Path | None = None,
) -> None:
    """:func:`_members` of ``directory``, whose ``entries`` are listed already; ``seen``
    holds the real paths of the folders read so far."""
    ours = (directory / "findings.json").is_file()
    for entry in entries:
        if entry.name.startswith("."):
            continue
        if ours and entry.name in OWN_OUTPUTS:
            skipped.append(
                f"{entry} not read: the analyzer's output beside {directory / 'findings.json'}"
            )
            continue
        if entry.is_symlink() and not entry.exists():
            # (said where it could be an input: a known suffix, or none, as a folder has)
            if _suffix(entry) or not entry.suffix:
                skipped.append(f"{entry} not read: {_dangling(entry)}")
            continue
        if inside is not None and (why := link_out(entry, inside)) is not None:
            skipped.append(f"{entry} not read: {why}")
            continue
        if entry.is_dir():
            if is_ros2_bag(entry):
                if inside is not None and (why := bag_link_out(entry, inside)) is not None:
                    skipped.append(f"{entry} not read: {why}")
                    continue
                found.append(entry)
                continue
            why = skipped_folder(entry, seen)
            if why is not None:
                skipped.append(why)
                continue
            try:
                inner = sorted(entry.iterdir())
            except OSError as err:
                skipped.append(
                    f"{entry} not read: cannot list the folder: {one_line(err.strerror or err)}"
                )
                continue
            _walk(entry, inner, seen, found, skipped, inside)
        elif (special := special_kind(entry)) is not None:
            if _suffix(entry):
                skipped.append(f"{entry} not read: not a regular file ({special})")
        elif _suffix(entry) or _is_toa5(entry):
            found.append(entry)


def _dangling(link: Path) -> str:
    """Why the symbolic link ``link``, whose target cannot be reached, is not read: a
    link to a folder on a drive not mounted (say) was passed over without a word, as if
    the archive had nothing there (a QA audit)."""
    try:
        target = os.readlink(link)
    except OSError:
        return "a symbolic link whose target cannot be read"
    return f"a symbolic link to {target}, which does not exist"


def _is_toa5(path: Path) -> bool:
    """A ``.dat`` file that starts as a TOA5 table does."""
    if not path.name.lower().endswith(TOA5_SUFFIX):
        return False
    try:
        with path.open("rb") as handle:
            return handle.read(10).startswith(TOA5_MAGICS)
    except OSError:
        return False


def _failed(path: Path, err: ReaderError) -> InputInfo:
    suffix = _suffix(path)
    fmt = Format.ROS2BAG if path.is_dir() else SUFFIXES.get(suffix, Format.CSV)
    message = str(err)
    prefix = f"{path}: "
    if message.startswith(prefix):
        message = message[len(prefix) :]
    info = InputInfo(path, fmt, errors=[message])
    with contextlib.suppress(OSError):
        info.size_bytes, info.sha256 = file_digest(bag_files(path))
    return info


def open_archive(paths: str | Path | Sequence[str | Path], inside: Path | None = None) -> Archive:
    """Open the inputs of one archive.

    A directory that is not a ROS 2 bag stands for the files in it and in its subfolders
    (see :data:`SUFFIXES`) and the ROS 2 bags under it (:func:`_members`). With one
    input in total, any problem raises ReaderError; with several, an input that cannot be
    opened is recorded (and skipped) unless none can be opened. Inputs with relative
    times that overlap are refused while they are read (:class:`Unstitchable`).
    ``inside``: the watcher's INBOX (:attr:`~analyzer.options.RunOptions.inside`):
    nothing is read through a symbolic link leading out of it (an input that is one, or
    a ROS 2 bag with such a file, raises ReaderError; a folder's, skipped, said)."""
    if isinstance(paths, str | Path):
        paths = [paths]
    if not paths:
        raise ReaderError("no input given")
    members: list[Path] = []
    skipped: list[str] = []
    for raw in paths:
        path = Path(raw)
        if not path.exists():
            raise ReaderError(f"{path}: no such file or directory")
        if inside is not None:
            bag = path.is_dir() and is_ros2_bag(path)
            why = bag_link_out(path, inside) if bag else link_out(path, inside)
            if why is not None:
                raise ReaderError(f"{path}: not read: {why}")
        if path.is_dir() and not is_ros2_bag(path):
            found = _members(path, skipped, inside)
            if not found:
                raise ReaderError(
                    f"{path}: the directory holds no input (.mcap, .bag, .db3, .csv, .tsv, "
                    ".csv.gz, TOA5 .dat or ROS 2 bag directories), nor do its subfolders"
                )
            members.extend(found)
        else:
            if path.is_file() and not _suffix(path):
                detect_format(path)  # an explicit file of unknown format is a usage error
            members.append(path)
    # an input given twice (a file and its folder, a shell glob and the file again) is
    # read once: its second copy would be dropped sample by sample as overlapping
    once: dict[Path, Path] = {}
    for member in members:
        first = once.setdefault(member.resolve(), member)
        if first is not member:
            skipped.append(f"{member} given twice: read once")
    members = list(once.values())
    if len(members) == 1:
        return Archive([open_input(members[0])], notes=skipped)
    readers: list[Reader] = []
    failed: list[InputInfo] = []
    for member, opened in zip(members, _open_members(members), strict=True):
        if isinstance(opened, ReaderError):
            failed.append(_failed(member, opened))
        elif opened.info.no_numeric:  # (a member with nothing to analyze: not read, said)
            opened.info.errors.insert(0, opened.info.no_numeric)
            failed.append(opened.info)
        else:
            readers.append(opened)
    readers = _read_once(readers, skipped)
    if not readers:
        raise ReaderError(
            f"none of the {len(members)} inputs can be read; first: {failed[0].path}: "
            f"{failed[0].errors[0]}"
        )
    _one_clock(readers)
    return Archive(readers, failed, skipped)


def _read_once(readers: Sequence[Reader], skipped: list[str]) -> list[Reader]:
    """``readers`` without those whose file holds the same bytes as an earlier one's (a
    file copied under another name), each said in ``skipped``: its samples would all be
    dropped as overlapping the first's, five warnings that never said why. (The same
    recording in another format is found by its values: :class:`~analyzer.selection.
    TwinInputNote`.)"""
    first: dict[tuple[int, str], Path] = {}
    kept: list[Reader] = []
    for reader in readers:
        info = reader.info
        if not info.sha256 or not info.size_bytes:
            kept.append(reader)
            continue
        seen = first.setdefault((info.size_bytes, info.sha256), info.path)
        if seen == info.path:
            kept.append(reader)
            continue
        why = "the first of the two by file name" if str(seen) < str(info.path) else "given first"
        skipped.append(
            f"{info.path} holds the same bytes as {seen} (a copy of the file): read once, "
            f"as {seen} ({why})"
        )
    return kept


def _one_clock(readers: Sequence[Reader]) -> None:
    """Inputs with relative times (seconds from their start: a CSV without dates) and
    inputs with Unix times cannot be stitched on one clock: the error said "a timestamp
    lies far from the others (an outlier, or a wrong unit)"."""
    relative = next((r for r in readers if not r.info.absolute_time), None)
    if relative is None:
        return
    for r in readers:
        if r.info.absolute_time:
            start = r.start_ns()
            if start is not None and plausible_epoch(start):
                raise ReaderError(
                    f"{relative.info.path} has relative times (seconds from its start) and "
                    f"{r.info.path} Unix times (UTC): one archive needs one clock; analyze "
                    "them apart"
                )

"""Which archives in a drop folder are ready to analyze (the discovery half of
``analyzer watch``).

:func:`ready_batches` is shaped like watchfiles' ``watch``: a generator of debounced
batches. Each batch lists the archives that became *ready* since the previous one:

* **Archives.** Every entry directly in INBOX is one archive: a file, a ROS 2 bag
  directory, or a directory of files forming one archive (contract: "a directory holding
  several such files"). With ``group_by`` the entries whose names give the same value for
  the regex's first group form one archive named by that value (for example
  ``(\\d{8}T\\d{2})``: one archive per hour). Hidden and temporary names are ignored: a
  leading ``.``, or a trailing ``.tmp``, ``.part``, ``~``, ``.active`` (``rosbag record``
  writes ``NAME.bag.active`` and renames it when the bag is closed), ``.filepart``,
  ``.partial``, ``.crdownload``, ``.download``, ``.swp`` or ``.swx``
  (:data:`IGNORED_SUFFIXES`, any case), as are sqlite sidecars (``-journal``, ``-wal``,
  ``-shm``).
* **Stable.** The (relative path, size, mtime) of every file of the archive has not
  changed for ``settle`` seconds, measured on the monotonic clock by observing it (an old
  mtime alone is not trusted: network file systems and copies that preserve times lie).
* **Complete**, where the format says so (:func:`incomplete_reason`): a file that holds
  only the beginning of an MCAP's, ROS 1 bag's or sqlite file's opening magic is not; an
  MCAP file has its magic at both ends; a ROS 1 bag has an index (``index_pos`` in the bag
  header is not 0 and the file extends past it); a ROS 2 bag directory has its
  ``metadata.yaml``, the storage files it lists (by name in the folder, as the reader
  opens them), none with a sqlite journal, and a sqlite file is as long as its header says
  (:func:`sqlite_unfinished`); a CSV file (``.gz`` too) has a data row under its header
  line. An archive that is stable but still looks unfinished after ``incomplete_timeout``
  seconds (a recorder that died, a truncated copy) is yielded anyway with the reason, so
  that it ends up with an error record instead of waiting forever.

Not archives, and not readable: FIFOs, sockets and devices (or links to them) are
ignored and never opened (opening a FIFO blocks until a writer comes, deaf to signals),
said once. An archive that cannot be read (a dangling symbolic link, permission denied)
is handed on once per reason with :attr:`ReadyArchive.unreadable` set (to be counted and
skipped, so that ``once`` ends) and looked at again whenever it is listed or changes.
An archive that looks unfinished is not waited for when the caller knows it already
(``known``: recorded with this content). One that changes soon after it was handed on as
complete (a writer pausing longer than ``settle``) gets twice the settle time, up to
:data:`MAX_SETTLE_S` (:meth:`InboxTracker.settle_of`).

Changes are noticed through file-system events (``watchdog``: inotify, FSEvents, kqueue,
with a full rescan every :data:`RESCAN_S` seconds in case events were dropped) or, with
``poll`` or where events are unavailable, by rescanning the folder every ``poll``
seconds. An archive is yielded again when its content changes after it was yielded.
"""

from __future__ import annotations

import errno
import logging
import os
import queue
import re
import stat
import struct
import threading
import time
import zlib
from collections.abc import Callable, Generator, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from analyzer.errors import counted
from analyzer.readers import SUFFIXES, Format, skipped_folder
from analyzer.readers._common import (
    LINK_LOOP,
    bag_listed_files,
    link_out,
    open_inside,
    special_kind,
)
from analyzer.timeutil import spoken_duration

log = logging.getLogger("analyzer.watch")

Signature = tuple[tuple[str, int, int], ...]
"""(path relative to INBOX, size, mtime_ns) of every file of an archive, sorted."""

IGNORED_SUFFIXES = (
    ".tmp",
    ".part",
    "~",
    ".active",
    ".filepart",  # WinSCP's upload, renamed when complete
    ".partial",
    ".crdownload",  # Chrome's download
    ".download",  # Safari's download (a folder)
    ".swp",  # vim's swap file, where 'directory' puts it outside the file's folder
    ".swx",
)
"""Endings of names of files still being written under a temporary name (compared
ignoring case: a Windows share's ``X.TMP``). None is a format the analyzer reads, and an
upload that stalled longer than ``--settle`` was analyzed as an unknown format, and
moved to ``--failed`` under the uploader's hands."""
SQLITE_SIDECARS = ("-journal", "-wal", "-shm")
MCAP_MAGIC = b"\x89MCAP0\r\n"
WRITING = "(still being written?)"
"""The end of the reasons of a file whose format says it is not closed yet."""
ROS1_MAGIC = b"#ROSBAG V2.0\n"
SQLITE_MAGIC = b"SQLite format 3\x00"
SQLITE_HEADER = 100
"""Bytes of a sqlite database's header."""
CSV_SUFFIXES = tuple(s for s, f in SUFFIXES.items() if f is Format.CSV)
CSV_HEAD = 1 << 16
"""Bytes at the start of a CSV file (inflated, of a ``.gz``) looked at for a data row."""
INCOMPLETE_TIMEOUT_S = 600.0
"""An archive stable this long but still structurally unfinished is handed on anyway."""
MAX_SETTLE_S = 120.0
"""The longest an archive's settle time grows to (or ``settle``, if that is longer):
each time it changes soon after it was taken as complete, it doubles
(:meth:`InboxTracker.settle_of`)."""
RESCAN_S = 30.0
"""With file events, the whole folder is still rescanned this often (dropped events)."""
FALLBACK_POLL_S = 1.0
"""Polling interval where file events are unavailable and ``poll`` was not given."""
SOON_SETTLES = 4
"""A change within this many settle times of an archive being handed on as complete
means it was not complete (a writer pausing): its settle time doubles
(:meth:`InboxTracker.settle_of`), and ``--done``/``--failed`` do not move it before that
window is over (:attr:`ReadyArchive.hold_until`)."""


@dataclass(frozen=True, slots=True)
class ReadyArchive:
    """One archive that is ready: its name (entry name or ``group_by`` value), its member
    paths (sorted) and the signature it had when found stable."""

    name: str
    paths: tuple[Path, ...]
    signature: Signature
    incomplete: str | None = None
    """Why it still looks unfinished, when handed on after ``incomplete_timeout``."""
    unreadable: str | None = None
    """Why it cannot be read (a dangling symbolic link, permission denied): such an
    archive is handed on once per reason, to be counted and skipped, not analyzed; the
    tracker looks at it again when it changes (:func:`unreadable_reason`)."""
    hold_until: float = 0.0
    """``time.monotonic()`` until which a change would still show that the archive was
    not complete (:data:`SOON_SETTLES` settle times after it was handed on): it is not
    moved out of INBOX before then. A writer that paused longer than the settle time
    and goes on writing through an open descriptor wrote the rest into the moved file,
    whose first part alone was analyzed and recorded."""


def ignored(name: str) -> bool:
    """Hidden, temporary and sidecar names, never archives on their own."""
    folded = name.lower()
    return name.startswith(".") or folded.endswith(IGNORED_SUFFIXES + SQLITE_SIDECARS)


# --------------------------------------------------------------------------- signatures


def _files(path: Path, real_root: Path, away: Callable[[Path, str], None] | None) -> list[Path]:
    """The files of the archive entry ``path`` (itself, or those in its folders), but
    for the links leading out of ``real_root`` (INBOX's real path: never read, their
    targets not part of the archive), each handed to ``away`` with the reason."""
    if not path.is_dir():
        return [path]
    files = []
    for p in sorted(path.rglob("*")):  # (links to folders not followed)
        if not p.is_file():
            continue
        if (why := link_out(p, real_root, "INBOX")) is not None:
            if away is not None:
                away(p, why)
            continue
        files.append(p)
    return files


def signature(
    paths: Iterable[Path], root: Path, away: Callable[[Path, str], None] | None = None
) -> Signature:
    """The signature of the files under ``paths``; raises OSError if one vanishes. A
    file of a folder that is a symbolic link leading out of ``root`` is not part of it
    (:func:`~analyzer.readers._common.link_out`; handed to ``away``)."""
    sig = []
    real_root = root.resolve()
    for path in paths:
        for f in _files(path, real_root, away):
            st = f.stat()
            sig.append((f.relative_to(root).as_posix(), st.st_size, st.st_mtime_ns))
    return tuple(sorted(sig))


# --------------------------------------------------------------------------- completeness


def _read_ends(path: Path, n: int, root: Path | None = None) -> tuple[bytes, bytes, int]:
    # O_NONBLOCK: a FIFO that took a file's place opens at once instead of waiting for a
    # writer (forever, deaf to signals); it is then refused as not a regular file. With
    # ``root`` (INBOX's real path), a file that is (or became) a link leading out of it
    # is not opened (:func:`~analyzer.readers._common.open_inside`: O_NOFOLLOW)
    plain = os.O_RDONLY | os.O_NONBLOCK
    fd = os.open(path, plain) if root is None else open_inside(path, root)
    with os.fdopen(fd, "rb") as f:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise OSError(errno.EINVAL, "not a regular file", str(path))
        size = st.st_size
        head = f.read(n)
        if size > n:
            f.seek(max(0, size - n))
        tail = f.read(n) if size > n else head
    return head, tail, size


def ros1_index_pos(header: bytes) -> int | None:
    """``index_pos`` of a ROS 1 bag from its first bytes (magic + bag header record), or
    None if it cannot be found there."""
    if not header.startswith(ROS1_MAGIC):
        return None
    pos = len(ROS1_MAGIC)
    if len(header) < pos + 4:
        return None
    (header_len,) = struct.unpack_from("<I", header, pos)
    pos += 4
    end = min(pos + header_len, len(header))
    while pos + 4 <= end:
        (field_len,) = struct.unpack_from("<I", header, pos)
        pos += 4
        entry = header[pos : pos + field_len]
        pos += field_len
        name, sep, value = entry.partition(b"=")
        if sep and name == b"index_pos" and len(value) == 8:
            return int(struct.unpack("<Q", value)[0])
    return None


def _file_incomplete(path: Path, root: Path | None = None) -> str | None:
    csv = path.name.lower().endswith(CSV_SUFFIXES)
    head, tail, size = _read_ends(path, CSV_HEAD if csv else 4096 + 64, root)
    if size == 0:
        return "empty file"
    if not csv and (begun := _magic_begun(head)) is not None:
        magic, name = begun
        return (
            f"{name} file with only the first {size} of the {len(magic)} bytes of its "
            f"opening magic {WRITING}"
        )
    if head.startswith(MCAP_MAGIC):
        if size < 2 * len(MCAP_MAGIC) or not tail.endswith(MCAP_MAGIC):
            return f"MCAP file without its closing magic {WRITING}"
        return None
    if head.startswith(ROS1_MAGIC):
        index_pos = ros1_index_pos(head)
        if index_pos is None:
            return "ROS 1 bag header not complete"
        if index_pos == 0:
            return "ROS 1 bag not indexed yet (index_pos = 0)"
        if size <= index_pos:
            return f"ROS 1 bag ends at byte {size}, before its index at {index_pos}"
        return None
    if head.startswith(SQLITE_MAGIC) or path.suffix.lower() == ".db3":
        busy = [s for s in SQLITE_SIDECARS if path.with_name(path.name + s).exists()]
        if busy:
            return f"sqlite file still open for writing ({path.name}{busy[0]} present)"
        if head.startswith(SQLITE_MAGIC):
            return sqlite_unfinished(head, size)
    if csv and not _csv_has_row(head, size, gz=path.name.lower().endswith(".gz")):
        return "a header line only (no data row yet)"
    return None


OPENING_MAGICS = ((MCAP_MAGIC, "MCAP"), (ROS1_MAGIC, "ROS 1 bag"), (SQLITE_MAGIC, "SQLite"))
"""The first bytes of the formats whose structure says when they are complete."""


def _magic_begun(head: bytes) -> tuple[bytes, str] | None:
    """The opening magic, and its format's name, that ``head`` (a whole file, not a CSV)
    is the beginning of and shorter than, or None: a recorder that has opened its file
    and written its first bytes (an MCAP writer's ``\\x89MCA``), which was taken for a
    complete file of unknown format, analyzed at once and moved to ``--failed`` under the
    writer's hands."""
    for magic, name in OPENING_MAGICS:
        if len(head) < len(magic) and magic.startswith(head):
            return magic, name
    return None


def _csv_has_row(head: bytes, size: int, gz: bool) -> bool:
    """Whether a CSV/TSV file of ``size`` bytes starting with ``head`` (inflated, of a
    ``.gz``) has a data row there: a second non-blank line ended by a newline, under
    the header (a logger writes its header first and its rows later). A file whose start
    cannot tell (a header longer than ``head``, a damaged ``.gz``) counts as having one:
    the analysis says what is wrong with it."""
    try:
        text = _inflated_start(head) if gz else head
    except zlib.error:
        return True
    return _has_row(text) or size > len(head)


def _has_row(text: bytes) -> bool:
    lines = text.split(b"\n")[:-1]  # (the last piece is not ended by a newline)
    return sum(1 for line in lines if line.strip()) >= 2


def _inflated_start(data: bytes) -> bytes:
    """The first :data:`CSV_HEAD` bytes inflated from gzip ``data`` (member after
    member: a logger may append one per flush), or what ``data`` holds of them."""
    out = b""
    while data and len(out) < CSV_HEAD:
        member = zlib.decompressobj(wbits=31)
        out += member.decompress(data, CSV_HEAD - len(out))
        if not member.eof:
            break
        data = member.unused_data
    return out


def sqlite_unfinished(head: bytes, size: int) -> str | None:
    """Why a sqlite database of ``size`` bytes whose file starts with ``head`` is
    unfinished (a copy still under way), or None. A complete, checkpointed database is
    as long as its header says: the in-header database size in pages (big-endian uint32
    at offset 28) times the page size (uint16 at offset 16, 1 meaning 65536). That size
    is valid only when it is not 0 and the change counter (offset 24) equals the
    version-valid-for number (offset 92); else nothing is said (sqlite.org/fileformat2.html,
    "In-header database size")."""
    if size < SQLITE_HEADER:
        return f"sqlite database unfinished: {counted(size, 'byte')}, less than its header"
    (page_size,) = struct.unpack_from(">H", head, 16)
    page_size = 65536 if page_size == 1 else page_size
    counter, pages = struct.unpack_from(">II", head, 24)
    (valid_for,) = struct.unpack_from(">I", head, 92)
    if pages == 0 or counter != valid_for or page_size < 512 or page_size & (page_size - 1):
        return None
    if size < pages * page_size:
        return (
            f"sqlite database unfinished: {size} of the {pages * page_size} bytes its header "
            "gives (still being copied?)"
        )
    return None


def _looks_like_bag(directory: Path, files: Sequence[Path]) -> bool:
    """A directory without metadata.yaml that a ROS 2 recorder is filling: storage
    files named ``<dir>.db3`` / ``<dir>_<N>.mcap`` (rosbag2, rosbags) or any ``.db3``."""
    pattern = re.compile(rf"{re.escape(directory.name)}(_\d+)?\.(db3|mcap)(\.zstd)?")
    return any(f.suffix == ".db3" or pattern.fullmatch(f.name) for f in files)


SPLIT_NAME = re.compile(r"(.+)_(\d+)\.(db3|mcap)(\.zstd)?")
"""A ROS 2 recorder's storage file: ``<bag>_<N>.db3`` / ``.mcap``, N counting its splits."""


def _unlisted_split(path: Path, listed: Sequence[str], files: Sequence[Path]) -> str | None:
    """The first storage file in the bag folder ``path`` that is a split of its recording
    (named ``<stem>_<N>`` as a listed file, or as the folder) but that metadata.yaml does
    not list, or None. rosbag2 rewrites metadata.yaml at each split while it writes the
    next file, so such a file is a recording under way; a file of another name stays what
    the reader says it is (not read, for it may belong to another recording)."""
    stems = {path.name} | {m.group(1) for name in listed if (m := SPLIT_NAME.fullmatch(name))}
    names = set(listed)
    for f in files:
        m = SPLIT_NAME.fullmatch(f.name)
        if m is not None and m.group(1) in stems and f.name not in names:
            return f.name
    return None


def incomplete_reason(
    path: Path, _seen: set[Path] | None = None, root: Path | None = None
) -> str | None:
    """Why the archive member ``path`` looks unfinished, or None when it looks complete.

    Only the structure is checked here (a few bytes at each end); stability is the
    caller's business. A file of unknown or damaged format is "complete": the analysis
    will say what is wrong with it. With ``root`` (INBOX's real path), what leads out of
    it through a symbolic link is not looked at (:func:`~analyzer.readers._common.
    link_out`), and files are opened with ``O_NOFOLLOW``."""
    if not path.is_dir():
        return _file_incomplete(path, root)

    def inside(p: Path) -> bool:
        return root is None or link_out(p, root) is None

    files = [
        f
        for f in sorted(path.iterdir())
        if f.is_file() and not f.name.startswith(".") and inside(f)
    ]
    metadata = path / "metadata.yaml"
    if metadata.is_file() and inside(metadata):
        listed = bag_listed_files(path)  # (by name, as the reader opens them)
        if listed is None:
            return "metadata.yaml not readable yet"
        for name in listed:
            if not (path / name).is_file():
                return f"storage file {name} listed in metadata.yaml is missing"
        if (split := _unlisted_split(path, listed, files)) is not None:
            return f"storage file {split} not in metadata.yaml yet (still recording?)"
        for f in files:
            if f.name != "metadata.yaml" and (reason := _file_incomplete(f, root)):
                return f"{f.name}: {reason}"
        return None
    subfolders = [
        p for p in sorted(path.iterdir()) if p.is_dir() and not p.name.startswith(".") and inside(p)
    ]
    if not files and not subfolders:
        return "empty directory"  # still being filled
    if files and _looks_like_bag(path, files):
        return "ROS 2 bag without metadata.yaml (still recording?)"
    for f in files:
        if not ignored(f.name) and (reason := _file_incomplete(f, root)):
            return f"{f.name}: {reason}"
    # the analysis reads the subfolders too (a folder of day folders): their files are
    # checked alike, an empty one is no sign of a copy under way; as the readers walk
    # them (analyzer.readers._members): a folder once, however many links lead to it
    # (two links to a parent made this walk exponential), backup folders not at all
    seen = {path.resolve()} if _seen is None else _seen
    for sub in subfolders:
        if skipped_folder(sub, seen) is not None:
            continue
        reason = incomplete_reason(sub, seen, root)
        if reason is not None and reason != "empty directory":
            return f"{sub.name}/{reason}" if ":" in reason else f"{sub.name}: {reason}"
    return None


def unreadable_reason(paths: Iterable[Path], err: OSError, root: Path) -> str | None:
    """Why an archive whose ``signature`` or structure check raised ``err`` cannot be
    read (``dangling symbolic link (to X)``, ``x.mcap: Permission denied``), or None
    when a member merely vanished meanwhile (look again)."""
    for path in paths:
        if os.path.islink(path) and not os.path.exists(path):
            return f"dangling symbolic link (to {os.readlink(path)})"
    if isinstance(err, FileNotFoundError):
        return None
    where = ""
    if err.filename:
        name = Path(os.fsdecode(err.filename))
        where = f"{name.relative_to(root) if name.is_relative_to(root) else name}: "
    return f"{where}{err.strerror or err}"


# --------------------------------------------------------------------------- tracking


@dataclass(slots=True)
class _Track:
    signature: Signature
    since: float
    yielded: Signature | None = None
    checked: Signature | None = None
    reason: str | None = None
    problem: str | None = None
    """Why it cannot be read, once said (:func:`unreadable_reason`); it is then handled
    (for ``once``) and looked at again whenever it is listed or changes."""
    known: bool | None = False
    """Unfinished-looking but recorded already with this content: not waited for (None:
    not known yet, asked again at the next step)."""
    told: str | None = None
    """The unfinished reason last said, without its numbers (:func:`_gist`): each is said
    once, not again at every pause of a slow copy whose byte counts moved on."""


@dataclass(slots=True)
class InboxTracker:
    """The bookkeeping behind :func:`ready_batches`, driven by an explicit clock so that
    it can be tested step by step: :meth:`touch` the names that changed (or
    :meth:`rescan`), then :meth:`step` returns the archives that became ready."""

    inbox: Path
    settle: float
    group_by: re.Pattern[str] | None = None
    exclude: frozenset[str] = frozenset()
    incomplete_timeout: float = INCOMPLETE_TIMEOUT_S
    quiet: bool = False
    """Say nothing (a tracker that only lists the archives: :func:`archive_names`)."""
    known: Callable[[ReadyArchive], bool | None] | None = None
    """Whether an archive is recorded already with its present content (the watcher's
    ledger, looked up by content hash): one that looks unfinished is then handed on at
    once instead of being waited for (it will not be analyzed again anyway). None: not
    known yet (a big archive being hashed off the loop), asked again at the next step."""
    _members: dict[str, set[str]] = field(default_factory=dict)
    _tracks: dict[str, _Track] = field(default_factory=dict)
    _dirty: set[str] = field(default_factory=set)
    once: bool = False
    """``watch --once``: an archive that is only empty (a 0-byte file, an empty folder)
    once stable for its settle time is handed on at once, to be recorded as empty, not
    waited for (:func:`_only_empty`)."""
    _special: set[str] = field(default_factory=set)
    """Entries ignored as FIFOs, sockets or devices, each said once."""
    _loops: set[str] = field(default_factory=set)
    """Entries ignored as symbolic links not followed (:meth:`_is_loop`: to INBOX or a
    folder above it, out of INBOX, a loop), each said once."""
    _away: set[str] = field(default_factory=set)
    """Files of folder archives not read as links out of INBOX (by their path relative
    to it: :meth:`_member_away`), each said once."""
    _settles: dict[str, float] = field(default_factory=dict)
    """Archives whose settle time grew beyond ``settle`` (:meth:`settle_of`)."""
    _taken: dict[str, float] = field(default_factory=dict)
    """When each archive was last handed on as complete (kept when it goes away, as
    ``--done`` moves it: a writer still at it then makes a new file of that name)."""
    gone: bool = False
    """INBOX itself was missing at the last look (:meth:`rescan`): said once when it
    goes, once when it comes back."""
    back: Callable[[], None] | None = None
    """Called when INBOX comes back (the watcher locks the new folder)."""

    def key(self, name: str) -> str | None:
        """The archive an INBOX entry belongs to, or None if the entry is ignored."""
        if ignored(name) or name in self.exclude:
            return None
        if self.group_by is not None:
            m = self.group_by.search(name)
            if m is not None and m.group(1):
                return m.group(1)
        return name

    def _is_special(self, name: str) -> bool:
        """Whether INBOX entry ``name`` is a FIFO, socket or device (or a link to one):
        never an archive, never opened (opening a FIFO blocks); said once."""
        kind = special_kind(self.inbox / name)
        if kind is None:
            self._special.discard(name)
            return False
        if name not in self._special and not self.quiet:
            log.warning("%s: ignored: not a regular file or a directory (%s)", name, kind)
        self._special.add(name)
        return True

    def _is_loop(self, name: str) -> bool:
        """Whether INBOX entry ``name`` is a symbolic link not followed: to INBOX itself
        or to a folder above it (``loop -> ../inbox``: its folder holds INBOX's archives
        again; it was waited on as one, for an empty file it reached through the link),
        to anything else outside INBOX (``passwd.csv -> /etc/passwd``: whoever may drop
        files would have the watcher read, and publish in its report and index, what
        only the watcher's account may read), or a link loop. Such an entry is not an
        archive: never read, never moved; said once. A link to a file or folder inside
        INBOX is followed (read as what it leads to; ``--done`` moves the link)."""
        path = self.inbox / name
        if not path.is_symlink():
            self._loops.discard(name)
            return False
        inbox = self.inbox.resolve()
        try:
            target = path.resolve()
        except (OSError, RuntimeError):
            target = None
        if target is not None and (target == inbox or target in inbox.parents):
            why = f"a link to {target}, which holds INBOX itself"
        else:
            out = link_out(path, inbox, "INBOX")
            if out is None:
                self._loops.discard(name)
                return False
            why = out if out == LINK_LOOP else f"{out}: never read nor moved"
        if name not in self._loops and not self.quiet:
            log.warning("%s: ignored: %s", name, why)
        self._loops.add(name)
        return True

    def _listed(self, entry: os.DirEntry[str]) -> bool:
        """Whether the INBOX entry ``entry`` may be an archive's member: not a link that
        is not followed (:meth:`_is_loop`), nor a FIFO, socket or device
        (:meth:`_is_special`). One that cannot be looked at is not, said once: it was
        the ``OSError`` of the whole listing, which stopped the watcher."""
        try:
            if entry.is_symlink() and self._is_loop(entry.name):
                return False
            # (d_type: a stat only for links and special files)
            return entry.is_file() or entry.is_dir() or not self._is_special(entry.name)
        except OSError as err:
            if entry.name not in self._loops and not self.quiet:
                log.warning("%s: ignored: cannot look at it (%s)", entry.name, err.strerror or err)
            self._loops.add(entry.name)
            return False

    def _member_away(self, path: Path, why: str) -> None:
        """A file of a folder archive not read, as a link out of INBOX; said once."""
        rel = path.relative_to(self.inbox).as_posix()
        if rel not in self._away and not self.quiet:
            log.warning("%s: ignored: %s: never read nor moved", rel, why)
        self._away.add(rel)

    def rescan(self) -> None:
        """Re-list INBOX (start, polling, and the periodic safety rescan)."""
        try:
            with os.scandir(self.inbox) as entries:
                names = {e.name for e in entries if self._listed(e)}
        except (FileNotFoundError, NotADirectoryError):
            names = set()
            self._inbox_gone(True)
        else:
            self._inbox_gone(False)
        members: dict[str, set[str]] = {}
        for name in names:
            k = self.key(name)
            if k is not None:
                members.setdefault(k, set()).add(name)
        self._dirty.update(self._members.keys() | members.keys())
        self._members = members

    def _inbox_gone(self, gone: bool) -> None:
        """Say when INBOX goes (removed by a clean-up job, a share unmounted) and when
        it comes back, once each, not at every look: before, a watcher whose INBOX was
        removed watched nothing in silence (a QA audit's ux66 item M5)."""
        if gone == self.gone:
            return
        self.gone = gone
        if self.quiet:
            return
        if gone:
            log.warning(
                "INBOX %s is gone (removed, or its share unmounted?); waiting for it to come back",
                self.inbox,
            )
        else:
            log.warning("INBOX %s is back; watching it again", self.inbox)
        if not gone and self.back is not None:
            self.back()

    def touch(self, name: str) -> None:
        """An event about INBOX entry ``name`` (created, modified, moved, deleted)."""
        name = name.removesuffix("-journal").removesuffix("-wal").removesuffix("-shm")
        k = self.key(name)
        if k is None:
            return
        if (
            os.path.lexists(self.inbox / name)
            and not self._is_loop(name)
            and not self._is_special(name)
        ):
            self._members.setdefault(k, set()).add(name)
        else:
            self._members.get(k, set()).discard(name)
        self._dirty.add(k)

    @property
    def keys(self) -> set[str]:
        return {k for k, v in self._members.items() if v}

    def pending(self) -> set[str]:
        """Archives seen but not (re)yielded in their current state."""
        return {k for k, t in self._tracks.items() if t.yielded != t.signature}

    def done(self, keys: Iterable[str]) -> bool:
        """Whether each of ``keys`` has been yielded in its current state or is gone."""
        for k in keys:
            if not self._members.get(k):
                continue
            track = self._tracks.get(k)
            if track is None or (track.yielded != track.signature and track.problem is None):
                return False
        return True

    def again(self, key: str, sig: Signature, now: float) -> None:
        """Archive ``key``, handed on as ``sig``, was not taken as such: the consumer
        found INBOX no longer holding it so (its result discarded, its move refused), a
        change this tracker may never see (a ``--group-by`` member that came and went
        between two looks, the group as it was handed on again by the time it is
        looked at). It is handed on again once it has been stable for its settle time
        from ``now``, even as ``sig``; if it is gone by then, it is dropped. Before,
        ``sig`` counted as handed on: the archive was neither analyzed nor moved again
        while the watcher ran (``once``: it ended without it)."""
        track = self._tracks.get(key)
        if track is None or track.yielded != sig:  # (a later state handed on meanwhile)
            return
        track.yielded, track.since = None, max(track.since, now)
        self._dirty.add(key)

    def settle_of(self, key: str) -> float:
        """How long archive ``key`` must be stable: ``settle``, doubled each time it
        changed soon (within 4 settle times) after it was handed on as complete (a
        writer that pauses longer than the settle time: a logger flushing every few
        seconds, a stalled copy), up to :data:`MAX_SETTLE_S`."""
        return self._settles.get(key, self.settle)

    def _changed(self, key: str, now: float) -> None:
        """Archive ``key`` appeared or changed at ``now``: if that is soon after it was
        handed on as complete, it was not complete; it gets a longer settle time."""
        taken = self._taken.pop(key, None)
        settle = self.settle_of(key)
        if taken is None or now - taken >= SOON_SETTLES * settle:
            return
        longer = min(2 * settle, max(self.settle, MAX_SETTLE_S))
        if longer > settle:
            self._settles[key] = longer
            log.info(
                "%s: changed %.1f s after it was taken as complete (a writer pausing longer "
                "than the settle time?); it now has to be stable for %g s",
                key,
                now - taken,
                longer,
            )

    def _known(self, archive: ReadyArchive) -> bool | None:
        if self.known is None:
            return False
        try:
            return self.known(archive)
        except OSError:  # (it is being rewritten, or gone: look again when it settles)
            return False

    def step(self, now: float) -> list[ReadyArchive]:
        check = self._dirty | self.pending()
        self._dirty = set()
        ready = []
        for k in sorted(check):
            names = sorted(self._members.get(k, ()))
            if not names:
                self._members.pop(k, None)
                self._tracks.pop(k, None)
                continue
            paths = tuple(self.inbox / n for n in names)
            problem = None
            try:
                sig = signature(paths, self.inbox, self._member_away)
            except OSError as err:
                problem = unreadable_reason(paths, err, self.inbox)
                if problem is None:  # a member vanished or changed type under us: look again
                    self._dirty.add(k)
                    continue
                sig = ()
            track = self._tracks.get(k)
            if track is None:
                track = self._tracks[k] = _Track(sig, now)
                self._changed(k, now)
            elif sig != track.signature:
                track.signature, track.since, track.checked = sig, now, None
                self._changed(k, now)
            if now - track.since < self.settle_of(k):
                continue
            if track.yielded == sig and track.problem is None:
                continue
            if problem is None and track.checked != sig:
                track.checked = sig
                try:
                    track.reason = next(
                        (
                            r if p.name == k else f"{p.name}: {r}"
                            for p in paths
                            if (r := incomplete_reason(p, root=self.inbox.resolve()))
                        ),
                        None,
                    )
                except OSError as err:
                    track.checked = None
                    problem = unreadable_reason(paths, err, self.inbox)
                    if problem is None:
                        self._dirty.add(k)
                        continue
                track.known = None if track.reason else False
            if problem is None and track.reason and track.known is None:
                track.known = self._known(ReadyArchive(k, paths, sig, track.reason))
                waits = not (self.once and _only_empty(track.reason))  # (handed on now)
                if waits and track.known is False and _gist(track.reason) != track.told:
                    track.told = _gist(track.reason)
                    if not self.quiet:
                        log.warning(
                            "waiting up to %s (--wait-unfinished) for %s to be complete: %s",
                            spoken_duration(self.incomplete_timeout),
                            k,
                            track.reason,
                        )
            if problem is not None:
                # said once; looked at again whenever listed (rescans) or changed (events)
                track.yielded, track.checked = sig, None
                if problem != track.problem:
                    track.problem = problem
                    log.warning("%s: skipped, cannot read it: %s", k, problem)
                    ready.append(ReadyArchive(k, paths, sig, unreadable=problem))
                continue
            if track.problem is not None:
                track.problem, track.yielded = None, None
            gave_up = now - track.since >= self.incomplete_timeout
            gave_up = gave_up or (self.once and _only_empty(track.reason))
            if track.reason is None or track.known or gave_up:
                track.yielded = sig
                self._taken[k] = now
                hold = now + SOON_SETTLES * self.settle_of(k)
                ready.append(ReadyArchive(k, paths, sig, track.reason, hold_until=hold))
        return ready


def _only_empty(reason: str | None) -> bool:
    """Whether an archive looks unfinished only for being empty: a 0-byte file (or a
    folder's 0-byte member), an empty folder. Under ``--once``, stable for its settle
    time, nothing more is on its way (a copy writes its first bytes at once), and a
    0-byte file held ``watch --once`` for 10 minutes (a QA audit); a truncated MCAP or
    an unindexed bag is still waited for (a copy or a recorder that pauses)."""
    return reason is not None and (
        reason in ("empty file", "empty directory") or reason.endswith(": empty file")
    )


def _gist(reason: str) -> str:
    """An unfinished reason without its numbers (``sqlite database unfinished: # of the #
    bytes...``): a copy that pauses again and again gives the same gist. The reasons of a
    file being written (:data:`WRITING`: the first bytes of an MCAP's opening magic, then
    no closing magic) have one gist per member, so that a logger's file is said once."""
    if reason.endswith(WRITING):
        member, _, _ = reason.rpartition(": ")
        return f"{member}: {WRITING}"
    return re.sub(r"\d+", "#", reason)


def archive_names(
    inbox: Path, group_by: re.Pattern[str] | None = None, exclude: Iterable[str] = ()
) -> set[str]:
    """The archives INBOX holds now, as :func:`ready_batches` groups its entries."""
    tracker = InboxTracker(inbox, 0.0, group_by, frozenset(exclude), quiet=True)
    tracker.rescan()
    return tracker.keys


def archive_members(
    inbox: Path, group_by: re.Pattern[str] | None = None, exclude: Iterable[str] = ()
) -> dict[str, tuple[Path, ...]]:
    """The archives INBOX holds now and their member paths (sorted, as
    :attr:`ReadyArchive.paths`), as :func:`ready_batches` groups its entries: one
    listing of INBOX for all of them (:func:`archive_paths` lists it for one)."""
    tracker = InboxTracker(inbox, 0.0, group_by, frozenset(exclude), quiet=True)
    tracker.rescan()
    return {
        k: tuple(inbox / n for n in sorted(names)) for k, names in tracker._members.items() if names
    }


def archive_paths(
    inbox: Path, name: str, group_by: re.Pattern[str] | None = None, exclude: Iterable[str] = ()
) -> tuple[Path, ...]:
    """The member paths INBOX holds now of archive ``name``, as :func:`ready_batches`
    groups its entries (sorted, as :attr:`ReadyArchive.paths`): with ``group_by``, a
    member dropped since the archive was found is among them. Asked two or three times
    per archive: only the entries whose names hold ``name`` are grouped (an archive's
    name is part of each member's, the group's text), the others skipped by a substring
    test; grouping every entry (:meth:`InboxTracker.rescan`) took 30-50 ms at 10 000
    entries, each time."""
    tracker = InboxTracker(inbox, 0.0, group_by, frozenset(exclude), quiet=True)
    try:
        with os.scandir(inbox) as entries:
            names = [e.name for e in entries if name in e.name and tracker._listed(e)]
    except FileNotFoundError:
        return ()
    return tuple(inbox / n for n in sorted(names) if tracker.key(n) == name)


# --------------------------------------------------------------------------- events


def _start_observer(inbox: Path, sink: queue.SimpleQueue[str]) -> Any:
    """A started watchdog observer feeding the names of changed INBOX entries into
    ``sink``; raises whatever the platform raises when events are unavailable."""
    from watchdog.events import FileSystemEvent, FileSystemEventHandler
    from watchdog.observers import Observer

    root = os.path.abspath(inbox)
    quiet = {"opened", "closed_no_write"}  # reads (ours included) change nothing

    class Handler(FileSystemEventHandler):
        def on_any_event(self, event: FileSystemEvent) -> None:
            if event.event_type in quiet:
                return
            for raw in (event.src_path, getattr(event, "dest_path", "")):
                p = os.fsdecode(raw)
                if not p:
                    continue
                rel = os.path.relpath(p, root)
                if rel != "." and not rel.startswith(".."):
                    sink.put(rel.split(os.sep, 1)[0])

    observer = Observer()
    observer.schedule(Handler(), root, recursive=True)
    observer.daemon = True
    observer.start()
    return observer


def ready_batches(
    inbox: Path,
    *,
    settle: float = 2.0,
    poll: float | None = None,
    group_by: re.Pattern[str] | None = None,
    exclude: Iterable[str] = (),
    stop: threading.Event | None = None,
    once: bool = False,
    incomplete_timeout: float = INCOMPLETE_TIMEOUT_S,
    yield_on_timeout: bool = False,
    known: Callable[[ReadyArchive], bool | None] | None = None,
    busy: Callable[[], bool] | None = None,
    pause: Callable[[float], object] | None = None,
    again: Callable[[], Iterable[tuple[str, Signature]]] | None = None,
    back: Callable[[], None] | None = None,
) -> Generator[list[ReadyArchive], None, None]:
    """Batches of archives of ``inbox`` that became ready (see the module doc).

    ``poll``: rescan every ``poll`` seconds instead of using file events. ``exclude``:
    entry names of INBOX that are never archives (output folders inside it). ``stop``:
    the generator returns soon after it is set. ``once``: return when every archive
    present at the start has been yielded (or has gone) and ``busy()`` says the
    consumer is through with them, after one more look at INBOX: an archive that
    changed while the consumer analyzed it (a writer pausing longer than ``settle``)
    is yielded again once it has settled. ``yield_on_timeout``: yield an empty batch
    after every idle tick (about 0.1 s) so the consumer can do other work. ``known``:
    :attr:`InboxTracker.known`. ``pause``: how a tick is waited (default
    ``stop.wait``; the consumer may return sooner, when its own work ends).
    ``again``: the archives (name, signature as handed on) that the consumer hands
    back since it last asked (:meth:`InboxTracker.again`); ``once`` waits for them too.
    ``back``: called when INBOX, gone, is there again (:attr:`InboxTracker.back`).
    """
    stop = stop or threading.Event()
    tracker = InboxTracker(
        inbox,
        settle,
        group_by,
        frozenset(exclude),
        incomplete_timeout,
        known=known,
        once=once,
        back=back,
    )
    tick = min(0.25, max(0.02, settle / 4))
    sink: queue.SimpleQueue[str] = queue.SimpleQueue()
    observer = None
    if poll is None:
        try:
            observer = _start_observer(inbox, sink)
        except Exception as err:  # noqa: BLE001 - any failure means "no events here"
            poll = FALLBACK_POLL_S
            log.warning("file events unavailable (%s); polling every %g s", err, poll)
    interval = poll if poll is not None else RESCAN_S
    try:
        tracker.rescan()
        initial = tracker.keys
        next_scan = time.monotonic() + interval
        next_step = 0.0
        last_look = False
        while not stop.is_set():
            now = time.monotonic()
            while True:
                try:
                    tracker.touch(sink.get_nowait())
                except queue.Empty:
                    break
            for key, sig in again() if again is not None else ():
                tracker.again(key, sig, now)
                initial.add(key)
            if now >= next_scan:
                tracker.rescan()
                next_scan = now + interval
            batch: list[ReadyArchive] = []
            if now >= next_step:
                batch = tracker.step(now)
                next_step = now + (poll if poll is not None else 0.0)
            if batch or yield_on_timeout:
                yield batch
            if once and tracker.done(initial) and not (busy is not None and busy()):
                if last_look:
                    return
                tracker.rescan()  # (a change its events have not told yet)
                next_step, last_look = 0.0, True
                continue
            last_look = False
            (pause or stop.wait)(tick)
    finally:
        if observer is not None:
            observer.stop()
            observer.join(timeout=5)


__all__ = [
    "INCOMPLETE_TIMEOUT_S",
    "MAX_SETTLE_S",
    "SOON_SETTLES",
    "InboxTracker",
    "ReadyArchive",
    "archive_members",
    "archive_names",
    "Signature",
    "ignored",
    "incomplete_reason",
    "ready_batches",
    "ros1_index_pos",
    "signature",
    "special_kind",
    "sqlite_unfinished",
    "unreadable_reason",
]

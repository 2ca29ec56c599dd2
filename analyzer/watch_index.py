"""What ``analyzer watch`` keeps in REPORTS: the lock, the state file and the index.

* ``REPORTS/.lock``: ``fcntl.flock``-ed for the watcher's lifetime; it holds the pid of the
  watcher for the error message a second watcher prints (the lock itself, not the pid,
  is what counts, so a stale pid after a crash is harmless).
* ``REPORTS/.watch-state.json``: one record per archive name: the sha256 of its content,
  the (path, size, mtime) signature it had, and the result. Written atomically after
  every archive (before its files are moved); this is what makes the watcher process
  each content once across restarts. An earlier content of a name keeps its record under
  another name, and its report folder where it was (:meth:`Ledger.keep_aside`).
* ``REPORTS/index.json`` and ``REPORTS/index.html``: every archive with its verdict,
  faulty sensors and a link to its report (or error), newest first. Views of the state,
  rewritten (atomically) after an archive, or, while archives end in quick succession,
  at most every :data:`VIEW_INTERVAL_S` seconds (:meth:`Ledger.refresh_views`): a year
  of hourly files is 8760 lines, and rewriting both views after each of a burst of
  archives would cost the watcher more than the bookkeeping of the state itself.
* ``REPORTS/<archive>/``: ``report.html`` + ``findings.json`` (+ ``corrected.csv`` with
  ``--corrected``), or ``error.txt``. Written
  into a hidden temporary directory that is renamed into place (:func:`publish`).
"""

from __future__ import annotations

import bisect
import contextlib
import fcntl
import hashlib
import itertools
import json
import logging
import math
import os
import shutil
import time
import uuid
from collections.abc import Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, fields, replace
from enum import StrEnum
from pathlib import Path
from types import TracebackType
from typing import Any, Self
from urllib.parse import quote

from analyzer import __version__
from analyzer.errors import UsageError, clipped_line, counted
from analyzer.outdir import write_atomic
from analyzer.timeutil import iso_utc, parse_time
from analyzer.types import NS_PER_S

log = logging.getLogger("analyzer.watch")

STATE_SCHEMA = "analyzer.watch-state/1"
INDEX_SCHEMA = "analyzer.watch-index/1"
STATE_FILE = ".watch-state.json"
LOCK_FILE = ".lock"
TMP_PREFIX = ".tmp-"
OLD_PREFIX = ".old-"
RESERVED = frozenset({"index.html", "index.json"})
VIEW_INTERVAL_S = 5.0
"""Least time between two rewrites of ``index.json`` and ``index.html`` while archives end
in quick succession; the views are rewritten at once when the watcher has nothing left
to do, and when it stops."""
VIEW_SHARE = 0.02
"""Largest share of the watcher's time its rewrites of the views may take while archives
keep ending: the interval grows to ``1 / VIEW_SHARE`` times the last rewrite's duration
(0.3 s for a year of hourly files: every 15 s)."""


class Verdict(StrEnum):
    """The verdict of one archive in the index."""

    FAULT = "fault"
    NO_FAULT = "no fault"
    ERROR = "error"


MISMATCH = "mismatch"
""":attr:`Record.error_reason` of an archive these options, sound in themselves, do not fit."""
TOO_SHORT = "too short"
""":attr:`Record.error_reason` of an archive too short for the training window."""
UNWRITTEN = "unwritten"
""":attr:`Record.error_reason` of an archive whose report could not be written (REPORTS
full): an ``internal`` error, not the archive's fault."""


class ErrorKind(StrEnum):
    """Why an archive could not be analyzed, which says what happens to it next."""

    INPUT = "input"
    """The archive itself (corrupt, unreadable), or an archive these options, sound in
    themselves, do not fit (:attr:`Record.error_reason` ``mismatch``): a verdict on the
    content, kept while the options stay the same; moved to ``--failed`` (a mismatch only
    once an archive has fit these options, :meth:`Ledger.fitted`)."""
    OPTIONS = "options"
    """An error of the options alone, one every archive would get (a ``--train`` that
    cannot be read, a ``[model]`` of the config that does not fit together, ``--rate``
    against the model's), or an archive too short for the training window
    (:attr:`Record.error_reason` ``too short``: a file still being written): kept while
    the options stay the same, and the archive is left in INBOX (with mended options, or
    grown, it is fine), said each time it is seen."""
    INTERNAL = "internal"
    """Not the archive's fault (an internal error, a full disk, a killed analysis): shown
    in the index, but analyzed again on the next start; the archive stays in INBOX."""


@dataclass(slots=True)
class Record:
    """One archive's line in the state file and in ``index.json``."""

    name: str
    sha256: str
    verdict: Verdict
    report: str
    """Link to the report (or error.txt), relative to REPORTS."""
    inputs: list[str]
    processed: str
    """When the analysis finished, ISO-8601 UTC."""
    analysis_s: float
    faulty_sensors: list[str] = field(default_factory=list)
    faults: int = 0
    error: str | None = None
    start: str | None = None
    """First sample of the data, ISO-8601 UTC, where the archive has absolute times."""
    duration_s: float | None = None
    signature: list[list[Any]] = field(default_factory=list)
    moved_to: list[str] = field(default_factory=list)
    fault_list: list[dict[str, Any]] = field(default_factory=list)
    """Each fault of the archive: ``channel``, ``type``, ``onset`` and ``end`` (ISO-8601
    UTC; ``end`` None while it lasts to the archive's end) and ``from_start`` (present
    from the first sample searched: it may have begun before the archive)."""
    screen: dict[str, Any] | None = None
    """With ``--screen``: ``findings.json``'s ``screen`` (the screening's detectors and
    whether they found a fault, so whether every detector analyzed the archive)."""
    error_kind: ErrorKind | None = None
    """Of an ``error``: whose fault it is (None in the records of older watchers)."""
    options: str | None = None
    """Fingerprint of the analysis options and analyzer version the result was made with
    (:func:`analyzer.watch.options_fingerprint`; None in the records of older watchers)."""
    dropped_as: str | None = None
    """The name it arrived under, when a later archive of that name took it
    (:meth:`Ledger.keep_aside`); None while it has its own name."""
    input_errors: list[str] = field(default_factory=list)
    """Of an archive analyzed past input errors (a truncated file, a damaged member of a
    folder: ``findings.json``'s ``inputs[].errors`` and the archive's notes), the lines
    ``analyzer run`` warns of: the first five, and a count of the rest."""
    warnings: list[str] = field(default_factory=list)
    """Of an analyzed archive, the other lines the watcher warned of after its verdict,
    as ``analyzer run`` does: about the config (a ``[[group]]`` naming no channel of it),
    the model (its spread 1000 times the model's: another unit), the training window, and
    the anomalies the detectors attributed to no sensor: the archive's own lines first,
    the config's (every archive's) last; the first five, and a count of the rest
    (:func:`more_warnings`). Empty in the records of older watchers. The index says how
    many, and the first."""
    file_marks: dict[str, str] = field(default_factory=dict)
    """Of a folder or group, each file's mark (:func:`analyzer.watch.file_mark`: the
    sha256 of its first and last 64 KiB) by its path relative to INBOX (as in
    ``signature``), to tell a file that grew from one replaced by another recording
    (:meth:`analyzer.watch._Runner._grew`); empty for a single file (``sha256`` is its
    own) and in the records of older watchers. Not in ``index.json``."""
    corrected: str | None = None
    """Link to ``corrected.csv`` (``--corrected``: the readings with the faults
    corrected), relative to REPORTS; None where the analysis wrote none."""
    error_reason: str | None = None
    """Of an ``error``, a finer reason than :attr:`error_kind`: ``mismatch`` (an
    ``input`` error: an archive that these options, sound in themselves, do not fit, as
    a one-channel file or ``--channels`` matching none of its channels, with
    :attr:`misfit_option` the option to check) or ``too short`` (an ``options`` error: too
    short for the training window, as a file still being written; left in INBOX and
    analyzed again when it grows; unchanged for ``--give-up-after`` seconds, given up:
    its ``error_kind`` becomes ``input`` and it goes to ``--failed``) or ``unwritten``
    (an ``internal`` error: its report could not be written, REPORTS full). A field, not a
    kind of its own: a watcher of analyzer 49, which knows only the kinds, still reads
    the state (it leaves out fields it does not know)."""
    misfit_option: str | None = None
    """Of a ``mismatch``: the option the archive does not fit (``--channels``,
    ``--model``, ``--train``, ``--config``)."""
    left_in_inbox: str | None = None
    """Of an ``error`` that stays in INBOX on purpose, why (no ``--failed`` folder, an
    error of the options alone), set each time a watcher sees the archive there; None
    once it is moved, and for an internal error (analyzed again on the next start)."""
    summary: str | None = None
    """Of a ``fault``: its faults as ``analyzer run``'s last line says them (``2 sensor
    faults found on 2 sensors: s1 additive from 20.000 s, ...``), without the report's
    path; None for other verdicts and in the records of older watchers."""
    rate_hz: float | None = None
    """Its sample rate (``findings.json``'s ``rate_hz``): the sample period that
    :func:`episodes` allows between one archive's end and the next one's start; None
    for errors and in the records of older watchers."""
    short_since: float | None = None
    """Of a ``too short`` archive left in INBOX: when the watcher first saw it at its
    size (seconds since the epoch): ``--give-up-after`` counts from then, not from the
    file's mtime (a share whose clock is behind, a copy that kept its mtime)."""
    moving: list[list[str]] = field(default_factory=list)
    """A move by ``--done``/``--failed`` under way that could be stopped half-done
    (copies to another file system, several renames): ``[source, copy, target]``
    lines, ``copy`` "" for a rename. Written before the move begins, emptied when it
    ends; the start after a watcher killed during it finishes or undoes it
    (:func:`analyzer.watch._end_move`). In the state file only while not empty; not in
    ``index.json``."""
    unpublished: bool = False
    """Reserved (:meth:`Ledger.reserve`): written to the state file before its report
    was published into :attr:`folder`. True only in the state of a watcher stopped by
    force between the two (the record that follows the publish has it False): the next
    start then tells a folder never made from one removed since (:meth:`Ledger.tidy`).
    In the state file only while True; not in ``index.json``."""

    @property
    def folder(self) -> str:
        """Its folder of REPORTS (that of :attr:`report`)."""
        return self.report.split("/", 1)[0]

    def redo_reason(self, options: str) -> str | None:
        """Why this archive, recorded already with this content, is analyzed again by a
        watcher whose options have the fingerprint ``options``; None when it is not.

        A result (fault, no fault) is kept whatever the options. An error is redone when
        it was not the archive's (:attr:`ErrorKind.INTERNAL`) or when it was made with
        other options or another analyzer version; an error recorded by an older
        watcher (no fingerprint: possibly an internal error) is redone once."""
        if self.verdict is not Verdict.ERROR:
            return None
        if self.error_kind is ErrorKind.INTERNAL and self.error_reason == UNWRITTEN:
            return "its last report could not be written (not the archive's fault)"
        if self.error_kind is ErrorKind.INTERNAL:
            return "its last analysis ended in an internal error (not the archive's fault)"
        if self.options is None:
            return (
                "its error was recorded by an older watcher, without the options it was made with"
            )
        if self.options != options:
            return "its error was recorded with other analysis options or another analyzer version"
        return None

    def as_json(self) -> dict[str, Any]:
        """The record as a JSON object: a new dict, whose lists are the record's own (to
        be serialized, not changed; ``dataclasses.asdict`` deep-copied them, which was
        most of the cost of writing the state of a year of files)."""
        doc = {name: getattr(self, name) for name in _RECORD_FIELDS}
        if not self.moving:
            del doc["moving"]  # (the state of a watcher between moves, as before)
        if not self.unpublished:
            del doc["unpublished"]
        doc["verdict"] = str(self.verdict)
        if self.error_kind is not None:
            doc["error_kind"] = str(self.error_kind)
        return doc

    @classmethod
    def from_json(cls, doc: dict[str, Any]) -> Record:
        known = {f.name for f in fields(cls)}
        doc = {k: v for k, v in doc.items() if k in known}  # fields of later versions
        doc["verdict"] = Verdict(doc["verdict"])
        if doc.get("error_kind") is not None:
            doc["error_kind"] = ErrorKind(doc["error_kind"])
        return cls(**doc)


_RECORD_FIELDS = tuple(f.name for f in fields(Record))


def report_dirname(name: str) -> str:
    """The folder of REPORTS that holds an archive's report: its name, unless that
    would collide with the index or be hidden, or starts with ``_``: then ``_`` + the
    name. One to one (``index.html`` is ``_index.html``, ``_index.html`` is
    ``__index.html``). A record links to its own folder (:attr:`Record.folder`), so the
    records of watchers that named ``_x`` folder ``_x`` stay valid."""
    return f"_{name}" if name in RESERVED or name.startswith((".", "_")) else name


def numbered_names(name: str) -> Iterator[str]:
    """The names that stand for ``name`` where it is taken, in the order tried:
    ``stem-1.suffixes``, ``stem-2.suffixes``... (``x.csv.gz``: ``x-1.csv.gz``, the number
    before every suffix, so the name still reads as its format). One rule for the
    archives moved to DONE or FAILED, their report folders and their records."""
    stem, dot, suffixes = name.partition(".")
    return (f"{stem}-{n}{dot}{suffixes}" for n in itertools.count(1))


def now_iso() -> str:
    return iso_utc(time.time_ns()) or ""


# --------------------------------------------------------------------------- lock


def lock_holder(fd: int) -> int | None:
    """The pid of the process holding a ``flock`` on the file open as ``fd``, as Linux's
    ``/proc/locks`` tells it (None where it does not: another system, a lock taken on
    another machine of a network file system)."""
    try:
        st = os.fstat(fd)
        with open("/proc/locks", encoding="ascii", errors="replace") as f:
            lines = f.read().splitlines()
    except OSError:
        return None
    inode = f":{st.st_ino}"
    for line in lines:
        parts = line.split()
        # "1: FLOCK  ADVISORY  WRITE 4242 08:01:1234 0 EOF" (a waiter's line has "->")
        if len(parts) >= 6 and parts[1] == "FLOCK" and "->" not in parts:
            device = parts[5]
            if device.endswith(inode) and parts[4].isdigit():
                major, _, minor = device[: -len(inode)].partition(":")
                try:
                    same = os.makedev(int(major, 16), int(minor, 16)) == st.st_dev
                except ValueError:
                    continue
                if same and int(parts[4]) != os.getpid():
                    return int(parts[4])
    return None


class _HeldLock:
    """A ``flock`` held on an open descriptor while the watcher runs (:meth:`acquire`,
    given by each kind), released by :meth:`release` or at the end of a ``with`` block."""

    _fd: int | None = None

    def acquire(self) -> None:
        raise NotImplementedError

    def release(self) -> None:
        if self._fd is not None:
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> Self:
        self.acquire()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.release()


class ReportsLock(_HeldLock):
    """``flock`` on ``REPORTS/.lock`` while the watcher runs. A second watcher on the same
    REPORTS does not wait: :meth:`acquire` raises :class:`UsageError` (exit code 2).

    The lock holds only while ``REPORTS/.lock`` is the file locked: a REPORTS folder
    removed under the watcher (a clean-up job) took the lock with it, and a second
    watcher could then start there (a QA audit's ux66 item H1). :meth:`lost` tells it,
    and :meth:`retake` makes the folder again and locks it again."""

    def __init__(self, reports: Path) -> None:
        self.path = reports / LOCK_FILE
        self._fd: int | None = None

    def lost(self) -> bool:
        """Whether ``REPORTS/.lock`` is no longer the file this watcher locked (removed
        with its folder, or replaced): one ``stat`` and one ``fstat``."""
        if self._fd is None:
            return False
        try:
            now = os.stat(self.path)
        except (FileNotFoundError, NotADirectoryError):
            return True
        except OSError:  # (REPORTS unreadable for a while: its writes fail, tried again)
            return False
        held = os.fstat(self._fd)
        return (now.st_dev, now.st_ino) != (held.st_dev, held.st_ino)

    def retake(self) -> None:
        """After :meth:`lost`: make REPORTS again (with its parents) and lock it anew;
        :class:`UsageError` when that cannot be done or when another watcher holds the
        new lock now (it started there meanwhile)."""
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise UsageError(
                f"--out: cannot make {self.path.parent} again: {err.strerror or err}"
            ) from None
        old, self._fd = self._fd, None
        try:
            self.acquire()
        finally:
            if old is not None:
                os.close(old)  # (the lock of a file no longer there: it guards nothing)

    def acquire(self) -> None:
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as err:  # (a read-only REPORTS: the option named, as run's --out)
            # (the lock file named when it is there: another user's, say)
            what = self.path if os.path.lexists(self.path) else self.path.parent
            raise UsageError(
                f"--out: cannot write to {what}: {err.strerror or err} (the watcher keeps "
                f"its lock, state and reports there)"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 64, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise UsageError(
                f"--out: {self.path.parent} is in use by another watcher (pid {holder}); "
                "only one watcher may write a REPORTS folder"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        self._fd = fd


class InboxLock(_HeldLock):
    """``flock`` on the INBOX folder itself (a descriptor of the folder: nothing is
    written into INBOX, whose files are only read) while the watcher runs. A second
    watcher on the same INBOX, even with another REPORTS, does not wait: :meth:`acquire`
    raises :class:`UsageError` (exit code 2) naming INBOX and the first watcher's pid
    where the system tells it (:func:`lock_holder`). Before, both analyzed every archive
    and split the reports between their two REPORTS folders (a QA audit's ux66 item M3).
    A file system without ``flock`` leaves INBOX unlocked."""

    def __init__(self, inbox: Path) -> None:
        self.inbox = inbox
        self._fd: int | None = None

    def acquire(self) -> None:
        try:
            fd = os.open(self.inbox, os.O_RDONLY | os.O_DIRECTORY)
        except OSError:
            return  # (INBOX is checked before: gone since, it is said as such later)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = lock_holder(fd)
            os.close(fd)
            raise UsageError(
                f"INBOX: {self.inbox} is watched by another watcher"
                f"{f' (pid {holder})' if holder else ''}; only one watcher may watch an "
                "INBOX folder"
            ) from None
        except OSError:
            os.close(fd)  # (no locks on this file system: unlocked, as before)
            return
        self._fd = fd

    def renew(self) -> None:
        """INBOX made again after it went (:attr:`~analyzer.watch_inbox.InboxTracker.gone`):
        the lock held is on the folder that went, so lock the new one (:meth:`acquire`:
        :class:`UsageError` if another watcher has taken it meanwhile). Nothing is done
        while INBOX is the folder locked, or is not there."""
        try:
            now = os.stat(self.inbox)
        except OSError:
            return
        if self._fd is not None:
            held = os.fstat(self._fd)
            if (now.st_dev, now.st_ino) == (held.st_dev, held.st_ino):
                return
        old, self._fd = self._fd, None
        try:
            self.acquire()
        finally:
            if old is not None:
                os.close(old)


# --------------------------------------------------------------------------- report dirs


NAME_MAX = 255
"""Bytes a file name may have (Linux, macOS)."""


def hidden_name(prefix: str, name: str) -> str:
    """A new hidden name ``prefix + name + -XXXXXXXX`` (random), ``name`` cut to keep it
    within :data:`NAME_MAX` bytes: an archive of a 246-byte name, allowed itself, made
    the scratch folder's name too long, and the watcher died at every start."""
    return _within(prefix, name, f"-{uuid.uuid4().hex[:8]}")


def _within(prefix: str, name: str, tag: str) -> str:
    """``prefix + name + tag``, ``name`` cut to keep it within :data:`NAME_MAX` bytes."""
    room = NAME_MAX - len(os.fsencode(prefix + tag))
    return prefix + os.fsdecode(os.fsencode(name)[:room]) + tag


def scratch_dir(reports: Path, name: str) -> Path:
    """A new hidden folder of REPORTS to write an archive's outputs into."""
    path = reports / hidden_name(TMP_PREFIX, report_dirname(name))
    path.mkdir()
    return path


REPORT_FILES = frozenset({"report.html", "findings.json", "error.txt", "corrected.csv"})
"""What a report folder of the watcher holds (an analysis's outputs, or its error)."""


def _report_folder(path: Path) -> bool:
    """Whether ``path`` is a folder (not a link) holding report files only: one the
    watcher published, which a new report of its archive may replace."""
    try:
        return not path.is_symlink() and all(e.name in REPORT_FILES for e in path.iterdir())
    except OSError:  # (a file, or a folder that cannot be read: not one of ours)
        return False


def _fitting(name: str) -> str:
    """``name``, or where it is longer than :data:`NAME_MAX` bytes (``_`` + a 255-byte
    name, or ``NAME-report``), its first bytes and a hash of the whole, which keeps
    names apart."""
    raw = os.fsencode(name)
    if len(raw) <= NAME_MAX:
        return name
    return _within("", name, "-" + hashlib.sha256(raw).hexdigest()[:12])


def publish(
    scratch: Path,
    reports: Path,
    name: str,
    previous: str | None = None,
    keep: Collection[str] = (),
) -> Path:
    """Rename ``scratch`` to ``REPORTS/<name>``, replacing an older report of the same
    archive (``previous``: its record's folder, when it has one). Readers see the old
    folder or the new one, never a half-written one. A folder there that is no report
    of the watcher's (a user's folder, or INBOX's archives, which an INBOX inside
    REPORTS put there: both were deleted), or that is in ``keep`` (the folders of the
    other records: one kept aside by :meth:`Ledger.keep_aside`, whose folder stays where
    it was announced), is left alone: the report takes the first free name
    of ``NAME-report``, ``NAME-report-2``... Returns the report's folder."""
    base = report_dirname(name)
    names = [previous] if previous else []
    names += [base, f"{base}-report", *(f"{base}-report-{k}" for k in range(2, 10_000))]
    final = next(
        p
        for p in (reports / _fitting(n) for n in names)
        if not os.path.lexists(p) or (_report_folder(p) and p.name not in keep)
    )
    old = None
    if final.exists():
        old = reports / hidden_name(OLD_PREFIX, final.name)
        os.replace(final, old)
    os.replace(scratch, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
    return final


# --------------------------------------------------------------------------- state + index


class Ledger:
    """The state file and the index of one REPORTS folder (the caller holds the lock)."""

    def __init__(self, reports: Path) -> None:
        self.reports = reports
        self.path = reports / STATE_FILE
        self.records: dict[str, Record] = {}
        self._views_stale = True
        self._views_written = -math.inf
        """``time.monotonic()`` of the last rewrite of the views."""
        self._views_interval = VIEW_INTERVAL_S
        self.unpublished: dict[str, str] = {}
        """The folders reserved for archives whose report was never published (a
        watcher stopped by force between :meth:`reserve` and the publish), by name: set
        by :meth:`tidy`, taken by :meth:`unpublished_folder`."""

    @classmethod
    def load(cls, reports: Path) -> Ledger:
        """Read the state; a state file that cannot be read is an error (exit 2) rather
        than a silent restart that would analyze everything again."""
        ledger = cls(reports)
        if not ledger.path.exists():
            return ledger
        try:
            text = ledger.path.read_text(encoding="utf-8")
        except OSError as err:  # (not a damaged state: moving it away would lose it)
            raise UsageError(
                f"{ledger.path}: cannot read the watcher state: {err.strerror or err}; let "
                "the watcher's user read and write it"
            ) from None
        try:
            doc = json.loads(text)
            if doc.get("schema") != STATE_SCHEMA:
                raise ValueError(f"schema {doc.get('schema')!r}, expected {STATE_SCHEMA!r}")
            ledger.records = {name: Record.from_json(rec) for name, rec in doc["archives"].items()}
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
            raise UsageError(
                f"{ledger.path}: unreadable watcher state ({err}); move it away to start "
                "afresh (every archive in INBOX will then be analyzed again)"
            ) from err
        return ledger

    def tidy(self) -> list[str]:
        """Remove what an interrupted watcher left (scratch and replaced folders) and
        forget archives whose report folder is gone, so that they are analyzed again, but
        for one whose move a start could not end (:attr:`Record.moving`: forgotten, what
        was left of it in INBOX was analyzed alone as the archive, and its ``.partial-``
        copies stayed), kept until its move is ended. A record reserved but never
        published (:attr:`Record.unpublished`, its folder never made) is forgotten too,
        its folder kept in :attr:`unpublished`; one whose folder is there was published
        and holds. Returns the names forgotten."""
        own_temp = tuple(f".{name}." for name in (STATE_FILE, "index.json", "index.html"))
        for entry in self.reports.iterdir():
            if entry.is_dir() and entry.name.startswith((TMP_PREFIX, OLD_PREFIX)):
                shutil.rmtree(entry, ignore_errors=True)
                # (said: a watcher killed outright leaves these, and nothing else tells)
                log.info(
                    "%s: removed: left by a watcher stopped by force (%s)",
                    entry.name,
                    "an analysis it had not recorded: its archive is analyzed again"
                    if entry.name.startswith(TMP_PREFIX)
                    else "a report it was replacing",
                )
            elif entry.is_file() and entry.name.startswith(own_temp):
                entry.unlink()  # a write_atomic interrupted by a crash
        repaired = False
        folders = {rec.folder for rec in self.records.values()}
        for rec in self.records.values():
            # (kept aside by a watcher killed between the rename of its folder and the
            # state's second write: the folder is at its new name)
            moved = report_dirname(rec.name)
            if (
                rec.dropped_as is not None
                and not (self.reports / rec.folder).is_dir()
                and _report_folder(self.reports / moved)
                and moved not in folders
            ):
                rec.report = f"{moved}/{rec.report.partition('/')[2]}"
                repaired = True
        # (not one whose move could not be ended: its lines are all that tells what is
        # left of its archive in INBOX from an archive of its own)
        for rec in self.records.values():
            if rec.unpublished and (self.reports / rec.folder).is_dir():
                rec.unpublished = False  # (stopped after the publish: its record holds)
                repaired = True
        gone = [
            name
            for name, rec in self.records.items()
            if not (self.reports / rec.folder).is_dir() and not rec.moving
        ]
        for name in gone:
            rec = self.records.pop(name)
            if rec.unpublished:
                self.unpublished[name] = rec.folder
        if gone or repaired:
            self.save()
        return gone

    def folders_except(self, name: str) -> set[str]:
        """The report folders of the records other than ``name``'s (:func:`publish`'s
        ``keep``)."""
        return {rec.folder for n, rec in self.records.items() if n != name}

    def get(self, name: str) -> Record | None:
        return self.records.get(name)

    def keep_aside(self, name: str) -> str:
        """Make room for a new archive under ``name`` without losing the record of the
        earlier one (another content that arrived under that name: replaced in INBOX,
        or moved away by ``--done``/``--failed`` and dropped again): its record takes a
        free name (that of the file ``--done`` moved it to when that differs, else
        ``stem-N.suffixes``), with ``dropped_as`` the name it came under; its report
        folder stays where it is, so that every report path the watcher printed for it
        still points to it (the new archive's report takes a free folder of its own:
        :meth:`new_folder`). Before, the folder moved to the new name and the new
        analysis took the old folder, so the lines and links printed for the earlier
        one showed other data. Nothing published is moved or deleted. Returns the new
        name."""
        rec = self.records.pop(name)
        new = self._free_name(rec)
        self.records[new] = replace(rec, name=new, dropped_as=rec.dropped_as or name)
        self.save_state()
        self._views_stale = True
        return new

    def new_folder(self, name: str) -> str:
        """A free report folder for a new content of ``name`` whose earlier result keeps
        its folder (:meth:`keep_aside`): ``stem-N.suffixes`` (as :func:`report_dirname`
        makes it), the first that no record links to and that is not in REPORTS."""
        taken = {rec.folder for rec in self.records.values()}
        folders = (_fitting(report_dirname(c)) for c in numbered_names(name))
        return next(f for f in folders if f not in taken and not os.path.lexists(self.reports / f))

    def reserve(self, rec: Record) -> None:
        """Keep ``rec`` in the state file before its report is published into
        :attr:`Record.folder`, a new folder (:meth:`new_folder`, for new content whose
        name's earlier result keeps its own). A watcher killed after the publish, whose
        line named that folder, leaves it recorded: the next start finds the archive
        analyzed already, its report where the line said. Killed before the publish, the
        record's folder is missing: the next start forgets it (:meth:`tidy`), and the
        archive is analyzed again. Before, the record was written only after the
        publish: a kill between left the folder announced but linked by no record and
        never removed, and the next start published the same content to ``NAME-report``.
        Not the index: it must not link a folder not there yet (:meth:`record`, after
        the publish, has the views rewritten). A state that cannot be written raises,
        and the record is dropped: one left in memory would make the same content, found
        again in that run, "analyzed already", its report a folder never made."""
        self.records[rec.name] = replace(rec, unpublished=True)
        try:
            self.save_state()
        except OSError:  # (REPORTS full: nothing is recorded that was not published)
            del self.records[rec.name]
            raise

    def unpublished_folder(self, name: str) -> str | None:
        """The folder reserved for ``name``'s report by a watcher stopped before it
        published it (:meth:`tidy`), once: the report of its content, analyzed again,
        goes there, the name that content's line would have said, unless a record or
        another file has it since. Before, it went to ``NAME-report`` (the archive's
        own name being the earlier content's folder)."""
        folder = self.unpublished.pop(name, None)
        if folder is None or folder in {rec.folder for rec in self.records.values()}:
            return None
        return None if os.path.lexists(self.reports / folder) else folder

    def forget(self, name: str) -> None:
        """Drop the record of ``name`` (reserved, :meth:`reserve`, but its report not
        published) from the state file; a state that cannot be written keeps it, and the
        next start forgets it (its folder missing)."""
        self.records.pop(name, None)
        with contextlib.suppress(OSError):
            self.save_state()

    def _free_name(self, rec: Record) -> str:
        def free(candidate: str) -> bool:
            return candidate not in self.records and not os.path.lexists(
                self.reports / report_dirname(candidate)
            )

        if len(rec.moved_to) == 1:
            moved = Path(rec.moved_to[0]).name
            if moved != rec.name and free(moved):
                return moved
        return next(c for c in numbered_names(rec.name) if free(c))

    def record(self, rec: Record) -> None:
        """Keep ``rec``: the state file at once, the views when due
        (:meth:`refresh_views`)."""
        self.records[rec.name] = rec
        self.save_state()
        self._views_stale = True
        self.refresh_views()

    def fitted(self, options: str) -> bool:
        """Whether an archive has been analyzed (a fault or no fault) with the options of
        fingerprint ``options``: until then an archive they do not fit
        (:attr:`Record.error_reason` ``mismatch``) may show an option wrong for every
        archive (``--channels 'S*'``), and stays in INBOX; it moved the whole INBOX to
        ``--failed``, one archive at a time. Told from the records (the state file)."""
        return any(
            r.options == options and r.verdict is not Verdict.ERROR for r in self.records.values()
        )

    def newest_first(self) -> list[Record]:
        return sorted(self.records.values(), key=lambda r: (r.processed, r.name), reverse=True)

    def save(self) -> None:
        """The state file, then ``index.json`` and ``index.html`` (each atomically)."""
        self.save_state()
        self._views_stale = True
        self.refresh_views(force=True)

    def save_state(self) -> None:
        """The state file (atomically; compact JSON, one record per line)."""
        lines = [
            f"{json.dumps(name)}:{json.dumps(rec.as_json(), separators=(',', ':'))}"
            for name, rec in sorted(self.records.items())
        ]
        head = {"schema": STATE_SCHEMA, "analyzer_version": __version__}
        text = json.dumps(head)[:-1] + ', "archives": {\n' + ",\n".join(lines) + "\n}}\n"
        write_atomic(self.path, text)

    def refresh_views(self, *, force: bool = False) -> bool:
        """Rewrite ``index.json`` and ``index.html`` if a record changed since they were
        written, and ``force`` or their interval has passed since then (at least
        :data:`VIEW_INTERVAL_S`, longer when they take long to write: :data:`VIEW_SHARE`).
        Returns whether they were written."""
        if not self._views_stale:
            return False
        begin = time.monotonic()
        if not force and begin - self._views_written < self._views_interval:
            return False
        index = self.index_document()
        try:
            write_atomic(self.reports / "index.json", index_json(index))
            write_atomic(self.reports / "index.html", render_index(index))
        except OSError as err:  # a full disk: the state is what counts; try again later
            log.warning("cannot write the index in %s: %s", self.reports, err)
            self._views_written = time.monotonic()
            return False
        self._views_stale = False
        self._views_written = time.monotonic()
        cost = self._views_written - begin
        self._views_interval = max(VIEW_INTERVAL_S, cost / VIEW_SHARE)
        return True

    def index_document(self) -> dict[str, Any]:
        rows = []
        for rec in self.newest_first():
            doc = rec.as_json()
            del doc["signature"]
            del doc["file_marks"]
            del doc["rate_hz"]
            del doc["short_since"]
            doc.pop("moving", None)
            doc.pop("unpublished", None)
            rows.append(doc)
        counts = {str(v): sum(r["verdict"] == v for r in rows) for v in Verdict}
        return {
            "schema": INDEX_SCHEMA,
            "analyzer_version": __version__,
            "updated": now_iso(),
            "counts": counts,
            "archives": rows,
            "episodes": episodes(self.records.values())[::-1],
        }


def index_json(index: dict[str, Any]) -> str:
    """``index.json``'s text: indented, but each archive and each episode on one line (a
    year of hourly files is 8760 of them; fully indented they took 3x longer to write)."""
    parts = []
    for key, value in index.items():
        if isinstance(value, list) and value:
            rows = ",\n    ".join(json.dumps(row, separators=(", ", ": ")) for row in value)
            parts.append(f"  {json.dumps(key)}: [\n    {rows}\n  ]")
        else:
            parts.append(f"  {json.dumps(key)}: {json.dumps(value)}")
    return "{\n" + ",\n".join(parts) + "\n}\n"


JOIN_GAP_S = 5.0
"""The least join gap: an archive that starts within this many seconds after the end of
an archive whose fault lasts to its end, with that fault from its start, carries the
fault on (a recorder that takes a few seconds to start its next file)."""

JOIN_GAP_PERIODS = 2.5
"""The join gap in sample periods of the earlier archive, where that is longer than
:data:`JOIN_GAP_S`: a minute-rate logger that lost one sample at a rotation starts its
next file two periods after the last one's end, which this joins; more missing is a gap,
as ``findings.json``'s ``gaps`` count one (steps longer than 2.5 sample periods)."""

JOIN_TOLERANCE_S = 0.001
"""The least tolerance before an archive's end (one sample period of it, where longer):
how far a following archive may start before the earlier one's end and still follow it
rather than overlap it (a duration counted to the end of the last sample period, or a
recorder that writes the rotation's sample in both files)."""


def episodes(records: Iterable[Record]) -> list[dict[str, Any]]:
    """Every fault of the archives, oldest first, joined across archives where it goes
    on; each episode has the first onset and the last end (None while it lasts to the
    end of its latest archive). Archives without absolute times are never joined.

    Two faults on the same sensor in two archives (A starting no later than B, A ending
    at E) are one episode when

    * B follows A and carries A's fault on: A's fault lasts to E, B has it from its
      first sample searched (``from_start``: with ``--model``, which searches a file
      from its start), and B starts no earlier than E less one sample period of A (at
      least :data:`JOIN_TOLERANCE_S`) and no later than the join gap after E (the
      longer of :data:`JOIN_GAP_S` and :data:`JOIN_GAP_PERIODS` sample periods of A); or
    * their times overlap: B's fault begins before A's ends (within that tolerance) and
      after A's began, as a second file of the same time that sees the same fault (a
      duplicate, a second recorder's): it joins the episode rather than split it.

    So an episode goes on where ANY archive that follows its last one carries it, and
    ends where none does (followers without the fault, or none within the gap). An
    archive that has no fault on that sensor never splits an episode, wherever it lies:
    one that overlaps A or B (a file of the same minute, another source's) or one that
    follows A beside an archive that carries the fault. Nothing depends on the archives'
    names or the order they come in. A healthy archive between two faulty ones ends the
    episode only by taking the time between them: the later one no longer starts within
    the gap.

    Each episode: ``channel``, ``types`` (as classified in each archive, in order, each
    once), ``size`` (the fault's size in its first archive, as the report says it:
    ``gain ×0 (dead sensor)``; None in the records of older watchers), ``onset``,
    ``from_start`` (the fault was there from its first archive's first sample
    searched, so its onset is "at or before" ``onset``), ``end``, ``archives``."""
    timed: list[_Timed] = []
    out: list[dict[str, Any]] = []
    for rec in records:
        start = _epoch_ns(rec.start)
        if start is None or rec.duration_s is None:
            out.extend(_episode(f, rec.name) for f in rec.fault_list)
        elif rec.fault_list:
            timed.append(_Timed.of(rec, start))
    timed.sort(key=lambda t: (t.start, t.rec.name))
    parent = {(i, k): (i, k) for i, t in enumerate(timed) for k in range(len(t.rec.fault_list))}

    def root(node: tuple[int, int]) -> tuple[int, int]:
        while parent[node] != node:
            parent[node] = parent[parent[node]]
            node = parent[node]
        return node

    starts = [t.start for t in timed]
    for i, a in enumerate(timed):
        # (the archives that start before the join gap after a's end: sorted by start)
        for j in range(i + 1, bisect.bisect_right(starts, a.end + a.gap)):
            for k, fa in enumerate(a.rec.fault_list):
                for m, fb in enumerate(timed[j].rec.fault_list):
                    if fa["channel"] == fb["channel"] and _joined(a, k, timed[j], m):
                        parent[root((i, k))] = root((j, m))
    groups: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for node in parent:  # (in the order of the archives' starts)
        groups.setdefault(root(node), []).append(node)
    out.extend(_joined_episode([(timed[i], k) for i, k in nodes]) for nodes in groups.values())
    out.sort(key=lambda ep: (_epoch_ns(ep["onset"]) or 0, ep["channel"]))
    return out


@dataclass(frozen=True, slots=True)
class _Timed:
    """An archive with absolute times, as :func:`episodes` joins it (times in ns)."""

    rec: Record
    start: int
    end: int
    tolerance: int
    """One sample period, at least :data:`JOIN_TOLERANCE_S`."""
    gap: int
    """The join gap after its end."""

    @classmethod
    def of(cls, rec: Record, start: int) -> _Timed:
        period = 1.0 / rec.rate_hz if rec.rate_hz else 0.0  # (0: older watchers' records)
        return cls(
            rec,
            start,
            start + int(round(float(rec.duration_s or 0.0) * NS_PER_S)),
            int(max(period, JOIN_TOLERANCE_S) * NS_PER_S),
            int(max(JOIN_GAP_PERIODS * period, JOIN_GAP_S) * NS_PER_S),
        )

    def span(self, k: int) -> tuple[int, int]:
        """Its fault ``k``'s onset and end (its archive's start, end where not said)."""
        fault = self.rec.fault_list[k]
        onset = _epoch_ns(fault.get("onset"))
        end = _epoch_ns(fault.get("end"))
        return (self.start if onset is None else onset, self.end if end is None else end)


def _joined(a: _Timed, k: int, b: _Timed, m: int) -> bool:
    """Whether fault ``k`` of ``a`` and fault ``m`` of ``b`` (same sensor; ``b`` starts
    no earlier than ``a``) are one episode (:func:`episodes`)."""
    fa, fb = a.rec.fault_list[k], b.rec.fault_list[m]
    if (
        fa.get("end") is None
        and fb.get("from_start")
        and a.end - a.tolerance <= b.start <= a.end + a.gap
    ):
        return True  # (b follows a and carries the fault on)
    onset_a, end_a = a.span(k)
    onset_b, end_b = b.span(m)
    return onset_b <= end_a + a.tolerance and onset_a <= end_b + b.tolerance  # (overlap)


def _joined_episode(members: list[tuple[_Timed, int]]) -> dict[str, Any]:
    """One episode of the faults ``members`` (each an archive and its fault's index),
    in the order of their archives' starts: the earliest onset's fault gives its onset,
    size and ``from_start``; the latest ending one its end."""
    first_t, first_k = min(members, key=lambda mk: mk[0].span(mk[1])[0])
    ep = _episode(first_t.rec.fault_list[first_k], first_t.rec.name)
    ep["archives"], ep["types"] = [], []
    for t, k in members:
        if t.rec.name not in ep["archives"]:
            ep["archives"].append(t.rec.name)
        if t.rec.fault_list[k]["type"] not in ep["types"]:
            ep["types"].append(t.rec.fault_list[k]["type"])
    last_t, last_k = max(
        members,
        key=lambda mk: (mk[0].span(mk[1])[1], mk[0].rec.fault_list[mk[1]].get("end") is None),
    )
    ep["end"] = last_t.rec.fault_list[last_k].get("end")
    return ep


def _episode(fault: dict[str, Any], archive: str) -> dict[str, Any]:
    return {
        "channel": str(fault["channel"]),
        "types": [fault["type"]],
        "size": fault.get("size"),
        "onset": fault.get("onset"),
        "from_start": bool(fault.get("from_start")),
        "end": fault.get("end"),
        "archives": [archive],
    }


def _epoch_ns(text: str | None) -> int | None:
    if not text:
        return None
    try:
        kind, value = parse_time(text)
    except ValueError:
        return None
    return int(value) if kind == "ns" else None


@dataclass(frozen=True, slots=True)
class IndexRow:
    """One archive in ``index.html``: display strings only."""

    name: str
    href: str
    verdict: str
    css: str
    """Classes of report.css: ``reject`` (red), ``pass`` (green), ``tag type`` (amber)."""
    sensors: str
    start: str
    duration: str
    processed: str
    details: str
    is_error: bool


@dataclass(frozen=True, slots=True)
class EpisodeRow:
    """One fault episode in ``index.html`` (:func:`episodes`): display strings only."""

    sensor: str
    types: str
    onset: str
    end: str
    archives: str
    href: str
    """The report of the archive it starts in."""


@dataclass(frozen=True, slots=True)
class IndexView:
    """What ``index.html`` shows (``title`` and ``version`` are the names ``base.html``
    expects of every page)."""

    title: str
    version: str
    summary: str
    updated: str
    rows: list[IndexRow]
    episodes: list[EpisodeRow] = field(default_factory=list)
    corrected: bool = False
    """Whether an archive's folder holds a ``corrected.csv`` (the footer lists it)."""


def _screening(screen: dict[str, Any]) -> str:
    """How a screened archive was analyzed (``watch --screen``), for its index line."""
    by = ", ".join(screen["detectors"])
    if screen.get("fault") is False:
        return f"screened by {by} alone"
    if screen.get("fault"):
        return f"flagged by {by}, analyzed by every detector"
    return f"{by} could not screen it, analyzed by every detector"


def _onset_words(ep: dict[str, Any], by_name: Mapping[str, dict[str, Any]]) -> str:
    """An episode's onset as ``index.html`` says it: where the fault was there from its
    first archive's first sample searched (``from_start``: it may have begun before that
    archive), "from the start", with the time before which nothing was judged where that
    is not the first sample of one of its archives, as ``analyzer run``'s last line says
    it. It read "at or before" the onset: the archive's first sample for one fault there
    from the start, 3.6 s later for another (the filters' warm-up; ux53 item 8).
    ``by_name``: the index's archives by name (:func:`_by_name`, built once per index:
    a search of the archives per episode made a year of hourly archives, each with a
    fault, take 32 s in place of 0.25 s)."""
    if not ep.get("onset"):
        return "n/a"
    onset = str(ep["onset"])
    if not ep.get("from_start"):
        return onset
    starts = {by_name[n].get("start") for n in ep["archives"] if n in by_name}
    if onset in starts:
        return f"from the start ({onset})"
    return f"from the start (not judged before {onset})"


def _by_name(archives: Iterable[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The index's archive rows by name, for the episodes' words (one row per name)."""
    return {r["name"]: r for r in archives}


def _identical(names: list[str], rows: Mapping[str, dict[str, Any]]) -> list[list[str]]:
    """``names`` (an episode's archives, in their order) grouped by content: the archives
    of one ``sha256`` (one file copied in under two names, each analyzed: the watcher's
    content check goes by name) in one group, the first analyzed first, the groups in
    the order of their first names. The index said "2 archives: offset_copy.csv to
    offset_mid.csv" for a file and its copy, which read as a span of time (ux53 item 9).
    ``rows``: the index's archives by name (:func:`_by_name`)."""
    groups: dict[str, list[str]] = {}
    for name in names:
        sha = (rows.get(name) or {}).get("sha256")
        groups.setdefault(str(sha) if sha else f"\0{name}", []).append(name)
    return [
        sorted(g, key=lambda n: (str(rows[n]["processed"]), n) if n in rows else ("", n))
        for g in groups.values()
    ]


def _identical_words(group: list[str]) -> str:
    """``offset_mid.csv (and 1 identical file: offset_copy.csv)``; one name alone."""
    if len(group) == 1:
        return group[0]
    more = len(group) - 1
    return f"{group[0]} (and {counted(more, 'identical file')}: {', '.join(group[1:])})"


WARNING_SHOWN = 320
"""Characters of an archive's first warning ``index.html`` shows: a ``[[group]]`` naming
5000 missing channels made one line of 97 KB on the page (rcfg53)."""

_MORE_WARNINGS = " more warnings in the watcher's log"


def more_warnings(n: int) -> str:
    """The line that ends an archive's :attr:`Record.warnings` in place of the ``n``
    lines past the first :data:`~analyzer.errors.WARNED_LINES` (every line in every
    record: 3000 config lines made a 786 KB state and a 798 KB index.json, rcfg53)."""
    return f"{n}{_MORE_WARNINGS}"


def warning_count(said: list[str]) -> int:
    """How many warnings the lines of :attr:`Record.warnings` stand for: the lines, and
    those the last one counts (:func:`more_warnings`) in place of itself."""
    head, _, tail = said[-1].partition(" ") if said else ("", "", "")
    if head.isdigit() and f" {tail}" == _MORE_WARNINGS:
        return len(said) - 1 + int(head)
    return len(said)


def index_view(index: dict[str, Any]) -> IndexView:
    """The display strings of ``index.html`` from the ``index.json`` document."""
    rows = []
    superseded = {r["dropped_as"] for r in index["archives"] if r.get("dropped_as")}
    for r in index["archives"]:
        verdict = str(r["verdict"])
        details = r["error"] or "report"
        if r.get("screen"):
            details += f"; {_screening(r['screen'])}"
        if r.get("input_errors"):
            damage = r["input_errors"]
            more = f" (and {len(damage) - 1} more lines)" if len(damage) > 1 else ""
            details += f"; analyzed past input errors: {damage[0]}{more}"
        if r.get("warnings"):
            said = r["warnings"]
            n = warning_count(said)
            where = "the watcher's log" if n > len(said) else "index.json and the watcher's log"
            details += f"; {counted(n, 'warning')}: {clipped_line(said[0], WARNING_SHOWN)}" + (
                f" (all of them in {where})" if n > 1 else ""
            )
        if r.get("dropped_as"):
            details += (
                f"; dropped as {r['dropped_as']}: an earlier content of that name, its "
                f"report where it was announced (the latest is {r['dropped_as']}'s line)"
            )
        elif r["name"] in superseded:
            details += "; the latest result of this name (earlier ones: dropped as it)"
        if r["moved_to"]:
            details += f"; moved to {', '.join(r['moved_to'])}"
        if r.get("corrected"):
            details += f"; corrected readings in {r['corrected']}"
        if r.get("left_in_inbox"):  # (cleared by a move: an earlier copy's is listed)
            details += f"; left in INBOX: {r['left_in_inbox']}"
        duration = r["duration_s"]
        rows.append(
            IndexRow(
                name=r["name"],
                # (a name that is no UTF-8, held with surrogates: its bytes, as on disk)
                href="/".join(quote(os.fsencode(part)) for part in str(r["report"]).split("/")),
                verdict=verdict,
                css={"fault": "reject", "no fault": "pass"}.get(verdict, "tag type"),
                sensors=", ".join(r["faulty_sensors"]) or "none",
                start=r["start"] or "n/a",
                duration="n/a" if duration is None else f"{float(duration):.1f} s",
                processed=r["processed"],
                details=details,
                is_error=verdict == Verdict.ERROR,
            )
        )
    hrefs = {row.name: row.href for row in rows}
    shown = []
    by_name = _by_name(index["archives"])
    for ep in index.get("episodes", []):
        names = list(ep["archives"])
        groups = _identical(names, by_name)
        said = [_identical_words(g) for g in groups]
        # (every archive counted, the identical ones too, as the index's counts count
        # them: "2 archives: h1.csv (and 2 identical files: ...) to h2.csv" covered 4)
        span = said[0] if len(said) == 1 else f"{len(names)} archives: {said[0]} to {said[-1]}"
        shown.append(
            EpisodeRow(
                sensor=str(ep["channel"]),
                types=", ".join(str(t) for t in ep["types"])
                + (f": {ep['size']}" if ep.get("size") else ""),
                onset=_onset_words(ep, by_name),
                end=str(ep["end"] or f"to the end of {groups[-1][0]}"),
                archives=span,
                href=hrefs.get(groups[0][0], ""),
            )
        )
    counts = index["counts"]
    summary = (
        f"{len(rows)} archive{'' if len(rows) == 1 else 's'}: "
        f"{counts['fault']} with a sensor fault, {counts['no fault']} without, "
        f"{counts['error']} that could not be analyzed."
    )
    return IndexView(
        title="Sensor fault audit: archives",
        version=str(index["analyzer_version"]),
        summary=summary,
        updated=str(index["updated"]),
        rows=rows,
        episodes=shown,
        corrected=any(r.get("corrected") for r in index["archives"]),
    )


def render_index(index: dict[str, Any]) -> str:
    """``index.html`` from the ``index.json`` document."""
    from analyzer.report import environment

    return environment().get_template("index.html").render(report=index_view(index))


__all__ = [
    "ErrorKind",
    "EpisodeRow",
    "IndexRow",
    "IndexView",
    "InboxLock",
    "Ledger",
    "Record",
    "ReportsLock",
    "lock_holder",
    "Verdict",
    "episodes",
    "now_iso",
    "publish",
    "index_view",
    "render_index",
    "report_dirname",
    "hidden_name",
    "scratch_dir",
]

"""``analyzer watch INBOX --out REPORTS``: analyze every archive that lands in a folder.

Monitoring systems and robots drop archives into INBOX (an SHM file per hour, a bag per
mission); the watcher analyzes each once it is complete and keeps an index of verdicts.

What is an archive, and when is it ready
    Every entry of INBOX: a file, a ROS 2 bag directory (one archive, not many files) or a
    directory of files forming one archive; with ``--group-by REGEX`` the entries whose
    names give the same value for the regex's first group are one archive named by that
    value (``(\\d{8}T\\d{2})``: one archive per hour), analyzed as a multi-file input. Hidden
    and temporary names (``.x``, ``x.tmp``, ``x.part``, ``x~``, ``x.active``, an upload's
    ``x.filepart``, ``x.crdownload``...: :data:`~analyzer.watch_inbox.IGNORED_SUFFIXES`)
    are ignored, and so are FIFOs, sockets and devices (never opened: said once). An
    archive is ready when its files' sizes and mtimes have not changed for ``--settle``
    seconds and it is structurally complete where the format allows: MCAP magic at both
    ends, a ROS 1 bag
    with its index, a ROS 2 bag directory with its ``metadata.yaml`` and its storage
    files as long as their sqlite headers say, a CSV file with a data row under its
    header (see :mod:`analyzer.watch_inbox`). An
    archive that changes soon after it was taken as ready (a writer pausing longer
    than ``--settle``) has to be stable twice as long the next time, up to 2 minutes.
    Changes are seen through file-system events (inotify and the like, via
    ``watchdog``), or by polling every ``--poll`` seconds, which is also the fallback
    where events are unavailable (some network file systems: there, pass ``--poll``).
    An archive that cannot be read (a dangling symbolic link, permission denied) is
    skipped with one warning, and looked at again when it changes.

Exactly once
    ``REPORTS/.watch-state.json`` records the sha256 of each archive's content (of the
    file, of every file of a directory, of the members of a group) and its result. A
    restarted watcher skips what it has done, and analyzes again an archive whose content
    changed (the hash is reused without reading the files again while every file has
    the size and mtime it had when recorded). The result of an archive that changed
    while it was analyzed is discarded, and it is not moved; it is analyzed again once
    it has settled (``--once`` waits for that too). Options (``--train``,
    ``--config``...) are not part of a result's record: changing them does not
    re-analyze archives found with or without a fault.
    An error is recorded with a fingerprint of the analysis options and the analyzer
    version (:func:`options_fingerprint`), and the archive is analyzed again by a
    watcher whose fingerprint differs (an error recorded by an older watcher, without
    the fingerprint, is analyzed again once). An error that is not the archive's (an
    internal error, a report that cannot be written, a full disk, an analysis process
    killed) is shown in the index but is no verdict: the archive is analyzed again on
    the next start; one whose report could not be written is also tried again while the
    watcher runs, after :data:`RETRY_FIRST_S`, doubling up to :data:`RETRY_MAX_S`. A
    report folder deleted by hand makes its archive be analyzed again on the next start.
    An archive that arrives under the name of a recorded one with other content (the
    earlier file replaced, or moved away by ``--done``) does not
    replace the earlier result: that record and its fault episodes are kept under a
    free name (that of the file ``--done`` moved it to when it differs, else
    ``name-1.ext``, ``name-2.ext``...), with ``dropped_as`` the name it came under, and
    its report folder stays where it was announced; the new content's report goes to the
    next free folder (``name-1.ext``...), said on its line, its record written before
    that folder is published (:meth:`~analyzer.watch_index.Ledger.reserve`: a kill
    between leaves no folder linked by no record). An archive that grew after
    its analysis (the earlier content is the file's beginning; a folder or group whose
    earlier files are all there, none shorter or older, each that changed beginning
    with its earlier content) is the same archive: its record is replaced
    (:meth:`_Runner._grew`). An
    archive that still looks unfinished but is recorded already with this content is
    not waited for.

One watcher per REPORTS, one per INBOX
    ``REPORTS/.lock`` is ``flock``-ed for the watcher's lifetime, and so is INBOX itself
    (a descriptor of the folder: :class:`~analyzer.watch_index.InboxLock`). A second
    watcher on the same REPORTS, or on the same INBOX with another REPORTS, does not
    wait: it exits at once with code 2 and a one-line error. REPORTS removed or replaced
    under the watcher (its lock file no longer the one locked) is made again and locked
    again before the next write, its state and index rebuilt from what it holds, and the
    archives whose reports went with it analyzed again while INBOX holds them
    (:meth:`_Runner._reports_here`); another watcher holding the new lock by then: exit 2,
    nothing more written there. ``analyzer run --out`` into a watcher's REPORTS, or a
    folder of it, is refused (:func:`analyzer.outdir.not_into_watch`). An INBOX that goes
    away is said once, and once when it is back.

Outputs
    ``REPORTS/<archive>/report.html`` and ``findings.json`` (as ``analyzer run``), or
    ``REPORTS/<archive>/error.txt`` for an archive that cannot be analyzed (corrupt,
    unreadable, too short...); each folder is written under a temporary name and renamed
    into place, so no half-written report folder is ever visible. ``REPORTS/index.html``
    and ``REPORTS/index.json`` list every archive (verdict ``fault``, ``no fault`` or
    ``error``, faulty sensors, link to the report), newest first, and every fault once
    across the archives: one that goes on from an archive into the next is one episode
    (:func:`analyzer.watch_index.episodes`). An archive analyzed past input errors (a
    truncated file, a damaged member of a folder) keeps its verdict, as with ``analyzer
    run``; the lines ``run`` warns of are logged and kept in its record
    (``input_errors``, :data:`INPUT_WARNINGS`). An archive named ``index.html``,
    ``index.json``, or starting with ``.`` or ``_``, has its folder named ``_`` + its
    name.

Inputs
    Archives are only read, never modified. ``--done DIR`` moves each analyzed archive
    (fault or no fault) to DIR after its report is written, ``--failed DIR`` each archive
    that could not be analyzed; an archive dropped again with the same content is moved
    without being analyzed again, said with its earlier result and report. A name taken
    in DIR gets a ``-1``, ``-2``... suffix, said (``moved to DIR as x-1.bag``).
    An archive is moved only once :data:`~analyzer.watch_inbox.SOON_SETTLES` settle
    times have passed since it was found complete (a change until then shows a writer
    that was only pausing: it is analyzed again instead; ``--once`` waits for these
    moves).
    An archive that these options, sound in themselves, cannot analyze (one channel,
    ``--channels`` matching none of its channels, not the channels of ``--model``:
    :attr:`Record.error_reason` ``mismatch``) is the archive's error and goes to
    ``--failed``, as a corrupt one does, once an archive has fit these options (until
    then it may be the option's: it stays, said with the option to check). An archive too
    short for the training window (a file still being written: ``too short``), one whose
    error is of the options alone (one every archive would get) or is not its own (above)
    stays in INBOX, and
    so does one that changed since it was found complete. DIR must be outside INBOX's
    own archives and outside REPORTS (exit 2 otherwise), and writable, as INBOX then must
    be (exit 2 at start otherwise; a move refused later is a warning naming the folder
    that refused it, and the archive stays in INBOX, recorded). A move to another file
    system is copies, made off the loop (other archives are started and recorded
    meanwhile), renamed into place, then the sources removed, only while INBOX holds the
    archive as it was found (one that changed while it was copied is analyzed again).

Running
    ``--jobs N`` analyses run at a time (default: one per CPU it may use), each on one
    thread, or on all N when it starts with nothing else running or waiting (a file an hour is
    analyzed on every core; the findings do not depend on it), each in its own process
    (forked from a preloaded server: a crash or a runaway archive cannot take the watcher
    down) with one BLAS thread unless ``OPENBLAS_NUM_THREADS`` / ``OMP_NUM_THREADS`` /
    ``MKL_NUM_THREADS`` say otherwise. One log line per archive on stderr when it starts
    and one when it ends (verdict and duration). The options of ``run`` apply to every
    archive; with ``--model FILE`` (saved by ``run --save-model``) every archive is tested
    whole against that one fitted model instead of being fitted on its own first minutes
    (the model file is read once, at start-up). ``--once`` processes what is in INBOX
    (waiting for it to be complete) and exits. An archive that stays stable but
    structurally unfinished for 10 minutes (``--wait-unfinished SECONDS``: a recorder
    that died, a truncated copy) is analyzed anyway, and gets its error record; the
    watcher says once, as a warning, how long it waits for it. What ``analyzer run``
    would warn about the ``--config`` on that archive (a ``[model]`` or ``[[group]]`` it
    could not use, the reason), about its training window (not steady: trained on its
    part before the change) or a figure it could not draw is a warning line of the
    watcher's too, after the archive's analysis.

On a cluster
    With ``--scheduler ADDRESS`` each archive's analysis is a task of that Dask cluster,
    one per worker thread at a time (``--jobs`` does not apply), and the worker reads the
    archive's files itself
    (INBOX at the same path on every worker); the report's files come back to the
    watcher, which publishes and records them as above (:mod:`analyzer.watch_cluster`).

Stopping
    SIGINT, SIGTERM or SIGHUP: no new analysis starts; the running ones finish and are
    recorded, then the watcher exits (an archive being hashed is not waited for: archives over
    :data:`INLINE_HASH_BYTES` are hashed by a thread of their own, off the loop; nor is a
    move's copy to another file system, made by a thread of its own too: it stops at its
    next block, what it made is removed, and the archive, recorded, is moved on the next
    start; a copy that does not stop within :data:`MOVE_GRACE_S` is left to the next
    start, as that of a watcher killed during it). A second
    signal abandons the running analyses (their processes are killed, their scratch folders
    removed, nothing recorded: they are analyzed on the next start). Analysis processes
    ignore SIGINT and SIGHUP, so Ctrl-C or a hang-up in a terminal behaves the same; under
    systemd use ``KillMode=mixed`` so that SIGTERM reaches only the watcher. A watcher
    killed outright (SIGKILL) takes its analyses with it (:func:`_end_with`); what it left
    in REPORTS
    (hidden ``.tmp-``/``.old-`` folders, half-written state) is removed by the next start,
    a move it left half-done is finished or undone then (:func:`_end_move`; one that
    cannot be told yet is kept, and what is left of its archive not analyzed), and what
    it had not recorded is analyzed again.

Exit codes: 0 after a clean shutdown; with ``--once``, 1 when an archive analyzed by this
run has a fault, else 2 when an archive of this run could not be analyzed (an error
record, an archive that cannot be read, a report that cannot be written) or INBOX holds
an archive in error that stays there (no ``--failed``, an error of the options: said
``NAME: left in INBOX: REASON`` each time it is seen, and in the index), else 0 (other
archives found analyzed already do not count), and 130 when a signal stopped it first;
2 on a usage error (INBOX missing, REPORTS locked by another watcher, ``--done`` inside
REPORTS, bad ``--group-by``...).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import ctypes
import ctypes.util
import errno
import hashlib
import json
import logging
import multiprocessing
import multiprocessing.forkserver
import os
import queue
import re
import select
import shutil
import signal
import stat
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Future
from concurrent.futures import wait as wait_futures
from dataclasses import dataclass, replace
from functools import partial
from multiprocessing.connection import wait as wait_for
from multiprocessing.context import ForkServerContext, SpawnContext
from multiprocessing.process import BaseProcess
from pathlib import Path
from types import FrameType
from typing import Any, BinaryIO, NamedTuple, TypeVar

from analyzer import __version__
from analyzer.diagnosis.training_check import window_warnings
from analyzer.errors import (
    WARNED_LINES,
    AnalyzerError,
    ArchiveMismatch,
    ArchiveTooShort,
    ConfigError,
    MachineLimit,
    TooLittleDataError,
    UsageError,
    capped,
    one_line,
    terminal_safe,
)
from analyzer.findings import Analysis, write_outputs
from analyzer.options import RunOptions, train_is_absolute
from analyzer.outdir import write_atomic
from analyzer.paging import tune_heap
from analyzer.parallel import DaskExecutor, usable_cpus
from analyzer.pipeline import (
    BlankModelNote,
    analyze_screened,
    config_warnings,
    faults_words,
    input_warnings,
)
from analyzer.readers._common import link_out, open_inside
from analyzer.report.format import magnitude
from analyzer.report.jobs import PRELOAD_MODULE
from analyzer.scratch import hold, make_scratch, remove_scratch
from analyzer.time_left import left_text
from analyzer.timeutil import spoken_duration
from analyzer.types import MSG_PATH_ENV
from analyzer.watch_cluster import ClusterTask, warm_worker
from analyzer.watch_inbox import (
    INCOMPLETE_TIMEOUT_S,
    ReadyArchive,
    Signature,
    archive_members,
    archive_paths,
    ignored,
    ready_batches,
    signature,
)
from analyzer.watch_index import (
    MISMATCH,
    TOO_SHORT,
    UNWRITTEN,
    ErrorKind,
    InboxLock,
    Ledger,
    Record,
    ReportsLock,
    Verdict,
    hidden_name,
    more_warnings,
    now_iso,
    numbered_names,
    publish,
    report_dirname,
    scratch_dir,
)
from analyzer.window_note import AnomalyNote

log = logging.getLogger("analyzer.watch")

TICK_S = 0.1
"""How often the loop wakes up while it waits for analyses to end."""
EXIT_INTERRUPTED = 130
"""``--once`` stopped by a signal before it was through (as ``analyzer run``)."""
RETRY_FIRST_S = 10.0
"""How long after a report that could not be written (REPORTS full, unwritable, gone:
not the archive's fault) its archive is analyzed again while the watcher runs; doubled
after each failure, up to :data:`RETRY_MAX_S`. Before, it waited for the next start,
weeks away for a service (a QA audit's ux66 item H2)."""
RETRY_MAX_S = 600.0
"""The longest wait between two tries of an archive whose report could not be written."""
KILL_GRACE_S = 2.0
"""When abandoning, how long an analysis process gets after SIGTERM before SIGKILL."""


GIVE_UP_AFTER_S = 3600.0
"""Default of ``--give-up-after``: a file too short for the training window, unchanged
this long, is no longer taken for one still being written (a short but complete archive
stayed in INBOX for good, and each ``--once`` exited 2). An hour: loggers that append a
table every 15 min or hourly are common, and one that pauses longer than this between
appends has its file cut in two (0: never given up)."""


def _now() -> float:
    """Seconds since the epoch (the give-up's clock: tests set it)."""
    return time.time()


@dataclass(frozen=True, slots=True)
class WatchSettings:
    """The watcher's own options (the analysis options are a :class:`RunOptions`)."""

    inbox: Path
    reports: Path
    settle: float = 2.0
    poll: float | None = None
    done: Path | None = None
    failed: Path | None = None
    group_by: re.Pattern[str] | None = None
    once: bool = False
    jobs: int = 1
    incomplete_timeout: float = INCOMPLETE_TIMEOUT_S
    give_up_after: float = GIVE_UP_AFTER_S
    """``--give-up-after``: seconds an archive too short for the training window (left in
    INBOX: a file still being written grows) stays unchanged before it is given up, an
    error of its own, and moved to ``--failed`` (:meth:`_Runner._gives_up`)."""

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> WatchSettings:
        group_by = None
        if args.group_by:
            try:
                group_by = re.compile(args.group_by)
            except re.error as err:
                raise UsageError(
                    f"--group-by: {args.group_by!r} is not a regular expression ({err})"
                ) from None
            if group_by.groups < 1:
                raise UsageError(
                    f"--group-by: {args.group_by!r} has no group; put the part of the name "
                    r"that identifies the archive in parentheses, e.g. '(\d{8}T\d{2})'"
                )
        return cls(
            inbox=Path(args.inbox),
            reports=Path(args.out),
            settle=args.settle,
            poll=args.poll,
            done=Path(args.done) if args.done else None,
            failed=Path(args.failed) if args.failed else None,
            group_by=group_by,
            once=bool(args.once),
            jobs=args.jobs or usable_cpus(),
            incomplete_timeout=args.wait_unfinished,
            give_up_after=args.give_up_after,
        )


def options_fingerprint(options: RunOptions) -> str:
    """What the findings depend on, as 16 hex digits of a sha256: the analyzer version
    and the analysis options (not ``--jobs``, ``--scheduler`` or the progress display,
    which never change them; the saved model by its file's sha256) and the kinds of
    error (:class:`ErrorKind`). An error recorded with another fingerprint is analyzed
    again (:meth:`Record.redo_reason`)."""
    config = options.config
    doc = {
        "version": __version__,
        "channels": options.channels,
        "train": options.train,
        "config": {**config.as_context(), "train": config.train},
        "detectors": options.detectors,
        "rate": options.rate,
        "time": options.time_source,
        "corrected": options.corrected,
        "model": options.model_sha256 or options.model_path,
        "screen": options.screen,
        "msg_path": os.environ.get(MSG_PATH_ENV, ""),
        # how errors are classed: an error recorded before the archive's were told from
        # the options' (a one-channel file, left in INBOX as an "options" error) is
        # analyzed again once, and moved to --failed
        "error_kinds": sorted(str(kind) for kind in ErrorKind),
    }
    text = json.dumps(doc, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _prepare(settings: WatchSettings) -> set[str]:
    """Check the folders, create the output ones; return the INBOX entries that are
    output folders (never archives)."""
    inbox = settings.inbox
    if not inbox.is_dir():
        raise UsageError(f"INBOX: {inbox} is not a directory")
    root = inbox.resolve()
    reports = settings.reports.resolve()
    exclude: set[str] = set()
    for option, folder in (
        ("--out", settings.reports),
        ("--done", settings.done),
        ("--failed", settings.failed),
    ):
        if folder is None:
            continue
        if folder.exists() and not folder.is_dir():
            raise UsageError(f"{option}: {folder} exists and is not a directory")
        if folder.resolve() == root:
            raise UsageError(f"{option}: {folder} is INBOX itself; use another folder")
        if option != "--out" and folder.resolve().is_relative_to(reports):
            # archives among the report folders: a report could take a moved file's name
            raise UsageError(
                f"{option}: {folder} is inside REPORTS (--out {settings.reports}); "
                "use a folder outside it"
            )
        inside = (
            folder.resolve().relative_to(root).parts
            if folder.resolve().is_relative_to(root)
            else ()
        )
        if len(inside) > 1:
            # (a folder directly in INBOX is left out of the archives; one deeper is in
            # an archive folder, which would then be neither analyzed nor left as it was)
            raise UsageError(
                f"{option}: {folder} is inside the archive folder {inbox / inside[0]} of "
                "INBOX: inputs are never modified; use a folder outside it, or directly in "
                "INBOX"
            )
    if root.is_relative_to(reports):
        # (report folders take archives' names: one named like INBOX replaced it)
        raise UsageError(
            f"INBOX: {inbox} is inside REPORTS (--out {settings.reports}); use folders side by side"
        )
    for option, folder in (
        ("--out", settings.reports),
        ("--done", settings.done),
        ("--failed", settings.failed),
    ):
        if folder is None:
            continue
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as err:  # (as run's --out: the option named, one line)
            raise UsageError(
                f"{option}: cannot write to {folder}: {one_line(err.strerror or err)}"
            ) from None
        if option != "--out" and not os.access(folder, os.W_OK | os.X_OK):
            # (found at once, not as a warning per archive, each left in INBOX)
            raise UsageError(f"{option}: cannot write to {folder}: permission denied")
        resolved = folder.resolve()
        if resolved.is_relative_to(root):
            exclude.add(resolved.relative_to(root).parts[0])
    moving = [
        option for option, f in (("--done", settings.done), ("--failed", settings.failed)) if f
    ]
    if moving and not os.access(inbox, os.W_OK | os.X_OK):
        raise UsageError(
            f"{' and '.join(moving)}: archives cannot be moved out of INBOX {inbox}: it is "
            "not writable (permission denied); leave the option out, or let the watcher "
            "write to INBOX"
        )
    return exclude


# --------------------------------------------------------------------------- analysis process


EXIT_INPUT_ERROR = 2
EXIT_INTERNAL_ERROR = 3
EXIT_OPTION_ERROR = 4
EXIT_MISMATCH = 5
EXIT_TOO_SHORT = 6
EXIT_UNWRITTEN = 7
"""An analysis whose outputs could not be written (REPORTS full), or that the machine
stopped (:class:`~analyzer.errors.MachineLimit`: its scratch space full, too many open
files, no memory): not the archive's
fault, which stays in INBOX and is analyzed again on the next start, as after an
internal error; but said as the file's error (``REPORTS/x.mcap/report.html: No space
left on device``), with no traceback (it was an "internal error: OSError" that asked
the user to report a bug: a QA audit's ux59 item M2)."""
ERROR_KINDS = {
    EXIT_INPUT_ERROR: ErrorKind.INPUT,
    EXIT_INTERNAL_ERROR: ErrorKind.INTERNAL,
    EXIT_UNWRITTEN: ErrorKind.INTERNAL,
    EXIT_OPTION_ERROR: ErrorKind.OPTIONS,
    EXIT_MISMATCH: ErrorKind.INPUT,
    EXIT_TOO_SHORT: ErrorKind.OPTIONS,
}
"""An analysis's exit code (:func:`analysis_into`) and whose fault its error is: kinds a
watcher of analyzer 49 knows, which reads the state file of this one
(:attr:`Record.error_reason` says more)."""
ERROR_REASONS = {EXIT_MISMATCH: MISMATCH, EXIT_TOO_SHORT: TOO_SHORT, EXIT_UNWRITTEN: UNWRITTEN}
"""The exit codes of :data:`ERROR_KINDS` with a finer reason (:attr:`Record.error_reason`)."""
MISFIT = ".misfit"
"""The file a mismatch's analysis leaves beside ``error.txt`` with the option to check
(:attr:`~analyzer.errors.ArchiveMismatch.option`), read into
:attr:`Record.misfit_option`."""


CONFIG_WARNINGS = ".config-warnings"
"""The file an analysis leaves beside its outputs with the lines ``analyzer run`` prints
about the config (:func:`~analyzer.pipeline.config_warnings`), the training window
(:func:`~analyzer.diagnosis.training_check.window_warnings`: a fault inside the default
window, trained around), figures that could not be drawn and the run's anomalies
attributed to no sensor (:class:`~analyzer.window_note.AnomalyNote`), one a line; the
watcher logs them, keeps them in the archive's record (:attr:`Record.warnings`) and
removes the file before it publishes the report folder."""

CORRECTED = "corrected.csv"
"""What ``--corrected`` writes beside the report (:func:`~analyzer.findings.write_outputs`),
linked from the archive's record (:attr:`Record.corrected`)."""

FAULT_WORDS = ".faults"
"""The file an analysis with a fault leaves beside its outputs with its faults as
``analyzer run``'s last line says them (:func:`~analyzer.pipeline.faults_words`); the
watcher logs it with the report's path, keeps it in the archive's record
(:attr:`Record.summary`) and removes the file before it publishes the report folder."""

INPUT_WARNINGS = ".input-warnings"
"""The file an analysis that went on past input errors (a truncated file, a damaged
member of a folder: :func:`~analyzer.pipeline.input_warnings`) leaves beside its
outputs, a JSON list of the lines ``analyzer run`` warns of; the watcher logs them,
keeps them in the archive's record (:attr:`Record.input_errors`) and removes the file
before it publishes the report folder."""


def analysis_into(inputs: list[str], options: RunOptions, out_dir: Path, work: Path) -> int:
    """One archive's analysis: the outputs of ``analyzer run`` into ``out_dir``, or
    ``out_dir/error.txt``, with ``work`` as its scratch space; the config warnings ``run``
    would print, if any, into ``out_dir/`` :data:`CONFIG_WARNINGS` (the watcher logs
    them). Returns the exit code: 0/1 analyzed (no fault/fault), 2 input error, 3 bug or
    an error of the options alone (:class:`UsageError`, :class:`ConfigError`), 5 an
    archive that the options, sound in themselves, do not fit (one channel,
    ``--channels`` matching none of its channels: :class:`ArchiveMismatch`, its option
    in ``out_dir/`` :data:`MISFIT`), 6 an archive too short for the training window, as
    one still being written (:class:`ArchiveTooShort`, a detector's too little healthy
    data)."""
    try:
        analysis = analyze_screened(inputs, options, work)
        if isinstance(analysis.unrun, ArchiveTooShort):
            # (the constant check's findings alone: a file still being written waits to
            # grow, as before, and is analyzed whole)
            raise analysis.unrun
        try:
            _write_results(analysis, options, out_dir)
        except OSError as err:  # (REPORTS full): the file's error, not a bug's
            _error_file(out_dir, unwritten_line(err, out_dir) + "\n")
            return EXIT_UNWRITTEN
        return 1 if analysis.faulty else 0
    except (ArchiveTooShort, TooLittleDataError) as err:  # (first: a mismatch too)
        _error_file(out_dir, one_line(err) + "\n")
        return EXIT_TOO_SHORT
    except ArchiveMismatch as err:  # (a UsageError too: caught first)
        _error_file(out_dir, one_line(err) + "\n")
        with contextlib.suppress(OSError):
            write_atomic(out_dir / MISFIT, err.option)
        return EXIT_MISMATCH
    except (UsageError, ConfigError) as err:
        _error_file(out_dir, one_line(err) + "\n")
        return EXIT_OPTION_ERROR
    except AnalyzerError as err:
        _error_file(out_dir, one_line(err) + "\n")
        return 2
    except MachineLimit as err:  # (scratch space full, too many open files, no memory)
        # the machine's, not the archive's: one line, no traceback, tried again as a
        # report that could not be written is (it was "internal error: ScratchFull"
        # with a traceback, an operator's audit's ux66 M1)
        _error_file(out_dir, one_line(err.strerror or err) + "\n")
        return EXIT_UNWRITTEN
    except Exception as err:  # noqa: BLE001 - recorded as this archive's error
        text = f"internal error: {type(err).__name__}: {one_line(err)}"
        _error_file(out_dir, f"{text}\n\n{traceback.format_exc()}")
        return 3


def _write_results(analysis: Analysis, options: RunOptions, out_dir: Path) -> None:
    """The outputs of ``analyzer run`` into ``out_dir`` and the files the watcher reads
    beside them (:data:`CONFIG_WARNINGS`, :data:`INPUT_WARNINGS`, :data:`FAULT_WORDS`),
    which it removes before it publishes the folder (renamed into REPORTS whole, so a
    reader never sees part of it)."""
    figures: list[str] = []  # (figures that could not be drawn)
    write_outputs(analysis, out_dir, figures.append)
    lines = [  # (the archive's own lines first: the index shows the first)
        # (findings.json's notes too, but "no fault" in the index hid them)
        *(n for n in analysis.notes if isinstance(n, AnomalyNote)),
        # (--model: a model's channel blank in every row, and what the model lost with it)
        *(n for n in analysis.notes if isinstance(n, BlankModelNote)),
        *window_warnings(analysis.notes),
        *figures,
        # (last: every archive gets them, and first they hid its anomaly, rcfg53)
        *config_warnings(options.config, analysis),
    ]
    if lines:
        write_atomic(out_dir / CONFIG_WARNINGS, "".join(f"{line}\n" for line in lines))
    if damage := input_warnings(analysis):
        write_atomic(out_dir / INPUT_WARNINGS, json.dumps(damage))
    if analysis.findings:
        write_atomic(out_dir / FAULT_WORDS, faults_words(analysis.findings, labels=analysis.labels))


def unwritten_line(err: OSError, out_dir: Path) -> str:
    """The error line of outputs that could not be written into ``out_dir`` (the
    analysis's scratch folder, on this machine or a cluster worker's): the file by its
    name in the folder (``report.html: No space left on device``), which the watcher
    says as ``REPORTS/<folder>/report.html`` (:meth:`_Runner._result`); another file by
    its path."""
    name = os.fsdecode(err.filename) if err.filename is not None else ""
    if name and Path(name).parent == out_dir:
        name = Path(name).name
    return one_line(f"{name}: {err.strerror or err}" if name else str(err.strerror or err))


def _error_file(out_dir: Path, text: str) -> None:
    """``out_dir/error.txt``, where it can be written: on a full disk, where the analysis
    failed for want of room, it cannot, and the watcher records the process's exit code
    (a traceback of the second failure went to stderr)."""
    with contextlib.suppress(OSError):
        write_atomic(out_dir / "error.txt", text)


def _analyze_into(
    inputs: list[str], options: RunOptions, out: str, work_dir: str, watcher: int | None = None
) -> None:
    """Body of an analysis process: :func:`analysis_into`, its code the exit code; it
    ends with the watcher of pid ``watcher`` (:func:`_end_with`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is for the watcher to handle
    signal.signal(signal.SIGHUP, signal.SIG_IGN)  # (so is a terminal's hang-up)
    work = Path(work_dir)  # the watcher's: it removes it however this process ends
    hold(work)  # and if the watcher is killed, it stays while this process uses it
    if watcher is not None:
        _end_with(watcher, (Path(out), work))
    tune_heap()  # this process is the analysis's own (see analyzer.paging.tune_heap)
    code = 3
    try:
        code = analysis_into(inputs, options, Path(out), work)
    finally:
        remove_scratch(work)
    sys.exit(code)


WATCHER_CHECK_S = 1.0
"""Where a process cannot be waited for (no ``pidfd``), how often an analysis process
looks whether its watcher is still there (:func:`_end_with`)."""


def _end_with(watcher: int, leftovers: Sequence[Path]) -> None:
    """End this analysis process, removing ``leftovers`` (its hidden folder in REPORTS,
    its scratch space), as soon as the watcher process ``watcher`` is gone. A watcher
    killed outright (``kill -9``, the OOM killer) cannot stop its analyses, whose
    processes are the fork server's children: they went on analyzing (the archive
    analyzed twice at once after a restart, on cores the new watcher's analyses need)
    and wrote their outputs into a ``.tmp-`` folder of REPORTS after the new watcher had
    cleared the old ones, which then stayed there until its next start. A daemon thread
    waits on a ``pidfd`` of the watcher (Linux), else looks every
    :data:`WATCHER_CHECK_S` seconds."""

    def gone() -> None:
        for path in leftovers:
            shutil.rmtree(path, ignore_errors=True)
        os._exit(EXIT_INTERNAL_ERROR)  # (nobody is left to read the exit code)

    try:
        fd = os.pidfd_open(watcher)
    except ProcessLookupError:
        gone()
    except (AttributeError, OSError):  # (not Linux, or a kernel before 5.3)
        fd = None

    def wait() -> None:
        if fd is not None:
            select.select([fd], [], [])  # (readable once the process has ended)
        else:
            while _alive(watcher):
                time.sleep(WATCHER_CHECK_S)
        gone()

    threading.Thread(target=wait, name="analyzer-watch-watcher", daemon=True).start()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # (there, but another user's: a reused pid)
        return False
    return True


def _context() -> ForkServerContext | SpawnContext:
    """Analyses run in processes forked from a server that has the pipeline and the
    report's figure module (matplotlib: ~0.7 s per analysis otherwise) imported and the
    compiled kernels warmed (numba's first call: ~0.3 s per analysis otherwise,
    :mod:`analyzer.warm`); fast to start, safe with the watcher's threads. ``spawn``
    where there is no fork server."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(list(PRELOADED))
        return ctx
    return multiprocessing.get_context("spawn")


WARM_PRELOAD = "analyzer.warm_preload"
"""The fork server's module that warms the compiled kernels (:mod:`analyzer.warm`)."""
PRELOADED = ("analyzer.watch", PRELOAD_MODULE, WARM_PRELOAD)
"""What an analysis finds imported and warmed: in the fork server, and on each worker of
a cluster (:func:`analyzer.watch_cluster.warm_worker`)."""

BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
_ENV_LOCK = threading.Lock()


@contextlib.contextmanager
def _one_blas_thread() -> Iterator[None]:
    """Environment for starting analysis processes (and their fork server): one BLAS
    thread each, unless the user set these variables. Parallelism comes from ``--jobs``;
    threaded BLAS on the pipeline's many small least-squares problems is far slower
    (measured: 28 s instead of 1.9 s for a 5-channel, 60 000-sample archive on 2 cores)."""
    with _ENV_LOCK:
        saved = {k: os.environ.get(k) for k in BLAS_THREADS}
        for k in BLAS_THREADS:
            os.environ.setdefault(k, "1")
        try:
            yield
        finally:
            for k, v in saved.items():
                if v is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = v


def _warm_up() -> None:
    """Start the fork server (it imports the pipeline: seconds) while the first archives
    settle, instead of when the first analysis starts."""
    with contextlib.suppress(Exception), _one_blas_thread():
        multiprocessing.forkserver.ensure_running()


@dataclass(slots=True)
class _Job:
    archive: ReadyArchive
    sha256: str
    hashes: ArchiveHashes
    """Its files' own sha256 and those of the beginnings :meth:`_Runner._grew` asks for."""
    scratch: Path
    process: BaseProcess | ClusterTask
    started: float
    work: Path | None
    """The analysis's scratch space (memory-mapped arrays of a long archive): made and
    removed by the watcher, so a killed analysis leaves nothing behind (None on a
    cluster: the worker has its own)."""

    def remove_work(self) -> None:
        if self.work is not None:
            remove_scratch(self.work)


def _warm_cluster(cluster: DaskExecutor) -> None:
    """:func:`~analyzer.watch_cluster.warm_worker` on every worker (imports and compiled
    kernels), while the first archives settle."""
    with contextlib.suppress(Exception):
        cluster.client.run(warm_worker)


def _size(signature: Sequence[Sequence[Any]]) -> int:
    """The bytes of the files of a signature (``(path, size, mtime_ns)`` each)."""
    return sum(int(entry[1]) for entry in signature)


def _renamed_words(archive: ReadyArchive, moved: Sequence[str]) -> str:
    """`` as NAME`` where a single file was moved under another name (its own was taken
    in the folder: ``x-1.bag``), else "": the line said only "moved to DONE", and the
    archive was not there under its name."""
    if len(moved) != 1 or len(archive.paths) != 1:
        return ""
    name = Path(moved[0]).name
    return "" if name == archive.paths[0].name else f" as {name}"


def _free_name(folder: Path, name: str) -> Path:
    """``folder/name``, or ``folder/stem-N.suffixes`` if that is taken
    (:func:`~analyzer.watch_index.numbered_names`)."""
    if not os.path.lexists(folder / name):
        return folder / name
    return next(folder / c for c in numbered_names(name) if not os.path.lexists(folder / c))


def _other_fs(paths: Sequence[Path], folder: Path) -> bool:
    """Whether a path of ``paths`` is on another file system than ``folder`` (a symbolic
    link's own, not its target's): moved by copies, not renames."""
    device = os.lstat(folder).st_dev
    return not all(os.lstat(p).st_dev == device for p in paths)


def _free_of(folder: Path, name: str, taken: Sequence[Path]) -> Path:
    """:func:`_free_name`, free of ``taken`` too (the other files of a move)."""
    target = _free_name(folder, name)
    others = numbered_names(name)
    while target in taken:
        target = _free_name(folder, next(others))
    return target


def _moving_of(
    sources: Sequence[Path], copies: Sequence[Path | None], targets: Sequence[Path]
) -> list[list[str]]:
    """A move's :attr:`~analyzer.watch_index.Record.moving` lines, ``[source, copy,
    target]`` (``copy`` "" for a rename): what :func:`_moving_lines` reads back."""
    lines = zip(sources, copies, targets, strict=True)
    return [[str(s), str(c) if c else "", str(t)] for s, c, t in lines]


_RENAME_NOREPLACE, _AT_FDCWD = 1, -100  # linux/fs.h, fcntl.h


def _renameat2_function() -> Any:
    try:
        fn = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True).renameat2
    except (OSError, AttributeError):  # not Linux, or a C library before glibc 2.28
        return None
    fn.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint)
    return fn


_RENAMEAT2 = _renameat2_function()

_NO_HARD_LINKS = (errno.EPERM, errno.EOPNOTSUPP, errno.ENOSYS, errno.EMLINK, errno.EXDEV)
"""``link`` errors of a file system without hard links (vfat, some network shares)."""


def _rename_new(source: Path, target: Path, before_link: Callable[[], None] | None = None) -> None:
    """Rename ``source`` to ``target`` (the same file system), never replacing a file
    there: :class:`FileExistsError` where ``target`` exists, made by another process
    since it was looked at too. ``renameat2(RENAME_NOREPLACE)`` (Linux); where it is
    missing or refused (a file system without it), a file is linked to ``target`` and
    then unlinked (``link`` never replaces), and a folder, which cannot be, renamed
    after a look (a rename replaces only an empty folder; a file or a folder that holds
    anything fails it). Before, a look then ``rename``: a file made in between was lost.

    A kill between the link and the unlink leaves the file under both names: the next
    start ends such a move from the state file (:func:`_end_move`), where a move of one
    file, which writes none for a rename, writes it in ``before_link``. An unlink
    refused (INBOX read-only to the watcher) unlinks ``target`` again (the same file,
    still under its own name) and raises: before, the file stayed in INBOX and under
    ``target`` too, one more name at each try."""
    if _RENAMEAT2 is not None:
        src, dst = os.fsencode(source), os.fsencode(target)
        if _RENAMEAT2(_AT_FDCWD, src, _AT_FDCWD, dst, _RENAME_NOREPLACE) == 0:
            return
        err = ctypes.get_errno()
        if err not in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
            raise OSError(err, os.strerror(err), str(source), None, str(target))
    if source.is_dir() and not source.is_symlink():
        if os.path.lexists(target):
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(target))
        try:
            os.rename(source, target)
        except OSError as err:
            if err.errno in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR):
                raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(target)) from err
            raise
        return
    if before_link is not None:
        before_link()
    try:
        os.link(source, target, follow_symlinks=False)
    except OSError as err:
        if err.errno not in _NO_HARD_LINKS:
            raise
        if os.path.lexists(target):  # (no hard links: a look, then the rename, as before)
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(target)) from err
        os.rename(source, target)
        return
    try:
        os.unlink(source)
    except OSError:
        if _linked(source, target):  # (never the file's last name: it is still source)
            os.unlink(target)
            raise
        if os.path.lexists(source) or not os.path.lexists(target):
            raise
        # (source unlinked by another process meanwhile: the file is at target, moved)


def _linked(source: Path, target: Path) -> bool:
    """Whether ``source`` and ``target`` are one file by two names: a rename by
    :func:`_rename_new`'s link and unlink stopped between them."""
    try:
        a, b = os.lstat(source), os.lstat(target)
    except OSError:
        return False
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _place(path: Path, targets: list[Path], k: int, tell: Callable[[], None]) -> Path:
    """``path`` renamed to ``targets[k]``, or, where that name was taken since it was
    planned, to a free one (``targets[k]`` updated) told first (``tell``: the state
    file), so that the record names the archive's own file. The rename never replaces
    a file (:func:`_rename_new`): a name taken between the look and the rename is
    found taken by the rename itself, and another free one told and tried."""
    while True:
        if os.path.lexists(targets[k]):
            targets[k] = _free_of(targets[k].parent, targets[k].name, targets)
            tell()
        try:
            _rename_new(path, targets[k])
            return targets[k]
        except FileExistsError:
            if not os.path.lexists(targets[k]):  # (not a name taken: never tried again)
                raise


class MoveCancelled(Exception):
    """:func:`_copy_all` stopped by its ``cancel`` event (the watcher stopping, or the
    archive changed since its copies began)."""


class _CopyFailed(Exception):
    """An :class:`OSError` of a file's copy in a folder's, out of :func:`shutil.copytree`
    at once (which would go on with the other files and raise them all as one)."""

    def __init__(self, err: OSError) -> None:
        super().__init__(err)
        self.err = err


COPY_BLOCK = 8 << 20
"""Bytes copied at a time to another file system (:func:`_copy_file`: a stop is seen
between two blocks)."""


def _copy_file(source: Path, copy: Path, cancel: threading.Event) -> None:
    """:func:`shutil.copy2` of ``source`` (a link as a link), in blocks of
    :data:`COPY_BLOCK` by ``sendfile`` (read and write where it is refused), raising
    :class:`MoveCancelled` at the next block once ``cancel`` is set: one call of
    ``copy2`` copied a 1.5 GB file in one piece, and nothing could stop it. Its bytes,
    then its mode and times (the size and mtime by which the next start knows the copy as
    the archive's: :func:`_end_move`)."""
    if source.is_symlink():
        shutil.copy2(source, copy, follow_symlinks=False)
        return
    # O_NONBLOCK: a FIFO (in a folder, or put in a file's place since it was listed)
    # opens at once instead of waiting for a writer, and is refused by its fstat
    fd = os.open(source, os.O_RDONLY | os.O_NONBLOCK)
    with os.fdopen(fd, "rb") as fin:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise shutil.SpecialFileError(errno.EINVAL, "not a regular file", str(source))
        _copy_blocks(source, fin, copy, cancel)
    shutil.copystat(source, copy)


def _copy_blocks(source: Path, fin: BinaryIO, copy: Path, cancel: threading.Event) -> None:
    """The bytes of :func:`_copy_file`, from ``fin`` (``source`` opened) to ``copy``. An
    error names ``copy``'s folder where it is full (also at the close, where the read and
    write path writes its last buffered bytes), else ``source``."""
    try:
        with copy.open("wb") as fout:
            sendfile, offset = hasattr(os, "sendfile"), 0
            while not cancel.is_set():
                try:
                    if sendfile:
                        n = os.sendfile(fout.fileno(), fin.fileno(), offset, COPY_BLOCK)
                    else:
                        block = fin.read(COPY_BLOCK)
                        n = fout.write(block)
                except OSError as err:
                    full = err.errno in (errno.ENOSPC, errno.EDQUOT)
                    if sendfile and offset == 0 and not full:
                        sendfile = False  # (a file system that refuses it: as shutil does)
                        continue
                    raise
                if n == 0:
                    break
                offset += n
            else:
                raise MoveCancelled(str(source))
    except OSError as err:
        if err.filename is None:  # (a full disk is the folder's, else the source's)
            full = err.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
            err.filename = str(copy.parent if full else source)
        raise


def _copy_all(
    paths: Sequence[Path], copies: Sequence[Path], cancel: threading.Event | None = None
) -> None:
    """Copy each of ``paths`` (a file, a link, a folder with what it holds) to its
    ``copies`` (hidden names in the folder of a move), stopping at the next block once
    ``cancel`` is set (:class:`MoveCancelled`). Raises the first :class:`OSError`; on
    either, what it made is removed first."""
    cancel = cancel or threading.Event()

    def one(source: str, copy: str) -> None:
        try:
            _copy_file(Path(source), Path(copy), cancel)
        except OSError as err:
            raise _CopyFailed(err) from err

    made: list[Path] = []
    try:
        for path, copy in zip(paths, copies, strict=True):
            made.append(copy)
            if path.is_dir() and not path.is_symlink():
                shutil.copytree(path, copy, symlinks=True, copy_function=one)
            else:
                _copy_file(path, copy, cancel)
    except (OSError, MoveCancelled, _CopyFailed) as err:
        for p in made:
            _remove(p)
        if isinstance(err, _CopyFailed):
            raise err.err from None
        raise


def _plan_move(
    paths: Sequence[Path], folder: Path, copies: bool
) -> tuple[list[Path], list[Path | None]]:
    """The targets of a move of ``paths`` into ``folder`` (free names, free of each
    other's too) and, for a move by copies, the hidden names the copies are made under
    (else None). Raises :class:`OSError` for a source that could not be removed after
    its copy (it would be left twice)."""
    if copies:
        for path in paths:
            if not os.access(path.parent, os.W_OK | os.X_OK):
                raise OSError(errno.EACCES, "cannot remove it from INBOX", str(path))
    targets: list[Path] = []
    for path in paths:
        targets.append(_free_of(folder, path.name, targets))
    staged = [folder / hidden_name(".partial-", t.name) if copies else None for t in targets]
    return targets, staged


class _Stayed(NamedTuple):
    """The sources a move by copies left in INBOX (:func:`_place_all`), for its line."""

    paths: tuple[Path, ...]
    """The source that could not be removed (a folder perhaps in part) and those after
    it, not tried."""
    err: OSError


def _place_all(
    paths: Sequence[Path],
    copies: Sequence[Path],
    targets: list[Path],
    tell: Callable[[], None],
    stayed: list[_Stayed] | None = None,
) -> list[Path]:
    """The end of a move by copies, once every copy is made: each renamed to its target
    (:func:`_place`), then the sources removed. Raises the first :class:`OSError` with
    what was made in the folder removed and INBOX as it was; a source that cannot be
    removed (INBOX turned read-only since) keeps its place and loses its copy, and so do
    those after it: the archive split, the sources left in INBOX appended to ``stayed``
    (a folder partly removed keeps its copy, and is among them)."""
    made = list(copies)  # in the folder: the copies, then the files renamed from them
    try:
        for k, copy in enumerate(copies):
            made[k] = _place(copy, targets, k, tell)
    except OSError:
        for p in made:
            _remove(p)
        raise
    for k, path in enumerate(paths):
        folder_source = path.is_dir() and not path.is_symlink()
        try:
            _remove(path, strict=True)
        except OSError as err:
            # a file still whole in INBOX keeps its place and loses its copy; a folder
            # partly removed keeps its copy
            moved = k + 1 if folder_source else k
            for p in targets[moved:]:
                _remove(p)
            if moved == 0:
                raise
            if stayed is not None:
                stayed.append(_Stayed(tuple(paths[k:]), err))
            return targets[:moved]
    return targets


def _move_all(
    paths: Sequence[Path],
    folder: Path,
    intent: Callable[[list[list[str]]], None] | None = None,
    kept: list[_Kept] | None = None,
) -> list[Path]:
    """Move ``paths`` into ``folder`` under free names (:func:`_free_name`), all or none.
    Where a path is on another file system than ``folder`` (a symbolic link's own, not
    its target's), the archive's files are copied first (to hidden names there), and
    the sources go only once every copy is in place: a move that failed part-way
    (``--done`` on a full disk) left a truncated copy in ``folder``, and split an archive
    of several files, whose rest was then analyzed alone as the archive. Raises the first
    :class:`OSError`, with what was made in ``folder`` removed and INBOX as it was. (The
    watcher makes the copies on a thread of their own: :meth:`_Runner._move`.)

    A move that can be stopped half-done (copies, several renames, or one rename by
    link and unlink, :func:`_rename_new`) is handed to ``intent`` first, as ``[source,
    copy, target]`` lines (``copy`` "" for a rename), for the state file, and again
    before a file goes to another name than planned (taken since): a watcher killed
    during it is finished or undone by the next start (:func:`_end_moves`), and the
    record names the archive's own files.

    Several renames that fail part-way are undone: the files renamed already go back to
    their names in INBOX (:func:`_put_back`), and the move's lines are emptied. Before,
    they stayed in ``folder`` and the rest in INBOX, later analyzed alone as the
    archive. Where the name in INBOX of one of them is taken by another file, none goes
    back (:class:`_NamesTaken` raised): the lines stay in the state file, for the next
    start to end the move (:func:`_end_moves`), and what is left in INBOX is not
    analyzed meanwhile (before, the others went back, and the new file was analyzed
    with them as the archive); so too where one cannot go back for another cause. Such
    a file, or one whose name was taken in the instant it went back, stays in
    ``folder``, never lost, appended to ``kept`` with why; for the latter the lines are
    left to the caller (emptied with the record's ``moved_to``). The lines stay too
    while files go back: a kill then is ended by the next start."""
    copies = _other_fs(paths, folder)
    if not copies and len(paths) == 1:
        # (a rename: nothing half-done, told only before a link and unlink in its stead)
        return [_rename(paths[0], folder, intent)]
    targets, staged = _plan_move(paths, folder, copies)

    def tell() -> None:
        if intent is not None:
            intent(_moving_of(paths, staged, targets))

    tell()
    if not copies:  # (several renames: one stopped between them is finished next start)
        placed: list[Path] = []
        try:
            for k, path in enumerate(paths):
                placed.append(_place(path, targets, k, tell))
        except OSError as err:
            left: list[_Kept] = []
            renamed = list(zip(paths[: len(placed)], placed, strict=True))
            undone = _put_back(renamed, left, err)  # (_NamesTaken: the lines stay)
            if kept is not None:
                kept.extend(left)
            if undone and not left and intent is not None:
                intent([])  # (a file kept: emptied by the caller with its moved_to)
            raise
        return placed
    made = [c for c in staged if c is not None]
    _copy_all(paths, made)
    return _place_all(paths, made, targets, tell)


class _Kept(NamedTuple):
    """A file of a move undone that stays in the folder of the move (:func:`_put_back`)."""

    path: Path
    why: str
    taken: bool
    """Its name in INBOX taken in the instant it went back (the move is over); else the
    move is left for the next start to end."""


class _NamesTaken(OSError):
    """A move of renames that failed part-way (``cause``, whose errno, message and file
    it has) left as it is, not undone: ``names``, in INBOX, of files it renamed are
    taken by other files since (:func:`_put_back`)."""

    def __init__(self, cause: OSError, names: list[str]) -> None:
        super().__init__(cause.errno, cause.strerror, cause.filename)
        self.names = names


def _put_back(renamed: Sequence[tuple[Path, Path]], kept: list[_Kept], cause: OSError) -> bool:
    """Undo the renames of a move that failed (``cause``) part-way: each ``(source,
    target)`` of ``renamed`` renamed back, never over a file (:func:`_rename_new`); a
    target that is its source by a second name (a rename by link and unlink killed
    between) unlinked. All or none: where a source's name in INBOX is taken by another
    file, nothing is put back and :class:`_NamesTaken` is raised (the move left for the
    next start, what is left in INBOX not analyzed); before, the others went back, and
    the new file was analyzed with them as the archive. One whose name is taken in the
    instant it goes back, after that look, stays where it is, appended to ``kept`` with
    why (as one that cannot go back for another cause); returns whether every file is
    back or kept for that reason alone (else the move is left for the next start)."""
    taken = [s.name for s, t in renamed if os.path.lexists(s) and not _linked(s, t)]
    if taken:
        raise _NamesTaken(cause, taken) from cause
    ended = True
    for source, target in renamed:
        try:
            if _linked(source, target):
                _remove(target, strict=True)
            else:
                _rename_new(target, source)
            continue
        except FileExistsError:
            left = _Kept(target, f"its name in INBOX, {source.name}, was taken meanwhile", True)
        except OSError as err:
            ended = False
            left = _Kept(
                target, f"it cannot go back to INBOX: {one_line(err.strerror or err)}", False
            )
        kept.append(left)
    return ended


_Line = tuple[Path, Path | None, Path]
"""A line of :attr:`~analyzer.watch_index.Record.moving`: source, copy (None for a
rename), target."""


def _moving_lines(rec: Record) -> list[_Line]:
    """The lines of ``rec``'s move; raises ValueError for lines that are not as written
    (a state file edited by hand): a copy, removed to undo the move, must be a hidden
    ``.partial-`` file beside its target."""
    lines: list[_Line] = []
    if not isinstance(rec.moving, list):
        raise ValueError("not a list")
    for line in rec.moving:
        if not (
            isinstance(line, list) and len(line) == 3 and all(isinstance(x, str) for x in line)
        ):
            raise ValueError(f"{line!r}: not [source, copy, target]")
        source, copy, target = line
        if not source or not target:
            raise ValueError(f"{line!r}: no source or target")
        if not all(Path(x).is_absolute() and "\0" not in x for x in line if x):
            raise ValueError(f"{line!r}: not absolute paths")  # (else: the start's folder's)
        if copy and (
            not Path(copy).name.startswith(".partial-") or Path(copy).parent != Path(target).parent
        ):
            raise ValueError(f"{line!r}: not a copy of the watcher's")
        lines.append((Path(source), Path(copy) if copy else None, Path(target)))
    if not lines:
        raise ValueError("no lines")
    return lines


def note_moves(
    reports: Path, rec: Record, sources: Sequence[Path | str], targets: Sequence[str]
) -> None:
    """Write into ``rec``'s ``findings.json`` where each of its inputs is now, after a
    move by ``--done``/``--failed``: ``inputs[].moved_to`` beside ``path`` (where it was
    read, in INBOX, which no longer holds it); a member of a folder moved whole, under
    the folder's new place. Written atomically, as every file of REPORTS. A report that
    cannot be read or written is said in one line, the move kept (it is in the state
    file and the index)."""
    if rec.verdict is Verdict.ERROR or len(sources) != len(targets):
        return
    path = reports / rec.folder / "findings.json"
    pairs = [(os.path.abspath(s), t) for s, t in zip(sources, targets, strict=True)]
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        for item in doc["inputs"]:
            read = os.path.abspath(str(item["path"]))
            for source, target in pairs:
                if read == source or read.startswith(source + os.sep):
                    item["moved_to"] = target + read[len(source) :]
                    break
        write_atomic(path, json.dumps(doc, indent=2, allow_nan=False) + "\n")
    except (OSError, ValueError, KeyError, TypeError) as err:
        log.warning(
            "%s: its findings.json does not say where its inputs were moved (%s)",
            rec.name,
            one_line(getattr(err, "strerror", None) or err),
        )


def _end_moves(ledger: Ledger, inbox: Path) -> None:
    """At the start: the moves of a watcher killed outright during them, finished or
    undone (:func:`_end_move`), each said in a line. A move that cannot be ended yet
    keeps its lines (tried again at the next start), and what is left of its archive in
    INBOX is not analyzed meanwhile (:meth:`_Runner.offer`)."""
    for rec in ledger.records.values():
        if not rec.moving:
            continue
        try:
            lines = _moving_lines(rec)
        except ValueError as err:
            log.warning(
                "%s: its move in the state file cannot be read (%s): ignored", rec.name, err
            )
            rec.moving = []
            continue
        folder = lines[0][2].parent

        def intent(moving: list[list[str]], rec: Record = rec) -> None:
            rec.moving = moving
            with contextlib.suppress(OSError):  # (REPORTS full: saved at the start's end)
                ledger.save_state()

        moved_from: list[Path] = []
        try:
            how, moved = _end_move(rec, inbox, lines, intent, moved_from)
        except OSError as err:
            nor = ""
            if isinstance(err, _NamesTaken):
                nor = f"; nor undone: {', '.join(err.names)} in INBOX taken by another file since"
            log.warning(
                "%s: its move to %s, stopped by force, cannot be ended: %s%s; what is left "
                "of it in INBOX is not analyzed, and the next start tries again",
                rec.name,
                folder,
                _move_error(err, [line[0] for line in lines], folder),
                nor,
            )
            continue
        if how == "kept":
            log.warning(
                "%s: its move to %s, stopped by force, cannot be ended: part of it is "
                "neither in INBOX as it was nor found in %s (not mounted? taken from "
                "there?); what is left of it in INBOX is not analyzed, and the next start "
                "tries again (ended once the part is back there, or what is left is removed "
                "from INBOX)",
                rec.name,
                folder,
                folder,
            )
            continue
        rec.moving = []
        if moved:  # (maybe in part; under other names than planned where taken since)
            rec.moved_to = [*rec.moved_to, *moved]
            note_moves(ledger.reports, rec, moved_from, moved)
        said = {
            "undone": "undone (its copies there removed); it is moved again",
            "changed": "undone (its copies there removed): part of it changed since it "
            "was analyzed; it is analyzed again (if its content changed), then moved",
            "not begun": "had not begun; it is moved again",
            "finished": "finished",
            "gone": "finished as far as can be told (part of it, gone from INBOX, is not in "
            "it: taken from there since?)",
            "put back": "could not be finished (a rename refused): undone, its files put back "
            "in INBOX; it is moved again",
        }[how]
        if how == "put back" and moved:
            said += f" (but for {', '.join(moved)}, whose name in INBOX was taken since)"
        log.info("%s: its move to %s, stopped by force, %s", rec.name, folder, said)


_OLD_COPY = re.compile(r"\.partial-.+-[0-9a-f]{8}")
"""The name of a move's copy (:func:`_plan_move`: ``hidden_name(".partial-", ...)``)."""


def _forget_left(ledger: Ledger, inbox: Path) -> None:
    """Clear :attr:`Record.left_in_inbox` of the archives no longer in INBOX (removed
    by hand since): the index said "left in INBOX" of a file that was gone."""
    gone = [
        rec
        for rec in ledger.records.values()
        if rec.left_in_inbox and not any((inbox / p).exists() for p in rec.inputs)
    ]
    for rec in gone:
        rec.left_in_inbox = None
    if gone:
        with contextlib.suppress(OSError):  # (REPORTS full: the next record says it)
            ledger.save()


def _unknown_copies(ledger: Ledger, folders: Sequence[Path | None]) -> list[Path]:
    """The hidden ``.partial-`` copies in ``folders`` (``--done``, ``--failed``) that no
    move of the state file names: left by a watcher older than the forty-sixth session,
    killed during a move to another file system (it wrote no move to the state file),
    or a copy of another watcher sharing the folder. Said at the start, never removed:
    nothing tells them from a file of another process of that name, and a watcher
    under way may be making them."""
    known: set[str] = set()
    for rec in ledger.records.values():
        with contextlib.suppress(ValueError):
            known.update(str(c) for _, c, _ in (_moving_lines(rec) if rec.moving else ()) if c)
    found: list[Path] = []
    for folder in dict.fromkeys(f for f in folders if f is not None):
        try:
            with os.scandir(folder) as entries:
                names = sorted(e.name for e in entries if _OLD_COPY.fullmatch(e.name))
        except OSError:
            continue
        found += [folder / n for n in names if str(folder / n) not in known]
    return found


UNKNOWN_COPIES_NAMED = 10
"""How many unknown ``.partial-`` copies the start's line names (:func:`_unknown_copies`)."""


def _end_move(
    rec: Record,
    inbox: Path,
    lines: list[_Line],
    intent: Callable[[list[list[str]]], None],
    moved_from: list[Path] | None = None,
) -> tuple[str, list[str]]:
    """Finish or undo the move of ``rec`` that a watcher killed outright left half-done
    (its :attr:`~analyzer.watch_index.Record.moving`, as ``lines``); returns how (below)
    and the targets the archive is in now, whose sources are appended to ``moved_from``
    in the same order (a target may have another name than its line's: one taken
    since, :func:`_place`). Decided from the sources and from what is
    the archive's own: a file is the archive's (a source as recorded, or a copy or
    target of it) only where it has the size and mtime the record has for the source
    (a rename and ``copy2`` keep both), never by its name alone (another process may
    have put a file of that name in the folder since).

    - ``"undone"``/``"not begun"``: every source still in INBOX as recorded and none of
      the archive's files in place: its ``.partial-`` copies removed (if any); the
      archive, recorded, is moved again.
    - ``"changed"``: as undone, but a source changed since it was recorded (a writer
      appending while it was copied): still before the point of no return, since the
      sources go only once every copy is in place (:func:`_place_all`, and below), and
      neither a target in place nor a source gone or part-removed says otherwise; the
      archive is analyzed again (if its content changed), then moved. Before, its
      truncated copy made the move "kept" for good, the archive held in INBOX.
    - ``"finished"``: past the point of no return (a file in place, or a source gone),
      and every file of the archive in place or able to be (a whole copy, or a source to
      rename): the rest renamed (a target taken since: another free name, told to
      ``intent`` first), the sources left in INBOX removed.
    - ``"gone"``: as finished, but a part neither in INBOX nor identifiable in the folder
      (taken from there since): the move is over with what is there.
    - ``"kept"``: such a part, and the rest still in INBOX: nothing touched (the folder
      may be a mount not mounted yet); the move stays, for the next start.
    - ``"put back"``: a move of renames (every file in place or in INBOX, as a watcher
      killed while it undid a move refused part-way leaves it) whose finish is refused
      again: undone (:func:`_put_back`), the targets returned those kept in the folder
      (their names in INBOX taken in the instant they went back); the archive is moved
      again. Before, the move was kept, and the rest held in INBOX, at every start while
      the refusal lasted. Where a file cannot go back, or the name in INBOX of one is
      taken by another file (:class:`_NamesTaken`: none put back), the error is raised
      (the move kept, the rest held).

    Before, an archive whose first planned name was taken by another file was taken for
    moved: a source was removed with no copy of it anywhere, or left alone in INBOX and
    analyzed as the archive; and a source gone from INBOX with --done emptied since
    made the move "undone", the rest analyzed alone."""
    entries: dict[Path, set[tuple[str, int, int]]] = {}
    for source, _, _ in lines:  # (each source's recorded files, by their path in it)
        try:
            rel = source.relative_to(inbox).as_posix()
            entries[source] = {
                (n[len(rel) :], int(size), int(mtime))
                for n, size, mtime in rec.signature
                if n == rel or str(n).startswith(rel + "/")
            }
        except (ValueError, TypeError):  # (INBOX another folder now; a hand-edited state)
            entries[source] = set()

    def files(path: Path) -> set[tuple[str, int, int]] | None:
        try:
            sig = signature([path], path.parent) if os.path.lexists(path) else None
        except (OSError, ValueError):
            return None
        if sig is None:
            return None
        return {(n[len(path.name) :], size, mtime) for n, size, mtime in sig}

    def is_of(path: Path | None, source: Path, whole: bool = True) -> bool:
        """Whether ``path`` is ``source`` as recorded (``whole``: all of it; else what is
        left of it, a folder partly removed)."""
        if path is None or not entries[source]:
            return False
        found = files(path)
        if found is None:
            return False
        return found == entries[source] if whole else found <= entries[source]

    in_place = [is_of(t, s) for s, _, t in lines]
    # a source in INBOX: there, as recorded or changed since, but not a folder with only
    # some of its files, as recorded (the move's removal of it stopped part-way)
    there = [
        os.path.lexists(s) and (is_of(s, s) or not is_of(s, s, whole=False)) for s, _, _ in lines
    ]
    if all(there) and not any(in_place):
        removed = False
        for _, copy, _ in lines:
            if copy is not None and os.path.lexists(copy):
                _remove(copy, strict=True)
                removed = True
        if not all(is_of(s, s) for s, _, _ in lines):
            return "changed", []
        return ("undone" if removed else "not begun"), []
    placeable = [
        placed or is_of(c, s) if c is not None else placed or is_of(s, s)
        for (s, c, _), placed in zip(lines, in_place, strict=True)
    ]
    if not all(placeable) and any(is_of(s, s, whole=False) for s, _, _ in lines):
        return "kept", []
    sources = [s for s, _, _ in lines]
    copies = [c for _, c, _ in lines]
    targets = [t for _, _, t in lines]

    def tell() -> None:
        intent(_moving_of(sources, copies, targets))

    renamed = [(s, t) for (s, _, _), t, p in zip(lines, targets, in_place, strict=True) if p]
    for k, (source, copy, _) in enumerate(lines):
        if in_place[k] or not placeable[k]:
            if copy is not None and not in_place[k] and os.path.lexists(copy):
                _remove(copy, strict=True)  # (truncated: its source is gone)
            continue
        try:
            renamed.append((source, _place(copy if copy is not None else source, targets, k, tell)))
        except OSError as err:
            # a move of renames, each file there: undone, as by the watcher (_move_all)
            if not all(placeable) or any(c is not None for c in copies):
                raise
            kept: list[_Kept] = []
            if not _put_back(renamed, kept, err):
                raise
            if moved_from is not None:
                source_of = {t: s for s, t in renamed}
                moved_from += [source_of[k.path] for k in kept]
            return "put back", [str(k.path) for k in kept]
    for (source, copy, _), placed, target in zip(lines, placeable, targets, strict=True):
        if placed and copy is not None and _linked(copy, target):
            _remove(copy, strict=True)  # (its rename by link and unlink, killed between)
        if placed and copy is not None and is_of(source, source, whole=False):
            _remove(source, strict=True)
        elif placed and copy is None and _linked(source, target):
            _remove(source, strict=True)  # (as for a copy)
    moved = [str(t) for t, placed in zip(targets, placeable, strict=True) if placed]
    if moved_from is not None:
        moved_from += [s for s, placed in zip(sources, placeable, strict=True) if placed]
    return ("finished" if all(placeable) else "gone"), moved


def _move_error(err: OSError, paths: Sequence[Path], folder: Path) -> str:
    """Why :func:`_move_all` failed, for its log line: a refused rename names its
    source only, where the folder that refused may be the target (``--done`` made
    read-only while the watcher runs) or INBOX (a file it may not remove)."""
    if err.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        if not os.access(folder, os.W_OK | os.X_OK):
            return f"cannot write to {folder}: {one_line(err.strerror or err)}"
        for path in paths:
            if not os.access(path.parent, os.W_OK | os.X_OK):
                return f"cannot remove {path} from {path.parent}: {one_line(err.strerror or err)}"
    where = f"{os.fsdecode(err.filename)}: " if err.filename else ""
    return f"{where}{one_line(err.strerror or err)}"


def _removal_error(err: OSError) -> str:
    """Why a source of a move by copies could not be removed from INBOX, for its line."""
    where = f"{os.fsdecode(err.filename)}: " if err.filename else ""
    return f"cannot remove {where}{one_line(err.strerror or err)}"


def _open_in(path: Path, root: Path | None) -> BinaryIO:
    """The file ``path`` opened for reading; with ``root`` (INBOX), never through a
    symbolic link leading out of it (:func:`~analyzer.readers._common.open_inside`:
    by its real path, ``O_NOFOLLOW``), as the watcher reads INBOX's files."""
    if root is None:
        return path.open("rb")
    return os.fdopen(open_inside(path, root.resolve()), "rb")


def _sha256_head(path: Path, size: int, root: Path | None = None) -> str:
    """sha256 of the first ``size`` bytes of the file ``path`` (of INBOX ``root``)."""
    h = hashlib.sha256()
    with _open_in(path, root) as f:
        while size > 0 and (block := f.read(min(size, 1 << 20))):
            h.update(block)
            size -= len(block)
    return h.hexdigest()


BLOCK = 1 << 20
"""Bytes read at a time to hash a file."""
MARK_BYTES = 1 << 16
"""The bytes at each end of a file that its mark hashes (:func:`file_mark`)."""
REWRITTEN_IN_PLACE = (".db3", ".bag", "metadata.yaml")
"""Endings of the names of files that their writer rewrites in place as they grow (a
ROS 2 bag's sqlite storage, whose header and index pages change with every row, and
its ``metadata.yaml``; a ROS 1 bag's header, given its index on close): such a file
that changed is judged by its size and mtime alone (:meth:`_Runner._grew`)."""


def file_mark(path: Path, size: int, root: Path | None = None) -> str:
    """sha256 of the first and the last :data:`MARK_BYTES` of the first ``size`` bytes
    of the file ``path`` (all of them when there are fewer): a folder's file that grew
    from what it was keeps the mark of its earlier size, another recording put in its
    place does not. Two small reads, where a second hash of every byte of a folder
    would double the cost of hashing it on the watcher's loop. ``root``: INBOX, as
    :func:`_open_in`."""
    h = hashlib.sha256()
    with _open_in(path, root) as f:
        h.update(f.read(min(size, MARK_BYTES)))
        if size > MARK_BYTES:
            at = max(MARK_BYTES, size - MARK_BYTES)
            f.seek(at)
            h.update(f.read(size - at))
    return h.hexdigest()


@dataclass(frozen=True, slots=True)
class ArchiveHashes:
    """What one read of an archive's files gives (:func:`hash_archive`)."""

    sha256: str
    """The archive's: a single file's own, a folder's
    :func:`~analyzer.findings.sha256_of`, of several entries each one's, named."""
    marks: dict[str, str]
    """Of a folder or group, each file's :func:`file_mark` at its size, by its path
    relative to INBOX (as in a signature); empty for a single file."""
    heads: dict[str, str]
    """Of a single file, the sha256 of its first bytes as asked for (none when it is
    shorter than asked)."""


class HashCancelled(Exception):
    """:func:`hash_archive` stopped by its ``cancel`` event (the watcher stopping)."""


def hash_archive(
    paths: Sequence[Path],
    root: Path,
    head: int | None = None,
    cancel: threading.Event | None = None,
) -> ArchiveHashes:
    """The archive's sha256 (the same as the watcher has always recorded) and, of a
    folder or group, each file's :func:`file_mark`; of a single file, with ``head``
    (its earlier size), the sha256 of its first ``head`` bytes too, in the same read
    (not a second read of a large file that grew). Raises :class:`HashCancelled` soon
    after ``cancel`` is set. Files are read as :func:`_open_in` reads INBOX ``root``'s,
    and a folder's files that are links leading out of it are not part of it (as in
    its :func:`~analyzer.watch_inbox.signature`)."""
    heads: dict[str, str] = {}
    real_root = root.resolve()

    def one(path: Path, h: Any, cut: int | None = None) -> None:
        pos = 0
        with _open_in(path, root) as f:
            while True:
                if pos == cut:
                    heads[path.relative_to(root).as_posix()] = h.hexdigest()
                want = BLOCK if cut is None or pos >= cut else min(BLOCK, cut - pos)
                if not (block := f.read(want)):
                    break
                if cancel is not None and cancel.is_set():
                    raise HashCancelled(str(path))
                h.update(block)
                pos += len(block)

    single = len(paths) == 1 and not paths[0].is_dir()
    if single:
        h = hashlib.sha256()
        one(paths[0], h, head)
        return ArchiveHashes(h.hexdigest(), {}, heads)
    marks: dict[str, str] = {}

    def entry(path: Path) -> str:
        h = hashlib.sha256()
        files = [path]
        if path.is_dir():
            files = sorted(
                p for p in path.rglob("*") if p.is_file() and link_out(p, real_root) is None
            )
        for p in files:
            if path.is_dir():  # (as sha256_of: each file's path in it, then its bytes)
                h.update(p.relative_to(path).as_posix().encode())
            one(p, h)
            marks[p.relative_to(root).as_posix()] = file_mark(p, p.stat().st_size, root)
        return h.hexdigest()

    if len(paths) == 1:
        return ArchiveHashes(entry(paths[0]), marks, heads)
    outer = hashlib.sha256()
    for path in paths:
        outer.update(f"{path.name}\0{entry(path)}\n".encode())
    return ArchiveHashes(outer.hexdigest(), marks, heads)


INLINE_HASH_BYTES = 64 << 20
"""An archive of at most this many bytes is hashed on the watcher's loop (tens of
milliseconds); a larger one by :class:`_Hasher`'s thread, while the loop goes on."""


_T = TypeVar("_T")


class _Worker:
    """One daemon thread that runs jobs one at a time, off the watcher's loop, each
    job's outcome (or exception) in its :class:`Future`: the thread never touches the
    watcher's state, which the loop alone reads and writes."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._jobs: queue.SimpleQueue[tuple[Future[Any], Callable[[], Any]]] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None

    def run_later(self, job: Callable[[], _T]) -> Future[_T]:
        future: Future[_T] = Future()
        self._jobs.put((future, job))
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name=self.name, daemon=True)
            self._thread.start()
        return future

    def _run(self) -> None:
        while True:
            future, job = self._jobs.get()
            if not future.set_running_or_notify_cancel():
                continue
            try:
                future.set_result(job())
            except BaseException as err:  # noqa: BLE001 - handed to the loop
                future.set_exception(err)


class _Hasher(_Worker):
    """The thread that hashes the big archives (:func:`hash_archive`), one at a time, off
    the watcher's loop: hashing reads every byte (~1 s per GB when the file is cached;
    measured 10 s for a 2 GB file just written, on a loaded machine), and on the loop it
    held up every other archive (a small one dropped with it waited as long), the end of
    the analyses and the stop signal. :meth:`drop` and :meth:`close` make a running hash
    stop at its next block."""

    def __init__(self) -> None:
        super().__init__("analyzer-watch-hash")
        self._stops: dict[Future[ArchiveHashes], threading.Event] = {}

    def submit(self, paths: Sequence[Path], root: Path, head: int | None) -> Future[ArchiveHashes]:
        stop = threading.Event()
        future = self.run_later(lambda: hash_archive(paths, root, head, stop))
        self._stops[future] = stop
        future.add_done_callback(lambda done: self._stops.pop(done, None))
        return future

    def drop(self, future: Future[ArchiveHashes]) -> None:
        """A hash no longer wanted (of content that changed since, of an archive gone):
        not begun, or stopped at its next block."""
        stop = self._stops.get(future)
        future.cancel()
        if stop is not None:
            stop.set()

    def close(self) -> None:
        """Stop: the running hash ends at its next block, the waiting ones at their first
        (the thread, a daemon, never holds up the watcher's exit)."""
        for stop in tuple(self._stops.values()):
            stop.set()


MOVE_GRACE_S = 2.0
"""At the stop, how long the copies of a move under way get to stop (at their next
block: milliseconds) and remove what they made; after it, the move is left in the state
file for the next start to end."""


@dataclass(slots=True)
class _Copying:
    """A move by ``--done``/``--failed`` to another file system under way: its copies
    made by :attr:`_Runner.copier`'s thread, the rest (renames into place, INBOX's
    sources removed, the record) done by the loop once they are (:meth:`_Runner._copied`)."""

    archive: ReadyArchive
    rec: Record
    folder: Path
    copies: list[Path]
    targets: list[Path]
    tell: Callable[[list[list[str]]], None]
    """The move's lines to the state file (:attr:`~analyzer.watch_index.Record.moving`)."""
    future: Future[None]
    cancel: threading.Event
    again: ReadyArchive | None = None
    """The archive offered again meanwhile (changed: the move is cancelled), offered once
    the move is over."""


def _rename(
    path: Path, folder: Path, intent: Callable[[list[list[str]]], None] | None = None
) -> Path:
    """``path`` renamed into ``folder`` under a free name (:func:`_free_name`), never
    over a file made there since that name was found free (:func:`_rename_new`). Its
    move goes to ``intent`` (the state file) only before a rename by link and unlink,
    which a kill can stop between them (:func:`_end_move` ends it): before, the next
    start moved the file again, under a second name (``A-1``) beside the first."""
    while True:
        target = _free_name(folder, path.name)

        def tell(target: Path = target) -> None:
            if intent is not None:
                intent(_moving_of([path], [None], [target]))

        try:
            _rename_new(path, target, tell)
            return target
        except FileExistsError:
            if not os.path.lexists(target):
                raise


def _remove(path: Path, strict: bool = False) -> None:
    """Remove ``path`` (a folder with what it holds; a link, not its target); ``strict``:
    raise what goes wrong, else only try."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=not strict)
    elif strict:
        path.unlink()
    else:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def _earlier_files(rec: Record) -> set[tuple[str, int, int]]:
    """The (path, size, mtime) of the files of a record's signature; raises TypeError or
    ValueError for one edited by hand."""
    return {(str(p), int(n), int(t)) for p, n, t in rec.signature}


@dataclass
class _Retry:
    """An archive whose report could not be written, tried again later
    (:meth:`_Runner._unwritten`)."""

    archive: ReadyArchive
    error: str
    """The last try's error (said again only when it changes)."""
    due: float | None
    """``time.monotonic()`` of the next try; None once handed back for it."""
    delay: float
    tries: int


class _Runner:
    """The queue of ready archives and the analysis processes (at most ``jobs``)."""

    def __init__(
        self,
        settings: WatchSettings,
        options: RunOptions,
        ledger: Ledger,
        stopping: threading.Event,
        cluster: DaskExecutor | None = None,
        exclude: frozenset[str] = frozenset(),
        lock: ReportsLock | None = None,
    ) -> None:
        self.settings = settings
        self.lock = lock
        """REPORTS' lock, checked before each step that writes there (:meth:`_reports_here`)."""
        self.lost_reports = False
        """REPORTS was taken by another watcher after it was removed under this one:
        nothing more is written there."""
        self.retries: dict[str, _Retry] = {}
        """Archives whose report could not be written, tried again while the watcher
        runs (:meth:`_unwritten`), by name."""
        self.exclude = exclude
        """INBOX's entries that are output folders (never archives' members)."""
        self.stopping = stopping
        self.ledger = ledger
        self.options = replace(
            options,
            progress=None,
            warn=None,  # an archive's input errors go to its own record
            jobs=1 if settings.jobs > 1 else options.jobs,
            inside=settings.inbox.resolve(),  # (nothing read through a link out of it)
        )
        self.queue: dict[str, ReadyArchive] = {}
        self.running: dict[str, _Job] = {}
        self.expected: frozenset[str] | None = None
        """With ``--once``: the archives INBOX held at the start that it will analyze, as
        far as their records tell (:meth:`to_analyze`; the progress's total)."""
        self.skipped: set[str] = set()
        """Archives found recorded already (not in the rate of the analyses), by name."""
        self.begun: float | None = None
        """``time.monotonic()`` when the first analysis started."""
        self.results: dict[str, Verdict] = {}
        """The verdict of each archive analyzed since the start, by name, its last one
        where it was analyzed again (:meth:`summary`): counted by analysis, an archive
        analyzed while half written, then whole, was two archives, one an error."""
        self.left: set[str] = set()
        """Archives seen since the start that stay in INBOX in error
        (:meth:`_left_in_inbox`): ``--once`` exits with 2 while there are any."""
        self.unreadable: set[str] = set()
        """Archives skipped since the start because they cannot be read."""
        self.unwritten = 0
        """Analyses since the start whose outputs could not be written (a full disk)."""
        self.fingerprint = options_fingerprint(options)
        self.fitted = ledger.fitted(self.fingerprint)
        """Whether an archive has been analyzed with these options (:meth:`Ledger.fitted`):
        until then an archive they do not fit stays in INBOX (:meth:`_stays_why`)."""
        self.unfit: dict[str, ReadyArchive] = {}
        """Archives they do not fit, left in INBOX while no archive has fit these options
        (:attr:`fitted`): moved to ``--failed`` once one has (:meth:`_fits`)."""
        self.moves: dict[str, tuple[ReadyArchive, Record]] = {}
        """Archives recorded whose move by ``--done``/``--failed`` waits for the end of
        their hold (:attr:`~analyzer.watch_inbox.ReadyArchive.hold_until`)."""
        self.short: dict[str, tuple[ReadyArchive, float]] = {}
        """The archives too short for the training window, left in INBOX, and the time
        (:func:`_now`) at which they are given up if unchanged and these options have
        analyzed an archive by then (:meth:`_gives_up`)."""
        self.unsaved = False
        """A move not written to the state file (REPORTS full): written at the latest
        when the watcher stops (:meth:`save_unsaved`)."""
        self._hashed: dict[str, tuple[Signature, int | None, ArchiveHashes]] = {}
        """The last hashes of each archive not recorded with its signature: the signature
        and the earlier size whose beginning was hashed (:meth:`_head`) they are of."""
        self.hasher = _Hasher()
        self.copier = _Worker("analyzer-watch-copy")
        self.copying: dict[str, _Copying] = {}
        """Moves to another file system whose copies :attr:`copier` is making, by archive,
        in the order they began."""
        self.hashing: dict[str, tuple[ReadyArchive, int | None, Future[ArchiveHashes]]] = {}
        """Ready archives being hashed by :attr:`hasher` (too big to hash on the loop),
        started once hashed, in the order they were ready."""
        self.held: set[str] = set()
        """Archives not analyzed: what is left in INBOX of a move that the start could
        not end (:func:`_end_moves`), said once at its first offer (:meth:`offer`), or
        of a move refused part-way that this run could not undo (:meth:`_not_moved`,
        said there alone). Either ends only with a start that ends the move."""
        self.returned: list[tuple[str, Signature]] = []
        """Archives not taken as handed on (:meth:`_look_again`), for the inbox tracker
        (:meth:`handed_back`)."""
        self.asked: dict[str, tuple[Signature, int | None, Future[ArchiveHashes]]] = {}
        """Archives too big to hash on the loop that the inbox tracker asked about
        (:meth:`recorded`), being hashed by :attr:`hasher`."""
        self.cluster = cluster
        self.slots = settings.jobs
        self.ctx = _context()
        self.cluster_options: Any = None
        if cluster is not None:
            # one analysis per worker thread, each on that thread; the options (with a
            # saved model: megabytes) go to the workers once, not with every archive
            self.slots = cluster.workers
            self.cluster_options = cluster.scatter(replace(self.options, scheduler=None, jobs=1))
            threading.Thread(
                target=_warm_cluster, args=(cluster,), name="analyzer-watch-warm-up", daemon=True
            ).start()
        elif self.ctx.get_start_method() == "forkserver":
            threading.Thread(target=_warm_up, name="analyzer-watch-warm-up", daemon=True).start()

    def offer(self, archive: ReadyArchive) -> None:
        copying = self.copying.get(archive.name)
        if copying is not None:  # (its move under way: offered again once it is over)
            if archive.signature != copying.archive.signature:
                copying.cancel.set()  # (changed: its copies are not what INBOX holds)
                copying.again = archive
            return
        retry = self.retries.get(archive.name)
        if retry is not None and retry.archive.signature != archive.signature:
            del self.retries[archive.name]  # (changed: a new archive, a new series)
        self.queue.pop(archive.name, None)  # the newest state of an archive wins
        hashing = self.hashing.pop(archive.name, None)
        if hashing is not None and hashing[0].signature != archive.signature:
            self.hasher.drop(hashing[2])  # (of the old content)
        self.moves.pop(archive.name, None)  # (it changed: moved after its next analysis)
        self.short.pop(archive.name, None)  # (it changed: not given up)
        if archive.unreadable is not None:  # (said by the tracker; counted, not analyzed)
            self.unreadable.add(archive.name)
            return
        self.unreadable.discard(archive.name)
        rec = self.ledger.get(archive.name)
        if rec is not None and rec.moving:  # (what is left of it: not the archive)
            if archive.name not in self.held:  # (held by this run: said by _not_moved)
                self.held.add(archive.name)
                try:
                    folder = f" to {_moving_lines(rec)[0][2].parent}"
                except (ValueError, IndexError):
                    folder = ""
                log.warning(
                    "%s: not analyzed: what is left in INBOX of its move%s, stopped by force "
                    "by an earlier watcher, that this start could not end (said above); "
                    "left as it is until a start ends the move: restart the watcher once "
                    "its cause is mended",
                    archive.name,
                    folder,
                )
            return
        self.queue[archive.name] = archive

    def exit_code(self) -> int:
        """``--once``'s exit code: 1 when an archive analyzed by this run has a fault,
        else 2 when an archive of this run could not be analyzed (an error, unreadable,
        its report not written) or one found analyzed already is left in INBOX in error
        (:attr:`left`), else 0. Other archives found analyzed already do not count."""
        verdicts = set(self.results.values())
        if Verdict.FAULT in verdicts:
            return 1
        if Verdict.ERROR in verdicts or self.left or self.unreadable or self.unwritten:
            return 2
        return 0

    def busy(self) -> bool:
        return bool(
            self.queue
            or self.hashing
            or self.running
            or self.moves
            or self.copying
            or self.returned
        )

    def _look_again(self, archive: ReadyArchive) -> None:
        """``archive`` not taken as the tracker handed it on (INBOX no longer holds it
        so, :meth:`_as_found`: its result discarded, its move refused): the tracker
        hands it on again once it has settled, even unchanged (a ``--group-by`` member
        that came and went meanwhile), and ``--once`` waits for it. Before, the tracker
        took it for handed on: it was never analyzed (or moved) again that session."""
        self.returned.append((archive.name, archive.signature))

    def handed_back(self) -> list[tuple[str, Signature]]:
        """The archives :meth:`_look_again` gave back since the tracker last asked."""
        returned, self.returned = self.returned, []
        return returned

    def pump(self, wait: float = 0.0, start: bool = True) -> None:
        """Record the analyses that ended (waiting up to ``wait`` seconds for one), then
        start queued ones while there are free slots."""
        self._reports_here()
        self._reap(wait)
        self._retry_due()
        self._copied()
        self._held_moves()
        self._short_ends()
        self._forget_gone()
        while start and len(self.running) < self.slots:
            archive = self._next()
            if archive is None:
                break
            self._start(archive)
        # the index: when due while archives end in quick succession, at once when idle
        self.ledger.refresh_views(force=not self.busy())

    def _next(self) -> ReadyArchive | None:
        """The next archive to start, its hashes at hand (:meth:`_hashes` will not read
        it): one that :attr:`hasher` has hashed, else the first of the queue whose name
        is not running, hashed here if it is small, else handed to :attr:`hasher` (and
        the next one looked at)."""
        for name, (archive, head, future) in list(self.hashing.items()):
            if not future.done():
                continue
            del self.hashing[name]
            try:
                hashes = future.result()
            except OSError as err:
                log.info("%s: gone before its analysis (%s)", name, one_line(err.strerror or err))
                continue
            except HashCancelled:
                continue
            self._hashed[name] = (archive.signature, head, hashes)
            return archive
        for name, archive in list(self.queue.items()):
            if name in self.running:
                continue
            del self.queue[name]
            size = sum(s[1] for s in archive.signature)
            if size <= INLINE_HASH_BYTES or self._known_hashes(archive) is not None:
                return archive
            head = self._head(archive)
            asked = self.asked.pop(name, None)  # (hashed already for the tracker's question)
            if asked is not None and asked[:2] == (archive.signature, head):
                future = asked[2]
            else:
                if asked is not None:
                    self.hasher.drop(asked[2])  # (of content that has changed since)
                future = self.hasher.submit(archive.paths, self.settings.inbox, head)
            self.hashing[name] = (archive, head, future)
        return None

    # ------------------------------------------------------------------ start
    def _digest(self, archive: ReadyArchive) -> str:
        """sha256 of the archive's content (:meth:`_hashes`)."""
        return self._hashes(archive).sha256

    def _hashes(self, archive: ReadyArchive) -> ArchiveHashes:
        """The archive's hashes (:func:`hash_archive`), with that of the earlier part of a
        single file that grew since its record (:meth:`_grew`); reused from the state
        when the archive has the same (path, size, mtime) signature as when it was
        recorded, or as when it was last hashed."""
        known = self._known_hashes(archive)
        if known is not None:
            return known
        head = self._head(archive)
        hashes = hash_archive(archive.paths, self.settings.inbox, head)
        self._hashed[archive.name] = (archive.signature, head, hashes)
        return hashes

    def _known_hashes(self, archive: ReadyArchive) -> ArchiveHashes | None:
        """The archive's hashes without reading it: those of its record or of its last
        hash, when it has the signature it had then (and, of the last hash, the beginning
        :meth:`_head` asks for now: one taken against the record an analysis replaced
        since has the wrong one, and :meth:`_grew` would read it again); else None."""
        rec = self.ledger.get(archive.name)
        if rec is not None and rec.signature == [list(s) for s in archive.signature]:
            return ArchiveHashes(rec.sha256, rec.file_marks, {})
        hashed = self._hashed.get(archive.name)
        if hashed is not None and hashed[:2] == (archive.signature, self._head(archive)):
            return hashed[2]
        return None

    def _head(self, archive: ReadyArchive) -> int | None:
        """Of a single file that grew since its record, its earlier size (whose
        beginning's hash :meth:`_grew` asks for); else None."""
        rec = self.ledger.get(archive.name)
        if rec is not None and not rec.moved_to and len(archive.signature) == 1:
            with contextlib.suppress(TypeError, ValueError):  # (a state file edited by hand)
                ((name, size, _),) = _earlier_files(rec)
                if archive.signature[0][0] == name and archive.signature[0][1] >= size:
                    return size
        return None

    def recorded(self, archive: ReadyArchive) -> bool | None:
        """Whether ``archive`` is recorded already with its present content (and would
        not be analyzed again): :attr:`analyzer.watch_inbox.InboxTracker.known`. Only
        an archive whose name has a record is hashed; one over :data:`INLINE_HASH_BYTES`
        by :attr:`hasher`, and None until its hash is there (asked again at the
        tracker's next step: a 2 GB recording that looked unfinished, under the name of
        a recorded one, held the loop 20-30 s, every other archive and the stop signal
        with it)."""
        rec = self.ledger.get(archive.name)
        if rec is None:
            return False
        hashes = self._known_hashes(archive)
        if hashes is None and sum(s[1] for s in archive.signature) > INLINE_HASH_BYTES:
            hashes = self._asked_hashes(archive)
            if hashes is None:
                return None
        digest = hashes.sha256 if hashes is not None else self._digest(archive)
        return rec.sha256 == digest and rec.redo_reason(self.fingerprint) is None

    def _asked_hashes(self, archive: ReadyArchive) -> ArchiveHashes | None:
        """For :meth:`recorded`: the hashes of ``archive`` from :attr:`hasher`, asked
        for now if they are not (or were of other content), None until they are done;
        raises what the hash raised (OSError: the tracker looks again when it settles)."""
        name, head = archive.name, self._head(archive)
        asked = self.asked.get(name)
        if asked is None or asked[:2] != (archive.signature, head):
            if asked is not None:
                self.hasher.drop(asked[2])  # (of content that has changed since)
            future = self.hasher.submit(archive.paths, self.settings.inbox, head)
            self.asked[name] = (archive.signature, head, future)
            return None
        if not asked[2].done():
            return None
        del self.asked[name]
        try:
            hashes = asked[2].result()
        except HashCancelled:  # (the watcher is stopping)
            return None
        self._hashed[name] = (archive.signature, head, hashes)
        return hashes

    def _forget_gone(self) -> None:
        """Drop the hashes kept of archives gone from INBOX (the first file of their
        signature gone: no later state of theirs can have that signature), and stop
        those still being made for the tracker's question: the tracker asks no more about
        an archive deleted from INBOX, and its entry stayed for the watcher's life."""
        if not self.asked and not self._hashed:
            return
        inbox = self.settings.inbox

        def gone(sig: Signature) -> bool:
            return not sig or not os.path.lexists(inbox / sig[0][0])

        for name, (sig, _, future) in list(self.asked.items()):
            if gone(sig):
                del self.asked[name]
                self.hasher.drop(future)
        for name, (sig, _, _) in list(self._hashed.items()):
            if gone(sig):
                del self._hashed[name]

    def progress(self) -> str:
        """With ``--once``, where the watcher stands: `` [analyzed/to analyze, about T
        left]`` (the time left from the rate so far, parallel analyses included, worded
        by :func:`~analyzer.time_left.left_text` as ``run``'s progress is); else "".
        Analyses alone: the archives found analyzed already are neither done nor to do
        (before, ``[3/3]`` ended the only analysis of a pass that found two recorded,
        ux53 item 13), left out of the total from the start (:meth:`to_analyze`: it
        dropped only as the watcher reached them, so a new file that sorted first said
        ``[1/4, about 32 s left]`` for the pass's only analysis)."""
        if self.expected is None:
            return ""
        analyzed = len(self.results)
        # (those counted at the start that turn out recorded: their hash matched where
        # their signature did not, a file touched)
        total = max(len(self.expected) - len(self.skipped & self.expected), analyzed)
        if self.begun is None or analyzed == 0 or analyzed >= total:
            return f" [{analyzed}/{total}]"
        left = (time.monotonic() - self.begun) / analyzed * (total - analyzed)
        # (worded as run's progress words it: the two said 20 s as "about 20 s left" and
        # "less than a minute left"; the rate of a few analyses is no more precise)
        return f" [{analyzed}/{total}, {left_text(left)}]"

    def to_analyze(self, members: Mapping[str, tuple[Path, ...]]) -> frozenset[str]:
        """Of INBOX's archives at the start (``members``: their paths by name), those
        this watcher will analyze as far as their records tell, without reading them:
        not one whose record has its present signature (its files' sizes and
        modification times, trusted as its content as :meth:`_known_hashes` trusts
        them) and no reason to be analyzed again."""
        inbox = self.settings.inbox
        out = set()
        for name, paths in members.items():
            rec = self.ledger.get(name)
            if rec is not None and rec.redo_reason(self.fingerprint) is None:
                with contextlib.suppress(OSError):  # (gone or unreadable: counted)
                    if rec.signature == [list(s) for s in signature(paths, inbox)]:
                        continue
            out.add(name)
        return frozenset(out)

    def summary(self) -> str | None:
        """What this watcher did, for its last lines: ``24 archives analyzed in 39.5 s: 22
        no fault, 1 fault, 1 error; 3 other archives found analyzed already, not
        analyzed again``; None if nothing. Archives, each once with its last verdict
        (an archive analyzed again after it changed was counted twice), and those found
        analyzed already after the verdicts, not in a parenthesis that read as part of
        them ("2 error (1 found analyzed already)", the one found a fault)."""
        analyzed = len(self.results)
        if not analyzed and not self.skipped and not self.unreadable and not self.unwritten:
            return None
        took = "" if self.begun is None else f" in {spoken_duration(time.monotonic() - self.begun)}"
        counts = {v: n for v in Verdict if (n := sum(r is v for r in self.results.values()))}
        parts = ", ".join(f"{n} {v}" for v, n in counts.items())
        text = f"{analyzed} archive{'' if analyzed == 1 else 's'} analyzed{took}"
        text += f": {parts}" if parts else ""
        if self.skipped:
            n = len(self.skipped)
            text += (
                f"; {n} {'other ' if analyzed else ''}archive{'' if n == 1 else 's'} found "
                "analyzed already, not analyzed again"
            )
        if self.left:
            n = len(self.left)
            text += f"; {n} archive{'' if n == 1 else 's'} in error left in INBOX"
        if self.unreadable:
            text += f"; {len(self.unreadable)} skipped (cannot be read)"
        if self.unwritten:
            text += f"; {self.unwritten} whose report could not be written"
        return text

    def _counted_as(self, name: str, kept: str) -> None:
        """The earlier archive of ``name``, kept aside as ``kept``
        (:meth:`~analyzer.watch_index.Ledger.keep_aside`), counted under that name: the
        new content under ``name`` is another archive."""
        if name in self.results:
            self.results[kept] = self.results.pop(name)
        if name in self.skipped:
            self.skipped.discard(name)
            self.skipped.add(kept)
        if name in self.left:
            self.left.discard(name)
            self.left.add(kept)

    def _verdict_words(self, rec: Record) -> str:
        """An archive's result as its log lines say it: its faults as ``analyzer run``'s
        last line says them (or the faulty sensors, in the record of an older watcher),
        that none was found, or its error; and where its report is."""
        report = self.settings.reports / rec.report
        if rec.verdict is Verdict.FAULT:
            words = rec.summary or f"faults on {', '.join(rec.faulty_sensors)}"
            return f"{words}; report: {report}"
        if rec.verdict is Verdict.NO_FAULT:
            return f"no sensor fault found; report: {report}"
        return f"{rec.error}; see {report}"

    def _same_content(self, archive: ReadyArchive, rec: Record) -> None:
        """``archive``, found with ``rec``'s content but other sizes and mtimes in its
        signature (a ``touch``, the same file copied in again), gives the record its
        signature: the record names the files as INBOX holds them now, by which the next
        start knows the archive's own files in a move stopped by a kill
        (:func:`_end_move`: by size and mtime) and reuses its hash
        (:meth:`_known_hashes`). Before, the record kept the signature of its analysis:
        a file touched since, its move by copies killed once the copies were in place,
        was taken at the next start for one changed since, and moved again beside its
        copy (``x-1.csv``: twice in ``--done``); and it was hashed again at every start."""
        sig = [list(s) for s in archive.signature]
        if rec.signature == sig:
            return
        rec.signature = sig
        try:
            self.ledger.save_state()
        except OSError:  # (REPORTS full: written with the next record, or at the stop)
            self.unsaved = True

    def _found_already(self, archive: ReadyArchive, rec: Record) -> None:
        """``archive``, recorded already with this content, not analyzed again: moved by
        ``--done``/``--failed`` as its verdict says, or left in INBOX. An archive to be
        moved is one dropped again (or whose move an earlier start could not make), said
        with its earlier result (it was only "moved to DONE", the verdict nowhere); one
        left in INBOX in error is said each time (:meth:`_left_in_inbox`); the others
        (a watcher without ``--done`` started again over its INBOX) only at debug level.
        One never moved (no ``moved_to``: a watcher stopped before the end of its hold, a
        move undone, no ``--done`` before) is said as such, not as dropped again: "found
        analyzed already" read as a file dropped a second time (ux53 item 13)."""
        name = archive.name
        folder = self.settings.failed if rec.verdict is Verdict.ERROR else self.settings.done
        if folder is not None and self._stays_why(rec) is None:
            log.info(
                "%s: %s, not analyzed again: %s",
                name,
                "found analyzed already (same content)"
                if rec.moved_to
                else "analyzed already and not moved yet (same content)",
                self._verdict_words(rec),
            )
        else:
            log.debug("%s: already analyzed (same content): %s", name, rec.verdict)
        self._move(archive, rec)
        self._left_in_inbox(name, said=False)

    def _train_advice(self, after: float) -> str:
        """What to do about archives too short for the training window while none has
        fit it: check the option that set the window (``--train``, the config's
        ``[train]``: a watcher given no ``--train`` was told to check it), or, with
        neither, give one (the default window is used: "check --train (the default
        training window is used) (given up ...)", two parentheses and an option not
        given, rcfg53); then when it is given up."""
        then = f"given up only once one has, and it is unchanged for --give-up-after {after:g}"
        if self.options.train is not None:
            return f"check --train ({then})"
        config = self.options.config
        if config.train is not None and config.path is not None:
            return f"check --config {config.path} [train] ({then})"
        return (
            "give --train or a config [train] (without either, the default training "
            f"window is used; {then.replace('one has', 'an archive has fit')})"
        )

    def _stays_why(self, rec: Record) -> str | None:
        """Why an archive recorded in error stays in INBOX, or None: moved (or to be
        moved) by ``--failed``, not an error, or an internal error (not a verdict:
        analyzed again on the next start, said so)."""
        if rec.verdict is not Verdict.ERROR or rec.error_kind is ErrorKind.INTERNAL:
            return None
        if rec.error_reason == TOO_SHORT and rec.error_kind is ErrorKind.OPTIONS:
            why = (
                "too short for the training window so far (a file still being written?): "
                "analyzed again when it changes; "
            )
            after = self.settings.give_up_after
            if not after:
                return why + "never given up (--give-up-after 0)"
            at = (rec.short_since or _now()) + after
            then = " and moved to --failed" if self.settings.failed is not None else ""
            when = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(at))  # (as the log's)
            if not self.fitted:
                return why + f"no archive has fit these options yet: {self._train_advice(after)}"
            return (
                why
                + f"given up{then} at {when} if unchanged until then (--give-up-after {after:g})"
            )
        if rec.error_kind is ErrorKind.OPTIONS:
            return (
                "an error of the options, not of the archive (every archive would get it): "
                "mend them and start the watcher again"
            )
        if self.settings.failed is None:
            return "no --failed folder to move it to"
        if rec.error_reason == MISMATCH and not self.fitted:
            return (
                "no archive has fit these options yet: check "
                f"{rec.misfit_option or 'the options'} (moved to --failed once one has)"
            )
        return None

    def _gives_up(self, archive: ReadyArchive, rec: Record) -> bool:
        """Whether ``archive``, recorded too short for the training window (left in
        INBOX: a file still being written grows), is given up now: unchanged for
        ``--give-up-after`` seconds (0: never) since the watcher first saw it at its
        size (:attr:`~analyzer.watch_index.Record.short_since`, in the state: a restart
        does not start the count again; not the file's mtime, which a share whose clock
        is behind or a copy that kept it made look old at first sight), and these
        options have analyzed at least one archive (:attr:`fitted`: a ``--train`` that
        fits no archive is the options' error, and gave up the whole INBOX). Its record
        becomes an error of the archive's own (``error_kind`` ``input``, ``error_reason``
        still ``too short``, its error ending ``(given up: unchanged for N min, ...)``),
        said in a line, and its ``error.txt`` begins with that error, as the index says
        it (before, with the plain error, the given-up words in a paragraph below), and
        it is moved to ``--failed`` as such (left in INBOX, said so, without one). Until then it
        waits in :attr:`short`, looked at again once its time is up
        (:meth:`_short_ends`); a change hands it on again (:meth:`offer`)."""
        after = self.settings.give_up_after
        if rec.error_reason != TOO_SHORT or rec.error_kind is not ErrorKind.OPTIONS or not after:
            return False
        if rec.short_since is None:  # (a record of an older watcher: seen now)
            rec.short_since = _now()
            try:
                self.ledger.record(rec)
            except OSError:
                self.unsaved = True
        unchanged = _now() - rec.short_since
        if unchanged < after or not self.fitted:
            self.short[archive.name] = (archive, rec.short_since + after)
            return False
        self.short.pop(archive.name, None)
        if not self._as_found(archive):  # (changed since: handed on again once settled)
            return False
        words = f"unchanged for {spoken_duration(unchanged)}"
        rec.error = f"{rec.error} (given up: {words}, not a file still being written)"
        rec.error_kind = ErrorKind.INPUT
        rec.left_in_inbox = None
        error_txt = self.settings.reports / rec.folder / "error.txt"
        with contextlib.suppress(OSError):  # (its first line, the error, as in the index)
            details = error_txt.read_text(encoding="utf-8").partition("\n")[2]
            write_atomic(error_txt, f"{rec.error}\n{details}")
        try:
            self.ledger.record(rec)
        except OSError:  # (REPORTS full: written with the next record, or at the stop)
            self.unsaved = True
        log.warning(
            "%s: given up: too short for the training window and %s (--give-up-after %g)%s",
            archive.name,
            words,
            self.settings.give_up_after,
            "" if self.settings.failed is not None else "; no --failed folder to move it to",
        )
        return True

    def _short_ends(self) -> None:
        """The archives too short for the training window whose time to be given up
        has come (:meth:`_gives_up`), given up and moved, where the record is still
        that one."""
        now = _now()
        for name, (archive, due) in list(self.short.items()):
            if now < due or not self.fitted:
                continue  # (none fit these options yet: a wrong --train, not the archive)
            del self.short[name]
            rec = self.ledger.get(name)
            if rec is not None and name not in self.running and name not in self.queue:
                self._move(archive, rec)
                self._left_in_inbox(name, said=True)

    def _left_in_inbox(self, name: str, said: bool) -> None:
        """Where the archive ``name``, just recorded or found recorded, stays in INBOX in
        error (:meth:`_stays_why`): a warning line each time it is seen, its record's
        :attr:`~analyzer.watch_index.Record.left_in_inbox`, and ``--once`` exits with 2
        (:attr:`left`). A NAB file of one channel stayed in INBOX with nothing said, and
        the next ``--once`` said "0 archives analyzed" and exited 0. ``said``: its error
        is on the line before (the end of its analysis), not repeated."""
        rec = self.ledger.get(name)
        why = None if rec is None else self._stays_why(rec)
        if rec is None or why is None:
            self.left.discard(name)
            return
        self.left.add(name)
        error = "" if said else f"; its error: {rec.error}"
        log.warning("%s: left in INBOX: %s%s", name, why, error)
        if rec.left_in_inbox != why:
            rec.left_in_inbox = why
            with contextlib.suppress(OSError):  # (REPORTS full: said on the next record)
                self.ledger.record(rec)

    def _start(self, archive: ReadyArchive) -> None:
        name = archive.name
        try:
            hashes = self._hashes(archive)
        except OSError as err:
            log.info("%s: gone before its analysis (%s)", name, one_line(err.strerror or err))
            return
        digest = hashes.sha256
        rec = self.ledger.get(name)
        if rec is not None and rec.sha256 == digest:
            again = rec.redo_reason(self.fingerprint)
            if again is None:
                if name not in self.results:  # (dropped again in this run: counted once)
                    self.skipped.add(name)
                self._hashed.pop(name, None)  # (another hash only if it changes)
                self._same_content(archive, rec)
                self._found_already(archive, rec)
                return
            if name not in self.retries:  # (a retry's series said once)
                log.info("%s: analyzed again: %s", name, again)
        if archive.incomplete:
            log.warning(
                "%s: analyzing although it still looks unfinished: %s", name, archive.incomplete
            )
        if self.begun is None:
            self.begun = time.monotonic()
        try:
            scratch = scratch_dir(self.settings.reports, name)
        except OSError as err:  # REPORTS full or gone: not the archive's fault
            self.unwritten += 1
            where = f"{os.fsdecode(err.filename)}: " if err.filename else ""
            self._unwritten(archive, f"{where}{one_line(err.strerror or err)}")
            return
        inputs = [str(p) for p in archive.paths]
        process: BaseProcess | ClusterTask
        work = None
        if self.cluster is not None:
            process = ClusterTask(
                self.cluster,
                inputs,
                self.cluster_options,
                scratch,
                os.environ.get(MSG_PATH_ENV, ""),
            )
        else:
            work = make_scratch("analyzer-watch-")
            process = self.ctx.Process(
                target=_analyze_into,
                args=(inputs, self._options(), str(scratch), str(work), os.getpid()),
                name=f"analyzer-watch {name}",
                daemon=True,
            )
            with _one_blas_thread():
                process.start()
        self.running[name] = _Job(archive, digest, hashes, scratch, process, time.monotonic(), work)
        size = sum(s[1] for s in archive.signature)
        if name in self.retries:  # (its series said once: not each try)
            return
        log.info(
            "%s: start (%d input%s, %.1f MB)",
            name,
            len(archive.paths),
            "" if len(archive.paths) == 1 else "s",
            size / 1e6,
        )

    def _options(self) -> RunOptions:
        """The options of the analysis about to start: one thread each while several
        share the cores, but all ``--jobs`` threads for one that starts alone (nothing
        else running or waiting: the usual file an hour), which then takes about half
        the time on two cores. The findings are the same either way (``--jobs`` never
        changes them)."""
        alone = not self.running and not self.queue and not self.hashing
        if self.settings.jobs > 1 and alone:
            return replace(self.options, jobs=self.settings.jobs)
        return self.options

    def pause(self, seconds: float) -> None:
        """The inbox loop's wait between looks: up to ``seconds``, less when an analysis
        ends meanwhile (recorded at once) or the watcher is stopped."""
        if self.running:
            wait_for([job.process.sentinel for job in self.running.values()], timeout=seconds)
        else:
            self.stopping.wait(seconds)

    # ------------------------------------------------------------------ finish
    def _reap(self, wait: float) -> None:
        if not self.running:
            if wait > 0:
                time.sleep(wait)
            return
        jobs = {job.process.sentinel: job for job in self.running.values()}
        ended = set(wait_for(list(jobs), timeout=wait))
        for sentinel, job in jobs.items():
            if sentinel in ended:
                self._finish(job)

    def _finish(self, job: _Job) -> None:
        name = job.archive.name
        job.process.join()
        job.remove_work()
        del self.running[name]
        elapsed = time.monotonic() - job.started
        code = job.process.exitcode
        if self.stopping.is_set() and code not in (0, 1, *ERROR_KINDS):
            # killed by the stop signal itself (a terminal's Ctrl-C reaching a process
            # before it ignores SIGINT, systemd signalling the whole group): abandoned
            shutil.rmtree(job.scratch, ignore_errors=True)
            log.info(
                "%s: abandoned (exit code %s); it will be analyzed on the next start", name, code
            )
            return
        if not self._as_found(job.archive):
            shutil.rmtree(job.scratch, ignore_errors=True)
            self._look_again(job.archive)
            log.info(
                "%s: changed or removed while it was analyzed; result discarded "
                "(it is analyzed again once it has settled)",
                name,
            )
            return
        try:
            rec = self._result(job, elapsed)
            kept: str | None = None
            earlier = self.ledger.get(name)
            if rec.error_reason == TOO_SHORT:  # (--give-up-after counts from first sight)
                same = earlier is not None and _size(earlier.signature) == _size(rec.signature)
                rec.short_since = (earlier.short_since if same and earlier else None) or _now()
            if (
                earlier is not None
                and earlier.sha256 != rec.sha256
                and earlier.error_kind is not ErrorKind.INTERNAL  # (not a result)
            ):
                if self._grew(earlier, job):
                    log.info(
                        "%s: grew since its last analysis (a writer pausing longer than the "
                        "settle time?); that analysis's result is replaced",
                        name,
                    )
                else:
                    kept = self.ledger.keep_aside(name)
                    self._counted_as(name, kept)
            mine = self.ledger.get(name)  # (its record, unless kept aside just now)
            reserved = mine is None and kept is not None
            previous = mine.folder if mine else self.ledger.unpublished_folder(name)
            if reserved:  # (the earlier folder stays as announced)
                previous = self.ledger.new_folder(name)
                self._linked_to(rec, previous)
                self.ledger.reserve(rec)  # (a kill after the publish: its line holds)
            try:
                folder = publish(
                    job.scratch,
                    self.settings.reports,
                    name,
                    previous,
                    self.ledger.folders_except(name),
                )
            except OSError:
                if reserved:
                    self.ledger.forget(name)
                raise
            if kept is not None:
                log.info(
                    "%s: new content; its report goes to %s (the earlier content's result "
                    "stays in %s, listed as %s in the index)",
                    name,
                    folder,
                    self.settings.reports / self.ledger.records[kept].folder,
                    kept,
                )
            self._linked_to(rec, folder.name)
            self.ledger.record(rec)
        except OSError as err:  # REPORTS full or gone: not the archive's fault
            shutil.rmtree(job.scratch, ignore_errors=True)
            self.unwritten += 1
            where = f"{os.fsdecode(err.filename)}: " if err.filename else ""
            self._unwritten(job.archive, f"{where}{one_line(err.strerror or err)}")
            return
        self._hashed.pop(name, None)
        self.skipped.discard(name)
        self.results[name] = rec.verdict
        self.unfit.pop(name, None)
        at = self.progress()
        if rec.error_reason == UNWRITTEN and not self.settings.once:
            self._unwritten(job.archive, rec.error or "", f" (analyzed in {elapsed:.1f} s{at})")
            return
        retry = self.retries.pop(name, None)
        if retry is not None:  # (its failed tries no longer count: it is written)
            self.unwritten -= retry.tries
            log.info("%s: its report is written now, at try %d", name, retry.tries + 1)
        if rec.error_kind is ErrorKind.INTERNAL:
            log.error(
                "%s: error in %.1f s%s: %s (not the archive's fault: it is analyzed again "
                "on the next start)",
                name,
                elapsed,
                at,
                rec.error,
            )
        elif rec.verdict is Verdict.ERROR:
            log.info("%s: error in %.1f s%s: %s", name, elapsed, at, rec.error)
        elif rec.verdict is Verdict.FAULT:
            log.info("%s: fault in %.1f s%s: %s", name, elapsed, at, self._verdict_words(rec))
        else:
            log.info("%s: no fault in %.1f s%s", name, elapsed, at)
        for line in rec.input_errors:  # (what analyzer run warns of: it went on past them)
            log.warning("%s: %s", name, line)
        self._move(job.archive, rec)
        self._left_in_inbox(job.archive.name, said=True)
        if rec.verdict is not Verdict.ERROR and not self.fitted:
            self._fits(name)

    def _unwritten(self, archive: ReadyArchive, error: str, took: str = "") -> None:
        """``archive``'s report could not be written (``error``: the file and the
        system's words): not the archive's fault. While the watcher runs (not
        ``--once``), it is tried again after :data:`RETRY_FIRST_S`, twice as long after
        each failure up to :data:`RETRY_MAX_S` (:meth:`_retry_due`); said at the first
        failure of a series and when the error changes, not at each try."""
        name = archive.name
        if self.settings.once:
            log.error(
                "%s: cannot write its report%s: %s; it is analyzed again on the next start",
                name,
                took,
                error,
            )
            return
        retry = self.retries.get(name)
        delay = RETRY_FIRST_S if retry is None else min(2 * retry.delay, RETRY_MAX_S)
        tries = 1 if retry is None else retry.tries + 1
        if retry is None or retry.error != error:
            log.error(
                "%s: cannot write its report%s: %s (not the archive's fault); tried again in "
                "%s, then less often (up to every %s) while it fails",
                name,
                took,
                error,
                spoken_duration(delay),
                spoken_duration(RETRY_MAX_S),
            )
        self.retries[name] = _Retry(archive, error, time.monotonic() + delay, delay, tries)

    def _retry_due(self) -> None:
        """The archives whose try is due (:meth:`_unwritten`): handed back to the inbox
        tracker, which hands each on again once it is stable (gone: dropped)."""
        now = time.monotonic()
        for name, retry in self.retries.items():
            if retry.due is not None and now >= retry.due and name not in self.running:
                retry.due = None  # (one hand-back per try)
                self.queue.pop(name, None)
                self._look_again(retry.archive)

    def _reports_here(self) -> None:
        """Before the loop writes to REPORTS: if REPORTS (its lock file) is no longer the
        one locked at the start (removed by a clean-up job, or replaced), make it again,
        lock it again, and rebuild the state and index from what it holds; the archives
        whose reports went with it are analyzed again while INBOX holds them. Before, the
        watcher went on failing every archive without exiting, and a second watcher
        could lock the new folder and share it (a QA audit's ux66 item H1). A second
        watcher holding the new lock: :class:`UsageError` (exit 2), nothing more
        written there."""
        if self.lock is None or self.lost_reports or not self.lock.lost():
            return
        reports = self.settings.reports
        try:
            self.lock.retake()
            ledger = Ledger.load(reports)
        except UsageError:
            self.lost_reports = True
            raise
        ledger.tidy()
        old, self.ledger = self.ledger, ledger
        try:
            ledger.save()
        except OSError as err:  # (a full disk: written with the next record)
            log.warning("cannot write the state in %s: %s", reports, err.strerror or err)
        self.fitted = ledger.fitted(self.fingerprint)
        again = [rec for name, rec in old.records.items() if name not in ledger.records]
        for rec in again:
            self.returned.append((rec.name, tuple((p, n, t) for p, n, t in rec.signature)))
        log.warning(
            "REPORTS %s was removed or replaced under the watcher: made again and locked "
            "again, its state and index rebuilt from what it holds (%d record%s); %d "
            "archive%s whose report went with it %s analyzed again while INBOX holds %s",
            reports,
            len(ledger.records),
            "" if len(ledger.records) == 1 else "s",
            len(again),
            "" if len(again) == 1 else "s",
            "is" if len(again) == 1 else "are",
            "it" if len(again) == 1 else "them",
        )

    @staticmethod
    def _linked_to(rec: Record, folder: str) -> None:
        """``rec``'s links (its report or error, ``corrected.csv``) into ``folder``."""
        rec.report = f"{folder}/{rec.report.partition('/')[2]}"
        if rec.corrected is not None:
            rec.corrected = f"{folder}/{CORRECTED}"

    def _fits(self, name: str) -> None:
        """The archive ``name`` is the first these options have analyzed: the archives
        they did not fit, left in INBOX until now (:attr:`unfit`), are the archives'
        errors after all, and go to ``--failed``."""
        self.fitted = True
        for other, archive in list(self.unfit.items()):
            del self.unfit[other]
            rec = self.ledger.get(other)
            if rec is None or rec.verdict is not Verdict.ERROR or rec.error_reason != MISMATCH:
                continue  # (analyzed again since)
            self.left.discard(other)
            log.info(
                "%s: %s fits these options: %s is this archive's error, not theirs",
                other,
                name,
                rec.misfit_option or "the option",
            )
            self._move(archive, rec)

    def _result(self, job: _Job, elapsed: float) -> Record:
        """The record of a finished analysis process, from what it left in its scratch
        folder (which then holds the report, or only ``error.txt``)."""
        dirname = report_dirname(job.archive.name)
        code = job.process.exitcode
        rec = Record(
            name=job.archive.name,
            sha256=job.sha256,
            verdict=Verdict.ERROR,
            report=f"{dirname}/error.txt",
            inputs=[str(p) for p in job.archive.paths],
            processed=now_iso(),
            analysis_s=round(elapsed, 3),
            signature=[list(s) for s in job.archive.signature],
            options=self.fingerprint,
            file_marks=job.hashes.marks,
        )
        findings = job.scratch / "findings.json"
        error = job.scratch / "error.txt"
        details = ""  # what follows the one-line message in error.txt (a traceback)
        rec.error_kind = ErrorKind.INTERNAL
        warned = self._log_config_warnings(job) if code in (0, 1) else []
        if code in (0, 1) and findings.is_file():
            try:
                doc = json.loads(findings.read_text(encoding="utf-8"))
                faults = doc["faults"]
                rec.faulty_sensors = sorted({str(f["channel"]) for f in faults})
                rec.faults = len(faults)
                rec.fault_list = [
                    {
                        "channel": str(f["channel"]),
                        "type": str(f["type"]),
                        "onset": f.get("onset"),
                        "end": f.get("end"),
                        "from_start": bool(f.get("evidence", {}).get("onset_at_or_before")),
                        "size": magnitude(f["magnitude"]) if f.get("magnitude") else None,
                    }
                    for f in faults
                ]
                rec.summary = self._fault_words(job) if faults else None
                rate = doc.get("rate_hz")
                rec.rate_hz = float(rate) if isinstance(rate, int | float) and rate > 0 else None
                rec.start = doc.get("start")
                rec.duration_s = doc.get("duration_s")
                rec.screen = doc.get("screen")
                rec.verdict = Verdict.FAULT if faults else Verdict.NO_FAULT
                rec.input_errors = self._input_warnings(job)
                rec.warnings = warned
                rec.report = f"{dirname}/report.html"
                if (job.scratch / CORRECTED).is_file():
                    rec.corrected = f"{dirname}/{CORRECTED}"
                rec.error_kind = None
                return rec
            except (OSError, ValueError, KeyError, TypeError) as err:
                message = f"internal error: unreadable findings.json ({one_line(err)})"
        elif code in ERROR_KINDS and error.is_file():
            message, _, details = error.read_text(encoding="utf-8").partition("\n")
            if code == EXIT_UNWRITTEN and not Path(message).is_absolute():
                # ("report.html: No space left on device", the file by its name in the
                # scratch folder: said where the report goes)
                message = f"{self.settings.reports / dirname}{os.sep}{message}"
            rec.error_kind = ERROR_KINDS[code]
            rec.error_reason = ERROR_REASONS.get(code)
            if code == EXIT_MISMATCH:
                with contextlib.suppress(OSError, ValueError):
                    rec.misfit_option = (job.scratch / MISFIT).read_text(encoding="utf-8")
        elif code is not None and code < 0:
            message = f"analysis process killed by signal {-code}"
            with contextlib.suppress(ValueError):
                message = f"analysis process killed by {signal.Signals(-code).name}"
        elif code == EXIT_UNWRITTEN:  # (not even error.txt could be written)
            message = f"its report could not be written into {self.settings.reports}"
        else:
            message = f"analysis process exited with code {code}"
        if job.archive.incomplete:
            message += f" (it still looked unfinished: {job.archive.incomplete})"
        for leftover in job.scratch.iterdir():  # no partial report next to an error
            leftover.unlink()
        write_atomic(error, f"{message}\n{details}")
        rec.error = message
        return rec

    @staticmethod
    def _input_warnings(job: _Job) -> list[str]:
        """The input errors and notes an analysis that went on past them left
        (:data:`INPUT_WARNINGS`), the first :data:`~analyzer.errors.WARNED_LINES` and a
        count of the rest, as ``analyzer run`` prints them; the file is removed (it is not
        part of the report, whose findings.json has them all)."""
        path = job.scratch / INPUT_WARNINGS
        try:
            lines = [str(line) for line in json.loads(path.read_text(encoding="utf-8"))]
        except FileNotFoundError:
            return []
        except (OSError, ValueError, TypeError) as err:
            lines = [f"its input errors cannot be read ({one_line(err)}): see findings.json"]
        with contextlib.suppress(OSError):
            path.unlink()
        if len(lines) > WARNED_LINES:
            more = len(lines) - WARNED_LINES
            lines = [*lines[:WARNED_LINES], f"{more} more input errors and notes in findings.json"]
        return lines

    @staticmethod
    def _fault_words(job: _Job) -> str | None:
        """The faults as ``analyzer run``'s last line says them, that the analysis left
        (:data:`FAULT_WORDS`), or None; the file is removed (it is not part of the
        report)."""
        path = job.scratch / FAULT_WORDS
        try:
            text = one_line(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):  # (none: an analysis that wrote none)
            return None
        with contextlib.suppress(OSError):
            path.unlink()
        return text

    @staticmethod
    def _log_config_warnings(job: _Job) -> list[str]:
        """Log, as ``analyzer run`` prints them, the warnings the analysis left
        (:data:`CONFIG_WARNINGS`), and remove their file: it is not part of the report.
        Returns them, for the archive's record (:attr:`Record.warnings`): the first
        :data:`~analyzer.errors.WARNED_LINES` and a count of the rest
        (:func:`~analyzer.watch_index.more_warnings`), as ``input_errors`` keeps them."""
        path = job.scratch / CONFIG_WARNINGS
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return []
        except (OSError, ValueError) as err:
            text = f"its config warnings cannot be read ({one_line(err)})\n"
        lines = [line for line in text.splitlines() if line.strip()]
        for line in lines:
            log.warning("%s: %s", job.archive.name, line)
        with contextlib.suppress(OSError):  # (left in the folder, it harms nothing)
            path.unlink()
        if len(lines) > WARNED_LINES:  # (every line in every record: 3000 config lines
            # made a 786 KB state, rewritten on every save, rcfg53)
            lines = [*lines[:WARNED_LINES], more_warnings(len(lines) - WARNED_LINES)]
        return lines

    def _as_found(self, archive: ReadyArchive) -> bool:
        """Whether INBOX holds ``archive`` as it was found: its files unchanged and, with
        ``--group-by``, no member dropped since (its members listed again). Asked before
        its analysis is recorded and before its move, as after its copies: a member
        dropped while the others were analyzed had them recorded and moved without it,
        and was then analyzed alone as the archive (the first result kept aside)."""
        inbox, group_by = self.settings.inbox, self.settings.group_by
        try:
            listed = (
                archive.paths
                if group_by is None
                else archive_paths(inbox, archive.name, group_by, self.exclude)
            )
            return listed == archive.paths and signature(archive.paths, inbox) == archive.signature
        except OSError:
            return False

    def _move(self, archive: ReadyArchive, rec: Record) -> None:
        """``--done`` / ``--failed``: move the archive's files out of INBOX, once its hold
        is over (:attr:`~analyzer.watch_inbox.ReadyArchive.hold_until`: until then, a
        change shows that a writer was only pausing, and the archive is analyzed again
        instead). An archive whose error is of the options alone or not its own
        (:class:`ErrorKind`) stays. A move to another file system is copies, made by
        :attr:`copier`'s thread and ended by the loop once they are (:meth:`_copied`):
        made here, they held up every other archive and the stop signal (a 1.5 GB archive
        to tmpfs: 1.2-6.2 s)."""
        folder = self.settings.failed if rec.verdict is Verdict.ERROR else self.settings.done
        if rec.error_reason == TOO_SHORT and self._gives_up(archive, rec):
            folder = self.settings.failed
        if rec.error_kind in (ErrorKind.OPTIONS, ErrorKind.INTERNAL) or folder is None:
            return
        if rec.error_reason == MISMATCH and self._stays_why(rec) is not None:  # (none fit)
            self.unfit[archive.name] = archive
            return
        if archive.name in self.copying:  # (the move under way moves it, or, changed, it
            return  # is offered again; a second move took its place, its copies left)
        if time.monotonic() < archive.hold_until:
            self.moves[archive.name] = (archive, rec)
            return
        if not self._as_found(archive):  # a writer still at it: moving would split it
            log.warning(
                "%s: not moved to %s: it changed since it was found complete (still being "
                "written, or a member dropped since?); it is looked at again once it has settled",
                archive.name,
                folder,
            )
            self._look_again(archive)
            return
        tell = self._teller(archive, rec, folder)
        kept: list[_Kept] = []
        try:
            if _other_fs(archive.paths, folder):
                targets, staged = _plan_move(archive.paths, folder, copies=True)
                copies = [c for c in staged if c is not None]
                tell(_moving_of(archive.paths, copies, targets))
                cancel = threading.Event()
                future = self.copier.run_later(partial(_copy_all, archive.paths, copies, cancel))
                self.copying[archive.name] = _Copying(
                    archive, rec, folder, copies, targets, tell, future, cancel
                )
                return
            moved = [str(t) for t in _move_all(archive.paths, folder, tell, kept)]
        except OSError as err:
            self._not_moved(archive, rec, folder, tell, err, kept)
            return
        self._moved(archive, rec, folder, moved)

    def _teller(
        self, archive: ReadyArchive, rec: Record, folder: Path
    ) -> Callable[[list[list[str]]], None]:
        """What writes the lines of ``rec``'s move to the state file before a move that
        can stop half-done (where REPORTS is full, the move goes on without them, as
        before, said once), and ``[]`` once it is over or undone."""
        said: list[bool] = []

        def moving(lines: list[list[str]]) -> None:
            rec.moving = lines
            try:
                self.ledger.save_state()
            except OSError as err:  # (written with the next record, or at the stop)
                self.unsaved = True
                if lines and not said:
                    said.append(True)
                    log.warning(
                        "%s: its move to %s is not in the state file (%s): a kill during it "
                        "would leave it half-done",
                        archive.name,
                        folder,
                        one_line(err.strerror or err),
                    )

        return moving

    def _not_moved(
        self,
        archive: ReadyArchive,
        rec: Record,
        folder: Path,
        tell: Callable[[list[list[str]]], None],
        err: OSError,
        kept: Sequence[_Kept] = (),
    ) -> None:
        """A move that failed (undone: nothing of it left to end): one line naming the
        cause; the archive stays in INBOX, recorded. The line names too each file that
        could not go back to INBOX (``kept``): where its name there was taken in the
        instant it went back, it joins the record's ``moved_to`` and the move is over;
        else the move stays in the state file, ended by the next start (what is left in
        INBOX not analyzed meanwhile, said in this line alone). So too for a move not
        undone, the name in INBOX of a file it renamed taken (:class:`_NamesTaken`)."""
        cause = _move_error(err, archive.paths, folder)
        if isinstance(err, _NamesTaken):
            self.held.add(archive.name)
            log.warning(
                "%s: not moved to %s: %s; not undone: %s in INBOX taken by another file "
                "since (the files moved stay there, the rest in INBOX, not analyzed): the "
                "next start ends the move (as one stopped by force)",
                archive.name,
                folder,
                cause,
                ", ".join(err.names),
            )
            return
        if not kept:
            if rec.moving:
                tell([])
            log.warning("%s: not moved to %s (it stays in INBOX): %s", archive.name, folder, cause)
            return
        stays = "; ".join(f"{k.path.name} stays there ({k.why})" for k in kept)
        if all(k.taken for k in kept):
            rec.moved_to = [*rec.moved_to, *(str(k.path) for k in kept)]
            rec.moving = []
            try:
                self.ledger.record(rec)
            except OSError:  # (REPORTS full: written with the next record, or at the stop)
                self.unsaved = True
            then = "the rest stays in INBOX"
        else:
            self.held.add(archive.name)
            then = (
                "the rest stays in INBOX, not analyzed: the next start ends the move (as one "
                "stopped by force)"
            )
        log.warning(
            "%s: not moved to %s: %s; undone but %s; %s", archive.name, folder, cause, stays, then
        )

    def _moved(
        self,
        archive: ReadyArchive,
        rec: Record,
        folder: Path,
        moved: list[str],
        stayed: _Stayed | None = None,
    ) -> None:
        """A move that is over: its record with where the archive went. One by copies
        may have left sources in INBOX (``stayed``: one could not be removed), said in
        one line (before, silently): what is left there is another archive, analyzed on
        its own under the archive's name (:meth:`_grew`), the record kept aside."""
        rec.moving = []
        if moved:
            # (the same content dropped again and moved: its earlier copy stays listed)
            rec.moved_to = [*rec.moved_to, *moved]
            rec.left_in_inbox = None
            log.info("%s: moved to %s%s", archive.name, folder, _renamed_words(archive, moved))
            note_moves(self.settings.reports, rec, archive.paths, moved)
            try:
                self.ledger.record(rec)
            except OSError as err:  # REPORTS full: the watcher goes on (it died here)
                self.unsaved = True
                where = f"{os.fsdecode(err.filename)}: " if err.filename else ""
                log.warning(
                    "%s: its move is not in the state file yet (%s%s); it is with the next "
                    "record written",
                    archive.name,
                    where,
                    one_line(err.strerror or err),
                )
        if not moved:
            return
        if self.settings.group_by is not None and any(
            p.name != archive.name for p in archive.paths
        ):  # (a group: its name from the pattern, not an entry's own)
            self._left_behind(archive, folder, stayed)
        elif stayed is not None:  # (a folder partly removed: copied whole)
            log.warning(
                "%s: moved to %s, but what is left of it stays in INBOX (%s): analyzed on "
                "its own as %s once settled, the archive's result then kept aside under a "
                "free name",
                archive.name,
                folder,
                _removal_error(stayed.err),
                archive.name,
            )

    def _left_behind(
        self, archive: ReadyArchive, folder: Path, stayed: _Stayed | None = None
    ) -> None:
        """A ``--group-by`` group moved: its members INBOX still holds, said in a line
        each: those dropped in the instant between their last listing (:meth:`_as_found`)
        and the renames, and those of the analysis that a move by copies left there
        (``stayed``: one could not be removed from INBOX), not dropped. What comes after
        a move is another archive (:meth:`_grew`): it is analyzed on its own under the
        group's name, the group's record kept aside, as before, but no longer silently.
        Not for an archive of one entry under its own name (a file the pattern does not
        match): a file of that name after its move is only a new archive. One listing of
        INBOX after the move, none before it: the move is as quick as before."""
        try:
            left = archive_paths(
                self.settings.inbox, archive.name, self.settings.group_by, self.exclude
            )
        except OSError:
            left = ()
        if stayed is not None:
            log.warning(
                "%s: %s: in its analysis but left in INBOX by its move to %s (%s): analyzed "
                "on its own as %s once settled, the group's result then kept aside under a "
                "free name",
                archive.name,
                ", ".join(p.name for p in stayed.paths),
                folder,
                _removal_error(stayed.err),
                archive.name,
            )
            left = tuple(p for p in left if p not in stayed.paths)
        if left:
            log.warning(
                "%s: %s: dropped as its group was moved to %s (after the last look at its "
                "members), not in its analysis: analyzed on its own as %s once settled, the "
                "group's result then kept aside under a free name",
                archive.name,
                ", ".join(p.name for p in left),
                folder,
                archive.name,
            )

    def _copied(self) -> None:
        """The moves to another file system whose copies are made (or failed, or were
        stopped), ended (:meth:`_end_copied`)."""
        for name, c in list(self.copying.items()):
            if c.future.done():
                del self.copying[name]
                self._end_copied(c)

    def _end_copied(self, c: _Copying) -> None:
        """A move whose copies are made: renamed into place and INBOX's sources removed,
        where INBOX still holds the archive as it was found, its members too (else the
        copies are removed: it changed while it was copied, and is analyzed again once it
        has settled). One
        whose copies failed or were stopped (their copies removed by the thread): over.
        The archive offered again meanwhile is offered now."""
        archive, name = c.archive, c.archive.name

        def tell() -> None:
            c.tell(_moving_of(archive.paths, c.copies, c.targets))

        try:
            c.future.result()
            if not self._as_found(archive):
                for copy in c.copies:
                    _remove(copy)
                c.tell([])
                log.warning(
                    "%s: not moved to %s: it changed while it was copied there (still being "
                    "written, or a member dropped meanwhile?); it is looked at again once it "
                    "has settled",
                    name,
                    c.folder,
                )
                self._look_again(archive)
            else:
                stayed: list[_Stayed] = []
                targets = _place_all(archive.paths, c.copies, c.targets, tell, stayed)
                self._moved(
                    archive,
                    c.rec,
                    c.folder,
                    [str(t) for t in targets],
                    stayed[0] if stayed else None,
                )
        except MoveCancelled:
            c.tell([])
            log.info(
                "%s: its move to %s stopped (%s); its copies there removed, it stays in INBOX",
                name,
                c.folder,
                "it changed"
                if c.again is not None
                else "the watcher stopping: it is moved on the next start",
            )
        except OSError as err:
            self._not_moved(archive, c.rec, c.folder, c.tell, err)
        if c.again is not None:
            self.offer(c.again)

    def stop_moves(self) -> None:
        """At the stop: the moves whose copies are under way stop at their next block
        (:data:`COPY_BLOCK`) and remove what they made; the archive stays in INBOX,
        recorded, and is moved on the next start. A copy that does not stop within
        :data:`MOVE_GRACE_S` (a hung network file system) is left: its move stays in the
        state file, and the next start ends it as that of a watcher killed during it."""
        for c in self.copying.values():
            c.cancel.set()
        wait_futures([c.future for c in self.copying.values()], timeout=MOVE_GRACE_S)
        self._copied()
        for name, c in self.copying.items():
            log.warning(
                "%s: its move to %s did not stop within %g s; it is ended on the next start",
                name,
                c.folder,
                MOVE_GRACE_S,
            )
        self.copying.clear()

    def save_unsaved(self) -> None:
        """At the stop: the state file with the moves it could not be written with
        (:attr:`unsaved`), so that the next start does not take an archive moved to
        ``--done`` for one still in INBOX (its record without ``moved_to``)."""
        if not self.unsaved:
            return
        try:
            self.ledger.save_state()
            self.unsaved = False
        except OSError as err:
            log.warning(
                "the state file cannot be written (%s): the last moves are not in it",
                one_line(err.strerror or err),
            )

    def _held_moves(self) -> None:
        """The moves whose hold is over (:meth:`_move`)."""
        now = time.monotonic()
        for name, (archive, rec) in list(self.moves.items()):
            if now >= archive.hold_until:
                del self.moves[name]
                self._move(archive, rec)

    def _grew(self, earlier: Record, job: _Job) -> bool:
        """Whether the archive of ``job`` is what ``earlier`` recorded, grown since (a
        writer that paused longer than the settle time, or a folder still being filled).
        A single file: the same file, with the earlier content as its first bytes. A
        folder or group: the earlier files all there, none shorter or older, each one
        that changed with the ends of its earlier content where they were (its
        :func:`file_mark`: another recording put in its place is not the archive grown;
        a record of an older watcher has no marks, and a file its writer rewrites in
        place has none to compare, :data:`REWRITTEN_IN_PLACE`: sizes and mtimes alone
        then), but for hidden and temporary ones, which a copy renames when done
        (:func:`~analyzer.watch_inbox.ignored`). Never once the earlier one was moved out
        of INBOX (what came after it is another archive)."""
        archive = job.archive
        if earlier.moved_to or not earlier.signature:
            return False
        try:
            old = _earlier_files(earlier)
        except (TypeError, ValueError):  # (a state file edited by hand)
            return False
        now = {name: (size, mtime) for name, size, mtime in archive.signature}
        inbox = self.settings.inbox
        try:
            if len(archive.paths) == 1 and not archive.paths[0].is_dir():
                if not len(old) == len(now) == 1:
                    return False
                ((name, size, _),) = old
                if name not in now or now[name][0] < size:
                    return False
                head = job.hashes.heads.get(name)
                if head is None:  # (hashed before, without it: read again)
                    head = _sha256_head(inbox / name, size, inbox)
                return head == earlier.sha256
            for name, size, mtime in old:
                if ignored(name.rpartition("/")[2]):  # (rsync's .x.csv.AbC12z)
                    continue
                if name not in now or now[name][0] < size or now[name][1] < mtime:
                    return False
                # (a file with its size and mtime: unchanged, as for the hash's reuse)
                was = earlier.file_marks.get(name)
                if (
                    now[name] != (size, mtime)
                    and was is not None
                    and not name.lower().endswith(REWRITTEN_IN_PLACE)
                    and file_mark(inbox / name, size, inbox) != was
                ):
                    return False
        except OSError:
            return False
        return True

    # ------------------------------------------------------------------ stop
    def abandon_all(self) -> None:
        """Kill the running analyses and remove their scratch folders; nothing is
        recorded, so they are analyzed on the next start."""
        for job in self.running.values():
            job.process.terminate()
        for name, job in self.running.items():
            job.process.join(KILL_GRACE_S)
            if job.process.is_alive():
                job.process.kill()
                job.process.join()
            job.remove_work()
            shutil.rmtree(job.scratch, ignore_errors=True)
            log.info("%s: abandoned; it will be analyzed on the next start", name)
        self.running.clear()


# --------------------------------------------------------------------------- the loop


def watch(
    settings: WatchSettings,
    options: RunOptions,
    *,
    stop: threading.Event | None = None,
    abandon: threading.Event | None = None,
) -> int:
    """Watch ``settings.inbox`` until ``stop`` is set (or, with ``once``, until what was
    there is done). After ``stop``, running analyses finish unless ``abandon`` is set.
    Returns the exit code (0; with ``once``: see :meth:`_Runner.exit_code`, 130 when
    stopped first); raises :class:`UsageError` for an ISO ``--train`` (it fits only the
    archives holding it), bad folders or a REPORTS folder
    locked by another watcher."""
    if options.train is not None and train_is_absolute(options.train):
        raise UsageError(
            f"--train {options.train}: ISO times fit only the archives that hold them; give "
            "the window in seconds from each archive's start (e.g. --train 0:60)"
        )
    stop = stop or threading.Event()
    abandon = abandon or threading.Event()
    settings = replace(
        settings,
        inbox=settings.inbox.absolute(),
        reports=settings.reports.absolute(),
        done=settings.done.absolute() if settings.done else None,
        failed=settings.failed.absolute() if settings.failed else None,
    )
    exclude = _prepare(settings)
    # the scheduler is contacted before REPORTS is locked: an unreachable one is exit 2 at
    # once, and a signal ends the wait for one that does not answer
    try:
        cluster = DaskExecutor(options.scheduler, stop=stop) if options.scheduler else None
    except KeyboardInterrupt:
        if not stop.is_set():
            raise
        log.info("stopped while connecting to the scheduler")
        return EXIT_INTERRUPTED if settings.once else 0
    with contextlib.ExitStack() as stack:
        if cluster is not None:
            stack.callback(cluster.close)
        lock = stack.enter_context(ReportsLock(settings.reports))
        inbox = stack.enter_context(InboxLock(settings.inbox))  # (after: REPORTS said first)
        return _watch_locked(settings, options, stop, abandon, exclude, cluster, lock, inbox)


def _watch_locked(
    settings: WatchSettings,
    options: RunOptions,
    stop: threading.Event,
    abandon: threading.Event,
    exclude: set[str],
    cluster: DaskExecutor | None,
    lock: ReportsLock | None = None,
    inbox_lock: InboxLock | None = None,
) -> int:
    """:func:`watch` once REPORTS is locked (and the cluster, if any, connected); returns
    its exit code."""
    ledger = Ledger.load(settings.reports)
    _end_moves(ledger, settings.inbox)  # (first: a record tidied away keeps no copies)
    _forget_left(ledger, settings.inbox)
    for name in ledger.tidy():
        if name in ledger.unpublished:
            log.info(
                "%s: its report was never written (the watcher was stopped before); it "
                "will be analyzed again",
                name,
            )
        else:
            log.info("%s: its report folder is gone; it will be analyzed again", name)
    unknown = _unknown_copies(ledger, [settings.done, settings.failed])
    if unknown:
        log.warning(
            "%d hidden cop%s of a move that the state file does not know (left by an older "
            "watcher killed during a move, or another watcher's under way?), not removed: "
            "%s; remove them by hand once checked",
            len(unknown),
            "y" if len(unknown) == 1 else "ies",
            capped([str(p) for p in unknown], UNKNOWN_COPIES_NAMED),
        )
    ledger.save()
    runner = _Runner(settings, options, ledger, stop, cluster, frozenset(exclude), lock)
    if settings.once:  # what --once will go through: the progress's total
        runner.expected = runner.to_analyze(
            archive_members(settings.inbox, settings.group_by, exclude)
        )
    how = f"polling every {settings.poll:g} s" if settings.poll else "file events"
    if cluster is None:
        where = f"{settings.jobs} analysis process{'' if settings.jobs == 1 else 'es'}"
    else:
        where = (
            f"analyses as cluster tasks {cluster.describe()[4:]} (the workers read the archives)"
        )
        if options.jobs is not None:  # (said: it was ignored without a word, ux53 item 11)
            where += (
                f"; --jobs {options.jobs} not used: the cluster's worker threads set how "
                "many archives are analyzed at once"
            )
    log.info(
        "watching %s (%s, settle %g s); reports in %s; %s",
        settings.inbox,
        how,
        settings.settle,
        settings.reports,
        where,
    )
    batches = ready_batches(
        settings.inbox,
        settle=settings.settle,
        poll=settings.poll,
        group_by=settings.group_by,
        exclude=exclude,
        stop=stop,
        once=settings.once,
        incomplete_timeout=settings.incomplete_timeout,
        yield_on_timeout=True,
        known=runner.recorded,
        busy=runner.busy,  # (--once: an archive discarded as it changed is done again)
        pause=runner.pause,
        again=runner.handed_back,  # (not taken as handed on: looked at again)
        back=inbox_lock.renew if inbox_lock is not None else None,  # (the new INBOX locked)
    )
    try:
        with contextlib.closing(batches):
            for batch in batches:
                for archive in batch:
                    runner.offer(archive)
                runner.pump()
        if runner.running and not abandon.is_set():
            many = len(runner.running)
            log.info(
                "stopping: waiting for %s to finish (signal again to abandon %s)",
                f"{many} running analyses" if many > 1 else "1 running analysis",
                "them" if many > 1 else "it",
            )
            while runner.running and not abandon.is_set():
                runner.pump(wait=TICK_S, start=False)
    finally:
        runner.hasher.close()
        runner.stop_moves()
        runner.abandon_all()
        if not runner.lost_reports:  # (else REPORTS is another watcher's now)
            runner.save_unsaved()
            runner.ledger.refresh_views(force=True)
        if runner.queue or runner.hashing:
            ready = len(runner.queue) + len(runner.hashing)
            log.info(
                "%s not started; %s analyzed on the next start",
                f"{ready} ready archives" if ready > 1 else "1 ready archive",
                "they are" if ready > 1 else "it is",
            )
        if runner.moves:
            moves = len(runner.moves)
            log.info(
                "%s not moved yet (stopped before the end of %s hold); %s moved on the next start",
                f"{moves} analyzed archives" if moves > 1 else "1 analyzed archive",
                "their" if moves > 1 else "its",
                "they are" if moves > 1 else "it is",
            )
    summary = runner.summary()
    if summary is not None:
        log.info("%s; index: %s", summary, settings.reports / "index.html")
    log.info("stopped")
    if not settings.once:
        return 0  # a long-running watcher ends by a signal: its clean shutdown
    return EXIT_INTERRUPTED if stop.is_set() else runner.exit_code()


class _StderrFormatter(logging.Formatter):
    """ISO times in UTC (``2026-12-07T18:33:13Z``), and each message one line of
    printable characters (a file name with a newline or a control character in it:
    :func:`~analyzer.errors.terminal_safe`). The times were local without a zone, while
    ``index.json``'s are UTC: ambiguous across a change to or from summer time, or in
    logs gathered from machines in several zones (a QA audit's ux59 item L5)."""

    def formatTime(self, record: logging.LogRecord, datefmt: str | None = None) -> str:  # noqa: N802
        return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(record.created))

    def format(self, record: logging.LogRecord) -> str:
        # (the message only: a traceback, with ANALYZER_DEBUG, keeps its lines)
        safe = copy.copy(record)
        safe.msg, safe.args = terminal_safe(record.getMessage()), None
        return super().format(safe)


def watch_main(args: argparse.Namespace, options: RunOptions) -> int:
    """``analyzer watch``: :func:`watch` with log lines on stderr, and SIGINT/SIGTERM/SIGHUP
    handled as described in the module doc."""
    settings = WatchSettings.from_args(args)
    stop, abandon = threading.Event(), threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        (abandon if stop.is_set() else stop).set()

    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_StderrFormatter("%(asctime)s analyzer watch: %(message)s"))
    log.addHandler(handler)
    level, propagate = log.level, log.propagate
    log.setLevel(logging.INFO)
    log.propagate = False
    previous = {}
    if threading.current_thread() is threading.main_thread():
        # SIGHUP (a terminal closed, a session ended) as SIGTERM: before, it killed the
        # watcher with 129 and not a word (a QA audit's ux66 item L1). A signal ignored
        # at the start stays ignored: `nohup analyzer watch ...` ignores SIGHUP so that the
        # watcher goes on after its terminal is closed (as run does: cli._stop_on_signals)
        for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            if signum == signal.SIGHUP and signal.getsignal(signum) is signal.SIG_IGN:
                continue
            previous[signum] = signal.signal(signum, on_signal)
    try:
        return watch(settings, options, stop=stop, abandon=abandon)
    finally:
        for signum, old in previous.items():
            signal.signal(signum, old)
        log.removeHandler(handler)
        log.setLevel(level)
        log.propagate = propagate


__all__ = ["WatchSettings", "options_fingerprint", "watch", "watch_main"]

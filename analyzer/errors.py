"""One exception tree for the whole tool.

Every error a user can cause derives from :class:`AnalyzerError`; the CLI catches it,
prints its message on one line and exits with code 2. Messages quote the bad value and
say what was expected.
"""

from __future__ import annotations

import errno
import re
import resource
import unicodedata
from collections.abc import Sequence


def one_line(err: BaseException | str) -> str:
    """An exception (or text) as a single line, for ``InputInfo.errors`` and messages;
    a bare ``MemoryError`` (a buffer the machine could not give) as ``not enough
    memory``, where its class name alone was printed."""
    text = str(err).strip()
    if not text and isinstance(err, MemoryError):
        text = "not enough memory"
    text = text or type(err).__name__
    return " ".join(text.split())


LISTED = 4
"""Items of a list an error message names before it counts the rest (:func:`capped`)."""

WARNED_LINES = 5
"""Lines of input errors a command repeats on stderr before it counts the rest (``run``,
``export``, ``watch``'s record): findings.json, or ``analyzer inspect``, has them all."""


def capped(items: Sequence[str], most: int = LISTED, sep: str = ", ", what: str = "") -> str:
    """``items`` joined by ``sep``, the first ``most`` of them and ``and N more`` (``and N
    more WHAT``) after: the contract's error is one line, and a list of every channel of
    a 1 000-channel laser scan, or every topic of a bag, made it kilobytes long."""
    if len(items) <= most:
        return sep.join(items)
    return sep.join(items[:most]) + f" and {len(items) - most} more" + (f" {what}" if what else "")


def counted(n: int, noun: str, plural: str = "") -> str:
    """``n`` and ``noun`` as said: ``1 row``, ``2 rows``, ``0 rows`` (``plural`` where it
    is not ``noun + "s"``: ``1 was``/``2 were`` counts take a verb of their own). A
    message read ``1 rows without a readable time ... skipped`` (a new user's audit)."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


LINE_MOST = 640
"""Characters of the one-line error :func:`clipped_line` keeps: two or three reasons with
their advice (a line of 1.1 kB, ``tilt_laser.bag``'s four detectors' reasons and two
hints, wrapped to a screenful and buried the hint that fixed it)."""


def clipped_line(text: str, most: int = LINE_MOST, keep: int = 0, where: str = "") -> str:
    """``text`` cut to at most ``most`` characters at the last clause boundary in the
    second half of them (``; ``, else before a parenthesis, else ``, ``, else a space),
    ended with `` ...``, the parentheses it left open closed, and ``[N characters in
    all]``, or ``[N characters in all; the whole message: WHERE]`` when the whole text
    was kept in the file ``where`` (:mod:`analyzer.error_file`): the contract's error is
    one readable line, and its head (the file it names, the first reason) is what it
    keeps. Shorter text is returned as it is. The first ``keep`` characters are never
    cut (the file or option the line names, however long its path), nor the quarter of
    ``most`` after them (the first reason): a line whose path is that long is longer
    than ``most``."""
    if len(text) <= most:
        return text
    whole = f"; the whole message: {where}" if where else ""
    tail = f" [{len(text):,} characters in all{whole}]"
    # (" ..." and up to 4 closing parentheses)
    room = max(1, most - len(tail) - 8, keep + (most // 4 if keep else 0))
    cut = -1
    for sep in ("; ", " (", ", ", " "):
        cut = text.rfind(sep, keep, room)
        if cut > max(keep, room // 2):
            break
    head = text[: cut if cut > keep else room]
    head = head[:keep] + head[keep:].rstrip(" ;,(")
    still_open = max(0, head.count("(") - head.count(")"))
    line = head + " ..." + ")" * min(still_open, 4) + tail
    return line if len(line) < len(text) else text


def terminal_safe(text: str) -> str:
    """``text`` with its control and format characters escaped (``\\x01``, ``\\u202e``),
    for a line on a terminal: a channel or file name may hold any of them (a CSV header,
    an MCAP topic, a file name from a share), and written as they are they would move
    the cursor, recolour the terminal or reverse the line (a right-to-left override), or
    split a log's one-line message in two (a newline)."""
    if text.isprintable():
        return text
    return "".join(
        ch
        if ch.isprintable() or unicodedata.category(ch) == "Zs"  # (a no-break space: kept)
        else f"\\x{ord(ch):02x}"
        if ord(ch) < 0x100
        else f"\\u{ord(ch):04x}"
        if ord(ch) < 0x10000
        else f"\\U{ord(ch):08x}"
        for ch in text
    )


class AnalyzerError(Exception):
    """Root of every error the analyzer raises on purpose."""


class UsageError(AnalyzerError):
    """A command-line option or argument is wrong."""


class ConfigError(AnalyzerError):
    """The TOML config file is unreadable, has an unknown key or a bad value."""


class ArchiveMismatch(AnalyzerError):
    """Mixed into an option's error when the option is sound but this archive cannot be
    analyzed with it: too few channels, none that ``--channels`` matches, not the
    channels of ``--model`` (too short for the training window: :class:`ArchiveTooShort`).
    ``analyzer run`` treats it as the option's error it also is (exit 2); ``analyzer
    watch`` as the archive's, moved to ``--failed`` like a corrupt file once an archive
    has fit the options (until then the option may be wrong for every archive), where
    an error of the options alone leaves the archive in INBOX. A NAB file of one channel
    was classed with the options, left in INBOX, and said nothing on the next start."""

    @property
    def option(self) -> str:
        """The option to check when no archive fits (``--channels``, ``--model``,
        ``--train``, ``--config``): the one the message starts with, ``--config`` for a
        setting of the config file, else ``--channels`` (one channel, none left)."""
        if isinstance(self, ConfigError):
            return "--config"
        named = re.match(r"--[a-z][a-z-]*", str(self))
        return named[0] if named else "--channels"


class ArchiveUsageError(UsageError, ArchiveMismatch):
    """An option (``--channels``, ``--train``, ``--model``) this archive does not fit."""


class ArchiveConfigError(ConfigError, ArchiveMismatch):
    """A ``--config`` setting (``[train]``, a group's channels) this archive does not fit."""


class ArchiveTooShort(ArchiveMismatch):
    """Mixed into an archive's error that a file still being written can cause: too
    short for the training window (too few samples in it, a window that starts after
    the data ends or covers all of it). ``analyzer watch`` leaves such an archive in
    INBOX, analyzed again when it grows: moved to ``--failed``, a CSV written slowly was
    cut in two there (its first part moved, the rest written into INBOX again)."""


class ShortUsageError(ArchiveUsageError, ArchiveTooShort):
    """``--train`` (or the default window) that this archive is too short for."""


class ShortConfigError(ArchiveConfigError, ArchiveTooShort):
    """The config's ``[train]`` that this archive is too short for."""


OUT_OF_MEMORY = "out of memory (choose fewer channels with --channels, or a lower --rate)"
"""The line of a run that ran out of memory, however it did (a ``MemoryError``, an
``OSError`` "Cannot allocate memory" from mapping a scratch file)."""


def out_of_memory_line() -> str:
    """:data:`OUT_OF_MEMORY`, and where this process's address space is limited (``ulimit
    -v``), that limit and that it counts the scratch files the run maps: at ``ulimit -v
    1500000`` a 4-hour archive stopped with a resident size of 553 MB (ux66 L2), and one
    of its two paths said only "Cannot allocate memory"."""
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft == resource.RLIM_INFINITY:
        return OUT_OF_MEMORY
    return (
        f"{OUT_OF_MEMORY}; or raise the address-space limit (now ulimit -v {soft // 1024}, "
        "in kB): the scratch files the run maps count against it"
    )


def limit_line(code: int | None) -> str | None:
    """The run's error line when the machine ran out of something an input's reading
    needs (``errno`` ``code``): open files for this process (EMFILE) or for the whole
    machine (ENFILE), or memory (ENOMEM); None for any other error, which may be the
    file's own."""
    if code == errno.EMFILE:
        soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
        now = "" if soft == resource.RLIM_INFINITY else f", {soft} now"
        return f"too many open files: raise the limit (ulimit -n{now}) or give fewer files"
    if code == errno.ENFILE:
        return (
            "too many open files on this machine (its limit for all programs together): "
            "close other programs or give fewer files"
        )
    if code == errno.ENOMEM:
        return out_of_memory_line()
    return None


class MachineLimit(OSError):
    """The machine ran out of something the run needs (open files, memory, scratch
    space): the run's error (one line, exit 2), never an input's damage. Taken for a
    member's damage, a file-descriptor limit dropped 172 or 185 of a 200-file archive's
    files, and the verdict changed run to run ("no sensor fault found", exit 0: ux66
    H3). An ``OSError``, so that ``analyzer watch`` counts it as not the archive's
    fault (the archive stays in INBOX) rather than moving it to ``--failed``; its
    ``strerror`` is the whole line."""


class ScratchFull(MachineLimit):
    """The scratch space (TMPDIR) is full: named, with the advice to move it, where the
    line said only "No space left on device" and an operator looked at ``--out``'s disk
    (ux66 M1)."""


class ReaderError(AnalyzerError):
    """An input file is missing, of unknown format, truncated or corrupt."""


class StoreError(AnalyzerError):
    """The channel store cannot serve what was asked (unknown channel, empty range...)."""


class DetectorError(AnalyzerError):
    """A detector cannot be fitted or run (too little healthy data, singular model...)."""


class TooLittleDataError(DetectorError):
    """A detector's "too little healthy data": it had ``have`` of the ``need`` samples it
    counts (training rows, or what it keeps of them: finite residual samples, rows with
    every lagged value). The numbers, not the message's words, let the run say how long
    a window would do (:func:`analyzer.detector_runs.skip_reason`): 169 of 170 real
    archives stopped at the default window with no hint of the length they needed."""

    def __init__(self, message: str, have: int, need: int) -> None:
        super().__init__(message)
        self.have = int(have)
        self.need = int(need)

    def __reduce__(self) -> tuple[type, tuple[str, int, int]]:
        # (pickled to and from a cluster's workers: the default gives args only)
        return (type(self), (str(self), self.have, self.need))


class ShortDetectorError(DetectorError, ArchiveTooShort):
    """No detector could run for too little healthy data: the training window (by
    default the first 20 % of the data) is too short, as in a file still being written."""


class IntegrityError(AnalyzerError):
    """An internal consistency check failed: samples changed between two stages of the
    analyzer itself (:class:`~analyzer.readers.tally.Tally`), not a fault of the input.
    The pipeline reads the input again once; a second failure stops the run (exit 2)
    rather than report a result computed from corrupted samples."""

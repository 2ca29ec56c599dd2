"""stderr that can be lost without failing the command (the integrator's audit, int56
item 2).

What the analyzer says on stderr (warnings, progress, the one-line summary, the
watcher's log) is for a person; its results are its files and its exit code. A stderr
that cannot be written must not change those: a shell's ``2>&-`` (stderr closed: every
write fails with "Bad file descriptor"), a pipe whose reader has gone (``EPIPE``), or a
full pipe its reader made non-blocking (``EAGAIN``). Before, the first line written
failed the command: ``run ... 2>&-`` wrote its outputs, failed at its summary line,
removed them again and exited 1 (an error it could not say), and a usage error exited 1,
not 2. Now such a stream is given up at its first failed write, the rest of what would
have been said is dropped, and the command's files and exit code are those it has with
stderr open.

A stderr that is a pipe never read and not made non-blocking blocks the writer once the
pipe's buffer (64 KiB on Linux) is full, as for any program: ``run``, ``inspect`` and
``export`` say far less than that; ``watch`` logs a line per event and needs a reader
(a service manager's journal)."""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Iterator
from typing import Any, TextIO


class LossyStream:
    """A text stream (stderr) whose writes and flushes never raise: the first that fails
    (:class:`OSError`, a closed file's :class:`ValueError`) gives the stream up, and
    every later write is dropped. A stream that is None (Python's stderr when the
    process started without one) is given up from the start. Anything else is the
    wrapped stream's (``isatty``, ``fileno``, ``encoding``)."""

    def __init__(self, stream: TextIO | None) -> None:
        self._stream = stream
        self.lost = stream is None
        """Whether the stream was given up (nothing more is written to it)."""

    def write(self, text: str) -> int:
        if not self.lost:
            try:
                assert self._stream is not None
                self._stream.write(text)
            except (OSError, ValueError):
                self._give_up()
        return len(text)

    def flush(self) -> None:
        if not self.lost:
            try:
                assert self._stream is not None
                self._stream.flush()
            except (OSError, ValueError):
                self._give_up()

    def isatty(self) -> bool:
        if self.lost or self._stream is None:
            return False
        try:
            return self._stream.isatty()
        except (OSError, ValueError):
            return False

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)

    def _give_up(self) -> None:
        """Stop writing to the stream. Where it is the process's stderr (descriptor 2),
        that descriptor is pointed at the null device: what the stream still holds in
        its buffer, a library writing to descriptor 2 and the processes started later
        then write without error, and no file opened later can be given number 2 (and
        receive what is meant for stderr)."""
        self.lost = True
        stream = self._stream
        try:
            number = stream.fileno() if stream is not None else -1
        except (OSError, ValueError, AttributeError):
            number = -1
        if number == 2:
            _null_onto(2)


def _null_onto(fd: int) -> None:
    """Open the null device on descriptor ``fd`` (replacing what is there)."""
    with contextlib.suppress(OSError):
        null = os.open(os.devnull, os.O_WRONLY)
        if null != fd:
            os.dup2(null, fd)
            os.close(null)


def _descriptor_closed(fd: int) -> bool:
    """Whether descriptor ``fd`` is not open (a shell's ``2>&-``)."""
    try:
        os.fstat(fd)
    except OSError:
        return True
    return False


@contextlib.contextmanager
def lossy_stderr() -> Iterator[LossyStream]:
    """``sys.stderr`` as a :class:`LossyStream` while the block runs (the one it was
    put back after). A process started with descriptor 2 closed gets the null device
    there first, so that no file the command opens is given number 2."""
    if _descriptor_closed(2):
        _null_onto(2)
    previous = sys.stderr
    lossy = previous if isinstance(previous, LossyStream) else LossyStream(previous)
    sys.stderr = lossy
    try:
        yield lossy
    finally:
        sys.stderr = previous

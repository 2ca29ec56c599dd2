"""Scratch directories in TMPDIR that a killed run does not leave behind for good.

A run of a long archive keeps gigabytes in its scratch directory (the raw store, the
aligned matrix, the detectors' signals). A run that ends, normally or by an exception,
Ctrl-C or SIGTERM, removes it; one killed outright (``kill -9``, the kernel's OOM killer)
cannot. So every scratch directory holds a lock file, ``.lock``, on which its process
keeps a shared ``flock`` for as long as it uses the directory (a worker process that uses
the directory takes its own with :func:`hold`). The kernel drops a process's locks when
the process ends, however it ends; :func:`sweep_stale`, called when a command starts,
removes every ``analyzer-*`` directory in TMPDIR whose lock nobody holds. Locks, unlike
process ids, work across PID namespaces (containers sharing a /tmp) and are not fooled by
a reused pid. A directory without the lock file (another program's, or an older
analyzer's) is never touched, nor one younger than :data:`MIN_AGE_S`.

The lock file is locked under a temporary name and then renamed to ``.lock``, so a sweep
never finds a new directory's ``.lock`` unlocked.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: no locks, no sweeping
    fcntl = None  # type: ignore[assignment]

from analyzer.errors import ScratchFull

LOCK = ".lock"
PREFIX = "analyzer-"
MIN_AGE_S = 60.0
"""A directory this young is left alone whatever its lock says."""

_held: dict[Path, int] = {}
"""Scratch directory -> the descriptor of its lock file, for this process."""


FULL = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
"""The errors of a write that the disk (or a quota, or a file-size limit) had no room
for."""


def scratch_full(err: OSError, place: str | Path | None = None) -> OSError:
    """``err`` as the run's error when it is a write into scratch space that had no room
    (:data:`FULL`): :class:`~analyzer.errors.ScratchFull`, naming the file, the scratch
    folder ``place`` (default: the file's) and TMPDIR, the advice to move it; any
    other error as it is. A full TMPDIR said only "No space left on device", and an
    operator looked at ``--out``'s disk, which had room (ux66 M1)."""
    if err.errno not in FULL or isinstance(err, ScratchFull):
        return err
    name = os.fsdecode(err.filename) if err.filename is not None else ""
    folder = Path(place) if place is not None else Path(name).parent if name else None
    where = (
        f"the scratch folder {folder}"
        if folder is not None
        else f"scratch space in TMPDIR ({tempfile.gettempdir()})"
    )
    line = f"{err.strerror or err}: no room for {where}; set TMPDIR to a directory on a larger disk"
    full = ScratchFull(err.errno, line, *((name,) if name else ()))
    full.__cause__ = err
    return full


def make_scratch(prefix: str = PREFIX, base: str | Path | None = None) -> Path:
    """A new directory ``base/prefix*`` (default base: TMPDIR) with its lock held. An
    interruption (SIGTERM, Ctrl-C) while it is being made removes it again: a signal
    that came between the directory and its lock left ``analyzer-*/.lock.PID`` behind
    (seen by ``test_sigterm_stops_cleanly_without_leftovers`` on a loaded machine)."""
    path = Path(tempfile.mkdtemp(prefix=prefix, dir=base))
    if fcntl is None:
        return path
    try:
        temp = path / f"{LOCK}.{os.getpid()}"
        fd = os.open(temp, os.O_RDWR | os.O_CREAT, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_SH)
        except OSError:  # a file system without locks: the directory is never swept
            os.close(fd)
            os.unlink(temp)
            return path
        _held[path] = fd
        os.rename(temp, path / LOCK)
    except BaseException:
        remove_scratch(path)
        raise
    return path


def hold(path: str | Path) -> None:
    """Take this process's own lock on an existing scratch directory (a worker process
    that uses its parent's), so that it stays while either of them lives."""
    path = Path(path)
    if fcntl is None or path in _held:
        return
    with contextlib.suppress(OSError):
        fd = os.open(path / LOCK, os.O_RDWR)
        fcntl.flock(fd, fcntl.LOCK_SH)
        _held[path] = fd


def remove_scratch(path: str | Path) -> None:
    """Remove a scratch directory and let go of its lock (what is left of it: nothing)."""
    path = Path(path)
    shutil.rmtree(path, ignore_errors=True)
    fd = _held.pop(path, None)
    if fd is not None:
        with contextlib.suppress(OSError):
            os.close(fd)


@contextlib.contextmanager
def scratch(prefix: str = PREFIX) -> Iterator[Path]:
    """:func:`make_scratch` as a context manager: the directory goes at its end."""
    path = make_scratch(prefix)
    try:
        yield path
    finally:
        remove_scratch(path)


def sweep_stale(base: str | Path | None = None, min_age_s: float = MIN_AGE_S) -> list[Path]:
    """Remove the ``analyzer-*`` directories in ``base`` (default: TMPDIR) that a process
    which no longer runs left behind: those with a lock file nobody holds, older than
    ``min_age_s``. Returns what was removed; never raises."""
    if fcntl is None:
        return []
    removed: list[Path] = []
    root = Path(base if base is not None else tempfile.gettempdir())
    try:
        entries = [e for e in os.scandir(root) if e.name.startswith(PREFIX)]
    except OSError:
        return removed
    now = time.time()
    for entry in entries:
        path = Path(entry.path)
        if path in _held:
            continue
        try:
            info = entry.stat(follow_symlinks=False)
            if not entry.is_dir(follow_symlinks=False) or info.st_uid != os.getuid():
                continue
            if now - info.st_mtime < min_age_s:
                continue
            fd = os.open(path / LOCK, os.O_RDWR | getattr(os, "O_NOFOLLOW", 0))
        except OSError:
            continue  # no lock file: not ours to judge
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue  # in use
        try:
            shutil.rmtree(path, ignore_errors=True)
            if not path.exists():
                removed.append(path)
        finally:
            os.close(fd)
    return removed


__all__ = ["hold", "make_scratch", "remove_scratch", "scratch", "sweep_stale"]

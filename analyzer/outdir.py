"""Output locations checked before the work, not after it."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator, Mapping, Sequence
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


def write_atomic(path: Path, data: bytes | str) -> None:
    """Write ``path`` via a temporary file and rename, so readers never see half a file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            # (a file name that is no UTF-8 is held with surrogates: written as \udcXX)
            text = data.encode("utf-8", "backslashreplace") if isinstance(data, str) else data
            f.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual file mode
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise

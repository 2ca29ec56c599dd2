"""Output locations checked before the work, not after it."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Mapping, Sequence
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

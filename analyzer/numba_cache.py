"""Where numba keeps the compiled kernels when the package's folders are read-only.

The kernels are compiled with ``cache=True``. numba stores them beside the source
(``__pycache__``) or, where that is read-only, in the user's cache folder
(``$XDG_CACHE_HOME/numba`` or ``~/.cache/numba``); where neither can be written it
refuses to define the function at all ("cannot cache function ...: no locator
available"), so the analyzer failed at import. That is the usual case of a service
account (``nobody``, a systemd ``DynamicUser``, a container's user) running
``analyzer watch`` from a package installed by root.

:func:`ensure_cache_dir` sees that case before numba does and points numba at a
private folder of the temporary directory, ``analyzer-numba-UID``: created with mode
0700, used only when it is a real folder owned by this user that no one else can write
(numba loads its cache with ``pickle``, so a folder another user could write would let
them run code as this one). Otherwise a fresh folder of its own is made for the process
(the kernels are then compiled again at each start: slower, never wrong). An explicit
``NUMBA_CACHE_DIR`` is always left alone.
"""

from __future__ import annotations

import contextlib
import os
import stat
import sys
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path

# the package's folders that hold compiled kernels (numba caches beside the source)
KERNEL_FOLDERS = ("stats", "detectors", "diagnosis")


def _writable(folder: Path) -> bool:
    """True when ``folder`` can be written, or created in a parent that can be."""
    for candidate in (folder, *folder.parents):
        if candidate.exists():
            return candidate.is_dir() and os.access(candidate, os.W_OK | os.X_OK)
    return False


def _user_cache(environ: Mapping[str, str]) -> Path:
    """numba's user-wide cache folder on POSIX (its ``appdirs.user_cache_dir``)."""
    base = environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "numba"


def _private(folder: Path) -> bool:
    """True when ``folder`` is a real folder of this user that no one else can write."""
    try:
        info = os.lstat(folder)
    except OSError:
        return False
    return (
        stat.S_ISDIR(info.st_mode)
        and info.st_uid == os.getuid()
        and not info.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
    )


def private_dir(prefix: str, tmp: str | None = None) -> str:
    """This user's private folder ``PREFIX-UID`` under ``tmp`` (the temporary directory),
    or a fresh one of its own when that name is taken by something that is not private."""
    root = Path(tmp or tempfile.gettempdir())
    folder = root / f"{prefix}-{os.getuid()}"
    with contextlib.suppress(OSError):
        folder.mkdir(mode=0o700, exist_ok=True)
    if _private(folder):
        return str(folder)
    return tempfile.mkdtemp(prefix=f"{prefix}-", dir=root)


def fallback_dir(tmp: str | None = None) -> str:
    """numba's private cache folder under ``tmp``: ``analyzer-numba-UID``, or a fresh one."""
    return private_dir("analyzer-numba", tmp)


def needs_fallback(
    package: Path, environ: Mapping[str, str], folders: Iterable[str] = KERNEL_FOLDERS
) -> bool:
    """True when numba could cache none of the package's kernels: no ``NUMBA_CACHE_DIR``,
    a kernel folder's ``__pycache__`` not writable, and no writable user-wide cache."""
    if environ.get("NUMBA_CACHE_DIR"):
        return False
    if all(_writable(package / name / "__pycache__") for name in folders):
        return False
    return not _writable(_user_cache(environ))


def ensure_cache_dir() -> str | None:
    """Set ``NUMBA_CACHE_DIR`` (and numba's config, if numba is already imported) to a
    private folder when numba could not cache the kernels otherwise; the folder, or
    None when nothing had to be done. Never raises: a failure leaves numba as it was."""
    try:
        if not needs_fallback(Path(__file__).resolve().parent, os.environ):
            return None
        folder = fallback_dir()
    except OSError:
        return None
    os.environ["NUMBA_CACHE_DIR"] = folder
    config = sys.modules.get("numba.core.config")
    if config is not None:
        config.CACHE_DIR = folder  # type: ignore[attr-defined]
    return folder

"""A disk that fills while the outputs are written, without a full file system: the
``k``-th output file written into a folder meets ``No space left on device``.

The outputs are written through a temporary file from :func:`tempfile.mkstemp` (its
descriptor opened with :func:`os.fdopen`: ``findings.json``, ``report.html``, the watcher's
own files) or through pyarrow's writers (``corrected.csv``, ``export``). Both are counted
in the order they are written, whatever that order, and the ``k``-th fails as a full disk
makes it fail: the write raises ``OSError(ENOSPC)`` (pyarrow's with its own words, which
name no file)."""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

PYARROW_WORDS = "Error writing bytes to file. Detail: [errno 28] No space left on device"
"""What pyarrow says when its file's disk is full (its OSError's text, errno 28)."""


class _FullFile:
    """A file whose every write meets a full disk."""

    def __init__(self, fd: int) -> None:
        self.fd = fd

    def write(self, data: Any) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def close(self) -> None:
        os.close(self.fd)

    def __enter__(self) -> _FullFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class FullDisk:
    """Fails the ``fail_at``-th output file written into ``folder`` (1 the first; 0
    none), or the file called ``name``; :attr:`written` lists the files' names in the
    order they were begun. ``folder`` may be a test of a folder (the watcher's hidden
    scratch folders, made as it goes)."""

    def __init__(
        self,
        monkeypatch: pytest.MonkeyPatch,
        folder: Path | Callable[[Path], bool],
        fail_at: int = 0,
        name: str | None = None,
    ) -> None:
        if callable(folder):
            self._here = folder
        else:
            place = folder.resolve()
            self._here = lambda p: p.resolve() == place
        self.fail_at = fail_at
        self.name = name
        self.written: list[str] = []
        self.failed: str | None = None
        """The name of the file that met the full disk."""
        self._temps: dict[str, str] = {}  # (a temporary file's name: the output's)
        self._full: set[int] = set()
        real_mkstemp, real_fdopen = tempfile.mkstemp, os.fdopen

        def mkstemp(*args: Any, **kw: Any) -> Any:
            fd, name = real_mkstemp(*args, **kw)
            prefix = str(kw.get("prefix", ""))
            here = self._here(Path(name).parent)
            if here and not prefix.startswith(".analyzer-probe-"):
                # (".report.html.new-": the output report.html)
                output = (
                    prefix[1:].removesuffix("new-").removesuffix(".")
                    if prefix.startswith(".")
                    else Path(name).name
                )
                self._temps[Path(name).name] = output
                if self._next(output):
                    self._full.add(fd)
            return fd, name

        def fdopen(fd: int, *args: Any, **kw: Any) -> Any:
            if fd in self._full:
                self._full.discard(fd)
                return _FullFile(fd)
            return real_fdopen(fd, *args, **kw)

        monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
        monkeypatch.setattr(os, "fdopen", fdopen)
        for module, name in (("pyarrow.csv", "CSVWriter"), ("pyarrow.parquet", "ParquetWriter")):
            self._wrap_writer(monkeypatch, module, name)

    def _next(self, output: str) -> bool:
        """Count a file begun in the folder: whether it is the one to fail."""
        self.written.append(output)
        if len(self.written) == self.fail_at or output == self.name:
            self.failed = output
        return self.failed == output

    def _output_of(self, path: Path) -> str | None:
        """The output a pyarrow writer writes at ``path`` (a ``.part`` file beside it, or
        beside a temporary file counted already), or None where it is no output here;
        the file is counted when it was not."""
        if not self._here(path.parent):
            return None
        name = path.name[: -len(".part")] if path.name.endswith(".part") else path.name
        if name[1:] in self._temps:  # (a .part beside a temporary file counted)
            return self._temps[name[1:]]
        output = name.lstrip(".")
        self._next(output)
        return output

    def _wrap_writer(self, monkeypatch: pytest.MonkeyPatch, module: str, name: str) -> None:
        import importlib

        mod = importlib.import_module(module)
        real = getattr(mod, name)
        disk = self

        class Writer(real):  # type: ignore[misc, valid-type]
            def __init__(self, where: Any, *args: Any, **kw: Any) -> None:
                super().__init__(where, *args, **kw)
                output = disk._output_of(Path(os.fspath(where)))
                self._full = output is not None and output == disk.failed

            def write_table(self, *args: Any, **kw: Any) -> None:
                if self._full:
                    raise OSError(errno.ENOSPC, PYARROW_WORDS)
                super().write_table(*args, **kw)

        monkeypatch.setattr(mod, name, Writer)


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file in ``folder`` (hidden ones too) and its bytes."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}

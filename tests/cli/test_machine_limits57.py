"""The machine's limits are the run's error, not an input's damage (ux66 H3, L2).

With ``prlimit --nofile=16`` a 200-file archive lost 172 or 185 of its files as "cannot
read: Too many open files", and the verdict changed from run to run ("no sensor fault
found", exit 0, once). An ``OSError`` EMFILE, ENFILE or ENOMEM while one member is opened
or read now stops the run with one line naming the limit (exit 2); a bare
``MemoryError`` (a damaged file's declared size too large to hold) stays that file's
damage. The seams: ``Path.open`` of one member, and a reader's method used while its
chunks are read, raising the error as the system would."""

from __future__ import annotations

import errno
import os
import resource
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from cli_helpers import one_line_error, run_to

import analyzer.errors
from analyzer.readers.csv_reader import CsvReader
from analyzer.readers.mcap_reader import McapReader
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

RATE = 50.0


def _parts(tmp_path: Path, suffix: str, n: int = 3) -> list[Path]:
    """One 480 s building record written as ``n`` files of a folder, in time order."""
    t, Y, names = simulate_building(n_floors=3, duration_s=480.0, rate_hz=RATE, seed=4)
    t_ns = np.round(t * 1e9).astype(np.int64)
    folder = tmp_path / "in"
    folder.mkdir()
    paths = []
    for k, rows in enumerate(np.array_split(np.arange(len(t)), n)):
        path = folder / f"part{k}.{suffix}"
        write_archive(
            path,
            suffix,
            t_ns[rows],
            {name: Y[rows, j] for j, name in enumerate(names)},
            start_iso="2026-03-01T12:00:00Z",
        )
        paths.append(path)
    return paths


class _Limits:
    """``resource`` as :mod:`analyzer.errors` sees it, with ``getrlimit`` replaced."""

    def __init__(self, getrlimit: Callable[[int], tuple[int, int]]) -> None:
        self.getrlimit = getrlimit

    def __getattr__(self, name: str) -> Any:
        return getattr(resource, name)


def _os_error(code: int) -> OSError:
    return OSError(code, os.strerror(code))


def _failing_on(name: str, original: Callable[..., Any], error: Exception) -> Callable[..., Any]:
    """``original`` (a reader's method), raising ``error`` for the input called ``name``."""

    def method(self: Any, *args: Any, **kwargs: Any) -> Any:
        if Path(self.path).name == name:
            raise error
        return original(self, *args, **kwargs)

    return method


def _open_failing(monkeypatch: pytest.MonkeyPatch, name: str, error: OSError) -> None:
    """Every ``Path.open`` of the file called ``name`` raises ``error``."""
    original = Path.open

    def opened(self: Path, *args: Any, **kwargs: Any) -> Any:
        if self.name == name:
            raise error
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Path, "open", opened)


@pytest.mark.parametrize("suffix", ["mcap", "csv"])
def test_too_many_open_files_while_opening_a_member_stops_the_run(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    suffix: str,
) -> None:
    """Before: ``part1.SUFFIX: cannot read: Too many open files`` as a warning, the run
    analysed the other parts (exit 0 or 1)."""
    parts = _parts(tmp_path, suffix)
    _open_failing(monkeypatch, parts[1].name, _os_error(errno.EMFILE))
    code, err, doc, _ = run_to(tmp_path, capsys, parts[0].parent)
    assert code == 2, err
    assert doc is None
    line = one_line_error(err, "too many open files", "ulimit -n", "give fewer files")
    assert "cannot read" not in line


WHILE_READING = [("mcap", McapReader, "_decoder"), ("csv", CsvReader, "_stream")]
"""(format, the reader's method used while its chunks are read)"""


@pytest.mark.parametrize(("suffix", "reader", "method"), WHILE_READING)
@pytest.mark.parametrize(
    ("code", "words"),
    [
        (errno.EMFILE, "ulimit -n"),
        (errno.ENFILE, "too many open files on this machine"),
        (errno.ENOMEM, "out of memory"),
    ],
)
def test_the_machines_limit_while_reading_a_member_stops_the_run(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    suffix: str,
    reader: type,
    method: str,
    code: int,
    words: str,
) -> None:
    """Before: ``part1.SUFFIX: reading stopped: Too many open files`` (or "Cannot
    allocate memory") and the run went on without that part's samples."""
    parts = _parts(tmp_path, suffix)
    failing = _failing_on(parts[1].name, getattr(reader, method), _os_error(code))
    monkeypatch.setattr(reader, method, failing)
    exit_code, err, doc, _ = run_to(tmp_path, capsys, parts[0].parent)
    assert exit_code == 2, err
    assert doc is None
    line = one_line_error(err, words)
    assert "reading stopped" not in line


def test_a_bare_memory_error_of_one_member_is_still_its_damage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A ``MemoryError`` (a damaged chunk's size too large to hold) skips that member, as
    the contract asks of one damaged input among several: the others are analysed."""
    parts = _parts(tmp_path, "mcap")
    failing = _failing_on(parts[1].name, McapReader._decoder, MemoryError())
    monkeypatch.setattr(McapReader, "_decoder", failing)
    code, err, doc, _ = run_to(tmp_path, capsys, parts[0].parent)
    assert code in (0, 1), err
    assert any(parts[1].name in line and "not enough memory" in line for line in err.splitlines())
    assert doc is not None


def test_cannot_allocate_memory_gets_the_out_of_memory_advice(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Mapping a scratch file beyond ``ulimit -v`` raises ``OSError`` ENOMEM: before, the
    line was "Cannot allocate memory" alone, where a ``MemoryError`` had advice (ux66
    L2). The address-space limit is named where one is set."""
    parts = _parts(tmp_path, "mcap", n=1)
    import analyzer.store.store as store

    def mapping(*args: Any, **kwargs: Any) -> Any:
        raise _os_error(errno.ENOMEM)

    monkeypatch.setattr(store, "_finish", mapping)
    limit = 1_500_000 * 1024
    real = resource.getrlimit

    def limited(which: int) -> tuple[int, int]:
        if which == resource.RLIMIT_AS:
            return (limit, resource.RLIM_INFINITY)
        return real(which)

    monkeypatch.setattr(analyzer.errors, "resource", _Limits(limited), raising=False)
    code, err, _, _ = run_to(tmp_path, capsys, parts[0])
    assert code == 2, err
    line = one_line_error(
        err, "out of memory (choose fewer channels", "ulimit -v", "ulimit -v 1500000"
    )
    from analyzer.errors import out_of_memory_line

    assert line.endswith(out_of_memory_line())


def test_out_of_memory_line_without_an_address_space_limit(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    real = resource.getrlimit

    def unlimited(which: int) -> tuple[int, int]:
        if which == resource.RLIMIT_AS:
            return (resource.RLIM_INFINITY, resource.RLIM_INFINITY)
        return real(which)

    monkeypatch.setattr(analyzer.errors, "resource", _Limits(unlimited), raising=False)
    from analyzer.errors import OUT_OF_MEMORY, out_of_memory_line

    assert out_of_memory_line() == OUT_OF_MEMORY

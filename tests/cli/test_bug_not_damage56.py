"""A bug of ours while reading is an internal error, not a damaged file.

Reading is caught so that one damaged input of several does not stop the others
(``readers.Archive``) and a file that cannot be opened says so in one line
(``readers.open_input``). Only what a damaged or foreign file raises counts
(``readers.base.damage_of``: OSError, ValueError, struct.error, the libraries' own errors);
a ``TypeError`` or ``AttributeError`` in our reader reaches the CLI's "internal error ...
(please report it)" line and exit 2, instead of "reading stopped" and a partial run."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pytest
from cli_helpers import one_line_error, run_to
from mcap.exceptions import McapError

from analyzer.readers.csv_reader import CsvReader
from analyzer.readers.mcap_reader import McapReader
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

RATE = 50.0


def _halves(tmp_path: Path, suffix: str) -> tuple[Path, Path]:
    """One 480 s building record written as two files of 240 s each (``a``, then ``b``)."""
    t, Y, names = simulate_building(n_floors=3, duration_s=480.0, rate_hz=RATE, seed=4)
    t_ns = np.round(t * 1e9).astype(np.int64)
    half = len(t) // 2
    folder = tmp_path / "in"
    folder.mkdir()
    paths = []
    for name, rows in (("a", slice(None, half)), ("b", slice(half, None))):
        path = folder / f"{name}.{suffix}"
        write_archive(
            path,
            suffix,
            t_ns[rows],
            {n: Y[rows, j] for j, n in enumerate(names)},
            start_iso="2026-03-01T12:00:00Z",
        )
        paths.append(path)
    return paths[0], paths[1]


def _failing_on(name: str, original: Callable[..., Any], error: Exception) -> Callable[..., Any]:
    """``original`` (a reader's method), raising ``error`` for the input called ``name``."""

    def method(self: Any, *args: Any, **kwargs: Any) -> Any:
        if Path(self.path).name == name:
            raise error
        return original(self, *args, **kwargs)

    return method


# (format, the reader's method used while its chunks are read)
WHILE_READING = [("mcap", McapReader, "_decoder"), ("csv", CsvReader, "_stream")]


@pytest.mark.parametrize(("suffix", "reader", "method"), WHILE_READING)
def test_a_bug_while_reading_one_of_several_inputs_is_an_internal_error(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    suffix: str,
    reader: type,
    method: str,
) -> None:
    """Before, the second input's TypeError read "reading stopped: ..." and the run went
    on with the first half alone (exit 0 or 1)."""
    a, b = _halves(tmp_path, suffix)
    bug = TypeError("unsupported operand type(s) for +: 'int' and 'NoneType'")
    monkeypatch.setattr(reader, method, _failing_on(b.name, getattr(reader, method), bug))
    code, err, doc, _ = run_to(tmp_path, capsys, a.parent)
    assert code == 2, err
    assert doc is None
    line = one_line_error(err, "internal error: TypeError", "please report it")
    assert "reading stopped" not in line


@pytest.mark.parametrize(("suffix", "reader", "method"), WHILE_READING)
def test_a_bug_while_reading_the_only_input_is_an_internal_error(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    suffix: str,
    reader: type,
    method: str,
) -> None:
    """Before, it read as the file's own problem ("a.mcap: unsupported operand ...")."""
    a, _ = _halves(tmp_path, suffix)
    bug = AttributeError("'NoneType' object has no attribute 'size'")
    monkeypatch.setattr(reader, method, _failing_on(a.name, getattr(reader, method), bug))
    code, err, _, _ = run_to(tmp_path, capsys, a)
    assert code == 2, err
    one_line_error(err, "internal error: AttributeError", "please report it")


def test_a_bug_while_opening_is_an_internal_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before, it read "a.mcap: cannot be read as mcap (...)": a damaged file."""
    a, _ = _halves(tmp_path, "mcap")
    bug = TypeError("'NoneType' object is not subscriptable")
    original = McapReader._read_summary
    monkeypatch.setattr(McapReader, "_read_summary", _failing_on(a.name, original, bug))
    code, err, _, _ = run_to(tmp_path, capsys, a)
    assert code == 2, err
    line = one_line_error(err, "internal error: TypeError", "please report it")
    assert "cannot be read as" not in line


# (format, a method used while its chunks are read, its library's error on damaged bytes)
LIBRARY_DAMAGE = [
    ("mcap", McapReader, "_decoder", McapError("invalid record opcode 0x5a")),
    ("csv", CsvReader, "_stream", pa.ArrowInvalid("CSV parse error: invalid record opcode 0x5a")),
]


@pytest.mark.parametrize(("suffix", "reader", "method", "damage"), LIBRARY_DAMAGE)
def test_a_library_error_while_reading_is_still_the_files_damage(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    suffix: str,
    reader: type,
    method: str,
    damage: Exception,
) -> None:
    """The parsing library's own error on the second input: that input's damage, said on
    stderr with its name, and the first input is analysed (exit 0 or 1)."""
    a, b = _halves(tmp_path, suffix)
    monkeypatch.setattr(reader, method, _failing_on(b.name, getattr(reader, method), damage))
    code, err, doc, _ = run_to(tmp_path, capsys, a.parent)
    assert code in (0, 1), err
    assert "internal error" not in err
    warned = [ln for ln in err.splitlines() if "invalid record opcode 0x5a" in ln]
    assert warned, err
    assert all(ln.startswith(f"analyzer: warning: {b}: ") for ln in warned), warned
    damaged = [i["path"] for i in doc["inputs"] if i.get("errors")]
    assert [Path(p).name for p in damaged] == [b.name]


def test_a_truncated_only_input_is_still_one_clear_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A file cut short inside its first bytes: the reader's one line, naming the file."""
    a, _ = _halves(tmp_path, "mcap")
    a.write_bytes(a.read_bytes()[:5])
    code, err, _, _ = run_to(tmp_path, capsys, a)
    assert code == 2, err
    line = one_line_error(err, str(a), "truncated MCAP file")
    assert "internal error" not in line

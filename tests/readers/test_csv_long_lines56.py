"""A CSV line longer than the reader's block (security review ux63, L1): said in plain
words, not in Arrow's ("straddling object straddles two block boundaries (try to
increase block size?)", "header is larger than block size"); a bare MemoryError as
"not enough memory". The files are 2-4 MB: a line only has to pass the 1 MiB block."""

from __future__ import annotations

from pathlib import Path

import pytest

from analyzer.errors import ReaderError, one_line
from analyzer.readers import open_archive


def test_a_data_line_longer_than_a_block_is_said_plainly(tmp_path: Path) -> None:
    path = tmp_path / "long.csv"
    with path.open("w") as f:
        f.write("time,a,b\n")
        f.writelines(f"{i * 0.01},{i % 7},{i % 5}\n" for i in range(200))
        f.write("2.0,1," + "9" * (2 << 20) + "\n")
        f.writelines(f"{i * 0.01},{i % 7},{i % 5}\n" for i in range(201, 400))
    archive = open_archive(path)
    assert sum(c.values.size for c in archive.chunks("log")) == 400
    (info,) = archive.inputs
    assert info.errors == [
        "unreadable from some point on (a line longer than 1 MiB, the most one line may "
        "hold: damaged, or not a table of readings?); the rows before it were read (200 "
        "rows, up to 1.990 s)"
    ]


def test_a_header_longer_than_a_block_is_said_plainly(tmp_path: Path) -> None:
    path = tmp_path / "wide.csv"
    n = 200_000
    with path.open("w") as f:
        f.write("time," + ",".join(f"c{i}" for i in range(n)) + "\n")
        f.writelines(f"{r * 0.01}," + ",".join("1.5" for _ in range(n)) + "\n" for r in range(3))
    with pytest.raises(ReaderError) as err:
        open_archive(path)
    assert str(err.value) == (
        f"{path}: cannot parse as CSV (its header line is longer than 1 MiB, the most one "
        "line may hold: a table of too many columns?)"
    )


def test_a_bare_memory_error_is_not_enough_memory() -> None:
    assert one_line(MemoryError()) == "not enough memory"
    assert one_line(MemoryError("cannot allocate 8 GB")) == "cannot allocate 8 GB"

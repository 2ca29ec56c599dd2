"""A units line under a CSV's header (catman, DEWESoft, LabVIEW, many loggers): it was
taken for the header, the header above it for a preamble line, so that the channels
were named by their units (``m/s^2``, ``m/s^2_2``, ``mm``) without a word. It is skipped
and named, with each column's unit; a row is never taken for units, nor units for a row."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import read

from analyzer.errors import ReaderError
from analyzer.inspect import inspect_archive
from analyzer.readers import open_input

N = 500
TEN_MS = 10_000_000


def values(n: int = N) -> np.ndarray:
    """``n`` rows of three channels, values with four decimals."""
    rng = np.random.default_rng(7)
    return np.round(rng.normal(size=(n, 3)), 4)


def body(data: np.ndarray, separator: str = ",", comma: bool = False) -> str:
    """Rows ``time,s0,s1,s2`` at 100 Hz (a decimal comma with ``comma``)."""
    lines = []
    for i, row in enumerate(data):
        cells = [f"{i * 0.01:.2f}", *(f"{v:.4f}" for v in row)]
        if comma:
            cells = [c.replace(".", ",") for c in cells]
        lines.append(separator.join(cells) + "\n")
    return "".join(lines)


def check(path: Path, data: np.ndarray, note: str) -> None:
    """Every row read under the names of the header, and one note: the units line."""
    got, info = read(path)
    assert set(got) == {"s0", "s1", "s2"}
    for k, name in enumerate(("s0", "s1", "s2")):
        np.testing.assert_array_equal(got[name][0], TEN_MS * np.arange(len(data)))
        np.testing.assert_array_equal(got[name][1], data[:, k])
    assert info.errors == [note]


UNITS_NOTE = "line 2 read as units, not as data: time [s], s0 [m/s^2], s1 [m/s^2], s2 [mm]"


@pytest.mark.parametrize(
    ("head", "separator", "comma", "note"),
    [
        ("time,s0,s1,s2\ns,m/s^2,m/s^2,mm\n", ",", False, UNITS_NOTE),
        (
            "time,s0,s1,s2\n[s],[m/s2],[m/s2],[mm]\n",
            ",",
            False,
            "line 2 read as units, not as data: time [s], s0 [m/s2], s1 [m/s2], s2 [mm]",
        ),
        (
            "time,s0,s1,s2\n,m/s^2,m/s^2,mm\n",
            ",",
            False,
            "line 2 read as units, not as data: s0 [m/s^2], s1 [m/s^2], s2 [mm]",
        ),
        ("time;s0;s1;s2\ns;m/s^2;m/s^2;mm\n", ";", True, UNITS_NOTE),
        ('"time"\t"s0"\t"s1"\t"s2"\n"s"\t"m/s^2"\t"m/s^2"\t"mm"\n', "\t", False, UNITS_NOTE),
        (
            "Logger,DL-8\n\ntime,s0,s1,s2\n(s),(°C),(%),(Deg C)\n",
            ",",
            False,
            "line 4 read as units, not as data: time [s], s0 [°C], s1 [%], s2 [Deg C]",
        ),
    ],
    ids=[
        "plain",
        "brackets",
        "blank-time-unit",
        "semicolon-decimal-comma",
        "tab-quoted",
        "preamble",
    ],
)
def test_a_units_line_under_the_header_is_skipped_and_named(
    tmp_path: Path, head: str, separator: str, comma: bool, note: str
) -> None:
    data = values()
    path = tmp_path / "units.csv"
    path.write_text(head + body(data, separator, comma), encoding="utf-8")
    check(path, data, note)


def test_a_units_line_is_found_in_a_gzip_file_and_above_sparse_rows(tmp_path: Path) -> None:
    """Rows with many blank cells are as "numeric" as a units line with a blank cell:
    the header search took the units line for the first row (a row without a time,
    counted as skipped) where it did not take it for the header."""
    data = values()
    path = tmp_path / "units.csv.gz"
    with gzip.open(path, "wt") as handle:
        handle.write("time,s0,s1,s2\ns,m/s^2,m/s^2,mm\n" + body(data))
    check(path, data, UNITS_NOTE)
    sparse = tmp_path / "sparse.csv"
    lines = [f"{i * 0.01:.2f},{i},{'' if i % 2 else i},{'' if i % 3 else i}\n" for i in range(N)]
    sparse.write_text("time,s0,s1,s2\ns,,V,\n" + "".join(lines))
    got, info = read(sparse)
    assert set(got) == {"s0", "s1", "s2"}
    assert got["s1"][0].size == (N + 1) // 2 and got["s2"][0].size == (N + 2) // 3
    assert info.errors == ["line 2 read as units, not as data: time [s], s1 [V]"]


def test_a_time_unit_on_the_units_line_scales_the_times(tmp_path: Path) -> None:
    """``ms`` under the time column is a unit as ``time [ms]`` is; ``min`` too."""
    path = tmp_path / "ms.csv"
    path.write_text("time,a\nms,V\n" + "".join(f"{10 * i},{i}\n" for i in range(N)))
    got, info = read(path)
    np.testing.assert_array_equal(got["a"][0], TEN_MS * np.arange(N))
    assert info.time == "column 'time': milliseconds, relative"
    minutes = tmp_path / "min.csv"
    minutes.write_text("Elapsed,T\n[min],[°C]\n" + "".join(f"{i},{i}\n" for i in range(N)))
    got, _ = read(minutes)
    np.testing.assert_array_equal(got["T"][0], 60_000_000_000 * np.arange(N))


def test_only_units_are_read_as_units(tmp_path: Path) -> None:
    """A units line is skipped, while a second line of names, a row without a time
    (blanks, ``nan``, ``NA``, error codes) and a preamble line above a header of as
    many fields are read as before: a line of names stays the header, a row stays a
    row (counted where it has no readable time)."""
    data = values(50)
    cases = {
        # (lines above the rows, expected channels, a row skipped)
        "units": ("time,a,b,c\ns,V,V,mm\n", {"a", "b", "c"}, False),
        "names": ("time,a,b,c\nTime,north,south,west\n", {"north", "south", "west"}, False),
        "preamble": ("station,ABC,x,y\ntime,s0,s1,s2\n", {"s0", "s1", "s2"}, False),
        "nan row": ("time,a,b,c\n,nan,nan,nan\n", {"a", "b", "c"}, True),
        "NA row": ("time,a,b,c\n,NA,,NA\n", {"a", "b", "c"}, True),
        "numbers": ("time,a,b,c\ns,1,1,1\n", {"1", "1_2", "1_3"}, False),
        "unknown words": ("time,a,b,c\n,foo,bar,baz\n", {"foo", "bar", "baz"}, False),
        "names like units": ("Exported by,,,\n,a,b,m\n", {"a", "b", "m"}, False),
    }
    for case, (head, names, skipped) in cases.items():
        path = tmp_path / f"{case}.csv"
        path.write_text(head + body(data))
        got, info = read(path)
        assert set(got) == names, case
        assert all(len(got[name][0]) == 50 for name in names), case
        units = [e for e in info.errors if "read as units" in e]
        assert bool(units) == (case == "units"), case
        assert any("1 row without a readable time" in e for e in info.errors) == skipped, case


def test_a_header_over_a_units_line_alone_is_no_data(tmp_path: Path) -> None:
    path = tmp_path / "head.csv"
    path.write_text("time,s0,s1\ns,V,V\n")
    with pytest.raises(ReaderError, match=r"no data rows \(a header and a units line only\)$"):
        open_input(path)
    one = tmp_path / "one.csv"  # one row: the header search alone cannot tell
    one.write_text("time,s0,s1\ns,V,V\n0.5,1,2\n")
    got, info = read(one)
    assert got["s0"][1].tolist() == [1.0] and got["s1"][0].tolist() == [500_000_000]
    assert info.errors == ["line 2 read as units, not as data: time [s], s0 [V], s1 [V]"]


def test_the_first_line_as_data_is_still_refused_and_a_nan_row_is_no_header(
    tmp_path: Path,
) -> None:
    """The refusals of a header-less file and of a ``nan`` first row as the header hold
    beside a units line."""
    path = tmp_path / "noheader.csv"
    path.write_text(body(values(20)))
    with pytest.raises(ReaderError, match="the first line is data"):
        open_input(path)
    nan = tmp_path / "nan.csv"
    nan.write_text(
        "time,a,b\ns,V,V\n0.00,nan,1\n" + "".join(f"{i / 100:.2f},{i},{i}\n" for i in range(1, 20))
    )
    got, info = read(nan)
    assert set(got) == {"a", "b"} and len(got["a"][0]) == 19 and len(got["b"][0]) == 20
    assert info.errors == ["line 2 read as units, not as data: time [s], a [V], b [V]"]


def test_inspect_names_the_channels_by_the_header_and_says_the_units(tmp_path: Path) -> None:
    """The units of many columns are named up to a length, the rest counted."""
    names = [f"acc{i}" for i in range(40)]
    path = tmp_path / "wide.csv"
    rows = "".join(f"{i * 0.01:.2f}," + ",".join("0.5" for _ in names) + "\n" for i in range(50))
    path.write_text(
        "time," + ",".join(names) + "\ns," + ",".join("m/s^2" for _ in names) + "\n" + rows
    )
    doc = inspect_archive([path])
    assert [c["name"] for c in doc["channels"]] == names
    (note,) = doc["inputs"][0]["errors"]
    assert note.startswith(
        "line 2 read as units, not as data: time [s], acc0 [m/s^2], acc1 [m/s^2]"
    )
    shown = note.count(" [m/s^2]")
    assert note.endswith(f", ... ({40 - shown} more)") and 5 < shown < 40

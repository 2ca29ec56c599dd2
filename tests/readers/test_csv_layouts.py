"""CSV reader on the layouts data loggers write: a time column named with its unit or in
another language, Campbell Scientific TOA5 files, metadata lines above the header and
decimal commas that first appear after the opening rows."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, read

from analyzer.errors import ReaderError
from analyzer.readers import csv_reader, open_input

N = 500
TEN_MS = 10_000_000
"""The rows' time step (100 Hz) in nanoseconds."""


def iso(i: int) -> str:
    """Row ``i``'s time as ISO text without a zone, from :data:`T0` at 100 Hz."""
    ms = 10 * i
    return f"2026-01-01 00:{ms // 60_000:02d}:{ms // 1000 % 60:02d}.{ms % 1000:03d}"


def assert_rows(got: dict[str, tuple[np.ndarray, np.ndarray]], t0: int = 0, n: int = N) -> None:
    """Channels ``a`` = i and ``b`` = -i at 100 Hz from ``t0``, every row read."""
    assert set(got) == {"a", "b"}
    np.testing.assert_array_equal(got["a"][0], t0 + TEN_MS * np.arange(n))
    np.testing.assert_array_equal(got["a"][1], np.arange(n))
    np.testing.assert_array_equal(got["b"][0], t0 + TEN_MS * np.arange(n))
    np.testing.assert_array_equal(got["b"][1], -np.arange(n))


# --------------------------------------------------------------------------- time column


@pytest.mark.parametrize(
    "name",
    [
        "Time (s)",
        "time [s]",
        "Time_s",
        "time_sec",
        "t [s]",
        "Zeit",
        "Zeit [s]",
        "tiempo",
        "Elapsed Time",
        "elapsed_s",
        "seconds",
    ],
)
def test_a_time_column_named_with_its_unit_or_language_is_the_time(
    tmp_path: Path, name: str
) -> None:
    """``a,Time (s),b``: the first column, ``a``, was the time and the real time a
    channel."""
    path = tmp_path / "named.csv"
    path.write_text(f"a,{name},b\n" + "".join(f"{i},{i / 100:.2f},{-i}\n" for i in range(N)))
    got, info = read(path)
    assert_rows(got)
    assert info.errors == []
    assert info.absolute_time is False


@pytest.mark.parametrize("name", ["Timestamp (UTC)", "Date/Time", "date time", "time_utc"])
def test_a_date_time_column_named_so_is_the_time(tmp_path: Path, name: str) -> None:
    path = tmp_path / "dates.csv"
    path.write_text(f"a,{name},b\n" + "".join(f"{i},{iso(i)},{-i}\n" for i in range(N)))
    got, info = read(path)
    assert_rows(got, T0)
    assert info.errors == []
    assert info.absolute_time is True


@pytest.mark.parametrize("name", ["time [ms]", "time_ms", "Time (ms)", "t_msec"])
def test_milliseconds_named_so_are_scaled(tmp_path: Path, name: str) -> None:
    """Milliseconds were read as seconds: a file 1000 times too slow. ``12.5`` ms is
    12 500 000 ns exactly."""
    path = tmp_path / "ms.csv"
    path.write_text(f"a,{name},b\n" + "".join(f"{i},{10 * i + 0.5},{-i}\n" for i in range(N)))
    got, info = read(path)
    assert set(got) == {"a", "b"}
    np.testing.assert_array_equal(got["a"][0], TEN_MS * np.arange(N) + 500_000)
    np.testing.assert_array_equal(got["b"][1], -np.arange(N))
    assert info.errors == []
    assert info.absolute_time is False


def test_epoch_milliseconds_named_so_are_read(tmp_path: Path) -> None:
    """Epoch milliseconds under ``time_ms`` were refused as seconds beyond 2262."""
    path = tmp_path / "epoch_ms.csv"
    ms0 = T0 // 1_000_000
    path.write_text("time_ms,a,b\n" + "".join(f"{ms0 + 10 * i},{i},{-i}\n" for i in range(N)))
    got, info = read(path)
    assert_rows(got, T0)
    assert info.absolute_time is True


@pytest.mark.parametrize(
    ("unit", "ns"), [("min", 60_000_000_000), ("h", 3_600_000_000_000), ("us", 1_000)]
)
def test_other_units_in_brackets_are_scaled(tmp_path: Path, unit: str, ns: int) -> None:
    path = tmp_path / "units.csv"
    path.write_text(f"a,Time [{unit}]\n" + "".join(f"{i},{i * 0.25}\n" for i in range(N)))
    got, _ = read(path)
    np.testing.assert_array_equal(got["a"][0], np.arange(N) * ns // 4)


@pytest.mark.parametrize(
    ("name", "ns"),
    [
        ("milliseconds", 1_000_000),
        ("seconds", 1_000_000_000),
        ("secs", 1_000_000_000),
        ("sec", 1_000_000_000),
    ],
)
def test_a_time_column_named_by_its_unit_alone_is_scaled(
    tmp_path: Path, name: str, ns: int
) -> None:
    """A column named only ``milliseconds`` (or ``seconds``, ``secs``, ``sec``) is the time
    in that unit: ``0.25 * i`` of it is ``i * ns / 4`` nanoseconds by the SI prefix, not a
    time 1000 times too slow or too fast."""
    path = tmp_path / "bare.csv"
    path.write_text(f"{name},a\n" + "".join(f"{i * 0.25},{i}\n" for i in range(N)))
    got, info = read(path)
    assert set(got) == {"a"}
    np.testing.assert_array_equal(got["a"][0], np.arange(N) * ns // 4)
    np.testing.assert_array_equal(got["a"][1], np.arange(N))
    assert info.errors == []


@pytest.mark.parametrize(
    "header",
    [
        "clock,time_offset_sensor,timer_count",
        "clock,time (sensor a),times",
        "clock,runtime,t1",
        "clock,time_min,time (d)",
        "clock,temps,humidity",  # temperatures in English, though time in French
    ],
)
def test_names_that_only_contain_time_are_channels(tmp_path: Path, header: str) -> None:
    """Conservative: a name is a time name when, less a unit, it is one."""
    path = tmp_path / "channels.csv"
    path.write_text(f"{header}\n" + "".join(f"{i / 100:.2f},{i},{-i}\n" for i in range(N)))
    got, _ = read(path)
    first, second = header.split(",")[1:]
    assert set(got) == {first, second}
    np.testing.assert_array_equal(got[first][0], TEN_MS * np.arange(N))
    np.testing.assert_array_equal(got[second][1], -np.arange(N))


@pytest.mark.parametrize("header", ["Zeit,time,a", "Zeit,a,time"])
def test_an_exact_time_name_beats_a_fuzzy_one(tmp_path: Path, header: str) -> None:
    path = tmp_path / "both.csv"
    time = header.split(",").index("time")
    lines = []
    for i in range(N):
        cells = [str(1000 + i), str(i), str(i)]
        cells[time] = f"{i / 100:.2f}"
        lines.append(",".join(cells) + "\n")
    path.write_text(header + "\n" + "".join(lines))
    got, _ = read(path)
    assert set(got) == {"Zeit", "a"}
    np.testing.assert_array_equal(got["Zeit"][0], TEN_MS * np.arange(N))
    np.testing.assert_array_equal(got["Zeit"][1], 1000 + np.arange(N))


# --------------------------------------------------------------------------- TOA5

TOA5_HEAD = (
    '"TOA5","CR1000X_SHM","CR1000X","12345","CR1000X.Std.05.00","CPU:bridge.CR1X","6789",'
    '"Strain"\n'
    '"TIMESTAMP","RECORD","Strain_1","Strain_2","Temp_C"\n'
    '"TS","RN","ue","ue","Deg C"\n'
    '"","","Smp","Smp","Avg"\n'
)


def test_a_campbell_toa5_file_is_read(tmp_path: Path) -> None:
    """The station line was the header: every row had the wrong number of fields and
    the file was refused."""
    path = tmp_path / "CR1000X_Strain.csv"
    path.write_text(
        TOA5_HEAD + "".join(f'"{iso(i)}",{i},{i / 4},{-i},{20 + i % 7}\n' for i in range(2 * N))
    )
    got, info = read(path)
    assert set(got) == {"Strain_1", "Strain_2", "Temp_C"}  # RECORD is a row counter
    for name in got:
        np.testing.assert_array_equal(got[name][0], T0 + TEN_MS * np.arange(2 * N))
    np.testing.assert_array_equal(got["Strain_1"][1], np.arange(2 * N) / 4)
    np.testing.assert_array_equal(got["Temp_C"][1], 20 + np.arange(2 * N) % 7)
    assert info.errors == []  # the units and processing lines are not bad rows
    assert info.absolute_time is True


def test_toa5_tables_named_dat_are_read_and_found_in_a_folder(tmp_path: Path) -> None:
    """CardConvert names a logger's tables ``.dat``: given, such a file is read by its
    first bytes; in a folder, the ``.dat`` files that are TOA5 tables are its inputs and
    other ``.dat`` files are not."""
    from analyzer.readers import open_archive

    folder = tmp_path / "logger"
    folder.mkdir()
    for hour in range(2):
        rows = range(hour * N, (hour + 1) * N)
        (folder / f"CR1000X_Strain_{hour}.dat").write_text(
            TOA5_HEAD + "".join(f'"{iso(i)}",{i},{i / 4},{-i},{20 + i % 7}\n' for i in rows)
        )
    (folder / "calibration.dat").write_bytes(b"\x00\x01 binary")
    got, info = read(folder / "CR1000X_Strain_0.dat")
    assert set(got) == {"Strain_1", "Strain_2", "Temp_C"} and info.errors == []
    archive = open_archive(folder)
    assert [i.path.name for i in archive.inputs] == [
        "CR1000X_Strain_0.dat",
        "CR1000X_Strain_1.dat",
    ]


def test_a_toa5_file_without_rows_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "empty_toa5.csv"
    path.write_text(TOA5_HEAD)
    with pytest.raises(ReaderError, match=r"no data rows \(a header line only\)$"):
        open_input(path)


def test_a_header_name_with_a_line_break_inside_its_quotes_is_refused_so(
    tmp_path: Path,
) -> None:
    """RFC 4180 lets a quoted field hold a line break; the header is found line by line,
    and such a name split it: an audit's file was refused as having "no data rows: no
    line under the first has its 2 fields". Now the error says what is wrong. A quote
    inside an unquoted name (inches) is no opening, and is read."""
    rows = "".join(f"{k * 0.01:.2f},{k},{2 * k}\n" for k in range(50))
    path = tmp_path / "newline.csv"
    path.write_text('time,"line1\nline2",s2\n' + rows)
    with pytest.raises(ReaderError, match=r"leaves a quote open: a column name with a line"):
        open_input(path)
    inches = tmp_path / "inches.csv"
    inches.write_text('time,Diameter ("),s2\n' + rows)
    samples, _ = read(inches)
    assert sorted(samples) == ['Diameter (")', "s2"]
    # (a review: text after a closing quote is no open quote either)
    for header in ('"time" ,"a",s2', '"time","Temp"C,s2'):
        after = tmp_path / "after.csv"
        after.write_text(header + "\n" + rows)
        samples, _ = read(after)
        assert len(samples) == 2, header


# --------------------------------------------------------------------------- preamble


@pytest.mark.parametrize(
    "preamble",
    [
        "# Logger: X-200\nSample rate: 100 Hz\nStart: 2024-01-01\n\n",
        "Logger,X-200\nSerial,1234\nStart,2024-01-01 00:00:00\n",
        "sep=,\n",  # Excel's separator line
        "\n\n",  # blank lines only: the header row was read as a row without a time
        "# a,b,c\n",  # the rows' field count, but a comment
    ],
    ids=["comments", "pairs", "excel", "blank", "hash"],
)
def test_lines_above_the_header_are_skipped(tmp_path: Path, preamble: str) -> None:
    path = tmp_path / "preamble.csv"
    path.write_text(
        preamble + "time,a,b\n" + "".join(f"{i / 100:.2f},{i},{-i}\n" for i in range(N))
    )
    got, info = read(path)
    assert_rows(got)
    assert info.errors == []


def test_a_semicolon_file_with_a_preamble(tmp_path: Path) -> None:
    path = tmp_path / "eu.csv"
    path.write_text(
        "Gerät: DL-1\nAbtastrate: 100 Hz\n\na;Zeit [s];b\n"
        + "".join(f"{i};{i // 100},{i % 100:02d};{-i}\n" for i in range(N)),
        encoding="utf-8",
    )
    got, info = read(path)
    assert_rows(got)
    assert info.errors == []


def test_a_preamble_and_a_header_alone(tmp_path: Path) -> None:
    path = tmp_path / "header.csv"
    path.write_text("# Logger: X-200\nSample rate: 100 Hz\ntime,a,b\n")
    with pytest.raises(ReaderError, match=r"no data rows \(a header line only\)$"):
        open_input(path)


def test_a_header_with_more_fields_than_the_rows_is_still_suspected(tmp_path: Path) -> None:
    """No header among the lines with the rows' field count: the first line stays the
    header and the refusal says why."""
    path = tmp_path / "damaged.csv"
    path.write_text("time,a,b,c\n" + "".join(f"{i},{i},{i}\n" for i in range(N)))
    with pytest.raises(ReaderError, match=r"no line under the first has its 4 fields"):
        open_input(path)


# --------------------------------------------------------------------------- decimal comma


def decimal_rows(n: int, first_decimal: int) -> str:
    """``time;a;b`` rows, 1 s apart, ``a`` = i + 0.5 and ``b`` = -i - 0.25 written with a
    decimal comma from row ``first_decimal`` on and integers ``i``, ``-i`` before it."""
    out = []
    for i in range(n):
        if i < first_decimal:
            out.append(f"{i};{i};{-i}\n")
        else:
            out.append(f"{i},0;{i},5;-{i},25\n")
    return "".join(out)


def decimal_expected(n: int, first_decimal: int) -> tuple[np.ndarray, np.ndarray]:
    i = np.arange(n, dtype=np.float64)
    late = i >= first_decimal
    return np.where(late, i + 0.5, i), np.where(late, -i - 0.25, -i)


def assert_decimal_file(path: Path, n: int, first: int) -> None:
    """``path`` holds :func:`decimal_rows` (``n`` rows, commas from row ``first``): read
    whole, with every value and no error."""
    path.write_text("time;a;b\n" + decimal_rows(n, first))
    got, info = read(path)
    a, b = decimal_expected(n, first)
    np.testing.assert_array_equal(got["a"][0], 1_000_000_000 * np.arange(n))
    np.testing.assert_array_equal(got["a"][1], a)
    np.testing.assert_array_equal(got["b"][1], b)
    assert info.errors == []


def test_decimal_commas_after_the_first_fifty_lines(tmp_path: Path) -> None:
    """The decimal mark was decided from the first 50 lines: the later ``12,5`` cells
    were non-numeric, the columns skipped as text."""
    assert_decimal_file(tmp_path / "late_comma.csv", N, 100)


def test_decimal_commas_after_the_sample_in_a_later_block(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Decimal commas that first appear after the 64 KiB the layout is read from (here
    4 KiB), in a later block: still numbers, time column included."""
    monkeypatch.setattr(csv_reader, "SAMPLE_BYTES", 4096)
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 4096)
    assert_decimal_file(tmp_path / "later_comma.csv", 2000, 1500)


@pytest.mark.parametrize(
    "header, cell, expected",
    [
        ("a,Time (ms),b", lambda i: str(10 * i), "column 'Time (ms)': milliseconds, relative"),
        ("time,a,b", lambda i: f"{1.7e9 + i / 100:.2f}", "column 'time': seconds since 1970 (UTC)"),
        ("a,Zeit,b", iso, "column 'Zeit': date-times (UTC where no zone is given)"),
    ],
)
def test_inspect_says_which_column_is_the_time_and_how_it_is_read(
    tmp_path: Path, header: str, cell, expected: str
) -> None:
    """With time columns found by name and scaled by their unit, the user sees which one
    was taken and how (``inspect``, text and JSON)."""
    from analyzer.inspect import inspect_archive, render_table

    path = tmp_path / "t.csv"
    time = header.split(",").index(next(h for h in header.split(",") if h not in ("a", "b")))
    rows = []
    for i in range(N):
        cells = [str(i), str(i), str(-i)]
        cells[time] = cell(i)
        rows.append(",".join(cells) + "\n")
    path.write_text(header + "\n" + "".join(rows))
    assert open_input(path).info.time == expected
    doc = inspect_archive([path])
    assert doc["inputs"][0]["time"] == expected
    assert f"  time: {expected}" in render_table(doc).splitlines()


@pytest.mark.parametrize(
    "text, channels",
    [
        # a closing remark with fewer fields does not set the rows' field count
        ("time,a,b\n0,1,2\n1,2,3\n2,3,4\nend of log,done\n", {"a", "b"}),
        # a header that names columns by numbers, under a preamble
        ("Device: X\ntime,100,200\n0,1,2\n1,2,3\n2,3,4\n", {"100", "200"}),
        # metadata lines with the rows' field count above the header
        ("station,ABC\nsite,north\ntime,value\n0,1\n1,2\n2,3\n", {"value"}),
        # rows with a text column: the header is still the less numeric line above them
        ("Logger X\ntime,a,status\n0,1,OK\n1,2,OK\n2,3,ERR\n", {"a"}),
    ],
    ids=["closing-remark", "numeric-names", "key-value-metadata", "text-column"],
)
def test_the_header_is_the_line_above_the_rows(tmp_path: Path, text: str, channels) -> None:
    """Review findings: the first two were refused (``no data rows``, ``no numeric
    column``), the third took ``station`` for the time and ``ABC`` for a channel."""
    path = tmp_path / "h.csv"
    path.write_text(text)
    got, _ = read(path)
    assert set(got) == channels
    for name in channels:
        np.testing.assert_array_equal(got[name][0], np.arange(3) * 1_000_000_000)


def test_a_long_preamble_is_skipped(tmp_path: Path) -> None:
    """60 lines of metadata (more than the 50 lines the layout was found from)."""
    path = tmp_path / "long.csv"
    meta = "".join(f"Parameter {k}: value {k}\n" for k in range(60))
    path.write_text(meta + "time,a,b\n" + "".join(f"{i / 100:.2f},{i},{-i}\n" for i in range(N)))
    got, _ = read(path)
    assert_rows(got)


def test_a_bare_t_is_the_time_only_where_no_other_name_says_so(tmp_path: Path) -> None:
    """``Time (s),T,RH``: ``T`` is a temperature; ``a,t,b``: ``t`` is the time."""
    path = tmp_path / "weather.csv"
    path.write_text(
        "Time (s),T,RH\n" + "".join(f"{i / 100:.2f},{20 + i % 3},{50 + i % 5}\n" for i in range(N))
    )
    got, _ = read(path)
    assert set(got) == {"T", "RH"}
    np.testing.assert_array_equal(got["T"][0], TEN_MS * np.arange(N))
    path.write_text("a,t,b\n" + "".join(f"{i},{i / 100:.2f},{-i}\n" for i in range(N)))
    got, _ = read(path)
    assert_rows(got)


def test_a_toa5_table_saved_with_a_byte_order_mark_is_read(tmp_path: Path) -> None:
    """A ``.dat`` with a UTF-8 BOM before ``"TOA5",`` was "unknown format"."""
    path = tmp_path / "CR1000X_Strain.dat"
    body = TOA5_HEAD + "".join(f'"{iso(i)}",{i},{i / 4},{-i},{20 + i % 7}\n' for i in range(N))
    path.write_bytes(b"\xef\xbb\xbf" + body.encode())
    got, info = read(path)
    assert set(got) == {"Strain_1", "Strain_2", "Temp_C"} and info.errors == []
    from analyzer.readers import open_archive

    assert [i.path.name for i in open_archive(tmp_path).inputs] == [path.name]

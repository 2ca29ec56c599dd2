"""CSV reader on the odd files real loggers and spreadsheets write: nothing is lost or
misread without a word, and a file that cannot be read says why, naming itself."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from readers_helpers import collect, read

from analyzer.errors import ReaderError
from analyzer.readers import csv_reader, open_input


def rows(n: int, start: int = 0) -> str:
    """``n`` lines ``time,a,b`` at 100 Hz from row ``start``: ``a`` = i, ``b`` = -i."""
    return "".join(f"{i * 0.01:.2f},{i},{-i}\n" for i in range(start, start + n))


def raises(path: Path, match: str) -> str:
    with pytest.raises(ReaderError, match=match) as err:
        open_input(path)
    message = str(err.value)
    assert "\n" not in message and str(path) in message
    return message


# --------------------------------------------------------------------------- header


def test_duplicate_names_never_share_a_channel(tmp_path: Path) -> None:
    """``a,a,a_2``: the second ``a`` was renamed ``a_2``, the name of the third column,
    and the two columns were read as one channel of twice the samples."""
    path = tmp_path / "dup.csv"
    path.write_text("time,a,a,a_2\n" + "".join(f"{i},{i},{10 + i},{20 + i}\n" for i in range(5)))
    got, info = read(path)
    assert set(got) == {"a", "a_3", "a_2"}
    np.testing.assert_array_equal(got["a"][1], [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(got["a_3"][1], [10, 11, 12, 13, 14])
    np.testing.assert_array_equal(got["a_2"][1], [20, 21, 22, 23, 24])
    # said (CLI audit: the repeat was renamed silently)
    assert info.errors == [
        "columns named alike, a repeat read under a name of its own: 'a' as 'a_3'"
    ]


def test_a_column_blank_in_every_row_is_named(tmp_path: Path) -> None:
    """A column with a header and no value in any row (a sensor not connected) vanished
    from ``inspect`` without a word; a column blank in the first block only is read."""
    path = tmp_path / "blank.csv"
    late = "".join(f"{i * 0.01:.2f},{i},,{'' if i < 50 else i}\n" for i in range(100))
    path.write_text("time,a,empty,late\n" + late)
    got, info = read(path)
    assert set(got) == {"a", "late"}
    assert info.errors == [
        "empty: blank in every row (no reading at all: a dead sensor, or one not recorded); "
        "not analyzed"
    ]
    # a separator ending every line (header too) is no column left blank
    trailing = tmp_path / "trailing.csv"
    trailing.write_text("time,a,\n" + "".join(f"{i * 0.01:.2f},{i},\n" for i in range(100)))
    got, info = read(trailing)
    assert set(got) == {"a"} and info.errors == []


@pytest.mark.parametrize(
    "odd",
    [
        "s,m/s^2,mm\n",  # a units line under the header (catman, DEWESoft, LabVIEW)
        "time,a,b\n",  # the header again (exports appended with cat)
        "\x00" * 300,  # zeros where a power loss cut the file, glued to the next line
    ],
    ids=["units", "header", "zeros"],
)
def test_one_odd_line_in_the_time_column_costs_its_row_not_the_file(
    tmp_path: Path, odd: str
) -> None:
    """One non-number in the first block's time column made the whole column date-time
    text: no time parsed, the file refused ("holds neither numbers nor dates"). The odd
    line comes after the 64 KiB from which the layout is found, in the first block."""
    path = tmp_path / "odd.csv"
    path.write_text("time,a,b\n" + rows(8000) + odd + rows(10, start=8000))
    got, info = read(path)
    assert len(got["a"][1]) >= 8009  # the zeros take the next line's row with them
    np.testing.assert_array_equal(got["a"][0], np.round(got["a"][1] * 1e7).astype(np.int64))
    assert any(" without a readable time" in e for e in info.errors)
    assert info.absolute_time is False


# --------------------------------------------------------------------------- times


def test_seconds_beyond_int64_nanoseconds_are_no_time(tmp_path: Path) -> None:
    """``1e300`` seconds became a wrapped int64 (a sample at -292 years); such a cell is
    a row without a time, counted."""
    path = tmp_path / "huge.csv"
    path.write_text("time,a,b\n" + rows(5) + "1e300,99,99\n" + "1e10,98,98\n")
    got, info = read(path)
    np.testing.assert_array_equal(got["a"][1], [0, 1, 2, 3, 4])
    np.testing.assert_array_equal(got["a"][0], np.arange(5) * 10_000_000)
    assert any(e.startswith("2 rows without a readable time") for e in info.errors)


def test_epoch_milliseconds_are_refused_not_read_as_seconds(tmp_path: Path) -> None:
    """Epoch milliseconds times 1e9 overflow int64: their low 64 bits were the times,
    a file at a 1000-times slower rate starting nowhere, without a word."""
    path = tmp_path / "ms.csv"
    path.write_text("time,a\n" + "".join(f"{1767225600000 + 10 * i},{i}\n" for i in range(20)))
    message = raises(path, "outside the years 1677-2262")
    assert "'1767225600000'" in message and "milliseconds" in message


def test_a_nanosecond_time_beyond_int64_is_a_row_not_the_file(tmp_path: Path) -> None:
    """One integer too large for int64 in a nanosecond column failed Arrow's cast: the
    whole file was unreadable (or everything after it, in a later block)."""
    path = tmp_path / "ns.csv"
    t0 = 1767225600000000000
    path.write_text(
        "time,a\n"
        + "".join(f"{t0 + 10_000_000 * i},{i}\n" for i in range(5))
        + "99999999999999999999,5\n"
    )
    got, info = read(path)
    np.testing.assert_array_equal(got["a"][0], t0 + 10_000_000 * np.arange(5))
    assert info.absolute_time is True
    assert any(e.startswith("1 row without a readable time") for e in info.errors)


def test_times_of_day_are_relative_and_cross_midnight(tmp_path: Path) -> None:
    """``hh:mm:ss`` cells without a date were given today's date by pandas: a different
    absolute time on every run; and the rows after midnight were sorted before the
    evening's."""
    path = tmp_path / "clock.csv"
    cells = ["23:59:58.5", "23:59:59.0", "23:59:59.5", "00:00:00.0", "00:00:00.5"]
    path.write_text("time,a\n" + "".join(f"{c},{i}\n" for i, c in enumerate(cells)))
    reader = open_input(path)
    got = collect(reader.chunks())
    assert reader.info.absolute_time is False
    start = (23 * 3600 + 59 * 60 + 58.5) * 1e9
    np.testing.assert_array_equal(got["a"][0], start + np.arange(5) * 500_000_000)
    np.testing.assert_array_equal(got["a"][1], [0, 1, 2, 3, 4])


# --------------------------------------------------------------------------- cells


def test_a_mostly_numeric_column_skipped_as_text_is_named(tmp_path: Path) -> None:
    """A sensor column with an error code in every fifth cell (80 % numbers, under the
    90 % of a channel) vanished without a word; a half-text column stays silent."""
    path = tmp_path / "codes.csv"
    path.write_text(
        "time,a,b,note\n"
        + "".join(
            f"{i},{'ERR' if i % 5 == 0 else i},{i},{'ok' if i % 2 else i}\n" for i in range(100)
        )
    )
    got, info = read(path)
    assert set(got) == {"b"}
    assert info.errors == [
        "a: skipped as a text column, though 80 of its 100 non-blank cells are numbers"
    ]


def test_a_column_whose_first_block_is_text_is_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sensor that reads ``OVERRANGE`` for the whole first block and numbers after:
    its first block decides that it is text, and every later number was dropped."""
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 4096)
    path = tmp_path / "late.csv"
    path.write_text(
        "time,a,b\n"
        + "".join(f"{i * 0.01:.2f},{'OVERRANGE' if i < 400 else i},{i}\n" for i in range(2000))
    )
    got, info = read(path)
    assert set(got) == {"b"}
    assert info.errors == [
        "a: skipped as a text column, though 1600 of its 2000 non-blank cells are numbers"
    ]


# --------------------------------------------------------------------------- damage


def test_an_unclosed_quote_counts_every_line_it_swallows(tmp_path: Path) -> None:
    """A cell opening a quote never closed joins the rest of the file into one bad
    row: 15 rows lost were reported as 1."""
    path = tmp_path / "quote.csv"
    path.write_text("time,a,b\n" + rows(5) + '0.05,"5,5\n' + rows(14, start=6))
    got, info = read(path)
    assert len(got["a"][1]) == 5
    assert (
        "a quote opened at line 7 is never closed: 15 lines read as one row, skipped" in info.errors
    )
    assert any(e.startswith("15 rows without a readable time") for e in info.errors)


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(
    "text", ["time,a,b", "time,a,b\n", "time,a,b\n\n  \n"], ids=["bare", "eol", "blanks"]
)
def test_a_header_alone(tmp_path: Path, text: str) -> None:
    """Without a final line end Arrow's own message came out ("could not skip initial
    1 rows ... header is larger than block size")."""
    path = tmp_path / "header.csv"
    path.write_text(text)
    raises(path, r"no data rows \(a header line only\)$")


def test_a_header_that_is_not_the_first_line_is_suspected(tmp_path: Path) -> None:
    """Every row was skipped for its number of fields and the message said only "no
    data rows" of a file full of them. (A TOA5 file and Excel's ``sep=;`` line, which
    this was first written for, are now read: tests/readers/test_csv_layouts.py.)"""
    path = tmp_path / "logger.csv"
    path.write_text("time,a,b,c\n" + "".join(f"{i},{i},{i}\n" for i in range(20)))
    raises(path, r"no line under the first has its \d fields \(is the first line the header\?\)")


def test_utf16_text_is_named_as_such(tmp_path: Path) -> None:
    """A spreadsheet's "Unicode text" export (UTF-16 with a byte order mark) was called
    binary data."""
    path = tmp_path / "excel.csv"
    path.write_bytes(("time\ta\n" + "".join(f"{i}\t{i}\n" for i in range(5))).encode("utf-16"))
    raises(path, "UTF-16 text")


def test_an_input_given_twice_is_read_once(tmp_path: Path) -> None:
    """The same file twice on the command line (or a file and its folder) was read
    twice, the second copy's samples each dropped as overlapping the first: noted as
    an input error of 'overlapping' files. Now it is read once, and a note says so."""
    from analyzer.readers import open_archive

    folder = tmp_path / "logs"
    folder.mkdir()
    path = folder / "a.csv"
    path.write_text("time,a,b\n" + rows(50))
    archive = open_archive([path, folder, str(folder / "." / "a.csv")])
    assert [str(i.path) for i in archive.inputs] == [str(path)]
    assert archive.notes == [
        f"{folder / 'a.csv'} given twice: read once",
        f"{folder / '.' / 'a.csv'} given twice: read once",
    ]
    got = collect(archive.chunks())
    assert len(got["a"][1]) == 50 and archive.inputs[0].errors == []

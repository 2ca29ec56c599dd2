"""The CSV reader against the 31st probe's findings: epoch microseconds read as
nanoseconds, a truncated ``.csv.gz`` losing the rows before the damage, zone-less local
times stepping back an hour without a word, a piece without a header whose first row
became channel names, and a last row cut in its last field read with the cut value."""

from __future__ import annotations

import gzip
import json
import zlib
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, collect, read

from analyzer import cli
from analyzer.errors import ReaderError
from analyzer.readers import _common, csv_reader, open_archive, open_input

Samples = dict[str, tuple[np.ndarray, np.ndarray]]
TEN_MS = 10_000_000


def table(n: int, time: list[str] | None = None, header: str = "time,a,b") -> str:
    """``n`` rows at 100 Hz from :data:`T0` (epoch seconds unless ``time`` gives the
    cells): ``a`` = i / 8, ``b`` = a value with 17 significant digits."""
    cells = time or [f"{(T0 + i * TEN_MS) / 1e9:.2f}" for i in range(n)]
    rng = np.random.default_rng(3)
    b = rng.normal(size=n)
    body = "".join(f"{cells[i]},{i / 8},{float(b[i])!r}\n" for i in range(n))
    return (header + "\n" if header else "") + body


# --------------------------------------------------------------------------- epoch µs


def test_epoch_microseconds_are_refused_by_name(tmp_path: Path) -> None:
    """1774745700000000 (epoch µs) was taken as integer nanoseconds: 0.6 s at 50 kHz in
    January 1970 instead of 600 s at 50 Hz in 2026, without a word."""
    path = tmp_path / "us.csv"
    us0 = T0 // 1000
    path.write_text("time,a\n" + "".join(f"{us0 + 20_000 * i},{i}\n" for i in range(100)))
    with pytest.raises(ReaderError, match="is no time") as err:
        open_input(path)
    message = str(err.value)
    assert message.startswith(f"{path}: time column 'time': '{us0}'")
    assert "epoch microseconds?" in message and "'time [us]'" in message


def test_epoch_microseconds_alone_exit_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "us.csv"
    path.write_text("time,a\n" + "".join(f"{T0 // 1000 + 20_000 * i},{i}\n" for i in range(9)))
    assert cli.main(["inspect", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "epoch microseconds?" in err and str(path) in err


@pytest.mark.parametrize("name", ["time [us]", "time [µs]", "Time (μs)", "time_us", "t_µs"])
def test_epoch_microseconds_named_so_are_read(tmp_path: Path, name: str) -> None:
    path = tmp_path / "us.csv"
    us0 = T0 // 1000
    path.write_text(f"{name},a\n" + "".join(f"{us0 + 20_000 * i},{i}\n" for i in range(100)))
    got, info = read(path)
    np.testing.assert_array_equal(got["a"][0], T0 + 20_000_000 * np.arange(100))
    assert info.absolute_time is True and info.errors == []
    assert info.time == f"column {name!r}: microseconds since 1970 (UTC)"


def test_epoch_nanoseconds_are_still_nanoseconds(tmp_path: Path) -> None:
    path = tmp_path / "ns.csv"
    path.write_text("time,a\n" + "".join(f"{T0 + TEN_MS * i},{i}\n" for i in range(100)))
    got, info = read(path)
    np.testing.assert_array_equal(got["a"][0], T0 + TEN_MS * np.arange(100))
    assert info.time == "column 'time': integer nanoseconds since 1970 (UTC)"


def test_epoch_milliseconds_are_still_refused_as_milliseconds(tmp_path: Path) -> None:
    path = tmp_path / "ms.csv"
    path.write_text("time,a\n" + "".join(f"{T0 // 10**6 + 10 * i},{i}\n" for i in range(20)))
    with pytest.raises(ReaderError, match=r"\(epoch milliseconds\? a name such as 'time \[ms\]'"):
        open_input(path)


def test_nanoseconds_before_1990_are_read_as_nanoseconds_from_another_start(
    tmp_path: Path,
) -> None:
    """Integers that as nanoseconds are 1970 (a clock since boot, 3e16 ns: a year of
    uptime) and as microseconds beyond the year 2262 are no epoch either way: relative
    nanoseconds, as before the 31st probe (it refused them; review 33)."""
    path = tmp_path / "boot.csv"
    path.write_text("time,a\n" + "".join(f"{3 * 10**16 + TEN_MS * i},{i}\n" for i in range(20)))
    got, info = read(path)
    np.testing.assert_array_equal(got["a"][0], 3 * 10**16 + TEN_MS * np.arange(20))
    assert info.absolute_time is False and info.errors == []
    assert info.time == "column 'time': integer nanoseconds from another start, relative"


# --------------------------------------------------------------------------- .csv.gz


def _whole_rows(data: bytes) -> int:
    """Rows under the header that the readable part of a cut gzip holds whole."""
    text = zlib.decompressobj(31).decompress(data)
    return text.count(b"\n") - 1


@pytest.mark.parametrize("share", [0.5, 0.7, 0.95])
def test_truncated_gzip_is_read_up_to_the_damage(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, share: float
) -> None:
    """Arrow's gzip stream failed the block it was reading at the cut and its streaming
    reader dropped the blocks read ahead: 9 371 of 20 980 whole rows at 70 %."""
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 1 << 16)  # many blocks
    text = table(40_000)
    data = gzip.compress(text.encode())
    path = tmp_path / "cut.csv.gz"
    path.write_bytes(data[: int(len(data) * share)])
    whole = _whole_rows(path.read_bytes())
    assert 0 < whole < 40_000
    got, info = read(path)
    expected = np.arange(whole)
    np.testing.assert_array_equal(got["a"][1], expected / 8)
    np.testing.assert_array_equal(got["a"][0], T0 + TEN_MS * expected)
    last = open_input(tmp_path / "cut.csv.gz")  # the same again: the fast path's read
    assert len(collect(last.chunks())["b"][1]) == whole
    (note,) = [e for e in info.errors if "unreadable from some point on" in e]
    assert "the compressed stream ends early" in note
    assert f"({whole} rows, up to " in note and "bytes of the line it cut dropped" in note


def test_truncated_small_gzip_alone_is_analyzed_not_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Cut in its first block, the file was refused: 'cannot parse as CSV (Truncated
    compressed stream)'."""
    data = gzip.compress(table(6000).encode())
    path = tmp_path / "cut.csv.gz"
    path.write_bytes(data[: len(data) // 2])
    whole = _whole_rows(path.read_bytes())
    assert cli.main(["inspect", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {c["samples"] for c in out["channels"]} == {whole}
    (note,) = out["inputs"][0]["errors"]
    assert note.startswith("unreadable from some point on (the compressed stream ends early")


def test_corrupt_gzip_keeps_the_rows_before_the_damage(tmp_path: Path) -> None:
    """Zeros in the middle of a deflate stream inflate to garbage that zlib sees only at
    the member's checksum: the file was refused (its one block failed); the rows before
    the damage are read, the garbage after it is not (review 33: it was kept)."""
    text = table(20_000).encode()
    data = bytearray(gzip.compress(text))
    middle = len(data) // 2
    data[middle : middle + 64] = bytes(64)
    path = tmp_path / "bad.csv.gz"
    path.write_bytes(bytes(data))
    got, info = read(path)
    t, a = got["a"]
    inflated = _inflated(bytes(data))
    good = text[: next(i for i, (x, y) in enumerate(zip(inflated, text, strict=False)) if x != y)]
    whole = good.count(b"\n") - 1  # rows before the first byte that differs
    assert whole - 2 <= len(a) <= whole
    np.testing.assert_array_equal(t, T0 + TEN_MS * np.arange(len(a)))
    np.testing.assert_array_equal(a, np.arange(len(a)) / 8)
    (note,) = [e for e in info.errors if "unreadable from some point on" in e]
    assert "corrupt compressed data (Error -3 while decompressing data: incorrect data " in note
    assert f"the rows before the damage were read ({len(a)} rows, up to " in note
    assert "the rest of the file from the damage on dropped" in note


def _inflated(data: bytes) -> bytes:
    """What zlib inflates of a gzip stream before its error."""
    state = zlib.decompressobj(31)
    out = []
    try:
        for start in range(0, len(data), 512):
            out.append(state.decompress(data[start : start + 512]))
    except zlib.error:
        pass
    return b"".join(out)


def test_gzip_of_several_members_and_no_final_line_break(tmp_path: Path) -> None:
    """``cat a.gz b.gz`` is one gzip text; both members are read, no note."""
    text = table(3000)
    lines = text.splitlines(keepends=True)
    path = tmp_path / "two.csv.gz"
    path.write_bytes(
        gzip.compress("".join(lines[:1500]).encode())
        + gzip.compress("".join(lines[1500:]).rstrip("\n").encode())
    )
    got, info = read(path)
    np.testing.assert_array_equal(got["a"][1], np.arange(3000) / 8)
    assert info.errors == []


# --------------------------------------------------------------------------- steps back


def _local_fall_back(n: int, zone: bool = False) -> list[str]:
    """Berlin wall-clock times at 50 Hz from 02:55 CEST on 2026-10-25: at 03:00 CEST the
    clock goes back to 02:00 CET (with ``zone``, each with its offset)."""
    out = []
    for i in range(n):
        utc = np.datetime64("2026-10-25T00:55:00") + np.timedelta64(20 * i, "ms")
        summer = utc < np.datetime64("2026-10-25T01:00:00")
        local = utc + np.timedelta64(2 if summer else 1, "h")
        cell = str(local)[:23]
        out.append(cell + ("+02:00" if summer else "+01:00") * zone)
    return out


def test_local_times_across_the_fall_back_are_refused(tmp_path: Path) -> None:
    """Zone-less times (read as UTC) step back an hour at the change to winter time: the
    rows after it were sorted in among those before, without a word (31st probe); then
    with a note guessing the cause, the two hours merged all the same (ux55 item 3). Now
    refused by ``run`` and ``export`` (``info.set_back``); the reading goes on for
    ``inspect``."""
    path = tmp_path / "local.csv"
    path.write_text(table(30_000, _local_fall_back(30_000)))
    got, info = read(path)
    assert len(got["a"][1]) == 30_000  # read through, for inspect
    (note,) = info.errors
    assert note == info.set_back
    assert note.startswith(
        "the time column 'time' steps back by 60 min at data row 15001 "
        "('2026-10-25T02:00:00.000': from 2026-10-25T02:59:59.980 to 2026-10-25T02:00:00.000), "
        "in times without a zone: local times set back an hour"
    )


def test_times_of_day_an_hour_back_are_refused_as_local_times_set_back(tmp_path: Path) -> None:
    cells = [f"02:59:{50 + i * 0.5:05.2f}" for i in range(20)]
    cells += [f"02:00:{i * 0.5:05.2f}" for i in range(20)]
    path = tmp_path / "clock.csv"
    path.write_text(table(40, cells))
    got, info = read(path)
    assert len(got["a"][1]) == 40
    (note,) = info.errors
    assert note.startswith(
        "the time column 'time' steps back by 60 min at data row 21 ('02:00:00.00': "
    )
    assert "in times without a zone: local times set back an hour" in note


def test_local_times_with_their_offset_do_not_step_back(tmp_path: Path) -> None:
    path = tmp_path / "zoned.csv"
    path.write_text(table(30_000, _local_fall_back(30_000, zone=True)))
    got, info = read(path)
    assert info.errors == []
    assert np.all(np.diff(got["a"][0]) == 20_000_000)


def test_a_step_back_in_seconds_is_named_without_summer_time(tmp_path: Path) -> None:
    t = [f"{100 + i * 0.01:.2f}" for i in range(1000)]
    t[500:] = [f"{90 + i * 0.01:.2f}" for i in range(500)]  # 15 s back at row 501
    t[200] = f"{float(t[200]) - 1.5:.2f}"  # jitter within the window: no step
    path = tmp_path / "back.csv"
    path.write_text(table(1000, t))
    _, info = read(path)
    (note,) = info.errors
    assert note.startswith("the time steps back by 15 s at data row 501 ('90.00': ")
    assert "from 104.990 s to 90.000 s)" in note and "summer" not in note
    assert "the 500 rows stamped more than 2 s before" in note  # not row 201


def test_rows_stepping_back_behind_passed_on_rows_are_said_dropped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Once the reorderer has passed rows on, rows stamped before them are dropped: the
    note says so, and the drop lines count them."""
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 1 << 14)
    monkeypatch.setattr(_common.Reorderer.__init__, "__defaults__", (2_000_000_000, 5000))
    path = tmp_path / "back.csv"  # epoch seconds, 50 min back at row 15001
    cells = [f"{(T0 + i * TEN_MS) / 1e9 - 3000 * (i >= 15_000):.2f}" for i in range(30_000)]
    path.write_text(table(30_000, cells))
    got, info = read(path)
    assert info.set_back == ""
    assert len(got["a"][1]) < 30_000
    (note, *_) = info.errors
    assert "sorted in by time among the rows before them where those were still held" in note
    assert any(e.startswith("a: ") and "dropped because their timestamps" in e for e in info.errors)


# --------------------------------------------------------------------------- no header


def test_a_piece_without_header_is_refused_by_name(tmp_path: Path) -> None:
    """Its first row became channel names ('0.3514...'), one row lost, no note."""
    path = tmp_path / "piece.csv"
    path.write_text(table(100, header=""))
    with pytest.raises(ReaderError, match="no header line: the first line is data") as err:
        open_input(path)
    assert str(err.value).startswith(f"{path}: ") and "add a line naming the columns" in str(
        err.value
    )


@pytest.mark.parametrize(
    "first", ["2026-01-01T00:00:00Z,1.5,2", "00:00:01.5;1,5;2", "12.5,,3e-4", "0.0,1,2"]
)
def test_first_lines_of_numbers_and_times_are_data(tmp_path: Path, first: str) -> None:
    sep = ";" if ";" in first else ","
    path = tmp_path / "piece.csv"
    path.write_text(first + "\n" + "".join(f"{i}{sep}{i}{sep}{i}\n" for i in range(1, 50)))
    with pytest.raises(ReaderError, match="the first line is data"):
        open_input(path)


@pytest.mark.parametrize(("start", "step"), [(0, 1), (1, 1), (1000, 10)])
def test_an_integer_export_without_header_is_refused(tmp_path: Path, start: int, step: int) -> None:
    """A sample counter and ADC counts, no header line: its first row (``0,500,514``,
    increasing integers) was taken for column numbers, the channels named 500 and 514
    and that row lost, without a word."""
    rng = np.random.default_rng(1)
    path = tmp_path / "adc.csv"
    rows = [(start + step * i, 500 + i % 7, 514 + int(rng.integers(9))) for i in range(300)]
    path.write_text("".join(f"{a},{b},{c}\n" for a, b, c in rows))
    with pytest.raises(ReaderError, match="no header line: the first line is data"):
        open_input(path)


@pytest.mark.parametrize("header", ["0,1,2", "1,2,3", "time,1,2"])
@pytest.mark.parametrize("first", [100, 1, 10])
def test_numbered_columns_over_integer_rows_are_a_header(
    tmp_path: Path, header: str, first: int
) -> None:
    """Consecutive column numbers (pandas' default names, ``to_csv(index=False)``) over
    integer rows, even where the rows' first column goes on from the header's first
    field (a counter from 1 under ``0,1,2``; a time from 10 in steps of 10): a header."""
    path = tmp_path / "numbered.csv"
    step = 10 if first == 10 else 1
    path.write_text(
        header + "\n" + "".join(f"{first + step * i},{i % 5},{-i}\n" for i in range(50))
    )
    got, _ = read(path)
    assert set(got) == set(header.split(",")[1:])
    assert len(got[header.split(",")[1]][1]) == 50


@pytest.mark.parametrize(
    "header", ["time,1,2", "t,100,200", "0,1,2", "1,2,3", ",1,2", "time [s],1e3,2e3"]
)
def test_headers_naming_columns_by_numbers_are_headers(tmp_path: Path, header: str) -> None:
    path = tmp_path / "numbered.csv"
    path.write_text(header + "\n" + "".join(f"{i * 0.5},{i},{-i}\n" for i in range(50)))
    got, info = read(path)
    names = [n.strip() or f"column{k}" for k, n in enumerate(header.split(","))]
    assert set(got) == set(names[1:])
    assert len(got[names[1]][1]) == 50


def test_a_piece_without_header_in_an_archive_is_skipped_and_said(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "archive"
    folder.mkdir()
    (folder / "p0.csv").write_text(table(100))
    rest = table(200).splitlines(keepends=True)[101:]
    (folder / "p1.csv").write_text("".join(rest))
    archive = open_archive(folder)
    got = collect(archive.chunks())
    assert set(got) == {"a", "b"} and len(got["a"][1]) == 100
    errors = {info.path.name: info.errors for info in archive.inputs}
    assert errors["p0.csv"] == []
    assert any("the first line is data" in e for e in errors["p1.csv"])
    assert cli.main(["inspect", str(folder / "p1.csv")]) == 2
    assert "the first line is data" in capsys.readouterr().err


# --------------------------------------------------------------------------- cut last row


def _cut(text: str, keep: int) -> str:
    """``text`` without its final line break and all but ``keep`` characters of its
    last field."""
    body = text.rstrip("\n")
    head, _, last = body.rpartition(",")
    return f"{head},{last[:keep]}"


def test_a_last_row_cut_in_its_last_field_is_dropped_and_said(tmp_path: Path) -> None:
    """'-0.8417832579164083' cut to '-0.8' by a power loss was read as -0.8. (A ``.gz``
    that ends cleanly is not looked at: its text's end is Arrow's, and a gzip stream
    cut by a power loss is damage, read up to its last whole line.)"""
    path = tmp_path / "cut.csv"
    path.write_text(_cut(table(500), 4))
    got, info = read(path)
    assert len(got["b"][1]) == 499 and len(got["a"][1]) == 499
    (note,) = info.errors
    assert note.startswith("the last line (no line break after it) dropped: its cell '0.85' ")
    assert "of column 'b' has fewer decimals" in note


def test_a_last_row_cut_is_dropped_on_every_read(tmp_path: Path) -> None:
    """The float64 read and the text read (from a late ``nan``) drop the same row."""
    lines = table(3000).splitlines()
    lines[2500] = lines[2500].rpartition(",")[0] + ",nan"
    path = tmp_path / "cut.csv"
    path.write_text(_cut("\n".join(lines), 3))
    got, info = read(path)
    assert len(got["a"][1]) == 2999
    assert any(e.startswith("the last line (no line break after it) dropped") for e in info.errors)


@pytest.mark.parametrize("keep", [None, 0])
def test_a_last_row_without_line_break_is_kept_when_whole(tmp_path: Path, keep: int | None) -> None:
    """Many writers end the file without a line break: nothing is said of it. A blank
    last cell under a column with blanks is no sign of a cut either."""
    text = table(500).rstrip("\n")
    if keep is not None:  # the column has blanks: a blank last cell is a gap
        lines = text.splitlines()
        lines[450] = lines[450].rpartition(",")[0] + ","
        text = _cut("\n".join(lines), keep)
    path = tmp_path / "whole.csv"
    path.write_text(text)
    got, info = read(path)
    assert len(got["a"][1]) == 500 and info.errors == []


def test_an_integer_column_last_is_not_taken_as_cut(tmp_path: Path) -> None:
    path = tmp_path / "ints.csv"
    path.write_text("time,a\n" + "\n".join(f"{i * 0.01:.2f},{1000 + i}" for i in range(300)))
    got, info = read(path)
    assert len(got["a"][1]) == 300 and info.errors == []

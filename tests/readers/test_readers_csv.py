"""CSV/TSV reader: separators, decimal commas, gaps, time formats."""

from __future__ import annotations

import contextlib
import gzip
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import collect, read, synthetic

from analyzer.readers import open_input
from analyzer.writers import write_archive


@pytest.mark.parametrize("name", ["data.csv", "data.tsv", "data.csv.gz"])
def test_round_trip_relative_seconds(tmp_path: Path, name: str) -> None:
    t, data = synthetic(2500, channels=3)
    path = tmp_path / name
    write_archive(path, "csv", t, data)
    got, info = read(path)
    assert info.absolute_time is False
    for key in data:
        np.testing.assert_array_equal(got[key][0], t - t[0])  # exact nanoseconds
        np.testing.assert_array_equal(got[key][1], data[key])  # exact float round trip


def test_round_trip_iso_times(tmp_path: Path) -> None:
    t, data = synthetic(500, channels=2)
    path = tmp_path / "iso.csv"
    write_archive(path, "csv", t, data, start_iso="2026-01-01T00:00:00Z")
    got, info = read(path)
    assert info.absolute_time is True
    np.testing.assert_array_equal(got["s0"][0], t)  # synthetic() starts 2026-01-01 UTC


def test_semicolon_and_decimal_comma(tmp_path: Path) -> None:
    path = tmp_path / "eu.csv"
    path.write_text("Zeit;Druck;Temp\n0,0;1,5;20\n0,5;2,25;21\n1,0;-3,125;22\n")
    got, _ = read(path)
    np.testing.assert_array_equal(got["Druck"][0], [0, 500_000_000, 1_000_000_000])
    np.testing.assert_array_equal(got["Druck"][1], [1.5, 2.25, -3.125])
    np.testing.assert_array_equal(got["Temp"][1], [20.0, 21.0, 22.0])


def test_blank_cells_are_gaps_and_text_columns_are_skipped(tmp_path: Path) -> None:
    path = tmp_path / "gaps.csv"
    path.write_text("timestamp,A,B,label,flag\n0.0, ,1,x,true\n0.1, 4,,y,false\n0.2, 5,3,z,TRUE\n")
    got, _ = read(path)
    assert set(got) == {"A", "B", "flag"}
    np.testing.assert_array_equal(got["A"][0], [100_000_000, 200_000_000])
    np.testing.assert_array_equal(got["A"][1], [4.0, 5.0])
    np.testing.assert_array_equal(got["B"][0], [0, 200_000_000])
    np.testing.assert_array_equal(got["flag"][1], [1.0, 0.0, 1.0])


def test_time_column_by_name_not_position(tmp_path: Path) -> None:
    path = tmp_path / "late.csv"
    path.write_text("x,y,Time\n1,2,10\n3,4,11\n")
    got, _ = read(path)
    assert set(got) == {"x", "y"}
    np.testing.assert_array_equal(got["x"][0], [10_000_000_000, 11_000_000_000])


def test_nanosecond_integers_and_zones(tmp_path: Path) -> None:
    path = tmp_path / "ns.csv"
    path.write_text("%time,v\n1486559106139796569,1\n1486559106140360682,2\n")
    got, info = read(path)
    np.testing.assert_array_equal(got["v"][0], [1486559106139796569, 1486559106140360682])
    assert info.absolute_time is True
    zoned = tmp_path / "zoned.csv"
    zoned.write_text("datetime,v\n2026-01-01T02:00:00+02:00,1\n2026-01-01T02:00:01+02:00,2\n")
    got, _ = read(zoned)
    np.testing.assert_array_equal(
        got["v"][0], [1_767_225_600_000_000_000, 1_767_225_601_000_000_000]
    )


def test_quoted_us_style_timestamps(tmp_path: Path) -> None:
    path = tmp_path / "quoted.csv"
    path.write_text('timestamp,A\n" 01/20/2021 10:11:32.332", 1\n" 01/20/2021 10:11:32.532",2\n')
    got, _ = read(path)
    np.testing.assert_array_equal(got["A"][0], [1611137492332000000, 1611137492532000000])


def test_non_numeric_cells_later_are_gaps_and_recorded(tmp_path: Path) -> None:
    path = tmp_path / "dirty.csv.gz"
    with gzip.open(path, "wt") as handle:
        handle.write("time,x,note\n")
        for i in range(20):
            handle.write(f"{i},{'ERR' if i == 7 else i},{'ok' if i % 2 else 12}\n")
    got, info = read(path)
    np.testing.assert_array_equal(got["x"][1], [i for i in range(20) if i != 7])
    assert "note" not in got  # half numbers: a text column
    assert info.errors == ["x: 1 non-numeric cell treated as gaps"]


def test_rows_without_time_are_skipped_and_recorded(tmp_path: Path) -> None:
    path = tmp_path / "holes.csv"
    path.write_text("time,x\n0,1\n,2\n2,3\n")
    got, info = read(path)
    np.testing.assert_array_equal(got["x"][1], [1.0, 3.0])
    assert any(" without a readable time" in e for e in info.errors)


def test_unsorted_rows_come_out_sorted(tmp_path: Path) -> None:
    path = tmp_path / "unsorted.csv"
    path.write_text("time,x\n0.2,3\n0.0,1\n0.1,2\n")
    got, _ = read(path)
    np.testing.assert_array_equal(got["x"][1], [1.0, 2.0, 3.0])


def test_latin1_file(tmp_path: Path) -> None:
    path = tmp_path / "latin1.csv"
    path.write_bytes("time;Temperatur (°C);Ort\n0;21,5;Köln\n1;22,0;Köln\n".encode("latin-1"))
    got, _ = read(path)
    np.testing.assert_array_equal(got["Temperatur (°C)"][1], [21.5, 22.0])


def test_fast_numeric_path_equals_the_careful_path():
    """A column of plain numbers is converted by Arrow's cast in one pass; anything the
    careful path treats specially (blanks, text, booleans, nan/inf, padding) falls back,
    and both give the same values."""
    import pyarrow as pa

    from analyzer.readers.csv_reader import _all_numbers

    clean = pa.array(["1.5", "-2e-3", "+.5", "5.", "-0", "1E+05", "123456789.123456789"])
    fast = _all_numbers(clean)
    assert fast is not None
    np.testing.assert_array_equal(fast, [1.5, -2e-3, 0.5, 5.0, -0.0, 1e5, 123456789.123456789])
    for odd in ("", " 1.5", "true", "nan", "inf", "1,5", "abc"):
        assert _all_numbers(pa.array(["1.0", odd])) is None, odd


# --------------------------------------------------------------------------- fast paths


def _read_both(
    path: Path, monkeypatch: pytest.MonkeyPatch
) -> tuple[tuple[dict, list[str]], tuple[dict, list[str]], list[bool]]:
    """``path`` read as it is (float64 blocks where they parse) and on the text path only
    (no float64 column), with small blocks; also which reads were float64 reads."""
    from analyzer.readers import csv_reader

    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 4096)
    typed: list[bool] = []
    batches = csv_reader.CsvReader._batches

    def spy(self, types=None, **kwargs):  # type: ignore[no-untyped-def]
        typed.append(bool(types))
        return batches(self, types, **kwargs)

    monkeypatch.setattr(csv_reader.CsvReader, "_batches", spy)
    fast = open_input(path)
    fast_out = collect(fast.chunks()), fast.info.errors
    fast_reads = typed[:]  # the first reader's reads only
    text = open_input(path)
    text._fast = ()  # type: ignore[attr-defined]
    text_out = collect(text.chunks()), text.info.errors
    return fast_out, text_out, fast_reads


def _assert_same(a: tuple[dict, list[str]], b: tuple[dict, list[str]]) -> None:
    assert set(a[0]) == set(b[0])
    for name in a[0]:
        np.testing.assert_array_equal(a[0][name][0], b[0][name][0])
        assert a[0][name][1].tobytes() == b[0][name][1].tobytes(), name  # bit for bit
    assert a[1] == b[1]


def _rows(n: int, odd: dict[int, str] | None = None, width: int = 3) -> str:
    """``n`` rows ``time,x0..`` with varied number spellings; row ``i`` of ``odd`` gets
    that text instead (a cell, or a whole line when it starts with ``!``)."""
    rng = np.random.default_rng(1)
    forms = ["{:.17g}", "{:.3e}", " {:.6f}", "{:.4f}\t", '"{:.9g}"', "{:+.2f}", "{:.0f}."]
    lines = ["time," + ",".join(f"x{j}" for j in range(width))]
    for i in range(n):
        cells = [
            forms[(i + j) % len(forms)].format(v)
            for j, v in enumerate(rng.normal(size=width) * 10.0 ** rng.integers(-5, 8))
        ]
        line = f"{i * 0.01:.2f}," + ",".join(cells)
        text = (odd or {}).get(i)
        if text is not None:
            line = (
                text[1:] if text.startswith("!") else f"{i * 0.01:.2f},{text}" + ",1" * (width - 1)
            )
        lines.append(line)
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    "odd",
    [
        {},  # every block float64
        {900: "ERR"},  # a late non-numeric cell: text from that block on
        {900: ""},  # a late blank
        {900: "nan", 950: "-inf"},  # spelled-out values: the text path's
        {900: "nan(1)"},  # parsed by Arrow as nan, not a number to the text path
        {900: "true"},  # a boolean
        {300: "!1.0,1", 600: "!x,y,z,w,v", 900: "ERR", 1200: "!5.0,1,2,3,4"},  # bad rows
        {5: "!,1,2,3", 1100: "!abc,1,2,3"},  # rows without a time, no fallback
        {850: "!1", 880: "!1", 900: "ERR", 901: "!1", 960: "!1", 1000: "!1"},  # near it
    ],
)
def test_float64_blocks_equal_the_text_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, odd: dict[int, str]
) -> None:
    path = tmp_path / "many.csv"
    path.write_text(_rows(1500, odd))
    fast, text, typed = _read_both(path, monkeypatch)
    _assert_same(fast, text)
    assert typed[:2] == [False, True]  # first block as text, then the float64 read
    fallback = any(not cell.startswith("!") for cell in odd.values())
    assert typed[2:] == ([False] if fallback else [])  # then the text read
    assert len(fast[0]["x1"][0]) > 1000


def test_float64_blocks_equal_the_text_path_gzip_and_damage(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A gzip file cut short: both reads stop with the same error. Where exactly is up to
    Arrow's read-ahead (it varies from run to run on the text path alone), so the rows
    are compared as far as both got."""
    data = gzip.compress(_rows(60000, {30000: "ERR"}).encode())
    path = tmp_path / "cut.csv.gz"
    path.write_bytes(data[: len(data) * 3 // 4])
    fast, text, typed = _read_both(path, monkeypatch)
    assert typed == [False, True, False]
    assert fast[1] == text[1]
    assert any("unreadable from some point on" in e for e in fast[1])
    for name in text[0]:
        n = min(len(fast[0][name][0]), len(text[0][name][0]))
        assert n > 30000
        np.testing.assert_array_equal(fast[0][name][0][:n], text[0][name][0][:n])
        assert fast[0][name][1][:n].tobytes() == text[0][name][1][:n].tobytes()


ISO_BLOCKS = [
    ["2026-01-01T01:00:00Z", "2026-01-01 01:00:00.5Z", "2026-01-01T01:00:00.123456789Z"],
    ["2026-01-01T01:00:00+02:00", "2026-01-01T01:00:00-05:30", "2026-01-01T01:00:00+0200"],
    ["2026-01-01T01:00:00", "2026-01-01 01:00:00.25", "2026-01-01T01:00", "2026-01-01"],
    ["2026-01-01T01:00:00Z", "2026-01-01T01:00:00"],  # with and without zone
    ["2026-01-01T01:00:00Z", ""],  # a blank
    ["2026-02-29T01:00:00Z", "2024-02-29T01:00:00Z"],  # no such day
    ["2026-01-01T23:59:60Z", "2026-01-01T24:00:00Z"],  # leap second, hour 24
    ["1600-01-01T00:00:00Z", "2300-01-01T00:00:00Z", "2262-04-11T23:47:16.854775807Z"],
    ["1677-09-21T00:12:43.145224192Z", "1677-09-21T00:12:43.145224193Z"],  # int64 min, NaT
    ["2026-01-01T01:00:00.1234567891Z", "20260101T010000Z", "2026-1-1T01:00:00Z"],
]


@pytest.mark.parametrize("cells", ISO_BLOCKS)
def test_iso_times_by_arrow_equal_pandas(cells: list[str]) -> None:
    """Arrow's ISO 8601 parse of a block, where it takes it, gives pandas' instants."""
    import pyarrow as pa

    from analyzer.readers.csv_reader import CsvReader

    reader = CsvReader.__new__(CsvReader)
    reader._time_format = "ISO8601"
    reader._iso_type = pa.timestamp("ns", "UTC")
    text = pa.array(cells)
    t_fast, keep_fast = reader._datetimes(text)
    reader._iso_type = pa.timestamp("ns")  # the other form first
    t_other, keep_other = reader._datetimes(text)
    reader._iso_datetimes = lambda _text: None  # type: ignore[method-assign]
    t_pandas, keep_pandas = reader._datetimes(text)
    np.testing.assert_array_equal(keep_fast, keep_pandas)
    np.testing.assert_array_equal(t_fast[keep_fast], t_pandas[keep_pandas])
    np.testing.assert_array_equal(keep_other, keep_pandas)
    np.testing.assert_array_equal(t_other[keep_other], t_pandas[keep_pandas])


def test_iso_time_file_equals_the_pandas_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from analyzer.readers import csv_reader

    t, data = synthetic(3000, channels=2)
    path = tmp_path / "iso.csv"
    write_archive(path, "csv", t, data, start_iso="2026-01-01T00:00:00Z")
    text = path.read_text().splitlines()
    text[1500] = "2026-13-01T00:00:00Z," + text[1500].split(",", 1)[1]  # one bad time
    path.write_text("\n".join(text) + "\n")
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 4096)
    fast = open_input(path)
    fast_out = collect(fast.chunks()), fast.info.errors
    monkeypatch.setattr(csv_reader.CsvReader, "_iso_datetimes", lambda _self, _text: None)
    slow = open_input(path)
    _assert_same(fast_out, (collect(slow.chunks()), slow.info.errors))
    assert len(fast_out[0]["s0"][0]) == 2999


def test_time_bounds_are_pandas_and_pandas_loads_only_when_needed():
    """The reader's ns bounds are pandas' Timestamp range, and reading an MCAP archive
    (or importing the pipeline) never imports pandas: only a CSV time column needs it."""
    import subprocess
    import sys

    import pandas as pd

    from analyzer.readers import csv_reader

    assert pd.Timestamp.min.tz_localize("UTC").value == csv_reader._NS_MIN
    assert pd.Timestamp.max.tz_localize("UTC").value == csv_reader._NS_MAX
    sample = Path(__file__).resolve().parents[2] / "samples" / "building_additive.mcap"
    code = (
        "import sys\n"
        "from analyzer.pipeline import analyze, RunOptions\n"
        f"analyze([{str(sample)!r}], RunOptions(jobs=1))\n"
        "print('pandas' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def _open_fds(path) -> int:
    import os

    target = os.path.realpath(path)
    count = 0
    for fd in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):
            count += os.readlink(f"/proc/self/fd/{fd}") == target
    return count


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_arrows_file_is_left_to_arrow_to_close(tmp_path, monkeypatch):
    """The reader never closes the file it gave Arrow by hand: Arrow's streaming reader
    reads ahead on its I/O threads, and a read still in flight when the descriptor was
    closed (the first block's reader, given up after one block) asked the number for
    the rest of its block after the next reader of the file had it: that reader lost
    ``BLOCK_BYTES - size % BLOCK_BYTES`` bytes of rows (benchmarks/README.md,
    ``stress_repeat.py``). The file closes once Arrow lets go of it: no descriptor is
    left open."""
    import time

    from analyzer.readers import csv_reader

    path = tmp_path / "rec.csv"
    rows = "\n".join(f"{i / 100:.2f},{i % 7},{i % 5}" for i in range(20000))
    path.write_text("time,a,b\n" + rows + "\n")
    given = []
    first = csv_reader._arrow_file

    def kept(p):
        given.append(first(p))
        return given[-1]

    monkeypatch.setattr(csv_reader, "_arrow_file", kept)
    reader = csv_reader.CsvReader(path)
    samples = sum(len(c) for c in reader.chunks())
    assert samples == 2 * 20000
    assert len(given) >= 2  # the first block's reader, then the whole read
    assert not any(f.closed for f in given)
    given.clear()
    deadline = time.monotonic() + 5.0
    while _open_fds(path) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert _open_fds(path) == 0


def _random_gz_rows(path, rows, keep, nan_at=-1):
    """A ``.csv.gz`` of ``rows`` rows ``time,a,b`` of random digits (they do not
    compress to nothing; ``a`` is ``nan`` in row ``nan_at``), cut after ``keep`` of its
    compressed bytes (a power loss); returns the whole rows before the cut."""
    import zlib

    rng = np.random.default_rng(3)
    index = np.arange(rows)[:, None] // 10 ** np.arange(6, -1, -1) % 10  # time: 7 digits
    text = np.full((rows, 43), ord(","), dtype=np.uint8)
    text[:, :7] = ord("0") + index
    text[:, 7:10] = np.frombuffer(b".00", dtype=np.uint8)
    for start in (11, 27):  # a and b: 0.DDDDDDDDDDDDD
        text[:, start : start + 2] = np.frombuffer(b"0.", dtype=np.uint8)
        text[:, start + 2 : start + 15] = ord("0") + rng.integers(0, 10, (rows, 13))
    text[:, 42] = ord("\n")
    lines = text.tobytes()
    if nan_at >= 0:
        row = lines[43 * nan_at : 43 * (nan_at + 1)]
        lines = lines[: 43 * nan_at] + row[:11] + b"nan" + row[26:] + lines[43 * (nan_at + 1) :]
    packed = gzip.compress(b"time,a,b\n" + lines, compresslevel=1)
    cut = packed[: int(len(packed) * keep)]
    path.write_bytes(cut)
    return zlib.decompressobj(16 + zlib.MAX_WBITS).decompress(cut).count(b"\n") - 1


def test_a_closed_gunzip_never_reads_its_descriptors_next_owner(tmp_path):
    """Why ``_inflated_blocks`` may close its ``_Gunzip`` by hand while Arrow's I/O
    thread still reads ahead: a read after the close raises, and does not read the
    file that now has the descriptor's number (``OSFile``'s number did: see
    :meth:`CsvReader._arrow_blocks`)."""
    import os

    from analyzer.readers import csv_reader

    path = tmp_path / "rec.csv.gz"
    _random_gz_rows(path, 60000, 1.0)
    other = tmp_path / "other.bin"
    other.write_bytes(bytes(1 << 20))
    gunzip = csv_reader._Gunzip(path)
    assert len(gunzip.read(1000)) > 0
    gunzip.close()
    with other.open("rb", buffering=0) as handle:
        with pytest.raises(ValueError, match="closed file"):
            while gunzip.read(1 << 20):  # (the text inflated before the close, then the file)
                pass
        assert os.lseek(handle.fileno(), 0, os.SEEK_CUR) == 0


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc")
def test_a_damaged_gz_read_after_a_reader_given_up_keeps_every_row(tmp_path, monkeypatch):
    """A ``.csv.gz`` cut short, whose inflation by Arrow fails before its first block
    (as it does where the damage comes early): every read goes through ``_Gunzip``.
    The first block's reader, and the float64 reader at the block with a ``nan``, are
    given up with Arrow's read-ahead of their ``_Gunzip`` in flight and their files
    closed by hand (reads end after the close); the next reads get every whole row
    before the damage, read after read, and no descriptor is left open."""
    import time

    from analyzer.readers import csv_reader

    def failing(self, *args):
        raise OSError("Arrow's inflation failed (as where the damage comes early)")
        yield

    read_text = csv_reader._Gunzip.read
    after_close = []

    def counted(self, size=-1):
        try:
            return read_text(self, size)
        finally:
            after_close.append(self.closed)

    monkeypatch.setattr(csv_reader.CsvReader, "_arrow_blocks", failing)
    monkeypatch.setattr(csv_reader._Gunzip, "read", counted)
    path = tmp_path / "cut.csv.gz"
    rows = _random_gz_rows(path, 250000, 0.7, nan_at=100)  # 7.5 MB of text
    for attempt in range(10):
        got, info = read(path)
        np.testing.assert_array_equal(got["b"][0], np.arange(rows) * 1_000_000_000)
        assert len(got["a"][0]) == rows - 1  # (the nan)
        assert any("cut short" in e for e in info.errors), info.errors
        if attempt >= 2 and any(after_close):
            break
    assert any(after_close)  # the case in question did occur
    deadline = time.monotonic() + 5.0
    while _open_fds(path) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert _open_fds(path) == 0

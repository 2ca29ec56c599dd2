"""The CSV reader against the 33rd review's findings: a corrupt ``.csv.gz`` kept the
garbage zlib inflated between the damage and its error (times on to 6.6e9 s, hundreds
of steps back: the file refused alone, and in an archive taken as relative time, which
refused the whole archive); integer nanoseconds since boot refused with a hint to epoch
microseconds only (which then gave a 1000x wrong time base); a sparse wide table said
to repeat times though no channel did; headers numbering columns from 101, by years or
from -1 refused as data."""

from __future__ import annotations

import gzip
import json
import zlib
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, read

from analyzer import cli
from analyzer.errors import ReaderError
from analyzer.readers import csv_reader, open_input

Samples = dict[str, tuple[np.ndarray, np.ndarray]]
TEN_MS = 10_000_000
SECTOR = 4096


def table(n: int, start_s: float = T0 / 1e9, seed: int = 2) -> bytes:
    """``n`` rows at 100 Hz from ``start_s`` (epoch seconds, two decimals): ``a`` =
    i / 8, ``b`` random with six decimals."""
    rng = np.random.default_rng(seed)
    b = rng.standard_normal(n)
    rows = "".join(f"{start_s + i / 100:.2f},{i / 8},{b[i]:.6f}\n" for i in range(n))
    return ("time,a,b\n" + rows).encode()


def zero_sector(data: bytes, share: float = 0.5) -> bytes:
    """``data`` with the 4 KiB sector at ``share`` of it zeroed (disk damage)."""
    out = bytearray(data)
    at = int(len(out) * share) // SECTOR * SECTOR
    out[at : at + SECTOR] = bytes(SECTOR)
    return bytes(out)


def flip(data: bytes, count: int = 20, share: float = 0.5) -> bytes:
    """``data`` with ``count`` bytes at ``share`` of it inverted."""
    out = bytearray(data)
    at = int(len(out) * share)
    out[at : at + count] = bytes(x ^ 0xFF for x in out[at : at + count])
    return bytes(out)


def sound_rows(damaged: bytes, text: bytes) -> int:
    """Rows under the header that zlib inflates of ``damaged`` as they were written:
    those before the first byte of its text that differs from ``text``."""
    state = zlib.decompressobj(31)
    pieces = []
    try:
        for start in range(0, len(damaged), 512):
            pieces.append(state.decompress(damaged[start : start + 512]))
    except zlib.error:
        pass
    inflated = b"".join(pieces)
    first = next(i for i, (x, y) in enumerate(zip(inflated, text, strict=False)) if x != y)
    return text[:first].count(b"\n") - 1


def assert_rows_before_the_damage(got: Samples, sound: int, start_ns: int = T0) -> None:
    """Every row read is a row as written (its time and ``a``; ``b`` may differ in a
    digit in the last one, touched by the garbage unseen), in order, and they are all
    those before the damage (but at most the last two)."""
    t, a = got["a"]
    assert sound - 2 <= len(a) <= sound + 1
    np.testing.assert_array_equal(t, start_ns + TEN_MS * np.arange(len(a)))
    np.testing.assert_array_equal(a, np.arange(len(a)) / 8)
    assert len(got["b"][1]) == len(a)


# --------------------------------------------------------------------------- corrupt .gz


@pytest.mark.parametrize("damage", ["sector", "flip"])
def test_a_corrupt_gzip_is_read_up_to_the_damage_not_beyond(tmp_path: Path, damage: str) -> None:
    """A 4 KiB sector of zeros (or 20 bytes inverted) in the middle: the rows zlib
    inflated between the damage and its error (the checksum) were kept, garbage (times
    stepping back seconds and on to 6.6e9 s)."""
    text = table(60_000)
    data = gzip.compress(text)
    bad = zero_sector(data) if damage == "sector" else flip(data)
    path = tmp_path / "bad.csv.gz"
    path.write_bytes(bad)
    got, info = read(path)
    sound = sound_rows(bad, text)
    assert 20_000 < sound < 40_000
    assert_rows_before_the_damage(got, sound)
    assert info.absolute_time is True
    (note,) = [e for e in info.errors if e.startswith("unreadable from some point on")]
    assert "corrupt compressed data (Error -3 while decompressing data: " in note
    rows = len(got["a"][1])
    assert f"the rows before the damage were read ({rows} rows, up to 2026-01-01T" in note
    assert "the rest of the file from the damage on dropped (the rows turn to garbage at " in note
    assert f"at data row {rows + 1}: " in note


@pytest.mark.parametrize("share", [0.3, 0.6])
def test_garbage_arrow_passed_on_before_its_error_is_dropped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, share: float
) -> None:
    """In a file of many blocks, Arrow passes on the blocks it inflates from garbage
    until zlib fails at the member's checksum: they were read as rows."""
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 1 << 16)
    text = table(150_000, start_s=100.0)
    bad = zero_sector(gzip.compress(text), share)
    path = tmp_path / "big.csv.gz"
    path.write_bytes(bad)
    got, info = read(path)
    assert_rows_before_the_damage(got, sound_rows(bad, text), start_ns=100 * 10**9)
    assert info.absolute_time is False
    assert [e for e in info.errors if "the rest of the file from the damage on dropped" in e]
    assert not [e for e in info.errors if "steps back" in e or "skipped" in e]


def test_a_corrupt_gzip_alone_is_analyzed_up_to_the_damage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Refused: 'the common clock at 100 Hz would need 662,827,111,901 rows'."""
    rng = np.random.default_rng(4)
    rows = "".join(
        f"{T0 / 1e9 + i / 100:.2f},{x:.6f},{y:.6f},{z:.6f}\n"
        for i, (x, y, z) in enumerate(rng.standard_normal((20_000, 3)))
    )
    path = tmp_path / "single.csv.gz"
    path.write_bytes(zero_sector(gzip.compress(("time,a,b,c\n" + rows).encode())))
    out = tmp_path / "out"
    assert cli.main(["run", str(path), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    *err, last = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the rest of the file from the damage on dropped" in err[0]
    assert last.startswith("analyzer: no sensor fault found; report: ")  # (the run's last line)
    findings = json.loads((out / "findings.json").read_text())
    assert findings["start"].startswith("2026-01-01T00:00:00")
    assert 50 < findings["duration_s"] < 150  # up to the damage (200 s written)


def test_a_corrupt_member_does_not_decide_the_archives_clock(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The middle one of three epoch-time pieces damaged: its garbage made it 'relative
    time', and the archive was refused ('one archive needs one clock'); exit 2."""
    folder = tmp_path / "arch"
    folder.mkdir()
    n = 20_000
    kept = 0
    for k in range(3):
        text = table(n, start_s=T0 / 1e9 + 600 * k, seed=k)
        data = gzip.compress(text)
        if k == 1:
            data = zero_sector(data)
            kept = sound_rows(data, text)
        (folder / f"p{k}.csv.gz").write_bytes(data)
    assert cli.main(["inspect", str(folder), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    errors = {Path(i["path"]).name: i["errors"] for i in doc["inputs"]}
    assert errors["p0.csv.gz"] == errors["p2.csv.gz"] == []
    (note,) = errors["p1.csv.gz"]
    assert "the rest of the file from the damage on dropped" in note
    (a,) = [c for c in doc["channels"] if c["name"] == "a"]
    assert 2 * n + kept - 2 <= a["samples"] <= 2 * n + kept
    assert a["end_s"] == pytest.approx(1200 + (n - 1) / 100)


@pytest.mark.parametrize("cut", [False, True])
def test_a_sound_or_cut_gzip_with_a_step_back_keeps_its_rows(tmp_path: Path, cut: bool) -> None:
    """Signs of garbage in a stream that is sound, or merely cut short, are no garbage:
    a clock set back by 15 s and a line with a field too many; every row is read."""
    lines = table(30_000, start_s=100.0).decode().splitlines(keepends=True)
    for i in range(15_001, len(lines)):  # data row 15001 on: 15 s back
        time, rest = lines[i].split(",", 1)
        lines[i] = f"{float(time) - 15:.2f},{rest}"
    lines[5000] = lines[5000].rstrip("\n") + ",7\n"
    data = gzip.compress("".join(lines).encode())
    path = tmp_path / "back.csv.gz"
    path.write_bytes(data[: int(len(data) * 0.9)] if cut else data)
    got, info = read(path)
    whole = _whole_rows(path.read_bytes()) - 1 if cut else 29_999
    assert len(got["a"][1]) == whole
    assert any(e.startswith("the time steps back by 15 s at data row 15000") for e in info.errors)
    assert "1 row without a readable time or with the wrong number of fields skipped" in (
        info.errors
    )
    assert not [e for e in info.errors if "garbage" in e]


def _whole_rows(data: bytes) -> int:
    """Rows under the header that a cut gzip holds whole."""
    return zlib.decompressobj(31).decompress(data).count(b"\n") - 1


# --------------------------------------------------------------------------- ns since boot

BOOT_NS = 1_728_000_000_000_000  # 20 days of uptime in ns; as epoch µs, October 2024


def _boot(path: Path, name: str, start: int = BOOT_NS) -> Path:
    path.write_text(f"{name},a\n" + "".join(f"{start + 20_000_000 * i},{i}\n" for i in range(3000)))
    return path


def test_nanoseconds_since_boot_are_refused_naming_both_readings(tmp_path: Path) -> None:
    """The refusal named epoch microseconds only: following it ('time [us]') read 60 s
    at 50 Hz as 60 000 s at 0.05 Hz without a word."""
    path = _boot(tmp_path / "boot.csv", "time")
    with pytest.raises(ReaderError, match="is no time") as err:
        open_input(path)
    message = str(err.value)
    assert "epoch microseconds? a name such as 'time [us]' says so" in message
    assert "'time [ns]' if they are nanoseconds counted from another start" in message


@pytest.mark.parametrize("name", ["time [ns]", "time_ns"])
def test_nanoseconds_since_boot_named_so_are_relative_nanoseconds(
    tmp_path: Path, name: str
) -> None:
    got, info = read(_boot(tmp_path / "boot.csv", name))
    np.testing.assert_array_equal(got["a"][0], BOOT_NS + 20_000_000 * np.arange(3000))
    assert info.absolute_time is False and info.errors == []
    assert info.time == f"column {name!r}: nanoseconds, relative"


def test_nanoseconds_since_boot_that_are_no_epoch_either_way_are_read(tmp_path: Path) -> None:
    """2e16 ns (231 days of uptime) is 1970 as nanoseconds and beyond 2262 as
    microseconds: nanoseconds from another start, as before the 31st probe."""
    got, info = read(_boot(tmp_path / "boot.csv", "time", start=2 * 10**16))
    np.testing.assert_array_equal(got["a"][0], 2 * 10**16 + 20_000_000 * np.arange(3000))
    assert info.absolute_time is False and info.errors == []
    assert info.time == "column 'time': integer nanoseconds from another start, relative"


# --------------------------------------------------------------------------- numbered headers


@pytest.mark.parametrize(
    "header", ["101,102,103", "2024,2025,2026", "-1,0,1", "0,1,2", "1,2,3", "10, 20, 35"]
)
def test_headers_numbering_columns_in_increasing_order_are_headers(
    tmp_path: Path, header: str
) -> None:
    path = tmp_path / "numbered.csv"
    path.write_text(header + "\n" + "".join(f"{i * 0.02:.2f},{i},{-i}\n" for i in range(500)))
    got, info = read(path)
    names = [n.strip() for n in header.split(",")]
    assert sorted(got) == sorted(names[1:])
    assert len(got[names[1]][1]) == 500 and info.errors == []


@pytest.mark.parametrize("first", ["3,2,1", "5,5,6", "1,2,2", "0.0,1,2", "1,2.5,3"])
def test_first_lines_not_numbering_columns_are_still_data(tmp_path: Path, first: str) -> None:
    path = tmp_path / "piece.csv"
    path.write_text(first + "\n" + "".join(f"{i},{i},{i}\n" for i in range(4, 50)))
    with pytest.raises(ReaderError, match="the first line is data"):
        open_input(path)

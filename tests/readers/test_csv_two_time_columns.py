"""A CSV with a ``time`` column of seconds from the start beside an ISO ``timestamp``
column: ``time`` is the time column (its name comes first), and the date-times were
dropped as a text column without a word, so the findings had no absolute times. Where
the two agree, the absolute times now come from the ISO column; where they do not, a
line says which column gave the time and that the other was ignored."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, collect

from analyzer.cli import main
from analyzer.errors import ReaderError
from analyzer.inspect import inspect_archive
from analyzer.readers import csv_reader, open_input

N = 400
START = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)  # T0


def _write(path: Path, seconds: np.ndarray, stamps: list[str], columns: int = 2) -> Path:
    rng = np.random.default_rng(5)
    values = rng.normal(size=(len(seconds), columns))
    names = ",".join(f"s{k}" for k in range(columns))
    rows = [
        f"{t:.2f},{s}," + ",".join(f"{v:.5f}" for v in row)
        for t, s, row in zip(seconds, stamps, values, strict=True)
    ]
    path.write_text(f"time,timestamp,{names}\n" + "\n".join(rows) + "\n")
    return path


def _iso(seconds: np.ndarray, timespec: str = "milliseconds") -> list[str]:
    return [
        (START + dt.timedelta(seconds=float(s))).isoformat(timespec=timespec).replace("+00:00", "Z")
        for s in seconds
    ]


def test_agreeing_iso_column_gives_the_absolute_times(tmp_path: Path) -> None:
    seconds = np.arange(N) * 0.05
    reader = open_input(_write(tmp_path / "a.csv", seconds, _iso(seconds)))
    assert reader.info.absolute_time and reader.info.errors == []
    assert reader.info.time == (
        "column 'time': seconds; absolute times from column 'timestamp', whose date-times "
        "agree with it (to 0.01 s): 0 s is 2026-01-01T00:00:00.000Z"
    )
    t, _ = collect(reader.chunks())["s0"]
    np.testing.assert_array_equal(t, T0 + np.arange(N) * 50_000_000)
    assert reader.info.errors == []
    doc = inspect_archive([tmp_path / "a.csv"])
    assert doc["start"] == "2026-01-01T00:00:00.000Z"


def test_whole_second_stamps_give_the_start_to_the_second(tmp_path: Path) -> None:
    """ISO times cut to the second (``isoformat(timespec="seconds")``, strftime) beside
    times of 0.05 s from 3.3 s: they agree to the second, and the largest difference
    (the stamp least cut) is the offset: exact here, where some times are whole seconds."""
    seconds = 3.3 + np.arange(N) * 0.05
    stamps = _iso(np.floor(seconds), "seconds")
    reader = open_input(_write(tmp_path / "s.csv", seconds, stamps))
    assert reader.info.absolute_time
    assert "agree with it (to 1 s): 3.3 s is 2026-01-01T00:00:03.300Z" in reader.info.time
    t, _ = collect(reader.chunks())["s0"]
    np.testing.assert_array_equal(t, T0 + 3_300_000_000 + np.arange(N) * 50_000_000)


def test_disagreeing_iso_column_is_ignored_and_said(tmp_path: Path) -> None:
    """Date-times that run 1.5 times as fast as ``time`` (another clock): ``time`` stays
    the time, relative, and the line says so."""
    seconds = np.arange(N) * 0.05
    reader = open_input(_write(tmp_path / "d.csv", seconds, _iso(1.5 * seconds)))
    assert not reader.info.absolute_time
    assert reader.info.time == "column 'time': seconds, relative"
    (line,) = reader.info.errors
    assert line.startswith(
        "two time columns: 'time' gave the time (seconds, relative); 'timestamp' "
        "(date-times) was ignored: its date-times less the times of 'time' vary by 10 s "
        "over the first 400 rows"
    )
    t, _ = collect(reader.chunks())["s0"]
    np.testing.assert_array_equal(t, np.arange(N) * 50_000_000)


def test_iso_column_alone_is_unchanged(tmp_path: Path) -> None:
    path = tmp_path / "iso.csv"
    seconds = np.arange(N) * 0.05
    path.write_text(
        "timestamp,s0\n" + "\n".join(f"{s},{k}" for k, s in enumerate(_iso(seconds))) + "\n"
    )
    reader = open_input(path)
    assert reader.info.time == "column 'timestamp': date-times (UTC where no zone is given)"
    assert collect(reader.chunks())["s0"][0][0] == T0


def test_findings_have_iso_times(tmp_path: Path) -> None:
    """The run's findings carry the absolute start and onsets (null before): an offset
    of 2 on s3 from 80 s, four sensors of one sinusoidal excitation."""
    n = 12_000
    seconds = np.arange(n) * 0.01
    common = np.sin(2 * np.pi * 0.5 * seconds) + 0.3 * np.sin(2 * np.pi * 1.3 * seconds)
    values = common[:, None] * np.array([1.0, 0.8, 1.2, 0.9])
    values += 0.05 * np.random.default_rng(7).normal(size=(n, 4))
    values[8000:, 3] += 2.0
    rows = [
        f"{t:.2f},{s}," + ",".join(f"{v:.5f}" for v in row)
        for t, s, row in zip(seconds, _iso(seconds), values, strict=True)
    ]
    path = tmp_path / "f.csv"
    path.write_text("time,timestamp,s0,s1,s2,s3\n" + "\n".join(rows) + "\n")
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 1
    doc = json.loads((out / "findings.json").read_text())
    assert doc["start"] == "2026-01-01T00:00:00.000Z"
    (fault,) = doc["faults"]
    assert (fault["channel"], fault["onset_s"]) == ("s3", 80.0)
    assert fault["onset"] == "2026-01-01T00:01:20.000Z"


# ------------------------------------ compared on every block, not the first only (contract46)

MANY = 6_000  # rows: with blocks of 16 KiB, about 20 blocks


def _blocks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocks of 16 KiB (1 MiB in use), for files of several blocks in a small test."""
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 1 << 14)


@pytest.mark.parametrize(
    "part, row",
    [
        ("iso_hour", 4_000),  # the date-times jump an hour ahead (a clock reset to local time)
        ("time_restart", 5_000),  # the seconds restart from 0 (a logger restarted)
        ("blank_cells", 4_000),  # the hour, in blocks with a blank date-time (read by pandas)
    ],
)
def test_time_columns_that_part_after_the_first_block_are_refused(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    part: str,
    row: int,
) -> None:
    _blocks(monkeypatch)
    seconds = np.arange(MANY) * 0.05
    stamps = seconds.copy()
    if part == "time_restart":
        seconds[row:] -= seconds[row]
    else:
        stamps[row:] += 3600.0
    cells = _iso(stamps)
    if part == "blank_cells":
        cells[row - 1] = cells[row + 1] = ""
    path = _write(tmp_path / "p.csv", seconds, cells)
    reader = open_input(path)
    assert reader.info.absolute_time  # (agreed on the first block)
    with pytest.raises(ReaderError) as caught:
        collect(reader.chunks())
    first_block = int(caught.value.args[0].split("over the first ")[1].split(" rows")[0])
    assert first_block < row  # (the parting lies beyond the first block)
    offset = row * 0.05 if part == "time_restart" else 3600.0
    assert str(caught.value).startswith(
        f"{path}: two time columns part at data row {row + 1}: 'timestamp' "
        f"{_iso(stamps[row : row + 1])[0]!r} lies {offset:+.3f} s from 'time' "
        f"'{seconds[row]:.2f}' ({_iso(seconds[row : row + 1])[0]}), after they agreed (to "
        "0.01 s) over the first"
    )
    for command in (["run", path, "--out", tmp_path / "o", "--no-progress"], ["inspect", path]):
        assert main([str(a) for a in command]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "two time columns part at data row" in err


def test_time_columns_that_agree_throughout_read_as_before(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Many blocks that agree, the date-times cut to the second (each block's differences
    lie anywhere within the second): absolute times, nothing said."""
    _blocks(monkeypatch)
    seconds = 3.3 + np.arange(MANY) * 0.05
    reader = open_input(_write(tmp_path / "a.csv", seconds, _iso(np.floor(seconds), "seconds")))
    t, _ = collect(reader.chunks())["s0"]
    np.testing.assert_array_equal(t, T0 + 3_300_000_000 + np.arange(MANY) * 50_000_000)
    assert reader.info.errors == []

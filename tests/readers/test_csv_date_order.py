"""Audit: day-first dates (``dd/mm/yyyy``) were read month first from the first cell's
guess: a file crossing 12/03 -> 13/03 lost the rows after midnight, two pieces of one
archive landed 266 days apart, and a file of days up to 12 read two months off with
nothing said."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from readers_helpers import collect

from analyzer.readers import open_archive, open_input


def _write(path: Path, start: str, rows: int, fmt: str = "%d/%m/%Y %H:%M:%S.%f") -> Path:
    t = pd.date_range(start, periods=rows, freq="100ms")
    values = np.random.default_rng(0).standard_normal((rows, 2))
    frame = pd.DataFrame({"time": t.strftime(fmt), "a": values[:, 0], "b": values[:, 1]})
    frame.to_csv(path, index=False)
    return path


def test_a_day_above_12_at_the_files_end_reads_it_day_first(tmp_path: Path) -> None:
    reader = open_input(_write(tmp_path / "one.csv", "2026-03-12 23:59:00", 1200))
    t, _ = collect(reader.chunks())["a"]
    assert t.size == 1200 and reader.start_ns() == pd.Timestamp("2026-03-12 23:59:00Z").value
    assert reader.info.errors == []
    assert reader.info.time.endswith("day first")


def test_dates_either_way_round_are_said(tmp_path: Path) -> None:
    reader = open_input(_write(tmp_path / "x.csv", "2026-03-01 02:00:00", 600))
    assert reader.start_ns() == pd.Timestamp("2026-01-03 02:00:00Z").value  # month first
    assert "month first (either way round: no day above 12)" in reader.info.time
    (line,) = reader.info.errors
    assert line.startswith("dates whose day and month could be either way round")


def test_an_archives_day_first_file_decides_for_the_others(tmp_path: Path) -> None:
    _write(tmp_path / "p0.csv", "2026-03-12 23:58:00", 600)  # days 12 only
    _write(tmp_path / "p1.csv", "2026-03-13 00:00:00", 600)  # day 13: day first
    archive = open_archive(tmp_path)
    t, _ = collect(archive.chunks())["a"]
    assert t.size == 1200 and np.all(np.diff(t) > 0)
    assert t[0] == pd.Timestamp("2026-03-12 23:58:00Z").value
    assert archive.inputs[0].errors == [
        "dates whose day and month could be either way round (no day above 12): read day "
        "first, as another file of the archive has a day above 12"
    ]


def test_month_first_and_iso_dates_are_read_as_before(tmp_path: Path) -> None:
    us = open_input(_write(tmp_path / "us.csv", "2026-03-13 00:00:00", 100, "%m/%d/%Y %H:%M:%S.%f"))
    assert us.start_ns() == pd.Timestamp("2026-03-13T00:00:00Z").value and us.info.errors == []
    assert us.info.time.endswith("month first")
    iso = open_input(
        _write(tmp_path / "iso.csv", "2026-03-01 00:00:00", 100, "%Y-%m-%d %H:%M:%S.%f")
    )
    assert iso.start_ns() == pd.Timestamp("2026-03-01T00:00:00Z").value and iso.info.errors == []


def test_a_short_file_and_a_cut_last_line_do_not_hide_the_day(tmp_path: Path) -> None:
    """Review: a 40-row file had its header among its last cells, and a file cut short in
    its last line (time column last) a cell of neither order; either made the tail
    useless: the short piece of a day-first archive stayed month first, 57 days off,
    and the cut file lost its rows after day 12."""
    (tmp_path / "a").mkdir()
    _write(tmp_path / "a" / "1.csv", "2026-02-28 23:54:00", 3600)
    _write(tmp_path / "a" / "2.csv", "2026-03-01 00:00:00", 40)
    archive = open_archive(tmp_path / "a")
    t, _ = collect(archive.chunks())["a"]
    assert t.size == 3640 and t[-1] - t[0] < 400 * 10**9  # not 57 days
    cut = tmp_path / "cut.csv"
    frame = pd.read_csv(_write(tmp_path / "full.csv", "2026-03-12 23:55:00", 7200))
    text = frame[["a", "b", "time"]].to_csv(index=False)
    cut.write_text(text + "0.1,0.2,13/03/20")  # a last line cut short
    reader = open_input(cut)
    t, _ = collect(reader.chunks())["a"]
    assert t.size == 7200 and reader.info.time.endswith("day first")

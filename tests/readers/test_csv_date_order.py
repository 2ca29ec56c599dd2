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

"""Clock changes at the seams between files (ux62 HIGH 1, MEDIUM 2 and 5): the rules a
zone-less CSV file's own times follow (an hour set back refused as the change to winter
time, an hour skipped said as the change to summer time) hold where one file ends and
the next begins; samples dropped at a seam are said in one line per file; the seams
where the reading changed are kept for the run's notes."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np
from readers_helpers import collect

from analyzer.readers import open_archive

DAY = dt.datetime(2026, 10, 25)  # the change to winter time in Europe
STEP_S = 10.0  # a row every 10 s: an hour's file of 360 rows
CHANNELS = ("s0", "s1", "s2")


def _hour_file(path: Path, begin: dt.datetime, zone: str = "", seconds: float = 3600.0) -> Path:
    """A CSV of ``seconds`` from ``begin`` (a row every :data:`STEP_S` s), its times
    written as date-times followed by ``zone`` ("" for none, a logger's local time), its
    values a function of its name's length (two files of one hour are no copies)."""
    n = int(seconds / STEP_S)
    k = np.arange(n)
    times = [(begin + dt.timedelta(seconds=float(s) * STEP_S)).isoformat(sep=" ") for s in k]
    lines = ["time," + ",".join(CHANNELS)]
    for i, t in enumerate(times):
        values = ",".join(
            f"{np.sin(i / (3.0 + c) + len(path.name)):.6f}" for c in range(len(CHANNELS))
        )
        lines.append(f"{t}{zone},{values}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_zoneless_hour_set_back_between_files_is_said_once(tmp_path: Path) -> None:
    """Hourly zone-less files where the 02:00 hour comes twice (the second file named
    ``h02b``): the second is left out with the within-file rule's words, in one line (it
    was dropped as 3 lines of "samples overlap the previous input in time", no clock
    named), and the seam is kept."""
    _hour_file(tmp_path / "h01.csv", DAY.replace(hour=1))
    _hour_file(tmp_path / "h02.csv", DAY.replace(hour=2))
    _hour_file(tmp_path / "h02b.csv", DAY.replace(hour=2))
    _hour_file(tmp_path / "h03.csv", DAY.replace(hour=3))
    archive = open_archive(tmp_path)
    samples = collect(archive.chunks())
    assert samples["s0"][0].size == 3 * 360
    errors = {Path(i.path).name: i.errors for i in archive.inputs}
    assert errors["h01.csv"] == errors["h02.csv"] == errors["h03.csv"] == []
    (line,) = errors["h02b.csv"]
    assert line.startswith("reading stopped: ")
    assert "begin 60 min before the last time of" in line
    assert "local times set back an hour, as at the change from summer to winter time" in line
    assert "(from 2026-10-25T02:59:50.000 to 2026-10-25T02:00:00.000)" in line
    from analyzer.readers.seams import near_seam  # (new in this change)

    seam = near_seam(archive.seams, archive.start_ns() or 0, 2 * 3600 - 10.0)
    assert seam is not None and "h02.csv and h02b.csv" in seam.words


def test_zoned_files_that_overlap_by_an_hour_are_no_clock_change(tmp_path: Path) -> None:
    """The same archive in UTC (``Z``): a file repeating an hour is a copy, not a clock
    change: its samples dropped as overlapping, in one line for its three channels."""
    _hour_file(tmp_path / "h01.csv", DAY.replace(hour=1), "Z")
    _hour_file(tmp_path / "h02.csv", DAY.replace(hour=2), "Z")
    _hour_file(tmp_path / "h02b.csv", DAY.replace(hour=2), "Z")
    archive = open_archive(tmp_path)
    collect(archive.chunks())
    (line,) = next(i.errors for i in archive.inputs if Path(i.path).name == "h02b.csv")
    assert line.startswith("s0, s1, s2 (3 channels): 360 samples each overlap the previous")
    assert "(60 min that h02.csv covers already; its samples are kept)" in line
    assert "summer" not in line


def test_zoneless_hour_skipped_between_files_is_said(tmp_path: Path) -> None:
    """Zone-less files 01:00-02:00 and 03:00-04:00 (the change to summer time): the
    second says that the hour is a gap and its UTC times local ones (before, nothing
    said, and the run read every sensor as stopping)."""
    _hour_file(tmp_path / "h01.csv", DAY.replace(hour=1))
    _hour_file(tmp_path / "h03.csv", DAY.replace(hour=3))
    archive = open_archive(tmp_path)
    collect(archive.chunks())
    errors = {Path(i.path).name: i.errors for i in archive.inputs}
    assert errors["h01.csv"] == []
    (line,) = errors["h03.csv"]
    assert "begin 60 min after the last time of" in line
    assert "local times set forward, as at the change from winter to summer time" in line
    from analyzer.readers.seams import near_seam  # (new in this change)

    seam = near_seam(archive.seams, archive.start_ns() or 0, 3590.0)
    assert seam is not None and "where a gap of 60 min begins" in seam.words


def test_overlap_at_a_seam_is_one_line_per_file(tmp_path: Path) -> None:
    """A file written 60 s early (UTC times): its first minute, on three channels, is one
    line naming how much and which file covered it, and the seam is kept; a seam that
    changed nothing is not."""
    _hour_file(tmp_path / "a.csv", DAY.replace(hour=1), "Z", seconds=300.0)
    _hour_file(tmp_path / "b.csv", DAY.replace(hour=1, minute=4), "Z", seconds=300.0)
    _hour_file(tmp_path / "c.csv", DAY.replace(hour=1, minute=9), "Z", seconds=300.0)
    archive = open_archive(tmp_path)
    samples = collect(archive.chunks())
    assert samples["s1"][0].size == 30 + 24 + 30
    errors = [i.errors for i in archive.inputs]
    assert errors[0] == errors[2] == []
    assert errors[1] == [
        "s0, s1, s2 (3 channels): 6 samples each overlap the previous input in time "
        "(50 s that a.csv covers already; its samples are kept); dropped"
    ]
    assert [s.words for s in archive.seams] == [
        "the seam of a.csv and b.csv, where 6 overlapping samples were dropped"
    ]


def test_zoneless_files_of_other_channels_over_the_same_hour_are_no_clock_change(
    tmp_path: Path,
) -> None:
    """One zone-less file per sensor node over the same hour (other column names): both
    read whole, nothing said of a clock."""
    _hour_file(tmp_path / "node_a.csv", DAY.replace(hour=2))
    other = _hour_file(tmp_path / "node_b.csv", DAY.replace(hour=2))
    other.write_text(other.read_text().replace("time,s0,s1,s2", "time,b0,b1,b2", 1))
    archive = open_archive(tmp_path)
    samples = collect(archive.chunks())
    assert samples["s0"][0].size == samples["b0"][0].size == 360
    assert all(i.errors == [] for i in archive.inputs)

"""The CSV reader's time column against ux55's items 2, 3 and 7: a logger restarted in
the middle of a file of relative times (its seconds counting from 0 again) had its second
stretch laid over its first, one value kept at each time (half the record lost, said as
rows "written in batches"); local times without a zone across the change to winter time
had their repeated hour merged into the hour before (a fault lost, or an hour dropped and
the onset an hour off); a ``Date`` column beside a ``Time`` column of times of day was
skipped as text without a word (relative times, no start, no UTC onset). The files are
written from the package's simulated building (5 floors, 50 Hz)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import read
from test_two_clocks import _refused

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building

RATE = 50.0


def _values(seconds: float, seed: int = 3) -> np.ndarray:
    """(rows, 5) simulated accelerations of the building at :data:`RATE`."""
    _, y, _ = simulate_building(5, seconds, RATE, seed=seed)
    return y


def _write(
    path: Path, cells: list[str], y: np.ndarray, header: str = "time", sep: str = ","
) -> Path:
    """A CSV of the time cells ``cells`` (a time column, or ``Date<sep>Time`` pairs that
    ``header`` names) and the channels s0..s4 of ``y``."""
    names = sep.join(f"s{i}" for i in range(y.shape[1]))
    rows = [
        f"{c}{sep}" + sep.join(f"{v:.6f}" for v in row) for c, row in zip(cells, y, strict=True)
    ]
    path.write_text("\n".join([f"{header}{sep}{names}", *rows]) + "\n")
    return path


# ------------------------------------------------------------------ a logger restarted


def _restarted(path: Path, start: float = 0.0, again: float | None = None) -> Path:
    """150 s of seconds from ``start``, then the seconds from ``again`` (``start`` where
    None) on for 150 s more: a logger that restarted after 150 s."""
    n = int(150 * RATE)
    first = start + np.arange(n) / RATE
    second = (start if again is None else again) + np.arange(n) / RATE
    cells = [f"{s:.3f}" for s in np.concatenate([first, second])]
    return _write(path, cells, _values(300.0))


def test_a_restart_of_relative_times_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: 'the time steps back by 149.980 s ... sorted in', the second stretch's
    values kept at each time, ``export`` 7 500 of 15 000 rows. Now refused by ``run`` and
    ``export`` in one line naming the file, the row and both times; ``inspect`` lists it."""
    path = _restarted(tmp_path / "reboot.csv")
    _, info = read(path)
    said = (
        "the time column 'time' steps back by 2.5 min at data row 7501 ('0.000': from "
        "149.980 s to 0.000 s), to the time of its first row (0.000 s), and counts on over "
        "the times already read: a logger restarted, its clock counting from its start "
        "again? Its rows would fall on those before at the same times; split the file at "
        "that row and analyze the parts apart"
    )
    assert info.set_back == said
    assert info.errors == [said]
    for err in _refused(path, tmp_path, capsys):
        assert err == f"analyzer: error: {path}: {said}\n"
    assert main(["inspect", str(path)]) == 0
    assert f"  ! {said}\n" in capsys.readouterr().out


def test_a_restart_a_little_after_the_first_time_is_refused(tmp_path: Path) -> None:
    """A file starting at 12.5 s of the logger's clock, which restarts at 11 s (before
    its first time): the rows from 12.5 s on fall on the first stretch again."""
    path = _restarted(tmp_path / "reboot.csv", start=12.5, again=11.0)
    _, info = read(path)
    assert info.set_back.startswith(
        "the time column 'time' steps back by 2.5 min at data row 7501 ('11.000': "
        "from 162.480 s to 11.000 s), to the time of its first row (12.500 s)"
    )


def test_a_restart_in_a_folder_stops_that_files_reading(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """In a folder of files a restarted file is a damaged file, as one set back by hours:
    its reading stops at the step, said; the other file is kept."""
    folder = tmp_path / "files"
    folder.mkdir()
    cells = [f"{s:.3f}" for s in np.arange(int(150 * RATE)) / RATE]
    _write(folder / "a.csv", cells, _values(150.0, seed=4))
    late = _restarted(folder / "b.csv", start=150.0)
    assert main(["export", str(folder), "--out", str(tmp_path / "o.csv")]) == 0
    err = capsys.readouterr().err
    assert f"reading stopped: {late}: the time column 'time' steps back by 2.5 min" in err
    rows = (tmp_path / "o.csv").read_text().count("\n") - 1
    # a.csv's, and b.csv's of the blocks read before the one of the restart (none here)
    assert 7500 <= rows < 15_000


def test_rows_of_the_start_written_late_are_sorted_in_as_before(tmp_path: Path) -> None:
    """The file's first 4 s written after the next 4 s (a logger's late batch at the start):
    the rows go back to before the first time but not over the times already read: no
    restart, sorted in and said as before."""
    seconds = np.arange(int(20 * RATE)) / RATE
    order = np.concatenate([seconds[200:400], seconds[:200], seconds[400:]])
    path = _write(tmp_path / "late.csv", [f"{s:.3f}" for s in order], _values(20.0))
    got, info = read(path)
    assert info.set_back == ""
    assert np.array_equal(got["s0"][0], np.round(seconds * 1e9).astype(np.int64))
    (note,) = info.errors
    assert note.startswith("the time steps back by 8.0 s at data row 201 ('0.000': ")


def test_a_few_rows_stamped_at_the_start_are_outliers(tmp_path: Path) -> None:
    """Up to 4 rows in a row stamped back at the start (a logger writing 0 for a time it
    lacks): no restart, sorted in and said as before."""
    seconds = 100.0 + np.arange(int(20 * RATE)) / RATE
    seconds[500:504] = 100.0 + np.arange(4) * 3.0  # back to the start, then past it
    path = _write(tmp_path / "zero.csv", [f"{s:.3f}" for s in seconds], _values(20.0))
    _, info = read(path)
    assert info.set_back == ""
    assert info.errors[0].startswith("the time steps back by 10 s at data row 501")


# ------------------------------------------------------------------ the change to winter time


def _fall_back(seconds: float, zone: bool = False, fmt: str = "%Y-%m-%d %H:%M:%S.%f") -> list[str]:
    """Berlin wall-clock times at :data:`RATE` from 02:58 CEST on 2026-10-25: at 03:00 CEST
    the clock goes back to 02:00 CET (with ``zone``, each with its offset)."""
    import datetime as dt

    start = dt.datetime(2026, 10, 25, 0, 58, tzinfo=dt.UTC)
    change = dt.datetime(2026, 10, 25, 1, 0, tzinfo=dt.UTC)
    out = []
    for i in range(int(seconds * RATE)):
        utc = start + dt.timedelta(seconds=i / RATE)
        offset = dt.timedelta(hours=2 if utc < change else 1)
        cell = (utc + offset).strftime(fmt)[:-3]
        out.append(cell + ("+02:00" if offset.seconds == 7200 else "+01:00") * zone)
    return out


def test_local_times_set_back_an_hour_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Before: a note guessing the change to winter time, the rows after it sorted in
    among those before (the fault at 02:01:50 CET moved into the training window: 'no
    sensor fault found'). Now refused in one line that says how to write the times."""
    path = _write(tmp_path / "local.csv", _fall_back(300.0), _values(300.0), header="timestamp")
    _, info = read(path)
    said = (
        "the time column 'timestamp' steps back by 60 min at data row 6001 "
        "('2026-10-25 02:00:00.000': from 2026-10-25T02:59:59.980 to 2026-10-25T02:00:00.000), "
        "in times without a zone: local times set back an hour, as at the change from summer "
        "to winter time? The hour after the step repeats the times of the hour before, which "
        "cannot be told apart; write the times in UTC, or as date-times with their offset "
        "from UTC (such as +02:00 before the change and +01:00 after it)"
    )
    assert info.set_back == said
    for err in _refused(path, tmp_path, capsys):
        assert err == f"analyzer: error: {path}: {said}\n"


def test_times_of_day_set_back_an_hour_are_refused(tmp_path: Path) -> None:
    cells = [c.split(" ")[1] for c in _fall_back(300.0)]
    path = _write(tmp_path / "clock.csv", cells, _values(300.0), header="Time")
    _, info = read(path)
    assert info.set_back.startswith(
        "the time column 'Time' steps back by 60 min at data row 6001 ('02:00:00.000': "
        "from 10799.980 s to 7200.000 s), in times without a zone: local times set back an hour"
    )


def test_the_same_times_with_their_offset_are_read_in_order(tmp_path: Path) -> None:
    path = _write(tmp_path / "zoned.csv", _fall_back(300.0, zone=True), _values(300.0))
    got, info = read(path)
    assert info.set_back == "" and info.errors == []
    assert got["s0"][0].size == 15_000
    assert np.all(np.diff(got["s0"][0]) == 20_000_000)


def test_a_few_local_rows_an_hour_back_are_outliers(tmp_path: Path) -> None:
    """Up to 4 rows in a row an hour back: sorted in and said, as before."""
    cells = _fall_back(100.0)[:4000]  # 02:58:00 to 02:59:19.98 CEST, no change
    cells[3000:3003] = [c.replace("02:59", "01:59") for c in cells[3000:3003]]
    path = _write(tmp_path / "odd.csv", cells, _values(80.0), header="timestamp")
    got, info = read(path)
    assert info.set_back == ""
    assert got["s0"][0].size == 4000
    assert "an hour back in times without a zone" in info.errors[0]


# ------------------------------------------------------------------ a date column and a time column


def test_a_date_column_and_a_time_column_are_one_time(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``Date,Time`` across midnight, a fault at 230 s: before, the date was skipped as
    text without a word, the times relative (``start`` null, no UTC onset)."""
    import datetime as dt

    y = _values(300.0)
    y[:, 2] = inject_fault(y[:, 2], RATE, "additive", 230.0, 4.0 * float(np.std(y[:, 2])))
    start = dt.datetime(2026, 3, 28, 23, 58)
    stamps = [start + dt.timedelta(seconds=i / RATE) for i in range(y.shape[0])]
    cells = [s.strftime("%Y-%m-%d,%H:%M:%S.%f")[:-3] for s in stamps]
    path = _write(tmp_path / "dt.csv", cells, y, header="Date,Time")
    got, info = read(path)
    assert info.time == "columns 'Date' and 'Time' joined: date-times (UTC where no zone is given)"
    assert info.absolute_time and info.errors == []
    assert set(got) == {f"s{i}" for i in range(5)}  # the date is no channel
    first = int(np.datetime64("2026-03-28T23:58:00", "ns").astype(np.int64))
    assert got["s0"][0][0] == first
    assert np.all(np.diff(got["s0"][0]) == 20_000_000)  # midnight crossed in order
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 1
    capsys.readouterr()
    doc = json.loads((out / "findings.json").read_text())
    assert doc["start"] == "2026-03-28T23:58:00.000Z"
    (fault,) = doc["faults"]
    assert fault["onset"] == "2026-03-29T00:01:50.000Z"


def test_german_date_and_time_columns_are_read_day_first(tmp_path: Path) -> None:
    """``Datum;Zeit`` with decimal commas, as a German spreadsheet writes them."""
    y = _values(20.0)
    cells = [
        f"13.03.2026;10:00:{int(i / RATE):02d},{round(i % RATE * 1000 / RATE):03d}"
        for i in range(y.shape[0])
    ]
    y_text = [";".join(f"{v:.6f}".replace(".", ",") for v in row) for row in y]
    path = tmp_path / "de.csv"
    names = ";".join(f"s{i}" for i in range(5))
    rows = [f"{c};{v}" for c, v in zip(cells, y_text, strict=True)]
    path.write_text("\n".join([f"Datum;Zeit;{names}", *rows]) + "\n")
    got, info = read(path)
    assert info.time.startswith("columns 'Datum' and 'Zeit' joined: date-times")
    first = int(np.datetime64("2026-03-13T10:00:00", "ns").astype(np.int64))
    assert got["s0"][0][0] == first and got["s0"][0].size == y.shape[0]
    assert np.all(np.diff(got["s0"][0]) == 20_000_000)


def test_a_date_column_beside_seconds_is_said(tmp_path: Path) -> None:
    """Dates beside relative seconds are not joined (no time of day to join), but said."""
    y = _values(10.0)
    cells = [f"2026-03-29,{i / RATE:.3f}" for i in range(y.shape[0])]
    path = _write(tmp_path / "ds.csv", cells, y, header="Date,time")
    _, info = read(path)
    assert info.time == "column 'time': seconds, relative"
    assert info.errors == [
        "column 'Date' holds dates, not joined with the time column 'time', which holds no "
        "times of day; skipped as text"
    ]


# ------------------------------------------------------------------ the change to summer time


def _spring(zone: bool = False, skip: bool = True) -> list[str]:
    """Berlin wall-clock times at :data:`RATE` from 01:58 CET on 2026-03-29 for 4 min: at
    02:00 CET the clock goes on to 03:00 CEST (``skip`` False: a pause of an hour from
    01:59:30, no whole hour of the clock skipped)."""
    import datetime as dt

    start = dt.datetime(2026, 3, 29, 0, 58, tzinfo=dt.UTC)
    out = []
    for i in range(int(240 * RATE)):
        utc = start + dt.timedelta(seconds=i / RATE)
        summer = utc >= dt.datetime(2026, 3, 29, 1, 0, tzinfo=dt.UTC)
        if skip:
            local = utc + dt.timedelta(hours=2 if summer else 1)
        else:
            late = utc >= dt.datetime(2026, 3, 29, 0, 59, 30, tzinfo=dt.UTC)
            local = utc + dt.timedelta(hours=2 if late else 1)
        cell = local.strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]
        out.append(cell + ("+02:00" if summer else "+01:00") * zone)
    return out


def test_local_times_that_skip_an_hour_are_said(tmp_path: Path) -> None:
    """ux55 item 11: the hour the clock skips was said as a gap of the span only."""
    path = _write(tmp_path / "spring.csv", _spring(), _values(240.0), header="timestamp")
    got, info = read(path)
    assert got["s0"][0].size == 12_000 and info.set_back == ""
    assert info.errors == [
        "the time jumps forward by 60 min at data row 6001 ('2026-03-29 03:00:00.000': "
        "from 2026-03-29T01:59:59.980 to 2026-03-29T03:00:00.000), over a whole hour of the "
        "clock, in times without a zone: local times set forward, as at the change from "
        "winter to summer time? Read as UTC, that hour is a gap and every time said in UTC "
        "is the file's local time; write the times in UTC, or as date-times with their "
        "offset from UTC, for true UTC times"
    ]


@pytest.mark.parametrize(("zone", "skip"), [(True, True), (False, False)])
def test_zoned_times_or_a_pause_off_the_hour_are_not(
    tmp_path: Path, zone: bool, skip: bool
) -> None:
    path = _write(tmp_path / "s.csv", _spring(zone, skip), _values(240.0), header="timestamp")
    _, info = read(path)
    assert info.errors == []

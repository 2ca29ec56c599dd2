"""A sensor that goes silent partway (the ux53 audit, items 1 and 2): its CSV cells blank
from 20 s on, or its topic publishing NaN from then, got "no sensor fault found", exit 0,
with a note only, while the same sensor reading 0 was found as a gain of 0. Now it is a
finding (``other``, ``magnitude.no_data_s``, detector ``silent_check``) from the first
missing sample; a topic whose messages simply stop (a node stopped) is left as before.
Under ``--model``, a column blank in every row is its sensor's finding, not a channel the
archive lacks."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

RATE = 100.0
START = "2026-03-03T14:00:00Z"


def _building(seconds: float = 60.0) -> tuple[np.ndarray, np.ndarray, list[str]]:
    t, y, names = simulate_building(3, seconds, RATE, seed=3, sensors_per_floor=2)
    return (np.round(t * 1e9).astype(np.int64), y, list(names))


def _write(tmp_path, fmt: str, y: np.ndarray, names: list[str], t_ns: np.ndarray) -> str:
    path = tmp_path / f"b.{fmt if fmt == 'csv' else 'mcap'}"
    write_archive(path, fmt, t_ns, {n: y[:, i] for i, n in enumerate(names)}, start_iso=START)
    return str(path)


def _run(path: str, out, *more: str) -> tuple[int, dict]:
    code = main(["run", path, "--out", str(out), "--no-progress", *more])
    return code, json.loads((out / "findings.json").read_text())


@pytest.mark.parametrize("fmt", ["csv", "mcap"])
def test_a_sensor_silent_from_20_s_is_a_finding(tmp_path, fmt):
    """s3 blank (CSV) or NaN (MCAP) from 20 s of 60 s: a finding from 20 s, exit 1."""
    t_ns, y, names = _building()
    y[int(20 * RATE) :, 3] = np.nan
    code, doc = _run(_write(tmp_path, fmt, y, names, t_ns), tmp_path / "out")
    silent = [f for f in doc["faults"] if f["detector"] == "silent_check"]
    assert code == 1
    assert len(silent) == 1 and "s3" in silent[0]["channel"], doc["faults"]
    assert silent[0]["type"] == "other" and silent[0]["end_s"] is None
    assert silent[0]["onset_s"] == pytest.approx(20.0, abs=0.02)
    assert silent[0]["magnitude"]["no_data_s"] == pytest.approx(40.0, abs=0.05)


def test_a_short_silence_at_the_end_is_no_finding(tmp_path):
    """Blank for the last 0.5 s (50 rows, under both the 100 samples and three long
    alarm windows): no silent finding."""
    t_ns, y, names = _building()
    y[-50:, 3] = np.nan
    _, doc = _run(_write(tmp_path, "csv", y, names, t_ns), tmp_path / "out")
    assert not [f for f in doc["faults"] if f["detector"] == "silent_check"]


def test_a_channel_that_stops_publishing_is_no_finding():
    """Samples that stop (no NaN sample, no blank cell: a node stopped) leave no mark of
    silence: the rule gives no finding; the same stretch marked by NaN samples does."""
    from analyzer.readers.base import Format, InputInfo
    from analyzer.silent import silent_findings
    from analyzer.store.store import ChannelInfo

    values = np.ones((6000, 3))
    values[2000:, 2] = np.nan
    ns = int(1e9 / RATE)
    full = [ChannelInfo(n, 6000, 0, 5999 * ns, RATE, 0, 6000, 0.0, 1.0) for n in "ab"]
    stops = ChannelInfo("c", 2000, 0, 1999 * ns, RATE, 0, 2000, 0.0, 1.0)
    nan = ChannelInfo("c", 6000, 0, 5999 * ns, RATE, 0, 2000, 0.0, 1.0)
    csv = InputInfo(Path("x.csv"), Format.CSV, blank_until={"c": 5999 * ns})
    assert silent_findings(values, "abc", RATE, 0, [*full, stops], []) == []
    (f,) = silent_findings(values, "abc", RATE, 0, [*full, nan], [])
    assert (f.channel, f.onset_s, f.magnitude) == ("c", 20.0, {"no_data_s": 40.0})
    assert len(silent_findings(values, "abc", RATE, 0, [*full, stops], [csv])) == 1


def test_model_names_a_blank_column_as_blank(tmp_path, capsys):
    """--model on a file whose s3 column is blank in every row: not "this archive has no
    channel s3" (nor a refusal: its finding, tests/cli/test_model_blank_channel.py)."""
    t_ns, y, names = _building()
    fit = _write(tmp_path, "csv", y, names, t_ns)
    model = tmp_path / "b.model"
    main(["run", fit, "--out", str(tmp_path / "fit"), "--no-progress", "--save-model", str(model)])
    y[:, 3] = np.nan
    (tmp_path / "day").mkdir()
    day = _write(tmp_path / "day", "csv", y, names, t_ns)
    capsys.readouterr()
    code = main(["run", day, "--out", str(tmp_path / "o"), "--no-progress", "--model", str(model)])
    err = capsys.readouterr().err
    assert code == 1
    assert "has no channel" not in err


def test_a_sparse_tables_topic_that_stops_is_no_silence(tmp_path):
    """A sparse table (one topic a row: a, b on even rows, c on odd ones, c's rows stop
    at 20 s of 60 s) has c blank on a and b's rows by its layout: no mark of silence.
    The same c written on every row and blank from 20 s is marked to the last row."""
    from analyzer.readers.csv_reader import CsvReader

    t = np.arange(0, 60, 0.01)
    rows = ["time,a,b,c"]
    for i, x in enumerate(t):
        if i % 2 == 0:
            rows.append(f"{x:.2f},{np.sin(x)},{np.cos(x)},")
        elif x < 20:
            rows.append(f"{x:.2f},,,{np.sin(3 * x)}")
    sparse = tmp_path / "sparse.csv"
    sparse.write_text("\n".join(rows) + "\n")
    reader = CsvReader(sparse)
    for _ in reader.chunks():
        pass
    assert reader.info.blank_until == {}
    dense = tmp_path / "dense.csv"
    lines = [f"{x:.2f},{np.sin(x)},{np.cos(x)},{np.sin(3 * x) if x < 20 else ''}" for x in t]
    dense.write_text("time,a,b,c\n" + "\n".join(lines) + "\n")
    reader = CsvReader(dense)
    for _ in reader.chunks():
        pass
    assert list(reader.info.blank_until) == ["c"]


def test_silent_sensor_reported_where_no_detector_can_run(tmp_path):
    """A 20 s record (too short for the detectors' healthy window) whose s3 is blank
    from 8 s: the silent finding is reported with why the detectors did not run, exit
    1, as the constant check's is."""
    t_ns, y, names = _building(20.0)
    y[int(8 * RATE) :, 3] = np.nan
    code, doc = _run(_write(tmp_path, "csv", y, names, t_ns), tmp_path / "out")
    assert code == 1
    assert [(f["channel"], f["detector"]) for f in doc["faults"]] == [("s3", "silent_check")]


def test_channels_naming_a_blank_column_says_it_is_blank(tmp_path, capsys):
    """--channels naming a column blank in every row: the error says the column is
    there and blank, not that the pattern "matches no channel"; a default run warns of
    it as a sensor without any reading."""
    t_ns, y, names = _building()
    y[:, 3] = np.nan
    path = _write(tmp_path, "csv", y, names, t_ns)
    code = main(["run", path, "--out", str(tmp_path / "o"), "--no-progress", "--channels", "s*,s3"])
    err = capsys.readouterr().err
    assert code == 2
    assert "s3 is in the input but blank in every row" in err and "matches no" not in err
    main(["run", path, "--out", str(tmp_path / "d"), "--no-progress"])
    assert "s3: blank in every row (no reading at all: a dead sensor" in capsys.readouterr().err

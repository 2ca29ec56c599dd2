"""One rule for "is this a Unix time", decided by the reader and taken by every command
(a maintainer's audit, ux61 item H2). A CSV timed from 1980-01-01, a logger whose clock
was never set, was "seconds since 1970 (UTC)" in ``inspect``'s time line but relative
everywhere else: ``inspect --json`` and findings.json gave ``start`` null (the commands
judged the first time again by 1990, the CSV reader by 1973), and its date, the sign of
the unset clock, was said nowhere."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
from cli_helpers import run_cli, run_to

from analyzer.simulate import simulate_building

T1980_S = 315_532_800
"""1980-01-01T00:00:00Z in seconds since 1970, where a logger's unset clock starts (FAT's
and GPS's start)."""


def _csv_from(tmp_path, start_s: int, name: str):
    """Four floors of a building at 200 Hz for 60 s, timed in seconds since 1970 from
    ``start_s`` (as a logger writes them)."""
    t, y, names = simulate_building(n_floors=4, duration_s=60.0, seed=3)
    path = tmp_path / name
    ms = np.round(t * 1000).astype(np.int64)
    frame = pd.DataFrame({"time": [f"{start_s + m // 1000}.{m % 1000:03d}" for m in ms]})
    for j, n in enumerate(names):
        frame[n] = y[:, j]
    frame.to_csv(path, index=False)
    return path


def test_a_1980_record_is_dated_alike_by_inspect_run_and_export(tmp_path, capsys):
    path = _csv_from(tmp_path, T1980_S, "t1980.csv")
    code, out, err = run_cli(["inspect", path, "--json"], capsys)
    assert code == 0, err
    listed = json.loads(out)
    assert listed["start"] == "1980-01-01T00:00:00.000Z"
    assert listed["time_origin_s"] is None
    assert listed["inputs"][0]["time"] == "column 'time': seconds since 1970 (UTC)"
    code, out, err = run_cli(["inspect", path], capsys)
    assert code == 0, err
    assert "start 1980-01-01T00:00:00.000Z" in out.splitlines()
    assert "times in seconds from the first sample" not in out
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--jobs", "1")
    assert code in (0, 1), err
    assert doc["start"] == listed["start"]
    assert doc["time_origin_s"] is None
    exported = tmp_path / "x.csv"
    code, _, err = run_cli(["export", path, "--out", exported, "--utc"], capsys)
    assert code == 0, err
    assert pd.read_csv(exported)["utc"].iloc[0] == "1980-01-01T00:00:00.000Z"


def test_before_the_line_the_commands_agree_on_relative_times(tmp_path, capsys):
    """Seconds from 1972-01-01 (6.3e7 s: a counter, not a date, by the line of 1e8 s)."""
    path = _csv_from(tmp_path, 63_072_000, "t1972.csv")
    code, out, err = run_cli(["inspect", path, "--json"], capsys)
    assert code == 0, err
    listed = json.loads(out)
    assert listed["start"] is None
    assert listed["time_origin_s"] == 63_072_000.0
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--jobs", "1")
    assert code in (0, 1), err
    assert doc["start"] is None
    assert doc["time_origin_s"] == listed["time_origin_s"]


def test_one_named_line_and_the_header_stamps_later_one():
    """The line is one named constant, which the readers' rule uses; the header stamps'
    later line is named apart (its docstring says why)."""
    from analyzer.readers._common import HEADER_EPOCH_NS
    from analyzer.timeutil import EPOCH_LINE_NS, plausible_epoch  # (new: not on the base)

    assert EPOCH_LINE_NS == 10**17  # (1e8 s: 1973-03-03)
    assert plausible_epoch(T1980_S * 10**9) and plausible_epoch(EPOCH_LINE_NS)
    assert not plausible_epoch(EPOCH_LINE_NS - 1)
    assert HEADER_EPOCH_NS > EPOCH_LINE_NS

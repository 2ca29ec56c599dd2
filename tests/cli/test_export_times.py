"""``export`` and ``run --corrected`` keep the record's absolute start, and a successful
export says what it wrote (the ux50 audit: a nav2 bag of 2026-05-08 exported as seconds
from 0 with its start nowhere, the parquet file without metadata, corrected.csv from 0.0
though its input had ISO times; a 1.4 Hz channel exported at 27.6 Hz as 2 625
interpolated values unsaid; ``--rate 1000`` on a 200 Hz file five times the rows unsaid;
a successful export printed nothing)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from cli_helpers import one_line_error, run_cli

import analyzer
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 200.0
START = "2026-03-01T12:00:00Z"
START_NS = int(pd.Timestamp(START).value)


def _building_csv(path: Path, start_iso: str | None = START, fault: bool = False) -> Path:
    """Four floors at 200 Hz for 60 s; ISO times from ``start_iso`` (seconds if None)."""
    t, y, names = simulate_building(n_floors=4, duration_s=60.0, seed=2)
    if fault:
        y[:, 2] = inject_fault(y[:, 2], RATE, "additive", 30.0, 3.0 * np.std(y[:, 2]))
    t_ns = np.round(t * 1e9).astype(np.int64)
    data = {n: y[:, j] for j, n in enumerate(names)}
    write_archive(path, "csv", t_ns, data, start_iso=start_iso)
    return path


@pytest.fixture(scope="module")
def dated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _building_csv(tmp_path_factory.mktemp("in") / "dated.csv")


@pytest.fixture(scope="module")
def relative(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _building_csv(tmp_path_factory.mktemp("in") / "relative.csv", None)


def _last_line(err: str) -> str:
    lines = err.splitlines()
    assert lines, "nothing said on stderr"
    return lines[-1]


# ------------------------------------------------------------------ the absolute start


def test_a_parquet_export_holds_the_start_and_the_rates_as_metadata(dated, tmp_path, capsys):
    out = tmp_path / "x.parquet"
    code, _, err = run_cli(["export", dated, "--out", out], capsys)
    assert code == 0, err
    meta = pq.read_schema(out).metadata
    assert meta is not None
    got = {k.decode(): v.decode() for k, v in meta.items() if k.startswith(b"analyzer.")}
    assert got["analyzer.start_utc"] == "2026-03-01T12:00:00.000Z"
    assert int(got["analyzer.start_ns"]) == START_NS
    assert got["analyzer.absolute_time"] == "true"
    assert float(got["analyzer.rate_hz"]) == pytest.approx(RATE)
    assert int(got["analyzer.rows"]) == 12000
    assert got["analyzer.version"] == analyzer.__version__
    channels = json.loads(got["analyzer.channels"])
    assert [c["name"] for c in channels] == ["s0", "s1", "s2", "s3"]
    assert all(c["samples"] == 12000 and not c["interpolated"] for c in channels)
    assert all(c["rate_hz"] == pytest.approx(RATE) for c in channels)
    # the contract's columns are as they were
    assert list(pd.read_parquet(out).columns) == ["time", "s0", "s1", "s2", "s3"]


def test_relative_times_are_said_in_the_metadata(relative, tmp_path, capsys):
    out = tmp_path / "x.parquet"
    assert run_cli(["export", relative, "--out", out], capsys)[0] == 0
    meta = {k.decode(): v.decode() for k, v in (pq.read_schema(out).metadata or {}).items()}
    assert meta["analyzer.absolute_time"] == "false" and meta["analyzer.start_utc"] == ""
    assert meta["analyzer.start_ns"] == "0"


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_utc_adds_a_last_column_of_each_rows_utc_time(dated, tmp_path, capsys, suffix):
    out = tmp_path / f"x{suffix}"
    code, _, err = run_cli(["export", dated, "--out", out, "--utc", "--rate", "50"], capsys)
    assert code == 0, err
    got = pd.read_csv(out) if suffix == ".csv" else pd.read_parquet(out)
    assert list(got.columns) == ["time", "s0", "s1", "s2", "s3", "utc"]
    assert got.shape[0] == 3000
    if suffix == ".csv":
        assert got["utc"].iloc[0] == "2026-03-01T12:00:00.000Z"
        assert got["utc"].iloc[1] == "2026-03-01T12:00:00.020Z"
    utc = pd.to_datetime(got["utc"], utc=True)
    want = pd.Timestamp(START) + pd.to_timedelta(np.arange(3000) * 20, unit="ms")
    assert (utc.to_numpy() == want.to_numpy()).all()
    np.testing.assert_allclose(got["time"], np.arange(3000) / 50.0, atol=1e-12)


def test_utc_keeps_nanoseconds_where_the_start_has_them(tmp_path, capsys):
    """A ROS log time starts anywhere inside a millisecond: the column is exact to the
    nanosecond there (``...05.123456789Z``), not rounded to a tick of another time."""
    t_ns = 1_778_234_345_123_456_789 + np.arange(400, dtype=np.int64) * 10_000_000
    y = np.sin(np.arange(400) / 7.0)
    path = tmp_path / "n.mcap"
    names = write_archive(path, "mcap", t_ns, {"a": y, "b": np.cos(np.arange(400) / 5.0)})
    out = tmp_path / "n.csv"
    code, _, err = run_cli(["export", path, "--out", out, "--utc"], capsys)
    assert code == 0, err
    got = pd.read_csv(out)
    assert list(got.columns) == ["time", *names.values(), "utc"]
    assert got["utc"].iloc[0] == "2026-05-08T09:59:05.123456789Z"
    assert got["utc"].iloc[3] == "2026-05-08T09:59:05.153456789Z"


def test_utc_is_refused_for_relative_times_before_anything_is_written(relative, tmp_path, capsys):
    out = tmp_path / "new" / "x.csv"
    code, _, err = run_cli(["export", relative, "--out", out, "--utc"], capsys)
    assert code == 2
    one_line_error(err, "--utc: ", str(relative), "relative times", "export without --utc")
    assert not out.parent.exists()


def test_utc_is_refused_beside_a_channel_named_utc(tmp_path, capsys):
    src = tmp_path / "u.csv"
    n = 400
    t = pd.date_range(START, periods=n, freq="10ms").strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    pd.DataFrame({"time": t, "utc": np.sin(np.arange(n)), "b": np.cos(np.arange(n))}).to_csv(
        src, index=False
    )
    code, _, err = run_cli(["export", src, "--out", tmp_path / "x.csv", "--utc"], capsys)
    assert code == 2
    one_line_error(err, "--utc: a channel is named 'utc'", "--channels '!utc'")
    code, _, err = run_cli(
        ["export", src, "--out", tmp_path / "x.csv", "--utc", "--channels", "!utc"], capsys
    )
    assert code == 0, err
    assert list(pd.read_csv(tmp_path / "x.csv").columns) == ["time", "b", "utc"]


# ------------------------------------------------------------------ what it says


def test_a_successful_export_ends_with_one_line(dated, relative, tmp_path, capsys):
    out = tmp_path / "x.csv"
    code, _, err = run_cli(["export", dated, "--out", out], capsys)
    assert code == 0
    assert err == (
        f"analyzer: exported 12000 rows of 4 channels at 200 Hz (60 s, from "
        f"2026-03-01T12:00:00.000Z) to {out}\n"
    )
    code, _, err = run_cli(["export", relative, "--out", out, "--channels", "s1"], capsys)
    assert code == 0
    assert err == (
        f"analyzer: exported 12000 rows of 1 channel at 200 Hz (60 s, relative times, no "
        f"date) to {out}\n"
    )


def _slow_channels_csv(path: Path, slow: int) -> Path:
    """One channel at 100 Hz, ``slow`` varying channels at 5 Hz (a cell every 20th row)
    and a constant one at 5 Hz, with ISO times."""
    n = 2000
    t = pd.date_range(START, periods=n, freq="10ms").strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    cols: dict[str, object] = {"time": t, "fast": np.sin(np.arange(n) / 9.0)}
    every = np.arange(n) % 20 == 0
    for j in range(slow):
        cols[f"slow{j}"] = np.where(every, np.cos(np.arange(n) / (50.0 + j)), np.nan)
    cols["flat"] = np.where(every, 1.0, np.nan)
    pd.DataFrame(cols).to_csv(path, index=False)
    return path


@pytest.mark.parametrize("slow", [1, 6])
def test_channels_exported_at_over_twice_their_rate_are_named(tmp_path, capsys, slow):
    src = _slow_channels_csv(tmp_path / "s.csv", slow)
    out = tmp_path / "x.parquet"
    # (six slow channels outnumber the fast one and would set a 5 Hz clock: --rate 100)
    extra = ["--rate", "100"] if slow > 1 else []
    code, _, err = run_cli(["export", src, "--out", out, *extra], capsys)
    assert code == 0, err
    lines = err.splitlines()
    assert len(lines) == 2 and lines[1].startswith("analyzer: exported 2000 rows of ")
    warning = lines[0]
    assert warning.startswith(f"analyzer: warning: {out}: {slow} channel")
    assert "at more than twice" in warning and "100 Hz clock" in warning
    assert "interpolated" in warning and "fast" not in warning and "flat" not in warning
    if slow == 1:
        assert warning.endswith(": slow0 (5 Hz)")
    else:
        assert warning.endswith(
            ": slow0 (5 Hz), slow1 (5 Hz), slow2 (5 Hz), slow3 (5 Hz) and 2 more"
        )
    meta = json.loads((pq.read_schema(out).metadata or {})[b"analyzer.channels"])
    assert {c["name"] for c in meta if c["interpolated"]} == {f"slow{j}" for j in range(slow)}
    assert {c["name"]: c["samples"] for c in meta}["slow0"] == 100


@pytest.mark.parametrize(("rate", "warned"), [("1000", True), ("300", True), ("200", False)])
def test_a_rate_above_every_channels_own_is_said(dated, tmp_path, capsys, rate, warned):
    out = tmp_path / "x.csv"
    code, _, err = run_cli(["export", dated, "--out", out, "--rate", rate], capsys)
    assert code == 0
    lines = err.splitlines()
    assert lines[-1].startswith("analyzer: exported ") and f" at {rate} Hz " in lines[-1]
    assert len(lines) == (2 if warned else 1), err
    if warned:
        assert lines[0].startswith(
            f"analyzer: warning: {out}: --rate {rate} is above every channel's own rate "
            "(the fastest: 200 Hz): at least "
        )
        assert ("and 4 varying channels are at more than twice" in lines[0]) is (rate == "1000")


# ------------------------------------------------------------------ corrected.csv


def test_corrected_csv_gets_a_utc_column_with_utc(tmp_path, capsys):
    src = _building_csv(tmp_path / "f.csv", fault=True)
    argv = ["run", src, "--corrected", "--no-progress", "--detectors", "ar_kalman_bank"]
    code, _, err = run_cli([*argv, "--out", tmp_path / "plain"], capsys)
    assert code == 1, err
    code, _, err = run_cli([*argv, "--out", tmp_path / "utc", "--utc"], capsys)
    assert code == 1, err
    plain = pd.read_csv(tmp_path / "plain" / "corrected.csv")
    got = pd.read_csv(tmp_path / "utc" / "corrected.csv")
    assert list(plain.columns) == ["time", "s0", "s1", "s2", "s3"]  # its default columns
    assert list(got.columns) == [*plain.columns, "utc"]
    pd.testing.assert_frame_equal(got[plain.columns], plain)
    assert got["utc"].iloc[0] == "2026-03-01T12:00:00.000Z"
    utc = pd.to_datetime(got["utc"], utc=True)
    want = pd.Timestamp(START) + pd.to_timedelta(np.arange(12000) * 5, unit="ms")
    assert (utc.to_numpy() == want.to_numpy()).all()
    start = json.loads((tmp_path / "utc" / "findings.json").read_text())["start"]
    assert start == got["utc"].iloc[0]


def test_run_utc_is_refused_without_corrected_and_for_relative_times(relative, tmp_path, capsys):
    code, _, err = run_cli(["run", relative, "--out", tmp_path / "o", "--utc"], capsys)
    assert code == 2
    one_line_error(err, "--utc: ", "corrected.csv", "give --corrected too")
    code, _, err = run_cli(
        ["run", relative, "--out", tmp_path / "o", "--utc", "--corrected", "--no-progress"],
        capsys,
    )
    assert code == 2
    one_line_error(err, "--utc: the record has relative times", "run without --utc")
    assert not (tmp_path / "o").exists()

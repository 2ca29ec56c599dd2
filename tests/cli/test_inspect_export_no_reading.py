"""``inspect`` and ``export`` read a record as ``run`` does: a sample that is no reading
(NaN, an infinity, a value beyond 1e30, a ``--missing-values`` code) is a gap, dropped as
it is read, counted by channel and said in ``run``'s words (left55, item 1). Before, both
listed such samples as readings: ``inspect`` counted an infinity and a -9999 among a
channel's samples (an MCAP's NaN too) and ``export`` wrote them into the file as values
(``inf``, ``-9999``), and neither accepted ``--missing-values``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_helpers import one_line_error, run_cli, run_to

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

RATE = 100.0
EVERY = 250
START = "2026-01-01T00:00:00Z"
CODE = -9999.0


def _record() -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """Five floors, 60 s at 100 Hz; every 250th sample of s2 an infinity (+ and -), of s3
    the code -9999 and of s4 NaN: the rows returned."""
    t, y, names = simulate_building(n_floors=5, duration_s=60.0, rate_hz=RATE, seed=3)
    t_ns = np.round(t * 1e9).astype(np.int64)
    data = {n: y[:, j].copy() for j, n in enumerate(names)}
    rows = np.arange(0, t_ns.shape[0], EVERY)
    data["s2"][rows] = np.resize([np.inf, -np.inf], rows.shape[0])
    data["s3"][rows] = CODE
    data["s4"][rows] = np.nan
    return t_ns, data, rows


@pytest.fixture(scope="module")
def record() -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    return _record()


def _inspect(path: Path, capsys, *more: str) -> dict:
    code, out, err = run_cli(["inspect", path, "--json", *more], capsys)
    assert code == 0, err
    return json.loads(out)


@pytest.mark.parametrize("fmt", ["csv", "mcap"])
def test_inspect_counts_no_reading_as_gaps_as_run_does(tmp_path: Path, capsys, record, fmt):
    """Each channel's ``samples`` are its readings (the infinities, the codes with
    ``--missing-values`` and the NaN not among them), and the notes count them by
    channel in ``run``'s words; without ``--missing-values`` a code is a reading."""
    t_ns, data, rows = record
    path = tmp_path / f"r.{fmt}"
    write_archive(path, fmt, t_ns, data, start_iso=START)
    name = (lambda c: c) if fmt == "csv" else (lambda c: f"/{c}.data")
    n, k = t_ns.shape[0], rows.shape[0]
    plain = _inspect(path, capsys)  # (a code is a value unless --missing-values names it)
    samples = {c["name"]: c["samples"] for c in plain["channels"]}
    assert (samples[name("s2")], samples[name("s3")], samples[name("s4")]) == (n - k, n, n - k)
    assert not any("missing-value codes" in note for note in plain["notes"])
    assert any(note.endswith(f"taken as gaps: {name('s2')} ({k})") for note in plain["notes"])
    doc = _inspect(path, capsys, "--missing-values", "-9999")
    samples = {c["name"]: c["samples"] for c in doc["channels"]}
    assert samples == {
        name("s0"): n,
        name("s1"): n,
        name("s2"): n - k,
        name("s3"): n - k,
        name("s4"): n - k,
    }, samples
    assert (
        "infinite or absurd values (beyond 1e30: an overrange or error code?) taken as gaps: "
        f"{name('s2')} ({k})" in doc["notes"]
    ), doc["notes"]
    assert (
        f"missing-value codes (-9999, --missing-values) taken as gaps: {name('s3')} ({k})"
        in doc["notes"]
    ), doc["notes"]
    # the table says the same notes
    code, out, err = run_cli(["inspect", path, "--missing-values", "-9999"], capsys)
    assert code == 0, err
    assert f"note: missing-value codes (-9999, --missing-values) taken as gaps: {name('s3')}" in out


def test_inspect_lists_the_samples_run_reads(tmp_path: Path, capsys, record):
    """The samples ``inspect`` lists per channel are those ``run`` reads (findings.json's
    ``channels[].samples``), with the same notes on what was taken as gaps."""
    t_ns, data, _ = record
    path = tmp_path / "r.csv"
    write_archive(path, "csv", t_ns, data, start_iso=START)
    listed = _inspect(path, capsys, "--missing-values", "-9999")
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--missing-values", "-9999")
    assert code in (0, 1), err
    ran = {c["name"]: c["samples"] for c in doc["channels"]}
    assert {c["name"]: c["samples"] for c in listed["channels"]} == ran
    gaps = [n for n in doc["notes"] if "taken as gaps" in n]
    assert gaps and all(g in listed["notes"] for g in gaps), (gaps, listed["notes"])


def test_export_writes_no_infinity_or_code_and_says_how_many(tmp_path: Path, capsys, record):
    """A CSV export with ``--missing-values``: no value in the file is infinite or the
    code; every other value is the reading at its row; stderr counts what was dropped by
    channel before the last line."""
    t_ns, data, rows = record
    path = tmp_path / "r.csv"
    write_archive(path, "csv", t_ns, data, start_iso=START)
    out = tmp_path / "x.csv"
    code, _, err = run_cli(["export", path, "--out", out, "--missing-values", "-9999"], capsys)
    assert code == 0, err
    table = np.genfromtxt(out, delimiter=",", names=True)
    assert table.shape[0] == t_ns.shape[0]
    k = rows.shape[0]
    for c in ("s2", "s3", "s4"):
        col = table[c]
        assert not np.isinf(col).any() and not (col == CODE).any(), c
        other = np.setdiff1d(np.arange(t_ns.shape[0]), rows)
        assert np.allclose(col[other], data[c][other]), c
    lines = err.splitlines()
    assert lines[-1].startswith("analyzer: exported "), err
    assert (
        f"analyzer: warning: {out}: missing-value codes (-9999, --missing-values) taken as "
        f"gaps: s3 ({k})" in lines
    ), err
    assert any(
        line.startswith(f"analyzer: warning: {out}: infinite or absurd values")
        and line.endswith(f"taken as gaps: s2 ({k})")
        for line in lines
    ), err


def test_export_of_an_mcap_writes_no_infinity(tmp_path: Path, capsys, record):
    """A parquet export of an MCAP whose float64 field holds infinities: none in the
    file (a null where no reading is near), the readings as they were."""
    t_ns, data, rows = record
    path = tmp_path / "r.mcap"
    write_archive(path, "mcap", t_ns, data, start_iso=START)
    out = tmp_path / "x.parquet"
    code, _, err = run_cli(["export", path, "--out", out], capsys)
    assert code == 0, err
    table = pq.read_table(out)
    col = table.column("/s2.data").to_numpy(zero_copy_only=False).astype(np.float64)
    assert not np.isinf(col).any()
    other = np.setdiff1d(np.arange(t_ns.shape[0]), rows)
    assert np.allclose(col[other], data["s2"][other])
    assert f"/s2.data ({rows.shape[0]})" in err and "infinite or absurd values" in err, err


def test_export_of_a_record_with_no_reading_says_why(tmp_path: Path, capsys):
    """Every value infinite in one column and the code in the other: export stops with
    ``run``'s line, naming each column and what its values were."""
    path = tmp_path / "dead.csv"
    rows = "".join(f"{i * 0.01:.2f},inf,-9999\n" for i in range(300))
    path.write_text("time,a,b\n" + rows)
    code, _, err = run_cli(
        ["export", path, "--out", tmp_path / "x.csv", "--missing-values", "-9999"], capsys
    )
    assert code == 2, err
    line = one_line_error(err, "no channel has a reading", "a: every one of its 300 values")
    assert "b: every one of its 300 values is a missing-value code" in line, line


@pytest.mark.parametrize("command", ["inspect", "export"])
def test_missing_values_is_an_option_as_runs(capsys, command):
    """``inspect --help`` and ``export --help`` show ``--missing-values`` with ``run``'s
    words."""

    def option_help(cmd: str) -> str:
        with pytest.raises(SystemExit):
            run_cli([cmd, "--help"], capsys)
        text = capsys.readouterr().out
        start = text.index("\n  --missing-values")
        end = text.index("\n  --", start + 1)
        return " ".join(text[start:end].split())

    assert option_help(command) == option_help("run")

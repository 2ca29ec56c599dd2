"""Audit ux55, item 12: an NI LabVIEW ``.lvm`` file (tab-separated text under one or two
headers, ``X_Value`` the time, a trailing ``Comment`` column left blank) had its blank
``Comment`` column called a dead sensor at every run, its header's ``Date`` and
``Time`` (the recording's start) ignored (relative times, no UTC onset), and a file
named ``.lvm`` was refused as an unknown format. The files are written here from the
package's simulated building."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import read

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building

RATE = 20.0
START = "2026-03-29T00:58:00.000Z"
START_NS = int(np.datetime64(START.removesuffix("Z"), "ns").astype(np.int64))


def _lvm(
    path: Path,
    seconds: float = 120.0,
    fault_at: float | None = None,
    clock: str = "00:58:00.0000000000000000",
) -> Path:
    """An ``.lvm`` file as LabVIEW's Write To Measurement File writes it: a file header
    with ``Date`` and ``Time`` (``clock``), a segment header, then ``X_Value``, the
    channels and a blank ``Comment`` column (each row ends with a tab)."""
    t, y, names = simulate_building(3, seconds, RATE, seed=5, f1_hz=1.0)
    if fault_at is not None:
        y[:, 1] = inject_fault(y[:, 1], RATE, "additive", fault_at, 4.0 * float(np.std(y[:, 1])))
    m = len(names)
    head = [
        "LabVIEW Measurement\t",
        "Writer_Version\t2",
        "Reader_Version\t2",
        "Separator\tTab",
        "Decimal_Separator\t.",
        "Multi_Headings\tNo",
        "X_Columns\tOne",
        "Time_Pref\tRelative",
        "Operator\tlab",
        "Date\t2026/03/29",
        f"Time\t{clock}",
        "***End_of_Header***\t",
        "",
        f"Channels\t{m}\t" + "\t" * (m - 1),
        "Samples\t" + "\t".join([str(len(t))] * m),
        "Date\t" + "\t".join(["2026/03/29"] * m),
        "Time\t" + "\t".join([clock] * m),
        "X_Dimension\t" + "\t".join(["Time"] * m),
        "X0\t" + "\t".join(["0.0000000000000000E+0"] * m),
        "Delta_X\t" + "\t".join([f"{1 / RATE:.6f}"] * m),
        "***End_of_Header***\t",
        "X_Value\t" + "\t".join(names) + "\tComment",
    ]
    rows = [
        f"{s:.6f}\t" + "\t".join(f"{v:.6f}" for v in row) + "\t"
        for s, row in zip(t, y, strict=True)
    ]
    path.write_text("\r\n".join(head + rows) + "\r\n")
    return path


def test_the_header_gives_the_start_and_the_comment_column_is_no_channel(tmp_path: Path) -> None:
    got, info = read(_lvm(tmp_path / "bench.lvm"))
    assert sorted(got) == ["s0", "s1", "s2"]
    assert info.absolute_time
    assert int(got["s0"][0][0]) == START_NS
    assert not any("Comment" in e for e in info.errors), info.errors
    assert info.skipped.startswith("'Comment': a column of comments"), info.skipped


@pytest.mark.parametrize(
    ("clock", "utc"),
    [
        ("00:58:00.25", "2026-03-29T00:58:00.250"),
        ("00:58:00.5", "2026-03-29T00:58:00.500"),
        ("00:58:00.2500000000000000", "2026-03-29T00:58:00.250"),
        ("00:58:07.000125", "2026-03-29T00:58:07.000125"),
    ],
)
def test_the_header_times_fraction_of_a_second_is_kept(
    tmp_path: Path, clock: str, utc: str
) -> None:
    """``Time 00:58:00.25`` starts the record a quarter second after 00:58:00, however
    many decimals LabVIEW wrote (test audit ux65 R1: the fraction's digits padded on the
    wrong side read ``.25`` as 25 nanoseconds and nothing caught it, the one fixture's
    fraction being zero)."""
    got, info = read(_lvm(tmp_path / "bench.lvm", seconds=10.0, clock=clock))
    assert info.absolute_time
    first = int(got["s0"][0][0])
    unit = "us" if len(utc) > 23 else "ms"
    assert str(np.datetime64(first, "ns").astype(f"datetime64[{unit}]")) == utc
    assert first == int(np.datetime64(utc, "ns").astype(np.int64))


def test_inspect_says_the_comment_column_once_and_run_not_at_all(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _lvm(tmp_path / "bench.lvm", fault_at=80.0)
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.count("Comment") == 1 and "  skipped: 'Comment'" in out, out
    assert "dead sensor" not in out
    assert f"start {START}" in out
    code = main(
        ["run", str(path), "--train", "0:40", "--out", str(tmp_path / "o"), "--no-progress"]
    )
    err = capsys.readouterr().err
    assert code in (0, 1), err
    assert "Comment" not in err and "dead sensor" not in err, err
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert doc["start"] == START
    (found,) = [f for f in doc["faults"] if f["channel"] == "s1"]
    # the onset's UTC time: the header's start and its seconds
    at = np.datetime64(START_NS + round(found["onset_s"] * 1e9), "ns")
    assert found["onset"] == np.datetime_as_string(at, unit="ms") + "Z", found


def test_a_blank_column_named_otherwise_is_still_a_dead_sensor(tmp_path: Path) -> None:
    """Only a column named as comments is no channel: a blank sensor column is told."""
    path = _lvm(tmp_path / "bench.lvm")
    path.write_bytes(path.read_bytes().replace(b"\tComment\r\n", b"\ts9\r\n", 1))
    _, info = read(path)
    assert info.skipped == ""
    assert any(e.startswith("s9: blank in every row") for e in info.errors), info.errors

"""Counts said as counts: ``1 row``, ``2 rows`` (a new user's audit read "1 rows without
a readable time ... skipped" in stderr and ``inputs[].errors``)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.cli_helpers import one_line_error, run_cli


def test_counted_says_one_and_many():
    from analyzer.errors import counted

    assert counted(1, "row") == "1 row"
    assert counted(2, "row") == "2 rows"
    assert counted(0, "row") == "0 rows"
    assert counted(1, "non-numeric cell") == "1 non-numeric cell"
    assert counted(3, "entry", "entries") == "3 entries"


def _csv(path: Path, bad: list[str]) -> Path:
    rows = ["time,a,b"] + [f"{i * 0.1:.1f},{i % 3},{i % 5}" for i in range(50)]
    for k, line in enumerate(bad):
        rows.insert(20 + 10 * k, line)
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(
    ("bad", "said"),
    [
        (["oops,1,2"], "1 row without a readable time"),
        (["oops,1,2", "1.5,2"], "2 rows without a readable time"),
    ],
)
def test_rows_skipped_are_counted_in_the_right_number(tmp_path, capsys, bad, said):
    path = _csv(tmp_path / "r.csv", bad)
    code, out, _ = run_cli(["inspect", path, "--json"], capsys)
    assert code == 0
    assert json.loads(out)["inputs"][0]["errors"] == [
        f"{said} or with the wrong number of fields skipped"
    ]


def test_a_one_byte_mcap_is_one_byte(tmp_path, capsys):
    path = tmp_path / "one.mcap"
    path.write_bytes(b"\x89")
    code, _, err = run_cli(["inspect", path], capsys)
    assert code == 2
    one_line_error(err, "truncated MCAP file (1 byte, no complete magic)")


def test_one_non_numeric_cell_is_one_cell(tmp_path, capsys):
    rows = ["time,a,b"] + [f"{i * 0.1:.1f},{i % 3},{i % 5}" for i in range(50)]
    rows[10] = "0.9,x,4"
    path = tmp_path / "c.csv"
    path.write_text("\n".join(rows) + "\n")
    code, out, _ = run_cli(["inspect", path, "--json"], capsys)
    assert code == 0
    assert json.loads(out)["inputs"][0]["errors"] == ["a: 1 non-numeric cell treated as gaps"]

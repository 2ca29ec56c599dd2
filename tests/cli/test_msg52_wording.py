"""Wording a new user's audit (ux52) found wrong or unclear in a run's lines."""

from __future__ import annotations

import json

import numpy as np
from cli_helpers import one_line_error, run_cli, said

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive


def _building(tmp_path):
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=1)
    src = tmp_path / "b.csv"
    write_archive(
        src, "csv", np.round(t * 1e9).astype(np.int64), {c: Y[:, j] for j, c in enumerate(names)}
    )
    return src


def test_a_window_over_the_end_only_says_it_leaves_nothing_after_it(tmp_path, capsys):
    """``--train 800:900`` on an 889-s bag was refused as a window that "covers all the
    data": it covers the end only, and what it leaves is nothing after it to search."""
    src = _building(tmp_path)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "a", "--train", "40:100"], capsys)
    assert code == 2
    line = one_line_error(err, "--train", "'40:100'", "ends at 60.000 s", "nothing after it")
    assert "covers all the data" not in line
    code, _, err = run_cli(["run", src, "--out", tmp_path / "b", "--train", "0:100"], capsys)
    assert code == 2
    one_line_error(err, "--train", "covers all the data")


def test_default_detectors_that_did_not_run_are_named_on_stderr(tmp_path, capsys):
    """A run on which the equivalent model ran alone (the others had too little healthy
    data: nav2's ``--train 0:27``, the README's window) said "no sensor fault found" with
    nothing on stderr of the two that did not run; findings.json alone held why."""
    src = _building(tmp_path)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "a", "--train", "0:10"], capsys)
    assert code == 0, err
    doc = json.loads((tmp_path / "a" / "findings.json").read_text())
    assert [d["name"] for d in doc["detectors"]] == ["equivalent_model"]
    lines = [ln for ln in said(err) if "did not run" in ln]
    assert len(lines) == 1, err
    line = lines[0]
    assert line.startswith("analyzer: warning: ar_kalman_bank, detection_filter did not run")
    assert "equivalent_model alone" in line
    assert "too little healthy data" in line  # (the reason findings.json holds)
    assert "give --train 0:" in line  # (what to do)
    assert "error_function" not in line  # (it runs with a config's groups only)
    # the window it gives lets them run, and then nothing is said
    window = line.split("give --train ", 1)[1].split(",", 1)[0]
    code, _, err = run_cli(["run", src, "--out", tmp_path / "b", "--train", window], capsys)
    assert code == 0, err
    assert not [ln for ln in said(err) if "did not run" in ln], err


def test_a_rate_and_a_span_in_a_line_are_written_without_exponents(tmp_path, capsys):
    """``--rate 1e6`` was refused as "the common clock at 1e+06 Hz would need ... rows
    over 59.995 s" (and a span of years as ``4.51335e+08 s``)."""
    src = _building(tmp_path)
    code, _, err = run_cli(["run", src, "--out", tmp_path / "a", "--rate", "1e6"], capsys)
    assert code == 2
    line = one_line_error(err, "the common clock at 1000000 Hz", "over 60 s")
    assert "e+" not in line

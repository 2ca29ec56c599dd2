"""An ISO ``--train`` start a fraction of a second before the data's first sample (the
realdata audit: ``inspect`` prints 09:59:13.383, a user types 09:59:13) was refused;
it is the data's start now, with a note. A start before the data by more than its slack
(1 s, or the minute, hour or day it is written to), or a window wholly before the data,
is refused as before, naming where the data starts."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import one_line_error, run_cli

from analyzer.options import _resolution_s
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

START = "2026-03-01T12:00:13.400Z"


def _csv(path: Path) -> Path:
    """A 3-floor building for 60 s from 12:00:13.400 UTC."""
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=0)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: Y[:, j] for j, n in enumerate(names)}, start_iso=START)
    return path


@pytest.mark.parametrize(
    "start, before",
    [
        ("2026-03-01T12:00:13Z", "0.400"),  # typed to the second
        ("2026-03-01T12:00:13.000Z", "0.400"),  # to the millisecond: 1 s still
        ("2026-03-01T12:00:12.5Z", "0.900"),
        ("2026-03-01T12:00Z", "13.400"),  # to the minute
    ],
)
def test_a_start_just_before_the_data_is_its_start(tmp_path, capsys, start, before):
    out = tmp_path / "o"
    train = f"{start}:2026-03-01T12:00:28Z"
    code, _, err = run_cli(
        ["run", _csv(tmp_path / "a.csv"), "--out", out, "--train", train], capsys
    )
    assert code in (0, 1), err
    doc = json.loads((out / "findings.json").read_text())
    assert doc["train"]["start_s"] == 0.0
    assert doc["train"]["end_s"] == pytest.approx(14.6, abs=0.01)
    (note,) = [n for n in doc["notes"] if n.startswith("--train:")]
    assert f"starts {before} s before the data's first sample (2026-03-01T12:00:13.400Z)" in note
    assert "it starts at that sample" in note


@pytest.mark.parametrize(
    "train, before",
    [
        ("2026-03-01T12:00:11Z:2026-03-01T12:00:28Z", "2.400"),  # beyond 1 s
        ("2026-03-01T11:59Z:2026-03-01T12:00:28Z", "73.400"),  # beyond its minute
        ("2026-03-01T11:00Z:2026-03-01T11:30Z", "3613.400"),  # wholly before the data
        ("2026-03-01T12:00:13Z:2026-03-01T12:00:13.2Z", "0.400"),  # ends before it too
    ],
)
def test_a_start_further_before_the_data_is_refused(tmp_path, capsys, train, before):
    src = _csv(tmp_path / "a.csv")
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o", "--train", train], capsys)
    assert code == 2
    one_line_error(err, "--train", f"starts {before} s before the data", START)


def test_the_resolution_of_an_iso_start():
    assert _resolution_s("2026-03-01") == 86400.0
    assert _resolution_s("2026-03-01T12") == 3600.0
    assert _resolution_s("2026-03-01T12:00Z") == 60.0
    assert _resolution_s("2026-03-01 12:00:07+02:00") == 1.0
    assert _resolution_s("2026-03-01T12:00:07.25Z") == pytest.approx(0.01)

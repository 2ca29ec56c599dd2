"""What a run killed outright while it put its outputs in place left in ``--out`` is
tidied by the next run (ux66 M2): a SIGKILL right after the first rename left
``.findings.json.earlier-*``, ``.findings.json.XXXXXXXX`` and ``.report.html.earlier-*``,
which every later run left there too. Only names of that pattern are touched."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive


def _csv(path: Path) -> Path:
    t, Y, names = simulate_building(n_floors=3, duration_s=60.0, seed=0)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: Y[:, j] for j, n in enumerate(names)})
    return path


def _aged(path: Path, text: str) -> Path:
    path.write_text(text)
    hour_ago = time.time() - 3600
    os.utime(path, (hour_ago, hour_ago))
    return path


LEFT = [
    ".findings.json.earlier-9161d97646ec",
    ".findings.json.new-qsi71ybk",
    ".report.html.earlier-f9951a711c8a",
    ".corrected.csv.earlier-0123456789ab",
]
"""A killed run's leftovers, as the audit found them (and one of ``--corrected``)."""

THE_USERS = [
    ".findings.json.bak",
    "findings.json.earlier-9161d97646ec",
    ".report.html.old",
    ".report.html.backup01",  # (the shape of mkstemp's eight characters)
]
"""Files of other names beside them: never touched."""


def test_a_later_run_removes_a_killed_runs_leftovers_and_nothing_else(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    src = _csv(tmp_path / "a.csv")
    out = tmp_path / "o"
    code, _, err = run_cli(["run", src, "--out", out, "--no-progress"], capsys)
    assert code in (0, 1), err
    for name in [*LEFT, *THE_USERS]:
        _aged(out / name, name)
    code, _, err = run_cli(["run", src, "--out", out, "--no-progress"], capsys)
    assert code in (0, 1), err
    names = {p.name for p in out.iterdir()}
    assert not names & set(LEFT), sorted(names)
    assert set(THE_USERS) <= names
    assert {"findings.json", "report.html"} <= names
    assert "put back" not in err  # (every place had its file)


def test_an_earlier_file_without_its_place_is_put_back(tmp_path: Path) -> None:
    """A run killed between moving ``findings.json`` aside (a file system without hard
    links renames it) and renaming the new one in: the earlier file is put back, the
    newest if there are several, and said so."""
    from analyzer.outdir import tidy_leftovers

    place = tmp_path / "findings.json"
    older = _aged(tmp_path / ".findings.json.earlier-000000000001", "older")
    time.sleep(0.05)
    newer = _aged(tmp_path / ".findings.json.earlier-000000000002", "newer")
    temporary = _aged(tmp_path / ".findings.json.new-k2j4h5g6", "half written")
    said = tidy_leftovers([place], time.time())
    assert place.read_text() == "newer"
    assert not older.exists() and not newer.exists() and not temporary.exists()
    assert len(said) == 1 and said[0].startswith(f"{place}: put back from {newer.name}")


def test_this_runs_own_and_newer_files_are_left(tmp_path: Path) -> None:
    """A temporary file of the run itself, or one made after the run began, is not a
    leftover."""
    from analyzer.outdir import tidy_leftovers

    place = tmp_path / "report.html"
    since = time.time() - 60
    own = _aged(tmp_path / ".report.html.new-abcdefgh", "this run's")
    fresh = tmp_path / ".report.html.earlier-00000000000f"
    fresh.write_text("made after the run began")
    assert tidy_leftovers([place], since, {own}) == []
    assert own.exists() and fresh.exists() and not place.exists()

"""The elements of a long array (more than 64 numbers in one field of a message: a laser
scan's beams) are left out of the default channels, with a note repeated on stderr, and
vote for the common clock as one channel (ux58 #2: a 360-beam /scan at 10 Hz set a robot
bag's clock to 10 Hz, the run was refused, and with --rate 200 a beam was found faulty)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli, said

from analyzer.writers import write_archive

BEAMS = 100
FAST = 4


def _robot(tmp_path: Path, seconds: float = 60.0) -> list[Path]:
    """Two MCAP files by the project's writer: ``/data`` (a ``Float64MultiArray`` of
    :data:`BEAMS` elements at 10 Hz, noise about 2 m: a scan's beams) and ``/s0``..``/s3``
    at 200 Hz (one shared signal plus noise each: sensors of one structure)."""
    rng = np.random.default_rng(5)
    slow = np.arange(int(seconds * 10), dtype=np.int64) * 100_000_000 + 10**18
    scan = {f"b{k}": 2.0 + 0.01 * rng.standard_normal(slow.size) for k in range(BEAMS)}
    fast = np.arange(int(seconds * 200), dtype=np.int64) * 5_000_000 + 10**18
    shared = np.sin(2 * np.pi * 1.3 * fast / 1e9) + 0.3 * np.sin(2 * np.pi * 0.4 * fast / 1e9)
    data = {
        f"s{k}": (1 + k / 4) * shared + 0.05 * rng.standard_normal(fast.size) for k in range(FAST)
    }
    paths = [tmp_path / "scan.mcap", tmp_path / "robot.mcap"]
    write_archive(paths[0], "mcap", slow, scan, layout="multiarray")
    write_archive(paths[1], "mcap", fast, data)
    return paths


def test_inspect_marks_a_long_array_and_keeps_the_fast_clock(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    paths = _robot(tmp_path)
    code, out, _ = run_cli(["inspect", *paths, "--json"], capsys)
    assert code == 0
    doc = json.loads(out)
    beams = [c for c in doc["channels"] if c["name"].startswith("/data.data[")]
    assert len(beams) == BEAMS
    assert all(not c["analyzed"] and c["why"] == "long array" for c in beams)
    assert doc["run_defaults"]["rate_hz"] == 200.0
    assert doc["run_defaults"]["channels"] == FAST
    code, out, _ = run_cli(["inspect", *paths], capsys)
    assert "/data.data[7] [long array]" in out
    assert "[long array] an element of an array field of more than 64 numbers" in out


def test_run_says_so_and_names_them_with_channels(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    paths = _robot(tmp_path)
    code, _, err = run_cli(["run", *paths, "--out", tmp_path / "o", "--jobs", "1"], capsys)
    assert code == 0, err
    (line,) = [ln for ln in said(err) if "/data.data[*]" in ln]
    assert line.startswith(f"analyzer: warning: /data.data[*] ({BEAMS} elements): more than 64")
    assert "--channels naming them analyzes them ('/data.data[*]' names every element" in line
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert doc["rate_hz"] == 200.0
    why = {c["name"]: c.get("why") for c in doc["channels"]}
    assert why["/data.data[0]"] == "long array" and why["/s0.data"] is None


def test_a_long_array_alone_is_analyzed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A record whose varying channels are all one array's elements (a data logger's
    ``Float64MultiArray``) keeps them, as before."""
    scan = _robot(tmp_path)[0]
    code, out, _ = run_cli(["inspect", scan, "--json"], capsys)
    doc = json.loads(out)
    assert doc["run_defaults"]["channels"] == BEAMS
    assert not any(c.get("why") == "long array" for c in doc["channels"])

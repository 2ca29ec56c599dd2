"""The error of a run whose input was cut short names the other inputs cut short, and
counts nothing it does not name (a QA audit, ux56 item 10: a single truncated ROS 1 bag
said "(and 1 more input errors of the kind)", its own "index lies past the end of the
file (truncated?)", the same cut); and a truncated chunk is "the chunk that starts at
byte N", not "the chunk at byte N" (read as "cut at byte N")."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from analyzer.cli import main
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive


def _cut(path: Path, fmt: str, share: float, prefix: str = "") -> Path:
    """A 5-floor building, 60 s at 200 Hz, written as ``fmt`` and cut at ``share`` of
    its bytes (in ``path``'s folder, as ``cut_`` + its name)."""
    t, y, names = simulate_building(n_floors=5, duration_s=60.0, rate_hz=200.0, seed=5)
    cols = {prefix + n: y[:, i] for i, n in enumerate(names)}
    write_archive(path, fmt, np.round(t * 1e9).astype(np.int64), cols)
    data = path.read_bytes()
    cut = path.with_name("cut_" + path.name)
    cut.write_bytes(data[: int(len(data) * share)])
    path.unlink()
    return cut


def _error(args: list[str], capsys) -> str:
    assert main([*args, "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("analyzer: error: ")
    return err


def test_one_truncated_bag_counts_no_other_error(tmp_path, capsys):
    bag = _cut(tmp_path / "r.bag", "ros1bag", 0.5)
    err = _error(["run", str(bag), "--out", str(tmp_path / "o")], capsys)
    assert re.search(
        rf"{re.escape(str(bag))}: truncated inside the uncompressed chunk that "
        r"starts at byte \d+ \(the file ends at byte \d+\): only",
        err,
    )
    assert "more input errors" not in err and "also cut short" not in err


def test_the_other_inputs_cut_short_are_named(tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir()
    bag = _cut(folder / "a.bag", "ros1bag", 0.5)
    mcap = _cut(folder / "b.mcap", "mcap", 0.5, prefix="m")
    err = _error(["run", str(folder), "--out", str(tmp_path / "o")], capsys)
    first, other = (bag, mcap) if err.startswith(f"analyzer: error: {bag}") else (mcap, bag)
    assert err.startswith(f"analyzer: error: {first}: truncated inside the ")
    assert f"(also cut short: {other}): only" in err
    assert "more input errors" not in err


def test_a_cut_mcap_chunk_is_said_to_start_at_its_byte(tmp_path, capsys):
    mcap = _cut(tmp_path / "r.mcap", "mcap", 0.5)
    err = _error(["run", str(mcap), "--out", str(tmp_path / "o")], capsys)
    assert re.search(r"truncated inside the zstd-compressed chunk that starts at byte \d+ ", err)

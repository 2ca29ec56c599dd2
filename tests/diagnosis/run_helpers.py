"""What the end-to-end tests of the diagnosis share: a simulated record written as CSV
and analyzed by ``analyzer run`` with the defaults."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from analyzer.cli import main


def run_csv(
    tmp_path: Path,
    t: np.ndarray,
    y: np.ndarray,
    names: list[str],
    code: int = 1,
    options: tuple[str, ...] = (),
) -> list[dict[str, Any]]:
    """``analyzer run`` on the record (``t`` seconds, ``y`` one column per channel of
    ``names``) written as CSV, with the command-line ``options``: its ``findings.json``
    faults, after checking its exit ``code``."""
    path = tmp_path / "record.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress", *options]) == code
    faults: list[dict[str, Any]] = json.loads((out / "findings.json").read_text())["faults"]
    return faults

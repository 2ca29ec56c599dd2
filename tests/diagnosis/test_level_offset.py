"""An offset on sensors that sit on a large level, end to end (probe finding: reported as
a gain of 1.002 before the classifier left each residual's healthy slope out)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive


@pytest.mark.parametrize("level", [0.0, 1e3])
def test_an_offset_on_a_large_level_is_an_offset(tmp_path, level, capsys):
    rate, seconds = 100.0, 600.0
    t, y, names = simulate_building(4, seconds, rate, seed=2)
    size = float(y[:, 2].std())
    y = y + level
    y[:, 2] = inject_fault(y[:, 2], rate, "additive", 300.0, size)
    path = tmp_path / "level.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 1
    faults = json.loads((out / "findings.json").read_text())["faults"]
    assert [(f["channel"], f["type"]) for f in faults] == [(names[2], "additive")]
    assert faults[0]["magnitude"]["offset"] == pytest.approx(size, rel=0.05)
    assert faults[0]["onset_s"] == pytest.approx(300.0, abs=0.5)

"""An offset on sensors that sit on a large level, end to end (probe finding: reported as
a gain of 1.002 before the classifier left each residual's healthy slope out)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive


@pytest.mark.parametrize(("level", "scale"), [(0.0, 1.0), (1e3, 1.0), (1e3, 3e-7)])
def test_an_offset_on_a_large_level_is_an_offset(tmp_path, level, scale, capsys):
    rate, seconds = 100.0, 600.0
    t, y, names = simulate_building(4, seconds, rate, seed=2)
    size = float(y[:, 2].std())
    y = y + level
    y[:, 2] = inject_fault(y[:, 2], rate, "additive", 300.0, size)
    y, size = y * scale, size * scale  # in other units (a strain in m/m: 3e-7)
    path = tmp_path / "level.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 1
    faults = json.loads((out / "findings.json").read_text())["faults"]
    assert [(f["channel"], f["type"]) for f in faults] == [(names[2], "additive")]
    assert faults[0]["magnitude"]["offset"] == pytest.approx(size, rel=0.05)
    assert faults[0]["onset_s"] == pytest.approx(300.0, abs=0.5)


def test_with_a_model_of_another_archive_the_slope_is_measured_before_the_onset(tmp_path):
    """``--model``: the record has no healthy window of its own (its start is the filters'
    warm-up, where a fault may already be), so each fault's healthy slope is measured on
    the residual before its onset: the offset on the reading at 1000 is an offset there
    too (a gain of 1.002 before)."""
    rate = 100.0
    t, y, names = simulate_building(4, 1200.0, rate, seed=2)
    y = y + 1e3
    t_ns = np.round(t * 1e9).astype(np.int64)
    half = t.shape[0] // 2
    healthy, later = tmp_path / "healthy.csv", tmp_path / "later.csv"
    write_archive(healthy, "csv", t_ns[:half], {n: y[:half, i] for i, n in enumerate(names)})
    size = float(y[:half, 2].std())
    z = y[half:].copy()
    z[:, 2] = inject_fault(z[:, 2], rate, "additive", 300.0, size)
    write_archive(later, "csv", t_ns[:half], {n: z[:, i] for i, n in enumerate(names)})
    model = tmp_path / "m.model"
    assert (
        main(
            [
                "run",
                str(healthy),
                "--out",
                str(tmp_path / "o1"),
                "--save-model",
                str(model),
                "--no-progress",
            ]
        )
        == 0
    )
    out = tmp_path / "o2"
    assert main(["run", str(later), "--out", str(out), "--model", str(model), "--no-progress"]) == 1
    faults = json.loads((out / "findings.json").read_text())["faults"]
    assert [(f["channel"], f["type"]) for f in faults] == [(names[2], "additive")]
    assert faults[0]["magnitude"]["offset"] == pytest.approx(size, rel=0.05)

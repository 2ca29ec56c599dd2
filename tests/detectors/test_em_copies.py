"""A channel logged twice (s6 a copy of s2): the equivalent model made each the other's
assistant, so s2's residual was s2 - s6, zero but for rounding, and a step of 2 sd on s2
at 40 s, a change of ~5e9 noise levels, was typed a drift from 15 s (signal-pathology
probe). A copy is never an assistant now: the step is an offset at 40 s."""

import json

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.simulate import inject_fault, simulate_building


@pytest.mark.parametrize("faulty", [2, 6])
def test_a_step_on_a_sensor_logged_twice_is_an_offset(tmp_path, faulty):
    t, y, names = simulate_building(3, 60.0, 100.0, seed=1, sensors_per_floor=2)
    y = np.column_stack([y, y[:, 2]])
    names = [*names, "s6"]
    size = 2.0 * y[:, 2].std()
    y[:, faulty] = inject_fault(y[:, faulty], 100.0, "additive", 40.0, size)
    path = tmp_path / "b.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) == 1
    doc = json.loads((out / "findings.json").read_text())
    ((channel, kind, onset, offset),) = [
        (f["channel"], f["type"], f["onset_s"], f["magnitude"].get("offset")) for f in doc["faults"]
    ]
    assert (channel, kind) == (f"s{faulty}", "additive")
    assert abs(onset - 40.0) < 0.1 and abs(offset - size) < 0.05 * size
    (em,) = [d for d in doc["detectors"] if d["name"] == "equivalent_model"]
    assistants = em["model"]["network"]["assistants"]
    assert "s6" not in assistants.get("s2", []) and "s2" not in assistants.get("s6", [])

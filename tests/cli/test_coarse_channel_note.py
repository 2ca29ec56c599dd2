"""A healthy sensor quantized to three levels (a step of 4 sd) got findings from the
detection filter with nothing to say it is coarse (signal-pathology probe): a note
names it now. Channels quantized finer than their noise get no note."""

import json

import numpy as np

from analyzer.cli import main
from analyzer.simulate import simulate_building


def _run(tmp_path, step_sd):
    t, y, names = simulate_building(3, 60.0, 100.0, seed=1, sensors_per_floor=2)
    q = step_sd * y[:, 2].std()
    y[:, 2] = np.round(y[:, 2] / q) * q
    path = tmp_path / f"q{step_sd}.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    out = tmp_path / f"o{step_sd}"
    main(["run", str(path), "--out", str(out), "--no-progress", "--detectors", "equivalent_model"])
    return json.loads((out / "findings.json").read_text())["notes"]


def test_a_coarsely_quantized_channel_is_named(tmp_path):
    notes = _run(tmp_path, 4.0)
    assert any(
        n.startswith("at most 4 distinct values in the training window") and n.endswith(": s2")
        for n in notes
    ), notes
    assert not any("distinct values" in n for n in _run(tmp_path, 0.5))

"""A channel much slower than the run's clock (a 1 Hz temperature beside 50 Hz
accelerometers, interpolated 50-fold) is named in one note of ``run``, in export's words
with the factor; export said it and run did not (the ux55 audit, item 13)."""

from __future__ import annotations

import json

import numpy as np

from analyzer.cli import main
from analyzer.simulate import simulate_building


def _two_rates(folder, temp_hz: float) -> None:
    t, y, names = simulate_building(n_floors=3, duration_s=300.0, rate_hz=50.0, seed=1)
    header = "time," + ",".join(names)
    fast = np.column_stack([t, y])
    np.savetxt(folder / "acc.csv", fast, delimiter=",", header=header, comments="", fmt="%.9g")
    ts = np.arange(0.0, 300.0, 1.0 / temp_hz)
    temp = 20.0 + 0.002 * ts + 0.05 * np.sin(ts / 7.0)
    slow = np.column_stack([ts, temp])
    np.savetxt(
        folder / "temp.csv", slow, delimiter=",", header="time,temp1", comments="", fmt="%.9g"
    )


def _notes(tmp_path, temp_hz: float) -> list[str]:
    folder = tmp_path / f"in{temp_hz:g}"
    folder.mkdir()
    _two_rates(folder, temp_hz)
    out = tmp_path / f"out{temp_hz:g}"
    main(["run", str(folder), "--out", str(out), "--no-progress"])
    return json.loads((out / "findings.json").read_text())["notes"]


def test_a_channel_interpolated_50_fold_is_named_in_one_note(tmp_path):
    notes = _notes(tmp_path, 1.0)
    said = [n for n in notes if "interpolated" in n and "temp1" in n]
    assert said == [
        "1 channel analyzed at more than twice its own rate on the 50 Hz clock, the values "
        "between its samples interpolated: temp1 (1 Hz, 50-fold)"
    ], notes


def test_a_channel_at_the_clocks_rate_gets_no_such_note(tmp_path):
    notes = _notes(tmp_path, 50.0)
    assert not [n for n in notes if "own rate on the" in n], notes

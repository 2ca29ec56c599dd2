"""``--rate`` far above every analyzed channel's rate is said on stderr and in the notes
(the realdata audit: a 16.7-Hz bag at --rate 1000 took 15 times as long and gave four
findings the bag at its own rate did not, without a word)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.simulate import simulate_building


@pytest.mark.parametrize(("rate", "noted"), [("100", True), ("40", False), (None, False)])
def test_a_clock_far_above_the_channels_is_noted(tmp_path, capsys, rate, noted):
    t, y, names = simulate_building(n_floors=3, duration_s=300.0, rate_hz=20.0, seed=1)
    path = tmp_path / "r.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    extra = [] if rate is None else ["--rate", rate]
    main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress", *extra])
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    said = [n for n in doc["notes"] if "puts the clock at" in n]
    assert bool(said) is noted, doc["notes"]
    if noted:
        assert said[0].startswith("--rate 100 puts the clock at 5 times the fastest")
        assert "puts the clock at 5 times" in capsys.readouterr().err

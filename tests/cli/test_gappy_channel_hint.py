"""A channel with scattered losses (a fifth of s2's samples, dropped packets) left the
models too few complete stretches, and the run refused with "the training window is
too short ... give a longer one with --train", which left fewer (signal-pathology
probe). It names the channel and how to leave it out now."""

import numpy as np

from analyzer.cli import main
from analyzer.simulate import simulate_building


def test_a_gappy_channel_is_named_when_no_detector_can_run(tmp_path, capsys):
    t, y, names = simulate_building(3, 60.0, 100.0, seed=1, sensors_per_floor=2)
    lost = np.random.default_rng(3).random(t.size) < 0.2
    lost[0] = False  # (a first row with "nan" is another matter)
    y[lost, 2] = np.nan
    path = tmp_path / "b.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    code = main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1
    assert "channels with samples missing in the training window (s2 " in err
    assert "--channels '!s2'" in err and "is too short" not in err

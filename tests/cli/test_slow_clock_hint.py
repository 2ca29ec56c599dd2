"""Real-data audit (nav2_turtlebot.mcap): the 36 entries of /amcl_pose's covariance
matrix, at 1.4 Hz, outvoted the 27 Hz odometry for the common clock, so the refusal's
only advice, a longer --train, could not help."""

from __future__ import annotations

import numpy as np

from analyzer.cli import main
from analyzer.simulate import simulate_building


def _save(path, t, columns, names):
    header = "time," + ",".join(names)
    np.savetxt(
        path, np.column_stack([t, columns]), delimiter=",", header=header, comments="", fmt="%.17g"
    )
    return path


def test_a_slow_common_clock_is_named_when_the_window_is_too_short(tmp_path, capsys):
    """4 channels at 100 Hz, 8 at 5 Hz: the clock runs at 5 Hz, 24 s hold 120 samples."""
    t, y, names = simulate_building(2, 120.0, 100.0, seed=1, sensors_per_floor=2)
    slow = np.full((t.size, 8), np.nan)
    slow[::20] = np.random.default_rng(0).standard_normal((t[::20].size, 8)).cumsum(axis=0)
    path = _save(
        tmp_path / "s.csv", t, np.column_stack([y, slow]), [*names, *(f"c{k}" for k in range(8))]
    )
    assert main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert (
        "or analyze faster channels: the common clock runs at 5 Hz, the rate of 8 of the 12 "
        "channels, while 4 run at up to 100 Hz: --rate 100, or --channels naming them (s0, "
        "s1, s2, ...)"
    ) in err
    # and the advice works
    args = ["run", str(path), "--out", str(tmp_path / "o2"), "--no-progress", "--channels", "s*"]
    assert main(args) in (0, 1)


def test_a_given_rate_is_named_as_such(tmp_path, capsys):
    """Review: with --rate 2 it said "the rate of 0 of the 12 channels" and advised
    --channels naming all of them."""
    t, y, names = simulate_building(2, 120.0, 100.0, seed=1, sensors_per_floor=2)
    path = _save(tmp_path / "r.csv", t, y, names)
    args = ["run", str(path), "--out", str(tmp_path / "o"), "--no-progress", "--rate", "2"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "or a faster clock: --rate is 2 Hz, and 4 of the 4 channels run at up to 100 Hz" in err

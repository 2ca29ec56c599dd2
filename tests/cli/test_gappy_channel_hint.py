"""A channel with scattered losses (a fifth of s2's samples, dropped packets) left the
models too few complete stretches, and the run refused with "the training window is
too short ... give a longer one with --train", which left fewer (signal-pathology
probe). It names the channel and how to leave it out now."""

import json

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


def _gappy(tmp_path):
    """s2 losing 10 samples of every 50 (short stretches between gaps)."""
    t, y, names = simulate_building(3, 60.0, 100.0, seed=1, sensors_per_floor=2)
    y[np.arange(t.size) % 50 >= 40, 2] = np.nan
    path = tmp_path / "b.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header=header, comments="", fmt="%.9g")
    return path


def test_a_named_detector_that_cannot_calibrate_says_it_and_why(tmp_path, capsys):
    """Real-data audit (ROS_example.bag): "0 finite training samples" with 2114 complete
    training rows, and no word of which detector failed: the detection filter's output
    is left out while it settles after each gap, longer than the stretches between."""
    path = _gappy(tmp_path)
    args = ["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]
    assert main([*args, "--detectors", "detection_filter"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "b.csv: detection_filter: too little healthy data to calibrate" in err
    assert "samples of the training residual" in err and "training samples" not in err
    assert "while it settles after a gap" in err and "most gaps there: s2 20 %" in err


def test_the_banks_error_names_it_once(tmp_path, capsys):
    path = _gappy(tmp_path)
    args = ["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"]
    assert main([*args, "--detectors", "ar_kalman_bank"]) == 2
    err = capsys.readouterr().err.strip()
    assert "b.csv: ar_kalman_bank: too little finite training data" in err
    assert err.count("ar_kalman_bank") == 1


def test_skipped_detectors_on_a_gappy_bag_read_once_and_true(tmp_path, realdata):
    """Real-data audit: ROS_example.bag's findings.json and report said
    "ar_kalman_bank: ar_kalman_bank: too little ..." and "0 finite training samples"."""
    out = tmp_path / "o"
    bag = realdata / "ros1" / "evo" / "ROS_example.bag"
    assert main(["run", str(bag), "--out", str(out), "--no-progress"]) in (0, 1)
    skipped = json.loads((out / "findings.json").read_text())["skipped_detectors"]
    reasons = {k: v for k, v in skipped.items() if k.startswith(("ar_kalman", "detection"))}
    assert reasons
    for key, reason in reasons.items():
        assert not reason.startswith(key.split(" (")[0]), reason
        assert "finite training samples" not in reason
    page = (out / "report.html").read_text()
    assert "ar_kalman_bank: ar_kalman_bank" not in page
    assert "while it settles after a gap" in page

"""Small text and JSON items of a new user's audit (ux52, item 17): fourteen alike notes
for the fields of two topics, an estimator named by its index, one-sample channels
called constant or empty, a folder run's title listing its files, times in findings.json
to 15 digits, and a Python list in a ROS 2 bag's error."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
from cli_helpers import one_line_error, run_cli

from analyzer.errors import DetectorError
from analyzer.pipeline import _partial_channels
from analyzer.readers.ros2_reader import _bag_error
from analyzer.regenerate import Correction
from analyzer.report.view import _Access
from analyzer.simulate import simulate_building
from analyzer.writers import write_archive


def test_the_fields_of_a_topic_that_stop_together_are_one_note():
    chosen = ["ORB.x", "ORB.y", "ORB.z", "S.x", "S.y", "gt.x"]
    rate = 10.0
    stops = [[(7404, 8890)]] * 3 + [[(7406, 8890)]] * 2 + [[]]
    topics = {"ORB", "S", "gt"}  # (a bag's: its channels are fields of these topics)
    notes = _partial_channels(stops, chosen, topics, rate, set(chosen), False)
    assert len(notes) == 2, notes
    assert notes[0].startswith(
        "ORB.x, ORB.y, ORB.z (3 channels of ORB) have no reading in their last 148.6 s "
        "(after 740.4 s) of the record: where they are missing"
    )
    assert notes[1].startswith("S.x, S.y (2 channels of S) have no reading in their last")
    # one channel alone: the note as it was
    (one,) = _partial_channels(
        [[(7404, 8890)], []], ["a.x", "b.x"], {"a", "b"}, rate, {"a.x"}, False
    )
    assert one.startswith("a.x has no reading in its last 148.6 s (after 740.4 s) of the record")


def test_an_estimator_is_named_by_its_channel():
    from analyzer.detectors.ar_kalman import _named  # (new: the base has none)

    err = DetectorError("the Kalman estimator without channel 1 is unstable (spectral radius 1.2)")
    named = _named(err, ["/odom.x", "/odom.y"])
    assert str(named) == "the Kalman estimator without /odom.y is unstable (spectral radius 1.2)"


def test_channels_of_one_sample_are_not_called_constant_or_empty(tmp_path, capsys):
    src = tmp_path / "one.mcap"
    write_archive(src, "mcap", np.array([10**9]), {"a": np.array([1.0]), "b": np.array([2.0])})
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o"], capsys)
    assert code == 2
    line = one_line_error(err, "every numeric channel holds one sample")
    assert "constant or empty" not in line


def test_a_folder_run_is_titled_by_its_folder():
    doc = {"inputs": [{"path": f"mix2/part{k}.bag"} for k in range(7)]}
    assert _Access(SimpleNamespace(), doc, None).title() == "Sensor fault audit: mix2 (7 files)"
    doc = {"inputs": [{"path": "a/x.bag"}, {"path": "a/y.mcap"}]}  # (a few: their names)
    assert _Access(SimpleNamespace(), doc, None).title() == "Sensor fault audit: x.bag, y.mcap"


def test_times_in_findings_json_have_four_decimals(tmp_path, capsys):
    t, y, names = simulate_building(n_floors=3, duration_s=120.0, rate_hz=30.0, seed=1)
    src = tmp_path / "b.csv"
    write_archive(
        src, "csv", np.round(t * 1e9).astype(np.int64), {c: y[:, j] for j, c in enumerate(names)}
    )
    code, _, err = run_cli(["run", src, "--out", tmp_path / "o", "--train", "0.5:40"], capsys)
    assert code in (0, 1), err
    train = json.loads((tmp_path / "o" / "findings.json").read_text())["train"]
    for x in train.values():
        assert x == round(x, 4), train
    c = Correction(
        "s0", "ar_kalman_bank", "additive", 300.002537658976, None, "offset", 1, None, None
    )
    assert c.as_dict()["start_s"] == 300.0025


def test_a_ros2_bag_missing_its_database_says_which_without_a_python_list():
    err = Exception("Some database files are missing: ['b2/nodb/rosbag2_test_0.db3']")
    text = _bag_error(err)
    assert "[" not in text and "'" not in text
    assert text.endswith("missing: b2/nodb/rosbag2_test_0.db3")

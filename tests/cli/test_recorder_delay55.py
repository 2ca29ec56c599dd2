"""Log times that jitter against the header stamps, and which time a run used (the
robotics audit ux58 items 3 and 4).

On the real ``rosbag2_test`` the default log time turned a ``/battery`` message logged
16 ms late (of a 40 ms period) into a confident fault that ``--time header`` does not
give, and nothing said so; findings.json and the report did not say which time was
used (a run with ``--time header`` wrote a byte-identical findings.json). Now a run
says where an analyzed topic's log times depart from its header stamps by more than a
quarter of its sample period (stderr, notes, report), a finding whose onset coincides
with such a message carries a ``caution``, and findings.json's ``time_source`` and the
report's Archive section say which time placed the samples."""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_to, said, schema_valid

from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 200.0
ONSET_S = 30.0


def _bag(path: Path, late_ns: int) -> Path:
    """A 4-floor building at 200 Hz, 60 s, an offset on ``s2`` from 30 s, as an MCAP of
    Imu messages whose header stamps tick regularly; the recorder logs each message
    0.3 ms after its stamp, but the one at the onset ``late_ns`` after it."""
    t, y, names = simulate_building(n_floors=4, duration_s=60.0, seed=2)
    y[:, 2] = inject_fault(y[:, 2], RATE, "additive", ONSET_S, 3.0 * np.std(y[:, 2]))
    stamps = 1_780_000_000_000_000_000 + np.round(t * 1e9).astype(np.int64)
    log = stamps + 300_000
    at = int(ONSET_S * RATE)
    log[at] = stamps[at] + late_ns
    write_archive(
        path,
        "mcap",
        log,
        {n: y[:, j] for j, n in enumerate(names)},
        layout="imu",
        header_offset_ns=stamps - log,
    )
    return path


@pytest.fixture(scope="module")
def late(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _bag(tmp_path_factory.mktemp("in") / "late.mcap", 3_300_000)


@pytest.fixture(scope="module")
def steady(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _bag(tmp_path_factory.mktemp("in") / "steady.mcap", 300_000)


def test_a_late_message_at_the_onset_is_said(late, tmp_path, capsys):
    code, err, doc, out = run_to(tmp_path, capsys, late, "--jobs", "1")
    assert code == 1, err
    schema_valid(doc)
    (f,) = doc["faults"]
    assert f["channel"] == "/imu0.linear_acceleration.z"
    assert abs(f["onset_s"] - ONSET_S) < 0.05
    # the topic's jitter: stderr, the notes
    jitter = [ln for ln in said(err) if "log times of /imu0" in ln]
    assert len(jitter) == 1, err
    assert (
        "by up to 3.0 ms against their header stamps (60 % of its 5.0 ms sample period"
        in (jitter[0])
    )
    assert "try --time header" in jitter[0]
    assert any(n.startswith("log times of /imu0") for n in doc["notes"])
    # the finding's caution: findings.json, stderr, the report beside the verdict
    caution = f["caution"]
    assert caution.startswith("/imu0.linear_acceleration.z additive from 30.0")
    assert "a message of /imu0 logged 3.0 ms late (at 30.003 s; 60 % of its sample period)" in (
        caution
    )
    assert "the recorder's delay" in caution and "try --time header" in caution
    assert any(caution in ln for ln in said(err))
    page = html.unescape((out / "report.html").read_text())
    assert caution in page
    assert "Timestamps: log times (when the recorder wrote each message" in page
    assert doc["time_source"] == "log"


def test_steady_log_times_say_nothing_and_header_time_is_named(steady, tmp_path, capsys):
    code, err, doc, _ = run_to(tmp_path, capsys, steady, "--jobs", "1")
    assert code == 1, err
    assert not any("log times of" in n or "recorder's delay" in n for n in doc["notes"])
    assert "caution" not in doc["faults"][0]
    assert doc["time_source"] == "log"
    code, err, doc2, out = run_to(tmp_path / "h", capsys, steady, "--jobs", "1", "--time", "header")
    assert code == 1, err
    schema_valid(doc2)
    assert doc2["time_source"] == "header"
    page = html.unescape((out / "report.html").read_text())
    assert "Timestamps: the header.stamp of each message (--time header" in page
    # the two files differ in the key that says which time was used
    assert {k for k in doc if doc[k] != doc2[k]} >= {"time_source"}


def test_csv_alone_has_no_time_source(tmp_path, capsys):
    t, y, names = simulate_building(n_floors=4, duration_s=60.0, seed=2)
    path = tmp_path / "b.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: y[:, j] for j, n in enumerate(names)}
    )
    code, err, doc, out = run_to(tmp_path, capsys, path, "--jobs", "1")
    assert code == 0, err
    schema_valid(doc)
    assert doc["time_source"] is None
    assert "Timestamps:" not in (out / "report.html").read_text()


def test_rosbag2_test_battery_fault_carries_the_caution(realdata, tmp_path, capsys):
    """The audit's case: ``--train 0:29`` (the window the tool suggests) finds
    ``/battery.voltage other from 54.840 s``; a ``/battery`` message was logged 15 ms
    later than its usual delay at 54.856 s (``--time header`` finds no fault)."""
    bag = realdata / "ros2" / "plotjuggler" / "rosbag2_test"
    code, err, doc, _ = run_to(tmp_path, capsys, bag, "--train", "0:29", "--jobs", "1")
    assert code in (0, 1), err
    assert doc["time_source"] == "log"
    jitter = [ln for ln in said(err) if ln.startswith("analyzer: warning: log times of /battery")]
    assert len(jitter) == 1, err
    assert "by up to 40 ms" in jitter[0] and "(100 % of its 40 ms sample period" in jitter[0]
    battery = [f for f in doc["faults"] if f["channel"].startswith("/battery.")]
    for f in battery:
        if abs(f["onset_s"] - 54.84) < 0.1:
            assert "logged 15 ms late (at 54.856 s" in f["caution"], json.dumps(f)[:300]
    assert any(abs(f["onset_s"] - 54.84) < 0.1 for f in battery), doc["faults"]

"""How far log times depart from the header stamps (:mod:`analyzer.readers.delays`),
measured by every message reader with ``--time log`` (the robotics audit ux58 item 3:
a message of the real ``rosbag2_test``'s ``/battery`` logged 16 ms late became a
confident fault)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, read

from analyzer.readers._common import NO_STAMP
from analyzer.readers.delays import KEPT, LogDelays, TopicDelays
from analyzer.writers import write_archive

RATE = 100.0
N = 3000
LATE_AT = 1700
"""The message logged late (17 s in)."""


def _times(late_ns: int) -> tuple[np.ndarray, np.ndarray]:
    """Regular header stamps at :data:`RATE` and log times 0.4 ms after them, but the
    message at :data:`LATE_AT`, logged ``late_ns`` after its stamp."""
    stamps = T0 + np.round(np.arange(N) * 1e9 / RATE).astype(np.int64)
    log = stamps + 400_000
    log[LATE_AT] = stamps[LATE_AT] + late_ns
    return stamps, log


def test_a_late_message_is_the_largest_departure():
    stamps, log = _times(4_000_000)
    d = LogDelays()
    for s in range(0, N, 700):  # batches, as a reader hands them over
        d.add("/imu", log[s : s + 700], stamps[s : s + 700], int(NO_STAMP))
    got = d.topics["/imu"]
    assert got.measured == N
    assert got.largest_ns == 3_600_000  # 4 ms late against the usual 0.4 ms
    assert got.over(1_000_000) == 1 and got.over(4_000_000) == 0
    k = int(np.argmax(np.abs(got.late_ns)))
    assert int(got.late_log_ns[k]) == int(log[LATE_AT])
    assert got.late_ns.size == KEPT


def test_a_slow_topic_is_measured_against_its_recent_past():
    """One message per batch (a 1 Hz topic among fast ones): its departure is measured
    against the messages before it, not against itself."""
    stamps, log = _times(30_000_000)
    d = LogDelays()
    for s in range(N):
        d.add("/battery", log[s : s + 1], stamps[s : s + 1], int(NO_STAMP))
    assert d.topics["/battery"].largest_ns == 29_600_000


def test_stamps_unset_or_on_another_clock_are_not_measured():
    stamps, log = _times(4_000_000)
    d = LogDelays()
    d.add("/zero", log, np.zeros(N, dtype=np.int64), int(NO_STAMP))
    d.add("/none", log, np.full(N, NO_STAMP, dtype=np.int64), int(NO_STAMP))
    d.add("/sim", log, stamps - T0, int(NO_STAMP))  # a simulation clock from 0
    assert "/zero" not in d.topics and "/none" not in d.topics
    assert d.topics.get("/sim", TopicDelays()).measured == 0


@pytest.mark.parametrize("fmt", ["mcap", "ros1bag", "ros2bag"])
def test_each_reader_measures_its_topics(tmp_path: Path, fmt: str):
    stamps, log = _times(6_000_000)
    rng = np.random.default_rng(5)
    data = {f"s{i}": rng.normal(size=N) for i in range(3)}
    path = tmp_path / {"mcap": "a.mcap", "ros1bag": "a.bag", "ros2bag": "a"}[fmt]
    write_archive(path, fmt, log, data, layout="imu", header_offset_ns=stamps - log)
    _, info = read(path)
    got = info.log_delays["/imu0"]
    assert got.measured == N
    assert got.largest_ns == 5_600_000
    k = int(np.argmax(np.abs(got.late_ns)))
    assert int(got.late_log_ns[k]) == int(log[LATE_AT])


def test_header_time_measures_nothing(tmp_path: Path):
    """With ``--time header`` the samples are at their stamps: nothing to say."""
    from analyzer.readers import open_input

    stamps, log = _times(6_000_000)
    path = tmp_path / "a.mcap"
    write_archive(
        path, "mcap", log, {"s0": np.zeros(N)}, layout="imu", header_offset_ns=stamps - log
    )
    reader = open_input(path)
    for _ in reader.chunks("header"):
        pass
    assert reader.info.log_delays == {}

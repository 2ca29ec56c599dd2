"""``watch`` on an MCAP a logger is still writing into the inbox (rob56 #4): the file
grows in bursts, with pauses longer than ``--settle``, and has its closing magic only
when the logger closes it. It must be held (said once in the log) until complete, never
handed on while the writer writes. A file that holds only the first bytes of the opening
magic (a writer that has just opened it: ``\\x89MCA``) was taken as a complete file of
unknown format, analyzed at once and moved to ``--failed`` under the writer's hands."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from analyzer.watch_inbox import InboxTracker, incomplete_reason
from analyzer.writers import write_archive


def _mcap(path: Path) -> bytes:
    t = np.arange(2000, dtype=np.int64) * 10_000_000
    rng = np.random.default_rng(3)
    write_archive(path, "mcap", t, {"a": rng.normal(size=2000), "b": rng.normal(size=2000)})
    return path.read_bytes()


@pytest.mark.parametrize(
    ("head", "reason"),
    [
        (b"\x89MCA", "MCAP file with only the first 4 of the 8 bytes of its opening magic"),
        (b"#ROSBAG", "ROS 1 bag file with only the first 7 of the 13 bytes of its opening magic"),
        (b"SQLite f", "SQLite file with only the first 8 of the 16 bytes of its opening magic"),
    ],
)
def test_the_first_bytes_of_a_magic_are_no_complete_file(
    tmp_path: Path, head: bytes, reason: str
) -> None:
    path = tmp_path / "x.mcap"
    path.write_bytes(head)
    assert incomplete_reason(path) == f"{reason} (still being written?)"


def test_a_short_file_of_other_bytes_is_left_to_the_analysis(tmp_path: Path) -> None:
    """Bytes that begin no magic: a damaged file, which the analysis reports."""
    path = tmp_path / "x.mcap"
    path.write_bytes(b"\x89MCB")
    assert incomplete_reason(path) is None
    csv = tmp_path / "x.csv"
    csv.write_bytes(b"SQL")  # (a CSV's first bytes are judged as a CSV's)
    assert incomplete_reason(csv) == "a header line only (no data row yet)"


def test_an_mcap_written_in_bursts_is_held_until_it_is_complete(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A writer that opens the file (4 bytes), pauses, writes a third, pauses, another
    third, pauses, and the rest with the closing magic; every pause longer than the
    settle time (a fake clock: ``step(now)``). Nothing is handed on before the last
    burst, the wait is said once, and the whole file is handed on after it."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    data = _mcap(tmp_path / "full.mcap")
    path = inbox / "rec.mcap"
    tracker = InboxTracker(inbox, settle=1.0, incomplete_timeout=600.0)
    now = 0.0
    ends = [4, len(data) // 3, 2 * len(data) // 3]
    with caplog.at_level(logging.WARNING, logger="analyzer.watch"):
        for end in ends:
            path.write_bytes(data[:end])
            tracker.touch("rec.mcap")
            for _ in range(5):  # 5 s of silence per pause, stepped every second
                now += 1.0
                assert tracker.step(now) == []
        assert tracker.pending() == {"rec.mcap"}
        path.write_bytes(data)
        tracker.touch("rec.mcap")
        assert tracker.step(now + 0.5) == []  # (changed: the settle time starts again)
        (ready,) = tracker.step(now + 1.5)
    assert ready.incomplete is None and ready.paths == (path,)
    said = [r.getMessage() for r in caplog.records if "waiting up to" in r.getMessage()]
    assert len(said) == 1 and "rec.mcap" in said[0]

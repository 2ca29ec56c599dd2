"""Readiness of drop-folder archives (:mod:`analyzer.watch_inbox`) and the REPORTS
bookkeeping (:mod:`analyzer.watch_index`), without running the watcher: real files built
with the writers, a fake clock for the tracker."""

from __future__ import annotations

import gzip
import json
import logging
import os
import re
import shutil
import struct
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from analyzer import watch_inbox, watch_index
from analyzer.errors import UsageError
from analyzer.watch_inbox import (
    InboxTracker,
    archive_paths,
    ignored,
    incomplete_reason,
    ros1_index_pos,
    signature,
)
from analyzer.watch_index import (
    Ledger,
    Record,
    ReportsLock,
    Verdict,
    publish,
    report_dirname,
    scratch_dir,
)
from analyzer.writers import write_archive

START = "2026-01-01T00:00:00Z"


def small_archive(path: Path, fmt: str, n: int = 400) -> Path:
    """A few hundred samples of two channels, enough for structure checks."""
    t = np.arange(n, dtype=np.int64) * 10_000_000
    rng = np.random.default_rng(1)
    write_archive(path, fmt, t, {"a": rng.normal(size=n), "b": rng.normal(size=n)}, start_iso=START)
    return path


# --------------------------------------------------------------------------- names


@pytest.mark.parametrize(
    ("name", "skip"),
    [
        (".hidden.mcap", True),
        ("x.mcap.tmp", True),
        ("x.csv.part", True),
        ("x.csv~", True),
        ("mission.bag.active", True),
        ("x.db3-journal", True),
        ("x.csv.filepart", True),  # WinSCP: renamed when the upload is complete
        ("x.mcap.crdownload", True),
        ("x.bag.partial", True),
        ("x.mcap.download", True),
        ("x.csv.swp", True),
        ("X.CSV.TMP", True),  # (a Windows share)
        ("x.mcap.PART", True),
        ("x.mcap", False),
        ("hour_20260101T10.csv.gz", False),
        ("bag_dir", False),
    ],
)
def test_hidden_and_temporary_names_are_ignored(name: str, skip: bool) -> None:
    assert ignored(name) is skip


# --------------------------------------------------------------------------- structure


def test_mcap_needs_magic_at_both_ends(tmp_path: Path) -> None:
    full = small_archive(tmp_path / "full.mcap", "mcap")
    data = full.read_bytes()
    half = tmp_path / "half.mcap"
    half.write_bytes(data[: len(data) // 2])
    assert incomplete_reason(full) is None
    assert incomplete_reason(half) == "MCAP file without its closing magic (still being written?)"
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    assert incomplete_reason(empty) == "empty file"


def test_damaged_file_counts_as_complete_so_the_analysis_reports_it(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap at all" * 100)
    assert incomplete_reason(junk) is None


def _zero_index_pos(data: bytes) -> bytes:
    at = data.index(b"index_pos=") + len(b"index_pos=")
    return data[:at] + b"\0" * 8 + data[at + 8 :]


def test_ros1_bag_needs_its_index(tmp_path: Path) -> None:
    bag = small_archive(tmp_path / "ok.bag", "ros1bag")
    data = bag.read_bytes()
    index_pos = ros1_index_pos(data[:8192])
    assert index_pos is not None and 0 < index_pos < len(data)
    assert incomplete_reason(bag) is None

    recording = tmp_path / "recording.bag"  # what rosbag writes before it closes the bag
    recording.write_bytes(_zero_index_pos(data))
    assert ros1_index_pos(recording.read_bytes()[:8192]) == 0
    assert incomplete_reason(recording) == "ROS 1 bag not indexed yet (index_pos = 0)"

    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[:index_pos])
    assert incomplete_reason(cut) == (
        f"ROS 1 bag ends at byte {index_pos}, before its index at {index_pos}"
    )


def test_ros2_bag_directory_needs_metadata_and_its_storage(tmp_path: Path) -> None:
    src = small_archive(tmp_path / "src_bag", "ros2bag")
    bag = tmp_path / "bag"
    bag.mkdir()
    storage = next(src.glob("*.db3"))
    shutil.copy2(storage, bag / "bag.db3")
    assert incomplete_reason(bag) == "ROS 2 bag without metadata.yaml (still recording?)"
    meta = (src / "metadata.yaml").read_text().replace(storage.name, "bag.db3")
    (bag / "metadata.yaml").write_text(meta)
    assert incomplete_reason(bag) is None
    (bag / "bag.db3-journal").write_bytes(b"")
    assert incomplete_reason(bag) == (
        "bag.db3: sqlite file still open for writing (bag.db3-journal present)"
    )
    (bag / "bag.db3-journal").unlink()
    (bag / "bag.db3").rename(bag / "other.db3")
    assert incomplete_reason(bag) == "storage file bag.db3 listed in metadata.yaml is missing"
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [unterminated")
    assert incomplete_reason(bag) == "metadata.yaml not readable yet"


def test_a_split_not_yet_in_metadata_is_a_recording_under_way(tmp_path: Path) -> None:
    """rosbag2 rewrites metadata.yaml at each split while it writes the next file: a bag
    folder whose metadata.yaml lists ``rec_0.db3`` beside a ``rec_1.db3`` was analyzed
    and, with --done, moved while the recorder was still writing into it (ux58 item 7).
    A split sibling not listed yet holds the folder; a file of another name does not."""
    src = small_archive(tmp_path / "src_bag", "ros2bag")
    storage = next(src.glob("*.db3"))
    bag = tmp_path / "rec2"  # a folder renamed: the stem comes from the listed files too
    bag.mkdir()
    shutil.copy2(storage, bag / "split_imu_0.db3")
    meta = (src / "metadata.yaml").read_text().replace(storage.name, "split_imu_0.db3")
    (bag / "metadata.yaml").write_text(meta)
    assert incomplete_reason(bag) is None
    shutil.copy2(storage, bag / "other.db3")  # another recording's file: the reader's note
    assert incomplete_reason(bag) is None
    shutil.copy2(storage, bag / "split_imu_1.db3")
    assert incomplete_reason(bag) == (
        "storage file split_imu_1.db3 not in metadata.yaml yet (still recording?)"
    )
    (bag / "split_imu_1.db3").rename(bag / "rec2_1.db3")  # named after the folder
    assert incomplete_reason(bag) == (
        "storage file rec2_1.db3 not in metadata.yaml yet (still recording?)"
    )


def test_a_db3_shorter_than_its_header_says_is_unfinished(tmp_path: Path) -> None:
    """A bag copied piecewise (metadata.yaml first, the .db3 with pauses longer than
    --settle) was analyzed half copied ("database disk image is malformed") and, with
    --failed, moved there whole: the sqlite header gives the size of the database."""
    src = small_archive(tmp_path / "src_bag", "ros2bag")
    storage = next(src.glob("*.db3"))
    data = storage.read_bytes()
    pages, page_size = struct.unpack_from(">I", data, 28)[0], struct.unpack_from(">H", data, 16)[0]
    assert pages * page_size == len(data) and len(data) > 3 * 4096
    bag = tmp_path / "bag"
    shutil.copytree(src, bag)
    copied = bag / storage.name
    assert incomplete_reason(bag) is None
    copied.write_bytes(data[:4096])  # the copy's first block
    assert incomplete_reason(bag) == (
        f"{storage.name}: sqlite database unfinished: 4096 of the {len(data)} bytes its "
        "header gives (still being copied?)"
    )
    assert incomplete_reason(copied) == (
        f"sqlite database unfinished: 4096 of the {len(data)} bytes its header gives "
        "(still being copied?)"
    )
    copied.write_bytes(data[:50])
    assert incomplete_reason(copied) == (
        "sqlite database unfinished: 50 bytes, less than its header"
    )
    copied.write_bytes(data + b"\0" * 4096)  # longer: not a copy under way (read as it is)
    assert incomplete_reason(copied) is None
    # a header whose database size is not valid (the change counter at 24 differs from
    # the version-valid-for number at 92: written by an old sqlite) says nothing
    stale = bytearray(data[:4096])
    stale[92:96] = (struct.unpack_from(">I", data, 24)[0] + 1).to_bytes(4, "big")
    copied.write_bytes(bytes(stale))
    assert incomplete_reason(copied) is None


def test_storage_files_listed_with_the_bag_folder_s_name_are_found(tmp_path: Path) -> None:
    """Old rosbag2 versions list ``bag/bag_0.db3`` in the folder ``bag``; the reader
    (as rosbags) opens the file of that name in the folder, the watcher looked for
    ``bag/bag/bag_0.db3`` and waited --wait-unfinished (10 min) for it."""
    src = small_archive(tmp_path / "src_bag", "ros2bag")
    storage = next(src.glob("*.db3"))
    bag = tmp_path / "bag"
    bag.mkdir()
    shutil.copy2(storage, bag / "bag_0.db3")
    meta = (src / "metadata.yaml").read_text().replace(storage.name, "bag/bag_0.db3")
    assert "- bag/bag_0.db3" in meta
    (bag / "metadata.yaml").write_text(meta)
    assert incomplete_reason(bag) is None
    (bag / "bag_0.db3").unlink()
    assert incomplete_reason(bag) == "storage file bag_0.db3 listed in metadata.yaml is missing"


def test_a_real_bag_of_an_old_rosbag2_is_complete(tmp_path: Path, realdata: Path) -> None:
    """PlotJuggler's ``rosbag2_test`` lists ``rosbag2_test/rosbag2_test_0.db3``."""
    from analyzer.readers import open_input

    src = realdata / "ros2" / "plotjuggler" / "rosbag2_test"
    bag = tmp_path / "rosbag2_test"
    bag.mkdir()
    for name in ("metadata.yaml", "rosbag2_test_0.db3"):  # (not the recorder's -wal, -shm)
        shutil.copyfile(src / name, bag / name)
    assert "rosbag2_test/rosbag2_test_0.db3" in (bag / "metadata.yaml").read_text()
    assert incomplete_reason(bag) is None
    assert open_input(bag).info.errors == []


def test_ros2_bag_with_mcap_storage(tmp_path: Path) -> None:
    bag = tmp_path / "mcap_bag"
    t = np.arange(300, dtype=np.int64) * 10_000_000
    from analyzer.writers import write_ros2_bag

    write_ros2_bag(bag, t, {"a": np.sin(t / 1e9)}, storage="mcap")
    assert incomplete_reason(bag) is None
    storage = next(bag.glob("*.mcap"))
    data = storage.read_bytes()
    storage.write_bytes(data[:-100])
    assert incomplete_reason(bag) == (
        f"{storage.name}: MCAP file without its closing magic (still being written?)"
    )


def test_directory_of_files_is_one_archive(tmp_path: Path) -> None:
    folder = tmp_path / "hours"
    folder.mkdir()
    assert incomplete_reason(folder) == "empty directory"
    small_archive(folder / "h1.csv", "csv")
    full = small_archive(tmp_path / "h2.mcap", "mcap")
    (folder / "h2.mcap").write_bytes(full.read_bytes()[:-10])
    assert incomplete_reason(folder) == (
        "h2.mcap: MCAP file without its closing magic (still being written?)"
    )
    shutil.copy2(full, folder / "h2.mcap")
    assert incomplete_reason(folder) is None


def test_a_csv_with_its_header_line_only_is_unfinished(tmp_path: Path) -> None:
    """A CSV logger writes its header line, then its rows; taken as complete with the
    header alone, the file was analyzed ("no data rows") and, with --failed, moved there
    before its rows came. Unfinished until a data row (ended by a newline) is there, as
    an empty file is; a .csv.gz alike (gzip members appended one by one included)."""
    header = "time,a,b\n"
    for text, reason in (
        (header, "a header line only (no data row yet)"),
        ("time,a,b", "a header line only (no data row yet)"),
        (header + "\n", "a header line only (no data row yet)"),
        (header + "0.0,1,2", "a header line only (no data row yet)"),  # a row being written
        (header + "0.0,1,2\n", None),
        (header + "0.0,1,2\n0.01,1", None),
        ("t\tx\n", "a header line only (no data row yet)"),
    ):
        for name in ("log.csv", "log.tsv", "LOG.CSV"):
            (tmp_path / name).write_text(text)
            assert incomplete_reason(tmp_path / name) == reason, (name, text)
        with gzip.open(tmp_path / "log.csv.gz", "wt") as f:
            f.write(text)
        assert incomplete_reason(tmp_path / "log.csv.gz") == reason, text
    with gzip.open(tmp_path / "log.csv.gz", "wt") as f:
        f.write(header)
    with gzip.open(tmp_path / "log.csv.gz", "at") as f:  # a second gzip member
        f.write("0.0,1,2\n")
    assert incomplete_reason(tmp_path / "log.csv.gz") is None
    # a header longer than what is looked at, a damaged .gz: the analysis will say
    (tmp_path / "wide.csv").write_text(",".join(f"channel_{i}" for i in range(20_000)) + "\n")
    assert incomplete_reason(tmp_path / "wide.csv") is None
    (tmp_path / "bad.csv.gz").write_bytes(b"\x1f\x8b\x08\x00" + b"garbage" * 10)
    assert incomplete_reason(tmp_path / "bad.csv.gz") is None
    # other formats are not read as text
    (tmp_path / "notes.txt").write_text(header)
    assert incomplete_reason(tmp_path / "notes.txt") is None


def test_a_header_only_csv_waits_for_its_rows_or_the_timeout(tmp_path: Path) -> None:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    (inbox / "log.csv").write_text("time,a\n")
    (inbox / "dead.csv").write_text("time,a\n")
    tracker = InboxTracker(inbox, settle=1.0, incomplete_timeout=30.0)
    tracker.rescan()
    assert tracker.step(0.0) == [] and tracker.step(2.0) == []
    with (inbox / "log.csv").open("a") as f:
        f.write("0.0,1\n0.01,2\n")
    tracker.touch("log.csv")
    assert tracker.step(2.5) == []
    (rows,) = tracker.step(3.6)
    assert rows.name == "log.csv" and rows.incomplete is None
    assert tracker.step(29.0) == []
    (dead,) = tracker.step(30.0)  # analyzed anyway after --wait-unfinished
    assert dead.name == "dead.csv"
    assert dead.incomplete == "a header line only (no data row yet)"


# --------------------------------------------------------------------------- tracker


def test_tracker_waits_for_settle_and_yields_each_state_once(tmp_path: Path) -> None:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    src = small_archive(tmp_path / "a.mcap", "mcap").read_bytes()
    tracker = InboxTracker(inbox, settle=1.0)
    (inbox / "a.mcap").write_bytes(src[:1000])
    (inbox / ".a.mcap.swp").write_bytes(b"x")
    tracker.rescan()
    assert tracker.step(0.0) == []
    assert tracker.step(0.9) == []  # not settled
    assert tracker.step(1.5) == []  # settled but incomplete
    assert tracker.pending() == {"a.mcap"}
    (inbox / "a.mcap").write_bytes(src)
    tracker.touch("a.mcap")
    assert tracker.step(1.6) == []  # changed: the settle time starts again
    assert tracker.step(2.5) == []
    (ready,) = tracker.step(2.7)
    assert ready.name == "a.mcap" and ready.paths == (inbox / "a.mcap",)
    assert ready.incomplete is None
    assert ready.signature == signature([inbox / "a.mcap"], inbox)
    assert tracker.step(10.0) == []  # yielded once
    assert tracker.done({"a.mcap"})
    other = small_archive(tmp_path / "b.mcap", "mcap", n=500).read_bytes()
    (inbox / "a.mcap").write_bytes(other)  # new content: yielded again once settled
    tracker.touch("a.mcap")
    assert tracker.step(11.0) == []
    (again,) = tracker.step(12.5)
    assert again.name == "a.mcap"
    (inbox / "a.mcap").unlink()
    tracker.touch("a.mcap")
    assert tracker.step(13.0) == [] and tracker.keys == set()


def test_tracker_gives_up_on_an_archive_that_never_completes(tmp_path: Path) -> None:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    (inbox / "dead.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\0" * 100)
    tracker = InboxTracker(inbox, settle=0.5, incomplete_timeout=5.0)
    tracker.rescan()
    assert tracker.step(0.0) == [] and tracker.step(1.0) == [] and tracker.step(4.9) == []
    (ready,) = tracker.step(5.0)
    assert ready.incomplete == "MCAP file without its closing magic (still being written?)"


def test_tracker_groups_by_the_first_regex_group(tmp_path: Path) -> None:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    for name in ("site_20260101T10_a.csv", "site_20260101T10_b.csv", "notes.csv"):
        small_archive(inbox / name, "csv")
    tracker = InboxTracker(
        inbox, settle=0.5, group_by=re.compile(r"(\d{8}T\d{2})"), exclude=frozenset({"out"})
    )
    (inbox / "out").mkdir()
    tracker.rescan()
    assert tracker.keys == {"20260101T10", "notes.csv"}
    tracker.step(0.0)
    small_archive(inbox / "site_20260101T10_c.csv", "csv")  # the group is not quiet yet
    tracker.touch("site_20260101T10_c.csv")
    ready = {r.name: r for r in tracker.step(0.6)}
    assert set(ready) == {"notes.csv"}
    (group,) = tracker.step(1.2)
    assert group.name == "20260101T10"
    assert [p.name for p in group.paths] == [
        "site_20260101T10_a.csv",
        "site_20260101T10_b.csv",
        "site_20260101T10_c.csv",
    ]


# --------------------------------------------------------------------------- REPORTS


def _record(name: str, processed: str, verdict: Verdict = Verdict.NO_FAULT) -> Record:
    return Record(
        name=name,
        sha256="0" * 64,
        verdict=verdict,
        report=f"{report_dirname(name)}/report.html",
        inputs=[f"/inbox/{name}"],
        processed=processed,
        analysis_s=1.0,
        faulty_sensors=["s1"] if verdict is Verdict.FAULT else [],
        faults=1 if verdict is Verdict.FAULT else 0,
    )


def test_ledger_round_trip_and_index_newest_first(tmp_path: Path) -> None:
    ledger = Ledger(tmp_path)
    for name, when, verdict in [
        ("old.csv", "2026-01-01T00:00:00.000Z", Verdict.NO_FAULT),
        ("new <b>.mcap", "2026-01-02T00:00:00.000Z", Verdict.FAULT),
    ]:
        (tmp_path / report_dirname(name)).mkdir()
        ledger.record(_record(name, when, verdict))
    again = Ledger.load(tmp_path)
    assert again.records == ledger.records
    assert ledger.refresh_views(force=True)  # the second record came within the interval
    index = json.loads((tmp_path / "index.json").read_text())
    assert index["schema"] == "analyzer.watch-index/1"
    assert [a["name"] for a in index["archives"]] == ["new <b>.mcap", "old.csv"]
    assert index["counts"] == {"fault": 1, "no fault": 1, "error": 0}
    assert "signature" not in index["archives"][0]
    page = (tmp_path / "index.html").read_text()
    assert '<a href="new%20%3Cb%3E.mcap/report.html">new &lt;b&gt;.mcap</a>' in page
    assert page.index("new &lt;b&gt;.mcap") < page.index("old.csv")


def test_the_index_says_how_a_screened_archive_was_analyzed(tmp_path: Path) -> None:
    """``watch --screen``: each record keeps findings.json's ``screen``, and the index's
    details say whether the screening alone analyzed the archive; a state file written
    before the field existed still loads (no screen)."""
    ledger = Ledger(tmp_path)
    cases = {
        "a.csv": {"detectors": ["equivalent_model"], "fault": False},
        "b.csv": {"detectors": ["equivalent_model"], "fault": True},
        "c.csv": {"detectors": ["equivalent_model"], "fault": None, "error": "no detector"},
        "d.csv": None,
    }
    for k, (name, screen) in enumerate(cases.items()):
        rec = _record(name, f"2026-01-01T0{k}:00:00.000Z")
        rec.screen = screen
        ledger.record(rec)
    ledger.refresh_views(force=True)
    index = json.loads((tmp_path / "index.json").read_text())
    assert {a["name"]: a["screen"] for a in index["archives"]} == cases
    details = {row.name: row.details for row in watch_index.index_view(index).rows}
    assert details["a.csv"] == "report; screened by equivalent_model alone"
    assert details["b.csv"] == "report; flagged by equivalent_model, analyzed by every detector"
    assert "could not screen it" in details["c.csv"]
    assert details["d.csv"] == "report"
    assert "screened by equivalent_model alone" in (tmp_path / "index.html").read_text()
    old = Record.from_json(
        {k: v for k, v in ledger.records["a.csv"].as_json().items() if k != "screen"}
    )
    assert old.screen is None


def test_the_state_is_written_at_every_record_and_the_views_at_most_every_interval(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    clock = [1000.0]
    monkeypatch.setattr(watch_index.time, "monotonic", lambda: clock[0])

    def listed() -> list[str]:
        return [a["name"] for a in json.loads((tmp_path / "index.json").read_text())["archives"]]

    ledger = Ledger(tmp_path)
    ledger.record(_record("a.csv", "2026-01-01T00:00:00.000Z"))
    assert listed() == ["a.csv"]  # the first record: the views at once
    clock[0] += watch_index.VIEW_INTERVAL_S / 2
    ledger.record(_record("b.csv", "2026-01-01T01:00:00.000Z"))
    assert set(Ledger.load(tmp_path).records) == {"a.csv", "b.csv"}  # the state at once
    assert listed() == ["a.csv"]  # the views not yet
    assert not ledger.refresh_views()
    clock[0] += watch_index.VIEW_INTERVAL_S / 2
    assert ledger.refresh_views()  # due
    assert listed() == ["b.csv", "a.csv"]
    assert not ledger.refresh_views(force=True)  # nothing changed since
    ledger.record(_record("c.csv", "2026-01-01T02:00:00.000Z"))
    assert listed() == ["b.csv", "a.csv"]
    assert ledger.refresh_views(force=True)  # what the watcher does when it is idle or stops
    assert listed() == ["c.csv", "b.csv", "a.csv"]


def test_views_that_take_long_to_write_are_written_less_often(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    clock = [1000.0]
    monkeypatch.setattr(watch_index.time, "monotonic", lambda: clock[0])
    render = watch_index.render_index

    def slow_render(index: dict[str, Any]) -> str:
        clock[0] += 1.0  # a page of a year of archives: a second to render, say
        return render(index)

    monkeypatch.setattr(watch_index, "render_index", slow_render)
    ledger = Ledger(tmp_path)
    ledger.record(_record("a.csv", "2026-01-01T00:00:00.000Z"))
    interval = 1.0 / watch_index.VIEW_SHARE
    assert interval > watch_index.VIEW_INTERVAL_S
    clock[0] += interval / 2
    ledger.record(_record("b.csv", "2026-01-01T01:00:00.000Z"))
    assert not ledger.refresh_views()  # past VIEW_INTERVAL_S, not past the grown interval
    clock[0] += interval / 2
    assert ledger.refresh_views()


def test_the_state_file_is_json_with_one_record_per_line(tmp_path: Path) -> None:
    ledger = Ledger(tmp_path)
    ledger.save_state()
    assert json.loads((tmp_path / ".watch-state.json").read_text())["archives"] == {}
    names = ["b.csv", 'quo"te.csv', "a.csv"]
    for name in names:
        ledger.record(_record(name, "2026-01-01T00:00:00.000Z", Verdict.FAULT))
    text = (tmp_path / ".watch-state.json").read_text()
    doc = json.loads(text)
    assert doc["schema"] == "analyzer.watch-state/1"
    assert list(doc["archives"]) == sorted(names)
    assert (
        doc["archives"]['quo"te.csv']
        == _record('quo"te.csv', "2026-01-01T00:00:00.000Z", Verdict.FAULT).as_json()
    )
    assert len(text.splitlines()) == 2 + len(names)
    assert Ledger.load(tmp_path).records == ledger.records


def test_unreadable_state_is_an_error(tmp_path: Path) -> None:
    (tmp_path / ".watch-state.json").write_text("{not json")
    with pytest.raises(UsageError, match=r"unreadable watcher state .* move it away"):
        Ledger.load(tmp_path)
    (tmp_path / ".watch-state.json").write_text('{"schema": "other/9", "archives": {}}')
    with pytest.raises(UsageError, match="schema 'other/9', expected 'analyzer.watch-state/1'"):
        Ledger.load(tmp_path)


def test_tidy_removes_scratch_and_forgets_lost_reports(tmp_path: Path) -> None:
    ledger = Ledger(tmp_path)
    (tmp_path / "kept.csv").mkdir()
    ledger.record(_record("kept.csv", "2026-01-01T00:00:00.000Z"))
    ledger.record(_record("lost.csv", "2026-01-01T00:00:00.000Z"))
    scratch = scratch_dir(tmp_path, "x.csv")
    (scratch / "findings.json").write_text("{}")
    (tmp_path / ".index.json.k2j4l1").write_text("{")  # an interrupted atomic write
    assert ledger.tidy() == ["lost.csv"]
    assert not scratch.exists() and not (tmp_path / ".index.json.k2j4l1").exists()
    assert set(Ledger.load(tmp_path).records) == {"kept.csv"}


def test_publish_replaces_a_report_folder_whole(tmp_path: Path) -> None:
    first = scratch_dir(tmp_path, "a.csv")
    (first / "report.html").write_text("first")
    (first / "findings.json").write_text("{}")
    publish(first, tmp_path, "a.csv")
    second = scratch_dir(tmp_path, "a.csv")
    (second / "error.txt").write_text("broken\n")
    final = publish(second, tmp_path, "a.csv")
    assert final == tmp_path / "a.csv"
    assert sorted(p.name for p in final.iterdir()) == ["error.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]
    assert report_dirname("index.html") == "_index.html"


def test_lock_admits_one_watcher(tmp_path: Path) -> None:
    held = ReportsLock(tmp_path)
    held.acquire()
    with pytest.raises(UsageError, match=r"is in use by another watcher \(pid \d+\)"):
        ReportsLock(tmp_path).acquire()
    held.release()
    with ReportsLock(tmp_path):  # released on exit
        pass


def test_ros1_index_pos_rejects_other_bytes() -> None:
    assert ros1_index_pos(b"\x89MCAP0\r\n") is None
    header = b"index_pos=" + struct.pack("<Q", 4117)
    record = struct.pack("<I", len(header)) + header
    assert ros1_index_pos(b"#ROSBAG V2.0\n" + struct.pack("<I", len(record)) + record) == 4117


# --------------------------------------------------------------------------- generator


def test_ready_batches_falls_back_to_polling_without_events(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    def no_events(*args: object) -> None:
        raise OSError(28, "inotify watch limit reached")

    monkeypatch.setattr(watch_inbox, "_start_observer", no_events)
    monkeypatch.setattr(watch_inbox, "FALLBACK_POLL_S", 0.05)
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    small_archive(inbox / "a.csv", "csv")
    (inbox / "b.csv.tmp").write_text("time,a\n")
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    stop = threading.Event()
    timer = threading.Timer(20.0, stop.set)  # hard limit: the generator ends regardless
    timer.start()
    try:
        batches = list(watch_inbox.ready_batches(inbox, settle=0.1, once=True, stop=stop))
    finally:
        timer.cancel()
    assert not stop.is_set()
    assert [[r.name for r in b] for b in batches] == [["a.csv"]]
    assert (
        "file events unavailable ([Errno 28] inotify watch limit reached); polling every "
        "0.05 s" in caplog.text
    )


def test_ready_batches_sees_events_and_stops(tmp_path: Path) -> None:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    stop = threading.Event()
    limit = threading.Timer(20.0, stop.set)  # hard limit: the generator ends regardless
    drop = threading.Timer(0.3, lambda: small_archive(inbox / "late.csv", "csv"))
    limit.start()
    drop.start()
    seen: list[str] = []
    try:
        for batch in watch_inbox.ready_batches(inbox, settle=0.1, stop=stop):
            seen += [r.name for r in batch]
            stop.set()
    finally:
        limit.cancel()
        drop.join()
    assert seen == ["late.csv"]


@pytest.mark.parametrize("group_by", [None, r"^(.*)_part[0-9]+\.csv$", r"(\d*)"])
def test_archive_paths_lists_an_archive_as_the_tracker_groups_it(
    tmp_path: Path, group_by: str | None
) -> None:
    """:func:`~analyzer.watch_inbox.archive_paths` (which groups only the entries whose
    names hold the archive's) gives, for every archive, what a rescan of INBOX groups
    under its name: names holding another archive's (``A`` in ``AA_part0.csv``),
    hidden, temporary and excluded names, a FIFO, a dangling link, a folder, a name
    that is no UTF-8, an empty group text."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    names = [
        "A_part0.csv", "A_part1.csv", "AA_part0.csv", "A_part2.csv.part", ".A_part3.csv",
        "xA_part0.csv", "A", "A.csv", "_part0.csv", "B_part0.csv", "excluded_part0.csv",
        "12", "x", os.fsdecode(b"caf\xe9_part0.csv"),
    ]  # fmt: skip
    for name in names:
        (inbox / name).write_bytes(b"x")
    (inbox / "A_part4.csv").mkdir()
    (inbox / "A_part5.csv").symlink_to(inbox / "gone")
    os.mkfifo(inbox / "A_part6.csv")
    pattern = None if group_by is None else re.compile(group_by)
    tracker = InboxTracker(inbox, 0.0, pattern, frozenset({"excluded_part0.csv"}), quiet=True)
    tracker.rescan()
    assert tracker.keys
    for key, members in tracker._members.items():
        listed = archive_paths(inbox, key, pattern, {"excluded_part0.csv"})
        assert listed == tuple(inbox / n for n in sorted(members)), key
    assert archive_paths(inbox, "nothing", pattern) == ()

"""A writer that pauses longer than ``--settle`` and then goes on: the archive was taken
as complete too early and analyzed on its first part. The watcher must end with one
record, of the whole content, and ``--done`` must not move the file while the writer
may still be at it (a writer holding its file open writes the rest into the moved file,
whose first part alone was then recorded).

The analyses are a stand-in that writes a small ``findings.json`` at once (forked from
this process, which has the replacement), so that every analysis ends well inside the
hold of ``--done``, however loaded the machine is."""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import test_watch_run
from test_watch_run import Watcher, state, wait_until, write

from analyzer import watch as watch_module
from analyzer.findings import sha256_of
from analyzer.options import RunOptions
from analyzer.watch import WatchSettings
from analyzer.watch_inbox import ReadyArchive, signature
from analyzer.watch_index import Ledger, Record, Verdict

folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server


def _quick_analysis(inputs: list[str], options: RunOptions, out_dir: Path, work: Path) -> int:
    """``analysis_into`` without the analysis: no fault, the duration read from the
    number of rows of the CSV files (so that each version of an archive has its own)."""
    rows = sum(len(Path(p).read_bytes().splitlines()) - 1 for p in _csv_files(inputs))
    (out_dir / "findings.json").write_text(
        json.dumps({"faults": [], "start": None, "duration_s": rows / 100.0, "screen": None})
    )
    (out_dir / "report.html").write_text("<html></html>")
    return 0


def _csv_files(inputs: list[str]) -> list[Path]:
    files: list[Path] = []
    for p in map(Path, inputs):
        files += sorted(p.glob("*.csv")) if p.is_dir() else [p]
    return files


@pytest.fixture
def quick(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    monkeypatch.setattr(watch_module, "analysis_into", _quick_analysis)


def _said(caplog: pytest.LogCaptureFixture, text: str) -> list[str]:
    return [r.getMessage() for r in caplog.records if text in r.getMessage()]


def test_an_archive_that_grew_after_its_analysis_replaces_its_record(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    quick: None,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A file appended to, and a folder whose last file grew and that got another one,
    after their analysis: analyzed again, and the record of the first part is replaced,
    not kept as another archive (``a-1.csv``, ``day-1``: archives that never existed). A
    file of that name with other content is still another archive (kept aside)."""
    inbox, reports = folders
    full = write(tmp_path / "full.csv", "csv", seed=2).read_bytes()
    cut = full.index(b"\n", len(full) // 2) + 1
    csv = inbox / "a.csv"
    csv.write_bytes(full[:cut])
    day = inbox / "day"  # a folder of hourly files: the second hour being written
    day.mkdir()
    write(day / "h0.csv", "csv", seed=3)
    hour = write(tmp_path / "h1.csv", "csv", seed=4).read_bytes()
    (day / "h1.csv").write_bytes(hour[: hour.index(b"\n", len(hour) // 2) + 1])
    rsync = day / ".h2.csv.Xq81Zb"  # (rsync's temporary name, renamed when complete)
    write(rsync, "csv", seed=5)
    w = start_watcher(WatchSettings(inbox, reports, settle=0.3, poll=0.1))
    wait_until(lambda: {"a.csv", "day"} <= state(reports).keys(), "the first analyses")
    with csv.open("ab") as f:
        f.write(full[cut:])
    (day / "h1.csv").write_bytes(hour)
    rsync.rename(day / "h2.csv")
    wait_until(
        lambda: (
            state(reports).get("a.csv", {}).get("sha256") == sha256_of(csv)
            and [s[0] for s in state(reports).get("day", {}).get("signature", []) if "h2" in s[0]]
            == ["day/h2.csv"]
        ),
        "the grown archives to be analyzed again",
    )
    assert set(state(reports)) == {"a.csv", "day"}
    assert _said(caplog, "a.csv: grew since its last analysis")
    assert _said(caplog, "day: grew since its last analysis")
    assert not _said(caplog, "the earlier one's result is kept as")

    # other content under the name (not the earlier one grown): another archive
    other = write(tmp_path / "other.csv", "csv", seed=6).read_bytes()
    csv.write_bytes(other)
    wait_until(lambda: "a-1.csv" in state(reports), "the earlier content to be kept aside")
    wait_until(
        lambda: state(reports).get("a.csv", {}).get("sha256") == sha256_of(csv),
        "the new content's record",
    )
    assert state(reports)["a-1.csv"]["sha256"] == sha256_of(tmp_path / "full.csv")
    w.stop.set()
    assert w.join() == 0


def test_done_waits_for_a_paused_writer_before_moving(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    quick: None,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A writer holding its file open pauses longer than --settle, and goes on right after
    the first part's analysis: the file is not moved meanwhile, it is analyzed again
    whole, and what --done receives is what was recorded (``--once`` included: it waits
    for the hold before it ends)."""
    inbox, reports = folders
    done = tmp_path / "done"
    full = write(tmp_path / "full.csv", "csv", seed=2).read_bytes()
    cut = full.index(b"\n", len(full) // 2) + 1
    f = (inbox / "a.csv").open("wb")
    f.write(full[:cut])
    f.flush()
    settings = WatchSettings(inbox, reports, settle=0.5, poll=0.1, done=done, once=True)
    w = start_watcher(settings)

    def writer() -> None:
        try:
            wait_until(lambda: "a.csv" in state(reports), "the first part's record")
            f.write(full[cut:])  # (through the open file, wherever it now is)
        finally:
            f.close()

    thread = threading.Thread(target=writer, daemon=True)
    thread.start()
    assert w.join() == 0
    thread.join(5)
    assert not (inbox / "a.csv").exists() and (done / "a.csv").read_bytes() == full
    record = state(reports)["a.csv"]
    assert record["sha256"] == sha256_of(done / "a.csv")
    assert record["moved_to"] == [str(done / "a.csv")]
    assert set(state(reports)) == {"a.csv"}
    assert _said(caplog, "a.csv: grew since its last analysis")


def test_a_folder_whose_file_was_replaced_by_a_larger_one_is_another_archive(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    quick: None,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A folder whose file was replaced by another recording, longer (so larger and
    newer: size and mtime alone read it as grown): other content under the name, so
    the earlier record and report are kept aside (``site-1``), as for a single file;
    only a file that begins with its earlier content grew."""
    inbox, reports = folders
    site = inbox / "site"
    site.mkdir()
    write(site / "data.csv", "csv", seed=3)
    w = start_watcher(WatchSettings(inbox, reports, settle=0.3, poll=0.1))
    wait_until(lambda: "site" in state(reports), "the first analysis")
    first = state(reports)["site"]["sha256"]
    write(site / "data.csv", "csv", seed=4, seconds=80.0)  # (another day's, twice as long)
    wait_until(lambda: "site-1" in state(reports), "the earlier result to be kept aside")
    wait_until(
        lambda: state(reports).get("site", {}).get("sha256") not in (None, first),
        "the new content's record",
    )
    assert state(reports)["site-1"]["sha256"] == first
    assert (reports / "site-1" / "report.html").is_file()
    assert not _said(caplog, "site: grew since its last analysis")
    w.stop.set()
    assert w.join() == 0


def test_the_beginning_of_a_grown_file_is_hashed_in_the_same_read(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    quick: None,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The hash of a grown file's earlier part is taken in the read that hashes the
    whole file (on the watcher's loop: a multi-GB file was read twice), not by reading
    its beginning again."""
    inbox, reports = folders
    full = write(tmp_path / "full.csv", "csv", seed=2).read_bytes()
    cut = full.index(b"\n", len(full) // 2) + 1
    csv = inbox / "a.csv"
    csv.write_bytes(full[:cut])
    reread: list[Path] = []

    def head(path: Path, size: int) -> str:
        reread.append(path)
        raise OSError(f"{path}: read again")

    monkeypatch.setattr(watch_module, "_sha256_head", head)
    w = start_watcher(WatchSettings(inbox, reports, settle=0.3, poll=0.1))
    wait_until(lambda: "a.csv" in state(reports), "the first analysis")
    with csv.open("ab") as f:
        f.write(full[cut:])
    wait_until(
        lambda: state(reports).get("a.csv", {}).get("sha256") == sha256_of(csv),
        "the grown file to be analyzed again",
    )
    assert set(state(reports)) == {"a.csv"} and reread == []
    w.stop.set()
    assert w.join() == 0


@pytest.mark.parametrize("layout", ["file", "folder", "group"])
def test_archive_hashes_are_those_recorded_before(tmp_path: Path, layout: str) -> None:
    """:func:`~analyzer.watch.hash_archive` gives the archive's sha256 as the records of
    earlier watchers hold it (a file's own, a folder's ``sha256_of``, a group's named
    lines: else every archive would be analyzed again after an upgrade); of a single
    file the beginning asked for (none when it is shorter), of a folder's or group's
    files their marks: the hash of their first and last 64 KiB."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    if layout == "folder":
        (inbox / "day").mkdir()
        paths = [inbox / "day"]
        files = [write(inbox / "day" / f"h{i}.csv", "csv", seed=i) for i in range(2)]
        expected = sha256_of(inbox / "day")
    else:
        files = paths = [write(inbox / f"A_part{i}.csv", "csv", seed=i) for i in range(2)]
        lines = "".join(f"{p.name}\0{sha256_of(p)}\n" for p in paths)
        expected = hashlib.sha256(lines.encode()).hexdigest()
        if layout == "file":
            files = paths = paths[:1]
            expected = sha256_of(paths[0])
    got = watch_module.hash_archive(paths, inbox, 1000)
    assert got.sha256 == expected
    data = files[0].read_bytes()
    if layout == "file":
        assert got.heads == {"A_part0.csv": hashlib.sha256(data[:1000]).hexdigest()}
        assert got.marks == {}
        assert watch_module.hash_archive(paths, inbox, len(data) + 1).heads == {}
        return
    rel = [f.relative_to(inbox).as_posix() for f in files]
    ends = data[: 1 << 16] + data[-(1 << 16) :]
    assert len(data) > 1 << 17 and got.heads == {}
    assert got.marks == {
        r: watch_module.file_mark(f, f.stat().st_size) for r, f in zip(rel, files, strict=True)
    }
    assert got.marks[rel[0]] == hashlib.sha256(ends).hexdigest()


def test_a_file_mark_is_of_the_ends_of_its_earlier_size(tmp_path: Path) -> None:
    """A file that grew has the mark of its earlier size at that size; another content
    as long or longer does not, even with the same first bytes (a CSV header)."""
    path = tmp_path / "h1.csv"
    rng = np.random.default_rng(0)
    first = b"time,a,b\n" + rng.bytes(300_000)
    path.write_bytes(first)
    mark = watch_module.file_mark(path, len(first))
    path.write_bytes(first + rng.bytes(50_000))
    assert watch_module.file_mark(path, len(first)) == mark
    path.write_bytes(first[:-10] + rng.bytes(60_000))
    assert watch_module.file_mark(path, len(first)) != mark
    small = b"time,a\n1,2\n"
    path.write_bytes(small)
    assert watch_module.file_mark(path, len(small)) == hashlib.sha256(small).hexdigest()


def test_a_move_not_written_to_the_state_is_written_at_the_stop(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    quick: None,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """REPORTS full when a move by --done is recorded, and no other record after it
    before the watcher stops: the state file holds the move once written at the stop
    (it was lost: the next start read the archive as never moved out of INBOX)."""
    from analyzer.watch_index import Ledger

    inbox, reports = folders
    done = tmp_path / "done"
    write(inbox / "a.csv", "csv", seed=2)
    save = Ledger.save_state
    failed: list[bool] = []

    def full_once(self: Ledger) -> None:
        if not failed and any(r.moved_to for r in self.records.values()):
            failed.append(True)
            raise OSError(28, "No space left on device", str(self.path))
        save(self)

    monkeypatch.setattr(Ledger, "save_state", full_once)
    w = start_watcher(WatchSettings(inbox, reports, settle=0.3, poll=0.1, done=done))
    wait_until(lambda: failed and (done / "a.csv").is_file(), "the move")
    assert state(reports)["a.csv"]["moved_to"] == []
    w.stop.set()
    assert w.join() == 0
    assert state(reports)["a.csv"]["moved_to"] == [str(done / "a.csv")]


def test_a_bag_folder_whose_metadata_was_rewritten_as_it_grew_grew(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    quick: None,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A ROS 2 bag folder being recorded: its ``metadata.yaml`` is rewritten (other first
    bytes, longer) as the storage grows, so no mark of it can match; a file its writer
    rewrites in place is judged by size and mtime (the bag grew, one record), while its
    storage that grew by appending keeps its mark."""
    inbox, reports = folders
    bag = inbox / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  message_count: 9\n")
    full = write(tmp_path / "full.csv", "csv", seed=2).read_bytes()
    cut = full.index(b"\n", len(full) // 2) + 1
    (bag / "bag_0.csv").write_bytes(full[:cut])
    # (not a bag the tracker can read as complete: analyzed once it gives up waiting)
    settings = WatchSettings(inbox, reports, settle=0.3, poll=0.1, incomplete_timeout=0.6)
    w = start_watcher(settings)
    wait_until(lambda: "bag" in state(reports), "the first analysis")
    first = state(reports)["bag"]["sha256"]
    with (bag / "bag_0.csv").open("ab") as f:
        f.write(full[cut:])
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information:\n  message_count: 1800\n")
    wait_until(
        lambda: state(reports).get("bag", {}).get("sha256") not in (None, first),
        "the grown bag's record",
    )
    assert set(state(reports)) == {"bag"}
    assert _said(caplog, "bag: grew since its last analysis")
    w.stop.set()
    assert w.join() == 0


def test_a_hash_taken_against_an_earlier_record_is_not_reused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A file's hashes (with the beginning of its record's size) are kept for its start,
    but not once another record of it replaced that one (an analysis ended while the
    hasher thread was answering the tracker): :meth:`_grew` would be given the beginning
    of the earlier record's size, and keep the grown file aside as new content."""
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    inbox, reports = tmp_path / "inbox", tmp_path / "out"
    inbox.mkdir()
    reports.mkdir()
    data = write(tmp_path / "full.csv", "csv", seed=2).read_bytes()
    csv = inbox / "a.csv"
    csv.write_bytes(data)

    def record(size: int) -> Record:
        return Record(
            name="a.csv",
            sha256=hashlib.sha256(data[:size]).hexdigest(),
            verdict=Verdict.NO_FAULT,
            report="a.csv/report.html",
            inputs=[str(csv)],
            processed="2026-01-01T00:00:00Z",
            analysis_s=1.0,
            signature=[["a.csv", size, 0]],
        )

    ledger = Ledger(reports)
    ledger.records["a.csv"] = record(len(data) // 4)
    runner = watch_module._Runner(
        WatchSettings(inbox, reports), RunOptions(), ledger, threading.Event()
    )
    archive = ReadyArchive("a.csv", (csv,), signature([csv], inbox))
    assert runner._hashes(archive).heads == {"a.csv": record(len(data) // 4).sha256}
    ledger.records["a.csv"] = record(len(data) // 2)
    assert runner._hashes(archive).heads == {"a.csv": record(len(data) // 2).sha256}

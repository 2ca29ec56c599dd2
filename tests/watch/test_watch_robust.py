"""What the drop folder may hold besides archives, and how the watcher copes: FIFOs and
other special files, dangling symbolic links, unreadable files (:mod:`analyzer.watch_inbox`).

Every generator runs in a thread with a hard time limit, so that a watcher that blocks or
never ends fails the test instead of hanging it."""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from analyzer import watch_inbox
from analyzer.watch_inbox import InboxTracker, ReadyArchive, incomplete_reason
from analyzer.writers import write_archive

START = "2026-01-01T00:00:00Z"
LIMIT_S = 8.0
"""Hard limit of one ``--once`` pass over a small INBOX in these tests."""


def small_archive(path: Path, fmt: str = "csv", n: int = 400) -> Path:
    t = np.arange(n, dtype=np.int64) * 10_000_000
    rng = np.random.default_rng(1)
    write_archive(path, fmt, t, {"a": rng.normal(size=n), "b": rng.normal(size=n)}, start_iso=START)
    return path


def once(inbox: Path, **kw: object) -> list[ReadyArchive]:
    """Everything one ``--once`` pass of :func:`ready_batches` yields; fails (instead of
    hanging) when the pass does not end within :data:`LIMIT_S`."""
    stop = threading.Event()
    out: list[ReadyArchive] = []
    error: list[BaseException] = []

    def run() -> None:
        try:
            for batch in watch_inbox.ready_batches(
                inbox, settle=0.1, poll=0.05, once=True, stop=stop, **kw
            ):
                out.extend(batch)
        except BaseException as err:  # noqa: BLE001 - handed to the test
            error.append(err)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(LIMIT_S)
    stop.set()
    hung = thread.is_alive()
    if hung:  # unblock a reader stuck in open() on a FIFO, so the thread can end
        for fifo in inbox.iterdir():
            with contextlib.suppress(OSError):
                os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(LIMIT_S)
    assert not hung, f"--once did not end within {LIMIT_S:g} s"
    if error:
        raise error[0]
    return out


@contextlib.contextmanager
def unblocking(fifo: Path) -> Iterator[None]:
    """Should a reader block in open() on ``fifo``, open its other end after
    :data:`LIMIT_S` so that the test fails instead of hanging."""
    timer = threading.Timer(LIMIT_S, lambda: os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)))
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


def messages(caplog: pytest.LogCaptureFixture, level: int = logging.INFO) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.levelno >= level]


@pytest.fixture
def inbox(tmp_path: Path) -> Path:
    folder = tmp_path / "inbox"
    folder.mkdir()
    return folder


@pytest.fixture(autouse=True)
def _info_logs(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="analyzer.watch")


# --------------------------------------------------------------------------- special files


def test_a_fifo_is_ignored_without_being_opened(
    inbox: Path, caplog: pytest.LogCaptureFixture
) -> None:
    small_archive(inbox / "good.csv")
    os.mkfifo(inbox / "stream.csv")
    ready = once(inbox)
    assert [r.name for r in ready] == ["good.csv"]
    said = [m for m in messages(caplog, logging.INFO) if m.startswith("stream.csv")]
    assert said == ["stream.csv: ignored: not a regular file or a directory (a FIFO)"]


def test_a_fifo_is_logged_once_however_often_it_is_seen(
    inbox: Path, caplog: pytest.LogCaptureFixture
) -> None:
    os.mkfifo(inbox / "stream.csv")
    tracker = InboxTracker(inbox, settle=0.5)
    with unblocking(inbox / "stream.csv"):
        for now in (0.0, 1.0, 2.0):
            tracker.rescan()
            tracker.touch("stream.csv")
            assert tracker.step(now) == []
    assert tracker.keys == set() and tracker.done({"stream.csv"})
    assert len([m for m in messages(caplog) if m.startswith("stream.csv")]) == 1


def test_a_file_replaced_by_a_fifo_is_never_opened_blocking(tmp_path: Path) -> None:
    """The structure check itself never blocks on a FIFO (it opens without waiting
    for a writer), should one take a file's place between the listing and the check."""
    os.mkfifo(tmp_path / "x.mcap")
    done: list[object] = []
    thread = threading.Thread(
        target=lambda: done.append(_reason_or_error(tmp_path / "x.mcap")), daemon=True
    )
    thread.start()
    thread.join(LIMIT_S)
    if thread.is_alive():
        os.close(os.open(tmp_path / "x.mcap", os.O_WRONLY | os.O_NONBLOCK))
        thread.join(LIMIT_S)
        pytest.fail("incomplete_reason blocked in open() on a FIFO")
    (what,) = done
    assert isinstance(what, OSError) and "not a regular file" in str(what)


def _reason_or_error(path: Path) -> object:
    try:
        return incomplete_reason(path)
    except OSError as err:
        return err


# --------------------------------------------------------------------------- unreadable


def test_a_dangling_symlink_ends_once_with_a_reason(
    tmp_path: Path, inbox: Path, caplog: pytest.LogCaptureFixture
) -> None:
    small_archive(inbox / "good.csv")
    os.symlink(tmp_path / "gone.mcap", inbox / "dangling.mcap")
    ready = {r.name: r for r in once(inbox)}
    assert set(ready) == {"good.csv", "dangling.mcap"}
    assert ready["good.csv"].unreadable is None
    reason = ready["dangling.mcap"].unreadable
    assert reason == f"dangling symbolic link (to {tmp_path / 'gone.mcap'})"
    said = [m for m in messages(caplog, logging.WARNING) if m.startswith("dangling.mcap")]
    assert said == [f"dangling.mcap: skipped, cannot read it: {reason}"]


def _deny(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Reading the file ``name`` fails as it does for a file of mode 000 (the tests may
    run as root, who reads everything)."""
    read_ends = watch_inbox._read_ends

    def denied(path: Path, n: int, root: Path | None = None) -> tuple[bytes, bytes, int]:
        if path.name == name:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return read_ends(path, n, root)

    monkeypatch.setattr(watch_inbox, "_read_ends", denied)


def test_an_unreadable_file_ends_once_with_a_reason(
    inbox: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    small_archive(inbox / "good.csv")
    small_archive(inbox / "secret.mcap", "mcap")
    _deny("secret.mcap", monkeypatch)
    ready = {r.name: r for r in once(inbox)}
    assert ready["secret.mcap"].unreadable == "secret.mcap: Permission denied"
    said = [m for m in messages(caplog, logging.WARNING) if m.startswith("secret.mcap")]
    assert said == ["secret.mcap: skipped, cannot read it: secret.mcap: Permission denied"]


def test_an_unreadable_file_is_said_once_and_taken_when_readable(
    inbox: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """The long-running watcher: one warning (not a debug line per tick), the archive
    counts as handled, and once it can be read it is handed on as usual."""
    small_archive(inbox / "secret.mcap", "mcap")
    _deny("secret.mcap", monkeypatch)
    tracker = InboxTracker(inbox, settle=0.5)
    tracker.rescan()
    assert tracker.step(0.0) == []
    (skipped,) = tracker.step(1.0)
    assert skipped.unreadable == "secret.mcap: Permission denied"
    for now in (2.0, 3.0, 40.0):
        tracker.rescan()  # the periodic rescans look at it again, quietly
        assert tracker.step(now) == []
    assert tracker.done({"secret.mcap"})
    assert len([m for m in messages(caplog) if m.startswith("secret.mcap")]) == 1
    monkeypatch.undo()  # chmod a+r: an attribute event
    tracker.touch("secret.mcap")
    (ready,) = tracker.step(41.0)
    assert ready.name == "secret.mcap" and ready.unreadable is None and ready.incomplete is None


# --------------------------------------------------------------------------- incomplete


def test_an_incomplete_archive_says_once_how_long_it_may_be_waited_for(
    inbox: Path, caplog: pytest.LogCaptureFixture
) -> None:
    (inbox / "zero.csv").write_bytes(b"")
    tracker = InboxTracker(inbox, settle=0.5, incomplete_timeout=600.0)
    tracker.rescan()
    for now in (0.0, 1.0, 2.0, 30.0):
        tracker.rescan()
        assert tracker.step(now) == []
    said = [m for m in messages(caplog) if "zero.csv" in m]
    assert said == [
        "waiting up to 10 min (--wait-unfinished) for zero.csv to be complete: empty file"
    ]
    assert [r.levelno for r in caplog.records if "zero.csv" in r.getMessage()] == [logging.WARNING]


def test_a_slow_copy_says_how_long_it_may_be_waited_for_once_not_at_every_pause(
    inbox: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A .db3 copied with pauses longer than the settle time: its reason's byte count
    moves on at every pause (``206166 of the 618496 bytes``, then ``412332 of...``); the
    warning is the same one, said once (it was said again at each pause)."""
    import struct

    head = bytearray(b"SQLite format 3\x00".ljust(100, b"\x00"))
    struct.pack_into(">H", head, 16, 4096)  # page size
    struct.pack_into(">II", head, 24, 7, 40)  # change counter, 40 pages
    struct.pack_into(">I", head, 92, 7)  # valid for that counter
    db3 = inbox / "mission.db3"
    tracker = InboxTracker(inbox, settle=0.5, incomplete_timeout=600.0)
    for now, size in ((0.0, 8192), (1.0, 8192), (2.0, 65536), (3.0, 65536), (4.0, 131072)):
        if not db3.exists() or db3.stat().st_size != size:
            db3.write_bytes(bytes(head).ljust(size, b"\x00"))
        tracker.rescan()
        tracker.step(now)
    tracker.step(5.0)
    said = [m for m in messages(caplog) if "mission.db3" in m]
    assert said == [
        "waiting up to 10 min (--wait-unfinished) for mission.db3 to be complete: sqlite "
        "database unfinished: 8192 of the 163840 bytes its header gives (still being copied?)"
    ]


def test_an_incomplete_archive_recorded_already_is_not_waited_for(
    inbox: Path, caplog: pytest.LogCaptureFixture
) -> None:
    (inbox / "zero.csv").write_bytes(b"")
    asked: list[str] = []

    def known(archive: ReadyArchive) -> bool:
        asked.append(archive.name)
        return True

    tracker = InboxTracker(inbox, settle=0.5, incomplete_timeout=600.0, known=known)
    tracker.rescan()
    assert tracker.step(0.0) == []
    (ready,) = tracker.step(1.0)  # settled: recorded already, so not waited for
    assert ready.name == "zero.csv" and ready.incomplete == "empty file"
    assert asked == ["zero.csv"]
    assert not [m for m in messages(caplog) if "waiting" in m]


def test_a_folder_of_sub_folders_is_not_an_empty_directory(tmp_path: Path) -> None:
    nested = tmp_path / "nested"
    (nested / "day1").mkdir(parents=True)
    small_archive(nested / "day1" / "h00.csv")
    assert incomplete_reason(nested) is None  # the analysis says what it makes of it
    (tmp_path / "empty").mkdir()
    assert incomplete_reason(tmp_path / "empty") == "empty directory"


# --------------------------------------------------------------------------- report folders


def test_report_folders_are_one_to_one_with_names() -> None:
    from analyzer.watch_index import report_dirname

    names = ["index.html", "_index.html", "__index.html", "index.json", ".x", "_.x", "a.csv"]
    folders = [report_dirname(n) for n in names]
    assert len(set(folders)) == len(names), dict(zip(names, folders, strict=True))
    assert report_dirname("a.csv") == "a.csv"
    assert not any(f in ("index.html", "index.json") or f.startswith(".") for f in folders)


def test_a_record_keeps_the_report_folder_it_was_written_to(tmp_path: Path) -> None:
    """A state written with the earlier naming (``_x.csv`` in folder ``_x.csv``) is read
    by its records' own links, so no report is lost to the new naming."""
    from analyzer.watch_index import Ledger, Record, Verdict

    ledger = Ledger(tmp_path)
    (tmp_path / "_x.csv").mkdir()
    ledger.record(Record("_x.csv", "0" * 64, Verdict.NO_FAULT, "_x.csv/report.html", [], "t", 1.0))
    assert ledger.tidy() == []
    assert set(Ledger.load(tmp_path).records) == {"_x.csv"}


# --------------------------------------------------------------------------- slow writers


def _append(path: Path, rows: str) -> None:
    with path.open("a") as f:
        f.write(rows)


def test_a_file_that_changes_after_it_was_taken_as_settled_settles_longer(
    inbox: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A writer that pauses longer than ``settle``: the next state of that archive has
    to be stable twice as long (up to a cap), and so on."""
    csv = inbox / "slow.csv"
    csv.write_text("time,a\n0,1\n")
    tracker = InboxTracker(inbox, settle=1.0)
    tracker.rescan()
    assert tracker.step(0.0) == []
    (first,) = tracker.step(1.1)  # taken as complete...
    _append(csv, "1,2\n")  # ...but the writer goes on
    tracker.touch("slow.csv")
    assert tracker.step(1.5) == []
    assert tracker.step(2.6) == []  # 1.1 s: settled before, not now
    (second,) = tracker.step(3.6)  # 2.1 s
    assert second.signature != first.signature
    said = [m for m in messages(caplog) if m.startswith("slow.csv")]
    assert said == [
        "slow.csv: changed 0.4 s after it was taken as complete (a writer pausing longer "
        "than the settle time?); it now has to be stable for 2 s"
    ]
    # gone (moved away by --done) and written again at once: longer still
    csv.unlink()
    tracker.touch("slow.csv")
    assert tracker.step(3.7) == []
    csv.write_text("time,a\n2,3\n")
    tracker.touch("slow.csv")
    assert tracker.step(4.0) == [] and tracker.step(7.9) == []
    (third,) = tracker.step(8.1)  # 4 s
    # a change long after it was taken (a new file an hour) changes nothing
    _append(csv, "3,4\n")
    tracker.touch("slow.csv")
    assert tracker.step(100.0) == []
    (fourth,) = tracker.step(104.1)
    assert len([m for m in messages(caplog) if m.startswith("slow.csv")]) == 2


def test_the_longer_settle_has_a_cap(inbox: Path) -> None:
    csv = inbox / "slow.csv"
    csv.write_text("time,a\n0,1\n")
    tracker = InboxTracker(inbox, settle=100.0)
    tracker.rescan()
    now = 0.0
    tracker.step(now)
    for _ in range(4):
        now += tracker.settle_of("slow.csv") + 0.1
        assert len(tracker.step(now)) == 1
        _append(csv, "1,2\n")
        tracker.touch("slow.csv")
        now += 0.1
        assert tracker.step(now) == []
    assert tracker.settle_of("slow.csv") == watch_inbox.MAX_SETTLE_S

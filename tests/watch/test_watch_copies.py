"""A move by ``--done`` to another file system: copies made off the watcher's loop
(:mod:`analyzer.watch`).

The copy is made slow where it reads and writes (``os.sendfile``, which ``shutil.copy2``
called too), so that these tests hold on any machine: the ``--done`` folder is on
``/dev/shm`` or, where that is missing or the same file system, copied to as if it were
another. Every wait has a hard timeout; threads started here are ended in ``finally``."""

from __future__ import annotations

import errno
import logging
import os
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from test_watch_killed import (
    LIMIT_S,
    _analyses,
    _archive,
    _done_folder,
    _settings,
    _state_record,
    _two_parts,
)

from analyzer.options import RunOptions
from analyzer.watch import WatchSettings, watch


class _SlowCopy:
    """``os.sendfile`` whose first call waits for ``release`` (for the test to set it, or
    ``until``), each call after it as it was, or, ``crawl``, a byte every 10 ms (a copy
    that takes minutes)."""

    def __init__(
        self,
        monkeypatch: pytest.MonkeyPatch,
        until: threading.Event | None = None,
        crawl: bool = False,
    ) -> None:
        self.began, self.release = threading.Event(), until or threading.Event()
        real = os.sendfile

        def sendfile(out_fd: int, in_fd: int, offset: Any, count: int) -> int:
            if not self.began.is_set():
                self.began.set()
                self.release.wait(LIMIT_S)
            if crawl:
                time.sleep(0.01)
                count = 1
            return real(out_fd, in_fd, offset, count)

        monkeypatch.setattr(os, "sendfile", sendfile)


class _Watcher:
    """:func:`watch` on a thread of its own (``stop`` ends it)."""

    def __init__(self, settings: WatchSettings, stop: threading.Event | None = None) -> None:
        self.stop = stop or threading.Event()
        self.code: list[int] = []
        self.thread = threading.Thread(
            target=lambda: self.code.append(watch(settings, RunOptions(), stop=self.stop)),
            daemon=True,
        )
        self.thread.start()

    def join(self) -> bool:
        """Whether it ended (within :data:`LIMIT_S`)."""
        self.thread.join(LIMIT_S)
        return not self.thread.is_alive()

    def end(self) -> None:
        """Wait for it to end, else stop it."""
        if not self.join():
            self.stop.set()
            self.join()


def _wait(what: Callable[[], object], limit: float = LIMIT_S) -> bool:
    deadline = time.monotonic() + limit
    while not what() and time.monotonic() < deadline:
        time.sleep(0.02)
    return bool(what())


@pytest.fixture
def copies(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[tuple[Path, Path, dict]]:
    """INBOX with the archive ``A`` of two files (analyses quick and counted), and a
    ``--done`` folder on another file system."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        yield inbox, done, content


def _partial(done: Path) -> list[str]:
    return [p.name for p in done.iterdir() if p.name.startswith(".partial-")]


def test_another_archive_is_started_while_one_is_copied(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, copies: tuple[Path, Path, dict]
) -> None:
    """An archive dropped while another one's copies to ``--done`` are made is analyzed
    meanwhile, and ``--once`` ends once both are moved, with its exit code. Before, the
    copies were made on the watcher's loop (5.2 s per GB): nothing else was started or
    recorded until they were done."""
    inbox, done, content = copies
    slow = _SlowCopy(monkeypatch)
    w = _Watcher(_settings(tmp_path, done))
    try:
        assert slow.began.wait(LIMIT_S)
        b = _archive(tmp_path / "B.csv", 350)
        b.rename(inbox / "B.csv")
        started = _wait(lambda: "['B.csv']" in _analyses(tmp_path))
        assert not slow.release.is_set()
        assert started, "B was not analyzed while A's copies were being made"
    finally:
        slow.release.set()
        w.end()
    assert w.code == [0]
    assert not any(inbox.iterdir())
    assert sorted(p.name for p in done.iterdir()) == ["A_part0.csv", "A_part1.csv", "B.csv"]
    assert {n: (done / n).read_bytes() for n in content} == content


def test_a_stop_during_a_copy_ends_it_at_its_next_block(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    copies: tuple[Path, Path, dict],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """SIGTERM while an archive is copied to ``--done``: the copy stops at its next
    block, what it made is removed, the archive stays in INBOX, recorded, its move not
    in the state file; the next start moves it (not analyzed again). Before, the copies
    went on to the end (the stop waited for them) and the archive was moved."""
    inbox, done, content = copies
    settings = _settings(tmp_path, done)
    stop = threading.Event()
    slow = _SlowCopy(monkeypatch, until=stop, crawl=True)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    w = _Watcher(settings, stop)
    try:
        assert slow.began.wait(LIMIT_S)
    finally:
        stop.set()
        assert w.join()
    assert w.code == [130]
    assert {p.name: p.read_bytes() for p in inbox.iterdir()} == content
    assert not any(done.iterdir())
    assert "moving" not in _state_record(tmp_path)
    said = [r.getMessage() for r in caplog.records if "its move to" in r.getMessage()]
    assert len(said) == 1 and "stopped (the watcher stopping" in said[0], said
    monkeypatch.undo()
    assert watch(settings, RunOptions()) == 0
    assert not any(inbox.iterdir())
    assert {p.name: p.read_bytes() for p in done.iterdir()} == content
    assert _analyses(tmp_path) == [str(sorted(content))]


def test_a_copy_that_does_not_stop_is_ended_by_the_next_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, copies: tuple[Path, Path, dict]
) -> None:
    """A stop while a copy hangs (a network file system that does not answer): the
    watcher ends anyway, its move left in the state file, and the next start ends it as
    that of a watcher killed during it. Before, the watcher waited for the copy."""
    inbox, done, content = copies
    settings = _settings(tmp_path, done)
    slow = _SlowCopy(monkeypatch)
    w = _Watcher(settings)
    try:
        assert slow.began.wait(LIMIT_S)
        w.stop.set()
        ended = w.join()
        assert not slow.release.is_set()
        assert ended, "the watcher waited for the copy"
        assert _state_record(tmp_path)["moving"]
    finally:
        slow.release.set()
        w.join()
    assert _wait(lambda: not _partial(done))  # (the thread, stopped at last, cleans up)
    monkeypatch.undo()
    assert watch(settings, RunOptions()) == 0
    assert not any(inbox.iterdir())
    assert {p.name: p.read_bytes() for p in done.iterdir()} == content
    rec = _state_record(tmp_path)
    assert "moving" not in rec
    assert sorted(rec["moved_to"]) == [str(done / name) for name in sorted(content)]
    assert _analyses(tmp_path) == [str(sorted(content))]


def test_an_archive_that_changes_while_it_is_copied_is_not_moved(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, copies: tuple[Path, Path, dict]
) -> None:
    """A writer still at it appends to the archive while it is copied to ``--done``:
    the move is not ended (copies removed), the archive is analyzed again once it has
    settled, and moved with what was appended. Before, it was moved with the appended
    rows that its record had never seen."""
    inbox, done, content = copies
    slow = _SlowCopy(monkeypatch)
    w = _Watcher(_settings(tmp_path, done))
    more = b"9.99,1.0,1.0\n"
    try:
        assert slow.began.wait(LIMIT_S)
        with (inbox / "A_part1.csv").open("ab") as f:
            f.write(more)
    finally:
        slow.release.set()
        w.end()
    assert w.code == [0]
    _moved_with_what_was_appended(tmp_path, inbox, done, content, more)


def _moved_with_what_was_appended(
    tmp_path: Path, inbox: Path, done: Path, content: dict[str, bytes], more: bytes
) -> None:
    """The archive analyzed twice (before and after ``more`` was appended to its
    ``A_part1.csv``) and moved whole, with what was appended; INBOX empty."""
    assert _analyses(tmp_path) == [str(sorted(content))] * 2
    assert not any(inbox.iterdir())
    found = {p.name: p.read_bytes() for p in done.iterdir()}
    assert found == {**content, "A_part1.csv": content["A_part1.csv"] + more}


def test_an_archive_offered_again_during_its_copy_stops_it(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    copies: tuple[Path, Path, dict],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The archive changes while it is copied, and the watcher is offered it again
    before the copy ends: the copy stops at its next block (what it made removed), and
    the archive is analyzed again, then moved with what was appended."""
    from analyzer import watch as watch_module

    inbox, done, content = copies
    slow = _SlowCopy(monkeypatch)
    offers: list[str] = []
    real_offer = watch_module._Runner.offer

    def offer(self: Any, archive: Any) -> None:
        real_offer(self, archive)
        offers.append(archive.name)
        if offers.count("A") == 2:  # (the copy goes on once the watcher knows)
            slow.release.set()

    monkeypatch.setattr(watch_module._Runner, "offer", offer)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    w = _Watcher(_settings(tmp_path, done))
    more = b"9.99,1.0,1.0\n"
    try:
        assert slow.began.wait(LIMIT_S)
        with (inbox / "A_part1.csv").open("ab") as f:
            f.write(more)
    finally:
        w.end()
        slow.release.set()
    assert w.code == [0]
    said = [r.getMessage() for r in caplog.records if "its move to" in r.getMessage()]
    assert len(said) == 1 and "stopped (it changed)" in said[0], said
    _moved_with_what_was_appended(tmp_path, inbox, done, content, more)


def test_a_full_disk_in_a_copy_leaves_the_archive_in_inbox_with_one_line(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    copies: tuple[Path, Path, dict],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """``--done`` full in the second file's copy: nothing of the archive is left in it,
    the archive stays in INBOX, recorded, its move not in the state file, and one line
    names the full folder (it named the INBOX file being copied)."""
    inbox, done, content = copies
    real = os.sendfile
    calls: list[int] = []

    def full(out_fd: int, in_fd: int, offset: Any, count: int) -> int:
        calls.append(offset)
        if calls.count(0) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(out_fd, in_fd, offset, count)

    monkeypatch.setattr(os, "sendfile", full)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    assert watch(_settings(tmp_path, done), RunOptions()) == 0
    assert {p.name: p.read_bytes() for p in inbox.iterdir()} == content
    assert not any(done.iterdir())
    assert "moving" not in _state_record(tmp_path)
    said = [r.getMessage() for r in caplog.records if "not moved" in r.getMessage()]
    assert said == [f"A: not moved to {done} (it stays in INBOX): {done}: No space left on device"]


def test_a_fifo_in_a_folder_archive_fails_its_copy_without_blocking(tmp_path: Path) -> None:
    """A FIFO inside a folder archive (never opened by the watcher): its copy is
    refused at once, as ``shutil.copy2`` refused it, and what was made is removed; a
    copy in blocks that opened it would wait for a writer for good."""
    from analyzer import watch as watch_module

    folder = tmp_path / "mission"
    folder.mkdir()
    (folder / "a.csv").write_text("time,a\n0,1\n")
    os.mkfifo(folder / "pipe")
    done = tmp_path / "done"
    done.mkdir()
    with pytest.raises(OSError, match="not a regular file"):
        watch_module._copy_all([folder], [done / ".partial-mission-0123abcd"])
    assert not any(done.iterdir())


def test_a_member_dropped_during_a_copy_is_not_left_behind(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    copies: tuple[Path, Path, dict],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A third file of ``--group-by`` archive ``A`` dropped while A's copies are made,
    seen by the watcher only once they are (its tracker not yet settled on it): the move
    is not ended (copies removed), and the archive of three files is analyzed again and
    moved. Before, only the files found at the start were checked: the two were moved,
    and the third was analyzed alone as the archive."""
    from analyzer import watch as watch_module

    inbox, done, content = copies
    real_end = watch_module._Runner._end_copied

    def end_copied(self: Any, c: Any) -> None:
        if not (inbox / "A_part2.csv").exists():
            _archive(tmp_path / "A_part2.csv", 302).rename(inbox / "A_part2.csv")
        real_end(self, c)

    monkeypatch.setattr(watch_module._Runner, "_end_copied", end_copied)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    assert watch(_settings(tmp_path, done), RunOptions()) == 0
    three = sorted([*content, "A_part2.csv"])
    assert _analyses(tmp_path) == [str(sorted(content)), str(three)]
    assert not any(inbox.iterdir())
    assert sorted(p.name for p in done.iterdir()) == three
    said = [
        r.getMessage() for r in caplog.records if "changed while it was copied" in r.getMessage()
    ]
    assert len(said) == 1, said


def test_a_fifo_put_in_a_files_place_fails_its_copy_without_blocking(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A file that was regular when looked at and is a FIFO when its copy opens it (put
    in its place meanwhile): the copy is refused at once. Before, it was looked at, then
    opened, and the open waited for a writer for good (the copying thread stuck)."""
    from analyzer import watch as watch_module

    fifo, regular = tmp_path / "a.csv", _archive(tmp_path / "b.csv", 300)
    os.mkfifo(fifo)
    real_stat = Path.stat

    def looked_at(self: Path, *, follow_symlinks: bool = True) -> os.stat_result:
        if self == fifo and follow_symlinks:  # (a regular file when looked at)
            return real_stat(regular)
        return real_stat(self, follow_symlinks=follow_symlinks)

    monkeypatch.setattr(Path, "stat", looked_at)
    outcome: list[BaseException | None] = []

    def copy() -> None:
        try:
            watch_module._copy_file(fifo, tmp_path / ".partial-a.csv-0123abcd", threading.Event())
            outcome.append(None)
        except BaseException as err:  # noqa: BLE001 - asserted below
            outcome.append(err)

    thread = threading.Thread(target=copy, daemon=True)
    thread.start()
    thread.join(LIMIT_S / 4)
    if thread.is_alive():  # (the open waits for a writer: give it one, then fail)
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        thread.join(LIMIT_S / 4)
        pytest.fail("the copy's open of a FIFO waited for a writer")
    assert isinstance(outcome[0], OSError) and "not a regular file" in str(outcome[0])


class _FullAtClose:
    """A file whose close fails for a full disk (its last buffered bytes)."""

    def __init__(self, f: Any) -> None:
        self.f = f

    def __getattr__(self, name: str) -> Any:
        return getattr(self.f, name)

    def __enter__(self) -> _FullAtClose:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.f.close()
        raise OSError(errno.ENOSPC, "No space left on device")


def test_a_full_disk_at_the_close_of_a_read_and_write_copy_names_the_folder(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    copies: tuple[Path, Path, dict],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Where ``sendfile`` is refused, the copy reads and writes, and a full ``--done``
    may show only when the copy is closed (its last bytes, buffered): the line names the
    full folder, as a full disk in ``sendfile`` does. Before, it named no file at all."""
    inbox, done, content = copies
    monkeypatch.delattr(os, "sendfile")
    real_open = Path.open

    def open_(self: Path, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        f = real_open(self, mode, *args, **kwargs)
        return _FullAtClose(f) if self.name.startswith(".partial-") and "w" in mode else f

    monkeypatch.setattr(Path, "open", open_)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    assert watch(_settings(tmp_path, done), RunOptions()) == 0
    assert {p.name: p.read_bytes() for p in inbox.iterdir()} == content
    assert not any(done.iterdir())
    said = [r.getMessage() for r in caplog.records if "not moved" in r.getMessage()]
    assert said == [f"A: not moved to {done} (it stays in INBOX): {done}: No space left on device"]


def test_a_move_asked_again_while_its_copies_are_made_is_not_begun_twice(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, copies: tuple[Path, Path, dict]
) -> None:
    """An archive's move asked for again while its copies are being made (its record
    found again, the same content): the move under way ends it, once. Before, a second
    move began beside it and took its place: the first one's copies, never ended, stayed
    hidden in ``--done`` for good."""
    from analyzer import watch as watch_module
    from analyzer.watch_inbox import ReadyArchive, signature
    from analyzer.watch_index import Ledger, Record, Verdict

    inbox, done, content = copies
    settings = _settings(tmp_path, done)
    settings.reports.mkdir()
    runner = watch_module._Runner(
        settings, RunOptions(), Ledger.load(settings.reports), threading.Event()
    )
    paths = tuple(sorted(inbox.iterdir()))
    sig = signature(paths, inbox)
    archive = ReadyArchive("A", paths, sig)
    rec = Record(
        name="A",
        sha256="1" * 64,
        verdict=Verdict.NO_FAULT,
        report="A/report.html",
        inputs=[str(p) for p in paths],
        processed="2026-01-01T00:00:00Z",
        analysis_s=1.0,
        signature=[list(s) for s in sig],
    )
    slow = _SlowCopy(monkeypatch)
    try:
        runner._move(archive, rec)
        assert slow.began.wait(LIMIT_S)
        runner._move(archive, rec)
        slow.release.set()
        assert _wait(lambda: (runner.pump(), not runner.copying)[1])
    finally:
        slow.release.set()
        runner.stop_moves()
        runner.hasher.close()
    assert not any(inbox.iterdir())
    assert {p.name: p.read_bytes() for p in done.iterdir()} == content

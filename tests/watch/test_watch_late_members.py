"""A ``--group-by`` member dropped late: while its archive is analyzed, or after the
analysis and before the archive's move (:mod:`analyzer.watch`).

The member is dropped by the watcher's own loop at that moment (a monkeypatched step),
so that these tests hold on any machine; analyses are quick and counted
(:func:`test_watch_killed._two_parts`)."""

from __future__ import annotations

import errno
import json
import logging
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from test_watch_killed import (
    LIMIT_S,
    _analyses,
    _archive,
    _done_folder,
    _Killed,
    _run_killed,
    _settings,
    _two_parts,
)

from analyzer import watch as watch_module
from analyzer.options import RunOptions
from analyzer.watch import watch
from analyzer.watch_inbox import InboxTracker
from analyzer.watch_index import Ledger


def _records(tmp_path: Path) -> dict[str, Any]:
    doc = json.loads((tmp_path / "in" / "reports" / ".watch-state.json").read_text())
    return doc["archives"]  # type: ignore[no-any-return]


def _drop_third(tmp_path: Path) -> None:
    """``A_part2.csv`` into INBOX (written beside it, renamed in), once."""
    member = tmp_path / "in" / "inbox" / "A_part2.csv"
    if not member.exists():
        _archive(tmp_path / "A_part2.csv", 302).rename(member)


def _past_hold(archive: Any) -> None:
    """Wait out the archive's hold on the loop (nothing else runs meanwhile): an
    analysis that outlasted it, as one of real data (seconds to minutes) outlasts 4
    settle times."""
    time.sleep(max(0.0, archive.hold_until - time.monotonic()))


def _dropped_in_analysis(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The third member dropped while A's analysis runs, seen by the watcher only once
    it ended (its tracker not yet settled on it), with A's hold over."""
    real_finish = watch_module._Runner._finish

    def finish(self: Any, job: Any) -> None:
        if job.archive.name == "A":
            _past_hold(job.archive)
            _drop_third(tmp_path)
        real_finish(self, job)

    monkeypatch.setattr(watch_module._Runner, "_finish", finish)


def _dropped_before_move(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The third member dropped after A's analysis was recorded, as its move begins."""
    real_move = watch_module._Runner._move

    def move(self: Any, archive: Any, rec: Any) -> None:
        if archive.name == "A" and time.monotonic() >= archive.hold_until:
            _drop_third(tmp_path)
        real_move(self, archive, rec)

    monkeypatch.setattr(watch_module._Runner, "_move", move)


def _all_three_once(tmp_path: Path, done: Path, content: dict[str, bytes]) -> None:
    """Every member moved, by one record that read all three, nothing analyzed alone."""
    three = sorted([*content, "A_part2.csv"])
    assert _analyses(tmp_path)[-1] == str(three)
    assert str(["A_part2.csv"]) not in _analyses(tmp_path)
    assert not any((tmp_path / "in" / "inbox").iterdir())
    assert sorted(p.name for p in done.iterdir()) == three
    records = _records(tmp_path)
    assert list(records) == ["A"], list(records)
    assert sorted(Path(p).name for p in records["A"]["inputs"]) == three
    assert sorted(Path(p).name for p in records["A"]["moved_to"]) == three
    assert "moving" not in records["A"]


@pytest.mark.parametrize("other", [False, True], ids=["renames", "copies"])
@pytest.mark.parametrize("when", ["analysis", "move"])
def test_a_member_dropped_late_is_in_the_archives_one_analysis(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
    when: str,
    other: bool,
) -> None:
    """A third file of ``--group-by`` archive ``A`` dropped while A is analyzed (its
    members listed and hashed), or after A's analysis as its move begins: A is not
    recorded (during the analysis) or not moved (before the move) without it, but
    analyzed again with all three, that record replacing the first, and the three moved.
    Before, the two files were recorded and moved (a rename: their signature was
    unchanged), then the third was analyzed alone as ``A`` and the first result kept
    aside as ``A-1`` (copies: caught only once they were made)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    drop = _dropped_in_analysis if when == "analysis" else _dropped_before_move
    drop(tmp_path, monkeypatch)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    with _done_folder(tmp_path, monkeypatch, other) as done:
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        _all_three_once(tmp_path, done, content)
    said = [r.getMessage() for r in caplog.records]
    assert not [line for line in said if "kept as" in line], said


def test_a_member_dropped_during_the_analysis_of_a_held_archive(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The third member dropped as A's analysis ends, within A's hold (a short
    analysis): A with two files is never recorded, only with three."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    real_finish = watch_module._Runner._finish
    recorded: list[list[str]] = []
    real_record = Ledger.record

    def record(self: Ledger, rec: Any) -> None:
        recorded.append(sorted(Path(p).name for p in rec.inputs))
        real_record(self, rec)

    def finish(self: Any, job: Any) -> None:
        _drop_third(tmp_path)
        real_finish(self, job)

    monkeypatch.setattr(watch_module._Runner, "_finish", finish)
    monkeypatch.setattr(Ledger, "record", record)
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        _all_three_once(tmp_path, done, content)
    assert sorted(content) not in recorded, recorded


def test_a_kill_after_a_record_without_the_late_member_is_mended(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Killed once A's two files are recorded, with the third dropped since: the next
    start analyzes the three as A, that record replacing the first (A grew), and moves
    them; nothing analyzed alone, no record kept aside (so before too: a guard that the
    record without the member, once written, is still mended)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = _settings(tmp_path, done)

        def kill(undo: pytest.MonkeyPatch) -> None:
            def move(self: Any, archive: Any, rec: Any) -> None:
                _drop_third(tmp_path)
                raise _Killed

            undo.setattr(watch_module._Runner, "_move", move)

        _run_killed(settings, kill)
        assert [sorted(Path(p).name for p in r["inputs"]) for r in _records(tmp_path).values()] == [
            sorted(content)
        ]
        assert watch(settings, RunOptions()) == 0
        _all_three_once(tmp_path, done, content)


@pytest.mark.parametrize("when", ["analysis", "move"])
def test_a_file_dropped_late_into_a_folder_archive_is_in_its_one_analysis(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, when: str
) -> None:
    """Without ``--group-by``: a file dropped into folder archive ``F`` while it is
    analyzed, or as its move begins. Its signature lists the files it holds, so it was
    caught before as it is now: F is analyzed again with the file, and moved whole."""
    inbox, _ = _two_parts(tmp_path, monkeypatch)
    folder = inbox / "F"
    folder.mkdir()
    for f in sorted(inbox.glob("A_part*.csv")):
        f.rename(folder / f.name)
    step = "_finish" if when == "analysis" else "_move"
    real = getattr(watch_module._Runner, step)

    def dropped(self: Any, job_or_archive: Any, *rest: Any) -> None:
        archive = getattr(job_or_archive, "archive", job_or_archive)
        _past_hold(archive)
        if not (folder / "A_part2.csv").exists():
            _archive(tmp_path / "A_part2.csv", 302).rename(folder / "A_part2.csv")
        real(self, job_or_archive, *rest)

    monkeypatch.setattr(watch_module._Runner, step, dropped)
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = replace(_settings(tmp_path, done), group_by=None)
        assert watch(settings, RunOptions()) == 0
        three = ["A_part0.csv", "A_part1.csv", "A_part2.csv"]
        assert _analyses(tmp_path) == [str(["F"])] * 2
        assert not any(inbox.iterdir())
        assert sorted(p.name for p in (done / "F").iterdir()) == three
        records = _records(tmp_path)
        assert list(records) == ["F"]
        assert [Path(n).name for n, _, _ in records["F"]["signature"]] == three


def _came_and_went(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, step: str, rounds: int = 1
) -> None:
    """At A's ``step`` (``_finish``: its analysis ended; ``_move``: its move, past its
    hold), a third member is in INBOX while the step looks, and taken away right after
    (a wrong drop taken back, a tool's short-lived file matching the pattern), at the
    first ``rounds`` such steps: A is in INBOX as it was handed on before the tracker
    settles on the change. ``_list``: INBOX's listing fails instead (EIO), once."""
    member = tmp_path / "in" / "inbox" / "A_part2.csv"
    done: list[bool] = []
    name = "_move" if step == "_move" else "_finish"
    real = getattr(watch_module._Runner, name)
    real_paths = watch_module.archive_paths

    def failing(*args: Any, **kwargs: Any) -> Any:
        raise OSError(errno.EIO, "Input/output error")

    def disturbed(self: Any, job_or_archive: Any, *rest: Any) -> None:
        archive = getattr(job_or_archive, "archive", job_or_archive)
        held = name == "_move" and time.monotonic() < archive.hold_until
        if archive.name != "A" or len(done) >= rounds or held:
            real(self, job_or_archive, *rest)
            return
        done.append(True)
        if step == "_list":
            monkeypatch.setattr(watch_module, "archive_paths", failing)
            real(self, job_or_archive, *rest)
            monkeypatch.setattr(watch_module, "archive_paths", real_paths)
            return
        _archive(tmp_path / "A_part2.csv", 302).rename(member)
        real(self, job_or_archive, *rest)
        member.unlink()

    monkeypatch.setattr(watch_module._Runner, name, disturbed)


@pytest.mark.parametrize(
    ("step", "rounds"),
    [("_finish", 1), ("_finish", 2), ("_list", 1), ("_move", 1)],
    ids=["analysis", "analysis-twice", "listing-failed", "move"],
)
def test_an_archive_found_changed_but_back_as_it_was_is_done_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, step: str, rounds: int
) -> None:
    """A member that came and went while A was analyzed (its result discarded), or as
    its move began (not moved), or INBOX's listing failing then: A, back in INBOX as it
    was handed on, is handed on again once it has settled (analyzed again, or moved),
    and ``--once`` waits for it. Before, the tracker took A for handed on already: it was
    never analyzed or moved again that session (``--once`` ended with A unrecorded, or
    recorded and left in INBOX, exit code 0)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    _came_and_went(tmp_path, monkeypatch, step, rounds)
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        analyses = 1 if step == "_move" else 1 + rounds
        assert _analyses(tmp_path) == [str(sorted(content))] * analyses
        assert not any(inbox.iterdir())
        assert sorted(p.name for p in done.iterdir()) == sorted(content)
        records = _records(tmp_path)
        assert list(records) == ["A"]
        assert sorted(Path(p).name for p in records["A"]["moved_to"]) == sorted(content)


def test_an_archive_back_as_it_was_is_done_again_by_a_long_running_watcher(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """As above (a member that came and went during A's analysis), without ``--once``:
    A is analyzed again and moved while the watcher runs. Before, not until the next
    start."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    _came_and_went(tmp_path, monkeypatch, "_finish")
    stop = threading.Event()
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = replace(_settings(tmp_path, done), once=False)
        thread = threading.Thread(
            target=watch, args=(settings, RunOptions()), kwargs={"stop": stop}
        )
        thread.start()
        try:
            deadline = time.monotonic() + LIMIT_S
            while any(inbox.iterdir()) and time.monotonic() < deadline:
                time.sleep(0.05)
        finally:
            stop.set()
            thread.join(LIMIT_S)
        assert not thread.is_alive()
        assert not any(inbox.iterdir())
        assert list(_records(tmp_path)) == ["A"]
        assert _analyses(tmp_path) == [str(sorted(content))] * 2


def test_an_archive_gone_once_found_changed_is_not_waited_for(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A removed from INBOX while it was analyzed (its result discarded): ``--once`` ends
    without it (it is not waited for once gone), nothing recorded. (So before too: a
    guard that the archive handed back is dropped once gone.)"""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    real_finish = watch_module._Runner._finish

    def finish(self: Any, job: Any) -> None:
        for path in job.archive.paths:
            path.unlink()
        real_finish(self, job)

    monkeypatch.setattr(watch_module._Runner, "_finish", finish)
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        assert _analyses(tmp_path) == [str(sorted(content))]
        assert not any(done.iterdir())
    state = tmp_path / "in" / "reports" / ".watch-state.json"
    assert not state.exists() or not _records(tmp_path)


def test_the_tracker_hands_back_only_what_it_handed_on_and_after_the_settle_time(
    tmp_path: Path,
) -> None:
    """:meth:`~analyzer.watch_inbox.InboxTracker.again`: the archive is handed on again,
    unchanged, once a settle time has passed from the hand-back (a member that keeps
    coming and going costs one settle time each round, never a busy loop); a hand-back
    of a state other than the one last handed on (a later one handed on meanwhile) is
    ignored."""
    _archive(tmp_path / "a.csv", 300)
    tracker = InboxTracker(tmp_path, 1.0, quiet=True)
    tracker.rescan()
    assert tracker.step(0.0) == []
    (first,) = tracker.step(1.0)
    assert tracker.step(2.0) == []
    tracker.again("a.csv", first.signature, 2.0)
    assert tracker.step(2.5) == []
    (again,) = tracker.step(3.0)
    assert (again.paths, again.signature) == (first.paths, first.signature)
    tracker.again("a.csv", (("a.csv", 0, 0),), 3.0)
    assert tracker.step(5.0) == []


@pytest.mark.parametrize("other", [False, True], ids=["renames", "copies"])
def test_a_member_dropped_after_the_last_listing_is_said_once_its_group_moved(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, other: bool
) -> None:
    """A third member of ``A`` dropped in the instant between the members' last listing
    (:meth:`~analyzer.watch._Runner._as_found`, true) and the move: the two are moved
    without it (all or none, as before); a listing of ``A`` in INBOX after the move finds
    it, said in one line (the file, its group analyzed and moved, that it is analyzed on
    its own as ``A``, the group's record kept aside). Before, nothing was said: it was
    analyzed alone as ``A``, the group's result kept aside as ``A-1``, silently."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    real_found = watch_module._Runner._as_found
    looks: list[str] = []

    last = "_end_copied" if other else "_move"

    def as_found(self: Any, archive: Any) -> bool:
        found = real_found(self, archive)
        if found and archive.name == "A" and sys._getframe(1).f_code.co_name == last:
            looks.append(archive.name)
            _drop_third(tmp_path)
        return bool(found)

    monkeypatch.setattr(watch_module._Runner, "_as_found", as_found)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    with _done_folder(tmp_path, monkeypatch, other) as done:
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        assert looks
        assert set(content) <= {p.name for p in done.iterdir()}
        assert str(sorted(content)) in _analyses(tmp_path)
        assert str(["A_part2.csv"]) in _analyses(tmp_path)
        said = [r.getMessage() for r in caplog.records if "A_part2.csv" in r.getMessage()]
        assert len(said) == 1, said
        assert said[0].startswith(f"A: A_part2.csv: dropped as its group was moved to {done}")
        assert "analyzed on its own as A" in said[0]


def test_a_member_left_in_inbox_by_a_move_by_copies_is_said_so_not_dropped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A move by copies whose second source cannot be removed from INBOX (a sticky
    INBOX, a file made immutable): ``A_part0.csv`` is moved, ``A_part1.csv`` keeps its
    place and loses its copy; it was in the group's analysis, and is said so, with the
    cause, in one line: not as a member "dropped ... after the last look at its members"
    (said so by the watcher that first listed the group after a move), before, silently
    left. It is then analyzed on its own as ``A``, as the line says."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    real_remove = watch_module._remove
    refused: list[Path] = []

    def remove(path: Path, strict: bool = False) -> None:
        if strict and path == inbox / "A_part1.csv" and not refused:
            refused.append(path)
            raise PermissionError(errno.EPERM, "Operation not permitted", str(path))
        real_remove(path, strict)

    monkeypatch.setattr(watch_module, "_remove", remove)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        assert refused
        assert _analyses(tmp_path) == [str(sorted(content)), str(["A_part1.csv"])]
        said = [r.getMessage() for r in caplog.records if "A_part1.csv" in r.getMessage()]
        assert said == [
            f"A: A_part1.csv: in its analysis but left in INBOX by its move to {done} "
            f"(cannot remove {inbox / 'A_part1.csv'}: Operation not permitted): analyzed on "
            "its own as A once settled, the group's result then kept aside under a free name"
        ]


def test_a_file_of_no_group_dropped_after_its_move_is_not_said_left_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """With ``--group-by``, a file whose name the pattern does not match (``B.csv``) is
    an archive of its own, not a group: another ``B.csv`` dropped just after its move is
    a new archive, analyzed as one, and no line calls it "dropped as its group was
    moved" (as the first version of that line did: ``B.csv: B.csv: dropped as its
    group was moved to DONE ...``)."""
    inbox, _ = _two_parts(tmp_path, monkeypatch)
    _archive(inbox / "B.csv", 310)
    real_move = watch_module._move_all
    dropped: list[str] = []

    def move_all(paths: Any, folder: Path, *args: Any) -> list[Path]:
        moved = real_move(paths, folder, *args)
        if [p.name for p in paths] == ["B.csv"] and not dropped:
            dropped.append("B.csv")
            _archive(tmp_path / "B.csv", 311).rename(inbox / "B.csv")
        return moved

    monkeypatch.setattr(watch_module, "_move_all", move_all)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        assert dropped
        assert _analyses(tmp_path).count(str(["B.csv"])) == 2
        said = [r.getMessage() for r in caplog.records if "dropped as its group" in r.getMessage()]
        assert said == []


def test_a_folder_left_in_part_in_inbox_by_its_move_by_copies_is_said(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """An archive folder (no ``--group-by``) moved by copies, one of its files not
    removable from INBOX: its copy is moved whole, what is left of it stays in INBOX,
    said in one line with the cause (before, silently), and is analyzed on its own as
    the archive, as the line says."""
    inbox, _ = _two_parts(tmp_path, monkeypatch)
    folder = inbox / "F"
    folder.mkdir()
    for name in ("A_part0.csv", "A_part1.csv"):
        (inbox / name).rename(folder / name)
    real_remove = watch_module._remove
    refused: list[Path] = []

    def remove(path: Path, strict: bool = False) -> None:
        if strict and path == folder and not refused:
            refused.append(folder / "A_part1.csv")
            (folder / "A_part0.csv").unlink()
            raise PermissionError(errno.EPERM, "Operation not permitted", str(refused[0]))
        real_remove(path, strict)

    monkeypatch.setattr(watch_module, "_remove", remove)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = replace(_settings(tmp_path, done), group_by=None)
        assert watch(settings, RunOptions()) == 0
        assert refused
        assert sorted(p.name for p in (done / "F").iterdir()) == ["A_part0.csv", "A_part1.csv"]
        assert _analyses(tmp_path) == [str(["F"])] * 2
        assert any("F: new content" in r.getMessage() for r in caplog.records)
        said = [r.getMessage() for r in caplog.records if "stays in INBOX" in r.getMessage()]
        assert said == [
            f"F: moved to {done}, but what is left of it stays in INBOX (cannot remove "
            f"{refused[0]}: Operation not permitted): analyzed on its own as F once settled, "
            "the archive's result then kept aside under a free name"
        ]

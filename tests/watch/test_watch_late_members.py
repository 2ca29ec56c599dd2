"""A ``--group-by`` member dropped late: while its archive is analyzed, or after the
analysis and before the archive's move (:mod:`analyzer.watch`).

The member is dropped by the watcher's own loop at that moment (a monkeypatched step),
so that these tests hold on any machine; analyses are quick and counted
(:func:`test_watch_killed._two_parts`)."""

from __future__ import annotations

import json
import logging
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from test_watch_killed import (
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

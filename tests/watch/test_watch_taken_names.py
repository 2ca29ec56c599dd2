"""A name in ``--done`` taken by another process between the watcher's look and its
rename (:func:`analyzer.watch._place`, :func:`analyzer.watch._rename`): never replaced.

The other process's file is made by the look itself (``os.path.lexists`` of the
target, from the function that looks), so that these tests hold on any machine."""

from __future__ import annotations

import errno
import logging
import os
import shutil
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from test_watch_killed import (
    OTHER,
    _archive,
    _done_folder,
    _Killed,
    _killed_in_move,
    _run_killed,
    _settings,
    _state_record,
    _two_parts,
)

from analyzer import watch as watch_module
from analyzer.options import RunOptions
from analyzer.watch import watch


def _taken_after_look(monkeypatch: pytest.MonkeyPatch, target: Path, looker: str) -> list[bool]:
    """Make ``target`` (another process's file) right after ``looker`` found it free;
    returns a list that holds True once it was."""
    real = os.path.lexists
    made: list[bool] = []

    def lexists(path: Any) -> bool:
        found = real(path)
        caller = sys._getframe(1)
        callers = {caller.f_code.co_name, caller.f_back and caller.f_back.f_code.co_name}
        if not found and not made and Path(path) == target and looker in callers:
            target.write_bytes(OTHER)
            made.append(True)
        return found

    monkeypatch.setattr(os.path, "lexists", lexists)
    return made


@pytest.mark.parametrize("how", ["renames", "copies", "one file"])
def test_a_name_taken_between_the_look_and_the_rename_is_not_replaced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, how: str
) -> None:
    """Another process makes ``A_part0.csv`` in ``--done`` after the watcher found the
    name free, before its rename: that file stays, and the archive's goes to the next
    free name (``A_part0-1.csv``), which its record names. Before, the rename replaced
    the other process's file (lost)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=how == "copies") as done:
        settings = _settings(tmp_path, done)
        if how == "one file":  # (each file an archive: moved by one rename)
            settings = replace(settings, group_by=None)
        looker = "_rename" if how == "one file" else "_place"
        made = _taken_after_look(monkeypatch, done / "A_part0.csv", looker)
        assert watch(settings, RunOptions()) == 0
        assert made
        assert not any(inbox.iterdir())
        assert {p.name: p.read_bytes() for p in done.iterdir()} == {
            "A_part0.csv": OTHER,
            "A_part0-1.csv": content["A_part0.csv"],
            "A_part1.csv": content["A_part1.csv"],
        }
        if how != "one file":
            assert sorted(_state_record(tmp_path)["moved_to"]) == [
                str(done / "A_part0-1.csv"),
                str(done / "A_part1.csv"),
            ]


@pytest.mark.parametrize("links", [True, False], ids=["link", "no hard links"])
def test_the_rename_without_renameat2_never_replaces_a_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, links: bool
) -> None:
    """Where ``renameat2`` is missing: a file is linked then unlinked (``link`` refuses
    a taken name); where hard links are refused too, a look then the rename; a folder is
    never renamed over a file or a folder that holds anything."""
    monkeypatch.setattr(watch_module, "_RENAMEAT2", None)
    if not links:

        def no_link(*args: Any, **kwargs: Any) -> None:
            raise OSError(errno.EPERM, "Operation not permitted")

        monkeypatch.setattr(os, "link", no_link)
    source, target = tmp_path / "a.csv", tmp_path / "b.csv"
    source.write_text("a")
    target.write_text("b")
    with pytest.raises(FileExistsError):
        watch_module._rename_new(source, target)
    assert source.read_text() == "a" and target.read_text() == "b"
    watch_module._rename_new(source, tmp_path / "c.csv")
    assert not source.exists() and (tmp_path / "c.csv").read_text() == "a"
    folder = tmp_path / "mission"
    folder.mkdir()
    (folder / "h0.csv").write_text("x")
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "other.csv").write_text("y")
    for taken in (target, tmp_path / "taken"):
        with pytest.raises(FileExistsError):
            watch_module._rename_new(folder, taken)
    assert (folder / "h0.csv").read_text() == "x" and target.read_text() == "b"
    watch_module._rename_new(folder, tmp_path / "moved")
    assert (tmp_path / "moved" / "h0.csv").read_text() == "x" and not folder.exists()


def _two_part_record(tmp_path: Path) -> tuple[Path, Path, list[Path], Any]:
    """INBOX and ``--done`` folders, a two-file archive ``A`` in INBOX and its record
    (analyzed, no fault), for the tests of a move stopped by force: INBOX, ``--done``,
    the archive's files, the record."""
    from analyzer.watch_index import Record, Verdict

    inbox, done = tmp_path / "inbox", tmp_path / "done"
    inbox.mkdir()
    done.mkdir()
    sources = [_archive(inbox / f"A_part{i}.csv", 300 + i) for i in range(2)]
    rec = Record(
        name="A",
        sha256="1" * 64,
        verdict=Verdict.NO_FAULT,
        report="A/report.html",
        inputs=[str(p) for p in sources],
        processed="2026-01-01T00:00:00Z",
        analysis_s=1.0,
        signature=[[p.name, p.stat().st_size, p.stat().st_mtime_ns] for p in sources],
    )
    return inbox, done, sources, rec


def test_a_rename_by_link_killed_before_its_unlink_is_ended(tmp_path: Path) -> None:
    """A watcher killed between the link and the unlink of a rename without
    ``renameat2`` (the file under both names, in INBOX and in ``--done``): the next
    start ends the move, and the name left in INBOX goes (one file: nothing is lost).
    Else it stayed there, to be analyzed alone as the archive."""
    inbox, done, sources, rec = _two_part_record(tmp_path)
    content = {p.name: p.read_bytes() for p in sources}
    rec.moving = [[str(p), "", str(done / p.name)] for p in sources]
    os.rename(sources[0], done / sources[0].name)  # (the first renamed)
    os.link(sources[1], done / sources[1].name)  # (the second linked, not yet unlinked)
    lines = watch_module._moving_lines(rec)
    how, moved = watch_module._end_move(rec, inbox, lines, lambda moving: None)
    assert how == "finished"
    assert sorted(moved) == [str(done / name) for name in sorted(content)]
    assert not any(inbox.iterdir())
    assert {p.name: p.read_bytes() for p in done.iterdir()} == content


def test_the_start_names_partial_copies_no_move_accounts_for(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """``.partial-`` copies in ``--done`` that no move of the state file names (an older
    watcher killed during a move wrote none): each start names them in one warning line
    and leaves them; those of a move kept for the next start (named in the state) are
    not among them. Before, nothing was said: they stayed hidden for good."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = _settings(tmp_path, done)
        _run_killed(settings, lambda undo: _killed_in_move("copying", inbox, undo))
        kept = sorted(p.name for p in done.iterdir())
        assert kept and all(name.startswith(".partial-") for name in kept)
        old = [done / ".partial-B_part0.csv-0123abcd", done / ".partial-B_part1.csv-89abcdef"]
        for p in old:
            p.write_bytes(OTHER)
        (done / ".partial-notes.txt").write_text("someone's")  # (not a copy's name)
        real_remove = watch_module._remove

        def refused(path: Path, strict: bool = False) -> None:
            if path.name in kept:  # (the kept move's copies stay, named in the state)
                raise PermissionError(13, "Permission denied", str(path))
            real_remove(path, strict)

        caplog.set_level(logging.INFO, logger="analyzer.watch")
        with monkeypatch.context() as m:
            m.setattr(watch_module, "_remove", refused)
            watch(settings, RunOptions())
        said = [r.getMessage() for r in caplog.records if "hidden cop" in r.getMessage()]
        assert len(said) == 1, said
        assert said[0].startswith("2 hidden copies of a move that the state file does not")
        assert f"{old[0]}, {old[1]};" in said[0]
        assert not [name for name in kept if name in said[0]]
        assert all(p.read_bytes() == OTHER for p in old)
        assert (done / ".partial-notes.txt").read_text() == "someone's"
        caplog.clear()
        assert watch(settings, RunOptions()) == 0  # (the kept move ended: its copies placed)
        said = [r.getMessage() for r in caplog.records if "hidden cop" in r.getMessage()]
        assert len(said) == 1 and said[0].startswith("2 hidden copies"), said
        assert {p.name: p.read_bytes() for p in done.iterdir() if p.name in content} == content


def _unlink_refused_in(inbox: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """INBOX not writable by the watcher, as seen by ``os.unlink`` (EACCES; simulated:
    root ignores modes)."""
    real_unlink = os.unlink

    def unlink(path: Any, *args: Any, **kwargs: Any) -> None:
        if Path(path).parent == inbox:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        real_unlink(path, *args, **kwargs)

    monkeypatch.setattr(os, "unlink", unlink)


@pytest.mark.parametrize("how", ["renames", "one file"])
def test_an_unlink_refused_after_the_link_leaves_no_second_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, how: str
) -> None:
    """Without ``renameat2`` (a network file system) and with INBOX not writable by the
    watcher: the link into ``--done`` is made, the unlink from INBOX refused. The
    archive stays in INBOX ("not moved"), and nothing of it in ``--done``, at this start
    and the next. Before, each start left one more name of each file in ``--done``."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    monkeypatch.setattr(watch_module, "_RENAMEAT2", None)
    _unlink_refused_in(inbox, monkeypatch)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = _settings(tmp_path, done)
        if how == "one file":
            settings = replace(settings, group_by=None)
        for _ in range(2):
            watch(settings, RunOptions())
            assert not any(done.iterdir()), sorted(p.name for p in done.iterdir())
            assert {p.name: p.read_bytes() for p in inbox.iterdir()} == content
    assert [r for r in caplog.records if "not moved" in r.getMessage()]


def test_a_rename_by_link_killed_before_its_unlink_is_ended_for_one_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A one-file archive (no move in the state file for a rename) moved without
    ``renameat2``, the watcher killed between the link and the unlink: the next start
    ends the move (the state file has it, written before the link), and the file is in
    ``--done`` under one name, which its record names. Before, the next start moved it
    again, beside itself (``A_part0-1.csv``, the same file)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    (inbox / "A_part1.csv").unlink()
    monkeypatch.setattr(watch_module, "_RENAMEAT2", None)
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = replace(_settings(tmp_path, done), group_by=None)

        def kill(undo: pytest.MonkeyPatch) -> None:
            real_unlink = os.unlink

            def unlink(path: Any, *args: Any, **kwargs: Any) -> None:
                if Path(path).parent == inbox:
                    raise _Killed
                real_unlink(path, *args, **kwargs)

            undo.setattr(os, "unlink", unlink)

        _run_killed(settings, kill)
        assert (done / "A_part0.csv").exists() and (inbox / "A_part0.csv").exists()
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        assert {p.name: p.read_bytes() for p in done.iterdir()} == {
            "A_part0.csv": content["A_part0.csv"]
        }
        assert _state_record(tmp_path)["moved_to"] == [str(done / "A_part0.csv")]


def test_a_copy_renamed_by_link_killed_before_its_unlink_is_ended(tmp_path: Path) -> None:
    """A move by copies (another file system) without ``renameat2`` there, killed between
    the link of a copy to its target and the unlink of the copy: the next start ends the
    move and removes the copy's hidden name (the file stays under its target's). Before,
    the target counted as in place and the ``.partial-`` name stayed (said at each start
    as a copy no move accounts for)."""
    inbox, done, sources, rec = _two_part_record(tmp_path)
    content = {p.name: p.read_bytes() for p in sources}
    copies = [done / f".partial-{p.name}-0123abcd" for p in sources]
    for source, copy in zip(sources, copies, strict=True):
        shutil.copy2(source, copy)
    rec.moving = [
        [str(s), str(c), str(done / s.name)] for s, c in zip(sources, copies, strict=True)
    ]
    os.rename(copies[0], done / sources[0].name)  # (the first copy in place)
    os.link(copies[1], done / sources[1].name)  # (the second linked, not yet unlinked)
    how, moved = watch_module._end_move(
        rec, inbox, watch_module._moving_lines(rec), lambda moving: None
    )
    assert how == "finished"
    assert sorted(moved) == [str(done / name) for name in sorted(content)]
    assert not any(inbox.iterdir())
    assert {p.name: p.read_bytes() for p in done.iterdir()} == content


def test_a_refused_unlink_never_removes_the_files_last_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """:func:`~analyzer.watch._rename_new` by link and unlink, the unlink refused: the
    link is undone, the file still at its own name. Where the source went meanwhile
    (another process took it), the link is the file's last name: kept, as moved."""
    real_unlink = os.unlink
    monkeypatch.setattr(watch_module, "_RENAMEAT2", None)
    _unlink_refused_in(tmp_path / "in", monkeypatch)
    (tmp_path / "in").mkdir()
    source, target = tmp_path / "in" / "a.csv", tmp_path / "b.csv"
    source.write_text("a")
    with pytest.raises(PermissionError):
        watch_module._rename_new(source, target)
    assert source.read_text() == "a" and not target.exists()

    def taken_away(path: Any, *args: Any, **kwargs: Any) -> None:
        real_unlink(path)  # (another process's unlink, just before the watcher's)
        raise FileNotFoundError(errno.ENOENT, "No such file or directory", str(path))

    monkeypatch.setattr(os, "unlink", taken_away)
    watch_module._rename_new(source, target)
    assert not source.exists() and target.read_text() == "a"

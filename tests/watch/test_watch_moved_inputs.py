"""``findings.json``'s ``inputs[].moved_to``: where each input is after ``--done`` /
``--failed`` moved it (``path`` stays where it was read: an INBOX path that no longer
holds it)."""

from __future__ import annotations

import errno
import json
from pathlib import Path
from typing import Any

import pytest
from test_watch_run import (
    OPTIONS,
    SETTLE,
    _stop_fork_server,  # noqa: F401 - stops the local watcher's server
    write,
)

from analyzer import watch as watch_module
from analyzer.watch import WatchSettings, _end_moves, note_moves, watch
from analyzer.watch_inbox import signature
from analyzer.watch_index import Ledger, Record, Verdict


def test_findings_json_says_where_a_moved_input_is_now(tmp_path: Path) -> None:
    inbox, reports = tmp_path / "inbox", tmp_path / "reports"
    inbox.mkdir()
    done = tmp_path / "done"
    done.mkdir()
    (done / "a.csv").write_text("an older file of the same name\n")
    write(inbox / "a.csv", "csv", seed=5)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, done=done, once=True)
    assert watch(settings, OPTIONS) == 0
    (item,) = json.loads((reports / "a.csv" / "findings.json").read_text())["inputs"]
    assert Path(item["path"]) == inbox / "a.csv"  # where it was read
    assert item["moved_to"] == str(done / "a-1.csv")  # where it is now (renamed: taken)
    assert (done / "a-1.csv").is_file() and not (inbox / "a.csv").exists()


def test_a_member_of_a_folder_moved_whole_is_under_the_folders_new_place(tmp_path: Path):
    reports = tmp_path / "reports"
    (reports / "day").mkdir(parents=True)
    inbox = tmp_path / "inbox"
    doc = {
        "inputs": [
            {"path": str(inbox / "day" / "h0.csv"), "errors": []},
            {"path": str(inbox / "day2.csv"), "errors": []},  # (not under the folder)
        ]
    }
    (reports / "day" / "findings.json").write_text(json.dumps(doc))
    rec = Record("day", "0", Verdict.NO_FAULT, "day/report.html", [], "", 0.0)
    note_moves(reports, rec, [inbox / "day"], [str(tmp_path / "done" / "day-1")])
    inputs = json.loads((reports / "day" / "findings.json").read_text())["inputs"]
    assert inputs[0]["moved_to"] == str(tmp_path / "done" / "day-1" / "h0.csv")
    assert "moved_to" not in inputs[1]


def test_a_killed_move_finished_in_part_at_the_next_start_says_so_in_findings_json(
    tmp_path: Path,
) -> None:
    """A watcher killed in the move of a group of two files: one renamed into --done,
    the other gone from INBOX since. The next start finishes the move as far as it can
    ("gone"): the moved file's ``moved_to`` is written (before: only where every file of
    the move was moved, so a move ended in part left findings.json without it)."""
    inbox, reports, done = tmp_path / "inbox", tmp_path / "reports", tmp_path / "done"
    for folder in (inbox, reports / "grp", done):
        folder.mkdir(parents=True)
    (done / "a.csv").write_text("t,s1\n0,1\n")
    sig = [list(entry) for entry in signature([done / "a.csv"], done)]
    doc = {"inputs": [{"path": str(inbox / n), "errors": []} for n in ("a.csv", "b.csv")]}
    (reports / "grp" / "findings.json").write_text(json.dumps(doc))
    ledger = Ledger(reports)
    ledger.records["grp"] = Record(
        name="grp",
        sha256="1" * 64,
        verdict=Verdict.NO_FAULT,
        report="grp/report.html",
        inputs=["a.csv", "b.csv"],
        processed="2026-01-01T00:00:00Z",
        analysis_s=1.0,
        signature=[*sig, ["b.csv", 10, 0]],
        moving=[[str(inbox / n), "", str(done / n)] for n in ("a.csv", "b.csv")],
    )
    ledger.save_state()
    ledger = Ledger.load(reports)
    _end_moves(ledger, inbox)
    assert ledger.records["grp"].moved_to == [str(done / "a.csv")]
    inputs = json.loads((reports / "grp" / "findings.json").read_text())["inputs"]
    assert inputs[0].get("moved_to") == str(done / "a.csv")
    assert "moved_to" not in inputs[1]


def _group_in_move(tmp_path: Path) -> tuple[Path, Path, Path, Ledger]:
    """A group ``grp`` of ``a.csv`` and ``b.csv`` whose move by renames into ``done`` was
    stopped by a kill with ``a.csv`` in ``done``, ``b.csv`` still in INBOX: INBOX,
    REPORTS, ``done`` and the state as the next start loads it."""
    inbox, reports, done = tmp_path / "inbox", tmp_path / "reports", tmp_path / "done"
    for folder in (inbox, reports / "grp", done):
        folder.mkdir(parents=True)
    (done / "a.csv").write_text("t,s1\n0,1\n")
    (inbox / "b.csv").write_text("t,s1\n1,2\n")
    sig = [
        *(list(entry) for entry in signature([done / "a.csv"], done)),
        *(list(entry) for entry in signature([inbox / "b.csv"], inbox)),
    ]
    doc = {"inputs": [{"path": str(inbox / n), "errors": []} for n in ("a.csv", "b.csv")]}
    (reports / "grp" / "findings.json").write_text(json.dumps(doc))
    ledger = Ledger(reports)
    ledger.records["grp"] = Record(
        name="grp",
        sha256="1" * 64,
        verdict=Verdict.NO_FAULT,
        report="grp/report.html",
        inputs=["a.csv", "b.csv"],
        processed="2026-01-01T00:00:00Z",
        analysis_s=1.0,
        signature=sig,
        moving=[[str(inbox / n), "", str(done / n)] for n in ("a.csv", "b.csv")],
    )
    ledger.save_state()
    return inbox, reports, done, Ledger.load(reports)


def _moved_to(reports: Path) -> list[str | None]:
    inputs = json.loads((reports / "grp" / "findings.json").read_text())["inputs"]
    return [item.get("moved_to") for item in inputs]


def test_a_killed_move_finished_under_a_name_taken_since_says_it_in_findings_json(
    tmp_path: Path,
) -> None:
    """The start that finishes the move finds ``b.csv``'s planned name in ``done`` taken
    by another file since: ``b.csv`` goes to ``b-1.csv``, and findings.json says so.
    Before, the moved files were told from the move's planned names: ``b.csv``'s
    ``moved_to`` was missing (the record had it)."""
    inbox, reports, done, ledger = _group_in_move(tmp_path)
    (done / "b.csv").write_text("another process's file\n")
    _end_moves(ledger, inbox)
    rec = ledger.records["grp"]
    assert sorted(rec.moved_to) == [str(done / "a.csv"), str(done / "b-1.csv")]
    assert _moved_to(reports) == [str(done / "a.csv"), str(done / "b-1.csv")]
    assert (done / "b-1.csv").read_text() == "t,s1\n1,2\n"


def test_a_killed_move_put_back_but_for_a_file_says_where_that_file_is(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The start that ends the move is refused ``b.csv``'s rename (INBOX read-only to
    it, say): the move is undone, but ``a.csv``, whose name in INBOX another file takes
    in the instant it goes back, stays in ``done``: "put back" with one file moved.
    findings.json says where ``a.csv`` is (the review of watch51 feared it did not:
    reproduced here), and nothing for ``b.csv``, back in INBOX."""
    inbox, reports, done, ledger = _group_in_move(tmp_path)
    real_rename = watch_module._rename_new

    def rename(source: Path, target: Path, *rest: Any) -> None:
        if source == inbox / "b.csv":
            raise PermissionError(errno.EACCES, "Permission denied", str(source))
        if target == inbox / "a.csv":  # (taken in the instant it goes back)
            target.write_text("another process's file\n")
            raise FileExistsError(errno.EEXIST, "File exists", str(target))
        real_rename(source, target, *rest)

    monkeypatch.setattr(watch_module, "_rename_new", rename)
    _end_moves(ledger, inbox)
    rec = ledger.records["grp"]
    assert rec.moving == [] and rec.moved_to == [str(done / "a.csv")]
    assert (inbox / "b.csv").is_file() and (done / "a.csv").is_file()
    assert _moved_to(reports) == [str(done / "a.csv"), None]

"""``findings.json``'s ``inputs[].moved_to``: where each input is after ``--done`` /
``--failed`` moved it (``path`` stays where it was read: an INBOX path that no longer
holds it)."""

from __future__ import annotations

import json
from pathlib import Path

from test_watch_run import (
    OPTIONS,
    SETTLE,
    _stop_fork_server,  # noqa: F401 - stops the local watcher's server
    write,
)

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

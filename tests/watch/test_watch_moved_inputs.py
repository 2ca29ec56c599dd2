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

from analyzer.watch import WatchSettings, note_moves, watch
from analyzer.watch_index import Record, Verdict


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

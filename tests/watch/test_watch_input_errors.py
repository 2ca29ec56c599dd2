"""An archive analyzed past input errors (a truncated file read up to its damage, a
damaged file in a folder archive, skipped): ``analyzer run`` exits 0 or 1 and warns of
each on stderr; the watcher says them in its log, keeps them in the archive's record and
shows them in the index, instead of a plain "no fault" for an archive partly read."""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from pathlib import Path

import pytest
import test_watch_run
from test_watch_run import SETTLE, Watcher, corrupt_mcap, state, write

from analyzer.watch import WatchSettings

folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server


def test_input_errors_of_an_analyzed_archive_are_logged_recorded_and_indexed(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    whole = write(tmp_path / "whole.mcap", "mcap", seed=1).read_bytes()
    (inbox / "cut.mcap").write_bytes(whole[: len(whole) * 3 // 4])  # no closing magic
    day = inbox / "day"
    day.mkdir()
    write(day / "h0.csv", "csv", seed=2)
    corrupt_mcap(day / "h1.mcap")
    write(inbox / "fine.csv", "csv", seed=3)
    settings = WatchSettings(
        inbox, reports, settle=SETTLE, poll=0.1, once=True, incomplete_timeout=1.0
    )
    assert start_watcher(settings).join() == 0  # (as analyzer run: 0, with warnings)

    records = state(reports)
    assert {n: r["verdict"] for n, r in records.items()} == dict.fromkeys(
        ("cut.mcap", "day", "fine.csv"), "no fault"
    )
    assert records["fine.csv"]["input_errors"] == []
    for name, member in (("cut.mcap", inbox / "cut.mcap"), ("day", day / "h1.mcap")):
        findings = json.loads((reports / name / "findings.json").read_text())
        errors = [f"{i['path']}: {e}" for i in findings["inputs"] for e in i["errors"]]
        assert errors and all(e.startswith(f"{member}: ") for e in errors)
        assert records[name]["input_errors"][: len(errors)] == errors
        warned = [
            r.getMessage()
            for r in caplog.records
            if r.levelno == logging.WARNING and r.getMessage().startswith(f"{name}: {member}: ")
        ]
        assert warned == [f"{name}: {e}" for e in errors]
    index = json.loads((reports / "index.json").read_text())
    rows = {row["name"]: row for row in index["archives"]}
    assert rows["cut.mcap"]["input_errors"] == records["cut.mcap"]["input_errors"]
    page = (reports / "index.html").read_text()
    assert page.count("analyzed past input errors: ") == 2
    assert not [p for p in (reports / "day").iterdir() if p.name.startswith(".")]

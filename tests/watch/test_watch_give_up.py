"""``--give-up-after``: an archive too short for the training window stays in INBOX (a
file still being written grows, and is analyzed again); one unchanged (size and mtime)
that long is given up: an error of its own, moved to ``--failed`` with its reason. Before,
a short but complete archive stayed in INBOX for good, and each ``--once`` exited 2."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import test_watch_run
from test_watch_run import SETTLE, Watcher, state, wait_until, write

from analyzer.cli import build_parser
from analyzer.watch import WatchSettings

# the fixtures of test_watch_run (found by pytest among this module's names)
folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server


def said(caplog: pytest.LogCaptureFixture, text: str) -> list[str]:
    return [r.getMessage() for r in caplog.records if text in r.getMessage()]


def short_csv(tmp_path: Path, path: Path) -> Path:
    """A CSV of 2 s: too short for the tests' 12 s training window."""
    write(path, "csv", seconds=2.0, seed=4)
    return path


def test_once_moves_a_short_archive_unchanged_that_long_to_failed(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    failed = tmp_path / "failed"
    old = short_csv(tmp_path, inbox / "old.csv")
    an_hour_ago = time.time() - 3600
    os.utime(old, (an_hour_ago, an_hour_ago))
    short_csv(tmp_path, inbox / "new.csv")  # (just written: still waited for)
    settings = WatchSettings(inbox, reports, settle=SETTLE, failed=failed, once=True)
    assert start_watcher(settings).join() == 2
    assert sorted(p.name for p in inbox.iterdir()) == ["new.csv"]
    assert (failed / "old.csv").is_file()
    (line,) = said(caplog, "old.csv: given up")
    assert "too short for the training window and unchanged for 60 min" in line, line
    rec = state(reports)["old.csv"]
    assert (rec["error_kind"], rec["error_reason"]) == ("input", "too short")
    assert "unchanged for 60 min" in rec["error"] and rec["moved_to"] == [str(failed / "old.csv")]
    (left,) = said(caplog, "new.csv: left in INBOX")
    assert "given up and moved to --failed at " in left and "--give-up-after 600" in left
    assert state(reports)["new.csv"]["error_kind"] == "options"
    # a second --once: the new file, not unchanged that long yet, still stays
    caplog.clear()
    assert start_watcher(settings).join() == 2
    assert sorted(p.name for p in inbox.iterdir()) == ["new.csv"]


def test_a_running_watcher_gives_up_a_short_archive_once_its_time_is_up(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    failed = tmp_path / "failed"
    short_csv(tmp_path, inbox / "a.csv")
    settings = WatchSettings(
        inbox, reports, settle=SETTLE, poll=0.1, failed=failed, give_up_after=2.0
    )
    watcher = start_watcher(settings)
    wait_until(lambda: said(caplog, "a.csv: left in INBOX"), "the short file's error")
    assert (inbox / "a.csv").is_file()
    wait_until(lambda: (failed / "a.csv").is_file(), "the short file given up")
    watcher.stop.set()
    assert watcher.join() == 0
    assert said(caplog, "a.csv: given up: too short for the training window and unchanged")


def test_give_up_after_is_an_option_of_watch() -> None:
    args = build_parser().parse_args(["watch", "in", "--out", "r", "--give-up-after", "90"])
    assert WatchSettings.from_args(args).give_up_after == 90.0
    args = build_parser().parse_args(["watch", "in", "--out", "r"])
    assert WatchSettings.from_args(args).give_up_after == 600.0

"""``watch --once`` and what is never going to be finished (a QA audit, ux56 item 9): a
0-byte file in INBOX held the run for the 10 minutes of ``--wait-unfinished``, and a
link ``loop -> ../inbox`` was waited on as an archive (for an empty file it reached
through the link). Under ``--once`` an archive that is only empty, stable for its settle
time, is handed on at once (to be recorded as empty); a truncated MCAP is still waited
for (a copy may be under way); a link to INBOX or a folder above it is no archive."""

from __future__ import annotations

import logging
import os
from pathlib import Path

from analyzer.watch_inbox import InboxTracker, ready_batches


def _inbox(tmp_path: Path) -> Path:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    (inbox / "empty.csv").write_bytes(b"")
    (inbox / "cut.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\0" * 100)  # no closing magic
    return inbox


def test_under_once_an_empty_file_is_handed_on_after_its_settle_time(tmp_path, caplog):
    inbox = _inbox(tmp_path)
    (inbox / "nothing").mkdir()
    tracker = InboxTracker(inbox, settle=0.5, incomplete_timeout=600.0, once=True)
    tracker.rescan()
    with caplog.at_level(logging.WARNING, logger="analyzer"):
        assert tracker.step(0.0) == []
        assert tracker.step(0.4) == []  # not settled yet: a copy may write its first bytes
        ready = {a.name: a for a in tracker.step(0.6)}
    assert set(ready) == {"empty.csv", "nothing"}
    assert ready["empty.csv"].incomplete == "empty file"
    assert ready["nothing"].incomplete == "empty directory"
    assert tracker.step(599.0) == []  # the truncated MCAP is still waited for
    (cut,) = tracker.step(600.0)
    assert cut.name == "cut.mcap"
    said = [r.getMessage() for r in caplog.records]
    assert not [m for m in said if "empty" in m and "waiting" in m]
    assert [m for m in said if "for cut.mcap to be complete" in m]


def test_without_once_an_empty_file_is_waited_for(tmp_path):
    inbox = _inbox(tmp_path)
    tracker = InboxTracker(inbox, settle=0.5, incomplete_timeout=600.0)
    tracker.rescan()
    assert tracker.step(0.0) == [] and tracker.step(0.6) == [] and tracker.step(599.0) == []
    assert {a.name for a in tracker.step(600.0)} == {"empty.csv", "cut.mcap"}


def test_a_link_to_the_inbox_or_above_is_no_archive(tmp_path, caplog):
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    (inbox / "a.csv").write_text("time,s\n0,1\n1,2\n")
    os.symlink("../inbox", inbox / "loop")
    os.symlink(tmp_path, inbox / "up")
    elsewhere = tmp_path / "site"
    elsewhere.mkdir()
    (elsewhere / "b.csv").write_text("time,s\n0,1\n1,2\n")
    # (an archive linked in from outside INBOX: no longer one, sec56b: never read, never
    # moved, said once; a link inside INBOX still is, test_watch_links_out56)
    os.symlink(elsewhere, inbox / "site")
    tracker = InboxTracker(inbox, settle=0.5, once=True)
    with caplog.at_level(logging.WARNING, logger="analyzer"):
        tracker.rescan()
        tracker.rescan()
        tracker.touch("loop")
        tracker.touch("site")
    assert tracker.keys == {"a.csv"}
    said = [r.getMessage() for r in caplog.records]
    assert (
        said.count(
            f"site: ignored: a symbolic link to {elsewhere.resolve()}, outside INBOX: never read "
            "nor moved"
        )
        == 1
    )
    assert said.count(f"loop: ignored: a link to {inbox.resolve()}, which holds INBOX itself") == 1
    assert said.count(f"up: ignored: a link to {tmp_path.resolve()}, which holds INBOX itself") == 1


def test_once_ends_over_an_empty_file_and_a_loop(tmp_path):
    """The audit's INBOX, through the generator ``watch --once`` runs: it ends after the
    settle time, the empty file handed on, the loop never (a base run waited 10 min)."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    (inbox / "empty.csv").write_bytes(b"")
    os.symlink("../inbox", inbox / "loop")
    batches = list(ready_batches(inbox, settle=0.1, poll=0.05, once=True, incomplete_timeout=30))
    assert [a.name for b in batches for a in b] == ["empty.csv"]

"""Symbolic links in the drop folder that lead out of it (security review ux63, H3 and
M1): whoever may drop files must not have the watcher read, and publish in its report
and index, a file only the watcher's account may read (``passwd.csv -> /etc/passwd``
put its first line into ``index.html`` and ``error.txt``); a looping pair of links
must not stop the watcher. Links that stay inside INBOX are followed."""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from pathlib import Path

import pytest
import test_watch_run
from test_watch_run import SETTLE, Watcher, said, started, state, write

from analyzer.errors import ReaderError
from analyzer.readers import open_archive
from analyzer.readers._common import link_out, open_inside
from analyzer.watch import WatchSettings, hash_archive
from analyzer.watch_inbox import InboxTracker, incomplete_reason, signature

folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server

SECRET = "root:$6$SECRETHASH:19000:0:99999:7:::"


def outside(tmp_path: Path) -> Path:
    """A folder beside INBOX holding a "secret" file and an archive folder."""
    out = tmp_path / "outside"
    (out / "arch").mkdir(parents=True)
    (out / "shadow").write_text(SECRET + "\n")
    write(out / "arch" / "elsewhere.csv", "csv", seed=3)
    return out


def all_text(folder: Path) -> str:
    """Every file's text under ``folder`` (reports, index, error files, state)."""
    return "".join(p.read_text(errors="replace") for p in sorted(folder.rglob("*")) if p.is_file())


def test_links_out_of_inbox_are_ignored_never_read_nor_moved(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A file and a folder linked from outside INBOX: one warning each, no analysis, no
    record, nothing of them in REPORTS, left in INBOX by ``--done``/``--failed``; the
    archive beside them is analyzed as usual. Before, ``shadow.csv``'s target was
    analyzed and its first line quoted in ``error.txt`` and ``index.html``."""
    inbox, reports = folders
    out = outside(tmp_path)
    done, failed = tmp_path / "done", tmp_path / "failed"
    (inbox / "shadow.csv").symlink_to(out / "shadow")
    (inbox / "outside_dir").symlink_to(out / "arch")
    write(inbox / "a.csv", "csv", seed=1)
    settings = WatchSettings(
        inbox, reports, settle=SETTLE, poll=0.1, done=done, failed=failed, once=True
    )
    with caplog.at_level(logging.INFO, logger="analyzer.watch"):
        # (a long limit: a loaded machine; the base took over 60 s, analyzing all three)
        assert start_watcher(settings).join(timeout=300) in (0, 1)
    assert started(caplog) == ["a.csv"]
    assert set(state(reports)) == {"a.csv"}
    assert "SECRETHASH" not in all_text(reports) and "elsewhere" not in all_text(reports)
    assert (inbox / "shadow.csv").is_symlink() and (inbox / "outside_dir").is_symlink()
    assert not (failed / "shadow.csv").exists() and not (done / "outside_dir").exists()
    assert (out / "shadow").read_text() == SECRET + "\n"
    for name, target in (("shadow.csv", out / "shadow"), ("outside_dir", out / "arch")):
        assert said(caplog, f"{name}: ignored: a symbolic link to {target.resolve()}, ") == [
            f"{name}: ignored: a symbolic link to {target.resolve()}, outside INBOX: "
            "never read nor moved"
        ]


def test_a_folder_s_file_linked_from_outside_is_not_part_of_it(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """A folder archive holding a link to a file outside INBOX: not in its signature or
    hash (never read by the watcher), said once however often it is looked at, and the
    analysis skips it with a note; its other files are read as before."""
    inbox = tmp_path / "inbox"
    arch = inbox / "arch"
    arch.mkdir(parents=True)
    out = outside(tmp_path)
    write(arch / "own.csv", "csv", seed=1)
    (arch / "leak.csv").symlink_to(out / "shadow")
    (arch / "sub").symlink_to(out / "arch")
    tracker = InboxTracker(inbox, 0.0)
    tracker.rescan()
    with caplog.at_level(logging.WARNING, logger="analyzer.watch"):
        for now in (1.0, 2.0, 3.0):
            tracker.touch("arch")
            (ready,) = tracker.step(now) or (None,)
    assert said(caplog, "arch/leak.csv: ignored: a symbolic link to") == [
        f"arch/leak.csv: ignored: a symbolic link to {(out / 'shadow').resolve()}, outside "
        "INBOX: never read nor moved"
    ]
    assert [s[0] for s in signature([arch], inbox)] == ["arch/own.csv"]
    assert incomplete_reason(arch, root=inbox.resolve()) is None
    hashes = hash_archive([arch], inbox)
    assert set(hashes.marks) == {"arch/own.csv"}
    archive = open_archive([arch], inside=inbox.resolve())
    assert [r.info.path.name for r in archive.readers] == ["own.csv"]
    notes = [str(n) for n in archive.notes]
    assert any(n.startswith(f"{arch / 'leak.csv'} not read: a symbolic link to ") for n in notes)
    assert any(n.startswith(f"{arch / 'sub'} not read: a symbolic link to ") for n in notes)


def test_a_ros2_bag_with_a_storage_file_from_outside_is_not_read(tmp_path: Path) -> None:
    """A bag folder whose storage file is a link out of INBOX is refused whole, naming
    the file (its metadata.yaml alone cannot be read); the watcher never opens it."""
    inbox = tmp_path / "inbox"
    bag = inbox / "bag"
    bag.mkdir(parents=True)
    out = outside(tmp_path)
    (bag / "metadata.yaml").write_text(
        "rosbag2_bagfile_information:\n  relative_file_paths: [bag_0.db3]\n"
    )
    (bag / "bag_0.db3").symlink_to(out / "shadow")
    assert [s[0] for s in signature([bag], inbox)] == ["bag/metadata.yaml"]
    with pytest.raises(ReaderError, match=r"bag: not read: its file bag_0\.db3 is a symbolic"):
        open_archive([bag], inside=inbox.resolve())


def test_a_file_swapped_for_a_link_after_its_check_is_not_opened(tmp_path: Path) -> None:
    """The watcher opens INBOX's files by their real path with ``O_NOFOLLOW`` after the
    check, so a file replaced by a link out of INBOX between the two is refused."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    out = outside(tmp_path)
    f = inbox / "a.csv"
    f.write_text("time,a\n0,1\n")
    os.close(open_inside(f, inbox.resolve()))
    f.unlink()
    f.symlink_to(out / "shadow")
    with pytest.raises(OSError, match="outside the watched folder"):
        open_inside(f, inbox.resolve())
    with pytest.raises(OSError):
        incomplete_reason(f, root=inbox.resolve())
    with pytest.raises(OSError):
        hash_archive([f], inbox)


def test_a_link_inside_inbox_is_followed(tmp_path: Path) -> None:
    """A link to a file or folder inside INBOX is read as what it leads to (the choice:
    it shows nothing the uploader could not drop itself)."""
    inbox = tmp_path / "inbox"
    (inbox / "runs").mkdir(parents=True)
    (inbox / "runs" / "r1.csv").write_text("time,a\n0,1\n1,2\n")
    (inbox / "latest.csv").symlink_to("runs/r1.csv")
    assert link_out(inbox / "latest.csv", inbox.resolve()) is None
    tracker = InboxTracker(inbox, 0.0, quiet=True)
    tracker.rescan()
    assert tracker.keys == {"latest.csv", "runs"}
    assert incomplete_reason(inbox / "latest.csv", root=inbox.resolve()) is None
    assert hash_archive([inbox / "latest.csv"], inbox).sha256


def test_a_looping_pair_of_links_does_not_stop_the_watcher(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """``loop_a -> loop_b -> loop_a`` in INBOX: each said once and passed over; the
    other archives are listed. Before, the listing raised "Too many levels of symbolic
    links" and the watcher exited (at start, or whenever such a pair appeared)."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    (inbox / "a.csv").write_text("time,a\n0,1\n1,2\n")
    (inbox / "loop_a").symlink_to("loop_b")
    (inbox / "loop_b").symlink_to("loop_a")
    tracker = InboxTracker(inbox, 0.0)
    with caplog.at_level(logging.WARNING, logger="analyzer.watch"):
        tracker.rescan()
        tracker.rescan()
        tracker.touch("loop_a")
    assert tracker.keys == {"a.csv"}
    for name in ("loop_a", "loop_b"):
        assert said(caplog, f"{name}: ignored") == [f"{name}: ignored: a symbolic link loop"]

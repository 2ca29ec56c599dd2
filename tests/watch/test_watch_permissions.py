"""Folders and files the watcher may not write or read (:mod:`analyzer.watch`).

CI runs as root, where permissions do not bite: the refusals are made by monkeypatching
the OS calls (``os.access``, ``os.open``, a rename) to say or raise what a permission
denied does for another user. (Checked live as ``nobody``: see the watch README
section.)"""

from __future__ import annotations

import errno
import logging
import os
import threading
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from analyzer import watch as watch_module
from analyzer import watch_index
from analyzer.errors import UsageError
from analyzer.options import RunOptions
from analyzer.watch import WatchSettings, watch
from analyzer.writers import write_archive

START = "2026-01-01T00:00:00Z"
LIMIT_S = 60.0


def small_archive(path: Path, n: int = 400) -> Path:
    """An archive too short to analyze: an input error, moved to ``--failed``."""
    t = np.arange(n, dtype=np.int64) * 10_000_000
    rng = np.random.default_rng(1)
    write_archive(
        path, "csv", t, {"a": rng.normal(size=n), "b": rng.normal(size=n)}, start_iso=START
    )
    return path


def unreadable_archive(path: Path) -> Path:
    """A CSV without data rows: an input error, moved to ``--failed`` (one too short
    for the training window stays in INBOX, as a file still being written)."""
    path.write_text("not,a\ntable\n")
    return path


def refuse_writes_to(monkeypatch: pytest.MonkeyPatch, refused: set[Path]) -> None:
    """``os.access(path, W_OK)`` is False for the folders in ``refused`` (which the test
    may fill later), as for a user who may not write them."""
    real = os.access

    def access(path: str | os.PathLike[str], mode: int, **kw: object) -> bool:
        if mode & os.W_OK and Path(path).absolute() in refused:
            return False
        return real(path, mode, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "access", access)


def run_once(settings: WatchSettings) -> int:
    """:func:`watch` with ``--once`` in a thread with a hard time limit; its exit code,
    or what it raised."""
    out: list[int] = []
    error: list[BaseException] = []

    def run() -> None:
        try:
            out.append(watch(settings, RunOptions()))
        except BaseException as err:  # noqa: BLE001 - handed to the test
            error.append(err)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join(LIMIT_S)
    assert not thread.is_alive(), "--once did not end"
    if error:
        raise error[0]
    return out[0]


@pytest.fixture
def folders(tmp_path: Path) -> tuple[Path, Path, Path]:
    inbox, reports, failed = tmp_path / "inbox", tmp_path / "reports", tmp_path / "failed"
    inbox.mkdir()
    failed.mkdir()
    return inbox, reports, failed


@pytest.mark.parametrize("option", ["done", "failed"])
def test_a_move_folder_the_watcher_cannot_write_is_refused_at_start(
    folders: tuple[Path, Path, Path], monkeypatch: pytest.MonkeyPatch, option: str
) -> None:
    """``--done``/``--failed`` that the watcher may not write: exit 2 at start, the
    option named (before, it analyzed every archive and warned, for each, that it could
    not move it, naming the archive's file as the cause)."""
    inbox, reports, folder = folders
    small_archive(inbox / "a.csv")
    refuse_writes_to(monkeypatch, {folder})
    settings = WatchSettings(inbox=inbox, reports=reports, settle=0.1, poll=0.05, once=True)
    with pytest.raises(UsageError, match=rf"^--{option}: cannot write to {folder}: permission"):
        run_once(replace(settings, **{option: folder}))
    assert (inbox / "a.csv").is_file() and not (reports / "a.csv").exists()


def test_moving_out_of_an_inbox_the_watcher_cannot_write_is_refused_at_start(
    folders: tuple[Path, Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """With ``--done``/``--failed``, an INBOX the watcher may not write (a read-only
    share): exit 2 at start, saying why (no archive could ever be moved)."""
    inbox, reports, failed = folders
    refuse_writes_to(monkeypatch, {inbox})
    settings = WatchSettings(inbox=inbox, reports=reports, failed=failed, once=True, poll=0.05)
    with pytest.raises(UsageError, match=r"^--failed: archives cannot be moved out of INBOX .*"):
        run_once(settings)
    # without a move option, a read-only INBOX is fine
    assert run_once(WatchSettings(inbox=inbox, reports=reports, once=True, poll=0.05)) == 0


def test_a_move_refused_while_running_names_the_folder_that_refused_it(
    folders: tuple[Path, Path, Path],
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """``--failed`` made read-only while the watcher runs: the archive is recorded, stays
    in INBOX, and the warning names ``--failed``'s folder as the cause (a refused
    rename names its source only: the line said ``INBOX/a.csv: Permission denied``)."""
    inbox, reports, failed = folders
    unreadable_archive(inbox / "a.csv")
    refused: set[Path] = set()
    refuse_writes_to(monkeypatch, refused)

    def rename_refused(paths: Sequence[Path], folder: Path, *_: object) -> list[Path]:
        refused.add(folder.absolute())  # (made read-only since the start)
        src = paths[0]
        raise PermissionError(errno.EACCES, "Permission denied", str(src), str(folder / src.name))

    monkeypatch.setattr(watch_module, "_move_all", rename_refused)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    settings = WatchSettings(
        inbox=inbox, reports=reports, failed=failed, settle=0.1, poll=0.05, once=True
    )
    assert run_once(settings) == 2  # (the archive's error)
    lines = [r.getMessage() for r in caplog.records if "not moved" in r.getMessage()]
    assert lines == [
        f"a.csv: not moved to {failed} (it stays in INBOX): cannot write to {failed}: "
        "Permission denied"
    ]
    assert (inbox / "a.csv").is_file() and (reports / "a.csv" / "error.txt").is_file()


def test_a_lock_file_the_watcher_cannot_open_is_named(
    folders: tuple[Path, Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``REPORTS/.lock`` left by another user: exit 2 naming that file (the line named
    REPORTS, which the watcher may well write)."""
    inbox, reports, _ = folders
    reports.mkdir()
    lock = reports / ".lock"
    lock.write_text("1\n")
    real = os.open

    def refused(path: str | os.PathLike[str], flags: int, *args: int, **kw: object) -> int:
        if Path(path) == lock:
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real(path, flags, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(watch_index.os, "open", refused)
    with pytest.raises(UsageError, match=rf"^--out: cannot write to {lock}: Permission denied"):
        run_once(WatchSettings(inbox=inbox, reports=reports, once=True, poll=0.05))


def test_a_state_file_the_watcher_cannot_read_is_not_called_damaged(
    folders: tuple[Path, Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A state file the watcher's user may not read: exit 2 saying so, without the
    advice for a damaged one (move it away: every archive analyzed again)."""
    inbox, reports, _ = folders
    reports.mkdir()
    state = reports / ".watch-state.json"
    state.write_text("{}")
    real = Path.read_text

    def refused(self: Path, *args: object, **kw: object) -> str:
        if self == state:
            raise PermissionError(errno.EACCES, "Permission denied", str(self))
        return real(self, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(Path, "read_text", refused)
    with pytest.raises(
        UsageError, match="cannot read the watcher state: Permission denied"
    ) as info:
        run_once(WatchSettings(inbox=inbox, reports=reports, once=True, poll=0.05))
    assert "move it away" not in str(info.value)

"""A watcher whose folders fail under it (a QA audit's ux66, watch part): REPORTS removed
(H1), a report that cannot be written for a while (H2), two watchers on one INBOX (M3),
``run --out`` into a watcher's reports (M4), INBOX removed (M5), SIGHUP (L1).

Running watchers are threads of the test (stopped by their event) or, for the signal, a
process; every wait has a hard limit, so a watcher that never gets there fails the test
instead of hanging it."""

from __future__ import annotations

import errno
import fcntl
import json
import logging
import multiprocessing
import multiprocessing.forkserver
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from analyzer import watch as watch_module
from analyzer.errors import UsageError
from analyzer.options import RunOptions
from analyzer.pipeline import run
from analyzer.simulate import simulate_building
from analyzer.watch import WatchSettings, watch
from analyzer.watch_inbox import InboxTracker
from analyzer.watch_index import ReportsLock
from analyzer.writers import write_archive

LIMIT_S = 60.0
"""Hard limit of one wait for a watcher."""
OPTIONS = RunOptions(train="0:12")


def _building(path: Path, seed: int = 2) -> Path:
    t, y, names = simulate_building(3, 40.0, 100.0, seed=seed)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    return path


def _until(what: Callable[[], bool], why: str) -> None:
    end = time.monotonic() + LIMIT_S
    while not what():
        assert time.monotonic() < end, f"not within {LIMIT_S:g} s: {why}"
        time.sleep(0.05)


@contextmanager
def _watcher(settings: WatchSettings) -> Iterator[dict[str, Any]]:
    """A watcher running in a thread; stopped (and its exit code or error kept in the
    dict yielded) at the end of the block."""
    stop = threading.Event()
    result: dict[str, Any] = {}

    def body() -> None:
        try:
            result["code"] = watch(settings, OPTIONS, stop=stop)
        except BaseException as err:  # noqa: BLE001 - handed to the test
            result["error"] = err

    thread = threading.Thread(target=body, daemon=True)
    thread.start()
    try:
        yield result
    finally:
        stop.set()
        thread.join(LIMIT_S)
        assert not thread.is_alive(), "the watcher did not stop"


def _said(caplog: pytest.LogCaptureFixture, text: str) -> list[str]:
    return [r.getMessage() for r in caplog.records if text in r.getMessage()]


@pytest.fixture(scope="module", autouse=True)
def _stop_fork_server() -> Iterator[None]:
    """The analysis processes fork from multiprocessing's fork server, which would live
    on until pytest exits: stop it after this module."""
    yield
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    stop = getattr(server, "_stop", None)
    if callable(stop):
        stop()


def _settings(tmp_path: Path, name: str = "reports") -> WatchSettings:
    inbox = tmp_path / "inbox"
    inbox.mkdir(exist_ok=True)
    return WatchSettings(inbox=inbox, reports=tmp_path / name, settle=0.2, poll=0.05)


def _indexed(reports: Path) -> list[str]:
    try:
        doc = json.loads((reports / "index.json").read_text())
    except (OSError, ValueError):
        return []
    return sorted(a["name"] for a in doc["archives"])


def test_reports_removed_under_a_running_watcher_is_made_again_and_locked_again(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    settings = _settings(tmp_path)
    reports = settings.reports
    with _watcher(settings) as result:
        _building(settings.inbox / "a.csv")
        _until(lambda: _indexed(reports) == ["a.csv"], "a.csv analyzed")
        # (a disk clean-up; renamed away first so that it is gone at once, not file by
        # file while the watcher makes it again)
        reports.rename(tmp_path / "trash")
        shutil.rmtree(tmp_path / "trash")
        _until(lambda: _indexed(reports) == ["a.csv"], "a.csv analyzed again into REPORTS")
        assert (reports / "a.csv" / "report.html").is_file()  # (its report went: made again)
        # the new lock file is held: a second watcher there is refused
        fd = os.open(reports / ".lock", os.O_RDONLY)
        try:
            with pytest.raises(BlockingIOError):
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(fd)
        state = json.loads((reports / ".watch-state.json").read_text())
        assert sorted(state["archives"]) == ["a.csv"]
    assert result == {"code": 0}
    (line,) = _said(caplog, "was removed or replaced under the watcher")
    assert str(reports) in line and "1 archive whose report went with it" in line, line
    assert not _said(caplog, "cannot write its report")


def test_reports_taken_by_another_watcher_after_its_removal_stops_this_one(
    tmp_path: Path,
) -> None:
    """A watcher that finds its REPORTS made again and locked by another watcher writes
    nothing more there: one line naming REPORTS and the other's lock, exit 2."""
    reports = tmp_path / "reports"
    reports.mkdir()
    mine = ReportsLock(reports)
    mine.acquire()
    other = ReportsLock(reports)
    try:
        assert not mine.lost()
        shutil.rmtree(reports)
        assert mine.lost()
        reports.mkdir()
        other.acquire()  # (possible: the first lock went with its file)
        with pytest.raises(UsageError, match="in use by another watcher"):
            mine.retake()
    finally:
        other.release()
        mine.release()


def test_a_report_that_could_not_be_written_is_tried_again_while_the_watcher_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """REPORTS full (or unwritable) for a while: the archive is analyzed again once the
    retry's wait is over, not only at the next start; the failure is said once for the
    series, not at each try."""
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    monkeypatch.setattr(watch_module, "RETRY_FIRST_S", 0.2, raising=False)
    real = watch_module.scratch_dir
    failures = [2]  # (the first two tries meet a full disk)

    def scratch_dir(reports: Path, name: str) -> Path:
        if failures[0] > 0:
            failures[0] -= 1
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(reports / f".tmp-{name}"))
        return real(reports, name)

    monkeypatch.setattr(watch_module, "scratch_dir", scratch_dir)
    settings = _settings(tmp_path)
    with _watcher(settings) as result:
        _building(settings.inbox / "b.csv")
        _until(lambda: (settings.reports / "b.csv" / "report.html").is_file(), "b.csv retried")
    assert result == {"code": 0}
    assert failures == [0]
    (line,) = _said(caplog, "cannot write its report")
    assert "No space left on device" in line and "tried again in 200 ms" in line, line
    assert _said(caplog, "b.csv: its report is written now, at try 3")


def test_a_second_watcher_on_one_inbox_is_refused(tmp_path: Path) -> None:
    """Two watchers on one INBOX (other REPORTS) analyzed every archive twice and split
    the reports; the second is refused at once, INBOX named, exit 2."""
    settings = _settings(tmp_path, "reports1")
    with _watcher(settings) as result:
        _until(lambda: (settings.reports / ".watch-state.json").is_file(), "watcher 1 started")
        second = WatchSettings(
            inbox=settings.inbox, reports=tmp_path / "reports2", settle=0.2, poll=0.05, once=True
        )
        with pytest.raises(UsageError, match="INBOX: .*inbox is watched by another watcher"):
            watch(second, OPTIONS)
    assert result == {"code": 0}
    assert not (tmp_path / "reports2" / ".watch-state.json").exists()


def test_run_into_a_watcher_s_reports_is_refused(tmp_path: Path) -> None:
    settings = WatchSettings(
        inbox=tmp_path / "inbox", reports=tmp_path / "reports", settle=0.1, poll=0.05, once=True
    )
    settings.inbox.mkdir()
    assert watch(settings, OPTIONS) == 0  # (an empty INBOX: its REPORTS made, and its state)
    src = _building(tmp_path / "x.csv")
    for out in (settings.reports, settings.reports / "a.csv"):
        with pytest.raises(UsageError, match=f"--out: {out} .*a watcher's report folder"):
            run([src], out, OPTIONS)
    assert not (settings.reports / "a.csv").exists()
    assert not (settings.reports / "findings.json").exists()


def test_inbox_removed_and_back_is_said_once_each(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    tracker = InboxTracker(inbox, 0.1)
    tracker.rescan()
    inbox.rmdir()
    for _ in range(3):
        tracker.rescan()
    inbox.mkdir()
    for _ in range(3):
        tracker.rescan()
    gone = _said(caplog, "is gone")
    back = _said(caplog, "is back")
    assert len(gone) == 1 and str(inbox) in gone[0] and "waiting for it" in gone[0], gone
    assert len(back) == 1 and str(inbox) in back[0], back


def test_an_inbox_made_again_is_locked_again(tmp_path: Path) -> None:
    """The lock held was on the INBOX that went: the new one is locked when it is back,
    and a watcher that started on it meanwhile stops this one (exit 2)."""
    from analyzer.watch_index import InboxLock  # (new here: the other tests run on 4daf9c6)

    inbox = tmp_path / "inbox"
    inbox.mkdir()
    mine, other = InboxLock(inbox), InboxLock(inbox)
    try:
        mine.acquire()
        backs: list[int] = []
        tracker = InboxTracker(inbox, 0.1, back=lambda: (backs.append(1), mine.renew()))
        tracker.rescan()
        inbox.rmdir()
        tracker.rescan()
        mine.renew()  # (not there: nothing to lock)
        inbox.mkdir()
        tracker.rescan()  # (back: the new INBOX locked)
        tracker.rescan()
        assert backs == [1]
        with pytest.raises(UsageError, match="INBOX: .* is watched by another watcher"):
            other.acquire()
        inbox.rmdir()
        inbox.mkdir()
        other.acquire()  # (a watcher started on the new INBOX before this one saw it)
        with pytest.raises(UsageError, match="INBOX: .* is watched by another watcher"):
            mine.renew()
    finally:
        other.release()
        mine.release()


@contextmanager
def _watching(tmp_path: Path, **popen: Any) -> Iterator[subprocess.Popen[str]]:
    """``analyzer watch`` of an empty INBOX in a process of its own, once it said it is
    watching (its signal handlers set); killed at the end if still running."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, PYTHONPATH=str(root))
    cmd = [sys.executable, "-m", "analyzer", "watch", str(inbox), "--out", str(tmp_path / "r")]
    # (SIGHUP as a terminal's session has it, unless the test says otherwise: a suite run
    # under nohup passed its ignored SIGHUP on, and the watcher keeps an ignored one)
    popen.setdefault("preexec_fn", lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL))
    proc = subprocess.Popen(cmd, env=env, stderr=subprocess.PIPE, text=True, cwd=tmp_path, **popen)
    try:
        assert proc.stderr is not None
        lines = []
        end = time.monotonic() + LIMIT_S
        while time.monotonic() < end:  # (the start line: its signal handlers are set)
            line = proc.stderr.readline()
            lines.append(line)
            if "watching" in line or not line:
                break
        assert "watching" in lines[-1], lines
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_sighup_stops_the_watcher_as_sigterm_does(tmp_path: Path) -> None:
    """SIGHUP (a terminal closed) ended the watcher with 129 and no word; it is a clean
    stop now: its "stopped" line, exit 0."""
    with _watching(tmp_path) as proc:
        proc.send_signal(signal.SIGHUP)
        rest = proc.communicate(timeout=LIMIT_S)[1]
    assert proc.returncode == 0, (proc.returncode, rest)
    assert rest.rstrip().endswith("analyzer watch: stopped"), rest


def test_a_watcher_under_nohup_goes_on_after_a_hang_up(tmp_path: Path) -> None:
    """``nohup analyzer watch ...``: SIGHUP ignored when the watcher starts stays ignored
    (the terminal closed, the watcher goes on), as ``run`` keeps it; the SIGHUP handler
    taken above set it anew, and nohup's watcher stopped with its terminal."""
    nohup = {"preexec_fn": lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN)}
    with _watching(tmp_path, **nohup) as proc:
        proc.send_signal(signal.SIGHUP)
        with pytest.raises(subprocess.TimeoutExpired):
            proc.wait(timeout=2.0)  # (still watching)
        proc.send_signal(signal.SIGTERM)
        rest = proc.communicate(timeout=LIMIT_S)[1]
    assert proc.returncode == 0, (proc.returncode, rest)
    assert rest.rstrip().endswith("analyzer watch: stopped"), rest

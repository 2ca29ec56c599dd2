"""A watcher killed outright (``kill -9``, the OOM killer), and a watcher whose loop must
not wait for a big archive's hash (:mod:`analyzer.watch`).

Every wait has a hard timeout; processes and threads started here are ended in
``finally`` blocks."""

from __future__ import annotations

import contextlib
import errno
import inspect
import json
import logging
import multiprocessing
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from analyzer import watch as watch_module
from analyzer.findings import sha256_of
from analyzer.options import RunOptions
from analyzer.watch import WatchSettings, watch
from analyzer.watch_inbox import ReadyArchive, signature
from analyzer.watch_index import Ledger, Record, Verdict, publish
from analyzer.writers import write_archive

START = "2026-01-01T00:00:00Z"
LIMIT_S = 60.0
"""Hard limit of a wait in these tests (a first analysis starts the fork server, which
imports the pipeline: seconds, more on a loaded machine)."""


def _sleeping_analysis(inputs: list[str], options: RunOptions, out: Path, work: Path) -> int:
    """An analysis that takes a minute (its outputs half written)."""
    (out / "findings.json").write_text("{")
    time.sleep(60)
    return 0


def _analysis_process(out: Path, work: Path, watcher: int) -> None:
    """The body of an analysis process of the watcher of pid ``watcher``, with an
    analysis that would take a minute."""
    watch_module.analysis_into = _sleeping_analysis  # type: ignore[assignment]
    args: list[Any] = [["x.csv"], RunOptions(), str(out), str(work)]
    if "watcher" in inspect.signature(watch_module._analyze_into).parameters:
        args.append(watcher)
    watch_module._analyze_into(*args)


def test_an_analysis_ends_with_its_watcher_killed_outright(tmp_path: Path) -> None:
    """A watcher killed by SIGKILL cannot stop its analyses (fork server children): each
    one ends by itself once the watcher is gone, and removes its hidden folder of REPORTS
    and its scratch space. Before, it went on for the whole analysis and then wrote its
    report into a ``.tmp-`` folder that a restarted watcher had already cleared away."""
    out, work = tmp_path / ".tmp-x.csv-0000", tmp_path / "work"
    out.mkdir()
    work.mkdir()
    watcher = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    ctx = multiprocessing.get_context("fork")
    analysis = ctx.Process(target=_analysis_process, args=(out, work, watcher.pid), daemon=True)
    try:
        analysis.start()
        time.sleep(0.5)  # (its watch begun)
        assert analysis.is_alive()
        watcher.kill()
        watcher.wait()
        analysis.join(LIMIT_S / 4)
        assert not analysis.is_alive(), "the analysis went on after its watcher was killed"
        assert not out.exists() and not work.exists()
    finally:
        watcher.kill()
        watcher.wait()
        if analysis.is_alive():
            analysis.kill()
        analysis.join()


# --------------------------------------------------------------------------- big archives


def _archive(path: Path, n: int) -> Path:
    t = np.arange(n, dtype=np.int64) * 10_000_000
    rng = np.random.default_rng(n)
    write_archive(
        path, "csv", t, {"a": rng.normal(size=n), "b": rng.normal(size=n)}, start_iso=START
    )
    return path


def _recorded(reports: Path) -> set[str]:
    try:
        return set(json.loads((reports / ".watch-state.json").read_text())["archives"])
    except (OSError, ValueError, KeyError):
        return set()


def _wait_recorded(reports: Path, name: str) -> None:
    """Wait (up to :data:`LIMIT_S`) until ``name`` has a record in REPORTS' state file."""
    deadline = time.monotonic() + LIMIT_S
    while name not in _recorded(reports) and time.monotonic() < deadline:
        time.sleep(0.05)


@pytest.fixture
def big_and_small(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    """INBOX with ``a_big.csv`` (first in order) and ``b_small.csv``, the big one above
    the size hashed on the loop."""
    inbox, reports = tmp_path / "inbox", tmp_path / "reports"
    inbox.mkdir()
    big, small = _archive(inbox / "a_big.csv", 4000), _archive(inbox / "b_small.csv", 400)
    assert small.stat().st_size < big.stat().st_size
    monkeypatch.setattr(watch_module, "INLINE_HASH_BYTES", small.stat().st_size, raising=False)
    return inbox, reports


def _slow_hash_of(name: str, until: threading.Event, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Make the hash of archive ``name`` last until ``until`` is set (at most
    :data:`LIMIT_S`); returns the list the hashed archives' first paths go to, as
    each hash begins."""
    real = watch_module.hash_archive
    begun: list[str] = []

    def slow(paths: Sequence[Path], *args: Any, **kw: Any) -> Any:
        begun.append(paths[0].name)
        if paths[0].name == name:
            until.wait(LIMIT_S)
        return real(paths, *args, **kw)

    monkeypatch.setattr(watch_module, "hash_archive", slow)
    return begun


def _run(inbox: Path, reports: Path, stop: threading.Event) -> threading.Thread:
    settings = WatchSettings(inbox=inbox, reports=reports, settle=0.2, poll=0.05, once=True)
    thread = threading.Thread(target=watch, args=(settings, RunOptions()), kwargs={"stop": stop})
    thread.start()
    return thread


def test_a_small_archive_is_not_held_up_by_a_big_ones_hash(
    big_and_small: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A big archive is hashed off the watcher's loop: a small one dropped with it is
    analyzed and recorded while the big one is still being hashed (before, the loop
    was in the big one's hash, and every other archive waited for it: a 2 GB file held
    a small one up 10-16 s)."""
    inbox, reports = big_and_small
    small_done = threading.Event()
    begun = _slow_hash_of("a_big.csv", small_done, monkeypatch)
    stop = threading.Event()
    thread = _run(inbox, reports, stop)
    try:
        _wait_recorded(reports, "b_small.csv")
        assert "a_big.csv" in begun
        assert "b_small.csv" in _recorded(reports), "the small archive waited for the big hash"
        assert "a_big.csv" not in _recorded(reports)
        small_done.set()
        thread.join(LIMIT_S)
        assert not thread.is_alive()
        assert _recorded(reports) == {"a_big.csv", "b_small.csv"}  # (the same results)
    finally:
        small_done.set()
        stop.set()
        thread.join(LIMIT_S)


def test_the_stop_signal_does_not_wait_for_a_big_archives_hash(
    big_and_small: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Stopping while a big archive is hashed: the watcher stops at once (the hash is
    abandoned, the archive analyzed on the next start), where it waited for the hash."""
    inbox, reports = big_and_small
    (inbox / "b_small.csv").unlink()
    never = threading.Event()
    begun = _slow_hash_of("a_big.csv", never, monkeypatch)
    stop = threading.Event()
    thread = _run(inbox, reports, stop)
    try:
        deadline = time.monotonic() + LIMIT_S / 2
        while "a_big.csv" not in begun and time.monotonic() < deadline:
            time.sleep(0.02)
        assert "a_big.csv" in begun
        stop.set()
        thread.join(5.0)
        assert not thread.is_alive(), "the stop waited for the hash"
        assert "a_big.csv" not in _recorded(reports)
    finally:
        never.set()
        stop.set()
        thread.join(LIMIT_S)


MCAP_MAGIC = b"\x89MCAP0\r\n"


@pytest.fixture
def recorded_and_unfinished(
    big_and_small: tuple[Path, Path],
) -> tuple[Path, Path, Path]:
    """INBOX with ``a_big.csv`` replaced by ``a_big.mcap``: an MCAP recording still being
    written (no closing magic), big, under the name of an archive recorded with other
    content, so that the inbox tracker asks whether it is recorded already; and
    ``b_small.csv``."""
    inbox, reports = big_and_small
    big = inbox / "a_big.mcap"
    big.write_bytes(MCAP_MAGIC + (inbox / "a_big.csv").read_bytes())
    (inbox / "a_big.csv").unlink()
    ledger = Ledger(reports)
    ledger.records[big.name] = Record(
        name=big.name,
        sha256="1" * 64,
        verdict=Verdict.ERROR,
        report=f"{big.name}/error.txt",
        inputs=[str(big)],
        processed="2026-01-01T00:00:00Z",
        analysis_s=1.0,
        signature=[[big.name, 100, 0]],
        options=watch_module.options_fingerprint(RunOptions()),
    )
    (reports / big.name).mkdir(parents=True)
    (reports / big.name / "error.txt").write_text("truncated")
    ledger.save_state()
    return inbox, reports, big


def test_a_small_archive_is_not_held_up_by_the_hash_of_an_unfinished_big_one(
    recorded_and_unfinished: tuple[Path, Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A big archive that looks unfinished under a recorded name is hashed to learn
    whether it is that record's content (then it is not waited for): off the loop, so a
    small archive dropped with it is analyzed meanwhile (before, the loop hashed it: a
    2 GB recording held a small one up 29 s, and a SIGTERM 20 s). Its record stays."""
    inbox, reports, big = recorded_and_unfinished
    small_done = threading.Event()
    begun = _slow_hash_of(big.name, small_done, monkeypatch)
    stop = threading.Event()
    thread = _run(inbox, reports, stop)
    try:
        _wait_recorded(reports, "b_small.csv")
        assert big.name in begun
        assert "b_small.csv" in _recorded(reports), "the small archive waited for the big hash"
        small_done.set()
        stop.set()
        thread.join(5.0)
        assert not thread.is_alive()
        state = json.loads((reports / ".watch-state.json").read_text())["archives"]
        assert state[big.name]["sha256"] == "1" * 64  # (other content, still unfinished)
    finally:
        small_done.set()
        stop.set()
        thread.join(LIMIT_S)


def test_the_stop_signal_does_not_wait_for_the_hash_of_an_unfinished_big_archive(
    recorded_and_unfinished: tuple[Path, Path, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Stopping while the tracker's question about a big unfinished archive is being
    hashed: the watcher stops at once, where it waited for the hash."""
    inbox, reports, big = recorded_and_unfinished
    (inbox / "b_small.csv").unlink()
    never = threading.Event()
    begun = _slow_hash_of(big.name, never, monkeypatch)
    stop = threading.Event()
    thread = _run(inbox, reports, stop)
    try:
        deadline = time.monotonic() + LIMIT_S / 2
        while big.name not in begun and time.monotonic() < deadline:
            time.sleep(0.02)
        assert big.name in begun
        stop.set()
        thread.join(5.0)
        assert not thread.is_alive(), "the stop waited for the hash"
    finally:
        never.set()
        stop.set()
        thread.join(LIMIT_S)


def test_a_big_unfinished_archive_recorded_with_its_content_is_not_waited_for(
    recorded_and_unfinished: tuple[Path, Path, Path], caplog: pytest.LogCaptureFixture
) -> None:
    """The same decision as when it was hashed on the loop: a big archive that looks
    unfinished but is recorded with this content (touched since: its signature differs)
    is found analyzed already once its hash is there, and ``--once`` ends without waiting
    ``--wait-unfinished`` for it, or analyzing it again."""
    inbox, reports, big = recorded_and_unfinished
    (inbox / "b_small.csv").unlink()
    state_file = reports / ".watch-state.json"
    doc = json.loads(state_file.read_text())
    doc["archives"][big.name]["sha256"] = sha256_of(big)
    state_file.write_text(json.dumps(doc))
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    settings = WatchSettings(inbox=inbox, reports=reports, settle=0.2, poll=0.05, once=True)
    assert watch(settings, RunOptions()) == 2  # (its record an error: left in INBOX)
    said = [r.getMessage() for r in caplog.records]
    assert not [line for line in said if "waiting up to" in line]
    assert any("1 archive found analyzed already" in line for line in said)
    assert json.loads(state_file.read_text())["archives"][big.name]["sha256"] == sha256_of(big)


def _runner(inbox: Path, reports: Path, monkeypatch: pytest.MonkeyPatch) -> Any:
    """A watcher's runner over INBOX and REPORTS, its loop driven by the test."""
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    settings = WatchSettings(inbox=inbox, reports=reports, settle=0.2, poll=0.05)
    return watch_module._Runner(settings, RunOptions(), Ledger.load(reports), threading.Event())


def _stoppable_hashes(monkeypatch: pytest.MonkeyPatch) -> list[threading.Event]:
    """Make every hash wait (at most :data:`LIMIT_S`) until it is told to stop; returns
    an event per hash begun, set once it is told."""
    told: list[threading.Event] = []

    def held(paths: Sequence[Path], root: Path, head: Any = None, cancel: Any = None) -> Any:
        told.append(threading.Event())
        if cancel is not None and cancel.wait(LIMIT_S):
            told[-1].set()
        raise watch_module.HashCancelled(str(paths[0]))

    monkeypatch.setattr(watch_module, "hash_archive", held)
    return told


@pytest.mark.parametrize("then", ["deleted", "changed"])
def test_the_hash_of_an_archive_deleted_or_changed_since_it_was_asked_about_is_dropped(
    recorded_and_unfinished: tuple[Path, Path, Path],
    monkeypatch: pytest.MonkeyPatch,
    then: str,
) -> None:
    """The tracker's question about a big unfinished archive is being hashed, and the
    archive is deleted from INBOX (or changed, and ready): its hash is stopped, and the
    watcher keeps nothing of it. Before, a deleted archive's entry stayed for the
    watcher's life (a slow leak), and the hash of content changed since went on to its
    end (seconds per GB of a thread's reads, for nothing)."""
    inbox, reports, big = recorded_and_unfinished
    (inbox / "b_small.csv").unlink()
    told = _stoppable_hashes(monkeypatch)
    runner = _runner(inbox, reports, monkeypatch)
    try:
        archive = ReadyArchive(big.name, (big,), signature([big], inbox), "unfinished")
        assert runner.recorded(archive) is None  # (asked: being hashed)
        if then == "deleted":
            big.unlink()
            runner.pump()
            assert big.name not in runner.asked
        else:
            with big.open("ab") as f:
                f.write(MCAP_MAGIC)
            runner.offer(ReadyArchive(big.name, (big,), signature([big], inbox)))
            runner.pump()
        assert told and told[0].wait(LIMIT_S / 4), "the hash went on"
    finally:
        runner.hasher.close()


# --------------------------------------------------------------------------- kept aside


class _Killed(BaseException):
    """The watcher killed at this point (nothing after it runs)."""


def _recorded_once(reports: Path) -> Ledger:
    """REPORTS with one published record, ``a.csv``."""
    (reports / "a.csv").mkdir(parents=True)
    (reports / "a.csv" / "report.html").write_text("first")
    ledger = Ledger(reports)
    ledger.records["a.csv"] = Record(
        name="a.csv",
        sha256="1" * 64,
        verdict=Verdict.NO_FAULT,
        report="a.csv/report.html",
        inputs=["a.csv"],
        processed="2026-01-01T00:00:00Z",
        analysis_s=1.0,
    )
    ledger.save_state()
    return ledger


def test_a_record_kept_aside_keeps_its_folder(tmp_path: Path) -> None:
    """New content under a recorded name: the earlier record is kept aside under a new
    name (``a-1.csv``) and its report folder stays where it was announced (``a.csv/``),
    so keeping it aside is one write of the state (a watcher killed at it leaves the
    record under its old name or its new one, its folder where it was), and the new
    content's report goes to a folder of its own (before, the folder was renamed to
    ``a-1.csv/`` and the new report took ``a.csv/``, which the earlier lines had
    announced)."""
    reports = tmp_path / "reports"
    ledger = _recorded_once(reports)
    assert ledger.keep_aside("a.csv") == "a-1.csv"
    again = Ledger.load(reports)
    assert again.tidy() == []
    (rec,) = again.records.values()
    assert rec.report == "a.csv/report.html" and (reports / rec.report).read_text() == "first"
    assert rec.dropped_as == "a.csv"
    scratch = reports / ".tmp-new"
    scratch.mkdir()
    (scratch / "report.html").write_text("second")
    final = publish(
        scratch, reports, "a.csv", again.new_folder("a.csv"), again.folders_except("a.csv")
    )
    assert final.name == "a-1.csv" and (final / "report.html").read_text() == "second"
    assert (reports / rec.report).read_text() == "first"


def test_the_next_start_says_what_it_removed_of_a_killed_watcher(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """The hidden folders a killed watcher left in REPORTS are removed at the next start,
    each with a line saying so (it was silent: a report folder seemingly vanished)."""
    reports = tmp_path / "reports"
    ledger = _recorded_once(reports)
    (reports / ".tmp-b.csv-0123abcd").mkdir()
    (reports / ".tmp-b.csv-0123abcd" / "findings.json").write_text("{}")
    (reports / ".old-a.csv-4567cdef").mkdir()
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    assert ledger.tidy() == []
    assert sorted(p.name for p in reports.iterdir()) == [".watch-state.json", "a.csv"]
    said = sorted(r.getMessage() for r in caplog.records)
    assert said == [
        ".old-a.csv-4567cdef: removed: left by a watcher stopped by force (a report it was "
        "replacing)",
        ".tmp-b.csv-0123abcd: removed: left by a watcher stopped by force (an analysis it "
        "had not recorded: its archive is analyzed again)",
    ]


# --------------------------------------------------------------------------- moves


def _quick_analysis(inputs: list[str], options: RunOptions, out_dir: Path, work: Path) -> int:
    """``analysis_into`` without the analysis: no fault, at once; each call counted in
    ``analyses.txt`` beside REPORTS."""
    with (out_dir.parent.parent / "analyses.txt").open("a") as f:
        f.write(f"{sorted(Path(p).name for p in inputs)}\n")
    (out_dir / "findings.json").write_text(
        json.dumps({"faults": [], "start": None, "duration_s": 1.0, "screen": None})
    )
    (out_dir / "report.html").write_text("<html></html>")
    return 0


def _killed_in_move(stage: str, inbox: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Kill the watcher (:class:`_Killed`) in its move of INBOX's files: ``copying``, in
    the second file's copy to the other file system (half written); ``renamed``, once
    every copy is in place, before INBOX changes; ``removed``, once the first source is
    removed; ``between``, between two renames on the same file system."""
    calls: list[str] = []
    if stage == "copying":
        real_copy = watch_module._copy_file

        def copy(src: Path, dst: Path, cancel: threading.Event) -> None:
            calls.append(str(src))
            if len(calls) == 2:
                dst.write_bytes(src.read_bytes()[:100])
                raise _Killed
            real_copy(src, dst, cancel)

        monkeypatch.setattr(watch_module, "_copy_file", copy)
    elif stage == "between":
        real_rename = watch_module._rename_new

        def rename(src: Path, dst: Path, *rest: Any) -> None:
            if src.parent == inbox:
                calls.append(str(src))
                if len(calls) == 2:
                    raise _Killed
            real_rename(src, dst, *rest)

        monkeypatch.setattr(watch_module, "_rename_new", rename)
    else:
        real_unlink = Path.unlink

        def unlink(self: Path, missing_ok: bool = False) -> None:
            if self.parent == inbox:
                calls.append(str(self))
                if stage == "renamed" or len(calls) == 2:
                    raise _Killed
            real_unlink(self, missing_ok=missing_ok)

        monkeypatch.setattr(Path, "unlink", unlink)


def _two_parts(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, dict[str, bytes]]:
    """INBOX (``tmp_path/in/inbox``) with an archive of two files, ``A_part0.csv`` and
    ``A_part1.csv``, and their contents; analyses quick and counted (:func:`_analyses`)."""
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    monkeypatch.setattr(watch_module, "analysis_into", _quick_analysis)
    inbox = tmp_path / "in" / "inbox"
    inbox.mkdir(parents=True)
    files = [_archive(inbox / f"A_part{i}.csv", 300 + i) for i in range(2)]
    return inbox, {f.name: f.read_bytes() for f in files}


@contextlib.contextmanager
def _done_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, other: bool) -> Iterator[Path]:
    """A ``--done`` folder; ``other``: on another file system than INBOX (``/dev/shm``,
    or, where it is the same or missing, a move made by copies as to another one)."""
    shm = Path("/dev/shm")
    if other and (not shm.is_dir() or os.stat(shm).st_dev == os.stat(tmp_path).st_dev):
        monkeypatch.setattr(watch_module, "_other_fs", lambda paths, folder: True)
        shm = tmp_path
    with tempfile.TemporaryDirectory(dir=shm if other else tmp_path) as folder:
        yield Path(folder)


def _settings(tmp_path: Path, done: Path) -> WatchSettings:
    return WatchSettings(
        inbox=tmp_path / "in" / "inbox",
        reports=tmp_path / "in" / "reports",
        settle=0.2,
        poll=0.05,
        once=True,
        done=done,
        group_by=re.compile(r"^(.*)_part[0-9]+\.csv$"),
    )


def _analyses(tmp_path: Path) -> list[str]:
    """The inputs of each analysis made (:func:`_quick_analysis`)."""
    return (tmp_path / "in" / "analyses.txt").read_text().splitlines()


def _state_record(tmp_path: Path) -> dict[str, Any]:
    (rec,) = json.loads((tmp_path / "in" / "reports" / ".watch-state.json").read_text())[
        "archives"
    ].values()
    return rec  # type: ignore[no-any-return]


@pytest.mark.parametrize("stage", ["copying", "renamed", "removed", "between"])
def test_a_move_stopped_by_a_kill_is_ended_by_the_next_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stage: str
) -> None:
    """A watcher killed in the middle of a ``--done`` move of an archive of two files:
    the next start ends the move, with the archive once in ``--done``, under its own
    names, nothing left in INBOX or hidden in ``--done``, the record pointing at the
    files and the archive not analyzed again. Before: a kill in the copies left them in
    ``--done`` for good (hidden ``.partial-`` names, one truncated); once they were in
    place, the archive was moved again beside them (``A_part0-1.csv``); with a source
    removed, or between two renames on one file system, the other file was analyzed
    alone as the archive."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=stage != "between") as done:
        settings = _settings(tmp_path, done)
        undo = pytest.MonkeyPatch()
        _killed_in_move(stage, inbox, undo)
        try:
            with pytest.raises(_Killed):
                watch(settings, RunOptions())
        finally:
            undo.undo()
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        assert {p.name: p.read_bytes() for p in done.iterdir()} == content
        rec = _state_record(tmp_path)
        assert sorted(rec["moved_to"]) == [str(done / name) for name in sorted(content)]
        assert "moving" not in rec
        assert _analyses(tmp_path) == [str(sorted(content))]


def _end(rec: Record, inbox: Path) -> tuple[str, list[str]]:
    """The next start's end of ``rec``'s move (:func:`analyzer.watch._end_move`)."""
    lines = watch_module._moving_lines(rec)
    return watch_module._end_move(rec, inbox, lines, lambda moving: None)


def test_a_kill_before_the_move_began_leaves_nothing_to_end(tmp_path: Path) -> None:
    """A move written to the state and killed before its first copy: nothing to finish
    or remove; a source that is no longer what the record says (dropped again under its
    name since) is left in INBOX, never removed, and a file in its target's place is the
    archive's only where it has the recorded size and mtime."""
    done = tmp_path / "done"
    done.mkdir()
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    source = _archive(inbox / "a.csv", 300)
    st = source.stat()
    rec = Record(
        name="a.csv",
        sha256="1" * 64,
        verdict=Verdict.NO_FAULT,
        report="a.csv/report.html",
        inputs=[str(source)],
        processed="2026-01-01T00:00:00Z",
        analysis_s=1.0,
        signature=[["a.csv", st.st_size, st.st_mtime_ns]],
    )
    copy, target = done / ".partial-a.csv-0123abcd", done / "a.csv"
    rec.moving = [[str(source), str(copy), str(target)]]
    assert _end(rec, inbox) == ("not begun", [])
    assert source.is_file() and not any(done.iterdir())
    target.write_bytes(source.read_bytes())  # (another file of its name: not the archive's)
    assert _end(rec, inbox) == ("not begun", [])
    assert source.is_file() and target.is_file()
    target.unlink()
    shutil.copy2(source, target)  # (its copy in place: finished)
    rec.signature = [["a.csv", st.st_size + 1, st.st_mtime_ns]]  # (not the recorded one)
    assert _end(rec, inbox) == ("changed", [])
    assert source.is_file() and target.is_file()
    rec.signature = [["a.csv", st.st_size, st.st_mtime_ns]]
    assert _end(rec, inbox) == ("finished", [str(target)])
    assert not source.exists() and target.is_file()


def _killed_once_told(monkeypatch: pytest.MonkeyPatch) -> None:
    """Kill the watcher right after it wrote a move to the state file, before the move."""
    real_save = Ledger.save_state

    def save(self: Ledger) -> None:
        real_save(self)
        if any(rec.moving for rec in self.records.values()):
            raise _Killed

    monkeypatch.setattr(Ledger, "save_state", save)


def _killed_at_an_inbox_unlink(n: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Kill the watcher at its ``n``-th removal of a file of INBOX (a source)."""
    real_unlink = Path.unlink
    calls: list[Path] = []

    def unlink(self: Path, missing_ok: bool = False) -> None:
        if self.parent.name == "inbox":
            calls.append(self)
            if len(calls) == n:
                raise _Killed
        real_unlink(self, missing_ok=missing_ok)

    monkeypatch.setattr(Path, "unlink", unlink)


def _run_killed(settings: WatchSettings, kill: Any) -> None:
    """A watcher run killed as ``kill(monkeypatch)`` sets up."""
    undo = pytest.MonkeyPatch()
    kill(undo)
    try:
        with pytest.raises(_Killed):
            watch(settings, RunOptions())
    finally:
        undo.undo()


OTHER = b"time,a\nanother process's file\n"


@pytest.mark.parametrize("other", [True, False], ids=["copies", "renames"])
def test_a_file_dropped_under_a_planned_name_is_not_taken_for_the_archives(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, other: bool
) -> None:
    """Killed once its move was written to the state, before it began; another process
    puts a file of its own under the first planned name. The next start finds the move
    not begun and moves the archive again, whole, beside that file. Before, it took that
    file for the archive's first part: with copies, ``A_part0.csv`` was removed from
    INBOX with no copy of it anywhere; with renames, it was left alone in INBOX and
    analyzed as the archive."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other) as done:
        settings = _settings(tmp_path, done)
        _run_killed(settings, _killed_once_told)
        (done / "A_part0.csv").write_bytes(OTHER)
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        found = {p.name: p.read_bytes() for p in done.iterdir()}
        assert found == {
            "A_part0.csv": OTHER,
            "A_part0-1.csv": content["A_part0.csv"],
            "A_part1.csv": content["A_part1.csv"],
        }
        rec = _state_record(tmp_path)
        assert sorted(rec["moved_to"]) == [str(done / "A_part0-1.csv"), str(done / "A_part1.csv")]
        assert _analyses(tmp_path) == [str(sorted(content))]
        said = [r.getMessage() for r in caplog.records]
        assert not [line for line in said if "undone" in line]


def test_a_file_renamed_past_a_name_taken_since_is_the_one_recorded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A file dropped under a planned name during the copies: the copy goes to another
    free name, which is written to the state first; killed before INBOX changed, the
    next start finishes the move, and the record names the archive's own files
    (before, it named the other process's file and not ``A_part0-1.csv``)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = _settings(tmp_path, done)

        def kill(undo: pytest.MonkeyPatch) -> None:
            real_copy, calls = watch_module._copy_file, []

            def copy(src: Path, dst: Path, cancel: threading.Event) -> None:
                calls.append(src)
                if len(calls) == 2:
                    (done / "A_part0.csv").write_bytes(OTHER)
                real_copy(src, dst, cancel)

            undo.setattr(watch_module, "_copy_file", copy)
            _killed_at_an_inbox_unlink(1, undo)

        _run_killed(settings, kill)
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        assert (done / "A_part0.csv").read_bytes() == OTHER
        rec = _state_record(tmp_path)
        assert sorted(rec["moved_to"]) == [str(done / "A_part0-1.csv"), str(done / "A_part1.csv")]
        assert (done / "A_part0-1.csv").read_bytes() == content["A_part0.csv"]
        assert _analyses(tmp_path) == [str(sorted(content))]


def _killed_with_the_copies_taken_away(settings: WatchSettings, done: Path, away: Path) -> None:
    """A watcher killed once the first source of its move was removed; then ``--done``'s
    files taken away to ``away`` (a mount not mounted yet; a downstream job took them)."""
    _run_killed(settings, lambda undo: _killed_at_an_inbox_unlink(2, undo))
    for p in done.iterdir():
        shutil.move(p, away / p.name)


def _mounted_again_and_ended(
    settings: WatchSettings, away: Path, done: Path, content: dict[str, bytes]
) -> None:
    """The copies taken away (:func:`_killed_with_the_copies_taken_away`) put back in
    ``--done``: the next start ends the move, INBOX empty, ``--done`` holding the archive."""
    for p in away.iterdir():  # (mounted)
        shutil.move(p, done / p.name)
    assert watch(settings, RunOptions()) == 0
    assert not any(settings.inbox.iterdir())
    assert {p.name: p.read_bytes() for p in done.iterdir()} == content


def _recorded_with_a_move(tmp_path: Path, moving: Any) -> tuple[Path, Path, Path]:
    """REPORTS with ``a.csv`` recorded once and its state's ``moving`` set to ``moving``
    (as edited by hand), an empty INBOX: the REPORTS, the INBOX and the state file."""
    reports, inbox = tmp_path / "reports", tmp_path / "inbox"
    inbox.mkdir()
    _recorded_once(reports)
    state = reports / ".watch-state.json"
    doc = json.loads(state.read_text())
    doc["archives"]["a.csv"]["moving"] = moving
    state.write_text(json.dumps(doc))
    return reports, inbox, state


def test_a_move_whose_removed_part_is_not_found_is_kept_not_undone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """Killed once the first source was removed; before the next start, ``--done`` no
    longer holds the copies (a mount not mounted yet; a downstream job took them). The
    start cannot end the move: it says so, keeps it, and leaves ``A_part1.csv`` in
    INBOX, not analyzed; once the files are back, the next start finishes it. Before,
    the move was said undone and ``A_part1.csv`` analyzed alone as the archive."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    away = tmp_path / "away"
    away.mkdir()
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = _settings(tmp_path, done)
        _killed_with_the_copies_taken_away(settings, done, away)
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        watch(settings, RunOptions())
        said = [r.getMessage() for r in caplog.records]
        assert not [line for line in said if "undone" in line]
        assert [line for line in said if "cannot be ended" in line]
        assert [p.name for p in inbox.iterdir()] == ["A_part1.csv"]
        assert _analyses(tmp_path) == [str(sorted(content))]
        assert _state_record(tmp_path)["moving"]
        _mounted_again_and_ended(settings, away, done, content)
        rec = _state_record(tmp_path)
        assert "moving" not in rec
        assert sorted(rec["moved_to"]) == [str(done / name) for name in sorted(content)]
        assert _analyses(tmp_path) == [str(sorted(content))]


@pytest.mark.parametrize("moving", [[["only a source"]], "a line", [[1, 2, 3]]])
def test_a_move_edited_by_hand_in_the_state_is_ignored(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, moving: Any
) -> None:
    """A state file edited by hand whose move cannot be read: the start says so and
    goes on without it (it stopped with an IndexError at every start)."""
    reports, inbox, state = _recorded_with_a_move(tmp_path, moving)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    settings = WatchSettings(inbox=inbox, reports=reports, settle=0.2, poll=0.05, once=True)
    assert watch(settings, RunOptions()) == 0
    assert [r for r in caplog.records if "cannot be read" in r.getMessage()]
    assert "moving" not in json.loads(state.read_text())["archives"]["a.csv"]


def test_a_move_of_relative_paths_in_the_state_is_ignored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A hand-edited move of relative paths: ignored with a warning, nothing of the
    watcher's folder touched. Before, it was read as paths in the watcher's working
    folder: a ``.partial-`` file there was removed as the move's copy."""
    reports, inbox, state = _recorded_with_a_move(
        tmp_path, [["a.csv", ".partial-a.csv-0123abcd", "a.csv"]]
    )
    monkeypatch.chdir(tmp_path)
    (tmp_path / ".partial-a.csv-0123abcd").write_text("someone's")
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    settings = WatchSettings(inbox=inbox, reports=reports, settle=0.2, poll=0.05, once=True)
    assert watch(settings, RunOptions()) == 0
    assert [r for r in caplog.records if "cannot be read" in r.getMessage()]
    assert (tmp_path / ".partial-a.csv-0123abcd").read_text() == "someone's"
    assert "moving" not in json.loads(state.read_text())["archives"]["a.csv"]


def test_a_move_kept_for_the_next_start_outlives_its_report_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A move the start could not end (a part gone from INBOX, not in ``--done``), and
    the record's report folder deleted by hand: the record and its move are kept, what
    is left in INBOX is not analyzed alone; once the part is back, the move is ended.
    Before, the start forgot the record with its move, and analyzed ``A_part1.csv``
    alone as the archive ``A``."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    away = tmp_path / "away"
    away.mkdir()
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = _settings(tmp_path, done)
        _killed_with_the_copies_taken_away(settings, done, away)
        shutil.rmtree(tmp_path / "in" / "reports" / "A")
        watch(settings, RunOptions())
        assert [p.name for p in inbox.iterdir()] == ["A_part1.csv"]
        assert _analyses(tmp_path) == [str(sorted(content))]
        assert _state_record(tmp_path)["moving"]
        _mounted_again_and_ended(settings, away, done, content)
        assert _analyses(tmp_path) == [str(sorted(content))]


def test_a_move_that_cannot_be_ended_is_kept_for_the_next_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Killed in the copies; the next start cannot remove them (an OSError): it keeps
    the move, and the archive stays in INBOX, not moved again; the start after that
    undoes it. Before, the move was forgotten: the copies stayed for good, and the
    archive was moved beside them."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = _settings(tmp_path, done)
        _run_killed(settings, lambda undo: _killed_in_move("copying", inbox, undo))
        real_remove = watch_module._remove

        def refused(path: Path, strict: bool = False) -> None:
            if path.name.startswith(".partial-"):
                raise PermissionError(13, "Permission denied", str(path))
            real_remove(path, strict)

        with monkeypatch.context() as m:
            m.setattr(watch_module, "_remove", refused)
            watch(settings, RunOptions())
        assert _state_record(tmp_path)["moving"]
        assert {p.name: p.read_bytes() for p in inbox.iterdir()} == content
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        assert {p.name: p.read_bytes() for p in done.iterdir()} == content
        assert _analyses(tmp_path) == [str(sorted(content))]


def test_a_move_not_written_to_the_state_first_is_said(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """REPORTS full when a move is written to the state before it begins: the move goes
    on, with one line saying that it is not protected from a kill (it was silent)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    real_save = Ledger.save_state

    def save(self: Ledger) -> None:
        if any(rec.moving for rec in self.records.values()):
            raise OSError(28, "No space left on device")
        real_save(self)

    monkeypatch.setattr(Ledger, "save_state", save)
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        assert {p.name: p.read_bytes() for p in done.iterdir()} == content
    said = [r.getMessage() for r in caplog.records if "not in the state file" in r.getMessage()]
    assert len(said) == 1, said


MORE = b"9.99,1.0,1.0\n"
"""A row the writer appends to ``A_part1.csv`` while its copy is made."""


def _killed_in_a_changing_copy(stage: str, inbox: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The writer appends to ``A_part1.csv`` as it is copied, and the watcher is killed:
    ``copying``, in that copy (half written); ``removed``, once the loop saw the change
    and removed the copies, before the move's end was written to the state file."""
    real_copy = watch_module._copy_file
    calls: list[Path] = []

    def copy(src: Path, dst: Path, cancel: threading.Event) -> None:
        calls.append(src)
        if len(calls) == 2:
            with (inbox / "A_part1.csv").open("ab") as f:
                f.write(MORE)
            if stage == "copying":
                dst.write_bytes(src.read_bytes()[:100])
                raise _Killed
        real_copy(src, dst, cancel)

    monkeypatch.setattr(watch_module, "_copy_file", copy)
    if stage == "removed":
        real_save = Ledger.save_state
        moved: list[bool] = []

        def save(self: Ledger) -> None:
            rec = self.records.get("A")
            if rec is not None and rec.moving:
                moved.append(True)
            elif moved:  # (the move cleared: killed before it is written)
                raise _Killed
            real_save(self)

        monkeypatch.setattr(Ledger, "save_state", save)


@pytest.mark.parametrize("stage", ["copying", "removed"])
def test_a_move_killed_while_the_archive_changed_is_undone(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
    stage: str,
) -> None:
    """Killed while a writer appended to the archive during its copy to ``--done``: the
    next start undoes the move (nothing in place, every source still in INBOX: before
    the point of no return), says so, and the archive is analyzed again and moved with
    what was appended. Before, the move was kept for good ("cannot be ended": a copy
    truncated or gone, its source not as recorded), the archive held in INBOX, never
    analyzed again, until a file of it was removed by hand."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = _settings(tmp_path, done)
        _run_killed(settings, lambda undo: _killed_in_a_changing_copy(stage, inbox, undo))
        assert _state_record(tmp_path)["moving"]
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        assert watch(settings, RunOptions()) == 0
        said = [r.getMessage() for r in caplog.records if "stopped by force" in r.getMessage()]
        assert len(said) == 1 and "undone" in said[0] and "changed" in said[0], said
        assert not any(inbox.iterdir())
        found = {p.name: p.read_bytes() for p in done.iterdir()}
        assert found == {**content, "A_part1.csv": content["A_part1.csv"] + MORE}
        assert _analyses(tmp_path) == [str(sorted(content))] * 2
        rec = _state_record(tmp_path)
        assert "moving" not in rec
        assert sorted(rec["moved_to"]) == [str(done / name) for name in sorted(content)]


def test_a_folder_part_removed_by_its_move_is_not_taken_for_a_changed_one(
    tmp_path: Path,
) -> None:
    """A folder archive's move killed part-way through the removal of its source, its
    copy no longer found in ``--done`` (a mount not mounted yet): what is left of the
    folder (some of its files, as recorded) is not the archive changed, so the move is
    kept, not undone (which would analyze the rest alone as the archive)."""
    inbox, done = tmp_path / "inbox", tmp_path / "done"
    source = inbox / "m"
    source.mkdir(parents=True)
    for name in ("a.csv", "b.csv"):
        _archive(source / name, 300)
    rec = Record(
        name="m",
        sha256="1" * 64,
        verdict=Verdict.NO_FAULT,
        report="m/report.html",
        inputs=[str(source)],
        processed=START,
        analysis_s=1.0,
        signature=[list(s) for s in signature([source], inbox)],
    )
    rec.moving = [[str(source), str(done / ".partial-m-0123abcd"), str(done / "m")]]
    (source / "a.csv").unlink()
    assert _end(rec, inbox) == ("kept", [])
    assert [p.name for p in source.iterdir()] == ["b.csv"]


# ------------------------------------------------------- a move by renames refused part-way


def _three_parts(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, bytes]:
    """:func:`_two_parts` with a third file, ``A_part2.csv``; the contents by name."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    third = _archive(inbox / "A_part2.csv", 302)
    return {**content, third.name: third.read_bytes()}


def _refused(
    name: str,
    inbox: Path,
    monkeypatch: pytest.MonkeyPatch,
    meanwhile: Any = None,
    back: Any = None,
) -> None:
    """Every rename of INBOX's ``name`` out of it refused (EPERM: another user's file in
    a sticky INBOX), ``meanwhile()`` called before the first refusal; ``back(target)``
    called before each rename back into INBOX."""
    real_rename = watch_module._rename_new
    refused: list[Path] = []

    def rename(src: Path, dst: Path, *rest: Any) -> None:
        if src.parent == inbox and src.name == name:
            if not refused and meanwhile is not None:
                meanwhile()
            refused.append(src)
            raise PermissionError(1, "Operation not permitted", str(src))
        if dst.parent == inbox and back is not None:
            back(src)
        real_rename(src, dst, *rest)

    monkeypatch.setattr(watch_module, "_rename_new", rename)


@pytest.mark.parametrize("refused", ["A_part1.csv", "A_part2.csv"], ids=["second", "last"])
def test_a_move_by_renames_refused_part_way_is_undone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, refused: str
) -> None:
    """A ``--group-by`` archive of three files whose second (or last) rename into
    ``--done`` (the same file system) is refused: the files renamed already go back to
    INBOX, the archive stays whole there, recorded once, its move not in the state, one
    line naming the cause. Before, they stayed in ``--done`` and the rest was analyzed
    alone as the archive (the first result kept aside as ``A-1``, its ``moved_to``
    empty)."""
    content = _three_parts(tmp_path, monkeypatch)
    inbox = tmp_path / "in" / "inbox"
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        _refused(refused, inbox, monkeypatch)
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        assert watch(_settings(tmp_path, done), RunOptions()) == 0
        assert {p.name: p.read_bytes() for p in inbox.iterdir()} == content
        assert not any(done.iterdir())
        rec = _state_record(tmp_path)
        assert rec["moved_to"] == [] and "moving" not in rec
        assert _analyses(tmp_path) == [str(sorted(content))]
        said = [r.getMessage() for r in caplog.records if "not moved" in r.getMessage()]
        assert said == [
            f"A: not moved to {done} (it stays in INBOX): {inbox / refused}: Operation not "
            "permitted"
        ]


def test_a_move_refused_part_way_whose_inbox_name_was_taken_is_not_undone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """The move refused part-way, but another file dropped under the first file's name
    in INBOX meanwhile: nothing is put back (all or none), the move stays in the state
    file and the rest in INBOX, not analyzed, said in one line naming the name taken;
    the next start (the rename allowed) ends the move, and the new file is analyzed
    alone. Before, the other files went back, and the new file was analyzed with them
    as the archive (the first file left in ``--done``)."""
    content = _three_parts(tmp_path, monkeypatch)
    inbox = tmp_path / "in" / "inbox"
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = _settings(tmp_path, done)
        undo = pytest.MonkeyPatch()
        _refused(
            "A_part1.csv",
            inbox,
            undo,
            meanwhile=lambda: (inbox / "A_part0.csv").write_bytes(OTHER),
        )
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        try:
            assert watch(settings, RunOptions()) == 0
        finally:
            undo.undo()
        assert {p.name: p.read_bytes() for p in done.iterdir()} == {
            "A_part0.csv": content["A_part0.csv"]
        }
        assert {p.name: p.read_bytes() for p in inbox.iterdir()} == {
            **content,
            "A_part0.csv": OTHER,
        }
        assert _analyses(tmp_path) == [str(sorted(content))]
        rec = _state_record(tmp_path)
        assert rec["moving"] and rec["moved_to"] == []
        said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("A: not")]
        assert said == [
            f"A: not moved to {done}: {inbox / 'A_part1.csv'}: Operation not permitted; not "
            "undone: A_part0.csv in INBOX taken by another file since (the files moved stay "
            "there, the rest in INBOX, not analyzed): the next start ends the move (as one "
            "stopped by force)"
        ]
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        assert {p.name: p.read_bytes() for p in done.iterdir()} == {
            **content,
            "A_part0-1.csv": OTHER,
        }
        assert _analyses(tmp_path) == [str(sorted(content)), str(["A_part0.csv"])]


def _killed_before_the_put_back(settings: Any, inbox: Path) -> None:
    """A watcher killed before it puts the first file of its move back in INBOX, the
    rename of ``A_part1.csv`` refused (:func:`_refused`)."""

    def back(target: Path) -> None:
        raise _Killed

    _run_killed(settings, lambda undo: _refused("A_part1.csv", inbox, undo, back=back))


def test_a_move_killed_while_undone_is_kept_by_the_start_where_an_inbox_name_was_taken(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """Killed before it put the first file of a refused move back in INBOX; another
    file dropped under that file's name there since, and the rename still refused at
    the next start: that start cannot finish the move nor undo it (all or none): the
    move kept, the rest held in INBOX, said in one line naming the name taken, and the
    rest's offer says what holds it and what ends the hold (a start, once the cause is
    mended; it said only "said at the start"). Before, the others went back, and the new
    file was analyzed with them as the archive."""
    content = _three_parts(tmp_path, monkeypatch)
    inbox = tmp_path / "in" / "inbox"
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = _settings(tmp_path, done)

        _killed_before_the_put_back(settings, inbox)
        moving = _state_record(tmp_path)["moving"]
        (inbox / "A_part0.csv").write_bytes(OTHER)
        _refused("A_part1.csv", inbox, monkeypatch)
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        assert watch(settings, RunOptions()) == 0
        assert {p.name: p.read_bytes() for p in inbox.iterdir()} == {
            **content,
            "A_part0.csv": OTHER,
        }
        assert {p.name: p.read_bytes() for p in done.iterdir()} == {
            "A_part0.csv": content["A_part0.csv"]
        }
        assert _analyses(tmp_path) == [str(sorted(content))]
        rec = _state_record(tmp_path)
        assert rec["moving"] == moving and rec["moved_to"] == []
        said = [r.getMessage() for r in caplog.records if "stopped by force" in r.getMessage()]
        assert said == [
            f"A: its move to {done}, stopped by force, cannot be ended: "
            f"{inbox / 'A_part1.csv'}: Operation not permitted; nor undone: A_part0.csv in "
            "INBOX taken by another file since; what is left of it in INBOX is not analyzed, "
            "and the next start tries again",
            f"A: not analyzed: what is left in INBOX of its move to {done}, stopped by force "
            "by an earlier watcher, that this start could not end (said above); left as it "
            "is until a start ends the move: restart the watcher once its cause is mended",
        ]


def test_a_move_whose_file_stays_in_done_is_not_cleared_without_a_list_for_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """:func:`~analyzer.watch._move_all` with no ``kept`` list: a file that cannot go
    back (its name in INBOX taken in the instant it went back) stays in ``--done``, and
    the move's lines are not emptied (the file would be in no record). Before, they
    were emptied though the file was kept."""
    content = _three_parts(tmp_path, monkeypatch)
    inbox = tmp_path / "in" / "inbox"
    done = tmp_path / "done"
    done.mkdir()
    told: list[list[list[str]]] = []

    def back(target: Path) -> None:
        (inbox / target.name).write_bytes(OTHER)

    _refused("A_part1.csv", inbox, monkeypatch, back=back)
    paths = [inbox / name for name in sorted(content)]
    with pytest.raises(PermissionError):
        watch_module._move_all(paths, done, told.append)
    assert {p.name: p.read_bytes() for p in done.iterdir()} == {
        "A_part0.csv": content["A_part0.csv"]
    }
    assert (inbox / "A_part0.csv").read_bytes() == OTHER
    assert told and told[-1]


@pytest.mark.parametrize("when", ["before", "after"])
def test_a_kill_while_a_move_is_undone_is_ended_by_the_next_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, when: str
) -> None:
    """A watcher killed while it puts the first file of a refused move back in INBOX
    (before or after its rename back): the next start ends the move (its rename no
    longer refused), the archive whole in ``--done``, recorded once."""
    content = _three_parts(tmp_path, monkeypatch)
    inbox = tmp_path / "in" / "inbox"
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = _settings(tmp_path, done)

        def kill(undo: pytest.MonkeyPatch) -> None:
            def back(target: Path) -> None:
                if when == "after":
                    target.rename(inbox / target.name)
                raise _Killed

            _refused("A_part1.csv", inbox, undo, back=back)

        _run_killed(settings, kill)
        assert _state_record(tmp_path)["moving"]
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        assert {p.name: p.read_bytes() for p in done.iterdir()} == content
        rec = _state_record(tmp_path)
        assert sorted(rec["moved_to"]) == [str(done / name) for name in sorted(content)]
        assert "moving" not in rec
        assert _analyses(tmp_path) == [str(sorted(content))]


def test_a_move_undone_by_a_killed_watcher_and_still_refused_is_undone_by_the_next_start(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """Killed before it put the first file of a refused move back in INBOX, and the
    rename still refused at the next start: that start cannot finish the move, and undoes
    it (the first file back in INBOX), then moves the archive again (refused, undone,
    said); the archive stays whole in INBOX, its move no longer in the state. Before
    (with no undo at the start), the move was kept, and the rest of the archive held in
    INBOX, at every start while the refusal lasted."""
    content = _three_parts(tmp_path, monkeypatch)
    inbox = tmp_path / "in" / "inbox"
    with _done_folder(tmp_path, monkeypatch, other=False) as done:
        settings = _settings(tmp_path, done)

        _killed_before_the_put_back(settings, inbox)
        assert _state_record(tmp_path)["moving"]
        _refused("A_part1.csv", inbox, monkeypatch)
        caplog.set_level(logging.INFO, logger="analyzer.watch")
        assert watch(settings, RunOptions()) == 0
        assert {p.name: p.read_bytes() for p in inbox.iterdir()} == content
        assert not any(done.iterdir())
        rec = _state_record(tmp_path)
        assert rec["moved_to"] == [] and "moving" not in rec
        assert _analyses(tmp_path) == [str(sorted(content))]
        said = [r.getMessage() for r in caplog.records if r.getMessage().startswith("A:")]
        assert said == [
            f"A: its move to {done}, stopped by force, could not be finished (a rename "
            "refused): undone, its files put back in INBOX; it is moved again",
            "A: analyzed already and not moved yet (same content), not analyzed again: no "
            "sensor fault "
            f"found; report: {settings.reports / 'A' / 'report.html'}",
            f"A: not moved to {done} (it stays in INBOX): {inbox / 'A_part1.csv'}: Operation "
            "not permitted",
        ]


def test_a_touched_archive_whose_move_was_killed_is_not_moved_twice(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An archive analyzed by a watcher without ``--done``, then touched (the same
    content, other mtimes), is moved by the next watcher, which is killed once its
    copies are in place, before INBOX changes. The start after finishes that move: the
    archive once in ``--done``. Before, the record kept its analysis's mtimes: the
    files in place were not known as the archive's, the move was taken for one of an
    archive changed since, and the archive was moved again beside them
    (``A_part0-1.csv``, ``A_part1-1.csv``)."""
    inbox, content = _two_parts(tmp_path, monkeypatch)
    with _done_folder(tmp_path, monkeypatch, other=True) as done:
        settings = _settings(tmp_path, done)
        assert watch(replace(settings, done=None), RunOptions()) == 0
        later = time.time() + 60
        for path in inbox.iterdir():
            os.utime(path, (later, later))
        _run_killed(settings, lambda undo: _killed_in_move("renamed", inbox, undo))
        assert watch(settings, RunOptions()) == 0
        assert not any(inbox.iterdir())
        assert {p.name: p.read_bytes() for p in done.iterdir()} == content
        rec = _state_record(tmp_path)
        assert sorted(rec["moved_to"]) == [str(done / name) for name in sorted(content)]
        assert _analyses(tmp_path) == [str(sorted(content))]


def _killed_before_the_new_contents_record(undo: pytest.MonkeyPatch) -> None:
    """Kill the watcher once the report of ``a.csv``'s new content is published (its
    folder said on its line), before its record is written."""
    real_record = Ledger.record

    def record(self: Ledger, rec: Record) -> None:
        if rec.name == "a.csv" and rec.dropped_as is None and rec.folder != "a.csv":
            raise _Killed
        real_record(self, rec)

    undo.setattr(Ledger, "record", record)


def test_a_new_contents_report_folder_published_before_a_kill_is_its_record_s(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """``a.csv`` analyzed, then replaced in INBOX by other content: the earlier record
    is kept aside (``a-1.csv``, its folder ``a.csv/``), and the new content's report
    goes to ``a-1.csv/``, said on its line. A watcher killed between that publish and
    the record: the next start finds the new content recorded, its report in
    ``a-1.csv/`` as said, linked by the index, not analyzed again. Before, ``a-1.csv/``
    was linked by no record and never removed, and the next start analyzed the content
    again into ``a.csv-report/``."""
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    monkeypatch.setattr(watch_module, "analysis_into", _quick_analysis)
    inbox, reports = tmp_path / "in" / "inbox", tmp_path / "in" / "reports"
    inbox.mkdir(parents=True)
    settings = WatchSettings(inbox, reports, settle=0.2, poll=0.05, once=True)
    _archive(inbox / "a.csv", 300)
    assert watch(settings, RunOptions()) == 0
    _archive(inbox / "new.csv", 301)
    os.replace(inbox / "new.csv", inbox / "a.csv")
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    _run_killed(settings, _killed_before_the_new_contents_record)
    (line,) = [r.getMessage() for r in caplog.records if "its report goes to" in r.getMessage()]
    assert f"its report goes to {reports / 'a-1.csv'} " in line, line
    assert watch(settings, RunOptions()) == 0
    records = json.loads((reports / ".watch-state.json").read_text())["archives"]
    assert records["a.csv"]["report"] == "a-1.csv/report.html"
    assert records["a.csv"]["sha256"] == sha256_of(inbox / "a.csv")
    assert "unpublished" not in records["a.csv"]  # (published: the start's tidy says so)
    assert records["a-1.csv"]["report"] == "a.csv/report.html"
    assert sorted(p.name for p in reports.iterdir() if not p.name.startswith(".")) == [
        "a-1.csv",
        "a.csv",
        "index.html",
        "index.json",
    ]
    index = json.loads((reports / "index.json").read_text())
    assert sorted(row["report"] for row in index["archives"]) == [
        "a-1.csv/report.html",
        "a.csv/report.html",
    ]
    assert len(_analyses(tmp_path)) == 2  # (each content once)


def _a_replaced(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> tuple[Path, Path, WatchSettings]:
    """``a.csv`` analyzed by a watcher, then replaced in INBOX by other content (the
    next watcher keeps the earlier record aside and reserves ``a-1.csv/`` for the new
    content's report); returns INBOX, REPORTS and the settings (``--once``)."""
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    monkeypatch.setattr(watch_module, "analysis_into", _quick_analysis)
    inbox, reports = tmp_path / "in" / "inbox", tmp_path / "in" / "reports"
    inbox.mkdir(parents=True)
    settings = WatchSettings(inbox, reports, settle=0.2, poll=0.05, once=True)
    _archive(inbox / "a.csv", 300)
    assert watch(settings, RunOptions()) == 0
    _archive(inbox / "new.csv", 301)
    os.replace(inbox / "new.csv", inbox / "a.csv")
    return inbox, reports, settings


def _links_only_folders_there(reports: Path) -> None:
    """Every record of the state and every row of the index links a folder of REPORTS
    that is there."""
    state = json.loads((reports / ".watch-state.json").read_text())["archives"]
    index = json.loads((reports / "index.json").read_text())["archives"]
    for row in [*state.values(), *index]:
        assert (reports / row["report"]).parent.is_dir(), row


def test_a_new_content_killed_before_its_publish_goes_to_its_reserved_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A watcher killed between the reserve of ``a.csv``'s new content (its record
    written, for ``a-1.csv/``) and its publish: the next start says that its report was
    never written (not that its folder is gone: none was made), analyzes it again, and
    publishes it into ``a-1.csv/``, the folder reserved. Before, the line said "its
    report folder is gone", and the report went to ``a.csv-report/``."""
    inbox, reports, settings = _a_replaced(tmp_path, monkeypatch)
    real_publish = watch_module.publish

    def killed(undo: pytest.MonkeyPatch) -> None:
        def publish(scratch: Path, reports_: Path, name: str, *args: Any) -> Path:
            if name == "a.csv" and _recorded(reports) == {"a.csv", "a-1.csv"}:
                raise _Killed
            return real_publish(scratch, reports_, name, *args)

        undo.setattr(watch_module, "publish", publish)

    _run_killed(settings, killed)
    state = json.loads((reports / ".watch-state.json").read_text())["archives"]
    assert state["a.csv"]["report"] == "a-1.csv/report.html"  # (reserved, not published)
    assert not (reports / "a-1.csv").exists()
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    assert watch(settings, RunOptions()) == 0
    said = [r.getMessage() for r in caplog.records]
    assert (
        "a.csv: its report was never written (the watcher was stopped before); it will "
        "be analyzed again" in said
    )
    assert not [line for line in said if "report folder is gone" in line]
    records = json.loads((reports / ".watch-state.json").read_text())["archives"]
    assert records["a.csv"]["report"] == "a-1.csv/report.html"
    assert records["a.csv"]["sha256"] == sha256_of(inbox / "a.csv")
    assert "unpublished" not in records["a.csv"]
    assert records["a-1.csv"]["report"] == "a.csv/report.html"
    assert sorted(p.name for p in reports.iterdir() if not p.name.startswith(".")) == [
        "a-1.csv",
        "a.csv",
        "index.html",
        "index.json",
    ]
    _links_only_folders_there(reports)
    assert len(_analyses(tmp_path)) == 3  # (the new content again: never published)


def test_a_new_content_whose_publish_fails_is_not_recorded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """The publish of ``a.csv``'s new content, reserved, fails (REPORTS full): its record
    is forgotten (:meth:`Ledger.forget`), so neither the state nor the index links a
    folder never made, and the next start analyzes it again; the earlier content's
    result stays, kept aside as ``a-1.csv``."""
    inbox, reports, settings = _a_replaced(tmp_path, monkeypatch)
    real_publish = watch_module.publish

    def publish(scratch: Path, reports_: Path, name: str, *args: Any) -> Path:
        if name == "a.csv":
            raise OSError(errno.ENOSPC, "No space left on device", str(reports_ / "a-1.csv"))
        return real_publish(scratch, reports_, name, *args)

    monkeypatch.setattr(watch_module, "publish", publish)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    assert watch(settings, RunOptions()) == 2
    assert any("a.csv: cannot write its report" in r.getMessage() for r in caplog.records)
    assert _recorded(reports) == {"a-1.csv"}
    _links_only_folders_there(reports)
    monkeypatch.setattr(watch_module, "publish", real_publish)
    assert watch(settings, RunOptions()) == 0
    records = json.loads((reports / ".watch-state.json").read_text())["archives"]
    assert records["a.csv"]["sha256"] == sha256_of(inbox / "a.csv")
    assert records["a-1.csv"]["report"] == "a.csv/report.html"
    _links_only_folders_there(reports)
    assert len(_analyses(tmp_path)) == 3


def test_a_new_content_whose_reserve_cannot_be_written_is_not_recorded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """The state write of the reserve of ``a.csv``'s new content fails (REPORTS full,
    once): no record of it is kept, in the state or in memory, so nothing links a
    folder never made, and its content is not taken for analyzed already. Before, the
    record stayed in memory: the run's end wrote it to the state and the index linked
    ``a-1.csv/``, never made (and the same content found again in a running watcher was
    "found analyzed already" with that folder as its report, then forgotten by the next
    start: its result lost)."""
    inbox, reports, settings = _a_replaced(tmp_path, monkeypatch)
    real_reserve = Ledger.reserve

    def reserve(self: Ledger, rec: Record) -> None:
        def refused() -> None:
            raise OSError(errno.ENOSPC, "No space left on device", str(self.path))

        self.save_state = refused  # type: ignore[method-assign]
        try:
            real_reserve(self, rec)
        finally:
            del self.save_state

    monkeypatch.setattr(Ledger, "reserve", reserve)
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    assert watch(settings, RunOptions()) == 2
    assert any("a.csv: cannot write its report" in r.getMessage() for r in caplog.records)
    assert _recorded(reports) == {"a-1.csv"}
    assert not (reports / "a-1.csv").exists()
    _links_only_folders_there(reports)
    monkeypatch.setattr(Ledger, "reserve", real_reserve)
    assert watch(settings, RunOptions()) == 0
    records = json.loads((reports / ".watch-state.json").read_text())["archives"]
    assert records["a.csv"]["sha256"] == sha256_of(inbox / "a.csv")
    _links_only_folders_there(reports)
    assert len(_analyses(tmp_path)) == 3

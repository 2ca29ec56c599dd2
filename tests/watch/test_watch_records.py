"""Which results the watcher keeps, and what ``--once`` returns: errors that are not the
archive's (an internal error, a full disk) are retried on the next start and never move
the archive; errors that depend on the options are redone with other options; the exit
code of ``--once`` says whether a fault was found or an archive could not be analyzed.

An internal error is made by replacing the pipeline in the analysis process: the
watcher's processes are then forked from the test process (which has the replacement)
instead of from the fork server."""

from __future__ import annotations

import errno
import json
import multiprocessing
import os
import threading
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import test_watch_run
from test_watch_run import OPTIONS, SETTLE, Watcher, said, started, state, write

from analyzer import watch as watch_module
from analyzer.cli import main
from analyzer.watch import WatchSettings, watch
from analyzer.watch_index import Record

# the fixtures of test_watch_run (found by pytest among this module's names)
folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server

# --------------------------------------------------------------------------- not verdicts


def _forked(monkeypatch: pytest.MonkeyPatch) -> None:
    """Analyses in processes forked from this one, so that they see its replacements."""
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))


def test_an_internal_error_is_retried_on_the_next_start_and_never_moved(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    done, failed = tmp_path / "done", tmp_path / "failed"
    write(inbox / "a.csv", "csv", seed=1)

    def disk_full(*args: object, **kw: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    _forked(monkeypatch)
    monkeypatch.setattr(watch_module, "analyze_screened", disk_full)
    settings = WatchSettings(
        inbox, reports, settle=SETTLE, poll=0.1, done=done, failed=failed, once=True
    )
    assert start_watcher(settings).join() == 2
    assert (inbox / "a.csv").is_file() and not (failed / "a.csv").exists()
    record = state(reports)["a.csv"]
    assert record["verdict"] == "error" and record["error_kind"] == "internal"
    assert record["error"] == "internal error: OSError: [Errno 28] No space left on device"
    assert said(caplog, "a.csv: error in ")[0].endswith(
        ": internal error: OSError: [Errno 28] No space left on device "
        "(not the archive's fault: it is analyzed again on the next start)"
    )

    monkeypatch.undo()
    caplog.clear()
    assert start_watcher(settings).join() in (0, 1)
    assert started(caplog) == ["a.csv"]
    assert said(caplog, "a.csv: analyzed again: its last analysis ended in an internal error")
    assert state(reports)["a.csv"]["verdict"] in ("fault", "no fault")
    assert (done / "a.csv").is_file() and not (inbox / "a.csv").exists()


def test_a_report_that_cannot_be_written_is_retried_on_the_next_start(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    failed = tmp_path / "failed"
    write(inbox / "a.csv", "csv", seed=1)

    def full(*args: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device", str(reports / "a.csv"))

    monkeypatch.setattr(watch_module, "publish", full)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, failed=failed, once=True)
    assert start_watcher(settings).join() == 2
    assert "a.csv" not in state(reports) and (inbox / "a.csv").is_file()
    assert said(caplog, "a.csv: cannot write its report")[0].endswith(
        "No space left on device; it is analyzed again on the next start"
    )
    assert not [p for p in reports.iterdir() if p.name.startswith(".tmp-")]
    monkeypatch.undo()
    caplog.clear()
    assert start_watcher(settings).join() in (0, 1)
    assert started(caplog) == ["a.csv"] and "a.csv" in state(reports)


def test_an_error_of_the_options_is_redone_with_other_options_and_keeps_the_archive(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A ``--train`` beyond the data's end: the archive is too short for it (as a file
    still being written), kept in INBOX even with ``--failed``, said each time, and
    ``--once`` exits 2."""
    inbox, reports = folders
    failed = tmp_path / "failed"
    write(inbox / "a.csv", "csv", seed=1)  # 40 s
    late = replace(OPTIONS, train="100:120")  # after the data's end
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, failed=failed, once=True)
    assert start_watcher(settings, late).join() == 2
    record = state(reports)["a.csv"]
    assert record["verdict"] == "error" and record["error"].startswith("--train: ")
    assert (record["error_kind"], record["error_reason"]) == ("options", "too short")
    assert record["options"] == watch_module.options_fingerprint(late)
    assert record["left_in_inbox"].startswith("too short for the training window so far")
    assert (inbox / "a.csv").is_file() and not (failed / "a.csv").exists()

    caplog.clear()  # the same options: the same error, found recorded, said again
    assert start_watcher(settings, late).join() == 2
    assert started(caplog) == [] and said(caplog, "1 archive found analyzed already")
    assert said(caplog, "a.csv: left in INBOX: too short for the training window so far")
    assert (inbox / "a.csv").is_file() and not (failed / "a.csv").exists()

    caplog.clear()  # other options: analyzed again
    assert start_watcher(settings).join() in (0, 1)
    assert started(caplog) == ["a.csv"]
    assert said(
        caplog,
        "a.csv: analyzed again: its error was recorded with other analysis options "
        "or another analyzer version",
    )
    record = state(reports)["a.csv"]
    assert record["verdict"] in ("fault", "no fault")
    assert record["options"] == watch_module.options_fingerprint(OPTIONS)


def _old(verdict: str, **extra: Any) -> Record:
    """A record as a watcher before the options fingerprint wrote it."""
    return Record.from_json(
        {
            "name": "a.csv",
            "sha256": "0" * 64,
            "verdict": verdict,
            "report": "a.csv/error.txt",
            "inputs": ["/inbox/a.csv"],
            "processed": "2026-01-01T00:00:00.000Z",
            "analysis_s": 1.0,
            "error": "internal error: ImportError: cannot import name 'X'",
            **extra,
        }
    )


def test_old_error_records_are_redone_once_and_old_results_kept() -> None:
    fingerprint = watch_module.options_fingerprint(OPTIONS)
    assert _old("error").redo_reason(fingerprint) == (
        "its error was recorded by an older watcher, without the options it was made with"
    )
    assert _old("no fault").redo_reason(fingerprint) is None
    assert _old("fault").redo_reason("other") is None  # options never redo a result
    assert _old("error", options=fingerprint, error_kind="input").redo_reason(fingerprint) is None


def test_the_fingerprint_follows_what_changes_findings(monkeypatch: pytest.MonkeyPatch) -> None:
    base = watch_module.options_fingerprint(OPTIONS)
    assert watch_module.options_fingerprint(replace(OPTIONS, jobs=4, progress=print)) == base
    assert watch_module.options_fingerprint(replace(OPTIONS, channels=["/s1*"])) != base
    assert watch_module.options_fingerprint(replace(OPTIONS, rate=50.0)) != base
    assert watch_module.options_fingerprint(replace(OPTIONS, model_sha256="ab" * 32)) != base
    monkeypatch.setattr(watch_module, "__version__", "0.0.0-other")
    assert watch_module.options_fingerprint(OPTIONS) != base


# --------------------------------------------------------------------------- exit codes


def test_once_exits_1_on_a_fault_2_on_an_error_and_0_otherwise(
    tmp_path: Path, folders: tuple[Path, Path], start_watcher: Callable[..., Watcher]
) -> None:
    inbox, reports = folders
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    write(inbox / "healthy.csv", "csv", seed=1)
    assert start_watcher(settings).join() == 0
    assert state(reports)["healthy.csv"]["verdict"] == "no fault"
    (inbox / "broken.csv").write_text("not,a\ntable\n")
    assert start_watcher(settings).join() == 2  # only this run's archives count
    write(inbox / "faulty.csv", "csv", seed=2, fault=True)
    (inbox / "broken2.csv").write_text("not,a\ntable\n")
    assert start_watcher(settings).join() == 1  # a fault before an error
    # nothing new, but the broken ones are left in INBOX in error (no --failed)
    assert start_watcher(settings).join() == 2
    assert start_watcher(replace(settings, failed=tmp_path / "failed")).join() == 0  # moved
    assert start_watcher(settings).join() == 0  # nothing new, nothing left in error
    assert {k: v["verdict"] for k, v in state(reports).items()} == {
        "healthy.csv": "no fault",
        "broken.csv": "error",
        "faulty.csv": "fault",
        "broken2.csv": "error",
    }


def test_once_exits_2_when_an_archive_cannot_be_read(
    tmp_path: Path, folders: tuple[Path, Path], start_watcher: Callable[..., Watcher]
) -> None:
    inbox, reports = folders
    (inbox / "dangling.csv").symlink_to(tmp_path / "gone.csv")
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    assert start_watcher(settings).join() == 2
    assert state(reports) == {}


def test_an_interrupted_once_exits_130(folders: tuple[Path, Path]) -> None:
    inbox, reports = folders
    write(inbox / "a.csv", "csv", seed=1)
    stop = threading.Event()
    stop.set()  # a signal before anything was done
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    assert watch(settings, OPTIONS, stop=stop) == 130
    assert state(reports) == {}


# --------------------------------------------------------------------------- folders


@pytest.mark.parametrize(
    ("option", "where"),
    [("--done", "."), ("--failed", "."), ("--done", "done"), ("--failed", "sub/failed")],
)
def test_done_or_failed_in_reports_is_a_usage_error(
    folders: tuple[Path, Path], capsys: pytest.CaptureFixture[str], option: str, where: str
) -> None:
    inbox, reports = folders
    folder = reports / where
    argv = ["watch", str(inbox), "--out", str(reports), option, str(folder), "--once"]
    assert main([*argv, "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert f"{option}: {folder} is inside REPORTS (--out {reports})" in err, err
    assert not (inbox / "done").exists()


def test_done_inside_reports_is_refused_before_anything_is_moved(
    folders: tuple[Path, Path],
) -> None:
    inbox, reports = folders
    write(inbox / "a.csv", "csv", seed=1)
    settings = WatchSettings(inbox, reports, settle=SETTLE, once=True, done=reports)
    with pytest.raises(Exception, match=r"--done: .* is inside REPORTS"):
        watch(settings, OPTIONS)
    assert (inbox / "a.csv").is_file()


# --------------------------------------------------------------------------- incomplete


def test_once_does_not_wait_again_for_an_incomplete_archive_recorded_already(
    folders: tuple[Path, Path], start_watcher: Callable[..., Watcher]
) -> None:
    inbox, reports = folders
    (inbox / "zero.csv").write_bytes(b"")
    write(inbox / "good.csv", "csv", seed=1)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    first = start_watcher(replace(settings, incomplete_timeout=1.0))
    assert first.join(timeout=8) == 2  # waited 1 s for zero.csv, then its error
    assert state(reports)["zero.csv"]["verdict"] == "error"
    again = start_watcher(settings)  # the default 10 min
    # nothing new: zero.csv found analyzed already (not waited for), left in INBOX in error
    assert again.join(timeout=8) == 2


# --------------------------------------------------------------------------- same name


def test_a_new_archive_under_a_recorded_name_keeps_the_earlier_result(
    tmp_path: Path, folders: tuple[Path, Path], start_watcher: Callable[..., Watcher]
) -> None:
    """A recorder that always writes ``latest.csv``, moved away by ``--done`` each time:
    the earlier file's record and fault episode stay, under a new name, and its report
    where it was announced (``latest.csv/``)."""
    inbox, reports = folders
    done = tmp_path / "done"
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, done=done, once=True)
    write(inbox / "latest.csv", "csv", seed=1, fault=True)
    assert start_watcher(settings).join() == 1
    first = state(reports)["latest.csv"]
    write(inbox / "latest.csv", "csv", seed=2)
    assert start_watcher(settings).join() == 0

    records = state(reports)
    assert set(records) == {"latest.csv", "latest-1.csv"}
    kept, new = records["latest-1.csv"], records["latest.csv"]
    assert new["verdict"] == "no fault" and new["moved_to"] == [str(done / "latest-1.csv")]
    assert kept["verdict"] == "fault" and kept["sha256"] == first["sha256"]
    assert kept["dropped_as"] == "latest.csv"
    assert kept["moved_to"] == [str(done / "latest.csv")]
    # (the earlier result stays where its report was announced; the new one goes to
    # the next free folder)
    assert kept["report"] == "latest.csv/report.html"
    assert new["report"] == "latest-1.csv/report.html"
    findings = (reports / "latest.csv" / "findings.json").read_text()
    assert '"faults": []' not in findings
    assert '"faults": []' in (reports / "latest-1.csv" / "findings.json").read_text()

    index = json.loads((reports / "index.json").read_text())
    assert {a["name"] for a in index["archives"]} == {"latest.csv", "latest-1.csv"}
    assert [e["archives"] for e in index["episodes"]] == [["latest-1.csv"]]
    page = (reports / "index.html").read_text()
    assert 'href="latest-1.csv/report.html"' in page and 'href="latest.csv/report.html"' in page
    assert "dropped as latest.csv" in page


def test_an_archive_replaced_in_place_keeps_the_earlier_result(
    tmp_path: Path, folders: tuple[Path, Path], start_watcher: Callable[..., Watcher]
) -> None:
    inbox, reports = folders
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    write(inbox / "a.csv", "csv", seed=1)
    assert start_watcher(settings).join() == 0
    (reports / "a-1.csv").mkdir()  # a name taken in REPORTS (an archive's, say) is skipped
    write(tmp_path / "new.csv", "csv", seed=2, fault=True)
    os.replace(tmp_path / "new.csv", inbox / "a.csv")
    assert start_watcher(settings).join() == 1
    records = state(reports)
    assert set(records) == {"a.csv", "a-2.csv"}
    assert records["a-2.csv"]["verdict"] == "no fault" and records["a.csv"]["verdict"] == "fault"
    assert (reports / "a-2.csv" / "report.html").is_file()
    # and a restart finds both in order (the kept one's folder is where its record says)
    assert start_watcher(settings).join() == 0
    assert set(state(reports)) == {"a.csv", "a-2.csv"}


def test_an_archive_that_grows_while_it_is_analyzed_is_analyzed_again_not_moved(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A copy that pauses longer than --settle goes on while its first half is analyzed:
    that result is discarded, the file is not moved (--done), and it is analyzed again
    once it has settled, by ``--once`` too (which ended without it: exit 0, the file
    left in INBOX without a record)."""
    from analyzer.findings import sha256_of

    inbox, reports = folders
    done = tmp_path / "done"
    full = write(tmp_path / "full.csv", "csv", seed=2, fault=True).read_bytes()
    cut = full.index(b"\n", len(full) // 2) + 1
    csv = inbox / "a.csv"
    csv.write_bytes(full[:cut])
    analyze = watch_module.analyze_screened

    def copy_goes_on(inputs: list[str], options: Any, work: Path) -> Any:
        if csv.stat().st_size < len(full):  # (the first analysis)
            with csv.open("ab") as f:
                f.write(full[cut:])
        return analyze(inputs, options, work)

    _forked(monkeypatch)
    monkeypatch.setattr(watch_module, "analyze_screened", copy_goes_on)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, done=done, once=True)
    assert start_watcher(settings).join() == 1  # the fault of the whole file
    assert said(caplog, "a.csv: changed or removed while it was analyzed; result discarded")
    assert started(caplog) == ["a.csv", "a.csv"]
    assert not csv.exists() and (done / "a.csv").read_bytes() == full
    record = state(reports)["a.csv"]
    assert record["sha256"] == sha256_of(done / "a.csv") and record["verdict"] == "fault"
    assert record["moved_to"] == [str(done / "a.csv")]


def test_an_archive_that_changed_since_it_was_taken_is_not_moved(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """``--done`` never moves a file that changed after it was found complete (a writer
    still at it): the move checks the archive's files once more."""
    from types import SimpleNamespace

    from analyzer.watch_inbox import ReadyArchive, signature
    from analyzer.watch_index import Ledger, Verdict

    inbox, done = tmp_path / "inbox", tmp_path / "done"
    inbox.mkdir()
    done.mkdir()
    csv = inbox / "a.csv"
    csv.write_text("time,a\n0,1\n")
    archive = ReadyArchive("a.csv", (csv,), signature([csv], inbox))
    with csv.open("a") as f:
        f.write("1,2\n")
    runner = SimpleNamespace(
        settings=WatchSettings(inbox, tmp_path / "reports", done=done),
        ledger=Ledger(tmp_path),
        copying={},
        returned=[],
    )
    runner._as_found = lambda archive: watch_module._Runner._as_found(runner, archive)  # type: ignore[arg-type]
    runner._look_again = lambda archive: watch_module._Runner._look_again(runner, archive)  # type: ignore[arg-type]
    record = Record("a.csv", "0" * 64, Verdict.NO_FAULT, "a.csv/report.html", [], "t", 1.0)
    watch_module._Runner._move(runner, archive, record)  # type: ignore[arg-type]
    assert csv.is_file() and not list(done.iterdir())
    assert said(caplog, "a.csv: not moved to ")
    assert runner.returned == [("a.csv", archive.signature)]  # (looked at again)


def test_a_state_file_that_cannot_be_written_after_a_move_does_not_stop_the_watcher(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    """REPORTS full when the move by --done is recorded: the archive is in --done, the
    record holds it (written with the next one) and the watcher goes on, where the
    OSError ended it (a one-line exit 2 in the middle of a service's life)."""
    from analyzer.watch_inbox import ReadyArchive, signature
    from analyzer.watch_index import Ledger, Verdict

    inbox, done, reports = tmp_path / "inbox", tmp_path / "done", tmp_path / "reports"
    for folder in (inbox, done, reports):
        folder.mkdir()
    csv = inbox / "a.csv"
    csv.write_text("time,a\n0,1\n1,2\n")
    archive = ReadyArchive("a.csv", (csv,), signature([csv], inbox))
    ledger = Ledger(reports)
    record = Record("a.csv", "0" * 64, Verdict.NO_FAULT, "a.csv/report.html", [], "t", 1.0)
    ledger.records["a.csv"] = record

    def full(self: Ledger) -> None:
        raise OSError(errno.ENOSPC, "No space left on device", str(self.path))

    monkeypatch.setattr(Ledger, "save_state", full)
    runner = object.__new__(watch_module._Runner)  # (no processes, no threads)
    vars(runner).update(
        settings=WatchSettings(inbox, reports, done=done), ledger=ledger, moves={}, copying={}
    )
    watch_module._Runner._move(runner, archive, record)  # type: ignore[arg-type]
    assert not csv.exists() and (done / "a.csv").is_file()
    assert ledger.get("a.csv") is record and record.moved_to == [str(done / "a.csv")]
    assert said(caplog, "a.csv: its move is not in the state file yet (")[0].endswith(
        "No space left on device); it is with the next record written"
    )
    monkeypatch.undo()
    ledger.save_state()
    assert state(reports)["a.csv"]["moved_to"] == [str(done / "a.csv")]

"""REPORTS on a disk that fills while an analysis writes its report (a QA audit's ux59 item
M2): the archive's error is the file's (``REPORTS/b.csv/report.html: No space left on
device``), not an "internal error" asking for a bug report, and its ``error.txt`` holds
no traceback; the archive stays in INBOX, analyzed again on the next start (nothing is
lost). The full disk is a seam (:mod:`full_disk` of the report tests), reaching the
analysis process through a fork."""

from __future__ import annotations

import json
import multiprocessing
import sys
from pathlib import Path

import numpy as np
import pytest

from analyzer import watch as watch_module
from analyzer.options import RunOptions
from analyzer.simulate import simulate_building
from analyzer.watch import WatchSettings, watch
from analyzer.writers import write_archive

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "report"))
from full_disk import FullDisk  # noqa: E402


def _building(path: Path) -> Path:
    t, y, names = simulate_building(3, 40.0, 100.0, seed=2)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    return path


def _scratch(folder: Path) -> bool:
    """An analysis's hidden folder of REPORTS (``.tmp-NAME``)."""
    return folder.name.startswith(".tmp-")


def test_an_analysis_that_cannot_write_its_report_says_which_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    src = _building(tmp_path / "b.csv")
    out = tmp_path / "out"
    out.mkdir()
    FullDisk(monkeypatch, out, name="report.html")
    code = watch_module.analysis_into([str(src)], RunOptions(train="0:12"), out, tmp_path)
    assert (out / "error.txt").read_text() == "report.html: No space left on device\n"
    assert code == watch_module.EXIT_UNWRITTEN
    assert sorted(p.name for p in out.iterdir()) == ["error.txt"]


def test_a_full_reports_disk_is_the_report_file_s_error_and_the_archive_stays(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    inbox, reports = tmp_path / "inbox", tmp_path / "reports"
    inbox.mkdir()
    _building(inbox / "b.csv")
    FullDisk(monkeypatch, _scratch, name="report.html")
    settings = WatchSettings(inbox=inbox, reports=reports, settle=0.2, poll=0.05, once=True)
    code = watch(settings, RunOptions(train="0:12"))
    assert code == 2
    (rec,) = json.loads((reports / ".watch-state.json").read_text())["archives"].values()
    said = f"{reports / 'b.csv' / 'report.html'}: No space left on device"
    assert rec["error"] == said, rec
    assert rec["error_kind"] == "internal" and rec["error_reason"] == "unwritten"
    text = (reports / "b.csv" / "error.txt").read_text()
    assert text.splitlines()[0] == said and "Traceback" not in text
    assert (inbox / "b.csv").is_file()  # (analyzed again on the next start)
    index = json.loads((reports / "index.json").read_text())
    assert said in json.dumps(index)


def test_the_log_s_times_are_utc_with_a_z(monkeypatch: pytest.MonkeyPatch) -> None:
    """The watcher's log lines carry UTC times with a ``Z``, as ``index.json``'s (a QA
    audit's ux59 item L5: they were local times without a zone)."""
    import logging
    import time

    monkeypatch.setenv("TZ", "America/New_York")
    time.tzset()
    try:
        record = logging.LogRecord("analyzer.watch", logging.INFO, __file__, 1, "x", (), None)
        record.created = 1_796_668_393.0  # 2026-12-07T18:33:13Z, 13:33:13 in New York
        line = watch_module._StderrFormatter("%(asctime)s analyzer watch: %(message)s").format(
            record
        )
    finally:
        monkeypatch.undo()  # (TZ as it was)
        time.tzset()
    assert line == "2026-12-07T18:33:13Z analyzer watch: x"


class _FakeClient:
    """A Dask client whose one task has ended with ``result``."""

    def __init__(self, result: object) -> None:
        from concurrent.futures import Future

        self.future: Future[object] = Future()
        self.future.set_result(result)

    def submit(self, fn: object, *args: object, pure: bool = True) -> object:
        return self.future


def test_a_cluster_task_whose_report_cannot_be_written_says_which_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``watch --scheduler``: the worker's files written into REPORTS on a full disk.
    Before, the OSError went up through the watcher's loop."""
    from types import SimpleNamespace

    from analyzer.watch_cluster import ClusterTask

    out = tmp_path / ".tmp-x.mcap"
    out.mkdir()
    files = {"findings.json": b"{}", "report.html": b"<html></html>"}
    executor = SimpleNamespace(client=_FakeClient((1, files)))
    task = ClusterTask(executor, ["x.mcap"], "options", out)  # type: ignore[arg-type]
    FullDisk(monkeypatch, out, name="report.html")
    task.join()
    assert (out / "error.txt").read_text() == "report.html: No space left on device\n"
    assert task.exitcode == watch_module.EXIT_UNWRITTEN
    assert sorted(p.name for p in out.iterdir()) == ["error.txt"]


def test_a_full_scratch_space_is_one_line_and_tried_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The machine's limit met while analyzing (res57b's ``ScratchFull``: TMPDIR full) is
    said in its own line, no traceback, and counted as a report not written (tried again,
    the archive stays in INBOX); it was "internal error: ScratchFull" with a traceback
    (an operator's audit's ux66 M1)."""
    import errno

    from analyzer.errors import ScratchFull

    def full(*args: object, **kwargs: object) -> None:
        raise ScratchFull(errno.ENOSPC, "No space left on device: no room for the scratch")

    monkeypatch.setattr(watch_module, "analyze_screened", full)
    out = tmp_path / "out"
    out.mkdir()
    code = watch_module.analysis_into([str(tmp_path / "b.csv")], RunOptions(), out, tmp_path)
    assert code == watch_module.EXIT_UNWRITTEN
    assert (out / "error.txt").read_text() == ("No space left on device: no room for the scratch\n")

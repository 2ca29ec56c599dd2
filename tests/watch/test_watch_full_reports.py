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

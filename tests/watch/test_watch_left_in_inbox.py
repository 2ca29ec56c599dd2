"""What the watcher says of an archive it cannot analyze, or found analyzed already.

An archive that these options, sound in themselves, cannot analyze (one channel,
``--channels`` matching none of its channels, ``--train`` beyond its end) is the
archive's error and goes to ``--failed``; one that stays in INBOX in error (no
``--failed``, an error of the options alone) is said each time it is seen, in the log and
the index, and ``--once`` exits 2. Before, a one-channel NAB file stayed in INBOX with
nothing said and the next ``--once`` said "0 archives analyzed" and exited 0. A file
dropped again with content analyzed already is said with its earlier result; the stop
summary counts archives, not analyses; a fault's line says its faults as ``analyzer run``
does."""

from __future__ import annotations

import json
import multiprocessing
import shutil
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import test_watch_run
from test_watch_run import OPTIONS, SETTLE, Watcher, started, state, wait_until, write

from analyzer import watch as watch_module
from analyzer.errors import UsageError
from analyzer.report.format import magnitude
from analyzer.watch import WatchSettings
from analyzer.watch_index import Record, Verdict, episodes, index_view, render_index

# the fixtures of test_watch_run (found by pytest among this module's names)
folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server


def said(caplog: pytest.LogCaptureFixture, text: str) -> list[str]:
    return [r.getMessage() for r in caplog.records if text in r.getMessage()]


def one_channel(path: Path) -> Path:
    """A CSV of one channel (as NAB's files), 40 s at 100 Hz with ISO times."""
    t = np.arange(4000) / 100.0
    value = np.sin(t) + 0.01 * np.random.default_rng(3).standard_normal(t.size)
    rows = [f"2026-01-01T00:00:{s:06.3f}Z,{v:.6f}" for s, v in zip(t, value, strict=True)]
    path.write_text("timestamp,value\n" + "\n".join(rows) + "\n")
    return path


def index(reports: Path) -> dict[str, dict[str, object]]:
    doc = json.loads((reports / "index.json").read_text())
    return {str(r["name"]): r for r in doc["archives"]}


def test_a_one_channel_archive_is_said_left_in_inbox_until_failed_takes_it(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    failed = tmp_path / "failed"
    one_channel(inbox / "nab.csv")
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    assert start_watcher(settings).join() == 2
    record = state(reports)["nab.csv"]
    assert record["error"].startswith("one channel to analyze (value)")
    assert record["error_kind"] == "does not fit the options"
    assert said(caplog, "nab.csv: left in INBOX: no --failed folder to move it to") == [
        "nab.csv: left in INBOX: no --failed folder to move it to"
    ]
    assert index(reports)["nab.csv"]["left_in_inbox"] == "no --failed folder to move it to"
    html = (reports / "index.html").read_text()
    assert "left in INBOX: no --failed folder to move it to" in html

    caplog.clear()  # found recorded: said again, with its error, and not a success
    assert start_watcher(settings).join() == 2
    assert started(caplog) == []
    (line,) = said(caplog, "nab.csv: left in INBOX: ")
    assert line.startswith(
        "nab.csv: left in INBOX: no --failed folder to move it to; its error: one channel "
        "to analyze (value)"
    )
    (summary,) = said(caplog, "0 archives analyzed")
    assert "1 archive found analyzed already, not analyzed again" in summary
    assert "; 1 archive in error left in INBOX" in summary

    caplog.clear()  # with --failed: moved there, as a corrupt file, and nothing left
    assert start_watcher(replace(settings, failed=failed)).join() == 0
    assert (failed / "nab.csv").is_file() and not (inbox / "nab.csv").exists()
    assert said(caplog, "left in INBOX") == []
    assert index(reports)["nab.csv"]["left_in_inbox"] is None


def test_channels_matching_none_of_an_archive_move_it_to_failed(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    failed = tmp_path / "failed"
    write(inbox / "a.csv", "csv", seed=1)
    one_channel(inbox / "nab.csv")
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, failed=failed, once=True)
    assert start_watcher(settings, replace(OPTIONS, channels=["zz*"])).join() == 2
    for name in ("a.csv", "nab.csv"):
        assert state(reports)[name]["error"].startswith("--channels: pattern 'zz*' matches no")
        assert state(reports)[name]["error_kind"] == "does not fit the options"
        assert (failed / name).is_file() and not (inbox / name).exists()
    assert said(caplog, "left in INBOX") == []


def _options_error(*args: object, **kw: object) -> None:
    raise UsageError("--frobnicate: every archive would get this")


def test_an_error_of_the_options_alone_stays_in_inbox_and_is_said_each_time(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    monkeypatch: pytest.MonkeyPatch,
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    failed = tmp_path / "failed"
    write(inbox / "a.csv", "csv", seed=1)
    # (analyses forked from this process, so that they see the replacement)
    monkeypatch.setattr(watch_module, "_context", lambda: multiprocessing.get_context("fork"))
    monkeypatch.setattr(watch_module, "analyze_screened", _options_error)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, failed=failed, once=True)
    why = (
        "an error of the options, not of the archive (every archive would get it): mend "
        "them and start the watcher again"
    )
    for _ in range(2):
        caplog.clear()
        assert start_watcher(settings).join() == 2
        assert (inbox / "a.csv").is_file() and not (failed / "a.csv").exists()
        assert state(reports)["a.csv"]["error_kind"] == "options"
        assert said(caplog, f"a.csv: left in INBOX: {why}")
    assert said(caplog, f"a.csv: left in INBOX: {why}; its error: --frobnicate: every")
    assert index(reports)["a.csv"]["left_in_inbox"] == why


def test_a_file_dropped_again_is_said_with_its_earlier_result_and_new_name(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    done = tmp_path / "done"
    write(inbox / "a.csv", "csv", seed=1, fault=True)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, done=done, once=True)
    assert start_watcher(settings).join() == 1
    report = reports / "a.csv" / "report.html"
    (ended,) = said(caplog, "a.csv: fault in ")
    # as analyzer run's last line: type and onset of each fault, and the report's path
    assert ": 1 sensor fault found on 1 sensor: " in ended and " additive from " in ended
    assert ended.endswith(f"; report: {report}")
    words = ended.partition(": ")[2].partition(": ")[2]  # (after "fault in 3 s [1/1]: ")

    shutil.copy2(done / "a.csv", inbox / "a.csv")
    caplog.clear()
    assert start_watcher(settings).join() == 0  # (a fault found earlier: not this run's)
    assert started(caplog) == []
    assert said(caplog, "a.csv: found analyzed already (same content), not analyzed again: ") == [
        f"a.csv: found analyzed already (same content), not analyzed again: {words}"
    ]
    assert said(caplog, "a.csv: moved to ") == [f"a.csv: moved to {done} as a-1.csv"]
    assert (done / "a-1.csv").is_file()


def test_the_summary_counts_an_archive_analyzed_twice_once(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """An archive that grew after its analysis (a writer pausing longer than the settle
    time) is analyzed again and its record replaced: one archive, counted once with its
    last verdict (it was "2 archives analyzed")."""
    inbox, reports = folders
    whole = write(tmp_path / "whole.csv", "csv", seed=1).read_bytes()
    head = whole[: whole.index(b"\n", len(whole) // 2) + 1]
    (inbox / "a.csv").write_bytes(head)
    watcher = start_watcher(WatchSettings(inbox, reports, settle=SETTLE, poll=0.1))
    wait_until(lambda: "a.csv" in state(reports), "the first analysis")
    first = state(reports)["a.csv"]["processed"]
    (inbox / "a.csv").write_bytes(whole)
    wait_until(lambda: state(reports)["a.csv"]["processed"] != first, "the second analysis")
    watcher.stop.set()
    assert watcher.join() == 0
    assert started(caplog) == ["a.csv", "a.csv"]
    assert said(caplog, "a.csv: grew since its last analysis")
    verdict = state(reports)["a.csv"]["verdict"]
    (summary,) = said(caplog, " analyzed in ")
    assert summary.startswith("1 archive analyzed in ")
    assert f": 1 {verdict}; index: " in summary


def test_the_index_gives_each_faults_size_and_names_corrected_csv(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
) -> None:
    inbox, reports = folders
    write(inbox / "a.csv", "csv", seed=1, fault=True)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    assert start_watcher(settings, replace(OPTIONS, corrected=True)).join() == 1
    row = index(reports)["a.csv"]
    assert row["corrected"] == "a.csv/corrected.csv"
    assert (reports / "a.csv" / "corrected.csv").is_file()
    findings = json.loads((reports / "a.csv" / "findings.json").read_text())
    sizes = [magnitude(f["magnitude"]) for f in findings["faults"]]
    assert [f["size"] for f in row["fault_list"]] == sizes  # type: ignore[union-attr]
    (offset,) = [f for f in findings["faults"] if f["channel"] == "s1"]  # (the injected)
    size = magnitude(offset["magnitude"])
    assert offset["type"] == "additive" and size.startswith("offset +")
    doc = json.loads((reports / "index.json").read_text())
    assert [e["size"] for e in doc["episodes"] if e["channel"] == "s1"] == [size]
    assert f"additive: {size}" in (reports / "index.html").read_text()
    html = (reports / "index.html").read_text()
    assert "<code>corrected.csv</code>" in html and "a.csv/corrected.csv" in html


def _record(name: str, fault: dict[str, object]) -> Record:
    return Record(
        name=name,
        sha256="0" * 64,
        verdict=Verdict.FAULT,
        report=f"{name}/report.html",
        inputs=[name],
        processed="2026-01-01T00:01:00.000Z",
        analysis_s=1.0,
        faulty_sensors=[str(fault["channel"])],
        faults=1,
        start="2026-01-01T00:00:00.000Z",
        duration_s=60.0,
        fault_list=[fault],
    )


def test_a_dead_sensor_is_shown_dead_in_the_index_not_only_multiplicative() -> None:
    fault = {
        "channel": "s3",
        "type": "multiplicative",
        "onset": "2026-01-01T00:00:45.000Z",
        "end": "2026-01-01T00:00:55.000Z",
        "from_start": False,
        "size": magnitude({"gain": 0.0}),
    }
    eps = episodes([_record("t.csv", fault)])
    doc = {
        "archives": [],
        "episodes": eps,
        "counts": {"fault": 1, "no fault": 0, "error": 0},
        "analyzer_version": "x",
        "updated": "now",
    }
    (row,) = index_view(doc).episodes
    assert row.types == "multiplicative: gain ×0 (dead sensor)"
    assert "corrected.csv" not in render_index(doc)  # (none written: not listed)

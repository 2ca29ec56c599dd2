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
from test_watch_run import OPTIONS, SETTLE, Watcher, said, started, state, wait_until, write

from analyzer import watch as watch_module
from analyzer.errors import UsageError
from analyzer.report.format import magnitude
from analyzer.watch import WatchSettings
from analyzer.watch_index import ErrorKind, Record, Verdict, episodes, index_view, render_index

# the fixtures of test_watch_run (found by pytest among this module's names)
folders = test_watch_run.folders
start_watcher = test_watch_run.start_watcher
_info_logs = test_watch_run._info_logs
_stop_fork_server = test_watch_run._stop_fork_server


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
    assert (record["error_kind"], record["error_reason"]) == ("input", "mismatch")
    assert record["misfit_option"] == "--channels"
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

    caplog.clear()  # with --failed, once an archive fits: moved there, as a corrupt file
    write(inbox / "a.csv", "csv", seed=1)
    assert start_watcher(replace(settings, failed=failed)).join() == 0
    assert (failed / "nab.csv").is_file() and not (inbox / "nab.csv").exists()
    assert index(reports)["nab.csv"]["left_in_inbox"] is None
    assert state(reports)["a.csv"]["verdict"] == "no fault"


def test_channels_matching_no_archive_leave_them_all_in_inbox_until_one_fits(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A ``--channels`` typo fits no archive: with ``--failed`` the branch moved the
    whole INBOX there, one archive at a time. Until an archive has fit these options,
    one they do not fit stays in INBOX, said with the option to check, and ``--once``
    exits 2; the options mended, each is analyzed again."""
    inbox, reports = folders
    failed = tmp_path / "failed"
    write(inbox / "a.csv", "csv", seed=1)
    write(inbox / "b.csv", "csv", seed=2)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, failed=failed, once=True)
    typo = replace(OPTIONS, channels=["S*"])
    for _ in range(2):  # (the second start: found recorded, said again)
        caplog.clear()
        assert start_watcher(settings, typo).join() == 2
        for name in ("a.csv", "b.csv"):
            assert (inbox / name).is_file()
            record = state(reports)[name]
            assert record["error"].startswith("--channels: pattern 'S*' matches no")
            assert (record["error_kind"], record["error_reason"]) == ("input", "mismatch")
            assert said(
                caplog,
                f"{name}: left in INBOX: no archive has fit these options yet: check --channels",
            )
            assert index(reports)[name]["left_in_inbox"].startswith("no archive has fit")
        assert not failed.exists() or not list(failed.iterdir())
    caplog.clear()
    assert start_watcher(settings, replace(OPTIONS, channels=["s*"])).join() == 0
    assert started(caplog) == ["a.csv", "b.csv"] or started(caplog) == ["b.csv", "a.csv"]
    assert {r["verdict"] for r in state(reports).values()} == {"no fault"}


def test_once_an_archive_fits_one_the_options_do_not_fit_goes_to_failed(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A mixed INBOX (a one-channel NAB file among the robot's): the robot's archive
    fits, so the NAB file's error is its own, and it goes to ``--failed``."""
    inbox, reports = folders
    failed = tmp_path / "failed"
    write(inbox / "a.csv", "csv", seed=1)
    one_channel(inbox / "nab.csv")
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, failed=failed, once=True)
    assert start_watcher(settings).join() == 2  # (nab.csv: an error of this run)
    assert (failed / "nab.csv").is_file() and not (inbox / "nab.csv").exists()
    assert state(reports)["nab.csv"]["misfit_option"] == "--channels"
    assert state(reports)["a.csv"]["verdict"] == "no fault"
    assert index(reports)["nab.csv"]["left_in_inbox"] is None


def test_an_iso_train_is_refused_at_start(folders: tuple[Path, Path]) -> None:
    """An ISO window fits only the archives holding it: every other archive failed."""
    inbox, reports = folders
    iso = replace(OPTIONS, train="2026-01-01T00:00:01Z:2026-01-01T00:00:12Z")
    with pytest.raises(UsageError, match=r"^--train 2026-01-01T00:00:01Z:.*: ISO times fit"):
        watch_module.watch(WatchSettings(inbox, reports, settle=SETTLE, once=True), iso)
    assert not reports.exists()


def test_a_csv_written_slowly_stays_in_inbox_until_whole(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """A CSV whose writer pauses longer than the settle time is too short for the
    training window at first: it stays in INBOX (as in analyzer 49) and is analyzed again
    when it grows. The branch moved it to ``--failed``, and the rest of it, appended
    after, went there as a second file without a header: the recording cut in two."""
    inbox, reports = folders
    done, failed = tmp_path / "done", tmp_path / "failed"
    whole = write(tmp_path / "whole.csv", "csv", seed=1).read_bytes()
    cut = 0
    for _ in range(11):  # (the header and 10 rows: 0.1 s)
        cut = whole.index(b"\n", cut) + 1
    (inbox / "a.csv").write_bytes(whole[:cut])
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, done=done, failed=failed)
    watcher = start_watcher(settings)
    wait_until(
        lambda: said(caplog, "a.csv: left in INBOX") or said(caplog, "a.csv: moved"),
        "the first part's error",
    )
    (line,) = said(caplog, "a.csv: left in INBOX")
    assert line.startswith("a.csv: left in INBOX: too short for the training window so far")
    record = state(reports)["a.csv"]
    assert (record["error_kind"], record["error_reason"]) == ("options", "too short")
    with (inbox / "a.csv").open("ab") as f:  # the writer goes on
        f.write(whole[cut:])
    wait_until(lambda: said(caplog, "a.csv: moved to "), "the whole file's move")
    watcher.stop.set()
    assert watcher.join() == 0
    assert (done / "a.csv").read_bytes() == whole
    assert not failed.exists() or not list(failed.iterdir())
    assert state(reports)["a.csv"]["verdict"] == "no fault"


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


def test_an_archive_not_moved_yet_is_not_said_dropped_again(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """An archive analyzed and never moved (a watcher without ``--done``, or one stopped
    before the end of its hold), found by the next start, is said as analyzed and not
    moved yet: "found analyzed already (same content)" read as a file dropped again
    (ux53 item 13). One moved and dropped again keeps those words (the test above)."""
    inbox, reports = folders
    done = tmp_path / "done"
    write(inbox / "a.csv", "csv", seed=1)
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    assert start_watcher(settings).join() == 0
    caplog.clear()
    assert start_watcher(replace(settings, done=done)).join() == 0
    assert started(caplog) == []
    report = reports / "a.csv" / "report.html"
    assert said(caplog, "a.csv: ") == [
        "a.csv: analyzed already and not moved yet (same content), not analyzed again: no "
        f"sensor fault found; report: {report}",
        f"a.csv: moved to {done}",
    ]
    assert said(caplog, "a.csv: found analyzed already") == []


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


def test_the_state_holds_only_error_kinds_an_older_watcher_reads() -> None:
    """A watcher of analyzer 49 refused the whole state file for a kind it did not know
    ("'does not fit the options' is not a valid ErrorKind"): going back to it meant
    analyzing everything again. The finer reasons are fields it leaves out."""
    assert {str(kind) for kind in ErrorKind} == {"input", "options", "internal"}
    doc = _record("n.csv", {"channel": "s1", "type": "additive"}).as_json()
    assert {"error_reason", "misfit_option"} <= set(doc)


def test_a_file_dropped_again_in_the_same_run_is_counted_once(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    done = tmp_path / "done"
    write(inbox / "a.csv", "csv", seed=1)
    watcher = start_watcher(WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, done=done))
    wait_until(lambda: (done / "a.csv").is_file(), "the first move")
    (inbox / "a.csv").write_bytes((done / "a.csv").read_bytes())  # dropped again
    wait_until(lambda: (done / "a-1.csv").is_file(), "the second move")
    watcher.stop.set()
    assert watcher.join() == 0
    (summary,) = said(caplog, " analyzed in ")
    assert summary.startswith("1 archive analyzed in ") and ": 1 no fault; index: " in summary


def test_the_left_in_inbox_note_goes_once_the_file_is_removed(
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
) -> None:
    inbox, reports = folders
    one_channel(inbox / "nab.csv")
    settings = WatchSettings(inbox, reports, settle=SETTLE, poll=0.1, once=True)
    assert start_watcher(settings).join() == 2
    assert index(reports)["nab.csv"]["left_in_inbox"] == "no --failed folder to move it to"
    (inbox / "nab.csv").unlink()  # removed by hand
    assert start_watcher(settings).join() == 0
    assert index(reports)["nab.csv"]["left_in_inbox"] is None
    assert "left in INBOX" not in (reports / "index.html").read_text()

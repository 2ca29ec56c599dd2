"""``analyzer watch`` end to end, with real file-system events in ``tmp_path``.

The watcher runs in a thread (``watch()`` with stop/abandon events) or, for the signal
and CLI behaviour, in a subprocess. Every wait has a hard timeout, and the fixtures stop
and join every watcher they started, so that a failing test can neither hang nor leave a
watcher behind. Archives are small simulated buildings (3 floors, 40 s at 100 Hz) with a
12 s training window, which is long enough to calibrate the detectors."""

from __future__ import annotations

import json
import logging
import multiprocessing
import multiprocessing.forkserver
import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from analyzer.cli import main
from analyzer.errors import UsageError
from analyzer.findings import sha256_of
from analyzer.options import RunOptions
from analyzer.simulate import inject_fault, simulate_building
from analyzer.watch import WatchSettings, watch
from analyzer.writers import write_archive

START = "2026-01-01T00:00:00Z"
OPTIONS = RunOptions(train="0:12")
SETTLE = 0.3
TIMEOUT = 60.0
"""Hard limit of any single wait in these tests."""


# --------------------------------------------------------------------------- archives


def building(
    seconds: float = 40.0,
    rate: float = 100.0,
    floors: int = 3,
    seed: int = 0,
    fault: bool = False,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    t, y, names = simulate_building(floors, seconds, rate, seed=seed)
    if fault:
        y[:, 1] = inject_fault(y[:, 1], rate, "additive", 0.6 * seconds, 8.0 * y[:, 1].std())
    t_ns = np.round(t * 1e9).astype(np.int64)
    return t_ns, {name: y[:, i] for i, name in enumerate(names)}


def said(caplog: pytest.LogCaptureFixture, text: str) -> list[str]:
    """The watcher's log messages that contain ``text``."""
    return [r.getMessage() for r in caplog.records if text in r.getMessage()]


def write(path: Path, fmt: str, **kw: object) -> Path:
    t_ns, data = building(**kw)  # type: ignore[arg-type]
    write_archive(path, fmt, t_ns, data, start_iso=START)
    return path


def corrupt_mcap(path: Path) -> Path:
    """MCAP magic at both ends (so it looks complete) and garbage in between."""
    rng = np.random.default_rng(7)
    path.write_bytes(b"\x89MCAP0\r\n" + rng.bytes(20_000) + b"\x89MCAP0\r\n")
    return path


def digests(paths: list[Path]) -> dict[str, str]:
    return {p.name: sha256_of(p) for p in paths}


# --------------------------------------------------------------------------- helpers


def wait_until(check: Callable[[], object], what: str, timeout: float = TIMEOUT) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if check():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout:.0f} s waiting for {what}")


def state(reports: Path) -> dict[str, dict[str, Any]]:
    path = reports / ".watch-state.json"
    if not path.exists():
        return {}
    archives: dict[str, dict[str, Any]] = json.loads(path.read_text())["archives"]
    return archives


def started(caplog: pytest.LogCaptureFixture) -> list[str]:
    """Names of the archives whose analysis started, in order."""
    return [
        str(r.args[0])
        for r in caplog.records
        if r.name == "analyzer.watch"
        and r.msg.startswith("%s: start (")
        and isinstance(r.args, tuple)
    ]


@dataclass
class Watcher:
    """A ``watch()`` running in a thread."""

    settings: WatchSettings
    stop: threading.Event = field(default_factory=threading.Event)
    abandon: threading.Event = field(default_factory=threading.Event)
    outcome: dict[str, object] = field(default_factory=dict)
    thread: threading.Thread | None = None

    def run(self, options: RunOptions) -> None:
        try:
            self.outcome["code"] = watch(
                self.settings, options, stop=self.stop, abandon=self.abandon
            )
        except BaseException as err:  # noqa: BLE001 - handed to the test
            self.outcome["error"] = err

    def join(self, timeout: float = TIMEOUT) -> object:
        """Wait for the watcher to end; its return value (or re-raise its error)."""
        assert self.thread is not None
        self.thread.join(timeout)
        assert not self.thread.is_alive(), f"watcher still running after {timeout:.0f} s"
        if "error" in self.outcome:
            raise self.outcome["error"]  # type: ignore[misc]
        return self.outcome["code"]


@pytest.fixture
def start_watcher() -> Iterator[Callable[..., Watcher]]:
    """Start ``watch()`` threads; at teardown every one is stopped (abandoning running
    analyses) and joined."""
    watchers: list[Watcher] = []

    def start(settings: WatchSettings, options: RunOptions = OPTIONS) -> Watcher:
        w = Watcher(settings)
        w.thread = threading.Thread(target=w.run, args=(options,), daemon=True)
        watchers.append(w)
        w.thread.start()
        return w

    yield start
    for w in watchers:
        w.stop.set()
        w.abandon.set()
    for w in watchers:
        assert w.thread is not None
        w.thread.join(TIMEOUT)
        assert not w.thread.is_alive(), "a watcher thread did not stop"
    assert multiprocessing.active_children() == [], "an analysis process outlived its watcher"


@pytest.fixture(scope="module", autouse=True)
def _stop_fork_server() -> Iterator[None]:
    """The analysis processes fork from multiprocessing's fork server, which would live
    on until pytest exits: stop it after this module."""
    yield
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    stop = getattr(server, "_stop", None)
    if callable(stop):
        stop()


@pytest.fixture
def folders(tmp_path: Path) -> tuple[Path, Path]:
    inbox, reports = tmp_path / "inbox", tmp_path / "reports"
    inbox.mkdir()
    return inbox, reports


@pytest.fixture(autouse=True)
def _info_logs(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="analyzer.watch")


# --------------------------------------------------------------------------- tests


def test_drop_folder_end_to_end(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    settings = WatchSettings(inbox, reports, settle=SETTLE, jobs=2)
    w = start_watcher(settings)
    wait_until(lambda: (reports / "index.html").exists(), "the watcher to start")

    # a good CSV, dropped whole
    write(inbox / "good.csv", "csv", seed=1)
    # an MCAP written in two halves, the second long after --settle
    mcap = write(tmp_path / "src.mcap", "mcap", seed=2, fault=True).read_bytes()
    slow = inbox / "slow.mcap"
    slow.write_bytes(mcap[: len(mcap) // 2])
    # a ROS 2 bag directory whose metadata.yaml comes last, as rosbag2 writes it
    src_bag = write(tmp_path / "src_bag", "ros2bag", seed=3)
    bag = inbox / "mission"
    bag.mkdir()
    storage = next(src_bag.glob("*.db3"))
    shutil.copy2(storage, bag / "mission.db3")
    # and a corrupt file
    corrupt_mcap(inbox / "broken.mcap")
    before = digests([inbox / "good.csv", inbox / "broken.mcap"])

    wait_until(lambda: {"good.csv", "broken.mcap"} <= state(reports).keys(), "good + broken")
    time.sleep(4 * SETTLE)  # both incomplete archives have long been stable
    assert {"slow.mcap", "mission"}.isdisjoint(started(caplog))
    assert not (reports / "slow.mcap").exists() and not (reports / "mission").exists()
    assert any(
        "waiting up to 10 min (--wait-unfinished) for slow.mcap to be complete: MCAP file "
        "without its closing magic" in r.getMessage()
        for r in caplog.records
    )

    with slow.open("ab") as f:
        f.write(mcap[len(mcap) // 2 :])
    (bag / "metadata.yaml").write_text(
        (src_bag / "metadata.yaml").read_text().replace(storage.name, "mission.db3")
    )
    before.update(digests([slow, bag]))
    wait_until(lambda: len(state(reports)) == 4, "all four archives")

    # each good archive has a report, the corrupt one an error record; the watcher lives on
    assert w.thread is not None and w.thread.is_alive()
    records = state(reports)
    assert records.keys() == {"good.csv", "slow.mcap", "mission", "broken.mcap"}
    assert records["broken.mcap"]["verdict"] == "error"
    assert records["slow.mcap"]["verdict"] == "fault"  # the injected 8-sigma offset
    assert records["slow.mcap"]["faulty_sensors"] == ["/s1.data"]
    for name in ("good.csv", "slow.mcap", "mission"):
        assert sorted(p.name for p in (reports / name).iterdir()) == [
            "findings.json",
            "report.html",
        ]
        findings = json.loads((reports / name / "findings.json").read_text())
        assert findings["inputs"][0]["errors"] == []
        assert records[name]["verdict"] == ("fault" if findings["faults"] else "no fault")
        assert records[name]["faulty_sensors"] == sorted({f["channel"] for f in findings["faults"]})
        assert records[name]["sha256"] == sha256_of(inbox / name)
    assert sorted(p.name for p in (reports / "broken.mcap").iterdir()) == ["error.txt"]
    error = (reports / "broken.mcap" / "error.txt").read_text().splitlines()[0]
    assert error and records["broken.mcap"]["error"] == error
    assert started(caplog).count("slow.mcap") == 1  # never analyzed while incomplete

    # the index is rewritten after the state file, index.json before index.html: under
    # load the page can lag the state by a moment (a full suite saw it once)
    links = [f'href="{records[name]["report"]}"' for name in records]
    wait_until(
        lambda: all(link in (reports / "index.html").read_text() for link in links),
        "index.html to list every archive",
    )
    index = json.loads((reports / "index.json").read_text())
    newest_first = sorted(records, key=lambda n: (str(records[n]["processed"]), n), reverse=True)
    assert [a["name"] for a in index["archives"]] == newest_first
    assert not [p for p in reports.iterdir() if p.name.startswith((".tmp-", ".old-"))]

    # clean stop: code 0, inputs untouched
    w.stop.set()
    assert w.join() == 0
    assert digests(sorted(inbox.iterdir())) == before

    # a restart analyzes nothing again
    caplog.clear()
    report_mtime = (reports / "good.csv" / "report.html").stat().st_mtime_ns
    again = start_watcher(replace(settings, once=True))
    assert again.join() == 2  # broken.mcap is left in INBOX in error (no --failed)
    assert started(caplog) == []
    assert state(reports) == records
    assert (reports / "good.csv" / "report.html").stat().st_mtime_ns == report_mtime

    # a changed file is analyzed again
    caplog.clear()
    write(tmp_path / "new.csv", "csv", seed=4, fault=True)
    os.replace(tmp_path / "new.csv", inbox / "good.csv")
    third = start_watcher(replace(settings, once=True))
    assert third.join() == 1  # --once: a fault found
    assert started(caplog) == ["good.csv"]
    changed = state(reports)["good.csv"]
    assert changed["verdict"] == "fault" and changed["sha256"] == sha256_of(inbox / "good.csv")
    assert digests(sorted(inbox.iterdir()))["mission"] == before["mission"]


def test_done_and_failed_folders_receive_the_archives(
    tmp_path: Path, folders: tuple[Path, Path], start_watcher: Callable[..., Watcher]
) -> None:
    inbox, reports = folders
    done, failed = tmp_path / "done", tmp_path / "failed"
    write(inbox / "good.csv", "csv", seed=5)
    corrupt_mcap(inbox / "broken.mcap")
    (inbox / "partial.csv.part").write_text("time,a\n0,1\n")  # a download in progress
    before = digests(sorted(inbox.iterdir()))
    done.mkdir()
    (done / "good.csv").write_text("an older file of the same name\n")
    settings = WatchSettings(
        inbox, reports, settle=SETTLE, poll=0.1, done=done, failed=failed, once=True
    )
    assert start_watcher(settings).join() == 2  # --once: an archive could not be analyzed
    assert sorted(p.name for p in inbox.iterdir()) == ["partial.csv.part"]
    assert sha256_of(done / "good-1.csv") == before["good.csv"]
    assert sha256_of(failed / "broken.mcap") == before["broken.mcap"]
    records = state(reports)
    assert records["good.csv"]["moved_to"] == [str(done / "good-1.csv")]
    assert records["broken.mcap"]["moved_to"] == [str(failed / "broken.mcap")]
    assert records["broken.mcap"]["verdict"] == "error"
    # the same content dropped again is moved again, and both copies stay listed (audit:
    # the second move replaced the first's in the record)
    shutil.copy(done / "good-1.csv", inbox / "good.csv")
    assert start_watcher(settings).join() == 0
    assert state(reports)["good.csv"]["moved_to"] == [
        str(done / "good-1.csv"),
        str(done / "good-2.csv"),
    ]


def test_once_says_how_far_it_is_and_how_long_is_left(
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    for seed in range(3):
        write(inbox / f"hour{seed}.csv", "csv", seed=10 + seed)
    (inbox / "notes.txt.part").write_text("not an archive")  # ignored: not counted
    settings = WatchSettings(inbox, reports, settle=SETTLE, jobs=1, once=True)
    assert start_watcher(settings).join() in (0, 1)  # (1 if a fault was found)
    ends = [
        r.getMessage()
        for r in caplog.records
        if re.match(r"hour\d\.csv: (no fault|fault|error)", r.getMessage())
    ]
    assert len(ends) == 3
    # (worded as run's progress words it, analyzer.time_left.left_text: a few seconds
    # each, "less than a minute left" unless the machine is very slow)
    left = r"(less than a minute|about \d+ min|about \d+(\.\d)? (h|days)) left"
    assert re.search(rf" \[1/3, {left}\]", ends[0]), ends
    assert re.search(rf" \[2/3, {left}\]", ends[1]), ends
    assert ends[2].endswith(" [3/3]") or " [3/3]:" in ends[2], ends
    verdicts = [e.split(": ")[1].split(" in ")[0] for e in ends]  # no fault / fault (..)
    (summary,) = [r.getMessage() for r in caplog.records if " analyzed" in r.getMessage()]
    assert summary.startswith("3 archives analyzed in ")
    assert f"{verdicts.count('no fault')} no fault" in summary or "no fault" not in verdicts
    assert summary.endswith(f"; index: {reports / 'index.html'}")
    # a second pass finds them recorded and one new: the counter counts analyses, the
    # three found analyzed already are not in it ("[4/4]" read as four analyzed, ux53)
    write(inbox / "hour3.csv", "csv", seed=13)
    caplog.clear()
    assert start_watcher(settings).join() in (0, 1)
    lines = [r.getMessage() for r in caplog.records if " [" in r.getMessage()]
    assert len(lines) == 1 and lines[0].startswith("hour3.csv: "), lines
    assert re.search(r" \[1/1\]($|: )", lines[0]), lines
    assert any(
        r.getMessage().startswith("1 archive analyzed in ")
        and "; 3 other archives found analyzed already, not analyzed again; index: "
        in r.getMessage()
        for r in caplog.records
    )


def test_archives_recorded_already_are_out_of_the_total_from_the_start(
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The total dropped only as the watcher reached the recorded archives: a new file
    that sorts before them (analyzed first) said ``[1/3, about 30 s left]`` for the
    pass's only analysis (review of ux53 item 13). Their records' signatures leave them
    out from the start, whatever the order."""
    inbox, reports = folders
    for name in ("b.csv", "c.csv"):
        write(inbox / name, "csv", seed=20 + len(name))
    settings = WatchSettings(inbox, reports, settle=SETTLE, jobs=1, once=True)
    assert start_watcher(settings).join() in (0, 1)
    write(inbox / "0.csv", "csv", seed=23)  # sorts before b and c: analyzed first
    caplog.clear()
    assert start_watcher(settings).join() in (0, 1)
    lines = [r.getMessage() for r in caplog.records if " [" in r.getMessage()]
    assert len(lines) == 1 and lines[0].startswith("0.csv: "), lines
    assert re.search(r" \[1/1\]($|: )", lines[0]), lines
    assert any(
        r.getMessage().startswith("1 archive analyzed in ")
        and "; 2 other archives found analyzed already" in r.getMessage()
        for r in caplog.records
    )


def test_the_time_left_comes_from_the_analyses_not_from_archives_found_recorded(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from types import SimpleNamespace

    from analyzer import watch as watch_module

    monkeypatch.setattr(watch_module.time, "monotonic", lambda: 1000.0)
    progress = watch_module._Runner.progress
    # 4000 of a year recorded (out of the total from the start), then 10 analyses in
    # 100 s: 10 s each
    todo = frozenset(f"h{i}" for i in range(4000, 8760))
    state = SimpleNamespace(expected=todo, results=range(10), skipped=set(), begun=900.0)
    assert progress(state) == " [10/4760, about 13 h left]"  # 4750 x 10 s
    three = frozenset("abc")
    state = SimpleNamespace(expected=three, results=range(1), skipped=set(), begun=990.0)
    assert progress(state) == " [1/3, less than a minute left]"  # (as run says 20 s)
    # two counted at the start found recorded after all (a file touched, same content),
    # and one found recorded that was not there at the start (dropped again): not counted
    state = SimpleNamespace(expected=three, results=range(0), skipped={"a", "b", "z"}, begun=None)
    assert progress(state) == " [0/1]"  # (none analyzed yet)
    assert progress(SimpleNamespace(expected=None)) == ""


def test_without_once_there_is_no_total(
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    w = start_watcher(WatchSettings(inbox, reports, settle=SETTLE, jobs=1))
    write(inbox / "one.csv", "csv", seed=20)
    wait_until(lambda: "one.csv" in state(reports), "one.csv")
    w.stop.set()
    assert w.join() == 0
    (line,) = [r.getMessage() for r in caplog.records if r.getMessage().startswith("one.csv: no")]
    assert "[" not in line


def test_group_by_analyzes_an_hour_as_one_archive(
    folders: tuple[Path, Path], start_watcher: Callable[..., Watcher]
) -> None:
    inbox, reports = folders
    t_ns, data = building(seed=6)
    half = len(t_ns) // 2
    for part, sl, start in (
        ("a", slice(None, half), "2026-01-01T10:00:00Z"),
        ("b", slice(half, None), "2026-01-01T10:00:20Z"),
    ):
        write_archive(
            inbox / f"site_20260101T10_{part}.csv",
            "csv",
            t_ns[sl],
            {k: v[sl] for k, v in data.items()},
            start_iso=start,
        )
    settings = WatchSettings(
        inbox, reports, settle=SETTLE, group_by=re.compile(r"_(\d{8}T\d{2})_"), once=True
    )
    assert start_watcher(settings).join() in (0, 1)
    (record,) = state(reports).values()
    assert record["name"] == "20260101T10" and record["verdict"] in ("fault", "no fault")
    assert [Path(p).name for p in record["inputs"]] == [
        "site_20260101T10_a.csv",
        "site_20260101T10_b.csv",
    ]
    findings = json.loads((reports / "20260101T10" / "findings.json").read_text())
    assert len(findings["inputs"]) == 2
    assert findings["duration_s"] == pytest.approx(40.0, abs=0.1)


def test_second_watcher_is_refused(
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
) -> None:
    inbox, reports = folders
    start_watcher(WatchSettings(inbox, reports, settle=SETTLE))
    wait_until(  # its last start-up line, which must not land in the stderr checked below
        lambda: any(r.getMessage().startswith("watching ") for r in caplog.records),
        "the first watcher to start",
    )
    with pytest.raises(UsageError, match=r"is in use by another watcher \(pid \d+\)"):
        watch(WatchSettings(inbox, reports, settle=SETTLE, once=True), OPTIONS)
    code = main(["watch", str(inbox), "--out", str(reports), "--once", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "in use by another watcher" in err


def own_tempdir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A TMPDIR of the test's own, where the watcher makes its analyses' scratch space
    (``analyzer-watch-*``): what is left there is this test's watcher's alone. Before,
    the tests compared the shared TMPDIR before and after, and a watcher of another
    process (another pytest) that made one meanwhile failed them."""
    temp = tmp_path / "tmp"
    temp.mkdir()
    monkeypatch.setenv("TMPDIR", str(temp))
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    return temp


def test_stop_waits_for_the_running_analysis_and_a_second_stop_abandons_it(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    inbox, reports = folders
    temp = own_tempdir(tmp_path, monkeypatch)
    write(tmp_path / "long.csv", "csv", seconds=300.0, rate=200.0, floors=5)
    w = start_watcher(WatchSettings(inbox, reports, settle=SETTLE, jobs=1))
    wait_until(lambda: (reports / "index.html").exists(), "the watcher to start")
    os.replace(tmp_path / "long.csv", inbox / "long.csv")
    wait_until(lambda: started(caplog) == ["long.csv"], "the analysis to start")
    assert list(temp.glob("analyzer-watch-*")), "its scratch space is not where this looks"
    w.stop.set()
    time.sleep(0.3)
    assert w.thread is not None and w.thread.is_alive()  # waiting for the analysis
    w.abandon.set()
    assert w.join(timeout=15) == 0
    assert any(r.getMessage().startswith("long.csv: abandoned") for r in caplog.records)
    assert state(reports) == {}
    assert sorted(p.name for p in reports.iterdir()) == [
        ".lock",
        ".watch-state.json",
        "index.html",
        "index.json",
    ]
    # the abandoned analysis took its scratch space with it
    assert not list(temp.glob("analyzer-watch-*"))


def test_a_crashed_analysis_is_an_error_record_and_the_watcher_goes_on(
    tmp_path: Path,
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """An analysis process killed outright (as the OOM killer would) is an error record
    with its cause, and the watcher goes on with the next archive.

    The kill follows the analysis's start by a poll of the log (50 ms), about 1.3 s
    before that analysis would end; should it have ended anyway (this thread kept off
    the CPU that long on a loaded machine), nothing was tested: then again, on an
    archive 4x as long."""
    inbox, reports = folders
    temp = own_tempdir(tmp_path, monkeypatch)
    seen: set[Path] = set()
    w = start_watcher(WatchSettings(inbox, reports, settle=SETTLE, jobs=1))
    wait_until(lambda: (reports / "index.html").exists(), "the watcher to start")
    for attempt, seconds in enumerate((300.0, 1200.0)):
        name = f"long{attempt}.csv"
        write(tmp_path / name, "csv", seconds=seconds, rate=200.0, floors=5)
        os.replace(tmp_path / name, inbox / name)
        wait_until(lambda: name in started(caplog), "the analysis to start")  # noqa: B023
        children = multiprocessing.active_children()  # (reaps those that have ended)
        if children:
            seen.update(temp.glob("analyzer-watch-*"))  # (its scratch space, before the kill)
            (child,) = children
            assert child.pid is not None
            os.kill(child.pid, signal.SIGKILL)  # as the OOM killer would
        wait_until(lambda: name in state(reports), "the crash to be recorded")  # noqa: B023
        record = state(reports)[name]
        if attempt == 0 and (not children or child.exitcode != -signal.SIGKILL):
            assert record["verdict"] in ("no fault", "fault"), record  # ended before
            continue
        assert record["verdict"] == "error"
        assert record["error"] == "analysis process killed by SIGKILL"
        assert (reports / name / "error.txt").read_text() == record["error"] + "\n"
        break
    corrupt_mcap(inbox / "next.mcap")
    wait_until(lambda: "next.mcap" in state(reports), "the next archive")
    assert w.thread is not None and w.thread.is_alive()
    # the killed analysis's scratch space was the watcher's to remove
    assert seen, "its scratch space is not where this test looks"
    assert not list(temp.glob("analyzer-watch-*"))


def test_cli_watcher_finishes_the_running_analysis_on_sigterm(
    folders: tuple[Path, Path],
) -> None:
    inbox, reports = folders
    write(inbox / "good.csv", "csv", seed=8)
    cmd = [sys.executable, "-m", "analyzer", "watch", str(inbox), "--out", str(reports)]
    cmd += ["--settle", str(SETTLE), "--train", "0:12", "--jobs", "1", "--no-progress"]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True)
    lines: queue.SimpleQueue[str] = queue.SimpleQueue()

    def read() -> None:
        for line in proc.stderr or ():
            lines.put(line)

    reader = threading.Thread(target=read)
    reader.start()
    err: list[str] = []
    try:
        end = time.monotonic() + TIMEOUT
        while not any("good.csv: start (1 input" in line for line in err):
            err.append(lines.get(timeout=max(0.0, end - time.monotonic())))
        proc.send_signal(signal.SIGTERM)  # while good.csv is being analyzed
        proc.wait(TIMEOUT)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        reader.join(10)
    while not lines.empty():
        err.append(lines.get())
    text = "".join(err)
    assert proc.returncode == 0, text
    assert "stopping: waiting for 1 running analysis to finish" in text  # (ux53 item 13)
    assert re.search(r"good\.csv: (no fault|fault \(.*\)) in \d+\.\d s", text), text
    assert err[-1].rstrip().endswith("analyzer watch: stopped")
    assert state(reports)["good.csv"]["verdict"] in ("fault", "no fault")
    assert (reports / "good.csv" / "report.html").is_file()


def test_cli_help_documents_the_move_options(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["watch", "--help"])
    assert exit_.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "--done DIR move each analyzed archive here" in out
    assert "--failed DIR move each archive that could not be read here" in out


def test_bad_folders_and_patterns_are_usage_errors(
    folders: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    inbox, reports = folders
    file = inbox.parent / "file.txt"
    file.write_text("not a folder")
    cases = [
        ([str(inbox / "missing"), "--out", str(reports)], "is not a directory"),
        ([str(inbox), "--out", str(file / "r")], "^analyzer: error: --out: cannot write to "),
        (
            [str(inbox), "--out", str(reports), "--done", str(file / "d")],
            "^analyzer: error: --done: cannot write to .*: Not a directory$",
        ),
        ([str(inbox), "--out", str(inbox)], "--out: .* is INBOX itself"),
        ([str(inbox), "--out", str(reports), "--group-by", "("], "--group-by: '\\(' is not a"),
        ([str(inbox), "--out", str(reports), "--group-by", r"\d+"], "has no group"),
    ]
    for argv, message in cases:
        assert main(["watch", *argv, "--once"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and re.search(message, err), err


def test_a_screened_watcher_records_how_each_archive_was_analyzed(
    folders: tuple[Path, Path],
    start_watcher: Callable[..., Watcher],
) -> None:
    """``watch --screen``: a healthy archive is analyzed by the screening's detector
    alone, a faulty one by every detector after it, and the state and the index say so."""
    inbox, reports = folders
    w = start_watcher(
        WatchSettings(inbox, reports, settle=SETTLE, jobs=1),
        replace(OPTIONS, screen=["equivalent_model"]),
    )
    wait_until(lambda: (reports / "index.html").exists(), "the watcher to start")
    write(inbox / "healthy.csv", "csv", seed=1)
    write(inbox / "faulty.csv", "csv", seed=2, fault=True)
    wait_until(lambda: {"healthy.csv", "faulty.csv"} <= state(reports).keys(), "both archives")
    records = state(reports)
    assert records["healthy.csv"]["verdict"] == "no fault"
    assert records["healthy.csv"]["screen"] == {"detectors": ["equivalent_model"], "fault": False}
    assert records["faulty.csv"]["verdict"] == "fault"
    assert records["faulty.csv"]["screen"] == {"detectors": ["equivalent_model"], "fault": True}
    found = json.loads((reports / "faulty.csv" / "findings.json").read_text())
    assert len(found["detectors"]) == 3
    w.stop.set()
    assert w.join(timeout=TIMEOUT) == 0
    assert "screened by equivalent_model alone" in (reports / "index.html").read_text()


def test_wait_unfinished_hands_a_truncated_file_on_after_its_seconds(
    folders: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``watch --once`` over a folder of finished copies, one of them a damaged MCAP:
    waited for 10 minutes by default; ``--wait-unfinished 1`` hands it on after a second,
    with its error record, and the run ends (exit 2: an archive could not be analyzed)."""
    inbox, reports = folders
    cut = corrupt_mcap(tmp_path / "src.mcap").read_bytes()[:-8]  # no closing magic
    (inbox / "cut.mcap").write_bytes(cut)
    write(inbox / "good.csv", "csv", seed=1)
    argv = ["watch", str(inbox), "--out", str(reports), "--once", "--train", "0:12"]
    began = time.monotonic()
    code = main([*argv, "--settle", str(SETTLE), "--wait-unfinished", "1", "--no-progress"])
    assert code == 2, capsys.readouterr().err
    assert time.monotonic() - began < TIMEOUT
    records = state(reports)
    assert records["cut.mcap"]["verdict"] == "error"
    assert records["good.csv"]["verdict"] == "no fault"
    err = capsys.readouterr().err
    assert "waiting up to 1.0 s (--wait-unfinished) for cut.mcap to be complete" in err, err
    assert (inbox / "cut.mcap").read_bytes() == cut  # never modified


def test_wait_unfinished_must_be_a_positive_number(
    folders: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    inbox, reports = folders
    for value in ("0", "-3", "soon"):
        argv = ["watch", str(inbox), "--out", str(reports), "--once", "--wait-unfinished", value]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--wait-unfinished" in err, err

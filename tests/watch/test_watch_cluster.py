"""``analyzer watch --scheduler``: every archive's analysis is a task of a real local Dask
cluster (two worker processes) whose worker reads the archive itself; the records,
findings and errors are the local watcher's. :class:`ClusterTask` (the watcher's view of
one task) is checked on its own with plain futures: results, failures and cancels."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import socket
import threading
from concurrent.futures import Future
from multiprocessing.connection import wait as wait_for
from pathlib import Path
from typing import Any

import pytest
from test_watch_run import (  # this folder is on sys.path
    OPTIONS,
    _stop_fork_server,  # noqa: F401 - stops the local watcher's server
    corrupt_mcap,
    write,
)

from analyzer.cli import main
from analyzer.pipeline import RunOptions
from analyzer.watch import WatchSettings, watch
from analyzer.watch_cluster import CANCELLED, ClusterTask, analyze_on_worker

BLAS_ENV = {v: "1" for v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}


@pytest.fixture(scope="module")
def cluster() -> Any:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, env=BLAS_ENV
    ) as c:
        yield c


def _records(reports: Path) -> dict[str, dict[str, Any]]:
    doc = json.loads((reports / ".watch-state.json").read_text())
    return {
        name: {k: rec.get(k) for k in ("verdict", "faulty_sensors", "faults", "error")}
        for name, rec in doc["archives"].items()
    }


def test_cluster_watcher_gives_the_local_watcher_s_records_and_reports(
    cluster: Any, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    write(inbox / "good.csv", "csv", seed=1)
    write(inbox / "fault.mcap", "mcap", seed=2, fault=True)
    write(inbox / "second.mcap", "mcap", seed=3, fault=True)
    corrupt_mcap(inbox / "broken.mcap")
    before = {p.name: p.read_bytes() for p in inbox.iterdir()}
    caplog.set_level(logging.INFO, logger="analyzer.watch")

    local, remote = tmp_path / "local", tmp_path / "remote"
    # exit code 1: a fault was found (before the error of broken.mcap)
    assert watch(WatchSettings(inbox, local, settle=0.2, once=True, jobs=2), OPTIONS) == 1
    on_cluster = RunOptions(train=OPTIONS.train, scheduler=cluster.scheduler_address)
    assert watch(WatchSettings(inbox, remote, settle=0.2, once=True, jobs=1), on_cluster) == 1
    # each archive was one task of the cluster, computed by a worker
    tasks = cluster.scheduler.task_prefixes["analyze_on_worker"].state_counts
    assert tasks["memory"] == 4

    assert any(
        "analyses as cluster tasks on Dask scheduler" in r.getMessage() for r in caplog.records
    )
    records = _records(remote)
    assert records == _records(local)
    assert records["fault.mcap"]["verdict"] == "fault"
    assert records["broken.mcap"]["verdict"] == "error" and records["good.csv"]["verdict"]
    for name in ("good.csv", "fault.mcap", "second.mcap"):
        assert sorted(p.name for p in (remote / name).iterdir()) == ["findings.json", "report.html"]
        ours, theirs = (
            json.loads((d / name / "findings.json").read_text()) for d in (remote, local)
        )
        assert ours["faults"] == theirs["faults"]
        assert ours["channels"] == theirs["channels"]
        assert (remote / name / "report.html").read_text().startswith("<!doctype html>")
    assert (remote / "broken.mcap" / "error.txt").read_text().splitlines()[0] == (
        local / "broken.mcap" / "error.txt"
    ).read_text().splitlines()[0]
    assert {p.name: p.read_bytes() for p in inbox.iterdir()} == before  # inputs untouched
    assert not [p for p in remote.iterdir() if p.name.startswith((".tmp-", ".old-"))]


def test_unreachable_scheduler_is_exit_2_in_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("distributed")
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    write(inbox / "good.csv", "csv", seed=1)
    argv = ["watch", str(inbox), "--out", str(tmp_path / "reports"), "--once"]
    assert main([*argv, "--scheduler", f"tcp://127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scheduler" in err[0] and "cannot connect" in err[0]
    assert not (tmp_path / "reports" / ".watch-state.json").exists()


def test_a_worker_that_cannot_see_the_archive_says_so(tmp_path: Path) -> None:
    missing = str(tmp_path / "elsewhere" / "a.mcap")
    code, files = analyze_on_worker([missing], OPTIONS)
    assert code == 2 and list(files) == ["error.txt"]
    text = files["error.txt"].decode()
    assert text.startswith(f"{missing}: not found on the cluster worker {socket.gethostname()}")
    assert "same path on every worker" in text


def test_a_worker_reads_the_watchers_msg_path(tmp_path: Path, monkeypatch) -> None:
    """``watch --msg-path`` goes with each task: the worker reads the definitions itself
    (and says so when it cannot see them); the archive is then analyzed as it is
    locally."""
    from analyzer.types import MSG_PATH_ENV

    monkeypatch.setenv(MSG_PATH_ENV, "")  # the task sets it on the worker: restored after
    archive = write(tmp_path / "a.mcap", "mcap", seed=2, fault=True)
    nowhere = str(tmp_path / "msgs")
    code, files = analyze_on_worker([str(archive)], OPTIONS, nowhere)
    assert code == 2 and list(files) == ["error.txt"]
    text = files["error.txt"].decode()
    assert text.startswith(f"--msg-path: {nowhere}: no such directory on the cluster worker")
    msg = tmp_path / "msgs" / "plant_msgs" / "msg"
    msg.mkdir(parents=True)
    (msg / "Strain.msg").write_text("float64 value\n")
    code, files = analyze_on_worker([str(archive)], OPTIONS, nowhere)
    assert code == 1 and _report(files) == ["findings.json", "report.html"]
    assert os.environ[MSG_PATH_ENV] == nowhere


def _report(files: dict[str, bytes]) -> list[str]:
    """The report's files among what a worker returns (beside them: the warnings ``run``
    would print, for the watcher to log, :data:`analyzer.watch.CONFIG_WARNINGS`)."""
    return sorted(name for name in files if not name.startswith("."))


def test_analyze_on_worker_returns_the_report_files(tmp_path: Path) -> None:
    archive = write(tmp_path / "a.mcap", "mcap", seed=2, fault=True)
    code, files = analyze_on_worker([str(archive)], OPTIONS)
    assert code == 1 and _report(files) == ["findings.json", "report.html"]
    assert json.loads(files["findings.json"])["faults"][0]["channel"] == "/s1.data"


class _FakeClient:
    def __init__(self) -> None:
        self.future: Future[Any] = Future()
        self.calls: list[tuple[Any, ...]] = []

    def submit(self, fn: Any, *args: Any, pure: bool = True) -> Future[Any]:
        self.calls.append((fn, *args))
        return self.future


class _FakeExecutor:
    def __init__(self) -> None:
        self.client = _FakeClient()


def _task(tmp_path: Path) -> tuple[ClusterTask, _FakeExecutor]:
    ex = _FakeExecutor()
    out = tmp_path / "out"
    out.mkdir(exist_ok=True)
    return ClusterTask(ex, ["x.mcap"], "options", out), ex  # type: ignore[arg-type]


def test_cluster_task_writes_the_returned_files_when_it_ends(tmp_path: Path) -> None:
    task, ex = _task(tmp_path)
    assert ex.client.calls == [(analyze_on_worker, ["x.mcap"], "options", "")]
    assert task.is_alive() and task.exitcode is None
    assert wait_for([task.sentinel], timeout=0.05) == []  # not ended: not readable
    threading.Timer(0.1, ex.client.future.set_result, ((1, {"findings.json": b"{}"}),)).start()
    assert wait_for([task.sentinel], timeout=10) == [task.sentinel]
    task.join()
    assert task.exitcode == 1 and not task.is_alive()
    assert (task.out / "findings.json").read_bytes() == b"{}"


def test_a_failed_task_is_an_error_record_and_a_cancelled_one_is_abandoned(
    tmp_path: Path,
) -> None:
    task, ex = _task(tmp_path)
    ex.client.future.set_exception(RuntimeError("worker lost twice"))
    task.join()
    assert task.exitcode == 3
    assert (task.out / "error.txt").read_text() == (
        "internal error: the analysis task failed on the cluster: RuntimeError: worker lost twice\n"
    )
    (tmp_path / "b").mkdir()
    other, _ = _task(tmp_path / "b")
    other.terminate()  # by the watcher: abandoned, nothing written
    other.join(timeout=1)
    assert other.exitcode == CANCELLED and list(other.out.iterdir()) == []
    assert os.listdir(tmp_path / "b" / "out") == []
    # cancelled by the cluster, not by the watcher (a scheduler that went away): an error
    (tmp_path / "c").mkdir()
    lost, ex3 = _task(tmp_path / "c")
    ex3.client.future.cancel()
    lost.join(timeout=1)
    assert lost.exitcode == 3
    assert (
        (lost.out / "error.txt")
        .read_text()
        .startswith("internal error: the analysis task cancelled by the cluster: CancelledError")
    )


def test_cluster_watcher_with_a_saved_model_gives_the_local_records(
    cluster: Any, tmp_path: Path
) -> None:
    from dataclasses import replace

    from analyzer.pipeline import load_options

    write(tmp_path / "healthy.mcap", "mcap", seed=5)
    model = tmp_path / "building.model"
    fit = ["run", str(tmp_path / "healthy.mcap"), "--out", str(tmp_path / "fit")]
    assert main([*fit, "--train", "0:30", "--save-model", str(model), "--no-progress"]) == 0
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    write(inbox / "a.mcap", "mcap", seed=6)
    write(inbox / "b.mcap", "mcap", seed=7, fault=True)
    saved = load_options(None, model=str(model))  # as the command line loads it
    moved = tmp_path / "moved.model"
    os.replace(model, moved)  # the workers need not see the file, nor the watcher after
    local, remote = tmp_path / "local", tmp_path / "remote"
    settings = WatchSettings(inbox, local, settle=0.2, once=True, jobs=2)
    assert watch(settings, saved) == 1  # b.mcap's fault
    on_cluster = replace(saved, scheduler=cluster.scheduler_address)
    assert watch(WatchSettings(inbox, remote, settle=0.2, once=True), on_cluster) == 1
    records = _records(remote)
    assert records == _records(local)
    assert records["b.mcap"]["verdict"] == "fault" and records["b.mcap"]["faulty_sensors"]
    for name in ("a.mcap", "b.mcap"):
        ours, theirs = (
            json.loads((d / name / "findings.json").read_text()) for d in (remote, local)
        )
        assert ours["model"] == theirs["model"]
        assert ours["model"]["sha256"] == hashlib.sha256(moved.read_bytes()).hexdigest()
        assert ours["faults"] == theirs["faults"]


def test_jobs_with_a_scheduler_is_said_not_used(
    cluster: Any, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """``watch --jobs 4 --scheduler ...``: the cluster sets how many archives are analyzed
    at once, and the watcher's first line says ``--jobs`` is not used (it was ignored
    without a word: a new user's audit, ux53 item 11); ``--help`` says so too."""
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    caplog.set_level(logging.INFO, logger="analyzer.watch")
    options = RunOptions(train=OPTIONS.train, scheduler=cluster.scheduler_address, jobs=4)
    assert watch(WatchSettings(inbox, tmp_path / "reports", settle=0.2, once=True), options) == 0
    (line,) = [r.getMessage() for r in caplog.records if r.getMessage().startswith("watching ")]
    assert "--jobs 4 not used: the cluster's worker threads set" in line, line
    caplog.clear()
    options = RunOptions(train=OPTIONS.train, scheduler=cluster.scheduler_address)
    assert watch(WatchSettings(inbox, tmp_path / "reports", settle=0.2, once=True), options) == 0
    assert not [r for r in caplog.records if "--jobs" in r.getMessage()]

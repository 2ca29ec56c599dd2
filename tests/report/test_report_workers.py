"""Figures drawn by worker processes (analyzer.report.workers): the same page byte for
byte as in-process drawing, every figure still drawn when the pool breaks, no matplotlib
in the main process, and nothing left behind (processes, files in TMPDIR)."""

from __future__ import annotations

import json
import multiprocessing
import os
import re
import subprocess
import sys
import uuid
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest

import analyzer
from analyzer.pipeline import RunOptions, analyze, findings_document
from analyzer.report import render_report
from analyzer.report.jobs import FigureJob
from analyzer.report.workers import FigureBatch, FigureWorkers, active_workers, figure_workers

ROOT = Path(analyzer.__file__).resolve().parent.parent
SAMPLE = ROOT / "samples" / "building_additive.mcap"

pytestmark = pytest.mark.skipif(
    "forkserver" not in multiprocessing.get_all_start_methods(), reason="needs a forkserver"
)


@pytest.fixture(scope="module")
def sample():
    """A bundled sample with a fault and the corrected signal: every kind of figure."""
    analysis = analyze([SAMPLE], RunOptions(corrected=True))
    assert analysis.findings
    doc = findings_document(analysis)
    return analysis, doc, render_report(analysis, doc)


def _kinds(html: str) -> list[str]:
    return re.findall(r'<figure class="plot" data-kind="(\w+)">', html)


def _server_pid() -> int | None:
    server = getattr(multiprocessing.forkserver, "_forkserver", None)
    return getattr(server, "_forkserver_pid", None)


@pytest.fixture(autouse=True)
def _no_server_left_by_other_tests():
    """These tests check that a figure pool stops the fork server it started; one left
    running by an earlier test in this process (the watcher's forked analyses) is
    stopped first, so that the check is about the pool (it failed when tests/watch ran
    before this file)."""
    if _server_pid() is not None:
        multiprocessing.forkserver._forkserver._stop()
    yield


def test_pool_draws_the_same_page_as_in_process(sample, monkeypatch):
    analysis, doc, in_process = sample
    kinds = _kinds(in_process)
    assert {"signal", "residual", "tests", "corrected", "coverage"} <= set(kinds)
    submitted, failures = [], []
    submit = FigureWorkers.submit

    def spy_submit(self, job):
        future = submit(self, job)
        submitted.append(future)
        return future

    monkeypatch.setattr(FigureWorkers, "submit", spy_submit)
    monkeypatch.setattr(FigureWorkers, "failed", lambda self, err: failures.append(err))
    with figure_workers() as workers:
        assert workers is not None and workers.usable
        assert active_workers() is workers
        pooled = render_report(analysis, doc)  # the pool of the context, implicitly
    assert active_workers() is None
    # every figure went to the pool and came back from it
    assert len(submitted) == len(kinds) and None not in submitted and failures == []
    assert pooled == in_process
    # the context stopped its workers and its server: nothing outlives it
    assert multiprocessing.active_children() == []
    assert _server_pid() is None


def test_a_broken_pool_still_draws_every_figure(sample, monkeypatch):
    """A worker dying (BrokenProcessPool), at submission or on a job: the figures the
    pool did not deliver are drawn in-process, the page is the same."""
    analysis, doc, in_process = sample
    calls = {"n": 0}

    def flaky_submit(self, fn, *args, **kwargs):
        calls["n"] += 1
        if calls["n"] == 1:
            future: Future[str] = Future()
            future.set_result(fn(*args, **kwargs))  # the first figure comes back fine
            return future
        if calls["n"] == 2:
            future = Future()
            future.set_exception(BrokenProcessPool("a worker died"))
            return future
        raise BrokenProcessPool("the pool is broken")

    monkeypatch.setattr("concurrent.futures.ProcessPoolExecutor.submit", flaky_submit)
    workers = FigureWorkers()
    try:
        html = render_report(analysis, doc, workers)
        assert calls["n"] >= 2
        assert not workers.usable  # given up after the failure: the rest in-process
    finally:
        workers.close()
    assert html == in_process
    assert multiprocessing.active_children() == [] and _server_pid() is None


def test_a_job_that_cannot_be_pickled_is_drawn_in_process():
    """Pickling happens in the executor's feeder thread: the error comes back on the
    future, and the batch draws that figure here."""
    import numpy as np

    class Unpicklable(np.ndarray):
        def __reduce__(self):
            raise TypeError("no pickling here")

    t = np.arange(50, dtype=np.float64).view(Unpicklable)
    y = np.sin(np.arange(50, dtype=np.float64))
    job = FigureJob("signal_figure", (t, y, None, "", 10.0, None, "x", "k"))
    plain = FigureJob("signal_figure", (np.arange(50.0), y, None, "", 10.0, None, "x", "k"))
    with figure_workers() as workers:
        batch = FigureBatch(workers)
        batch.add(plain)
        batch.add(job)
        first, second = batch.results()
    assert first == second and first.startswith("<svg")


def test_the_figure_processes_yield_the_cpu_to_the_run():
    """The server (and so every worker forked from it) runs NICENESS below this process:
    its matplotlib import must not compete with the run's reading."""
    from analyzer.report.workers import NICENESS

    own = os.getpriority(os.PRIO_PROCESS, 0)
    with figure_workers() as workers:
        assert workers is not None
        pid = _server_pid()
        assert pid is not None
        assert os.getpriority(os.PRIO_PROCESS, pid) == min(19, own + NICENESS)
    assert _server_pid() is None


def test_no_forkserver_means_in_process(sample, monkeypatch):
    analysis, doc, in_process = sample

    def no_server():
        raise OSError("cannot start")

    monkeypatch.setattr("multiprocessing.forkserver.ensure_running", no_server)
    with figure_workers() as workers:
        assert workers is None
        assert render_report(analysis, doc) == in_process


_CODE = """
import json, sys
from analyzer.cli import main
code = main(sys.argv[1:], figure_processes=True)
print(json.dumps({"code": code, "matplotlib": "matplotlib" in sys.modules}))
"""


def _leftovers(marker: str) -> list[int]:
    """Processes (of this user) whose environment holds ``marker``."""
    found = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit() or int(d.name) == os.getpid():
            continue
        try:
            if marker.encode() in (d / "environ").read_bytes():
                found.append(int(d.name))
        except OSError:
            continue
    return found


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_cli_pool_path_imports_no_matplotlib_and_leaves_nothing(tmp_path, sample):
    """The CLI with figure workers, in a fresh interpreter: the main process never
    imports matplotlib, the page matches in-process drawing (run times aside), and once
    it exits no process of it (server, workers) is left and TMPDIR is empty."""
    _, _, in_process = sample
    marker = f"ANALYZER_TEST_MARKER={uuid.uuid4().hex}"
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "TMPDIR": str(scratch),
        marker.split("=")[0]: marker.split("=")[1],
    }
    out = tmp_path / "o"
    args = ["run", str(SAMPLE), "--out", str(out), "--corrected", "--no-progress"]
    done = subprocess.run(
        [sys.executable, "-c", _CODE, *args], capture_output=True, text=True, env=env, timeout=300
    )
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert seen == {"code": 1, "matplotlib": False}, done.stderr
    assert _leftovers(marker) == []
    assert not any(scratch.iterdir())

    def masked(html: str) -> str:
        return re.sub(r"Run time: [^<]*", "Run time: -", html)

    assert masked((out / "report.html").read_text(encoding="utf-8")) == masked(in_process)

    # the real entry point, as a user runs it
    done = subprocess.run(
        [sys.executable, "-m", "analyzer", "run", str(SAMPLE), "--out", str(tmp_path / "o2")],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert done.returncode == 1, done.stderr
    assert done.stderr.startswith("analyzer: 1 sensor fault found") and done.stderr.count("\n") == 1
    assert _leftovers(marker) == []
    assert not any(scratch.iterdir())


_PRELOAD = """
import importlib.abc, sys
class Broken(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "analyzer.report.figures" and BREAK:
            raise RuntimeError("a broken matplotlib configuration")
        return None
sys.meta_path.insert(0, Broken())
import analyzer.report.preload
print("matplotlib" in sys.modules, "analyzer.report.figures" in sys.modules)
"""


@pytest.mark.parametrize("broken", [False, True])
def test_the_fork_servers_preload_never_fails(broken):
    """A fork server stops on any preload error but ImportError (and the watcher's server
    with it, every analysis it was to fork): the preload imports the figure module when
    it can and swallows any error when it cannot."""
    code = f"BREAK = {broken}\n" + _PRELOAD
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    ).stdout.split()
    assert out == (["False", "False"] if broken else ["True", "True"])

"""The compiled kernels warmed once in the watcher's fork server, not per archive."""

from __future__ import annotations

import importlib
import multiprocessing
import multiprocessing.forkserver
import subprocess
import sys

import pytest

import analyzer.warm as warm_module
from analyzer.diagnosis import changes


@pytest.mark.skipif(changes._alarm_kernel is None, reason="numba not installed")
def test_warm_loads_the_hot_kernels_in_both_precisions():
    """In a fresh process, warm() leaves the alarm statistic's compiled kernel with its
    double- and single-precision machine code and the windowed tests' kernel with its
    own, which is what a process forked then (an analysis of the watcher) inherits: it
    calls them without loading anything. Nothing is loaded before it."""
    code = (
        "from analyzer.diagnosis import changes\n"
        "from analyzer.stats import _windowed_kernel as w\n"
        "before = len(changes._alarm_kernel.signatures) + len(w.window_kernel.signatures)\n"
        "from analyzer.warm import warm\n"
        "ok = warm()\n"
        "alarm = sorted({str(s[0].dtype) for s in changes._alarm_kernel.signatures})\n"
        "print(before, ok, ','.join(alarm), len(w.window_kernel.signatures))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, check=True
    ).stdout.split()
    assert out[:3] == ["0", "True", "float32,float64"], out
    assert int(out[3]) >= 1


def test_warm_never_raises(monkeypatch):
    """A warm-up that fails is dropped (the fork server must not stop on it)."""

    def broken(*args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(changes, "calibrate", broken)
    assert warm_module.warm() is False


def test_the_watchers_fork_server_preloads_the_warm_up():
    """The watcher's analyses are forked from a server that imported the pipeline, the
    figure module and the warm-up (which ran there)."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        pytest.skip("no fork server on this platform")
    from analyzer.watch import WARM_PRELOAD, _context

    ctx = _context()
    assert ctx.get_start_method() == "forkserver"
    preload = multiprocessing.forkserver._forkserver._preload_modules
    assert WARM_PRELOAD in preload and "analyzer.watch" in preload
    module = importlib.import_module(WARM_PRELOAD)
    assert module.WARMED is True


def test_an_analysis_that_starts_alone_gets_every_thread(tmp_path, monkeypatch):
    """With ``--jobs 2`` an archive that starts while nothing else runs or waits (the
    usual file an hour) is analyzed on two threads; one that starts beside others, or
    with more waiting, on one (the cores are shared); ``--jobs 1``: one thread always.
    The process started gets those options."""
    import threading

    from analyzer import watch as watch_module
    from analyzer.pipeline import RunOptions
    from analyzer.scratch import remove_scratch
    from analyzer.watch_inbox import ReadyArchive
    from analyzer.watch_index import Ledger

    started: list[RunOptions] = []

    class Process:
        def __init__(self, target, args, name, daemon):
            started.append(args[1])
            self.sentinel = 0

        def start(self):
            pass

    def runner(jobs: int) -> watch_module._Runner:
        settings = watch_module.WatchSettings(tmp_path / "in", tmp_path / "out", jobs=jobs)
        options = RunOptions(jobs=jobs)
        r = watch_module._Runner(settings, options, Ledger(tmp_path / "out"), threading.Event())
        monkeypatch.setattr(r, "ctx", type("Ctx", (), {"Process": Process})())
        return r

    def archive(name: str) -> ReadyArchive:
        path = tmp_path / "in" / name  # (in INBOX: the watcher reads nothing outside it)
        path.write_bytes(name.encode())
        return ReadyArchive(name, (path,), ((str(path), path.stat().st_size, 0),))

    (tmp_path / "out").mkdir()
    (tmp_path / "in").mkdir()
    r = runner(2)
    r._start(archive("a"))  # alone
    r.offer(archive("c"))  # waiting while b starts
    r._start(archive("b"))
    assert [o.jobs for o in started] == [2, 1]
    works = [job.work for job in r.running.values()]
    r.queue.clear()
    r.running.clear()
    assert r._options().jobs == 2
    r.offer(archive("d"))
    assert r._options().jobs == 1
    started.clear()
    single = runner(1)
    single._start(archive("e"))
    assert [o.jobs for o in started] == [1]
    for work in [*works, *(job.work for job in single.running.values())]:
        remove_scratch(work)

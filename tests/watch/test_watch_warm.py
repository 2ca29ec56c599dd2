"""The compiled kernels warmed once in the watcher's fork server, not per archive."""

from __future__ import annotations

import importlib
import multiprocessing
import multiprocessing.forkserver

import pytest

import analyzer.warm as warm_module
from analyzer.diagnosis import changes
from analyzer.stats import _windowed_kernel


@pytest.mark.skipif(changes._alarm_kernel is None, reason="numba not installed")
def test_warm_loads_the_hot_kernels_in_both_precisions():
    """After warm() the alarm statistic's and the windowed tests' compiled kernels hold
    their double- and single-precision machine code: a process forked then (an
    analysis of the watcher) calls them without loading anything."""
    assert warm_module.warm() is True
    alarm = {str(sig[0].dtype) for sig in changes._alarm_kernel.signatures}
    assert {"float64", "float32"} <= alarm
    assert _windowed_kernel.window_kernel is not None
    assert _windowed_kernel.window_kernel.signatures  # float64 windows (standardized)


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

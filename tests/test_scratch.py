"""Scratch directories that a killed process leaves behind are removed by the next command
(analyzer.scratch): by their lock, which the kernel drops when the process dies."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import analyzer
from analyzer.scratch import LOCK, hold, make_scratch, remove_scratch, scratch, sweep_stale

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="flock semantics checked on Linux"
)

ROOT = str(Path(analyzer.__file__).parent.parent)

_OWNER = """
import sys, time
from analyzer.scratch import make_scratch, hold
base, parent = sys.argv[1], sys.argv[2]
if parent == "-":
    path = make_scratch(base=base)
    (path / "data.bin").write_bytes(b"x" * 1000)
else:
    path = parent
    hold(path)
print(path, flush=True)
time.sleep(600)
"""


def _owner(base: Path, parent: str = "-") -> tuple[subprocess.Popen[str], Path]:
    """A process that makes (or, given ``parent``, holds) a scratch directory in ``base``
    and sleeps; returns it and the directory."""
    env = {**os.environ, "PYTHONPATH": ROOT}
    proc = subprocess.Popen(
        [sys.executable, "-c", _OWNER, str(base), parent],
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline().strip()
    assert line, "the owner process did not start"
    return proc, Path(line)


def _kill(proc: subprocess.Popen[str]) -> None:
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=30)


def test_a_killed_owners_directory_goes_and_a_living_ones_stays(tmp_path):
    proc, path = _owner(tmp_path)
    try:
        assert (path / LOCK).is_file() and path.name.startswith("analyzer-")
        assert sweep_stale(tmp_path, min_age_s=0) == []  # its owner lives
        assert (path / "data.bin").is_file()
    finally:
        _kill(proc)  # as kill -9 or the OOM killer would: nothing of its own clean-up runs
    assert path.is_dir()
    assert sweep_stale(tmp_path, min_age_s=60) == []  # too young to judge
    assert sweep_stale(tmp_path, min_age_s=0) == [path]
    assert not path.exists()


def test_a_worker_that_holds_the_directory_keeps_it_after_its_parent_died(tmp_path):
    parent, path = _owner(tmp_path)
    worker, same = _owner(tmp_path, str(path))
    assert same == path
    try:
        _kill(parent)
        assert sweep_stale(tmp_path, min_age_s=0) == []  # the worker still uses it
        assert path.is_dir()
    finally:
        _kill(worker)
    assert sweep_stale(tmp_path, min_age_s=0) == [path]


def test_directories_without_a_lock_and_other_names_are_never_touched(tmp_path):
    foreign = tmp_path / "analyzer-from-an-older-version"
    foreign.mkdir()
    other = tmp_path / "something-else"
    other.mkdir()
    (other / LOCK).write_text("")
    old = time.time() - 3600
    for p in (foreign, other):
        os.utime(p, (old, old))
    assert sweep_stale(tmp_path, min_age_s=0) == []
    assert foreign.is_dir() and other.is_dir()


def test_this_process_directories_are_its_own(tmp_path):
    path = make_scratch(base=tmp_path)
    assert sweep_stale(tmp_path, min_age_s=0) == []
    hold(path)  # holding twice is harmless
    remove_scratch(path)
    assert not path.exists()
    with scratch() as p:
        assert (p / LOCK).is_file()
    assert not p.exists()


def test_the_cli_sweeps_what_a_killed_run_left(tmp_path):
    """A stale directory in TMPDIR (its owner killed, an hour old) is gone after any
    command; a directory of a living process is not."""
    proc, stale = _owner(tmp_path)
    _kill(proc)
    old = time.time() - 3600
    os.utime(stale, (old, old))
    living, kept = _owner(tmp_path)
    os.utime(kept, (old, old))
    try:
        sample = Path(ROOT) / "samples" / "building_additive.mcap"
        env = {**os.environ, "PYTHONPATH": ROOT, "TMPDIR": str(tmp_path)}
        done = subprocess.run(
            [sys.executable, "-m", "analyzer", "inspect", str(sample)],
            capture_output=True,
            text=True,
            env=env,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr
        assert not stale.exists()
        assert kept.is_dir()
    finally:
        _kill(living)


def test_a_file_system_without_locks_still_gets_a_scratch_directory(tmp_path, monkeypatch):
    """flock failing (ENOLCK on some network file systems): the directory is made and
    used, without a lock file, so no sweep ever removes it."""
    import fcntl

    def no_locks(fd, op):
        raise OSError(37, "No locks available")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    path = make_scratch(base=tmp_path)
    assert path.is_dir() and list(path.iterdir()) == []
    monkeypatch.undo()
    old = time.time() - 3600
    os.utime(path, (old, old))
    assert sweep_stale(tmp_path, min_age_s=0) == []
    remove_scratch(path)
    assert not path.exists()

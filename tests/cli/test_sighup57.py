"""SIGHUP (a terminal closed, an ssh session dropped) stops ``run`` as SIGTERM and Ctrl-C
do (ux66 L1): exit 130, "interrupted", its scratch folder and multiprocessing's
``pymp-*`` folder removed, no new ``--out`` left. Before: exit 129, nothing said, a 50 MB
``analyzer-*`` folder and an empty ``--out`` left. Under ``nohup`` (SIGHUP ignored) the
run goes on."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive


def _csv(path: Path, seconds: float) -> Path:
    t, Y, names = simulate_building(n_floors=3, duration_s=seconds, seed=0)
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: Y[:, j] for j, n in enumerate(names)})
    return path


def _hup_once_scratch_is_made(
    case: Path, seconds: float, on_hup: Callable[[], object]
) -> tuple[subprocess.Popen[str], bool, str]:
    """``analyzer run`` of a ``seconds``-long CSV into ``case/o`` with TMPDIR ``case/tmp``,
    SIGHUP sent as soon as its scratch folder is there (``on_hup``: the child's SIGHUP
    disposition, set before it starts): the process, whether the signal went, stderr."""
    src = _csv(case / "long.csv", seconds)
    scratch = case / "tmp"
    scratch.mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-m", "analyzer", "run", str(src), "--out", str(case / "o")],
        env={**os.environ, "TMPDIR": str(scratch)},
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=on_hup,
    )
    deadline = time.monotonic() + 60
    while (
        not any(p.name.startswith("analyzer-") for p in scratch.iterdir())
        and proc.poll() is None
        and time.monotonic() < deadline
    ):
        time.sleep(0.01)
    sent = proc.poll() is None
    if sent:
        proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=300)
    return proc, sent, err


def test_sighup_stops_run_cleanly_without_leftovers(tmp_path: Path) -> None:
    """As ``test_sigterm_stops_cleanly_without_leftovers``: an archive 4x as long once
    more where the run ended before the signal could go (a loaded machine)."""
    for attempt, seconds in enumerate((600.0, 2400.0)):
        case = tmp_path / f"try{attempt}"
        case.mkdir()
        default = lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL)  # noqa: E731
        proc, sent, err = _hup_once_scratch_is_made(case, seconds, default)
        if not sent:
            assert proc.returncode == 0, err
            continue
        assert proc.returncode == 130, err
        assert "interrupted" in err and "Traceback" not in err
        left = [str(p) for p in (case / "tmp").rglob("*")]
        assert not left, left  # (no analyzer-* scratch folder, no pymp-*)
        assert not (case / "o").exists()
        return
    pytest.fail("the run ended before SIGHUP could be sent, twice")


def test_under_nohup_sighup_is_still_ignored(tmp_path: Path) -> None:
    ignored = lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN)  # noqa: E731
    proc, _, err = _hup_once_scratch_is_made(tmp_path, 600.0, ignored)
    assert proc.returncode in (0, 1), err
    assert (tmp_path / "o" / "findings.json").is_file()

"""What a default run imports: neither ``scipy.signal`` nor ``scipy.stats`` (together
~0.6-0.9 s of start-up, a third of a run on a one-minute file), and for an MCAP input
neither pyarrow nor the ROS 2 bag stack (~0.1 s). And how the console script ends: once
its output is flushed and the ``atexit`` handlers have run, without the interpreter's
teardown."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import analyzer
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 200.0

_CODE = """
import json, sys
from analyzer.cli import main
code = main(sys.argv[1:])
print(json.dumps({
    "code": code,
    "scipy.signal": "scipy.signal" in sys.modules,
    "scipy.stats": "scipy.stats" in sys.modules,
    "pyarrow": "pyarrow" in sys.modules,
    "rosbags.rosbag2": "rosbags.rosbag2" in sys.modules,
}))
"""


def test_default_run_imports_neither_scipy_signal_nor_scipy_stats(tmp_path: Path) -> None:
    """A default ``analyzer run`` (all detectors; the three that apply run) of a small MCAP
    with an offset fault, in a fresh interpreter, calling the CLI in-process."""
    t, Y, names = simulate_building(n_floors=4, duration_s=60.0, rate_hz=RATE, seed=2)
    Y[:, 2] = inject_fault(Y[:, 2], RATE, "additive", 35.0, 3.0 * float(np.std(Y[:, 2])))
    src = tmp_path / "small.mcap"
    write_archive(
        src,
        "mcap",
        np.round(t * 1e9).astype(np.int64),
        {n: Y[:, j] for j, n in enumerate(names)},
        start_iso="2026-03-01T12:00:00Z",
    )
    out = tmp_path / "o"
    env = {**os.environ, "PYTHONPATH": str(Path(analyzer.__file__).parent.parent)}
    done = subprocess.run(
        [sys.executable, "-c", _CODE, "run", str(src), "--out", str(out), "--no-progress"],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert seen["code"] == 1, done.stderr  # the fault was found: the detectors ran
    doc = json.loads((out / "findings.json").read_text())
    ran = {d if isinstance(d, str) else d["name"] for d in doc["detectors"]}
    assert {"ar_kalman_bank", "detection_filter", "equivalent_model"} <= ran
    assert not seen["scipy.signal"]
    assert not seen["scipy.stats"]
    assert not seen["pyarrow"]
    assert not seen["rosbags.rosbag2"]


_ENTRY = """
import atexit, sys
from analyzer import cli
mark = sys.argv.pop(1)
atexit.register(lambda: open(mark, "w").write("atexit ran"))
sys.argv[0] = "analyzer"
cli.entry()
"""


def test_console_script_ends_after_flushing_and_atexit(tmp_path: Path) -> None:
    """``entry`` ends ``inspect`` and ``run`` by ``os._exit`` after the atexit handlers:
    the exit status is the command's, stdout (a pipe, so block-buffered) arrives whole,
    and the handlers (multiprocessing's clean-up, temporary files' finalizers) have run."""
    t, Y, names = simulate_building(n_floors=2, duration_s=60.0, rate_hz=RATE, seed=3)
    src = tmp_path / "small.csv"
    write_archive(
        src, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, Y.T, strict=True))
    )
    env = {**os.environ, "PYTHONPATH": str(Path(analyzer.__file__).parent.parent)}
    for args, status in (
        (["inspect", str(src), "--json"], 0),
        (["run", str(tmp_path / "missing.mcap"), "--out", str(tmp_path / "o")], 2),
    ):
        mark = tmp_path / f"atexit-{args[0]}"
        done = subprocess.run(
            [sys.executable, "-c", _ENTRY, str(mark), *args],
            capture_output=True,
            text=True,
            env=env,
            timeout=300,
        )
        assert done.returncode == status, done.stderr
        assert mark.read_text() == "atexit ran"
        if args[0] == "inspect":
            doc = json.loads(done.stdout)  # the whole document
            assert {c["name"] for c in doc["channels"]} >= set(names)
        else:
            assert done.stderr.startswith("analyzer: error: ") and "missing.mcap" in done.stderr

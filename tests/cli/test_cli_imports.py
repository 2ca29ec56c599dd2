"""What a default run imports: neither ``scipy.signal`` nor ``scipy.stats`` (together
~0.6-0.9 s of start-up, a third of a run on a one-minute file)."""

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

"""SIGTERM is handled (exit 130, "analyzer: interrupted") from the moment the command is
known: a signal while the stale scratch folders of killed runs are swept, the first thing
a command does, ended the process by the signal itself (status 143, nothing said; a QA
audit's ux59 item L1). The signal is sent by the sweep itself, not at a time."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "samples" / "building_additive.mcap"

SCRIPT = """
import os, signal, sys
import analyzer.cli as cli
def sweep():
    os.kill(os.getpid(), signal.SIGTERM)
cli.sweep_stale = sweep
sys.exit(cli.main(sys.argv[1:]))
"""


def test_a_sigterm_while_stale_folders_are_swept_is_an_interrupt(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT, "inspect", str(SAMPLE)],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert done.returncode == 130, (done.returncode, done.stderr)
    assert done.stderr.strip() == "analyzer: interrupted"
    assert done.stdout == ""

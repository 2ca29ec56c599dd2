"""Where the benchmarks find the real-data corpus when ``--corpus`` is not given, by the
same rule as the tests' (``tests/_realdata.py``; a name of its own, as the tests load
the sweeps beside it): ``$ANALYZER_REALDATA`` where it names a folder, then
``../shared/realdata`` beside this checkout (a git worktree elsewhere has none beside
it: set ``ANALYZER_REALDATA`` or give ``--corpus``)."""

from __future__ import annotations

import os
from pathlib import Path

BESIDE = Path(__file__).resolve().parents[2] / "shared" / "realdata"
"""The corpus's place beside the checkout (``../shared/realdata``)."""


def default_corpus() -> Path:
    """``$ANALYZER_REALDATA`` where it is a folder, else ``../shared/realdata`` beside the
    checkout (whether or not it is there: the benchmark's own line says a file of it is
    not found, naming ``--corpus``)."""
    env = os.environ.get("ANALYZER_REALDATA")
    if env and Path(env).is_dir():
        return Path(env)
    return BESIDE

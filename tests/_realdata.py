"""Where the optional real-data corpus is, for every test that uses it (``tests/conftest.py``'s
``realdata`` fixture, ``tests/readers/conftest.py``'s ``corpus``, and the tests that
look for one file of it): one rule, so that no test looks elsewhere and skips alone.

The order: ``$ANALYZER_REALDATA`` where it names a folder, then ``../shared/realdata``
beside this checkout. A checkout elsewhere (a git worktree under /tmp) has no such
folder beside it: set ``ANALYZER_REALDATA``, which the skip reason says."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BESIDE = REPO.parent / "shared" / "realdata"
"""The corpus's place beside the checkout (``../shared/realdata``)."""


def realdata_root() -> Path | None:
    """The corpus folder: ``$ANALYZER_REALDATA``, else ``../shared/realdata`` beside the
    checkout, the first that is a folder; None where neither is."""
    env = os.environ.get("ANALYZER_REALDATA")
    for root in [Path(env)] if env else []:
        if root.is_dir():
            return root.resolve()
    return BESIDE.resolve() if BESIDE.is_dir() else None


def absent_reason() -> str:
    """Why a real-data test skips: both places looked at."""
    env = os.environ.get("ANALYZER_REALDATA")
    first = f"ANALYZER_REALDATA={env} is no folder" if env else "ANALYZER_REALDATA is not set"
    return f"real-data corpus absent: {first}, and {BESIDE} is no folder"


def realdata_or_skip(relative: str | Path = "") -> Path:
    """The corpus folder, or its file or folder ``relative``; the test skips (saying where
    it looked) where the corpus, or that entry in it, is absent."""
    root = realdata_root()
    if root is None:
        pytest.skip(absent_reason())
    path = root / relative
    if not path.exists():
        pytest.skip(f"real-data corpus at {root} has no {relative}")
    return path

"""Fixtures for the reader tests: the optional real-data corpus."""

from __future__ import annotations

import os
from pathlib import Path

import pytest


@pytest.fixture
def corpus() -> Path:
    """The real-data corpus (``../shared/realdata`` or ``$ANALYZER_REALDATA``)."""
    env = os.environ.get("ANALYZER_REALDATA")
    root = Path(env) if env else Path(__file__).resolve().parents[2] / "../shared/realdata"
    if not root.is_dir():
        pytest.skip("real-data corpus absent (set ANALYZER_REALDATA)")
    return root.resolve()

"""Fixtures for the reader tests: the optional real-data corpus."""

from __future__ import annotations

from pathlib import Path

import pytest
from _realdata import realdata_or_skip


@pytest.fixture
def corpus() -> Path:
    """The real-data corpus (:func:`_realdata.realdata_root`: ``$ANALYZER_REALDATA``, then
    ``../shared/realdata`` beside the checkout), or a skip saying where it was looked for."""
    return realdata_or_skip()

"""Fixtures shared by the Dask backend's tests."""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from typing import Any

import pytest


@pytest.fixture
def in_process() -> Iterator[Any]:
    """A Dask cluster in this process (fast to start), closed after the test (a test may
    scale it down or close it first)."""
    distributed = pytest.importorskip("distributed")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # (the dashboard's port)
        c = distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
        )
    try:
        yield c
    finally:
        c.close()

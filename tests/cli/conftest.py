"""Fixtures shared by the CLI tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

OFFSET_RATE = 50.0


@pytest.fixture(scope="module")
def offset_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """60 s of a 3-floor building at 50 Hz, an offset on its second sensor at 36 s (one
    fault: exit 1), as a CSV with absolute times."""
    t, y, names = simulate_building(3, 60.0, OFFSET_RATE, seed=3)
    y[:, 1] = inject_fault(y[:, 1], OFFSET_RATE, "additive", 36.0, 3.0 * float(np.std(y[:, 1])))
    path = tmp_path_factory.mktemp("in") / "b.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "csv", t_ns, dict(zip(names, y.T, strict=True)), start_iso="2026-03-01T12:00:00Z"
    )
    return path

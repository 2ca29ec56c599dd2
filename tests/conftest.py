"""Shared fixtures: paths to the optional real-data corpus.

BLAS threads are pinned to one: on a small shared machine, threaded BLAS makes the many
small and tall least-squares problems of the tests far slower, not faster."""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


def realdata_root() -> Path | None:
    env = os.environ.get("ANALYZER_REALDATA")
    cands = [Path(env)] if env else []
    cands.append(REPO.parent / "shared" / "realdata")
    for c in cands:
        if c.is_dir():
            return c
    return None


@pytest.fixture
def realdata() -> Path:
    root = realdata_root()
    if root is None:
        pytest.skip("../shared/realdata is absent (set ANALYZER_REALDATA to run these tests)")
    return root

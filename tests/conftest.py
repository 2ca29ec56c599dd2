"""Shared fixtures: paths to the optional real-data corpus.

BLAS threads are pinned to one: on a small shared machine, threaded BLAS makes the many
small and tall least-squares problems of the tests far slower, not faster."""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402
from _realdata import realdata_or_skip  # noqa: E402


@pytest.fixture
def realdata() -> Path:
    """The real-data corpus (:func:`_realdata.realdata_root`), or a skip saying where it
    was looked for."""
    return realdata_or_skip()


def _findings_of(analysis) -> list[tuple]:
    """``(channel, type, onset_s, magnitude)`` of each finding of an analysis."""
    return [(f.channel, str(f.type), f.onset_s, dict(f.magnitude)) for f in analysis.findings]


def _same_findings(a: list[tuple], b: list[tuple]) -> None:
    """Same channels and types in the same order; onsets and magnitudes to 1e-9."""
    assert [x[:2] for x in a] == [y[:2] for y in b]
    for (_, _, onset_a, mag_a), (_, _, onset_b, mag_b) in zip(a, b, strict=True):
        assert onset_a == pytest.approx(onset_b, abs=1e-9)
        assert mag_a.keys() == mag_b.keys()
        for k in mag_a:
            assert mag_a[k] == pytest.approx(mag_b[k], rel=1e-9, abs=1e-9)


@pytest.fixture
def findings_of():
    return _findings_of


@pytest.fixture
def same_findings():
    return _same_findings


class _TwoThreadPool:
    """A two-thread executor as the pipeline lends one to a detector (results in input
    order); ``shares_memory`` picks the in-place (threads) or the copy (cluster) path, and
    ``calls`` counts the maps."""

    def __init__(self, shares_memory: bool) -> None:
        self.shares_memory = shares_memory
        self.calls = 0

    def map(self, fn, items):
        from concurrent.futures import ThreadPoolExecutor

        self.calls += 1
        with ThreadPoolExecutor(2) as ex:
            return list(ex.map(fn, items))

    def imap(self, fn, items):
        return iter(self.map(fn, list(items)))

    def scatter(self, obj):
        return obj


@pytest.fixture
def two_thread_pool():
    """``two_thread_pool(shares_memory)``: a new :class:`_TwoThreadPool`."""
    return _TwoThreadPool

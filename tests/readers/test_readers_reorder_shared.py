"""The reorderer's shortcut for channels that share their time arrays (the fields of one
topic, a CSV's columns) releases what it releases for the same times in separate arrays."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.readers._common import Reorderer


def _run(shared: bool, seed: int, bounded: bool) -> list[tuple[str, np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    reorder = Reorderer(window_ns=50_000, batch_samples=3_000)
    out = []
    start = 0
    for _ in range(40):
        n = int(rng.integers(1, 400))
        t = start + np.cumsum(rng.integers(0, 1_000, n)).astype(np.int64)
        if rng.random() < 0.3:  # a batch out of order, some samples late
            t = t - rng.integers(0, 80_000, n)
        start = int(t.max())
        for c in range(4):
            times = t if shared else t.copy()
            if c == 3:  # a channel with its own times
                times = t[::2].copy()
            reorder.push(f"c{c}", times, rng.normal(size=times.shape[0]))
        bound = start - int(rng.integers(0, 30_000)) if bounded else None
        out.extend((c.name, c.t_ns.copy(), c.values.copy()) for c in reorder.release(bound))
    out.extend((c.name, c.t_ns.copy(), c.values.copy()) for c in reorder.flush())
    out.append(("dropped", np.array(sorted(reorder.dropped.items()), dtype=object), np.zeros(0)))
    return out


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("bounded", [False, True])
def test_shared_times_release_what_separate_times_release(seed: int, bounded: bool) -> None:
    separate = _run(False, seed, bounded)
    shared = _run(True, seed, bounded)
    assert len(separate) == len(shared) > 5
    for (name_a, t_a, v_a), (name_b, t_b, v_b) in zip(separate, shared, strict=True):
        assert name_a == name_b
        np.testing.assert_array_equal(t_a, t_b)
        np.testing.assert_array_equal(v_a, v_b)

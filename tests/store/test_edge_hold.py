"""A channel's first and last values are held for half of its own sample period beyond
its first and last samples on the clock, and no further.

Reference: the rule in closed form. A clock tick within ``0.5 / rate`` of the channel's
nearest edge sample reads that sample; a tick farther out reads NaN (the channel did not
exist there). Between samples the value is the straight line between them."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.readers.base import ChannelChunk
from analyzer.store.store import ChannelStore

TICK_NS = 10_000_000  # 100 Hz, both the clock and the channel
N = 100


@pytest.mark.parametrize("offset_ms", [4, 6, 10, 14])
def test_edge_values_are_held_half_a_period_and_no_more(offset_ms: int) -> None:
    """A 100 Hz channel starting ``offset_ms`` after a 100 Hz clock (and ending 3 ticks
    before it, minus the offset): tick ``k`` outside the channel reads its edge sample
    exactly when it lies within 5 ms of it, else NaN; inside it is the linear
    interpolation of the two samples around it."""
    tick = np.arange(N, dtype=np.int64) * TICK_NS
    t = tick[:-3] + offset_ms * 1_000_000
    v = np.arange(t.size, dtype=np.float64) + 1.0
    chunks = [ChannelChunk("clock", tick, np.zeros(N)), ChannelChunk("late", t, v)]
    with ChannelStore.from_chunks(chunks) as store:
        got = store.align(["clock", "late"], rate_hz=100.0).materialize()[:, 1]
    half = TICK_NS // 2
    expected = np.interp(tick, t, v)
    expected[(tick < t[0]) & (t[0] - tick > half)] = np.nan
    expected[(tick > t[-1]) & (tick - t[-1] > half)] = np.nan
    # the rule decides at least one tick at each end either way
    assert np.isnan(expected[0]) == (offset_ms > 5)
    assert np.isnan(expected[-3]) == (offset_ms < 5)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)

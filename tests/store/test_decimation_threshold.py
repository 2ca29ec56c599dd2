"""A channel faster than the clock by any ratio above 1.5 is low-passed before it is
resampled, not only one much faster.

Reference (sampling theorem): on a 100 Hz clock, a tone above the 50 Hz Nyquist cannot be
represented; resampled without the anti-aliasing filter it folds to ``|f - k * 100|`` Hz
at full amplitude (RMS ``1/sqrt(2)``), with it it is gone. A 5 Hz tone, well inside the
band, must come through unchanged: its samples at the clock's ticks are ``sin(2 pi 5 t)``
in closed form.
"""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.readers.base import ChannelChunk
from analyzer.store.store import ChannelStore

NS = 1_000_000_000
CLOCK_HZ = 100.0
SECONDS = 20
EDGE = 100
"""Ticks left out at each end (the filter's start-up)."""


@pytest.mark.parametrize("ratio", [1.6, 2.0, 3.0, 5.0])
def test_a_tone_above_the_clock_nyquist_is_filtered_out_at_any_ratio(ratio: float) -> None:
    """A channel at ``ratio * 100`` Hz carries a 5 Hz tone plus a tone three quarters of
    the way from the clock's Nyquist (50 Hz) to its own; aligned on the 100 Hz clock of
    another channel, what remains is the 5 Hz tone to 0.01 (the alias would be 0.7 RMS)."""
    rate = ratio * CLOCK_HZ
    f_high = CLOCK_HZ / 2 + 0.75 * (rate / 2 - CLOCK_HZ / 2)  # 72.5 Hz at ratio 1.6
    t = np.round(np.arange(int(SECONDS * rate)) * NS / rate).astype(np.int64)
    sec = t / NS
    x = np.sin(2 * np.pi * 5.0 * sec) + np.sin(2 * np.pi * f_high * sec)
    tick = np.arange(int(SECONDS * CLOCK_HZ), dtype=np.int64) * (NS // int(CLOCK_HZ))
    chunks = [ChannelChunk("clock", tick, np.zeros(tick.size)), ChannelChunk("fast", t, x)]
    with ChannelStore.from_chunks(chunks) as store:
        aligned = store.align(["clock", "fast"], rate_hz=CLOCK_HZ).materialize()[:, 1]
    assert aligned.shape == tick.shape
    err = aligned[EDGE:-EDGE] - np.sin(2 * np.pi * 5.0 * tick[EDGE:-EDGE] / NS)
    assert np.sqrt(np.mean(err**2)) < 0.01

"""The time-aligned channel store (raw samples out of core, aligned blocks on demand)."""

from analyzer.store.store import (
    GAP_FACTOR,
    AlignedSeries,
    ChannelInfo,
    ChannelStore,
    clock_rate,
    dominant_rate,
)

__all__ = [
    "GAP_FACTOR",
    "AlignedSeries",
    "ChannelInfo",
    "ChannelStore",
    "clock_rate",
    "dominant_rate",
]

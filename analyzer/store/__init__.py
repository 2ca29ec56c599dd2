"""The time-aligned channel store (raw samples out of core, aligned blocks on demand)."""

from analyzer.store.store import (
    GAP_FACTOR,
    LONG_ARRAY,
    AlignedSeries,
    ChannelInfo,
    ChannelStore,
    array_field,
    clock_rate,
    dominant_rate,
    long_arrays,
)

__all__ = [
    "GAP_FACTOR",
    "LONG_ARRAY",
    "AlignedSeries",
    "ChannelInfo",
    "ChannelStore",
    "array_field",
    "clock_rate",
    "dominant_rate",
    "long_arrays",
]

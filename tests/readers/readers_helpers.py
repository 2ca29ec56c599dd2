"""Helpers shared by the reader tests (imported as a plain module: tests/ has no packages)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

from analyzer.readers import open_input
from analyzer.readers.base import ChannelChunk, InputInfo

Samples = dict[str, tuple[np.ndarray, np.ndarray]]

T0 = 1_767_225_600_000_000_000  # 2026-01-01T00:00:00Z
"""Start of the synthetic archives (absolute nanoseconds)."""


def collect(chunks: Iterable[ChannelChunk]) -> Samples:
    """All chunks concatenated per channel, checking the protocol on the way: int64
    times, float64 values, same lengths, non-decreasing time within each channel."""
    parts: dict[str, list[ChannelChunk]] = {}
    for chunk in chunks:
        assert chunk.t_ns.dtype == np.int64 and chunk.values.dtype == np.float64
        assert chunk.t_ns.shape == chunk.values.shape
        parts.setdefault(chunk.name, []).append(chunk)
    out: Samples = {}
    for name, chunks_ in parts.items():
        t = np.concatenate([c.t_ns for c in chunks_])
        v = np.concatenate([c.values for c in chunks_])
        assert np.all(np.diff(t) >= 0), f"{name}: time goes back"
        out[name] = (t, v)
    return out


def read(path: Path) -> tuple[Samples, InputInfo]:
    """One input file's samples (:func:`collect`) and what its reader said of it."""
    reader = open_input(path)
    return collect(reader.chunks()), reader.info


def synthetic(
    n: int = 3000, channels: int = 4, rate_hz: float = 200.0, seed: int = 0
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """``n`` samples of ``channels`` random-walk channels ``s0..``, from :data:`T0`."""
    rng = np.random.default_rng(seed)
    t = T0 + np.round(np.arange(n) * 1e9 / rate_hz).astype(np.int64)
    data = {f"s{i}": np.cumsum(rng.normal(size=n)) * (i + 1) for i in range(channels)}
    return t, data

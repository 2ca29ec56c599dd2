"""Decimation for plots of long archives: min/max envelopes and gap maps.

A browser draws a few thousand points per figure in no time and millions very slowly,
and a 24-hour record at 100 Hz has 8.6 million samples per channel. A plot therefore
never gets raw samples beyond ``max_points``: the series is cut into equal bins and
each bin contributes its minimum and maximum (the *envelope*), which keeps every spike
and every step visible at the cost of the detail inside a bin. All of it is vectorized
(reshape + reductions), one pass over the data, NaN-aware (a gap stays a gap).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from analyzer.paging import release

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

CHUNK_VALUES = 1 << 21
"""Samples reduced at a time by :func:`envelope` (bounded temporaries on long series)."""
ROW_BLOCK = 1 << 18
"""Rows of the aligned matrix read at a time by :func:`binned_nan_fraction` (bounded
memory on memory-mapped archives)."""


class Envelope(NamedTuple):
    """``t`` the bin centres (or the samples, when not decimated), ``lo``/``hi`` the
    per-bin minimum and maximum (equal when not decimated), NaN for an all-gap bin;
    ``decimated`` is True when bins hold more than one sample."""

    t: FloatArray
    lo: FloatArray
    hi: FloatArray
    decimated: bool


@dataclass(frozen=True, slots=True)
class Clock:
    """The times ``k / rate`` of samples ``k = 0 .. n - 1``, for :func:`envelope`
    without an array of them (as long as the archive): indexed like that array, with
    the same values (the same division of the same exact integers)."""

    n: int
    rate: float

    @property
    def shape(self) -> tuple[int]:
        return (self.n,)

    @property
    def ndim(self) -> int:
        return 1

    def __getitem__(self, k: slice | npt.NDArray[np.int64]) -> FloatArray:
        idx = np.arange(*k.indices(self.n)) if isinstance(k, slice) else np.asarray(k)
        return idx.astype(np.float64) / self.rate


def envelope(t: npt.ArrayLike | Clock, y: npt.ArrayLike, max_points: int = 2000) -> Envelope:
    """Min/max envelope of ``y(t)`` in at most ``max_points`` bins of equal sample count.

    ``t`` and ``y`` are 1-D and of the same length (``t`` increasing; a :class:`Clock`
    for a uniform one). With at most ``max_points`` samples the series comes back
    unchanged (``lo == hi == y``). Otherwise the samples are grouped in bins of
    ``ceil(n / max_points)``; the last, shorter bin is padded with NaN, which the
    reductions ignore. ``y`` (any float precision, memory-mapped or not) is read and
    converted to float64 a chunk at a time. Raises ValueError on mismatched shapes or a
    non-positive ``max_points``."""
    tt = t if isinstance(t, Clock) else np.asarray(t, dtype=np.float64)
    yy = np.asarray(y)
    if yy.dtype.kind != "f":
        yy = np.asarray(yy, dtype=np.float64)
    if tt.ndim != 1 or yy.shape != tt.shape:
        raise ValueError(
            f"expected 1-D t and y of the same length, got shapes {tt.shape} and {yy.shape}"
        )
    if max_points < 1:
        raise ValueError(f"max_points must be >= 1, got {max_points}")
    n = tt.shape[0]
    if n <= max_points:
        ts = tt[0:n] if isinstance(tt, Clock) else tt.copy()
        ys = np.array(yy, dtype=np.float64)
        return Envelope(ts, ys, ys.copy(), False)
    per = -(-n // max_points)
    bins = -(-n // per)
    lo = np.empty(bins, dtype=np.float64)
    hi = np.empty(bins, dtype=np.float64)
    step = max(1, CHUNK_VALUES // per)  # bins per chunk: bounded temporaries on long input
    for b0 in range(0, bins, step):
        b1 = min(bins, b0 + step)
        seg = np.asarray(yy[b0 * per : min(n, b1 * per)], dtype=np.float64)
        pad = (b1 - b0) * per - seg.shape[0]
        if pad:
            seg = np.concatenate((seg, np.full(pad, np.nan)))
        block = seg.reshape(b1 - b0, per)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN bins give NaN
            lo[b0:b1] = np.nanmin(block, axis=1)
            hi[b0:b1] = np.nanmax(block, axis=1)
    if isinstance(y, np.ndarray):
        release(y)  # a memory-mapped signal (a long archive's): its pages go back
    first = tt[::per]
    last = tt[np.minimum(np.arange(bins) * per + per - 1, n - 1)]
    return Envelope(0.5 * (first + last), lo, hi, True)


def binned_nan_fraction(values: npt.ArrayLike, bins: int) -> FloatArray:
    """Fraction of NaN samples per time bin and column of an (N, m) array: a
    ``(min(bins, N), m)`` array. Reads ``values`` in row blocks, so a memory-mapped archive
    is streamed once instead of loaded.

    Most blocks of most channels hold no NaN at all: a column sum (one fast pass, and NaN
    whenever the column holds a NaN) picks the columns worth counting, and only those are
    counted per bin. A sum can also be NaN without a NaN sample (``inf - inf``), which
    merely counts that column exactly."""
    v = values if isinstance(values, np.ndarray) else np.asarray(values)
    if v.ndim != 2:
        raise ValueError(f"expected an (N, m) array, got shape {v.shape}")
    n, m = v.shape
    if n == 0 or m == 0:
        return np.zeros((0, m), dtype=np.float64)
    bins = max(1, min(int(bins), n))
    edges = (np.arange(bins + 1) * n) // bins
    counts = np.zeros((bins, m), dtype=np.int64)
    for start in range(0, n, ROW_BLOCK):
        stop = min(n, start + ROW_BLOCK)
        block = np.asarray(v[start:stop], dtype=np.float64)
        with np.errstate(invalid="ignore", over="ignore"):
            cols = np.flatnonzero(np.isnan(block.sum(axis=0)))
        if cols.size == 0:
            release(v[start:stop])  # a memory-mapped archive: streamed, not kept resident
            continue
        nan = np.isnan(block[:, cols])
        b0 = int(np.searchsorted(edges, start, side="right")) - 1
        b1 = int(np.searchsorted(edges, stop - 1, side="right")) - 1
        cuts = np.maximum(edges[b0 : b1 + 1] - start, 0)
        counts[b0 : b1 + 1, cols] += np.add.reduceat(nan, cuts, axis=0, dtype=np.int64)
        release(v[start:stop])
    sizes = np.diff(edges).astype(np.float64)
    return counts / sizes[:, None]


def runs(mask: npt.ArrayLike) -> list[tuple[int, int]]:
    """Half-open ``[start, stop)`` index runs where ``mask`` is True."""
    b = np.asarray(mask, dtype=bool)
    if b.ndim != 1:
        raise ValueError(f"expected a 1-D mask, got shape {b.shape}")
    d = np.diff(np.concatenate(([0], b.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def moving_mean(x: npt.ArrayLike, window: int) -> FloatArray:
    """Trailing moving average over ``window`` samples, NaN-aware (the mean of the finite
    samples in the window; NaN where the window holds none). The detectors' alarm
    statistic is the same trailing mean of the standardized residual
    (:func:`analyzer.diagnosis.changes.alarm_statistic`)."""
    xx = np.asarray(x, dtype=np.float64)
    w = max(1, int(window))
    finite = np.isfinite(xx)
    c = np.cumsum(np.concatenate(([0.0], np.where(finite, xx, 0.0))))
    k = np.cumsum(np.concatenate(([0], finite.astype(np.int64))))
    idx = np.arange(1, xx.shape[0] + 1)
    lo = np.maximum(idx - w, 0)
    s = c[idx] - c[lo]
    cnt = k[idx] - k[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(cnt > 0, s / np.maximum(cnt, 1), np.nan)
    return out


__all__ = ["Envelope", "binned_nan_fraction", "envelope", "moving_mean", "runs"]

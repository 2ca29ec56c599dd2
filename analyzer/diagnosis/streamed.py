"""Statistics of a long healthy series taken a block at a time.

A detector's calibration reduces a healthy residual over the training window to a few
numbers: its mean and spread, its autocorrelation up to a few hundred lags, the spread of
its moving means and of their log mean squares, the variance of its block means. Taken
on the whole series at once, each of these made several copies of it (the finite values,
the standardized series, its square, the moving means, their logs): fitting on a day of
16 channels at 100 Hz held gigabytes that only fed a few sums. Here each statistic is a
running sum carried from block to block, with the few samples a block's sums need from
the block before (the last ``max_lag`` samples for lagged products, ``w - 1`` for moving
windows), so what is held at once is a block (:data:`SERIES_BLOCK` samples), whatever the
series' length; a memory-mapped series' pages are given back behind the pass
(:func:`analyzer.paging.row_blocks`).

:func:`row_moments` does the same for the covariance of a window's rows (the sensor
correlations of the equivalent model's network), :class:`ColumnMoments` for each
column's mean, spread and level (the healthy statistics, the flat-channel check and the
AR fits' standardization), NaN skipped column by column.

The sums are the whole-series sums in another order: they equal them to rounding
(tested against the whole-series formulas). The spread is merged block by block with the
pairwise update of Chan, Golub and LeVeque (1979), which is as accurate as the two-pass
formula.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.paging import row_blocks
from analyzer.stats.whiteness import lagged_products

FloatArray = npt.NDArray[np.float64]

SERIES_BLOCK = 1 << 17
"""Samples of a series a pass holds at once (1 MB in float64; a dozen temporaries)."""

Series = npt.NDArray[Any] | Sequence[npt.NDArray[Any]] | Sequence[float]
"""A 1-D array, or 1-D arrays read one after the other as one series (the held-out
parts of a training window, say: not concatenated into a copy), or a sequence of
numbers."""


def finite_blocks(series: Series, block: int | None = None) -> Iterator[FloatArray]:
    """The finite values of ``series`` in order, as float64 blocks of at most ``block``
    samples (default :data:`SERIES_BLOCK`; gaps closed up, as ``x[np.isfinite(x)]``
    closes them). Each block is a new array; the pages of a memory-mapped series are
    given back as the pass goes."""
    block = SERIES_BLOCK if block is None else int(block)
    if isinstance(series, np.ndarray):
        parts: list[Any] = [series]
    else:  # arrays read one after the other; anything else (a list of numbers) is one
        items = list(series)
        parts = items if items and all(isinstance(p, np.ndarray) for p in items) else [items]
    for part in parts:
        arr = np.asarray(part)
        if arr.ndim != 1:
            raise ValueError(f"finite_blocks: expected 1-D series, got shape {arr.shape}")
        for _, piece in row_blocks(arr, block):
            x = np.asarray(piece, dtype=np.float64)
            x = x[np.isfinite(x)]  # a copy, even where every value is finite
            if x.shape[0]:
                yield x


class RunningMoments:
    """Count, mean and centred sum of squares of the values added so far (Chan, Golub
    and LeVeque's pairwise update of a block's two-pass moments)."""

    __slots__ = ("m2", "mean", "n")

    def __init__(self) -> None:
        self.n = 0
        self.mean = 0.0
        self.m2 = 0.0

    def add(self, x: FloatArray) -> None:
        k = x.shape[0]
        if k == 0:
            return
        mu = float(np.mean(x))
        d = x - mu
        m2 = float(d @ d)
        if self.n == 0:
            self.n, self.mean, self.m2 = k, mu, m2
            return
        n = self.n + k
        delta = mu - self.mean
        self.mean += delta * k / n
        self.m2 += m2 + delta * delta * self.n * k / n
        self.n = n

    def var(self, ddof: int = 0) -> float:
        return self.m2 / (self.n - ddof) if self.n > ddof else float("nan")

    def std(self, ddof: int = 0) -> float:
        return float(np.sqrt(self.var(ddof)))


class RowMoments:
    """Count, mean and centred sum of squares and products (``m2``) of row vectors,
    added chunk by chunk: each chunk's own mean and centred products (two passes over
    the chunk, as ``np.cov``), merged by the pairwise update of Chan, Golub and LeVeque
    (1979). A covariance over a long stretch without holding the stretch."""

    __slots__ = ("m2", "mean", "n")

    def __init__(self, d: int) -> None:
        self.n = 0
        self.mean = np.zeros(d)
        self.m2 = np.zeros((d, d))

    def add(self, x: FloatArray) -> None:
        if x.shape[0]:
            mu = x.mean(axis=0)
            d = x - mu
            self._merge(x.shape[0], mu, d.T @ d)

    def _merge(self, k: int, mu: FloatArray, m2: FloatArray) -> None:
        n = self.n + k
        delta = mu - self.mean
        self.mean = self.mean + delta * (k / n)
        self.m2 = self.m2 + m2 + np.outer(delta, delta) * (self.n * k / n)
        self.n = n

    @staticmethod
    def merged(parts: Sequence[RowMoments]) -> RowMoments:
        out = RowMoments(parts[0].mean.shape[0])
        for p in parts:
            if p.n:
                out._merge(p.n, p.mean, p.m2)
        return out

    def covariance(self, ddof: int = 1) -> FloatArray:
        return self.m2 / (self.n - ddof)

    def correlation(self) -> FloatArray:
        """As ``np.corrcoef`` of the rows added: NaN where a component is constant (or
        fewer than two rows were added)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            c = self.covariance()
            d = np.sqrt(np.diag(c))
            c = c / d[:, None] / d[None, :]
        out: FloatArray = np.clip(c, -1.0, 1.0)
        return out


class ColumnMoments:
    """Per column: the count of finite values, their mean, centred sum of squares and
    largest magnitude, over blocks of rows added one after the other (each block's own
    moments merged by the pairwise update of Chan, Golub and LeVeque, 1979; the counts
    may differ by column where a block has NaN)."""

    def __init__(self, m: int) -> None:
        self.n = np.zeros(m)
        self.mean = np.zeros(m)
        self.m2 = np.zeros(m)
        self.level = np.zeros(m)

    def add(self, part: FloatArray) -> None:
        rows = part.shape[0]
        if not rows:
            return
        with np.errstate(all="ignore"):
            if np.isfinite(part).all():
                k = np.full(part.shape[1], float(rows))
                mu = part.mean(axis=0)
                m2 = part.var(axis=0) * k
                level = np.abs(part).max(axis=0)
            else:
                # as nanmean / nanvar / nanmax, and 0 for a column without a value
                ok = np.isfinite(part)
                k = ok.sum(axis=0).astype(np.float64)
                mu = np.where(ok, part, 0.0).sum(axis=0) / np.where(k > 0, k, 1.0)
                d = np.where(ok, part - mu, 0.0)
                m2 = (d * d).sum(axis=0)
                level = np.where(ok, np.abs(part), 0.0).max(axis=0)
            total = self.n + k
            safe = np.where(total > 0, total, 1.0)  # a column with no value yet: no change
            delta = mu - self.mean
            self.m2 = self.m2 + m2 + delta * delta * (self.n * k / safe)
            self.mean = self.mean + delta * (k / safe)
            self.n = total
            self.level = np.maximum(self.level, level)

    def stats(self) -> tuple[FloatArray, FloatArray, npt.NDArray[np.bool_]]:
        """Per column of the rows added: the mean, the spread (population) and whether
        it is flat (a spread below 1e-9 of its level, as
        :func:`~analyzer.detectors.ar_model.flat_channels`; NaN mean and spread for a
        column without a finite value: flat)."""
        with np.errstate(all="ignore"):
            some = self.n > 0
            mean = np.where(some, self.mean, np.nan)
            std = np.where(some, np.sqrt(self.m2 / np.where(some, self.n, 1.0)), np.nan)
            flat = ~(std > 1e-9 * self.level + 1e-300)
        return mean, std, np.asarray(flat)


class LaggedSums:
    """``c[k] = sum_t d[t] d[t + k]`` for ``k = 0 .. max_lag`` of the series added block
    by block (what :func:`analyzer.stats.whiteness.lagged_products` gives for the whole
    series). A block adds the products whose later factor lies in it: those of the block
    with the previous ``max_lag`` samples prepended, less those of the prepended samples
    alone (already counted)."""

    __slots__ = ("max_lag", "n", "sums", "tail")

    def __init__(self, max_lag: int) -> None:
        self.max_lag = int(max_lag)
        self.sums = np.zeros(self.max_lag + 1)
        self.tail = np.empty(0)
        self.n = 0

    def add(self, d: FloatArray) -> None:
        if d.shape[0] == 0:
            return
        ext = np.concatenate((self.tail, d)) if self.tail.shape[0] else d
        s = lagged_products(ext, self.max_lag)
        self.sums[: s.shape[0]] += s
        if self.tail.shape[0]:
            t = lagged_products(self.tail, self.max_lag)
            self.sums[: t.shape[0]] -= t
        self.tail = ext[max(0, ext.shape[0] - self.max_lag) :].copy()
        self.n += d.shape[0]

    def values(self) -> FloatArray:
        """The sums at the lags the series is long enough for (``min(max_lag, n - 1)``)."""
        return self.sums[: max(0, min(self.max_lag, self.n - 1)) + 1].copy()


class WindowSums:
    """Sums of every ``w`` consecutive samples of the series added block by block, the
    windows that end in each block (the trailing ``w - 1`` samples are carried)."""

    __slots__ = ("tail", "w")

    def __init__(self, w: int) -> None:
        self.w = int(w)
        self.tail = np.empty(0)

    def add(self, x: FloatArray) -> FloatArray:
        ext = np.concatenate((self.tail, x)) if self.tail.shape[0] else x
        w = self.w
        self.tail = ext[max(0, ext.shape[0] - (w - 1)) :].copy()
        if ext.shape[0] < w:
            return np.empty(0)
        c = np.cumsum(np.concatenate(([0.0], ext)))
        out: FloatArray = c[w:] - c[:-w]
        return out


class BlockMeans:
    """Moments of the means of consecutive, non-overlapping ``b``-sample blocks of the
    series added block by block (a last incomplete block does not count). An incomplete
    block is carried as its sum and count, not its samples: ``b`` may be an eighth of a
    day-long series."""

    __slots__ = ("b", "count", "moments", "partial")

    def __init__(self, b: int) -> None:
        self.b = int(b)
        self.partial = 0.0
        self.count = 0
        self.moments = RunningMoments()

    def add(self, x: FloatArray) -> None:
        b = self.b
        if self.count:  # complete the block begun before
            take = min(b - self.count, x.shape[0])
            self.partial += float(np.sum(x[:take]))
            self.count += take
            x = x[take:]
            if self.count < b:
                return
            self.moments.add(np.array([self.partial / b]))
            self.partial, self.count = 0.0, 0
        nb = x.shape[0] // b
        if nb:
            self.moments.add(x[: nb * b].reshape(nb, b).mean(axis=1))
        if x.shape[0] > nb * b:
            self.partial = float(np.sum(x[nb * b :]))
            self.count = x.shape[0] - nb * b


def series_moments(series: Series) -> RunningMoments:
    """Count, mean and spread of the finite values of ``series`` (one pass)."""
    moments = RunningMoments()
    for x in finite_blocks(series):
        moments.add(x)
    return moments


def row_moments(values: npt.NDArray[Any], cols: Sequence[int]) -> RowMoments:
    """Moments of the rows of ``values[:, cols]`` that have no NaN in those columns,
    read about :data:`SERIES_BLOCK` values at a time (no copy of the selection; a
    memory-mapped record's pages are given back behind): the correlations the
    equivalent model designs its sensor network from."""
    moments = RowMoments(len(cols))
    for _, block in row_blocks(values, max(1, SERIES_BLOCK // max(1, len(cols)))):
        rows = np.asarray(block, dtype=np.float64)[:, list(cols)]
        ok = np.isfinite(rows).all(axis=1)
        moments.add(rows if ok.all() else rows[ok])
    return moments

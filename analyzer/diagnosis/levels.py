"""The response level of every analyzed channel over time, against the training window's.

Sensor faults are searched with models fitted on a healthy training window; when the load
or the structure changes beyond anything that window held (a storm, a passing truck, a
machine started, a quiet night), what the models see can look like one sensor's fault
(``benchmarks/sweep_eov.py``). :func:`response_levels` measures each channel's RMS about
its training mean in bins of at least :data:`LEVEL_MIN_BIN_S` over its RMS in the training
window; :func:`level_note` names the stretches where the channels' median level left the
range of the training window's own bins by :data:`LEVEL_CHANGE` or more. The report draws
the map (``figures.level_figure``) and the run's notes carry the sentence.

The bins are long because a structure's response level varies on its own: a lightly
damped 1 Hz building under broadband load reaches 0.6-2.6x its mean RMS in 10 s bins of a
steady record. On the simulated buildings of ``sweep_eov.py`` (4, 6 and 16 channels, 5
seeds, 10 minutes) no steady record was named, and bursts of 3x / 5x / 10x, a quiet night
and narrow-band excitation were named in 10, 15, 15, 15 and 13 of 15 runs; a thermal
drift, a stiffness change and a colour change at the same level are not level changes
and were not named.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from analyzer.diagnosis.changes import _runs
from analyzer.paging import release

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

LEVEL_BINS, LEVEL_MIN_BIN_S = 300, 10.0
"""Time bins of the level map, each at least this long (s)."""
LEVEL_CHANGE, LEVEL_TRAIN_BINS = 2.0, 6
"""The channels' median level this many times above the highest of the training window's
bins, or under its lowest by as much, is named (the load or the structure outside anything
the models were fitted on), when the training window holds at least this many bins: fewer
do not show the level's own spread (a steady 2-minute record with 3 training bins reached
2.1x their highest)."""
LISTED = 3
"""Stretches named one by one; the rest are counted."""
RMS_ROWS = 16_384
"""Rows :func:`binned_rms` reads at a time (their deviations stay in the cache)."""


@dataclass(frozen=True, slots=True)
class Levels:
    """Each analyzed channel's level per time bin (:func:`response_levels`)."""

    edges_s: FloatArray
    """Bin edges, seconds from the start (bins + 1)."""
    ratio: FloatArray
    """(bins, channels): a bin's RMS about the reference mean over the reference RMS."""
    train: BoolArray | None
    """The bins inside the training window; None when the reference is not a training
    window of this record (a saved model: the record's median level instead)."""


def response_levels(
    values: npt.ArrayLike, rate_hz: float, train: tuple[int, int] | None
) -> Levels | None:
    """The levels of the (N, m) aligned ``values``: against rows ``train`` (start, stop)
    of the record, or with None against each channel's median level over the record.
    None for fewer than two rows."""
    v = values if isinstance(values, np.ndarray) else np.asarray(values)
    n = len(v)
    if n < 2 or v.ndim != 2 or v.shape[1] == 0:
        return None
    duration = n / rate_hz
    bins = int(min(LEVEL_BINS, max(1, duration // LEVEL_MIN_BIN_S), n))
    k0, k1 = (0, 0) if train is None else (max(0, train[0]), min(n, train[1]))
    own = k1 - k0 >= 2
    with np.errstate(invalid="ignore", divide="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN column: NaN
        if own:
            center = np.nanmean(np.asarray(v[k0:k1], dtype=np.float64), axis=0)
        else:
            center = np.nanmedian(np.asarray(v[:: max(1, n // 100_000)], dtype=np.float64), axis=0)
        rms = binned_rms(v, bins, center)
        ref = binned_rms(v[k0:k1], 1, center)[0] if own else np.nanmedian(rms, axis=0)
        ratio = rms / np.where(ref > 0, ref, np.nan)
    edges = (np.arange(rms.shape[0] + 1) * n) // rms.shape[0] / rate_hz
    inside = None
    if own:
        inside = (edges[:-1] >= k0 / rate_hz - 1e-9) & (edges[1:] <= k1 / rate_hz + 1e-9)
    return Levels(edges, ratio, inside)


def binned_rms(values: npt.ArrayLike, bins: int, center: npt.ArrayLike) -> FloatArray:
    """Root mean square about ``center`` (one value per column) per time bin and column
    of an (N, m) array, NaN samples left out: a ``(min(bins, N), m)`` array, NaN where a
    bin of a column holds no sample. Reads ``values`` in pieces of at most
    :data:`RMS_ROWS` rows (cache-sized: four hours of 16 channels in ~0.2 s), so a
    memory-mapped archive is streamed once instead of loaded."""
    v = values if isinstance(values, np.ndarray) else np.asarray(values)
    if v.ndim != 2:
        raise ValueError(f"expected an (N, m) array, got shape {v.shape}")
    n, m = v.shape
    c = np.broadcast_to(np.asarray(center, dtype=np.float64), (m,))
    if n == 0 or m == 0:
        return np.zeros((0, m), dtype=np.float64)
    bins = max(1, min(int(bins), n))
    edges = (np.arange(bins + 1) * n) // bins
    squares = np.zeros((bins, m), dtype=np.float64)
    counts = np.zeros((bins, m), dtype=np.int64)
    for b in range(bins):
        for start in range(int(edges[b]), int(edges[b + 1]), RMS_ROWS):
            stop = min(int(edges[b + 1]), start + RMS_ROWS)
            piece = np.asarray(v[start:stop], dtype=np.float64) - c
            q = np.einsum("ij,ij->j", piece, piece)
            bad = np.flatnonzero(np.isnan(q))
            if bad.size:  # the columns with NaN samples, counted one by one
                sub = piece[:, bad]
                ok = ~np.isnan(sub)
                q[bad] = np.einsum("ij,ij->j", np.where(ok, sub, 0.0), np.where(ok, sub, 0.0))
                counts[b, bad] -= (stop - start) - ok.sum(axis=0)
            squares[b] += q
            counts[b] += stop - start
            release(v[start:stop])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(squares / counts)


@dataclass(frozen=True, slots=True)
class Excursion:
    """A stretch where the channels' median level left the training window's range."""

    start_s: float
    end_s: float
    extreme: float
    """The median level's highest (over) or lowest (under) value there, in training RMS."""


def excursions(levels: Levels | None) -> tuple[list[Excursion], tuple[float, float]]:
    """The stretches (in time order) where the channels' median level left the range of
    the training window's bins (at least :data:`LEVEL_TRAIN_BINS`) by :data:`LEVEL_CHANGE`
    or more, and that range; none without a training window of the record's own."""
    if levels is None or levels.train is None or levels.ratio.shape[1] < 2:
        return [], (0.0, 0.0)
    train = levels.train
    if int(train.sum()) < LEVEL_TRAIN_BINS:
        return [], (0.0, 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a bin without data: NaN
        level = np.nanmedian(levels.ratio, axis=1)
    low, high = float(np.nanmin(level[train])), float(np.nanmax(level[train]))
    edges = levels.edges_s
    out = []
    for over, mask in ((True, level > LEVEL_CHANGE * high), (False, level < low / LEVEL_CHANGE)):
        for a, b in _runs(mask):
            x = level[a:b]
            extreme = float(np.nanmax(x) if over else np.nanmin(x))
            out.append(Excursion(float(edges[a]), float(edges[b]), extreme))
    out.sort(key=lambda e: e.start_s)
    return out, (low, high)


def level_note(levels: Levels | None) -> str:
    """The stretches where the channels' median level left the range of the training
    window's bins (:func:`excursions`) as one sentence; "" when none did, or without a
    training window of the record's own."""
    found, (low, high) = excursions(levels)
    if not found:
        return ""
    parts = [
        f"{e.start_s:.1f}-{e.end_s:.1f} s ({e.extreme:.2g}x its training level)" for e in found
    ]
    shown = "; ".join(parts[:LISTED])
    more = f", and {len(parts) - LISTED} more stretches" if len(parts) > LISTED else ""
    return (
        "the channels' median response level left the range of the training window "
        f"({low:.2g}-{high:.2g}x) by {LEVEL_CHANGE:g}x or more at "
        f"{shown}{more}: the load or the structure changed beyond anything the models were "
        "fitted on; a finding there may be that change rather than a sensor's fault (the "
        "report's response-level map shows whether its sensor stands out)"
    )


__all__ = [
    "Excursion",
    "LEVEL_CHANGE",
    "LEVEL_MIN_BIN_S",
    "Levels",
    "binned_rms",
    "excursions",
    "level_note",
    "response_levels",
]

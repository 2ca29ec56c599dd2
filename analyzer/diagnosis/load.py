"""The response level of a record against the healthy window's range of it.

Every model-based residual here is fitted and calibrated on the healthy window, and its
error grows with the structure's response: a model fitted on a quiet stretch predicts a
louder one less well. The default window (the first 20 % of the record) can be much
quieter than what follows: on the project's simulated 5-floor building (2 % damping, the
first mode's envelope time constant 7.9 s) the 2-s mean square of a 12-s window reached
1.6-2.7 times the window's average, and after it up to 11 times (seeds 0-9 of 60-s
records). There every residual rises together, and in a small bank one other residual
over its threshold confirmed healthy alarms as faults (``benchmarks/sweep_missing_floor.py``).

The level measured here is each channel's variance over a moving window (the detectors'
long window: 2 s from 64 Hz up, 128 samples below; its mean taken out, so an offset or a
slow drift is no louder), over the largest it reached inside the
healthy window; a stretch's level is the median of that over some channels. A level over
1 is a response the models never saw: there the detectors ask for more evidence of a
gain or a shapeless change (:data:`LOUD_KINDS`) than an alarm confirmed by one other
residual. It is only ever measured on the channels *other* than the one a fault is
looked for on: a sensor's own gain makes its signal louder, and must not excuse itself.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.diagnosis.changes import LONG_FACTOR, default_window, moving_mean
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

LOUD_KINDS = (FaultType.MULTIPLICATIVE, FaultType.OTHER)
"""The fault types a louder response passes for: its residuals' spread grows (a gain) or
changes with no shape (other). A zero-mean response, however loud, shifts no residual's
mean and draws no ramp: an offset or a drift fitted there is a shape of its own, and the
guard leaves it be (with one floor's sensor left out of the simulated 5-floor building,
0.5-sd offsets on the top floor, which no other residual sees, were reported by the
equivalent model and the bank alone, unconfirmed, in such stretches: 3 of 10 seeds). The
healthy findings the guard stops were all of these two types."""

LOUD_BANK_MAX = 5
"""The equivalent model's guard applies to records of at most this many channels: the
banks the detection filter's own rule is loosest in (under 6: one other residual over its
threshold confirms); larger ones leave a lone gain to the readings' judgement."""

LOUD_MARK = "times the loudest of the healthy window"
"""The words of every detector's note on an alarm the guard did not report (the run's
note counts them: :func:`loud_stretch_count`)."""


LEVEL_BLOCK = 1 << 18
"""Rows read at once when a level is measured over a long stretch."""


@dataclass(frozen=True)
class LoadRange:
    """The healthy window's range of response levels: per channel (a column of the
    values) the largest variance over a moving window of ``window`` samples inside it
    (NaN where it had too few finite samples)."""

    window: int
    peak: FloatArray


def level_window(rate_hz: float) -> int:
    """Samples the level is averaged over: the detectors' long window, the window their
    mean-square statistics alarm on (``LONG_FACTOR`` times
    :func:`~analyzer.diagnosis.changes.default_window`: 2 s from 64 Hz up, 128 samples
    below, e.g. 12.8 s at 10 Hz and 128 s at 1 Hz). The level is meant to say how loud the
    stretch an alarm was raised on was, so it is measured over that same stretch, not over
    a fixed 2 s: 2 s of a 1-Hz channel hold 2 samples, no variance."""
    return LONG_FACTOR * default_window(rate_hz)


def _moving_variance(x: FloatArray, window: int) -> FloatArray:
    """Trailing moving variance of ``x`` over ``window`` samples, NaNs left out (NaN where
    a window holds fewer than half its samples finite).

    The stretch's own mean is taken out first (the healthy window's, for
    :func:`load_range`): the variance comes from running sums of values and squares, and
    of raw values far from zero (a latitude, a pressure in pascals, a 1.7e9 timestamp-like
    count) those sums round away the spread itself. Raw, stationary channels at an offset
    of 1e6 (sd 1) or of a latitude (sd 1e-7) read 2.3-3.5 times the healthy window's
    loudest after it; centred, 0.955 like any other (``tests/diagnosis/test_load.py``)."""
    ok = np.isfinite(x)
    centre = float(np.mean(x[ok])) if ok.any() else 0.0
    v = np.where(ok, x - centre, 0.0)
    n = moving_mean(ok.astype(np.float64), window)
    with np.errstate(invalid="ignore", divide="ignore"):
        m1 = moving_mean(v, window) / n
        m2 = moving_mean(v * v, window) / n
        out = np.maximum(m2 - m1 * m1, 0.0)
    out[n < 0.5] = np.nan
    return out


def load_range(values: npt.ArrayLike, train: tuple[int, int], rate_hz: float) -> LoadRange:
    """:class:`LoadRange` of ``values`` (samples x channels) over the healthy window
    ``train`` (rows ``a .. b - 1``)."""
    a, b = train
    w = level_window(rate_hz)
    arr = np.asarray(values)
    peak = np.full(arr.shape[1], np.nan)
    for c in range(arr.shape[1]):
        x = np.asarray(arr[a:b, c], dtype=np.float64)
        mv = _moving_variance(x, w)[min(w, x.shape[0]) - 1 :]
        if np.isfinite(mv).any():
            peak[c] = float(np.nanmax(mv))
    return LoadRange(w, peak)


def load_level(
    rng: LoadRange, values: npt.ArrayLike, columns: Sequence[int], lo: int, hi: int
) -> FloatArray:
    """Per row ``lo .. hi - 1`` of ``values``: the median over ``columns`` of each one's
    moving variance (over the window ending at the row) over its healthy peak; NaN where
    no column has a level."""
    arr = np.asarray(values)
    cols = [c for c in columns if np.isfinite(rng.peak[c]) and rng.peak[c] > 0.0]
    lo, hi = max(0, lo), min(arr.shape[0], hi)
    if not cols or hi <= lo:
        return np.full(max(0, hi - lo), np.nan)
    start = max(0, lo - rng.window + 1)
    ratios = np.empty((hi - lo, len(cols)))
    for k, c in enumerate(cols):
        x = np.asarray(arr[start:hi, c], dtype=np.float64)
        ratios[:, k] = _moving_variance(x, rng.window)[lo - start :] / rng.peak[c]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a row with no level: NaN
        return np.asarray(np.nanmedian(ratios, axis=1), dtype=np.float64)


def load_ratio(
    rng: LoadRange, values: npt.ArrayLike, columns: Sequence[int], lo: int, hi: int
) -> float:
    """The largest :func:`load_level` of ``columns`` over rows ``lo .. hi - 1`` (0 when
    none has a level): over 1, the response there is louder than anywhere in the healthy
    window."""
    lv = load_level(rng, values, columns, lo, hi)
    return float(np.nanmax(lv)) if np.isfinite(lv).any() else 0.0


def loudest(
    rng: LoadRange, values: npt.ArrayLike, columns: Sequence[int], lo: int, hi: int
) -> tuple[float, int]:
    """``(ratio, row)``: the largest :func:`load_level` of ``columns`` over rows
    ``lo .. hi - 1`` and where it is, read :data:`LEVEL_BLOCK` rows at a time (a long
    record's channels are not held at once)."""
    best, where = 0.0, lo
    for a in range(max(0, lo), hi, LEVEL_BLOCK):
        lv = load_level(rng, values, columns, a, min(hi, a + LEVEL_BLOCK))
        if np.isfinite(lv).any():
            k = int(np.nanargmax(lv))
            if lv[k] > best:
                best, where = float(lv[k]), a + k
    return best, where


class LoadGuard:
    """The level of a record's channels but one over some rows, against the healthy
    window's range (measured once, at the first call: most runs never ask). For the
    detectors' guard against alarms in stretches louder than anything the healthy window
    held; without a healthy window (``healthy`` false: a model from another record) it
    measures nothing (0)."""

    def __init__(
        self, values: npt.ArrayLike, train: tuple[int, int], rate_hz: float, healthy: bool
    ) -> None:
        self.values = values
        self.train = train
        self.rate_hz = rate_hz
        self.healthy = healthy
        self.range: LoadRange | None = None

    def __call__(self, columns: Sequence[int], own: int, lo: int, hi: int) -> float:
        """:func:`load_ratio` of ``columns`` but ``own`` (the channel an alarm would name:
        its own gain must not excuse itself) over rows ``lo .. hi - 1``."""
        if not self.healthy:
            return 0.0
        if self.range is None:
            self.range = load_range(self.values, self.train, self.rate_hz)
        return load_ratio(self.range, self.values, [c for c in columns if c != own], lo, hi)

    def at_alarm(self, columns: Sequence[int], own: int, k0: int) -> float:
        """The level around an alarm first raised at row ``k0``: over the window that
        raised it and one after (the mean-square statistics look back a long window)."""
        w = level_window(self.rate_hz)
        return self(columns, own, k0 - w, k0 + w)


def loud_stretch_count(events: Sequence[Any], notes: Sequence[str], channels: int) -> int:
    """How many of ``events`` (with an ``evidence`` dict and a ``type``) the guard judged:
    of its kinds (:data:`LOUD_KINDS`) and carrying a ``load_ratio`` (raised where the other
    channels were louder than anywhere in the healthy window), in a record of at most
    :data:`LOUD_BANK_MAX` analyzed ``channels`` (larger ones are not guarded), plus how many
    of ``notes`` are a detector's word on an alarm it did not report there
    (:data:`LOUD_MARK`). An offset or a drift there carries its ``load_ratio`` too, but
    nothing more was asked of it: the run's note on the bundled sample's offset said the
    detectors "asked more of an alarm there" (the merged session's CI)."""
    guarded = channels <= LOUD_BANK_MAX
    kept = sum(
        1
        for ev in events
        if guarded and "load_ratio" in ev.evidence and getattr(ev, "type", None) in LOUD_KINDS
    )
    return kept + sum(1 for n in notes if LOUD_MARK in n)

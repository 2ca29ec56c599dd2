"""Deciding *when* a residual is faulty: thresholds from the healthy window, alarms on
sliding-window statistics, onset and end by change-point likelihood.

The residual is first standardized with its training mean and standard deviation, so
a healthy stretch is close to zero-mean, unit-variance (though not white: residuals of
the leave-one-out estimators are coloured). Two trailing-window statistics are watched:

* the window mean ``m_k`` (an offset or a drift moves it),
* the log of the window mean square ``log q_k`` (a gain change or an erratic sensor raises
  it; an offset raises it too).

Their healthy spread is measured on the training window, and a threshold is set where a
Gaussian tail with that spread has probability ``false_alarm_rate`` per sample. A
Gaussian model of window means is the central-limit approximation and holds for coloured
residuals as long as the window spans many correlation times; ``log q`` is close to
Gaussian for the same reason. No constant in here is tuned to a data set: everything
scales with the training residual and the false-alarm rate.

Onset and end are then refined by the maximum-likelihood change point (a Gaussian
generalized-likelihood-ratio, GLR) inside a search window around the first and last
alarm, computed with cumulative sums (no Python loop per sample).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import special

from analyzer.diagnosis.spread import profile_range
from analyzer.diagnosis.streamed import (
    LaggedSums,
    RunningMoments,
    Series,
    WindowSums,
    finite_blocks,
    series_moments,
)
from analyzer.errors import DetectorError, TooLittleDataError
from analyzer.paging import release

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Calibration:
    """Healthy statistics of one residual and the thresholds derived from them.

    Two window lengths are watched: ``window`` (times abrupt faults) and
    ``LONG_FACTOR * window`` (sees sustained small changes, such as a modest gain change
    whose residual swings through zero). The false-alarm rate is split between them."""

    mean: float
    std: float
    window: int
    windows: tuple[int, ...]
    mean_sd: tuple[float, ...]
    """Standard deviation of the window mean of the standardized training residual."""
    logq_mean: tuple[float, ...]
    logq_sd: tuple[float, ...]
    false_alarm_rate: float
    samples: int = 0
    """Finite samples of the training residual it was calibrated on (0: not known, a
    calibration read back from its thresholds)."""

    def mean_variance(self) -> float | None:
        """The variance of ``mean``, the healthy level a fault's size is measured from:
        the training residual's long-run variance (``std^2`` times the long window's
        length times its window mean's variance, the Bartlett-weighted sum of its
        autocorrelations) over its samples; None where they are not known."""
        n = int(getattr(self, "samples", 0))
        if n <= 0:
            return None
        return self.std**2 * self.windows[-1] * self.mean_sd[-1] ** 2 / n

    @property
    def z_crit(self) -> float:
        """Gaussian quantile for the per-sample false-alarm rate, two-sided, shared by the
        two statistics at each window length (Bonferroni)."""
        per_test = self.false_alarm_rate / (2.0 * len(self.windows))
        # the standard normal's inverse survival function, -ndtri(p) (what scipy.stats.norm.isf
        # computes, without its ~0.3 ms of argument handling per call: this property is
        # read for every threshold)
        return float(-special.ndtri(per_test / 2.0))

    @property
    def long_window(self) -> int:
        return self.windows[-1]

    def mean_threshold(self, i: int = 0) -> float:
        return self.z_crit * self.mean_sd[i]

    def logq_threshold(self, i: int = 0) -> float:
        return self.logq_mean[i] + self.z_crit * self.logq_sd[i]

    def standardize(self, r: FloatArray) -> FloatArray:
        return (np.asarray(r, dtype=np.float64) - self.mean) / self.std

    def as_dict(self) -> dict[str, object]:
        return {
            "mean": self.mean,
            "std": self.std,
            "windows": list(self.windows),
            "mean_threshold": [self.mean_threshold(i) for i in range(len(self.windows))],
            "logq_threshold": [self.logq_threshold(i) for i in range(len(self.windows))],
            "false_alarm_rate": self.false_alarm_rate,
        }

    @classmethod
    def from_dict(cls, d: object) -> Calibration | None:
        """A calibration with the thresholds of :meth:`as_dict`'s form ``d`` (a detector
        result's ``thresholds``): the window-mean spreads from the mean thresholds, the
        log-mean-square thresholds as their centres (spread 0); None when ``d`` is not
        such a form."""
        if not isinstance(d, dict):
            return None
        try:
            windows = tuple(int(w) for w in d["windows"])
            rate = float(d["false_alarm_rate"])
            zeros = (0.0,) * len(windows)
            z = cls(0.0, 1.0, windows[0], windows, zeros, zeros, zeros, rate).z_crit
            return cls(
                float(d["mean"]),
                float(d["std"]),
                windows[0],
                windows,
                tuple(float(m) / z for m in d["mean_threshold"]),
                tuple(float(q) for q in d["logq_threshold"]),
                zeros,
                rate,
            )
        except (KeyError, TypeError, ValueError, ZeroDivisionError, IndexError):
            return None


LONG_FACTOR = 8


@dataclass(frozen=True, slots=True)
class Interval:
    """A faulty stretch of one residual: ``[onset, end)`` in samples, ``end`` None when the
    fault lasts to the end of the data. ``peak`` is the largest alarm statistic in units
    of its threshold (> 1 by construction); ``p_value`` is the Bonferroni-corrected chance
    of such a peak in healthy data of the same length."""

    onset: int
    end: int | None
    first_alarm: int
    last_alarm: int
    peak: float
    p_value: float
    onset_range: tuple[int, int] | None = field(default=None, compare=False)
    """The onsets (first and last sample) the change-point search could not tell from
    ``onset`` at 95 % (:func:`change_point_profile`); None where the onset is no search's.
    Not part of an interval's equality: the same stretch is the same interval."""


def default_window(rate_hz: float) -> int:
    """Quarter of a second of samples, at least 16: long enough to average the coloured
    healthy residual, short enough to time an abrupt fault to a fraction of a second."""
    return max(16, int(round(0.25 * rate_hz)))


def moving_mean(x: FloatArray, window: int) -> FloatArray:
    """Trailing moving average; the first ``window - 1`` entries average what exists."""
    c = np.cumsum(np.concatenate(([0.0], x)))
    out = np.empty_like(x, dtype=np.float64)
    w = min(window, x.shape[0])
    out[w - 1 :] = (c[w:] - c[:-w]) / w
    idx = np.arange(1, w)
    out[: w - 1] = c[1:w] / idx
    return out


def _acf(lagged: FloatArray, n: int) -> FloatArray:
    """Sample autocorrelation from the lagged products ``lagged`` of a centred series of
    ``n`` samples (biased estimator, as in the variance formula it feeds). Not truncated
    at the first zero crossing: an oscillating residual's autocorrelation crosses zero
    and comes back, and every lag counts in a window's variance."""
    acf = lagged / lagged[0]
    # lags inside the white-noise band carry estimation noise only: zero them one by one
    # (an oscillating autocorrelation keeps its peaks; a short sum stays unbiased)
    band = 2.0 / np.sqrt(n)
    acf[1:][np.abs(acf[1:]) < band] = 0.0
    return acf


def calibration_need(window: int) -> int:
    """Finite samples of a training residual :func:`calibrate` needs with ``window``:
    four of its long windows."""
    return 4 * LONG_FACTOR * window


def training_need(window: int) -> int:
    """Training rows that leave :func:`calibration_need` samples of the residual with
    ``window``: the detectors leave at most a quarter of the window out while their
    filters settle (:func:`needing_calibration`). What a fitted detector's ``window``
    (its result's ``params``) tells of the window it needs, without another fit."""
    return -(-4 * calibration_need(window) // 3)


def needing_calibration(err: TooLittleDataError, window: int) -> TooLittleDataError:
    """``err``, a model fit's "too little healthy data", needing at least what the
    thresholds' calibration after the fit needs (:func:`calibration_need`): a model asks
    for fewer samples than its calibration, and a window long enough for the model alone
    failed next on the thresholds (an equivalent model's 64-lag relation asked for 329
    rows at 1 Hz, its calibration for 512). In training rows: the detectors leave at most a
    quarter of the window out of the residual while their filters settle (the bank's and
    the detection filter's ``skip``, the equivalent model's ``_head``)."""
    need = training_need(window)
    if err.need >= need:
        return err
    return TooLittleDataError(str(err), err.have, need)


def calibrate(train_residual: Series, window: int, false_alarm_rate: float = 1e-6) -> Calibration:
    """Healthy statistics of ``train_residual`` (NaNs ignored; one array, or arrays read
    one after the other as one series) for :func:`detect`.

    Two passes a block at a time (:mod:`analyzer.diagnosis.streamed`): the mean and
    spread, then, of the standardized series ``z``, its autocorrelation and that of
    ``z^2``, and the spread of the window means and log mean squares. What is held at
    once is a block, not the series: a fit on a long healthy window holds no copy of
    its residuals here (a memory-mapped series' pages are given back as the passes go).
    The same statistics as the whole-series formulas to rounding (tested)."""
    windows = (window, LONG_FACTOR * window)
    need = calibration_need(window)
    first = series_moments(train_residual)
    if first.n < need:
        raise TooLittleDataError(
            f"too little healthy data to calibrate thresholds: {first.n} finite samples of "
            f"the training residual, need at least {need} (4 windows of {windows[-1]})",
            first.n,
            need,
        )
    if not 0.0 < false_alarm_rate < 0.5:
        raise DetectorError(f"false_alarm_rate must be in (0, 0.5), got {false_alarm_rate!r}")
    mean = first.mean
    std = first.std(ddof=1)
    if not std > 0.0:
        raise DetectorError(
            "the training residual is constant (zero variance): cannot set a threshold"
        )
    n = first.n
    # z has mean 0 and z^2 mean (n - 1) / n by construction (to rounding): the centres
    # of the autocorrelations are known before the second pass
    z2_centre = (n - 1) / n
    lags_z, lags_z2 = LaggedSums(windows[-1]), LaggedSums(windows[-1])
    z2_moments = RunningMoments()
    sums = [(WindowSums(w), WindowSums(w)) for w in windows]
    m_moments = [RunningMoments() for _ in windows]
    q_moments = [RunningMoments() for _ in windows]
    for x in finite_blocks(train_residual):
        z = (x - mean) / std
        z2 = z * z
        lags_z.add(z)
        z2_moments.add(z2)
        for (of_z, of_z2), w, mm, qm in zip(sums, windows, m_moments, q_moments, strict=True):
            mm.add(of_z.add(z) / w)
            qm.add(np.log(np.maximum(of_z2.add(z2) / w, 1e-300)))
        z2 -= z2_centre
        lags_z2.add(z2)
    rho = _acf(lags_z.values(), n)
    rho2 = _acf(lags_z2.values(), n)
    var_z2 = z2_moments.var()
    msd, lqm, lqs = [], [], []
    for w, mm, qm in zip(windows, m_moments, q_moments, strict=True):
        # Variance of a w-sample mean of a stationary sequence with autocorrelation rho
        # (Priestley 1981, Eq. 5.3.5), applied to z and to z^2 (whose own autocorrelation
        # carries the slow envelope of a lightly damped response). These model-based spreads
        # use every training sample; the direct spread of the windowed statistics is
        # noisy with few long windows. The larger of the two is used (conservative).
        k = np.arange(1, w)
        taper = 1.0 - k / w
        var_m = (1.0 + 2.0 * np.sum(taper * rho[1:w])) / w
        var_q = var_z2 * (1.0 + 2.0 * np.sum(taper * rho2[1:w])) / w
        msd.append(max(mm.std(ddof=1), float(np.sqrt(max(var_m, 0.0)))))
        lqm.append(qm.mean)
        lqs.append(max(qm.std(ddof=1), float(np.sqrt(max(var_q, 0.0)))))
    return Calibration(
        mean=mean,
        std=std,
        window=window,
        windows=windows,
        mean_sd=tuple(msd),
        logq_mean=tuple(lqm),
        logq_sd=tuple(lqs),
        false_alarm_rate=false_alarm_rate,
        samples=n,
    )


def alarm_statistic(
    x: FloatArray,
    cal: Calibration,
    *,
    raw: bool = False,
    start: int = 0,
    out: FloatArray | None = None,
    carry: FloatArray | None = None,
    base: int = 0,
) -> FloatArray:
    """Per-sample alarm statistic in units of its threshold (> 1 means alarm): the
    largest, over both window lengths, of |window mean| / its threshold and the
    log-mean-square excess / its threshold.

    ``x`` is the standardized residual, or with ``raw`` the residual in channel units
    (standardized on the fly with ``cal``, no standardized copy). NaNs count as gaps: a
    window that is mostly gap says nothing (statistic 0). One compiled pass over the
    samples, equal to :func:`_alarm_statistic_numpy` up to rounding (the same sums in the
    same order).

    Only the statistic from ``start`` on is computed (a search that begins there, the end
    of the training window or a fault's onset, needs no more); the entries before it are
    0. Those from ``start`` on are the whole-record pass's bit for bit: the running sums
    before ``start`` are still taken in sample order (a plain sum costs a fraction of the
    statistic), so the window sums are the same differences of the same prefix sums.

    ``out``: an array of ``x``'s length to write the entries from ``start`` on into (the
    others are left alone), returned; a new one of zeros otherwise. ``carry``: four
    floats kept by a caller that computes a growing record's statistic piece by piece
    (zeros at first): the running sums where the last call's window sums began, from
    which the next call goes on instead of summing the record from its first sample.
    ``base``: ``out[i]`` holds the statistic at sample ``base + i`` (``base <= start``),
    so a piece's statistic needs an array of the piece's length only (:func:`detect`
    computes a long record's that way)."""
    arr = np.asarray(x)
    if arr.dtype not in (np.float64, np.float32):
        arr = arr.astype(np.float64)
    mean, std = (cal.mean, cal.std) if raw else (0.0, 1.0)
    k = len(cal.windows)
    windows = np.asarray(cal.windows, dtype=np.int64)
    # the thresholds as Calibration computes them, with its quantile taken once (a scipy
    # distribution call costs more than a short record's statistic)
    zc = cal.z_crit
    mthr = np.array([zc * cal.mean_sd[i] for i in range(k)])
    lqm = np.asarray(cal.logq_mean, dtype=np.float64)
    lqden = np.array(
        [(cal.logq_mean[i] + zc * cal.logq_sd[i]) - cal.logq_mean[i] for i in range(k)]
    )
    start = max(0, start)
    if not 0 <= base <= start:
        raise ValueError(f"alarm_statistic: base {base} must be in [0, start={start}]")
    if _alarm_kernel is None:  # pragma: no cover - numba is a dependency
        z = cal.standardize(arr) if raw else np.asarray(arr, dtype=np.float64)
        s = _alarm_statistic_numpy(z, cal)
        s[:start] = 0.0
        if out is None:
            return s[base:]
        out[start - base :] = s[start:]
        return out
    if out is None:
        out = np.zeros(arr.shape[0] - base, dtype=np.float64)
    _alarm_kernel(
        arr,
        mean,
        std,
        windows,
        mthr,
        lqm,
        lqden,
        start,
        out,
        np.zeros(4) if carry is None else carry,
        base,
    )
    return out


def _alarm_statistic_numpy(z: FloatArray, cal: Calibration) -> FloatArray:
    """Reference form of :func:`alarm_statistic` (standardized ``z``) with numpy moving
    means; what the compiled kernel is checked against."""
    finite = np.isfinite(z)
    zz = np.where(finite, z, 0.0)
    s = np.zeros(zz.shape[0], dtype=np.float64)
    for i, w in enumerate(cal.windows):
        m = np.abs(moving_mean(zz, w)) / cal.mean_threshold(i)
        logq = np.log(np.maximum(moving_mean(zz * zz, w), 1e-300))
        q = (logq - cal.logq_mean[i]) / (cal.logq_threshold(i) - cal.logq_mean[i])
        si = np.maximum(m, q)
        si[: w - 1] = 0.0
        si[moving_mean(finite.astype(np.float64), w) <= 0.5] = 0.0
        np.maximum(s, si, out=s)
    return s


def _tangent_bound(
    d: float, log_at: float, inv_at: float, lw: float, g: float
) -> float:  # pragma: no cover - compiled by numba
    """Upper bound of ``(log d - lw) g`` by the tangent of the log at ``D``
    (``log_at = log D``, ``inv_at = 1 / D``), with a margin of 1e-9 of the magnitudes
    summed (their rounding is ~1e-16 of them)."""
    r = d * inv_at
    return (log_at - lw + r - 1.0 + 1e-9 * (1.0 + abs(log_at) + abs(lw) + r)) * g


def _two_windows(
    m0: float,
    m1: float,
    d0: float,
    d1: float,
    lw0: float,
    lw1: float,
    fl0: float,
    fl1: float,
    if0: float,
    if1: float,
    g0: float,
    g1: float,
    log0: float,
    id0: float,
    log1: float,
    id1: float,
) -> tuple[float, float, float, float, float]:  # pragma: no cover - compiled by numba
    """One sample of :func:`_alarm_loop` with two windows: the largest of the window
    means ``m0, m1`` and the log mean squares of the sums of squares ``d0, d1`` that can
    beat it; returns it and the tangent points ``(log D, 1 / D)`` of both windows."""
    best = 0.0
    if m0 > best:
        best = m0
    if m1 > best:
        best = m1
    # the first bound times its denominator e = 6 + 4 u, with its margins
    u0 = d0 * if0 - 1.0
    u1 = d1 * if1 - 1.0
    e0 = 6.0 + 4.0 * u0
    e1 = 6.0 + 4.0 * u1
    h0 = (u0 * (6.0 + u0) * (1.0 + 1e-12) + 1e-9 * e0) * g0
    h1 = (u1 * (6.0 + u1) * (1.0 + 1e-12) + 1e-9 * e1) * g1
    t0 = d0 > fl0 and not h0 < best * e0
    t1 = d1 > fl1 and not h1 < best * e1
    if t0 and t1:  # both may beat best: the tangent bounds too
        ub0 = min(h0 / e0, _tangent_bound(d0, log0, id0, lw0, g0))
        ub1 = min(h1 / e1, _tangent_bound(d1, log1, id1, lw1, g1))
        t0 = not ub0 < best
        t1 = not ub1 < best
        if t1 and ub1 > ub0:  # the larger bound's log first: it may rule out the other
            log1 = math.log(d1)
            id1 = 1.0 / d1
            q = (log1 - lw1) * g1
            if q > best:
                best = q
            t1 = False
            t0 = not ub0 < best
    if t0:
        log0 = math.log(d0)
        id0 = 1.0 / d0
        q = (log0 - lw0) * g0
        if q > best:
            best = q
        if t1:  # window 1 still to do: rule it out against the new best if possible
            t1 = not min(h1 / e1, _tangent_bound(d1, log1, id1, lw1, g1)) < best
    if t1:
        log1 = math.log(d1)
        id1 = 1.0 / d1
        q = (log1 - lw1) * g1
        if q > best:
            best = q
    return best, log0, id0, log1, id1


def _alarm_loop(
    x: FloatArray,
    mean: float,
    std: float,
    windows: npt.NDArray[np.int64],
    mthr: FloatArray,
    lqm: FloatArray,
    lqden: FloatArray,
    start: int,
    out: FloatArray,
    carry: FloatArray,
    base: int,
) -> None:  # pragma: no cover - compiled by numba
    """``out[t - base]`` = the alarm statistic at ``t >= start`` (``out`` is left alone
    before):
    running sums of z, z^2 and the finite count, with the last prefix sums in a ring
    buffer (a power of two above ``max(windows)``: memory set by the window, not the
    record). Sums run in sample order, as ``np.cumsum`` does; divisions are folded into
    per-window constants.

    Before ``start - max(windows) + 1`` (the earliest prefix sum a window from ``start``
    on reads) only the running sums are taken. ``out[t]`` is the largest of the candidate
    values: the window means first (cheap), then each log mean square only where an upper
    bound of it can beat them. The logs (most of the cost) are skipped only where they
    could not change ``out[t]``: the same maximum of the same values. Two bounds of
    ``log d`` (``d`` a window's sum of squares, above the healthy floor ``e^lw``):

    * ``log(1 + u) <= u (6 + u) / (6 + 4 u)`` with ``u = d e^-lw - 1 >= 0`` (equal at 0;
      the difference's derivative is ``4 u^3 / ((1 + u)(6 + 4 u)^2) >= 0``), tight near
      the floor; tested without its division (``6 + 4 u > 0``);
    * ``log d <= log D + d / D - 1`` for any ``D > 0`` (the tangent of the concave log),
      ``D`` the window's sum of squares at its last log: tight while the window's
      energy changes slowly, as in a long alarm, where the other bound grows like ``u/4``.

    Both carry margins far above rounding (relative 1e-12 and absolute 1e-9 of the
    magnitudes involved), and a log is skipped only on a definite ``bound < best`` (a
    NaN bound computes it). With two windows (every :class:`Calibration`) the window with
    the larger bound is taken first, so the other's log is mostly skipped when both
    statistics are high; its constants are scalars; and a stretch without gaps (checked
    first) needs no count of observed samples. Other window counts take the general
    loop, with the first bound only."""
    n = x.shape[0]
    k = windows.shape[0]
    wmax = windows.max()
    ring = 1
    while ring <= wmax:
        ring *= 2
    mask = ring - 1
    c1 = np.zeros(ring)
    c2 = np.zeros(ring)
    cf = np.zeros(ring, dtype=np.int64)
    inv_std = 1.0 / std
    a = 1.0 / (windows * mthr)  # |sum| * a = |window mean| / its threshold
    lw = lqm + np.log(windows.astype(np.float64))  # log(sum of squares) at the healthy mean
    floor = np.exp(lw)  # below it log q <= its healthy mean: q <= 0 adds nothing
    inv_floor = 1.0 / floor
    g = 1.0 / lqden
    first = max(0, min(start, n) - wmax + 1)
    # carry: (index, its running sums): where a previous call on the same record began
    p = int(carry[0])
    s1, s2, sf = carry[1], carry[2], int(carry[3])
    if p > first:  # a previous call's sums past first: no use
        p, s1, s2, sf = 0, 0.0, 0.0, 0
    for t in range(p, first):
        v = (np.float64(x[t]) - mean) * inv_std
        if np.isfinite(v):
            s1 += v
            s2 += v * v
            sf += 1
    carry[0], carry[1], carry[2], carry[3] = first, s1, s2, sf
    c1[first & mask] = s1
    c2[first & mask] = s2
    cf[first & mask] = sf
    if k == 2:
        # without gaps every window from first on is full: no finite count is needed
        gap = 0  # an or of flags, which the compiler vectorizes (a loop with a break not)
        for t in range(first, n):
            v = (np.float64(x[t]) - mean) * inv_std
            gap |= v - v != 0.0  # inf - inf and NaN - NaN are NaN
        gaps = gap != 0
        w0, w1 = windows[0], windows[1]
        a0, a1 = a[0], a[1]
        lw0, lw1 = lw[0], lw[1]
        fl0, fl1 = floor[0], floor[1]
        if0, if1 = inv_floor[0], inv_floor[1]
        g0, g1 = g[0], g[1]
        log0, log1 = lw0, lw1  # tangent points (log D, 1 / D), first at the floors
        id0, id1 = if0, if1
        if not gaps:
            for t in range(first, n):
                v = (np.float64(x[t]) - mean) * inv_std
                s1 += v
                s2 += v * v
                j = (t + 1) & mask
                c1[j] = s1
                c2[j] = s2
                if t < start:
                    continue
                b0 = (t + 1 - w0) & mask
                b1 = (t + 1 - w1) & mask
                ok0 = t + 1 >= w0
                ok1 = t + 1 >= w1
                m0 = abs(s1 - c1[b0]) * a0 if ok0 else 0.0
                m1 = abs(s1 - c1[b1]) * a1 if ok1 else 0.0
                d0 = s2 - c2[b0] if ok0 else 0.0  # below every floor: no log mean square
                d1 = s2 - c2[b1] if ok1 else 0.0
                out[t - base], log0, id0, log1, id1 = _two_windows(
                    m0, m1, d0, d1, lw0, lw1, fl0, fl1, if0, if1, g0, g1, log0, id0, log1, id1
                )
            return
        for t in range(first, n):
            v = (np.float64(x[t]) - mean) * inv_std
            if np.isfinite(v):
                s1 += v
                s2 += v * v
                sf += 1
            j = (t + 1) & mask
            c1[j] = s1
            c2[j] = s2
            cf[j] = sf
            if t < start:
                continue
            b0 = (t + 1 - w0) & mask
            b1 = (t + 1 - w1) & mask
            # a window not yet full, or mostly gap, says nothing
            ok0 = t + 1 >= w0 and 2 * (sf - cf[b0]) > w0
            ok1 = t + 1 >= w1 and 2 * (sf - cf[b1]) > w1
            m0 = abs(s1 - c1[b0]) * a0 if ok0 else 0.0
            m1 = abs(s1 - c1[b1]) * a1 if ok1 else 0.0
            d0 = s2 - c2[b0] if ok0 else 0.0
            d1 = s2 - c2[b1] if ok1 else 0.0
            out[t - base], log0, id0, log1, id1 = _two_windows(
                m0, m1, d0, d1, lw0, lw1, fl0, fl1, if0, if1, g0, g1, log0, id0, log1, id1
            )
        return
    d2s = np.zeros(k)  # the window sums of squares at t
    for t in range(first, n):
        v = (np.float64(x[t]) - mean) * inv_std
        if np.isfinite(v):
            s1 += v
            s2 += v * v
            sf += 1
        j = (t + 1) & mask
        c1[j] = s1
        c2[j] = s2
        cf[j] = sf
        if t < start:
            continue
        best = 0.0
        for i in range(k):
            w = windows[i]
            d2s[i] = 0.0  # below every floor: no log mean square
            if t + 1 < w:
                continue
            b = (t + 1 - w) & mask
            if 2 * (sf - cf[b]) <= w:  # a window that is mostly gap says nothing
                continue
            m = abs(s1 - c1[b]) * a[i]
            if m > best:
                best = m
            d2s[i] = s2 - c2[b]
        for i in range(k):
            d2 = d2s[i]
            if d2 > floor[i]:
                u = d2 * inv_floor[i] - 1.0  # log(d2) - lw = log(1 + u)
                if (u * (6.0 + u) / (6.0 + 4.0 * u) * (1.0 + 1e-12) + 1e-9) * g[i] < best:
                    continue  # cannot beat best: no log
                q = (math.log(d2) - lw[i]) * g[i]
                if q > best:
                    best = q
        out[t - base] = best


_alarm_kernel: Callable[..., None] | None
try:  # numba compiles the per-sample pass; nogil lets threads run channels at once
    from numba import njit
except ImportError:  # pragma: no cover - numba is a dependency; numpy without it
    _alarm_kernel = None
else:
    # compiled before the kernel that calls it (numba resolves the global when compiling)
    _tangent_bound = njit(cache=True, nogil=True, inline="always")(_tangent_bound)
    _two_windows = njit(cache=True, nogil=True, inline="always")(_two_windows)
    _alarm_kernel = njit(cache=True, nogil=True)(_alarm_loop)


def _runs(mask: npt.NDArray[np.bool_], offset: int = 0) -> list[tuple[int, int]]:
    """Half-open [start, stop) runs of True, shifted by ``offset``. From the True
    samples' indices (alarms are rare: one pass over the mask, the rest on few indices)."""
    idx = np.flatnonzero(mask)
    if idx.shape[0] == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) > 1)
    starts = np.concatenate((idx[:1], idx[breaks + 1])) + offset
    stops = np.concatenate((idx[breaks], idx[-1:])) + (offset + 1)
    return list(zip(starts.tolist(), stops.tolist(), strict=True))


def change_point(z: FloatArray, *, before_normal: bool = True) -> int:
    """Maximum-likelihood change point in ``z`` between N(0, 1) and N(mu, v).

    With ``before_normal`` the samples before the change are healthy and those from the
    change on follow an unknown Gaussian; the log-likelihood ratio of the change at ``k``
    is ``0.5 * (S2 - n - n log v)`` over the ``n`` samples from ``k``, with ``S2`` their sum
    of squares and ``v`` their ML variance (Basseville & Nikiforov 1993, GLR). Otherwise
    the roles are swapped (the end of a fault). Returns the index of the first changed
    sample (``before_normal``) or the first healthy one."""
    x = np.where(np.isfinite(z), z, 0.0)
    if not before_normal:
        k = change_point(x[::-1], before_normal=True)
        return x.shape[0] - k
    return int(np.argmax(change_point_profile(x)))


def change_point_profile(x: FloatArray) -> FloatArray:
    """The log-likelihood ratio of :func:`change_point`'s change at each sample of ``x``
    (finite, ``before_normal``): its argmax is the change point, and the samples whose
    ratio lies near the best (:func:`analyzer.diagnosis.spread.profile_range`) are the
    onsets the data cannot tell from it."""
    n_tot = x.shape[0]
    s1 = np.cumsum(x[::-1])[::-1]
    s2 = np.cumsum((x * x)[::-1])[::-1]
    n = np.arange(n_tot, 0, -1, dtype=np.float64)
    mu = s1 / n
    v = np.maximum(s2 / n - mu * mu, 1e-12)
    llr = 0.5 * (s2 - n - n * np.log(v))
    # need at least a couple of samples after the change to estimate (mu, v)
    llr[-2:] = -np.inf
    return llr


STAT_PIECE = 1 << 18
"""Samples of the alarm statistic :func:`detect` computes at a time when it is not given
one (2 MB): a long record's statistic is never held whole, and a memory-mapped residual
is given back behind the pass."""


def detect(
    residual: FloatArray,
    cal: Calibration,
    *,
    min_gap: int | None = None,
    search_start: int = 0,
    statistic: FloatArray | None = None,
    index: SumsIndex | None = None,
) -> list[Interval]:
    """Faulty intervals of ``residual`` (channel units; standardized with ``cal``).

    Alarm runs closer than ``min_gap`` observed samples (default: the long window; missing
    samples do not count) are one interval; a fault whose residual swings through zero (a
    gain change) briefly drops its window statistics, which must not split it, and a gap
    in the data does not end it. Alarms before ``search_start`` (the training
    window's end, say) are ignored.

    ``statistic``: the residual's :func:`alarm_statistic` (``raw=True``), when the caller
    has it already; only its entries from ``search_start`` on are read (and none are
    changed). Without it, it is computed from ``search_start`` on, :data:`STAT_PIECE`
    samples at a time with the running sums carried (bit for bit the whole-record
    pass): what stays of it are the alarm runs and their peaks, so the memory does not
    grow with the record. ``index``: collects the running sums of that pass
    (:class:`SumsIndex`, for the searches of the faults' ends on the same residual)."""
    # alarms only from the search's start: the record before it is not looked at
    first = max(0, search_start)
    if statistic is not None:
        runs = AlarmRuns.of_statistic(statistic, first, residual.shape[0])
    else:
        runs = AlarmRuns(cal, first, index=index).extend(residual, release_behind=True)
    return intervals(residual, cal, runs, search_start=search_start, min_gap=min_gap)


def intervals(
    residual: FloatArray,
    cal: Calibration,
    runs: list[list[Any]],
    *,
    search_start: int = 0,
    min_gap: int | None = None,
) -> list[Interval]:
    """:func:`detect`'s intervals from the alarm runs of ``residual`` (:class:`AlarmRuns`),
    reading the residual only around the alarms and between them."""
    n = residual.shape[0]
    w = cal.window
    wl = cal.long_window
    gap = wl if min_gap is None else min_gap
    merged: list[list[Any]] = []
    for a, b, peak in runs:
        # samples between two runs count only where the residual was observed: a stretch
        # of missing data (a damaged or absent file) says nothing about the fault having
        # ended
        if merged and not _observed_above(residual, merged[-1][1], a, gap):
            merged[-1][1] = b
            merged[-1][2] = max(merged[-1][2], peak)
        else:
            merged.append([a, b, peak])
    n_windows = max(1.0, n / w) * len(cal.windows)
    out: list[Interval] = []
    prev_end = search_start
    for a, b, peak in merged:
        # one-sided Gaussian tail of the peak (in z units) over n/w independent windows
        z_peak = peak * cal.z_crit
        p = float(min(1.0, 2.0 * special.ndtr(-z_peak) * n_windows))
        lo = max(prev_end, a - wl - 2 * w)
        hi = min(n, a + w)
        onset, within = a, None
        if hi - lo > 4:
            z = cal.standardize(residual[lo:hi])
            llr = change_point_profile(np.where(np.isfinite(z), z, 0.0))
            onset = lo + int(np.argmax(llr))
            near = profile_range(llr, cal.window * cal.mean_sd[0] ** 2)
            within = None if near is None else (lo + near[0], min(lo + near[1], a))
        if onset > a:
            within = None  # (the first alarm, a bound: the search put the change after it)
        onset = min(onset, a)
        last = b - 1
        if b >= n - 1:
            end: int | None = None
        else:
            lo2 = max(onset + 1, last - wl - 2 * w)
            hi2 = min(n, last + w)
            end = (
                lo2 + change_point(cal.standardize(residual[lo2:hi2]), before_normal=False)
                if hi2 - lo2 > 4
                else b
            )
            end = max(end, onset + 1)
        out.append(Interval(onset, end, a, last, peak, p, within))
        prev_end = end if end is not None else n
    return out


class SumsIndex:
    """The alarm statistic's running sums of one record (and one calibration) at points
    along it, kept by a pass over it (:class:`AlarmRuns` with ``index``): a later pass
    that starts at some sample resumes from the last point before its first window
    instead of summing the record from sample 0, with the same sums bit for bit (the
    sums are sequential either way). A lasting fault's end searches each summed the
    record up to their onset: thousands of searches over a long archive, a cost
    quadratic in its length."""

    def __init__(self) -> None:
        self.points: list[FloatArray] = []  # carries, by increasing index

    def add(self, carry: FloatArray) -> None:
        if not self.points or carry[0] > self.points[-1][0]:
            self.points.append(carry.copy())

    def before(self, start: int, cal: Calibration) -> FloatArray:
        """A carry for a statistic from ``start`` on: the last point at or before the
        first sample its windows read (zeros, the record's start, when there is none)."""
        first = max(0, start - max(cal.windows) + 1)
        k = bisect.bisect_right([float(c[0]) for c in self.points], first)
        return self.points[k - 1].copy() if k else np.zeros(4)


class AlarmRuns:
    """The runs of alarm statistic above 1 of a record from ``first`` on, ``[start, stop,
    peak]`` each, found a :data:`STAT_PIECE` at a time as the record grows
    (:meth:`extend`): the statistic is bit for bit the whole-record pass's (its running
    sums carried), and only its runs are kept. A run cut by a piece's edge comes as two,
    which :func:`intervals` joins (no observed sample between them)."""

    def __init__(
        self,
        cal: Calibration,
        first: int,
        carry: FloatArray | None = None,
        index: SumsIndex | None = None,
    ) -> None:
        self.cal = cal
        self.h = max(0, first)  # the statistic is known before this sample
        self.carry = np.zeros(4) if carry is None else carry
        self.index = index  # where each piece's running sums are kept
        self.runs: list[list[Any]] = []

    @staticmethod
    def of_statistic(statistic: FloatArray, first: int, n: int) -> list[list[Any]]:
        """The runs of a whole-record ``statistic`` over ``first .. n - 1``."""
        return _runs_with_peaks(statistic[first:n], first)

    def extend(self, record: FloatArray, release_behind: bool = False) -> list[list[Any]]:
        """The runs up to the end of ``record`` (the record's first ``h`` samples, ``h`` at
        least the last call's). ``release_behind``: give back a memory-mapped record's
        pages behind the pass."""
        n = record.shape[0]
        if self.h >= n:
            return self.runs
        piece = np.empty(min(STAT_PIECE, n - self.h))
        done = int(self.carry[0])  # the record before it is read no more
        for lo in range(self.h, n, STAT_PIECE):
            hi = min(n, lo + STAT_PIECE)
            s = alarm_statistic(
                record[:hi],
                self.cal,
                raw=True,
                start=lo,
                out=piece[: hi - lo],
                carry=self.carry,
                base=lo,
            )
            self.runs.extend(_runs_with_peaks(s, lo))
            if self.index is not None:
                self.index.add(self.carry)
            # the next piece reads the record from its first window's start on
            read_from = int(self.carry[0])
            if release_behind and read_from > done:
                release(record[done:read_from])
                done = read_from
        if release_behind:
            release(record[done:n])
        self.h = n
        return self.runs


def _runs_with_peaks(s: FloatArray, offset: int) -> list[list[Any]]:
    """``[start, stop, peak]`` of the runs of ``s > 1``, shifted by ``offset``."""
    return [[a, b, float(np.max(s[a - offset : b - offset]))] for a, b in _runs(s > 1.0, offset)]


def _observed_above(x: FloatArray, lo: int, hi: int, limit: int) -> bool:
    """Whether more than ``limit`` samples of ``x[lo:hi]`` are finite, counted a stretch
    at a time until the answer is known (the stretch between two alarms can be most of
    the record)."""
    if hi - lo <= limit:
        return False
    count = 0
    step = max(limit + 1, 1 << 16)
    while lo < hi:
        b = min(hi, lo + step)
        count += int(np.count_nonzero(np.isfinite(x[lo:b])))
        if count > limit:
            return True
        if count + (hi - b) <= limit:
            return False
        lo = b
    return False


def detection_confidence(interval: Interval) -> float:
    """1 - p-value of the interval's peak (the chance it is no false alarm)."""
    return float(max(0.0, 1.0 - interval.p_value)) if math.isfinite(interval.p_value) else 0.0

"""How sure a fault's size and onset are: 95 % intervals from the fits that gave them.

The size (an offset ``D``, a drift's rate ``b``, a gain ``a``) is the least-squares or
maximum-likelihood estimate of :func:`~analyzer.diagnosis.classify.classify` over the
fault's stretch. Its standard error is that estimator's own, taken from the same samples:
the sandwich ``bread^-1 S bread^-1`` of its estimating equation ``sum_t psi_t = 0``, with
``S`` the Newey-West (HAC) long-run sum of the scores ``psi_t``
(:func:`analyzer.stats.moments.bartlett_sum`, the weights of ``mean_long_run``), because
a residual is coloured and its samples are not independent:

* offset, the stretch's mean: ``psi = e`` (``e = f - D``), ``se^2 = S / n^2``;
* drift, the line ``f = c + b tau``: ``psi = (tau - mean tau) e``, ``se^2 = S / Stt^2``
  (a line held through its onset ``s``, ``b (tau - s)``: ``psi = (tau - s) e``);
* a least-squares gain ``f = (a - 1) y``: ``psi = y e``, ``se^2 = S / Syy^2``;
* the scaled gain (``u z - y = e``, ``u = 1 / a``, :func:`~analyzer.diagnosis.classify.
  _scaled_gain`): ``psi = (u z - y) z - s2 / u``, ``bread = Szz + n s2 / u^2``, and the
  gain's error by the delta method, ``se(a) = se(u) a^2``.

The fault signal is measured from the healthy level (the training residual's mean,
``shift``), itself an estimate: its variance (the training residual's long-run variance
over its samples, :meth:`~analyzer.diagnosis.changes.Calibration.mean_variance`) is
added by the delta method, ``se^2 + (d size / d shift)^2 var(shift)`` (an offset's
slope is -1, a drift's rate's 0, a gain's from its estimating equation). Without it the
offsets' intervals held the true offset in 70 % of the sweep's records: over a 40 s
training window and a 100 s fault, the level's error is the larger part. The healthy
share of the reference (:class:`~analyzer.diagnosis.classify.ReferenceSlope`), also
measured in training, is taken as known.

These are statsmodels' OLS ``cov_type="HAC"`` standard errors (``use_correction=False``)
for the least-squares shapes. The interval is ``estimate +- 1.96 se``.

The Newey-West sum runs over :func:`hac_lags` lags: Andrews' (1991) automatic
bandwidth from the scores' own lag-1 autocorrelation, never fewer than the healthy
residual's correlation time (samples), over which its autocorrelation lasts. (A first
version used the Newey-West (1994) rule ``floor(4 (n / 100)^(2/9))``, 11 lags over 100 s
at 100 Hz: the offsets' errors were 1.6 times too small, their intervals held the true
offset in 70 % of the sweep's records; the residual stays correlated for longer than
that rule assumes.) The sum pairs samples within one contiguous run of the stretch only
(:class:`RunLaggedSums`): a lag never reaches across a gap in the aligned record (rows
where the channel or its estimate has no value), whose two sides may differ, a level
that stepped while the channel was silent; each run's sum is its own, as statsmodels'
``cov_type="hac-panel"`` with each run a group. The intervals are what the estimators
give, not widened to a target: ``benchmarks/sweep_intervals.py`` measures how often they
hold the true size and onset (README), and they miss where the estimate is biased (a
fault near the detection limit, a fit bent by the stretch's ends), which no standard
error accounts for.

The onset: where it is the change point of the alarm's likelihood search
(:func:`~analyzer.diagnosis.changes.change_point`), its interval is the onsets whose
log-likelihood ratio lies within ``chi2(1 dof, 0.95) / 2`` of the best, the ratio taken
per independent sample (divided by the residual's correlation time, as the classifier
counts its samples); where it is a drift's line traced back to zero (``-c / b``), the
delta method's ``sd^2 = var(D) / b^2 + D^2 var(b) / b^4 - 2 D cov(D, b) / b^3`` with
``D`` the line's value at the stretch's mean time. The search's candidates are first
faulty samples, so the fault began after the sample before the earliest of them: the
interval starts one sample period earlier (an onset is known to a sample at best; a
zero-width ``[k, k]`` would only say the first faulty sample is ``k``). The chi-square
bound is nominal: a change point's location is a non-regular problem, where Wilks'
theorem does not hold; the measured coverage (README) is the evidence. Where the onset
is a bound (the record's start, a drift's line held through the alarm's onset), there is
no interval: the reason is given instead.

The 95 % level is nominal everywhere, and two cases are marked as falling short of it
(measured: ``benchmarks/sweep_intervals.py``, README). A gain's size interval keeps its
numbers but counts the fit's noise only, not the error of the fault-free reference it is
measured against (``magnitude_partial``: it held the true gain in 68-75 % of simulated
records). A gain's onset has no interval: the search models a shift in the residual's
mean and spread, not a gain, and its profile held the true onset in 60-89 %. A size
measured from the healthy level whose variance is not known (a model saved before the
calibration kept its sample count) is marked too: it leaves that level's error out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from analyzer.stats.moments import bartlett_sum
from analyzer.stats.whiteness import lagged_products
from analyzer.types import FaultType

if TYPE_CHECKING:
    from analyzer.diagnosis.classify import Classification

FloatArray = npt.NDArray[np.float64]

Z_95 = 1.959963984540054
"""The standard normal's 97.5 % point: a two-sided 95 % interval is ``+- Z_95 se``."""
CHI2_1_95 = 3.841458820694124
"""The chi-square (1 dof) 95 % point: a profile's bound on twice the log-likelihood ratio."""
LEVEL = 0.95


MAX_LAGS = 500
"""Lags of a score's products kept for the Newey-West sum: the most :func:`hac_lags`
may choose. It counts samples, not time: 5 s at 100 Hz, but 0.5 s at 1 kHz."""

GAIN_COVERAGE = "68-75 %"
"""The share of simulated records in which a gain's "noise only" interval held the true
gain (benchmarks/sweep_intervals.py, README's Intervals of size and onset): said by
:data:`GAIN_SIZE_NOTE` and by the report beside such an interval."""
GAIN_SIZE_NOTE = (
    "counts the fit's noise only, not the error of the fault-free reference the gain is "
    "measured against (it pulls the estimate towards no gain): it held the true gain in "
    f"{GAIN_COVERAGE} of simulated records (README, Intervals of size and onset), not 95 %"
)
"""Why a gain's size interval is labelled "noise only" (:func:`event_intervals`)."""
GAIN_ONSET_NOTE = (
    "no interval for a gain's onset: the onset search models a shift in the residual's "
    "mean and spread, not a gain (whose residual follows the signal); its profile held "
    "the true onset in only 60-89 % of simulated records (README)"
)
"""Why a gain's onset has no interval (:func:`event_intervals`)."""
OLD_MODEL_NOTE = (
    "the healthy level's own error is not counted (a model saved by an older version "
    "does not keep its training sample count), so the interval is narrower than it "
    "should be; refit the model to include it"
)
"""Why a size interval from a model without its training sample count is partial."""


def hac_lags(lagged: FloatArray, n: int, tau_corr: float = 1.0) -> int:
    """Lags of the Newey-West sum of a score series over ``n`` samples, from its lagged
    products ``lagged`` (``c_0, c_1, ...``): Andrews' (1991) automatic bandwidth for the
    Bartlett kernel, ``1.1447 (alpha n)^(1/3)`` with ``alpha = 4 rho^2 / ((1 - rho)^2
    (1 + rho)^2)`` of the series' lag-1 autocorrelation ``rho`` (an AR(1) plug-in: the
    more correlated the scores, the further the sum reaches), and at least
    ``ceil(tau_corr)`` (the healthy residual's correlation time in samples), at most
    ``n - 1`` and :data:`MAX_LAGS`."""
    if n < 2 or lagged.shape[0] < 2 or not lagged[0] > 0.0:
        return 0
    rho = float(np.clip(lagged[1] / lagged[0], -0.99, 0.99))
    alpha = 4.0 * rho * rho / ((1.0 - rho) ** 2 * (1.0 + rho) ** 2)
    lags = int(1.1447 * (alpha * n) ** (1.0 / 3.0))
    return max(0, min(n - 1, MAX_LAGS, max(lags, int(math.ceil(tau_corr)))))


SPACED_GROWTH = 4
"""A block whose runs laid out apart (:func:`_spaced`) would be more than this many times
its samples long has its lagged products summed lag by lag instead (:func:`_run_products`):
a stretch cut by many short gaps would otherwise take :data:`MAX_LAGS` zeros per gap."""


def _spaced(d: FloatArray, at: npt.NDArray[np.int64], gap: int) -> FloatArray:
    """``d`` (samples at rows ``at``, increasing) laid out with ``gap`` zeros between its
    contiguous runs (where ``at`` steps by more than one row) and none within them: its
    lagged products up to lag ``gap`` are then those of pairs within one run."""
    step = np.where(np.diff(at) > 1, gap + 1, 1)
    pos = np.concatenate(([0], np.cumsum(step)))
    out = np.zeros(int(pos[-1]) + 1 if pos.shape[0] else 0)
    out[pos] = d
    return out


def _run_products(d: FloatArray, at: npt.NDArray[np.int64], max_lag: int) -> FloatArray:
    """``c[k] = sum_t d[t] d[t + k]`` over the pairs ``k`` rows apart within one contiguous
    run of ``at`` (``k = 0 .. min(max_lag, n - 1)``): :func:`lagged_products` of
    :func:`_spaced` where that is short enough, else lag by lag (a pair ``k`` places apart
    is in one run where its rows are ``k`` apart: one vectorized product per lag)."""
    n = d.shape[0]
    if n == 0:
        return np.zeros(1)
    top = min(max_lag, n - 1)
    breaks = int(np.count_nonzero(np.diff(at) > 1))
    if n + breaks * max_lag <= SPACED_GROWTH * n:
        return lagged_products(_spaced(d, at, max_lag), max_lag)[: top + 1]
    out = np.empty(top + 1)
    out[0] = float(np.dot(d, d))
    for k in range(1, top + 1):
        same = (at[k:] - at[:-k]) == k
        out[k] = float(np.dot(d[k:][same], d[:-k][same]))
    return out


def _contiguous(at: npt.NDArray[np.int64]) -> bool:
    """Whether the increasing rows ``at`` follow one another with no row missing."""
    return at.shape[0] < 2 or int(at[-1] - at[0]) == at.shape[0] - 1


class RunLaggedSums:
    """The lagged products ``c_k = sum_t d_t d_{t+k}`` (``k`` up to ``max_lag``) of a
    series with gaps, added block by block with each sample's row: only pairs within one
    contiguous run of rows count, never a pair across a gap (the aligned record's rows
    where the channel, or its estimate, has no value: NaN). Without gaps the same sums as
    :class:`~analyzer.diagnosis.streamed.LaggedSums` (the same arithmetic), with them the
    sum of each run's own."""

    __slots__ = ("max_lag", "n", "sums", "tail", "tail_at")

    def __init__(self, max_lag: int) -> None:
        self.max_lag = int(max_lag)
        self.sums = np.zeros(self.max_lag + 1)
        self.tail = np.empty(0)
        self.tail_at = np.empty(0, dtype=np.int64)
        self.n = 0

    def add(self, d: FloatArray, first: int, at: npt.NDArray[np.int64] | None = None) -> None:
        """Add the samples ``d`` at rows ``at`` (increasing), or, where ``at`` is None, at
        the contiguous rows from ``first`` on (no array of rows is made: a gapless
        stretch costs what :class:`~analyzer.diagnosis.streamed.LaggedSums` does)."""
        m = d.shape[0]
        if m == 0:
            return
        held = self.tail.shape[0]
        ext = np.concatenate((self.tail, d)) if held else d
        joined = at is None and (not held or int(self.tail_at[-1]) + 1 == first)
        if joined and _contiguous(self.tail_at):
            s = lagged_products(ext, self.max_lag)
            t = lagged_products(self.tail, self.max_lag) if held else None
            keep = max(0, ext.shape[0] - self.max_lag)
            tail_at = np.arange(first + m - (ext.shape[0] - keep), first + m, dtype=np.int64)
        else:
            rows = np.arange(first, first + m, dtype=np.int64) if at is None else at
            ext_at = np.concatenate((self.tail_at, rows)) if held else rows
            s = _run_products(ext, ext_at, self.max_lag)
            t = _run_products(self.tail, self.tail_at, self.max_lag) if held else None
            keep = max(0, ext.shape[0] - self.max_lag)
            tail_at = ext_at[keep:].copy()
        self.sums[: s.shape[0]] += s
        if t is not None:  # (the carried samples' own products: counted with the block before)
            self.sums[: t.shape[0]] -= t
        self.tail, self.tail_at = ext[keep:].copy(), tail_at
        self.n += m

    def values(self) -> FloatArray:
        """The sums at the lags the series is long enough for (``min(max_lag, n - 1)``)."""
        return self.sums[: max(0, min(self.max_lag, self.n - 1)) + 1].copy()


class ScoreSums:
    """The lagged products ``c_k = sum_t psi_t psi_{t+k}`` (``k`` up to :data:`MAX_LAGS`)
    of a score series added block by block, and their Newey-West long-run sum ``S = c_0
    + 2 sum_k (1 - k / (L + 1)) c_k`` over ``L`` lags (about zero: a fit's scores sum to
    zero at its estimate). Only pairs within one contiguous run of the stretch's valid
    samples count (:class:`RunLaggedSums`): a lag does not reach across a gap, whose two
    sides may differ (a level that stepped while the channel was silent), as statsmodels'
    ``cov_type="hac-panel"`` with each run a group. ``rate_hz``: the rows' rate, by which
    each sample's ``tau`` (seconds from the stretch's first row) gives its row."""

    __slots__ = ("lagged", "rate_hz")

    def __init__(self, rate_hz: float) -> None:
        self.lagged = RunLaggedSums(MAX_LAGS)
        self.rate_hz = rate_hz

    def add(self, psi: FloatArray, tau: FloatArray) -> None:
        if tau.shape[0] == 0:
            return
        first = round(float(tau[0]) * self.rate_hz)
        last = round(float(tau[-1]) * self.rate_hz)
        at = None
        if last - first != tau.shape[0] - 1:  # (a gap inside the block: each sample's row)
            at = np.rint(np.asarray(tau, dtype=np.float64) * self.rate_hz).astype(np.int64)
        self.lagged.add(np.asarray(psi, dtype=np.float64), first, at)

    def lags(self, tau_corr: float) -> int:
        """:func:`hac_lags` of this series."""
        return hac_lags(self.lagged.values(), self.lagged.n, tau_corr)

    def total(self, lags: int) -> float:
        values = self.lagged.values()[: lags + 1]
        return bartlett_sum(values) if values.shape[0] else 0.0


@dataclass(frozen=True, slots=True)
class Spread:
    """The standard errors of a fitted shape: ``se`` per magnitude key (channel units; a
    drift's per second), ``onset_sd_s`` of a drift's traced onset (seconds; None where
    the onset is no estimate: ``onset_note`` says why) and the Newey-West ``lags``."""

    se: dict[str, float]
    lags: int
    onset_sd_s: float | None = None
    onset_note: str | None = None
    level_slope: dict[str, float] = field(default_factory=dict)
    """How each size moves with the healthy level it is measured from (``shift``, the
    training residual's mean, itself an estimate): ``d size / d shift``."""
    onset_level_slope: float = 0.0
    """The same of a drift's traced onset (seconds per channel unit)."""

    def with_level(self, variance: float | None) -> Spread:
        """The errors with the healthy level's own ``variance`` added (the delta method:
        ``se^2 + slope^2 var``); unchanged where it is not known."""
        if variance is None or not variance >= 0.0:
            return self
        se = {
            k: math.hypot(v, self.level_slope.get(k, 0.0) * math.sqrt(variance))
            for k, v in self.se.items()
        }
        onset = self.onset_sd_s
        if onset is not None:
            onset = math.hypot(onset, self.onset_level_slope * math.sqrt(variance))
        return replace(self, se=se, onset_sd_s=onset)


Pieces = Callable[[], Iterable[tuple[FloatArray, FloatArray | None, FloatArray]]]
"""The stretch's valid samples a piece at a time (``f``, ``y``, ``tau``), as classify reads
them."""


def offset_spread(pieces: Pieces, n: int, offset: float, tau_corr: float, rate_hz: float) -> Spread:
    """The offset's (the stretch's mean's) standard error: ``sqrt(S) / n``, ``S`` the
    Newey-West sum of ``e = f - offset``."""
    s = ScoreSums(rate_hz)
    for f, _, tau in pieces():
        s.add(f - offset, tau)
    lags = s.lags(tau_corr)
    se = math.sqrt(max(s.total(lags), 0.0)) / n
    return Spread({"offset": se}, lags, level_slope={"offset": -1.0})


def drift_spread(
    pieces: Pieces,
    n: int,
    line: tuple[float, float, float],
    mean_tau: float,
    tau_corr: float,
    held_at: float | None,
    rate_hz: float,
) -> Spread:
    """A drift's rate's standard error and its traced onset's (``line``: the mean ``D``
    of the fault signal, the intercept ``c`` and rate ``b``; ``f = c + b tau``).
    ``held_at``: the onset ``s`` the line was held through (``b (tau - s)``, its zero
    outside the admissible onsets), whose onset is then a bound, not an estimate."""
    d, c, b = line
    if held_at is not None:
        s = ScoreSums(rate_hz)
        suu = 0.0
        for f, _, tau in pieces():
            u = tau - held_at
            suu += float(np.dot(u, u))
            s.add(u * (f - b * u), tau)
        lags = s.lags(tau_corr)
        se = math.sqrt(max(s.total(lags), 0.0)) / suu if suu > 0.0 else math.inf
        note = (
            "a bound: the fitted line met zero where no drift can begin (after the "
            "alarm's onset, or further back than the stretch is long), so it was held "
            "through that onset"
        )
        return Spread({"rate_per_s": se}, lags, None, note)
    se_e, se_h, se_eh = ScoreSums(rate_hz), ScoreSums(rate_hz), ScoreSums(rate_hz)
    stt = 0.0
    for f, _, tau in pieces():
        tc = tau - mean_tau
        e = f - (c + b * tau)
        h = tc * e
        stt += float(np.dot(tc, tc))
        se_e.add(e, tau)
        se_h.add(h, tau)
        se_eh.add(e + h, tau)
    # (one lag count for the three sums, the rate's score's: their covariance needs it)
    lags = se_h.lags(tau_corr)
    s_e, s_h = se_e.total(lags), se_h.total(lags)
    if not stt > 0.0:
        return Spread({"rate_per_s": math.inf}, lags, None, "the stretch spans no time")
    var_d = s_e / (n * n)
    var_b = s_h / (stt * stt)
    cov = 0.5 * (se_eh.total(lags) - s_e - s_h) / (n * stt)
    rate = {"rate_per_s": math.sqrt(max(var_b, 0.0))}
    if b == 0.0:
        return Spread(rate, lags, None, "the fitted line does not change: no onset to trace")
    # tau0 = -c / b = mean_tau - d / b: the delta method on (d, b)
    var_t = var_d / b**2 + d * d * var_b / b**4 - 2.0 * d * cov / b**3
    # (the level moves D by -1 per unit, so the onset mean_tau - D / b by 1 / b)
    return Spread(rate, lags, math.sqrt(max(var_t, 0.0)), onset_level_slope=1.0 / b)


def gain_spread(
    pieces: Pieces,
    n: int,
    gain: float,
    sums: tuple[float, float, float],
    noise: float,
    tau_corr: float,
    scaled: bool,
    rate_hz: float,
) -> Spread:
    """A gain's standard error. ``sums``: ``Sff``, ``Sfy``, ``Syy`` of the stretch;
    ``scaled``: the gain is :func:`~analyzer.diagnosis.classify._scaled_gain`'s maximum
    likelihood (its noise scaled with it, healthy variance ``noise``), else the least
    squares' ``1 + Sfy / Syy``."""
    energy, cross, den = sums
    s = ScoreSums(rate_hz)
    sum_f = sum_y = 0.0
    if not scaled:
        g = gain - 1.0
        for f, y, tau in pieces():
            if y is not None:
                s.add(y * (f - g * y), tau)
                sum_y += float(np.sum(y))
        lags = s.lags(tau_corr)
        if not den > 0.0:
            return Spread({"gain": math.inf}, lags)
        se = math.sqrt(max(s.total(lags), 0.0)) / den
        # (g = Sfy / Syy, f less the level: dg / dshift = -Sy / Syy)
        return Spread({"gain": se}, lags, level_slope={"gain": -sum_y / den})
    u = 1.0 / gain
    szz = energy + 2.0 * cross + den
    szy = cross + den
    for f, y, tau in pieces():
        if y is not None:
            z = f + y
            s.add((u * z - y) * z - noise / u, tau)
            sum_f += float(np.sum(f))
            sum_y += float(np.sum(y))
    bread = szz + n * noise / (u * u)
    lags = s.lags(tau_corr)
    se_u = math.sqrt(max(s.total(lags), 0.0)) / bread
    # u^2 Szz - u Szy - n s2 = 0 with z = f + y and f less the level: dSzz / dshift =
    # -2 Sz, dSzy / dshift = -Sy, so du / dshift = (2 u^2 Sz - u Sy) / (2 u Szz - Szy),
    # and da = -a^2 du
    sum_z = sum_f + sum_y
    slope_u = (2.0 * u * u * sum_z - u * sum_y) / (2.0 * u * szz - szy)
    return Spread({"gain": se_u * gain * gain}, lags, level_slope={"gain": -gain * gain * slope_u})


def profile_range(llr: FloatArray, tau_eff: float) -> tuple[int, int] | None:
    """The first and last index whose log-likelihood ratio lies within ``chi2(1, 0.95) /
    2`` of the best, the ratio counted per independent sample (divided by ``tau_eff``,
    the residual's correlation time, >= 1); None without a finite profile."""
    finite = np.isfinite(llr)
    if not finite.any():
        return None
    best = float(np.max(llr[finite]))
    inside = np.flatnonzero(finite & (2.0 * (best - llr) / max(tau_eff, 1.0) <= CHI2_1_95))
    return int(inside[0]), int(inside[-1])


def interval(estimate: float, se: float) -> list[float] | None:
    """``estimate +- Z_95 se``, or None where the error is not finite."""
    if not (math.isfinite(se) and math.isfinite(estimate)):
        return None
    return [estimate - Z_95 * se, estimate + Z_95 * se]


def event_intervals(
    cls: Classification,
    onset_range: tuple[int, int] | None,
    onset_s: float,
    extra: Mapping[str, Any],
    rate_hz: float,
    level_variance: float | None = None,
) -> dict[str, Any]:
    """An event's 95 % intervals: of its size (``cls``'s magnitude, from its fit's
    :class:`Spread`, with ``level_variance``, the variance of the healthy level the size
    is measured from, added by :meth:`Spread.with_level`; None: not known, left out) and
    of its onset ``onset_s`` (seconds): the change-point search's
    ``onset_range`` (samples), or a drift's traced onset +- 1.96 sd. ``extra``: the
    event's onset evidence (:func:`~analyzer.diagnosis.events.bounded_onset`'s, and a
    change's ``changed_at_s``), which says where the onset is a bound instead. What the
    intervals are of (``of_magnitude``, ``of_onset_s``) is kept, so a finding whose size
    or onset came from elsewhere does not show them beside another number."""
    out: dict[str, Any] = {
        "level": LEVEL,
        "of_magnitude": dict(cls.magnitude),
        "of_onset_s": float(onset_s),
    }
    spread = None if cls.spread is None else cls.spread.with_level(level_variance)
    if spread is None:
        out.update(
            magnitude=None,
            magnitude_note="no fitted shape: the size of an 'other' fault summarises its "
            "stretch (its mean and root mean square)",
        )
    else:
        sizes = {k: interval(float(cls.magnitude[k]), se) for k, se in spread.se.items()}
        out.update(magnitude=sizes, magnitude_se=dict(spread.se), lags=spread.lags)
        partial = _partial(cls, spread, level_variance)
        if partial:
            out["magnitude_partial"] = partial
    out.update(_onset(cls, spread, onset_range, onset_s, extra, rate_hz))
    return out


def _partial(cls: Classification, spread: Spread, level_variance: float | None) -> str | None:
    """Why a size interval that is given counts only part of the size's error, or None
    where it counts all the error it is meant to: a gain's counts the fit's noise only
    (:data:`GAIN_SIZE_NOTE`); any size measured from the healthy level leaves that
    level's error out where its variance is not known (:data:`OLD_MODEL_NOTE`)."""
    notes = []
    if cls.type is FaultType.MULTIPLICATIVE:
        notes.append(GAIN_SIZE_NOTE)
    level_moves = any(v != 0.0 for v in spread.level_slope.values())
    if level_variance is None and level_moves:
        notes.append(OLD_MODEL_NOTE)
    return "; ".join(notes) or None


def _onset(
    cls: Classification,
    spread: Spread | None,
    onset_range: tuple[int, int] | None,
    onset_s: float,
    extra: Mapping[str, Any],
    rate_hz: float,
) -> dict[str, Any]:
    """:func:`event_intervals`' onset part: ``onset_s`` (an interval or None) and, where
    None, ``onset_note`` (why)."""
    if extra.get("starts_in_training"):
        why = (
            "a bound: the fitted shape traced the onset back into the healthy window, "
            "so the onset given is that window's end"
        )
        return {"onset_s": None, "onset_note": why}
    if "changed_at_s" in extra:
        why = "the onset is where an earlier fault on the channel changed into this one"
        return {"onset_s": None, "onset_note": why}
    if cls.onset_shift_s != 0.0 and spread is not None:  # a drift traced back to zero
        if spread.onset_sd_s is None:
            return {"onset_s": None, "onset_note": spread.onset_note}
        return {"onset_s": interval(onset_s, spread.onset_sd_s)}
    if spread is not None and spread.onset_note is not None:
        return {"onset_s": None, "onset_note": spread.onset_note}
    if cls.type is FaultType.MULTIPLICATIVE:
        return {"onset_s": None, "onset_note": GAIN_ONSET_NOTE}
    if onset_range is None:
        return {
            "onset_s": None,
            "onset_note": "the onset is the first alarm: no change-point search around it",
        }
    # The search ranges over candidate first faulty samples: the fault began after the
    # sample before the earliest one (the last that may be healthy), so the interval
    # starts a sample period earlier; an onset is known to a sample at best.
    first = max(onset_range[0] - 1, 0)
    return {"onset_s": [first / rate_hz, onset_range[1] / rate_hz]}
